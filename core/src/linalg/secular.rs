//! Rank-one update of a symmetric eigendecomposition by the secular equation — the `R_SVD` step of
//! Algorithm 1 (seed 000, step 4) and its reference \[17\] (Gu & Eisenstat 1994; Bunch, Nielsen &
//! Sorensen 1978).
//!
//! The recursive PCA-GTLS never needs `U` of `D* = U S Vᵀ` (eq. 12), only `V` and `S`. Appending the
//! row `wᵀ` to the exponentially weighted matrix `√λ·D*` changes its Gram matrix to
//! `λ·V S² Vᵀ + w wᵀ`, so with `z = Vᵀ w` the new `S², V` are the eigenpairs of the diagonal-plus-
//! rank-one matrix `diag(λ s_j²) + z zᵀ`, rotated back by `V`. The singular values of the appended
//! matrix `[√λ·S; zᵀ]` are the square roots of these eigenvalues; because every pole difference is
//! formed from singular values as `(a_j − a_K)(a_j + a_K)` and each root is found relative to its
//! nearer pole (LAPACK `dlasd4`'s device), small singular values keep their relative accuracy.
//!
//! Steps (all on fixed-size stack arrays, `O(M²)` work plus one `O(M³)` product `V·Q`):
//! 0. **Scaling** by a power of two (exact) so that the largest of `a_j = √λ·s_j` and `|z_j|` lies
//!    in `[0.5, 1)`; components whose squares would underflow are dropped (they are below
//!    `MIN_POSITIVE` relative to `σ₁²`).
//! 1. **Deflation** (`dlaed2`'s two criteria with a tolerance local to each pole,
//!    `τ_j = 8ε·a_j²`, see `local_tol`): a component with `‖z‖·|z_j| ≤ τ_j` keeps its vector
//!    unchanged and its eigenvalue becomes `a_j² + z_j²` (the couplings are dropped, the diagonal
//!    term is kept); two poles whose Givens rotation zeroing one `z` entry
//!    leaves an off-diagonal `|t·c·s| ≤ τ` of the larger pole (near-equal singular values, including
//!    exactly equal ones such as the all-zero start) are rotated together and one of them deflated.
//! 2. **Secular equation** `f(μ) = 1 + Σ z_j²/(δ_j − μ) = 0`, one root in each gap `(δ_i, δ_{i+1})`
//!    and the last in `(δ_m, δ_m + ‖z‖²]`. Each root is shifted to its nearer pole (decided by the
//!    sign of `f` at the gap's midpoint), started from `dlaed4`'s initial guess (the two nearest poles
//!    exact, the rest a constant fitted at the midpoint) and refined by the Bunch–Nielsen–Sorensen
//!    iteration: the sums over poles left and right of the root are each replaced by one pole plus a
//!    constant that match value and slope, and the resulting quadratic is solved for the step. The
//!    iterate is kept inside a bisection bracket, so it cannot leave the gap; it stops when `|f|` is
//!    below its rounding error bound (`dlaed4`'s test), after a model step below `0.1·√ε` relative
//!    (quadratic convergence leaves ~ε/100), or after [`MAX_ITERATIONS`]. The roots are independent:
//!    on the MCU they are solved one after the other (one root's state stays in registers), on
//!    an out-of-order host in lock step (their dependency chains overlap); the two orders give
//!    bit-identical results ([`ROOTS_IN_LOCK_STEP`]).
//! 3. **Eigenvectors** by Gu & Eisenstat's stable formula: `ẑ` is recomputed from the computed roots
//!    (Löwner's theorem) so that the computed roots are exact eigenvalues of a nearby matrix, and each
//!    eigenvector `(D − μ_i I)⁻¹ ẑ` is then numerically orthogonal to the others. The new column is
//!    formed as `q_K + (û_K − 1)·q_K + Σ_{j≠K} û_j q_j` (`K` the root's origin pole, `û_K − 1` computed
//!    without cancellation): in steady state `Q ≈ I`, so only the small correction is rounded. This
//!    cut the orthonormality guard's repairs tenfold in `f32` (host test `orthonormality.rs`).
//! 4. The new values are sorted in decreasing order with their vectors (eq. 13's order).

use super::unrolled_upto;
use crate::Real;
use nalgebra::{SMatrix, SVector};

/// Iteration cap per root: enough for bisection alone to reach `f64` precision.
pub const MAX_ITERATIONS: u16 = 64;

/// What one update did (for health counters and benchmarks).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Outcome {
    /// Components deflated (no secular root needed).
    pub deflated: u8,
    /// Secular iterations over all roots.
    pub iterations: u16,
    /// Roots that hit [`MAX_ITERATIONS`] without meeting the stopping test (kept at the best iterate).
    pub not_converged: u8,
    /// `true` if [`steady_update`] declined and [`general_update`] did the update.
    pub general: bool,
}

/// Eigendecomposition of `λ·V diag(s²) Vᵀ + w wᵀ`, from and to the **squared** singular values.
///
/// `v` has orthonormal columns, `s2 = s²` is sorted in decreasing order and non-negative,
/// `0 < λ ≤ 1`. Returns the new `(V, s², outcome)` with `s²` sorted decreasingly, or `None` if the
/// result is not finite (the caller keeps its previous state).
///
/// Tries [`steady_update`] first (no deflation, every root nearer its lower pole: the steady state
/// of a recursion) and falls back to [`general_update`] when it declines.
pub fn rank_one_update<T: Real, const M: usize>(
    v: &SMatrix<T, M, M>,
    s2: &SVector<T, M>,
    lambda: T,
    w: &SVector<T, M>,
) -> Option<(SMatrix<T, M, M>, SVector<T, M>, Outcome)> {
    let mut v_out = SMatrix::zeros();
    let mut s2_out = SVector::zeros();
    let out = rank_one_update_into(v, s2, lambda, w, &mut v_out, &mut s2_out)?;
    Some((v_out, s2_out, out))
}

/// [`rank_one_update`] writing the new `V, s²` into `v_out, s2_out` (no copy of the result; the
/// estimator keeps two `V` buffers). On `None` the outputs hold unspecified values.
pub fn rank_one_update_into<T: Real, const M: usize>(
    v: &SMatrix<T, M, M>,
    s2: &SVector<T, M>,
    lambda: T,
    w: &SVector<T, M>,
    v_out: &mut SMatrix<T, M, M>,
    s2_out: &mut SVector<T, M>,
) -> Option<Outcome> {
    if let Some(out) = steady_update(v, s2, lambda, w, v_out, s2_out) {
        return Some(out);
    }
    let mut out = general_update(v, s2, lambda, w, v_out, s2_out)?;
    out.general = true;
    Some(out)
}

