//! Model selection by prediction of held-out time blocks: the statistics behind every cause the
//! model-gap analysis names.
//!
//! The flight is cut into contiguous **blocks** (default 3 s) and the blocks are dealt round-robin
//! into `K` **folds** (default 5). A model (a set of columns) is fitted with one fold left out and
//! predicts that fold's blocks; every block thus gets a held-out sum of squared errors (blocked
//! cross-validation; Roberts et al. 2017 on why blocks must be longer than the residuals'
//! correlation, Klein & Morelli 2006 §5.4 on stepwise selection). Two models are compared block by
//! block: the gain `d_b = SSE₀_b − SSE₁_b` of each block is one observation, and the gain is
//! **beyond noise** when the sign-flip statistic `Σd_b/√(Σd_b²)` ([`gain`]) exceeds the one-sided
//! Student-t quantile with `G − 1` degrees of freedom (`G` blocks; a little above the normal
//! quantile of the statistic's approximation, for few blocks). Blocks of a few seconds are nearly independent for the residuals of an
//! equation-error fit (sensor noise and turbulence decorrelate within a second or two at the speeds
//! of a small UAV), so the block gains are a fair sample even when the residuals are coloured.
//!
//! Significance of a term is its partial `t² = (θ̂/σ)²` with σ from the **block (cluster-robust)
//! sandwich** `H⁻¹(Σ_b s_b s_bᵀ)H⁻¹·G/(G−1)`, `s_b` the block's score: valid for residuals
//! correlated within a block, whatever their spectrum, and compared with the squared two-sided
//! Student-t quantile at `G − 1` degrees of freedom (the small-sample law of a cluster-robust t).
//!
//! Everything is computed from per-block Gram matrices of `[X z]`, so a fit or a cross-validation
//! of any subset of columns costs `O(p³)` per fold, independent of the flight's length. With an
//! errors-in-variables model (`W`, the per-sample error covariance of `[X z]`), the fits are the
//! bias-compensated least squares `(XᵀX − nW_xx)⁻¹(Xᵀz − nw_xz)` — the PCA-GTLS solution at the
//! output variance of [`super::regress::corrected_ls`] (its doc says why).

use nalgebra::{DMatrix, DVector};

/// How the flight is cut for cross-validation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CvSettings {
    /// Block length, s. Longer than the correlation time of the residuals.
    pub block_s: f64,
    /// Number of folds.
    pub folds: usize,
    /// One-sided level of the held-out gain test.
    pub gain_alpha: f64,
}

impl Default for CvSettings {
    fn default() -> Self {
        Self {
            block_s: 2.0,
            folds: 5,
            gain_alpha: 0.01,
        }
    }
}

/// Per-block Gram matrices of one regression problem `z ≈ Xθ` over every column it may use.
#[derive(Debug, Clone)]
pub struct Design {
    /// Sample ranges of the blocks.
    pub blocks: Vec<(usize, usize)>,
    /// Fold of each block.
    pub fold: Vec<usize>,
    /// Number of folds.
    pub folds: usize,
    /// `[X z]ᵀ[X z]` per block, `(p+1)²`.
    grams: Vec<DMatrix<f64>>,
    /// The per-sample error covariance of `[X z]` (zero: ordinary least squares).
    w: DMatrix<f64>,
    /// Number of columns `p` (the output is column `p`).
    p: usize,
    /// The column of ones, if any.
    ones: Option<usize>,
}

/// A fitted subset.
#[derive(Debug, Clone, PartialEq)]
pub struct SubsetFit {
    /// Columns (indices into the design).
    pub cols: Vec<usize>,
    /// Estimates, in the order of `cols`.
    pub theta: Vec<f64>,
    /// Block-sandwich standard errors.
    pub sigma: Vec<f64>,
    /// Held-out SSE of every block (its fold left out of the fit).
    pub cv_sse: Vec<f64>,
}

impl SubsetFit {
    /// Partial `t²` of the estimate at position `k`.
    pub fn t2(&self, k: usize) -> f64 {
        let t = (self.theta[k] / self.sigma[k]).powi(2);
        if t.is_finite() {
            t
        } else {
            0.0
        }
    }
}

/// Why a subset cannot be fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unfit {
    /// `XᵀX − nW` is not positive definite on some training set: a column is not excited beyond
    /// its error, or is a linear combination of the others.
    NotPositiveDefinite,
    /// Fewer blocks than folds, or fewer samples than columns.
    TooFewData,
}

