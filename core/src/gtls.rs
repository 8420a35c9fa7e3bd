//! Recursive PCA-GTLS (seed 000, Section III, Algorithm 1, eq. 8–23), with exactly known regressors
//! handled by mixed LS–TLS.
//!
//! ## Model and dimensions
//! `z ≈ xᵀθ` (eq. 4) with `NT = n_θ` parameters. The regressor vector is ordered
//! `x = [x_e, x_n]`: the first `NE` regressors are **exact** (no error: the intercept `1` of eq. 3,
//! or any regressor known without error), the remaining `NX = NT − NE` are **noisy**. The TLS block
//! is the augmented noisy row `d = [x_n, z]` of dimension `NA = NX + 1`; the const generics must
//! satisfy `NA + NE = NT + 1` and `NA ≥ 2` (checked at compile time).
//!
//! ## What is kept (all fixed-size)
//! * `C`: the upper Cholesky factor of the error covariance `W_T = CᵀC` of `d` (eq. 8–9); each row
//!   is scaled as `d* = d C⁻¹` (eq. 10) by a forward substitution with `Cᵀ` (no inverse is stored).
//! * `V`, `S`: right singular vectors and singular values of the exponentially weighted, scaled
//!   matrix `D*` (eq. 12) — after the exact columns are projected out (below). Updated per sample by
//!   [`rank_one_update`](crate::linalg::secular) (Algorithm 1, step 4).
//! * `G₁₁ = Σ w x_e x_eᵀ` and `B = G₂₁ G₁₁⁻¹` (the regression of the scaled noisy block on the exact
//!   columns) for mixed LS–TLS.
//!
//! ## Exact columns: mixed LS–TLS, recursively
//! With exact columns `W_T` of the full row is singular and eq. 10 has no `C⁻¹`. Following Golub,
//! Hoffman & Stewart (1987) and Van Huffel & Vandewalle (1991, ch. 3) the exact columns are projected
//! out and TLS runs on the projected noisy block (the Schur complement `G₂₂ − G₂₁G₁₁⁻¹G₁₂` of the
//! weighted Gram matrix). Recursively this is again a rank-one update: appending `[x_e, d*]` with
//! forgetting `λ` gives `S' = λS + w wᵀ` with the a priori innovation `e = d* − B x_e` and
//! `w = e·√(1 − x_eᵀ G₁₁'⁻¹ x_e)` (`G₁₁' = λG₁₁ + x_e x_eᵀ`; by Sherman–Morrison
//! `1 − x_eᵀG₁₁'⁻¹x_e = 1/(1 + x_eᵀ(λG₁₁)⁻¹x_e)`). For the intercept alone this is exponentially
//! weighted centring. `B` is updated as `B ← B + e kᵀ`, `k = G₁₁'⁻¹ x_e`. The exact parameters follow
//! by least squares given the TLS ones: `θ_e = −Bᵀ C a` with `a = [θ_n; −1]`.
//!
//! ## Solution (Algorithm 1, steps 5–9)
//! * Threshold (eq. 21): `k = card{σ_j > (1 + s/n)·√(N_eff − n_θ), j ≤ NX}` with the **effective
//!   weighted count** `N_eff = Σ_i Π λ` (with forgetting the plain count would make the threshold grow
//!   without bound while the information does not). Until `N_eff > n_θ`, `k = 0`.
//! * `k = NX`: eq. 16, `[θ_n; −1] = h C⁻¹ v_NA`.
//! * `k < NX`: eq. 22–23. The solution space `{[θ_n;−1] ∈ C⁻¹ span(v_{k+1..NA})}` is equivalently
//!   `V₁ᵀ C [θ_n; −1] = 0` with `V₁ = [v_1 … v_k]`, i.e. `k` linear constraints `M θ_n = b`; the
//!   minimum of `‖W θ_n‖₂` under them is `θ_n = W⁻¹ (MW⁻¹)ᵀ ((MW⁻¹)(MW⁻¹)ᵀ)⁻¹ b` (a weighted least
//!   squares, as the seed says). `W = diag(weights)`; the exact parameters then follow by LS.
//!
//! ## Covariance (eq. 17, our reading)
//! Computed in the whitened coordinates of the TLS block: with `θ*` the TLS solution of the scaled
//! problem (`a* = v_NA` normalised to `a*_NA = −1`),
//! `cov θ* ≈ σ̂² (1 + ‖θ*‖²) (G*ₓₓ − σ²_NA I)⁻¹ · N₂/N_eff`, where `G*ₓₓ` is the noisy-regressor
//! block of `V S² Vᵀ`, `σ̂² = σ²_NA/(N_eff − n_θ)` and `N₂ = Σ (Π λ)²`. The seed prints `(1 + ‖θ‖)²`;
//! the Van Huffel & Vandewalle form has `‖θ‖²` inside, which is what we use (the seeds README reports
//! it matches Monte Carlo spread within 0–6 % while the literal form overstates it by ~18 %). The
//! factor `N₂/N_eff` (`= 1/(1+λ)`·(1 − λ^{2N})/(1 − λ^N)·… → `1` for `λ = 1`) corrects the
//! over-statement of the weighted estimate's variance by about `1 + λ` under forgetting. `θ_n` is an
//! affine map of `θ*` with Jacobian `J = C_NA,NA·(C⁻¹)ₓₓ`, so `cov θ_n = J cov θ* Jᵀ`; the exact
//! parameters add the LS term: `cov θ_e = σ̂²‖Ca‖²G₁₁⁻¹·N₂/N_eff + J_e cov θ_n J_eᵀ` with
//! `J_e = −Bᵀ C[:, :NX]`.
//!
//! ## TLS-corrected regressor (eq. 24–25)
//! The ML estimate of the noise-free row given `θ` is the `W_T`-orthogonal projection of the noisy
//! block onto `{d : [x_e, d]·[θ_e; a] = 0}`: `d̂ = d − ρ·(W_T a)ᵀ/(aᵀW_T a)` with the equation residual
//! `ρ = x_eᵀθ_e + dᵀa`; `x̂₀ = [x_e, d̂[..NX]]`. For eq. 24 we correct `x(t)` with `θ(t−1)` (the estimate
//! the sample meets), and reuse that `x̂₀` in eq. 25, 29 and 30.

