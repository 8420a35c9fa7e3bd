//! MS4525DO driver against scripted I2C transactions. Addresses, frame layout and transfer
//! functions are re-typed from the datasheet here, not imported from the driver.

use aerosid_core::drivers::ms4525do::{Config, Error, Ms4525do, OutputType};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};

/// -I interface option address (datasheet ordering information).
const ADDR: u8 = 0x28;
/// Pa per psi.
const PA_PER_PSI: f64 = 6894.757;

/// A Read_DF4 frame: status (2 bits) | pressure count (14 bits) | temperature count (11 bits) | 5
/// undetermined bits, set here to 1 to check that the driver masks them.
fn frame(status: u8, p_count: u16, t_count: u16) -> Vec<u8> {
    vec![
        (status << 6) | (p_count >> 8) as u8,
        (p_count & 0xFF) as u8,
        (t_count >> 3) as u8,
        (((t_count & 0x7) << 5) as u8) | 0x1F,
    ]
}

/// Type A, ±1 psi: P[psi] = (count − 1638.3)·2/13106.4 − 1.
fn pa_type_a_1psi(count: f64) -> f64 {
    ((count - 0.1 * 16383.0) * 2.0 / (0.8 * 16383.0) - 1.0) * PA_PER_PSI
}

fn close(a: f32, b: f64, tol: f64) -> bool {
    (f64::from(a) - b).abs() <= tol
}

