//! ams **AS5600** 12-bit magnetic rotary encoder, as an angle-of-attack (α) or sideslip (β) vane.
//!
//! Each reading checks the STATUS register (0x0B; datasheet "Status Registers", bits MD = 5
//! magnet detected, ML = 4 AGC maximum-gain overflow i.e. magnet too weak, MH = 3 AGC
//! minimum-gain overflow i.e. magnet too strong) and only then reads RAW ANGLE (0x0C/0x0D,
//! "Output Registers", 12 bits, 4096 counts per turn). Any magnet flag other than "MD alone" is an
//! error, never a reading. RAW ANGLE is used rather than ANGLE: ANGLE depends on ZPOS/MPOS/MANG,
//! which can be burnt only three times (ZMCO); the vane zero, sign and scale live in software
//! ([`VaneConfig`]) instead, so a vane can be recalibrated as often as needed.
//!
//! ## Crate used
//! Register access goes through the `as5600` crate (0.8, blocking embedded-hal 1.0 `I2c`,
//! `no_std`, no panics on the read paths, bus errors kept as `Communication(E)`, STATUS decoded
//! with the raw byte kept for patterns it does not name). This module adds what a vane needs:
//! the calibration, the conversion to radians, the plausibility range and the health counters.
//!
//! ## Vane calibration
//! The output is `angle_rad = k · θ`, where `θ ∈ (−π, π]` is the vane angle from the raw count:
//! * **zero** — `zero_count`, the raw count with the vane on the reference line (aligned with the
//!   body x axis / fuselage reference, i.e. `θ = 0`);
//! * **direction** — whether `θ` grows with the count ([`Direction::CountsIncrease`]) or against
//!   it, chosen so that, body FRD, α is positive nose-up relative to the flow (the relative wind
//!   from below: vane leading edge *below* the reference line, trailing edge up) and β is positive
//!   with the wind from the right (vane leading edge to the *right* of the reference line, seen
//!   from above). The sign depends on how the magnet and chip are mounted and on the DIR pin;
//! * **wrap-around** — the count difference is taken modulo 4096 into `(−2048, 2048]`, so a zero
//!   near 4095 and a reading near 0 (or the reverse) give a small angle, not ≈ 2π;
//! * **scale** `k` (default 1) — a linear vane factor, e.g. `k = 1/(1 + ε)` for an upwash
//!   `α_vane = (1 + ε) α` from the wing or the propeller, found from flight data;
//! * **plausibility range** `[min_angle_rad, max_angle_rad]` on `k · θ` (e.g. `|α| ≤ 0.5`): outside
//!   it the reading is [`Error::OutOfRange`].
//!
//! To calibrate on the ground: hold the vane on the reference line and read the raw count
//! ([`As5600::read_raw_count`]); then either declare the direction
//! ([`VaneConfig::with_reference`]) or hold the vane at a known positive or negative angle on a
//! protractor jig, read the count again, and let [`VaneConfig::calibrated`] find the direction and
//! check that the measured angle agrees with the declared one.

use core::f32::consts::{FRAC_PI_2, PI, TAU};

use ::as5600::error::Error as CrateError;
use ::as5600::status::{Error as StatusError, Status};
use embedded_hal::i2c::I2c;

/// 7-bit I2C address of the AS5600 (fixed; datasheet "I²C Interface").
pub const ADDRESS: u8 = 0x36;

/// Raw counts per mechanical turn (12 bits).
pub const COUNTS_PER_TURN: u16 = 4096;

/// Radians per raw count, `2π / 4096`.
pub const RAD_PER_COUNT: f32 = TAU / COUNTS_PER_TURN as f32;

/// Smallest |declared angle| accepted by [`VaneConfig::calibrated`] (5°, about 57 counts).
pub const CALIBRATION_MIN_ANGLE_RAD: f32 = 0.087_266_46;

/// Largest |declared angle| accepted by [`VaneConfig::calibrated`] (90°).
pub const CALIBRATION_MAX_ANGLE_RAD: f32 = FRAC_PI_2;