use crate::estimator::{check_sample, Estimator, Solution, Step};
use crate::linalg::secular::rank_one_update_into;
use crate::linalg::{
    all_finite, cholesky_regularised, cholesky_upper, const_zeros, inv_upper, orthonormality_error, reorthonormalise,
    slice_finite, solve_spd_regularised, unrolled_upto,
};
use crate::vff::{Vff, VffSettings, VffStep};
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// How `λ_F` is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Forgetting<T> {
    /// A constant `λ_F ∈ (0, 1]` (1: no forgetting).
    Constant(T),
    /// The variable forgetting factor of eq. 24–33.
    Variable(VffSettings<T>),
}

/// Settings of the recursive PCA-GTLS estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GtlsSettings<T> {
    /// `s/n` of eq. 21: the minimal signal-to-noise ratio between a singular value and the noise
    /// level `√(N_eff − n_θ)` for its direction to count as excited. Dimensionless, default 1.
    pub snr: T,
    /// Largest accepted magnitude of any input element (in the caller's units); larger ones are
    /// refused as absurd. Default 1e6.
    pub max_abs_input: T,
    /// Tolerance of the orthonormality guard on `|v_iᵀv_j − δ_ij|`; `0` selects the default
    /// `4·NA·ε`. One entry of `VᵀV` is checked per update, cycling through all of them.
    pub reorth_tol: T,
    /// Forgetting scheme.
    pub forgetting: Forgetting<T>,
}

impl<T: Real> GtlsSettings<T> {
    /// A placeholder for `const` initialisers, every number 0 (no input accepted, the variable
    /// forgetting factor with [`VffSettings::ZERO`]: not valid settings, [`Gtls::new`] refuses
    /// them). Its bytes are all zero, so that a static holding it needs no initial image in flash
    /// (see [`crate::aero::Pipeline::PLACEHOLDER`]; `Forgetting::Constant` would be stored in the
    /// niche of [`crate::vff::Eq28Reading`], as 2).
    pub const PLACEHOLDER: Self = Self {
        snr: T::ZERO,
        max_abs_input: T::ZERO,
        reorth_tol: T::ZERO,
        forgetting: Forgetting::Variable(VffSettings::ZERO),
    };
}

impl<T: Real> Default for GtlsSettings<T> {
    fn default() -> Self {
        Self {
            snr: T::one(),
            max_abs_input: T::lit(1e6),
            reorth_tol: T::zero(),
            forgetting: Forgetting::Constant(T::one()),
        }
    }
}

/// Numerical events the estimator handled (for the firmware's health report).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GtlsHealth {
    /// Accepted samples.
    pub updates: u32,
    /// Times the orthonormality guard re-orthonormalised `V`.
    pub reorthonormalisations: u32,
    /// Samples where the TLS problem was non-generic (see [`Solution::Nongeneric`]).
    pub nongeneric: u32,
    /// Secular roots that hit the iteration cap.
    pub secular_not_converged: u32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum ForgettingState<T: Real, const NT: usize> {
    Constant(T),
    Variable(Vff<T, NT>),
}

/// The recursive PCA-GTLS estimator (Algorithm 1) for `NT` parameters, `NE` of them on exact
/// regressors, with TLS block dimension `NA = NT − NE + 1`.
///
/// `V` is kept in two buffers: the update writes the new `V` into the spare one and a successful
/// sample flips them, so no `NA×NA` matrix is copied per sample. The spare buffer is scratch, not
/// state: equality (`PartialEq`) and `Debug` cover the state only (the current `V`).
#[allow(non_snake_case)]
#[derive(Clone, Copy)]
pub struct Gtls<T: Real, const NT: usize, const NE: usize, const NA: usize> {
    /// [`GtlsSettings::snr`], [`GtlsSettings::max_abs_input`], [`GtlsSettings::reorth_tol`] (the
    /// forgetting settings live in `forgetting`; [`Self::settings`] puts them together).
    snr: T,
    max_abs_input: T,
    reorth_tol: T,
    /// `C` (upper triangular, `W_T = CᵀC`, eq. 9).
    c: SMatrix<T, NA, NA>,
    /// Diagonal of `W` (eq. 23), one weight per parameter (the exact entries are unused).
    weights: SVector<T, NT>,
    /// Right singular vectors of the projected scaled data matrix, by decreasing singular value:
    /// `v[cur]`; the other buffer is scratch for the next update.
    v: [SMatrix<T, NA, NA>; 2],
    cur: u8,
    /// Squared singular values `σ_j²`, decreasing (eq. 13): the eigenvalues of `D*ᵀD*`, which is
    /// what the secular update produces (no square root per value) and what eq. 17 and eq. 21 use.
    s2: SVector<T, NA>,
    /// `G₁₁`: weighted Gram matrix of the exact regressors.
    g11: SMatrix<T, NE, NE>,
    /// `B = G₂₁G₁₁⁻¹` in scaled coordinates.
    b: SMatrix<T, NA, NE>,
    theta: SVector<T, NT>,
    /// `C·a` with `a = [θ_n; −1]` of the current `θ` (eq. 24 of the next sample needs `W_T a`).
    ca: SVector<T, NA>,
    k: u8,
    solution: Solution,
    /// `N_eff = Σ Π λ` and `N₂ = Σ (Π λ)²`.
    n_eff: T,
    n_eff2: T,
    lambda: T,
    forgetting: ForgettingState<T, NT>,
    check_cursor: u16,
    health: GtlsHealth,
}