impl Design {
    /// The design of `cols` (each of length `n`) and `z`, cut into blocks of `cv.block_s`. `w`:
    /// the per-sample error covariance of `[X z]`, `(p+1)²` row-major, or `None` (all exact).
    pub fn new(cols: &[&[f64]], z: &[f64], h_s: f64, cv: &CvSettings, w: Option<&[f64]>) -> Self {
        let n = z.len();
        let p = cols.len();
        let len = ((cv.block_s / h_s).round() as usize).max(10);
        let g = (n / len).max(1);
        let blocks: Vec<(usize, usize)> = (0..g).map(|i| (i * n / g, (i + 1) * n / g)).collect();
        let folds = cv.folds.clamp(2, g.max(2));
        let fold = (0..g).map(|i| i % folds).collect();
        let grams = blocks
            .iter()
            .map(|&(a, b)| {
                let mut m = DMatrix::zeros(p + 1, p + 1);
                let col = |j: usize, i: usize| if j < p { cols[j][i] } else { z[i] };
                for r in 0..=p {
                    for c in r..=p {
                        let s: f64 = (a..b).map(|i| col(r, i) * col(c, i)).sum();
                        m[(r, c)] = s;
                        m[(c, r)] = s;
                    }
                }
                m
            })
            .collect();
        let w = match w {
            Some(w) if w.len() == (p + 1) * (p + 1) => DMatrix::from_row_slice(p + 1, p + 1, w),
            _ => DMatrix::zeros(p + 1, p + 1),
        };
        Self {
            blocks,
            fold,
            folds,
            grams,
            w,
            p,
            ones: None,
        }
    }

    /// Number of blocks.
    pub fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    fn rows(&self, b: usize) -> f64 {
        (self.blocks[b].1 - self.blocks[b].0) as f64
    }

    /// `(A, c)` of the normal equations of `cols` over the blocks `use_block` selects.
    fn normal(&self, cols: &[usize], use_block: impl Fn(usize) -> bool) -> (DMatrix<f64>, DVector<f64>, f64) {
        self.normal_over(cols, (0..self.grams.len()).filter(|&b| use_block(b)))
    }

    /// `(A, c)` of the normal equations of `cols` over the given blocks.
    fn normal_over(&self, cols: &[usize], blocks: impl Iterator<Item = usize>) -> (DMatrix<f64>, DVector<f64>, f64) {
        let k = cols.len();
        let mut a = DMatrix::zeros(k, k);
        let mut c = DVector::zeros(k);
        let mut n = 0.0;
        for b in blocks {
            let g = &self.grams[b];
            n += self.rows(b);
            for (r, &i) in cols.iter().enumerate() {
                c[r] += g[(i, self.p)];
                for (s, &j) in cols.iter().enumerate() {
                    a[(r, s)] += g[(i, j)];
                }
            }
        }
        for (r, &i) in cols.iter().enumerate() {
            c[r] -= n * self.w[(i, self.p)];
            for (s, &j) in cols.iter().enumerate() {
                a[(r, s)] -= n * self.w[(i, j)];
            }
        }
        (a, c, n)
    }

