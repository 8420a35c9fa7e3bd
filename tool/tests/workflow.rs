//! The researcher's workflow: a model read from a TOML file run in the core's filter error method,
//! fixed parameters, pooled segments, validation, saved models applied to other data
//! (`aerosid fem`, `aerosid predict`), and the refusal of bad files.

use aerosid::fem_report::{hfb320_filter, hfb320_rows, step_data, PUBLISHED, START};
use aerosid::usermodel::UserModel;
use aerosid::workflow::{fit_metrics, identify, read_segments, run_fem, run_predict, simulate, FemArgs, SavedModel};
use aerosid_core::fem::Sensitivity;
use std::path::{Path, PathBuf};

fn models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models")
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../target/workflow-tests")
        .join(name);
    std::fs::create_dir_all(&d).expect("scratch folder");
    d
}

fn hfb320_model() -> UserModel {
    UserModel::read(&models().join("hfb320.toml")).expect("hfb320.toml")
}

#[test]
fn hfb320_model_file_reproduces_the_compiled_model() {
    // GIVEN models/hfb320.toml (the README's model written as equations) and its data file,
    // found relative to the model file's folder
    let model = hfb320_model();
    let data = model.default_data().expect("[data] file");
    assert_eq!(data, models().join("../data/flight/hfb320_1_10.asc"));
    let segs = read_segments(&model, &data, &[]).expect("data");
    assert_eq!(segs.len(), 1);
    // (its starting and reference values are the book's, as the compiled report has them)
    for (i, p) in model.file.parameters.iter().enumerate() {
        assert_eq!((p.start, p.reference), (START[i], Some(PUBLISHED[i])), "{}", p.name);
    }
    // WHEN the generic filter error method runs on it (one recursive pass, as `fem-hfb320`)
    let id = identify(&model, &segs).expect("identify");
    // and the compiled `Hfb320` model runs in the same filter
    let rows = hfb320_rows(&data).expect("rows");
    let mut fem = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    for w in rows.windows(2) {
        let (u, un, y) = step_data::<f64>(&w[0], &w[1]);
        fem.step(&u, &un, &y).expect("step");
    }
    // THEN every estimate agrees within 10⁻⁶ of its σ and every σ within 10⁻⁶ relative: the same
    // numbers `fem-hfb320` reports (tests/fem.rs: Cmq −35.49 ± 0.82, Cmα −0.994 ± 0.012). The two
    // differ only in rounding: the file's equations are evaluated by exmex in another order than
    // the compiled code, and ∂h/∂p is a central difference (exact for h linear in p up to the
    // ε^{2/3} ≈ 4·10⁻¹¹ relative rounding of the step) instead of the analytic one (measured: at
    // most 3·10⁻⁹ σ and 3·10⁻¹¹ relative in σ; the bound leaves room for another libm, not for a
    // different model).
    let (p, s) = (fem.parameters(), fem.parameter_sigma());
    let mut worst = (0.0f64, 0.0f64);
    for i in 0..11 {
        let sig = id.covariance[(i, i)].sqrt();
        let dp = (id.p[i] - p[i]).abs() / s[i];
        let ds = (sig / s[i] - 1.0).abs();
        println!(
            "{:>8}: file {:+.6} ± {:.6}, compiled {:+.6} ± {:.6} ({dp:.2e}σ, σ {ds:.2e})",
            model.file.parameters[i].name, id.p[i], sig, p[i], s[i]
        );
        worst = (worst.0.max(dp), worst.1.max(ds));
    }
    assert!(worst.0 < 1e-6 && worst.1 < 1e-6, "worst {worst:?}");
}