/// The general update (module doc, steps 0–4): scaling, deflation, roots from either pole, sort.
/// Same contract as [`rank_one_update_into`], and the same signature as [`steady_update`], which
/// the caller tries first. It writes the new `V, s²` into `v_out, s2_out` (returned by value they
/// were zero-filled, built, returned and copied once more: measured on the QEMU replay, the worst
/// step 40 505 → 38 737 instructions and 560 B less stack).
#[allow(non_snake_case)]
#[inline(never)]
pub fn general_update<T: Real, const M: usize>(
    v: &SMatrix<T, M, M>,
    s2: &SVector<T, M>,
    lambda: T,
    w: &SVector<T, M>,
    v_out: &mut SMatrix<T, M, M>,
    s2_out: &mut SVector<T, M>,
) -> Option<Outcome> {
    // Ascending working order: position k holds column M-1-k of the input.
    let mut a = [T::zero(); M]; // pole square roots √(λ·s²), ascending
    let mut z = [T::zero(); M]; // z = Vᵀw
    let mut q = SMatrix::<T, M, M>::zeros(); // columns of V in working order (rotated by deflation)
    for k in 0..M {
        let src = M - 1 - k;
        a[k] = root_call((lambda * s2[src]).maxr(T::zero()));
        // Whole columns (`data.0[j]` is column `j`): one block copy, not `M` element moves.
        q.data.0[k] = v.data.0[src];
        let mut zk = T::zero();
        for r in 0..M {
            zk += q.data.0[k][r] * w[r];
        }
        z[k] = zk;
    }
    // Scale the problem by a power of two (exact) so that the largest of a, |z| lies in [0.5, 1):
    // squares can then neither overflow nor lose a significant component to underflow. Components
    // below √(MIN_POSITIVE) of the largest (their squares would underflow) contribute less than
    // MIN_POSITIVE relative to σ₁² and are dropped.
    let mut big = T::zero();
    for k in 0..M {
        big = big.maxr(a[k]).maxr(z[k].abs());
    }
    if !(big > T::zero()) || !big.finite() {
        if !big.finite() {
            return None;
        }
        // Nothing to add and nothing held: the zero matrix, unchanged.
        *v_out = *v;
        *s2_out = s2 * lambda;
        return Some(Outcome::default());
    }
    let e = big.exponent();
    let floor = T::SQRT_MIN_POSITIVE;
    // 2^−e as a factor: multiplying by it is exact (2^−e is representable: |e| ≤ 128 / 1024).
    let down = T::one().scale_pow2(-e);
    for k in 0..M {
        a[k] *= down;
        let zk = z[k] * down;
        z[k] = if zk.abs() < floor { T::zero() } else { zk };
    }
    let mut zn2 = T::zero();
    for zk in z.iter() {
        zn2 += *zk * *zk;
    }
    let zn = root_call(zn2);
    let mut out = Outcome::default();

    // 1. Deflation.
    let mut defl = [false; M];
    for k in 0..M {
        if zn * z[k].abs() <= local_tol(a[k]) {
            // The couplings z_k·z_j are negligible; the diagonal term z_k² is kept (exact for the
            // decoupled component), so small increments of a large pole are never lost.
            defl[k] = true;
            a[k] = root_call(a[k] * a[k] + z[k] * z[k]);
            z[k] = T::zero();
        }
    }
    let mut prev: Option<usize> = None;
    for k in 0..M {
        if defl[k] {
            continue;
        }
        if let Some(p) = prev {
            let t = (a[k] - a[p]) * (a[k] + a[p]);
            // The test |t·c·s| ≤ τ with c = z_k/r, s = z_p/r, multiplied by r² (no square root
            // unless the pair is rotated).
            let r2 = z[p] * z[p] + z[k] * z[k];
            if r2 > T::zero() && (t * z[k] * z[p]).abs() <= local_tol(a[k]) * r2 {
                let r = root_call(r2);
                let c = z[k] / r;
                let sn = z[p] / r;
                // Rotate columns p, k so that z_p becomes 0 and z_k becomes r.
                for row in 0..M {
                    let qp = q[(row, p)];
                    let qk = q[(row, k)];
                    q[(row, p)] = c * qp - sn * qk;
                    q[(row, k)] = sn * qp + c * qk;
                }
                let dp = a[p] * a[p];
                let dk = a[k] * a[k];
                a[p] = root_call(dp * c * c + dk * sn * sn);
                a[k] = root_call(dp * sn * sn + dk * c * c);
                z[p] = T::zero();
                z[k] = r;
                defl[p] = true;
            }
        }
        prev = Some(k);
    }
    // Indices of the remaining secular problem, ascending.
    let mut idx = [0usize; M];
    let mut m = 0usize;
    for k in 0..M {
        if !defl[k] {
            idx[m] = k;
            m += 1;
        }
    }
    // m ≤ M by construction; said to the compiler so that the loops below carry no bounds check.
    let m = m.min(M);
    out.deflated = (M - m) as u8;

    // From here on the loops over the `m` poles not deflated run over `unrolled_upto::<M>(…, m)`,
    // which the compiler unrolls, and not over run-time ranges (as `secular_terms`): the worst
    // replay step −1 667 instructions (42 457 → 40 790; the general path runs on the worst
    // samples), +1.7 KB of flash.
    // 2. Roots. Compact copies of the secular problem (ascending poles ac², weights zc).
    let mut ac = [T::zero(); M];
    let mut zc = [T::zero(); M];
    let mut zr2 = T::zero();
    for j in unrolled_upto::<M>(0, m) {
        let k = below::<M>(idx[j]);
        ac[j] = a[k];
        zc[j] = z[k];
        zr2 += zc[j] * zc[j];
    }
    // Pole differences pd[K][j] = δ_j − δ_K, each formed from singular values (no cancellation).
    let mut pd = [[T::zero(); M]; M];
    for kk in unrolled_upto::<M>(0, m) {
        for j in unrolled_upto::<M>(kk + 1, m) {
            let d = (ac[j] - ac[kk]) * (ac[j] + ac[kk]);
            pd[kk][j] = d;
            pd[j][kk] = -d;
        }
    }
    // Root by root (the roots are independent; all state of one root stays in registers). Root r:
    // origin pole `origin[r]`, offset `tau[r]`; `active[r]` stays set if it hit the iteration cap.
    let mut origin = [0usize; M];
    let mut tau = [T::zero(); M];
    let mut active = [false; M];
    for r in unrolled_upto::<M>(0, m) {
        let last = r + 1 == m;
        let r1 = below::<M>(r + 1); // the upper pole (used only when !last, then r + 1 < m ≤ M)
                                    // Midpoint of the gap (the last root: the upper bound δ_m + ‖z‖²), bracket (lo, hi).
        let mut t = if !last { pd[r][r1] * T::lit(0.5) } else { zr2 };
        let mut lo = T::zero();
        let mut hi = t;
        let mut ev = secular_terms_call(&pd[r], &zc, m, r, t);
        out.iterations = out.iterations.saturating_add(1);
        // Origin at the nearer pole, then `dlaed4`'s initial guess: the two poles nearest the root
        // kept exactly, the others lumped into a constant fitted at the evaluated point. Near a pole
        // (the common case once the information is large) it is accurate to a few digits.
        let f0 = T::one() + ev.0 + ev.2;
        let mut kq = r;
        if !last && f0 < T::zero() {
            // Nearer the upper pole. The function values at the midpoint do not depend on the origin.
            kq = r1;
            t = -t;
            lo = t;
            hi = T::zero();
        }
        origin[r] = kq;
        let dk = &pd[kq];
        let (pl, ph) = if last { (r.saturating_sub(1), r) } else { (r, r1) };
        let (zl2, zh2) = if pl == ph {
            (T::zero(), zc[ph] * zc[ph])
        } else {
            (zc[pl] * zc[pl], zc[ph] * zc[ph])
        };
        let (dl, dh) = (dk[pl], dk[ph]);
        let c = f0 - zl2 / (dl - t) - zh2 / (dh - t);
        let qb = c * (dl + dh) + zl2 + zh2;
        let qc = c * dl * dh + zl2 * dh + zh2 * dl;
        if let Some(t0) = quadratic_root_in(c, qb, qc, lo, hi) {
            if t0 != t {
                t = t0;
                ev = secular_terms_call(dk, &zc, m, r, t); // an evaluation at the guess
                out.iterations = out.iterations.saturating_add(1);
            }
        }
        let mut unconverged = true;
        for _ in 0..MAX_ITERATIONS {
            if bns_iteration(dk, r, last, ev, &mut t, &mut lo, &mut hi) {
                unconverged = false;
                break;
            }
            ev = secular_terms_call(dk, &zc, m, r, t);
            out.iterations = out.iterations.saturating_add(1);
        }
        tau[r] = t;
        active[r] = unconverged;
    }
    let mut diff = [[T::zero(); M]; M];
    for r in unrolled_upto::<M>(0, m) {
        if active[r] {
            out.not_converged = out.not_converged.saturating_add(1);
        }
        let dk = &pd[below::<M>(origin[r])];
        for j in unrolled_upto::<M>(0, m) {
            let mut dj = dk[j] - tau[r];
            if dj == T::zero() {
                // The root sits on a pole in floating point: keep the sign the interlacing implies.
                dj = if j <= r { -T::MIN_POSITIVE } else { T::MIN_POSITIVE };
            }
            diff[r][j] = dj;
        }
    }

    // 3. Gu–Eisenstat: ẑ_j² = Π_i (μ_i − δ_j) / Π_{i≠j} (δ_i − δ_j), each factor pair positive.
    let mut rpd = [[T::zero(); M]; M]; // 1/(δ_i − δ_j), i ≠ j
    for j in unrolled_upto::<M>(0, m) {
        for i in unrolled_upto::<M>(j + 1, m) {
            let r = T::one() / pd[j][i];
            rpd[j][i] = r;
            rpd[i][j] = -r;
        }
    }
    let mut zhat = [T::zero(); M];
    for j in unrolled_upto::<M>(0, m) {
        let mut p = -diff[j][j];
        for i in unrolled_upto::<M>(0, m) {
            if i != j {
                p *= -diff[i][j] * rpd[j][i];
            }
        }
        let mag = root_call(p.maxr(T::zero()));
        zhat[j] = if z[below::<M>(idx[j])] < T::zero() { -mag } else { mag };
    }
    // New values and vectors, then sort decreasingly.
    let mut sig = [T::zero(); M];
    let mut cols = SMatrix::<T, M, M>::zeros();
    let mut slot = 0usize;
    for k in 0..M {
        if defl[k] {
            let at = below::<M>(slot); // slots: one per deflated k, then one per root: < M
            sig[at] = a[k] * a[k];
            cols.data.0[at] = q.data.0[k];
            slot += 1;
        }
    }
    // Columns of V taking part in the secular problem, contiguous for the product V·Q.
    let mut qc = [[T::zero(); M]; M];
    for j in unrolled_upto::<M>(0, m) {
        qc[j] = q.data.0[below::<M>(idx[j])];
    }
    for r in unrolled_upto::<M>(0, m) {
        // u = (D − μ_r I)⁻¹ ẑ, normalised, signed so that its component on the origin pole K is
        // positive. Near convergence of the recursion Q ≈ I (each root is close to its own pole), so
        // the new column is formed as q_K + (û_K − 1)·q_K + Σ_{j≠K} û_j q_j with û_K − 1 computed
        // without cancellation: only the small correction is rounded, not the whole product V·Q.
        //
        // `u` is scaled by `δ_K − μ_r` (the smallest `|δ_j − μ_r|`, the root being nearer its origin
        // pole): `u_j = ẑ_j·(δ_K − μ_r)/(δ_j − μ_r)`, `|ratio| ≤ 1`, so a root within rounding of its
        // pole (noise-free data: a zero singular value and a tiny `z_K`) cannot overflow `u`. If the
        // root sits on the pole in floating point, or `u_K` underflows, the eigenvector is the
        // pole's own vector to working precision and the column is kept.
        let kq = below::<M>(origin[r]);
        let acc = general_correction(&diff[r], &zhat, &qc, kq, tau[r], m)?;
        let slot_r = below::<M>(slot);
        for row in 0..M {
            cols[(row, slot_r)] = qc[kq][row] + acc[row];
        }
        let ak = ac[kq];
        sig[slot_r] = (ak * ak + tau[r]).maxr(T::zero());
        slot += 1;
    }
    // Insertion sort by decreasing σ (M is small), carrying the columns.
    let mut order = [0usize; M];
    for (i, o) in order.iter_mut().enumerate() {
        *o = i;
    }
    for i in 1..M {
        let mut j = i;
        while j > 0 && sig[below::<M>(order[j - 1])] < sig[below::<M>(order[j])] {
            order.swap(j - 1, j);
            j -= 1;
        }
    }
    let up = T::one().scale_pow2(e);
    for (dst, &src) in order.iter().enumerate() {
        let src = below::<M>(src);
        // σ² scaled back by 2^2e in two exact steps (2^2e alone may not be representable).
        s2_out[dst] = sig[src] * up * up;
        v_out.data.0[dst] = cols.data.0[src];
    }
    if !super::all_finite(s2_out) || !super::all_finite(v_out) {
        return None;
    }
    Some(out)
}

