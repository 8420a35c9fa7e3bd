//! Counters shared by the tasks and their report by the low-priority `telemetry` task.

use crate::estimate::StepError;

/// What the tasks count; the `telemetry` task reports a copy. Counters wrap at 2³².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct Stats {
    /// Samples taken by the `sample` task.
    pub sampled: u32,
    /// Samples dropped because the channel to `estimate` was full (the estimator fell behind).
    pub dropped: u32,
    /// Samples the estimator accepted.
    pub estimated: u32,
    /// Samples the estimator refused.
    pub rejected: u32,
    /// The last refusal, if any.
    pub last_error: Option<StepError>,
    /// Core cycles of the last `estimate::step` (DWT CYCCNT; 0 under QEMU).
    pub step_cycles_last: u32,
    /// Most core cycles of one `estimate::step` since boot.
    pub step_cycles_max: u32,
}

impl Stats {
    /// Counts one sample taken, and whether it made it into the channel.
    pub fn record_sample(&mut self, queued: bool) {
        self.sampled = self.sampled.wrapping_add(1);
        if !queued {
            self.dropped = self.dropped.wrapping_add(1);
        }
    }

    /// Counts one estimator step, its outcome and its cost in core cycles.
    pub fn record_step(&mut self, result: Result<(), StepError>, cycles: u32) {
        match result {
            Ok(()) => self.estimated = self.estimated.wrapping_add(1),
            Err(e) => {
                self.rejected = self.rejected.wrapping_add(1);
                self.last_error = Some(e);
            }
        }
        self.step_cycles_last = cycles;
        self.step_cycles_max = self.step_cycles_max.max(cycles);
    }
}

/// Sends one report. For now a defmt log line; a telemetry link (MAVLink or a compact frame carrying
/// the core's `Health`) replaces it.
pub fn report(stats: &Stats) {
    defmt::info!("telemetry: {}", stats);
}
