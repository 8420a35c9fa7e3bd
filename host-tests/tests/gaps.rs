//! Flights with one hidden effect, drawn at random; the model-gap analysis
//! ([`aerosid::gaps::run_gaps`]) is told nothing of the draw and must name the hidden effect as
//! its top cause, and name nothing on clean flights.
//!
//! The calm-air campaign: 40 flights whose hidden effect (kind and size) is drawn by a seeded
//! ChaCha8 from the 8 kinds of [`HiddenKind::CALM`], and 20 clean flights, each 90 s at 100 Hz with
//! its own sensor-noise seed. Required: ≥ 95 % named correctly (kind *and* place: the coefficient,
//! or the sensor channel), and nothing named on ≥ 95 % of the clean flights. The confusion table is
//! printed (`cargo test -p aerosid-host-tests --test integration gaps:: -- --nocapture`).
//!
//! In turbulence (the simulator's Dryden gusts, σ 0.3 m/s, L 50 m: [`aerosid::gaps::hidden::CAMPAIGN_TURBULENCE`])
//! one flight per kind of [`HiddenKind::ALL`] and ten clean flights: what is identifiable must be
//! named in its place, what is not must not be named wrongly, and at most one clean flight in ten
//! may name anything. The benchmark against the peers (`scripts/bench/`) runs larger draws.

use aerosid::gaps::compat::SensorParam;
use aerosid::gaps::hidden::{flight, HiddenEffect, HiddenKind};
use aerosid::gaps::{run_gaps, GapSettings};
use aerosid::io::measured::Quantity;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Number of flights with a hidden effect, and of clean flights (required: ≥ 40 and ≥ 20).
const HIDDEN: usize = 40;
const CLEAN: usize = 20;
/// Flight length, s.
const DURATION_S: f64 = 90.0;

struct Outcome {
    truth: String,
    named: String,
    correct: bool,
    detail: String,
}

fn case(effect: Option<HiddenEffect>, seed: u64) -> Outcome {
    case_in(effect, seed, false).0
}

fn case_in(effect: Option<HiddenEffect>, seed: u64, turbulence: bool) -> (Outcome, aerosid::gaps::GapReport) {
    let f = flight(effect.as_ref(), DURATION_S, seed, turbulence).expect("the campaign's flights trim");
    let settings = GapSettings {
        baseline: Some(HiddenEffect::baseline(effect.as_ref())),
        ..GapSettings::default()
    };
    let r = run_gaps(&f, &settings).expect("the simulated flight has every channel");
    let top = r.top_cause();
    let named = top.map_or("nothing".to_string(), |c| format!("{:?}", c.kind));
    let (truth, correct) = match &effect {
        None => ("clean".to_string(), top.is_none()),
        Some(e) => {
            let (kind, place) = e.expected();
            (
                format!("{:?}", e.kind),
                top.is_some_and(|c| c.kind == kind && c.location == place),
            )
        }
    };
    let detail = format!(
        "{:<48} → {}",
        effect.map_or("clean".into(), |e| e.describe()),
        top.map_or("nothing".into(), |c| format!(
            "{:?} in {}: {} (t² {:.0})",
            c.kind, c.location, c.what, c.t2
        ))
    );
    (
        Outcome {
            truth,
            named,
            correct,
            detail,
        },
        r,
    )
}