/// The correction `û − e_K` to column `q_K` (`K = kq`, the origin pole of root `r`) of
/// [`general_update`]'s new eigenvector `r` (module doc, step 3; the comment at the call), from row
/// `r` of the root–pole differences `diff_r`, Gu–Eisenstat's `ẑ`, the columns `qc` and the root's
/// offset `tau_r`; `None` if its norm is not finite. A function of its own, not inlined, so that
/// the loop over the roots is not unrolled `M` times around its `M × M` product (BENCHMARKS.md
/// "Firmware size"; one call per root on the rare samples this path runs, the same arithmetic in
/// the same order).
#[inline(never)]
fn general_correction<T: Real, const M: usize>(
    diff_r: &[T; M],
    zhat: &[T; M],
    qc: &[[T; M]; M],
    kq: usize,
    tau_r: T,
    m: usize,
) -> Option<[T; M]> {
    let kq = below::<M>(kq);
    let dkq = diff_r[kq];
    let mut u = [T::zero(); M];
    let mut off = T::zero();
    // j < K, then j > K (the same order as one loop skipping K, without a branch per entry).
    for j in 0..kq {
        u[j] = zhat[j] * (dkq / diff_r[j]);
        off += u[j] * u[j];
    }
    let uk = zhat[kq];
    u[kq] = uk;
    for j in unrolled_upto::<M>(kq + 1, m) {
        u[j] = zhat[j] * (dkq / diff_r[j]);
        off += u[j] * u[j];
    }
    let nrm = root_call(uk * uk + off);
    if !nrm.finite() {
        return None;
    }
    // The correction û − e_K to the column q_K (zero when the root sits on its pole).
    let mut acc = [T::zero(); M];
    if tau_r != T::zero() && uk != T::zero() && nrm > T::zero() {
        let inv = if uk < T::zero() {
            -T::one() / nrm
        } else {
            T::one() / nrm
        };
        // û_K − 1 = |u_K|/‖u‖ − 1 = −off/(‖u‖·(|u_K| + ‖u‖)), without cancellation and without a
        // second square root (√(1 + off/u_K²) = ‖u‖/|u_K|).
        let mut coef = [T::zero(); M];
        for j in unrolled_upto::<M>(0, m) {
            coef[j] = u[j] * inv;
        }
        coef[kq] = -off / (nrm * (uk.abs() + nrm));
        for j in unrolled_upto::<M>(0, m) {
            let uj = coef[j];
            for row in 0..M {
                acc[row] += qc[j][row] * uj;
            }
        }
    }
    Some(acc)
}

