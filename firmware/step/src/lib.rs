//! The firmware's hot path — one sample through the six-coefficient pipeline
//! ([`Pipeline::process_into`]: synthesis, then the six recursive PCA-GTLS updates with VFF) — as
//! one non-generic function, in a crate of its own so that it keeps `opt-level = 3` while the rest
//! of the firmware is built for size (root `Cargo.toml`, `[profile.release.package.*]`).
//!
//! Why a crate: the core is generic over the scalar, so its code is compiled (monomorphised) in the
//! crate that names `f32`, at that crate's opt-level. Named here, the estimator step is compiled at
//! opt-level 3 and the firmware only calls it; everything else the firmware instantiates from the
//! core (boot-time configuration, telemetry encoding, the autopilot link's parser, the drivers)
//! is compiled at the firmware's opt-level. Fat LTO then merges both without re-optimising the
//! step for size (measured: the QEMU replay's per-sample instruction counts, BENCHMARKS.md).
#![no_std]

use aerosid_core::aero::{Pipeline, PipelineStep, SensorSample, Stage};
use aerosid_core::fem::models::Hfb320;
use aerosid_core::fem::{FemStep, FilterError};
use aerosid_core::Error;
use nalgebra::SVector;

/// [`Pipeline::process_into`] for `f32`: `step` is overwritten with the result of `sample`, and
/// `probe` is called at the end of each stage (the firmware reads its counter there).
#[inline(never)]
pub fn process_into(
    pipeline: &mut Pipeline<f32>,
    sample: &SensorSample<f32>,
    step: &mut PipelineStep<f32>,
    mut probe: &mut dyn FnMut(Stage),
) {
    pipeline.process_into(sample, step, &mut probe);
}

/// The filter error method's HFB-320 filter in `f32` (4 states, 2 inputs, 7 outputs, 11
/// parameters) as the QEMU example `fem_count` runs it.
pub type Hfb320Filter = FilterError<f32, Hfb320<f32>, 4, 2, 7, 11>;

/// [`FilterError::step`] of [`Hfb320Filter`], here for the same reason as [`process_into`]: the
/// example `fem_count` times it under QEMU and must time the opt-level 3 code.
#[inline(never)]
pub fn fem_step(
    fem: &mut Hfb320Filter,
    u: &SVector<f32, 2>,
    u_next: &SVector<f32, 2>,
    y_next: &SVector<f32, 7>,
) -> Result<FemStep<f32, 7, 11>, Error> {
    fem.step(u, u_next, y_next)
}
