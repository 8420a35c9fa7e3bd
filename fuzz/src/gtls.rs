//! Fuzz target `gtls`: a bare recursive PCA-GTLS estimator fed an arbitrary sample sequence.
//!
//! ## Input
//! * Byte 0, the set-up: bit 0 the scalar (`f32`/`f64`); bits 1–2 the estimator (`Gtls<_, 4, 1, 4>`
//!   intercept + 3 noisy, `Gtls<_, 3, 0, 4>` no exact column, `Gtls<_, 6, 1, 6>` the pipeline's
//!   largest); bits 3–4 the forgetting (`λ = 1`, `λ = 0.98`, VFF `for_dimension`, VFF
//!   `for_aero_coefficients(100)`); bits 5–6 `max_abs_input` (1e6, 1e30, the largest finite value).
//! * Then `W_T = D^½ L Lᵀ D^½` (per noisy-block entry a byte: variance `10^−(b mod 8)`; per entry
//!   below the diagonal of the unit triangular `L` a byte: `(b as i8)/512`), one weight byte per
//!   parameter (`10^((b mod 7) − 3)`) and an `s/n` byte (`0, 0.5, 1, 1.5`).
//! * Then operations until the input ends or [`MAX_STEPS`] updates: an explicit sample (every element
//!   from [`scalar`]: ordinary, NaN, ±∞, subnormal, ±1e30, ±0, the bound, just above it, tiny,
//!   square-underflowing, any bit pattern); a repeat of the last sample (up to 256 times); a scale
//!   jump (×10^k, |k| < 30); a block of up to 1021 samples of a linear model with noise from a seeded
//!   generator (optionally a column stuck at 0 and/or an exactly collinear pair); a run of up to 2047
//!   identical samples (loss of excitation).
//!
//! ## Invariants (every update)
//! * A sample with a NaN/±∞ or an element above the bound is refused with exactly
//!   `NonFinite { index }` / `OutOfRange { index }` of its first bad element; an in-range sample is
//!   accepted or refused only as `NumericalFault`. After any refusal the whole state is
//!   bit-identical ([`crate::snapshot`]).
//! * After an accepted sample: every float of the whole state finite; `S` sorted, non-negative;
//!   `‖VᵀV − I‖_F ≤` [`crate::orthonormality_tolerance`]; `k` = the number of the `NA − 1` leading
//!   `σ_j` above `threshold()` (0 without one); the solution kind consistent with `k`; at `k = 0`
//!   the noisy parameters exactly 0 (eq. 22–23 with no constraint); `λ` equal to the constant or in
//!   `[λ_min, λ_max]`; `1 ≤ N_eff ≤` the number of accepted samples.

use crate::input::{scalar, Gen, Input};
use crate::{assert_state_finite, orthonormality_tolerance, snapshot};
use aerosid_core::{Error, Estimator, Forgetting, Gtls, GtlsSettings, Real, Solution, VffSettings};
use nalgebra::{SMatrix, SVector};
use std::fmt::Debug;

/// Most updates per input (keeps one execution in the milliseconds).
pub const MAX_STEPS: usize = 4000;

/// The fuzz entry point.
pub fn run(data: &[u8]) {
    let mut inp = Input::new(data);
    let setup = inp.u8();
    let f64_scalar = setup & 1 != 0;
    match ((setup >> 1) & 3, f64_scalar) {
        (0 | 3, false) => fuzz::<f32, 4, 1, 4>(setup, &mut inp),
        (0 | 3, true) => fuzz::<f64, 4, 1, 4>(setup, &mut inp),
        (1, false) => fuzz::<f32, 3, 0, 4>(setup, &mut inp),
        (1, true) => fuzz::<f64, 3, 0, 4>(setup, &mut inp),
        (_, false) => fuzz::<f32, 6, 1, 6>(setup, &mut inp),
        (_, true) => fuzz::<f64, 6, 1, 6>(setup, &mut inp),
    }
}

/// What the invariants need to know about the set-up.
struct Context<T> {
    bound: T,
    lambda: LambdaRange<T>,
    updates: u64,
}

/// The `λ` an estimator may report after an update.
#[derive(Debug, Clone, Copy)]
pub enum LambdaRange<T> {
    /// Exactly this constant.
    Constant(T),
    /// Within `[λ_min, λ_max]` (VFF).
    Between(T, T),
}

