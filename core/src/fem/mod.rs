//! The filter error method of seed 001 (Curvo & Rios Neto): a **state filter** and a **parameter
//! filter**, kept separate and small, for models with process noise (turbulence).
//!
//! The model (eq. 1–2) is `ẋ = f(x, u, p) + ω`, `y = h(x, u, p) + v_x`, with `ω ~ N(0, Q_x)`
//! (spectral density) and `v_x ~ N(0, R_x)`; the user implements [`Model`] for their aircraft
//! ([`models`] has the paper's longitudinal model and the HFB-320 model of the flight-data README).
//! One [`FilterError::step`] takes the input `u(t)` held over the step, the input `u(t+Δt)` and the
//! measurement `y(t+Δt)`, and does:
//!
//! 1. **Prediction** (eq. 3): `x̂⁻ = x̂ + f(x̂, u, p̄)Δt` (Euler, as the paper; [`Integrator::Rk2`] and
//!    [`Integrator::Rk4`] are offered, with the input held or interpolated between the samples,
//!    [`InputHold`]), its transition `Φ = ∂x̂⁻/∂x̂` and sensitivity `S = ∂x̂⁻/∂p` (Euler:
//!    `Φ = I + AΔt`, `S = Δt ∂f/∂p`; RK: central differences of the step), and the state covariance
//!    `P⁻ = Φ P Φᵀ + Q_x Δt`.
//! 2. **Parameter filter** (eq. 6–12): the predicted-output error `Δz = y − h(x̂⁻, u(t+Δt), p̄)`, its
//!    sensitivity `H = C S + D` (eq. 7, with `C = ∂h/∂x` and `D = ∂h/∂p`; the paper's `h` has no
//!    direct `p` dependence, but outputs such as `q̇`, `a_x`, `a_z` do, so `D` is kept), its noise
//!    `R_p = C P⁻ Cᵀ + R_x` (eq. 9, with the transposes on the side that makes it `NY × NY` — the
//!    seeds README notes the misprint), and the sequential Bayesian update with the a priori
//!    covariance `P̄_p` (eq. 10–12). We evaluate eq. 11–12 in the equivalent gain form
//!    (matrix inversion lemma): `K = P̄_p Hᵀ (H P̄_p Hᵀ + R_p)⁻¹`, `Δp̂ = K Δz`,
//!    `P_p = (I − KH) P̄_p (I − KH)ᵀ + K R_p Kᵀ` (Joseph form: symmetric and positive definite in
//!    floating point), which inverts an `NY × NY` matrix instead of two `NP × NP` ones. Then
//!    `p̄ ← p̂ = p̄ + Δp̂`, `P̄_p ← P_p` (end of Section 3).
//! 3. **State filter**: an extended Kalman update of the prediction made with the *updated* `p̂`
//!    (our reading: the scheme of Fig. 1 filters the states with the current parameters) with the
//!    same `y(t+Δt)`: `K_x = P⁻Cᵀ(CP⁻Cᵀ + R_x)⁻¹`, `x̂ = x̂⁻ + K_x(y − h)`, Joseph form for `P`.
//!
//! A step whose inputs are not finite, or whose update is not finite or loses definiteness, is
//! refused: the filter's state is left exactly as it was and [`FemHealth`] counts it.
//!
//! **Gauss–Newton passes** ([`FilterError::new_pass`]): the same two filters with the model held at
//! a fixed `p_lin` for a whole pass over a stored record, so that the parameter filter is a linear
//! Kalman filter and the pass is one Gauss–Newton step of the batch filter error method (host-side;
//! `aerosid::fem_batch` iterates it).
//!
//! *Math note*: eq. 6 linearises the prediction in `p` about `p̄` and neglects the correlation
//! between the state error and `Δp` (the paper's `E{ê_x v_xᵀ} = 0`); the parameter covariance is
//! therefore that of a one-step-ahead prediction-error estimator, `(P₀⁻¹ + Σ Hᵀ R_p⁻¹ H)⁻¹`, with
//! each term evaluated at the running estimate. Checked against the spread over Monte Carlo runs in
//! `host-tests/tests/table1.rs`: where a direction of `p` is weakly determined and its
//! sensitivity depends on the other parameters (Table 1's `CL0`, `Cm0`, confounded with the
//! record's mean vertical gust), the sum over the path overstates the information (σ 2.4× too
//! small); a pass at one point does not ([`FilterError::new_pass`]). The gain `K_x` is held fixed
//! in the propagated sensitivity (`∂K_x/∂p` neglected).

