//! The α-free mode ([`aerosid::io::flow_angles`]): α and β estimated from the ground velocity,
//! the attitude and a wind fitted with the pitot scale, on simulated flights whose truth is known
//! (the project's simulator, Dryden turbulence on, a constant wind), and refused when the heading
//! does not change enough to separate the wind from the pitot scale.

use aerosid::gaps::quality::assess;
use aerosid::gaps::{run_gaps, GapSettings};
use aerosid::io::flow_angles::{alpha_beta, estimate, heading_span, prepare, FlowAngleChoice, WindFitSettings};
use aerosid::io::measured::{Aircraft, MeasuredFlight, Quantity};
use aerosid::sim::{simulate, Channel, Manoeuvre, Shape, SimAirframe, SimOutput};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// The simulated wind, NED, m/s (velocity of the air): 5.4 m/s from the south-east at a 15 m/s
/// airspeed, a third of it, enough that ignoring it would be an α/β error of ~0.3 rad.
const WIND_NED: [f64; 3] = [-4.0, 3.5, 0.0];
/// GPS velocity: logged at 10 Hz with 0.05 m/s white noise per component (a u-blox M8/M9's
/// specified speed accuracy), joined by straight lines onto the 100-Hz time base as the readers do.
const GPS_PERIOD: usize = 10;
const GPS_NOISE_MPS: f64 = 0.05;

/// A simulated flight in the campaign's turbulence (σ 0.3 m/s, L 50 m) and [`WIND_NED`], with the
/// ground velocity logged as a GPS would; `bank` holds an aileron step from 1 s to the end, so
/// the aircraft turns (0: the stabiliser holds the wings level and the heading barely changes).
fn flight(seed: u64, seconds: f64, bank: f64, gust_sigma_mps: f64) -> (MeasuredFlight, SimOutput) {
    flight_gps(seed, seconds, bank, gust_sigma_mps, GPS_PERIOD, GPS_NOISE_MPS)
}

fn flight_gps(
    seed: u64,
    seconds: f64,
    bank: f64,
    gust_sigma_mps: f64,
    gps_period: usize,
    gps_noise: f64,
) -> (MeasuredFlight, SimOutput) {
    let mut cfg = aerosid::gaps::hidden::config(None, seconds, seed, true);
    cfg.turbulence = Some(aerosid::sim::Turbulence {
        lengths_m: [50.0; 3],
        sigma_mps: [gust_sigma_mps; 3],
    });
    cfg.plant.wind_ned_mps = Vector3::from(WIND_NED);
    if bank != 0.0 {
        cfg.schedule = cfg.schedule.clone().with(Manoeuvre {
            channel: Channel::Aileron,
            shape: Shape::Step,
            start_s: 1.0,
            amplitude: bank,
            period_s: seconds,
        });
    }
    let out = simulate(&cfg).expect("the flight trims");
    let nominal = SimAirframe::skywalker_2013_mod();
    let mut f = MeasuredFlight::from_samples(
        &format!("simulated, wind {WIND_NED:?}, seed {seed}"),
        &out.samples,
        Aircraft::from_airframe("skywalker_2013_mod", &nominal.frame),
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6a5);
    let noise = Normal::new(0.0, gps_noise).expect("σ > 0");
    let truth: Vec<Vector3<f64>> = out
        .truth
        .iter()
        .map(|t| t.state.attitude.transform_vector(&t.state.velocity_body_mps))
        .collect();
    let n = truth.len();
    for (c, q) in [Quantity::VelocityNorth, Quantity::VelocityEast, Quantity::VelocityDown]
        .into_iter()
        .enumerate()
    {
        let logged: Vec<(usize, f64)> = (0..n)
            .step_by(gps_period)
            .map(|i| (i, truth[i][c] + noise.sample(&mut rng)))
            .collect();
        let mut x = Vec::with_capacity(n);
        for i in 0..n {
            let k = (i / gps_period).min(logged.len() - 1);
            let (i0, x0) = logged[k];
            x.push(match logged.get(k + 1) {
                Some(&(i1, x1)) => x0 + (x1 - x0) * (i - i0) as f64 / (i1 - i0) as f64,
                None => x0,
            });
        }
        f.channels.insert(q, x);
    }
    (f, out)
}

fn without_vanes(f: &MeasuredFlight) -> MeasuredFlight {
    let mut g = f.clone();
    g.channels.remove(&Quantity::Alpha);
    g.channels.remove(&Quantity::Beta);
    g
}