/// The measured calibration angle must lie within this factor of the declared one (either way).
pub const CALIBRATION_RATIO_TOLERANCE: f32 = 1.25;

/// STATUS register bits (datasheet "Status Registers", register 0x0B).
pub mod status_bits {
    /// MD: magnet detected.
    pub const MD: u8 = 1 << 5;
    /// ML: AGC maximum gain overflow, magnet too weak.
    pub const ML: u8 = 1 << 4;
    /// MH: AGC minimum gain overflow, magnet too strong.
    pub const MH: u8 = 1 << 3;
}

/// Errors of the AS5600 vane driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<CommE> {
    /// The I2C bus reported an error (NACK, arbitration loss, …).
    Bus(CommE),
    /// STATUS has MD, ML and MH all clear: no magnet.
    MagnetMissing,
    /// STATUS has ML set: the field is too weak (magnet too far or degraded).
    MagnetTooWeak,
    /// STATUS has MH set: the field is too strong (magnet too close).
    MagnetTooStrong,
    /// STATUS has both ML and MH set, which has no meaning; the byte is kept.
    InvalidStatus(u8),
    /// The `as5600` crate reported a configuration or persistence error, which the read paths
    /// used here do not produce.
    Device,
    /// `k · θ` is outside the configured plausibility range.
    OutOfRange,
    /// A configuration value is out of its documented range; the previous configuration is kept.
    InvalidConfig,
}

/// Which way the vane angle grows with the raw count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Positive angle (nose-up α / wind-from-the-right β) gives a larger raw count.
    CountsIncrease,
    /// Positive angle gives a smaller raw count.
    CountsDecrease,
}

/// Why [`VaneConfig::calibrated`] refused a calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// A raw count is above 4095.
    InvalidCount,
    /// The declared angle is not finite or its magnitude is outside
    /// [[`CALIBRATION_MIN_ANGLE_RAD`], [`CALIBRATION_MAX_ANGLE_RAD`]].
    InvalidAngle,
    /// The measured angle between the two counts is not within [`CALIBRATION_RATIO_TOLERANCE`]
    /// of the declared one (wrong jig angle, slipping magnet, or vane not moved).
    Inconsistent,
}

/// Vane calibration and plausibility range, cached in the driver (module doc, "Vane calibration").
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VaneConfig {
    /// Raw count (0…4095) at which the vane reads 0 rad.
    pub zero_count: u16,
    /// Sign of the angle relative to the raw count.
    pub direction: Direction,
    /// Linear vane factor `k` (finite, `> 0`; default 1).
    pub scale: f32,
    /// Smallest plausible `k · θ`, rad (`−π ≤ min < max`).
    pub min_angle_rad: f32,
    /// Largest plausible `k · θ`, rad (`max ≤ π`).
    pub max_angle_rad: f32,
}

impl Default for VaneConfig {
    /// Zero at count 0, counts increasing, `k = 1`, the whole turn plausible.
    fn default() -> Self {
        Self {
            zero_count: 0,
            direction: Direction::CountsIncrease,
            scale: 1.0,
            min_angle_rad: -PI,
            max_angle_rad: PI,
        }
    }
}

/// Signed count difference `to − from` modulo 4096, in `(−2048, 2048]`.
fn wrapped_counts(from: u16, to: u16) -> i32 {
    let turn = i32::from(COUNTS_PER_TURN);
    let d = (i32::from(to) - i32::from(from)).rem_euclid(turn);
    if d > turn / 2 {
        d - turn
    } else {
        d
    }
}

impl VaneConfig {
    /// Whether every field is in its documented range.
    pub fn is_valid(&self) -> bool {
        self.zero_count < COUNTS_PER_TURN
            && self.scale.is_finite()
            && self.scale > 0.0
            && self.min_angle_rad.is_finite()
            && self.max_angle_rad.is_finite()
            && self.min_angle_rad >= -PI
            && self.min_angle_rad < self.max_angle_rad
            && self.max_angle_rad <= PI
    }

    /// This configuration with the zero at `reference_count` (masked to 12 bits) and the declared
    /// `direction`; scale and range unchanged.
    pub fn with_reference(self, reference_count: u16, direction: Direction) -> Self {
        Self {
            zero_count: reference_count & (COUNTS_PER_TURN - 1),
            direction,
            ..self
        }
    }