#[test]
fn the_analysis_names_the_hidden_effect_and_nothing_on_clean_flights() {
    // GIVEN 40 hidden effects drawn by a seeded generator from 8 kinds, and 20 clean flights
    let mut rng = ChaCha8Rng::seed_from_u64(0x6a95);
    let draws: Vec<(Option<HiddenEffect>, u64)> = (0..HIDDEN)
        .map(|i| (Some(HiddenEffect::draw(&mut rng)), 1000 + i as u64))
        .chain((0..CLEAN).map(|i| (None, 5000 + i as u64)))
        .collect();
    let kinds_drawn: std::collections::BTreeSet<HiddenKind> =
        draws.iter().filter_map(|d| d.0.map(|e| e.kind)).collect();
    assert!(
        kinds_drawn.len() >= 8,
        "the draw covers only {} kinds",
        kinds_drawn.len()
    );
    // WHEN the analysis runs on each, told nothing of the draw
    let out: Vec<Outcome> = draws.par_iter().map(|(e, seed)| case(*e, *seed)).collect();
    // THEN print the confusion table
    let mut table: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut columns = std::collections::BTreeSet::new();
    for o in &out {
        *table
            .entry(o.truth.clone())
            .or_default()
            .entry(o.named.clone())
            .or_default() += 1;
        columns.insert(o.named.clone());
    }
    let columns: Vec<String> = columns.into_iter().collect();
    println!("confusion table (rows: hidden effect; columns: top cause named)");
    print!("{:<15}", "");
    for c in &columns {
        print!(" {:>16}", c);
    }
    println!();
    for (row, counts) in &table {
        print!("{:<15}", row);
        for c in &columns {
            print!(" {:>16}", counts.get(c).copied().unwrap_or(0));
        }
        println!();
    }
    for o in out.iter().filter(|o| !o.correct) {
        println!("MISSED: {}", o.detail);
    }
    let hidden: Vec<&Outcome> = out.iter().filter(|o| o.truth != "clean").collect();
    let clean: Vec<&Outcome> = out.iter().filter(|o| o.truth == "clean").collect();
    let named_right = hidden.iter().filter(|o| o.correct).count();
    let quiet = clean.iter().filter(|o| o.correct).count();
    println!(
        "named correctly (kind and place): {named_right}/{} = {:.1} %; clean flights with nothing named: {quiet}/{} = {:.1} %",
        hidden.len(),
        100.0 * named_right as f64 / hidden.len() as f64,
        clean.len(),
        100.0 * quiet as f64 / clean.len() as f64
    );
    // AND at least 95 % of each (the required rates)
    assert!(
        20 * named_right >= 19 * hidden.len(),
        "{named_right}/{} named correctly",
        hidden.len()
    );
    assert!(
        20 * quiet >= 19 * clean.len(),
        "{quiet}/{} clean flights quiet",
        clean.len()
    );
}

#[test]
fn each_kind_of_hidden_effect_is_named_in_its_place() {
    // GIVEN one flight per kind, the size drawn by a seeded generator (the first draw of each kind
    // from seed 7; no selection), and the analysis told nothing
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let effects: Vec<HiddenEffect> = HiddenKind::CALM.iter().map(|k| k.draw(&mut rng)).collect();
    // WHEN it runs on each (calm air)
    let out: Vec<Outcome> = effects
        .par_iter()
        .enumerate()
        .map(|(i, e)| case(Some(*e), 300 + i as u64))
        .collect();
    // THEN each is named as the top cause, kind and place — every one: a kind that is never named
    // could hide inside the 5 % the campaign allows, so each kind is required on its own flight
    for o in &out {
        println!("{}", o.detail);
    }
    let missed: Vec<&String> = out.iter().filter(|o| !o.correct).map(|o| &o.detail).collect();
    assert!(missed.is_empty(), "missed: {missed:?}");
}

/// The kinds whose detection in turbulence depends on their drawn size, with what the analysis
/// must do when it does not name them: a vane scale factor (tested by instrumental variables,
/// which on these flights resolve about ±0.03) is named in its place or not at all, with the
/// output-error check's turbulence reason in the report; the lift curvature is open (the
/// benchmark table records its misses).
const NOT_IDENTIFIABLE_IN_TURBULENCE: [HiddenKind; 1] = [HiddenKind::VaneScale];
const OPEN_IN_TURBULENCE: [HiddenKind; 1] = [HiddenKind::LiftQuadratic];

