//! The estimator update run by the mid-priority `estimate` task for every sample it receives.

use crate::sample::Sample;

/// Why [`step`] refused a sample. Placeholder until the core's error type takes its place.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum StepError {
    /// `dt_s` was not a positive, finite number of seconds.
    BadDt,
}

/// Runs one estimator update with `sample`.
///
/// Placeholder: for now it only gates `dt_s` and, once per second (every 100th sample), logs the
/// `aerosid_core` version. The core's author replaces this body with the real estimator update; keep
/// it one small function — one sample in, a `Result` out, no panics.
pub fn step(sample: &Sample) -> Result<(), StepError> {
    if !(sample.dt_s.is_finite() && sample.dt_s > 0.0) {
        return Err(StepError::BadDt);
    }
    if sample.seq.is_multiple_of(100) {
        defmt::info!(
            "estimate: aerosid-core {=str} (placeholder step), sample {=u32}",
            aerosid_core::VERSION,
            sample.seq
        );
    }
    Ok(())
}