#[test]
fn fem_command_fixes_a_parameter_and_saves_a_model_predict_reapplies() {
    // GIVEN the HFB-320 model file with Cmq fixed at the published filter-error value
    let out = scratch("hfb320_fixed");
    let run = run_fem(&FemArgs {
        model: models().join("hfb320.toml"),
        fix: vec![("Cmq".into(), -34.7098)],
        out: out.clone(),
        ..FemArgs::default()
    })
    .expect("fem");
    println!("{}", run.text);
    // THEN Cmq is exactly that value, carries no σ, and the ten others are estimated
    let cmq = run.saved.parameters.iter().find(|p| p.name == "Cmq").expect("Cmq");
    assert!(cmq.fixed && cmq.value == -34.7098 && cmq.sigma.is_none());
    assert_eq!(run.saved.parameters.iter().filter(|p| p.sigma.is_some()).count(), 10);
    // … the saved JSON is what was returned (numbers to the last digit or two: serde_json's
    // default float parsing is not exact to the bit), and its figure was written
    let json = out.join("identification.json");
    let back: SavedModel = serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parse");
    assert_eq!(back.model_toml, run.saved.model_toml);
    for (a, b) in back.parameters.iter().zip(&run.saved.parameters) {
        assert_eq!((&a.name, a.fixed), (&b.name, b.fixed));
        assert!((a.value - b.value).abs() <= 1e-14 * b.value.abs(), "{}", a.name);
    }
    assert!(run.files.iter().all(|f| f.exists()));
    // WHEN the saved model is applied to the same record by `predict`
    let (pred, text, files) = run_predict(&json, &[], &[], &out).expect("predict");
    println!("{text}");
    // THEN it reproduces the fit the identification reported, to rounding (same simulation)
    assert!(files.iter().all(|f| f.exists()));
    for (a, b) in pred.fit.iter().zip(&run.saved.fit) {
        assert_eq!(a.name, b.name);
        assert!((a.r2 - b.r2).abs() < 1e-12 && (a.rms - b.rms).abs() <= 1e-12 * b.rms.abs().max(1.0));
    }
}

#[test]
fn twin_otter_identify_on_one_part_predict_another() {
    // GIVEN manoeuvre 018 of the Twin Otter (SIDPAC), models/twin_otter_lon.toml: a linear
    // short-period model (α, q; δe) in the matrix form, output error with the noise relaxation,
    // Zq fixed at 0
    let out = scratch("twin_otter");
    // WHEN it is identified on the first 3.5 s (the 3-2-1 part of the 3-2-1-1) and validated on
    // 3.5–8 s (the last pulses and the free response: samples it never saw)
    let run = run_fem(&FemArgs {
        model: models().join("twin_otter_lon.toml"),
        segments: vec![(0.0, 3.5)],
        validate_segments: vec![(3.5, 8.0)],
        out: out.clone(),
        ..FemArgs::default()
    })
    .expect("fem");
    println!("{}", run.text);
    assert!(run.saved.converged, "Gauss-Newton did not converge");
    // THEN the model predicts α and q on the unseen segment with R² ≥ 0.95 each: it explains
    // 95 % of the variance of a response it never saw. Measured: α 0.988, q 0.983 (on the
    // identification part 0.9994 both; RMS on the validation part 0.035° in α, 0.15 °/s in q);
    // the margin covers the open-loop start from one noisy sample and the bias drift of 4.5 s.
    let r2 = |name: &str| run.saved.validation.iter().find(|f| f.name == name).expect("output").r2;
    assert!(r2("alpha") >= 0.95, "R² alpha {}", r2("alpha"));
    assert!(r2("q") >= 0.95, "R² q {}", r2("q"));
    // … while the starting values (about 30 % off) fail it: the threshold tells a model with the
    // right dynamics from a rough one (measured: α 0.916, q 0.746)
    let start = UserModel::read(&models().join("twin_otter_lon.toml")).expect("model");
    let vsegs = read_segments(&start, &start.default_data().expect("data"), &[(3.5, 8.0)]).expect("segment");
    let sims: Vec<_> = vsegs.iter().map(|s| simulate(&start, s, run.saved.dt_s)).collect();
    let start_fit = fit_metrics(&start, &vsegs, &sims);
    println!("starting values on 3.5–8 s: {start_fit:?}");
    assert!(start_fit.iter().any(|f| f.r2 < 0.95), "{start_fit:?}");
    // … and `predict` with the saved model on that segment gives the same numbers
    let (pred, _, _) = run_predict(&out.join("identification.json"), &[], &[(3.5, 8.0)], &out).expect("predict");
    for (a, b) in pred.fit.iter().zip(&run.saved.validation) {
        assert!((a.r2 - b.r2).abs() < 1e-12, "{}: {} vs {}", a.name, a.r2, b.r2);
    }
}