#[test]
fn in_turbulence_each_identifiable_kind_is_named_and_clean_flights_stay_quiet() {
    // GIVEN one turbulent flight per kind (the first draw of each from seed 7) and ten clean ones
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let draws: Vec<(Option<HiddenEffect>, u64)> = HiddenKind::ALL
        .iter()
        .enumerate()
        .map(|(i, k)| (Some(k.draw(&mut rng)), 900 + i as u64))
        .chain((0..10).map(|i| (None, 950 + i as u64)))
        .collect();
    // WHEN the analysis runs on each, told nothing
    let out: Vec<(Outcome, aerosid::gaps::GapReport)> =
        draws.par_iter().map(|(e, seed)| case_in(*e, *seed, true)).collect();
    for (o, _) in &out {
        println!("{}", o.detail);
    }
    // THEN every identifiable kind is the top cause in its place
    for ((o, r), (e, _)) in out.iter().zip(&draws) {
        let Some(e) = e else { continue };
        if NOT_IDENTIFIABLE_IN_TURBULENCE.contains(&e.kind) {
            // AND a scale factor is named right or nothing is, and the report says what was
            // done: the turbulence noted, and the vane's scale scored by the instrumental check
            assert!(o.correct || r.named.is_empty(), "{}: named {:?}", o.detail, r.named);
            let c = &r.compatibility;
            assert!(
                c.notes.iter().any(|n| n.starts_with("turbulence")),
                "{}: no turbulence note in {:?}",
                o.detail,
                c.notes
            );
            let iv = c.tested.iter().find(|t| {
                t.part == "instrumental"
                    && t.param == aerosid::gaps::compat::SensorParam::Scale(aerosid::io::measured::Quantity::Alpha)
            });
            let Some(iv) = iv else {
                panic!(
                    "{}: scale(Alpha) not scored by the instrumental check: {:?}",
                    o.detail, c.tested
                );
            };
            // AND a scale factor not named is one the report says the flight cannot detect
            assert!(
                o.correct || iv.min_detectable > e.size.abs(),
                "{}: scale(Alpha) missed though detectable (needs {} < {})",
                o.detail,
                iv.min_detectable,
                e.size.abs()
            );
        } else if !OPEN_IN_TURBULENCE.contains(&e.kind) {
            assert!(o.correct, "missed in turbulence: {}", o.detail);
        } else if !o.correct {
            // AND a missed lift curvature is one the report says the flight cannot detect: the
            // planted |C_Lα²| below the least the flight names with 80 % probability
            let c = r.coefficients.iter().find(|c| c.name == "C_L").expect("C_L analysed");
            let a2 = c.candidates.iter().find(|k| k.term == "α²").expect("α² scored");
            assert!(
                a2.min_detectable > e.size.abs(),
                "{}: α² missed though detectable (needs {} < {})",
                o.detail,
                a2.min_detectable,
                e.size.abs()
            );
        }
        // AND every scored candidate states its estimate, σ and the least detectable effect:
        // sensor errors (its factor, (max(√t²_thr, 2·T_crit) + t₀.₂), between 4 and 8 at these
        // thresholds and block counts) — none for a candidate barred from output error in
        // turbulence (a vane's scale, delay or position; the instrumental test reports those)
        for k in &r.compatibility.tested {
            if k.min_detectable.is_nan() {
                let air = matches!(k.param.channel(), Quantity::Alpha | Quantity::Beta | Quantity::Airspeed);
                assert!(
                    air && !matches!(k.param, SensorParam::Bias(_)),
                    "{}: {k:?} without min_detectable",
                    o.detail
                );
                continue;
            }
            let factor = k.min_detectable / k.sigma;
            assert!(
                k.sigma > 0.0 && (4.0..8.0).contains(&factor),
                "{}: {k:?}: min_detectable {factor}·σ",
                o.detail
            );
        }
        for c in &r.coefficients {
            for k in c.candidates.iter().filter(|k| k.reason.is_none()) {
                // (max(√t²_thr, 2·T_crit) + t₀.₂)·σ, T_crit the held-out test's one-sided 1 %
                // quantile, both at G − 1 degrees of freedom (G blocks over the whole flight)
                let t = &c.traces.t_s;
                let g = ((t[t.len() - 1] - t[0] + (t[1] - t[0])) / c.block_s).round();
                let q = |p: f64| aerosid::gaps::select::student_t_upper_quantile(p, g - 1.0);
                let need = c.threshold_t2.sqrt().max(2.0 * q(0.01)) + q(0.2);
                assert!(
                    k.sigma > 0.0 && (k.min_detectable / (need * k.sigma) - 1.0).abs() < 1e-9,
                    "{} {}: {k:?}, expected {}·σ",
                    c.name,
                    k.term,
                    need
                );
            }
        }
    }
    // AND at most one clean flight in ten names anything
    let noisy: Vec<&String> = out
        .iter()
        .filter(|(o, _)| o.truth == "clean" && !o.correct)
        .map(|(o, _)| &o.detail)
        .collect();
    assert!(noisy.len() <= 1, "clean flights with a cause named: {noisy:?}");
    // AND the air data are the vanes, said so (turbulence detected)
    assert!(out.iter().all(|(_, r)| r.air_data.starts_with("air data: measured")));
}

