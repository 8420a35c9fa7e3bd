//! `f64` references for the recursive PCA-GTLS, built on faer (an independent implementation of
//! the same mathematics, with none of the core's recursion).
//!
//! * [`batch`] builds the exponentially weighted, scaled data matrix `D*` **explicitly** (eq. 10),
//!   projects out the exact columns by a faer QR (mixed LS–TLS, Golub–Hoffman–Stewart), takes its SVD
//!   with faer, and solves eq. 16 / eq. 21–23 from it. Cost `O(N n²)` per call: used at checkpoints.
//! * [`Compressed`] keeps only the triangular factor `R` of the same weighted matrix, updated per
//!   sample by a faer QR of `[√λ·R; row]`; the projected block `R₂₂` has the same singular values and
//!   right singular vectors as the explicit projected matrix. Cost `O(n³)` per sample: used at every
//!   step of long runs.
//!
//! Both take the core's conventions: regressors `[x_e, x_n]`, `W_T` the covariance of `[x_n, z]`,
//! weights `W` for eq. 23.

use faer::{Mat, Side};

/// The result of a reference solve.
#[derive(Debug, Clone, PartialEq)]
pub struct RefSolution {
    /// Singular values of the projected scaled block, decreasing (eq. 13).
    pub s: Vec<f64>,
    /// Right singular vectors (columns), same order.
    pub v: Mat<f64>,
    /// Number of excited directions (eq. 21).
    pub k: usize,
    /// Excitation threshold `(1+s/n)√(N_eff − n_θ)`, if `N_eff > n_θ`.
    pub threshold: Option<f64>,
    /// `θ = [θ_e, θ_n]`.
    pub theta: Vec<f64>,
    /// Effective weighted sample count.
    pub n_eff: f64,
}

/// The problem definition shared by the references.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Number of parameters.
    pub nt: usize,
    /// Number of exact regressors (first in `x`).
    pub ne: usize,
    /// `C` with `W_T = CᵀC` (upper triangular), computed by faer's Cholesky.
    pub c: Mat<f64>,
    /// `C⁻¹`.
    pub c_inv: Mat<f64>,
    /// Diagonal of `W` (eq. 23), length `nt`.
    pub weights: Vec<f64>,
    /// `s/n` of eq. 21.
    pub snr: f64,
}

impl Problem {
    /// Builds the problem from `W_T` (row-major, `na × na`).
    pub fn new(nt: usize, ne: usize, w_t: &[f64], weights: &[f64], snr: f64) -> Self {
        let na = nt - ne + 1;
        let w = Mat::from_fn(na, na, |i, j| w_t[i * na + j]);
        let llt = w.llt(Side::Lower).unwrap_or_else(|_| panic!("W_T not SPD"));
        let l = llt.L().to_owned();
        let c = l.transpose().to_owned();
        let c_inv = invert_upper(&c);
        Self {
            nt,
            ne,
            c,
            c_inv,
            weights: weights.to_vec(),
            snr,
        }
    }

    fn na(&self) -> usize {
        self.nt - self.ne + 1
    }

    /// The full scaled row `[x_e, d C⁻¹]`.
    pub fn scaled_row(&self, x: &[f64], z: f64) -> Vec<f64> {
        let na = self.na();
        let mut d = vec![0.0; na];
        d[..na - 1].copy_from_slice(&x[self.ne..]);
        d[na - 1] = z;
        let mut row = x[..self.ne].to_vec();
        for j in 0..na {
            let mut acc = 0.0;
            for i in 0..na {
                acc += d[i] * self.c_inv[(i, j)];
            }
            row.push(acc);
        }
        row
    }