/// [`secular_terms`] as a call, for [`general_update`]: there its three evaluations per root, in
/// a loop over the roots unrolled `M` times, were `3M` inlined copies of an `M`-term loop; called,
/// an evaluation costs a few instructions more on the rare samples this path runs (BENCHMARKS.md
/// "Firmware size"). Same function, same results.
#[inline(never)]
fn secular_terms_call<T: Real, const M: usize>(dk: &[T; M], zc: &[T; M], m: usize, r: usize, t: T) -> (T, T, T, T) {
    secular_terms(dk, zc, m, r, t)
}

/// `x.root()` as a call, for [`general_update`]: inlined, each of its square roots (up to `3M + 4`
/// per update; the software square root of `Real::root` for `f32`) was ≈ 70 instructions of code,
/// a quarter of the function's flash; called, it costs more instructions on the rare samples this
/// path runs (BENCHMARKS.md "Firmware size"). Same function, same results. ([`steady_update`]
/// keeps its roots inlined: called, they cost ≈ 2 000 instructions per replay sample.)
#[inline(never)]
fn root_call<T: Real>(x: T) -> T {
    x.root()
}

/// Largest `λ·s²` and `‖z‖²` [`steady_update`] accepts: `2⁶⁰`, so that products of two pole
/// differences (the BNS quadratic) stay below `2¹²⁰` and cannot overflow even in `f32`.
const STEADY_MAX: f64 = 1.152_921_504_606_847e18;
/// Smallest `λ·s²` and `z_j²` [`steady_update`] accepts: `2⁻⁶⁰` (no square underflows in `f32`).
const STEADY_MIN: f64 = 8.673_617_379_884_035e-19;
/// Iteration cap of [`steady_update`]'s roots (from its first-order start the iteration converges
/// in one or two steps; a root that needs more is left to [`general_update`]).
const STEADY_ITERATIONS: u16 = 8;

/// The rank-one update in the steady state of a recursion, at a fraction of [`general_update`]'s
/// cost; `None` when its assumptions do not hold (the caller then runs [`general_update`]).
///
/// Assumptions, each checked: (i) every `λ·s_j²` and `z_j²` lies in `[2⁻⁶⁰, 2⁶⁰]` and so does
/// `‖z‖²` (no scaling needed, module doc step 0); (ii) nothing deflates by either of
/// [`general_update`]'s two criteria (module doc step 1); (iii) every root lies in the half of its gap
/// next to the pole it starts from (its origin); (iv) every root converges within
/// 8 iterations. Then the roots interlace `δ_r < μ_r < δ_{r+1}` with the poles in order,
/// so no sort is needed, and the eigenvalues are the squared singular values themselves (no square
/// root per value).
///
/// Differences from [`general_update`] on the same input:
/// * the poles are `δ_j = λ·s_j²` and their differences `δ_j − δ_k` are formed from the squares
///   (exact by Sterbenz's lemma whenever `δ_j/δ_k ∈ [½, 2]`, and of the same accuracy as
///   `(a_j − a_k)(a_j + a_k)` otherwise);
/// * each root starts from the first-order perturbation of its pole,
///   `t₀ = z_r² / (1 + Σ_{j≠r} z_j²/(δ_j − δ_r))` (the rank-one term is a small perturbation of
///   `diag(δ)` once the information is large), instead of the midpoint evaluation and `dlaed4`'s
///   guess: in steady state `t₀` is within ~`(t₀/(δ_{r+1} − δ_r))²` of the root, so one evaluation
///   and one Bunch–Nielsen–Sorensen step reach rounding (`f32`), two in `f64`;
/// * Gu–Eisenstat's `ẑ` and the eigenvectors use the reciprocal pole differences once each.
///
/// Math note: the stopping test, the bisection bracket and the eigenvector formula (`q_r` plus a
/// correction, `û_r − 1` without cancellation) are [`general_update`]'s.
///
/// Not inlined (nor is [`general_update`]): measured on the QEMU replay, the median step is 500
/// instructions shorter this way than with the two inlined into their caller, and the firmware
/// 1.6 KB smaller.
#[allow(clippy::needless_range_loop)]
#[inline(never)]
pub fn steady_update<T: Real, const M: usize>(
    v: &SMatrix<T, M, M>,
    s2: &SVector<T, M>,
    lambda: T,
    w: &SVector<T, M>,
    v_out: &mut SMatrix<T, M, M>,
    s2_out: &mut SVector<T, M>,
) -> Option<Outcome> {
    steady_update_in::<T, M, ROOTS_IN_LOCK_STEP>(v, s2, lambda, w, v_out, s2_out)
}

