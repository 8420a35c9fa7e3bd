//! Recursive least squares with exponential forgetting — the baseline the seed compares PCA-GTLS
//! against (Section VI-A, "sequential OLS"), with the same [`Estimator`] interface.
//!
//! Standard exponentially weighted RLS (e.g. Klein & Morelli 2006, §9.2): with `P = (Σ λ x xᵀ)⁻¹`,
//! `K = P x/(λ + xᵀPx)`, `θ ← θ + K (z − xᵀθ)`, `P ← (P − K xᵀP)/λ`. It assumes exact regressors and
//! is therefore biased when they are noisy (the errors-in-variables attenuation the seed's eq. 5
//! warns about).
//!
//! `P` is kept as a square root `P = S Sᵀ` updated by Potter's algorithm (`φ = Sᵀx`,
//! `α = λ + φᵀφ`, `S ← (S − γ Sφφᵀ)/√λ` with `γ = 1/(α + √(λα))`), so it stays symmetric positive
//! semi-definite in `f32` even with a weak prior, where the plain update cancels catastrophically
//! (a negative variance after five samples was found by the property tests). `λ` may be constant or the variable forgetting factor of eq. 27–33 driven by the
//! a priori residual and the *measured* regressor (no TLS correction).
//!
//! Guards: `P` starts at `I/π₀`; while the regressors are unexcited and `λ < 1`, forgetting is not
//! applied to `P` once its trace would exceed the initial trace (anti-wind-up), so `P` stays bounded.
//! Covariance: `σ̂²·P·N₂/N_eff` with `σ̂²` the exponentially weighted a posteriori residual power
//! divided by `(N_eff − n_θ)`.

use crate::estimator::{check_sample, Estimator, Solution, Step};
use crate::gtls::Forgetting;
use crate::vff::Vff;
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// Settings of the RLS baseline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsSettings<T> {
    /// `P(0) = I/π₀`, in squared regressor units. Default 1e-6 (a weak prior).
    pub pi0: T,
    /// Largest accepted magnitude of any input element. Default 1e6.
    pub max_abs_input: T,
    /// Forgetting scheme.
    pub forgetting: Forgetting<T>,
}

impl<T: Real> Default for RlsSettings<T> {
    fn default() -> Self {
        Self {
            pi0: T::lit(1e-6),
            max_abs_input: T::lit(1e6),
            forgetting: Forgetting::Constant(T::one()),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Lam<T: Real, const NT: usize> {
    Constant(T),
    Variable(Vff<T, NT>),
}

/// Exponentially weighted recursive least squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rls<T: Real, const NT: usize> {
    settings: RlsSettings<T>,
    /// `S` with `P = S Sᵀ`.
    sqrt_p: SMatrix<T, NT, NT>,
    p_trace_max: T,
    theta: SVector<T, NT>,
    lambda: T,
    forgetting: Lam<T, NT>,
    n_eff: T,
    n_eff2: T,
    /// Σ weighted a posteriori residual².
    sse: T,
}

impl<T: Real, const NT: usize> Rls<T, NT> {
    /// A new RLS estimator with `θ(0) = 0`.
    pub fn new(settings: RlsSettings<T>) -> Result<Self, Error> {
        if !(settings.pi0 > T::zero() && settings.pi0.finite() && settings.max_abs_input > T::zero()) {
            return Err(Error::InvalidSetting);
        }
        let (forgetting, lambda) = match settings.forgetting {
            Forgetting::Constant(l) => {
                if !(l > T::zero() && l <= T::one()) {
                    return Err(Error::InvalidSetting);
                }
                (Lam::Constant(l), l)
            }
            Forgetting::Variable(vs) => {
                let v = Vff::new(vs)?;
                let l = v.lambda();
                (Lam::Variable(v), l)
            }
        };
        let sqrt_p = SMatrix::<T, NT, NT>::identity() / settings.pi0.root();
        Ok(Self {
            settings,
            sqrt_p,
            p_trace_max: sqrt_p.norm_squared(),
            theta: SVector::zeros(),
            lambda,
            forgetting,
            n_eff: T::zero(),
            n_eff2: T::zero(),
            sse: T::zero(),
        })
    }

    /// `P = S Sᵀ`, the (un-scaled) inverse information matrix.
    pub fn p(&self) -> SMatrix<T, NT, NT> {
        self.sqrt_p * self.sqrt_p.transpose()
    }

    fn apply(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        let lambda = self.lambda;
        let phi = self.sqrt_p.transpose() * x;
        let alpha = lambda + phi.dot(&phi);
        if !(alpha > T::zero()) {
            return Err(Error::NumericalFault);
        }
        let s_phi = self.sqrt_p * phi; // = P x
        let gain = s_phi / alpha;
        let nu = z - x.dot(&self.theta);
        self.theta += gain * nu;
        let gamma = T::one() / (alpha + (lambda * alpha).root());
        let shrunk = self.sqrt_p - s_phi * phi.transpose() * gamma; // P − PxxᵀP/α
        let grown = shrunk / lambda.root();
        self.sqrt_p = if grown.norm_squared() <= self.p_trace_max {
            grown
        } else {
            shrunk
        };
        let r = z - x.dot(&self.theta);
        // θ(t−1) is a least-squares solution once more than NT samples of information made it
        // (the VFF's statistics start there; `vff` module doc).
        let solved = self.n_eff > T::lit(NT as f64);
        self.n_eff = lambda * self.n_eff + T::one();
        self.n_eff2 = lambda * lambda * self.n_eff2 + T::one();
        self.sse = lambda * self.sse + r * r;
        let lambda_next = match &mut self.forgetting {
            Lam::Constant(l) => *l,
            Lam::Variable(v) => v.update(x, nu, solved).ok_or(Error::NumericalFault)?.lambda,
        };
        self.lambda = lambda_next;
        Ok(Step {
            k: NT.min(u8::MAX as usize) as u8,
            lambda,
            lambda_next,
            prior_residual: nu,
            posterior_residual: r,
            solution: Solution::LeastSquares,
            ..Step::default()
        })
    }
}

impl<T: Real, const NT: usize> Estimator<T, NT> for Rls<T, NT> {
    fn update(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        check_sample(x, z, self.settings.max_abs_input)?;
        let mut next = *self;
        let step = next.apply(x, z)?;
        let finite = next.sqrt_p.iter().all(|v| v.finite())
            && next.theta.iter().all(|v| v.finite())
            && next.sse.finite()
            && next.lambda.finite();
        if !finite {
            return Err(Error::NumericalFault);
        }
        *self = next;
        Ok(step)
    }

    fn theta(&self) -> &SVector<T, NT> {
        &self.theta
    }

    fn covariance(&self) -> Result<SMatrix<T, NT, NT>, Error> {
        let dof = self.n_eff - T::lit(NT as f64);
        if !(dof > T::zero()) {
            return Err(Error::InsufficientExcitation);
        }
        let sigma2 = self.sse / dof;
        let f = self.sqrt_p * (sigma2 * self.n_eff2 / self.n_eff).root();
        Ok(f * f.transpose())
    }

    fn lambda(&self) -> T {
        self.lambda
    }

    fn excited(&self) -> usize {
        NT
    }

    fn effective_samples(&self) -> T {
        self.n_eff
    }
}