    /// Solves eq. 16 / 21–23 given the projected block's SVD and `B` (scaled regression of the noisy
    /// block on the exact columns, `na × ne`).
    fn solve(&self, s: Vec<f64>, v: Mat<f64>, b: &Mat<f64>, n_eff: f64) -> RefSolution {
        let na = self.na();
        let nx = na - 1;
        let dof = n_eff - self.nt as f64;
        let threshold = if dof > 0.0 {
            Some((1.0 + self.snr) * dof.sqrt())
        } else {
            None
        };
        let k = match threshold {
            Some(t) => (0..nx).filter(|&j| s[j] > t).count(),
            None => 0,
        };
        let mut a = vec![0.0; na];
        a[nx] = -1.0;
        let tls = if threshold.is_some() && k == nx {
            let al: Vec<f64> = (0..na)
                .map(|i| (0..na).map(|j| self.c_inv[(i, j)] * v[(j, na - 1)]).sum())
                .collect();
            let nrm = al.iter().map(|x| x * x).sum::<f64>().sqrt();
            if al[nx].abs() > f64::EPSILON.sqrt() * nrm {
                for i in 0..na {
                    a[i] = -al[i] / al[nx];
                }
                true
            } else {
                false
            }
        } else {
            false
        };
        let kk = if threshold.is_none() {
            0
        } else if !tls && k == nx {
            nx - 1
        } else {
            k
        };
        if !tls && kk > 0 {
            // Minimum ‖W θ_n‖ subject to V₁ᵀ C [θ_n; −1] = 0: θ' = pinv(M W⁻¹) b by faer's SVD.
            let mut m = Mat::<f64>::zeros(kk, nx);
            let mut rhs = Mat::<f64>::zeros(kk, 1);
            for r in 0..kk {
                for j in 0..na {
                    let mut acc = 0.0;
                    for i in 0..na {
                        acc += v[(i, r)] * self.c[(i, j)];
                    }
                    if j < nx {
                        m[(r, j)] = acc / self.weights[self.ne + j];
                    } else {
                        rhs[(r, 0)] = acc;
                    }
                }
            }
            let svd = m.thin_svd().unwrap_or_else(|_| panic!("svd failed"));
            let (u, sv, vv) = (svd.U(), svd.S().column_vector(), svd.V());
            let smax = (0..sv.nrows()).map(|i| sv[i]).fold(0.0, f64::max);
            let mut tp = vec![0.0; nx];
            for i in 0..sv.nrows() {
                if sv[i] > 1e-12 * smax {
                    let coef: f64 = (0..kk).map(|r| u[(r, i)] * rhs[(r, 0)]).sum::<f64>() / sv[i];
                    for j in 0..nx {
                        tp[j] += vv[(j, i)] * coef;
                    }
                }
            }
            for j in 0..nx {
                a[j] = tp[j] / self.weights[self.ne + j];
            }
        }
        // θ_e = −Bᵀ C a.
        let ca: Vec<f64> = (0..na).map(|i| (0..na).map(|j| self.c[(i, j)] * a[j]).sum()).collect();
        let mut theta = vec![0.0; self.nt];
        for e in 0..self.ne {
            theta[e] = -(0..na).map(|i| b[(i, e)] * ca[i]).sum::<f64>();
        }
        theta[self.ne..].copy_from_slice(&a[..nx]);
        RefSolution {
            s,
            v,
            k,
            threshold,
            theta,
            n_eff,
        }
    }
}

fn invert_upper(c: &Mat<f64>) -> Mat<f64> {
    let n = c.nrows();
    let mut x = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for i in (0..=j).rev() {
            let mut s = if i == j { 1.0 } else { 0.0 };
            for k in (i + 1)..=j {
                s -= c[(i, k)] * x[(k, j)];
            }
            x[(i, j)] = s / c[(i, i)];
        }
    }
    x
}

