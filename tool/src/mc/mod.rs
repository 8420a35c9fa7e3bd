//! Monte Carlo uncertainty of compound (synthetic) measurands — seed paper 000, Section V, eq. 34–41.
//!
//! A measurand `Z = f(Ξ₁, …, Ξₙ)` is evaluated at `M` random input points; at each point the error
//! of a measured input set is `ε = f(Ξ) − f(Ξ + ΔΞ)` (eq. 35). Its empirical CDF (eq. 34) gives the
//! 95 % coverage bounds `[U₋, U₊]` (eq. 40) and the variance that goes into the last diagonal entry
//! of `W_T` (eq. 41): `σ̂_ε = max(|U₋|, |U₊|) / 1.96`.
//!
//! * **Inputs** (eq. 36–38): a Gaussian copula. `y ~ N(0, R)` with `R` the input *correlation*
//!   matrix (unit diagonal; the paper's `Σ_Ξ`), drawn as `y = L z` with `L Lᵀ = R` (Cholesky);
//!   each `u_j = Φ(y_j)` is then `U(0, 1)` and `ξ_j = r₋ + (r₊ − r₋) u_j`.
//! * **Errors** (eq. 39): `ΔΞ = L_Δ w`, `w ~ N(0, I)`, `L_Δ L_Δᵀ = Σ_ΔΞ`. `Σ_ΔΞ` may be singular
//!   (an input known exactly has a zero row); the factor is a positive-semidefinite Cholesky.
//!   As an extension to eq. 39 an input may carry a *relative* error, `ξ(1 + Δξ)` instead of
//!   `ξ + Δξ` (an RPM sensor specified as 1 % of reading).
//! * **Quantiles** (eq. 40): exact order statistics by selection (`select_nth_unstable`, O(M)):
//!   `U₋ = ε₍k₋₎`, `U₊ = ε₍k₊₎` (1-based), `k₋ = ⌈0.025 M⌉`, `k₊ = ⌈0.975 M⌉`.
//! * **Reproducible in parallel**: the `M` draws are cut into fixed chunks of
//!   [`McSettings::chunk_size`]; chunk `c` draws from its own `ChaCha8Rng` keyed by `seed` on
//!   stream `c`, and writes its slot of one output vector. The result is bit-identical for any
//!   number of rayon threads.
//! * **Progress**: an indicatif bar, one tick per chunk, only when stderr is a terminal.
//!
//! Math note: `Φ(x) = ½ erfc(−x/√2)` with `libm::erfc` (musl's, < 1 ulp), so `u` is correct to
//! ~1e-16 absolute in the body and keeps its relative accuracy in the lower tail. A copula matrix
//! with a non-unit diagonal would make the marginals non-uniform, so it is refused.
//!
//! [`synth`] holds the six coefficient measurands (eq. 1–2 solved for the coefficients) and the
//! default ranges and sensor errors for the `skywalker_2013_mod` airframe.

pub mod synth;

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// How an input's error `Δξ` (eq. 39) is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// `ξ + Δξ` (eq. 35 as printed); `Δξ` in the input's unit.
    Absolute,
    /// `ξ (1 + Δξ)`; `Δξ` dimensionless (a sensor specified in % of reading).
    Relative,
}

/// One uncertain input `Ξ_j`.
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// Name with unit, for reports (e.g. `"airspeed_mps"`).
    pub name: &'static str,
    /// Nominal range `[r₋, r₊]` (eq. 38), in the input's unit; `r₋ ≤ r₊` (equal: a fixed value).
    pub range: [f64; 2],
    /// How its error is applied.
    pub error_kind: ErrorKind,
}

impl Input {
    /// The centre of the range, `(r₋ + r₊)/2`.
    pub fn centre(&self) -> f64 {
        0.5 * (self.range[0] + self.range[1])
    }
}