#[test]
fn pooling_a_record_with_itself_keeps_the_estimate_and_halves_the_variance() {
    // GIVEN the Twin Otter record written twice into one file, the second copy 100 s later (a
    // concatenated two-manoeuvre file)
    let model = UserModel::read(&models().join("twin_otter_lon.toml")).expect("model");
    let src = model.default_data().expect("data");
    let text = std::fs::read_to_string(&src).expect("read");
    let mut doubled = text.clone();
    for line in text.lines() {
        let mut cols: Vec<String> = line.split_whitespace().map(String::from).collect();
        let t: f64 = cols[0].parse().expect("time");
        cols[0] = format!("{}", t + 100.0);
        doubled.push_str(&cols.join(" "));
        doubled.push('\n');
    }
    let file = scratch("pooling").join("twice.asc");
    std::fs::write(&file, doubled).expect("write");
    // WHEN it is read: two segments, each with its own initial state, not a refusal
    let segs = read_segments(&model, &file, &[]).expect("segments");
    assert_eq!(segs.len(), 2);
    let once = identify(&model, &segs[..1]).expect("once");
    let twice = identify(&model, &segs).expect("twice");
    // THEN the pooled estimate equals the single one within 10⁻³ σ (the same data twice: the
    // same normal equations, twice the information; the Gauss–Newton iterations stop at slightly
    // different points within their 0.01σ tolerance, hence not exact) and each variance is half
    // (the noise relaxation gives both the same R; within 2 %, the difference of the stopping
    // points)
    // AND as a validation file it is two validation segments, each scored like the one segment
    let out = scratch("pooling");
    let single = run_fem(&FemArgs {
        model: models().join("twin_otter_lon.toml"),
        segments: vec![(0.0, 3.5)],
        validate_segments: vec![(3.5, 8.0)],
        out: out.join("single"),
        ..FemArgs::default()
    })
    .expect("fem");
    let both = run_fem(&FemArgs {
        model: models().join("twin_otter_lon.toml"),
        segments: vec![(0.0, 3.5)],
        validate: vec![file.clone()],
        validate_segments: vec![(3.5, 8.0), (103.5, 108.0)],
        out: out.join("both"),
        ..FemArgs::default()
    })
    .expect("fem");
    assert_eq!(both.saved.validation_data.len(), 2);
    for (a, b) in both.saved.validation.iter().zip(&single.saved.validation) {
        assert_eq!(a.samples, 2 * b.samples);
        assert!((a.r2 - b.r2).abs() < 1e-9, "{}: {} vs {}", a.name, a.r2, b.r2);
    }
    for k in 0..model.free().len() {
        let (s1, s2) = (once.covariance[(k, k)].sqrt(), twice.covariance[(k, k)].sqrt());
        let dp = (twice.p[k] - once.p[k]).abs() / s1;
        let ratio = s2 / s1 * 2f64.sqrt();
        println!(
            "free {k}: once {:+.5} ± {s1:.5}, twice {:+.5} ± {s2:.5}",
            once.p[k], twice.p[k]
        );
        assert!(dp < 1e-3, "parameter {k}: {dp}σ");
        assert!((ratio - 1.0).abs() < 0.02, "parameter {k}: σ ratio·√2 = {ratio}");
    }
}

