//! Real autopilot logs (PX4 ULog, ArduPilot DataFlash) and a MATLAB `.mat` file through the
//! readers and the data-quality assessment: each log parses, gets a report, and gets no verdict it
//! cannot support. The logs are `tool/data/logs/` (provenance and licences in its
//! README.md): one short fixed-wing flight (log_52: an RC F-16 jet, ~8 s in the air, airspeed at
//! 1 Hz) and ground or bench parser fixtures. The Twin Otter `.mat` is
//! `tool/data/flight/totter_lon_020213f1_018.mat` with its text export `_fdata.asc`.

use aerosid::gaps::quality::assess;
use aerosid::gaps::{run_gaps, GapSettings};
use aerosid::io::flow_angles::{prepare, FlowAngleChoice, WindFitSettings};
use aerosid::io::measured::{MeasuredFlight, Quantity};
use aerosid::io::quality::table;
use aerosid::io::{read_measured, read_measured_with, ReadOptions};
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

fn logs() -> PathBuf {
    data().join("logs")
}

/// A fresh scratch folder per test.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-real-logs-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// The logs of `tool/data/logs/`.
const LOGS: [&str; 5] = [
    "log_52_2021-5-22-12-42-56.ulg",
    "pyulog_sample_log_small.ulg",
    "pyulog_sample_appended_multiple.ulg",
    "pymavlink_test.BIN",
    "pyflightcoach_center_0003.bin",
];
const LOG_52: &str = "log_52_2021-5-22-12-42-56.ulg";

fn read(name: &str, opts: &ReadOptions) -> MeasuredFlight {
    read_measured_with(&logs().join(name), None, opts).unwrap_or_else(|e| panic!("{e}"))
}

/// The output time base is uniform: every step equal to the first within 1 µs·1e-3 (the grid is
/// built in integer microseconds, so the only error is the µs → s rounding, ≈ 1e-15 s).
fn assert_uniform(f: &MeasuredFlight) {
    let h = f.t_s[1] - f.t_s[0];
    for (k, w) in f.t_s.windows(2).enumerate() {
        assert!(
            ((w[1] - w[0]) - h).abs() < 1e-9,
            "{}: step {k} is {} s, the first {h} s",
            f.source,
            w[1] - w[0]
        );
    }
}

/// An aircraft file for the RC F-16 of log_52. Its constants are not published; these are round
/// values of the right size (a 3 kg, 1 m span jet model). They only scale the coefficients; the
/// assertions below are about what the data can support, which they do not change.
const F16_AIRCRAFT: &str = "name = RC F-16 (log_52; constants assumed, not measured)\n\
mass_kg = 3\njx_kgm2 = 0.05\njy_kgm2 = 0.3\njz_kgm2 = 0.33\nwing_area_m2 = 0.35\nspan_m = 0.9\nchord_m = 0.45\n";

#[test]
fn every_real_log_parses_and_gets_no_verdict_it_cannot_support() {
    for name in LOGS {
        let f = read(name, &ReadOptions::default());
        assert_uniform(&f);
        assert!(!f.log.parameters.is_empty(), "{name}: no parameters read");
        let q = assess(&f);
        println!("{name}:\n{}", table(&q));
        // None of these logs can support a verdict: the only flight is 7.5 s long with airspeed at
        // 1 Hz, the others are on the ground; and none comes with an aircraft file.
        assert!(!q.supports_verdict && !q.why_not.is_empty(), "{name}: {q:?}");
        assert!(q.why_not.iter().any(|w| w.contains("no aircraft file")), "{name}");
        assert!(serde_json::to_string(&q).is_ok());
        match run_gaps(&f, &GapSettings::default()) {
            Err(e) => println!("{name}: gap analysis refused: {e}"),
            Ok(r) => {
                assert!(r.named.is_empty(), "{name}: named {:?}", r.named);
                assert!(r.verdict.starts_with("no verdict"), "{name}: {}", r.verdict);
            }
        }
    }
}

