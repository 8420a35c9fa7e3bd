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
/// `R_vv` estimated per block with divisor `N_block`).
pub fn coloured_variance(w: &[f64], v: &[f64], block_len: usize, max_lag: usize) -> f64 {
    let n = w.len();
    let bl = block_len.max(1);
    let mut total = 0.0;
    let mut start = 0;
    while start < n {
        let end = (start + bl).min(n);
        let (wb, vb) = (&w[start..end], &v[start..end]);
        let nb = wb.len();
        let lmax = max_lag.min(nb.saturating_sub(1));
        for k in 0..=lmax {
            let r: f64 = (0..nb - k).map(|i| vb[i] * vb[i + k]).sum::<f64>() / nb as f64;
            let ww: f64 = (0..nb - k).map(|i| wb[i] * wb[i + k]).sum();
            total += if k == 0 { r * ww } else { 2.0 * r * ww };
        }
        start = end;
    }
    total.max(0.0)
}

/// OLS of `z` on the columns `cols` with coloured-residual standard errors (`block_len`: length of
/// each independent block of stacked data, `z.len()` for a single series). `None` when the columns
/// are (numerically) dependent: a column whose part orthogonal to the others is below `1e-9` of its
/// own norm.
pub fn ols(cols: &[Vec<f64>], z: &[f64], block_len: usize, max_lag: usize) -> Option<Fit> {
    ols_sigma(cols, z, block_len, max_lag, None)
}

/// [`ols`], with the coloured-residual σ computed only for parameter `only` when given (the
/// others are then NaN): the partial test needs only the candidate's.
pub fn ols_sigma(cols: &[Vec<f64>], z: &[f64], block_len: usize, max_lag: usize, only: Option<usize>) -> Option<Fit> {
    let n = z.len();
    let p = cols.len();
    if p == 0 || n <= p || cols.iter().any(|c| c.len() != n) {
        return None;
    }
    let scale: Vec<f64> = cols
        .iter()
        .map(|c| (c.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt())
        .collect();
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    let x = DMatrix::from_fn(n, p, |i, j| cols[j][i] / scale[j]);
    let qr = x.clone().qr();
    let r = qr.r();
    let dmax = (0..p).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
    if (0..p).any(|i| r[(i, i)].abs() < 1e-9 * dmax.max(1e-300)) {
        return None;
    }
    let qtz = qr.q().transpose() * DVector::from_column_slice(z);
    let ts = r.solve_upper_triangular(&qtz)?;
    let residual: Vec<f64> = (0..n)
        .map(|i| z[i] - (0..p).map(|j| x[(i, j)] * ts[j]).sum::<f64>())
        .collect();
    // W = X (XᵀX)⁻¹ = Q R⁻ᵀ: column j of W is the weight series of parameter j.
    let rinv = r.clone().try_inverse()?;
    let w = qr.q() * rinv.transpose();
    let mut theta = vec![0.0; p];
    let mut sigma = vec![0.0; p];
    for j in 0..p {
        theta[j] = ts[j] / scale[j];
        if only.is_some_and(|k| k != j) {
            sigma[j] = f64::NAN;
            continue;
        }
        let wj: Vec<f64> = w.column(j).iter().copied().collect();
        sigma[j] = coloured_variance(&wj, &residual, block_len, max_lag).sqrt() / scale[j];
    }
    Some(Fit { theta, sigma, residual })
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

    #[test]
    fn dependent_columns_are_refused() {
        let x: Vec<f64> = (0..100).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 2.0 * v).collect();
        assert!(ols(&[x.clone(), y], &x, 100, 5).is_none());
    }
}