/// The flight of a campaign case with its truth (the simulator's output).
fn simulated(
    effect: Option<&HiddenEffect>,
    seed: u64,
) -> (aerosid::io::measured::MeasuredFlight, aerosid_sim::SimOutput) {
    use aerosid::io::measured::{Aircraft, MeasuredFlight};
    use aerosid_sim::{simulate, SimAirframe};
    let out = simulate(&aerosid::gaps::hidden::config(effect, DURATION_S, seed, false)).expect("trims");
    let nominal = SimAirframe::skywalker_2013_mod();
    let f = MeasuredFlight::from_samples(
        "simulated",
        &out.samples,
        Aircraft::from_airframe("skywalker_2013_mod", &nominal.frame),
    );
    (f, out)
}

#[test]
fn the_monte_carlo_error_model_matches_the_reconstructions_actual_error() {
    use aerosid::gaps::compat::{check, CompatSettings};
    use aerosid::gaps::model::{synthesise, Corrections, Signal, Term, TermRefs};
    use aerosid::gaps::noise::{column_errors, MonteCarlo, Synthesis};
    use aerosid::gaps::signal::sg_smooth;
    // GIVEN three clean flights (seeds outside the campaign's) and their truth
    for seed in [7001u64, 7002, 7003] {
        let (f, out) = simulated(None, seed);
        let h = 0.01;
        let c = check(
            &f,
            h,
            &CompatSettings {
                threshold_t2: 19.1,
                max_lag: 500,
                max_added: 3,
                gain_alpha: 0.01,
                iv: aerosid::gaps::instrumental::IvSettings {
                    level: 1e-5,
                    cv: aerosid::gaps::select::CvSettings::default(),
                },
            },
        );
        let corr = Corrections::default();
        let table = synthesise(&f, h, &corr, 10, Some(&c.air_data));
        let n_id = 5400;
        let refs = TermRefs {
            alpha_break_rad: 0.1,
            airspeed_mps: 15.0,
            mach: 0.0,
        };
        // WHEN the Monte Carlo estimates the error variance of the α and ΔV/V columns of C_L
        let terms: [Vec<Term>; 6] =
            core::array::from_fn(|i| if i == 0 { vec![Term::Alpha, Term::Speed] } else { vec![] });
        let syn = Synthesis {
            flight: &f,
            h_s: h,
            corrections: &corr,
            sg_half: 10,
            compat: Some(&c),
            fuse_cutoffs: None,
            refs: &refs,
            n_id,
            estimate_errors: &Default::default(),
        };
        let e = column_errors(&syn, &table, &terms, &MonteCarlo::default());
        let e = e[0].as_ref().expect("C_L synthesised");
        // AND the actual errors are the table's columns less the smoothed truth
        let truth_alpha: Vec<f64> = out.truth.iter().map(|t| t.eval.alpha_rad).collect();
        let truth_v: Vec<f64> = out.truth.iter().map(|t| t.eval.airspeed_mps).collect();
        let (ta, tv) = (sg_smooth(&truth_alpha, 10), sg_smooth(&truth_v, 10));
        let rms =
            |x: &[f64], y: &[f64]| (x.iter().zip(y).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / x.len() as f64).sqrt();
        let actual_alpha = rms(&table.signals[&Signal::Alpha][..n_id], &ta[..n_id]);
        let actual_v = rms(&table.signals[&Signal::Airspeed][..n_id], &tv[..n_id]) / 15.0;
        let mc_alpha = e.variance(&Term::Alpha).sqrt();
        let mc_v = e.variance(&Term::Speed).sqrt();
        println!(
            "seed {seed}: α error {actual_alpha:.2e} (MC {mc_alpha:.2e}), ΔV/V error {actual_v:.2e} (MC {mc_v:.2e})"
        );
        // THEN the two agree within a factor 1.6: the Monte Carlo's own spread is ±15 % (8 replicas
        // of ~11 segments), and the actual error of one flight is itself one draw of a
        // segment-correlated error (~11 segments in the identification part: ±30 % in RMS at 2σ)
        for (a, m) in [(actual_alpha, mc_alpha), (actual_v, mc_v)] {
            assert!(m / a < 1.6 && a / m < 1.6, "actual {a:.3e}, Monte Carlo {m:.3e}");
        }
    }
}

