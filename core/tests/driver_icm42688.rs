//! ICM-42688-P driver against scripted SPI transactions written from the datasheet (DS-000347).
//!
//! Register addresses and bit values are typed again here from the datasheet, not imported from the
//! driver, so a wrong constant in the driver fails a test instead of agreeing with itself.

use aerosid_core::drivers::icm42688::{
    AccelRange, AxisMap, Config, Error, GyroRange, Health, Icm42688, Odr, Reading, SensorAxis,
};
use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as DelayTransaction};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiTransaction};

// Bank-0 registers (DS register map, user bank 0).
const DEVICE_CONFIG: u8 = 0x11;
const TEMP_DATA1: u8 = 0x1D;
const INT_STATUS: u8 = 0x2D;
const PWR_MGMT0: u8 = 0x4E;
const GYRO_CONFIG0: u8 = 0x4F;
const ACCEL_CONFIG0: u8 = 0x50;
const WHO_AM_I: u8 = 0x75;
// Values.
const READ: u8 = 0x80;
const ICM42688P_ID: u8 = 0x47;
const SOFT_RESET: u8 = 0x01;
const DATA_RDY_INT: u8 = 0x08;
/// GYRO_MODE = 11 (bits 3:2), ACCEL_MODE = 11 (bits 1:0): both low noise.
const BOTH_LOW_NOISE: u8 = 0x0F;
/// GYRO_FS_SEL = 000 (±2000 °/s) | GYRO_ODR = 0110 (1 kHz): the reset value.
const CONFIG0_DEFAULT: u8 = 0x06;
const INVALID: i16 = -32768;

/// `GYRO_CONFIG0` / `ACCEL_CONFIG0`: FS_SEL in bits 7:5, ODR in bits 3:0.
fn config0(fs_sel: u8, odr: u8) -> u8 {
    (fs_sel << 5) | odr
}

const G: f32 = 9.80665;
const DEG: f32 = core::f32::consts::PI / 180.0;

fn write(register: u8, value: u8) -> Vec<SpiTransaction<u8>> {
    vec![
        SpiTransaction::transaction_start(),
        SpiTransaction::write_vec(vec![register, value]),
        SpiTransaction::transaction_end(),
    ]
}

fn read(register: u8, response: Vec<u8>) -> Vec<SpiTransaction<u8>> {
    vec![
        SpiTransaction::transaction_start(),
        SpiTransaction::write_vec(vec![register | READ]),
        SpiTransaction::read_vec(response),
        SpiTransaction::transaction_end(),
    ]
}

/// A data-ready status read followed by the 14-byte burst TEMP_DATA1..=GYRO_DATA_Z0, big-endian.
fn sample(temperature: i16, accel: [i16; 3], gyro: [i16; 3]) -> Vec<SpiTransaction<u8>> {
    let words = [temperature, accel[0], accel[1], accel[2], gyro[0], gyro[1], gyro[2]];
    let bytes = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    [read(INT_STATUS, vec![DATA_RDY_INT]), read(TEMP_DATA1, bytes)].concat()
}

fn assert_close(actual: [f32; 3], expected: [f32; 3]) {
    for (a, e) in actual.iter().zip(expected) {
        assert!((a - e).abs() <= 1e-5 * e.abs().max(1.0), "{actual:?} != {expected:?}");
    }
}

/// Runs `f` on a driver over the scripted bus, then checks every transaction happened.
fn with_driver<R>(config: Config, script: &[SpiTransaction<u8>], f: impl FnOnce(&mut Icm42688<SpiMock<u8>>) -> R) -> R {
    let mut imu = Icm42688::new(SpiMock::new(script), config);
    let result = f(&mut imu);
    imu.release().done();
    result
}

/// An `SpiDevice` that fails its `fail_at`-th transaction (0-based) and passes the others to a mock.
struct FailOn {
    inner: SpiMock<u8>,
    fail_at: usize,
    count: usize,
}

impl ErrorType for FailOn {
    type Error = ErrorKind;
}

impl SpiDevice for FailOn {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        let n = self.count;
        self.count += 1;
        if n == self.fail_at {
            return Err(ErrorKind::Other);
        }
        self.inner.transaction(operations)
    }
}

