//! The low-rate path of `aerosid gaps` (below 20 Hz: the six coefficients by output error): the
//! HFB-320 (10 Hz) gets a verdict, a lift-curve curvature and a missing roll control planted in a
//! simulated flight averaged down to 10 Hz are named in `C_L` and `C_l`, the same flight without
//! them names nothing, pooled manoeuvres report each added term's agreement across them, and the
//! ATTAS lateral records at 12.5 Hz get a verdict or the reason. With the process-noise test
//! (`LowRateMethod::Test`) the filter error method runs where the residuals show turbulence; the
//! ignored measurements compare it with output error (σ against the scatter, detection and false
//! alarms).

use aerosid::gaps::hidden::{self, HiddenEffect, HiddenKind};
use aerosid::gaps::model::CauseKind;
use aerosid::gaps::{run_gaps, GapReport, GapSettings, LowRateMethod};
use aerosid::io::measured::MeasuredFlight;
use std::path::Path;

/// A simulated flight of 60 s in the campaign's light turbulence, logged at 100 Hz and averaged
/// in blocks of 10 samples: a 10 Hz log.
fn ten_hz(effect: Option<&HiddenEffect>, seed: u64) -> GapReport {
    ten_hz_with(effect, seed, GapSettings::default().low_rate_method)
}

/// [`ten_hz`] with the low-rate path's `method`.
fn ten_hz_with(effect: Option<&HiddenEffect>, seed: u64, method: LowRateMethod) -> GapReport {
    let f = hidden::flight(effect, 60.0, seed, true).expect("the simulator flies");
    let n = f.len();
    let rate = (n - 1) as f64 / (f.t_s[n - 1] - f.t_s[0]);
    let k = (rate / 10.0).round() as usize;
    let slow = f.block_means(k);
    let s = GapSettings {
        baseline: Some(HiddenEffect::baseline(effect)),
        low_rate_method: method,
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

/// A verdict of the low-rate path: output error, or the filter error method where an axis's
/// residuals show process noise.
fn low_rate_verdict(v: &str) -> bool {
    v.contains("(output error)") || v.contains("(filter error)")
}

/// An estimator of the low-rate path.
fn low_rate_estimator(e: &str) -> bool {
    e.starts_with("output error") || e.starts_with("filter error")
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
        assert!(low_rate_verdict(&c.verdict), "{name}: {}", c.verdict);
        assert!(
            c.cv_r2_baseline.is_finite() && c.cv_r2_baseline <= 1.0,
            "{name}: {}",
            c.cv_r2_baseline
        );
        assert!(low_rate_estimator(&c.baseline.estimator), "{name}");
    }
    // The record does not say how its samples were formed: the timing resolution of a surface
    // delay is half its 100 ms interval, and the report says so.
    assert!(
        r.notes
            .iter()
            .any(|n| n.contains("not stated by the source") && n.contains("within ±50 ms")),
        "{:?}",
        r.notes
    );
    // The record has no lateral channels: the lateral coefficients are absent or say why.
    assert!(
        r.coefficients
            .iter()
            .all(|c| !["C_Y", "C_l", "C_n"].contains(&c.name.as_str()))
            || r.notes.iter().any(|n| n.contains("lateral output error cannot run")),
        "{:?}",
        r.notes
    );
}

/// `--low-rate-method filter-error` reaches the analysis: the HFB-320's report says, per axis,
/// that the filter error method ran, and a verdict is still given.
#[test]
fn the_command_runs_the_filter_error_method_when_asked() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let out = std::env::temp_dir().join(format!("aerosid-low-rate-fem-{}", std::process::id()));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .arg("gaps")
        .arg("--data")
        .arg(data.join("flight").join("hfb320_1_10.asc"))
        .arg("--with")
        .arg(data.join("maps").join("hfb320.map"))
        .args(["--low-rate-method", "filter-error", "--out"])
        .arg(&out)
        .output()
        .expect("running aerosid");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("report.json")).expect("report.json");
    let _ = std::fs::remove_dir_all(&out);
    let r: serde_json::Value = serde_json::from_str(&text).expect("report.json is JSON");
    let notes: Vec<&str> = r["notes"]
        .as_array()
        .expect("notes")
        .iter()
        .filter_map(|n| n.as_str())
        .collect();
    assert!(
        notes.iter().any(|n| n.starts_with("method of this axis: filter error")),
        "{notes:?}"
    );
    assert!(
        !r["verdict"].as_str().expect("verdict").starts_with("no verdict"),
        "{}",
        r["verdict"]
    );
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
    for name in ["C_Y", "C_l", "C_n"] {
        let c = r.coefficients.iter().find(|c| c.name == name).expect(name);
        assert!(low_rate_verdict(&c.verdict), "{name}: {}", c.verdict);
    }
}