#[test]
fn bad_model_and_data_files_are_refused_with_the_place_and_the_fix() {
    let model = hfb320_model();
    let dir = scratch("refusals");
    // A data file with 21 instead of 20 columns on one line names the line and the setting.
    let src = std::fs::read_to_string(model.default_data().expect("data")).expect("read");
    let mut lines: Vec<String> = src.lines().map(String::from).collect();
    lines[4].push_str(" 0.0");
    let f = dir.join("extra_column.asc");
    std::fs::write(&f, lines.join("\n")).expect("write");
    let e = read_segments(&model, &f, &[]).expect_err("refused");
    assert!(e.contains(":5: 21 columns") && e.contains("data.columns = 20"), "{e}");
    // A column the model reads that is zero everywhere is a missing channel, not data.
    let zeroed: Vec<String> = src
        .lines()
        .map(|l| {
            let mut c: Vec<&str> = l.split_whitespace().collect();
            c[5] = "0";
            c.join(" ")
        })
        .collect();
    let f = dir.join("zero_alpha.asc");
    std::fs::write(&f, zeroed.join("\n")).expect("write");
    let e = read_segments(&model, &f, &[]).expect_err("refused");
    assert!(e.contains("column 6 (output alpha) is zero on every line"), "{e}");
    // An equation naming something undefined names the field.
    let text = model
        .text
        .replace("\"qbar*SCoIy*Cm + kF*F\"", "\"qbar*SCoIy*Cm + kT*F\"");
    let e = UserModel::parse(&text, Path::new("m.toml")).expect_err("refused");
    assert!(
        e.0.contains("m.toml: definitions.qdot") && e.0.contains("`kT`"),
        "{}",
        e.0
    );
    // An unknown key is refused by name (a typo is not silently ignored).
    let text = model
        .text
        .replace("process_noise = 0.358553", "proces_noise = 0.358553");
    let e = UserModel::parse(&text, Path::new("m.toml")).expect_err("refused");
    assert!(e.0.contains("proces_noise"), "{}", e.0);
    // The noise relaxation belongs to the output error method only.
    let text = model.text.replace(
        "prior_sigma_floor = 0.05",
        "prior_sigma_floor = 0.05\nestimate_noise = true",
    );
    let e = UserModel::parse(&text, Path::new("m.toml")).expect_err("refused");
    assert!(
        e.0.contains("estimation.estimate_noise") && e.0.contains("output-error"),
        "{}",
        e.0
    );
    // Fixing a parameter the model does not have lists those it has.
    let mut m = hfb320_model();
    let e = m.fix("Cmdelta", 1.0).expect_err("refused");
    assert!(
        e.0.contains("`Cmdelta` is not a parameter") && e.0.contains("Cmde"),
        "{}",
        e.0
    );
    // A segment outside the record says where the record is.
    let e = read_segments(&model, &model.default_data().expect("data"), &[(100.0, 120.0)]).expect_err("refused");
    assert!(e.contains("no samples") && e.contains("0 to 60.000 s"), "{e}");
}

#[test]
fn cli_fem_then_predict_on_the_twin_otter() {
    // GIVEN the `aerosid` binary, WHEN `fem` identifies on 0–3.5 s and `predict` applies the saved
    // model to 3.5–8 s
    let out = scratch("cli");
    let exe = env!("CARGO_BIN_EXE_aerosid");
    let model = models().join("twin_otter_lon.toml");
    let fem = std::process::Command::new(exe)
        .args(["fem", "--model"])
        .arg(&model)
        .args(["--segment", "0:3.5", "--validate-segment", "3.5:8", "--out"])
        .arg(&out)
        .output()
        .expect("run aerosid fem");
    let text = String::from_utf8_lossy(&fem.stdout);
    println!("{text}{}", String::from_utf8_lossy(&fem.stderr));
    assert!(fem.status.success());
    let saved = out.join("identification.json");
    let predict = std::process::Command::new(exe)
        .args(["predict", "--saved"])
        .arg(&saved)
        .args(["--segment", "3.5:8", "--out"])
        .arg(&out)
        .output()
        .expect("run aerosid predict");
    println!("{}", String::from_utf8_lossy(&predict.stdout));
    // THEN both succeed and write their JSON and figures, and the prediction's table is the
    // validation table of `fem`
    assert!(predict.status.success(), "{}", String::from_utf8_lossy(&predict.stderr));
    for f in [
        "identification.json",
        "identification_fit.svg",
        "validation_fit.svg",
        "prediction.json",
        "prediction.svg",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    let rows = |t: &str, after: &str| -> Vec<String> {
        t.lines()
            .skip_while(|l| !l.starts_with(after))
            .skip(2)
            .take(2)
            .map(String::from)
            .collect()
    };
    let p = String::from_utf8_lossy(&predict.stdout).to_string();
    assert_eq!(
        rows(&text, "simulation on the validation data:"),
        rows(&p, "simulation:")
    );
    // AND a malformed flag is refused with the fix, exit code 2
    let bad = std::process::Command::new(exe)
        .args(["fem", "--model"])
        .arg(&model)
        .args(["--fix", "Mq"])
        .output()
        .expect("run");
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("NAME=VALUE"));
}