fn largest<T: Real>() -> T {
    // The largest finite value of T: 2^(emax) · (2 − ε).
    let mut x = T::one();
    while (x * T::lit(2.0)).finite() {
        x *= T::lit(2.0);
    }
    x * (T::lit(2.0) - T::EPS)
}

fn fuzz<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize>(setup: u8, inp: &mut Input<'_>) {
    let Some((est, cx)) = estimator::<T, NT, NE, NA>(setup, inp) else {
        return;
    };
    let mut feed = Feed::new(est, cx);
    while !inp.is_empty() && feed.steps < MAX_STEPS {
        let op = inp.u8();
        match op % 8 {
            0..=2 => feed.explicit_sample(op, inp),
            3 => {
                let n = usize::from(inp.u8()) + 1;
                feed.repeat_last(n);
            }
            4 => {
                let k = i32::from(inp.u8() as i8) % 30;
                feed.scale = (feed.scale * 10f64.powi(k)).clamp(1e-30, 1e30);
            }
            5 => feed.linear_block(op, inp),
            6 => feed.stuck = inp.u8(),
            _ => {
                let n = usize::from(inp.u16() % 2048);
                feed.repeat_last(n);
            }
        }
    }
    assert_state_finite("gtls at the end", &feed.est);
}

/// The input bound (bits 5–6 of the set-up byte).
fn input_bound<T: Real>(setup: u8) -> T {
    match (setup >> 5) & 3 {
        0 | 3 => T::lit(1e6),
        1 => T::lit(1e30),
        _ => largest::<T>(),
    }
}

/// The forgetting (bits 3–4 of the set-up byte) and the `λ` it allows.
fn forgetting<T: Real>(setup: u8, nt: usize) -> (Forgetting<T>, LambdaRange<T>) {
    match (setup >> 3) & 3 {
        0 => (Forgetting::Constant(T::one()), LambdaRange::Constant(T::one())),
        1 => (Forgetting::Constant(T::lit(0.98)), LambdaRange::Constant(T::lit(0.98))),
        2 => {
            let v = VffSettings::for_dimension(nt);
            (
                Forgetting::Variable(v),
                LambdaRange::Between(v.lambda_min, v.lambda_max),
            )
        }
        _ => {
            let v = VffSettings::for_aero_coefficients(T::lit(100.0));
            (
                Forgetting::Variable(v),
                LambdaRange::Between(v.lambda_min, v.lambda_max),
            )
        }
    }
}

/// `W_T = D^½ L Lᵀ D^½` from the input (module doc), in `f64`.
fn noise_covariance<const NA: usize>(inp: &mut Input<'_>) -> SMatrix<f64, NA, NA> {
    let d: [f64; NA] = core::array::from_fn(|_| 10f64.powi(-i32::from(inp.u8() % 8)));
    let mut l = SMatrix::<f64, NA, NA>::identity();
    for i in 0..NA {
        for j in 0..i {
            l[(i, j)] = f64::from(inp.u8() as i8) / 512.0;
        }
    }
    let dh = SMatrix::<f64, NA, NA>::from_fn(|i, j| if i == j { d[i].sqrt() } else { 0.0 });
    dh * l * l.transpose() * dh
}

/// The estimator the set-up byte and the input's `W_T`, weight and `s/n` bytes describe, and what
/// its invariants need; `None` when it is refused as not positive definite (the documented
/// refusal).
fn estimator<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize>(
    setup: u8,
    inp: &mut Input<'_>,
) -> Option<(Gtls<T, NT, NE, NA>, Context<T>)> {
    let bound = input_bound(setup);
    let (forgetting, lambda) = forgetting(setup, NT);
    let w_t = noise_covariance::<NA>(inp).map(T::lit);
    let weights = SVector::<T, NT>::from_fn(|_, _| T::lit(10f64.powi(i32::from(inp.u8() % 7) - 3)));
    let snr = T::lit(f64::from(inp.u8() % 4) * 0.5);
    let settings = GtlsSettings {
        snr,
        max_abs_input: bound,
        reorth_tol: T::zero(),
        forgetting,
    };
    match Gtls::<T, NT, NE, NA>::new(&w_t, &weights, settings) {
        Ok(est) => Some((
            est,
            Context {
                bound,
                lambda,
                updates: 0,
            },
        )),
        // W_T is SPD by construction, but rounding to f32 of a badly scaled one may not be: a
        // refusal at construction is the documented behaviour.
        Err(Error::NotPositiveDefinite) => None,
        Err(e) => panic!("valid settings refused: {e:?}"),
    }
}

