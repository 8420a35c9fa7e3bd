//! The on-board configuration the firmware flies with, in one place so that the host can build the
//! very same pipeline (the QEMU replay test compares the firmware's estimates with a host `f32` run
//! of the same log, bit for bit).
//!
//! Airframe: `skywalker_2013_mod` ([`Airframe::skywalker_2013_mod`]); models: the default regressor
//! sets of eq. 3 with the typical-magnitude weights of eq. 23; `σ_ε`: [`SIGMA_EPS`]; settings:
//! the defaults with the variable forgetting factor for aerodynamic coefficients at
//! [`SAMPLE_RATE_HZ`] ([`VffSettings::for_aero_coefficients`]). Another airframe means another
//! `Airframe`, `σ_ε` and (from the host Monte Carlo) this module's constants.

use super::{AeroModels, Airframe, Pipeline, PipelineSettings};
use crate::{Error, Forgetting, Real, VffSettings};

/// Sampling rate of the flight computer, Hz.
pub const SAMPLE_RATE_HZ: f64 = 100.0;

/// `σ_ε` of the six synthetic coefficients (eq. 41), indexed by [`super::model::idx`]: the host
/// Monte Carlo of Section V (eq. 34–41) for the default sensors on `skywalker_2013_mod`, 2¹⁸ draws,
/// seed 1 (`aerosid run` prints it), rounded to 3 significant digits.
pub const SIGMA_EPS: [f64; 6] = [0.0149, 0.0107, 0.00226, 0.00126, 0.0135, 0.00247];

/// The on-board pipeline settings (module doc).
pub fn settings<T: Real>() -> PipelineSettings<T> {
    let mut s = PipelineSettings::default();
    s.gtls.forgetting = Forgetting::Variable(VffSettings::for_aero_coefficients(T::lit(SAMPLE_RATE_HZ)));
    s
}

/// The on-board pipeline (module doc).
pub fn pipeline<T: Real>() -> Result<Pipeline<T>, Error> {
    Pipeline::new(
        Airframe::skywalker_2013_mod(),
        AeroModels::with_sigma_eps(SIGMA_EPS.map(T::lit)),
        settings(),
    )
}

/// Configures `pipeline` in place as the on-board pipeline ([`Pipeline::configure`]: the
/// firmware's static, without the whole pipeline on the boot stack).
pub fn configure<T: Real>(pipeline: &mut Pipeline<T>) -> Result<(), Error> {
    pipeline.configure(
        Airframe::skywalker_2013_mod(),
        AeroModels::with_sigma_eps(SIGMA_EPS.map(T::lit)),
        settings(),
    )
}