/// [`steady_update`] with the order of its roots' iterations chosen ([`ROOTS_IN_LOCK_STEP`]).
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn steady_update_in<T: Real, const M: usize, const LOCK_STEP: bool>(
    v: &SMatrix<T, M, M>,
    s2: &SVector<T, M>,
    lambda: T,
    w: &SVector<T, M>,
    v_out: &mut SMatrix<T, M, M>,
    s2_out: &mut SVector<T, M>,
) -> Option<Outcome> {
    let vc = &v.data.0; // columns
    let hi_lim = T::lit(STEADY_MAX);
    let lo_lim = T::lit(STEADY_MIN);
    // Ascending working order: k ↔ column M−1−k.
    let mut d = [T::zero(); M]; // δ_k = λ s²
    let mut z = [T::zero(); M]; // z = Vᵀ w
    let mut z2 = [T::zero(); M];
    let mut zn2 = T::zero();
    for k in 0..M {
        let col = &vc[M - 1 - k];
        let mut acc = T::zero();
        for r in 0..M {
            acc += col[r] * w[r];
        }
        z[k] = acc;
        z2[k] = acc * acc;
        zn2 += z2[k];
        d[k] = lambda * s2[M - 1 - k];
    }
    // (i) range (NaN fails every comparison).
    let mut ok = zn2 <= hi_lim && d[M - 1] <= hi_lim;
    for k in 0..M {
        ok &= d[k] >= lo_lim && z2[k] >= lo_lim;
    }
    // (ii) no deflation: |z_k|·‖z‖ > 8ε·δ_k (squared), and no close pair (the Givens criterion,
    // `|t·z_k·z_p| > 8ε·δ_k·(z_p² + z_k²)` with t = δ_k − δ_p).
    let eps8 = T::lit(8.0) * T::EPS;
    for k in 0..M {
        let tol = eps8 * d[k];
        ok &= z2[k] * zn2 > tol * tol;
        if k > 0 {
            let t = d[k] - d[k - 1];
            ok &= (t * z[k] * z[k - 1]).abs() > tol * (z2[k] + z2[k - 1]);
        }
    }
    if !ok {
        return None;
    }
    // Pole differences pd[k][j] = δ_j − δ_k (exactly antisymmetric: a rounded difference changes
    // sign with its operands; 0 on the diagonal) and their reciprocals (k ≠ j). `pd` is built
    // element by element rather than zero-filled and then written: a zero fill of the array is a
    // `memclr` call per update on the M4F.
    let pd: [[T; M]; M] = core::array::from_fn(|k| core::array::from_fn(|j| d[j] - d[k]));
    let mut rp = [[T::zero(); M]; M];
    for k in 0..M {
        for j in (k + 1)..M {
            let r = T::one() / pd[k][j];
            rp[k][j] = r;
            rp[j][k] = -r;
        }
    }
    // First-order denominators 1 + A_k, A_k = Σ_{j≠k} z_j²/(δ_j − δ_k): the root near pole k lies
    // above it at ≈ z_k²/(1 + A_k) if 1 + A_k > 0, below it if 1 + A_k < 0.
    let den: [T; M] = core::array::from_fn(|k| {
        let mut acc = T::one();
        for j in 0..M {
            if j != k {
                acc += z2[j] * rp[k][j];
            }
        }
        acc
    });
    let mut out = Outcome::default();
    let mut tau = [T::zero(); M];
    let mut origin = [0usize; M];
    if LOCK_STEP {
        if !steady_roots_in_lock_step(&pd, &z, &z2, &den, zn2, &mut tau, &mut origin, &mut out) {
            return None;
        }
    } else {
        let half = T::lit(0.5);
        for r in 0..M {
            let last = r + 1 == M;
            // Root r lies in (δ_r, δ_{r+1}) (the last in (δ_r, δ_r + ‖z‖²]). Its origin is the pole it
            // is nearer to; the start is that pole's first-order offset, or (when neither pole's
            // first-order root falls in its half of the gap) the midpoint, whose sign of f decides.
            let gap = if last { zn2 } else { pd[r][r + 1] };
            let mid = gap * half;
            let tl = z2[r] / den[r];
            let (kq, mut t, mut lo, mut hi) =
                if den[r] > T::zero() && tl > T::zero() && (tl < mid || (last && tl < gap)) {
                    (r, tl, T::zero(), gap)
                } else if !last && den[r + 1] < T::zero() && z2[r + 1] / den[r + 1] > -mid {
                    (r + 1, z2[r + 1] / den[r + 1], -gap, T::zero())
                } else if last {
                    (r, gap, T::zero(), gap)
                } else {
                    let (psi, _, phi, _) = secular_terms(&pd[r], &z, M, r, mid);
                    out.iterations = out.iterations.saturating_add(1);
                    if T::one() + psi + phi < T::zero() {
                        (r + 1, -mid, -mid, T::zero())
                    } else {
                        (r, mid, T::zero(), mid)
                    }
                };
            let dk = &pd[kq];
            let mut converged = false;
            for _ in 0..STEADY_ITERATIONS {
                let ev = secular_terms(dk, &z, M, r, t);
                out.iterations = out.iterations.saturating_add(1);
                if bns_iteration(dk, r, last, ev, &mut t, &mut lo, &mut hi) {
                    converged = true;
                    break;
                }
            }
            // (iii) the root in its origin's half of the gap (strictly off the pole), (iv) converged.
            let in_half = if kq == r {
                t > T::zero() && (t <= mid || last)
            } else {
                t < T::zero() && t >= -mid
            };
            if !(converged && in_half) {
                return None;
            }
            tau[r] = t;
            origin[r] = kq;
        }
    }
    // diff[r][j] = δ_j − μ_r (never 0: τ_r is strictly between its origin pole and the midpoint).
    let mut diff = [[T::zero(); M]; M];
    for r in 0..M {
        let dk = &pd[below::<M>(origin[r])];
        for j in 0..M {
            diff[r][j] = dk[j] - tau[r];
        }
    }
    // Gu–Eisenstat: ẑ_j² = Π_i (μ_i − δ_j) / Π_{i≠j} (δ_i − δ_j), every factor pair positive.
    let mut zhat = [T::zero(); M];
    for j in 0..M {
        let mut p = -diff[j][j];
        for i in 0..M {
            if i != j {
                p *= -diff[i][j] * rp[j][i];
            }
        }
        let mag = p.root();
        zhat[j] = if z[j] < T::zero() { -mag } else { mag };
    }
    // Eigenvector r with origin K: u_j = ẑ_j·(δ_K − μ_r)/(δ_j − μ_r) (|ratio| ≤ 1), u_K = ẑ_K; new
    // column q_K + (û_K − 1)·q_K + Σ_{j≠K} û_j q_j (module doc, step 3).
    for r in 0..M {
        let kq = below::<M>(origin[r]);
        let mut coef = [T::zero(); M];
        let mut off = T::zero();
        let dkq = diff[r][kq];
        for j in 0..M {
            if j != kq {
                let u = zhat[j] * (dkq / diff[r][j]);
                coef[j] = u;
                off += u * u;
            }
        }
        let uk = zhat[kq];
        let nrm = (uk * uk + off).root();
        if !(nrm > T::zero() && nrm.finite() && uk != T::zero()) {
            return None;
        }
        let inv = if uk < T::zero() {
            -T::one() / nrm
        } else {
            T::one() / nrm
        };
        for j in 0..M {
            coef[j] *= inv;
        }
        coef[kq] = -off / (nrm * (uk.abs() + nrm));
        let dst = M - 1 - r;
        let mut col = vc[M - 1 - kq];
        for j in 0..M {
            let cj = coef[j];
            let src = &vc[M - 1 - j];
            for row in 0..M {
                col[row] += src[row] * cj;
            }
        }
        v_out.data.0[dst] = col;
        s2_out[dst] = d[kq] + tau[r];
    }
    Some(out)
}

/// Whether [`steady_update`] iterates its roots in lock step (every root one iteration, then
/// the next round) rather than in turn (each root to convergence, then the next). The roots are
/// independent and each sees the same arithmetic in the same order either way, so the two orders
/// give bit-identical results (host test `the_two_root_orders_agree_bit_for_bit`). In lock step,
/// the roots' dependency chains (an evaluation, then the step's square root and division) overlap
/// on an out-of-order CPU: measured on the host, one `f64` update with five parameters
/// 561 → 471 ns. In turn, one root's state stays in registers: on the in-order Cortex-M4F the
/// lock-step order cost 3 % more instructions per step (QEMU replay median 24 270 → 25 011).
/// So: in turn on bare-metal targets, in lock step elsewhere.
pub const ROOTS_IN_LOCK_STEP: bool = cfg!(not(target_os = "none"));

