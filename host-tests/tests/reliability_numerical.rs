#![allow(clippy::needless_range_loop)]
//! Numerical faults, in `f32` and `f64`: hours without excitation (with the on-board
//! VFF, and with a constant forgetting that makes the excitation fade so that `k` falls to 0),
//! exactly collinear regressors, a regressor stuck at zero, `λ_F` driven to its floor after each
//! of 59 parameter switches (asserted).
//!
//! Subject: `Gtls<T, 4, 1, 4>` (intercept + 3 noisy regressors, the size of `C_L` and `C_m`) with
//! the on-board forgetting (`VffSettings::for_aero_coefficients(100)`: λ ∈ [0.8, 1]). Every sample
//! is checked:
//! * nothing refused, every observable finite, `S` sorted and non-negative,
//!   `‖VᵀV − I‖_F ≤ 224ε` (the bound derived in `fuzz/src/lib.rs` for a TLS block of 4);
//! * **`k` honest**: `k` is the number of the three leading singular values above `threshold()`;
//!   with `k < 3` the covariance is refused (`InsufficientExcitation`: no σ is claimed);
//! * **minimum-norm**: with `k < 3`, the noisy parameters equal the minimum weighted-norm solution of
//!   eq. 22–23 computed here independently in `f64` from `V` and `W_T` (nalgebra's SVD
//!   pseudo-inverse; every 997 samples), within [`Tol::min_norm`].

use aerosid_core::{Error, Estimator, Forgetting, Gtls, GtlsSettings, Real, Solution, VffSettings};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

type Est<T> = Gtls<T, 4, 1, 4>;

/// Regressor noise (σ of α-like, q-like, δ-like regressors) and output noise.
const SIGMA: [f64; 4] = [0.005, 0.001, 0.002, 0.01];
/// The truth `[θ_0, θ_1, θ_2, θ_3]`.
const THETA: [f64; 4] = [0.4, 6.5, -0.4, 0.3];
/// Typical magnitudes (eq. 23 weights).
const WEIGHTS: [f64; 4] = [1.0, 5.0, 5.0, 0.2];

trait Tol: Real + std::fmt::Debug {
    /// Relative agreement of `θ_n` with the independent minimum-norm solution: the constraint
    /// matrix `V₁ᵀC` has condition ≈ σ_noise ratio ≲ 10 here, so a few hundred ε of the scalar,
    /// 1e-3 in `f32` (1.2e-7·~10³ margin), 1e-9 in `f64`.
    fn min_norm() -> f64;
}
impl Tol for f32 {
    fn min_norm() -> f64 {
        1e-3
    }
}
impl Tol for f64 {
    fn min_norm() -> f64 {
        1e-9
    }
}

fn new_est<T: Real>() -> Est<T> {
    let w_t = SMatrix::<T, 4, 4>::from_fn(|i, j| if i == j { T::lit(SIGMA[i] * SIGMA[i]) } else { T::zero() });
    let weights = SVector::<T, 4>::from_fn(|i, _| T::lit(WEIGHTS[i]));
    let settings = GtlsSettings {
        forgetting: Forgetting::Variable(VffSettings::for_aero_coefficients(T::lit(100.0))),
        ..GtlsSettings::default()
    };
    Est::<T>::new(&w_t, &weights, settings).expect("estimator")
}

/// A sample: true regressors `xt` (noisy ones), noise added, `z = [1, xt]·θ + e`.
fn sample<T: Real>(xt: [f64; 3], theta: &[f64; 4], rng: &mut ChaCha8Rng) -> (SVector<T, 4>, T) {
    let mut n = || -> f64 { StandardNormal.sample(rng) };
    let z = theta[0] + xt[0] * theta[1] + xt[1] * theta[2] + xt[2] * theta[3] + SIGMA[3] * n();
    let x = SVector::<T, 4>::from_column_slice(&[
        T::one(),
        T::lit(xt[0] + SIGMA[0] * n()),
        T::lit(xt[1] + SIGMA[1] * n()),
        T::lit(xt[2] + SIGMA[2] * n()),
    ]);
    (x, T::lit(z))
}