#[test]
fn every_term_evaluates_on_a_snapshot_as_its_column() {
    use aerosid::gaps::model::{synthesise, Corrections, Term, TermRefs};
    // GIVEN a simulated flight's table
    let (f, _) = simulated(None, 7004);
    let t = synthesise(&f, 0.01, &Corrections::default(), 10, None);
    let refs = TermRefs {
        alpha_break_rad: 0.08,
        airspeed_mps: 15.0,
        mach: 0.0,
    };
    // THEN every term's per-sample value equals its column (the simulation relies on it)
    for term in Term::ALL {
        let Some(col) = term.column(&t, &refs) else { continue };
        for k in (0..col.len()).step_by(97) {
            let v = term.eval(&t.snapshot(k, 0.0), &refs).expect("the signals exist");
            assert!(
                (v - col[k]).abs() <= 1e-12 * col[k].abs().max(1.0),
                "{}: {v} vs {}",
                term.name(),
                col[k]
            );
        }
    }
}

#[test]
fn the_simulation_of_the_held_out_segment_shows_the_gap_and_the_gain() {
    // GIVEN a flight with a lift quadratic and one with a thrust-line offset (first draws of seed 9)
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let lift = HiddenKind::LiftQuadratic.draw(&mut rng);
    let thrust = HiddenKind::ThrustMoment.draw(&mut rng);
    for (e, output) in [(lift, "Alpha"), (thrust, "PitchRate")] {
        let f = flight(Some(&e), DURATION_S, 7010, false).expect("trims");
        // WHEN the analysis simulates the held-out segment with the baseline and the extended models
        let r = run_gaps(&f, &GapSettings::default()).expect("runs");
        let o = r
            .simulation
            .outputs
            .iter()
            .find(|o| o.channel == output)
            .expect("simulated");
        println!(
            "{}: {} RMS {:.3e} → {:.3e}, R² {:.4} → {:.4}, PSE {:.3e} → {:.3e}",
            e.describe(),
            output,
            o.baseline.rms,
            o.extended.rms,
            o.baseline.r2,
            o.extended.r2,
            o.baseline.pse,
            o.extended.pse
        );
        // THEN nothing diverged, the baseline follows the motion broadly (R² > 0.9; measured 0.998
        // for α, 0.960 for q with the thrust moment missing), and the extended model — with the
        // hidden effect found — simulates the affected state better (measured: α RMS −10 %, q
        // RMS −89 %)
        assert_eq!(o.diverged, [0, 0]);
        assert!(o.baseline.r2 > 0.9, "{}", o.baseline.r2);
        assert!(
            o.extended.rms < o.baseline.rms,
            "{} → {}",
            o.baseline.rms,
            o.extended.rms
        );
    }
}

#[test]
fn on_the_jsbsim_flights_table_effects_are_found_and_no_sensor_error_is_invented() {
    // GIVEN the vendored JSBSim c172x flights (an independent simulator, light turbulence; truth in
    // tool/data/jsbsim/truth.json)
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data/jsbsim");
    let out = std::env::temp_dir().join(format!("aerosid-gaps-jsbsim-{}", std::process::id()));
    // WHEN the benchmark campaign runs on them alone
    let lines = aerosid::gaps::bench::write(
        &aerosid::gaps::bench::Campaign {
            draws_per_kind: 0,
            clean: 0,
            jsbsim: Some(dir),
            real: None,
            levels: Default::default(),
            cards: None,
        },
        &out,
    )
    .expect("the campaign writes its manifest");
    for l in &lines {
        println!("{l}");
    }
    let manifest = read_json(&out.join("manifest.json"), "manifest");
    let flights = manifest.as_array().expect("a list of flights");
    // THEN every flight was analysed and its regression table written
    assert_eq!(flights.len(), 13, "{lines:?}");
    assert_times_recorded(flights, &out);
    for f in flights {
        let table = out.join(f["table"].as_str().expect("table path"));
        let header = std::fs::read_to_string(&table).expect("table written");
        assert!(header.starts_with("t_s,z:C_L,z:C_D"), "{}", table.display());
    }
    assert_drag_polar_not_excited_beyond_its_error(&out);
    assert_no_sensor_error_invented_and_beta_drag_found(flights);
    assert_planted_effects_named(flights);
    assert_alpha_dot_listed_as_rival(&out);
    assert_gyroscopic_moment_named_and_equal_and_opposite(flights, &out);
    let _ = std::fs::remove_dir_all(&out);
}