/// Each wind component of `b` within 3σ of [`WIND_NED`].
fn within_3_sigma(b: &aerosid::io::flow_angles::WindBlock) -> bool {
    (0..2).all(|k| (b.wind_ne_mps[k] - WIND_NED[k]).abs() <= 3.0 * b.sigma_ne_mps[k])
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

#[test]
fn the_wind_triangle_geometry() {
    // Level, heading north, 15 m/s ground speed into a 5 m/s head wind from the north (air moving
    // south): the air-relative speed is 20 m/s along the nose, α = β = 0.
    let (a, b, v) = alpha_beta([15.0, 0.0, 0.0], [-5.0, 0.0], 0.0, 0.0, 0.0);
    assert!(a.abs() < 1e-12 && b.abs() < 1e-12 && (v - 20.0).abs() < 1e-12);
    // Pitched up 0.1 rad, flying level: α = 0.1.
    let (a, b, _) = alpha_beta([20.0, 0.0, 0.0], [0.0, 0.0], 0.0, 0.1, 0.0);
    assert!((a - 0.1).abs() < 1e-12 && b.abs() < 1e-12, "{a} {b}");
    // Heading east, air moving north at 2 m/s, ground velocity 20 m/s east: v_air = (−2, 20, 0)
    // NED is, in body axes, u = 20 and v = 2 (the aircraft moves to its right through the air,
    // the relative wind comes from the right), so β = asin(2/V) > 0.
    let (_, b, v) = alpha_beta([0.0, 20.0, 0.0], [2.0, 0.0], 0.0, 0.0, std::f64::consts::FRAC_PI_2);
    assert!((b - (2.0 / v).asin()).abs() < 1e-12, "{b}");
    // Heading span: a wrap through north is one short span, not a full circle.
    let span = heading_span(&[-0.2, -0.1, 0.0, 0.1, 0.2]);
    assert!((span - 0.4).abs() < 1e-12, "{span}");
    assert!((heading_span(&[0.0, 2.0, 4.0]) - 4.0).abs() < 1e-12);
}

/// The gap analysis's baseline α derivative of `c` (value, σ).
fn alpha_slope(r: &aerosid::gaps::GapReport, c: &str) -> (f64, f64) {
    let p = r
        .coefficients
        .iter()
        .find(|x| x.name == c)
        .and_then(|x| x.baseline.parameters.iter().find(|p| p.term == "α"))
        .unwrap_or_else(|| panic!("{c}: no α term"));
    (p.value, p.sigma)
}

#[test]
fn in_turbulence_the_estimate_follows_the_truth_and_supports_no_verdict() {
    // GIVEN a 120-s flight in the campaign's turbulence (σ 0.3 m/s, L 50 m) and a 5.3 m/s wind,
    // circling (aileron step 0.06 rad: about 0.2 rad of bank against the stabiliser, a full
    // circle every ~50 s), GPS velocity at 10 Hz, the vanes dropped
    let (f, out) = flight(11, 120.0, 0.06, 0.3);
    let g = without_vanes(&f);
    // WHEN α and β are estimated
    let e = estimate(&g, &WindFitSettings::default()).unwrap_or_else(|i| panic!("refused: {i:#?}"));
    let fit = e.info.fit.clone().expect("a wind fit");
    println!("{}", e.info.summary);
    // THEN the wind is within 3σ of the truth per component, and the pitot scale within 3σ of 1
    // (plus 0.01: the simulated pitot's 0.1 m/s bias is 0.7 % of 15 m/s, which the scale absorbs)
    let b = &fit.blocks[0];
    for k in 0..2 {
        let err = b.wind_ne_mps[k] - WIND_NED[k];
        println!(
            "wind {}: {:.3} ± {:.3} m/s (truth {}), error {err:.3} m/s = {:.1} σ",
            ["north", "east"][k],
            b.wind_ne_mps[k],
            b.sigma_ne_mps[k],
            WIND_NED[k],
            err / b.sigma_ne_mps[k]
        );
        assert!(
            err.abs() <= 3.0 * b.sigma_ne_mps[k],
            "wind {k}: error {err} m/s, σ {}",
            b.sigma_ne_mps[k]
        );
    }
    println!("pitot scale {:.4} ± {:.4}", fit.pitot_scale, fit.pitot_scale_sigma);
    assert!((fit.pitot_scale - 1.0).abs() <= 3.0 * fit.pitot_scale_sigma + 0.01);
    // AND the α and β errors against the truth (gusts included) are the size of the turbulence:
    // the estimate assumes steady air, so a gust of σ_w = 0.3 m/s is an angle error of
    // σ_w/V = 0.02 rad, plus the attitude's 0.5° white noise (0.009 rad): √(0.02² + 0.009²) =
    // 0.022 rad. The bound 1.5 × that (0.033 rad) leaves room for one flight's draw of the gusts
    // (120 s over L/V = 3.3 s ≈ 36 correlation times: ±25 % on an RMS at 2σ).
    let truth_a: Vec<f64> = out.truth.iter().map(|t| t.eval.alpha_rad).collect();
    let truth_b: Vec<f64> = out.truth.iter().map(|t| t.eval.beta_rad).collect();
    let da: Vec<f64> = e.alpha_rad.iter().zip(&truth_a).map(|(a, b)| a - b).collect();
    let db: Vec<f64> = e.beta_rad.iter().zip(&truth_b).map(|(a, b)| a - b).collect();
    let bound = 1.5 * ((0.3f64 / 15.0).powi(2) + 0.5f64.to_radians().powi(2)).sqrt();
    println!(
        "α RMS error {:.4} rad, β RMS error {:.4} rad (bound {bound:.4}); stated σ_α {:.4}, σ_β {:.4}",
        rms(&da),
        rms(&db),
        e.info.alpha_sigma_rad,
        e.info.beta_sigma_rad
    );
    assert!(rms(&da) < bound && rms(&db) < bound);
    // AND the stated σ is honest: the actual RMS error within a factor 1.6 of it either way (the
    // gust draw as above, and the gust term is inferred from the airspeed residual alone)
    for (actual, stated) in [(rms(&da), e.info.alpha_sigma_rad), (rms(&db), e.info.beta_sigma_rad)] {
        assert!(
            actual / stated < 1.6 && stated / actual < 1.6,
            "actual {actual}, stated {stated}"
        );
    }
    // WHEN the gap analysis runs on the estimate (auto: no vane, so estimated)
    let r = run_gaps(&g, &GapSettings::default()).expect("runs");
    let q = &r.data_quality;
    println!("{}", aerosid::io::quality::table(q));
    let (v, sv) = alpha_slope(&run_gaps(&f, &GapSettings::default()).expect("runs"), "C_L");
    let (es, se) = alpha_slope(&r, "C_L");
    println!("C_Lα: vanes {v:.3} ± {sv:.3}, estimated {es:.3} ± {se:.3}");
    // THEN it says where α came from, with the wind, the scale and the σ, and the assumptions
    assert!(
        q.air_data
            .contains("α, β estimated from GPS velocity, attitude and a wind estimate"),
        "{}",
        q.air_data
    );
    assert!(q.air_data.contains("vertical wind assumed 0") && q.air_data.contains("pitot scale"));
    assert!(q
        .warnings
        .iter()
        .any(|w| w.contains("α-free mode") && w.contains("gusts are not followed")));
    let json = serde_json::to_value(q).expect("json");
    assert_eq!(json["flow_angles"]["status"], serde_json::json!("estimated"));
    assert!(json["flow_angles"]["fit"]["pitot_scale"].is_number());
    // AND, the gusts making the estimated α's error as large as a third of its excursion, it
    // supports no verdict and names nothing (here the α slopes from it are far too low: the
    // gust-driven part of the inertial α does not move the lift)
    assert!(!q.supports_verdict, "{:?}", q.why_not);
    assert!(
        q.why_not.iter().any(|w| w.contains("estimated α varies by")),
        "{:?}",
        q.why_not
    );
    assert!(
        r.named.is_empty() && r.verdict.starts_with("no verdict"),
        "{}",
        r.verdict
    );
}

#[test]
fn in_light_turbulence_the_estimate_identifies_the_lift_and_pitch_slopes() {
    // GIVEN the circling flight in light turbulence (σ 0.05 m/s) and the 5.3 m/s wind
    let (f, out) = flight(12, 120.0, 0.06, 0.05);
    let g = without_vanes(&f);
    // WHEN the gap analysis runs on the vanes and, without them, on the estimate
    let with_vanes = run_gaps(&f, &GapSettings::default()).expect("runs");
    let estimated = run_gaps(&g, &GapSettings::default()).expect("runs");
    println!("{}", aerosid::io::quality::table(&estimated.data_quality));
    let e = estimate(&g, &WindFitSettings::default()).unwrap_or_else(|i| panic!("refused: {i:#?}"));
    let truth_a: Vec<f64> = out.truth.iter().map(|t| t.eval.alpha_rad).collect();
    let da: Vec<f64> = e.alpha_rad.iter().zip(&truth_a).map(|(a, b)| a - b).collect();
    println!(
        "α RMS error {:.4} rad (stated σ {:.4})",
        rms(&da),
        e.info.alpha_sigma_rad
    );
    // THEN C_Lα and C_mα agree with the vanes' within 25 %. The estimate's α is the inertial α:
    // the 10-Hz GPS velocity, joined by straight lines, low-passes the short period and carries
    // 0.05 m/s of noise (in calm air this alone gives −9 % on the simulator), the attitude's
    // 0.5° noise is an α error one for one, and the gusts it does not follow are errors in the
    // regressor, which bias a slope low by up to 1/9 ≈ 11 % when α varies by 3 σ (the data-quality
    // rule); with two fits' 2σ (≈ 4 %) that is 25 %.
    for c in ["C_L", "C_m"] {
        let (v, sv) = alpha_slope(&with_vanes, c);
        let (es, se) = alpha_slope(&estimated, c);
        let rel = (es - v) / v;
        println!(
            "{c}α: vanes {v:.4} ± {sv:.4}, estimated {es:.4} ± {se:.4}: {:+.1} %",
            100.0 * rel
        );
        assert!(rel.abs() < 0.25, "{c}α: {es} against {v}");
    }
    assert!(estimated.data_quality.air_data.contains("estimated"));
}

#[test]
fn a_piecewise_constant_wind_is_fitted_per_block() {
    // GIVEN the circling flight (a circle per ~50 s), blocks of 60 s
    let (f, _) = flight(13, 120.0, 0.06, 0.3);
    let s = WindFitSettings {
        block_s: Some(60.0),
        ..WindFitSettings::default()
    };
    let e = estimate(&without_vanes(&f), &s).unwrap_or_else(|i| panic!("refused: {i:#?}"));
    let fit = e.info.fit.expect("fit");
    // THEN two blocks, each with more than 90° of heading and its wind within 3σ of the truth
    assert_eq!(fit.blocks.len(), 2);
    for b in &fit.blocks {
        println!("{b:?}");
        assert!(b.heading_span_deg > 90.0);
        assert!(within_3_sigma(b), "{b:?}");
    }
}

#[test]
fn too_little_heading_change_is_refused_not_answered() {
    // GIVEN a flight with the wings held level (the heading wanders by a few degrees only)
    let (f, _) = flight(14, 60.0, 0.0, 0.3);
    let g = without_vanes(&f);
    // WHEN α and β are to be estimated
    let info = estimate(&g, &WindFitSettings::default()).expect_err("the wind is not observable");
    println!("{:#?}", info.why_not);
    // THEN the fit is refused, saying why, with its numbers kept for the report
    assert_eq!(info.status, "not estimated");
    assert!(
        info.why_not.iter().any(|w| w.contains("heading spans only")),
        "{:?}",
        info.why_not
    );
    let fit = info.fit.as_ref().expect("the fit is reported");
    assert!(fit.blocks[0].heading_span_deg < 90.0);
    // AND the flight the analysis gets has no α, and the data quality says the estimate was not
    // made and why; no lift or drag coefficient is offered
    let p = prepare(&g, FlowAngleChoice::Auto, &WindFitSettings::default());
    assert!(p.get(Quantity::Alpha).is_none() && p.get(Quantity::Beta).is_none());
    let q = assess(&p);
    assert!(
        q.air_data.contains("not made") && q.air_data.contains("heading spans only"),
        "{}",
        q.air_data
    );
    for c in &q.coefficients {
        if matches!(c.coefficient.as_str(), "C_L" | "C_D") {
            assert!(!c.identifiable, "{c:?}");
        }
    }
    // AND a lower threshold does not make it confident: the σ or the condition still refuse it
    // or the wind found is within 3σ of the truth
    let loose = WindFitSettings {
        min_heading_span_rad: 0.0,
        ..WindFitSettings::default()
    };
    match estimate(&g, &loose) {
        Err(i) => assert!(!i.why_not.is_empty()),
        Ok(e) => {
            let b = &e.info.fit.expect("fit").blocks[0];
            assert!(within_3_sigma(b), "{b:?}");
        }
    }
}

#[test]
fn without_airspeed_the_autopilot_wind_is_used_or_nothing() {
    let (f, _) = flight(15, 30.0, 0.06, 0.3);
    let mut g = without_vanes(&f);
    g.channels.remove(&Quantity::Airspeed);
    // No airspeed and no autopilot wind: no estimate, said so.
    let info = estimate(&g, &WindFitSettings::default()).expect_err("no wind");
    assert!(
        info.why_not.iter().any(|w| w.contains("no airspeed logged")),
        "{:?}",
        info.why_not
    );
    // The autopilot's wind estimate logged: used, its uncertainty unknown; no verdict rests on it.
    let n = g.len();
    g.channels.insert(Quantity::WindNorth, vec![WIND_NED[0]; n]);
    g.channels.insert(Quantity::WindEast, vec![WIND_NED[1]; n]);
    let e = estimate(&g, &WindFitSettings::default()).unwrap_or_else(|i| panic!("{i:#?}"));
    assert_eq!(e.info.wind_source, "autopilot wind estimate");
    assert!(e.info.alpha_sigma_rad.is_nan() && e.info.summary.contains("uncertainty unknown"));
    let q = assess(&prepare(&g, FlowAngleChoice::Auto, &WindFitSettings::default()));
    assert!(!q.supports_verdict);
    assert!(
        q.why_not.iter().any(|w| w.contains("uncertainty is unknown")),
        "{:?}",
        q.why_not
    );
}

#[test]
fn the_choice_vanes_none_and_estimated() {
    let (f, _) = flight(16, 60.0, 0.06, 0.3);
    let s = WindFitSettings::default();
    let vanes = prepare(&f, FlowAngleChoice::Auto, &s);
    assert_eq!(vanes.get(Quantity::Alpha), f.get(Quantity::Alpha));
    assert_eq!(vanes.log.flow_angles.as_ref().map(|x| x.status.as_str()), Some("vanes"));
    let none = prepare(&f, FlowAngleChoice::None, &s);
    assert!(none.get(Quantity::Alpha).is_none());
    let est = prepare(&f, FlowAngleChoice::Estimated, &s);
    assert_ne!(est.get(Quantity::Alpha), f.get(Quantity::Alpha));
    let info = est.log.flow_angles.as_ref().expect("info");
    assert_eq!(info.status, "estimated");
    assert!(info.assumptions.iter().any(|a| a.contains("replaced")));
    assert_eq!(FlowAngleChoice::parse("estimated"), Some(FlowAngleChoice::Estimated));
    assert_eq!(FlowAngleChoice::parse("vane"), None);
}

#[test]
fn the_command_estimates_alpha_from_a_csv_log_without_vanes() {
    use aerosid::io::project_csv::csv_column;
    // GIVEN the circling flight as a project CSV log with the ground-velocity columns and no vane
    let (f, _) = flight(17, 60.0, 0.06, 0.05);
    let g = without_vanes(&f);
    let dir = std::env::temp_dir().join(format!("aerosid-flow-angles-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let cols: Vec<(&str, &Vec<f64>)> = g.channels.iter().map(|(q, x)| (csv_column(*q), x)).collect();
    assert!(cols.iter().any(|(c, _)| *c == "vel_ned_mps_n"));
    let mut text = String::from("t_s");
    for (c, _) in &cols {
        text += &format!(",{c}");
    }
    text.push('\n');
    for (k, t) in g.t_s.iter().enumerate() {
        text += &format!("{t}");
        for (_, x) in &cols {
            text += &format!(",{}", x[k]);
        }
        text.push('\n');
    }
    let csv = dir.join("flight.csv");
    std::fs::write(&csv, text).expect("write");
    let aircraft = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/aircraft/skywalker_2013_mod.aircraft");
    // WHEN `aerosid gaps` reads it (default --flow-angles auto)
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(["gaps", "--data"])
        .arg(&csv)
        .arg("--with")
        .arg(&aircraft)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .expect("run aerosid");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}\n{out}", String::from_utf8_lossy(&o.stderr));
    // THEN the CSV's velocity columns are read, α and β are estimated, and the report says so
    assert!(out.contains("air data: estimated (no vane used)"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/report.json")).expect("report.json"))
            .expect("parse");
    let fa = &json["data_quality"]["flow_angles"];
    assert_eq!(fa["status"], serde_json::json!("estimated"), "{fa}");
    assert_eq!(fa["wind_source"], serde_json::json!("wind-triangle fit"));
    // AND `--flow-angles vanes` (there are none) leaves α out
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_aerosid"))
        .args(["gaps", "--flow-angles", "vanes", "--data"])
        .arg(&csv)
        .arg("--with")
        .arg(&aircraft)
        .arg("--out")
        .arg(dir.join("vanes"))
        .output()
        .expect("run aerosid");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("no α/β vane: none"), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}
