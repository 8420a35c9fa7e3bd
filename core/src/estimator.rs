//! What every recursive estimator of the crate offers, so the six-coefficient pipeline, the firmware
//! and the host tools can swap PCA-GTLS for the RLS baseline.

use crate::linalg::secular::Outcome;
use crate::vff::VffStep;
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// How the latest sample was used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Solution {
    /// Not enough (weighted) samples yet: `N_eff ≤ n_θ` (Algorithm 1, step 5); `θ` is the minimum
    /// weighted-norm solution of no constraint, i.e. the noisy-regressor parameters are 0.
    #[default]
    NotEnoughData,
    /// Every parameter excited (`k = n_θ`): the GTLS solution of eq. 16.
    Tls,
    /// Insufficient excitation (`k < n_θ`): the minimum weighted-norm solution of eq. 22–23.
    MinimumNorm,
    /// `k = n_θ`, but the last right singular vector has a (near-)zero output component (a
    /// non-generic TLS problem); the minimum-norm solution with `k = n_θ − 1` was used instead.
    Nongeneric,
    /// Recursive least squares (the baseline).
    LeastSquares,
}

/// The outcome of one accepted sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Step<T> {
    /// Number of sufficiently excited directions `k` (eq. 21).
    pub k: u8,
    /// `λ_F` applied to this sample.
    pub lambda: T,
    /// `λ_F` that will be applied to the next sample.
    pub lambda_next: T,
    /// A priori residual `ν(t)` (eq. 24, with the TLS-corrected regressor under the variable
    /// forgetting factor; the plain `z − xᵀθ(t−1)` otherwise).
    pub prior_residual: T,
    /// A posteriori residual `r(t)` (eq. 25; the plain `z − xᵀθ(t)` without the VFF).
    pub posterior_residual: T,
    /// Which solution produced `θ`.
    pub solution: Solution,
    /// What the rank-one SVD update did (zero for RLS).
    pub secular: Outcome,
    /// Whether the orthonormality guard re-orthonormalised `V` after this sample.
    pub reorthonormalised: bool,
    /// The variable forgetting factor's quantities of this sample (eq. 28–33; zero with constant
    /// forgetting and for RLS).
    pub vff: VffStep<T>,
}

/// A recursive estimator of `z ≈ xᵀθ` with `NT` parameters.
pub trait Estimator<T: Real, const NT: usize> {
    /// Processes one sample `(x, z)`. On `Err` the state is unchanged.
    fn update(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error>;
    /// The current parameter estimate `θ̂`.
    fn theta(&self) -> &SVector<T, NT>;
    /// The covariance of `θ̂` (eq. 17 for GTLS).
    fn covariance(&self) -> Result<SMatrix<T, NT, NT>, Error>;
    /// The forgetting factor that will be applied to the next sample.
    fn lambda(&self) -> T;
    /// The number of excited directions `k` (eq. 21); `NT` for RLS.
    fn excited(&self) -> usize;
    /// The effective weighted sample count `Σ Π λ` (equals the sample count for `λ = 1`).
    fn effective_samples(&self) -> T;
}

/// Refuses a sample with a non-finite or absurdly large element. `index == NT` denotes `z`.
pub fn check_sample<T: Real, const NT: usize>(x: &SVector<T, NT>, z: T, max_abs: T) -> Result<(), Error> {
    for i in 0..NT + 1 {
        let v = if i < NT { x[i] } else { z };
        let index = i.min(u8::MAX as usize) as u8;
        if !v.finite() {
            return Err(Error::NonFinite { index });
        }
        if v.abs() > max_abs {
            return Err(Error::OutOfRange { index });
        }
    }
    Ok(())
}
