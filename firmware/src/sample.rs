//! The sample that flows from the `sample` task to the `estimate` task through the bounded queue.

use aerosid_core::aero::SensorSample;

/// One timestamped sample, as pushed by the high-priority `sample` task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Sequence number, +1 per sampling period (wraps at 2³²); a gap means samples were dropped.
    pub seq: u32,
    /// Time stamp, µs since boot, on the clock `sensors.dt_s` was measured with (the estimator
    /// re-stamps the sample after a gap from it: `aerosid_core::aero::SequenceCheck`).
    pub t_us: u64,
    /// Every sensor at the sampling instant (bad channels NaN; see `board::SensorSource`).
    pub sensors: SensorSample<f32>,
}

/// Numbers and timestamps samples: the only state of the `sample` task besides the sensors.
#[derive(Debug, Default)]
pub struct Sampler {
    next_seq: u32,
    last_t_us: Option<u64>,
}

impl Sampler {
    /// The time stamps of the sample taken at `t_us` (µs since boot): `(t_s, dt_s)`, with
    /// `nominal_dt_s` as `dt_s` of the first sample.
    pub fn stamp(&mut self, t_us: u64, nominal_dt_s: f32) -> (f32, f32) {
        let dt_s = match self.last_t_us {
            Some(last) => t_us.saturating_sub(last) as f32 * 1e-6,
            None => nominal_dt_s,
        };
        self.last_t_us = Some(t_us);
        (t_us as f32 * 1e-6, dt_s)
    }

    /// The next sample's sequence number (every sample taken gets one, queued or dropped, so the
    /// estimator sees the gap a drop leaves).
    pub fn next_seq(&mut self) -> u32 {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        seq
    }
}
