//! One coherent `aerosid gaps` report: the text (`report.txt`) and `report.json` of the vendored
//! HFB-320 and ATTAS files, a short simulated flight with a hidden effect, a clean one and a
//! pooled test card (all seeded) are checked for what a reader trips over — a "NaN" or "inf"
//! printed as an estimate, an absurd R² or coefficient, a reason given twice, a table whose
//! held-out R² is not the verdict's, sections out of order, a named cause whose `t²` is not
//! `(value/σ)²`, a diverged simulation given an R², and a report labelled by anything but its
//! data file.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// A fresh scratch folder per case.
fn scratch(case: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-coherence-{}-{case}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

fn run(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running aerosid {args:?}: {e}"));
    assert!(
        o.status.success(),
        "aerosid {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `aerosid gaps ARGS --out DIR`; the report's text and JSON.
fn gaps(case: &str, args: &[&str]) -> (String, Value) {
    let out = scratch(case);
    let mut a = vec!["gaps"];
    a.extend_from_slice(args);
    let o = out.display().to_string();
    a.extend_from_slice(&["--out", &o]);
    run(&a);
    let text = std::fs::read_to_string(out.join("report.txt")).expect("report.txt");
    let json = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).expect("report.json"))
        .expect("report.json parses");
    (text, json)
}

/// "inf" as a word of its own (not inside "information" or "influence").
fn has_inf_token(s: &str) -> bool {
    let b = s.as_bytes();
    s.match_indices("inf").any(|(i, _)| {
        let before = i.checked_sub(1).map(|j| b[j]);
        let after = b.get(i + 3).copied();
        !before.is_some_and(|c| c.is_ascii_alphabetic()) && !after.is_some_and(|c| c.is_ascii_alphabetic())
    })
}

/// Every string of a JSON document.
fn strings<'a>(v: &'a Value, out: &mut Vec<&'a str>) {
    match v {
        Value::String(s) => out.push(s),
        Value::Array(a) => a.iter().for_each(|x| strings(x, out)),
        Value::Object(m) => m.values().for_each(|x| strings(x, out)),
        _ => {}
    }
}

/// Every object of a JSON document that has both `value` and `sigma`: an estimate.
fn estimates<'a>(v: &'a Value, out: &mut Vec<&'a Value>) {
    match v {
        Value::Array(a) => a.iter().for_each(|x| estimates(x, out)),
        Value::Object(m) => {
            if m.contains_key("value") && m.contains_key("sigma") {
                out.push(v);
            }
            m.values().for_each(|x| estimates(x, out));
        }
        _ => {}
    }
}

/// Largest magnitude a coefficient estimate or an R² may have in a report: a coefficient of a
/// small aircraft's aerodynamics is of order 1–100 (a rate derivative per normalised rate); an
/// R² below −10⁶ says only that the figure means nothing.
const ABSURD: f64 = 1e6;

/// The held-out R² figures (baseline, extended) of a coefficient's row in the text's table.
fn table_r2(text: &str, coef: &str) -> (String, String) {
    let sec = &text[text.find("\n2. coefficients").expect("section 2")..];
    let row = sec
        .lines()
        .find(|l| l.split_whitespace().next() == Some(coef))
        .unwrap_or_else(|| panic!("{coef} has a row in the table"));
    let mut f = row.split_whitespace();
    f.next();
    (f.next().unwrap_or("").to_string(), f.next().unwrap_or("").to_string())
}

/// The held-out R² figures a coefficient's verdict line quotes.
fn verdict_r2(text: &str, coef: &str) -> Vec<String> {
    let sec = &text[text.find("   verdicts:").expect("the verdicts")..];
    let line = sec
        .lines()
        .find(|l| l.split_whitespace().next() == Some(coef))
        .unwrap_or_else(|| panic!("{coef} has a verdict"));
    let Some(at) = line.find("held-out R² ") else {
        return Vec::new();
    };
    let rest = &line[at + "held-out R² ".len()..];
    rest[..rest.find(')').unwrap_or(rest.len())]
        .split([' ', ',', ':'])
        .filter(|w| w.parse::<f64>().is_ok() || *w == "–")
        .take(2)
        .map(str::to_string)
        .collect()
}

