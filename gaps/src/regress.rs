//! Least squares, its parameter covariance under coloured residuals, the fit metrics and the partial
//! test that ranks candidate terms.
//!
//! * **Estimator**: ordinary least squares by a QR factorisation of the column-scaled regressor
//!   matrix (equation-error, Klein & Morelli 2006 §5.1, eq. 5.8).
//! * **Covariance with coloured residuals** (Morelli & Klein 1997; Klein & Morelli §5.2.4,
//!   eq. 5.67–5.70): `Cov θ̂ = (XᵀX)⁻¹ [Σᵢ Σⱼ xᵢ R_vv(i−j) xⱼᵀ] (XᵀX)⁻¹` with the residual
//!   autocorrelation `R_vv(k) = (1/N) Σ v(i) v(i+k)` truncated at `max_lag` samples. For one
//!   parameter `j` this is `Σ_k R_vv(k) Σᵢ wᵢ w_{i+k}` with `w = X (XᵀX)⁻¹ e_j`. Smoothing and
//!   model errors make equation-error residuals coloured; the white-noise formula would then
//!   overstate the significance of every candidate (and clean flights would "find" causes).
//! * **Metrics**: `R² = 1 − Σv²/Σ(z − z̄)²`, `RMS = √(Σv²/N)`, and Morelli's predicted squared
//!   error (Klein & Morelli §5.4.2, eq. 5.90–5.92; Morelli 1995):
//!   `PSE = (1/N) Σv² + σ²_max · p/N` with `σ²_max = (1/N) Σ(z − z̄)²` — the fit error plus a
//!   penalty per parameter set by an upper bound on the noise variance (the output's own variance).
//! * **Partial test** of a candidate column `c` added to `X`: `t² = (θ̂_c/σ_c)²` with `σ_c` from the
//!   coloured-residual covariance of the extended fit. With white residuals this is the partial
//!   `F(1, N−p−1)` of stepwise regression (Klein & Morelli §5.4.1, eq. 5.85); for large `N`,
//!   `t² ~ χ²₁` under the null.

use nalgebra::{DMatrix, DVector};

/// One least-squares fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Estimates, one per column.
    pub theta: Vec<f64>,
    /// Standard errors from the coloured-residual covariance.
    pub sigma: Vec<f64>,
    /// Residuals `z − Xθ̂`.
    pub residual: Vec<f64>,
}

/// Fit metrics of a model on some data.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Metrics {
    /// Coefficient of determination `1 − Σv²/Σ(z−z̄)²`.
    pub r2: f64,
    /// Root mean square of the residuals (output units).
    pub rms: f64,
    /// Morelli's predicted squared error (output units squared); on held-out data, the penalty
    /// uses the held-out output's variance.
    pub pse: f64,
    /// Number of samples.
    pub n: usize,
}

/// Metrics of prediction `zhat` against `z` for a model of `p` parameters.
pub fn metrics(z: &[f64], zhat: &[f64], p: usize) -> Metrics {
    let n = z.len().max(1);
    let zbar = super::signal::mean(z);
    let tss: f64 = z.iter().map(|v| (v - zbar) * (v - zbar)).sum();
    let rss: f64 = z.iter().zip(zhat).map(|(a, b)| (a - b) * (a - b)).sum();
    let nf = n as f64;
    Metrics {
        r2: if tss > 0.0 { 1.0 - rss / tss } else { f64::NAN },
        rms: (rss / nf).sqrt(),
        pse: rss / nf + (tss / nf) * p as f64 / nf,
        n: z.len(),
    }
}

/// `X θ`, with `X` given as columns.
pub fn predict(cols: &[Vec<f64>], theta: &[f64]) -> Vec<f64> {
    let n = cols.first().map_or(0, |c| c.len());
    (0..n)
        .map(|i| cols.iter().zip(theta).map(|(c, t)| c[i] * t).sum())
        .collect()
}

/// The sum over blocks of `Σ_{|k|≤L} R_vv(k) Σᵢ wᵢ w_{i+k}` (lags never cross a block boundary;
/// `R_vv` estimated per block with divisor `N_block`), each block's sum floored at its lag-0 term.
/// One weight series; [`ResidualLags`] shares the residual's part between many.
pub fn coloured_variance(w: &[f64], v: &[f64], block_len: usize, max_lag: usize) -> f64 {
    ResidualLags::new(v, block_len, max_lag).variance(w)
}

/// Below this many lags a block's lag sums are computed directly (`O(N·L)`), above by FFT
/// (`O(N log N)`): at 32 lags the direct sums cost about as much as two transforms of the block.
const DIRECT_MAX_LAG: usize = 32;

/// The residual's share of [`coloured_variance`], computed once for every weight series of a fit
/// (the sandwich needs one per parameter, all against the same residual).
///
/// **Method** (why not the direct lag sums): with the 5 s lags of the analysis (500 samples at
/// 100 Hz) the direct sums cost `N·L` products per series and were the largest single cost of the
/// analysis. The autocorrelation of a block zero-padded to `M ≥ N_b + L` is the inverse FFT of its
/// power spectrum (Wiener–Khinchin, no circular wrap for lags up to `L`), `O(M log M)`. When every
/// lag of the block is summed (`L = N_b − 1`, the compatibility check's blocks) no inverse is
/// needed: by Parseval `Σ_{|k|<N_b} r_v(k) r_w(k) = (1/M) Σ_f |V_f|² |W_f|²`. The results equal the
/// direct sums to rounding (`tests::the_fft_lag_sums_equal_the_direct_ones`).
pub struct ResidualLags {
    blocks: Vec<BlockLags>,
}

struct BlockLags {
    start: usize,
    end: usize,
    lmax: usize,
    /// FFT length (0: direct sums).
    m: usize,
    /// `R_vv(k)`, `k = 0..=lmax` (divisor `N_block`).
    r_v: Vec<f64>,
    /// `|V_f|²` of the zero-padded block, when every lag is summed.
    power: Option<Vec<f64>>,
}

type Complex = realfft::num_complex::Complex<f64>;

/// The FFT plans and the transforms' buffers of one thread, reused across calls: planning costs
/// more than a transform, and the lag sums of a fit run many transforms of one length, whose
/// buffers (the padded input, the spectrum, the scratch) need not be allocated each time.
#[derive(Default)]
struct Transforms {
    planner: realfft::RealFftPlanner<f64>,
    real: Vec<f64>,
    spectrum: Vec<Complex>,
    scratch: Vec<Complex>,
}

impl Transforms {
    /// `|X_f|²` of `x` zero-padded to `m` (`m/2 + 1` bins).
    fn power_spectrum(&mut self, x: &[f64], m: usize) -> Vec<f64> {
        let fft = self.planner.plan_fft_forward(m);
        self.real.clear();
        self.real.extend_from_slice(x);
        self.real.resize(m, 0.0);
        self.spectrum.resize(m / 2 + 1, Complex::default());
        self.scratch
            .resize(fft.get_scratch_len().max(self.scratch.len()), Complex::default());
        let scratch = &mut self.scratch[..fft.get_scratch_len()];
        // The lengths are the plan's own: the transform cannot fail.
        if fft
            .process_with_scratch(&mut self.real, &mut self.spectrum[..m / 2 + 1], scratch)
            .is_err()
        {
            return vec![f64::NAN; m / 2 + 1];
        }
        self.spectrum[..m / 2 + 1].iter().map(|c| c.norm_sqr()).collect()
    }

    /// `Σᵢ xᵢ xᵢ₊ₖ`, `k = 0..=lmax`, from the power spectrum of `x` zero-padded to `m ≥ len + lmax`.
    fn autocorrelation(&mut self, power: &[f64], m: usize, lmax: usize) -> Vec<f64> {
        let ifft = self.planner.plan_fft_inverse(m);
        self.spectrum.clear();
        self.spectrum.extend(power.iter().map(|&x| Complex::new(x, 0.0)));
        self.real.resize(m, 0.0);
        self.scratch
            .resize(ifft.get_scratch_len().max(self.scratch.len()), Complex::default());
        let scratch = &mut self.scratch[..ifft.get_scratch_len()];
        if ifft
            .process_with_scratch(&mut self.spectrum, &mut self.real[..m], scratch)
            .is_err()
        {
            return vec![f64::NAN; lmax + 1];
        }
        self.real[..=lmax].iter().map(|x| x / m as f64).collect()
    }
}

thread_local! {
    static TRANSFORMS: std::cell::RefCell<Transforms> = std::cell::RefCell::new(Transforms::default());
}

/// [`Transforms::power_spectrum`] on this thread's plans and buffers.
fn power_spectrum(x: &[f64], m: usize) -> Vec<f64> {
    TRANSFORMS.with(|t| t.borrow_mut().power_spectrum(x, m))
}

/// [`Transforms::autocorrelation`] on this thread's plans and buffers.
fn autocorrelation(power: &[f64], m: usize, lmax: usize) -> Vec<f64> {
    TRANSFORMS.with(|t| t.borrow_mut().autocorrelation(power, m, lmax))
}

