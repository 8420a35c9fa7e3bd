//! The sample that flows from the `sample` task to the `estimate` task through the bounded channel.

/// One timestamped sample, as pushed by the high-priority `sample` task.
///
/// For now it carries only its timing; the sensor readings (IMU, airspeed, vanes, through the core's
/// drivers) join it when the drivers land.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub struct Sample {
    /// Sequence number, +1 per sampling period (wraps at 2³²); a gap means samples were dropped.
    pub seq: u32,
    /// Time of acquisition since boot, µs (SysTick monotonic, 1 ms resolution).
    pub t_us: u64,
    /// Time since the previous sample, s (the nominal period for the first one).
    pub dt_s: f32,
}

/// Numbers and timestamps samples: the only state of the `sample` task.
#[derive(Debug, Default)]
pub struct Sampler {
    next_seq: u32,
    last_t_us: Option<u64>,
}

impl Sampler {
    /// Makes the sample taken at `t_us` (µs since boot); `nominal_dt_s` is the sampling period, used
    /// as `dt_s` of the first sample.
    pub fn take(&mut self, t_us: u64, nominal_dt_s: f32) -> Sample {
        let dt_s = match self.last_t_us {
            Some(last) => t_us.saturating_sub(last) as f32 * 1e-6,
            None => nominal_dt_s,
        };
        let sample = Sample {
            seq: self.next_seq,
            t_us,
            dt_s,
        };
        self.next_seq = self.next_seq.wrapping_add(1);
        self.last_t_us = Some(t_us);
        sample
    }
}
