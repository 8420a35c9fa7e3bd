//! The residual of an output-error fit in turbulence modelled as a correlated process (per output a
//! first-order Gauss–Markov or a band-pass kernel) plus white noise, its parameters fitted through
//! the fit's residual maker, and the parameter covariance that model implies
//! ([`super::gust_covariance`]).
//!
//! Why a model and not the lag sums alone: on one manoeuvre of a few gust correlation times the
//! fit absorbs the residual's slow part (the residual is orthogonal to the sensitivities), and the
//! Morelli–Klein sum of the residual's sample autocorrelations over every lag is then biased low,
//! by a factor no lag window removes (the fixed-b limit of Kiefer & Vogelsang 2005, Econometric
//! Theory 21(6): with the bandwidth a fixed share of the record, the long-run variance estimate
//! stays random and its mean depends on the unknown correlation). A parametric correlation whose
//! expected sample autocorrelations are computed through the residual maker is unbiased where the
//! model holds.
//!
//! The model, in the weighted residual `ṽ = W^{1/2} v` (stacked `(t, a)`, `N` samples, `n_y`
//! outputs): `Cov(ẽ_{t,a}, ẽ_{s,b}) = C_ab k_ab(|t−s|) + D_a δ_ab δ_ts`. Each output has its own
//! correlation per sample `ρ_a = exp(−Δt/τ_a)` (the gust reaches a vane directly, a rate gyro
//! through the short-period response: not with one correlation time) and its own kernel
//! ([`Kernel`]): the first-order Gauss–Markov `ρ^k`, the Dryden shaping filter's first-order form
//! (`τ = L/V`, MIL-F-8785C), whose spectrum is largest at zero frequency; or the band-pass
//! `ρ^k (1 − k ln(1/ρ))`, whose spectrum is zero there. Why the second: an aircraft's air-relative
//! motion does not respond to a steady wind, only to its changes, so the part of a vane's or a rate
//! gyro's residual that is the aircraft's response to the gusts has little power below the
//! response's band; the low-pass kernel, fitted at the lags the record shows, then extrapolates
//! power to zero frequency, where an intercept's sensitivity lies, and overstates the intercept's
//! variance (`tests`: on band-pass draws the low-pass kernel overstates the intercept's variance
//! 4.6-fold). An output that integrates such a response (a roll angle from the roll rate) keeps
//! power at zero frequency, where the low-pass kernel is the expected one. Which kernel an output
//! gets is not assumed but fitted (below). A pair's kernel is at the geometric mean
//! `ρ_ab = √(ρ_a ρ_b)`, band-pass if either output's is (a process with no power at zero
//! frequency has no cross-power there); `C` is positive semi-definite (each output's correlated
//! share and the outputs' cross-covariance: one turbulence field drives them all), `D ≥ 0` (the
//! sensors' white noise). The fit's linearised residual is `ṽ = Q ẽ`, `Q = I − S̃ M⁻¹ S̃ᵀ` (`S̃` the
//! weighted sensitivities, `M` the information with the prior), so the expected sample
//! autocovariance `r̂_ab(k) = (1/N) Σ_t ṽ_{t,a} ṽ_{t+k,b}` is linear in `(C, D)`: `E r̂ = L(Q B
//! Qᵀ)` for each basis covariance `B`, where `L` sums the lag-`k` diagonal. Each output's `τ_a`
//! and kernel are the best of a log-spaced grid of times (two samples to the record; a longer
//! correlation cannot be told from a drift within one record) for each of the two kernels, for
//! output `a`'s own autocovariance (`C_aa ≥ 0`, `D_a` by least squares of `E r̂_aa = r̂_aa` over
//! lags `0 ≤ k < N/2`, a method of moments): both kernels have one time and two variances, so the
//! least squares that picks the time picks the kernel, with no penalty between them. Then `(C, D)`
//! are the least-squares solution over every ordered output pair, `C` is projected onto the
//! positive semi-definite cone (negative eigenvalues set to 0) and `D` clipped at 0. The meat is
//! `S̃ᵀ Σ̂ S̃`. Readings chosen: the prior's pseudo-data are white and stay out of `Q`'s noise (a
//! prior is a weak pull here); the geometric-mean correlation and the pair's kernel are model
//! choices (exact when the outputs share one correlation time and kernel), and the clipping makes
//! the stated variance biased up where a correlated share is near zero. What one record can tell:
//! on a record of five correlation times (`tests`, 200 draws) the band-pass kernel is chosen on
//! 66 % of band-pass draws and on 63 % of first-order Gauss–Markov draws, so the choice is weak
//! evidence; the slopes' stated variance is unbiased either way, and an intercept's is not
//! understated on Gauss–Markov draws.

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