pub mod models;

use crate::linalg::{cholesky_upper, solve_upper_t_upper};
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// The aircraft model of eq. 1–2: state equation `f`, output equation `h` and their Jacobians.
///
/// `NX` states, `NU` inputs, `NY` outputs, `NP` parameters. The Jacobians default to central
/// differences ([`central_difference`]); override them where the model gives them analytically.
pub trait Model<T: Real, const NX: usize, const NU: usize, const NY: usize, const NP: usize> {
    /// `ẋ = f(x, u, p)` (eq. 1 without the noise).
    fn f(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SVector<T, NX>;

    /// `y = h(x, u, p)` (eq. 2 without the noise).
    fn h(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SVector<T, NY>;

    /// `∂f/∂x`.
    fn df_dx(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SMatrix<T, NX, NX> {
        central_difference(x, |xx| self.f(xx, u, p))
    }

    /// `∂f/∂p`.
    fn df_dp(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SMatrix<T, NX, NP> {
        central_difference(p, |pp| self.f(x, u, pp))
    }

    /// `∂h/∂x`.
    fn dh_dx(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SMatrix<T, NY, NX> {
        central_difference(x, |xx| self.h(xx, u, p))
    }

    /// `∂h/∂p`.
    fn dh_dp(&self, x: &SVector<T, NX>, u: &SVector<T, NU>, p: &SVector<T, NP>) -> SMatrix<T, NY, NP> {
        central_difference(p, |pp| self.h(x, u, pp))
    }
}

/// `∂g/∂v` by central differences with the step `ε^{1/3}·max(|v_j|, 1)` per column (the step that
/// balances truncation and rounding error for a smooth `g`).
pub fn central_difference<T: Real, const N: usize, const M: usize>(
    v: &SVector<T, N>,
    mut g: impl FnMut(&SVector<T, N>) -> SVector<T, M>,
) -> SMatrix<T, M, N> {
    let base = libm::cbrt(T::EPS.to_f64());
    let mut jac = SMatrix::<T, M, N>::zeros();
    for j in 0..N {
        let h = T::lit(base) * v[j].abs().maxr(T::one());
        let (mut vp, mut vm) = (*v, *v);
        vp[j] += h;
        vm[j] -= h;
        // The step actually taken (vp − vm is exact for the rounded points).
        let d = vp[j] - vm[j];
        let col = (g(&vp) - g(&vm)) / d;
        jac.set_column(j, &col);
    }
    jac
}

/// The numerical integrator of the prediction step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Integrator {
    /// First-order Euler, eq. 3 of the paper.
    #[default]
    Euler,
    /// Heun's second-order Runge–Kutta.
    Rk2,
    /// Classical fourth-order Runge–Kutta.
    Rk4,
}

/// How the input is taken between two samples by the prediction's integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InputHold {
    /// `u(t)` held over `[t, t + Δt)` (zero-order hold; eq. 3 evaluates `f` at `u(t)`).
    #[default]
    Zero,
    /// Linear between `u(t)` and `u(t + Δt)` (first-order hold): the RK stages at `t + Δt/2` take
    /// the mean of the two and those at `t + Δt` take `u(t + Δt)`, as in Jategaonkar's `ruku4`;
    /// Euler's single stage at `t` is unchanged. At a 10 Hz sample rate the zero-order hold is a
    /// half-sample (50 ms) lag of the elevator, which the estimator turns into damping.
    Linear,
}

/// How the predicted state's sensitivity to the parameters, `∂x̂⁻/∂p`, is formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Sensitivity {
    /// The paper (eq. 6): through the one prediction step only, the filtered `x̂(t)` taken as
    /// independent of `p` — `S = ∂x̂⁻/∂p|_{x̂(t)}`. With a tight state filter this behaves like an
    /// equation-error regression on the filtered states.
    #[default]
    OneStep,
    /// Also through the state filter's history, as in Jategaonkar's filter error method:
    /// `S⁻(t+Δt) = Φ S(t) + ∂x̂⁻/∂p|_{x̂(t)}` and, after the state update with gain `K_x`,
    /// `S(t+Δt) = (I − K_x C) S⁻ − K_x D` (the gain held fixed). One `NX × NP` matrix of state.
    Propagated,
}

/// Settings of the filter error method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FemSettings<T: Real, const NX: usize, const NY: usize> {
    /// Process-noise spectral density `Q_x` (eq. 1), per second; the step adds `Q_x Δt`.
    pub q_x: SMatrix<T, NX, NX>,
    /// Measurement-noise covariance `R_x` (eq. 2).
    pub r_x: SMatrix<T, NY, NY>,
    /// The sample period `Δt`, s.
    pub dt_s: T,
    /// The prediction's integrator. Default Euler (eq. 3).
    pub integrator: Integrator,
    /// How the integrator takes the input between samples. Default [`InputHold::Zero`].
    pub input_hold: InputHold,
    /// How `∂x̂⁻/∂p` is formed. Default [`Sensitivity::OneStep`] (the paper).
    pub sensitivity: Sensitivity,
}

/// Counters of the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FemHealth {
    /// Accepted steps.
    pub steps: u32,
    /// Steps refused for non-finite inputs or measurements.
    pub refused_input: u32,
    /// Steps refused because the update was not finite or a covariance lost definiteness.
    pub refused_numerical: u32,
}