/// `Σᵢ xᵢ xᵢ₊ₖ`, `k = 0..=lmax` (`lmax < x.len()`): direct sums for short lags, else by FFT of `x`
/// zero-padded past `len + lmax` (equal to the direct sums to rounding).
pub fn lag_sums(x: &[f64], lmax: usize) -> Vec<f64> {
    let lmax = lmax.min(x.len().saturating_sub(1));
    if x.is_empty() {
        return Vec::new();
    }
    if lmax < DIRECT_MAX_LAG {
        return (0..=lmax).map(|k| lagged_products(x, x, k).0).collect();
    }
    let m = (x.len() + lmax).next_power_of_two().max(2);
    autocorrelation(&power_spectrum(x, m), m, lmax)
}

/// `Σ_f c_f a_f b_f` over the full spectrum of a real series of even length `m` from its `m/2 + 1`
/// bins (the others mirror them), divided by `m`: Parseval's `Σ_k` over every circular lag.
fn parseval(a: &[f64], b: &[f64], m: usize) -> f64 {
    let last = a.len() - 1;
    let inner: f64 = a[1..last].iter().zip(&b[1..last]).map(|(x, y)| x * y).sum();
    (a[0] * b[0] + a[last] * b[last] + 2.0 * inner) / m as f64
}

impl ResidualLags {
    /// The residual `v`'s lag sums per block of `block_len`, up to `max_lag`.
    pub fn new(v: &[f64], block_len: usize, max_lag: usize) -> Self {
        let n = v.len();
        let bl = block_len.max(1);
        let mut blocks = Vec::new();
        let mut start = 0;
        while start < n {
            let end = (start + bl).min(n);
            let vb = &v[start..end];
            let nb = vb.len();
            let lmax = max_lag.min(nb.saturating_sub(1));
            let b = if lmax < DIRECT_MAX_LAG {
                let r_v = (0..=lmax).map(|k| lagged_products(vb, vb, k).0 / nb as f64).collect();
                BlockLags {
                    start,
                    end,
                    lmax,
                    m: 0,
                    r_v,
                    power: None,
                }
            } else {
                // Even, and long enough that lags up to `lmax` do not wrap.
                let m = (nb + lmax).next_power_of_two().max(2);
                let pv = power_spectrum(vb, m);
                let r_v = autocorrelation(&pv, m, lmax).iter().map(|x| x / nb as f64).collect();
                BlockLags {
                    start,
                    end,
                    lmax,
                    m,
                    r_v,
                    power: (lmax + 1 == nb).then_some(pv),
                }
            };
            blocks.push(b);
            start = end;
        }
        Self { blocks }
    }

    /// [`coloured_variance`] of the weight series `w` (the residual's length).
    pub fn variance(&self, w: &[f64]) -> f64 {
        let mut total = 0.0;
        for b in &self.blocks {
            let Some(wb) = w.get(b.start..b.end) else {
                return f64::NAN;
            };
            let nb = (b.end - b.start) as f64;
            let ww0 = lagged_products(wb, wb, 0).0;
            let white = b.r_v[0] * ww0;
            let block = if b.m == 0 {
                white
                    + (1..=b.lmax)
                        .map(|k| 2.0 * b.r_v[k] * lagged_products(wb, wb, k).0)
                        .sum::<f64>()
            } else {
                let pw = power_spectrum(wb, b.m);
                match &b.power {
                    // Every lag: Parseval, no inverse transform.
                    Some(pv) => parseval(pv, &pw, b.m) / nb,
                    None => {
                        let r_w = autocorrelation(&pw, b.m, b.lmax);
                        white + (1..=b.lmax).map(|k| 2.0 * b.r_v[k] * r_w[k]).sum::<f64>()
                    }
                }
            };
            // Floor: never below the white-residual variance. The autocorrelation of *fitted*
            // residuals is biased low at long lags (the fit absorbs their slow part: for the
            // intercept the sum over all lags of a zero-mean residual's autocorrelation is zero),
            // so a truncated sum below its lag-0 term is an estimation artefact, not a real
            // negative correlation.
            total += block.max(white);
        }
        total.max(0.0)
    }
}

/// Manoeuvre-level sandwich standard errors of a pooled fit, bias-reduced for few manoeuvres: the
/// estimate `theta` of `z` on `cols` under the errors-in-variables model `eiv` ([`corrected_ls`]:
/// the PCA-GTLS solution in closed form; OLS when every column is exact), the manoeuvres `ranges`
/// (`G` disjoint sample ranges) its independent clusters.
///
/// `Cov θ̂ = H⁻¹ [Σ_g ψ_g ψ_gᵀ] H⁻¹` with `H = XᵀX − N W̃` (the corrected estimator's Jacobian) and
/// the manoeuvre's score `ψ_g = X_gᵀ A_g r_g − n_g (w̃ − W̃θ̂)`, `r_g` its residuals and
/// `A_g = (I − X_g (XᵀX)⁻¹ X_gᵀ)^{−1/2}`: the CR2 bias-reduced linearisation (Bell & McCaffrey
/// 2002, "Bias reduction in standard errors for linear regression with multi-stage samples",
/// Survey Methodology 28(2), eq. 3.3; Cameron & Miller 2015, J. Human Resources 50(2), §VI.B;
/// Imbens & Kolesár 2016 recommend it for few clusters). With every column exact it is the CR2 of
/// OLS, unbiased when the residuals are independent between manoeuvres with a common covariance.
/// **Reading chosen** for the corrected (PCA-GTLS) fits, which Bell & McCaffrey do not treat: the
/// leverage `A_g` is the regressors' own (`XᵀX`), the bread the corrected estimator's `H`.
///
/// `A_g` is formed in the parameter space: with `XᵀX = LLᵀ` and `B_g = L⁻¹X_gᵀX_g L⁻ᵀ`
/// (eigenvalues `λ ∈ [0, 1)`, the manoeuvre's share of the information along each direction),
/// `X_gᵀ A_g r_g = L (I − B_g)^{−1/2} L⁻¹ X_gᵀ r_g`.
///
/// **Why not the lag sums, the score sum (CR1) or the jackknife (CR3).** On pooled manoeuvres of
/// 5–10 s the residual carries the flow-angle estimate's error (a lagged wind: correlated for
/// longer than a manoeuvre) and turbulence, and a term is often excited mostly by one manoeuvre.
/// Lag sums truncated at `max_lag` miss the slow part. For a manoeuvre that holds a share `λ` of
/// a term's information, the expected contribution to the variance is `λ` (of the white-residual
/// variance); CR1 gives `λ(1 − λ)` (the fit passes through that manoeuvre: biased low), the
/// leave-one-manoeuvre-out jackknife `λ/(1 − λ)` (biased high: 4 instead of 0.8 at `λ = 0.8`,
/// σ twice the scatter), CR2 `λ` exactly. Measured on 40 pooled test cards: docs/model-gaps.md
/// ("Standard errors of pooled fits").
///
/// `None` when there are fewer than [`MANOEUVRE_SANDWICH_MIN`] ranges, a range is empty or out of
/// bounds, the columns are dependent, `H` is singular, or one manoeuvre carries a direction alone
/// (`λ > 1 − 1e-9`: the others do not determine it, so nothing tells its scatter): the caller
/// keeps its σ.
pub fn manoeuvre_sandwich(
    cols: &[Vec<f64>],
    z: &[f64],
    theta: &[f64],
    eiv: &EivModel,
    ranges: &[(usize, usize)],
) -> Option<Vec<f64>> {
    let p = cols.len();
    let n = z.len();
    let noisy: Vec<usize> = (0..p).filter(|&j| !eiv.exact[j]).collect();
    let nx = noisy.len();
    if ranges.len() < MANOEUVRE_SANDWICH_MIN
        || ranges.iter().any(|&(a, b)| a >= b || b > n)
        || p == 0
        || theta.len() != p
        || eiv.exact.len() != p
        || eiv.w_xx.len() != nx * nx
        || eiv.w_xz.len() != nx
        || cols.iter().any(|c| c.len() != n)
    {
        return None;
    }
    // Scaled columns (conditioning); the σ are scaled back at the end.
    let scale = column_scales(cols, n)?;
    let residual = residual_of(cols, z, theta);
    let gram = |a: usize, b: usize| -> DMatrix<f64> {
        DMatrix::from_fn(p, p, |r, c| {
            super::signal::dot(&cols[r][a..b], &cols[c][a..b]) / (scale[r] * scale[c])
        })
    };
    let xtx = gram(0, n);
    let l = xtx.clone().cholesky()?.l();
    let mut h = xtx;
    // The per-sample bias correction `w̃ − W̃θ̂` of the corrected estimator (scaled).
    let mut corr = DVector::<f64>::zeros(p);
    for (kr, &r) in noisy.iter().enumerate() {
        let mut c = eiv.w_xz[kr];
        for (kc, &cc) in noisy.iter().enumerate() {
            h[(r, cc)] -= n as f64 * eiv.w_xx[kr * nx + kc] / (scale[r] * scale[cc]);
            c -= eiv.w_xx[kr * nx + kc] * theta[cc];
        }
        corr[r] = c / scale[r];
    }
    let hinv = h.try_inverse()?;
    let mut meat = DMatrix::<f64>::zeros(p, p);
    for &(a, b) in ranges {
        let score = DVector::from_fn(p, |j, _| super::signal::dot(&cols[j][a..b], &residual[a..b]) / scale[j]);
        let psi = cr2_score(&l, &gram(a, b), &score)? - corr.scale((b - a) as f64);
        meat += &psi * psi.transpose();
    }
    let cov = &hinv * meat * hinv.transpose();
    let sigma: Vec<f64> = (0..p).map(|j| cov[(j, j)].max(0.0).sqrt() / scale[j]).collect();
    sigma.iter().all(|s| s.is_finite()).then_some(sigma)
}