/// Root `r`'s start for [`steady_roots_in_lock_step`]: `(origin, t, lo, hi, mid)`. Root `r` lies in
/// `(δ_r, δ_{r+1})` (the last in `(δ_r, δ_r + ‖z‖²]`); its origin is the pole it is nearer to; the
/// start is that pole's first-order offset, or (when neither pole's first-order root falls in its
/// half of the gap) the midpoint, whose sign of `f` decides (one evaluation, counted in `out`).
#[inline(always)]
fn steady_start<T: Real, const M: usize>(
    pd: &[[T; M]; M],
    z: &[T; M],
    z2: &[T; M],
    den: &[T; M],
    zn2: T,
    r: usize,
    out: &mut Outcome,
) -> (usize, T, T, T, T) {
    let last = r + 1 == M;
    let gap = if last { zn2 } else { pd[r][r + 1] };
    let mid = gap * T::lit(0.5);
    let tl = z2[r] / den[r];
    let (kq, t, lo, hi) = if den[r] > T::zero() && tl > T::zero() && (tl < mid || (last && tl < gap)) {
        (r, tl, T::zero(), gap)
    } else if !last && den[r + 1] < T::zero() && z2[r + 1] / den[r + 1] > -mid {
        (r + 1, z2[r + 1] / den[r + 1], -gap, T::zero())
    } else if last {
        (r, gap, T::zero(), gap)
    } else {
        let (psi, _, phi, _) = secular_terms(&pd[r], z, M, r, mid);
        out.iterations = out.iterations.saturating_add(1);
        if T::one() + psi + phi < T::zero() {
            (r + 1, -mid, -mid, T::zero())
        } else {
            (r, mid, T::zero(), mid)
        }
    };
    (kq, t, lo, hi, mid)
}

/// Whether root `r`, converged at offset `t` from its origin `kq`, lies in its origin's half of
/// the gap, strictly off the pole ([`steady_update`]'s assumption (iii)).
#[inline(always)]
fn steady_in_half<T: Real, const M: usize>(r: usize, kq: usize, t: T, mid: T) -> bool {
    if kq == r {
        t > T::zero() && (t <= mid || r + 1 == M)
    } else {
        t < T::zero() && t >= -mid
    }
}

/// [`steady_update`]'s roots in lock step ([`ROOTS_IN_LOCK_STEP`]): each root's offset `tau[r]`
/// from its origin pole `origin[r]`, by the Bunch–Nielsen–Sorensen iteration from
/// [`steady_start`], every root one iteration per round. The same arithmetic per root as the
/// in-turn loop in [`steady_update_in`] (which keeps its own copy of the start, inlined: through
/// this function's start the firmware grew by 1.2 KB). `false` if a root does not converge within
/// `STEADY_ITERATIONS` or leaves its origin's half of the gap (the caller declines).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn steady_roots_in_lock_step<T: Real, const M: usize>(
    pd: &[[T; M]; M],
    z: &[T; M],
    z2: &[T; M],
    den: &[T; M],
    zn2: T,
    tau: &mut [T; M],
    origin: &mut [usize; M],
    out: &mut Outcome,
) -> bool {
    let mut lo = [T::zero(); M];
    let mut hi = [T::zero(); M];
    let mut mid = [T::zero(); M];
    for r in 0..M {
        let (kq, t, l, h, m) = steady_start(pd, z, z2, den, zn2, r, out);
        (origin[r], tau[r], lo[r], hi[r], mid[r]) = (kq, t, l, h, m);
    }
    let mut converged = [false; M];
    for _ in 0..STEADY_ITERATIONS {
        let mut all = true;
        for r in 0..M {
            if converged[r] {
                continue;
            }
            let dk = &pd[below::<M>(origin[r])];
            let ev = secular_terms(dk, z, M, r, tau[r]);
            out.iterations = out.iterations.saturating_add(1);
            converged[r] = bns_iteration(dk, r, r + 1 == M, ev, &mut tau[r], &mut lo[r], &mut hi[r]);
            all &= converged[r];
        }
        if all {
            break;
        }
    }
    (0..M).all(|r| converged[r] && steady_in_half::<T, M>(r, origin[r], tau[r], mid[r]))
}

/// One Bunch–Nielsen–Sorensen iteration of root `r` after an evaluation `ev = (ψ, ψ′, φ, φ′)` at
/// `t` (offset from the origin pole; `dk[j] = δ_j − δ_origin`): narrows the bisection bracket
/// `(lo, hi)` by the sign of `f`, stops when `|f|` is below its rounding error bound (`dlaed4`'s
/// test), else replaces `ψ` and `φ` by one pole plus a constant each (matching value and slope),
/// solves the resulting quadratic for the step ([`small_root_in`]) and moves `t` (to the bracket's
/// midpoint if the step leaves it). Returns `true` when the root is converged: by the error bound,
/// because `t` did not move, or after a model step below `0.1·√ε` relative (the iteration is
/// quadratic, so the remaining error is ~ε/100 and no confirming evaluation is needed).
#[inline(always)]
fn bns_iteration<T: Real, const M: usize>(
    dk: &[T; M],
    r: usize,
    last: bool,
    ev: (T, T, T, T),
    t: &mut T,
    lo: &mut T,
    hi: &mut T,
) -> bool {
    let (psi, dpsi, phi, dphi) = ev;
    let f = T::one() + psi + phi;
    if f > T::zero() {
        *hi = *t;
    } else if f < T::zero() {
        *lo = *t;
    }
    let err_bound = T::EPS * (T::lit(8.0) * (T::one() + psi.abs() + phi.abs()) + t.abs() * (dpsi + dphi));
    if f.abs() <= err_bound {
        return true;
    }
    let d1 = dk[r] - *t; // δ_r − μ < 0
    let eta = if !last {
        let d2 = dk[below::<M>(r + 1)] - *t; // δ_{r+1} − μ > 0 (r + 1 < M when !last)
        let s1 = d1 * d1 * dpsi;
        let s2 = d2 * d2 * dphi;
        let c = f - d1 * dpsi - d2 * dphi;
        small_root_in(c, c * (d1 + d2) + s1 + s2, d1 * d2 * f, d1, d2)
    } else {
        let c = f - d1 * dpsi;
        if c > T::zero() {
            Some(d1 + d1 * d1 * dpsi / c)
        } else {
            None
        }
    };
    let (tn, model) = match eta {
        // False for a NaN or infinite e (see `quadratic_root_in`).
        Some(e) if *t + e > *lo && *t + e < *hi => (*t + e, true),
        _ => ((*lo + *hi) * T::lit(0.5), false),
    };
    if tn == *t {
        return true;
    }
    let step = tn - *t;
    *t = tn;
    model && step.abs() <= T::lit(0.1) * T::SQRT_EPS * tn.abs()
}