/// What one accepted step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FemStep<T: Real, const NY: usize, const NP: usize> {
    /// The predicted-output error `Δz` of eq. 7 (with `p̄`, before the update; in a Gauss–Newton
    /// pass, with the pass's `p_lin`).
    pub prediction_error: SVector<T, NY>,
    /// The parameter correction `Δp̂` of eq. 11.
    pub delta_p: SVector<T, NP>,
    /// The state filter's innovation `y − h(x̂⁻, p̂)` (in a pass, at `p_lin`: equal to
    /// `prediction_error`).
    pub innovation: SVector<T, NY>,
}

/// The filter error method: state filter and parameter filter (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterError<T: Real, M, const NX: usize, const NU: usize, const NY: usize, const NP: usize> {
    model: M,
    settings: FemSettings<T, NX, NY>,
    x: SVector<T, NX>,
    p_x: SMatrix<T, NX, NX>,
    p: SVector<T, NP>,
    p_p: SMatrix<T, NP, NP>,
    /// `∂x̂/∂p` of the filtered state ([`Sensitivity::Propagated`]; zero otherwise).
    s_x: SMatrix<T, NX, NP>,
    /// The fixed linearisation point of a Gauss–Newton pass ([`FilterError::new_pass`]); `None`:
    /// the recursive method, linearised at the running estimate.
    p_lin: Option<SVector<T, NP>>,
    health: FemHealth,
}