/// One segment's weighted residuals `ṽ` (`N·n_y`, stacked `(t, a)` as `t·n_y + a`) and weighted
/// sensitivities `S̃` (`N·n_y × n_p`).
pub(super) struct WeightedSegment {
    pub v: DMatrix<f64>,
    pub s: DMatrix<f64>,
}

/// Correlation times tried, s: log-spaced from two samples to the record.
const GRID: usize = 16;

/// `r(c, d, k) = (1/N) Σ_t Σ_p x[(t, c), p] y[(t + k, d), p]` for `k < kmax`, laid out
/// `(c·n_y + d)·kmax + k`; by FFT (zero-padded to `M ≥ 2N`, no circular wrap). With `only =
/// Some(o)` just the pair `(o, o)` is computed (the correlation-time search reads no other) and the
/// rest of the layout is 0.
fn lag_stats(
    planner: &mut RealFftPlanner<f64>,
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
    ny: usize,
    kmax: usize,
    only: Option<usize>,
) -> Vec<f64> {
    let wanted = |a: usize| only.is_none_or(|o| o == a);
    let n = x.nrows() / ny;
    let m = (2 * n).next_power_of_two();
    let fwd = planner.plan_fft_forward(m);
    let inv = planner.plan_fft_inverse(m);
    let spectra = |z: &DMatrix<f64>| -> Vec<Vec<Vec<Complex<f64>>>> {
        (0..ny)
            .map(|a| {
                if !wanted(a) {
                    return Vec::new();
                }
                (0..z.ncols())
                    .map(|p| {
                        let mut input = vec![0.0; m];
                        for t in 0..n {
                            input[t] = z[(t * ny + a, p)];
                        }
                        let mut out = fwd.make_output_vec();
                        if fwd.process(&mut input, &mut out).is_err() {
                            out.fill(Complex::new(f64::NAN, 0.0));
                        }
                        out
                    })
                    .collect()
            })
            .collect()
    };
    let (xs, ys) = (spectra(x), spectra(y));
    let mut out = vec![0.0; ny * ny * kmax];
    for c in (0..ny).filter(|&c| wanted(c)) {
        for d in (0..ny).filter(|&d| wanted(d)) {
            let mut f = vec![Complex::new(0.0, 0.0); m / 2 + 1];
            for (xp, yp) in xs[c].iter().zip(&ys[d]) {
                for (fi, (a, b)) in f.iter_mut().zip(xp.iter().zip(yp)) {
                    *fi += a.conj() * b;
                }
            }
            f[0].im = 0.0;
            f[m / 2].im = 0.0;
            let mut r = inv.make_output_vec();
            if inv.process(&mut f, &mut r).is_err() {
                r.fill(f64::NAN);
            }
            for k in 0..kmax {
                out[(c * ny + d) * kmax + k] = r[k] / (m as f64 * n as f64);
            }
        }
    }
    out
}

/// A correlated component's correlation at lag `k` samples, `ρ = exp(−Δt/τ)`: the first-order
/// Gauss–Markov `ρ^k` (low-pass: its spectrum is largest at zero frequency), or with `band_pass`
/// `ρ^k (1 − k ln(1/ρ))`, the sampled `e^{−|s|/τ} (1 − |s|/τ)` whose spectrum
/// `∝ ω²/(1/τ² + ω²)²` is zero at zero frequency and largest at `ω = 1/τ` (the limit of the
/// second-order `e^{−|s|/τ}(cos ωs − sin ω|s|/(ωτ))` as `ω → 0`; sampling keeps it positive
/// semi-definite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Kernel {
    pub rho: f64,
    pub band_pass: bool,
}

impl Kernel {
    fn at(self, k: usize) -> f64 {
        let r = self.rho.powi(k as i32);
        if self.band_pass {
            r * (1.0 + k as f64 * self.rho.ln())
        } else {
            r
        }
    }
}