/// `(ψ, ψ′, φ, φ′)` of the secular function at offset `t` from the origin pole: `ψ` sums the poles
/// `0..=r` (left of root `r`), `φ` the poles right of it up to the `m` not deflated;
/// `dk[j] = δ_j − δ_origin`.
///
/// One loop of compile-time length `M`, which the compiler unrolls, each term added to `ψ` or `φ`
/// (or, past `m`, to neither) by the index test, instead of two loops with run-time bounds: the
/// same terms in the same order, so bit-identical, and on the M4F −2 112 instructions per
/// six-coefficient step (median 29 723 → 27 611, max 44 228 → 42 860, QEMU replay) —
/// the loop overhead of the run-time bounds was a third of each evaluation. The terms past `m`
/// are computed and dropped (a division by `δ_j − δ_origin − t` that may be 0 gives ±∞ or NaN,
/// never a trap, and is not added).
#[inline(always)]
fn secular_terms<T: Real, const M: usize>(dk: &[T; M], zc: &[T; M], m: usize, r: usize, t: T) -> (T, T, T, T) {
    let (mut psi, mut dpsi, mut phi, mut dphi) = (T::zero(), T::zero(), T::zero(), T::zero());
    for j in 0..M {
        let term = zc[j] / (dk[j] - t);
        if j <= r {
            psi += zc[j] * term;
            dpsi += term * term;
        } else if j < m {
            phi += zc[j] * term;
            dphi += term * term;
        }
    }
    (psi, dpsi, phi, dphi)
}

/// `i` clamped into `0..M`. Every index this module keeps in an array (`idx`, `origin`) is below
/// `M` by construction, so this is the identity on every value it is given; it only lets the
/// compiler see the bound and drop the bounds check, and with it a panic path from the release
/// firmware (`firmware/panic-allow.txt`). One compare and a conditional move, the cost
/// of the check it replaces.
#[inline(always)]
fn below<const M: usize>(i: usize) -> usize {
    if i < M {
        i
    } else {
        M.saturating_sub(1)
    }
}

/// Deflation tolerance local to the pole `a²`: `8ε·a²` (floored at the smallest normal number).
///
/// Math note: LAPACK's `dlaed2` uses the global `8ε·max(‖D‖, ‖z‖²)` and drops `z_j` entirely, which
/// is backward stable for one update. In a recursion with `λ = 1` over 10⁵ samples in `f32` it is not
/// enough: every sample whose component along a small singular direction is below `8ε·σ₁²/‖z‖` would
/// be dropped and the small singular values (the noise level PCA-GTLS needs, eq. 19) would stop
/// growing; and dropping `z_j²` from a large pole loses a few ulps per sample, a systematic bias of
/// ~1e-3 over 10⁵ samples (measured). So a component is deflated only if the couplings it drops,
/// `|z_j|·‖z‖`, are below rounding of its *own* pole, and its diagonal term `z_j²` is kept. The dropped
/// off-diagonal entries move an eigenvalue `δ_k` by `(z_j z_k)²/|δ_j − δ_k|` (second order) and an
/// eigenvector by `O(ε·δ_j/|δ_j − δ_k|)`.
fn local_tol<T: Real>(a: T) -> T {
    (T::lit(8.0) * T::EPS * a * a).maxr(T::MIN_POSITIVE)
}

/// [`quadratic_root_in`] without its square root near convergence: when `u = qa·qc/qb²` is small
/// the root nearer 0 is `(qc/qb)·C(u)` with `C(u) = 2/(1 + √(1 − 4u)) = Σ Catalan_n uⁿ`
/// `= 1 + u + 2u² + 5u³ + 14u⁴ + …`; truncated after `u⁴` its relative error is `≈ 42u⁵`, below
/// `ε/4` for `|u| ≤ (ε/168)^⅕` (`f32`: 0.0148, `f64`: 2.3e-4). Otherwise, or if that root is not
/// inside `(lo, hi)`, [`quadratic_root_in`].
#[inline(always)]
fn small_root_in<T: Real>(qa: T, qb: T, qc: T, lo: T, hi: T) -> Option<T> {
    let u_max = if T::EPS.to_f64() > 1e-10 {
        T::lit(0.0148)
    } else {
        T::lit(2.3e-4)
    };
    let r = qc / qb;
    let u = qa * r / qb;
    if u.abs() <= u_max {
        let e = r * (T::one() + u * (T::one() + u * (T::lit(2.0) + u * (T::lit(5.0) + u * T::lit(14.0)))));
        if e > lo && e < hi {
            return Some(e);
        }
    }
    quadratic_root_in(qa, qb, qc, lo, hi)
}