/// A cluster's score with the CR2 bias reduction ([`manoeuvre_sandwich`]): `L (I − B_g)^{−1/2} L⁻¹ s_g`
/// with `L` the lower Cholesky factor of the whole information (`XᵀX`, or `Σ HᵀWH` of an output
/// error fit), `B_g = L⁻¹ M_g L⁻ᵀ` (`M_g`: the cluster's part of it) and `s_g` the cluster's score.
/// `None` when the cluster carries a direction alone (an eigenvalue of `B_g` above `1 − 1e-9`).
pub(crate) fn cr2_score(l: &DMatrix<f64>, gram_g: &DMatrix<f64>, score: &DVector<f64>) -> Option<DVector<f64>> {
    let p = score.len();
    let m = l.solve_lower_triangular(score)?;
    let lb = l.solve_lower_triangular(gram_g)?;
    let bg = l.solve_lower_triangular(&lb.transpose())?;
    let eig = nalgebra::SymmetricEigen::new(0.5 * (&bg + bg.transpose()));
    if eig.eigenvalues.iter().any(|&v| v.is_nan() || v >= 1.0 - 1e-9) {
        return None;
    }
    let d = DVector::from_fn(p, |k, _| (1.0 - eig.eigenvalues[k].max(0.0)).powf(-0.5));
    let v = &eig.eigenvectors;
    Some(l * (v * d.component_mul(&(v.transpose() * m))))
}

/// Fewest manoeuvres for [`manoeuvre_sandwich`] (as for holding out whole manoeuvres: with two,
/// the sandwich has one degree of freedom per direction).
pub const MANOEUVRE_SANDWICH_MIN: usize = 3;

/// `(Σᵢ vᵢ vᵢ₊ₖ, Σᵢ wᵢ wᵢ₊ₖ)` in one pass with four partial sums (the hot loop of the analysis:
/// independent accumulators let the compiler use vector instructions).
fn lagged_products(v: &[f64], w: &[f64], k: usize) -> (f64, f64) {
    let m = v.len().saturating_sub(k);
    let (v0, v1, w0, w1) = (&v[..m], &v[k..k + m], &w[..m], &w[k..k + m]);
    let mut a = [0.0f64; 4];
    let mut b = [0.0f64; 4];
    let chunks = m / 4;
    for c in 0..chunks {
        let i = 4 * c;
        for j in 0..4 {
            a[j] += v0[i + j] * v1[i + j];
            b[j] += w0[i + j] * w1[i + j];
        }
    }
    let (mut sa, mut sb) = ((a[0] + a[1]) + (a[2] + a[3]), (b[0] + b[1]) + (b[2] + b[3]));
    for i in 4 * chunks..m {
        sa += v0[i] * v1[i];
        sb += w0[i] * w1[i];
    }
    (sa, sb)
}

/// OLS of `z` on the columns `cols` with coloured-residual standard errors (`block_len`: length of
/// each independent block of stacked data, `z.len()` for a single series). `None` when the columns
/// are (numerically) dependent: a column whose part orthogonal to the others is below `1e-9` of its
/// own norm.
pub fn ols(cols: &[Vec<f64>], z: &[f64], block_len: usize, max_lag: usize) -> Option<Fit> {
    ols_sigma(cols, z, block_len, max_lag, None)
}

/// Every column of `cols` but column `k` (copied): the other regressors, beyond which a column's
/// own part is taken (a partial variance, a partial residual).
pub fn without(cols: &[Vec<f64>], k: usize) -> Vec<Vec<f64>> {
    cols.iter()
        .enumerate()
        .filter(|(j, _)| *j != k)
        .map(|(_, c)| c.clone())
        .collect()
}

/// [`ols`]'s estimates alone (no residual, no σ): for the Gauss–Newton steps, which need nothing
/// else. `None` as [`ols`].
pub fn ols_theta(cols: &[Vec<f64>], z: &[f64]) -> Option<Vec<f64>> {
    let n = z.len();
    let p = cols.len();
    if p == 0 || n <= p || cols.iter().any(|c| c.len() != n) {
        return None;
    }
    let ScaledQr { qr, r, scale, .. } = ScaledQr::new(cols, n)?;
    let mut qtz = DVector::from_column_slice(z);
    qr.q_tr_mul(&mut qtz);
    let ts = r.solve_upper_triangular(&qtz.rows(0, p).into_owned())?;
    Some((0..p).map(|j| ts[j] / scale[j]).collect())
}

/// The column scales (RMS) of `cols`, each of length `n`; `None` if one is zero or not finite.
/// Every fit scales its columns by them for conditioning.
pub(super) fn column_scales(cols: &[Vec<f64>], n: usize) -> Option<Vec<f64>> {
    let scale: Vec<f64> = cols
        .iter()
        .map(|c| (c.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt())
        .collect();
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    Some(scale)
}

/// The thin QR of the column-scaled matrix `X` (column `j` of `cols` over its RMS), refused
/// (`None`) when a column's part orthogonal to the others is below `1e-9` of the largest `|R_ii|`:
/// the dependence test shared by [`ols`], [`ols_theta`] and [`Basis`].
struct ScaledQr {
    /// The scaled columns, when asked for (`new_keeping_x`): only the residual needs them.
    x: Option<DMatrix<f64>>,
    qr: nalgebra::linalg::QR<f64, nalgebra::Dyn, nalgebra::Dyn>,
    r: DMatrix<f64>,
    scale: Vec<f64>,
    rdiag_max: f64,
}

impl ScaledQr {
    fn new(cols: &[Vec<f64>], n: usize) -> Option<Self> {
        Self::factor(cols, n, false)
    }

    fn new_keeping_x(cols: &[Vec<f64>], n: usize) -> Option<Self> {
        Self::factor(cols, n, true)
    }

    fn factor(cols: &[Vec<f64>], n: usize, keep_x: bool) -> Option<Self> {
        let p = cols.len();
        let scale = column_scales(cols, n)?;
        let x = DMatrix::from_fn(n, p, |i, j| cols[j][i] / scale[j]);
        let (x, qr) = if keep_x {
            (Some(x.clone()), x.qr())
        } else {
            (None, x.qr())
        };
        let r = qr.r();
        let rdiag_max = (0..p).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
        if (0..p).any(|i| r[(i, i)].abs() < 1e-9 * rdiag_max.max(1e-300)) {
            return None;
        }
        Some(Self {
            x,
            qr,
            r,
            scale,
            rdiag_max,
        })
    }
}

/// Which coloured-residual standard errors a fit computes: every parameter's, one parameter's (the
/// others NaN), or none (all NaN: the estimates and the residual alone, without the lag sums that
/// are most of a fit's cost).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sigmas {
    All,
    Only(usize),
    None,
}

impl Sigmas {
    /// Every parameter's, or `only`'s when given.
    fn of(only: Option<usize>) -> Self {
        only.map_or(Self::All, Self::Only)
    }

    /// The one parameter asked for, if only one is (`sandwich_sigma`'s `only`).
    fn only(self) -> Option<usize> {
        match self {
            Self::Only(k) => Some(k),
            _ => None,
        }
    }

    fn wants(self, j: usize) -> bool {
        match self {
            Self::All => true,
            Self::Only(k) => k == j,
            Self::None => false,
        }
    }
}

/// [`ols`], with the coloured-residual σ computed only for parameter `only` when given (the
/// others are then NaN): the partial test needs only the candidate's.
pub fn ols_sigma(cols: &[Vec<f64>], z: &[f64], block_len: usize, max_lag: usize, only: Option<usize>) -> Option<Fit> {
    ols_with(cols, z, block_len, max_lag, Sigmas::of(only))
}

/// [`ols`]'s estimates and residual, equal to its own to the bit, without its standard errors
/// (NaN): for a caller that reports the estimates alone. (`ols_theta` applies the reflections
/// to `z` instead of forming `Q`: equal to rounding, not to the bit.)
pub fn ols_estimates(cols: &[Vec<f64>], z: &[f64]) -> Option<Fit> {
    ols_with(cols, z, z.len(), 0, Sigmas::None)
}

