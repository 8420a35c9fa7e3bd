//! AS5600 vane driver against scripted I2C transactions. Address, registers and STATUS bits are
//! re-typed from the datasheet here, not imported from the driver.

use aerosid_core::drivers::as5600::{As5600, CalibrationError, Direction, Error, VaneConfig};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction};

/// Fixed 7-bit address (datasheet "I²C Interface").
const ADDR: u8 = 0x36;
/// STATUS register (datasheet "Status Registers").
const REG_STATUS: u8 = 0x0B;
/// RAW ANGLE, high byte (bits 11:8) then low byte at 0x0D (datasheet "Output Registers").
const REG_RAW_ANGLE: u8 = 0x0C;
/// STATUS bits: MD magnet detected (5), ML too weak (4), MH too strong (3).
const MD: u8 = 0x20;
const ML: u8 = 0x10;
const MH: u8 = 0x08;
/// 2π / 4096.
const RAD_PER_COUNT: f64 = std::f64::consts::TAU / 4096.0;

fn status(byte: u8) -> Transaction {
    Transaction::write_read(ADDR, vec![REG_STATUS], vec![byte])
}

/// RAW ANGLE answer; `high_junk` fills the unused top nibble of 0x0C to check the 12-bit mask.
fn raw(count: u16, high_junk: u8) -> Transaction {
    Transaction::write_read(
        ADDR,
        vec![REG_RAW_ANGLE],
        vec![(high_junk << 4) | (count >> 8) as u8, (count & 0xFF) as u8],
    )
}

fn close(a: f32, b: f64, tol: f64) -> bool {
    (f64::from(a) - b).abs() <= tol
}

fn calibrated(zero_count: u16, direction: Direction) -> VaneConfig {
    VaneConfig {
        zero_count,
        direction,
        ..VaneConfig::default()
    }
}

#[test]
fn normal_reading_checks_status_then_reads_raw_angle() {
    // Default calibration (zero 0, counts increasing, k = 1): count 1024 → 1024·2π/4096 = π/2.
    // The top nibble of 0x0C is 0xF and must be masked off (0xF4 0x00 → 0x400).
    let mut i2c = Mock::new(&[status(MD), raw(1024, 0xF)]);
    let mut vane = As5600::new(i2c.clone());
    let r = vane.read().unwrap();
    assert_eq!(r.raw_count, 1024);
    assert!(close(r.angle_rad, std::f64::consts::FRAC_PI_2, 1e-6), "{}", r.angle_rad);
    assert_eq!(vane.health().ok, 1);
    vane.release();
    i2c.done();
}

#[test]
fn zero_offset_and_direction() {
    // Zero 1024, count 1280: +256 counts = 256·2π/4096 = π/8 = 0.392699 rad;
    // with the direction reversed the same count is −π/8.
    let mut i2c = Mock::new(&[status(MD), raw(1280, 0), status(MD), raw(1280, 0)]);
    let mut vane = As5600::new(i2c.clone());
    vane.set_config(calibrated(1024, Direction::CountsIncrease)).unwrap();
    assert!(close(vane.read().unwrap().angle_rad, std::f64::consts::FRAC_PI_8, 1e-6));
    vane.set_config(calibrated(1024, Direction::CountsDecrease)).unwrap();
    assert!(close(
        vane.read().unwrap().angle_rad,
        -std::f64::consts::FRAC_PI_8,
        1e-6
    ));
    vane.release();
    i2c.done();
}

#[test]
fn wrap_around_across_4095_to_0() {
    // Zero 4000, count 100: 100 − 4000 = −3900 ≡ +196 (mod 4096) → 196·2π/4096 = 0.300660 rad.
    // Zero 96, count 3904: 3808 ≡ −288 → −288·2π/4096 = −0.441786 rad.
    // Zero 4000, count 100, decreasing: −196 counts → −0.300660 rad.
    let mut i2c = Mock::new(&[
        status(MD),
        raw(100, 0),
        status(MD),
        raw(3904, 0),
        status(MD),
        raw(100, 0),
    ]);
    let mut vane = As5600::new(i2c.clone());
    vane.set_config(calibrated(4000, Direction::CountsIncrease)).unwrap();
    let a = vane.read().unwrap().angle_rad;
    assert!(
        close(a, 196.0 * RAD_PER_COUNT, 1e-6) && close(a, 0.300_660, 1e-6),
        "{a}"
    );
    vane.set_config(calibrated(96, Direction::CountsIncrease)).unwrap();
    let b = vane.read().unwrap().angle_rad;
    assert!(close(b, -0.441_786, 1e-6), "{b}");
    vane.set_config(calibrated(4000, Direction::CountsDecrease)).unwrap();
    assert!(close(vane.read().unwrap().angle_rad, -0.300_660, 1e-6));
    vane.release();
    i2c.done();
}

