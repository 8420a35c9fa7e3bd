//! The estimator run by the mid-priority `estimate` task on every sample: the core's six-coefficient
//! pipeline (synthesis of eq. 1–2, then recursive PCA-GTLS with VFF per coefficient), configured by
//! `aerosid_core::aero::onboard`, timed stage by stage with the board's counter.

use crate::board::Counter;
use crate::sample::Sample;
use aerosid_core::aero::model::idx;
use aerosid_core::aero::{onboard, Pipeline, PipelineStep, Stage};

/// Timing probes per sample: the whole step, the synthesis stage, then one per coefficient.
pub const PROBES: usize = 2 + idx::COUNT;

/// Counter ticks of one step (cycles on hardware, instructions under QEMU), per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct StepCost {
    /// `[whole step, synthesis, C_L, C_D, C_Y, C_l, C_m, C_n]`; 0 for stages not reached (warm-up).
    pub ticks: [u32; PROBES],
}

/// The estimator: the pipeline (≈ 4.9 KB) and its per-sample result (≈ 0.5 KB), both in statics of
/// `init` and built there in place (see [`Estimator::new`]).
pub struct Estimator {
    pipeline: &'static mut Pipeline<f32>,
    /// The pipeline's per-sample result, filled in place ([`Pipeline::process_into`]).
    step: &'static mut PipelineStep<f32>,
}

/// Why the estimator could not be built (a configuration error, found at boot).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct ConfigError;

impl Estimator {
    /// The on-board pipeline, configured in place in `pipeline`, with the step buffer `step` (both
    /// `init`-local statics that start as the core's `const` placeholders).
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
    ) -> Result<Self, ConfigError> {
        onboard::configure(pipeline).map_err(|_| ConfigError)?;
        Ok(Self { pipeline, step })
    }

    /// Runs one sample through the pipeline; returns how many coefficients updated and the cost.
    pub fn step(&mut self, sample: &Sample, counter: &impl Counter) -> (u8, StepCost) {
        let mut cost = StepCost::default();
        let start = counter.now();
        let mut last = start;
        self.pipeline.process_into(&sample.sensors, self.step, &mut |stage| {
            let now = counter.now();
            let slot = match stage {
                Stage::Synthesis => 1,
                Stage::Coefficient(i) => 2 + i.min(idx::COUNT - 1),
            };
            cost.ticks[slot] = now.wrapping_sub(last);
            last = now;
        });
        cost.ticks[0] = counter.now().wrapping_sub(start);
        let updated = self.step.status.iter().filter(|s| s.is_ok()).count() as u8;
        (updated, cost)
    }

    /// The pipeline (for telemetry reports).
    pub fn pipeline(&self) -> &Pipeline<f32> {
        self.pipeline
    }
}
