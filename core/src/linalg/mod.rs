//! Small fixed-size linear algebra the estimators need beyond nalgebra's operators.
//!
//! Everything here works on `SMatrix`/`SVector` of const dimension, allocates nothing and never
//! panics: loops run over the const dimensions, and factorizations report failure as `None`.

pub mod secular;

use crate::Real;
use nalgebra::{SMatrix, SVector};

/// The zero matrix, in `const` contexts (the firmware's statics are built from these).
pub const fn const_zeros<T: Real, const R: usize, const C: usize>() -> SMatrix<T, R, C> {
    SMatrix::from_array_storage(nalgebra::ArrayStorage([[T::ZERO; R]; C]))
}

/// The indices `lo..end` as a loop of compile-time length `N` stopped at `end` (`end ≤ N`
/// assumed; larger is clamped to `N`). Over a run-time range `lo..end` the compiler keeps the loop;
/// over `lo..N` with the early stop it unrolls it and gives the inner products constant lengths:
/// measured on the M4F (instructions under QEMU) for the secular terms, the minimum-norm Cholesky
/// and solves and the general secular path.
#[inline(always)]
pub(crate) fn unrolled_upto<const N: usize>(lo: usize, end: usize) -> impl Iterator<Item = usize> {
    (lo..N).take_while(move |&j| j < end)
}

/// `true` if every element is finite: branch-free, `Σ x·0` is `±0` for finite elements and NaN as
/// soon as one is infinite or NaN (nalgebra's generic matrix iterator costs several times more).
#[inline]
pub fn all_finite<T: Real, const R: usize, const C: usize>(a: &SMatrix<T, R, C>) -> bool {
    slice_finite(a.as_slice())
}

/// [`all_finite`] for a slice.
#[inline]
pub fn slice_finite<T: Real>(a: &[T]) -> bool {
    let mut acc = T::zero();
    for x in a {
        acc += *x * T::zero();
    }
    acc == T::zero()
}

/// Upper-triangular Cholesky factor `C` with `A = Cᵀ C` (the convention of eq. 9: `W_T = CᵀC`).
///
/// Returns `None` if `A` has a non-finite entry (anywhere, both triangles are checked), is not
/// symmetric within `64·ε·max|A|`, or is not positive definite to working precision (a pivot is not
/// positive and finite).
pub fn cholesky_upper<T: Real, const N: usize>(a: &SMatrix<T, N, N>) -> Option<SMatrix<T, N, N>> {
    if !all_finite(a) {
        return None;
    }
    let scale = a.as_slice().iter().fold(T::zero(), |m, x| m.maxr(x.abs()));
    if !scale.finite() || scale <= T::zero() {
        return None;
    }
    // The column arrays (`ac[j][i]` is `A(i, j)`): indexed as arrays, the loops' bounds prove every
    // index in range at any opt-level; nalgebra's `(i, j)` index is a call with its own bounds
    // check once it is not inlined (the firmware builds this code for size: panic audit).
    let ac = &a.data.0;
    let sym_tol = T::lit(64.0) * T::EPS * scale;
    for i in 0..N {
        for j in (i + 1)..N {
            if (ac[j][i] - ac[i][j]).abs() > sym_tol {
                return None;
            }
        }
    }
    let mut c = SMatrix::<T, N, N>::zeros();
    let cc = &mut c.data.0;
    for j in 0..N {
        let mut d = ac[j][j];
        for k in 0..j {
            d -= cc[j][k] * cc[j][k];
        }
        if !(d > T::zero()) || !d.finite() {
            return None;
        }
        let cjj = d.root();
        cc[j][j] = cjj;
        for i in (j + 1)..N {
            let mut s = ac[i][j];
            for k in 0..j {
                s -= cc[j][k] * cc[i][k];
            }
            cc[i][j] = s / cjj;
        }
    }
    Some(c)
}

/// Inverse of an upper-triangular matrix with non-zero diagonal (`None` otherwise).
pub fn inv_upper<T: Real, const N: usize>(c: &SMatrix<T, N, N>) -> Option<SMatrix<T, N, N>> {
    let mut x = SMatrix::<T, N, N>::zeros();
    // Column arrays (`cc[k][i]` is `C(i, k)`), for the reason given in [`cholesky_upper`].
    let cc = &c.data.0;
    let xc = &mut x.data.0;
    for j in 0..N {
        // Solve C x_j = e_j by back substitution; x_j is zero below row j.
        for ii in 0..j + 1 {
            let i = j - ii;
            let mut s = if i == j { T::one() } else { T::zero() };
            for k in (i + 1)..j + 1 {
                s -= cc[k][i] * xc[j][k];
            }
            let d = cc[i][i];
            if d == T::zero() || !d.finite() {
                return None;
            }
            xc[j][i] = s / d;
        }
    }
    Some(x)
}