/// `T x` for every column of the `n_y` output rows of `s`, `T_ts` = the kernel at `|t − s|`: by a
/// forward and a backward first-order recursion (`f + b − x`), and for the band-pass kernel the
/// lag-weighted sums `Σ_s |t − s| ρ^{|t−s|} x_s` by the same recursions (`g_t = ρ (g_{t−1} +
/// f_{t−1})`). Returns one `N × n_p` block per output.
fn markov_times(s: &DMatrix<f64>, ny: usize, kernel: Kernel) -> Vec<DMatrix<f64>> {
    let n = s.nrows() / ny;
    let rho = kernel.rho;
    let lag_weight = if kernel.band_pass { rho.ln() } else { 0.0 };
    (0..ny)
        .map(|a| {
            let mut out = DMatrix::zeros(n, s.ncols());
            for p in 0..s.ncols() {
                let x = |t: usize| s[(t * ny + a, p)];
                let (mut f, mut g) = (0.0, 0.0);
                for t in 0..n {
                    g = rho * (g + f);
                    f = x(t) + rho * f;
                    out[(t, p)] = f + lag_weight * g;
                }
                let (mut b, mut h) = (0.0, 0.0);
                for t in (0..n).rev() {
                    h = rho * (h + b);
                    b = x(t) + rho * b;
                    out[(t, p)] += b - x(t) + lag_weight * h;
                }
            }
            out
        })
        .collect()
}

/// The basis covariances: a Markov term per output pair `c ≤ d`, then white noise per output.
fn basis(ny: usize) -> Vec<(bool, usize, usize)> {
    let mut b = Vec::new();
    for c in 0..ny {
        for d in c..ny {
            b.push((true, c, d));
        }
    }
    b.extend((0..ny).map(|c| (false, c, c)));
    b
}

/// `F = B S̃` for one basis covariance on one segment (`tx` = [`markov_times`] of `S̃`).
fn basis_times(
    seg: &WeightedSegment,
    tx: &[DMatrix<f64>],
    ny: usize,
    (markov, c, d): (bool, usize, usize),
) -> DMatrix<f64> {
    let n = seg.s.nrows() / ny;
    let mut f = DMatrix::zeros(seg.s.nrows(), seg.s.ncols());
    let src = |a: usize, t: usize, p: usize| if markov { tx[a][(t, p)] } else { seg.s[(t * ny + a, p)] };
    for t in 0..n {
        for p in 0..seg.s.ncols() {
            f[(t * ny + c, p)] = src(d, t, p);
            if c != d {
                f[(t * ny + d, p)] = src(c, t, p);
            }
        }
    }
    f
}

/// What the model fitted: per output the correlation time, s, the Markov covariance `C` (output
/// `a` with `b` at `ρ_ab = √(ρ_a ρ_b)`) and the white `D` (in the weighted residual), and the meat
/// `Σ S̃ᵀ Σ̂ S̃` over the segments.
pub(super) struct GustFit {
    pub tau_s: Vec<f64>,
    pub band_pass: Vec<bool>,
    pub markov: DMatrix<f64>,
    pub white: DVector<f64>,
    pub meat: DMatrix<f64>,
}