/// The root of `qa·x² − qb·x + qc = 0` strictly inside `(lo, hi)`, if there is one (stable formulas).
#[inline(always)]
fn quadratic_root_in<T: Real>(qa: T, qb: T, qc: T, lo: T, hi: T) -> Option<T> {
    // `lo < e < hi` is false for NaN and for ±∞ whatever the bounds, so no separate finiteness test.
    let inside = |e: T| e > lo && e < hi;
    if qa == T::zero() {
        let e = qc / qb;
        return if inside(e) { Some(e) } else { None };
    }
    let disc = root_call((qb * qb - T::lit(4.0) * qa * qc).maxr(T::zero()));
    let qq = if qb >= T::zero() {
        (qb + disc) * T::lit(0.5)
    } else {
        (qb - disc) * T::lit(0.5)
    };
    let e1 = qq / qa;
    if inside(e1) {
        return Some(e1);
    }
    if qq != T::zero() {
        let e2 = qc / qq;
        if inside(e2) {
            return Some(e2);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{SMatrix, SVector};

    /// xorshift64*: a tiny seeded generator for unit tests.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
            (v >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// Eigenvalues of a symmetric matrix by cyclic Jacobi (test oracle only), decreasing.
    fn jacobi_eigenvalues<const M: usize>(mut a: SMatrix<f64, M, M>) -> [f64; M] {
        for _ in 0..100 {
            let mut off = 0.0;
            for p in 0..M {
                for q in (p + 1)..M {
                    off += a[(p, q)] * a[(p, q)];
                    if a[(p, q)].abs() < 1e-300 {
                        continue;
                    }
                    let theta = (a[(q, q)] - a[(p, p)]) / (2.0 * a[(p, q)]);
                    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).root());
                    let t = if theta == 0.0 { 1.0 } else { t };
                    let c = 1.0 / (t * t + 1.0).root();
                    let sn = t * c;
                    for k in 0..M {
                        let akp = a[(k, p)];
                        let akq = a[(k, q)];
                        a[(k, p)] = c * akp - sn * akq;
                        a[(k, q)] = sn * akp + c * akq;
                    }
                    for k in 0..M {
                        let apk = a[(p, k)];
                        let aqk = a[(q, k)];
                        a[(p, k)] = c * apk - sn * aqk;
                        a[(q, k)] = sn * apk + c * aqk;
                    }
                }
            }
            if off < 1e-40 * a.norm_squared().max(1e-300) {
                break;
            }
        }
        let mut ev = [0.0; M];
        for i in 0..M {
            ev[i] = a[(i, i)];
        }
        ev.sort_by(|x, y| y.partial_cmp(x).unwrap());
        ev
    }

    /// A seeded recursion (`λ = 0.995`, rows of mixed scales) through [`steady_update_in`] in
    /// both root orders: every accepted update gives the same `V`, `s²` and iteration count, bit
    /// for bit, and both orders decline the same updates.
    fn root_orders_agree<T: Real + core::fmt::Debug, const M: usize>(seed: u64) -> usize {
        let mut rng = Rng(seed);
        let mut v = SMatrix::<T, M, M>::identity();
        let mut s2 = SVector::<T, M>::zeros();
        let lambda = T::lit(0.995);
        let scales: [f64; M] = core::array::from_fn(|j| 10f64.powi(j as i32 % 3 - 1));
        let mut accepted = 0;
        for _ in 0..3000 {
            let w = SVector::<T, M>::from_fn(|j, _| T::lit(scales[j] * rng.next()));
            let (mut va, mut sa) = (SMatrix::<T, M, M>::zeros(), SVector::<T, M>::zeros());
            let (mut vb, mut sb) = (SMatrix::<T, M, M>::zeros(), SVector::<T, M>::zeros());
            let a = steady_update_in::<T, M, true>(&v, &s2, lambda, &w, &mut va, &mut sa);
            let b = steady_update_in::<T, M, false>(&v, &s2, lambda, &w, &mut vb, &mut sb);
            assert_eq!(a.is_some(), b.is_some());
            if let (Some(a), Some(b)) = (a, b) {
                assert_eq!(a.iterations, b.iterations);
                for (x, y) in va.iter().chain(sa.iter()).zip(vb.iter().chain(sb.iter())) {
                    assert!(x.bits_u64() == y.bits_u64(), "{x:?} vs {y:?}");
                }
                accepted += 1;
            }
            // The recursion goes on with the general update (the estimator's fallback).
            let (nv, ns, _) = rank_one_update(&v, &s2, lambda, &w).expect("finite");
            (v, s2) = (nv, ns);
        }
        accepted
    }

    #[test]
    fn the_two_root_orders_agree_bit_for_bit() {
        // Most updates of a recursion past its start take the steady path: at least 90 %.
        let n = root_orders_agree::<f64, 6>(0x5EED_0001);
        assert!(n > 2700, "f64: {n} of 3000 steady");
        let n = root_orders_agree::<f32, 6>(0x5EED_0002);
        assert!(n > 2700, "f32: {n} of 3000 steady");
        let n = root_orders_agree::<f64, 4>(0x5EED_0003);
        assert!(n > 2700, "f64 M = 4: {n} of 3000 steady");
    }

    /// One update from `(V, s²)` checked against a dense eigensolver; returns the new `(V, s², outcome)`.
    fn check<const M: usize>(
        v: SMatrix<f64, M, M>,
        s2: SVector<f64, M>,
        lam: f64,
        w: SVector<f64, M>,
        tol: f64,
    ) -> (SMatrix<f64, M, M>, SVector<f64, M>, Outcome) {
        let g = v * SMatrix::from_diagonal(&s2) * v.transpose() * lam + w * w.transpose();
        let (v2, s2n, out) = rank_one_update(&v, &s2, lam, &w).unwrap();
        let ev = jacobi_eigenvalues(g);
        for i in 0..M {
            assert!((s2n[i] - ev[i]).abs() <= tol * ev[0], "σ²_{i}: {} vs {}", s2n[i], ev[i]);
            if i > 0 {
                assert!(s2n[i] <= s2n[i - 1]);
            }
        }
        let rec = v2 * SMatrix::from_diagonal(&s2n) * v2.transpose();
        let err = (rec - g).norm() / g.norm().max(1e-300);
        assert!(err < tol, "reconstruction {err}");
        let orth = crate::linalg::orthonormality_error(&v2);
        assert!(orth < tol, "orthonormality {orth}");
        (v2, s2n, out)
    }

    #[test]
    fn random_updates_match_dense_eigen() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut steady = 0;
        for _ in 0..500 {
            let mut v = SMatrix::<f64, 5, 5>::identity();
            let mut s2 = SVector::<f64, 5>::zeros();
            for _ in 0..20 {
                let w = SVector::<f64, 5>::from_fn(|_, _| rng.next());
                let lam = 0.9 + 0.1 * rng.next().abs();
                let (v2, s2n, out) = check(v, s2, lam, w, 1e-12);
                steady += usize::from(!out.general);
                v = v2;
                s2 = s2n;
            }
        }
        // Both paths are exercised: the first updates of each run deflate (general path).
        assert!(
            steady > 1000 && steady < 10_000,
            "steady path taken {steady} of 10000 times"
        );
    }

    #[test]
    fn steady_path_agrees_with_the_general_path_in_a_long_recursion() {
        // GIVEN a recursion with forgetting long past its start (large information, small updates)
        let mut rng = Rng(0x0123_4567_89AB_CDEF);
        let mut v = SMatrix::<f64, 6, 6>::identity();
        let mut s2 = SVector::<f64, 6>::zeros();
        let scale = [3.0, 1.0, 0.5, 0.2, 0.1, 0.05];
        let mut steady = 0;
        for n in 0..3000 {
            let w = SVector::<f64, 6>::from_fn(|i, _| rng.next() * scale[i]);
            // WHEN both paths update the same state
            let (mut vg, mut sg) = (SMatrix::zeros(), SVector::zeros());
            general_update(&v, &s2, 0.995, &w, &mut vg, &mut sg).unwrap();
            let general = (vg, sg);
            let (mut vf, mut sf) = (SMatrix::zeros(), SVector::zeros());
            let fast = steady_update(&v, &s2, 0.995, &w, &mut vf, &mut sf);
            // THEN where the steady path applies it agrees with the general one to rounding
            if fast.is_some() {
                steady += 1;
                for i in 0..6 {
                    assert!((sf[i] - general.1[i]).abs() <= 1e-13 * general.1[0], "step {n}: σ²_{i}");
                    // Columns agree up to sign (both sign the origin-pole component positive).
                    let dot: f64 = (0..6).map(|r| vf[(r, i)] * general.0[(r, i)]).sum();
                    assert!((dot.abs() - 1.0).abs() < 1e-12, "step {n}: column {i} {dot}");
                }
            }
            v = general.0;
            s2 = general.1;
        }
        assert!(steady > 2900, "steady path taken {steady} of 3000 times");
    }

    #[test]
    fn deflation_cases() {
        // Zero start (all poles equal), a zero update, a component-free update and equal values.
        let v = SMatrix::<f64, 4, 4>::identity();
        let s2 = SVector::<f64, 4>::zeros();
        check(v, s2, 1.0, SVector::from([1.0, 2.0, 3.0, 4.0]), 1e-13);
        let s2 = SVector::<f64, 4>::from([9.0, 4.0, 4.0, 1.0]);
        check(v, s2, 1.0, SVector::zeros(), 1e-14);
        check(v, s2, 0.5, SVector::from([0.0, 1.0, 0.0, 1.0]), 1e-13);
        check(v, s2, 1.0, SVector::from([1.0, 1.0, 1.0, 1.0]), 1e-13);
        check(v, s2, 1.0, SVector::from([1e-20, 1.0, 1e-20, 1e-3]), 1e-13);
    }
}