/// Upper Cholesky factor of a symmetric positive semi-definite `A`, regularised only if needed.
///
/// Math note: `A` is factorised as it is; if that fails (singular to working precision), `A + μI`
/// with `μ = 16·n·ε·max(trace(A)/n, tiny)` is factorised instead, which gives bounded solutions close
/// to the pseudo-inverse ones on the range of `A`. Returns `None` only on non-finite input.
pub fn cholesky_regularised<T: Real, const N: usize>(a: &SMatrix<T, N, N>) -> Option<SMatrix<T, N, N>> {
    let sym = (a + a.transpose()) * T::lit(0.5);
    if let Some(c) = cholesky_upper(&sym) {
        return Some(c);
    }
    let mut tr = T::zero();
    for i in 0..N {
        tr += sym[(i, i)].abs();
    }
    let n = T::lit(N as f64);
    let mu = T::lit(16.0) * n * T::EPS * (tr / n).maxr(T::SQRT_MIN_POSITIVE);
    let mut ar = sym;
    for i in 0..N {
        ar[(i, i)] += mu;
    }
    cholesky_upper(&ar)
}

/// Solves `A x = b` for a symmetric positive semi-definite `A` through [`cholesky_regularised`].
pub fn solve_spd_regularised<T: Real, const N: usize>(
    a: &SMatrix<T, N, N>,
    b: &SVector<T, N>,
) -> Option<SVector<T, N>> {
    let c = cholesky_regularised(a)?;
    let x = solve_upper_t_upper(&c, b);
    if all_finite(&x) {
        Some(x)
    } else {
        None
    }
}

/// Solves `Cᵀ y = b` (forward substitution) for an upper-triangular `C` with non-zero diagonal.
pub fn solve_upper_transposed<T: Real, const N: usize>(c: &SMatrix<T, N, N>, b: &SVector<T, N>) -> SVector<T, N> {
    let mut y = SVector::<T, N>::zeros();
    for i in 0..N {
        let mut s = b[i];
        for k in 0..i {
            s -= c[(k, i)] * y[k];
        }
        y[i] = s / c[(i, i)];
    }
    y
}

/// Solves `C x = y` (back substitution) for an upper-triangular `C` with non-zero diagonal.
pub fn solve_upper<T: Real, const N: usize>(c: &SMatrix<T, N, N>, y: &SVector<T, N>) -> SVector<T, N> {
    let mut x = SVector::<T, N>::zeros();
    for ii in 0..N {
        let i = N - 1 - ii;
        let mut s = y[i];
        for k in (i + 1)..N {
            s -= c[(i, k)] * x[k];
        }
        x[i] = s / c[(i, i)];
    }
    x
}

/// Solves `CᵀC x = b` given the upper-triangular factor `C` with non-zero diagonal.
pub fn solve_upper_t_upper<T: Real, const N: usize>(c: &SMatrix<T, N, N>, b: &SVector<T, N>) -> SVector<T, N> {
    solve_upper(c, &solve_upper_transposed(c, b))
}

/// `‖VᵀV − I‖_F`: the loss of orthonormality of the columns of `V`.
pub fn orthonormality_error<T: Real, const N: usize>(v: &SMatrix<T, N, N>) -> T {
    let mut s = T::zero();
    for i in 0..N {
        for j in 0..N {
            let mut d = T::zero();
            for k in 0..N {
                d += v[(k, i)] * v[(k, j)];
            }
            if i == j {
                d -= T::one();
            }
            s += d * d;
        }
    }
    s.root()
}

/// Re-orthonormalises the columns of `V` in place by modified Gram–Schmidt, column 0 first.
///
/// The columns are expected in order of decreasing singular value, so the dominant directions are
/// kept and the rounding error is pushed into the least significant ones. Returns `false` (and leaves
/// `V` unchanged) if a column collapses, which cannot happen for a `V` within `O(√ε)` of orthogonal.
pub fn reorthonormalise<T: Real, const N: usize>(v: &mut SMatrix<T, N, N>) -> bool {
    let mut w = *v;
    for j in 0..N {
        for i in 0..j {
            let mut d = T::zero();
            for k in 0..N {
                d += w[(k, i)] * w[(k, j)];
            }
            for k in 0..N {
                let wi = w[(k, i)];
                w[(k, j)] -= d * wi;
            }
        }
        let mut nrm = T::zero();
        for k in 0..N {
            nrm += w[(k, j)] * w[(k, j)];
        }
        let nrm = nrm.root();
        if !(nrm > T::lit(0.5)) || !nrm.finite() {
            return false;
        }
        for k in 0..N {
            w[(k, j)] /= nrm;
        }
    }
    *v = w;
    true
}
