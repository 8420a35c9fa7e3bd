//! The batch filter error method on a stored record: Gauss–Newton iterations, each
//! one pass of the core's filter linearised at a fixed point ([`FilterError::new_pass`]), and the
//! Cramér–Rao bound of a record from one such pass at the true parameters.
//!
//! The recursive filter of seed 001 (one pass, linearised at its running estimate) is what runs on
//! board; this is the offline counterpart the published HFB-320 values come from (Jategaonkar's
//! `ml_fem`: Gauss–Newton over the whole record) and the reference its σ is checked against.

use aerosid_core::fem::{FemSettings, FilterError, Model};
use nalgebra::{SMatrix, SVector};

/// One step of a record: `(u(t), u(t + Δt), y(t + Δt))`.
pub type Sample<const NU: usize, const NY: usize> = (SVector<f64, NU>, SVector<f64, NU>, SVector<f64, NY>);

/// What the state filter starts from: the model, its settings, `x̂₀` and `P_x0`.
#[derive(Debug, Clone, Copy)]
pub struct StateStart<M, const NX: usize, const NY: usize> {
    /// The model.
    pub model: M,
    /// The filter's settings (noise, Δt, integrator, sensitivity).
    pub settings: FemSettings<f64, NX, NY>,
    /// Initial state.
    pub x0: SVector<f64, NX>,
    /// Its covariance.
    pub p_x0: SMatrix<f64, NX, NX>,
}

/// The result of [`gauss_newton`].
#[derive(Debug, Clone)]
pub struct BatchFit<const NP: usize> {
    /// The estimate after the last iteration.
    pub p: SVector<f64, NP>,
    /// Its covariance `(P₀⁻¹ + Σ Hᵀ R_p⁻¹ H)⁻¹` at the last linearisation point.
    pub covariance: SMatrix<f64, NP, NP>,
    /// The estimate after each iteration.
    pub iterates: Vec<SVector<f64, NP>>,
    /// Whether the last step moved every parameter by less than `tolerance_sigma` of its σ.
    pub converged: bool,
}

impl<const NP: usize> BatchFit<NP> {
    /// `σ` of each parameter.
    pub fn sigma(&self) -> SVector<f64, NP> {
        self.covariance.diagonal().map(|v| v.max(0.0).sqrt())
    }
}

/// One pass of the filter over `data` linearised at `p_lin`, from the prior `(p_prior, p_p0)`:
/// the Gauss–Newton step's result and its covariance. `None` if the filter refuses a step.
pub fn pass<M, const NX: usize, const NU: usize, const NY: usize, const NP: usize>(
    start: &StateStart<M, NX, NY>,
    p_lin: &SVector<f64, NP>,
    p_prior: &SVector<f64, NP>,
    p_p0: &SMatrix<f64, NP, NP>,
    data: &[Sample<NU, NY>],
) -> Option<(SVector<f64, NP>, SMatrix<f64, NP, NP>)>
where
    M: Model<f64, NX, NU, NY, NP> + Copy,
{
    let mut fem = FilterError::new_pass(
        start.model,
        start.settings,
        start.x0,
        start.p_x0,
        *p_lin,
        *p_prior,
        *p_p0,
    )
    .ok()?;
    for (u, un, y) in data {
        fem.step(u, un, y).ok()?;
    }
    Some((*fem.parameters(), *fem.parameter_covariance()))
}

/// Gauss–Newton on the filter-error criterion with the prior `(p_prior, p_p0)`, starting the
/// linearisation at `p_start`: at most `max_iterations` passes, stopping when a step moves every
/// parameter by less than `tolerance_sigma` of its σ. `None` if a pass is refused.
#[allow(clippy::too_many_arguments)]
pub fn gauss_newton<M, const NX: usize, const NU: usize, const NY: usize, const NP: usize>(
    start: &StateStart<M, NX, NY>,
    p_start: &SVector<f64, NP>,
    p_prior: &SVector<f64, NP>,
    p_p0: &SMatrix<f64, NP, NP>,
    data: &[Sample<NU, NY>],
    max_iterations: usize,
    tolerance_sigma: f64,
) -> Option<BatchFit<NP>>
where
    M: Model<f64, NX, NU, NY, NP> + Copy,
{
    let mut p = *p_start;
    let mut fit = BatchFit {
        p,
        covariance: *p_p0,
        iterates: Vec::new(),
        converged: false,
    };
    for _ in 0..max_iterations.max(1) {
        let (next, cov) = pass(start, &p, p_prior, p_p0, data)?;
        let moved = (0..NP)
            .map(|j| (next[j] - p[j]).abs() / cov[(j, j)].max(f64::MIN_POSITIVE).sqrt())
            .fold(0.0, f64::max);
        p = next;
        fit.p = next;
        fit.covariance = cov;
        fit.iterates.push(next);
        if moved < tolerance_sigma {
            fit.converged = true;
            break;
        }
    }
    Some(fit)
}

/// The Cramér–Rao bound of the record: the covariance after one pass linearised at `p_true` with
/// a prior `10⁶` times broader in variance than `p_p0` (1000× in σ: its information is a fraction
/// `(σ_CRB/(1000 σ₀))²` of the data's, below 10⁻³ even for a parameter whose bound is as large as
/// its prior σ₀), i.e. `(Σ Hᵀ R_p⁻¹ H)⁻¹`, the inverse Fisher information of the parameters for
/// this input, these noise levels and this filter model. (Broader priors cost accuracy: the
/// Joseph update's rounding grows with the prior.)
pub fn cramer_rao<M, const NX: usize, const NU: usize, const NY: usize, const NP: usize>(
    start: &StateStart<M, NX, NY>,
    p_true: &SVector<f64, NP>,
    p_p0: &SMatrix<f64, NP, NP>,
    data: &[Sample<NU, NY>],
) -> Option<SMatrix<f64, NP, NP>>
where
    M: Model<f64, NX, NU, NY, NP> + Copy,
{
    pass(start, p_true, p_true, &(p_p0 * 1e6), data).map(|(_, c)| c)
}
