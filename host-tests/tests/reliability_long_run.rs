//! The CI slice of the long run: 10 minutes of simulated flight — 60 000 samples —
//! with the long run's time line compressed (`aerosid::longrun`: excitation/cruise cycles of
//! 100 s, calm cruise 60–120 s, the `C_m` jump at 200 s and the `C_l` jump at 400 s), through the
//! on-board `f32` pipeline. The 10-hour run is `aerosid long-run --hours 10` (BENCHMARKS.md); this
//! test asserts the same invariants on the slice:
//! * every estimator's `‖VᵀV − I‖_F` below 1e-5 at every sample (the reliability bound);
//! * nothing ever non-finite, no sample refused by an estimator, `λ_F` within `[0.8, 1]`;
//! * both jumps tracked: every changed parameter within a quarter of its jump of the new truth
//!   within [`SETTLE_S`] and for good until the end of that excitation phase;
//! * no drift in the calm cruise: no parameter of a fully excited coefficient moves by more than
//!   [`CALM_DRIFT`] of its typical magnitude.

use aerosid::longrun::{format_report, run, Invariants, LongRunConfig};

/// Largest settling time after a jump, s. The slice's excitation phase after each jump is 50 s
/// (its first manoeuvre 4 s after the jump); the VFF detects a jump within ~2 s and re-converges
/// within ~10 s on the Fig. 2 flight (`vff.rs` doc). Measured on this slice: at most 4.4 s
/// (C_mq). 30 s still fails an estimator that does not follow.
const SETTLE_S: f64 = 30.0;
/// Largest parameter change during the calm cruise, in typical magnitudes (the eq. 23 weights).
/// On the slice the calm minute follows only 30 s of manoeuvres, so the lateral estimates are still
/// converging on the turbulence's excitation: measured 0.40 (`C_Yr`, 0.04 absolute). The 10-hour
/// run, whose calm hour follows an hour of cycles, is the drift figure (BENCHMARKS.md). 0.8 still
/// fails a run-away estimate.
const CALM_DRIFT: f64 = 0.8;

#[test]
fn ten_minute_slice_keeps_every_invariant_and_tracks_both_jumps() {
    let cfg = LongRunConfig {
        duration_s: 600.0,
        seed: 1,
    };
    let r = run(&cfg, |_| {}).expect("long run");
    println!("{}", format_report(&r, 0.0));
    assert_eq!(r.samples, 60_000);
    assert_eq!(r.health.samples, 60_000);
    for (i, e) in r.coefficients.iter().enumerate() {
        assert!(
            e.worst_orthonormality < 1e-5,
            "coefficient {i}: ‖VᵀV − I‖ = {:e}",
            e.worst_orthonormality
        );
        assert_eq!(e.non_finite, 0, "coefficient {i}");
        assert_eq!(e.refused_estimator, 0, "coefficient {i}");
        assert!(
            e.lambda.0 >= 0.8 - 1e-6 && e.lambda.1 <= 1.0,
            "coefficient {i}: λ {:?}",
            e.lambda
        );
        assert!(e.updates > 55_000, "coefficient {i}: only {} updates", e.updates);
    }
    assert_eq!(r.tracking.len(), 5, "three C_m and two C_l parameters change");
    for t in &r.tracking {
        let settle = t.settle_s.unwrap_or(f64::INFINITY);
        assert!(
            settle <= SETTLE_S,
            "jump {}: {:?} never settled ({t:?})",
            t.jump + 1,
            t.regressor
        );
        let band = 0.25 * (t.truth.1 - t.truth.0).abs();
        assert!((t.after - t.truth.1).abs() <= band, "{t:?}");
    }
    let (drift, i, p) = r.calm_drift;
    assert!(
        drift <= CALM_DRIFT,
        "calm cruise: coefficient {i} parameter {p} moved {drift} typical magnitudes"
    );
    // … and the report's own check (what `aerosid long-run` exits on) agrees
    let inv = Invariants::REQUIRED;
    assert_eq!((inv.settle_s, inv.calm_drift), (SETTLE_S, CALM_DRIFT));
    assert_eq!(r.violations(&inv), Vec::<String>::new());
}

/// The 10-hour run of BENCHMARKS.md (`aerosid long-run --hours 10` prints the same table): not a CI
/// test (about a minute here); run with `cargo test -p aerosid-host-tests --test
/// integration reliability_long_run::ten_hours -- --ignored --nocapture`.
#[test]
#[ignore = "10 hours of simulated flight: a benchmark, run by hand"]
fn ten_hours() {
    let start = std::time::Instant::now();
    let r = run(&LongRunConfig::hours(10.0, 1), |_| {}).expect("long run");
    println!("{}", format_report(&r, start.elapsed().as_secs_f64()));
    assert_eq!(r.samples, 3_600_000);
    assert_eq!(r.tracking.len(), 5, "three C_m and two C_l parameters change");
    assert_eq!(r.violations(&Invariants::REQUIRED), Vec::<String>::new());
}
