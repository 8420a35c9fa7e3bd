//! `aerosid predict` with a gap report: the coefficient models `aerosid gaps` identified on one
//! simulated flight applied to another flight of the same airframe (another seed: other
//! turbulence, sensor noise and biases), a flight lacking a channel a term needs, and refused
//! inputs. Everything through the binary, as a user runs it; the flights are the main job's
//! (`aerosid simulate`), read back with the airframe's aircraft file.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn aerosid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running aerosid {args:?}: {e}"))
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn aircraft() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/aircraft/skywalker_2013_mod.aircraft")
        .display()
        .to_string()
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// The shared fixture (under the target folder, rewritten each run): a folder with flights `a.csv` (seed 1) and `b.csv` (seed 2), 90 s each,
/// and `id/report.json`, the gap analysis of `a.csv` (run once for every test of this file).
fn fixture() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("predict");
        std::fs::create_dir_all(&dir).expect("scratch folder");
        for (name, seed) in [("a.csv", "1"), ("b.csv", "2")] {
            let o = aerosid(&[
                "simulate",
                "--out",
                s(&dir.join(name)),
                "--seed",
                seed,
                "--seconds",
                "90",
            ]);
            assert!(o.status.success(), "simulate: {}", text(&o.stderr));
        }
        let o = aerosid(&[
            "gaps",
            "--data",
            s(&dir.join("a.csv")),
            "--with",
            &aircraft(),
            "--out",
            s(&dir.join("id")),
        ]);
        assert!(o.status.success(), "gaps: {}", text(&o.stderr));
        dir
    })
}

fn predict(dir: &Path, data: &str, out: &str) -> (Output, Value) {
    let o = aerosid(&[
        "predict",
        "--saved",
        s(&dir.join("id/report.json")),
        "--data",
        s(&dir.join(data)),
        "--with",
        &aircraft(),
        "--out",
        s(&dir.join(out)),
    ]);
    assert!(o.status.success(), "predict: {}\n{}", text(&o.stderr), text(&o.stdout));
    let j = std::fs::read_to_string(dir.join(out).join("prediction.json")).expect("prediction.json");
    (o, serde_json::from_str(&j).expect("prediction.json parses"))
}

fn coefficient<'a>(p: &'a Value, name: &str) -> &'a Value {
    p["coefficients"]
        .as_array()
        .expect("coefficients")
        .iter()
        .find(|c| c["name"] == name)
        .unwrap_or_else(|| panic!("{name} missing from {p}"))
}

#[test]
fn a_gap_report_predicts_another_flight_of_the_airframe() {
    // GIVEN the models identified on seed 1 and a flight of seed 2
    let dir = fixture();
    // WHEN they predict the other flight
    let (o, p) = predict(dir, "b.csv", "pred");
    // THEN the report has every field, for every coefficient of the gap report
    let out = text(&o.stdout);
    assert!(out.contains("C_m   baseline"), "{out}");
    assert!(dir.join("pred/prediction.svg").is_file());
    assert_eq!(p["schema"], "aerosid-gaps-prediction/1");
    assert_eq!(p["samples"], 9000);
    assert_eq!(p["term_refs"]["from"], "report", "{}", p["term_refs"]);
    assert!(p["air_data"].as_str().is_some_and(|a| a.starts_with("air data:")));
    for name in ["C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"] {
        let c = coefficient(&p, name);
        assert_eq!(c["predicted"], true, "{c}");
        for model in ["baseline", "extended"] {
            for field in ["samples", "rms", "r2", "theil_u"] {
                assert!(c[model][field].is_number(), "{name} {model}.{field}: {c}");
            }
        }
        assert!(c.get("extension_improves").is_some(), "{c}");
    }
    // AND C_L and C_m are predicted with R² ≥ 0.9. Why this bound: eq. 3 holds the terms that
    // dominate both coefficients, so only the turbulence, the sensor noise and the hidden effects
    // of the main flight are left unexplained; the analysis's own held-out R² is 0.99–1.0 for both,
    // and on seed 2 the prediction measures 0.98 (C_L) and 0.99 (C_m). 0.9 allows five times the
    // unexplained variance measured, and still fails a model with a wrong derivative (δe, α) or a
    // term formed with the wrong reference.
    for name in ["C_L", "C_m"] {
        let c = coefficient(&p, name);
        let r2 = c["baseline"]["r2"].as_f64().expect("r2");
        assert!(r2 >= 0.9, "{name}: baseline R² {r2} on the other flight");
        let u = c["baseline"]["theil_u"].as_f64().expect("theil_u");
        assert!((0.0..0.1).contains(&u), "{name}: Theil U {u}");
    }
    // AND the output simulation (5 s pieces from the measured state) follows α and q with the
    // baseline models: R² ≥ 0.8, no piece diverged. Measured 0.92 (α) and 0.99 (q); gusts the
    // models do not see are the error, and a sign error in a derivative diverges within a piece.
    assert!(dir.join("pred/prediction_simulation.svg").is_file());
    let outputs = p["simulation"]["outputs"].as_array().expect("simulation outputs");
    for channel in ["Alpha", "PitchRate"] {
        let o = outputs
            .iter()
            .find(|o| o["channel"] == channel)
            .unwrap_or_else(|| panic!("{channel} not simulated: {}", p["simulation"]));
        let r2 = o["baseline"]["r2"].as_f64().expect("r2");
        assert!(r2 >= 0.8, "{channel}: simulation R² {r2}");
        assert_eq!(o["diverged"], serde_json::json!([0, 0]), "{o}");
    }
}

