//! Memory of the on-board estimators (`core::mem::size_of`), as reported in the README.
//!
//! The firmware budget (estimator state ≤ 4 KB for the six estimators, asserted in
//! `synthesis.rs`) gives ~680 bytes each on average; these tests fail if a change makes the `f32`
//! state grow past the figures below (measured + ~2.5 %). The dimension-6 estimator is 820 B:
//! 680 B of matrices and scalars, plus `V` double-buffered (144 B: the update writes the new `V`
//! into the spare buffer instead of copying 144 B per sample), `C·a` of its `θ` (24 B), the VFF's
//! two sums of weights of its bias-corrected means (8 B), the clip of the noise power's input
//! (4 B) and the early test's smallest short-window power (4 B).

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
    assert!(gtls6_exact <= 820, "{gtls6_exact}");
    assert!(gtls6_noisy <= 960, "{gtls6_noisy}");
}