#[test]
fn init_checks_id_resets_configures_and_powers_on_with_datasheet_waits() {
    let script = [
        read(WHO_AM_I, vec![ICM42688P_ID]),
        write(DEVICE_CONFIG, SOFT_RESET),
        write(GYRO_CONFIG0, CONFIG0_DEFAULT),
        write(ACCEL_CONFIG0, CONFIG0_DEFAULT),
        write(PWR_MGMT0, BOTH_LOW_NOISE),
    ]
    .concat();
    // 1 ms after the soft reset, 200 µs after the gyro leaves OFF (DEVICE_CONFIG, PWR_MGMT0 notes).
    let mut delay = CheckedDelay::new(&[DelayTransaction::delay_ms(1), DelayTransaction::delay_us(200)]);
    with_driver(Config::default(), &script, |imu| imu.init(&mut delay)).unwrap();
    delay.done();
}

#[test]
fn init_writes_the_chosen_ranges_and_rates() {
    let config = Config {
        gyro_range: GyroRange::Dps500, // FS_SEL 010
        gyro_odr: Odr::Hz200,          // ODR 0111
        accel_range: AccelRange::G4,   // FS_SEL 010
        accel_odr: Odr::Hz500,         // ODR 1111
        ..Config::default()
    };
    let script = [
        read(WHO_AM_I, vec![ICM42688P_ID]),
        write(DEVICE_CONFIG, SOFT_RESET),
        write(GYRO_CONFIG0, config0(0b010, 0b0111)),
        write(ACCEL_CONFIG0, config0(0b010, 0b1111)),
        write(PWR_MGMT0, BOTH_LOW_NOISE),
    ]
    .concat();
    with_driver(config, &script, |imu| imu.init(&mut NoopDelay)).unwrap();
}

#[test]
fn wrong_who_am_i_is_reported_and_nothing_is_written() {
    let script = read(WHO_AM_I, vec![0x98]);
    let result = with_driver(Config::default(), &script, |imu| imu.init(&mut NoopDelay));
    assert_eq!(result, Err(Error::WrongDevice(0x98)));
}

#[test]
fn a_sample_is_converted_to_si_units_at_the_default_ranges() {
    // ±16 g: 2048 LSB/g; ±2000 °/s: 16.384 LSB/(°/s); level at rest the z axis reads −1 g (FRD).
    let script = sample(2650, [1024, -4096, -2048], [16384, -1638, 0]);
    let (reading, health) = with_driver(Config::default(), &script, |imu| (imu.read().unwrap(), imu.health()));
    assert_close(reading.accel_mps2, [0.5 * G, -2.0 * G, -G]);
    assert_close(reading.gyro_rad_s, [1000.0 * DEG, -1638.0 / 16.384 * DEG, 0.0]);
    assert!((reading.temperature_c - (2650.0 / 132.48 + 25.0)).abs() < 1e-4);
    assert_eq!(
        health,
        Health {
            reads_ok: 1,
            ..Health::default()
        }
    );
}

#[test]
fn the_scale_follows_each_range() {
    // Half of the raw span (16384) is half of the full scale in every range.
    let gyro = [
        (GyroRange::Dps2000, 2000.0),
        (GyroRange::Dps1000, 1000.0),
        (GyroRange::Dps500, 500.0),
        (GyroRange::Dps250, 250.0),
    ];
    let accel = [
        (AccelRange::G16, 16.0),
        (AccelRange::G8, 8.0),
        (AccelRange::G4, 4.0),
        (AccelRange::G2, 2.0),
    ];
    for ((gyro_range, fs_dps), (accel_range, fs_g)) in gyro.into_iter().zip(accel) {
        let config = Config {
            gyro_range,
            accel_range,
            ..Config::default()
        };
        let script = sample(0, [16384, 0, -16384], [0, 16384, -16384]);
        let reading: Reading = with_driver(config, &script, |imu| imu.read().unwrap());
        assert_close(reading.accel_mps2, [0.5 * fs_g * G, 0.0, -0.5 * fs_g * G]);
        assert_close(reading.gyro_rad_s, [0.0, 0.5 * fs_dps * DEG, -0.5 * fs_dps * DEG]);
        assert_eq!(reading.temperature_c, 25.0);
    }
}