#[test]
fn hfb320_model_file_gauss_newton_matches_the_compiled_batch() {
    // GIVEN hfb320.toml switched to Gauss–Newton iterations, and the compiled model's batch
    // (`fem_batch::gauss_newton`, the `variants` row "Rk4, input Linear, batch Gauss-Newton"),
    // both from the book's starting values with the same prior, 0.01σ tolerance, at most 20 passes
    let text = hfb320_model()
        .text
        .replace("iteration = \"recursive\"", "iteration = \"gauss-newton\"");
    let model = UserModel::parse(&text, &models().join("hfb320.toml")).expect("model");
    let data = model.default_data().expect("data");
    let segs = read_segments(&model, &data, &[]).expect("segments");
    // WHEN both run
    let id = identify(&model, &segs).expect("identify");
    let rows = hfb320_rows(&data).expect("rows");
    let fem = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    let steps: Vec<_> = rows.windows(2).map(|w| step_data::<f64>(&w[0], &w[1])).collect();
    let start = aerosid::fem_batch::StateStart {
        model: *fem.model(),
        settings: *fem.settings(),
        x0: *fem.state(),
        p_x0: *fem.state_covariance(),
    };
    let (p0, c0) = (*fem.parameters(), *fem.parameter_covariance());
    let fit = aerosid::fem_batch::gauss_newton(&start, &p0, &p0, &c0, &steps, 20, 0.01).expect("batch");
    // THEN both converge after the same number of passes to the same estimate: within 10⁻⁶ σ
    // (the rounding budget of the recursive comparison above, not compounded by the passes:
    // each pass starts from the previous estimate, which agrees to that order; measured 6·10⁻⁹ σ
    // after 4 passes)
    assert!(id.converged && fit.converged);
    assert_eq!(id.iterations, fit.iterates.len());
    let s = fit.sigma();
    let worst = (0..11).map(|i| (id.p[i] - fit.p[i]).abs() / s[i]).fold(0.0, f64::max);
    println!("{} passes; worst {worst:.2e}σ", id.iterations);
    assert!(worst < 1e-6, "worst {worst:e}σ");
}

/// Runs `aerosid` with `args` in `cwd`; its stdout, or a panic with both streams.
fn aerosid_in(cwd: &Path, args: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("run aerosid");
    let (o, e) = (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "aerosid {args:?} in {}:\n{o}\n{e}", cwd.display());
    o
}

#[test]
fn a_model_naming_channels_reads_what_gaps_reads_and_matches_the_column_model() {
    // GIVEN the Twin Otter short-period model twice: by column numbers of the ASCII file
    // (twin_otter_lon.toml) and by channel names, the file read through its column map
    // (twin_otter_lon_channels.toml), which converts degrees with the same factor π/180
    let out = scratch("channels");
    let by_column = run_fem(&FemArgs {
        model: models().join("twin_otter_lon.toml"),
        segments: vec![(0.0, 3.5)],
        validate_segments: vec![(3.5, 8.0)],
        out: out.join("columns"),
        ..FemArgs::default()
    })
    .expect("fem by column");
    let by_name = run_fem(&FemArgs {
        model: models().join("twin_otter_lon_channels.toml"),
        segments: vec![(0.0, 3.5)],
        validate_segments: vec![(3.5, 8.0)],
        out: out.join("names"),
        ..FemArgs::default()
    })
    .expect("fem by channel");
    println!("{}", by_name.text);
    // THEN the estimates, their σ and the validation fit are the same to the last bit: the same
    // numbers reach the filter by either path (the map's unit factor is the model's scale, both
    // multiply the column once)
    for (a, b) in by_name.saved.parameters.iter().zip(&by_column.saved.parameters) {
        assert_eq!((&a.name, a.value, a.sigma), (&b.name, b.value, b.sigma));
    }
    for (a, b) in by_name.saved.validation.iter().zip(&by_column.saved.validation) {
        assert_eq!((a.r2, a.rms), (b.r2, b.rms), "{}", a.name);
    }
    // … and through the `.mat` file of the same manoeuvre, read with the same map, the estimates
    // agree within 10⁻⁶ σ: the text export has 10 significant digits, the `.mat` full doubles, a
    // 5·10⁻¹⁰ relative difference in the data (measured: 1.4·10⁻⁸ σ at most, in Z0)
    let mat = run_fem(&FemArgs {
        model: models().join("twin_otter_lon_channels.toml"),
        data: vec![models().join("../data/flight/totter_lon_020213f1_018.mat")],
        with: Some(models().join("../data/maps/twin_otter.map")),
        segments: vec![(0.0, 3.5)],
        out: out.join("mat"),
        ..FemArgs::default()
    })
    .expect("fem on .mat");
    for (a, b) in mat.saved.parameters.iter().zip(&by_column.saved.parameters) {
        if let Some(s) = b.sigma {
            assert!(
                (a.value - b.value).abs() < 1e-6 * s,
                "{}: {} vs {} ± {s}",
                a.name,
                a.value,
                b.value
            );
        }
    }
}

