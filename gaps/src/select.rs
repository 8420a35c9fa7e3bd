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

/// Fewest manoeuvres whose pooled analysis holds out whole manoeuvres (leave one out): with two,
/// each fold's fit would rest on a single other manoeuvre.
pub const MIN_PIECES_FOR_FOLDS: usize = 3;

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
    /// The blocks' Grams summed per fold, and the fold's sample count: the normal equations of
    /// a fit on all blocks, or all but one fold, from `folds` matrices instead of every block's.
    fold_grams: Vec<(DMatrix<f64>, f64)>,
    /// The per-sample error covariance of `[X z]` (zero: ordinary least squares).
    w: DMatrix<f64>,
    /// Number of columns `p` (the output is column `p`).
    p: usize,
    /// The column of ones, if any.
    ones: Option<usize>,
    /// The columns and, last, the output, per sample (for [`Self::noise_gain`], which needs the
    /// held-out predictions sample by sample, not only their block sums).
    data: Vec<Vec<f64>>,
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
    /// The estimate of each fold's fit (that fold left out), in the order of `cols`.
    pub cv_theta: Vec<Vec<f64>>,
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
        Self::in_pieces(cols, z, h_s, cv, w, &[(0, z.len())])
    }

    /// [`Self::new`] for a flight of several manoeuvres (`pieces`: their sample ranges, in order,
    /// covering `0..n`): the blocks are cut inside each piece, never across a join. With
    /// [`MIN_PIECES_FOR_FOLDS`] pieces or more, the folds **are** the pieces (leave one manoeuvre
    /// out: each piece is predicted by a fit to the others, so a held-out gain is a gain on
    /// manoeuvres the fit never saw); with fewer, the blocks are dealt round-robin as for one
    /// record.
    pub fn in_pieces(
        cols: &[&[f64]],
        z: &[f64],
        h_s: f64,
        cv: &CvSettings,
        w: Option<&[f64]>,
        pieces: &[(usize, usize)],
    ) -> Self {
        let n = z.len();
        let p = cols.len();
        let len = ((cv.block_s / h_s).round() as usize).max(10);
        let mut blocks: Vec<(usize, usize)> = Vec::new();
        let mut piece_of: Vec<usize> = Vec::new();
        for (k, &(a, b)) in pieces.iter().enumerate() {
            let m = b - a;
            let g = (m / len).max(1);
            blocks.extend((0..g).map(|i| (a + i * m / g, a + (i + 1) * m / g)));
            piece_of.extend(core::iter::repeat_n(k, g));
        }
        let g = blocks.len();
        let (folds, fold): (usize, Vec<usize>) = if pieces.len() >= MIN_PIECES_FOR_FOLDS {
            (pieces.len(), piece_of)
        } else {
            let folds = cv.folds.clamp(2, g.max(2));
            (folds, (0..g).map(|i| i % folds).collect())
        };
        // Each block's Gram `[X z]ᵀ[X z]` by dot products of the columns' slices (blocks of a few
        // hundred rows and a few tens of columns: a matrix product's packing costs more than the
        // products), each entry computed once and stored in both triangles.
        let col = |j: usize| if j < p { &cols[j][..n] } else { &z[..n] };
        let grams: Vec<DMatrix<f64>> = blocks
            .iter()
            .map(|&(a, b)| {
                let mut m = DMatrix::zeros(p + 1, p + 1);
                for c in 0..=p {
                    for r in 0..=c {
                        let v = super::signal::dot(&col(r)[a..b], &col(c)[a..b]);
                        m[(r, c)] = v;
                        m[(c, r)] = v;
                    }
                }
                m
            })
            .collect();
        let mut fold_grams = vec![(DMatrix::zeros(p + 1, p + 1), 0.0); folds];
        for (b, g) in grams.iter().enumerate() {
            let (sum, rows) = &mut fold_grams[fold[b]];
            *sum += g;
            *rows += (blocks[b].1 - blocks[b].0) as f64;
        }
        let w = match w {
            Some(w) if w.len() == (p + 1) * (p + 1) => DMatrix::from_row_slice(p + 1, p + 1, w),
            _ => DMatrix::zeros(p + 1, p + 1),
        };
        let data = cols
            .iter()
            .map(|c| c[..n].to_vec())
            .chain(core::iter::once(z.to_vec()))
            .collect();
        Self {
            blocks,
            fold,
            folds,
            grams,
            fold_grams,
            w,
            p,
            ones: None,
            data,
        }
    }

    /// Number of blocks.
    pub fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    fn rows(&self, b: usize) -> f64 {
        (self.blocks[b].1 - self.blocks[b].0) as f64
    }

    /// `(A, c)` of the normal equations of `cols` over the folds `use_fold` selects.
    fn normal(&self, cols: &[usize], use_fold: impl Fn(usize) -> bool) -> (DMatrix<f64>, DVector<f64>, f64) {
        let k = cols.len();
        let mut a = DMatrix::zeros(k, k);
        let mut c = DVector::zeros(k);
        let mut n = 0.0;
        for (_, (g, rows)) in self.fold_grams.iter().enumerate().filter(|(f, _)| use_fold(*f)) {
            n += rows;
            Self::add_normal(&mut a, &mut c, g, cols, self.p);
        }
        self.correct(&mut a, &mut c, cols, n);
        (a, c, n)
    }

    /// Adds the entries of `cols` (and the output column `p`) of the Gram `g` to `(a, c)`.
    fn add_normal(a: &mut DMatrix<f64>, c: &mut DVector<f64>, g: &DMatrix<f64>, cols: &[usize], p: usize) {
        for (s, &j) in cols.iter().enumerate() {
            c[s] += g[(j, p)];
            for (r, &i) in cols.iter().enumerate() {
                a[(r, s)] += g[(i, j)];
            }
        }
    }

    /// The errors-in-variables correction of `n` samples' normal equations: `− n W`.
    fn correct(&self, a: &mut DMatrix<f64>, c: &mut DVector<f64>, cols: &[usize], n: f64) {
        for (r, &i) in cols.iter().enumerate() {
            c[r] -= n * self.w[(i, self.p)];
            for (s, &j) in cols.iter().enumerate() {
                a[(r, s)] -= n * self.w[(i, j)];
            }
        }
    }

    /// `(A, c)` of the normal equations of `cols` over block `b`.
    fn normal_of_block(&self, cols: &[usize], b: usize) -> (DMatrix<f64>, DVector<f64>) {
        let k = cols.len();
        let mut a = DMatrix::zeros(k, k);
        let mut c = DVector::zeros(k);
        Self::add_normal(&mut a, &mut c, &self.grams[b], cols, self.p);
        self.correct(&mut a, &mut c, cols, self.rows(b));
        (a, c)
    }

    /// Whether `cols` has regular normal equations over all blocks before the errors-in-variables
    /// correction: when [`Self::fit`] finds them singular but this holds, the columns do vary
    /// independently, only not beyond their own measurement error.
    pub fn regular_without_errors(&self, cols: &[usize]) -> bool {
        if cols.iter().any(|&c| c >= self.p) {
            return false;
        }
        let k = cols.len();
        let mut a = DMatrix::zeros(k, k);
        let mut c = DVector::zeros(k);
        for (g, _) in &self.fold_grams {
            Self::add_normal(&mut a, &mut c, g, cols, self.p);
        }
        Self::solve(a, &c).is_some()
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
            let (ab, cb) = self.normal_of_block(cols, b);
            let s = cb - ab * &theta;
            meat += &s * s.transpose();
        }
        let corr = g as f64 / (g as f64 - 1.0).max(1.0);
        let cov = &inv * meat * &inv * corr;
        let sigma = (0..k).map(|i| cov[(i, i)].max(0.0).sqrt()).collect();
        let mut cv_sse = vec![0.0; g];
        let mut cv_theta = Vec::with_capacity(self.folds);
        for f in 0..self.folds {
            let (af, cf, _) = self.normal(cols, |x| x != f);
            let (tf, _) = Self::solve(af, &cf).ok_or(Unfit::NotPositiveDefinite)?;
            for (b, sse) in cv_sse.iter_mut().enumerate() {
                if self.fold[b] == f {
                    *sse = self.block_sse(b, cols, &tf);
                }
            }
            cv_theta.push(tf.iter().copied().collect());
        }
        Ok(SubsetFit {
            cols: cols.to_vec(),
            theta: theta.iter().copied().collect(),
            sigma,
            cv_sse,
            cv_theta,
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

    /// Held-out prediction of sample `i` (in block `b`) by `f`'s fit without `b`'s fold.
    fn held_out(&self, f: &SubsetFit, b: usize, i: usize) -> f64 {
        let th = &f.cv_theta[self.fold[b]];
        f.cols.iter().zip(th).map(|(&c, t)| t * self.data[c][i]).sum()
    }

    /// The held-out gain of `f1` over `f0` against the noise of the held-out residuals:
    /// `T = Σ_b d_b / √Var(Σ_b d_b)`, `d_b = SSE₀_b − SSE₁_b`.
    ///
    /// Why: if model 1's extra terms carry nothing, the held-out predictions of block `b` differ
    /// by `δ_b` (fitted on the other folds, so independent of the block's noise `e_b`) and
    /// `d_b = 2δ_bᵀe_b − ‖δ_b‖²`: mean `−‖δ_b‖² ≤ 0`. `T` is that null law's standardised sum,
    /// one-sided normal (conservative: the mean is ≤ 0). With a real term of partial t-statistic
    /// `t`, `T ≈ t/2` — unlike the sign-flip `z` of [`gain`], which cannot exceed `√k` when the
    /// gain lives in `k` excited blocks, whatever its size (two rudder doublets: `k` ≈ 3, `z` ≤ 1.7
    /// below any 1 % critical value).
    ///
    /// **The variance is taken over every held-out stretch, not block by block.** A stretch is a
    /// run of adjacent blocks of one fold (a whole manoeuvre when the folds are the manoeuvres; one
    /// block when the blocks are dealt round-robin): its blocks are predicted by one fit and their
    /// noise is one correlated record, so `Var = Σ_s 4 δ_sᵀ Cov(e_s) δ_s` over the stretches `s`,
    /// the covariance between the blocks of a stretch included. Turbulence sets that correlation:
    /// MIL-F-8785C at low altitude has `L_w = h` and `L_u = L_v ≈ 260 m` at 100 m, so at 15 m/s
    /// the gust the estimated α and β miss stays correlated for 7–17 s, longer than a block (2 s)
    /// and about a manoeuvre (6–10 s). Summing the block variances alone drops those cross terms
    /// and states a gain that several adjacent blocks share as that many independent ones.
    ///
    /// `Cov(e_s)_ij = σ_i σ_j ρ(|i − j|)`: `σ_i²` the mean square of model 1's held-out residual in
    /// sample `i`'s block (turbulence and manoeuvres change the noise level from block to block),
    /// `ρ` the autocorrelation of the residual scaled by those levels, pooled over the stretches
    /// with lags within each and every lag up to the longest stretch, each lag's sum divided by
    /// its number of products (the unbiased estimate: a weight falling with the lag, as a
    /// Bartlett window, would shrink the long lags the turbulence fills). A stretch's variance is
    /// floored at its white-residual part, as the coloured-residual σ of
    /// [`super::regress::ResidualLags`] is: fitted residuals understate their long-lag
    /// correlation, so a sum below the lag-0 term is an estimation artefact.
    pub fn noise_gain(&self, f0: &SubsetFit, f1: &SubsetFit) -> f64 {
        let g = self.n_blocks();
        if g < 2 || f0.cv_theta.len() != self.folds || f1.cv_theta.len() != self.folds {
            return 0.0;
        }
        let z = &self.data[self.p];
        let mut stretches: Vec<Stretch> = Vec::new();
        for (b, &(a, e)) in self.blocks.iter().enumerate() {
            let resid: Vec<f64> = (a..e).map(|i| z[i] - self.held_out(f1, b, i)).collect();
            let level = (resid.iter().map(|x| x * x).sum::<f64>() / resid.len().max(1) as f64).sqrt();
            let joins = b > 0 && self.fold[b] == self.fold[b - 1] && self.blocks[b - 1].1 == a;
            if !joins {
                stretches.push(Stretch::default());
            }
            let s = stretches.last_mut().expect("a stretch was pushed");
            s.gain += f0.cv_sse[b] - f1.cv_sse[b];
            for (i, r) in (a..e).zip(&resid) {
                s.delta
                    .push((self.held_out(f1, b, i) - self.held_out(f0, b, i)) * level);
                s.scaled.push(if level > 0.0 { r / level } else { 0.0 });
            }
        }
        stretch_gain(&stretches)
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

/// One held-out stretch of [`Design::noise_gain`]: the difference of the two models' held-out
/// predictions times the residual level of each sample's block, the residual over that level, and
/// the stretch's gain `Σ d_b`.
#[derive(Debug, Default)]
struct Stretch {
    delta: Vec<f64>,
    scaled: Vec<f64>,
    gain: f64,
}

/// `Σ_s gain_s / √(Σ_s 4 δ̃_sᵀ R δ̃_s)` over the stretches ([`Design::noise_gain`] explains it):
/// `R` the Toeplitz matrix of the scaled residuals' pooled, unbiased autocorrelation; 0 when the
/// variance is 0.
fn stretch_gain(stretches: &[Stretch]) -> f64 {
    let len = stretches.iter().map(|s| s.scaled.len()).max().unwrap_or(0);
    if len == 0 {
        return 0.0;
    }
    let mut sums = vec![0.0; len];
    let mut pairs = vec![0.0; len];
    for s in stretches {
        let n = s.scaled.len();
        for (k, v) in super::regress::lag_sums(&s.scaled, n.saturating_sub(1))
            .into_iter()
            .enumerate()
        {
            sums[k] += v;
            pairs[k] += (n - k) as f64;
        }
    }
    let rho: Vec<f64> = sums
        .iter()
        .zip(&pairs)
        .map(|(s, p)| if *p > 0.0 { s / p } else { 0.0 })
        .collect();
    let (mut sum, mut var) = (0.0, 0.0);
    for s in stretches {
        sum += s.gain;
        let c = super::regress::lag_sums(&s.delta, s.delta.len().saturating_sub(1));
        let white = c.first().copied().unwrap_or(0.0) * rho[0];
        var += 4.0 * lag_form(&c, &rho).max(white).max(0.0);
    }
    gain_over_noise(sum, var)
}

/// `δᵀ R δ` from the lag sums `c_k = Σ_t δ_t δ_{t+k}` of `δ` and the autocorrelation `ρ_k` of
/// the Toeplitz `R`: `c₀ρ₀ + 2 Σ_{k>0} c_k ρ_k` (lags beyond the shorter of the two dropped).
fn lag_form(c: &[f64], rho: &[f64]) -> f64 {
    c.iter()
        .zip(rho)
        .enumerate()
        .map(|(k, (c, r))| if k == 0 { c * r } else { 2.0 * c * r })
        .sum()
}

/// The summed gain over the square root of its variance; 0 when the variance is 0.
fn gain_over_noise(sum: f64, var: f64) -> f64 {
    if var > 0.0 {
        sum / var.sqrt()
    } else {
        0.0
    }
}

/// The noise-referenced held-out gain `T = Σ_b d_b / √(Σ_b 4 σ_b² δ_bᵀ R δ_b)` of model 1 over
/// model 0 with the blocks taken as independent (the null law is [`Design::noise_gain`]'s): per
/// block `δ_b` the difference of the two models' held-out predictions (or errors), `resid` model
/// 1's held-out residual, `sse0`, `sse1` the blocks' held-out SSEs; `σ_b²` the block's mean
/// square residual and `R` the residual's autocorrelation with lags within a block,
/// Bartlett-tapered to the longest block. The sensor checks and the output-error path judge their
/// own segments with it. 0 when the variance is 0.
pub fn noise_referenced_gain(delta: &[Vec<f64>], resid: &[Vec<f64>], sse0: &[f64], sse1: &[f64]) -> f64 {
    // Autocorrelation of the held-out residuals, lags within a block, each block's own
    // mean square as its scale.
    let mean_sq: Vec<f64> = resid
        .iter()
        .map(|r| r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64)
        .collect();
    let len = resid.iter().map(|r| r.len()).max().unwrap_or(0);
    let mut acf = vec![0.0; len];
    let mut norm = 0.0;
    // The lag sums by FFT (`regress::lag_sums`): every lag of a block is summed, `O(N²)` directly.
    for (r, &ms) in resid.iter().zip(&mean_sq) {
        if ms <= 0.0 {
            continue;
        }
        for (a, s) in acf
            .iter_mut()
            .zip(super::regress::lag_sums(r, r.len().saturating_sub(1)))
        {
            *a += s / ms;
        }
        norm += r.len() as f64;
    }
    if norm <= 0.0 {
        return 0.0;
    }
    let rho: Vec<f64> = acf
        .iter()
        .enumerate()
        .map(|(k, a)| a / norm * (1.0 - k as f64 / len as f64))
        .collect();
    let (mut sum, mut var) = (0.0, 0.0);
    for (b, (d, ms)) in delta.iter().zip(&mean_sq).enumerate() {
        sum += sse0[b] - sse1[b];
        let lags = d.len().min(rho.len());
        let c = super::regress::lag_sums(d, lags.saturating_sub(1));
        var += 4.0 * ms * lag_form(&c, &rho).max(0.0);
    }
    gain_over_noise(sum, var)
}

/// The held-out gain of model 1 over model 0, block by block: `(z, mean gain relative to model
/// 0's mean held-out SSE)`, with `z = Σd_b / √(Σd_b²)` the normal approximation of the sign-flip
/// (randomisation) test of the gains `d_b = SSE₀_b − SSE₁_b`: under "no gain" each block's gain
/// is as likely negative as positive, whatever its size, so `Σ s_b|d_b|` with random signs has
/// variance `Σd_b²` (Fisher's randomisation test; Efron 1969 for the normal approximation).
/// Self-normalised, it cannot exceed `√k` when the gain lives in `k` blocks, so the selection
/// uses it only for the direction (`z > 0`, and "not significantly worse" for alternatives) and
/// tests the size against the noise with [`Design::noise_gain`].
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

/// `min_detectable / σ` for an entry threshold `threshold_t2`, a held-out critical value `crit`
/// and `dof` degrees of freedom of both: a real error's noise-referenced held-out gain `T` is about
/// half its `t`, so the held-out test needs `t ≈ 2·T_crit`.
pub fn detection_factor(threshold_t2: f64, crit: f64, dof: f64) -> f64 {
    threshold_t2.sqrt().max(2.0 * crit) + student_t_upper_quantile(0.2, dof.max(1.0))
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
pub(crate) fn ln_gamma(x: f64) -> f64 {
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

/// Upper tail `P(χ²_k > x)` of the chi-square law with `k` degrees of freedom: the regularised
/// upper incomplete gamma `Q(k/2, x/2)`, by its series below `a + 1` and its continued fraction
/// above (Numerical Recipes §6.2, `gser`/`gcf`).
pub fn chi2_sf(x: f64, k: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return 1.0;
    }
    let (a, x) = (0.5 * k, 0.5 * x);
    let front = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..500 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * front).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..500 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (front * h).clamp(0.0, 1.0)
    }
}

/// Cochran's Q of estimates `θ_k ± σ_k` of one quantity (Cochran 1954): `Q = Σ w_k(θ_k − θ̄)²`,
/// `w_k = 1/σ_k²`, `θ̄` the inverse-variance mean; under homogeneity `Q ~ χ²` with `k − 1`
/// degrees of freedom. Returns `(Q, θ̄, p)`; `None` with fewer than two finite estimates.
pub fn cochran_q(estimates: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let ok: Vec<(f64, f64)> = estimates
        .iter()
        .copied()
        .filter(|(t, s)| t.is_finite() && s.is_finite() && *s > 0.0)
        .collect();
    if ok.len() < 2 {
        return None;
    }
    let sw: f64 = ok.iter().map(|(_, s)| 1.0 / (s * s)).sum();
    let mean = ok.iter().map(|(t, s)| t / (s * s)).sum::<f64>() / sw;
    let q: f64 = ok.iter().map(|(t, s)| ((t - mean) / s).powi(2)).sum();
    Some((q, mean, chi2_sf(q, (ok.len() - 1) as f64)))
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

    /// A regression whose third column is excited only in three short pulses (like two or three
    /// rudder doublets), with AR(1) noise of correlation 0.9 per sample (coloured, as the
    /// residuals of smoothed turbulent data).
    fn pulse_design(effect: f64, seed: u64) -> Design {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nrm = Normal::new(0.0, 1.0).unwrap();
        let n = 9000;
        let x: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.011).sin() + 0.3 * nrm.sample(&mut rng))
            .collect();
        let c: Vec<f64> = (0..n)
            .map(|i| {
                let on = [2_000..2_150, 5_000..5_150, 7_600..7_750]
                    .iter()
                    .any(|r| r.contains(&i));
                if on {
                    ((i % 150) as f64 / 150.0 * core::f64::consts::TAU).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let ones = vec![1.0; n];
        let mut e = 0.0;
        let z: Vec<f64> = (0..n)
            .map(|i| {
                e = 0.9 * e + 0.1 * nrm.sample(&mut rng);
                0.5 + 2.0 * x[i] + effect * c[i] + e
            })
            .collect();
        Design::new(&[&ones, &x, &c], &z, 0.01, &CvSettings::default(), None).with_ones(0)
    }

    #[test]
    fn a_gain_in_three_excited_blocks_is_beyond_noise_where_the_sign_flip_cannot_be() {
        // GIVEN a real term excited in three pulses only (noise σ ≈ 0.23, effect amplitude 0.6)
        let d = pulse_design(0.6, 5);
        let crit = student_t_upper_quantile(0.01, d.n_blocks() as f64 - 1.0);
        // WHEN it is added to the model
        let m0 = d.fit(&[0, 1]).unwrap();
        let m1 = d.fit(&[0, 1, 2]).unwrap();
        let (z, _) = gain(&m0.cv_sse, &m1.cv_sse);
        let t = d.noise_gain(&m0, &m1);
        // THEN the sign-flip statistic is bounded by √(excited blocks) (≤ 3 blocks plus the
        // ones the pulses straddle: ≤ √6) and below the critical value, while the gain against
        // the noise is far beyond it, near half the term's t (T ≈ t/2, the doc's law)
        assert!(z < 6f64.sqrt() && z < crit, "sign-flip z {z}, critical {crit}");
        assert!(t > crit, "noise-referenced T {t}, critical {crit}");
        let half_t = 0.5 * m1.t2(2).sqrt();
        assert!(t > 0.5 * half_t && t < 2.0 * half_t, "T {t} against t/2 {half_t}");
    }

    #[test]
    fn a_null_term_rarely_passes_the_noise_referenced_gain() {
        // GIVEN 60 seeded flights where the pulsed term carries nothing, under coloured noise
        let mut passed = 0;
        for seed in 0..60 {
            let d = pulse_design(0.0, 100 + seed);
            let crit = student_t_upper_quantile(0.01, d.n_blocks() as f64 - 1.0);
            let m0 = d.fit(&[0, 1]).unwrap();
            let m1 = d.fit(&[0, 1, 2]).unwrap();
            // WHEN the held-out gain is tested against the noise
            if d.noise_gain(&m0, &m1) > crit {
                passed += 1;
            }
        }
        // THEN the one-sided 1 % test passes at most 2 of 60: with the true rate 1 %, P(≥ 3)
        // = 2.3 %; the statistic's null mean is ≤ 0, so it should pass fewer
        assert!(passed <= 2, "{passed} of 60 null terms passed");
    }

    #[test]
    fn chi_square_tail_matches_the_tables() {
        // Tabulated upper quantiles (Abramowitz & Stegun table 26.8): P(χ²_k > x).
        for (x, k, p) in [
            (3.841_459, 1.0, 0.05),
            (9.210_340, 2.0, 0.01),
            (11.070_50, 5.0, 0.05),
            (2.204_131, 6.0, 0.90),
        ] {
            assert!(
                (chi2_sf(x, k) - p).abs() < 2e-4,
                "χ²({k}) > {x}: {} vs {p}",
                chi2_sf(x, k)
            );
        }
    }

    #[test]
    fn cochran_q_separates_agreeing_from_scattered_estimates() {
        let agree = [(1.0, 0.1), (1.05, 0.1), (0.95, 0.1), (1.02, 0.2)];
        let (q, mean, p) = cochran_q(&agree).unwrap();
        assert!(q < 1.0 && (mean - 1.0).abs() < 0.05 && p > 0.5, "{q} {mean} {p}");
        let scatter = [(1.0, 0.1), (2.0, 0.1), (0.0, 0.1)];
        let (q, _, p) = cochran_q(&scatter).unwrap();
        assert!((q - 200.0).abs() < 1e-9 && p < 1e-12, "{q} {p}");
        assert!(cochran_q(&[(1.0, 0.1)]).is_none());
    }
}