/// The expected-statistic columns (`E r̂` of each basis, stacked over the segments) and the meats
/// `Σ S̃ᵀ B S̃` of the bases, each with its correlation per sample `ρ` (ignored by the white ones);
/// with `only = Some(o)` the columns' statistics of the pair `(o, o)` alone ([`lag_stats`]).
fn columns(
    planner: &mut RealFftPlanner<f64>,
    segs: &[WeightedSegment],
    a: &[DMatrix<f64>],
    ny: usize,
    kmaxes: &[usize],
    bases: &[((bool, usize, usize), Kernel)],
    only: Option<usize>,
) -> (Vec<Vec<f64>>, Vec<DMatrix<f64>>) {
    let mut cols = Vec::with_capacity(bases.len());
    let mut meats = Vec::with_capacity(bases.len());
    for &((markov, c, d), kernel) in bases {
        let tx: Vec<Vec<DMatrix<f64>>> = if markov {
            segs.iter().map(|s| markov_times(&s.s, ny, kernel)).collect()
        } else {
            vec![Vec::new(); segs.len()]
        };
        let fs: Vec<DMatrix<f64>> = segs
            .iter()
            .zip(&tx)
            .map(|(s, t)| basis_times(s, t, ny, (markov, c, d)))
            .collect();
        let meat: DMatrix<f64> = segs.iter().zip(&fs).map(|(s, f)| s.s.transpose() * f).sum();
        let mut col = Vec::new();
        for (si, seg) in segs.iter().enumerate() {
            let k = kmaxes[si];
            let n = seg.v.nrows() / ny;
            let am = &a[si] * &meat;
            let t1 = lag_stats(planner, &a[si], &fs[si], ny, k, only);
            let t2 = lag_stats(planner, &fs[si], &a[si], ny, k, only);
            let t3 = lag_stats(planner, &am, &a[si], ny, k, only);
            for cc in 0..ny {
                for dd in 0..ny {
                    for kk in 0..k {
                        let i = (cc * ny + dd) * k + kk;
                        let pair = (cc == c && dd == d) || (cc == d && dd == c);
                        let direct = if !pair {
                            0.0
                        } else if markov {
                            (n - kk) as f64 / n as f64 * kernel.at(kk)
                        } else if kk == 0 {
                            1.0
                        } else {
                            0.0
                        };
                        col.push(direct - t1[i] - t2[i] + t3[i]);
                    }
                }
            }
        }
        cols.push(col);
        meats.push(meat);
    }
    (cols, meats)
}

/// Least squares of `y` on the columns; the coefficients and the residual sum of squares.
fn least_squares(cols: &[&[f64]], y: &[f64]) -> Option<(DVector<f64>, f64)> {
    let x = DMatrix::from_fn(y.len(), cols.len(), |r, c| cols[c][r]);
    let y = DVector::from_column_slice(y);
    let beta = x.clone().svd(true, true).solve(&y, 1e-12).ok()?;
    let rss = (&x * &beta - &y).norm_squared();
    rss.is_finite().then_some((beta, rss))
}