/// Well-excited true regressors at sample `k` (multisines of different frequencies).
fn excited(k: usize) -> [f64; 3] {
    let t = k as f64 * 0.01;
    [
        0.05 + 0.05 * (1.3 * t).sin() + 0.02 * (4.1 * t).cos(),
        0.02 * (2.9 * t).sin() + 0.01 * (0.7 * t).cos(),
        -0.05 + 0.08 * (0.9 * t).sin() + 0.03 * (3.3 * t).sin(),
    ]
}

/// The eq. 22–23 solution for `k` constraints, computed independently in f64: minimise `‖W θ_n‖`
/// subject to `(V₁ᵀ C)[θ_n; −1] = 0`, `W_T = CᵀC` (diagonal here: `C = diag σ`).
fn min_norm_reference<T: Real>(e: &Est<T>, k: usize) -> [f64; 3] {
    if k == 0 {
        return [0.0; 3]; // no constraint: the minimum norm is 0
    }
    let v = e.right_singular_vectors().map(|x| x.to_f64());
    let c = SMatrix::<f64, 4, 4>::from_fn(|i, j| if i == j { SIGMA[i] } else { 0.0 });
    let vc = v.transpose() * c; // rows: v_rᵀ C
    let m = DMatrix::<f64>::from_fn(k, 3, |r, j| vc[(r, j)] / WEIGHTS[j + 1]);
    let b = DVector::<f64>::from_fn(k, |r, _| vc[(r, 3)]);
    let y = m.pseudo_inverse(1e-300).expect("pseudo-inverse") * b;
    [y[0] / WEIGHTS[1], y[1] / WEIGHTS[2], y[2] / WEIGHTS[3]]
}

/// Feeds one sample and checks every invariant of the module doc; returns `k`.
fn check<T: Tol>(e: &mut Est<T>, x: &SVector<T, 4>, z: T, n: usize) -> usize {
    let step = e.update(x, z);
    assert!(step.is_ok(), "sample {n}: refused {step:?}");
    let s = e.singular_values();
    assert!(
        e.theta().iter().all(|v| v.finite()) && s.iter().all(|v| v.finite()),
        "sample {n}: non-finite"
    );
    assert!(
        s.iter().all(|v| *v >= T::zero()) && s[0] >= s[1] && s[1] >= s[2] && s[2] >= s[3],
        "{s:?}"
    );
    let orth = e.orthonormality_error().to_f64();
    assert!(orth <= 224.0 * T::EPS.to_f64(), "sample {n}: ‖VᵀV − I‖ = {orth:e}");
    let l = e.lambda().to_f64();
    assert!((0.8 - 1e-6..=1.0).contains(&l), "λ = {l}");
    let k = e.excited();
    let counted = e.threshold().map_or(0, |thr| (0..3).filter(|&j| s[j] > thr).count());
    assert_eq!(k, counted, "sample {n}: k = {k} not the count of σ above the threshold");
    if k < 3 {
        assert_eq!(
            e.covariance().err(),
            Some(Error::InsufficientExcitation),
            "sample {n}: σ claimed with k = {k}"
        );
        if n.is_multiple_of(997) {
            let r = min_norm_reference(e, k);
            let th = e.theta();
            let scale = r.iter().fold(1e-3, |a: f64, v| a.max(v.abs()));
            for j in 0..3 {
                let d = (th[j + 1].to_f64() - r[j]).abs();
                assert!(
                    d <= T::min_norm() * scale,
                    "sample {n}, k = {k}: θ_{} = {:?}, minimum norm {}",
                    j + 1,
                    th[j + 1],
                    r[j]
                );
            }
        }
    } else {
        assert!(matches!(e.solution(), Solution::Tls | Solution::Nongeneric));
    }
    k
}