/// A JSON file of the campaign (`what` names it in a failure).
fn read_json(path: &std::path::Path, what: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{what} written: {e}")))
        .unwrap_or_else(|e| panic!("{what} is JSON: {e}"))
}

/// Each flight's time recorded, with the suite's median in timing.json (the median of the
/// flights' own times, whatever they are: no wall-clock bound is asserted).
fn assert_times_recorded(flights: &[serde_json::Value], out: &std::path::Path) {
    let timing = read_json(&out.join("timing.json"), "timing");
    let mut secs: Vec<f64> = flights
        .iter()
        .map(|f| f["aerosid"]["seconds"].as_f64().expect("seconds recorded"))
        .collect();
    assert!(secs.iter().all(|s| s.is_finite() && *s > 0.0), "{secs:?}");
    assert!(flights.iter().all(|f| f["aerosid"]["cpu_seconds"]
        .as_f64()
        .is_some_and(|c| c.is_finite() && c >= 0.0)));
    secs.sort_by(f64::total_cmp);
    assert_eq!(timing["suites"]["jsbsim"]["flights"], 13);
    assert_eq!(
        timing["suites"]["jsbsim"]["median_s"].as_f64(),
        Some(secs[6]),
        "{timing}"
    );
}

/// The drag polar's C_L², beside α and α² in the C_D baseline, is reported as not excited beyond
/// its own measurement error (regular normal equations before the errors-in-variables
/// correction), not as collinear, on a clean flight.
fn assert_drag_polar_not_excited_beyond_its_error(out: &std::path::Path) {
    let report = read_json(&out.join("reports/jsbsim_clean_s1.json"), "report");
    let cd = report["coefficients"]
        .as_array()
        .and_then(|c| c.iter().find(|c| c["name"] == "C_D"))
        .expect("C_D analysed");
    let cl2 = cd["candidates"]
        .as_array()
        .and_then(|c| c.iter().find(|k| k["term"] == "C_L²"))
        .expect("C_L² listed");
    assert!(
        cl2["reason"]
            .as_str()
            .is_some_and(|r| r.contains("beyond its measurement error")),
        "{cl2}"
    );
}

/// The causes the manifest names for flight `id`: (kind, location, term).
fn named_causes(flights: &[serde_json::Value], id: &str) -> Vec<(String, String, String)> {
    let f = flights.iter().find(|f| f["id"] == id).expect("flight present");
    f["aerosid"]["named"]
        .as_array()
        .expect("named list")
        .iter()
        .map(|n| {
            (
                n["kind"].as_str().unwrap_or_default().to_string(),
                n["location"].as_str().unwrap_or_default().to_string(),
                n["what"].as_str().unwrap_or_default().to_string(),
            )
        })
        .collect()
}

/// No sensor error is invented (JSBSim's own sensors are perfect; the planted vane errors are
/// either found or, in turbulence, said to be unidentifiable), and c172x's |β| drag table is
/// found on every flight.
fn assert_no_sensor_error_invented_and_beta_drag_found(flights: &[serde_json::Value]) {
    use aerosid::gaps::model::CauseKind;
    let sensor = [
        CauseKind::SensorBias,
        CauseKind::ScaleFactor,
        CauseKind::TimeDelay,
        CauseKind::VanePosition,
    ]
    .map(|k| format!("{k:?}"));
    for f in flights {
        let id = f["id"].as_str().unwrap_or_default();
        let n = named_causes(flights, id);
        let planted_sensor = f["planted"]
            .as_array()
            .is_some_and(|p| p.iter().any(|x| sensor.iter().any(|s| x["kind"] == s.as_str())));
        if !planted_sensor {
            assert!(!n.iter().any(|c| sensor.contains(&c.0)), "{id}: {n:?}");
        }
        assert!(n.iter().any(|c| c.1 == "C_D" && c.2 == "|β|"), "{id}: {n:?}");
    }
}