fn check(case: &str, text: &str, json: &Value, stem: &str) {
    let ctx = |what: &str| format!("{case}: {what}\n--- report.txt ---\n{text}");
    // No NaN or inf printed.
    assert!(!text.contains("NaN"), "{}", ctx("NaN in the text"));
    assert!(!has_inf_token(text), "{}", ctx("inf in the text"));
    let mut ss = Vec::new();
    strings(json, &mut ss);
    for s in &ss {
        assert!(
            !s.contains("NaN") && !has_inf_token(s),
            "{}",
            ctx(&format!("NaN/inf in a JSON string: {s}"))
        );
    }
    // An estimate is a value with a finite σ, or null with a reason.
    let mut es = Vec::new();
    estimates(json, &mut es);
    assert!(!es.is_empty(), "{}", ctx("no estimate in report.json"));
    for e in es {
        match (e["value"].as_f64(), e["sigma"].as_f64()) {
            (Some(v), Some(s)) => {
                assert!(v.abs() < ABSURD, "{}", ctx(&format!("absurd estimate {e}")));
                assert!(s.is_finite() && s >= 0.0, "{}", ctx(&format!("bad σ {e}")));
            }
            (Some(_), None) => panic!("{}", ctx(&format!("an estimate without σ shown as a number: {e}"))),
            (None, _) => {}
        }
    }
    // R² figures within reason; every simulated output with a diverged piece has none.
    for c in json["coefficients"].as_array().expect("coefficients") {
        for k in ["cv_r2_baseline", "cv_r2_extended"] {
            if let Some(r2) = c[k].as_f64() {
                assert!(r2.abs() < ABSURD && r2 <= 1.0, "{}", ctx(&format!("{k} {r2}")));
            }
        }
    }
    for o in json["simulation"]["outputs"].as_array().expect("simulation outputs") {
        for (w, m) in ["baseline", "extended"].iter().enumerate() {
            let diverged = o["diverged"][w].as_u64().expect("diverged count") > 0;
            let r2 = o[m]["r2"].as_f64();
            if diverged {
                assert!(r2.is_none(), "{}", ctx(&format!("diverged output with an R²: {o}")));
                assert!(text.contains("diverged at t = "), "{}", ctx("a divergence not said"));
            } else if let Some(r2) = r2 {
                assert!(r2.abs() < ABSURD, "{}", ctx(&format!("simulation R² {r2}")));
            }
        }
    }
    // Sections 1–4, once each, in order.
    let at: Vec<usize> = [
        "\n1. data compatibility",
        "\n2. coefficients",
        "\n3. simulation",
        "\n4. verdict",
    ]
    .iter()
    .map(|h| {
        assert_eq!(text.matches(h).count(), 1, "{}", ctx(&format!("section {h:?} once")));
        text.find(h).unwrap_or(0)
    })
    .collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{}", ctx("sections in order"));
    // Every no-verdict reason once in the text, once in `reasons`.
    let reasons: Vec<&str> = json["reasons"]
        .as_array()
        .expect("reasons")
        .iter()
        .filter_map(Value::as_str)
        .collect();
    for (k, r) in reasons.iter().enumerate() {
        assert_eq!(
            text.matches(r).count(),
            1,
            "{}",
            ctx(&format!("reason once in the text: {r}"))
        );
        assert!(
            !reasons[..k].contains(r),
            "{}",
            ctx(&format!("reason twice in JSON: {r}"))
        );
    }
    // No note twice.
    let notes: Vec<&str> = text.lines().filter(|l| l.starts_with("note: ")).collect();
    for (k, n) in notes.iter().enumerate() {
        assert!(!notes[..k].contains(n), "{}", ctx(&format!("note twice: {n}")));
    }
    // One held-out R² per coefficient: the table's, the verdict's and the JSON's agree.
    for c in json["coefficients"].as_array().expect("coefficients") {
        let name = c["name"].as_str().expect("name");
        let fmt = |k: &str| c[k].as_f64().map_or("–".to_string(), |x| format!("{x:.3}"));
        let (tb, te) = table_r2(text, name);
        assert_eq!(
            (tb.as_str(), te.as_str()),
            (fmt("cv_r2_baseline").as_str(), fmt("cv_r2_extended").as_str()),
            "{}",
            ctx(&format!("{name}: table vs JSON"))
        );
        let v = verdict_r2(text, name);
        if let Some(b) = v.first() {
            assert_eq!(
                b,
                &tb,
                "{}",
                ctx(&format!("{name}: verdict's baseline R² vs the table's"))
            );
        }
        if let Some(e) = v.get(1) {
            assert_eq!(
                e,
                &te,
                "{}",
                ctx(&format!("{name}: verdict's extended R² vs the table's"))
            );
        }
    }
    // A named cause's t² is (value/σ)² of the estimate beside it.
    for n in json["named"].as_array().expect("named") {
        if let (Some(t2), Some(v), Some(s)) = (n["t2"].as_f64(), n["value"].as_f64(), n["sigma"].as_f64()) {
            let want = (v / s).powi(2);
            assert!(
                (t2 - want).abs() <= 1e-9 * want.max(1.0),
                "{}",
                ctx(&format!("named t² {t2} vs (value/σ)² {want}: {n}"))
            );
        }
    }
    // Labelled by the data file.
    assert_eq!(json["label"].as_str(), Some(stem), "{}", ctx("label"));
    assert_eq!(
        text.lines().next(),
        Some(format!("model-gap analysis — {stem}").as_str()),
        "{}",
        ctx("the first line names the data file")
    );
}

