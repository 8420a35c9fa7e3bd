//! TDK InvenSense ICM-42688-P 6-axis IMU (gyroscope + accelerometer) over SPI.
//!
//! Source: the ICM-42688-P datasheet, DS-000347 rev. 1.7 ("DS" below). Register addresses and bit
//! fields are those of user bank 0 (DS "Register map", user bank 0, and the bank-0 register
//! descriptions, cited by register name since section numbers move between revisions), the bank the
//! chip selects after reset; this driver never switches banks.
//!
//! What it does:
//! * [`Icm42688::init`] checks `WHO_AM_I` (0x47), soft-resets the chip through `DEVICE_CONFIG`, writes
//!   the full-scale range and output data rate of both sensors (`GYRO_CONFIG0`, `ACCEL_CONFIG0`), then
//!   puts both in low-noise mode (`PWR_MGMT0`) and waits the 200 µs the datasheet requires after the
//!   gyroscope leaves the off state.
//! * [`Icm42688::read`] polls `INT_STATUS.DATA_RDY_INT` and, when set, reads `TEMP_DATA1` through
//!   `GYRO_DATA_Z0` (0x1D..=0x2A: temperature, 3 accelerometer and 3 gyroscope words, big-endian, the
//!   reset setting of `INTF_CONFIG0.SENSOR_DATA_ENDIAN`) in one burst, so all seven words come from the
//!   same sample. It returns a [`Reading`] in SI units in the body frame (FRD) through a fixed
//!   [`AxisMap`].
//!
//! Bad data is an `Err`, never a reading, and each outcome is counted in [`Health`]:
//! * a bus error → [`Error::Bus`];
//! * `DATA_RDY_INT` clear (no sample since the last read: the data registers are stale) →
//!   [`Error::NotReady`];
//! * the invalid-sample marker −32768 (0x8000, the reset value of every `*_DATA_*` register in the
//!   DS register map): the chip holds it while a sensor is off or still starting up (gyro start-up
//!   ≈ 30 ms, DS Table 1).
//!   If all three axes of the accelerometer or of the gyroscope, or the temperature word, hold it →
//!   [`Error::InvalidData`];
//! * any axis at full scale (|raw| ≥ 32767, or a lone −32768 beside valid axes) → [`Error::Saturated`].
//!   Saturation is an error rather than a flag: a clipped rate or acceleration would bias the
//!   identified coefficients, and the pipeline already knows how to drop a channel.
//!
//! Scale factors are the 16-bit span of the selected range, `full_scale / 32768` per LSB (DS Table 1
//! and Table 2 round these, e.g. 16.4 LSB/(°/s) for ±2000 °/s = 32768/2000). Temperature is
//! `TEMP_DATA / 132.48 + 25` °C (DS §4.13 and `TEMP_DATA1`). Accelerations use g = 9.80665 m/s².
//!
//! **Crates checked (why this driver is our own).** `icm42688` 0.2.0 depends on embedded-hal 0.2 and
//! on ESP32-C3 board crates (`esp32c3-hal`, `esp-println`, `riscv-rt` by default), so it neither fits
//! embedded-hal 1.0 `SpiDevice` nor builds for our target (one of its dependency versions is also
//! yanked). `icm426xx` 0.4.0 is embedded-hal 1.0 and no_std, but it reads only the 20-bit FIFO
//! high-resolution mode (fixed ±2000 °/s / ±16 g, no range or data-register path), reports neither
//! stale, invalid nor saturated data, its blocking path is untested by its authors, its low-level bank
//! access can `panic!` and its FIFO read indexes a caller buffer without a length check. So neither
//! meets the project's rules (blocking `SpiDevice`, no panics, errors for bad data); this driver is
//! written from the datasheet.

use embedded_hal::delay::DelayNs;
use embedded_hal::spi::{Operation, SpiDevice};

/// Standard gravity, m/s² (the g of the accelerometer ranges).
pub const STANDARD_GRAVITY_MPS2: f32 = 9.80665;

/// The `WHO_AM_I` value of the ICM-42688-P (DS register description `WHO_AM_I`, reset value).
pub const DEVICE_ID: u8 = 0x47;

