//! Issue 6 §1: reading measured data — the shared flight-test files through their column maps,
//! the project CSV, PX4 ULog (written here by a small ULog writer from a simulated flight), and
//! bad files refused with errors naming the file, line and column (or the ULog message).

use aerosid_core::aero::SensorSample;
use aerosid_host::io::aircraft::parse_aircraft;
use aerosid_host::io::measured::{Aircraft, MeasuredFlight, Quantity, ThrustSource};
use aerosid_host::io::{read_measured, ReadError};
use aerosid_host::sim::airframe::SimAirframe;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Helpers

fn flight_dir() -> PathBuf {
    // Where `fem_report::default_hfb320_path` (and tests/fem.rs) find the shared flight data.
    aerosid_host::fem_report::default_hfb320_path()
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

fn maps() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/maps")
}

fn aircraft_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/aircraft")
}

/// A fresh scratch folder per test.
fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("aerosid-measured-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

fn load(file: &str, map: &str) -> MeasuredFlight {
    match read_measured(&flight_dir().join(file), &maps().join(map)) {
        Ok(f) => f,
        Err(e) => panic!("{e}"),
    }
}

fn ch(f: &MeasuredFlight, q: Quantity) -> &[f64] {
    f.get(q).unwrap_or_else(|| panic!("{}: no channel {q}", f.source))
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// The raw numbers of one line (1-based) of a shared ASCII file, parsed independently.
fn raw_row(file: &str, line: usize) -> Vec<f64> {
    let text = std::fs::read_to_string(flight_dir().join(file)).expect("data file");
    let l = text.lines().nth(line - 1).expect("line");
    l.split_whitespace()
        .map(|s| s.parse::<f64>().expect("number"))
        .collect()
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Kinematic sanity (Euler 3-2-1 kinematics): over windows of `window_s` starting every second,
/// the change of the attitude angle `angle` against the trapezoidal integral of its Euler rate
/// (`θ̇ = q cos φ − r sin φ`, `φ̇ = p + (q sin φ + r cos φ) tan θ`); returns the correlation of the
/// two over all windows' samples and the least-squares slope (measured on integrated).
fn attitude_vs_integrated_rates(f: &MeasuredFlight, angle: Quantity, window_s: f64) -> (f64, f64) {
    let t = &f.t_s;
    let (p, q, r) = (
        ch(f, Quantity::RollRate),
        ch(f, Quantity::PitchRate),
        ch(f, Quantity::YawRate),
    );
    let (phi, theta) = (ch(f, Quantity::Roll), ch(f, Quantity::Pitch));
    let rate = |i: usize| match angle {
        Quantity::Pitch => q[i] * phi[i].cos() - r[i] * phi[i].sin(),
        _ => p[i] + (q[i] * phi[i].sin() + r[i] * phi[i].cos()) * theta[i].tan(),
    };
    let x = ch(f, angle);
    let (mut integ, mut meas) = (Vec::new(), Vec::new());
    let mut start = 0;
    while start < t.len() {
        let mut acc = 0.0;
        let mut i = start + 1;
        while i < t.len() && t[i] - t[start] <= window_s {
            acc += 0.5 * (rate(i - 1) + rate(i)) * (t[i] - t[i - 1]);
            integ.push(acc);
            meas.push(x[i] - x[start]);
            i += 1;
        }
        if i >= t.len() {
            break;
        }
        let next = t[start] + 1.0;
        while start < t.len() && t[start] < next {
            start += 1;
        }
    }
    let c = correlation(&integ, &meas);
    let sxy: f64 = integ.iter().zip(&meas).map(|(a, b)| a * b).sum();
    let sxx: f64 = integ.iter().map(|a| a * a).sum();
    (c, sxy / sxx)
}

fn assert_error(e: &ReadError, file_ends: &str, line: usize, column: usize, words: &[&str]) {
    let text = e.to_string();
    assert!(
        e.file.ends_with(file_ends),
        "file `{}` should end with `{file_ends}`: {text}",
        e.file
    );
    assert_eq!((e.line, e.column), (line, column), "{text}");
    let prefix = if column > 0 {
        format!("{}:{line}:{column}: ", e.file)
    } else if line > 0 {
        format!("{}:{line}: ", e.file)
    } else {
        format!("{}: ", e.file)
    };
    assert!(text.starts_with(&prefix), "`{text}` should start with `{prefix}`");
    for w in words {
        assert!(text.contains(w), "`{text}` should mention `{w}`");
    }
}

// ---------------------------------------------------------------------------------------------
// The shared flight-test data through the shipped maps

#[test]
fn hfb320_loads_through_its_map() {
    let f = load("hfb320_1_10.asc", "hfb320.map");
    // README s.1: 601 rows, t = 0 … 60 s, dt = 0.1 s.
    assert_eq!(f.len(), 601);
    // (The last time in the file is written 60.00002.)
    assert!(f.t_s[0] == 0.0 && (f.t_s[600] - 60.0).abs() < 1e-4);
    // README s.1: "starts near V ≈ 106 m/s and α ≈ 0.11 rad"; the first row has 106.0321 and 0.1117975.
    assert_eq!(ch(&f, Quantity::Airspeed)[0], 106.0321);
    assert_eq!(ch(&f, Quantity::Alpha)[0], 0.1117975);
    // Column 11 is az (≈ −9.8), column 12 ay (README's correction of the data's own README).
    let az = mean(ch(&f, Quantity::AccelZ));
    assert!((-10.3..-9.3).contains(&az), "mean az {az}");
    assert!(mean(ch(&f, Quantity::AccelY)).abs() < 0.5);
    assert_eq!(ch(&f, Quantity::AccelZ)[0], -9.86526);
    assert_eq!(ch(&f, Quantity::AirDensity), vec![0.792; 601].as_slice());
    // The measured q̄ against ½ρV² with the book's constant ρ: within 2 % at the first row
    // (4467.6 Pa against 4452.0 Pa; the book's ρ is a rounded constant).
    let qbar = 0.5 * 0.792 * 106.0321f64.powi(2);
    assert!((ch(&f, Quantity::DynamicPressure)[0] / qbar - 1.0).abs() < 0.02);
    // Aircraft constants (README s.1).
    let a = &f.aircraft;
    assert_eq!(a.mass_kg, 7472.0);
    assert!((a.wing_area_m2 / a.mass_kg - 4.028e-3).abs() < 1e-12);
    assert!((a.wing_area_m2 * a.chord_m / a.inertia_kgm2[(1, 1)] - 8.0027e-4).abs() < 1e-9);
    assert!(a.span_m.is_nan() && a.inertia_kgm2[(0, 0)].is_nan());
    match a.thrust {
        ThrustSource::Measured { position_m, pitch_rad } => {
            assert_eq!(pitch_rad, 0.0524);
            // The book's thrust pitching moment q̇ += −7.0153e-6·F (README s.1), to 1e-5 relative.
            let m_per_n = position_m.z * pitch_rad.cos() + position_m.x * pitch_rad.sin();
            assert!((m_per_n / a.inertia_kgm2[(1, 1)] / -7.0153e-6 - 1.0).abs() < 1e-5);
        }
        ref t => panic!("HFB-320 thrust {t:?}"),
    }
}

#[test]
fn attas_segments_load_through_one_map() {
    // README s.2: Elv1 626 samples 0–25 s, Ail1 751 samples 50.08–80.08 s, Rud1 751 samples
    // 110.16–140.16 s.
    for (file, n, t0, t1) in [
        ("fAttasElv1_pqrDot.asc", 626, 0.0, 25.0),
        ("fAttasAil1_pqrDot.asc", 751, 50.08, 80.08),
        ("fAttasRud1_pqrDot.asc", 751, 110.16, 140.16),
    ] {
        let f = load(file, "attas.map");
        assert_eq!(f.len(), n, "{file}");
        assert!(
            (f.t_s[0] - t0).abs() < 1e-9 && (f.t_s[n - 1] - t1).abs() < 1e-9,
            "{file}"
        );
        // Flight condition (README s.2): V ≈ 128–132 m/s, ≈ 16 000 ft, Mach 0.40, ρ ≈ 0.727.
        let v = mean(ch(&f, Quantity::Airspeed));
        assert!((126.0..134.0).contains(&v), "{file}: V {v}");
        let h_ft = mean(ch(&f, Quantity::Altitude)) / 0.3048;
        assert!((15_500.0..16_500.0).contains(&h_ft), "{file}: h {h_ft} ft");
        assert!((mean(ch(&f, Quantity::Mach)) - 0.40).abs() < 0.015, "{file}");
        assert!((mean(ch(&f, Quantity::AirDensity)) - 0.727).abs() < 0.01, "{file}");
        // The pre-processing, checked at the first row against the raw numbers: degrees → rad,
        // δa = (DAIL_R − DAIL_L)/2, biases subtracted, thrust sum and difference.
        let raw = raw_row(file, 1);
        let d = PI / 180.0;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
        assert!(close(ch(&f, Quantity::Aileron)[0], (raw[28] - raw[27]) / 2.0 * d));
        assert!(close(ch(&f, Quantity::Alpha)[0], raw[12] * d));
        assert!(close(ch(&f, Quantity::AccelZ)[0], raw[3] - 8.39892e-2));
        assert!(close(ch(&f, Quantity::PitchRate)[0], raw[7] * d - 3.40891e-3));
        assert!(close(ch(&f, Quantity::Thrust)[0], raw[36] + raw[37]));
        assert!(close(ch(&f, Quantity::ThrustDifference)[0], raw[36] - raw[37]));
        assert!(close(ch(&f, Quantity::PitchAccel)[0], raw[46]));
        let a = &f.aircraft;
        assert_eq!(
            (a.mass_kg, a.wing_area_m2, a.chord_m, a.span_m),
            (17631.0, 64.0, 3.159, 21.5)
        );
        assert_eq!(a.inertia_kgm2[(0, 2)], -1.14420e4);
        assert_eq!(a.accel_position_m.x, -1.010);
        assert_eq!(a.alpha_vane_position_m.x, 13.080);
        assert!(
            matches!(a.thrust, ThrustSource::MeasuredTwin { right_engine_position_m, .. }
            if right_engine_position_m.y == 2.990 && right_engine_position_m.z == -0.652)
        );
    }
}

#[test]
fn twin_otter_loads_in_si_units() {
    let f = load("totter_lon_020213f1_018_fdata.asc", "twin_otter.map");
    // README s.3: 401 samples, dt = 0.02 s, time of day 53550.06 … 53558.06 s.
    assert_eq!(f.len(), 401);
    assert!((f.t_s[0] - 53550.06).abs() < 1e-9 && (f.t_s[400] - 53558.06).abs() < 1e-9);
    // V ≈ 236 ft/s = 71.9 m/s; first row 238.112857 ft/s exactly converted.
    assert!((ch(&f, Quantity::Airspeed)[0] - 238.112857 * 0.3048).abs() < 1e-12);
    let v = mean(ch(&f, Quantity::Airspeed));
    assert!((v / 0.3048 - 236.0).abs() < 1.0, "V {v} m/s");
    // Altitude ≈ 7 200 ft, q̄ ≈ 55.6 lbf/ft² = 2662 Pa (README s.3).
    assert!((mean(ch(&f, Quantity::Altitude)) / 0.3048 - 7200.0).abs() < 30.0);
    let qbar = mean(ch(&f, Quantity::DynamicPressure));
    assert!((qbar / 47.880_259 - 55.6).abs() < 0.2, "q̄ {qbar} Pa");
    // q̄ = ½ρV² holds in SI after the three conversions (ft/s, slug/ft³, lbf/ft²): within 1 %.
    let (rho, vv) = (ch(&f, Quantity::AirDensity), ch(&f, Quantity::Airspeed));
    for i in [0, 200, 400] {
        let r = ch(&f, Quantity::DynamicPressure)[i] / (0.5 * rho[i] * vv[i] * vv[i]);
        assert!((r - 1.0).abs() < 0.01, "sample {i}: q̄/(½ρV²) = {r}");
    }
    // Accelerations from g: az ≈ −1 g.
    assert!((mean(ch(&f, Quantity::AccelZ)) / 9.80665 + 1.0).abs() < 0.05);
    // α0 ≈ 0.2° (README s.3).
    assert!((mean(ch(&f, Quantity::Alpha)).to_degrees() - 0.2).abs() < 0.15);
    let a = &f.aircraft;
    // 338.769 slug, S 422.48 ft², b 64.99 ft, c̄ 6.496 ft.
    assert!((a.mass_kg - 338.769 * 14.593_902_937).abs() < 1e-5);
    assert!((a.wing_area_m2 - 422.48 * 0.09290304).abs() < 1e-9);
    assert!((a.chord_m - 6.496 * 0.3048).abs() < 1e-12);
    assert!((a.inertia_kgm2[(1, 1)] - 24273.0 * 1.355_817_948).abs() < 1e-3);
}

/// Euler kinematics on each file: Δθ (or Δφ for the aileron segment) over 4 s windows against
/// the integral of the measured rates. Tolerance: correlation > 0.9 and slope within 15 % of 1 —
/// a degree/radian mix-up gives a slope of 57 or 1/57, a sign error −1; the rate biases (up to
/// 3.4e-3 rad/s on ATTAS, 0.014 rad over a window) against angle changes of 0.05–0.5 rad leave
/// the correlation above 0.9.
#[test]
fn attitudes_agree_with_integrated_rates() {
    for (file, map, angle) in [
        ("hfb320_1_10.asc", "hfb320.map", Quantity::Pitch),
        ("fAttasElv1_pqrDot.asc", "attas.map", Quantity::Pitch),
        ("fAttasAil1_pqrDot.asc", "attas.map", Quantity::Roll),
        ("totter_lon_020213f1_018_fdata.asc", "twin_otter.map", Quantity::Pitch),
    ] {
        let f = load(file, map);
        let (c, k) = attitude_vs_integrated_rates(&f, angle, 4.0);
        println!("{file}: {angle} against integrated rates: correlation {c:.4}, slope {k:.4}");
        assert!(c > 0.9, "{file}: correlation {c}");
        assert!((k - 1.0).abs() < 0.15, "{file}: slope {k}");
    }
}
