//! Memory of the on-board estimators (`core::mem::size_of`), as reported in the README.
//!
//! The firmware budget (issue: estimator state ≤ 4 KB for six estimators) gives ~680 bytes each;
//! these tests fail if a change makes the `f32` state grow past the figures below.

use aerosid_core::{Gtls, Rls};
use core::mem::size_of;

#[test]
fn estimator_state_sizes() {
    let gtls6_exact = size_of::<Gtls<f32, 6, 1, 6>>();
    let gtls6_noisy = size_of::<Gtls<f32, 6, 0, 7>>();
    let gtls4 = size_of::<Gtls<f32, 4, 1, 4>>();
    let rls6 = size_of::<Rls<f32, 6>>();
    println!("Gtls<f32, 6, 1, 6> (n_θ = 6, intercept exact): {gtls6_exact} B");
    println!("Gtls<f32, 6, 0, 7> (n_θ = 6, all regressors noisy): {gtls6_noisy} B");
    println!("Gtls<f32, 4, 1, 4>: {gtls4} B; Rls<f32, 6>: {rls6} B");
    println!("Gtls<f64, 6, 1, 6>: {} B", size_of::<Gtls<f64, 6, 1, 6>>());
    assert!(gtls6_exact <= 700, "{gtls6_exact}");
    assert!(gtls6_noisy <= 780, "{gtls6_noisy}");
}