#[test]
fn output_is_in_minus_pi_to_pi_half_turn_is_plus_pi() {
    // Half a turn (2048 counts) is +π for both directions; −π is never returned.
    for direction in [Direction::CountsIncrease, Direction::CountsDecrease] {
        let c = calibrated(10, direction);
        assert_eq!(c.vane_angle_rad(2058), std::f32::consts::PI);
        for count in [0u16, 11, 2057, 2059, 4095] {
            let a = c.vane_angle_rad(count);
            assert!(a > -std::f32::consts::PI && a <= std::f32::consts::PI);
        }
    }
}

#[test]
fn plausibility_range_is_out_of_range() {
    // |α| ≤ 0.5 rad, zero 2000: +325 counts = 0.498544 rad passes, +326 = 0.500078 rad does not,
    // −326 does not either.
    let mut i2c = Mock::new(&[
        status(MD),
        raw(2325, 0),
        status(MD),
        raw(2326, 0),
        status(MD),
        raw(1674, 0),
    ]);
    let mut vane = As5600::new(i2c.clone());
    vane.set_config(VaneConfig {
        min_angle_rad: -0.5,
        max_angle_rad: 0.5,
        ..calibrated(2000, Direction::CountsIncrease)
    })
    .unwrap();
    assert!(close(vane.read().unwrap().angle_rad, 0.498_544, 1e-6));
    assert_eq!(vane.read(), Err(Error::OutOfRange));
    assert_eq!(vane.read(), Err(Error::OutOfRange));
    let h = vane.health();
    assert_eq!((h.ok, h.out_of_range), (1, 2));
    vane.release();
    i2c.done();
}

#[test]
fn scale_factor() {
    // k = 0.8 (upwash ε = 0.25), zero 1024: count 1280 → 0.8·π/8 = 0.314159 rad;
    // count 1424 (+400 = 0.613592 rad vane angle) → 0.490874 rad, inside |α| ≤ 0.5 only thanks to k.
    let mut i2c = Mock::new(&[status(MD), raw(1280, 0), status(MD), raw(1424, 0)]);
    let mut vane = As5600::new(i2c.clone());
    vane.set_config(VaneConfig {
        scale: 0.8,
        min_angle_rad: -0.5,
        max_angle_rad: 0.5,
        ..calibrated(1024, Direction::CountsIncrease)
    })
    .unwrap();
    assert!(close(vane.read().unwrap().angle_rad, 0.314_159, 1e-6));
    let r = vane.read().unwrap();
    assert!(close(r.angle_rad, 0.490_874, 1e-6), "{}", r.angle_rad);
    vane.release();
    i2c.done();
}

#[test]
fn magnet_missing_weak_strong_are_errors_without_an_angle_read() {
    // STATUS only: after a bad magnet status RAW ANGLE must not be read.
    let mut i2c = Mock::new(&[
        status(0x00),
        status(ML),
        status(MD | ML),
        status(MH),
        status(MD | MH),
        status(MD | ML | MH),
    ]);
    let mut vane = As5600::new(i2c.clone());
    assert_eq!(vane.read(), Err(Error::MagnetMissing));
    assert_eq!(vane.read(), Err(Error::MagnetTooWeak));
    assert_eq!(vane.read(), Err(Error::MagnetTooWeak));
    assert_eq!(vane.read(), Err(Error::MagnetTooStrong));
    assert_eq!(vane.read_raw_count(), Err(Error::MagnetTooStrong));
    assert_eq!(vane.read(), Err(Error::InvalidStatus(MD | ML | MH)));
    let h = vane.health();
    assert_eq!(
        (h.magnet_missing, h.magnet_too_weak, h.magnet_too_strong, h.ok),
        (2, 2, 2, 0)
    );
    vane.release();
    i2c.done();
}

#[test]
fn nack_on_status_or_angle_is_a_bus_error() {
    let nack = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
    let mut i2c = Mock::new(&[
        Transaction::write_read(ADDR, vec![REG_STATUS], vec![0]).with_error(nack),
        status(MD),
        Transaction::write_read(ADDR, vec![REG_RAW_ANGLE], vec![0, 0]).with_error(ErrorKind::Bus),
    ]);
    let mut vane = As5600::new(i2c.clone());
    assert_eq!(vane.read(), Err(Error::Bus(nack)));
    assert_eq!(vane.read(), Err(Error::Bus(ErrorKind::Bus)));
    assert_eq!(vane.health().bus_errors, 2);
    vane.release();
    i2c.done();
}

