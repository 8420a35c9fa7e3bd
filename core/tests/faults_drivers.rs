//! Bus and sensor faults through the drivers, with scripted embedded-hal-mock
//! transactions: I2C NACK (address and data) and arbitration loss, SPI errors, bursts of faults
//! followed by recovery, a sensor stuck at a constant, a chip that restarts.
//!
//! The response each fault must get (README, "Reliability"):
//! * a failed transaction → `Err(Bus)`, counted in the driver's `Health::bus_errors`; no reading,
//!   no change of the cached configuration, and the next good transaction reads correctly (nothing
//!   is left half-done in the driver);
//! * a chip that restarted (ICM-42688-P back to its reset state: data registers at the invalid
//!   marker) → `Err(InvalidData)` until it is re-initialised with `init`, which the firmware does
//!   after `REINIT_AFTER` failed reads; the driver then reads correctly again;
//! * a sensor stuck at a constant → the driver cannot tell (each frame is valid), the core's
//!   `StuckDetector` marks the channel after its window (tested here on the readings the driver
//!   returned), and the channel becomes NaN for the pipeline.
//!
//! Register constants are re-typed from the datasheets as in `driver_*.rs`.

use aerosid_core::aero::model::channel;
use aerosid_core::aero::{SensorSample, StuckDetector, StuckSettings};
use aerosid_core::drivers::as5600::{self, As5600};
use aerosid_core::drivers::icm42688::{self, Icm42688};
use aerosid_core::drivers::ms4525do::{self, Ms4525do};
use embedded_hal::i2c::{ErrorKind as I2cError, NoAcknowledgeSource};
use embedded_hal::spi::ErrorKind as SpiError;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I2cT};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiT};

const MS_ADDR: u8 = 0x28;
const AS_ADDR: u8 = 0x36;
const AS_STATUS: u8 = 0x0B;
const AS_RAW: u8 = 0x0C;
const MD: u8 = 0x20;

/// The I2C faults of embedded-hal 1.0 a bus driver reports.
const I2C_FAULTS: [I2cError; 5] = [
    I2cError::NoAcknowledge(NoAcknowledgeSource::Address),
    I2cError::NoAcknowledge(NoAcknowledgeSource::Data),
    I2cError::ArbitrationLoss,
    I2cError::Bus,
    I2cError::Overrun,
];

/// MS4525DO Read_DF4: status 00, a bridge count and a temperature count.
fn ms_frame(count: u16, t_count: u16) -> Vec<u8> {
    vec![
        (count >> 8) as u8 & 0x3F,
        (count & 0xFF) as u8,
        (t_count >> 3) as u8,
        ((t_count & 7) << 5) as u8,
    ]
}

#[test]
fn ms4525do_every_i2c_fault_is_a_counted_bus_error_and_the_next_read_is_correct() {
    // GIVEN a good frame, then each I2C fault, each followed by a good frame
    let good = ms_frame(8292, 767);
    let mut script = vec![I2cT::read(MS_ADDR, good.clone())];
    for e in I2C_FAULTS {
        script.push(I2cT::read(MS_ADDR, vec![0; 4]).with_error(e));
        script.push(I2cT::read(MS_ADDR, good.clone()));
    }
    let mut bus = I2cMock::new(&script);
    let mut s = Ms4525do::new(bus.clone(), MS_ADDR);
    let config = *s.config();
    // WHEN every frame is read
    let first = s.read().expect("good frame");
    for e in I2C_FAULTS {
        // THEN each fault is Err(Bus(e)), counted, the configuration untouched …
        assert_eq!(s.read(), Err(ms4525do::Error::Bus(e)));
        assert_eq!(*s.config(), config);
        // … and the next frame reads exactly as before the fault.
        assert_eq!(s.read(), Ok(first));
    }
    let h = s.health();
    assert_eq!((h.ok, h.bus_errors, h.stale, h.faults, h.out_of_range), (6, 5, 0, 0, 0));
    s.release();
    bus.done();
}

