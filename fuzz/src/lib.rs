//! The fuzz targets of aerosid, as library functions: each `fuzz_targets/<name>.rs` is
//! `fuzz_target!(|data| aerosid_fuzz::<name>::run(data))`, and `run` panics (a libFuzzer crash)
//! when an invariant fails.
//!
//! | target | subject | invariants (besides "no panic") |
//! |---|---|---|
//! | [`gtls`] | a bare [`aerosid_core::Gtls`] (`f32`/`f64`, with/without intercept, three forgetting schemes, three input bounds) | exact refusal of bad input; whole state bit-identical after any refusal; after an accepted sample every float of the whole state finite, `S` sorted and non-negative, `V` orthonormal within [`orthonormality_tolerance`], `k` equal to the count of `σ_j` above the eq. 21 threshold, `λ` in range, the minimum-norm `θ` at `k = 0` |
//! | [`pipeline`] | the six-coefficient [`aerosid_core::aero::Pipeline`] on [`aerosid_core::aero::SensorSample`]s (`f32` on-board config, and `f64`) | every refused coefficient's estimator bit-identical; every updated one as for `gtls`; the whole pipeline state finite; the health counters add up |
//! | [`drivers`] | ICM-42688-P, MS4525DO, AS5600 on fake buses that return fuzz bytes and fuzz bus errors | each outcome equals an independent decoding of the bytes (datasheet rules re-typed here); readings finite and in range; health counters equal the outcomes counted here |
//! | [`mavlink`] | the MAVLink parser and [`aerosid_core::mavlink::MavlinkSurfaces`] | every delivered frame is a CRC-valid frame present in the input; counters consistent; surfaces/throttle/RPM/attitude finite and within their calibration |
//! | [`read_log`], [`read_project_csv`], [`read_aircraft`], [`read_colmap_ascii`], [`read_ulog`], [`read_dataflash`], [`read_mat`] | every log reader of `aerosid-read` | an `Ok` result holds only finite values, increasing time, and passes its own `validate` |
//!
//! ## The whole-state snapshot
//! The estimators keep private state (`G₁₁`, `B`, the VFF's `P`, …) that no accessor shows. The
//! snapshot is the estimator's `Debug` text ([`snapshot`]): it prints every field, including ones
//! added later, and Rust prints each float as the shortest decimal that parses back to the same
//! value, distinguishing `-0.0` from `0.0`; two snapshots are equal iff every field is equal bit for
//! bit, except that all NaNs print as `NaN` — and a NaN anywhere in the state is itself a failure
//! ([`non_finite_token`]).

pub mod drivers;
pub mod gtls;
pub mod input;
pub mod mavlink;
pub mod pipeline;
#[cfg(feature = "readers")]
pub mod readers;
#[cfg(feature = "seeds")]
pub mod seeds;

#[cfg(feature = "readers")]
pub use readers::{read_aircraft, read_colmap_ascii, read_dataflash, read_log, read_mat, read_project_csv, read_ulog};

use aerosid_core::Real;
use std::fmt::Debug;

/// The whole state of `x` as text (module doc).
pub fn snapshot(x: &impl Debug) -> String {
    format!("{x:?}")
}

/// The first `NaN`, `inf` or `-inf` token of a snapshot, if any.
pub fn non_finite_token(snapshot: &str) -> Option<&str> {
    snapshot
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '_'))
        .find(|t| matches!(*t, "NaN" | "inf" | "-inf"))
}

/// Panics unless every float in `x`'s whole state is finite.
pub fn assert_state_finite(what: &str, x: &impl Debug) {
    let s = snapshot(x);
    if let Some(t) = non_finite_token(&s) {
        panic!("{what}: `{t}` in the state: {s}");
    }
}

/// Bound on `‖VᵀV − I‖_F` after any accepted update of a TLS block of dimension `na`, in units of
/// `ε` of the scalar.
///
/// Derivation (as in `host-tests/tests/properties.rs`, for any `na`): the guard checks one of the
/// `P = na(na+1)/2` distinct entries of `VᵀV − I` per update and re-orthonormalises when it exceeds
/// `4·na·ε`. An entry is at most `4·na·ε + P·δ` when it is looked at again, `δ ≈ na·ε` being the
/// drift one update adds, so every entry stays below `(4 + P)·na·ε` and the Frobenius norm below
/// `na` times that: 224ε for `na = 4` (256ε is the property tests' bound), 525ε for 5, 900ε for 6.
pub fn orthonormality_tolerance<T: Real>(na: usize) -> f64 {
    let p = (na * (na + 1) / 2) as f64;
    let n = na as f64;
    n * (4.0 + p) * n * T::EPS.to_f64()
}