impl<T: Real, const NT: usize, const NE: usize, const NA: usize> Gtls<T, NT, NE, NA> {
    const DIMS_OK: () = assert!(
        NA + NE == NT + 1 && NA >= 2,
        "Gtls<_, NT, NE, NA> needs NA + NE = NT + 1 and NA >= 2"
    );
    const NX: usize = NA - 1;

    /// A new estimator.
    ///
    /// * `w_t`: the error covariance `W_T` of the noisy block `[x_n, z]` (eq. 9), symmetric positive
    ///   definite, in squared units of the data.
    /// * `weights`: the diagonal of `W` in eq. 23 (positive; entries of exact regressors unused).
    pub fn new(w_t: &SMatrix<T, NA, NA>, weights: &SVector<T, NT>, settings: GtlsSettings<T>) -> Result<Self, Error> {
        #[allow(clippy::let_unit_value)]
        let () = Self::DIMS_OK;
        let c = cholesky_upper(w_t).ok_or(Error::NotPositiveDefinite)?;
        let c_inv = inv_upper(&c).ok_or(Error::NotPositiveDefinite)?;
        if !c_inv.iter().all(|x| x.finite()) {
            return Err(Error::NotPositiveDefinite);
        }
        if !weights.iter().all(|w| *w > T::zero() && w.finite()) {
            return Err(Error::InvalidSetting);
        }
        if !(settings.snr >= T::zero() && settings.snr.finite() && settings.max_abs_input > T::zero()) {
            return Err(Error::InvalidSetting);
        }
        if !(settings.reorth_tol >= T::zero() && settings.reorth_tol.finite()) {
            return Err(Error::InvalidSetting);
        }
        let (forgetting, lambda) = match settings.forgetting {
            Forgetting::Constant(l) => {
                if !(l > T::zero() && l <= T::one()) {
                    return Err(Error::InvalidSetting);
                }
                (ForgettingState::Constant(l), l)
            }
            Forgetting::Variable(vs) => {
                let vff = Vff::new(vs)?;
                let l = vff.lambda();
                (ForgettingState::Variable(vff), l)
            }
        };
        Ok(Self {
            snr: settings.snr,
            max_abs_input: settings.max_abs_input,
            reorth_tol: settings.reorth_tol,
            c,
            weights: *weights,
            v: [SMatrix::identity(); 2],
            cur: 0,
            s2: SVector::zeros(),
            g11: SMatrix::zeros(),
            b: SMatrix::zeros(),
            theta: SVector::zeros(),
            // Element by element, not `column(..).into_owned()`: a view's copy goes through
            // nalgebra's iterator constructor, whose length assertion stays in the firmware as a
            // panic path (README "Reliability").
            ca: SVector::from_fn(|i, _| -c[(i, NA - 1)]),
            k: 0,
            solution: Solution::NotEnoughData,
            n_eff: T::zero(),
            n_eff2: T::zero(),
            lambda,
            forgetting,
            check_cursor: 0,
            health: GtlsHealth::default(),
        })
    }

    /// Every number 0 (`W_T = 0`, `V = 0`, no data): not an estimator, only the storage of one, for
    /// `const` initialisers; replace it with [`Self::new`]'s result before use. It refuses every
    /// sample and stays unchanged (`max_abs_input = 0` admits only the zero row, and that is refused
    /// too: host test `reliability_numerical::placeholder_refuses_every_sample`). The unconfigured pipeline
    /// ([`crate::aero::Pipeline::PLACEHOLDER`]) holds six of these and refuses every sample before
    /// they are reached. All zero so that the firmware's pipeline static lies in `.bss` and needs
    /// no initial image in flash (≈ 5.7 KB), nor does resetting the pipeline (another ≈ 5 KB of
    /// `.rodata`).
    pub const PLACEHOLDER: Self = Self {
        snr: T::ZERO,
        max_abs_input: T::ZERO,
        reorth_tol: T::ZERO,
        c: const_zeros(),
        weights: const_zeros(),
        v: [const_zeros(); 2],
        cur: 0,
        s2: const_zeros(),
        g11: const_zeros(),
        b: const_zeros(),
        theta: const_zeros(),
        ca: const_zeros(),
        k: 0,
        solution: Solution::NotEnoughData,
        n_eff: T::ZERO,
        n_eff2: T::ZERO,
        lambda: T::ZERO,
        // `Variable` with every number 0: the variant whose bytes are all zero (`Constant` is
        // stored in the niche of `Eq28Reading`, as 2).
        forgetting: ForgettingState::Variable(Vff::ZEROED),
        check_cursor: 0,
        health: GtlsHealth {
            updates: 0,
            reorthonormalisations: 0,
            nongeneric: 0,
            secular_not_converged: 0,
        },
    };

    /// Singular values `σ_1 ≥ … ≥ σ_NA` of the (projected) scaled data matrix (eq. 13), computed
    /// from [`Self::squared_singular_values`].
    pub fn singular_values(&self) -> SVector<T, NA> {
        self.s2.map(|x| x.root())
    }

    /// `σ_1² ≥ … ≥ σ_NA²`, as kept by the recursion.
    pub fn squared_singular_values(&self) -> &SVector<T, NA> {
        &self.s2
    }

    /// Right singular vectors `V` (eq. 12), columns in the order of [`Self::singular_values`].
    pub fn right_singular_vectors(&self) -> &SMatrix<T, NA, NA> {
        &self.v[usize::from(self.cur & 1)]
    }

