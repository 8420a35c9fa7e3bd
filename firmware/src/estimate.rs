//! The estimator run by the mid-priority `estimate` task on every sample: the core's six-coefficient
//! pipeline (synthesis of eq. 1–2, then recursive PCA-GTLS with VFF per coefficient), configured by
//! `aerosid_core::aero::onboard`, timed stage by stage with the board's counter.
//!
//! In front of the pipeline, the sequence check ([`SequenceCheck`]): when the `sample` task had to
//! drop samples (the queue was full), the next sample's `dt_s` still says one period; the check
//! sees the gap in the sequence numbers and sets `dt_s` to the real time since the last sample
//! processed, which the pipeline's `dt` check refuses, so the rate differentiator restarts instead
//! of taking a 20 ms step for 10 ms. A sample not newer than the last one is not processed.

use crate::board::{Counter, CycleCounter};
use crate::sample::Sample;
use aerosid_core::aero::model::{channel, idx, ChannelMask};
use aerosid_core::aero::{
    onboard, Admission, Pipeline, PipelineStep, SensorSample, SequenceCheck, SequenceHealth, Stage,
};
pub use aerosid_core::harness::{PERIOD_PROBE, PROBES};

/// Counter ticks of one step (cycles on hardware, instructions under QEMU), per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct StepCost {
    /// `[whole step, synthesis, C_L, C_D, C_Y, C_l, C_m, C_n, period]`; 0 for stages not reached
    /// (warm-up). `period` is the counter from the previous processed sample's step start to this
    /// one's: everything the processor executed for one sample — the step, the sample queue, the
    /// sampling task, telemetry and interrupts (under QEMU, where nothing waits for the sampling
    /// period, no sleep either); 0 for the first sample.
    pub ticks: [u32; PROBES],
}

/// The estimator: the pipeline (≈ 4.9 KB) and its per-sample result (≈ 0.5 KB), both in statics of
/// `init` and built there in place (see [`Estimator::new`]).
pub struct Estimator {
    pipeline: &'static mut Pipeline<f32>,
    /// The pipeline's per-sample result, filled in place ([`Pipeline::process_into`]).
    step: &'static mut PipelineStep<f32>,
    /// Gaps in the sample sequence (module doc).
    sequence: SequenceCheck,
    /// Channels the pipeline found invalid at the last sample.
    invalid_now: ChannelMask,
    /// The board's counter: times the pipeline's stages, and whoever holds the estimator lock
    /// ([`Estimator::now`]).
    counter: CycleCounter,
    /// The counter at the last processed sample's step start (for [`PERIOD_PROBE`]).
    last_start: Option<u32>,
}

/// Why the estimator could not be built (a configuration error, found at boot).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct ConfigError;

impl Estimator {
    /// The on-board pipeline, configured in place in `pipeline`, with the step buffer `step` (both
    /// `init`-local statics that start as the core's `const` placeholders) and the board's counter.
    ///
    /// Why statics and not values: RTIC moves `init`'s returned resources into their statics and
    /// enables the interrupts before `init`'s stack frame is released, so every task's first run
    /// (and, in a QEMU replay, the whole run) stacks on top of that frame. Returned by value, the
    /// pipeline occupied the frame twice (the value and the `Shared` struct holding it): 8.5 KB of
    /// stack under every task; built by value into a slot it still took 7.6 KB. Configured in place
    /// ([`onboard::configure`]) the frame holds at most one estimator under construction, and
    /// `Shared` holds only references.
    #[inline(never)]
    pub fn new(
        pipeline: &'static mut Pipeline<f32>,
        step: &'static mut PipelineStep<f32>,
        counter: CycleCounter,
    ) -> Result<Self, ConfigError> {
        onboard::configure(pipeline).map_err(|_| ConfigError)?;
        Ok(Self {
            pipeline,
            step,
            sequence: SequenceCheck::NEW,
            invalid_now: 0,
            counter,
            last_start: None,
        })
    }

    /// The board's counter now (cycles on hardware, instructions under QEMU): for timing work
    /// done under the estimator lock.
    pub fn now(&self) -> u32 {
        self.counter.now()
    }

    /// Runs one sample through the sequence check and the pipeline; returns how many
    /// coefficients updated and the cost, or `None` for a stale sample (not processed). The sample
    /// is read where it lies (the sampling task's queue); only after a gap, whose re-stamped
    /// `dt_s` it must carry, is it copied.
    pub fn step(&mut self, sample: &Sample) -> Option<(u8, StepCost)> {
        let (admission, gap_dt_s) = self.sequence.admit_stamp::<f32>(sample.seq, sample.t_us);
        match admission {
            Admission::Stale => {
                defmt::warn!("estimate: sample {=u32} is stale, not processed", sample.seq);
                return None;
            }
            Admission::Gap { missed } => {
                defmt::warn!("estimate: {=u32} samples missed before {=u32}", missed, sample.seq);
            }
            Admission::Next => {}
        }
        let restamped;
        let sensors = match gap_dt_s {
            Some(dt_s) => {
                restamped = SensorSample { dt_s, ..sample.sensors };
                &restamped
            }
            None => &sample.sensors,
        };
        let mut cost = StepCost::default();
        let counter = &self.counter;
        let start = counter.now();
        if let Some(previous) = self.last_start {
            cost.ticks[PERIOD_PROBE] = start.wrapping_sub(previous);
        }
        self.last_start = Some(start);
        let mut last = start;
        self.pipeline.process_into(sensors, self.step, &mut |stage| {
            let now = counter.now();
            let slot = match stage {
                Stage::Synthesis => 1,
                Stage::Coefficient(i) => 2 + i.min(idx::COUNT - 1),
            };
            if let Some(t) = cost.ticks.get_mut(slot) {
                *t = now.wrapping_sub(last);
            }
            last = now;
        });
        cost.ticks[0] = counter.now().wrapping_sub(start);
        // Outside the timed region: the mask the pipeline computed, for the health report.
        self.invalid_now = !self.pipeline.settings().limits.valid_channels(sensors) & channel::ALL;
        let updated = self.step.status.iter().filter(|s| s.is_ok()).count() as u8;
        Some((updated, cost))
    }

    /// The pipeline (for telemetry reports).
    pub fn pipeline(&self) -> &Pipeline<f32> {
        self.pipeline
    }

    /// The sequence check's counters.
    pub fn sequence(&self) -> &SequenceHealth {
        self.sequence.health()
    }

    /// Channels the pipeline found invalid at the last processed sample.
    pub fn invalid_now(&self) -> ChannelMask {
        self.invalid_now
    }
}