/// Bank-0 register addresses (DS register map, user bank 0).
pub mod register {
    /// `DEVICE_CONFIG`: bit 0 `SOFT_RESET_CONFIG`.
    pub const DEVICE_CONFIG: u8 = 0x11;
    /// `TEMP_DATA1`: temperature, upper byte; the burst read starts here.
    pub const TEMP_DATA1: u8 = 0x1D;
    /// `ACCEL_DATA_X1`: accelerometer X, upper byte.
    pub const ACCEL_DATA_X1: u8 = 0x1F;
    /// `GYRO_DATA_X1`: gyroscope X, upper byte.
    pub const GYRO_DATA_X1: u8 = 0x25;
    /// `GYRO_DATA_Z0`: gyroscope Z, lower byte; the burst read ends here.
    pub const GYRO_DATA_Z0: u8 = 0x2A;
    /// `INT_STATUS` (clear on read): bit 3 `DATA_RDY_INT`.
    pub const INT_STATUS: u8 = 0x2D;
    /// `PWR_MGMT0`: bits 3:2 `GYRO_MODE`, bits 1:0 `ACCEL_MODE`, bit 5 `TEMP_DIS`.
    pub const PWR_MGMT0: u8 = 0x4E;
    /// `GYRO_CONFIG0`: bits 7:5 `GYRO_FS_SEL`, bits 3:0 `GYRO_ODR`.
    pub const GYRO_CONFIG0: u8 = 0x4F;
    /// `ACCEL_CONFIG0`: bits 7:5 `ACCEL_FS_SEL`, bits 3:0 `ACCEL_ODR`.
    pub const ACCEL_CONFIG0: u8 = 0x50;
    /// `WHO_AM_I`: reads [`super::DEVICE_ID`].
    pub const WHO_AM_I: u8 = 0x75;
}

/// Bit fields of the bank-0 registers (DS bank-0 register descriptions, by register name).
pub mod bits {
    /// SPI read: the register address with bit 7 set (DS SPI interface: the first byte's MSB is R/W).
    pub const SPI_READ: u8 = 0x80;
    /// `DEVICE_CONFIG.SOFT_RESET_CONFIG`: write 1 to reset; wait 1 ms before the next access.
    pub const SOFT_RESET_CONFIG: u8 = 1 << 0;
    /// `INT_STATUS.DATA_RDY_INT`: a new sample is in the data registers (cleared by reading).
    pub const DATA_RDY_INT: u8 = 1 << 3;
    /// `PWR_MGMT0.GYRO_MODE` = 0b11, low-noise mode.
    pub const GYRO_MODE_LN: u8 = 0b11 << 2;
    /// `PWR_MGMT0.ACCEL_MODE` = 0b11, low-noise mode.
    pub const ACCEL_MODE_LN: u8 = 0b11;
    /// Position of `GYRO_FS_SEL` / `ACCEL_FS_SEL` in `*_CONFIG0`.
    pub const FS_SEL_SHIFT: u8 = 5;
}

/// Waits of the power-up sequence (DS register descriptions `DEVICE_CONFIG`, `PWR_MGMT0`).
mod timing {
    /// After `SOFT_RESET_CONFIG`: 1 ms before any register access (`DEVICE_CONFIG`).
    pub const SOFT_RESET_MS: u32 = 1;
    /// After the gyroscope leaves the off state: no register writes for 200 µs (`PWR_MGMT0`).
    pub const GYRO_ON_US: u32 = 200;
}

/// Bytes of the burst read `TEMP_DATA1..=GYRO_DATA_Z0`: temperature + 3 accel + 3 gyro words.
const BURST_LEN: usize = (register::GYRO_DATA_Z0 - register::TEMP_DATA1 + 1) as usize;
/// Offsets of the words in the burst.
const ACCEL_OFFSET: usize = (register::ACCEL_DATA_X1 - register::TEMP_DATA1) as usize;
const GYRO_OFFSET: usize = (register::GYRO_DATA_X1 - register::TEMP_DATA1) as usize;