    fn solve(a: DMatrix<f64>, c: &DVector<f64>) -> Option<(DVector<f64>, DMatrix<f64>)> {
        // Equilibrate so that the positive-definiteness test does not depend on column scales.
        let d: Vec<f64> = (0..a.nrows()).map(|i| a[(i, i)].max(0.0).sqrt()).collect();
        if d.iter().any(|x| !(*x > 0.0 && x.is_finite())) {
            return None;
        }
        let s = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] / (d[i] * d[j]));
        let ch = s.cholesky()?;
        // A numerically singular system (condition beyond 1e12) is refused as well.
        let diag = ch.l_dirty().diagonal();
        let (lo, hi) = diag.iter().fold((f64::MAX, 0.0f64), |(l, h), x| (l.min(*x), h.max(*x)));
        if lo <= 0.0 || (hi / lo).powi(2) > 1e12 {
            return None;
        }
        let cs = DVector::from_fn(c.len(), |i, _| c[i] / d[i]);
        let ys = ch.solve(&cs);
        let theta = DVector::from_fn(c.len(), |i, _| ys[i] / d[i]);
        let inv_s = ch.inverse();
        let inv = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| inv_s[(i, j)] / (d[i] * d[j]));
        Some((theta, inv))
    }

    /// Held-out SSE of block `b` for the estimate `theta` of `cols`.
    fn block_sse(&self, b: usize, cols: &[usize], theta: &DVector<f64>) -> f64 {
        let g = &self.grams[b];
        let mut s = g[(self.p, self.p)];
        for (r, &i) in cols.iter().enumerate() {
            s -= 2.0 * theta[r] * g[(i, self.p)];
            for (q, &j) in cols.iter().enumerate() {
                s += theta[r] * theta[q] * g[(i, j)];
            }
        }
        s.max(0.0)
    }

    /// Fits `cols` on every block (estimate and block sandwich) and by cross-validation.
    pub fn fit(&self, cols: &[usize]) -> Result<SubsetFit, Unfit> {
        let g = self.n_blocks();
        if g < self.folds || cols.is_empty() || cols.iter().any(|&c| c >= self.p) {
            return Err(Unfit::TooFewData);
        }
        let (a, c, n) = self.normal(cols, |_| true);
        if n <= cols.len() as f64 {
            return Err(Unfit::TooFewData);
        }
        let (theta, inv) = Self::solve(a, &c).ok_or(Unfit::NotPositiveDefinite)?;
        // Block sandwich: the score of block b is the block's share of the estimating equation.
        let k = cols.len();
        let mut meat = DMatrix::zeros(k, k);
        for b in 0..g {
            let (ab, cb, _) = self.normal_over(cols, core::iter::once(b));
            let s = cb - ab * &theta;
            meat += &s * s.transpose();
        }
        let corr = g as f64 / (g as f64 - 1.0).max(1.0);
        let cov = &inv * meat * &inv * corr;
        let sigma = (0..k).map(|i| cov[(i, i)].max(0.0).sqrt()).collect();
        let mut cv_sse = vec![0.0; g];
        for f in 0..self.folds {
            let (af, cf, _) = self.normal(cols, |x| self.fold[x] != f);
            let (tf, _) = Self::solve(af, &cf).ok_or(Unfit::NotPositiveDefinite)?;
            for (b, sse) in cv_sse.iter_mut().enumerate() {
                if self.fold[b] == f {
                    *sse = self.block_sse(b, cols, &tf);
                }
            }
        }
        Ok(SubsetFit {
            cols: cols.to_vec(),
            theta: theta.iter().copied().collect(),
            sigma,
            cv_sse,
        })
    }

    /// Held-out R² of a fit: `1 − ΣSSE_cv / Σ(z − z̄)²` (`z̄ = 0` when the design has no column
    /// of ones).
    pub fn cv_r2(&self, f: &SubsetFit) -> f64 {
        let zz: f64 = self.grams.iter().map(|g| g[(self.p, self.p)]).sum();
        let n: f64 = (0..self.n_blocks()).map(|b| self.rows(b)).sum();
        let mean_sq = self.output_mean().map_or(0.0, |m| m * m * n);
        let sst = (zz - mean_sq).max(1e-300);
        1.0 - f.cv_sse.iter().sum::<f64>() / sst
    }

    /// Marks column `j` as the column of ones (for [`Self::cv_r2`]).
    pub fn with_ones(mut self, j: usize) -> Self {
        self.ones = (j < self.p).then_some(j);
        self
    }

    /// Mean of the output, from the column of ones if the design has one.
    fn output_mean(&self) -> Option<f64> {
        let ones = self.ones?;
        let (mut s, mut n) = (0.0, 0.0);
        for (b, g) in self.grams.iter().enumerate() {
            s += g[(ones, self.p)];
            n += self.rows(b);
        }
        Some(s / n)
    }
}

/// The held-out gain of model 1 over model 0, block by block: `(z, mean gain relative to model
/// 0's mean held-out SSE)`, with `z = Σd_b / √(Σd_b²)` the normal approximation of the sign-flip
/// (randomisation) test of the gains `d_b = SSE₀_b − SSE₁_b`: under "no gain" each block's gain
/// is as likely negative as positive, whatever its size, so `Σ s_b|d_b|` with random signs has
/// variance `Σd_b²` (Fisher's randomisation test; Efron 1969 for the normal approximation). Why
/// not the ordinary paired t: a term's gain concentrates in the few blocks where it is excited
/// (β² where the rudder moved), and the t's spread about the mean counts that concentration as
/// noise — on a JSBSim flight a planted `C_mβ²` cut the held-out error by 33 % and its paired t
/// was 1.9; the sign-flip statistic asks only whether the gains lean positive beyond chance.
pub fn gain(sse0: &[f64], sse1: &[f64]) -> (f64, f64) {
    let g = sse0.len().min(sse1.len());
    if g < 2 {
        return (0.0, 0.0);
    }
    let d: Vec<f64> = (0..g).map(|b| sse0[b] - sse1[b]).collect();
    let sum = d.iter().sum::<f64>();
    let ss = d.iter().map(|x| x * x).sum::<f64>();
    let z = if ss > 0.0 { sum / ss.sqrt() } else { 0.0 };
    let base = sse0.iter().sum::<f64>() / g as f64;
    (z, if base > 0.0 { sum / g as f64 / base } else { 0.0 })
}