#[test]
fn log_52_the_flight_is_found_and_refused_for_its_real_limits() {
    let f = read(LOG_52, &ReadOptions::default());
    // The README: takeoff detected at 52.5 s of the 60.0-s log, still flying at its end.
    assert_eq!(f.log.airborne, Some(true));
    let w = f.log.window.as_deref().unwrap_or_default();
    assert!(w.contains("vehicle_land_detected"), "{w}");
    let d = f.t_s[f.len() - 1] - f.t_s[0];
    assert!((6.5..8.5).contains(&d), "in the air for {d} s");
    // Logged parameters (the README's MAV_TYPE 1, SYS_AUTOSTART 2100 "standard plane").
    assert_eq!(f.log.parameters.get("SYS_AUTOSTART"), Some(&2100.0));
    assert_eq!(f.log.parameters.get("MAV_TYPE"), Some(&1.0));
    // Airspeed at 1 Hz; rates at 50 Hz (the time base); no vanes.
    let v_rate = f.log.logged_rate_hz[&Quantity::Airspeed];
    assert!(v_rate < 2.0, "airspeed at {v_rate} Hz");
    assert!(f.get(Quantity::Alpha).is_none() && f.get(Quantity::Airspeed).is_some());
    // With an aircraft file the reasons left are the data's own.
    let dir = scratch("log52");
    let ac = dir.join("f16.aircraft");
    std::fs::write(&ac, F16_AIRCRAFT).expect("write");
    let f = read_measured(&logs().join(LOG_52), &ac).unwrap_or_else(|e| panic!("{e}"));
    let q = assess(&f);
    // No vane: no α, so no C_L or C_D; the moments without α or β terms.
    assert!(q.air_data.starts_with("no α/β vane: none"), "{}", q.air_data);
    for c in &q.coefficients {
        assert_eq!(
            c.identifiable,
            !matches!(c.coefficient.as_str(), "C_L" | "C_D"),
            "{c:?}"
        );
    }
    assert!(
        q.why_not.iter().any(|w| w.contains("airspeed is logged at")),
        "{:?}",
        q.why_not
    );
    assert!(q.why_not.iter().any(|w| w.contains("s of data")), "{:?}", q.why_not);
    assert!(!q.why_not.iter().any(|w| w.contains("aircraft file")));
    let c_m = q.coefficients.iter().find(|c| c.coefficient == "C_m").expect("C_m");
    assert!(
        c_m.notes.iter().any(|n| n.contains("no elevator deflection")),
        "{c_m:?}"
    );
    let c_d = q.coefficients.iter().find(|c| c.coefficient == "C_D").expect("C_D");
    assert!(c_d.notes.iter().any(|n| n.contains("not separable")), "{c_d:?}");
    match run_gaps(&f, &GapSettings::default()) {
        Err(e) => panic!("log_52 with an aircraft file should run: {e}"),
        Ok(r) => {
            println!("{}", aerosid::gaps::report::table(&r));
            assert!(r.named.is_empty());
            assert!(
                r.verdict.starts_with("no verdict") && r.verdict.contains("airspeed"),
                "{}",
                r.verdict
            );
            let json = aerosid::gaps::report::json(&r);
            assert_eq!(json["data_quality"]["supports_verdict"], serde_json::json!(false));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_wrong_topic_or_field_lists_what_the_log_has() {
    let dir = scratch("names");
    std::fs::write(dir.join("f16.aircraft"), F16_AIRCRAFT).expect("write");
    let map = |line: &str| {
        let p = dir.join("m.map");
        std::fs::write(&p, format!("format = ulog\naircraft = f16.aircraft\n{line}\n")).expect("write");
        p
    };
    let ulg = logs().join(LOG_52);
    let e = read_measured(&ulg, &map("channel.elevator = 0.3*actuator_servo.control[1] rad")).expect_err("wrong topic");
    let m = e.to_string();
    assert!(m.contains("no topic `actuator_servo`") && m.contains("m.map:3"), "{m}");
    assert!(
        m.contains("actuator_controls_0 [0:") && m.contains("sensor_combined [0:"),
        "{m}"
    );
    let e =
        read_measured(&ulg, &map("channel.elevator = 0.3*actuator_controls_0.ctrl[1] rad")).expect_err("wrong field");
    assert!(
        e.message.contains("no field `ctrl[1]`") && e.message.contains("control[1]"),
        "{e}"
    );
    // A map surface through the normalised command reads, and replaces the warning.
    let f = read_measured(&ulg, &map("channel.elevator = 0.3*actuator_controls_0.control[1] rad"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(f.get(Quantity::Elevator).is_some());
    assert!(!f
        .log
        .warnings
        .iter()
        .any(|w| w.contains("no surface deflection mapped")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_topic_instance_is_chosen() {
    // pyulog's VTOL log has two instances of `actuator_outputs` (8 and 4 outputs, 10 Hz).
    let dir = scratch("instance");
    std::fs::write(dir.join("f16.aircraft"), F16_AIRCRAFT).expect("write");
    let map = dir.join("m.map");
    // PWM 900…2000 µs × 1e-4 → 0.09…0.2 "rad": a number to compare, not a surface.
    std::fs::write(
        &map,
        "format = ulog\naircraft = f16.aircraft\nchannel.flap = 0.0001*actuator_outputs.output[0] rad\n",
    )
    .expect("write");
    let ulg = logs().join("pyulog_sample_log_small.ulg");
    let mut o = ReadOptions {
        whole_log: true,
        ..ReadOptions::default()
    };
    let f0 = read_measured_with(&ulg, Some(&map), &o).unwrap_or_else(|e| panic!("{e}"));
    o.add_instance("actuator_outputs=1").expect("spec");
    let f1 = read_measured_with(&ulg, Some(&map), &o).unwrap_or_else(|e| panic!("{e}"));
    let (a, b) = (
        f0.get(Quantity::Flap).expect("flap"),
        f1.get(Quantity::Flap).expect("flap"),
    );
    assert!(
        a.iter().zip(b).any(|(x, y)| x != y),
        "instances 0 and 1 read the same values"
    );
    o.add_instance("actuator_outputs=7").expect("spec");
    let e = read_measured_with(&ulg, Some(&map), &o).expect_err("no instance 7");
    assert!(
        e.message.contains("instance 7 of `actuator_outputs`") && e.message.contains("actuator_outputs [0:"),
        "{e}"
    );
    assert!(o.add_instance("actuator_outputs").is_err() && o.add_instance("a=x").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn from_and_to_cut_the_log() {
    // Times are the log's boot time, s (log_52: 598.7…658.7 s), as the report prints them.
    let mut o = ReadOptions {
        from_s: Some(620.0),
        to_s: Some(630.0),
        ..ReadOptions::default()
    };
    let f = read(LOG_52, &o);
    assert!(
        f.t_s[0] >= 620.0 && f.t_s[f.len() - 1] <= 630.0 && f.t_s[f.len() - 1] > 629.9,
        "{:?}",
        (f.t_s[0], f.t_s[f.len() - 1])
    );
    assert_uniform(&f);
    assert_eq!(f.log.airborne, None);
    o.from_s = Some(1000.0);
    o.to_s = Some(1001.0);
    let e = read_measured_with(&logs().join(LOG_52), None, &o).expect_err("outside");
    assert!(e.message.contains("does not overlap"), "{e}");
}

#[test]
fn dataflash_logs_read_with_their_units_and_parameters() {
    // ArduPlane 3.8 (no FMTU): IMU, ATT, AOA (all zero: no vane), RCOU with SERVOn_FUNCTION.
    let f = read("pymavlink_test.BIN", &ReadOptions::default());
    for q in [Quantity::PitchRate, Quantity::AccelZ, Quantity::Pitch] {
        assert!(f.get(q).is_some(), "{q}");
    }
    assert!(f.get(Quantity::Alpha).is_none());
    assert!(f
        .log
        .warnings
        .iter()
        .any(|w| w.contains("AOA") && w.contains("zero padding")));
    assert!(f.log.warnings.iter().any(|w| w.contains("SERVO2_FUNCTION 19")));
    assert_eq!(f.log.parameters.get("SERVO2_FUNCTION"), Some(&19.0));
    // On the ground: the accelerometer reads about +1 g up (specific force −9.8 m/s² on z).
    let az = f.get(Quantity::AccelZ).expect("az");
    let m = az.iter().sum::<f64>() / az.len() as f64;
    assert!((-10.5..-9.0).contains(&m), "mean a_z {m}");
    assert_eq!(f.log.airborne, Some(false));
    // ArduPlane 4.2 (FMTU/UNIT): ATT only (no IMU logged); angles in rad from `deg`.
    let f = read("pyflightcoach_center_0003.bin", &ReadOptions::default());
    let pitch = f.get(Quantity::Pitch).expect("pitch");
    assert!(pitch.iter().all(|p| p.abs() < 1.6), "pitch in rad");
    assert!(f.get(Quantity::PitchRate).is_none());
    assert!(f.log.parameters.len() > 1000);
}

#[test]
fn twin_otter_mat_agrees_with_its_text_export() {
    let map = data().join("maps/twin_otter.map");
    let flight = data().join("flight");
    let mat = read_measured(&flight.join("totter_lon_020213f1_018.mat"), &map).unwrap_or_else(|e| panic!("{e}"));
    let asc = read_measured(&flight.join("totter_lon_020213f1_018_fdata.asc"), &map).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mat.len(), 401);
    assert_eq!(
        mat.channels.keys().collect::<Vec<_>>(),
        asc.channels.keys().collect::<Vec<_>>()
    );
    // The text has 10 significant digits: each number within half a unit of the 10th digit,
    // 5e-10 relative (plus 1e-12 absolute for the columns that are exactly 0 in one and ~1e-17
    // in the other after a unit factor).
    let close = |a: f64, b: f64| (a - b).abs() <= 5e-10 * a.abs().max(b.abs()) + 1e-12;
    for (k, (a, b)) in mat.t_s.iter().zip(&asc.t_s).enumerate() {
        assert!(close(*a, *b), "t[{k}]: {a} against {b}");
    }
    let mut worst = 0.0f64;
    for (q, x) in &mat.channels {
        for (k, (a, b)) in x.iter().zip(&asc.channels[q]).enumerate() {
            assert!(close(*a, *b), "{q}[{k}]: {a} against {b}");
            if a.abs() > 0.0 {
                worst = worst.max((a - b).abs() / a.abs());
            }
        }
    }
    println!("Twin Otter .mat against _fdata.asc: largest relative difference {worst:.2e}");
    assert!(mat.log.format.contains("`fdata`"), "{}", mat.log.format);
    // A matrix that is not there is named, with what the file has.
    let dir = scratch("mat");
    let text = std::fs::read_to_string(&map)
        .expect("map")
        .replace("format = ascii", "format = ascii\nvariable = nodata")
        .replace("../aircraft/", &format!("{}/", data().join("aircraft").display()));
    std::fs::write(dir.join("t.map"), text).expect("write");
    let e = read_measured(&flight.join("totter_lon_020213f1_018.mat"), &dir.join("t.map")).expect_err("no matrix");
    assert!(
        e.message.contains("no numeric matrix `nodata`") && e.message.contains("`fdatao` 401×90"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_command_reads_each_real_log_without_an_aircraft_file() {
    let exe = env!("CARGO_BIN_EXE_aerosid");
    let dir = scratch("cli");
    // log_52 flies: the analysis runs and says why there is no verdict.
    let o = std::process::Command::new(exe)
        .args(["gaps", "--data"])
        .arg(logs().join(LOG_52))
        .arg("--out")
        .arg(dir.join("log52"))
        .output()
        .expect("run aerosid");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("NO VERDICT") && out.contains("4. verdict\n   no verdict:"),
        "{out}"
    );
    // A bench log, too short for the analysis: still a report (the data quality printed, and
    // report.json with status no_verdict and the reasons), exit 0.
    let o = std::process::Command::new(exe)
        .args(["gaps", "--data"])
        .arg(logs().join("pymavlink_test.BIN"))
        .arg("--out")
        .arg(dir.join("bin"))
        .output()
        .expect("run aerosid");
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("NO VERDICT"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("bin/report.json")).expect("json")).expect("parse");
    assert_eq!(json["data_quality"]["supports_verdict"], serde_json::json!(false));
    assert_eq!(json["status"], serde_json::json!("no_verdict"));
    let reasons = json["reasons"].as_array().expect("reasons");
    assert!(
        reasons[0]
            .as_str()
            .is_some_and(|r| r.contains("the analysis needs at least 200")),
        "{reasons:?}"
    );
    // --list names the topics.
    let o = std::process::Command::new(exe)
        .args(["gaps", "--list", "--data"])
        .arg(logs().join(LOG_52))
        .output()
        .expect("run aerosid");
    assert!(String::from_utf8_lossy(&o.stdout).contains("vehicle_land_detected (instance 0)"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_alpha_free_mode_on_every_real_log_says_what_it_can_and_cannot_do() {
    for name in LOGS {
        let f = read(name, &ReadOptions::default());
        let has = |q: Quantity| f.get(q).is_some();
        let velocity = has(Quantity::VelocityNorth) && has(Quantity::VelocityEast) && has(Quantity::VelocityDown);
        let p = prepare(&f, FlowAngleChoice::Auto, &WindFitSettings::default());
        let info = p.log.flow_angles.clone().expect("the mode ran");
        let q = assess(&p);
        println!(
            "{name}: velocity {velocity}, airspeed {}, autopilot wind {}; {}: {}\n   air data: {}",
            has(Quantity::Airspeed),
            has(Quantity::WindNorth),
            info.status,
            if info.why_not.is_empty() {
                info.summary.clone()
            } else {
                info.why_not.join("; ")
            },
            q.air_data
        );
        // No vane on any of them: the mode either estimated α/β (and said how, with the
        // assumptions) or said why not; either way no verdict (none of these logs supports one).
        assert!(f.get(Quantity::Alpha).is_none(), "{name}");
        match info.status.as_str() {
            "estimated" => {
                assert!(
                    q.air_data.contains("estimated from GPS velocity"),
                    "{name}: {}",
                    q.air_data
                );
                assert!(
                    q.warnings.iter().any(|w| w.contains("vertical wind assumed 0")),
                    "{name}"
                );
            }
            "not estimated" => {
                assert!(!info.why_not.is_empty(), "{name}");
                assert!(p.get(Quantity::Alpha).is_none(), "{name}");
                assert!(q.air_data.contains("was not made"), "{name}: {}", q.air_data);
            }
            s => panic!("{name}: status {s}"),
        }
        assert!(!q.supports_verdict, "{name}");
        if let Ok(r) = run_gaps(&f, &GapSettings::default()) {
            assert!(
                r.named.is_empty() && r.verdict.starts_with("no verdict"),
                "{name}: {}",
                r.verdict
            );
        }
    }
}

#[test]
fn an_optional_channel_that_starts_late_is_read_inside_a_window_that_it_covers() {
    // The handheld ArduPlane log: the EKF (XKF1, XKF2) starts 1.5 s after the attitude, so the
    // whole log's window leaves its velocity and wind out, with a warning naming the way in.
    let f = read("pyflightcoach_center_0003.bin", &ReadOptions::default());
    assert!(f.get(Quantity::VelocityNorth).is_none());
    assert!(f
        .log
        .warnings
        .iter()
        .any(|w| w.contains("XKF1[0].VN") && w.contains("--from/--to")));
    let o = ReadOptions {
        from_s: Some(6.0),
        ..ReadOptions::default()
    };
    let f = read("pyflightcoach_center_0003.bin", &o);
    for q in [
        Quantity::VelocityNorth,
        Quantity::VelocityEast,
        Quantity::VelocityDown,
        Quantity::WindNorth,
        Quantity::WindEast,
    ] {
        assert!(f.get(q).is_some(), "{q}");
    }
    // Walked by hand: the ground speed stays under 2 m/s (the README).
    let vn = f.get(Quantity::VelocityNorth).expect("vel_n");
    let ve = f.get(Quantity::VelocityEast).expect("vel_e");
    let mut speed: Vec<f64> = vn.iter().zip(ve).map(|(n, e)| n.hypot(*e)).collect();
    speed.sort_by(f64::total_cmp);
    println!(
        "EKF ground speed: median {:.2} m/s, max {:.2} m/s",
        speed[speed.len() / 2],
        speed[speed.len() - 1]
    );
    assert!(speed[speed.len() / 2] < 2.0, "a walk, not a flight");
    // No airspeed: the autopilot's wind would be used, but on the ground the angles are wild,
    // and the estimate is refused, saying so.
    let p = prepare(&f, FlowAngleChoice::Auto, &WindFitSettings::default());
    let info = p.log.flow_angles.clone().expect("ran");
    println!("{:?}", info.why_not);
    assert_eq!(info.status, "not estimated");
    assert!(p.get(Quantity::Alpha).is_none());
}

#[test]
fn the_command_takes_the_flow_angle_choice() {
    let exe = env!("CARGO_BIN_EXE_aerosid");
    let dir = scratch("flow");
    // log_52 has GPS velocity and airspeed, but 8 s of flight turn it by only 84°: the estimate
    // is refused and the data quality says why.
    let o = std::process::Command::new(exe)
        .args(["gaps", "--flow-angles", "estimated", "--data"])
        .arg(logs().join(LOG_52))
        .arg("--out")
        .arg(dir.join("log52"))
        .output()
        .expect("run aerosid");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("α-free estimate") && out.contains("heading spans only"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("log52/report.json")).expect("report.json"))
            .expect("parse");
    let fa = &json["data_quality"]["flow_angles"];
    assert_eq!(fa["status"], serde_json::json!("not estimated"), "{fa}");
    assert!(
        fa["fit"]["blocks"][0]["heading_span_deg"]
            .as_f64()
            .is_some_and(|d| d < 90.0),
        "{fa}"
    );
    // An unknown choice is a usage error naming the choices.
    let o = std::process::Command::new(exe)
        .args(["gaps", "--flow-angles", "vane", "--data"])
        .arg(logs().join(LOG_52))
        .output()
        .expect("run aerosid");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("estimated"));
    let _ = std::fs::remove_dir_all(&dir);
}