#[test]
fn a_project_csv_with_more_columns_than_the_model_uses_and_csv_names() {
    // GIVEN manoeuvre 018 written as a project CSV (header, SI units) with more columns than the
    // model reads, and the Twin Otter's aircraft file
    let dir = scratch("csv");
    let flight = aerosid::io::read_measured(
        &models().join("../data/flight/totter_lon_020213f1_018_fdata.asc"),
        &models().join("../data/maps/twin_otter.map"),
    )
    .expect("read");
    use aerosid::io::measured::Quantity::{Airspeed, Alpha, Beta, Elevator, PitchRate};
    let qs = [Alpha, PitchRate, Elevator, Beta, Airspeed];
    let mut csv = String::from("t_s,alpha_rad,gyro_rad_s_y,elevator_rad,beta_rad,airspeed_mps\n");
    for k in 0..flight.len() {
        csv.push_str(&format!("{:e}", flight.t_s[k]));
        for q in qs {
            csv.push_str(&format!(",{:e}", flight.get(q).expect("channel")[k]));
        }
        csv.push('\n');
    }
    let data = dir.join("to018.csv");
    std::fs::write(&data, csv).expect("write");
    // … and the channel model with its outputs named as the CSV's columns
    let text = std::fs::read_to_string(models().join("twin_otter_lon_channels.toml"))
        .expect("model")
        .replace("channel = \"pitch_rate\"", "channel = \"gyro_rad_s_y\"")
        .replace("channel = \"alpha\"", "channel = \"alpha_rad\"");
    let model_path = models().join("twin_otter_lon_csv_test.toml");
    let model = UserModel::parse(&text, &model_path).expect("model");
    // WHEN its segments are read from the CSV with the aircraft file, and from the ASCII file
    // through the map
    let aircraft = models().join("../data/aircraft/twin_otter.aircraft");
    let from_csv = aerosid::workflow::read_segments_with(&model, &data, Some(&aircraft), &[(0.0, 3.5)]).expect("csv");
    let from_asc = read_segments(&model, &model.default_data().expect("data"), &[(0.0, 3.5)]).expect("asc");
    // THEN they are the same numbers (the CSV holds the shortest round-trip text of each double)
    assert_eq!(from_csv.len(), 1);
    assert_eq!(from_csv[0].t_s, from_asc[0].t_s);
    assert_eq!(from_csv[0].u, from_asc[0].u);
    assert_eq!(from_csv[0].y, from_asc[0].y);
    // … and a channel the data lack is named, with what they have and the fix
    let text = text.replace("channel = \"elevator\"", "channel = \"rudder\"");
    let model = UserModel::parse(&text, &model_path).expect("model");
    let e = aerosid::workflow::read_segments_with(&model, &data, Some(&aircraft), &[]).expect_err("no rudder");
    assert!(
        e.contains("no `rudder` channel") && e.contains("elevator") && e.contains("to018.csv"),
        "{e}"
    );
}