impl<T, M, const NX: usize, const NU: usize, const NY: usize, const NP: usize> FilterError<T, M, NX, NU, NY, NP>
where
    T: Real,
    M: Model<T, NX, NU, NY, NP>,
{
    /// A filter starting from the state `x0` with covariance `p_x0`, the parameters `p0` with the a
    /// priori covariance `p_p0` (e.g. Bauer & Andrisani's `diag((0.25 p̄_j)²)`, [`bauer_andrisani`]).
    ///
    /// Refuses (`InvalidSetting`) a non-positive or non-finite `Δt`, non-finite starting values, and
    /// covariances (`P_x0`, `P_p0`, `R_x`) that are not symmetric positive definite or a `Q_x` that
    /// is not finite.
    pub fn new(
        model: M,
        settings: FemSettings<T, NX, NY>,
        x0: SVector<T, NX>,
        p_x0: SMatrix<T, NX, NX>,
        p0: SVector<T, NP>,
        p_p0: SMatrix<T, NP, NP>,
    ) -> Result<Self, Error> {
        Self::build(model, settings, x0, p_x0, p0, p_p0, None)
    }

    /// One **Gauss–Newton pass** of the batch filter error method over a record (Jategaonkar's
    /// formulation; the host or a stored record — not the on-line method of the paper). For the
    /// whole pass the model, the state filter and the sensitivities stay at the fixed `p_lin`, so
    /// `Δz(p) ≈ Δz(p_lin) − H (p − p_lin)` (eq. 7 linearised once, not at every step) and the
    /// parameter filter (eq. 10–12) is a linear Kalman filter for `p`, started from the prior mean
    /// `p_prior` with covariance `p_p0`: its measurement is `Δz − H(p̄ − p_lin)`. After the pass,
    /// [`FilterError::parameters`] is the Gauss–Newton step from `p_lin` on the criterion
    /// `(p − p_prior)ᵀP_p0⁻¹(p − p_prior) + Σ Δzᵀ R_p⁻¹ Δz` and [`FilterError::parameter_covariance`]
    /// is `(P_p0⁻¹ + Σ Hᵀ R_p⁻¹ H)⁻¹` at `p_lin` — the information of the whole record evaluated at
    /// one point. Passes repeated with `p_lin` set to the last result converge to the batch
    /// estimate. With a very broad `p_p0`, the covariance after a pass at the true parameters is the
    /// Cramér–Rao bound of the record.
    ///
    /// *Why it exists*: the recursive filter sums `Hᵀ R_p⁻¹ H` along the path of its running
    /// estimate; where a direction of the parameters is weakly determined and its sensitivity
    /// depends on the other parameters, the sum over different linearisation points overstates the
    /// information (measured in `host-tests/tests/table1.rs`).
    ///
    /// Refuses what [`FilterError::new`] refuses, and a non-finite `p_lin`.
    #[allow(clippy::too_many_arguments)]
    pub fn new_pass(
        model: M,
        settings: FemSettings<T, NX, NY>,
        x0: SVector<T, NX>,
        p_x0: SMatrix<T, NX, NX>,
        p_lin: SVector<T, NP>,
        p_prior: SVector<T, NP>,
        p_p0: SMatrix<T, NP, NP>,
    ) -> Result<Self, Error> {
        if !p_lin.iter().all(|v| v.finite()) {
            return Err(Error::InvalidSetting);
        }
        Self::build(model, settings, x0, p_x0, p_prior, p_p0, Some(p_lin))
    }

    fn build(
        model: M,
        settings: FemSettings<T, NX, NY>,
        x0: SVector<T, NX>,
        p_x0: SMatrix<T, NX, NX>,
        p0: SVector<T, NP>,
        p_p0: SMatrix<T, NP, NP>,
        p_lin: Option<SVector<T, NP>>,
    ) -> Result<Self, Error> {
        let finite = x0
            .iter()
            .chain(p0.iter())
            .chain(settings.q_x.iter())
            .all(|v| v.finite());
        if !(settings.dt_s > T::zero() && settings.dt_s.finite() && finite) {
            return Err(Error::InvalidSetting);
        }
        if cholesky_upper(&p_x0).is_none() || cholesky_upper(&p_p0).is_none() || cholesky_upper(&settings.r_x).is_none()
        {
            return Err(Error::NotPositiveDefinite);
        }
        Ok(Self {
            model,
            settings,
            x: x0,
            p_x: p_x0,
            p: p0,
            p_p: p_p0,
            s_x: SMatrix::zeros(),
            p_lin,
            health: FemHealth::default(),
        })
    }

    /// The filtered state `x̂`.
    pub fn state(&self) -> &SVector<T, NX> {
        &self.x
    }
    /// The state covariance `P_x`.
    pub fn state_covariance(&self) -> &SMatrix<T, NX, NX> {
        &self.p_x
    }
    /// The parameter estimate `p̂`.
    pub fn parameters(&self) -> &SVector<T, NP> {
        &self.p
    }
    /// The parameter covariance `P_p` (eq. 12).
    pub fn parameter_covariance(&self) -> &SMatrix<T, NP, NP> {
        &self.p_p
    }
    /// `σ` of each parameter (square roots of the diagonal of `P_p`).
    pub fn parameter_sigma(&self) -> SVector<T, NP> {
        SVector::<T, NP>::from_fn(|i, _| self.p_p[(i, i)].maxr(T::zero()).root())
    }
    /// The counters.
    pub fn health(&self) -> &FemHealth {
        &self.health
    }
    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }
    /// The settings.
    pub fn settings(&self) -> &FemSettings<T, NX, NY> {
        &self.settings
    }
    /// The fixed linearisation point of a Gauss–Newton pass ([`FilterError::new_pass`]), `None`
    /// for the recursive method.
    pub fn linearisation_point(&self) -> Option<&SVector<T, NP>> {
        self.p_lin.as_ref()
    }

    /// One step of the integrator from `x` with the input from `u` to `u_next` and parameters `p`.
    fn integrate(
        &self,
        x: &SVector<T, NX>,
        u: &SVector<T, NU>,
        u_next: &SVector<T, NU>,
        p: &SVector<T, NP>,
    ) -> SVector<T, NX> {
        let s = &self.settings;
        integrate(&self.model, s.integrator, s.input_hold, s.dt_s, x, u, u_next, p)
    }

    /// `(Φ, S)`: the prediction's transition and parameter sensitivity (module doc, step 1).
    fn prediction_jacobians(
        &self,
        u: &SVector<T, NU>,
        u_next: &SVector<T, NU>,
        p: &SVector<T, NP>,
    ) -> (SMatrix<T, NX, NX>, SMatrix<T, NX, NP>) {
        let dt = self.settings.dt_s;
        match self.settings.integrator {
            Integrator::Euler => {
                let phi = SMatrix::<T, NX, NX>::identity() + self.model.df_dx(&self.x, u, p) * dt;
                (phi, self.model.df_dp(&self.x, u, p) * dt)
            }
            _ => (
                central_difference(&self.x, |xx| self.integrate(xx, u, u_next, p)),
                central_difference(p, |pp| self.integrate(&self.x, u, u_next, pp)),
            ),
        }
    }

    /// One step (module doc): `u` held over `[t, t + Δt)`, `u_next` and the measurement `y_next` at
    /// `t + Δt`. A refused step leaves the filter exactly as it was.
    pub fn step(
        &mut self,
        u: &SVector<T, NU>,
        u_next: &SVector<T, NU>,
        y_next: &SVector<T, NY>,
    ) -> Result<FemStep<T, NY, NP>, Error> {
        let inputs_finite = u.iter().chain(u_next.iter()).chain(y_next.iter()).all(|v| v.finite());
        if !inputs_finite {
            self.health.refused_input = self.health.refused_input.saturating_add(1);
            return Err(Error::NonFinite { index: 0 });
        }
        match self.propose(u, u_next, y_next) {
            Some((x, p_x, p, p_p, s_x, step)) => {
                self.x = x;
                self.p_x = p_x;
                self.p = p;
                self.p_p = p_p;
                self.s_x = s_x;
                self.health.steps = self.health.steps.saturating_add(1);
                Ok(step)
            }
            None => {
                self.health.refused_numerical = self.health.refused_numerical.saturating_add(1);
                Err(Error::NumericalFault)
            }
        }
    }

    /// The new state, covariances and step report, or `None` if anything is not finite or a
    /// covariance to be inverted is not positive definite.
    #[allow(non_snake_case, clippy::type_complexity)]
    fn propose(
        &self,
        u: &SVector<T, NU>,
        u_next: &SVector<T, NU>,
        y_next: &SVector<T, NY>,
    ) -> Option<(
        SVector<T, NX>,
        SMatrix<T, NX, NX>,
        SVector<T, NP>,
        SMatrix<T, NP, NP>,
        SMatrix<T, NX, NP>,
        FemStep<T, NY, NP>,
    )> {
        let dt = self.settings.dt_s;
        let p_bar = self.p;
        // The model's parameters: the running estimate (recursive) or the pass's fixed point.
        let p_model = self.p_lin.unwrap_or(p_bar);
        // 1. Prediction (eq. 3), its Jacobians and the state covariance.
        let x_pred = self.integrate(&self.x, u, u_next, &p_model);
        let (phi, S_step) = self.prediction_jacobians(u, u_next, &p_model);
        let S = match self.settings.sensitivity {
            Sensitivity::OneStep => S_step,
            Sensitivity::Propagated => phi * self.s_x + S_step,
        };
        let P_pred = symmetric(&(phi * self.p_x * phi.transpose() + self.settings.q_x * dt));
        // 2. Parameter filter (eq. 6–12).
        let C = self.model.dh_dx(&x_pred, u_next, &p_model);
        let D = self.model.dh_dp(&x_pred, u_next, &p_model);
        let H = C * S + D;
        let dz = y_next - self.model.h(&x_pred, u_next, &p_model);
        // A pass linearised at p_lin: Δz(p̄) ≈ Δz(p_lin) − H (p̄ − p_lin).
        let dz_p = match self.p_lin {
            None => dz,
            Some(p_lin) => dz - H * (p_bar - p_lin),
        };
        let R_p = symmetric(&(C * P_pred * C.transpose() + self.settings.r_x)); // eq. 9
        let P_bar = self.p_p;
        let S_p = symmetric(&(H * P_bar * H.transpose() + R_p));
        let K = gain(&S_p, &(P_bar * H.transpose()))?; // NP × NY
        let delta_p = K * dz_p; // eq. 11
        let I_KH = SMatrix::<T, NP, NP>::identity() - K * H;
        let P_p = symmetric(&(I_KH * P_bar * I_KH.transpose() + K * R_p * K.transpose())); // eq. 12
        let p_hat = p_bar + delta_p;
        // 3. State filter: with the updated parameters (recursive), or at p_lin (a pass).
        let (x_pred2, C2, D2, innovation) = match self.p_lin {
            None => {
                let x_pred2 = self.integrate(&self.x, u, u_next, &p_hat);
                let C2 = self.model.dh_dx(&x_pred2, u_next, &p_hat);
                let D2 = match self.settings.sensitivity {
                    Sensitivity::OneStep => D,
                    Sensitivity::Propagated => self.model.dh_dp(&x_pred2, u_next, &p_hat),
                };
                (x_pred2, C2, D2, y_next - self.model.h(&x_pred2, u_next, &p_hat))
            }
            Some(_) => (x_pred, C, D, dz),
        };
        let S_x = symmetric(&(C2 * P_pred * C2.transpose() + self.settings.r_x));
        let K_x = gain(&S_x, &(P_pred * C2.transpose()))?; // NX × NY
        let x_new = x_pred2 + K_x * innovation;
        let I_KC = SMatrix::<T, NX, NX>::identity() - K_x * C2;
        let P_x = symmetric(&(I_KC * P_pred * I_KC.transpose() + K_x * self.settings.r_x * K_x.transpose()));
        let s_new = match self.settings.sensitivity {
            Sensitivity::OneStep => self.s_x,
            Sensitivity::Propagated => I_KC * S - K_x * D2,
        };

        let finite = x_new.iter().chain(p_hat.iter()).all(|v| v.finite())
            && (P_x.sum() + P_p.sum() + s_new.sum()).finite()
            && (0..NX).all(|i| P_x[(i, i)] > T::zero())
            && (0..NP).all(|i| P_p[(i, i)] > T::zero());
        if !finite {
            return None;
        }
        Some((
            x_new,
            P_x,
            p_hat,
            P_p,
            s_new,
            FemStep {
                prediction_error: dz,
                delta_p,
                innovation,
            },
        ))
    }
}