/// The invalid-sample marker in the data registers (−32768, 0x8000).
const INVALID_MARKER: i16 = i16::MIN;
/// Magnitude at or above which an axis is taken as clipped.
const SATURATION_RAW: i16 = i16::MAX;
/// LSB count of the full-scale range (the 16-bit span).
const FULL_SCALE_LSB: f32 = 32768.0;
/// Temperature sensitivity, LSB/°C, and offset, °C (DS §4.13, `TEMP_DATA1`).
const TEMP_LSB_PER_C: f32 = 132.48;
const TEMP_OFFSET_C: f32 = 25.0;

/// Driver errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<CommE> {
    /// The SPI transaction failed.
    Bus(CommE),
    /// `WHO_AM_I` returned this value instead of 0x47: wrong chip, or no chip on the bus.
    WrongDevice(u8),
    /// `DATA_RDY_INT` was clear: no new sample since the last read (the registers hold a stale one).
    NotReady,
    /// A sensor's data registers hold the invalid-sample marker (sensor off or starting up).
    InvalidData,
    /// An axis is at full scale: the true value may be larger. Choose a wider range.
    Saturated,
}

/// Gyroscope full-scale range (DS `GYRO_CONFIG0.GYRO_FS_SEL`). Default: ±2000 °/s (reset value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroRange {
    /// ±2000 °/s.
    #[default]
    Dps2000 = 0b000,
    /// ±1000 °/s.
    Dps1000 = 0b001,
    /// ±500 °/s.
    Dps500 = 0b010,
    /// ±250 °/s.
    Dps250 = 0b011,
}

impl GyroRange {
    /// Full scale, °/s.
    pub const fn full_scale_dps(self) -> f32 {
        match self {
            GyroRange::Dps2000 => 2000.0,
            GyroRange::Dps1000 => 1000.0,
            GyroRange::Dps500 => 500.0,
            GyroRange::Dps250 => 250.0,
        }
    }

    /// Scale factor, rad/s per LSB.
    pub fn rad_s_per_lsb(self) -> f32 {
        self.full_scale_dps().to_radians() / FULL_SCALE_LSB
    }
}

/// Accelerometer full-scale range (DS `ACCEL_CONFIG0.ACCEL_FS_SEL`). Default: ±16 g (reset value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// ±16 g.
    #[default]
    G16 = 0b000,
    /// ±8 g.
    G8 = 0b001,
    /// ±4 g.
    G4 = 0b010,
    /// ±2 g.
    G2 = 0b011,
}

impl AccelRange {
    /// Full scale, g.
    pub const fn full_scale_g(self) -> f32 {
        match self {
            AccelRange::G16 => 16.0,
            AccelRange::G8 => 8.0,
            AccelRange::G4 => 4.0,
            AccelRange::G2 => 2.0,
        }
    }

    /// Scale factor, m/s² per LSB.
    pub fn mps2_per_lsb(self) -> f32 {
        self.full_scale_g() * STANDARD_GRAVITY_MPS2 / FULL_SCALE_LSB
    }
}

/// Output data rate, the same code for DS `GYRO_CONFIG0.GYRO_ODR` and `ACCEL_CONFIG0.ACCEL_ODR`.
/// Only the rates both sensors offer in low-noise mode are listed. Default: 1 kHz (reset value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Odr {
    /// 8 kHz.
    Hz8000 = 0b0011,
    /// 4 kHz.
    Hz4000 = 0b0100,
    /// 2 kHz.
    Hz2000 = 0b0101,
    /// 1 kHz.
    #[default]
    Hz1000 = 0b0110,
    /// 500 Hz (code 0b1111: added after the others in the register map).
    Hz500 = 0b1111,
    /// 200 Hz.
    Hz200 = 0b0111,
    /// 100 Hz.
    Hz100 = 0b1000,
    /// 50 Hz.
    Hz50 = 0b1001,
    /// 25 Hz.
    Hz25 = 0b1010,
    /// 12.5 Hz.
    Hz12_5 = 0b1011,
}

impl Odr {
    /// The rate, Hz.
    pub const fn hz(self) -> f32 {
        match self {
            Odr::Hz8000 => 8000.0,
            Odr::Hz4000 => 4000.0,
            Odr::Hz2000 => 2000.0,
            Odr::Hz1000 => 1000.0,
            Odr::Hz500 => 500.0,
            Odr::Hz200 => 200.0,
            Odr::Hz100 => 100.0,
            Odr::Hz50 => 50.0,
            Odr::Hz25 => 25.0,
            Odr::Hz12_5 => 12.5,
        }
    }
}