/// Fits the model of the module doc to the segments' residuals; `minv` the inverse information
/// (with the prior), `dt_s` the sample period, `known` per output its correlation time, s, and
/// whether its kernel is band-pass, if known (else each output's best on the grid of both kernels,
/// from its own autocovariances).
pub(super) fn fit(
    segs: &[WeightedSegment],
    ny: usize,
    minv: &DMatrix<f64>,
    dt_s: f64,
    known: Option<&[(f64, bool)]>,
) -> Option<GustFit> {
    let mut planner = RealFftPlanner::<f64>::new();
    let n_min = segs.iter().map(|s| s.v.nrows() / ny).min()?;
    if n_min < 4 {
        return None;
    }
    let kmaxes: Vec<usize> = segs.iter().map(|s| (s.v.nrows() / ny / 2).max(1)).collect();
    let observed: Vec<f64> = segs
        .iter()
        .zip(&kmaxes)
        .flat_map(|(s, &k)| lag_stats(&mut planner, &s.v, &s.v, ny, k, None))
        .collect();
    // The rows of output pair (c, d) in the stacked statistics.
    let rows = |c: usize, d: usize| -> Vec<usize> {
        let mut out = Vec::new();
        let mut base = 0;
        for &k in &kmaxes {
            out.extend((0..k).map(|kk| base + (c * ny + d) * k + kk));
            base += ny * ny * k;
        }
        out
    };
    let a: Vec<DMatrix<f64>> = segs.iter().map(|s| &s.s * minv).collect();
    let record_s = n_min as f64 * dt_s;
    let rho = |t: f64| (-dt_s / t).exp();
    let shapes: Vec<(f64, bool)> = match known {
        Some(k) => k.to_vec(),
        None => {
            let grid: Vec<f64> = (0..GRID)
                .map(|g| 2.0 * dt_s * (record_s / (2.0 * dt_s)).powf(g as f64 / (GRID - 1) as f64))
                .collect();
            (0..ny)
                .map(|o| {
                    let r = rows(o, o);
                    let y: Vec<f64> = r.iter().map(|&i| observed[i]).collect();
                    let pick = |c: &[f64]| -> Vec<f64> { r.iter().map(|&i| c[i]).collect() };
                    // The white column does not depend on the kernel.
                    let white_kernel = Kernel {
                        rho: 0.0,
                        band_pass: false,
                    };
                    let (white, _) = columns(
                        &mut planner,
                        segs,
                        &a,
                        ny,
                        &kmaxes,
                        &[((false, o, o), white_kernel)],
                        Some(o),
                    );
                    let white = pick(&white[0]);
                    // Both kernels have one correlation time and two variances: the same least
                    // squares that picks the time picks the kernel.
                    let mut best = (f64::INFINITY, (grid[0], false));
                    for band_pass in [false, true] {
                        for &t in &grid {
                            let kernel = Kernel { rho: rho(t), band_pass };
                            let (markov, _) =
                                columns(&mut planner, segs, &a, ny, &kmaxes, &[((true, o, o), kernel)], Some(o));
                            let markov = pick(&markov[0]);
                            let refs: [&[f64]; 2] = [&markov, &white];
                            if let Some((beta, rss)) = least_squares(&refs, &y) {
                                // A negative correlated variance is no process of this kernel.
                                if beta[0] >= 0.0 && rss < best.0 {
                                    best = (rss, (t, band_pass));
                                }
                            }
                        }
                    }
                    best.1
                })
                .collect()
        }
    };
    // A pair's kernel: the geometric mean of the two correlations, band-pass if either output's
    // is (a process with no power at zero frequency has no cross-power there either).
    let all: Vec<((bool, usize, usize), Kernel)> = basis(ny)
        .into_iter()
        .map(|(m, c, d)| {
            let kernel = Kernel {
                rho: (rho(shapes[c].0) * rho(shapes[d].0)).sqrt(),
                band_pass: shapes[c].1 || shapes[d].1,
            };
            ((m, c, d), kernel)
        })
        .collect();
    let (cols, meats) = columns(&mut planner, segs, &a, ny, &kmaxes, &all, None);
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    let (beta, _) = least_squares(&refs, &observed)?;
    let nm = ny * (ny + 1) / 2;
    let mut c = DMatrix::zeros(ny, ny);
    for (&b, &((_, i, j), _)) in beta.iter().zip(&all[..nm]) {
        c[(i, j)] = b;
        c[(j, i)] = b;
    }
    let eig = SymmetricEigen::new(c);
    let clipped = eig.eigenvalues.map(|l| l.max(0.0));
    let c = &eig.eigenvectors * DMatrix::from_diagonal(&clipped) * eig.eigenvectors.transpose();
    let white = DVector::from_fn(ny, |k, _| beta[nm + k].max(0.0));
    let mut meat = DMatrix::zeros(minv.nrows(), minv.ncols());
    for (m, &((_, i, j), _)) in meats.iter().zip(&all[..nm]) {
        meat += m * c[(i, j)];
    }
    for (k, m) in meats[nm..].iter().enumerate() {
        meat += m * white[k];
    }
    Some(GustFit {
        tau_s: shapes.iter().map(|s| s.0).collect(),
        band_pass: shapes.iter().map(|s| s.1).collect(),
        markov: c,
        white,
        meat,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// What [`regression`] returns: the true σ per parameter, per draw the variances stated by
    /// the fitted model and by the Morelli–Klein lag sums, and per draw whether the fit chose the
    /// band-pass kernel.
    struct Draws {
        truth: Vec<f64>,
        gust: Vec<Vec<f64>>,
        mk: Vec<Vec<f64>>,
        band_pass: Vec<bool>,
    }

    /// A regression with a correlated error plus white noise of known covariance `Σ`: the true
    /// covariance of least squares is `M⁻¹ Xᵀ Σ X M⁻¹`; per draw the σ of the fitted model and of
    /// the Morelli–Klein lag sums. The correlated error is low-pass (first-order Gauss–Markov,
    /// drawn by its recursion) or band-pass (drawn through the Cholesky factor of its covariance),
    /// correlation time 60 samples, a fifth of the 300-sample record; `known` the kernel handed to
    /// the fit with the true time (`None`: both estimated).
    fn regression(draws: usize, band_pass: bool, known: Option<bool>) -> Draws {
        let (n, tau, white) = (300usize, 60.0, 0.3);
        let rho = (-1.0f64 / tau).exp();
        let kernel = Kernel { rho, band_pass };
        // Regressors: a constant, a 3-2-1-1 through a second-order response, and its rate.
        let (mut x, mut xd) = (0.0, 0.0);
        let mut reg = DMatrix::zeros(n, 3);
        for t in 0..n {
            let u = match t {
                20..=79 => 1.0,
                80..=119 => -1.0,
                120..=139 => 1.0,
                140..=159 => -1.0,
                _ => 0.0,
            };
            reg[(t, 0)] = 1.0;
            reg[(t, 1)] = x;
            reg[(t, 2)] = xd / 5.0;
            let xdd = -0.003 * x - 0.08 * xd + 0.01 * u;
            x += xd;
            xd += xdd;
        }
        let correlated = DMatrix::from_fn(n, n, |i, j| kernel.at(i.abs_diff(j)));
        let sigma = &correlated + DMatrix::identity(n, n) * white;
        let factor = correlated.clone().cholesky().map(|c| c.l());
        let minv = (reg.transpose() * &reg).try_inverse().expect("regressors independent");
        let truth = &minv * reg.transpose() * &sigma * &reg * &minv;
        let truth: Vec<f64> = (0..3).map(|i| truth[(i, i)].sqrt()).collect();
        let mut rng = rand::rngs::StdRng::seed_from_u64(41);
        let mut normal = || {
            let (a, b): (f64, f64) = (rng.random_range(f64::EPSILON..1.0), rng.random());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let (mut gust, mut mk, mut chosen) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..draws {
            let e = match (&factor, band_pass) {
                (Some(l), true) => {
                    let z = DMatrix::from_fn(n, 1, |_, _| normal());
                    l * z + DMatrix::from_fn(n, 1, |_, _| white.sqrt() * normal())
                }
                _ => {
                    let mut m = normal();
                    DMatrix::from_fn(n, 1, |t, _| {
                        if t > 0 {
                            m = rho * m + (1.0 - rho * rho).sqrt() * normal();
                        }
                        m + white.sqrt() * normal()
                    })
                }
            };
            let v = &e - &reg * (&minv * reg.transpose() * &e);
            let seg = WeightedSegment {
                v: v.clone(),
                s: reg.clone(),
            };
            let fitted = fit(
                &[seg],
                1,
                &minv,
                1.0,
                known.map(|b| [(tau, b)]).as_ref().map(|k| &k[..]),
            )
            .expect("the model fits");
            chosen.push(fitted.band_pass[0]);
            let cov = &minv * &fitted.meat * &minv;
            gust.push((0..3).map(|i| cov[(i, i)]).collect());
            let res: Vec<crate::usermodel::YVec> = (0..n)
                .map(|t| crate::usermodel::YVec::from_fn(|i, _| if i == 0 { v[(t, 0)] } else { 0.0 }))
                .collect();
            let sens: Vec<Vec<crate::usermodel::YVec>> = (0..3)
                .map(|p| {
                    (0..n)
                        .map(|t| crate::usermodel::YVec::from_fn(|i, _| if i == 0 { reg[(t, p)] } else { 0.0 }))
                        .collect()
                })
                .collect();
            let meat = super::super::lag_sandwich(&mut RealFftPlanner::new(), &res, &sens, &[1.0]);
            let cov = &minv * meat * &minv;
            mk.push((0..3).map(|i| cov[(i, i)]).collect());
        }
        Draws {
            truth,
            gust,
            mk,
            band_pass: chosen,
        }
    }

    /// The mean of the stated variances of parameter `i` and its standard error over the draws.
    fn mean_se(v: &[Vec<f64>], i: usize) -> (f64, f64) {
        let n = v.len() as f64;
        let m = v.iter().map(|c| c[i]).sum::<f64>() / n;
        let var = v.iter().map(|c| (c[i] - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, (var / n).sqrt())
    }

    /// The true variance within three standard errors of the mean stated variance: unbiased.
    fn assert_unbiased(truth: &[f64], stated: &[Vec<f64>], which: &[usize]) {
        for &i in which {
            let (m, se) = mean_se(stated, i);
            let t = truth[i] * truth[i];
            assert!(
                (m - t).abs() <= 3.0 * se,
                "parameter {i}: true variance {t:.4e}, stated {m:.4e} ± {se:.1e}"
            );
        }
    }

    #[test]
    fn with_the_correlation_known_the_stated_variance_is_unbiased() {
        // GIVEN 200 seeded draws of a regression whose error is a first-order Gauss–Markov process
        // (correlation 60 samples, a fifth of the 300-sample record) plus white noise, WHEN the
        // model with the true correlation time fits the residual's covariances to each draw
        let d = regression(200, false, Some(false));
        let (truth, gust, mk) = (d.truth, d.gust, d.mk);
        // THEN the variance it states is unbiased for every parameter (the moment equations are
        // exact for the linear fit: `E r̂ = L(Q Σ Qᵀ)`)
        assert_unbiased(&truth, &gust, &[0, 1, 2]);
        // while the Morelli–Klein lag sums understate the intercept's beyond their sampling error
        let (m, se) = mean_se(&mk, 0);
        assert!(
            m + 3.0 * se < truth[0] * truth[0],
            "the lag sums state the intercept's variance ({m:.3e} ± {se:.1e})"
        );
    }

    #[test]
    fn with_the_correlation_estimated_the_slopes_variance_is_unbiased() {
        // GIVEN the same draws, WHEN the correlation time (and the kernel) is estimated as well
        let d = regression(200, false, None);
        let (truth, gust) = (d.truth, d.gust);
        let share = d.band_pass.iter().filter(|&&b| b).count() as f64 / d.band_pass.len() as f64;
        println!("band-pass kernel chosen in {share:.2} of the Gauss–Markov draws");
        // THEN the slopes' stated variance is unbiased
        assert_unbiased(&truth, &gust, &[1, 2]);
        // and the intercept's, whose variance grows fast with the correlation time, is not below
        // the truth (an error in the estimated correlation time inflates it more than it shrinks it)
        let (m, se) = mean_se(&gust, 0);
        assert!(
            m + 3.0 * se >= truth[0] * truth[0],
            "the intercept's variance is understated ({m:.3e} ± {se:.1e})"
        );
    }

    #[test]
    fn the_kernels_products_equal_the_dense_sums() {
        // GIVEN two outputs of 40 samples and three columns, WHEN `T x` is formed by the
        // recursions, THEN it equals the dense `Σ_s k(|t − s|) x_s` for both kernels
        let (n, ny, np) = (40usize, 2usize, 3usize);
        let s = DMatrix::from_fn(n * ny, np, |r, c| ((r * 7 + c * 13) % 11) as f64 - 5.0);
        for band_pass in [false, true] {
            let kernel = Kernel { rho: 0.9, band_pass };
            let tx = markov_times(&s, ny, kernel);
            for (a, block) in tx.iter().enumerate() {
                for t in 0..n {
                    for p in 0..np {
                        let dense: f64 = (0..n).map(|u| kernel.at(t.abs_diff(u)) * s[(u * ny + a, p)]).sum();
                        assert!(
                            (block[(t, p)] - dense).abs() <= 1e-9 * dense.abs().max(1.0),
                            "band_pass {band_pass}, output {a}, t {t}, p {p}: {} vs {dense}",
                            block[(t, p)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_band_pass_error_is_recognised_and_its_variance_is_not_overstated() {
        // GIVEN 200 seeded draws of the regression whose correlated error has no power at zero
        // frequency (the band-pass kernel, correlation time 60 samples)
        let known = regression(200, true, Some(true));
        // WHEN the fitted model knows the kernel, THEN its stated variance is unbiased for every
        // parameter (the moment equations are exact for either kernel)
        assert_unbiased(&known.truth, &known.gust, &[0, 1, 2]);
        // WHEN the low-pass kernel is imposed with the true time, THEN the intercept's variance
        // is overstated beyond its sampling error: the low-pass kernel puts its largest power
        // at zero frequency, where an intercept's sensitivity is
        let low = regression(200, true, Some(false));
        let (m, se) = mean_se(&low.gust, 0);
        let t0 = low.truth[0] * low.truth[0];
        assert!(
            m - 3.0 * se > t0,
            "the low-pass kernel states {m:.3e} ± {se:.1e}, truth {t0:.3e}"
        );
        // WHEN the kernel and its time are estimated, THEN the band-pass kernel is chosen in most
        // draws and the stated variance is unbiased for the slopes
        let est = regression(200, true, None);
        let share = est.band_pass.iter().filter(|&&b| b).count() as f64 / est.band_pass.len() as f64;
        println!("band-pass kernel chosen in {share:.2} of the draws");
        assert!(share > 0.5, "the band-pass kernel chosen in {share:.2} of the draws");
        assert_unbiased(&est.truth, &est.gust, &[1, 2]);
    }
}