/// [`ols`] with the standard errors `sigmas`.
fn ols_with(cols: &[Vec<f64>], z: &[f64], block_len: usize, max_lag: usize, sigmas: Sigmas) -> Option<Fit> {
    let n = z.len();
    let p = cols.len();
    if p == 0 || n <= p || cols.iter().any(|c| c.len() != n) {
        return None;
    }
    let ScaledQr { x, qr, r, scale, .. } = ScaledQr::new_keeping_x(cols, n)?;
    let x = x?;
    // Q formed once: for `Qᵀz` and for the weight series below.
    let q = qr.q();
    let qtz = q.transpose() * DVector::from_column_slice(z);
    let ts = r.solve_upper_triangular(&qtz)?;
    let x_cols: Vec<&[f64]> = x.as_slice().chunks_exact(n).collect();
    let residual = residual_of(&x_cols, z, ts.as_slice());
    // W = X (XᵀX)⁻¹ = Q R⁻ᵀ: column j of W is the weight series of parameter j. The inverse is
    // formed whatever `sigmas` asks: a fit whose R cannot be inverted is refused either way.
    let rinv = r.clone().try_inverse()?;
    let theta: Vec<f64> = (0..p).map(|j| ts[j] / scale[j]).collect();
    let mut sigma = vec![f64::NAN; p];
    if (0..p).any(|j| sigmas.wants(j)) {
        let w = q * rinv.transpose();
        let lags = ResidualLags::new(&residual, block_len, max_lag);
        for (j, s) in sigma.iter_mut().enumerate().filter(|(j, _)| sigmas.wants(*j)) {
            let wj: Vec<f64> = w.column(j).iter().copied().collect();
            *s = lags.variance(&wj).sqrt() / scale[j];
        }
    }
    Some(Fit { theta, sigma, residual })
}

/// An orthonormal basis of a set of columns (thin QR of the column-scaled matrix, as [`ols`]),
/// kept to project many series out of the same columns: `v − QQᵀv` is [`ols`]'s residual of `v`
/// without a factorisation per series.
pub struct Basis {
    q: DMatrix<f64>,
    /// Largest `|R_ii|` of the scaled columns (the scale of [`ols`]'s dependence test).
    rdiag_max: f64,
}

impl Basis {
    /// The basis of `cols` (each of length `n`; none: the empty basis). `None` where [`ols`]
    /// refuses the columns: a column of zero or non-finite RMS, or a column whose part orthogonal
    /// to the others is below `1e-9` of the largest.
    pub fn new(cols: &[Vec<f64>], n: usize) -> Option<Self> {
        let p = cols.len();
        if p == 0 {
            return Some(Self {
                q: DMatrix::zeros(n, 0),
                rdiag_max: 0.0,
            });
        }
        if n <= p || cols.iter().any(|c| c.len() != n) {
            return None;
        }
        let ScaledQr { qr, rdiag_max, .. } = ScaledQr::new(cols, n)?;
        Some(Self { q: qr.q(), rdiag_max })
    }

    /// `v` less its projection on the columns.
    pub fn residual(&self, v: &[f64]) -> Vec<f64> {
        // `v − Q(Qᵀv)`: Q's columns are contiguous slices of its column-major storage.
        let mut out = v.to_vec();
        let n = self.q.nrows();
        for q in self.q.as_slice().chunks_exact(n.max(1)).take(self.q.ncols()) {
            let c = super::signal::dot(q, v);
            for (o, a) in out.iter_mut().zip(q) {
                *o -= c * a;
            }
        }
        out
    }
}

/// A candidate's partial test (the last parameter of the extended fit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Partial {
    /// Its estimate in the extended fit.
    pub theta: f64,
    /// Its coloured-residual standard error.
    pub sigma: f64,
    /// `(θ/σ)²` (0 when σ is 0).
    pub t2: f64,
}

/// [`partial_test`] of a candidate against the columns of `basis`, given `z_res`, the residual of
/// `z` on those columns ([`Basis::residual`]). By Frisch–Waugh–Lovell the candidate's estimate,
/// weight series and the extended fit's residual follow from its part `c̃` orthogonal to the
/// columns: `θ = c̃ᵀz/c̃ᵀc̃`, `w = c̃/c̃ᵀc̃`, `r = z_res − θc̃` — `O(N·p)` per candidate instead of a
/// QR of the extended matrix, equal to it to rounding. `None` as [`partial_test`].
pub fn partial_test_against(
    basis: &Basis,
    candidate: &[f64],
    z_res: &[f64],
    block_len: usize,
    max_lag: usize,
) -> Option<Partial> {
    let n = z_res.len();
    if candidate.len() != n || n <= basis.q.ncols() + 1 {
        return None;
    }
    let scale = (candidate.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    if !(scale.is_finite() && scale > 0.0) {
        return None;
    }
    let cs: Vec<f64> = candidate.iter().map(|v| v / scale).collect();
    let ct = basis.residual(&cs);
    let cc = super::signal::dot(&ct, &ct);
    let rpp = cc.sqrt();
    if rpp < 1e-9 * basis.rdiag_max.max(rpp).max(1e-300) {
        return None;
    }
    let ts = super::signal::dot(&ct, z_res) / cc;
    let residual: Vec<f64> = z_res.iter().zip(&ct).map(|(r, c)| r - ts * c).collect();
    let w: Vec<f64> = ct.iter().map(|c| c / cc).collect();
    let theta = ts / scale;
    let sigma = coloured_variance(&w, &residual, block_len, max_lag).sqrt() / scale;
    let t2 = if sigma > 0.0 { (theta / sigma).powi(2) } else { 0.0 };
    Some(Partial { theta, sigma, t2 })
}

/// The partial test of one candidate column added to `cols`: the extended fit and its `t²` for the
/// candidate (the last parameter). `None` when the candidate is dependent on `cols`.
pub fn partial_test(
    cols: &[Vec<f64>],
    candidate: &[f64],
    z: &[f64],
    block_len: usize,
    max_lag: usize,
) -> Option<(Fit, f64)> {
    let mut ext = cols.to_vec();
    ext.push(candidate.to_vec());
    let j = ext.len() - 1;
    let fit = ols_sigma(&ext, z, block_len, max_lag, Some(j))?;
    let t2 = if fit.sigma[j] > 0.0 {
        (fit.theta[j] / fit.sigma[j]).powi(2)
    } else {
        0.0
    };
    Some((fit, t2))
}

/// The errors-in-variables model of one fit: which columns are exact, and `W_T` (seed 000 eq. 9),
/// the error covariance of the noisy columns followed by the output `z`.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorModel {
    /// Per column: `true` when it is known without error (the intercept; a column whose white-noise
    /// variance is zero).
    pub exact: Vec<bool>,
    /// `W_T`, `(n_noisy + 1)²`, row-major, in the order of the noisy columns then `z`.
    pub w_t: Vec<f64>,
}

/// A batch PCA-GTLS fit by the core's recursive estimator ([`aerosid_core::gtls::Gtls`], `f64`,
/// no forgetting): after the last sample its solution is the batch GTLS of the whole segment.
#[derive(Debug, Clone, PartialEq)]
pub struct GtlsFit {
    /// Estimates, one per column (in the caller's column order).
    pub theta: Vec<f64>,
    /// Standard errors for coloured residuals: the sandwich of the GTLS estimating equation
    /// ([`gtls`]); NaN where not computed (`only`) or when the solution is not the TLS one.
    pub sigma: Vec<f64>,
    /// The estimator's own standard errors (eq. 17, white residuals); NaN when eq. 17 does not
    /// apply (a direction not excited, eq. 21).
    pub sigma_eq17: Vec<f64>,
    /// Equation residuals `z − Xθ̂`.
    pub residual: Vec<f64>,
    /// Which solution the estimator ended on.
    pub solution: aerosid_core::Solution,
    /// Excited directions `k` (eq. 21) of the noisy block.
    pub excited: usize,
    /// The output entry of `W_T` used.
    pub sigma_z2: f64,
}

/// Runs `Gtls<f64, NT, NE, NA>` over the samples of `cols` (ordered exact columns first).
fn run_gtls<const NT: usize, const NE: usize, const NA: usize>(
    cols: &[&[f64]],
    z: &[f64],
    w_t: &[f64],
    weights: &[f64],
) -> Option<(Vec<f64>, Vec<f64>, aerosid_core::Solution, usize)> {
    use aerosid_core::estimator::Estimator;
    use aerosid_core::gtls::{Gtls, GtlsSettings};
    use nalgebra::{SMatrix, SVector};
    let w = SMatrix::<f64, NA, NA>::from_fn(|i, j| w_t[i * NA + j]);
    let wv = SVector::<f64, NT>::from_fn(|i, _| weights[i]);
    let settings = GtlsSettings {
        max_abs_input: 1e12,
        ..GtlsSettings::default()
    };
    let mut g = Gtls::<f64, NT, NE, NA>::new(&w, &wv, settings).ok()?;
    for (k, &zi) in z.iter().enumerate() {
        let xv = SVector::<f64, NT>::from_fn(|i, _| cols[i][k]);
        g.update(&xv, zi).ok()?;
    }
    let theta: Vec<f64> = g.theta().iter().copied().collect();
    let s17 = match g.covariance() {
        Ok(c) => (0..NT).map(|i| c[(i, i)].max(0.0).sqrt()).collect(),
        Err(_) => vec![f64::NAN; NT],
    };
    Some((theta, s17, g.solution(), g.excited()))
}

macro_rules! gtls_dispatch {
    ($nt:expr, $ne:expr, $args:tt; $( ($a:literal, $b:literal, $c:literal) ),* ) => {
        match ($nt, $ne) {
            $( ($a, $b) => run_gtls::<$a, $b, $c> $args, )*
            _ => None,
        }
    };
}