#[test]
fn normal_reading_type_a_1psi() {
    // Pressure count 8292 = 0x2064: P = (8292 − 1638.3)·2/13106.4 − 1 = 201/13106.4 = 0.015336 psi
    //   = 0.015336 · 6894.757 = 105.74 Pa.
    // Temperature count 767 = 0x2FF: T = 767·200/2047 − 50 = 24.939 °C.
    // Airspeed at ρ = 1.225: V = sqrt(2 · 105.74 / 1.225) = sqrt(172.63) = 13.139 m/s.
    let f = frame(0b00, 8292, 767);
    assert_eq!(f, vec![0x20, 0x64, 0x5F, 0xFF]);
    let mut i2c = Mock::new(&[Transaction::read(ADDR, f)]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    let m = s.read().unwrap();
    assert_eq!(m.pressure_count, 8292);
    assert_eq!(m.temperature_count, 767);
    assert!(close(m.pressure_pa, 105.74, 0.01), "{}", m.pressure_pa);
    assert!(close(m.raw_pressure_pa, 105.74, 0.01));
    assert!(close(m.temperature_c, 24.939, 0.001), "{}", m.temperature_c);
    assert!(close(m.airspeed_mps, 13.139, 0.001), "{}", m.airspeed_mps);
    assert_eq!(s.health().ok, 1);
    s.release();
    i2c.done();
}

#[test]
fn type_b_and_configurable_address() {
    // Type B, ±1 psi: P = (count − 0.05·16383)·2/(0.9·16383) − 1.
    // Count 15000: (15000 − 819.15)·2/14744.7 − 1 = 0.923521 psi = 6367.46 Pa (beyond type A's 14744.7).
    // Temperature count 0 → −50 °C; 2047 → 150 °C is checked in the second frame.
    let addr = 0x36; // -J option
    let mut i2c = Mock::new(&[
        Transaction::read(addr, frame(0b00, 15000, 0)),
        Transaction::read(addr, frame(0b00, 819, 2047)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), addr);
    s.set_config(Config {
        output_type: OutputType::B,
        ..Config::default()
    })
    .unwrap();
    let m = s.read().unwrap();
    let expected = ((15000.0 - 819.15) * 2.0 / 14744.7 - 1.0) * PA_PER_PSI;
    assert!(close(m.pressure_pa, expected, 0.05), "{} vs {expected}", m.pressure_pa);
    assert!(close(m.pressure_pa, 6367.46, 0.1));
    assert!(close(m.temperature_c, -50.0, 1e-6));
    // Count 819 < 819.15: just below the type B span.
    assert_eq!(s.read(), Err(Error::OutOfRange));
    s.release();
    i2c.done();
}

#[test]
fn stale_frame_is_an_error() {
    let mut i2c = Mock::new(&[Transaction::read(ADDR, frame(0b10, 8292, 767))]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    assert_eq!(s.read(), Err(Error::Stale));
    assert_eq!(s.health().stale, 1);
    assert_eq!(s.health().ok, 0);
    s.release();
    i2c.done();
}

#[test]
fn fault_and_reserved_status_are_errors() {
    let mut i2c = Mock::new(&[
        Transaction::read(ADDR, frame(0b11, 8292, 767)),
        Transaction::read(ADDR, frame(0b01, 8292, 767)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    assert_eq!(s.read(), Err(Error::Fault));
    assert_eq!(s.read(), Err(Error::ReservedStatus));
    assert_eq!(s.health().faults, 2);
    s.release();
    i2c.done();
}

#[test]
fn nack_is_a_bus_error() {
    let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let mut i2c = Mock::new(&[Transaction::read(ADDR, vec![0; 4]).with_error(nack)]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    assert_eq!(s.read(), Err(Error::Bus(nack)));
    assert_eq!(s.health().bus_errors, 1);
    s.release();
    i2c.done();
}

#[test]
fn counts_outside_the_type_a_span_are_out_of_range() {
    // Type A span: 1638.3 … 14744.7 counts. 1000 and 15000 are outside; 0x0000 and 0x3FFF
    // (open/shorted bridge) too. 1639 and 14744 are the first counts inside.
    let mut i2c = Mock::new(&[
        Transaction::read(ADDR, frame(0b00, 1000, 767)),
        Transaction::read(ADDR, frame(0b00, 15000, 767)),
        Transaction::read(ADDR, frame(0b00, 0x3FFF, 767)),
        Transaction::read(ADDR, frame(0b00, 1639, 767)),
        Transaction::read(ADDR, frame(0b00, 14744, 767)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    assert_eq!(s.read(), Err(Error::OutOfRange));
    assert_eq!(s.read(), Err(Error::OutOfRange));
    assert_eq!(s.read(), Err(Error::OutOfRange));
    // 1639: (1639 − 1638.3)·2/13106.4 − 1 = −0.999893 psi = −6894.02 Pa.
    let lo = s.read().unwrap();
    assert!(close(lo.raw_pressure_pa, pa_type_a_1psi(1639.0), 0.05));
    assert!(close(lo.raw_pressure_pa, -6894.02, 0.1), "{}", lo.raw_pressure_pa);
    let hi = s.read().unwrap();
    assert!(close(hi.raw_pressure_pa, pa_type_a_1psi(14744.0), 0.05));
    let h = s.health();
    assert_eq!((h.out_of_range, h.ok), (3, 2));
    s.release();
    i2c.done();
}

#[test]
fn zero_calibration_averages_fresh_readings_and_skips_stale_ones() {
    // Counts 8200, 8202, (stale), 8204, 8206: mean 8203 →
    //   offset = ((8203 − 1638.3)·2/13106.4 − 1) psi = 23/13106.4 psi = 0.0017549 psi = 12.099 Pa.
    // Then a reading at 8203 gives Δp = 0 and V = 0; at 8303 (100 counts up):
    //   Δp = 100·2/13106.4 psi = 0.015260 psi = 105.21 Pa, V = sqrt(2·105.21/1.225) = 13.106 m/s.
    let mut i2c = Mock::new(&[
        Transaction::read(ADDR, frame(0b00, 8200, 767)),
        Transaction::read(ADDR, frame(0b00, 8202, 767)),
        Transaction::read(ADDR, frame(0b10, 8202, 767)),
        Transaction::read(ADDR, frame(0b00, 8204, 767)),
        Transaction::read(ADDR, frame(0b00, 8206, 767)),
        Transaction::read(ADDR, frame(0b00, 8203, 767)),
        Transaction::read(ADDR, frame(0b00, 8303, 767)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    let offset = s.calibrate_zero(&mut NoopDelay::new(), 4, 2_000).unwrap();
    assert!(close(offset, 12.099, 0.01), "{offset}");
    assert_eq!(s.config().zero_offset_pa, offset);
    let zero = s.read().unwrap();
    assert!(close(zero.pressure_pa, 0.0, 0.01), "{}", zero.pressure_pa);
    assert!(close(zero.airspeed_mps, 0.0, 0.05));
    let m = s.read().unwrap();
    assert!(close(m.pressure_pa, 105.21, 0.02), "{}", m.pressure_pa);
    assert!(close(m.airspeed_mps, 13.106, 0.002), "{}", m.airspeed_mps);
    assert_eq!(s.health().stale, 1);
    assert_eq!(s.health().ok, 6);
    s.release();
    i2c.done();
}

#[test]
fn zero_calibration_stops_on_fault_and_keeps_the_old_offset() {
    let mut i2c = Mock::new(&[
        Transaction::read(ADDR, frame(0b00, 8200, 767)),
        Transaction::read(ADDR, frame(0b11, 8200, 767)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    s.set_zero_offset_pa(3.0).unwrap();
    assert_eq!(s.calibrate_zero(&mut NoopDelay::new(), 4, 2_000), Err(Error::Fault));
    assert_eq!(s.config().zero_offset_pa, 3.0);
    assert_eq!(
        s.calibrate_zero(&mut NoopDelay::new(), 0, 2_000),
        Err(Error::InvalidConfig)
    );
    s.release();
    i2c.done();
}

#[test]
fn negative_pressure_within_noise_is_zero_airspeed_beyond_is_signed() {
    // Offset set to 0 at count 8191.5 (midscale). Count 8189: Δp = −2.5 counts ·
    //   (2·6894.757/13106.4 Pa/count = 1.052120) = −2.630 Pa, inside the 5 Pa band → V = 0.
    // Count 8141: Δp = −50.5 counts = −53.132 Pa, beyond the band → V = −sqrt(2·53.132/1.225)
    //   = −9.3135 m/s (reversed flow / swapped tubes stays visible).
    let mut i2c = Mock::new(&[
        Transaction::read(ADDR, frame(0b00, 8189, 767)),
        Transaction::read(ADDR, frame(0b00, 8141, 767)),
    ]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    let a = s.read().unwrap();
    assert!(close(a.pressure_pa, -2.630, 0.002), "{}", a.pressure_pa);
    assert_eq!(a.airspeed_mps, 0.0);
    let b = s.read().unwrap();
    assert!(close(b.pressure_pa, -53.132, 0.01), "{}", b.pressure_pa);
    assert!(close(b.airspeed_mps, -9.3135, 0.001), "{}", b.airspeed_mps);
    s.release();
    i2c.done();
}

#[test]
fn density_sets_true_airspeed_and_bad_configs_are_refused() {
    // Same 105.74 Pa as the first test at ρ = 0.9 kg/m³ (≈ 3 km): V = sqrt(2·105.74/0.9) = 15.328 m/s.
    let mut i2c = Mock::new(&[Transaction::read(ADDR, frame(0b00, 8292, 767))]);
    let mut s = Ms4525do::new(i2c.clone(), ADDR);
    assert_eq!(s.set_air_density_kg_m3(0.0), Err(Error::InvalidConfig));
    assert_eq!(s.set_air_density_kg_m3(f32::NAN), Err(Error::InvalidConfig));
    assert_eq!(
        s.set_config(Config {
            p_min_psi: 1.0,
            p_max_psi: -1.0,
            ..Config::default()
        }),
        Err(Error::InvalidConfig)
    );
    assert_eq!(s.set_zero_offset_pa(f32::INFINITY), Err(Error::InvalidConfig));
    assert_eq!(*s.config(), Config::default());
    s.set_air_density_kg_m3(0.9).unwrap();
    let m = s.read().unwrap();
    assert!(close(m.airspeed_mps, 15.328, 0.002), "{}", m.airspeed_mps);
    // ISA sea level from the ideal gas law: 101325/(287.05·288.15) = 1.2250 kg/m³.
    let rho = aerosid_core::drivers::ms4525do::air_density_kg_m3(101_325.0, 15.0);
    assert!(close(rho, 1.2250, 0.0005), "{rho}");
    s.release();
    i2c.done();
}