#[test]
fn derived_inputs_combine_channels_or_columns_as_maps_do() {
    // GIVEN the Twin Otter through its map, where `thrust` is left + right engine and
    // `thrust_difference` left − right (columns 38 and 39, lbf)
    let asc = models().join("../data/flight/totter_lon_020213f1_018_fdata.asc");
    let base = std::fs::read_to_string(models().join("twin_otter_lon_channels.toml")).expect("model");
    // WHEN a model's input is the left engine, (thrust + thrust_difference)/2 written as a map
    // writes it, in lbf
    let lbf = 0.453_592_37 * 9.806_65;
    let text = base.replace(
        "channel = \"elevator\"",
        &format!(
            "channel = \"0.5*thrust + 0.5*thrust_difference\"\nscale = {:e}",
            1.0 / lbf
        ),
    );
    let model = UserModel::parse(&text, &models().join("derived.toml")).expect("model");
    let segs = read_segments(&model, &asc, &[]).expect("segments");
    // THEN it is column 38 to rounding (10⁻¹² relative: a sum, a halving and two unit factors)
    let raw: Vec<f64> = std::fs::read_to_string(&asc)
        .expect("asc")
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .nth(37)
                .expect("column 38")
                .parse()
                .expect("number")
        })
        .collect();
    assert_eq!(segs[0].u.len(), raw.len());
    for (u, r) in segs[0].u.iter().zip(&raw) {
        assert!((u[0] - r).abs() <= 1e-12 * r.abs().max(1.0), "{} vs {r}", u[0]);
    }
    // AND in a file read by column number, δe = ($14 − $90)/2 with column 90 set to −δe is δe
    // itself (the form of δa = (δa_R − δa_L)/2; halving and adding halves are exact in binary), so
    // the identification is that of the column model to the last bit
    let dir = scratch("derived");
    let doubled: String = std::fs::read_to_string(&asc)
        .expect("asc")
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut c: Vec<String> = l.split_whitespace().map(String::from).collect();
            c[89] = format!("{:e}", -c[13].parse::<f64>().expect("number"));
            c.join(" ") + "\n"
        })
        .collect();
    let data = dir.join("two_elevators.asc");
    std::fs::write(&data, doubled).expect("write");
    let column_text = std::fs::read_to_string(models().join("twin_otter_lon.toml"))
        .expect("model")
        .replace("column = 14  ", "channel = \"0.5*$14 - 0.5*$90\"  ");
    assert!(column_text.contains("0.5*$90"), "the replacement took");
    let derived = dir.join("derived.toml");
    std::fs::write(&derived, column_text).expect("write");
    let fit = |model: PathBuf, data: PathBuf, out: &str| {
        run_fem(&FemArgs {
            model,
            data: vec![data],
            segments: vec![(0.0, 3.5)],
            out: dir.join(out),
            ..FemArgs::default()
        })
        .expect("fem")
    };
    let a = fit(derived, data, "derived");
    let b = fit(models().join("twin_otter_lon.toml"), asc, "plain");
    for (p, q) in a.saved.parameters.iter().zip(&b.saved.parameters) {
        assert_eq!((&p.name, p.value, p.sigma), (&q.name, q.value, q.sigma));
    }
    // … and a derived input naming something that is no channel is refused with the field
    let bad = base.replace(
        "channel = \"elevator\"",
        "channel = \"0.5*elevator_left - 0.5*elevator\"",
    );
    let e = UserModel::parse(&bad, Path::new("m.toml")).expect_err("refused");
    assert!(
        e.0.contains("m.toml: inputs.de.channel") && e.0.contains("`elevator_left` is not a measured channel"),
        "{}",
        e.0
    );
    // … as is a column number in a model without [data] columns
    let bad = base.replace("channel = \"elevator\"", "column = 14");
    let e = UserModel::parse(&bad, Path::new("m.toml")).expect_err("refused");
    assert!(
        e.0.contains("inputs.de.column") && e.0.contains("name the channel"),
        "{}",
        e.0
    );
}

#[test]
fn saved_data_and_a_copied_map_resolve_from_any_folder() {
    // GIVEN a folder tree with a copy of the Twin Otter column map beside a copy of its aircraft
    // file (`aircraft = ../aircraft/twin_otter.aircraft`) and of the data
    let root = scratch("paths");
    let _ = std::fs::remove_dir_all(&root);
    let src = models().join("../data");
    for (from, to) in [
        ("maps/twin_otter.map", "tree/maps/to.map"),
        ("aircraft/twin_otter.aircraft", "tree/aircraft/twin_otter.aircraft"),
        ("flight/totter_lon_020213f1_018_fdata.asc", "tree/flight/to018.asc"),
    ] {
        let dst = root.join(to);
        std::fs::create_dir_all(dst.parent().expect("folder")).expect("folder");
        std::fs::copy(src.join(from), &dst).expect("copy");
    }
    let elsewhere = root.join("elsewhere/deeper");
    std::fs::create_dir_all(&elsewhere).expect("folder");
    let model = models().join("twin_otter_lon_channels.toml");
    // WHEN `fem` runs in the tree's parent with relative paths, the map given as `tree/maps/to.map`
    let fem = aerosid_in(
        &root,
        &[
            "fem",
            "--model",
            model.to_str().expect("utf-8"),
            "--data",
            "tree/flight/to018.asc",
            "--with",
            "tree/maps/to.map",
            "--segment",
            "0:3.5",
            "--out",
            "tree/out",
        ],
    );
    // … and `predict --saved` without --data runs from another folder
    let predict = aerosid_in(
        &elsewhere,
        &[
            "predict",
            "--saved",
            "../../tree/out/identification.json",
            "--segment",
            "0:3.5",
            "--out",
            "pred",
        ],
    );
    // THEN the map found its aircraft file beside it, the saved paths are relative to the JSON,
    // and the prediction is the identification's fit (the same data, found from elsewhere)
    let saved: SavedModel =
        serde_json::from_str(&std::fs::read_to_string(root.join("tree/out/identification.json")).expect("json"))
            .expect("parse");
    assert_eq!(saved.data_files, vec!["../flight/to018.asc".to_string()]);
    assert_eq!(saved.with.as_deref(), Some("../maps/to.map"));
    let rows = |t: &str, after: &str| -> Vec<String> {
        t.lines()
            .skip_while(|l| !l.starts_with(after))
            .skip(2)
            .take(2)
            .map(String::from)
            .collect()
    };
    assert_eq!(
        rows(&fem, "simulation on the identification data:"),
        rows(&predict, "simulation:")
    );
    assert!(elsewhere.join("pred/prediction.json").exists());
    // … and so does a saved column model (its data found through the model file, stored
    // relative to the JSON), moved with its output folder
    let out = root.join("tree/out_columns");
    run_fem(&FemArgs {
        model: models().join("twin_otter_lon.toml"),
        segments: vec![(0.0, 3.5)],
        out: out.clone(),
        ..FemArgs::default()
    })
    .expect("fem");
    aerosid_in(
        &elsewhere,
        &[
            "predict",
            "--saved",
            "../../tree/out_columns/identification.json",
            "--segment",
            "0:3.5",
            "--out",
            "pred2",
        ],
    );
}