/// SVD (values decreasing, `V`) of the projected block and `B` from a weighted full matrix whose
/// first `ne` columns are exact.
fn project_and_svd(p: &Problem, full: &Mat<f64>) -> (Vec<f64>, Mat<f64>, Mat<f64>) {
    let ne = p.ne;
    let na = p.na();
    // Pad with zero rows so the thin SVD always has `na` singular values.
    let rows = full.nrows().max(p.nt + 1);
    let full = Mat::from_fn(
        rows,
        full.ncols(),
        |i, j| {
            if i < full.nrows() {
                full[(i, j)]
            } else {
                0.0
            }
        },
    );
    let full = &full;
    let (proj, b) = if ne > 0 {
        let xe = full.subcols(0, ne).to_owned();
        let dn = full.subcols(ne, na).to_owned();
        let qr = xe.qr();
        let q = qr.compute_thin_Q();
        let r = qr.thin_R().to_owned();
        let qtd = q.transpose() * &dn;
        let proj = &dn - &q * &qtd;
        // B = R⁻¹ Qᵀ D* (ne × na) transposed to na × ne.
        let mut bt = Mat::<f64>::zeros(ne, na);
        for col in 0..na {
            for i in (0..ne).rev() {
                let mut s = qtd[(i, col)];
                for kk in (i + 1)..ne {
                    s -= r[(i, kk)] * bt[(kk, col)];
                }
                bt[(i, col)] = s / r[(i, i)];
            }
        }
        (proj, bt.transpose().to_owned())
    } else {
        (full.to_owned(), Mat::<f64>::zeros(na, 0))
    };
    let svd = proj.thin_svd().unwrap_or_else(|_| panic!("svd failed"));
    let sv = svd.S().column_vector();
    let s: Vec<f64> = (0..na).map(|i| sv[i]).collect();
    (s, svd.V().to_owned(), b)
}

/// The explicit batch reference: rows `(x_t, z_t)` with forgetting factors `λ_t` (the factor applied
/// when sample `t` arrived: all earlier rows are multiplied by `√λ_t`).
pub fn batch(p: &Problem, rows: &[(Vec<f64>, f64)], lambdas: &[f64]) -> RefSolution {
    let n = rows.len();
    let ncol = p.nt + 1;
    // Weight of row i: Π_{t > i} λ_t.
    let mut wts = vec![1.0; n];
    let mut acc = 1.0;
    for i in (0..n).rev() {
        wts[i] = acc;
        acc *= lambdas[i];
    }
    let mut full = Mat::<f64>::zeros(n, ncol);
    for (i, (x, z)) in rows.iter().enumerate() {
        let r = p.scaled_row(x, *z);
        let sw = wts[i].sqrt();
        for j in 0..ncol {
            full[(i, j)] = sw * r[j];
        }
    }
    let n_eff: f64 = wts.iter().sum();
    let (s, v, b) = project_and_svd(p, &full);
    p.solve(s, v, &b, n_eff)
}

/// The compressed reference: the triangular factor of the weighted scaled matrix, updated by a
/// faer QR per sample.
#[derive(Debug, Clone)]
pub struct Compressed {
    p: Problem,
    r: Mat<f64>,
    n_eff: f64,
}

impl Compressed {
    /// An empty reference.
    pub fn new(p: Problem) -> Self {
        let n = p.nt + 1;
        Self {
            p,
            r: Mat::zeros(0, n),
            n_eff: 0.0,
        }
    }

    /// Appends a sample with forgetting `λ`.
    pub fn push(&mut self, x: &[f64], z: f64, lambda: f64) {
        let n = self.p.nt + 1;
        let row = self.p.scaled_row(x, z);
        let m = self.r.nrows();
        let mut stacked = Mat::<f64>::zeros(m + 1, n);
        let sl = lambda.sqrt();
        for i in 0..m {
            for j in 0..n {
                stacked[(i, j)] = sl * self.r[(i, j)];
            }
        }
        for j in 0..n {
            stacked[(m, j)] = row[j];
        }
        let qr = stacked.qr();
        let r = qr.thin_R().to_owned();
        self.r = r;
        self.n_eff = lambda * self.n_eff + 1.0;
    }

    /// The current solution.
    pub fn solve(&self) -> RefSolution {
        let (s, v, b) = project_and_svd(&self.p, &self.r);
        self.p.solve(s, v, &b, self.n_eff)
    }
}