/// `x(t + Δt)` by `integrator` from `x` with parameters `p` and the input `u(t)` → `u_next`
/// (`u(t + Δt)`) taken as `hold` says.
#[allow(clippy::too_many_arguments)]
pub fn integrate<T, M, const NX: usize, const NU: usize, const NY: usize, const NP: usize>(
    model: &M,
    integrator: Integrator,
    hold: InputHold,
    dt: T,
    x: &SVector<T, NX>,
    u: &SVector<T, NU>,
    u_next: &SVector<T, NU>,
    p: &SVector<T, NP>,
) -> SVector<T, NX>
where
    T: Real,
    M: Model<T, NX, NU, NY, NP> + ?Sized,
{
    let half = T::lit(0.5);
    let (u_mid, u_end) = match hold {
        InputHold::Zero => (*u, *u),
        InputHold::Linear => ((u + u_next) * half, *u_next),
    };
    match integrator {
        Integrator::Euler => x + model.f(x, u, p) * dt,
        Integrator::Rk2 => {
            let k1 = model.f(x, u, p);
            let k2 = model.f(&(x + k1 * dt), &u_end, p);
            x + (k1 + k2) * (dt * half)
        }
        Integrator::Rk4 => {
            let k1 = model.f(x, u, p);
            let k2 = model.f(&(x + k1 * (dt * half)), &u_mid, p);
            let k3 = model.f(&(x + k2 * (dt * half)), &u_mid, p);
            let k4 = model.f(&(x + k3 * dt), &u_end, p);
            x + (k1 + (k2 + k3) * T::lit(2.0) + k4) * (dt / T::lit(6.0))
        }
    }
}

