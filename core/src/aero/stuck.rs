//! Stuck-sensor detection: a sensor that keeps returning the same reading — a frozen
//! digital output, a jammed vane, a bus bridge replaying its last buffer — passes every range check,
//! so the pipeline alone would identify on a constant. [`StuckDetector`] watches each channel of the
//! [`SensorSample`]s and marks one *stuck* once its reading has repeated bit for bit for
//! [`StuckSettings::samples`] consecutive samples; [`StuckDetector::apply`] then sets the channel to
//! NaN, so the [`Pipeline`](super::Pipeline) refuses exactly the coefficients that need it (and
//! counts it in its `Health::invalid_channel`), until the reading changes again.
//!
//! ## Why bit-identical repeats, and the default windows
//! Every sensor here is quantised and noisy: a live one changes its least significant bits from
//! sample to sample, a stuck one repeats them exactly, and no threshold needs tuning. What a live
//! sensor may repeat by chance sets the window (100 Hz sampling):
//! * IMU (accelerometer, gyroscope; ICM-42688-P, 16 bits): the three axes repeat together only if
//!   the noise is below one LSB on each. The gyro's noise at ±2000 °/s is about ⅓ LSB (0.02 °/s
//!   rms against 0.061 °/s per LSB at 50 Hz bandwidth) and the accelerometer's about 1 LSB, so a
//!   still aircraft on the ground repeats a triple with a probability of at most ~0.1 per sample —
//!   `0.1²⁰ = 10⁻²⁰` for 20 in a row; in flight, vibration makes it far smaller. Window **20**
//!   samples (0.2 s).
//! * Airspeed (MS4525DO, 14 bits: 0.06 m/s per count at 15 m/s; noise 1–2 counts): window **50**
//!   (0.5 s).
//! * α, β vanes (AS5600, 12 bits: 0.088° per count): a vane in smooth air can rest on one count for
//!   a while, but a vane that does not move carries no information for the estimator either, so a
//!   false alarm costs little, while every undetected stuck sample is a wrong regressor: with a
//!   2 s window a β vane stuck during the rudder doublets of the main job's flight shifted the
//!   final lateral estimates by 0.55 of a parameter's typical magnitude
//!   (`host-tests/tests/reliability_faults.rs`). Window **50** (0.5 s).
//! * Surfaces, throttle and RPM come from the autopilot's commands, which are legitimately constant
//!   in steady cruise; air density is computed from a slowly varying temperature; `dt_s` is
//!   constant by design. These are **off** (0) by default.
//!
//! The first `samples − 1` repeats of a stuck channel still reach the estimators (a causal detector
//! cannot know earlier): a constant regressor adds no excitation, and a constant output carries the
//! last true value, so the damage is a few samples' worth of weight on one point.
//!
//! A NaN (already invalid) or changed reading ends a run; so does a reading that differs only in
//! the sign of zero.

use super::model::{channel, ChannelMask};
use super::SensorSample;
use crate::Real;

/// Per channel (indexed by the bit position of [`channel`]), the run of identical readings after
/// which it is stuck; 0 turns the check off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StuckSettings {
    /// Samples, by channel bit position.
    pub samples: [u16; channel::COUNT],
}

impl Default for StuckSettings {
    /// The module doc's windows at 100 Hz: IMU 20, airspeed 50, vanes 50, the rest off.
    fn default() -> Self {
        let mut samples = [0; channel::COUNT];
        samples[bit(channel::ACCEL)] = 20;
        samples[bit(channel::GYRO)] = 20;
        samples[bit(channel::AIRSPEED)] = 50;
        samples[bit(channel::ALPHA)] = 50;
        samples[bit(channel::BETA)] = 50;
        Self { samples }
    }
}

/// The bit position of a one-bit channel mask.
const fn bit(mask: ChannelMask) -> usize {
    mask.trailing_zeros() as usize
}

/// Counters (saturating), by channel bit position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StuckHealth {
    /// Times a channel became stuck.
    pub episodes: [u32; channel::COUNT],
    /// Samples a channel was reported stuck.
    pub samples: [u32; channel::COUNT],
}

/// The detector (module doc). Small and `Copy`: 11 runs and 11 readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StuckDetector {
    settings: StuckSettings,
    /// The last reading of each channel as bits (up to three components), valid while `run > 0`.
    last: [[u64; 3]; channel::COUNT],
    /// Consecutive samples with that reading (saturating); stays 0 for a channel whose window is
    /// off.
    run: [u16; channel::COUNT],
    health: StuckHealth,
}

/// The reading of channel `i` (bit position) of a sample as bits (`None`: NaN, no reading).
/// Channel by channel, so that no array of all readings sits on the caller's stack (the firmware
/// runs this in its highest-priority task, whose frame adds to every other task's).
fn reading<T: Real>(s: &SensorSample<T>, i: usize) -> Option<[u64; 3]> {
    let c = s.channel(1 << i);
    if c.is_empty() || c.iter().any(|x| x.nan()) {
        return None;
    }
    let mut bits = [0; 3];
    for (b, x) in bits.iter_mut().zip(c) {
        *b = x.bits_u64();
    }
    Some(bits)
}

impl StuckDetector {
    /// A detector with no history.
    pub fn new(settings: StuckSettings) -> Self {
        Self {
            settings,
            last: [[0; 3]; channel::COUNT],
            run: [0; channel::COUNT],
            health: StuckHealth::default(),
        }
    }

    /// The settings in force.
    pub fn settings(&self) -> &StuckSettings {
        &self.settings
    }

    /// The counters.
    pub fn health(&self) -> &StuckHealth {
        &self.health
    }

    /// Takes the next sample's readings; returns the channels that are stuck at this sample.
    /// Channels whose window is off are not read at all (6 of the 11 by default; comparing them
    /// cost 603 instructions per sample on the M4F, measured on the QEMU replay).
    pub fn check<T: Real>(&mut self, s: &SensorSample<T>) -> ChannelMask {
        let mut stuck = 0;
        for i in 0..channel::COUNT {
            let window = self.settings.samples[i];
            if window == 0 {
                continue;
            }
            match reading(s, i) {
                Some(bits) if self.run[i] > 0 && self.last[i] == bits => {
                    self.run[i] = self.run[i].saturating_add(1);
                }
                Some(bits) => {
                    self.last[i] = bits;
                    self.run[i] = 1;
                }
                None => self.run[i] = 0,
            }
            if self.run[i] >= window {
                if self.run[i] == window {
                    self.health.episodes[i] = self.health.episodes[i].saturating_add(1);
                }
                self.health.samples[i] = self.health.samples[i].saturating_add(1);
                stuck |= 1 << i;
            }
        }
        stuck
    }

    /// [`Self::check`], then the stuck channels of `s` set to NaN; returns them.
    pub fn apply<T: Real>(&mut self, s: &mut SensorSample<T>) -> ChannelMask {
        let stuck = self.check(s);
        s.invalidate(stuck);
        stuck
    }
}