/// The estimator being fed, with what the operations carry from one to the next.
struct Feed<T: Real, const NT: usize, const NE: usize, const NA: usize> {
    est: Gtls<T, NT, NE, NA>,
    cx: Context<T>,
    /// The last sample fed.
    last: (SVector<T, NT>, T),
    /// The scale of ordinary values.
    scale: f64,
    /// Bit `i`: column `i` stuck at 0 in linear blocks.
    stuck: u8,
    /// Updates so far.
    steps: usize,
}

impl<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize> Feed<T, NT, NE, NA> {
    fn new(est: Gtls<T, NT, NE, NA>, cx: Context<T>) -> Self {
        let mut last = (SVector::<T, NT>::zeros(), T::zero());
        if NE > 0 {
            last.0[0] = T::one();
        }
        Self {
            est,
            cx,
            last,
            scale: 1.0,
            stuck: 0,
            steps: 0,
        }
    }

    fn step(&mut self, x: SVector<T, NT>, z: T) {
        self.last = (x, z);
        step(&mut self.est, &x, z, &mut self.cx);
        self.steps += 1;
    }

    /// One sample, every element from [`scalar`]; the intercept unless `op` bit 7; an exactly
    /// collinear pair (`x_j = c·x_i`) if bit 6.
    fn explicit_sample(&mut self, op: u8, inp: &mut Input<'_>) {
        let bound = self.cx.bound.to_f64();
        let mut x = SVector::<T, NT>::zeros();
        for i in 0..NT {
            x[i] = scalar::<T>(inp, self.scale, bound).0;
        }
        let z = scalar::<T>(inp, self.scale, bound).0;
        if NE > 0 && op & 0x80 == 0 {
            x[0] = T::one();
        }
        if op & 0x40 != 0 && NT >= 2 {
            // Exactly collinear: x_j = c·x_i.
            let (i, j) = (NE + (op as usize >> 3) % (NT - NE), NT - 1);
            x[j] = x[i] * T::lit(f64::from(inp.u8() as i8) / 16.0);
        }
        self.step(x, z);
    }

    /// The last sample again, `n` times (fewer at [`MAX_STEPS`]).
    fn repeat_last(&mut self, n: usize) {
        for _ in 0..n.min(MAX_STEPS - self.steps) {
            let (x, z) = self.last;
            self.step(x, z);
        }
    }

    /// A block of samples of a linear model with seeded noise (optionally a column stuck at 0
    /// and, if `op` bit 7, an exactly collinear pair).
    fn linear_block(&mut self, op: u8, inp: &mut Input<'_>) {
        let seed = u64::from(inp.u32());
        let len = usize::from(inp.u8()) * 4 + 1;
        let theta: [f64; NT] = core::array::from_fn(|_| f64::from(inp.u8() as i8) / 16.0);
        let noise = 10f64.powi(-i32::from(inp.u8() % 10));
        let collinear = op & 0x80 != 0;
        let mut g = Gen::new(seed);
        for _ in 0..len.min(MAX_STEPS - self.steps) {
            let mut x = SVector::<T, NT>::zeros();
            let mut z = 0.0;
            for i in 0..NT {
                let v = if i < NE {
                    1.0
                } else if self.stuck & (1 << i) != 0 {
                    0.0
                } else if collinear && i == NT - 1 && NT - NE >= 2 {
                    2.0 * x[NE].to_f64()
                } else {
                    g.normal() * self.scale
                };
                x[i] = T::lit(v);
                z += v * theta[i];
            }
            let z = T::lit(z + noise * self.scale * g.normal());
            self.step(x, z);
        }
    }
}

/// The refusal `check_sample` must give: the first non-finite or out-of-range element.
pub fn expected_refusal<T: Real, const NT: usize>(x: &SVector<T, NT>, z: T, bound: T) -> Option<Error> {
    for i in 0..=NT {
        let v = if i < NT { x[i] } else { z };
        let index = i as u8;
        if !v.finite() {
            return Some(Error::NonFinite { index });
        }
        if v.abs() > bound {
            return Some(Error::OutOfRange { index });
        }
    }
    None
}

