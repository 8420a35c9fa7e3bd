//! The low-rate path of `aerosid gaps` (below 20 Hz: `C_L`, `C_D`, `C_m` by output error): the
//! HFB-320 (10 Hz) gets a verdict, a lift-curve curvature planted in a simulated flight averaged
//! down to 10 Hz is named in `C_L`, and the same flight without it names nothing.

use aerosid::gaps::hidden::{self, HiddenEffect, HiddenKind};
use aerosid::gaps::model::CauseKind;
use aerosid::gaps::{run_gaps, GapReport, GapSettings};
use std::path::Path;

/// A simulated flight of 60 s in the campaign's light turbulence, logged at 100 Hz and averaged
/// in blocks of 10 samples: a 10 Hz log.
fn ten_hz(effect: Option<&HiddenEffect>, seed: u64) -> GapReport {
    let f = hidden::flight(effect, 60.0, seed, true).expect("the simulator flies");
    let n = f.len();
    let rate = (n - 1) as f64 / (f.t_s[n - 1] - f.t_s[0]);
    let k = (rate / 10.0).round() as usize;
    let slow = f.block_means(k);
    let s = GapSettings {
        baseline: Some(HiddenEffect::baseline(effect)),
        ..GapSettings::default()
    };
    run_gaps(&slow, &s).expect("the analysis runs")
}

fn summary(r: &GapReport) -> String {
    let mut s = format!("verdict: {}\n", r.verdict);
    for c in &r.coefficients {
        s.push_str(&format!("{}: {}\n", c.name, c.verdict));
        for k in c.candidates.iter().take(3) {
            s.push_str(&format!(
                "   {} t² {:.1} T {:.2} {:+.4} ± {:.4}\n",
                k.term, k.t2, k.cv_noise_z, k.value, k.sigma
            ));
        }
    }
    for c in &r.named {
        s.push_str(&format!(
            "named {:?} {} {} = {:+.4}\n",
            c.kind, c.location, c.what, c.value
        ));
    }
    s
}

fn low_rate_method(r: &GapReport) -> bool {
    r.notes
        .iter()
        .any(|n| n.starts_with("method:") && n.contains("output error"))
}

#[test]
fn the_ten_hertz_hfb320_gets_a_verdict_by_output_error() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let f = aerosid::io::read_measured(
        &data.join("flight").join("hfb320_1_10.asc"),
        &data.join("maps").join("hfb320.map"),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let r = run_gaps(&f, &GapSettings::default()).expect("the analysis runs");
    let s = summary(&r);
    println!("{s}");
    assert!(r.data_quality.supports_verdict, "{:?}\n{s}", r.data_quality.why_not);
    assert!(!r.verdict.starts_with("no verdict"), "{s}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    // Each covered coefficient: a verdict of the low-rate path and a held-out figure.
    for name in ["C_L", "C_D", "C_m"] {
        let c = r.coefficients.iter().find(|c| c.name == name).expect(name);
        assert!(c.verdict.contains("(output error)"), "{name}: {}", c.verdict);
        assert!(
            c.cv_r2_baseline.is_finite() && c.cv_r2_baseline <= 1.0,
            "{name}: {}",
            c.cv_r2_baseline
        );
        assert!(c.baseline.estimator.starts_with("output error"), "{name}");
    }
}

#[test]
fn a_lift_curvature_planted_at_ten_hertz_is_named_in_c_l() {
    // −10 /rad²: the top of the campaign's range (the equation-error path's least detectable size
    // at 100 Hz is a few /rad² on these flights).
    let effect = HiddenEffect {
        kind: HiddenKind::LiftQuadratic,
        size: -10.0,
        channel: None,
    };
    let r = ten_hz(Some(&effect), 41_004);
    let s = summary(&r);
    println!("{s}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    assert!(
        r.named
            .iter()
            .any(|c| c.kind == CauseKind::NonlinearAlpha && c.location == "C_L"),
        "{s}"
    );
}

#[test]
fn a_clean_flight_at_ten_hertz_names_nothing() {
    let r = ten_hz(None, 41_004);
    let s = summary(&r);
    println!("{s}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    assert!(r.data_quality.supports_verdict, "{:?}\n{s}", r.data_quality.why_not);
    assert!(r.named.is_empty(), "{s}");
}