#[test]
fn a_constant_from_the_aircraft_file_and_channels_reproduce_the_hfb320_model() {
    // GIVEN hfb320.toml rewritten to name channels (read through tool/data/maps/hfb320.map, whose
    // units are SI already) and to take its mass from the map's aircraft file (7472 kg, as the
    // model file states it)
    let column = hfb320_model();
    let text = column
        .text
        .replace("columns = 20\ntime_column = 1", "with = \"../data/maps/hfb320.map\"")
        .replace("mass = 7472.0 ", "mass = \"aircraft.mass_kg\" ");
    let mut text = text.replace("column = 2\n", "channel = \"elevator\"\n");
    for (col, name) in [
        (4, "thrust"),
        (5, "airspeed"),
        (6, "alpha"),
        (7, "pitch"),
        (8, "pitch_rate"),
        (9, "pitch_accel"),
        (10, "accel_x"),
        (11, "accel_z"),
    ] {
        text = text.replace(&format!("column = {col}\n"), &format!("channel = \"{name}\"\n"));
    }
    assert!(
        !text.contains("column =") && text.contains("aircraft.mass_kg"),
        "{text}"
    );
    let mut named = UserModel::parse(&text, &models().join("hfb320_channels.toml")).expect("model");
    assert!(named.uses_aircraft());
    // WHEN both are identified (one recursive pass) on the flight
    let data = column.default_data().expect("data");
    let segs_named = read_segments(&named, &data, &[]).expect("segments");
    aerosid::workflow::apply_aircraft(&mut named, &segs_named).expect("aircraft");
    let a = identify(&named, &segs_named).expect("identify");
    let b = identify(&column, &read_segments(&column, &data, &[]).expect("segments")).expect("identify");
    // THEN the estimates and covariance are the same to the last bit
    assert_eq!(a.p, b.p);
    assert_eq!(a.covariance, b.covariance);
    // … and a model taking a constant the aircraft file leaves `unknown` is refused with the fix
    let text = text.replace("\"aircraft.mass_kg\"", "\"aircraft.span_m\"");
    let mut bad = UserModel::parse(&text, Path::new("m.toml")).expect("model");
    let e = aerosid::workflow::apply_aircraft(&mut bad, &segs_named).expect_err("span unknown");
    assert!(
        e.contains("no `span_m` (unknown)") && e.contains("constant `mass`"),
        "{e}"
    );
    // … as is a constant naming no aircraft value
    let text = text.replace("\"aircraft.span_m\"", "\"aircraft.weight\"");
    let e = UserModel::parse(&text, Path::new("m.toml")).expect_err("refused");
    assert!(
        e.0.contains("constants.mass") && e.0.contains("aircraft.mass_kg"),
        "{}",
        e.0
    );
}