fn rel_err<T: Real>(e: &Est<T>, truth: &[f64; 4], j: usize) -> f64 {
    (e.theta()[j].to_f64() - truth[j]).abs() / WEIGHTS[j]
}

fn loss_of_excitation_for_hours<T: Tol>() {
    let mut rng = ChaCha8Rng::seed_from_u64(71);
    let mut e = new_est::<T>();
    let mut n = 0;
    // GIVEN 2 min of excitation
    for k in 0..12_000 {
        let (x, z) = sample::<T>(excited(k), &THETA, &mut rng);
        check(&mut e, &x, z, n);
        n += 1;
    }
    assert_eq!(e.excited(), 3, "excited after 2 min");
    let before: Vec<f64> = e.theta().iter().map(|v| v.to_f64()).collect();
    // WHEN 2 h of steady cruise follow (regressors constant up to their noise)
    let mut k_min = 3;
    for _ in 0..720_000 {
        let (x, z) = sample::<T>([0.05, 0.0, -0.05], &THETA, &mut rng);
        k_min = k_min.min(check(&mut e, &x, z, n));
        n += 1;
    }
    // THEN nothing blew up, `k` fell as the threshold outgrew the unexcited directions (honestly
    // reported above at every sample), and the estimate did not run away: each noisy parameter is
    // within 30 % of its typical magnitude of where it was (the minimum-norm solution pulls the
    // unexcited directions towards 0, never beyond).
    println!(
        "{}: smallest k in 2 h of cruise {k_min}; θ {:?} → {:?}",
        std::any::type_name::<T>(),
        before,
        e.theta()
    );
    // k stayed 3 here (printed above; not asserted): 2 min of these manoeuvres keep every direction
    // above the eq. 21 threshold for 2 h at λ_F = 1, the VFF seeing no change. The test below
    // makes the excitation fade (constant forgetting) so that `k` does fall.
    for j in 1..4 {
        let d = (e.theta()[j].to_f64() - before[j]).abs() / WEIGHTS[j];
        assert!(
            d <= 0.3 + (before[j].abs() / WEIGHTS[j]),
            "θ_{j} ran away: {} → {:?}",
            before[j],
            e.theta()[j]
        );
    }
    // AND 3 min of excitation bring back every direction and the truth (within 3 % of the typical
    // magnitude: the errors-in-variables noise here gives ~1 % after 2 min).
    for k in 0..18_000 {
        let (x, z) = sample::<T>(excited(k), &THETA, &mut rng);
        check(&mut e, &x, z, n);
        n += 1;
    }
    assert_eq!(e.excited(), 3);
    for j in 0..4 {
        assert!(
            rel_err(&e, &THETA, j) <= 0.03,
            "θ_{j} = {:?} after re-excitation, truth {}",
            e.theta()[j],
            THETA[j]
        );
    }
}