fn detail(r: &GapReport) -> String {
    let mut s = summary(r);
    for c in &r.coefficients {
        for k in c.candidates.iter().filter(|k| k.reason.is_some()) {
            s.push_str(&format!("   {} {} unscored: {:?}\n", c.name, k.term, k.reason));
        }
        for h in &c.homogeneity {
            s.push_str(&format!("   {} {} homogeneity: {}\n", c.name, h.term, h.reason));
        }
        for n in &c.notes {
            s.push_str(&format!("   {} note: {n}\n", c.name));
        }
    }
    s
}

/// The lateral coefficients at 10 Hz: a roll control left out of the baseline (the campaign's
/// `missing-roll-control`: the user's `C_l` has no `δa`) is named in `C_l` by output error, on the
/// flight and seed of the longitudinal cases.
#[test]
fn a_missing_roll_control_at_ten_hertz_is_named_in_c_l() {
    let effect = HiddenEffect {
        kind: HiddenKind::MissingRollControl,
        size: 0.0,
        channel: None,
    };
    let r = ten_hz(Some(&effect), 41_004);
    let s = detail(&r);
    println!("{s}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    let (kind, location) = effect.expected();
    assert!(
        r.named
            .iter()
            .any(|c| c.kind == kind && c.location == location && c.what.contains("δa")),
        "{s}"
    );
}

/// Six manoeuvres of 10 s at 10 Hz, pooled: the held-out data are whole manoeuvres and every term
/// the low-rate path would add carries its per-manoeuvre estimates and Cochran's Q; a term whose
/// estimates disagree is not named and its coefficient's verdict says so. With the process-noise
/// test, where the filter error method adds the adverse yaw's `δa` in `C_n` (output error adds
/// nothing on these manoeuvres: `δa` in `C_n` stays below the held-out test's critical value).
#[test]
fn pooled_manoeuvres_at_ten_hertz_report_the_homogeneity_of_an_added_term() {
    let r = pooled_ten_hz(&ADVERSE_YAW, LowRateMethod::Test);
    let text = detail(&r);
    println!("{text}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    let tested: Vec<_> = r
        .coefficients
        .iter()
        .flat_map(|c| c.homogeneity.iter().map(move |h| (c, h)))
        .collect();
    assert!(!tested.is_empty(), "{text}");
    for (c, h) in tested {
        assert!(low_rate_verdict(&c.verdict), "{}: {}", c.name, c.verdict);
        assert!(!h.per_manoeuvre.is_empty() && !h.reason.is_empty(), "{text}");
        assert!(
            h.per_manoeuvre.iter().all(|e| e.manoeuvre < 6 && e.sigma > 0.0),
            "{text}"
        );
        if !h.agrees {
            assert!(c.verdict.contains("not confirmed"), "{}: {}", c.name, c.verdict);
            assert!(
                !r.named.iter().any(|n| n.location == c.name && n.what.contains(&h.term)),
                "{text}"
            );
        }
    }
}

/// The same six manoeuvres with the process-noise test: the lateral residuals show process noise
/// (light turbulence), the filter error method runs on that axis, and the adverse yaw that the
/// output error leaves below the held-out test's critical value is named in `C_n` as `δa`.
#[test]
fn the_filter_error_method_names_the_adverse_yaw_of_pooled_manoeuvres() {
    let r = pooled_ten_hz(&ADVERSE_YAW, LowRateMethod::Test);
    let text = detail(&r);
    println!("{text}");
    assert!(
        r.notes
            .iter()
            .any(|n| n.starts_with("method of this axis: filter error") && n.contains("2ΔlnL")),
        "{:?}",
        r.notes
    );
    let c_n = r.coefficients.iter().find(|c| c.name == "C_n").expect("C_n");
    assert!(c_n.verdict.contains("(filter error)"), "{}", c_n.verdict);
    assert!(
        r.named
            .iter()
            .any(|c| c.kind == CauseKind::ControlTerm && c.location == "C_n" && c.what == "δa"),
        "{text}"
    );
}

/// The pooled manoeuvres' effect: `C_nδa = −0.05`.
const ADVERSE_YAW: HiddenEffect = HiddenEffect {
    kind: HiddenKind::AdverseYaw,
    size: -0.05,
    channel: None,
};

/// Six manoeuvres of 10 s at 10 Hz from one flight with `effect`, pooled, analysed with the
/// low-rate `method`.
fn pooled_ten_hz(effect: &HiddenEffect, method: LowRateMethod) -> GapReport {
    let flight = hidden::flight(Some(effect), 66.0, 41_005, true).expect("the simulator flies");
    let parts: Vec<_> = (0..6)
        .map(|k| {
            let from = k as f64 * 11.0;
            let mut m = flight
                .window(from, from + 10.0)
                .expect("inside the flight")
                .block_means(10);
            m.source = format!("manoeuvre_{k:02}.csv");
            (m, "the file's start".to_string())
        })
        .collect();
    let pooled = MeasuredFlight::pool(parts).expect("the manoeuvres pool");
    let s = GapSettings {
        baseline: Some(HiddenEffect::baseline(Some(effect))),
        low_rate_method: method,
        ..GapSettings::default()
    };
    run_gaps(&pooled, &s).expect("the analysis runs")
}

/// The ATTAS aileron and rudder records (25 Hz) averaged in pairs to 12.5 Hz, below the
/// equation-error path's rate: the lateral coefficients get an output-error verdict or the
/// report says why not.
#[test]
fn attas_lateral_records_at_low_rate_get_a_verdict_or_a_reason() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let parts: Vec<_> = ["fAttasAil1_pqrDot.asc", "fAttasRud1_pqrDot.asc"]
        .iter()
        .map(|f| {
            let m = aerosid::io::read_measured(&data.join("flight").join(f), &data.join("maps").join("attas.map"))
                .unwrap_or_else(|e| panic!("{e}"));
            (m.block_means(2), String::new())
        })
        .collect();
    let pooled = MeasuredFlight::pool(parts).expect("the records pool");
    let r = run_gaps(&pooled, &GapSettings::default()).expect("the analysis runs");
    let s = detail(&r);
    println!("{s}");
    assert!(low_rate_method(&r), "{:?}", r.notes);
    for name in ["C_Y", "C_l", "C_n"] {
        let c = r.coefficients.iter().find(|c| c.name == name).expect(name);
        let lateral_ran = low_rate_verdict(&c.verdict);
        let why = r.notes.iter().any(|n| n.contains("lateral output error cannot run"));
        assert!(lateral_ran || why, "{name}: {}\n{:?}", c.verdict, r.notes);
    }
}

/// The low-rate path's σ against the scatter of its estimates: 20 seeded 60 s flights in moderate
/// turbulence (Dryden, σ 1.0 m/s, L 50 m: gusts of about 4° in α and β at 15 m/s), averaged to
/// 10 Hz, clean; per baseline parameter of `C_L`, `C_m`, `C_Y`, `C_l`, `C_n` the standard
/// deviation of the 20 estimates over the root mean square of their stated σ, held to the
/// issue's 0.7–1.5. Minutes of CPU, so run on demand:
/// `cargo test -p aerosid --test cli low_rate::sigma -- --ignored --nocapture`. It runs the
/// process-noise test (the filter error method on every axis of these flights): it fails on
/// `C_n`'s δr (0.64); with output error only (the test below) `C_m`'s intercept, α and `q_n` are
/// at 0.56–0.66 (docs/model-gaps.md). Beside each term it prints the white-residual Cramér–Rao
/// bound and on how many flights σ is at or below it.
#[test]
#[ignore = "a measurement of 20 flights (minutes)"]
fn sigma_against_the_scatter_in_moderate_turbulence() {
    let worst = sigma_scatter(LowRateMethod::Test);
    assert!(worst.is_empty(), "scatter/σ outside 0.7–1.5: {worst:?}");
}

/// The same measurement with output error on every axis (the method before the filter error
/// method): what the process-noise test is measured against.
#[test]
#[ignore = "a measurement of 20 flights (minutes)"]
fn sigma_against_the_scatter_with_output_error_only() {
    let worst = sigma_scatter(LowRateMethod::OutputError);
    println!("scatter/σ outside 0.7–1.5: {worst:?}");
}

/// The scatter/σ table of the 20 flights with the low-rate `method`; the parameters outside
/// 0.7–1.5.
fn sigma_scatter(method: LowRateMethod) -> Vec<String> {
    use aerosid::sim::{simulate, SimAirframe, Turbulence};
    // Per (coefficient, term): (estimate, σ, Cramér–Rao bound) of each flight.
    type Draws = Vec<(f64, f64, f64)>;
    let mut est: std::collections::BTreeMap<(String, String), Draws> = Default::default();
    let mut colour = Vec::new();
    for seed in 0..20u64 {
        let mut cfg = hidden::config(None, 60.0, 41_100 + seed, true);
        cfg.turbulence = Some(Turbulence {
            lengths_m: [50.0; 3],
            sigma_mps: [1.0; 3],
        });
        let out = simulate(&cfg).expect("the simulator flies");
        let ac = aerosid::io::measured::Aircraft::from_airframe(
            "skywalker_2013_mod",
            &SimAirframe::skywalker_2013_mod().frame,
        );
        let f = aerosid::io::measured::MeasuredFlight::from_samples("moderate", &out.samples, ac).block_means(10);
        let s = GapSettings {
            baseline: Some(HiddenEffect::baseline(None)),
            low_rate_method: method,
            ..GapSettings::default()
        };
        let r = run_gaps(&f, &s).expect("the analysis runs");
        assert!(low_rate_method(&r), "{:?}", r.notes);
        colour.extend(
            r.notes
                .iter()
                .filter(|n| low_rate_estimator(n) || n.starts_with("method of this axis"))
                .cloned(),
        );
        for c in &r.coefficients {
            if !low_rate_estimator(&c.baseline.estimator) || c.name == "C_D" {
                continue;
            }
            for p in &c.baseline.parameters {
                est.entry((c.name.clone(), p.term.clone()))
                    .or_default()
                    .push((p.value, p.sigma, p.sigma_eq17));
            }
        }
    }
    for n in colour.iter().take(4) {
        println!("{n}");
    }
    let mut worst: Vec<String> = Vec::new();
    println!("| coefficient | term | mean | scatter | rms σ | scatter/σ | rms σ CR bound | σ ≤ bound |");
    for ((c, t), v) in &est {
        let n = v.len() as f64;
        let mean = v.iter().map(|x| x.0).sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x.0 - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let rms = (v.iter().map(|x| x.1 * x.1).sum::<f64>() / n).sqrt();
        let ratio = sd / rms;
        let crb = (v.iter().map(|x| x.2 * x.2).sum::<f64>() / n).sqrt();
        let floored = v.iter().filter(|x| x.1 <= x.2 * (1.0 + 1e-12)).count();
        println!(
            "| {c} | {t} | {mean:+.4} | {sd:.4} | {rms:.4} | {ratio:.2} | {crb:.4} | {floored}/{} |",
            v.len()
        );
        if !(0.7..=1.5).contains(&ratio) {
            worst.push(format!("{c} {t} {ratio:.2}"));
        }
    }
    worst
}

/// Detection and false alarms at 10 Hz with output error against the filter error method: the
/// planted effects of the cases above and a clean flight, on three seeds, in light turbulence;
/// per case and method, whether the planted cause is named, what else is named, and the methods
/// the process-noise test chose. A measurement (minutes):
/// `cargo test -p aerosid --test cli low_rate::detection -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement of 24 flights (minutes)"]
fn detection_with_output_error_and_filter_error() {
    detection(&detection_cases(), &[LowRateMethod::OutputError, LowRateMethod::Test]);
}

/// The filter error method's half of [`detection_with_output_error_and_filter_error`] on the
/// clean flights and the adverse yaw, where the two methods differed most (the false alarm and
/// the detection): `cargo test -p aerosid --test cli
/// low_rate::filter_error_detection -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement of 6 flights (minutes)"]
fn filter_error_detection_on_clean_flights_and_adverse_yaw() {
    let cases: Vec<_> = detection_cases()
        .into_iter()
        .filter(|(name, _)| *name == "clean" || *name == "adverse yaw −0.05")
        .collect();
    detection(&cases, &[LowRateMethod::Test]);
}

/// The cases of the detection measurements: a clean flight and three planted effects.
fn detection_cases() -> Vec<(&'static str, Option<HiddenEffect>)> {
    vec![
        ("clean", None),
        (
            "C_Lα² −10",
            Some(HiddenEffect {
                kind: HiddenKind::LiftQuadratic,
                size: -10.0,
                channel: None,
            }),
        ),
        (
            "missing roll control",
            Some(HiddenEffect {
                kind: HiddenKind::MissingRollControl,
                size: 0.0,
                channel: None,
            }),
        ),
        ("adverse yaw −0.05", Some(ADVERSE_YAW)),
    ]
}

/// Prints, per case of `cases`, seed 41004–41006 and method of `methods`, whether the planted
/// cause is named, what else is named (with its estimate) and the methods chosen; then the tally.
fn detection(cases: &[(&'static str, Option<HiddenEffect>)], methods: &[LowRateMethod]) {
    println!("| case | seed | method | planted named | others named | methods chosen |");
    let mut tally = std::collections::BTreeMap::<(&str, bool), (usize, usize, usize)>::new();
    for (name, effect) in cases {
        for seed in [41_004u64, 41_005, 41_006] {
            for &method in methods {
                let r = ten_hz_with(effect.as_ref(), seed, method);
                let expected = effect.as_ref().map(|e| e.expected());
                let planted = expected
                    .as_ref()
                    .is_some_and(|(kind, loc)| r.named.iter().any(|c| c.kind == *kind && &c.location == loc));
                let others: Vec<String> = r
                    .named
                    .iter()
                    .filter(|c| {
                        expected
                            .as_ref()
                            .is_none_or(|(kind, loc)| !(c.kind == *kind && &c.location == loc))
                    })
                    .map(|c| format!("{} {} {:+.4}", c.location, c.what, c.value))
                    .collect();
                let chosen: Vec<&str> = r
                    .notes
                    .iter()
                    .filter(|n| n.starts_with("method of this axis"))
                    .map(|n| {
                        if n.starts_with("method of this axis: filter error") {
                            "FEM"
                        } else {
                            "OE"
                        }
                    })
                    .collect();
                let is_test = method == LowRateMethod::Test;
                let t = tally.entry((name, is_test)).or_default();
                t.0 += usize::from(planted);
                t.1 += usize::from(!others.is_empty());
                t.2 += 1;
                println!(
                    "| {name} | {seed} | {} | {planted} | {} | {} |",
                    if is_test {
                        "test (FEM where chosen)"
                    } else {
                        "output error"
                    },
                    others.join("; "),
                    chosen.join(", ")
                );
            }
        }
    }
    println!("| case | method | planted named | flights with another cause |");
    for ((name, is_test), (planted, others, n)) in &tally {
        println!(
            "| {name} | {} | {planted}/{n} | {others}/{n} |",
            if *is_test { "test" } else { "output error" }
        );
    }
}

/// Where the filter error method's aileron delay on clean flights comes from: the clean flight
/// of [`ten_hz`] (seeds 41004–41006, the filter error method on both axes) as flown — with the
/// stabiliser's aileron feedback on roll angle and rate, and the servos — then without the
/// stabiliser, without the servos, and without turbulence; per variant, `C_l`'s surface-rate
/// candidate (`t²`, its delay `−θ_δȧ/θ_δa`) and what is named. A measurement (minutes):
/// `cargo test -p aerosid --test cli low_rate::source_of_the -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement of 12 flights (minutes)"]
fn source_of_the_aileron_delay_on_clean_flights() {
    println!("| variant | seed | C_l δȧ t² | delay, ms | named |");
    type Variant = (&'static str, fn(&mut aerosid::sim::SimConfig));
    let variants: [Variant; 4] = [
        ("as flown", |_| {}),
        ("no stabiliser", |c| c.stabiliser = None),
        ("no servos", |c| c.servo = None),
        ("no turbulence", |c| c.turbulence = None),
    ];
    for (name, change) in variants {
        delay_source(name, change, 10);
    }
}

/// The flights of [`source_of_the_aileron_delay_on_clean_flights`] as flown, logged at 10 Hz by
/// taking every tenth 100 Hz sample instead of block means: whether the averaging makes the
/// delay. `cargo test -p aerosid --test cli low_rate::point_samples -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement of 3 flights (minutes)"]
fn point_samples_and_the_aileron_delay() {
    println!("| variant | seed | C_l δȧ t² | delay, ms | named |");
    delay_source("every tenth sample", |_| {}, 1);
}

/// One row per seed 41004–41006 of the delay measurements: the clean flight with `change`,
/// logged at 10 Hz (block means of `block` samples of 100 Hz; 1: every tenth sample).
fn delay_source(name: &str, change: fn(&mut aerosid::sim::SimConfig), block: usize) {
    use aerosid::sim::{simulate, SimAirframe};
    for seed in [41_004u64, 41_005, 41_006] {
        let mut cfg = hidden::config(None, 60.0, seed, true);
        change(&mut cfg);
        let out = simulate(&cfg).expect("the simulator flies");
        let ac = aerosid::io::measured::Aircraft::from_airframe(
            "skywalker_2013_mod",
            &SimAirframe::skywalker_2013_mod().frame,
        );
        let f = if block > 1 {
            MeasuredFlight::from_samples(name, &out.samples, ac).block_means(block)
        } else {
            let every: Vec<_> = out.samples.iter().step_by(10).cloned().collect();
            MeasuredFlight::from_samples(name, &every, ac)
        };
        let s = GapSettings {
            baseline: Some(HiddenEffect::baseline(None)),
            low_rate_method: LowRateMethod::FilterError,
            ..GapSettings::default()
        };
        let r = run_gaps(&f, &s).expect("the analysis runs");
        let c_l = r.coefficients.iter().find(|c| c.name == "C_l").expect("C_l");
        let rate = c_l.candidates.iter().find(|k| k.term == "δȧ");
        let delta_a = c_l
            .baseline
            .parameters
            .iter()
            .find(|p| p.term == "δa")
            .map_or(f64::NAN, |p| p.value);
        let named: Vec<String> = r
            .named
            .iter()
            .map(|c| format!("{} {} {:+.4}", c.location, c.what, c.value))
            .collect();
        println!(
            "| {name} | {seed} | {} | {} | {} |",
            rate.map_or("—".into(), |k| format!("{:.1}", k.t2)),
            rate.map_or("—".into(), |k| format!("{:.1}", -1e3 * k.value / delta_a)),
            named.join("; ")
        );
    }
}

/// The clean flight of [`ten_hz`] without servos (seed 41004): the surfaces are held for each
/// 10 ms output period, a real lag of 5 ms (half the hold) of the applied surfaces behind their
/// logged samples, far inside the 50 ms a 10 Hz sample leaves unresolved. Logged as centred
/// 10 Hz means and with the same samples' formation unstated, the elevator's lag that passes the
/// tests is not named but gets the verdict "not decided at this rate", each with its reason.
#[test]
fn a_surface_delay_within_half_an_interval_is_not_decided() {
    use aerosid::io::measured::Sampling;
    use aerosid::sim::{simulate, SimAirframe};
    let mut cfg = hidden::config(None, 60.0, 41_004, true);
    cfg.servo = None;
    let out = simulate(&cfg).expect("the simulator flies");
    let ac =
        aerosid::io::measured::Aircraft::from_airframe("skywalker_2013_mod", &SimAirframe::skywalker_2013_mod().frame);
    let centred = MeasuredFlight::from_samples("no servos", &out.samples, ac).block_means(10);
    assert_eq!(centred.log.sampling, Sampling::CentredMeans);
    let mut unstated = centred.clone();
    unstated.log.sampling = Sampling::Unstated;
    let s = GapSettings {
        baseline: Some(HiddenEffect::baseline(None)),
        low_rate_method: LowRateMethod::FilterError,
        ..GapSettings::default()
    };
    for (f, why) in [(&unstated, "do not say"), (&centred, "within one sample interval")] {
        let r = run_gaps(f, &s).expect("the analysis runs");
        let text = detail(&r);
        println!("{:?}:\n{text}", f.log.sampling);
        assert!(!r.named.iter().any(|c| c.kind == CauseKind::ControlDelay), "{text}");
        let c_m = r.coefficients.iter().find(|c| c.name == "C_m").expect("C_m");
        assert!(
            c_m.verdict.starts_with("not decided at this rate")
                && c_m.verdict.contains("δė")
                && c_m.verdict.contains(why),
            "{}",
            c_m.verdict
        );
    }
}