fn step<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize>(
    est: &mut Gtls<T, NT, NE, NA>,
    x: &SVector<T, NT>,
    z: T,
    cx: &mut Context<T>,
) {
    let before = *est;
    let result = est.update(x, z);
    let expected = expected_refusal(x, z, cx.bound);
    match (result, expected) {
        (Err(e), Some(want)) => {
            assert_eq!(e, want, "wrong refusal for x = {x:?}, z = {z:?}");
            assert_unchanged(&before, est);
        }
        (Ok(_), Some(want)) => panic!("accepted a sample that must be refused ({want:?}): x = {x:?}, z = {z:?}"),
        (Err(Error::NumericalFault), None) => assert_unchanged(&before, est),
        (Err(e), None) => panic!("in-range sample refused as {e:?} (only NumericalFault may): x = {x:?}, z = {z:?}"),
        (Ok(step), None) => {
            cx.updates += 1;
            assert_eq!(step.lambda.to_f64().to_bits(), before.lambda().to_f64().to_bits());
            check_accepted(est, cx);
        }
    }
}

/// Panics unless `after` is bit-identical to `before` (whole state).
pub fn assert_unchanged<E: Debug>(before: &E, after: &E) {
    let (b, a) = (snapshot(before), snapshot(after));
    assert!(b == a, "refused sample changed the state:\nbefore {b}\nafter  {a}");
}

fn check_accepted<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize>(
    est: &Gtls<T, NT, NE, NA>,
    cx: &Context<T>,
) {
    assert_state_finite("gtls after an accepted sample", est);
    check_estimator(est, cx.lambda, cx.updates);
}

/// The invariants of an estimator after an accepted update (module doc); shared with the
/// `pipeline` target. `updates` is the number of samples it accepted so far.
pub fn check_estimator<T: Real + Debug, const NT: usize, const NE: usize, const NA: usize>(
    est: &Gtls<T, NT, NE, NA>,
    lambda: LambdaRange<T>,
    updates: u64,
) {
    let s = est.singular_values();
    assert!(s.iter().all(|v| *v >= T::zero()), "negative singular value {s:?}");
    assert!(
        s.as_slice().windows(2).all(|w| w[0] >= w[1]),
        "singular values not sorted {s:?}"
    );
    let orth = est.orthonormality_error().to_f64();
    let tol = orthonormality_tolerance::<T>(NA);
    assert!(orth <= tol, "‖VᵀV − I‖_F = {orth:e} > {tol:e}");
    let nx = NA - 1;
    let k = est.excited();
    let counted = est.threshold().map_or(0, |thr| (0..nx).filter(|&j| s[j] > thr).count());
    assert_eq!(
        k,
        counted,
        "k = {k} but {counted} singular values exceed the threshold {:?}",
        est.threshold()
    );
    match est.solution() {
        Solution::Tls | Solution::Nongeneric => assert_eq!(k, nx, "{:?} with k = {k}", est.solution()),
        Solution::MinimumNorm => assert!(k < nx, "minimum-norm solution with k = {k} = n_θ − n_e"),
        Solution::NotEnoughData => {
            assert_eq!(k, 0);
            assert!(est.threshold().is_none());
        }
        Solution::LeastSquares => panic!("GTLS reported a least-squares solution"),
    }
    if k == 0 {
        let th = est.theta();
        assert!(
            (NE..NT).all(|i| th[i] == T::zero()),
            "k = 0 but the noisy parameters are not the minimum-norm 0: {th:?}"
        );
    }
    let l = est.lambda();
    match lambda {
        LambdaRange::Constant(c) => assert!(l == c, "λ = {l:?} ≠ {c:?}"),
        LambdaRange::Between(lo, hi) => assert!(l >= lo && l <= hi, "λ = {l:?} outside [{lo:?}, {hi:?}]"),
    }
    let n = est.effective_samples();
    assert!(n >= T::one(), "N_eff = {n:?} < 1");
    // N_eff = Σ Π λ ≤ the count, up to one rounding per sample.
    let count = updates as f64;
    assert!(
        n.to_f64() <= count * (1.0 + 4.0 * count * T::EPS.to_f64()),
        "N_eff = {n:?} > {count} samples"
    );
}

/// `λ` range of a forgetting scheme.
pub fn lambda_range<T: Real>(f: &Forgetting<T>) -> LambdaRange<T> {
    match f {
        Forgetting::Constant(l) => LambdaRange::Constant(*l),
        Forgetting::Variable(v) => LambdaRange::Between(v.lambda_min, v.lambda_max),
    }
}