#[test]
fn two_point_calibration_across_the_wrap() {
    // Vane on the reference line reads 50; held at α = +0.2 rad (nose-up relative to the flow) on
    // the jig it reads 4016: 4016 − 50 = 3966 ≡ −130 counts = −0.199418 rad, so the count falls as
    // α grows → CountsDecrease, zero 50; |−0.199418|/0.2 = 0.997 is within the tolerance.
    // A flight reading of 4016 is then +0.199418 rad, and 120 (+70 counts) is −0.107379 rad.
    let mut i2c = Mock::new(&[
        status(MD),
        raw(50, 0),
        status(MD),
        raw(4016, 0),
        status(MD),
        raw(4016, 0),
        status(MD),
        raw(120, 0),
    ]);
    let mut vane = As5600::new(i2c.clone());
    let reference = vane.read_raw_count().unwrap();
    let second = vane.read_raw_count().unwrap();
    let cal = vane.config().calibrated(reference, second, 0.2).unwrap();
    assert_eq!(cal.zero_count, 50);
    assert_eq!(cal.direction, Direction::CountsDecrease);
    vane.set_config(cal).unwrap();
    assert!(close(vane.read().unwrap().angle_rad, 0.199_418, 1e-6));
    assert!(close(vane.read().unwrap().angle_rad, -0.107_379, 1e-6));
    vane.release();
    i2c.done();
}

#[test]
fn calibration_refuses_bad_inputs_and_keeps_scale_and_range() {
    let base = VaneConfig {
        scale: 0.9,
        min_angle_rad: -0.4,
        max_angle_rad: 0.6,
        ..VaneConfig::default()
    };
    // β = −0.3 rad (wind from the left) read 1000 → 804: −196 counts = −0.300660 rad, same sign →
    // CountsIncrease; scale and range untouched.
    let ok = base.calibrated(1000, 804, -0.3).unwrap();
    assert_eq!(ok.direction, Direction::CountsIncrease);
    assert_eq!(
        (ok.zero_count, ok.scale, ok.min_angle_rad, ok.max_angle_rad),
        (1000, 0.9, -0.4, 0.6)
    );
    // Declared 0.2 rad but measured 65 counts = 0.0997 rad (ratio 0.5): inconsistent.
    assert_eq!(base.calibrated(1000, 1065, 0.2), Err(CalibrationError::Inconsistent));
    // Vane not moved.
    assert_eq!(base.calibrated(1000, 1000, 0.2), Err(CalibrationError::Inconsistent));
    // Angle too small (< 5°), too large (> 90°), not finite.
    for bad in [0.01, 2.0, f32::NAN, f32::INFINITY] {
        assert_eq!(base.calibrated(1000, 1130, bad), Err(CalibrationError::InvalidAngle));
    }
    assert_eq!(base.calibrated(4096, 100, 0.2), Err(CalibrationError::InvalidCount));
}

#[test]
fn zero_here_with_declared_direction_and_invalid_configs() {
    // Reference read 3000 with the direction declared decreasing; then 2900 (−100 counts) is
    // +100·2π/4096 = +0.153398 rad.
    let mut i2c = Mock::new(&[status(MD), raw(3000, 0), status(MD), raw(2900, 0)]);
    let mut vane = As5600::new(i2c.clone());
    assert_eq!(vane.set_zero_here(Direction::CountsDecrease), Ok(3000));
    assert!(close(vane.read().unwrap().angle_rad, 0.153_398, 1e-6));
    let kept = *vane.config();
    for bad in [
        VaneConfig {
            zero_count: 4096,
            ..kept
        },
        VaneConfig { scale: 0.0, ..kept },
        VaneConfig {
            scale: f32::NAN,
            ..kept
        },
        VaneConfig {
            min_angle_rad: 0.5,
            max_angle_rad: 0.5,
            ..kept
        },
        VaneConfig {
            min_angle_rad: -4.0,
            ..kept
        },
        VaneConfig {
            max_angle_rad: 4.0,
            ..kept
        },
    ] {
        assert_eq!(vane.set_config(bad), Err(Error::InvalidConfig));
    }
    assert_eq!(*vane.config(), kept);
    vane.release();
    i2c.done();
}