/// A Monte Carlo problem: inputs, their copula correlation (`Σ_Ξ`, eq. 36) and error covariance
/// (`Σ_ΔΞ`, eq. 39). Matrices are row-major `n × n`.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// The inputs `Ξ`, in the order the measurand reads them.
    pub inputs: Vec<Input>,
    /// Copula correlation matrix `R` (symmetric, unit diagonal, positive definite).
    pub input_corr: Vec<f64>,
    /// Error covariance `Σ_ΔΞ` (symmetric positive semidefinite), units of the inputs squared
    /// (dimensionless for [`ErrorKind::Relative`] inputs).
    pub error_cov: Vec<f64>,
}

impl Problem {
    /// A problem with independent inputs (`R = I`) and independent errors of the given standard
    /// deviations.
    pub fn independent(inputs: Vec<Input>, error_sigma: &[f64]) -> Self {
        let n = inputs.len();
        let mut input_corr = vec![0.0; n * n];
        let mut error_cov = vec![0.0; n * n];
        for j in 0..n {
            input_corr[j * n + j] = 1.0;
            error_cov[j * n + j] = error_sigma.get(j).map_or(0.0, |s| s * s);
        }
        Self {
            inputs,
            input_corr,
            error_cov,
        }
    }

    /// Number of inputs `n`.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// `true` when there are no inputs.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// Sets the copula correlation of inputs `i` and `j` (both triangles).
    pub fn set_corr(&mut self, i: usize, j: usize, rho: f64) {
        let n = self.len();
        self.input_corr[i * n + j] = rho;
        self.input_corr[j * n + i] = rho;
    }

    /// The range centres.
    pub fn centre(&self) -> Vec<f64> {
        self.inputs.iter().map(Input::centre).collect()
    }
}

/// Run settings.
#[derive(Debug, Clone, PartialEq)]
pub struct McSettings {
    /// Number of draws `M` (the paper: `M > 10⁶`). Default 10⁶.
    pub draws: usize,
    /// RNG key. Default 0.
    pub seed: u64,
    /// Draws per chunk (one RNG stream, one progress tick each). Fixing it fixes the result;
    /// changing it changes the draws. Default 16 384.
    pub chunk_size: usize,
    /// Show a progress bar when stderr is a terminal. Default `true`.
    pub progress: bool,
}

impl Default for McSettings {
    fn default() -> Self {
        Self {
            draws: 1_000_000,
            seed: 0,
            chunk_size: 16_384,
            progress: true,
        }
    }
}

/// Why a problem was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum McError {
    /// A matrix is not `n × n`, or there are no inputs.
    Dimension,
    /// Input `j` has `r₋ > r₊` or a non-finite bound.
    BadRange(usize),
    /// The copula matrix is not symmetric with unit diagonal.
    NotCorrelation,
    /// The copula matrix is not positive definite.
    CorrNotPositiveDefinite,
    /// `Σ_ΔΞ` is not symmetric positive semidefinite.
    ErrorCovNotPsd,
    /// Fewer than 40 finite errors (no 2.5 % quantile), or zero draws / chunk size.
    TooFewDraws,
}

/// The outcome of a run (eq. 40–41 plus moments).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McResult {
    /// Lower 95 % bound `U₋` (2.5 % order statistic), unit of the measurand.
    pub u_lower: f64,
    /// Upper 95 % bound `U₊` (97.5 % order statistic).
    pub u_upper: f64,
    /// `σ̂_ε = max(|U₋|, |U₊|)/1.96` (eq. 41).
    pub sigma_eps: f64,
    /// Sample mean of `ε`.
    pub mean: f64,
    /// Sample standard deviation of `ε` (`M − 1` denominator).
    pub std: f64,
    /// Number of finite errors used.
    pub used: usize,
    /// Draws where `f` returned a non-finite value (left out of every statistic).
    pub non_finite: usize,
}

impl McResult {
    /// `σ̂_ε²`, the last diagonal entry `W_T(n_θ+1, n_θ+1)` of eq. 41 (unit of the measurand squared).
    pub fn w_t_entry(&self) -> f64 {
        self.sigma_eps * self.sigma_eps
    }
}

