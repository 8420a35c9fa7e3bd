//! Noise-free data: a legitimate, degenerate input (a simulator with perfect sensors, a replay of
//! a smoothed log). Regression test for a defect: after a stretch of identical
//! rows (a trimmed aircraft before its first manoeuvre) the scaled data matrix has exactly-zero
//! singular values; the next exactly-consistent row put a secular root on its pole within
//! rounding, the eigenvector `ẑ_j/(δ_j − μ)` overflowed, and the rank-one update returned "not
//! finite" — so every later sample was refused (`NumericalFault`) and the estimator never moved
//! again (measured: 14 032 of 14 998 samples refused for `C_m` on a noise-free simulated flight).
//!
//! The flight test below reproduces it (it fails on the old code: 2797 of 2998 `C_L` samples
//! refused). The two estimator-level tests (200 identical rows, then 5000 rows with the output
//! exactly `θᵀx`, `f32` and `f64`, `λ = 1` and `0.99`) did not hit the defect — the root must land
//! on its pole to the last bit — and stay as coverage of exact data: no refusal, and `θ` equal to
//! the truth within `1e3·ε·max|θ|` (the only error is rounding through ~5000 updates).

use aerosid_core::{Estimator, Forgetting, Gtls, GtlsSettings, Real};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn run<T: Real>(lambda: f64, seed: u64) {
    let theta = [0.01, -1.3, -20.0, 1.0];
    let w_t = SMatrix::<T, 4, 4>::from_diagonal(&SVector::from([
        T::lit(0.0087 * 0.0087),
        T::lit(6e-5 * 6e-5),
        T::lit(0.0035 * 0.0035),
        T::lit(0.0136 * 0.0136),
    ]));
    let settings = GtlsSettings {
        forgetting: Forgetting::Constant(T::lit(lambda)),
        ..GtlsSettings::default()
    };
    let mut g = Gtls::<T, 4, 1, 4>::new(&w_t, &SVector::repeat(T::one()), settings).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let row = |a: f64, q: f64, de: f64| {
        let x = [1.0, a, q, de];
        let z: f64 = x.iter().zip(theta.iter()).map(|(x, t)| x * t).sum();
        (SVector::<T, 4>::from_fn(|i, _| T::lit(x[i])), T::lit(z))
    };
    for i in 0..200 {
        let (x, z) = row(0.05, 0.0, -0.02);
        assert!(g.update(&x, z).is_ok(), "constant row {i} refused");
    }
    for i in 0..5000 {
        let (x, z) = row(
            0.05 + rng.random_range(-0.05..0.05),
            rng.random_range(-0.005..0.005),
            -0.02 + rng.random_range(-0.1..0.1),
        );
        let r = g.update(&x, z);
        assert!(r.is_ok(), "row {i} refused: {r:?}");
    }
    let tol = 1e3 * T::EPS.to_f64() * 20.0;
    for (e, t) in g.theta().iter().zip(theta.iter()) {
        assert!((e.to_f64() - t).abs() <= tol, "θ {:?} vs {theta:?}", g.theta());
    }
}

#[test]
fn exact_data_after_a_constant_stretch_is_never_refused_f64() {
    run::<f64>(1.0, 1);
    run::<f64>(0.99, 2);
}

#[test]
fn exact_data_after_a_constant_stretch_is_never_refused_f32() {
    run::<f32>(1.0, 3);
    run::<f32>(0.99, 4);
}

/// GIVEN a noise-free simulated flight (perfect sensors, trimmed for 2 s, then elevator 3-2-1-1s),
/// WHEN it runs through the on-board `f32` pipeline with the variable forgetting factor (the
/// configuration that exposed the defect), THEN no estimator refuses a sample.
#[test]
fn noise_free_flight_is_never_refused_by_the_estimators() {
    use aerosid::experiment::{self, ExperimentConfig};
    use aerosid_core::VffSettings;
    use aerosid_sim::*;
    let mut schedule = Schedule::default();
    let mut t = 2.0;
    while t + 5.0 <= 30.0 {
        schedule = schedule.with(Manoeuvre {
            channel: Channel::Elevator,
            shape: Shape::Multistep3211,
            start_s: t,
            amplitude: 0.12,
            period_s: 0.4,
        });
        t += 5.0;
    }
    let sim = SimConfig {
        sensors: SensorNoise::none(),
        schedule,
        duration_s: 30.0,
        ..SimConfig::default()
    };
    let mut cfg = ExperimentConfig::new(sim, [0.015, 0.011, 0.0023, 0.0013, 0.0136, 0.0025]);
    cfg.pipeline.gtls.forgetting = Forgetting::Variable(VffSettings::for_dimension(4));
    let ex = experiment::run(&cfg).unwrap();
    for (i, c) in ex.health.coefficients.iter().enumerate() {
        assert_eq!(c.refused_estimator, 0, "coefficient {i}: {c:?}");
    }
}