    /// The excitation threshold of eq. 21, `(1 + s/n)·√(N_eff − n_θ)`, or `None` while
    /// `N_eff ≤ n_θ`.
    pub fn threshold(&self) -> Option<T> {
        Self::threshold_for(self.n_eff, self.snr)
    }

    /// Which solution produced the current `θ`.
    pub fn solution(&self) -> Solution {
        self.solution
    }

    /// Numerical events so far.
    pub fn health(&self) -> &GtlsHealth {
        &self.health
    }

    /// The settings in force.
    pub fn settings(&self) -> GtlsSettings<T> {
        GtlsSettings {
            snr: self.snr,
            max_abs_input: self.max_abs_input,
            reorth_tol: self.reorth_tol,
            forgetting: match &self.forgetting {
                ForgettingState::Constant(l) => Forgetting::Constant(*l),
                ForgettingState::Variable(v) => Forgetting::Variable(*v.settings()),
            },
        }
    }

    /// `‖VᵀV − I‖_F`, the orthonormality error of `V`.
    pub fn orthonormality_error(&self) -> T {
        orthonormality_error(self.right_singular_vectors())
    }

    /// The TLS-corrected regressor `x̂₀` (eq. 24–25) of the sample `(x, z)` for parameters `θ`, and the
    /// corrected output `ẑ = x̂₀ᵀθ`. Exact regressors are returned unchanged.
    pub fn corrected_regressor(&self, x: &SVector<T, NT>, z: T, theta: &SVector<T, NT>) -> (SVector<T, NT>, T) {
        let mut a = SVector::<T, NA>::zeros();
        for i in 0..Self::NX {
            a[i] = theta[NE + i];
        }
        a[Self::NX] = -T::one();
        self.corrected_with(x, z, theta, &self.c_times(&a))
    }

    /// [`Self::corrected_regressor`] given `ca = C·[θ_n; −1]` (the estimator keeps it for its own `θ`).
    #[inline(always)]
    fn corrected_with(
        &self,
        x: &SVector<T, NT>,
        z: T,
        theta: &SVector<T, NT>,
        ca: &SVector<T, NA>,
    ) -> (SVector<T, NT>, T) {
        let nx = Self::NX;
        // ρ = x_eᵀθ_e + dᵀa with d = [x_n, z], a = [θ_n; −1].
        let mut rho = -z;
        for i in 0..NT {
            rho += x[i] * theta[i];
        }
        // W_T a = Cᵀ(C a), over the upper triangle of C (column i of C holds C[(j, i)], j ≤ i).
        let c = &self.c.data.0;
        let mut wa = [T::zero(); NA];
        let mut awa = T::zero();
        for i in 0..NA {
            let ci = &c[i];
            let mut acc = T::zero();
            for j in 0..i + 1 {
                acc += ci[j] * ca[j];
            }
            wa[i] = acc;
            awa += ca[i] * ca[i];
        }
        let mut out = *x;
        let mut zhat = z;
        if awa > T::zero() {
            let f = rho / awa;
            for i in 0..nx {
                out[NE + i] = x[NE + i] - f * wa[i];
            }
            zhat = z - f * wa[nx];
        }
        (out, zhat)
    }

