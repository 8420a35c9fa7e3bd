//! Where a channel comes from (`io::measured::Origin`): each reader sets it where its format says
//! (ArduPilot `AOA`, PX4 `airspeed_validated`'s source), a column map and the project CSV's
//! `*_est_*` columns state it, and the gap analysis offers an estimated flow angle no sensor
//! errors and does not offer α̇ in C_L (the lift restated through `γ̇ = q − α̇`). Also the held
//! channels (sample-and-hold staircases) of a CSV log.

use aerosid::gaps::model::{synthesise, Corrections, Term};
use aerosid::gaps::{compat, hidden, run_gaps, GapSettings};
use aerosid::io::colmap::{parse_ascii, parse_map, ColumnMap};
use aerosid::io::dataflash::parse_dataflash;
use aerosid::io::measured::{Origin, Quantity};
use aerosid::io::project_csv::parse_project_csv;
use aerosid::io::ulog::parse_ulog;
use aerosid::io::{placeholder_aircraft, ReadOptions};
use std::path::Path;

fn aircraft_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/maps")
}

// ---- ArduPilot DataFlash: a log written here (FMT, IMU, ATT, AOA, ARSP), no FMTU, so the
// reader takes the units of LogStructure.h (degrees for ATT and AOA).

fn df_fmt(out: &mut Vec<u8>, kind: u8, name: &str, format: &str, labels: &str) {
    let size: usize = format
        .chars()
        .map(|c| match c {
            'Q' => 8,
            'f' => 4,
            _ => panic!("format {c}"),
        })
        .sum();
    out.extend_from_slice(&[0xA3, 0x95, 128, kind, (3 + size) as u8]);
    let pad = |s: &str, n: usize| {
        let mut b = s.as_bytes().to_vec();
        b.resize(n, 0);
        b
    };
    out.extend(pad(name, 4));
    out.extend(pad(format, 16));
    out.extend(pad(labels, 64));
}

