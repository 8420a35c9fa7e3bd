//! Pooled manoeuvres (`aerosid gaps` with several `--data` or `--segment`): short manoeuvres cut
//! from simulated flights with and without a hidden effect, analysed together with the held-out
//! data whole manoeuvres and each added term's estimates tested for agreement across them.

use aerosid::gaps::hidden::{self, HiddenEffect, HiddenKind};
use aerosid::gaps::model::CauseKind;
use aerosid::gaps::{predict, report, run_gaps, GapReport, GapSettings};
use aerosid::io::measured::MeasuredFlight;

/// Manoeuvres of `len_s` seconds cut from a simulated flight of `n · (len_s + 1)` seconds, one
/// second skipped between them (so no two are contiguous), each named as its own file.
fn manoeuvres(effect: Option<&HiddenEffect>, seed: u64, n: usize, len_s: f64) -> Vec<(MeasuredFlight, String)> {
    let flight = hidden::flight(effect, n as f64 * (len_s + 1.0), seed, true).expect("the simulator flies");
    (0..n)
        .map(|k| {
            let from = k as f64 * (len_s + 1.0);
            let mut m = flight.window(from, from + len_s).expect("inside the flight");
            m.source = format!("manoeuvre_{k:02}.csv");
            (m, "the file's start".to_string())
        })
        .collect()
}

fn settings(effect: Option<&HiddenEffect>) -> GapSettings {
    GapSettings {
        baseline: Some(HiddenEffect::baseline(effect)),
        ..GapSettings::default()
    }
}

fn analyse(parts: Vec<(MeasuredFlight, String)>, effect: Option<&HiddenEffect>) -> GapReport {
    let pooled = MeasuredFlight::pool(parts).expect("the manoeuvres pool");
    run_gaps(&pooled, &settings(effect)).expect("the analysis runs")
}

fn summary(r: &GapReport) -> String {
    let mut s = format!("verdict: {}\n", r.verdict);
    for c in &r.named {
        s.push_str(&format!(
            "named {} {} {} = {} ± {}\n",
            c.location, c.what, c.t2, c.value, c.sigma
        ));
    }
    for c in &r.coefficients {
        for h in &c.homogeneity {
            s.push_str(&format!("{} {}: {}\n", c.name, h.term, h.reason));
        }
        s.push_str(&format!("{}: {}\n", c.name, c.verdict));
    }
    s
}

fn lift_quadratic() -> HiddenEffect {
    HiddenEffect {
        kind: HiddenKind::LiftQuadratic,
        size: -8.0,
        channel: None,
    }
}