/// The planted thrust-line offset, β² in C_m (excited by two rudder doublets only: its held-out
/// gain lives in a few blocks), α³ in C_D and α·δa in C_n (the two weakest, see the data's
/// README) and the elevator delay are named in their place — the delay once: C_m and C_D both
/// show it, and a surface has one delay.
fn assert_planted_effects_named(flights: &[serde_json::Value]) {
    for (id, kind, coef, term) in [
        ("jsbsim/thrust_Cm", "Thrust", "C_m", "C_T"),
        ("jsbsim/beta2_Cm", "CrossCoupling", "C_m", "β²"),
        ("jsbsim/alpha3_CD", "NonlinearAlpha", "C_D", "α³"),
        ("jsbsim/alphadelta_a_Cn", "ControlTerm", "C_n", "α·δa"),
    ] {
        let n = named_causes(flights, id);
        assert!(
            n.iter().any(|c| c.0 == kind && c.1 == coef && c.2 == term),
            "{id}: {n:?}"
        );
    }
    let delay = named_causes(flights, "jsbsim/elevator_delay");
    assert_eq!(
        delay
            .iter()
            .filter(|c| c.0 == "ControlDelay" && c.1 == "Elevator")
            .count(),
        1,
        "{delay:?}"
    );
}

/// Where the held-out test alone chose between two significant terms, the report shows the one
/// it passed over: on the α̇ flight ΔV/V is named in C_m, and the planted α̇ (which in its place
/// is as significant, with the planted value) is listed as its rival.
fn assert_alpha_dot_listed_as_rival(out: &std::path::Path) {
    let report = read_json(&out.join("reports").join("jsbsim_alphadot_Cm.json"), "report");
    let rivals: Vec<&str> = report["coefficients"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|c| c["name"] == "C_m")
        .flat_map(|c| c["added"].as_array().into_iter().flatten())
        .filter(|a| a["term"] == "ΔV/V")
        .flat_map(|a| a["rivals"].as_array().into_iter().flatten())
        .filter_map(|r| r["term"].as_str())
        .collect();
    assert!(rivals.contains(&"α̇_n"), "{rivals:?}");
}

/// The propeller's gyroscopic moment (c172x: I_prop 1.67 slug·ft²) is named on every flight as q̂
/// in C_n; where r̂ in C_m is named too, the two derivatives are equal and opposite within 3
/// combined σ, as a rotor's `−ω × H` requires (`C_n,q̂ = −C_m,r̂ = 2VH/(q̄Sbc̄)` with the
/// normalisations q̂ = qc̄/2V, r̂ = rb/2V) — a check by physics the selection does not know.
fn assert_gyroscopic_moment_named_and_equal_and_opposite(flights: &[serde_json::Value], out: &std::path::Path) {
    let mut pairs = 0;
    for f in flights {
        let id = f["id"].as_str().unwrap_or_default();
        let report = read_json(
            &out.join("reports").join(format!("{}.json", id.replace('/', "_"))),
            "report",
        );
        let est = |coef: &str, term: &str| -> Option<(f64, f64)> {
            report["named"].as_array()?.iter().find_map(|n| {
                (n["location"] == coef && n["what"] == term).then(|| {
                    (
                        n["value"].as_f64().unwrap_or(f64::NAN),
                        n["sigma"].as_f64().unwrap_or(f64::NAN),
                    )
                })
            })
        };
        let Some((nq, sq)) = est("C_n", "q_n") else {
            panic!("{id}: q̂ in C_n not named: {:?}", named_causes(flights, id))
        };
        if let Some((mr, sr)) = est("C_m", "r_n") {
            pairs += 1;
            let bound = 3.0 * (sq * sq + sr * sr).sqrt();
            assert!((nq + mr).abs() <= bound, "{id}: C_n,q̂ {nq} and C_m,r̂ {mr} (3σ {bound})");
        }
    }
    // (r̂ in C_m has 2–3× the σ of q̂ in C_n; named on 12 of the 13 flights when written)
    assert!(pairs >= 10, "r̂ in C_m named on {pairs} of 13 flights");
}