    /// Algorithm 1 for one sample, computed into locals (the new `V` into the spare buffer) and
    /// committed only when every part succeeded, so a failure leaves the state untouched without
    /// copying it.
    fn apply(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        let nx = Self::NX;
        let lambda = self.lambda;
        // Eq. 10: the noisy block scaled, d* = d C⁻¹ (as a column: C⁻ᵀ dᵀ), by forward substitution
        // with the columns of C (column i holds C[(k, i)], k ≤ i).
        let c = &self.c.data.0;
        let mut w = SVector::<T, NA>::zeros();
        for i in 0..NA {
            let ci = &c[i];
            let mut acc = if i < nx { x[NE + i] } else { z };
            for k in 0..i {
                acc -= ci[k] * w[k];
            }
            w[i] = acc / ci[i];
        }
        // Mixed LS–TLS: project out the exact regressors (module doc).
        let mut b = self.b;
        let mut g11 = self.g11;
        if NE == 1 {
            // One exact regressor (the intercept): G₁₁ is a scalar.
            let xe = x[0];
            let g = lambda * self.g11[(0, 0)] + xe * xe;
            let kk = if g > T::zero() { xe / g } else { T::zero() };
            let f = (T::one() - xe * kk).maxr(T::zero()).root();
            for i in 0..NA {
                let e = w[i] - self.b[(i, 0)] * xe;
                b[(i, 0)] = self.b[(i, 0)] + e * kk;
                w[i] = e * f;
            }
            g11[(0, 0)] = g;
        } else if NE > 1 {
            let mut xe = SVector::<T, NE>::zeros();
            for i in 0..NE {
                xe[i] = x[i];
            }
            g11 = self.g11 * lambda + xe * xe.transpose();
            let kk = solve_spd_regularised(&g11, &xe).ok_or(Error::NumericalFault)?;
            let rho = xe.dot(&kk);
            let e = w - self.b * xe;
            w = e * (T::one() - rho).maxr(T::zero()).root();
            b = self.b + e * kk.transpose();
        }
        if !(all_finite(&w) && all_finite(&b) && all_finite(&g11)) {
            return Err(Error::NumericalFault);
        }
        let theta_prev = &self.theta;
        // Eq. 24 needs only θ(t−1) (and C·a of it, kept); the VFF step itself (eq. 28–33) runs last.
        let (nu, x0) = match self.forgetting {
            ForgettingState::Constant(_) => (z - x.dot(theta_prev), *x),
            ForgettingState::Variable(_) => {
                let (x0, _) = self.corrected_with(x, z, theta_prev, &self.ca);
                (z - x0.dot(theta_prev), x0)
            }
        };
        // Algorithm 1, step 4: rank-one SVD update of √λ·D* with the new row, into the spare buffer.
        let cur = usize::from(self.cur & 1);
        let (first, second) = self.v.split_at_mut(1);
        let (v_old, v) = if cur == 0 {
            (&first[0], &mut second[0])
        } else {
            (&second[0], &mut first[0])
        };
        let mut s = SVector::<T, NA>::zeros();
        let secular = rank_one_update_into(v_old, &self.s2, lambda, &w, v, &mut s).ok_or(Error::NumericalFault)?;
        let n_eff = lambda * self.n_eff + T::one();
        let (check_cursor, reorthonormalised) = guard_orthonormality(v, self.check_cursor, self.reorth_tol);
        // Steps 5–9.
        let (k, solution, a, ca) = solve(&self.c, &self.weights, self.snr, v, &s, n_eff);
        let theta = theta_from::<T, NT, NE, NA>(&a, &ca, &b);
        if !all_finite(&theta) {
            return Err(Error::NumericalFault);
        }
        // Eq. 25 (with x̂₀ under the VFF, with x otherwise).
        let r = z - x0.dot(&theta);
        // The VFF (eq. 28–33), independent of the steps above: updated in place, as the last step
        // that can fail (`Vff::update` leaves its state unchanged when it fails, and nothing else is
        // committed yet), so the state is not copied.
        let (lambda_next, vff_step) = match &mut self.forgetting {
            ForgettingState::Constant(l) => (*l, VffStep::default()),
            ForgettingState::Variable(vff) => {
                // The statistics start once θ(t−1) is a TLS solution (eq. 16; `vff` module doc).
                let st = vff
                    .update(&x0, nu, self.solution == Solution::Tls)
                    .ok_or(Error::NumericalFault)?;
                (st.lambda, st)
            }
        };
        // Commit.
        self.cur = (cur as u8) ^ 1;
        self.s2 = s;
        self.b = b;
        self.g11 = g11;
        self.theta = theta;
        self.ca = ca;
        self.k = k as u8;
        self.solution = solution;
        self.n_eff = n_eff;
        self.n_eff2 = lambda * lambda * self.n_eff2 + T::one();
        self.lambda = lambda_next;
        self.check_cursor = check_cursor;
        let h = &mut self.health;
        h.updates = h.updates.saturating_add(1);
        h.secular_not_converged = h.secular_not_converged.saturating_add(secular.not_converged as u32);
        if reorthonormalised {
            h.reorthonormalisations = h.reorthonormalisations.saturating_add(1);
        }
        if solution == Solution::Nongeneric {
            h.nongeneric = h.nongeneric.saturating_add(1);
        }
        Ok(Step {
            k: k as u8,
            lambda,
            lambda_next,
            prior_residual: nu,
            posterior_residual: r,
            solution,
            secular,
            reorthonormalised,
            vff: vff_step,
        })
    }

    fn threshold_for(n_eff: T, snr: T) -> Option<T> {
        threshold_for(n_eff, snr, NT)
    }

    /// `C·a` over the upper triangle of `C` (its lower part is zero).
    #[inline(always)]
    fn c_times(&self, a: &SVector<T, NA>) -> SVector<T, NA> {
        c_times(&self.c, a)
    }
}

/// Checks one entry of `VᵀV − I` per call (cycling from `cursor`), re-orthonormalising `v` if it
/// exceeds the tolerance (`0`: the default `4·NA·ε`). Cost: one dot product of length `NA` per
/// sample. Returns the next cursor and whether `v` was re-orthonormalised.
fn guard_orthonormality<T: Real, const NA: usize>(v: &mut SMatrix<T, NA, NA>, cursor: u16, tol: T) -> (u16, bool) {
    // The cursor is the pair (i, j), i ≤ j, as i·NA + j: the upper triangle row by row, so the
    // pair is two constant divisions away (a count of pairs would need a loop to map back).
    let c = cursor as usize;
    let (i, j) = ((c / NA).min(NA - 1), c % NA);
    let next = if j + 1 < NA {
        c + 1
    } else if i + 1 < NA {
        (i + 1) * (NA + 1)
    } else {
        0
    } as u16;
    let cols = &v.data.0;
    let (vi, vj) = (&cols[i], &cols[j]);
    let mut dot = T::zero();
    for r in 0..NA {
        dot += vi[r] * vj[r];
    }
    if i == j {
        dot -= T::one();
    }
    let tol = if tol > T::zero() {
        tol
    } else {
        T::lit(4.0 * NA as f64) * T::EPS
    };
    let reorth = dot.abs() > tol && reorthonormalise(v);
    (next, reorth)
}

/// Eq. 21's threshold `(1 + s/n)·√(N_eff − n_θ)`, or `None` while `N_eff ≤ n_θ`.
fn threshold_for<T: Real>(n_eff: T, snr: T, nt: usize) -> Option<T> {
    let dof = n_eff - T::lit(nt as f64);
    if dof > T::zero() {
        Some((T::one() + snr) * dof.root())
    } else {
        None
    }
}

/// `C·a` over the upper triangle of `C` (its lower part is zero; column `j` holds `C[(i, j)]`).
#[inline(always)]
fn c_times<T: Real, const NA: usize>(c: &SMatrix<T, NA, NA>, a: &SVector<T, NA>) -> SVector<T, NA> {
    let cols = &c.data.0;
    let mut out = SVector::<T, NA>::zeros();
    for j in 0..NA {
        let cj = &cols[j];
        let aj = a[j];
        for i in 0..j + 1 {
            out[i] += cj[i] * aj;
        }
    }
    out
}