/// Eight manoeuvres of 10 s with a lift-curve nonlinearity: named, in C_L, its per-manoeuvre
/// estimates agreeing; the held-out data are whole manoeuvres. The size (−8 /rad², inside the
/// campaign's range) is a clear case: this checks the pooled path end to end, the detection
/// rates belong to the benchmark.
#[test]
fn pooled_manoeuvres_name_a_planted_lift_nonlinearity_and_predict_takes_the_report() {
    let effect = lift_quadratic();
    let r = analyse(manoeuvres(Some(&effect), 3, 8, 10.0), Some(&effect));
    let s = summary(&r);
    assert_eq!(r.manoeuvres.len(), 8, "{s}");
    let top = r.top_cause().unwrap_or_else(|| panic!("nothing named:\n{s}"));
    assert_eq!(
        (top.kind, top.location.as_str()),
        (CauseKind::NonlinearAlpha, "C_L"),
        "{s}"
    );
    let cl = r.coefficients.iter().find(|c| c.name == "C_L").expect("C_L analysed");
    let h = cl
        .homogeneity
        .iter()
        .find(|h| h.term == top.what)
        .expect("its homogeneity test");
    assert!(h.agrees && h.per_manoeuvre.len() >= 2, "{s}");
    // Held out: whole manoeuvres after the identification split, and every manoeuvre excites
    // some baseline regressor.
    assert!(r.manoeuvres.iter().any(|m| m.identification) && r.manoeuvres.iter().any(|m| !m.identification));
    assert!(r.manoeuvres.iter().all(|m| !m.excites.is_empty()), "{s}");
    let json = report::json(&r);
    assert_eq!(json["manoeuvres"].as_array().map(Vec::len), Some(8));
    assert!(json["coefficients"][0]["homogeneity"].is_array());
    // The pooled report's models applied to another flight.
    let dir = std::env::temp_dir().join(format!("aerosid-pooled-{}", std::process::id()));
    report::write(&r, &dir).expect("report written");
    let saved = predict::read_report(&dir.join("report.json")).expect("a pooled report reads");
    let other = hidden::flight(Some(&effect), 40.0, 11, true).expect("the simulator flies");
    let (p, ..) = predict::run(&saved, &other, &dir.join("predict")).expect("predict runs");
    assert!(!p.coefficients.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same campaign without a hidden effect names nothing.
#[test]
fn a_clean_pooled_campaign_names_nothing() {
    let r = analyse(manoeuvres(None, 5, 8, 10.0), None);
    assert!(r.named.is_empty(), "{}", summary(&r));
}

/// One short manoeuvre alone gets no verdict, and says why.
#[test]
fn one_manoeuvre_alone_gives_no_verdict_with_the_reason() {
    let mut parts = manoeuvres(Some(&lift_quadratic()), 3, 1, 10.0);
    parts.truncate(1);
    let r = analyse(parts, Some(&lift_quadratic()));
    assert!(r.named.is_empty(), "{}", summary(&r));
    assert!(
        r.verdict.starts_with("no verdict: ") && r.verdict.len() > 20,
        "{}",
        r.verdict
    );
}

/// The files' order does not matter: the same report, bit for bit.
#[test]
fn the_order_of_the_files_does_not_change_the_report() {
    let effect = lift_quadratic();
    let parts = manoeuvres(Some(&effect), 3, 6, 10.0);
    let mut shuffled = parts.clone();
    shuffled.reverse();
    shuffled.swap(0, 2);
    let (a, b) = (analyse(parts, Some(&effect)), analyse(shuffled, Some(&effect)));
    assert_eq!(a.named, b.named);
    assert_eq!(report::json(&a).to_string(), report::json(&b).to_string());
}

/// A record whose time jumps is cut there, and the cut says where; pieces of another rate are
/// refused with the file named.
#[test]
fn a_time_jump_splits_a_record_and_a_rate_mismatch_is_refused() {
    let flight = hidden::flight(None, 20.0, 2, true).expect("the simulator flies");
    let (a, b) = (flight.window(0.0, 8.0).unwrap(), flight.window(10.0, 20.0).unwrap());
    let mut spliced = a.clone();
    spliced.t_s.extend(&b.t_s);
    for (q, v) in spliced.channels.iter_mut() {
        v.extend(b.get(*q).unwrap());
    }
    let pieces = spliced.split_at_jumps();
    assert_eq!(pieces.len(), 2);
    assert_eq!(pieces[0].0.len(), a.len());
    assert!(pieces[1].1.contains("time jump from"), "{}", pieces[1].1);
    let pooled = MeasuredFlight::pool(pieces).unwrap();
    assert_eq!(pooled.pieces().len(), 2);
    assert_eq!(pooled.pieces()[1].span_s[0], b.t_s[0]);
    let mut slow = b.block_means(2);
    slow.source = "slow.csv".into();
    let e = MeasuredFlight::pool(vec![(a, String::new()), (slow, String::new())]).unwrap_err();
    assert!(e.contains("slow.csv") && e.contains("step"), "{e}");
}

/// The command line: the ATTAS book case's three manoeuvre files (aileron, elevator, rudder)
/// pooled, given in two orders, write the same report.json byte for byte; `--segment` cuts a file
/// into manoeuvres the report lists.
#[test]
fn the_command_pools_files_in_any_order_and_cuts_segments() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let file = |n: &str| data.join("flight").join(n).display().to_string();
    let (ail, elv, rud) = (
        file("fAttasAil1_pqrDot.asc"),
        file("fAttasElv1_pqrDot.asc"),
        file("fAttasRud1_pqrDot.asc"),
    );
    let map = data.join("maps/attas.map").display().to_string();
    let tmp = std::env::temp_dir().join(format!("aerosid-pooled-cli-{}", std::process::id()));
    let run = |files: [&str; 3], out: &str| -> Vec<u8> {
        let dir = tmp.join(out);
        let mut args = vec!["gaps".to_string()];
        for f in files {
            args.extend(["--data".into(), f.to_string()]);
        }
        args.extend(["--with".into(), map.clone(), "--out".into(), dir.display().to_string()]);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
            .args(&args)
            .output()
            .expect("aerosid runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(dir.join("report.json")).expect("report.json written")
    };
    let a = run([&ail, &elv, &rud], "a");
    let b = run([&rud, &ail, &elv], "b");
    assert!(a == b, "report.json differs with the order of the files");
    let v: serde_json::Value = serde_json::from_slice(&a).expect("JSON");
    assert_eq!(v["manoeuvres"].as_array().map(Vec::len), Some(3));
    // Two segments of one file, given late first: two manoeuvres, in time order.
    let dir = tmp.join("segments");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args([
            "gaps",
            "--data",
            &ail,
            "--with",
            &map,
            "--segment",
            "15:28",
            "--segment",
            "0:12",
        ])
        .args(["--out", &dir.display().to_string()])
        .output()
        .expect("aerosid runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
    let m = v["manoeuvres"].as_array().expect("manoeuvres");
    assert_eq!(m.len(), 2);
    assert_eq!(m[0]["cut"], "--segment 0:12");
    assert!(m[0]["span_s"][0].as_f64() < m[1]["span_s"][0].as_f64());
    let _ = std::fs::remove_dir_all(&tmp);
}

/// A test card's estimated β errs by about as much as the manoeuvres move it (docs/test-card.md,
/// "Errors in variables of the estimated angles"): the report states no value and no σ for the
/// β terms, says why, keeps the other terms' estimates, and its saved report still predicts.
#[test]
fn on_a_card_the_estimated_beta_terms_are_not_identifiable_and_predict_takes_the_report() {
    use aerosid::card::{write_card, CardSettings, AIRCRAFT_FILE};
    use aerosid::sim::test_card::CardTurbulence;
    let dir = std::env::temp_dir().join(format!("aerosid-pooled-card-{}", std::process::id()));
    let card = CardSettings {
        effect: None,
        seed: 1,
        turbulence: CardTurbulence::Light,
    };
    let csvs: Vec<_> = write_card(&dir, &card)
        .expect("the card is flown and written")
        .into_iter()
        .filter(|f| f.extension().is_some_and(|x| x == "csv"))
        .collect();
    let flight = aerosid::io::read_pooled(
        &csvs,
        Some(&dir.join(AIRCRAFT_FILE)),
        &[],
        &aerosid::io::ReadOptions::default(),
    )
    .expect("the card reads back");
    let r = run_gaps(&flight, &GapSettings::default()).expect("the analysis runs");
    let s = summary(&r);
    for c in ["C_Y", "C_l", "C_n"] {
        let fit = &r.coefficients.iter().find(|x| x.name == c).expect("analysed").baseline;
        let beta = fit.parameters.iter().find(|p| p.term == "β").expect("a β term");
        assert!(beta.sigma.is_nan(), "{c}: β {} ± {}\n{s}", beta.value, beta.sigma);
        assert!(
            r.notes
                .iter()
                .any(|n| n.starts_with(&format!("{c}: the β term is not identifiable"))),
            "{c}: {:#?}",
            r.notes
        );
        // The other terms keep an estimate.
        assert!(
            fit.parameters
                .iter()
                .filter(|p| p.term != "β")
                .all(|p| p.sigma.is_finite()),
            "{c}: {:?}",
            fit.parameters
        );
    }
    let json = report::json(&r);
    let cy = json["coefficients"]
        .as_array()
        .and_then(|a| a.iter().find(|c| c["name"] == "C_Y"))
        .expect("C_Y");
    let beta = cy["baseline"]["parameters"]
        .as_array()
        .and_then(|a| a.iter().find(|p| p["term"] == "β"))
        .expect("β");
    assert!(beta["value"].is_null() && beta["fit_value"].is_number(), "{beta}");
    report::write(&r, &dir.join("gaps")).expect("report written");
    let saved = predict::read_report(&dir.join("gaps").join("report.json")).expect("the card's report reads");
    let (p, ..) = predict::run(&saved, &flight, &dir.join("predict")).expect("predict runs");
    assert!(!p.coefficients.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}