#[test]
fn data_not_ready_is_stale_and_the_data_registers_are_not_read() {
    // INT_STATUS with only RESET_DONE_INT (bit 4) set: DATA_RDY_INT clear.
    let script = read(INT_STATUS, vec![0x10]);
    let (result, health) = with_driver(Config::default(), &script, |imu| (imu.read(), imu.health()));
    assert_eq!(result, Err(Error::NotReady));
    assert_eq!(
        health,
        Health {
            not_ready: 1,
            ..Health::default()
        }
    );
}

#[test]
fn the_invalid_marker_of_a_sensor_that_is_off_is_an_error() {
    let script = [
        sample(100, [0, 0, -2048], [INVALID; 3]),  // gyro off / starting up
        sample(100, [INVALID; 3], [1, 2, 3]),      // accel off
        sample(INVALID, [0, 0, -2048], [1, 2, 3]), // temperature sensor off
    ]
    .concat();
    let (results, health) = with_driver(Config::default(), &script, |imu| {
        ([imu.read(), imu.read(), imu.read()], imu.health())
    });
    assert_eq!(results, [Err(Error::InvalidData); 3]);
    assert_eq!(
        health,
        Health {
            invalid: 3,
            ..Health::default()
        }
    );
}

#[test]
fn a_sample_at_full_scale_is_saturated() {
    let script = [
        sample(0, [32767, 0, -2048], [0; 3]),         // accel x at +full scale
        sample(0, [0, 0, -2048], [0, 0, -32767]),     // gyro z at −full scale
        sample(0, [0, 0, -2048], [100, INVALID, 50]), // a lone −32768 beside valid axes: clipped
    ]
    .concat();
    let (results, health) = with_driver(Config::default(), &script, |imu| {
        ([imu.read(), imu.read(), imu.read()], imu.health())
    });
    assert_eq!(results, [Err(Error::Saturated); 3]);
    assert_eq!(
        health,
        Health {
            saturated: 3,
            ..Health::default()
        }
    );
}

#[test]
fn one_lsb_below_full_scale_is_a_reading() {
    let script = sample(0, [32766, -32766, 0], [-32766, 0, 32766]);
    let reading = with_driver(Config::default(), &script, |imu| imu.read()).unwrap();
    assert_close(reading.accel_mps2, [32766.0 / 2048.0 * G, -32766.0 / 2048.0 * G, 0.0]);
}

#[test]
fn a_bus_error_is_reported_and_counted() {
    // The status read succeeds, the burst read fails.
    let spi = FailOn {
        inner: SpiMock::new(&read(INT_STATUS, vec![DATA_RDY_INT])),
        fail_at: 1,
        count: 0,
    };
    let mut imu = Icm42688::new(spi, Config::default());
    assert_eq!(imu.read(), Err(Error::Bus(ErrorKind::Other)));
    assert_eq!(
        imu.health(),
        Health {
            bus_errors: 1,
            ..Health::default()
        }
    );
    imu.release().inner.done();
}

#[test]
fn a_bus_error_during_init_stops_the_sequence() {
    // The reset write fails: nothing after it is sent, and no delay is asked for.
    let spi = FailOn {
        inner: SpiMock::new(&read(WHO_AM_I, vec![ICM42688P_ID])),
        fail_at: 1,
        count: 0,
    };
    let mut imu = Icm42688::new(spi, Config::default());
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(imu.init(&mut delay), Err(Error::Bus(ErrorKind::Other)));
    assert_eq!(imu.health().bus_errors, 1);
    delay.done();
    imu.release().inner.done();
}