    /// Two-point calibration: `reference_count` read with the vane on the reference line and
    /// `second_count` read with the vane held at `second_angle_rad` (signed, in the α/β convention
    /// of the module doc, `5° ≤ |angle| ≤ 90°`). Returns this configuration with the zero at
    /// `reference_count` and the direction in which the count moved; scale and range unchanged.
    ///
    /// # Errors
    /// [`CalibrationError::InvalidCount`], [`CalibrationError::InvalidAngle`], and
    /// [`CalibrationError::Inconsistent`] when the measured `|θ|` is not within a factor
    /// [`CALIBRATION_RATIO_TOLERANCE`] of `|second_angle_rad|`.
    pub fn calibrated(
        self,
        reference_count: u16,
        second_count: u16,
        second_angle_rad: f32,
    ) -> Result<Self, CalibrationError> {
        if reference_count >= COUNTS_PER_TURN || second_count >= COUNTS_PER_TURN {
            return Err(CalibrationError::InvalidCount);
        }
        let declared = libm::fabsf(second_angle_rad);
        if !(CALIBRATION_MIN_ANGLE_RAD..=CALIBRATION_MAX_ANGLE_RAD).contains(&declared) {
            return Err(CalibrationError::InvalidAngle);
        }
        let measured_rad = wrapped_counts(reference_count, second_count) as f32 * RAD_PER_COUNT;
        let ratio = libm::fabsf(measured_rad) / declared;
        if !(1.0 / CALIBRATION_RATIO_TOLERANCE..=CALIBRATION_RATIO_TOLERANCE).contains(&ratio) {
            return Err(CalibrationError::Inconsistent);
        }
        let direction = if (measured_rad > 0.0) == (second_angle_rad > 0.0) {
            Direction::CountsIncrease
        } else {
            Direction::CountsDecrease
        };
        Ok(self.with_reference(reference_count, direction))
    }

    /// The unscaled vane angle `θ ∈ (−π, π]` of a raw count (masked to 12 bits), after zero,
    /// direction and wrap-around.
    pub fn vane_angle_rad(&self, raw_count: u16) -> f32 {
        let mut d = wrapped_counts(self.zero_count, raw_count & (COUNTS_PER_TURN - 1));
        if self.direction == Direction::CountsDecrease && d != i32::from(COUNTS_PER_TURN / 2) {
            // −2048 is not in (−2048, 2048]: half a turn stays +π.
            d = -d;
        }
        d as f32 * RAD_PER_COUNT
    }

    /// The output `k · θ` of a raw count, or `None` outside the plausibility range.
    pub fn angle_rad(&self, raw_count: u16) -> Option<f32> {
        let a = self.scale * self.vane_angle_rad(raw_count);
        if a >= self.min_angle_rad && a <= self.max_angle_rad && a > -PI {
            Some(a)
        } else {
            None
        }
    }
}

/// One good reading.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reading {
    /// Calibrated vane output `k · θ`, rad.
    pub angle_rad: f32,
    /// The 12-bit RAW ANGLE count it came from.
    pub raw_count: u16,
}

/// Read counters, for telemetry. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Good readings (and good raw counts) returned.
    pub ok: u32,
    /// Bus errors (NACK and others).
    pub bus_errors: u32,
    /// Magnet missing, or a meaningless STATUS byte.
    pub magnet_missing: u32,
    /// Magnet too weak (ML).
    pub magnet_too_weak: u32,
    /// Magnet too strong (MH).
    pub magnet_too_strong: u32,
    /// Outputs outside the plausibility range.
    pub out_of_range: u32,
}

impl Health {
    fn count<T, E>(&mut self, result: &Result<T, Error<E>>) {
        let counter = match result {
            Ok(_) => &mut self.ok,
            Err(Error::Bus(_)) | Err(Error::Device) => &mut self.bus_errors,
            Err(Error::MagnetMissing) | Err(Error::InvalidStatus(_)) => &mut self.magnet_missing,
            Err(Error::MagnetTooWeak) => &mut self.magnet_too_weak,
            Err(Error::MagnetTooStrong) => &mut self.magnet_too_strong,
            Err(Error::OutOfRange) | Err(Error::InvalidConfig) => &mut self.out_of_range,
        };
        *counter = counter.saturating_add(1);
    }
}