fn df_msg(out: &mut Vec<u8>, kind: u8, time_us: u64, values: &[f32]) {
    out.extend_from_slice(&[0xA3, 0x95, kind]);
    out.extend_from_slice(&time_us.to_le_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// 10 s in the air: IMU and ATT at 50 Hz, AOA and ARSP at 20 Hz.
fn dataflash_log() -> Vec<u8> {
    let mut b = Vec::new();
    df_fmt(&mut b, 129, "IMU", "Qffffff", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ");
    df_fmt(&mut b, 130, "ATT", "Qfff", "TimeUS,Roll,Pitch,Yaw");
    df_fmt(&mut b, 131, "AOA", "Qff", "TimeUS,AOA,SSA");
    df_fmt(&mut b, 132, "ARSP", "Qf", "TimeUS,Airspeed");
    for k in 0..500u64 {
        let t = 1_000_000 + k * 20_000;
        let s = (k as f32 * 0.05).sin();
        df_msg(&mut b, 129, t, &[0.0, 0.02 * s, 0.0, 0.3, 0.0, -9.8]);
        df_msg(&mut b, 130, t, &[0.0, 3.0, 45.0]);
        if k % 5 == 0 || k % 5 == 2 {
            df_msg(&mut b, 131, t, &[3.0 + s, 0.5 * s]);
            df_msg(&mut b, 132, t, &[20.0 + s]);
        }
    }
    b
}

#[test]
fn dataflash_aoa_is_the_autopilots_estimate_and_arsp_a_sensor() {
    let f = parse_dataflash(
        &dataflash_log(),
        "aoa.bin",
        placeholder_aircraft(),
        &ReadOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for q in [Quantity::Alpha, Quantity::Beta] {
        assert!(f.get(q).is_some(), "{q} read");
        match f.log.origin_of(q) {
            Origin::Estimated { by } => assert!(by.contains("AOA") && by.contains("wind"), "{by}"),
            o => panic!("{q}: {o:?}"),
        }
    }
    assert_eq!(f.log.origin_of(Quantity::Airspeed), Origin::Sensor);
    assert_eq!(f.log.origin_of(Quantity::PitchRate), Origin::Sensor);
}

// ---- PX4 ULog: a log written here with `airspeed_validated` and its source field.

fn ulog_msg(out: &mut Vec<u8>, kind: u8, payload: &[u8]) {
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.push(kind);
    out.extend_from_slice(payload);
}

/// 10 s: `vehicle_angular_velocity` at 50 Hz and `airspeed_validated` at 10 Hz whose source
/// field (`int8_t NAME`) is `source` in every message.
fn ulog_with_source(field: &str, source: i8) -> Vec<u8> {
    let mut b = b"ULog\x01\x12\x35\x01".to_vec();
    b.extend_from_slice(&0u64.to_le_bytes());
    ulog_msg(&mut b, b'B', &[0u8; 40]);
    ulog_msg(
        &mut b,
        b'F',
        b"vehicle_angular_velocity:uint64_t timestamp;float[3] xyz;",
    );
    ulog_msg(
        &mut b,
        b'F',
        format!("airspeed_validated:uint64_t timestamp;float true_airspeed_m_s;int8_t {field};").as_bytes(),
    );
    for (id, name) in [(0u16, "vehicle_angular_velocity"), (1, "airspeed_validated")] {
        let mut a = vec![0u8];
        a.extend_from_slice(&id.to_le_bytes());
        a.extend_from_slice(name.as_bytes());
        ulog_msg(&mut b, b'A', &a);
    }
    for k in 0..500u64 {
        let t = 1_000_000 + k * 20_000;
        let mut d = 0u16.to_le_bytes().to_vec();
        d.extend_from_slice(&t.to_le_bytes());
        for v in [0.0f32, 0.01 * (k as f32 * 0.1).sin(), 0.0] {
            d.extend_from_slice(&v.to_le_bytes());
        }
        ulog_msg(&mut b, b'D', &d);
        if k % 5 == 0 {
            let mut d = 1u16.to_le_bytes().to_vec();
            d.extend_from_slice(&t.to_le_bytes());
            d.extend_from_slice(&(18.0f32 + (k as f32 * 0.02).sin()).to_le_bytes());
            d.push(source as u8);
            ulog_msg(&mut b, b'D', &d);
        }
    }
    b
}

#[test]
fn ulog_airspeed_from_ground_minus_wind_or_synthetic_is_estimated() {
    let map = ColumnMap::ulog_default(placeholder_aircraft());
    let read = |field: &str, source: i8| {
        parse_ulog(&ulog_with_source(field, source), "as.ulg", &map).unwrap_or_else(|e| panic!("{e}"))
    };
    // Older logs: `selected_airspeed_index` 0 is ground speed minus wind, 1 the first sensor.
    let f = read("selected_airspeed_index", 0);
    assert!(f.get(Quantity::Airspeed).is_some());
    match f.log.origin_of(Quantity::Airspeed) {
        Origin::Estimated { by } => assert!(by.contains("airspeed_validated") && by.contains("100 of 100"), "{by}"),
        o => panic!("{o:?}"),
    }
    assert_eq!(
        read("selected_airspeed_index", 1).log.origin_of(Quantity::Airspeed),
        Origin::Sensor
    );
    // PX4 1.15 on: `airspeed_source` 4 is the synthetic airspeed, 2 the second sensor.
    assert!(read("airspeed_source", 4).log.is_estimated(Quantity::Airspeed));
    assert!(!read("airspeed_source", 2).log.is_estimated(Quantity::Airspeed));
    // Index 4 meant nothing before the field was renamed: a sensor index out of range is not
    // read as "synthetic".
    assert!(!read("selected_airspeed_index", 4).log.is_estimated(Quantity::Airspeed));
}

// ---- Column maps: `origin.QUANTITY`.

const MAP_HEAD: &str = "format = ascii\ncolumns = 4\naircraft = ../aircraft/hfb320.aircraft\ntime = $1 s\nchannel.alpha = $2 rad\nchannel.airspeed = $3 m/s\nchannel.pitch_rate = $4 rad/s\n";

#[test]
fn a_map_states_a_channels_origin() {
    let map = parse_map(
        &format!(
            "{MAP_HEAD}origin.alpha = estimated autopilot EKF, ground velocity minus wind\norigin.airspeed = sensor\n"
        ),
        "est.map",
        &aircraft_dir(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let text: String = (0..200)
        .map(|i| {
            let t = i as f64 * 0.02;
            format!(
                "{t} {} 20.0 {}\n",
                0.05 + 0.01 * (t * 3.0).sin(),
                0.02 * (t * 3.0).cos()
            )
        })
        .collect();
    let f = parse_ascii(&text, "est.asc", &map).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        f.log.origin_of(Quantity::Alpha),
        Origin::Estimated {
            by: "autopilot EKF, ground velocity minus wind".into()
        }
    );
    assert_eq!(f.log.origin_of(Quantity::Airspeed), Origin::Sensor);
    // Refusals name the line and say what is expected.
    let refused = |extra: &str, want: &str, line: usize| {
        let e = parse_map(&format!("{MAP_HEAD}{extra}"), "bad.map", &aircraft_dir()).expect_err(extra);
        assert!(e.message.contains(want), "{extra}: {e}");
        assert_eq!(e.line, line, "{extra}: {e}");
    };
    refused("origin.alpha = estimated\n", "needs what estimated it", 8);
    refused("origin.alpha = vane\n", "`sensor` or `estimated BY`", 8);
    refused("origin.beta = estimated EKF\n", "has no `channel.beta`", 8);
    refused("origin.alpha = sensor\norigin.alpha = sensor\n", "already set", 9);
    refused("origin.gamma = sensor\n", "unknown quantity", 8);
}

// ---- The project CSV: `alpha_est_rad`, `beta_est_rad`, `airspeed_est_mps`.

fn csv(header: &str, row: impl Fn(f64) -> String) -> String {
    let mut s = format!("{header}\n");
    for i in 0..300 {
        s += &row(i as f64 * 0.02);
        s.push('\n');
    }
    s
}

#[test]
fn csv_estimated_columns_are_the_same_quantity_marked_estimated() {
    let text = csv("t_s,alpha_est_rad,beta_est_rad,airspeed_est_mps,gyro_rad_s_y", |t| {
        format!(
            "{t},{},{},{},{}",
            0.05 + 0.01 * t.sin(),
            0.01 * t.cos(),
            20.0 + t.sin(),
            0.01 * t.cos()
        )
    });
    let f = parse_project_csv(&text, "est.csv", placeholder_aircraft()).unwrap_or_else(|e| panic!("{e}"));
    for q in [Quantity::Alpha, Quantity::Beta, Quantity::Airspeed] {
        assert!(f.get(q).is_some(), "{q}");
        assert!(f.log.is_estimated(q), "{q}");
    }
    assert!(!f.log.is_estimated(Quantity::PitchRate));
    assert!((f.get(Quantity::Alpha).expect("alpha")[0] - 0.05).abs() < 1e-12);
    // With the sensor's column too, the sensor's is read and the estimate ignored, with a warning.
    let both = csv("t_s,alpha_rad,alpha_est_rad", |t| {
        format!("{t},{},{}", 0.04 + 0.01 * t.sin(), 0.9)
    });
    let f = parse_project_csv(&both, "both.csv", placeholder_aircraft()).unwrap_or_else(|e| panic!("{e}"));
    assert!(!f.log.is_estimated(Quantity::Alpha));
    assert!((f.get(Quantity::Alpha).expect("alpha")[0] - 0.04).abs() < 1e-12);
    assert!(f
        .log
        .warnings
        .iter()
        .any(|w| w.contains("'alpha_est_rad'") && w.contains("ignored")));
    // A bad cell of an estimated column is named by its own name.
    let bad = csv("t_s,alpha_est_rad", |t| {
        format!("{t},{}", if t > 1.0 { 3.5 } else { 0.05 })
    });
    let e = parse_project_csv(&bad, "bad.csv", placeholder_aircraft()).expect_err("out of range");
    assert!(e.message.contains("alpha_est_rad") && e.column == 2, "{e}");
}

#[test]
fn csv_held_channel_is_read_at_its_true_rate() {
    // α held at 10 Hz on a 50 Hz grid (each value five times), q at the full rate.
    let text = csv("t_s,alpha_est_rad,gyro_rad_s_y", |t| {
        let k = (t * 50.0).round() as i64;
        let held = (k / 5) as f64 * 0.1;
        format!("{t},{},{}", 0.05 + 0.02 * held.sin(), 0.01 * (3.0 * t).cos())
    });
    let f = parse_project_csv(&text, "held.csv", placeholder_aircraft()).unwrap_or_else(|e| panic!("{e}"));
    let r = f
        .log
        .logged_rate_hz
        .get(&Quantity::Alpha)
        .copied()
        .expect("α's rate recorded");
    assert!((r - 10.0).abs() < 0.1, "{r} Hz");
    assert!(!f.log.logged_rate_hz.contains_key(&Quantity::PitchRate));
    // No staircase left between the first and the last sample instant: no two neighbours equal.
    let a = f.get(Quantity::Alpha).expect("alpha");
    assert!(a[..295].windows(2).all(|w| w[0] != w[1]), "still held");
    assert!(f.log.warnings.iter().any(|w| w.contains("`alpha` is held")));
    // The data quality judges the channel by its true rate.
    let q = aerosid::gaps::quality::assess(&f);
    assert!(
        q.warnings.iter().any(|w| w.contains("`alpha` logged at 10.0 Hz")),
        "{:?}",
        q.warnings
    );
}

// ---- The gap analysis.

#[test]
fn an_estimated_alpha_gets_no_vane_errors_and_no_alpha_dot_in_c_l() {
    let vane = hidden::flight(None, 40.0, 3, true).unwrap_or_else(|e| panic!("{e}"));
    let mut est = vane.clone();
    est.log.set_estimated(Quantity::Alpha, "test estimator");
    // Compatibility candidates: the vane's errors are offered for the vane only.
    let of = |f: &aerosid::io::measured::MeasuredFlight| -> Vec<String> {
        compat::velocity_candidates(f)
            .iter()
            .filter(|p| p.channel() == Quantity::Alpha)
            .map(|p| p.name())
            .collect()
    };
    assert_eq!(of(&vane).len(), 4, "{:?}", of(&vane));
    assert!(of(&est).is_empty(), "{:?}", of(&est));
    // Beta stays a vane here and keeps its candidates.
    assert!(compat::velocity_candidates(&est)
        .iter()
        .any(|p| p.channel() == Quantity::Beta));
    // α̇ is offered with the vane, and with the estimate in no coefficient (the measured lift
    // restated, or in turbulence the gust's lift standing in); β̇ is kept (β is a vane); the table
    // says why.
    let h = vane.t_s[1] - vane.t_s[0];
    let (tv, te) = (
        synthesise(&vane, h, &Corrections::default(), 5, None),
        synthesise(&est, h, &Corrections::default(), 5, None),
    );
    for i in 0..6 {
        let lib = Term::library(i);
        assert_eq!(
            Term::offered(i, &tv).contains(&Term::AlphaDot),
            lib.contains(&Term::AlphaDot),
            "vane, coefficient {i}"
        );
        assert!(
            !Term::offered(i, &te).contains(&Term::AlphaDot),
            "estimate, coefficient {i}"
        );
        assert_eq!(
            Term::offered(i, &te).contains(&Term::BetaDot),
            lib.contains(&Term::BetaDot),
            "β vane, coefficient {i}"
        );
    }
    assert!(te
        .notes
        .iter()
        .any(|n| n.contains("α̇ not offered in C_m") && n.contains("gust")));
    assert!(te
        .notes
        .iter()
        .any(|n| n.contains("α̇ not offered in C_L") && n.contains("test estimator")));
    // The whole analysis: no α sensor error tested, no α̇ candidate in C_L, the origin reported.
    let r = run_gaps(&est, &GapSettings::default()).unwrap_or_else(|e| panic!("{e}"));
    assert!(r
        .compatibility
        .tested
        .iter()
        .all(|p| p.param.channel() != Quantity::Alpha));
    let cl = r.coefficients.iter().find(|c| c.name == "C_L").expect("C_L");
    assert!(cl.candidates.iter().all(|c| c.term != Term::AlphaDot.name()));
    assert!(r.named.iter().all(|n| n.location != "Alpha"));
    assert!(r
        .notes
        .iter()
        .any(|n| n.contains("Alpha is estimated (test estimator)")));
    let json = aerosid::gaps::report::json(&r);
    assert_eq!(json["channel_origin"]["Alpha"], "estimated: test estimator");
    assert_eq!(json["channel_origin"]["Airspeed"], "sensor");
    assert!(
        aerosid::gaps::report::table(&r).contains("channel origin: Airspeed sensor; Alpha estimated: test estimator")
    );
}

#[test]
fn the_shipped_flight_test_data_hold_only_the_attas_mach() {
    // Recorded at their own rates (HFB-320 10 Hz, ATTAS 25 Hz, Twin Otter 50 Hz). The ATTAS Mach
    // column is a staircase (runs of 3 and 4 rows, a few of 6 and 7: about 8 Hz on 25 Hz); every
    // other channel read, the constant, quantised and stepped ones among them, is left alone.
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    for (file, map) in [
        ("hfb320_1_10.asc", "hfb320.map"),
        ("fAttasElv1_pqrDot.asc", "attas.map"),
        ("fAttasAil1_pqrDot.asc", "attas.map"),
        ("fAttasRud1_pqrDot.asc", "attas.map"),
        ("totter_lon_020213f1_018_fdata.asc", "twin_otter.map"),
    ] {
        let f = aerosid::io::read_measured(&data.join("flight").join(file), &data.join("maps").join(map))
            .unwrap_or_else(|e| panic!("{e}"));
        println!("{file}: held {:?}", f.log.logged_rate_hz);
        let held: Vec<_> = f.log.logged_rate_hz.keys().copied().collect();
        if file.starts_with("fAttas") {
            assert_eq!(held, [Quantity::Mach], "{file}");
            let r = f.log.logged_rate_hz[&Quantity::Mach];
            assert!((7.5..=8.5).contains(&r), "{file}: Mach at {r} Hz");
        } else {
            assert!(held.is_empty(), "{file}: {held:?}");
        }
    }
}