#[test]
fn the_axis_map_turns_chip_axes_into_body_frd() {
    // Chip upside down (rotated 180° about x): body y = −chip Y, body z = −chip Z.
    let upside_down = AxisMap::new(SensorAxis::PlusX, SensorAxis::MinusY, SensorAxis::MinusZ).unwrap();
    // Chip yawed 90°: body x = chip Y, body y = −chip X.
    let yawed = AxisMap::new(SensorAxis::PlusY, SensorAxis::MinusX, SensorAxis::PlusZ).unwrap();
    let raw = sample(0, [2048, 4096, 6144], [1638, 3277, 4915]); // accel 1, 2, 3 g
    let script = [raw.clone(), raw].concat();
    let readings = with_driver(
        Config {
            axis_map: upside_down,
            ..Config::default()
        },
        &script,
        |imu| {
            let first = imu.read().unwrap();
            imu.set_axis_map(yawed);
            [first, imu.read().unwrap()]
        },
    );
    assert_close(readings[0].accel_mps2, [G, -2.0 * G, -3.0 * G]);
    assert_close(readings[1].accel_mps2, [2.0 * G, -G, 3.0 * G]);
    let dps = |raw: f32| raw / 16.384 * DEG;
    assert_close(readings[0].gyro_rad_s, [dps(1638.0), -dps(3277.0), -dps(4915.0)]);
    assert_close(readings[1].gyro_rad_s, [dps(3277.0), -dps(1638.0), dps(4915.0)]);
}

#[test]
fn the_axis_map_accepts_only_rotations() {
    assert_eq!(
        AxisMap::default(),
        AxisMap::new(SensorAxis::PlusX, SensorAxis::PlusY, SensorAxis::PlusZ).unwrap()
    );
    // The same chip axis twice.
    assert_eq!(
        AxisMap::new(SensorAxis::PlusX, SensorAxis::MinusX, SensorAxis::PlusZ),
        None
    );
    // Mirrors (determinant −1): one axis flipped, or two swapped.
    assert_eq!(
        AxisMap::new(SensorAxis::PlusX, SensorAxis::PlusY, SensorAxis::MinusZ),
        None
    );
    assert_eq!(
        AxisMap::new(SensorAxis::PlusY, SensorAxis::PlusX, SensorAxis::PlusZ),
        None
    );
    // A cyclic permutation is a rotation; a swap with one flip too.
    assert!(AxisMap::new(SensorAxis::PlusZ, SensorAxis::PlusX, SensorAxis::PlusY).is_some());
    assert!(AxisMap::new(SensorAxis::PlusY, SensorAxis::PlusX, SensorAxis::MinusZ).is_some());
}

#[test]
fn reconfiguring_range_and_rate_writes_config0_and_rescales() {
    let script = [
        write(GYRO_CONFIG0, config0(0b011, 0b0110)),  // ±250 °/s, 1 kHz
        write(GYRO_CONFIG0, config0(0b011, 0b1000)),  // ±250 °/s, 100 Hz
        write(ACCEL_CONFIG0, config0(0b011, 0b0110)), // ±2 g, 1 kHz
        write(ACCEL_CONFIG0, config0(0b011, 0b1000)), // ±2 g, 100 Hz
        sample(0, [16384, 0, 0], [16384, 0, 0]),
    ]
    .concat();
    let (reading, config) = with_driver(Config::default(), &script, |imu| {
        imu.set_gyro_range(GyroRange::Dps250).unwrap();
        imu.set_gyro_odr(Odr::Hz100).unwrap();
        imu.set_accel_range(AccelRange::G2).unwrap();
        imu.set_accel_odr(Odr::Hz100).unwrap();
        (imu.read().unwrap(), *imu.config())
    });
    assert_close(reading.accel_mps2, [G, 0.0, 0.0]);
    assert_close(reading.gyro_rad_s, [125.0 * DEG, 0.0, 0.0]);
    let expected = Config {
        gyro_range: GyroRange::Dps250,
        gyro_odr: Odr::Hz100,
        accel_range: AccelRange::G2,
        accel_odr: Odr::Hz100,
        axis_map: AxisMap::IDENTITY,
    };
    assert_eq!(config, expected);
}

#[test]
fn a_failed_reconfiguration_keeps_the_cached_range() {
    // The range write fails; the next sample is still scaled at ±16 g.
    let spi = FailOn {
        inner: SpiMock::new(&sample(0, [16384, 0, 0], [0; 3])),
        fail_at: 0,
        count: 0,
    };
    let mut imu = Icm42688::new(spi, Config::default());
    assert_eq!(imu.set_accel_range(AccelRange::G2), Err(Error::Bus(ErrorKind::Other)));
    assert_eq!(imu.config().accel_range, AccelRange::G16);
    assert_close(imu.read().unwrap().accel_mps2, [8.0 * G, 0.0, 0.0]);
    imu.release().inner.done();
}