/// Algorithm 1, steps 5–9: the threshold `k` (eq. 21) and `a = [θ_n; −1]` (eq. 16 or 22–23), with
/// `C·a`. `s2` holds the squared singular values.
fn solve<T: Real, const NT: usize, const NA: usize>(
    c: &SMatrix<T, NA, NA>,
    weights: &SVector<T, NT>,
    snr: T,
    v: &SMatrix<T, NA, NA>,
    s2: &SVector<T, NA>,
    n_eff: T,
) -> (usize, Solution, SVector<T, NA>, SVector<T, NA>) {
    let nx = NA - 1;
    let Some(thr) = threshold_for(n_eff, snr, NT) else {
        let (a, ca) = minimum_norm(c, weights, v, 0);
        return (0, Solution::NotEnoughData, a, ca);
    };
    // σ_j > thr compared as σ_j² > thr² (both sides non-negative).
    let thr2 = thr * thr;
    let mut k = 0;
    for j in 0..nx {
        k += usize::from(s2[j] > thr2);
    }
    if k < nx {
        let (a, ca) = minimum_norm(c, weights, v, k);
        return (k, Solution::MinimumNorm, a, ca);
    }
    match tls_direction(c, v) {
        Some((a, ca)) => (k, Solution::Tls, a, ca),
        None => {
            let (a, ca) = minimum_norm(c, weights, v, nx - 1);
            (k, Solution::Nongeneric, a, ca)
        }
    }
}

/// Eq. 16: `[θ_n; −1] = h C⁻¹ v_NA` (and `C·a = h v_NA`), or `None` if the output component is
/// negligible (`|a_NA| ≤ √ε‖a‖`).
fn tls_direction<T: Real, const NA: usize>(
    c: &SMatrix<T, NA, NA>,
    v: &SMatrix<T, NA, NA>,
) -> Option<(SVector<T, NA>, SVector<T, NA>)> {
    let nx = NA - 1;
    let vl = &v.data.0[NA - 1];
    let cols = &c.data.0;
    // Back substitution C a = v_NA, row i of C being C[(i, k)] = cols[k][i].
    let mut a = SVector::<T, NA>::zeros();
    let mut nrm2 = T::zero();
    for ii in 0..NA {
        let i = NA - 1 - ii;
        let mut acc = vl[i];
        for k in (i + 1)..NA {
            acc -= cols[k][i] * a[k];
        }
        let ai = acc / cols[i][i];
        a[i] = ai;
        nrm2 += ai * ai;
    }
    let last = a[nx];
    if !(last * last > T::EPS * nrm2) {
        return None;
    }
    let h = -T::one() / last;
    let mut ca = SVector::<T, NA>::zeros();
    for i in 0..NA {
        a[i] *= h;
        ca[i] = vl[i] * h;
    }
    // Exactly −1 (h·a_NA may round).
    a[nx] = -T::one();
    Some((a, ca))
}

/// Eq. 22–23: the minimum `‖W θ_n‖` among `[θ_n; −1]` with `V₁ᵀ C [θ_n; −1] = 0`, `V₁ = v_1..v_k`
/// (and `C·a`).
///
/// The constraints are `M θ_n = b` with the rows `(v_rᵀ C)`, split into `M` (first `NX` entries) and
/// `b` (the last, sign flipped by `a_NA = −1`); with `W = diag(weights)` the minimum is
/// `θ_n = W⁻¹ (MW⁻¹)ᵀ y`, `(MW⁻¹)(MW⁻¹)ᵀ y = b` — a `k×k` system, solved by Cholesky (regularised
/// as [`cholesky_regularised`] when singular to working precision).
fn minimum_norm<T: Real, const NT: usize, const NA: usize>(
    c: &SMatrix<T, NA, NA>,
    weights: &SVector<T, NT>,
    v: &SMatrix<T, NA, NA>,
    k: usize,
) -> (SVector<T, NA>, SVector<T, NA>) {
    let nx = NA - 1;
    let ne = NT + 1 - NA;
    let mut a = SVector::<T, NA>::zeros();
    a[nx] = -T::one();
    let k = k.min(nx);
    if k > 0 {
        let vc = &v.data.0;
        let cc = &c.data.0;
        // Rows r < k of M W⁻¹ and b: (v_rᵀ C)_j = Σ_{i ≤ j} v_r[i]·C[(i, j)]. Rows ≥ k are never
        // read; their placeholder is 1, not 0, because LLVM turns an all-zero array initialiser
        // into a `memclr` call (≈ 70 instructions on the M4F) but stores other constants inline.
        let mut rhs = [T::zero(); NA];
        let mut mw = [[T::one(); NA]; NA];
        for r in 0..k {
            let vr = &vc[r];
            for j in 0..NA {
                let cj = &cc[j];
                let mut acc = T::zero();
                for i in 0..j + 1 {
                    acc += vr[i] * cj[i];
                }
                if j < nx {
                    mw[r][j] = acc / weights[ne + j];
                } else {
                    rhs[r] = acc;
                }
            }
        }
        if let Some(y) = solve_gram(&mw, &rhs, k) {
            // a_j = Σ_r mw[r][j]·y_r / w_j, the rows outer (run-time k) and the entries inner
            // (compile-time nx, unrolled into registers): each sum in increasing r, as a j-outer
            // loop would add them.
            let mut acc = [T::zero(); NA];
            for r in 0..k {
                let yr = y[r];
                let mr = &mw[r];
                for j in 0..nx {
                    acc[j] += mr[j] * yr;
                }
            }
            for j in 0..nx {
                a[j] = acc[j] / weights[ne + j];
            }
        }
    }
    let ca = c_times(c, &a);
    (a, ca)
}