/// One sensor axis with a sign: what a body axis reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SensorAxis {
    /// +X of the chip (DS figure "Orientation of axes of sensitivity and polarity of rotation").
    PlusX,
    /// −X of the chip.
    MinusX,
    /// +Y of the chip.
    PlusY,
    /// −Y of the chip.
    MinusY,
    /// +Z of the chip.
    PlusZ,
    /// −Z of the chip.
    MinusZ,
}

impl SensorAxis {
    /// Index of the chip axis (0 = X, 1 = Y, 2 = Z).
    const fn index(self) -> usize {
        match self {
            SensorAxis::PlusX | SensorAxis::MinusX => 0,
            SensorAxis::PlusY | SensorAxis::MinusY => 1,
            SensorAxis::PlusZ | SensorAxis::MinusZ => 2,
        }
    }

    /// True for the minus axes.
    const fn negative(self) -> bool {
        matches!(self, SensorAxis::MinusX | SensorAxis::MinusY | SensorAxis::MinusZ)
    }

    fn pick(self, v: &[f32; 3]) -> f32 {
        let x = v[self.index()];
        if self.negative() {
            -x
        } else {
            x
        }
    }
}

/// The chip's mounting: which signed chip axis each body axis (FRD: x forward, y right, z down) reads.
///
/// A proper rotation by construction: each chip axis used once and determinant +1 (a mirror would
/// flip the sign of the rates, which are pseudo-vectors). The same map applies to both sensors.
/// Default: identity (chip X forward, Y right, Z down).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisMap {
    body: [SensorAxis; 3],
}

impl AxisMap {
    /// Chip axes are body axes.
    pub const IDENTITY: AxisMap = AxisMap {
        body: [SensorAxis::PlusX, SensorAxis::PlusY, SensorAxis::PlusZ],
    };

    /// Body x, y, z read the given chip axes. `None` unless this is a rotation (each chip axis once,
    /// determinant +1).
    pub fn new(body_x: SensorAxis, body_y: SensorAxis, body_z: SensorAxis) -> Option<Self> {
        let body = [body_x, body_y, body_z];
        let [i, j, k] = body.map(SensorAxis::index);
        if i == j || j == k || i == k {
            return None;
        }
        // Sign of the permutation (i, j, k) of (0, 1, 2): even for the cyclic shifts.
        let even = matches!((i, j, k), (0, 1, 2) | (1, 2, 0) | (2, 0, 1));
        let flips = body.iter().filter(|a| a.negative()).count();
        let positive_det = even == (flips % 2 == 0);
        positive_det.then_some(AxisMap { body })
    }

    /// The signed chip axis that body axis `0` (x), `1` (y) or `2` (z) reads.
    pub fn body_axes(&self) -> [SensorAxis; 3] {
        self.body
    }

    /// A chip-frame vector in the body frame.
    pub fn apply(&self, sensor: [f32; 3]) -> [f32; 3] {
        self.body.map(|a| a.pick(&sensor))
    }
}

impl Default for AxisMap {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// Settings the driver writes in [`Icm42688::init`] and keeps as its cached configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Gyroscope full scale; default ±2000 °/s.
    pub gyro_range: GyroRange,
    /// Gyroscope output data rate; default 1 kHz.
    pub gyro_odr: Odr,
    /// Accelerometer full scale; default ±16 g.
    pub accel_range: AccelRange,
    /// Accelerometer output data rate; default 1 kHz. Keep it equal to `gyro_odr` so that one
    /// `DATA_RDY_INT` means one new sample of each.
    pub accel_odr: Odr,
    /// Chip-to-body axes; default identity.
    pub axis_map: AxisMap,
}

impl Config {
    fn gyro_config0(&self) -> u8 {
        ((self.gyro_range as u8) << bits::FS_SEL_SHIFT) | self.gyro_odr as u8
    }

    fn accel_config0(&self) -> u8 {
        ((self.accel_range as u8) << bits::FS_SEL_SHIFT) | self.accel_odr as u8
    }
}