fn loss_of_excitation_with_forgetting_lowers_k_honestly<T: Tol>() {
    // The same flight with a constant λ = 0.999 (a memory of 10 s): the 2 min of excitation fade
    // during the cruise, so the unexcited directions fall below the eq. 21 threshold.
    let mut rng = ChaCha8Rng::seed_from_u64(74);
    let w_t = SMatrix::<T, 4, 4>::from_fn(|i, j| if i == j { T::lit(SIGMA[i] * SIGMA[i]) } else { T::zero() });
    let weights = SVector::<T, 4>::from_fn(|i, _| T::lit(WEIGHTS[i]));
    let settings = GtlsSettings {
        forgetting: Forgetting::Constant(T::lit(0.999)),
        ..GtlsSettings::default()
    };
    let mut e = Est::<T>::new(&w_t, &weights, settings).expect("estimator");
    let mut n = 0;
    for k in 0..12_000 {
        let (x, z) = sample::<T>(excited(k), &THETA, &mut rng);
        check(&mut e, &x, z, n);
        n += 1;
    }
    assert_eq!(e.excited(), 3, "excited after 2 min");
    // WHEN 1 h of steady cruise follows
    let mut k_min = 3;
    let mut minimum_norm_samples = 0;
    for _ in 0..360_000 {
        let (x, z) = sample::<T>([0.05, 0.0, -0.05], &THETA, &mut rng);
        let k = check(&mut e, &x, z, n);
        k_min = k_min.min(k);
        if k < 3 {
            minimum_norm_samples += 1;
        }
        n += 1;
    }
    println!(
        "{}: with λ = 0.999, k fell to {k_min}; minimum-norm solution at {minimum_norm_samples} of 360000 samples; θ {:?}",
        std::any::type_name::<T>(),
        e.theta()
    );
    // THEN k fell (at every such sample `check` verified: no σ claimed, k the count of singular
    // values above the threshold, θ the independent minimum-norm solution every 997 samples) …
    assert!(k_min < 3, "k never fell although the excitation faded");
    assert!(
        e.excited() < 3 && e.solution() == Solution::MinimumNorm,
        "{:?}",
        e.solution()
    );
    // … and 3 min of excitation bring every direction and the truth back. With a memory of
    // 1000 samples (not 3000 as in the switching test) the spread is √3 times larger: θ₀…θ₂ within
    // 0.05 of their typical magnitudes, θ₃ within 0.3 (≈ 4σ of 0.08; measured 0.05).
    for k in 0..18_000 {
        let (x, z) = sample::<T>(excited(k), &THETA, &mut rng);
        check(&mut e, &x, z, n);
        n += 1;
    }
    assert_eq!(e.excited(), 3);
    for (j, tol) in [0.05, 0.05, 0.05, 0.3].into_iter().enumerate() {
        assert!(rel_err(&e, &THETA, j) <= tol, "θ_{j} = {:?}", e.theta()[j]);
    }
}

fn exactly_collinear_and_stuck_regressors<T: Tol>() {
    for case in ["collinear", "stuck at zero"] {
        let mut rng = ChaCha8Rng::seed_from_u64(72);
        let mut e = new_est::<T>();
        let mut k_max = 0;
        for k in 0..60_000 {
            let mut xt = excited(k);
            // x₃ = 2·x₂ exactly (noise included), or x₃ ≡ 0 (no noise either: a dead channel, so
            // its true value is zeroed before the output is formed from it)
            if case == "stuck at zero" {
                xt[2] = 0.0;
            }
            let (mut x, z) = sample::<T>(xt, &THETA, &mut rng);
            match case {
                "collinear" => x[3] = x[2] * T::lit(2.0),
                _ => x[3] = T::zero(),
            }
            k_max = k_max.max(check(&mut e, &x, z, k));
        }
        // THEN at most two directions are excited, at every sample …
        assert!(
            k_max <= 2,
            "{case}: k reached {k_max} with a rank-deficient regressor set"
        );
        assert_eq!(e.solution(), Solution::MinimumNorm, "{case}");
        let th = e.theta();
        println!("{case} ({}): θ = {th:?}", std::any::type_name::<T>());
        if case == "stuck at zero" {
            // … the dead regressor's parameter is the minimum-norm 0 (relative to its weight) …
            assert!(th[3].to_f64().abs() / WEIGHTS[3] <= 1e-2, "{case}: θ_3 = {:?}", th[3]);
        }
        // … and the minimum-norm solution was checked against the independent one above.
    }
}