/// A vendored flight-test file with its column map (`tool/data/flight`, `tool/data/maps`).
fn vendored(case: &str, file: &str, map: &str) {
    let d = data();
    let (t, j) = gaps(
        case,
        &[
            "--data",
            &d.join("flight").join(file).display().to_string(),
            "--with",
            &d.join("maps").join(map).display().to_string(),
        ],
    );
    let stem = Path::new(file).file_stem().expect("a file name").to_string_lossy();
    check(case, &t, &j, &stem);
}

#[test]
fn hfb320_report_is_coherent() {
    vendored("hfb320", "hfb320_1_10.asc", "hfb320.map");
}

#[test]
fn attas_report_is_coherent() {
    vendored("attas", "fAttasElv1_pqrDot.asc", "attas.map");
}

#[test]
fn simulated_reports_are_coherent() {
    let (t, j) = gaps("clean", &["--clean", "--seconds", "60", "--seed", "2"]);
    let label = j["source"].as_str().expect("source").to_string();
    check("clean", &t, &j, &label);
    let (t, j) = gaps(
        "edrag",
        &["--simulate", "elevator-drag", "--seconds", "60", "--seed", "2"],
    );
    let label = j["source"].as_str().expect("source").to_string();
    check("elevator-drag", &t, &j, &label);
}

#[test]
fn pooled_card_report_is_coherent() {
    let card = scratch("card");
    run(&[
        "card",
        "--out",
        &card.display().to_string(),
        "--effect",
        "lift-quadratic",
        "--seed",
        "3",
    ]);
    let mut files: Vec<String> = std::fs::read_dir(&card)
        .expect("card folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .map(|p| p.display().to_string())
        .collect();
    files.sort();
    let aircraft = std::fs::read_dir(&card)
        .expect("card folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "aircraft"))
        .expect("the card's aircraft file");
    let stems: Vec<String> = files
        .iter()
        .map(|f| Path::new(f).file_stem().expect("stem").to_string_lossy().into_owned())
        .collect();
    let mut args: Vec<&str> = vec!["--data"];
    args.extend(files.iter().map(String::as_str));
    let ac = aircraft.display().to_string();
    args.extend(["--with", &ac]);
    let (t, j) = gaps("pooled", &args);
    check("pooled card", &t, &j, &stems.join(", "));
}