/// The coloured-residual sandwich standard errors of a GTLS estimate `theta` (module doc of
/// [`gtls`]): `H = XᵀX − (Σr²/s) W̃`, weights `wᵢ = H⁻¹x̂ᵢ`, [`coloured_variance`]. NaN entries where
/// not computed (`only`) or when `H` is singular.
#[allow(clippy::too_many_arguments)]
pub fn sandwich_sigma(
    cols: &[Vec<f64>],
    residual: &[f64],
    theta: &[f64],
    exact: &[bool],
    w_t: &[f64],
    block_len: usize,
    max_lag: usize,
    only: Option<usize>,
) -> Vec<f64> {
    let p = cols.len();
    let mut sigma = vec![f64::NAN; p];
    let noisy: Vec<usize> = (0..p).filter(|&j| !exact[j]).collect();
    let nx = noisy.len();
    let na = nx + 1;
    if w_t.len() != na * na {
        return sigma;
    }
    let mut a = vec![0.0; na];
    for (k, &j) in noisy.iter().enumerate() {
        a[k] = theta[j];
    }
    a[nx] = -1.0;
    let wa: Vec<f64> = (0..na).map(|r| (0..na).map(|c| w_t[r * na + c] * a[c]).sum()).collect();
    let s: f64 = (0..na).map(|r| a[r] * wa[r]).sum();
    if !(s > 0.0 && s.is_finite()) {
        return sigma;
    }
    let mut u = vec![0.0; p];
    for (k, &j) in noisy.iter().enumerate() {
        u[j] = wa[k];
    }
    let lam = residual.iter().map(|r| r * r).sum::<f64>() / s;
    let mut h = DMatrix::<f64>::zeros(p, p);
    for r in 0..p {
        for c in r..p {
            let v = super::signal::dot(&cols[r], &cols[c]);
            h[(r, c)] = v;
            h[(c, r)] = v;
        }
    }
    for (kr, &r) in noisy.iter().enumerate() {
        for (kc, &c) in noisy.iter().enumerate() {
            h[(r, c)] -= lam * w_t[kr * na + kc];
        }
    }
    let Some(hinv) = h.try_inverse() else {
        return sigma;
    };
    let lags = ResidualLags::new(residual, block_len, max_lag);
    for (j, sj) in sigma.iter_mut().enumerate() {
        if only.is_some_and(|k| k != j) {
            continue;
        }
        // `wᵢ = hⱼᵀx̂ᵢ = hⱼᵀxᵢ + rᵢ hⱼᵀU/s`, column by column (each pass vectorises).
        let hj: Vec<f64> = (0..p).map(|c| hinv[(j, c)]).collect();
        let hu = (0..p).map(|c| hj[c] * u[c]).sum::<f64>() / s;
        let mut w: Vec<f64> = residual.iter().map(|r| r * hu).collect();
        for (c, h) in cols.iter().zip(&hj) {
            for (wi, x) in w.iter_mut().zip(c) {
                *wi += h * x;
            }
        }
        *sj = lags.variance(&w).sqrt();
    }
    sigma
}

/// The regressor part of an errors-in-variables model: which columns are exact, and the error
/// covariance of the noisy columns (`W_xx`, row-major) and of each noisy column with the output
/// (`w_xz`). The output's own entry of `W_T` is not part of it: [`corrected_ls`] sets it.
#[derive(Debug, Clone, PartialEq)]
pub struct EivModel {
    /// Per column: known without error.
    pub exact: Vec<bool>,
    /// Error covariance of the noisy columns, `n_noisy²`, row-major.
    pub w_xx: Vec<f64>,
    /// Error covariance of each noisy column with the output's error.
    pub w_xz: Vec<f64>,
}

impl EivModel {
    /// Every column exact (the model of ordinary least squares).
    pub fn exact(p: usize) -> Self {
        Self {
            exact: vec![true; p],
            w_xx: Vec::new(),
            w_xz: Vec::new(),
        }
    }

    /// `W_T` with the output variance `sigma_z2` appended (the [`ErrorModel`] of [`gtls`]).
    pub fn with_output(&self, sigma_z2: f64) -> ErrorModel {
        let nx = self.w_xz.len();
        let na = nx + 1;
        let mut w = vec![0.0; na * na];
        for r in 0..nx {
            for c in 0..nx {
                w[r * na + c] = self.w_xx[r * nx + c];
            }
            w[r * na + nx] = self.w_xz[r];
            w[nx * na + r] = self.w_xz[r];
        }
        w[nx * na + nx] = sigma_z2;
        ErrorModel {
            exact: self.exact.clone(),
            w_t: w,
        }
    }
}

/// The GTLS solution in closed form at the output variance that makes it consistent with the
/// data, and that variance.
///
/// GTLS solves `(XᵀX − λW̃)θ = Xᵀz − λw̃` with `λ = Σr²/(aᵀW_T a)` the smallest generalised
/// eigenvalue of `([X_n z]ᵀ[X_n z], W_T)` (exact columns projected out). **Reading chosen** for
/// `W_T`'s output entry (seed 000 eq. 41 sets it from the Monte Carlo error of the synthesised
/// coefficient, on simulated data where the model is exact): in a model-gap analysis the model is
/// known to be incomplete, so the output's "error" is the equation error — the measurement error
/// of `z` plus whatever the model lacks — and we set `σ_z²` such that `λ = N`, i.e.
/// `σ_z² = Σr²/N − θ_nᵀW_xxθ_n + 2θ_nᵀw_xz`. At that `σ_z²` the GTLS solution is the
/// bias-compensated least squares `θ = (XᵀX − N W̃)⁻¹(Xᵀz − N w̃)` (Fuller 1987 §2.2), computed
/// here directly; [`gtls_fit`] then runs the core's estimator with it. With every column exact
/// this is OLS.
///
/// Returns the fit (σ: the coloured sandwich of [`sandwich_sigma`]) and `σ_z²`; `None` when
/// `XᵀX − N W̃` is not positive definite (a column whose variance does not exceed its error
/// variance: not excited, in the sense of eq. 21) or `σ_z²` would leave `W_T` indefinite.
pub fn corrected_ls(
    cols: &[Vec<f64>],
    z: &[f64],
    eiv: &EivModel,
    block_len: usize,
    max_lag: usize,
    only: Option<usize>,
) -> Option<(Fit, f64)> {
    corrected_with(cols, z, eiv, block_len, max_lag, Sigmas::of(only))
}

/// [`corrected_ls`]'s estimates, residual and `σ_z²`, equal to its own to the bit, without its
/// standard errors (NaN): for a caller that needs the fit alone and forms its own σ.
pub fn corrected_estimates(cols: &[Vec<f64>], z: &[f64], eiv: &EivModel) -> Option<(Fit, f64)> {
    corrected_with(cols, z, eiv, z.len(), 0, Sigmas::None)
}

/// [`corrected_ls`] with the standard errors `sigmas`.
fn corrected_with(
    cols: &[Vec<f64>],
    z: &[f64],
    eiv: &EivModel,
    block_len: usize,
    max_lag: usize,
    sigmas: Sigmas,
) -> Option<(Fit, f64)> {
    let n = z.len();
    let p = cols.len();
    if p == 0 || n <= p || cols.iter().any(|c| c.len() != n) || eiv.exact.len() != p {
        return None;
    }
    let noisy: Vec<usize> = (0..p).filter(|&j| !eiv.exact[j]).collect();
    let nx = noisy.len();
    if eiv.w_xx.len() != nx * nx || eiv.w_xz.len() != nx {
        return None;
    }
    if nx == 0 {
        let f = ols_with(cols, z, block_len, max_lag, sigmas)?;
        let s2 = f.residual.iter().map(|r| r * r).sum::<f64>() / n as f64;
        return Some((f, s2));
    }
    // Column scaling for conditioning.
    let scale = column_scales(cols, n)?;
    let nf = n as f64;
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut b = DVector::<f64>::zeros(p);
    for r in 0..p {
        for c in r..p {
            let v = super::signal::dot(&cols[r], &cols[c]) / (scale[r] * scale[c]);
            a[(r, c)] = v;
            a[(c, r)] = v;
        }
        b[r] = super::signal::dot(&cols[r], z) / scale[r];
    }
    for (kr, &r) in noisy.iter().enumerate() {
        for (kc, &c) in noisy.iter().enumerate() {
            a[(r, c)] -= nf * eiv.w_xx[kr * nx + kc] / (scale[r] * scale[c]);
        }
        b[r] -= nf * eiv.w_xz[kr] / scale[r];
    }
    let chol = a.cholesky()?;
    let ts = chol.solve(&b);
    let theta: Vec<f64> = (0..p).map(|j| ts[j] / scale[j]).collect();
    if theta.iter().any(|t| !t.is_finite()) {
        return None;
    }
    let residual = residual_of(cols, z, &theta);
    let rss = residual.iter().map(|r| r * r).sum::<f64>();
    let mut twx = 0.0;
    let mut txz = 0.0;
    for (kr, &r) in noisy.iter().enumerate() {
        txz += theta[r] * eiv.w_xz[kr];
        for (kc, &c) in noisy.iter().enumerate() {
            twx += theta[r] * eiv.w_xx[kr * nx + kc] * theta[c];
        }
    }
    let s2 = rss / nf - twx + 2.0 * txz;
    let em = eiv.with_output(s2);
    // W_T must be positive definite.
    let na = nx + 1;
    DMatrix::from_row_slice(na, na, &em.w_t).cholesky()?;
    let sigma = match sigmas {
        Sigmas::None => vec![f64::NAN; p],
        _ => sandwich_sigma(
            cols,
            &residual,
            &theta,
            &eiv.exact,
            &em.w_t,
            block_len,
            max_lag,
            sigmas.only(),
        ),
    };
    Some((Fit { theta, sigma, residual }, s2))
}