/// One sample in SI units, body frame FRD.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reading {
    /// Specific force (what an accelerometer measures), m/s², body x, y, z. Level and at rest:
    /// `[0, 0, −9.81]` (FRD, z down).
    pub accel_mps2: [f32; 3],
    /// Angular rate p, q, r, rad/s, body x, y, z.
    pub gyro_rad_s: [f32; 3],
    /// Die temperature, °C.
    pub temperature_c: f32,
}

/// Counters of [`Icm42688::read`] outcomes, and of bus errors in any call (for telemetry).
/// They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Readings returned.
    pub reads_ok: u32,
    /// Failed SPI transactions (any call).
    pub bus_errors: u32,
    /// Reads refused with [`Error::NotReady`].
    pub not_ready: u32,
    /// Reads refused with [`Error::InvalidData`].
    pub invalid: u32,
    /// Reads refused with [`Error::Saturated`].
    pub saturated: u32,
}

/// ICM-42688-P driver over an SPI device (chip select handled by the `SpiDevice`; SPI mode 0 or 3).
#[derive(Debug)]
pub struct Icm42688<SPI> {
    spi: SPI,
    config: Config,
    health: Health,
}

impl<SPI, CommE> Icm42688<SPI>
where
    SPI: SpiDevice<Error = CommE>,
{
    /// Wraps the SPI device. No bus traffic until [`init`](Self::init).
    pub fn new(spi: SPI, config: Config) -> Self {
        Icm42688 {
            spi,
            config,
            health: Health::default(),
        }
    }

    /// Gives the SPI device back.
    pub fn release(self) -> SPI {
        self.spi
    }

    /// Identifies the chip, soft-resets it, writes the cached [`Config`] and turns both sensors on in
    /// low-noise mode. The first samples after this (≈ 30 ms of gyro start-up, DS Table 1) are
    /// refused as [`Error::InvalidData`].
    pub fn init<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<CommE>> {
        let id = self.device_id()?;
        if id != DEVICE_ID {
            return Err(Error::WrongDevice(id));
        }
        self.write_register(register::DEVICE_CONFIG, bits::SOFT_RESET_CONFIG)?;
        delay.delay_ms(timing::SOFT_RESET_MS);
        self.write_register(register::GYRO_CONFIG0, self.config.gyro_config0())?;
        self.write_register(register::ACCEL_CONFIG0, self.config.accel_config0())?;
        self.write_register(register::PWR_MGMT0, bits::GYRO_MODE_LN | bits::ACCEL_MODE_LN)?;
        delay.delay_us(timing::GYRO_ON_US);
        Ok(())
    }

    /// Reads `WHO_AM_I` (0x47 for this chip).
    pub fn device_id(&mut self) -> Result<u8, Error<CommE>> {
        let mut id = [0];
        self.read_registers(register::WHO_AM_I, &mut id)?;
        Ok(id[0])
    }

    /// The cached configuration (what the chip was last told).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The outcome counters.
    pub fn health(&self) -> Health {
        self.health
    }

    /// Sets the gyroscope range (writes `GYRO_CONFIG0`). A sample already in the data registers may
    /// still be at the old range: discard the next reading.
    pub fn set_gyro_range(&mut self, range: GyroRange) -> Result<(), Error<CommE>> {
        let config = Config {
            gyro_range: range,
            ..self.config
        };
        self.write_register(register::GYRO_CONFIG0, config.gyro_config0())?;
        self.config = config;
        Ok(())
    }

    /// Sets the gyroscope output data rate (writes `GYRO_CONFIG0`).
    pub fn set_gyro_odr(&mut self, odr: Odr) -> Result<(), Error<CommE>> {
        let config = Config {
            gyro_odr: odr,
            ..self.config
        };
        self.write_register(register::GYRO_CONFIG0, config.gyro_config0())?;
        self.config = config;
        Ok(())
    }

    /// Sets the accelerometer range (writes `ACCEL_CONFIG0`). As for
    /// [`set_gyro_range`](Self::set_gyro_range), discard the next reading.
    pub fn set_accel_range(&mut self, range: AccelRange) -> Result<(), Error<CommE>> {
        let config = Config {
            accel_range: range,
            ..self.config
        };
        self.write_register(register::ACCEL_CONFIG0, config.accel_config0())?;
        self.config = config;
        Ok(())
    }

    /// Sets the accelerometer output data rate (writes `ACCEL_CONFIG0`).
    pub fn set_accel_odr(&mut self, odr: Odr) -> Result<(), Error<CommE>> {
        let config = Config {
            accel_odr: odr,
            ..self.config
        };
        self.write_register(register::ACCEL_CONFIG0, config.accel_config0())?;
        self.config = config;
        Ok(())
    }

    /// Sets the chip-to-body axis map (no bus traffic).
    pub fn set_axis_map(&mut self, axis_map: AxisMap) {
        self.config.axis_map = axis_map;
    }

    /// Reads one sample if `DATA_RDY_INT` is set (module doc for the errors). Reading `INT_STATUS`
    /// clears it, so call this once per data-ready interrupt or poll.
    pub fn read(&mut self) -> Result<Reading, Error<CommE>> {
        let mut status = [0];
        self.read_registers(register::INT_STATUS, &mut status)?;
        if status[0] & bits::DATA_RDY_INT == 0 {
            self.health.not_ready = self.health.not_ready.saturating_add(1);
            return Err(Error::NotReady);
        }
        let mut burst = [0; BURST_LEN];
        self.read_registers(register::TEMP_DATA1, &mut burst)?;
        let reading = self.convert(&burst);
        match reading {
            Ok(_) => self.health.reads_ok = self.health.reads_ok.saturating_add(1),
            Err(Error::InvalidData) => self.health.invalid = self.health.invalid.saturating_add(1),
            Err(Error::Saturated) => self.health.saturated = self.health.saturated.saturating_add(1),
            Err(_) => {}
        }
        reading
    }

    /// The burst (big-endian words) → SI, body frame; the validity checks of the module doc.
    fn convert(&self, burst: &[u8; BURST_LEN]) -> Result<Reading, Error<CommE>> {
        let word = |offset: usize| i16::from_be_bytes([burst[offset], burst[offset + 1]]);
        let triple = |offset: usize| [word(offset), word(offset + 2), word(offset + 4)];
        let temperature = word(0);
        let accel = triple(ACCEL_OFFSET);
        let gyro = triple(GYRO_OFFSET);

        let all_invalid = |v: &[i16; 3]| v.iter().all(|&x| x == INVALID_MARKER);
        if temperature == INVALID_MARKER || all_invalid(&accel) || all_invalid(&gyro) {
            return Err(Error::InvalidData);
        }
        // `unsigned_abs` keeps −32768 (a lone marker among valid axes: clipped negative) in range.
        let clipped = |v: &[i16; 3]| v.iter().any(|&x| x.unsigned_abs() >= SATURATION_RAW.unsigned_abs());
        if clipped(&accel) || clipped(&gyro) {
            return Err(Error::Saturated);
        }

        let accel_scale = self.config.accel_range.mps2_per_lsb();
        let gyro_scale = self.config.gyro_range.rad_s_per_lsb();
        let map = &self.config.axis_map;
        Ok(Reading {
            accel_mps2: map.apply(accel.map(|x| f32::from(x) * accel_scale)),
            gyro_rad_s: map.apply(gyro.map(|x| f32::from(x) * gyro_scale)),
            temperature_c: f32::from(temperature) / TEMP_LSB_PER_C + TEMP_OFFSET_C,
        })
    }

    fn write_register(&mut self, register: u8, value: u8) -> Result<(), Error<CommE>> {
        let result = self.spi.write(&[register, value]);
        self.bus(result)
    }

    /// Burst read from `register` (the chip auto-increments the address).
    fn read_registers(&mut self, register: u8, data: &mut [u8]) -> Result<(), Error<CommE>> {
        let result = self
            .spi
            .transaction(&mut [Operation::Write(&[register | bits::SPI_READ]), Operation::Read(data)]);
        self.bus(result)
    }

    fn bus(&mut self, result: Result<(), CommE>) -> Result<(), Error<CommE>> {
        result.map_err(|e| {
            self.health.bus_errors = self.health.bus_errors.saturating_add(1);
            Error::Bus(e)
        })
    }
}
