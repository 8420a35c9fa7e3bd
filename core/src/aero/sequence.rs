//! Missed samples: the time stamp of the sample after a gap.
//!
//! The flight computer numbers its samples as it takes them (one per sampling period) and stamps
//! each with `dt_s`, the time since the sample taken before it. When the estimator falls behind
//! and the channel between the sampling and the estimating task is full, a sample is dropped
//! (counted) rather than waited for. The estimator then sees sample `n` after sample `n − 2`, but
//! `n`'s `dt_s` still says one period: the [`RateDifferentiator`](super::RateDifferentiator) would
//! take a 20 ms step for a 10 ms one and get `ω̇` wrong by a factor of two for a whole window.
//!
//! [`SequenceCheck`] sits in front of the [`Pipeline`](super::Pipeline): it watches the sequence
//! numbers and, after a gap, sets `dt_s` to the real time since the last sample the pipeline saw
//! (from the exact µs time stamps, not from `t_s`, which an `f32` holds only to 4 ms after ten
//! hours). A gap of one or more periods is far outside the pipeline's `dt_s` tolerance
//! ([`Limits::dt_tolerance`](super::Limits::dt_tolerance), ±50 % by default), so the sample's
//! `dt` channel is invalid there: the differentiator restarts its window and the moment
//! coefficients wait for it to fill again (refused as warm-up), while the force coefficients,
//! which do not use `dt`, go on. A sample that is not newer than the last one (a repeated or
//! older sequence number: never produced by the firmware's single sampler) is
//! [`Admission::Stale`] and must not be processed.

use super::SensorSample;
use crate::Real;

/// What [`SequenceCheck::admit`] made of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Admission {
    /// The next sample in sequence (or the first): unchanged.
    Next,
    /// `missed` samples are missing before this one: its `dt_s` now spans the gap.
    Gap {
        /// Sequence numbers skipped.
        missed: u32,
    },
    /// Not newer than the last admitted sample: do not process it.
    Stale,
}

/// Counters (saturating).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SequenceHealth {
    /// Samples admitted.
    pub admitted: u32,
    /// Gaps seen.
    pub gaps: u32,
    /// Samples missing in those gaps.
    pub missed: u32,
    /// Samples refused as stale.
    pub stale: u32,
}

/// The sequence check (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SequenceCheck {
    /// Sequence number and time stamp (µs) of the last admitted sample.
    last: Option<(u32, u64)>,
    health: SequenceHealth,
}

/// Sequence differences at or above this are "older" (half the `u32` range, as serial-number
/// arithmetic does: 2³¹ samples are 248 days at 100 Hz).
const OLDER: u32 = 1 << 31;

impl SequenceCheck {
    /// A check that has seen no sample (a `const`, for statics).
    pub const NEW: Self = Self {
        last: None,
        health: SequenceHealth {
            admitted: 0,
            gaps: 0,
            missed: 0,
            stale: 0,
        },
    };

    /// Takes the next sample, numbered `seq` (wrapping) and taken at `t_us` (µs since boot, the
    /// clock its `dt_s` was measured with). After a gap `sample.dt_s` becomes the time since the
    /// last admitted sample, `(t_us − t_last)·10⁻⁶` s (0 if the clock did not advance); a stale
    /// sample is left as it is and does not move the check on. ([`Self::admit_stamp`] without
    /// the sample.)
    pub fn admit<T: Real>(&mut self, seq: u32, t_us: u64, sample: &mut SensorSample<T>) -> Admission {
        let (admission, dt_s) = self.admit_stamp(seq, t_us);
        if let Some(dt_s) = dt_s {
            sample.dt_s = dt_s;
        }
        admission
    }

    /// [`Self::admit`] for a sample the caller only borrows: the admission, and after a gap the
    /// `dt_s` the sample must be processed with (`None`: keep its own). The firmware reads its
    /// samples in place from the sampling task's queue and copies one only after a gap.
    pub fn admit_stamp<T: Real>(&mut self, seq: u32, t_us: u64) -> (Admission, Option<T>) {
        let mut dt_s = None;
        let admission = match self.last {
            None => Admission::Next,
            Some((last_seq, last_t_us)) => match seq.wrapping_sub(last_seq) {
                1 => Admission::Next,
                d if d == 0 || d >= OLDER => Admission::Stale,
                d => {
                    // In `T` (an `f64` product would be software on the M4F); gaps beyond
                    // 2³² µs (71 min) saturate, far beyond every `dt_s` the pipeline accepts.
                    let gap_us = u32::try_from(t_us.saturating_sub(last_t_us)).unwrap_or(u32::MAX);
                    dt_s = Some(T::lit(f64::from(gap_us)) * T::lit(1e-6));
                    Admission::Gap { missed: d - 1 }
                }
            },
        };
        let h = &mut self.health;
        match admission {
            Admission::Stale => h.stale = h.stale.saturating_add(1),
            Admission::Gap { missed } => {
                h.gaps = h.gaps.saturating_add(1);
                h.missed = h.missed.saturating_add(missed);
            }
            Admission::Next => {}
        }
        if admission != Admission::Stale {
            h.admitted = h.admitted.saturating_add(1);
            self.last = Some((seq, t_us));
        }
        (admission, dt_s)
    }

    /// The counters.
    pub fn health(&self) -> &SequenceHealth {
        &self.health
    }
}