/// `z − Σⱼ θⱼ colsⱼ`, column by column (each pass vectorises; a sum over the columns per sample
/// does not).
fn residual_of<C: AsRef<[f64]>>(cols: &[C], z: &[f64], theta: &[f64]) -> Vec<f64> {
    let mut fit = vec![0.0; z.len()];
    for (c, t) in cols.iter().zip(theta) {
        for (f, x) in fit.iter_mut().zip(c.as_ref()) {
            *f += x * t;
        }
    }
    z.iter().zip(fit).map(|(z, f)| z - f).collect()
}

/// The PCA-GTLS fit of the analysis: `σ_z²` from [`corrected_ls`], then the core's estimator
/// ([`gtls`]) with `W_T = [W_xx w_xz; w_xzᵀ σ_z²]`. Every column exact: OLS, reported as a GTLS fit
/// with the OLS σ. `None` as [`corrected_ls`] or [`gtls`].
pub fn gtls_fit(
    cols: &[Vec<f64>],
    z: &[f64],
    eiv: &EivModel,
    block_len: usize,
    max_lag: usize,
    only: Option<usize>,
) -> Option<GtlsFit> {
    // The corrected fit's σ is needed only when it is the answer (every column exact); else its
    // `σ_z²` alone, and the GTLS fit below forms its own σ.
    let all_exact = eiv.exact.iter().all(|e| *e);
    let sigmas = if all_exact { Sigmas::of(only) } else { Sigmas::None };
    let (cls, s2) = corrected_with(cols, z, eiv, block_len, max_lag, sigmas)?;
    if all_exact {
        return Some(GtlsFit {
            theta: cls.theta,
            sigma: cls.sigma,
            sigma_eq17: vec![f64::NAN; cols.len()],
            residual: cls.residual,
            solution: aerosid_core::Solution::LeastSquares,
            excited: cols.len(),
            sigma_z2: s2,
        });
    }
    gtls(cols, z, &eiv.with_output(s2), block_len, max_lag, only)
}

/// Largest number of columns [`gtls`] handles (the const-generic estimator is instantiated for
/// 2…[`GTLS_MAX_COLUMNS`] columns with 0…3 exact ones).
pub const GTLS_MAX_COLUMNS: usize = 10;