/// `(A + Aᵀ)/2`.
fn symmetric<T: Real, const N: usize>(a: &SMatrix<T, N, N>) -> SMatrix<T, N, N> {
    (a + a.transpose()) * T::lit(0.5)
}

/// `B S⁻¹` for symmetric positive definite `S` (`NY × NY`), by Cholesky: each row `r` of the result
/// solves `S rᵀ = bᵀ` (`S` symmetric). `None` if `S` is not positive definite.
fn gain<T: Real, const R: usize, const NY: usize>(
    s: &SMatrix<T, NY, NY>,
    b: &SMatrix<T, R, NY>,
) -> Option<SMatrix<T, R, NY>> {
    let c = cholesky_upper(s)?;
    let mut out = SMatrix::<T, R, NY>::zeros();
    for r in 0..R {
        let row: SVector<T, NY> = b.row(r).transpose();
        out.set_row(r, &solve_upper_t_upper(&c, &row).transpose());
    }
    Some(out)
}

/// Bauer & Andrisani's a priori parameter covariance `diag((0.25 p̄_j)²)`, with `floor` as the
/// standard deviation of parameters whose `0.25|p̄_j|` is below it (the paper: "for parameter values
/// equal to or close to zero, the initial variance is established based on engineering judgment").
pub fn bauer_andrisani<T: Real, const NP: usize>(p0: &SVector<T, NP>, floor: T) -> SMatrix<T, NP, NP> {
    SMatrix::<T, NP, NP>::from_fn(|i, j| {
        if i == j {
            let s = (T::lit(0.25) * p0[i].abs()).maxr(floor);
            s * s
        } else {
            T::zero()
        }
    })
}