/// Solves `G y = b` with the Gram matrix `G = M Mᵀ` of the first `k` rows of `m` over their first
/// `N − 1` entries (the lower triangle is formed and factorised in place by Cholesky), regularised by
/// `μ = 16·k·ε·max(tr G/k, tiny)` on the diagonal if a pivot is not positive (as
/// [`cholesky_regularised`]; `G` is then formed again, which is rare). `None` if that fails too or
/// the result is not finite.
fn solve_gram<T: Real, const N: usize>(m: &[[T; N]; N], b: &[T; N], k: usize) -> Option<[T; N]> {
    // The entries of a row: `N − 1`, a compile-time length, so that each inner product is
    // unrolled with the row `r` in registers (the rows are the run-time loops).
    let n = N.saturating_sub(1);
    let gram = |g: &mut [[T; N]; N], mu: T| {
        for r in 0..k.min(N) {
            let mr = &m[r];
            for q in 0..r + 1 {
                let mq = &m[q];
                let mut acc = T::zero();
                for j in 0..n {
                    acc += mr[j] * mq[j];
                }
                g[r][q] = if q == r { acc + mu } else { acc };
            }
        }
    };
    // Only the lower triangle of the leading k×k block is written and read; the placeholder 1
    // elsewhere (not 0) keeps the initialiser inline, as for `minimum_norm`'s rows.
    let mut g = [[T::one(); N]; N];
    gram(&mut g, T::zero());
    if !cholesky_lower_in_place(&mut g, k) {
        let mut tr = T::zero();
        for r in 0..k.min(N) {
            for j in 0..n {
                tr += m[r][j] * m[r][j];
            }
        }
        let kf = T::lit(k as f64);
        let mu = T::lit(16.0) * kf * T::EPS * (tr / kf).maxr(T::SQRT_MIN_POSITIVE);
        gram(&mut g, mu);
        if !cholesky_lower_in_place(&mut g, k) {
            return None;
        }
    }
    // L Lᵀ y = b, by loops of compile-time length stopped at `k` (`unrolled_upto`;
    // measured with the Cholesky: replay median −597 instructions and −1.3 KB of flash,
    // while the same change to the Gram product and to `minimum_norm`'s rows cost 3.5 KB for ±30).
    let mut y = [T::zero(); N];
    for i in unrolled_upto::<N>(0, k) {
        let mut acc = b[i];
        for j in 0..i {
            acc -= g[i][j] * y[j];
        }
        y[i] = acc / g[i][i];
    }
    for ii in 0..N {
        let i = N - 1 - ii;
        if i >= k {
            continue;
        }
        let mut acc = y[i];
        for j in unrolled_upto::<N>(i + 1, k) {
            acc -= g[j][i] * y[j];
        }
        y[i] = acc / g[i][i];
    }
    if slice_finite(&y) {
        Some(y)
    } else {
        None
    }
}

/// Cholesky `G = L Lᵀ` of the leading `k×k` block in place (lower triangle); `false` if a pivot is
/// not positive and finite.
fn cholesky_lower_in_place<T: Real, const N: usize>(g: &mut [[T; N]; N], k: usize) -> bool {
    // Loops of compile-time length that stop at `k` (`unrolled_upto`, not run-time ranges).
    for j in unrolled_upto::<N>(0, k) {
        let mut d = g[j][j];
        for q in 0..j {
            d -= g[j][q] * g[j][q];
        }
        if !(d > T::zero() && d.finite()) {
            return false;
        }
        let ljj = d.root();
        g[j][j] = ljj;
        for i in unrolled_upto::<N>(j + 1, k) {
            let mut acc = g[i][j];
            for q in 0..j {
                acc -= g[i][q] * g[j][q];
            }
            g[i][j] = acc / ljj;
        }
    }
    true
}

/// `θ = [θ_e; θ_n]` from `a = [θ_n; −1]` and `C·a`, with `θ_e = −Bᵀ C a` (LS given `θ_n`).
fn theta_from<T: Real, const NT: usize, const NE: usize, const NA: usize>(
    a: &SVector<T, NA>,
    ca: &SVector<T, NA>,
    b: &SMatrix<T, NA, NE>,
) -> SVector<T, NT> {
    let mut theta = SVector::<T, NT>::zeros();
    let bc = &b.data.0;
    for e in 0..NE {
        let be = &bc[e];
        let mut acc = T::zero();
        for i in 0..NA {
            acc -= be[i] * ca[i];
        }
        theta[e] = acc;
    }
    for j in 0..NA - 1 {
        theta[NE + j] = a[j];
    }
    theta
}

impl<T: Real, const NT: usize, const NE: usize, const NA: usize> core::fmt::Debug for Gtls<T, NT, NE, NA> {
    /// Every field of the state (the current `V`, not the scratch buffer).
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Gtls")
            .field("snr", &self.snr)
            .field("max_abs_input", &self.max_abs_input)
            .field("reorth_tol", &self.reorth_tol)
            .field("c", &self.c)
            .field("weights", &self.weights)
            .field("v", self.right_singular_vectors())
            .field("s2", &self.s2)
            .field("g11", &self.g11)
            .field("b", &self.b)
            .field("theta", &self.theta)
            .field("ca", &self.ca)
            .field("k", &self.k)
            .field("solution", &self.solution)
            .field("n_eff", &self.n_eff)
            .field("n_eff2", &self.n_eff2)
            .field("lambda", &self.lambda)
            .field("forgetting", &self.forgetting)
            .field("check_cursor", &self.check_cursor)
            .field("health", &self.health)
            .finish()
    }
}