#[test]
fn ms4525do_zero_calibration_interrupted_by_a_nack_keeps_the_old_offset() {
    // GIVEN a zero offset of 3 Pa and a calibration whose second read is NACKed
    let mut bus = I2cMock::new(&[
        I2cT::read(MS_ADDR, ms_frame(8192, 767)),
        I2cT::read(MS_ADDR, vec![0; 4]).with_error(I2cError::NoAcknowledge(NoAcknowledgeSource::Address)),
    ]);
    let mut s = Ms4525do::new(bus.clone(), MS_ADDR);
    s.set_zero_offset_pa(3.0).unwrap();
    // WHEN the calibration runs THEN it fails with the bus error and the offset stays 3 Pa
    let r = s.calibrate_zero(&mut NoopDelay::new(), 4, 100);
    assert_eq!(
        r,
        Err(ms4525do::Error::Bus(I2cError::NoAcknowledge(
            NoAcknowledgeSource::Address
        )))
    );
    assert_eq!(s.config().zero_offset_pa, 3.0);
    assert_eq!((s.health().ok, s.health().bus_errors), (1, 1));
    s.release();
    bus.done();
}

#[test]
fn as5600_faults_on_status_or_angle_read_are_counted_and_recovered_from() {
    // GIVEN for each I2C fault: a fault on the STATUS read, then a fault on the RAW ANGLE read, then
    // a good reading of count 2100
    let good = [
        I2cT::write_read(AS_ADDR, vec![AS_STATUS], vec![MD]),
        I2cT::write_read(AS_ADDR, vec![AS_RAW], vec![0x08, 0x34]),
    ];
    let mut script = Vec::new();
    for e in I2C_FAULTS {
        script.push(I2cT::write_read(AS_ADDR, vec![AS_STATUS], vec![0]).with_error(e));
        script.push(I2cT::write_read(AS_ADDR, vec![AS_STATUS], vec![MD]));
        script.push(I2cT::write_read(AS_ADDR, vec![AS_RAW], vec![0, 0]).with_error(e));
        script.extend_from_slice(&good);
    }
    let mut bus = I2cMock::new(&script);
    let mut v = As5600::new(bus.clone());
    let cfg = *v.config();
    for e in I2C_FAULTS {
        // WHEN read THEN Err(Bus) twice, the calibration unchanged, then the good angle
        assert_eq!(v.read(), Err(as5600::Error::Bus(e)));
        assert_eq!(v.read(), Err(as5600::Error::Bus(e)));
        assert_eq!(*v.config(), cfg);
        let r = v.read().expect("good reading after the faults");
        assert_eq!(r.raw_count, 0x834);
        assert!((f64::from(r.angle_rad) - (0x834 as f64 - 4096.0) * std::f64::consts::TAU / 4096.0).abs() < 1e-6);
    }
    let h = v.health();
    assert_eq!((h.ok, h.bus_errors), (5, 10));
    v.release();
    bus.done();
}

fn spi_read(register: u8, response: Vec<u8>) -> Vec<SpiT<u8>> {
    vec![
        SpiT::transaction_start(),
        SpiT::write_vec(vec![register | 0x80]),
        SpiT::read_vec(response),
        SpiT::transaction_end(),
    ]
}

fn spi_write(register: u8, value: u8) -> Vec<SpiT<u8>> {
    vec![
        SpiT::transaction_start(),
        SpiT::write_vec(vec![register, value]),
        SpiT::transaction_end(),
    ]
}

fn init_script() -> Vec<SpiT<u8>> {
    [
        spi_read(0x75, vec![0x47]),
        spi_write(0x11, 0x01),
        spi_write(0x4F, 0x06),
        spi_write(0x50, 0x06),
        spi_write(0x4E, 0x0F),
    ]
    .concat()
}

fn burst(words: [i16; 7]) -> Vec<SpiT<u8>> {
    [
        spi_read(0x2D, vec![0x08]),
        spi_read(0x1D, words.iter().flat_map(|w| w.to_be_bytes()).collect()),
    ]
    .concat()
}

/// An `SpiDevice` failing the transactions whose (0-based) numbers are listed, with `kind`, and
/// passing the others to the mock (the mock cannot fail a whole transaction by itself).
struct Failing {
    inner: SpiMock<u8>,
    fail: Vec<(usize, SpiError)>,
    n: usize,
}

impl embedded_hal::spi::ErrorType for Failing {
    type Error = SpiError;
}