fn map_crate_error<E>(e: CrateError<E>) -> Error<E> {
    match e {
        CrateError::Communication(e) => Error::Bus(e),
        CrateError::Status(StatusError::InvalidBitPattern(byte)) => {
            let flags = byte & (status_bits::MD | status_bits::ML | status_bits::MH);
            if flags == 0 {
                Error::MagnetMissing
            } else {
                Error::InvalidStatus(byte)
            }
        }
        _ => Error::Device,
    }
}

/// AS5600 vane driver over a blocking embedded-hal 1.0 I2C bus (wrapping `as5600::As5600`).
#[derive(Debug)]
pub struct As5600<I2C> {
    device: ::as5600::As5600<I2C>,
    config: VaneConfig,
    health: Health,
}

impl<I2C, E> As5600<I2C>
where
    I2C: I2c<Error = E>,
{
    /// A driver at [`ADDRESS`] with the default [`VaneConfig`]. No bus traffic.
    pub fn new(i2c: I2C) -> Self {
        Self {
            device: ::as5600::As5600::new(i2c),
            config: VaneConfig::default(),
            health: Health::default(),
        }
    }

    /// Give the bus back.
    pub fn release(self) -> I2C {
        self.device.release()
    }

    /// The cached calibration.
    pub fn config(&self) -> &VaneConfig {
        &self.config
    }

    /// Replace the calibration; an invalid one ([`VaneConfig::is_valid`]) is refused with
    /// [`Error::InvalidConfig`] and the old one kept.
    pub fn set_config(&mut self, config: VaneConfig) -> Result<(), Error<E>> {
        if !config.is_valid() {
            return Err(Error::InvalidConfig);
        }
        self.config = config;
        Ok(())
    }

    /// The read counters.
    pub fn health(&self) -> Health {
        self.health
    }

    /// Check STATUS, then read the 12-bit RAW ANGLE count (for calibration). Counted in [`Health`].
    ///
    /// # Errors
    /// [`Error::Bus`], [`Error::MagnetMissing`], [`Error::MagnetTooWeak`],
    /// [`Error::MagnetTooStrong`], [`Error::InvalidStatus`].
    pub fn read_raw_count(&mut self) -> Result<u16, Error<E>> {
        let result = self.raw_count_uncounted();
        self.health.count(&result);
        result
    }

    /// Check STATUS, read RAW ANGLE and return the calibrated angle. Counted in [`Health`].
    ///
    /// # Errors
    /// Those of [`As5600::read_raw_count`], and [`Error::OutOfRange`] outside the plausibility range.
    pub fn read(&mut self) -> Result<Reading, Error<E>> {
        let result = self.raw_count_uncounted().and_then(|raw_count| {
            self.config
                .angle_rad(raw_count)
                .map(|angle_rad| Reading { angle_rad, raw_count })
                .ok_or(Error::OutOfRange)
        });
        self.health.count(&result);
        result
    }

    /// Read the raw count with the vane held on the reference line and make it the zero, with the
    /// declared `direction`; returns the count. On error the calibration is unchanged.
    pub fn set_zero_here(&mut self, direction: Direction) -> Result<u16, Error<E>> {
        let count = self.read_raw_count()?;
        self.config = self.config.with_reference(count, direction);
        Ok(count)
    }

    fn raw_count_uncounted(&mut self) -> Result<u16, Error<E>> {
        match self.device.magnet_status().map_err(map_crate_error)? {
            Status::MagnetDetected => {}
            Status::MagnetLow | Status::MagnetDetectedLow => return Err(Error::MagnetTooWeak),
            Status::MagnetHigh | Status::MagnetDetectedHigh => return Err(Error::MagnetTooStrong),
        }
        self.device.raw_angle().map_err(map_crate_error)
    }
}