impl<T: Real, const NT: usize, const NE: usize, const NA: usize> PartialEq for Gtls<T, NT, NE, NA> {
    /// The state only: the spare `V` buffer (scratch) is not compared.
    fn eq(&self, other: &Self) -> bool {
        self.snr == other.snr
            && self.max_abs_input == other.max_abs_input
            && self.reorth_tol == other.reorth_tol
            && self.c == other.c
            && self.weights == other.weights
            && self.right_singular_vectors() == other.right_singular_vectors()
            && self.s2 == other.s2
            && self.g11 == other.g11
            && self.b == other.b
            && self.theta == other.theta
            && self.ca == other.ca
            && self.k == other.k
            && self.solution == other.solution
            && self.n_eff == other.n_eff
            && self.n_eff2 == other.n_eff2
            && self.lambda == other.lambda
            && self.forgetting == other.forgetting
            && self.check_cursor == other.check_cursor
            && self.health == other.health
    }
}

impl<T: Real, const NT: usize, const NE: usize, const NA: usize> Estimator<T, NT> for Gtls<T, NT, NE, NA> {
    /// Algorithm 1 for one sample. Refused (state untouched) if an element is non-finite or larger
    /// than `max_abs_input`, or if the update would leave a non-finite state.
    fn update(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        check_sample(x, z, self.max_abs_input)?;
        self.apply(x, z)
    }

    fn theta(&self) -> &SVector<T, NT> {
        &self.theta
    }

    /// Eq. 17 in our reading (module doc). `Err(InsufficientExcitation)` unless `k = n_θ`.
    #[allow(non_snake_case)]
    fn covariance(&self) -> Result<SMatrix<T, NT, NT>, Error> {
        let nx = Self::NX;
        if self.solution != Solution::Tls {
            return Err(Error::InsufficientExcitation);
        }
        let dof = self.n_eff - T::lit(NT as f64);
        if !(dof > T::zero()) {
            return Err(Error::InsufficientExcitation);
        }
        let s_last2 = self.s2[NA - 1];
        let sigma2 = s_last2 / dof;
        let ratio = self.n_eff2 / self.n_eff;
        // Scaled-space TLS solution θ* from v_NA.
        let vv = self.right_singular_vectors();
        let vl = vv.column(NA - 1);
        if !(vl[nx].abs() > T::EPS) {
            return Err(Error::InsufficientExcitation);
        }
        let mut theta_star_sq = T::zero();
        for j in 0..nx {
            let t = -vl[j] / vl[nx];
            theta_star_sq += t * t;
        }
        // G*ₓₓ − σ²_NA I, padded to NA×NA with 1 on the last diagonal entry.
        let mut g = SMatrix::<T, NA, NA>::zeros();
        for i in 0..NA {
            let si2 = self.s2[i];
            for r in 0..nx {
                for c in 0..nx {
                    g[(r, c)] += vv[(r, i)] * si2 * vv[(c, i)];
                }
            }
        }
        for r in 0..nx {
            g[(r, r)] -= s_last2;
        }
        g[(nx, nx)] = T::one();
        let g = (g + g.transpose()) * T::lit(0.5);
        let cg = cholesky_upper(&g).ok_or(Error::InsufficientExcitation)?;
        let cg_inv = inv_upper(&cg).ok_or(Error::InsufficientExcitation)?;
        let scale = sigma2 * (T::one() + theta_star_sq) * ratio;
        // J = C_NA,NA (C⁻¹)ₓₓ (padded). cov θ_n = J Σ* Jᵀ = M Mᵀ with M = √scale·J·G⁻ᵀᐟ² — formed as a
        // product of factors, so the result is exactly symmetric with a non-negative diagonal.
        let c_inv = inv_upper(&self.c).ok_or(Error::NumericalFault)?;
        let mut j = SMatrix::<T, NA, NA>::zeros();
        for r in 0..nx {
            for c in 0..nx {
                j[(r, c)] = self.c[(nx, nx)] * c_inv[(r, c)];
            }
        }
        let m = j * cg_inv * scale.root();
        // cov θ = F₁F₁ᵀ + F₂F₂ᵀ: F₁ carries the TLS part (rows of θ_e get J_e·M), F₂ the LS part of
        // the exact parameters, √(σ_vv·N₂/N_eff)·C₁₁⁻¹ with G₁₁ = C₁₁ᵀC₁₁.
        let mut f1 = SMatrix::<T, NT, NA>::zeros();
        let mut f2 = SMatrix::<T, NT, NE>::zeros();
        for r in 0..nx {
            for c in 0..NA {
                f1[(NE + r, c)] = m[(r, c)];
            }
        }
        if NE > 0 {
            // a = [θ_n; −1]; σ_vv = σ̂²‖Ca‖².
            let mut a = SVector::<T, NA>::zeros();
            for r in 0..nx {
                a[r] = self.theta[NE + r];
            }
            a[nx] = -T::one();
            let ca = self.c * a;
            let s_vv = sigma2 * ca.dot(&ca);
            let mut je = SMatrix::<T, NE, NA>::zeros(); // −Bᵀ C[:, :NX], padded
            let bc = -(self.b.transpose() * self.c);
            for r in 0..NE {
                for c in 0..nx {
                    je[(r, c)] = bc[(r, c)];
                }
            }
            let jem = je * m;
            let c11 = cholesky_regularised(&self.g11).ok_or(Error::InsufficientExcitation)?;
            let c11_inv = inv_upper(&c11).ok_or(Error::InsufficientExcitation)?;
            let ls = (s_vv * ratio).root();
            for r in 0..NE {
                for c in 0..NA {
                    f1[(r, c)] = jem[(r, c)];
                }
                for c in 0..NE {
                    f2[(r, c)] = ls * c11_inv[(r, c)];
                }
            }
        }
        let out = f1 * f1.transpose() + f2 * f2.transpose();
        if all_finite(&out) {
            Ok(out)
        } else {
            Err(Error::NumericalFault)
        }
    }

    fn lambda(&self) -> T {
        self.lambda
    }

    fn excited(&self) -> usize {
        self.k as usize
    }

    fn effective_samples(&self) -> T {
        self.n_eff
    }
}