/// Batch PCA-GTLS of `z` on `cols` with the error model `em`, by the core's estimator, and its
/// standard errors for coloured residuals.
///
/// **Covariance with coloured residuals** (our extension of Morelli & Klein 1997 to GTLS): the
/// GTLS estimate minimises `Σ rᵢ²/s` with `rᵢ = zᵢ − xᵢᵀθ`, `a = [θ_n; −1]`, `s = aᵀW_T a`; its
/// gradient is `−(2/s) Σ rᵢ x̂ᵢ` with the TLS-corrected regressor `x̂ᵢ = xᵢ + rᵢ U/s`,
/// `U = [0_e; (W_T a)_x]` (the `x̂₀` of seed 000 eq. 24–25). Differentiating the estimating
/// equation `Σ rᵢ x̂ᵢ = 0` at the solution gives `H = XᵀX − (Σr²/s) W̃` (`W̃` = `W_T`'s noisy-regressor
/// block in the noisy rows and columns), so `θ̂ − θ ≈ H⁻¹ Σ x̂ᵢ rᵢ` and
/// `Cov θ̂ = H⁻¹ [Σᵢ Σⱼ x̂ᵢ R_rr(i−j) x̂ⱼᵀ] H⁻¹` with the residual autocorrelation truncated at
/// `max_lag` ([`coloured_variance`] with the weight series `wᵢ = H⁻¹x̂ᵢ`). With `W_T → 0` this is the
/// OLS formula of [`ols`]; with white residuals it is eq. 17 plus the small Fuller term
/// `σ² N H⁻¹(W̃ − UUᵀ/s)H⁻¹` (checked against eq. 17 in the tests).
///
/// Weights of eq. 23 (used only when a direction is not excited): the reciprocal RMS of each
/// column. `None` when the columns are dependent, `W_T` is not positive definite, the size is
/// outside the instantiated range or the estimator refused a sample.
pub fn gtls(
    cols: &[Vec<f64>],
    z: &[f64],
    em: &ErrorModel,
    block_len: usize,
    max_lag: usize,
    only: Option<usize>,
) -> Option<GtlsFit> {
    let n = z.len();
    let p = cols.len();
    if p == 0 || n <= p || cols.iter().any(|c| c.len() != n) || em.exact.len() != p {
        return None;
    }
    // Dependent columns: refuse as OLS does (its test, without its fit).
    ScaledQr::new(cols, n)?;
    let order: Vec<usize> = (0..p)
        .filter(|&j| em.exact[j])
        .chain((0..p).filter(|&j| !em.exact[j]))
        .collect();
    let ne = (0..p).filter(|&j| em.exact[j]).count();
    let na = p - ne + 1;
    if em.w_t.len() != na * na || na < 2 {
        return None;
    }
    // The columns in the estimator's order (exact ones first); it reads sample `k` of each.
    let ordered: Vec<&[f64]> = order.iter().map(|&j| &cols[j][..n]).collect();
    let weights: Vec<f64> = order
        .iter()
        .map(|&j| {
            let rms = (cols[j].iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            if rms > 0.0 {
                1.0 / rms
            } else {
                1.0
            }
        })
        .collect();
    let args = (&ordered[..], z, &em.w_t[..], &weights[..]);
    let (th_o, s17_o, solution, excited) = gtls_dispatch!(p, ne, (args.0, args.1, args.2, args.3);
        (2,0,3),(2,1,2),
        (3,0,4),(3,1,3),(3,2,2),
        (4,0,5),(4,1,4),(4,2,3),(4,3,2),
        (5,0,6),(5,1,5),(5,2,4),(5,3,3),
        (6,0,7),(6,1,6),(6,2,5),(6,3,4),
        (7,0,8),(7,1,7),(7,2,6),(7,3,5),
        (8,0,9),(8,1,8),(8,2,7),(8,3,6),
        (9,0,10),(9,1,9),(9,2,8),(9,3,7),
        (10,0,11),(10,1,10),(10,2,9),(10,3,8))?;
    let mut theta = vec![0.0; p];
    let mut sigma_eq17 = vec![f64::NAN; p];
    for (k, &j) in order.iter().enumerate() {
        theta[j] = th_o[k];
        sigma_eq17[j] = s17_o[k];
    }
    let residual = residual_of(cols, z, &theta);
    let sigma = if solution == aerosid_core::Solution::Tls {
        sandwich_sigma(cols, &residual, &theta, &em.exact, &em.w_t, block_len, max_lag, only)
    } else {
        vec![f64::NAN; p]
    };
    Some(GtlsFit {
        theta,
        sigma,
        sigma_eq17,
        residual,
        solution,
        excited,
        sigma_z2: em.w_t[na * na - 1],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn ols_recovers_a_line_with_a_sensible_sigma() {
        // GIVEN z = 1 + 2x + white noise σ = 0.1 on 2000 points
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let nd = Normal::new(0.0, 0.1).unwrap();
        let x: Vec<f64> = (0..2000).map(|i| (i as f64 * 0.01).sin()).collect();
        let z: Vec<f64> = x.iter().map(|v| 1.0 + 2.0 * v + nd.sample(&mut rng)).collect();
        let fit = ols(&[vec![1.0; 2000], x.clone()], &z, 2000, 20).unwrap();
        // THEN the slope is within 4σ and σ near the white-noise value 0.1/√(Σ(x−x̄)²) (±30 %:
        // the truncated autocorrelation sum adds estimation noise)
        let xbar = x.iter().sum::<f64>() / 2000.0;
        let sxx: f64 = x.iter().map(|v| (v - xbar).powi(2)).sum();
        let s_white = 0.1 / sxx.sqrt();
        assert!((fit.theta[1] - 2.0).abs() < 4.0 * s_white);
        assert!(
            (fit.sigma[1] / s_white - 1.0).abs() < 0.3,
            "{} vs {}",
            fit.sigma[1],
            s_white
        );
    }

    /// The definition of [`coloured_variance`] term by term: the reference for the FFT sums.
    fn direct_coloured_variance(w: &[f64], v: &[f64], block_len: usize, max_lag: usize) -> f64 {
        let mut total = 0.0;
        for (wb, vb) in w.chunks(block_len).zip(v.chunks(block_len)) {
            let nb = wb.len();
            let mut white = 0.0;
            let mut block = 0.0;
            for k in 0..=max_lag.min(nb - 1) {
                let r: f64 = (0..nb - k).map(|i| vb[i] * vb[i + k]).sum::<f64>() / nb as f64;
                let ww: f64 = (0..nb - k).map(|i| wb[i] * wb[i + k]).sum();
                if k == 0 {
                    white = r * ww;
                    block += white;
                } else {
                    block += 2.0 * r * ww;
                }
            }
            total += block.max(white);
        }
        total.max(0.0)
    }

    #[test]
    fn the_fft_lag_sums_equal_the_direct_ones() {
        // GIVEN coloured residuals and weights (seeded), and the block/lag layouts of the analysis:
        // every lag of 500-sample blocks (the compatibility check), 500 lags of one long block
        // (the sandwich), a ragged last block, and short lags (the direct path)
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let mut ar = 0.0;
        let v: Vec<f64> = (0..5_230)
            .map(|_| {
                ar = 0.97 * ar + nd.sample(&mut rng);
                ar
            })
            .collect();
        let w: Vec<f64> = (0..5_230)
            .map(|i| (i as f64 * 0.01).sin() + 0.2 * nd.sample(&mut rng))
            .collect();
        for (block, lag) in [(500, 500), (5_230, 500), (1_000, 700), (700, 40), (500, 31), (500, 0)] {
            // WHEN both are computed
            let fast = coloured_variance(&w, &v, block, lag);
            let slow = direct_coloured_variance(&w, &v, block, lag);
            // THEN they agree to rounding (1e-10 relative: sums of ~10⁶ products of O(1) terms
            // in double precision, either way)
            assert!(
                (fast / slow - 1.0).abs() < 1e-10,
                "block {block}, lag {lag}: {fast} vs {slow}"
            );
        }
    }

    #[test]
    fn lag_sums_by_fft_equal_the_direct_ones() {
        // GIVEN a coloured series (seeded) of a compatibility block's length and a ragged one
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let mut ar = 0.0;
        let x: Vec<f64> = (0..1_501)
            .map(|_| {
                ar = 0.9 * ar + nd.sample(&mut rng);
                ar
            })
            .collect();
        for (len, lmax) in [(1_501, 1_500), (1_500, 1_499), (333, 100), (200, 31), (5, 4), (1, 0)] {
            // WHEN the lag sums are taken (FFT above 31 lags) and summed directly
            let fast = lag_sums(&x[..len], lmax);
            // THEN they agree to rounding: 1e-9 of the lag-0 sum (≈ 10³ products of O(1)
            // terms per lag, the FFT's error scales with the total energy, not each lag's)
            assert_eq!(fast.len(), lmax + 1);
            for (k, f) in fast.iter().enumerate() {
                let slow: f64 = (0..len - k).map(|i| x[i] * x[i + k]).sum();
                assert!((f - slow).abs() < 1e-9 * fast[0], "len {len}, lag {k}: {f} vs {slow}");
            }
        }
        assert!(lag_sums(&[], 3).is_empty());
    }

    /// `z = 1 + 2 x + e_z` with `x` measured with error `e_x` (`σ_x`, `σ_z` white, seeded).
    fn eiv_data(n: usize, sigma_x: f64, sigma_z: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let ex = Normal::new(0.0, sigma_x).unwrap();
        let ez = Normal::new(0.0, sigma_z).unwrap();
        let xt: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.013).sin() + 0.3 * (i as f64 * 0.0071).cos())
            .collect();
        let z: Vec<f64> = xt.iter().map(|x| 1.0 + 2.0 * x + ez.sample(&mut rng)).collect();
        let xm: Vec<f64> = xt.iter().map(|x| x + ex.sample(&mut rng)).collect();
        (vec![vec![1.0; n], xm], z)
    }

    #[test]
    fn the_core_gtls_equals_the_closed_form_at_its_output_variance() {
        // GIVEN errors in x (σ_x = 0.3 against a signal of RMS 0.74) and W_T's regressor part known
        let (cols, z) = eiv_data(3000, 0.3, 0.1, 5);
        let eiv = EivModel {
            exact: vec![true, false],
            w_xx: vec![0.09],
            w_xz: vec![0.0],
        };
        // WHEN both are solved
        let (cls, s2) = corrected_ls(&cols, &z, &eiv, 3000, 0, None).unwrap();
        let g = gtls_fit(&cols, &z, &eiv, 3000, 0, None).unwrap();
        // THEN the recursive estimator ends on the closed form (to rounding: 1e-8 relative) with
        // the output variance the closed form chose; that variance is the residual's (0.37) less the
        // regressor error's share (4·0.09), so its standard error is 0.37·√(2/N) ≈ 0.0096: the
        // truth 0.01 within 3 of those
        assert_eq!(g.solution, aerosid_core::Solution::Tls);
        for j in 0..2 {
            assert!(
                (g.theta[j] - cls.theta[j]).abs() < 1e-8 * cls.theta[j].abs().max(1.0),
                "{j}: {} vs {}",
                g.theta[j],
                cls.theta[j]
            );
        }
        assert!((s2 - 0.01).abs() < 3.0 * 0.37 * (2.0f64 / 3000.0).sqrt(), "{s2}");
        assert!((g.sigma_z2 - s2).abs() < 1e-15);
    }

    #[test]
    fn the_fits_without_sigma_equal_the_full_fits_to_the_bit() {
        // GIVEN one column with errors (the corrected fit) and every column exact (OLS)
        let (cols, z) = eiv_data(3000, 0.3, 0.1, 7);
        let noisy = EivModel {
            exact: vec![true, false],
            w_xx: vec![0.09],
            w_xz: vec![0.0],
        };
        for eiv in [noisy, EivModel::exact(2)] {
            // WHEN fitted with every σ and with none
            let (full, s2) = corrected_ls(&cols, &z, &eiv, 3000, 50, None).unwrap();
            let (bare, s2_bare) = corrected_estimates(&cols, &z, &eiv).unwrap();
            // THEN the estimates, residual and output variance are the same numbers (callers rely
            // on it: skipping σ must not change any result), and σ is left out
            assert_eq!(full.theta, bare.theta);
            assert_eq!(full.residual, bare.residual);
            assert_eq!(s2.to_bits(), s2_bare.to_bits());
            assert!(full.sigma.iter().all(|s| s.is_finite() && *s > 0.0));
            assert!(bare.sigma.iter().all(|s| s.is_nan()));
            // AND the GTLS fit starts from that same output variance
            let g = gtls_fit(&cols, &z, &eiv, 3000, 50, None).unwrap();
            assert_eq!(g.sigma_z2.to_bits(), s2.to_bits());
        }
        let full = ols(&cols, &z, 3000, 50).unwrap();
        let bare = ols_estimates(&cols, &z).unwrap();
        assert_eq!(full.theta, bare.theta);
        assert_eq!(full.residual, bare.residual);
        assert!(bare.sigma.iter().all(|s| s.is_nan()));
    }

    #[test]
    fn gtls_removes_the_attenuation_of_least_squares() {
        // GIVEN σ_x = 0.3: OLS's slope is attenuated by var(x)/(var(x) + σ_x²) ≈ 0.86
        let (cols, z) = eiv_data(3000, 0.3, 0.1, 6);
        let eiv = EivModel {
            exact: vec![true, false],
            w_xx: vec![0.09],
            w_xz: vec![0.0],
        };
        let o = ols(&cols, &z, 3000, 0).unwrap();
        let g = gtls_fit(&cols, &z, &eiv, 3000, 0, None).unwrap();
        // THEN OLS misses the slope 2 by more than 10 %, GTLS is within 3σ of it
        assert!(o.theta[1] < 1.8, "OLS {}", o.theta[1]);
        assert!(
            (g.theta[1] - 2.0).abs() < 3.0 * g.sigma[1],
            "GTLS {} ± {}",
            g.theta[1],
            g.sigma[1]
        );
    }

    #[test]
    fn the_sandwich_sigma_is_eq17_for_white_residuals() {
        // GIVEN white errors (σ_x = 0.05 on a signal of RMS 0.74, σ_z = 0.1): eq. 17 holds
        let (cols, z) = eiv_data(4000, 0.05, 0.1, 7);
        let eiv = EivModel {
            exact: vec![true, false],
            w_xx: vec![0.0025],
            w_xz: vec![0.0],
        };
        // WHEN the coloured-residual sandwich is computed with 20 lags
        let g = gtls_fit(&cols, &z, &eiv, 4000, 20, None).unwrap();
        // THEN it agrees with eq. 17 within 15 % (the truncated autocorrelation sum's own
        // estimation noise, as in the OLS test above)
        for j in 0..2 {
            assert!(
                (g.sigma[j] / g.sigma_eq17[j] - 1.0).abs() < 0.15,
                "{j}: sandwich {} eq. 17 {}",
                g.sigma[j],
                g.sigma_eq17[j]
            );
        }
    }

    /// The leave-one-manoeuvre-out jackknife (CR3), `((G−1)/G) Σ_g (θ̂₍₋g₎ − θ̄)²` over OLS refits
    /// without each manoeuvre: the reference [`manoeuvre_sandwich`] is measured against.
    fn jackknife(cols: &[Vec<f64>], z: &[f64], ranges: &[(usize, usize)]) -> Vec<f64> {
        let draws: Vec<Vec<f64>> = ranges
            .iter()
            .map(|&(a, b)| {
                let without = |x: &[f64]| -> Vec<f64> { x[..a].iter().chain(&x[b..]).copied().collect() };
                let sub: Vec<Vec<f64>> = cols.iter().map(|c| without(c)).collect();
                ols_theta(&sub, &without(z)).unwrap()
            })
            .collect();
        let g = ranges.len() as f64;
        (0..cols.len())
            .map(|j| {
                let m = draws.iter().map(|t| t[j]).sum::<f64>() / g;
                (draws.iter().map(|t| (t[j] - m).powi(2)).sum::<f64>() * (g - 1.0) / g).sqrt()
            })
            .collect()
    }

    /// Seeded repetitions of `g` pooled manoeuvres of `m` samples, `z = 1 + 2x + 0.1e`, `e` an AR(1)
    /// with coefficient `rho` scaled to unit variance (ρ = 0.995: correlated over ≈ 200 samples, a
    /// whole manoeuvre, as the flow-angle estimate's error on a test card), independent between
    /// manoeuvres; manoeuvre `k`'s input has amplitude `amp[k]`. Per repetition: the slope, and its
    /// σ by the manoeuvre sandwich, the jackknife and lag sums to 10 samples. Returns the scatter
    /// of the slope over the root mean square of each σ (what an unbiased variance estimate
    /// matches: `E σ̂² = Var θ̂`).
    fn scatter_over_sigma(amp: &[f64], m: usize, reps: u64, rho: f64) -> (f64, f64, f64) {
        let g = amp.len();
        let nd = Normal::new(0.0, 1.0).unwrap();
        let innovation = (1.0 - rho * rho).sqrt();
        let ranges: Vec<(usize, usize)> = (0..g).map(|k| (k * m, (k + 1) * m)).collect();
        let x: Vec<f64> = (0..g * m)
            .map(|i| amp[i / m] * ((i % m) as f64 * 0.05 * (1.0 + (i / m) as f64 * 0.3)).sin())
            .collect();
        let cols = vec![vec![1.0; g * m], x.clone()];
        let (mut est, mut cr2, mut jk, mut lags) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for seed in 0..reps {
            let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
            let mut z = Vec::with_capacity(g * m);
            for _ in 0..g {
                let mut e = nd.sample(&mut rng);
                for _ in 0..m {
                    e = rho * e + innovation * nd.sample(&mut rng);
                    z.push(1.0 + 2.0 * x[z.len()] + 0.1 * e);
                }
            }
            let fit = ols(&cols, &z, m, 10).unwrap();
            cr2.push(manoeuvre_sandwich(&cols, &z, &fit.theta, &EivModel::exact(2), &ranges).unwrap()[1]);
            jk.push(jackknife(&cols, &z, &ranges)[1]);
            est.push(fit.theta[1]);
            lags.push(fit.sigma[1]);
        }
        let mean = est.iter().sum::<f64>() / est.len() as f64;
        let sd = (est.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (est.len() - 1) as f64).sqrt();
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        (sd / rms(&cr2), sd / rms(&jk), sd / rms(&lags))
    }

    #[test]
    fn the_manoeuvre_sandwich_matches_the_scatter_where_lag_sums_do_not() {
        // GIVEN 300 repetitions of eight pooled manoeuvres of 200 samples that excite the slope
        // alike, the residual correlated over a whole manoeuvre (ρ = 0.995)
        // WHEN the slope's σ is taken by the manoeuvre sandwich, and by lag sums to 10 samples
        let (r_cr2, _, r_lags) = scatter_over_sigma(&[1.0; 8], 200, 300, 0.995);
        // THEN the scatter over the sandwich's σ is inside the band 0.7–1.5 (0.97 on these seeds;
        // the sampling error of a s.d. from 300 draws is 4 %), and over the lag sums' it is
        // outside it (0.48: the residual's slow part, orthogonal to the input, inflates its lag-0
        // term without reaching the slope)
        assert!((0.7..=1.5).contains(&r_cr2), "sandwich: scatter/σ {r_cr2:.2}");
        assert!(!(0.7..=1.5).contains(&r_lags), "lag sums: scatter/σ {r_lags:.2}");
    }

    #[test]
    fn the_manoeuvre_sandwich_is_unbiased_where_one_manoeuvre_carries_a_term() {
        // GIVEN five pooled manoeuvres of which the first holds 80 % of the slope's information
        // (input amplitude 4 against 1: 16/(16 + 4) of Σx²), as an aileron 3-2-1-1 holds a test
        // card's roll-control terms, white residuals (the case the bias reduction is exact for)
        // WHEN the slope's σ is taken by the manoeuvre sandwich and by the jackknife
        let (r_cr2, r_jk, _) = scatter_over_sigma(&[4.0, 1.0, 1.0, 1.0, 1.0], 200, 1000, 0.0);
        // THEN the sandwich's scatter/σ is 1 within three sampling errors (a s.d. from 1000 draws,
        // 2.2 %, and the mean of σ̂², which the dominant manoeuvre makes nearly a 0.8·χ²₁: 1.9 % on
        // σ; together 2.9 %), and the jackknife's is below 0.7: its variance counts the dominant
        // manoeuvre as λ/(1 − λ) = 4 instead of 0.8 (with the (G−1)/G factor and the spread of
        // the refits about their mean, ≈ 2.7 times the variance in all: ratio ≈ 0.6)
        assert!((r_cr2 - 1.0).abs() < 0.09, "sandwich: scatter/σ {r_cr2:.3}");
        assert!(r_jk < 0.7, "jackknife: scatter/σ {r_jk:.2}");
    }

    #[test]
    fn the_manoeuvre_sandwich_needs_three_manoeuvres_that_share_every_direction() {
        // GIVEN two manoeuvres, and three of which one alone excites the slope
        let x: Vec<f64> = (0..300)
            .map(|i| if i < 100 { (i as f64 * 0.3).sin() } else { 0.0 })
            .collect();
        let z: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, v)| 2.0 * v + (i as f64 * 0.7).cos())
            .collect();
        let cols = vec![vec![1.0; 300], x];
        let theta = ols_theta(&cols, &z).unwrap();
        // THEN neither has a manoeuvre σ (the caller keeps its own)
        let two = manoeuvre_sandwich(&cols, &z, &theta, &EivModel::exact(2), &[(0, 150), (150, 300)]);
        assert!(two.is_none());
        let alone = manoeuvre_sandwich(
            &cols,
            &z,
            &theta,
            &EivModel::exact(2),
            &[(0, 100), (100, 200), (200, 300)],
        );
        assert!(alone.is_none(), "{alone:?}");
    }

    #[test]
    fn the_manoeuvre_sandwich_is_cr2_by_its_definition() {
        // GIVEN an intercept and a slope on three manoeuvres of unequal length (seeded)
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let n = 90;
        let ranges = [(0, 20), (20, 50), (50, 90)];
        let x: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.37).sin() + 0.1 * i as f64 / n as f64)
            .collect();
        let z: Vec<f64> = x.iter().map(|v| 0.5 - 1.5 * v + 0.3 * nd.sample(&mut rng)).collect();
        let cols = vec![vec![1.0; n], x.clone()];
        let theta = ols_theta(&cols, &z).unwrap();
        // WHEN it is computed, and CR2 directly with n×n matrices: the manoeuvre's block of
        // I − X(XᵀX)⁻¹Xᵀ, its inverse square root by an eigen decomposition
        let s = manoeuvre_sandwich(&cols, &z, &theta, &EivModel::exact(2), &ranges).unwrap();
        let xm = DMatrix::from_fn(n, 2, |i, j| cols[j][i]);
        let xtx_inv = (xm.transpose() * &xm).try_inverse().unwrap();
        let r = DVector::from_iterator(n, residual_of(&cols, &z, &theta));
        let mut meat = DMatrix::<f64>::zeros(2, 2);
        for &(a, b) in &ranges {
            let xg = xm.rows(a, b - a).into_owned();
            let m = DMatrix::<f64>::identity(b - a, b - a) - &xg * &xtx_inv * xg.transpose();
            let e = nalgebra::SymmetricEigen::new(m);
            let d = DMatrix::from_diagonal(&e.eigenvalues.map(|v| v.powf(-0.5)));
            let a_g = &e.eigenvectors * d * e.eigenvectors.transpose();
            let psi = xg.transpose() * a_g * r.rows(a, b - a);
            meat += &psi * psi.transpose();
        }
        let cov = &xtx_inv * meat * &xtx_inv;
        // THEN they agree to rounding (1e-9 relative)
        for j in 0..2 {
            let direct = cov[(j, j)].sqrt();
            assert!((s[j] / direct - 1.0).abs() < 1e-9, "{j}: {} vs {direct}", s[j]);
        }
    }

    #[test]
    fn dependent_columns_are_refused() {
        let x: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 2.0 * v).collect();
        assert!(ols(&[x.clone(), y], &x, 100, 5).is_none());
    }
}