impl embedded_hal::spi::SpiDevice for Failing {
    fn transaction(&mut self, ops: &mut [embedded_hal::spi::Operation<'_, u8>]) -> Result<(), SpiError> {
        let n = self.n;
        self.n += 1;
        if let Some((_, k)) = self.fail.iter().find(|(i, _)| *i == n) {
            return Err(*k);
        }
        self.inner.transaction(ops)
    }
}

#[test]
fn icm42688_spi_errors_in_init_and_reads_then_a_restarted_chip_is_reinitialised() {
    // GIVEN: init fails on its third transaction (GYRO_CONFIG0 write, mode fault); a second init
    // succeeds; a read whose burst fails (overrun); a good read; the chip restarts (every data
    // register at the invalid marker −32768) → InvalidData; the firmware re-inits; a good read.
    let good = [2650i16, 100, -200, 2048, 50, -60, 70];
    let restarted = [i16::MIN; 7];
    let script = [
        // First init: WHO_AM_I and DEVICE_CONFIG pass, GYRO_CONFIG0 fails (not in the mock).
        spi_read(0x75, vec![0x47]),
        spi_write(0x11, 0x01),
        init_script(),
        // Read 1: status passes, burst fails (not in the mock).
        spi_read(0x2D, vec![0x08]),
        burst(good),
        burst(restarted),
        init_script(),
        burst(good),
    ]
    .concat();
    let dev = Failing {
        inner: SpiMock::new(&script),
        fail: vec![(2, SpiError::ModeFault), (9, SpiError::Overrun)],
        n: 0,
    };
    let mut imu = Icm42688::new(dev, icm42688::Config::default());
    let mut delay = NoopDelay::new();
    // WHEN / THEN
    assert_eq!(imu.init(&mut delay), Err(icm42688::Error::Bus(SpiError::ModeFault)));
    assert_eq!(imu.init(&mut delay), Ok(()));
    assert_eq!(imu.read(), Err(icm42688::Error::Bus(SpiError::Overrun)));
    let a = imu.read().expect("good burst after the overrun");
    assert_eq!(imu.read(), Err(icm42688::Error::InvalidData));
    assert_eq!(imu.init(&mut delay), Ok(()));
    let b = imu.read().expect("good burst after re-initialisation");
    assert_eq!(a, b, "the re-initialised chip reads exactly as before");
    let h = imu.health();
    assert_eq!(
        (h.reads_ok, h.bus_errors, h.invalid, h.not_ready, h.saturated),
        (2, 2, 1, 0, 0)
    );
    imu.release().inner.done();
}

#[test]
fn a_stuck_airspeed_sensor_is_caught_by_the_stuck_detector_after_its_window() {
    // GIVEN an MS4525DO whose output freezes: 10 varying frames, then 80 identical ones, then
    // varying again
    let window = StuckSettings::default().samples[channel::AIRSPEED.trailing_zeros() as usize];
    assert_eq!(window, 50);
    let mut frames = Vec::new();
    for i in 0..10u16 {
        frames.push(ms_frame(9000 + i * 7, 767));
    }
    for _ in 0..80 {
        frames.push(ms_frame(9100, 767));
    }
    for i in 0..10u16 {
        frames.push(ms_frame(9200 + i * 3, 767));
    }
    let script: Vec<I2cT> = frames.iter().map(|f| I2cT::read(MS_ADDR, f.clone())).collect();
    let mut bus = I2cMock::new(&script);
    let mut s = Ms4525do::new(bus.clone(), MS_ADDR);
    let mut det = StuckDetector::new(StuckSettings::default());
    let mut stuck_at = Vec::new();
    for k in 0..frames.len() {
        // WHEN each reading goes into a sample through the detector
        let m = s
            .read()
            .expect("every frame is valid: the driver cannot tell it is stuck");
        let mut sample = SensorSample::<f32> {
            airspeed_mps: m.airspeed_mps,
            ..SensorSample::default()
        };
        let mask = det.apply(&mut sample);
        if mask & channel::AIRSPEED != 0 {
            assert!(sample.airspeed_mps.is_nan(), "a stuck channel is NaN for the pipeline");
            stuck_at.push(k);
        } else {
            assert_eq!(sample.airspeed_mps, m.airspeed_mps);
        }
    }
    // THEN the channel is stuck from the window-th identical reading (frame 10 + 49) to the last
    // identical one (frame 89), and free again after
    let expected: Vec<usize> = (10 + window as usize - 1..90).collect();
    assert_eq!(stuck_at, expected);
    assert_eq!(det.health().episodes[2], 1);
    assert_eq!(det.health().samples[2], expected.len() as u32);
    s.release();
    bus.done();
}
