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
use crate::linalg::secular::rank_one_update;
use crate::linalg::{
    all_finite, cholesky_regularised, cholesky_upper, inv_upper, orthonormality_error, reorthonormalise,
    solve_spd_regularised, solve_upper, solve_upper_transposed,
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
#[allow(non_snake_case)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gtls<T: Real, const NT: usize, const NE: usize, const NA: usize> {
    settings: GtlsSettings<T>,
    /// `C` (upper triangular, `W_T = CᵀC`, eq. 9).
    c: SMatrix<T, NA, NA>,
    /// Diagonal of `W` (eq. 23), one weight per parameter (the exact entries are unused).
    weights: SVector<T, NT>,
    /// Right singular vectors of the projected scaled data matrix, by decreasing singular value.
    v: SMatrix<T, NA, NA>,
    /// Singular values, decreasing (eq. 13).
    s: SVector<T, NA>,
    /// `G₁₁`: weighted Gram matrix of the exact regressors.
    g11: SMatrix<T, NE, NE>,
    /// `B = G₂₁G₁₁⁻¹` in scaled coordinates.
    b: SMatrix<T, NA, NE>,
    theta: SVector<T, NT>,
    k: u8,
    solution: Solution,
    /// `N_eff = Σ Π λ` and `N₂ = Σ (Π λ)²`.
    n_eff: T,
    n_eff2: T,
    lambda: T,
    forgetting: ForgettingState<T, NT>,
    check_cursor: u16,
    health: GtlsHealth,
    last_vff: VffStep<T>,
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
            settings,
            c,
            weights: *weights,
            v: SMatrix::identity(),
            s: SVector::zeros(),
            g11: SMatrix::zeros(),
            b: SMatrix::zeros(),
            theta: SVector::zeros(),
            k: 0,
            solution: Solution::NotEnoughData,
            n_eff: T::zero(),
            n_eff2: T::zero(),
            lambda,
            forgetting,
            check_cursor: 0,
            health: GtlsHealth::default(),
            last_vff: VffStep::default(),
        })
    }

    /// Singular values `σ_1 ≥ … ≥ σ_NA` of the (projected) scaled data matrix (eq. 13).
    pub fn singular_values(&self) -> &SVector<T, NA> {
        &self.s
    }

    /// Right singular vectors `V` (eq. 12), columns in the order of [`Self::singular_values`].
    pub fn right_singular_vectors(&self) -> &SMatrix<T, NA, NA> {
        &self.v
    }

    /// The excitation threshold of eq. 21, `(1 + s/n)·√(N_eff − n_θ)`, or `None` while
    /// `N_eff ≤ n_θ`.
    pub fn threshold(&self) -> Option<T> {
        Self::threshold_for(self.n_eff, self.settings.snr)
    }

    /// Which solution produced the current `θ`.
    pub fn solution(&self) -> Solution {
        self.solution
    }

    /// Numerical events so far.
    pub fn health(&self) -> &GtlsHealth {
        &self.health
    }

    /// The VFF quantities of the last step (zero with constant forgetting).
    pub fn last_vff(&self) -> &VffStep<T> {
        &self.last_vff
    }

    /// The settings in force.
    pub fn settings(&self) -> &GtlsSettings<T> {
        &self.settings
    }

    /// `‖VᵀV − I‖_F`, the orthonormality error of `V`.
    pub fn orthonormality_error(&self) -> T {
        orthonormality_error(&self.v)
    }

    /// The TLS-corrected regressor `x̂₀` (eq. 24–25) of the sample `(x, z)` for parameters `θ`, and the
    /// corrected output `ẑ = x̂₀ᵀθ`. Exact regressors are returned unchanged.
    pub fn corrected_regressor(&self, x: &SVector<T, NT>, z: T, theta: &SVector<T, NT>) -> (SVector<T, NT>, T) {
        let nx = Self::NX;
        let mut a = SVector::<T, NA>::zeros();
        let mut d = SVector::<T, NA>::zeros();
        for i in 0..nx {
            a[i] = theta[NE + i];
            d[i] = x[NE + i];
        }
        a[nx] = -T::one();
        d[nx] = z;
        let mut rho = d.dot(&a);
        for i in 0..NE {
            rho += x[i] * theta[i];
        }
        // C is upper triangular: the products skip its zero lower part.
        let c = &self.c;
        let ca = self.c_times(&a);
        let wa = SVector::<T, NA>::from_fn(|i, _| {
            let mut acc = T::zero();
            for j in 0..i + 1 {
                acc += c[(j, i)] * ca[j];
            }
            acc
        }); // W_T a
        let awa = ca.dot(&ca);
        let mut out = *x;
        let mut zhat = z;
        if awa > T::zero() {
            let f = rho / awa;
            for i in 0..nx {
                out[NE + i] = d[i] - f * wa[i];
            }
            zhat = d[nx] - f * wa[nx];
        }
        (out, zhat)
    }

    /// Algorithm 1 for one sample, computed into locals and committed only when every part
    /// succeeded (so a failure leaves `self` untouched without copying the whole state).
    fn apply(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        let nx = Self::NX;
        let lambda = self.lambda;
        let theta_prev = self.theta;
        // Eq. 10: the noisy block scaled, d* = d C⁻¹ (as a column: C⁻ᵀ dᵀ).
        let mut d = SVector::<T, NA>::zeros();
        for i in 0..nx {
            d[i] = x[NE + i];
        }
        d[nx] = z;
        let d_star = solve_upper_transposed(&self.c, &d);
        // Mixed LS–TLS: project out the exact regressors (module doc).
        let (w, b, g11) = if NE > 0 {
            let mut xe = SVector::<T, NE>::zeros();
            for i in 0..NE {
                xe[i] = x[i];
            }
            let g11 = self.g11 * lambda + xe * xe.transpose();
            let kk = solve_spd_regularised(&g11, &xe).ok_or(Error::NumericalFault)?;
            let rho = xe.dot(&kk);
            let e = d_star - self.b * xe;
            (
                e * (T::one() - rho).maxr(T::zero()).root(),
                self.b + e * kk.transpose(),
                g11,
            )
        } else {
            (d_star, self.b, self.g11)
        };
        let finite = all_finite(&w) && all_finite(&b) && all_finite(&g11);
        if !finite {
            return Err(Error::NumericalFault);
        }
        // Eq. 24 needs only θ(t−1); the VFF step itself (eq. 28–33) runs last, in place (below).
        let (nu, x0) = match self.forgetting {
            ForgettingState::Constant(_) => (z - x.dot(&theta_prev), *x),
            ForgettingState::Variable(_) => {
                let (x0, _) = self.corrected_regressor(x, z, &theta_prev);
                (z - x0.dot(&theta_prev), x0)
            }
        };
        // Algorithm 1, step 4: rank-one SVD update of √λ·D* with the new row.
        let (mut v, s, secular) = rank_one_update(&self.v, &self.s, lambda, &w).ok_or(Error::NumericalFault)?;
        let n_eff = lambda * self.n_eff + T::one();
        let (check_cursor, reorthonormalised) = self.guard_orthonormality(&mut v);
        // Steps 5–9.
        let (k, solution, a) = self.solve(&v, &s, n_eff);
        let theta = self.theta_from(&a, &b);
        if !all_finite(&theta) {
            return Err(Error::NumericalFault);
        }
        // Eq. 25 (with x̂₀ under the VFF, with x otherwise).
        let r = z - x0.dot(&theta);
        // The VFF (eq. 28–33), independent of the steps above: updated in place, as the last step
        // that can fail (`Vff::update` leaves its state unchanged when it fails, and nothing else is
        // committed yet), so the state is not copied.
        let (lambda_next, vff_step) = match &mut self.forgetting {
            ForgettingState::Constant(l) => (*l, self.last_vff),
            ForgettingState::Variable(vff) => {
                let st = vff.update(&x0, nu).ok_or(Error::NumericalFault)?;
                (st.lambda, st)
            }
        };
        // Commit.
        self.v = v;
        self.s = s;
        self.b = b;
        self.g11 = g11;
        self.theta = theta;
        self.k = k as u8;
        self.solution = solution;
        self.n_eff = n_eff;
        self.n_eff2 = lambda * lambda * self.n_eff2 + T::one();
        self.lambda = lambda_next;
        self.last_vff = vff_step;
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
        })
    }

    /// Checks one entry of `VᵀV − I` per call (cycling), re-orthonormalising `v` if it exceeds the
    /// tolerance. Cost: one dot product of length `NA` per sample. Returns the next cursor and
    /// whether `v` was re-orthonormalised.
    fn guard_orthonormality(&self, v: &mut SMatrix<T, NA, NA>) -> (u16, bool) {
        let pairs = NA * (NA + 1) / 2;
        let mut c = (self.check_cursor as usize) % pairs;
        let next = ((c + 1) % pairs) as u16;
        // Map the cursor to (i, j), i ≤ j.
        let mut i = 0usize;
        while c >= NA - i {
            c -= NA - i;
            i += 1;
        }
        let j = i + c;
        let mut dot = T::zero();
        for r in 0..NA {
            dot += v[(r, i)] * v[(r, j)];
        }
        if i == j {
            dot -= T::one();
        }
        let tol = if self.settings.reorth_tol > T::zero() {
            self.settings.reorth_tol
        } else {
            T::lit(4.0 * NA as f64) * T::EPS
        };
        let reorth = dot.abs() > tol && reorthonormalise(v);
        (next, reorth)
    }

    /// Algorithm 1, steps 5–9: the threshold `k` (eq. 21) and `a = [θ_n; −1]` (eq. 16 or 22–23).
    fn solve(&self, v: &SMatrix<T, NA, NA>, s: &SVector<T, NA>, n_eff: T) -> (usize, Solution, SVector<T, NA>) {
        let nx = Self::NX;
        let Some(thr) = Self::threshold_for(n_eff, self.settings.snr) else {
            return (0, Solution::NotEnoughData, self.minimum_norm(v, 0));
        };
        let k = (0..nx).filter(|&j| s[j] > thr).count();
        if k < nx {
            return (k, Solution::MinimumNorm, self.minimum_norm(v, k));
        }
        match self.tls_direction(v) {
            Some(a) => (k, Solution::Tls, a),
            None => (k, Solution::Nongeneric, self.minimum_norm(v, nx - 1)),
        }
    }

    fn threshold_for(n_eff: T, snr: T) -> Option<T> {
        let dof = n_eff - T::lit(NT as f64);
        if dof > T::zero() {
            Some((T::one() + snr) * dof.root())
        } else {
            None
        }
    }

    /// Eq. 16: `[θ_n; −1] = h C⁻¹ v_NA`, or `None` if the output component is negligible.
    fn tls_direction(&self, v: &SMatrix<T, NA, NA>) -> Option<SVector<T, NA>> {
        let nx = Self::NX;
        let vl = v.column(NA - 1).into_owned();
        let a = solve_upper(&self.c, &vl);
        let nrm = a.norm();
        let last = a[nx];
        if !(last.abs() > T::SQRT_EPS * nrm) {
            return None;
        }
        Some(a * (-T::one() / last))
    }

    /// Eq. 22–23: the minimum `‖W θ_n‖` among `[θ_n; −1]` with `V₁ᵀ C [θ_n; −1] = 0`, `V₁ = v_1..v_k`.
    fn minimum_norm(&self, v: &SMatrix<T, NA, NA>, k: usize) -> SVector<T, NA> {
        let nx = Self::NX;
        let mut a = SVector::<T, NA>::zeros();
        a[nx] = -T::one();
        if k == 0 {
            return a;
        }
        // Rows r < k: (v_rᵀ C) split into M (first NX entries, scaled by W⁻¹) and b (last entry).
        let mut mw = SMatrix::<T, NA, NA>::zeros();
        let mut rhs = SVector::<T, NA>::zeros();
        for r in 0..k {
            // v_rᵀ C over the upper triangle of C.
            let row = SVector::<T, NA>::from_fn(|j, _| {
                let mut acc = T::zero();
                for i in 0..j + 1 {
                    acc += v[(i, r)] * self.c[(i, j)];
                }
                acc
            });
            for j in 0..nx {
                mw[(r, j)] = row[j] / self.weights[NE + j];
            }
            rhs[r] = row[nx];
        }
        // Only the leading k×k block of M Mᵀ is non-zero; the rest is the identity.
        let mut gram = SMatrix::<T, NA, NA>::identity();
        for r in 0..k {
            for c in 0..k {
                let mut acc = T::zero();
                for j in 0..nx {
                    acc += mw[(r, j)] * mw[(c, j)];
                }
                gram[(r, c)] = acc;
            }
        }
        if let Some(y) = solve_spd_regularised(&gram, &rhs) {
            let t = mw.transpose() * y;
            for j in 0..nx {
                a[j] = t[j] / self.weights[NE + j];
            }
        }
        a
    }

    /// `C·a` over the upper triangle of `C` (its lower part is zero).
    #[inline(always)]
    fn c_times(&self, a: &SVector<T, NA>) -> SVector<T, NA> {
        let c = &self.c;
        SVector::<T, NA>::from_fn(|i, _| {
            let mut acc = T::zero();
            for j in i..NA {
                acc += c[(i, j)] * a[j];
            }
            acc
        })
    }

    /// `θ = [θ_e; θ_n]` from `a = [θ_n; −1]`, with `θ_e = −Bᵀ C a` (LS given `θ_n`).
    fn theta_from(&self, a: &SVector<T, NA>, b: &SMatrix<T, NA, NE>) -> SVector<T, NT> {
        let nx = Self::NX;
        let mut theta = SVector::<T, NT>::zeros();
        if NE > 0 {
            let ca = self.c_times(a);
            let te = -(b.transpose() * ca);
            for i in 0..NE {
                theta[i] = te[i];
            }
        }
        for j in 0..nx {
            theta[NE + j] = a[j];
        }
        theta
    }
}

impl<T: Real, const NT: usize, const NE: usize, const NA: usize> Estimator<T, NT> for Gtls<T, NT, NE, NA> {
    /// Algorithm 1 for one sample. Refused (state untouched) if an element is non-finite or larger
    /// than `max_abs_input`, or if the update would leave a non-finite state.
    fn update(&mut self, x: &SVector<T, NT>, z: T) -> Result<Step<T>, Error> {
        check_sample(x, z, self.settings.max_abs_input)?;
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
        let s_last2 = self.s[NA - 1] * self.s[NA - 1];
        let sigma2 = s_last2 / dof;
        let ratio = self.n_eff2 / self.n_eff;
        // Scaled-space TLS solution θ* from v_NA.
        let vl = self.v.column(NA - 1);
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
            let si2 = self.s[i] * self.s[i];
            for r in 0..nx {
                for c in 0..nx {
                    g[(r, c)] += self.v[(r, i)] * si2 * self.v[(c, i)];
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