fn lambda_at_its_floor_again_and_again<T: Tol>() {
    let mut rng = ChaCha8Rng::seed_from_u64(73);
    let mut e = new_est::<T>();
    // The second set differs in every parameter and in the intercept by 0.6: a jump in `z` about
    // 20 times the errors-in-variables noise of the output (≈ 0.035, dominated by θ₁·σ₀), so that
    // the VFF's short-window error power exceeds γ₀ = 2 times its long-window noise power and
    // `λ_F` drops to its floor. (With a jump of the size of that noise, `λ_F` stays at 1: the
    // VFF then sees no change, correctly.)
    let other = [1.0, 5.0, -1.4, 0.1];
    let mut floors = 0;
    let mut n = 0;
    // GIVEN the parameters switching between two sets every 30 s, 60 times (30 min)
    for switch in 0..60 {
        let truth = if switch % 2 == 0 { THETA } else { other };
        let mut hit = false;
        for _ in 0..3000 {
            let (x, z) = sample::<T>(excited(n), &truth, &mut rng);
            check(&mut e, &x, z, n);
            if e.lambda().to_f64() <= 0.8 + 1e-6 {
                hit = true;
            }
            n += 1;
        }
        if hit && switch > 0 {
            floors += 1;
        }
        // THEN after each 30 s every direction is excited and the estimate has followed the switch.
        // Tolerances in typical magnitudes, from the spread of 30 s estimates (measured over the 60
        // segments, f64): θ₀…θ₂ at most 0.008 → 0.05; θ₃ (the weakest direction, regressor
        // amplitude 0.08 against noise 0.035 in z) median 0.031, i.e. σ ≈ 0.046, max 0.12 → 0.25,
        // about 5σ. An estimate that did not follow is off by the whole jump: 0.6 for θ₀ and 1.0
        // for θ₃.
        assert_eq!(e.excited(), 3, "switch {switch}");
        for (j, tol) in [0.05, 0.05, 0.05, 0.25].into_iter().enumerate() {
            assert!(
                rel_err(&e, &truth, j) <= tol,
                "switch {switch}: θ_{j} = {:?}, truth {}",
                e.theta()[j],
                truth[j]
            );
        }
        let n_eff = e.effective_samples().to_f64();
        assert!(n_eff.is_finite() && n_eff >= 1.0, "N_eff = {n_eff}");
    }
    // AND λ_F was at its floor after every one of the 59 switches — the situation this test is
    // about — with every invariant of `check` holding at every sample.
    println!(
        "{}: λ_F at its floor after {floors} of 59 switches",
        std::any::type_name::<T>()
    );
    assert_eq!(floors, 59, "λ_F did not reach its floor after every switch");
}

/// GIVEN the all-zero placeholder (`W_T = 0`, `V = 0`, `max_abs_input = 0`: the storage the
/// unconfigured pipeline holds), WHEN samples reach it anyway (the zero row, the only one within
/// its input limit, an ordinary row, a NaN), THEN each is refused and the placeholder is unchanged:
/// it cannot turn into a half-estimator.
fn placeholder_refuses_every_sample<T: Tol>() {
    let mut e = Est::<T>::PLACEHOLDER;
    let rows = [
        (SVector::<T, 4>::zeros(), T::zero()),
        (SVector::<T, 4>::from_element(T::lit(0.1)), T::lit(0.5)),
        (SVector::<T, 4>::from_element(T::lit(f64::NAN)), T::zero()),
    ];
    for (x, z) in rows {
        let r = e.update(&x, z);
        assert!(r.is_err(), "{x:?}, {z:?}: {r:?}");
        assert_eq!(e, Est::<T>::PLACEHOLDER, "{x:?}, {z:?}: the placeholder changed");
    }
}

macro_rules! both {
    ($($name:ident),*) => {
        mod f32_tests { $(#[test] fn $name() { super::$name::<f32>() })* }
        mod f64_tests { $(#[test] fn $name() { super::$name::<f64>() })* }
    };
}

both!(
    loss_of_excitation_for_hours,
    loss_of_excitation_with_forgetting_lowers_k_honestly,
    exactly_collinear_and_stuck_regressors,
    lambda_at_its_floor_again_and_again,
    placeholder_refuses_every_sample
);