/// Standard normal CDF `Φ(x) = ½ erfc(−x/√2)`.
pub fn phi(x: f64) -> f64 {
    0.5 * libm::erfc(-x * std::f64::consts::FRAC_1_SQRT_2)
}

/// Lower Cholesky factor of a symmetric positive-semidefinite row-major `n × n` matrix. A pivot
/// that is zero to within `1e-12` of the diagonal's scale gives a zero column (its variable is a
/// combination of earlier ones, or exact), provided the rest of that column is zero to the same
/// tolerance. `None` if the matrix is not symmetric or not semidefinite.
pub fn psd_cholesky(a: &[f64], n: usize) -> Option<Vec<f64>> {
    if a.len() != n * n {
        return None;
    }
    let scale = (0..n)
        .map(|i| a[i * n + i].abs())
        .fold(0.0_f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let tol = 1e-12 * scale;
    for i in 0..n {
        for j in 0..i {
            if (a[i * n + j] - a[j * n + i]).abs() > tol || !a[i * n + j].is_finite() {
                return None;
            }
        }
    }
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let d = a[j * n + j] - (0..j).map(|k| l[j * n + k] * l[j * n + k]).sum::<f64>();
        if d > tol {
            let ljj = d.sqrt();
            l[j * n + j] = ljj;
            for i in j + 1..n {
                let s = a[i * n + j] - (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum::<f64>();
                l[i * n + j] = s / ljj;
            }
        } else if d >= -tol {
            for i in j + 1..n {
                let s = a[i * n + j] - (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum::<f64>();
                if s.abs() > 1e-9 * scale {
                    return None;
                }
            }
        } else {
            return None;
        }
    }
    Some(l)
}

/// The checked, factorised problem; draws inputs and errors.
#[derive(Debug, Clone)]
pub struct Sampler {
    n: usize,
    lower: Vec<f64>,
    width: Vec<f64>,
    relative: Vec<bool>,
    l_corr: Vec<f64>,
    l_err: Vec<f64>,
}

impl Sampler {
    /// Checks and factorises a problem.
    pub fn new(problem: &Problem) -> Result<Self, McError> {
        let n = problem.len();
        if n == 0 || problem.input_corr.len() != n * n || problem.error_cov.len() != n * n {
            return Err(McError::Dimension);
        }
        for (j, inp) in problem.inputs.iter().enumerate() {
            let [lo, hi] = inp.range;
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(McError::BadRange(j));
            }
        }
        let r = &problem.input_corr;
        for i in 0..n {
            if (r[i * n + i] - 1.0).abs() > 1e-12 {
                return Err(McError::NotCorrelation);
            }
            for j in 0..i {
                if (r[i * n + j] - r[j * n + i]).abs() > 1e-12 || r[i * n + j].abs() > 1.0 {
                    return Err(McError::NotCorrelation);
                }
            }
        }
        let l_corr = psd_cholesky(r, n).ok_or(McError::CorrNotPositiveDefinite)?;
        if (0..n).any(|j| l_corr[j * n + j] <= 0.0) {
            return Err(McError::CorrNotPositiveDefinite);
        }
        let l_err = psd_cholesky(&problem.error_cov, n).ok_or(McError::ErrorCovNotPsd)?;
        Ok(Self {
            n,
            lower: problem.inputs.iter().map(|i| i.range[0]).collect(),
            width: problem.inputs.iter().map(|i| i.range[1] - i.range[0]).collect(),
            relative: problem
                .inputs
                .iter()
                .map(|i| i.error_kind == ErrorKind::Relative)
                .collect(),
            l_corr,
            l_err,
        })
    }

    /// Number of inputs.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Draws one copula point (eq. 36–37) into `u` (each `U(0,1)`), using `z` as scratch.
    pub fn draw_uniform<R: rand::Rng>(&self, rng: &mut R, z: &mut [f64], u: &mut [f64]) {
        let n = self.n;
        for zj in z.iter_mut() {
            *zj = StandardNormal.sample(rng);
        }
        for i in 0..n {
            let y: f64 = (0..=i).map(|k| self.l_corr[i * n + k] * z[k]).sum();
            u[i] = phi(y);
        }
    }

    /// Draws one input point `ξ` (eq. 36–38) and its measured counterpart `ξ + Δξ` (eq. 39).
    pub fn draw<R: rand::Rng>(&self, rng: &mut R, z: &mut [f64], xi: &mut [f64], xi_meas: &mut [f64]) {
        let n = self.n;
        self.draw_uniform(rng, z, xi);
        for j in 0..n {
            xi[j] = self.lower[j] + self.width[j] * xi[j];
        }
        for zj in z.iter_mut() {
            *zj = StandardNormal.sample(rng);
        }
        for i in 0..n {
            let d: f64 = (0..=i).map(|k| self.l_err[i * n + k] * z[k]).sum();
            xi_meas[i] = if self.relative[i] { xi[i] * (1.0 + d) } else { xi[i] + d };
        }
    }
}

/// Runs the Monte Carlo of eq. 35–41 for the measurand `f`.
///
/// Uses the current rayon pool (run inside `ThreadPool::install` to choose the thread count).
pub fn run<F>(problem: &Problem, settings: &McSettings, f: F) -> Result<McResult, McError>
where
    F: Fn(&[f64]) -> f64 + Sync,
{
    let sampler = Sampler::new(problem)?;
    let eps = errors(&sampler, settings, &f)?;
    summarise(eps)
}

/// The raw errors `ε` of eq. 35, in chunk order (non-finite ones included).
pub fn errors<F>(sampler: &Sampler, settings: &McSettings, f: &F) -> Result<Vec<f64>, McError>
where
    F: Fn(&[f64]) -> f64 + Sync,
{
    if settings.draws == 0 || settings.chunk_size == 0 {
        return Err(McError::TooFewDraws);
    }
    let n = sampler.dim();
    let n_chunks = settings.draws.div_ceil(settings.chunk_size);
    let bar = if settings.progress && std::io::stderr().is_terminal() {
        let bar = ProgressBar::with_draw_target(Some(n_chunks as u64), ProgressDrawTarget::stderr());
        if let Ok(style) = ProgressStyle::with_template("Monte Carlo {bar:40} {pos}/{len} chunks, eta {eta}") {
            bar.set_style(style);
        }
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut eps = vec![0.0; settings.draws];
    eps.par_chunks_mut(settings.chunk_size)
        .enumerate()
        .for_each(|(c, out)| {
            let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
            rng.set_stream(c as u64);
            let mut z = vec![0.0; n];
            let mut xi = vec![0.0; n];
            let mut xi_meas = vec![0.0; n];
            for e in out.iter_mut() {
                sampler.draw(&mut rng, &mut z, &mut xi, &mut xi_meas);
                *e = f(&xi) - f(&xi_meas);
            }
            bar.inc(1);
        });
    bar.finish_and_clear();
    Ok(eps)
}

/// Statistics of eq. 40–41 from raw errors (non-finite values are counted and dropped).
pub fn summarise(mut eps: Vec<f64>) -> Result<McResult, McError> {
    let total = eps.len();
    eps.retain(|e| e.is_finite());
    let m = eps.len();
    if m < 40 {
        return Err(McError::TooFewDraws);
    }
    let mean = eps.iter().sum::<f64>() / m as f64;
    let var = eps.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / (m - 1) as f64;
    let (u_lower, u_upper) = coverage_bounds(&mut eps, 0.025, 0.975);
    Ok(McResult {
        u_lower,
        u_upper,
        sigma_eps: u_lower.abs().max(u_upper.abs()) / 1.96,
        mean,
        std: var.sqrt(),
        used: m,
        non_finite: total - m,
    })
}

/// The 1-based order statistics `k = ⌈p M⌉` for `p_lo < p_hi`, by two selections (reorders `x`).
/// `x` must be non-empty and free of NaN.
pub fn coverage_bounds(x: &mut [f64], p_lo: f64, p_hi: f64) -> (f64, f64) {
    let m = x.len();
    let k = |p: f64| ((p * m as f64).ceil() as usize).clamp(1, m) - 1;
    let (k_lo, k_hi) = (k(p_lo), k(p_hi));
    let (_, hi, _) = x.select_nth_unstable_by(k_hi, f64::total_cmp);
    let hi = *hi;
    let (_, lo, _) = x[..=k_hi].select_nth_unstable_by(k_lo, f64::total_cmp);
    (*lo, hi)
}

/// First-order (Taylor) propagation at `x0`: `σ = (gᵀ Σ_ΔΞ g)^{1/2}` with `g` the central
/// finite-difference gradient of `f` (step `h_j = 10⁻³·σ_j` of each input's own error, and the
/// chain-rule factor `x0_j` for a relative error). Inputs with zero error variance are skipped.
pub fn taylor_sigma<F>(problem: &Problem, x0: &[f64], f: &F) -> f64
where
    F: Fn(&[f64]) -> f64,
{
    let n = problem.len();
    let g = gradient_in_error_units(problem, x0, f);
    let c = &problem.error_cov;
    let mut v = 0.0;
    for i in 0..n {
        for j in 0..n {
            v += g[i] * c[i * n + j] * g[j];
        }
    }
    v.max(0.0).sqrt()
}

/// `∂f/∂Δξ_j` at `x0` (central differences, step `10⁻³ σ_j`); zero where `σ_j = 0`.
pub fn gradient_in_error_units<F>(problem: &Problem, x0: &[f64], f: &F) -> Vec<f64>
where
    F: Fn(&[f64]) -> f64,
{
    let n = problem.len();
    let mut x = x0.to_vec();
    (0..n)
        .map(|j| {
            let s = problem.error_cov[j * n + j].max(0.0).sqrt();
            if s == 0.0 {
                return 0.0;
            }
            let h = 1e-3 * s;
            let (dp, dm) = match problem.inputs[j].error_kind {
                ErrorKind::Absolute => (x0[j] + h, x0[j] - h),
                ErrorKind::Relative => (x0[j] * (1.0 + h), x0[j] * (1.0 - h)),
            };
            x[j] = dp;
            let fp = f(&x);
            x[j] = dm;
            let fm = f(&x);
            x[j] = x0[j];
            (fp - fm) / (2.0 * h)
        })
        .collect()
}

/// The local-linearisation *mixture* prediction of `σ̂_ε` (eq. 41): at each of `samples` copula
/// points `ξ` the error is taken as `N(0, σ(ξ)²)` with `σ(ξ)` from [`taylor_sigma`]; the 97.5 %
/// quantile `q` of that mixture solves `mean_ξ Φ(q/σ(ξ)) = 0.975` (symmetric, so it is also
/// `−U₋`), and the prediction is `q/1.96`. This separates the two ways the MC differs from a single
/// Taylor value: variation of the sensitivity over the range (captured here) and curvature within
/// one error draw (not captured). Sequential, seeded.
pub fn taylor_mixture_sigma<F>(problem: &Problem, samples: usize, seed: u64, f: &F) -> Result<f64, McError>
where
    F: Fn(&[f64]) -> f64,
{
    let sampler = Sampler::new(problem)?;
    let n = sampler.dim();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut z, mut xi, mut scratch) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut sig = Vec::with_capacity(samples);
    for _ in 0..samples {
        sampler.draw(&mut rng, &mut z, &mut xi, &mut scratch);
        let s = taylor_sigma(problem, &xi, f);
        if s.is_finite() {
            sig.push(s);
        }
    }
    if sig.is_empty() {
        return Err(McError::TooFewDraws);
    }
    let cdf = |q: f64| sig.iter().map(|&s| if s > 0.0 { phi(q / s) } else { 1.0 }).sum::<f64>() / sig.len() as f64;
    let (mut lo, mut hi) = (
        0.0,
        1.96 * sig.iter().fold(0.0_f64, |a, &b| a.max(b)) * 2.0 + f64::MIN_POSITIVE,
    );
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < 0.975 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi) / 1.96)
}
