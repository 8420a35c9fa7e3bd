//! The TLS-corrected regressor `x̂₀` of eq. 24–25 (`Gtls::corrected_regressor`).
//!
//! GIVEN a sample `(x, z)`, parameters `θ` and a full (correlated) error covariance `W_T`,
//! THEN `x̂₀` (i) leaves the exact regressors unchanged, (ii) lies on the model: `x̂₀ᵀθ = ẑ`,
//! (iii) is the maximum-likelihood correction: the change of the noisy block is parallel to
//! `W_T a` (`a = [θ_n; −1]`), and (iv) no other point on the model is closer in the `W_T⁻¹` metric
//! (checked against 200 seeded random points of the constraint plane). Tolerances are relative to
//! `f64` rounding of these 4-element formulas (1e-12).

use aerosid_core::{Gtls, GtlsSettings};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn corrected_regressor_is_the_ml_projection_onto_the_model() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    // W_T of [x_n1, x_n2, z]: correlated, SPD.
    let l = SMatrix::<f64, 3, 3>::new(0.03, 0.0, 0.0, 0.01, 0.02, 0.0, -0.005, 0.004, 0.05);
    let w_t = l * l.transpose();
    let g = Gtls::<f64, 3, 1, 3>::new(&w_t, &SVector::repeat(1.0), GtlsSettings::default()).unwrap();
    let w_inv = w_t.try_inverse().unwrap();
    for _ in 0..100 {
        let theta = SVector::<f64, 3>::from_fn(|_, _| rng.random_range(-5.0..5.0));
        let x = SVector::<f64, 3>::from([1.0, rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)]);
        let z: f64 = rng.random_range(-3.0..3.0);
        let (x0, zhat) = g.corrected_regressor(&x, z, &theta);
        assert_eq!(x0[0], x[0], "exact regressor changed");
        let on_model = x0.dot(&theta) - zhat;
        assert!(on_model.abs() < 1e-12 * (1.0 + zhat.abs()), "x̂₀ᵀθ − ẑ = {on_model:e}");
        // The correction of the noisy block, δ = d − d̂, must be parallel to W_T a.
        let a = SVector::<f64, 3>::from([theta[1], theta[2], -1.0]);
        let delta = SVector::<f64, 3>::from([x[1] - x0[1], x[2] - x0[2], z - zhat]);
        let wa = w_t * a;
        let cross = delta - wa * (delta.dot(&wa) / wa.dot(&wa));
        assert!(
            cross.norm() < 1e-12 * (1.0 + delta.norm()),
            "correction not along W_T a"
        );
        // ML: no other point of the plane is closer in the W_T⁻¹ metric.
        let dist = |p: &SVector<f64, 3>| {
            let e = SVector::<f64, 3>::from([x[1], x[2], z]) - p;
            e.dot(&(w_inv * e))
        };
        let best = dist(&SVector::from([x0[1], x0[2], zhat]));
        for _ in 0..2 {
            let u1: f64 = rng.random_range(-2.0..2.0);
            let u2: f64 = rng.random_range(-2.0..2.0);
            // A point of the plane θ₀ + θ₁u₁ + θ₂u₂ = ẑ'.
            let p = SVector::<f64, 3>::from([u1, u2, theta[0] + theta[1] * u1 + theta[2] * u2]);
            assert!(dist(&p) >= best * (1.0 - 1e-12), "a closer point exists");
        }
    }
}