#[test]
fn a_flight_lacking_a_channel_lists_the_coefficients_it_cannot_predict() {
    // GIVEN the seed-2 flight without its elevator column
    let dir = fixture();
    let csv = std::fs::read_to_string(dir.join("b.csv")).expect("b.csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let drop = header
        .iter()
        .position(|h| *h == "elevator_rad")
        .expect("elevator column");
    let keep = |l: &str| {
        l.split(',')
            .enumerate()
            .filter(|(i, _)| *i != drop)
            .map(|(_, x)| x)
            .collect::<Vec<_>>()
            .join(",")
    };
    let mut cut = keep(&header.join(","));
    for l in lines {
        cut.push('\n');
        cut += &keep(l);
    }
    cut.push('\n');
    std::fs::write(dir.join("no_elevator.csv"), cut).expect("write");
    // WHEN the models predict it
    let (o, p) = predict(dir, "no_elevator.csv", "pred_no_elevator");
    // THEN the coefficients whose baseline has δe are "not predicted", the reason naming the term,
    // and the lateral ones are still predicted
    let out = text(&o.stdout);
    for name in ["C_L", "C_D", "C_m"] {
        let c = coefficient(&p, name);
        assert_eq!(c["predicted"], false, "{c}");
        assert!(c["baseline"].is_null(), "{c}");
        let reason = c["reason"].as_str().expect("reason");
        assert!(reason.contains("δe") && reason.contains("missing"), "{reason}");
        assert!(out.contains(&format!("{name:<5} not predicted: term `δe`")), "{out}");
    }
    for name in ["C_Y", "C_l", "C_n"] {
        assert_eq!(coefficient(&p, name)["predicted"], true);
    }
    // AND the simulation says why it could not run instead of simulating with half the models
    let notes = p["simulation"]["notes"].to_string();
    assert!(notes.contains("no C_m model"), "{notes}");
}

#[test]
fn a_wrong_report_or_path_is_refused_with_a_clear_error() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("predict-refused");
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let other = dir.join("quality.json");
    std::fs::write(&other, r#"{"schema": "aerosid-data-quality/1"}"#).expect("write");
    let run = |saved: &Path, with: bool| {
        let mut args = vec!["predict", "--saved", s(saved), "--data", "flight.csv", "--out", s(&dir)];
        let ac = aircraft();
        if with {
            args.extend(["--with", &ac]);
        }
        let o = aerosid(&args);
        (o.status.code(), text(&o.stderr))
    };
    // A JSON file of another schema: exit 1, the schema named and the two kinds predict reads.
    let (code, err) = run(&other, true);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("aerosid-data-quality/1") && err.contains("aerosid-gaps/3"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // A missing file: exit 1, the path named.
    let (code, err) = run(&dir.join("no-such-report.json"), true);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("no-such-report.json"), "{err}");
    // Not JSON: exit 1.
    let junk = dir.join("junk.json");
    std::fs::write(&junk, "not json").expect("write");
    let (code, err) = run(&junk, true);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("not JSON"), "{err}");
    // A gap report with a CSV flight but no --with: a usage error, exit 2.
    let report = dir.join("report.json");
    std::fs::write(&report, r#"{"schema": "aerosid-gaps/3", "coefficients": []}"#).expect("write");
    let (code, err) = run(&report, false);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("--with"), "{err}");
    // The flight's file missing: exit 1, its path named.
    let (code, err) = run(&report, true);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("flight.csv"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