/// Upper `p` quantile of Student's t with `nu` degrees of freedom (`P(T > t) = p`), by bisection
/// on the regularised incomplete beta function. Written here rather than taken from `statrs`:
/// that crate pins another nalgebra major version, a second copy in every build for one function.
pub fn student_t_upper_quantile(p: f64, nu: f64) -> f64 {
    if !(p > 0.0 && p < 0.5 && nu > 0.0) {
        return f64::NAN;
    }
    // P(T > t) = I_{ν/(ν+t²)}(ν/2, 1/2)/2 for t > 0, decreasing in t.
    let tail = |t: f64| 0.5 * reg_inc_beta(nu / 2.0, 0.5, nu / (nu + t * t));
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while tail(hi) > p {
        hi *= 2.0;
        if hi > 1e8 {
            return hi;
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Regularised incomplete beta `I_x(a, b)` (continued fraction, modified Lentz; Press et al.,
/// *Numerical Recipes* §6.4, whose symmetry switch keeps the fraction convergent).
pub fn reg_inc_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_cf(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_cf(b, a, 1.0 - x) / b
    }
}

fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..400 {
        let m = m as f64;
        let m2 = 2.0 * m;
        // One Lentz step: the fraction's next coefficient updates `c` and `d` (kept off zero).
        let step = |aa: f64, c: &mut f64, d: &mut f64| {
            *d = 1.0 + aa * *d;
            if d.abs() < TINY {
                *d = TINY;
            }
            *c = 1.0 + aa / *c;
            if c.abs() < TINY {
                *c = TINY;
            }
            *d = 1.0 / *d;
            *d * *c
        };
        h *= step(m * (b - m) * x / ((qam + m2) * (a + m2)), &mut c, &mut d);
        let del = step(-(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)), &mut c, &mut d);
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// `ln Γ(x)`, x > 0 (Lanczos, g = 7, n = 9; relative error below 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = core::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut s = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * core::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn student_t_quantiles_match_the_tables() {
        // Abramowitz & Stegun table 26.10 (two-sided 0.05 and 0.001 → upper 0.025, 0.0005).
        for (p, nu, t) in [
            (0.025, 10.0, 2.228),
            (0.025, 30.0, 2.042),
            (0.0005, 10.0, 4.587),
            (0.0005, 20.0, 3.850),
            (0.05, 5.0, 2.015),
        ] {
            let q = student_t_upper_quantile(p, nu);
            assert!((q - t).abs() < 1e-3, "t({p}, {nu}) = {q}, table {t}");
        }
        // Large ν: the normal quantile.
        let q = student_t_upper_quantile(0.025, 1e7);
        assert!((q - 1.959_964).abs() < 1e-4, "{q}");
    }

    fn design_with(effect: f64, seed: u64) -> Design {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nrm = Normal::new(0.0, 1.0).unwrap();
        let n = 6000;
        let x: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.013).sin() + 0.3 * nrm.sample(&mut rng))
            .collect();
        let c: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.0071).cos() + 0.3 * nrm.sample(&mut rng))
            .collect();
        let ones = vec![1.0; n];
        let z: Vec<f64> = (0..n)
            .map(|i| 0.5 + 2.0 * x[i] + effect * c[i] + 0.1 * nrm.sample(&mut rng))
            .collect();
        Design::new(&[&ones, &x, &c], &z, 0.01, &CvSettings::default(), None).with_ones(0)
    }

    #[test]
    fn a_real_term_gains_on_held_out_blocks_and_a_null_one_does_not() {
        // GIVEN a regression with a real third term, and one without
        for (effect, real) in [(0.05, true), (0.0, false)] {
            let d = design_with(effect, 11);
            // WHEN the term is added to the model
            let m0 = d.fit(&[0, 1]).unwrap();
            let m1 = d.fit(&[0, 1, 2]).unwrap();
            let (z, _) = gain(&m0.cv_sse, &m1.cv_sse);
            let crit = student_t_upper_quantile(0.01, d.n_blocks() as f64 - 1.0);
            // THEN the held-out gain is beyond noise exactly when the term is real
            assert_eq!(z > crit, real, "effect {effect}: gain z {z}, critical {crit}");
            // and the estimates are right within 4σ
            assert!((m1.theta[2] - effect).abs() < 4.0 * m1.sigma[2], "{m1:?}");
            assert!(d.cv_r2(&m1) > 0.9);
        }
    }
}
