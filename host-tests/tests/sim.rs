//! Scenario tests of the truth simulator and the CSV log layout. Seeded and fast.

use aerosid::io::log::{read_log, write_log, write_log_with_truth, LogError, COLUMNS};
use aerosid_core::aero::SensorSample;
use aerosid_sim::aero::{coefficients_from, AeroInput};
use aerosid_sim::dynamics::G_MPS2;
use aerosid_sim::*;
use nalgebra::{UnitQuaternion, Vector3};

/// A sensor channel read from a sample.
type Reading = dyn Fn(&SensorSample<f64>) -> f64;

fn quiet(effects: TruthEffects) -> SimConfig {
    SimConfig {
        plant: Plant::new(SimAirframe::skywalker_2013_mod(), effects),
        sensors: SensorNoise::none(),
        stabiliser: None,
        ..SimConfig::default()
    }
}

#[test]
fn trimmed_level_flight_stays_level_for_30_s() {
    // GIVEN the skywalker with every hidden effect on, trimmed at 15 m/s and 100 m, open loop,
    // calm air, no inputs
    let cfg = SimConfig {
        duration_s: 30.0,
        ..quiet(TruthEffects::all())
    };
    // WHEN it flies 30 s
    let out = simulate(&cfg).expect("trim");
    // THEN the trim is an equilibrium and altitude and airspeed drift by less than 0.05 m and 0.01 m/s
    assert!(out.trim.residual < 1e-8, "residual {}", out.trim.residual);
    assert!(out.trim.controls.throttle > 0.0 && out.trim.controls.throttle < 1.0);
    let last = out.truth.last().expect("samples");
    let dh = (last.state.altitude_m() - 100.0).abs();
    let dv = (last.eval.airspeed_mps - 15.0).abs();
    assert!(dh < 0.05 && dv < 0.01, "dh {dh}, dv {dv}");
    assert_eq!(out.samples.len(), 3000);
}

#[test]
fn rascal_trims_and_stabilised_flight_with_turbulence_stays_bounded() {
    // GIVEN the Rascal 110 at 20 m/s in moderate turbulence, with the stabiliser, and the skywalker
    // with manoeuvres on every channel in light turbulence
    let rascal = SimConfig {
        plant: Plant::new(SimAirframe::rascal_110(), TruthEffects::all()),
        airspeed_mps: 20.0,
        turbulence: Some(Turbulence::mil_f_8785c_low_altitude(
            100.0,
            Turbulence::W20_MODERATE_MPS,
        )),
        duration_s: 60.0,
        ..SimConfig::default()
    };
    let m = |channel, shape, start_s, amplitude, period_s| Manoeuvre {
        channel,
        shape,
        start_s,
        amplitude,
        period_s,
    };
    let sky = SimConfig {
        turbulence: Some(Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_LIGHT_MPS)),
        schedule: Schedule::default()
            .with(m(Channel::Elevator, Shape::Multistep3211, 5.0, 0.05, 0.3))
            .with(m(Channel::Aileron, Shape::Doublet, 10.0, 0.1, 0.5))
            .with(m(
                Channel::Rudder,
                Shape::Sweep {
                    f0_hz: 0.2,
                    f1_hz: 2.0,
                    duration_s: 10.0,
                },
                15.0,
                0.05,
                1.0,
            ))
            .with(m(Channel::Throttle, Shape::Step, 30.0, 0.1, 3.0)),
        duration_s: 60.0,
        ..SimConfig::default()
    };
    for cfg in [rascal, sky] {
        // WHEN each flies 60 s
        let out = simulate(&cfg).expect("trim");
        // THEN altitude stays within 30 m and airspeed within 5 m/s of trim, attitude within 45°
        for t in &out.truth {
            assert!(
                (t.state.altitude_m() - 100.0).abs() < 30.0,
                "{} t {} h {}",
                cfg.plant.airframe.name,
                t.t_s,
                t.state.altitude_m()
            );
            assert!(
                (t.eval.airspeed_mps - cfg.airspeed_mps).abs() < 5.0,
                "t {} V {}",
                t.t_s,
                t.eval.airspeed_mps
            );
            let e = t.state.euler_rad();
            assert!(e.x.abs() < 0.8 && e.y.abs() < 0.8, "t {} euler {e:?}", t.t_s);
        }
    }
}

#[test]
fn a_body_without_aerodynamics_or_thrust_falls_at_g() {
    // GIVEN the skywalker at rest with aerodynamics and propulsion off
    let mut plant = Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::none());
    plant.aerodynamics = false;
    plant.propulsion = false;
    let mut x = RigidState {
        position_ned_m: Vector3::zeros(),
        velocity_body_mps: Vector3::zeros(),
        attitude: UnitQuaternion::from_euler_angles(0.3, -0.2, 1.0),
        rate_rad_s: Vector3::zeros(),
    };
    // WHEN it is integrated for 2 s in 2 ms steps
    let h = 0.002;
    for k in 0..1000 {
        x = plant.rk4_step(&x, &Controls::default(), &Vector3::zeros(), k as f64 * h, h);
    }
    // THEN it has fallen ½gt² with velocity gt straight down (RK4 is exact for this polynomial)
    let v_ned = x.attitude.transform_vector(&x.velocity_body_mps);
    assert!(
        (v_ned - Vector3::new(0.0, 0.0, 2.0 * G_MPS2)).norm() < 1e-9,
        "{v_ned:?}"
    );
    assert!((x.position_ned_m - Vector3::new(0.0, 0.0, 2.0 * G_MPS2)).norm() < 1e-9);
}

#[test]
fn a_pure_roll_rate_integrates_to_the_bank_angle_and_free_rotation_conserves_energy_and_momentum() {
    // GIVEN a force-free body with Jxz = 0 rolling at 0.5 rad/s
    let mut af = SimAirframe::skywalker_2013_mod();
    let mut plant = Plant::new(af.clone(), TruthEffects::none());
    plant.aerodynamics = false;
    plant.propulsion = false;
    plant.gravity_mps2 = 0.0;
    let free = plant.clone();
    af.frame.inertia_kgm2[(0, 2)] = 0.0;
    af.frame.inertia_kgm2[(2, 0)] = 0.0;
    plant.airframe = af;
    let x0 = RigidState {
        position_ned_m: Vector3::zeros(),
        velocity_body_mps: Vector3::zeros(),
        attitude: UnitQuaternion::identity(),
        rate_rad_s: Vector3::new(0.5, 0.0, 0.0),
    };
    // WHEN integrated for 2 s
    let mut x = x0;
    for k in 0..1000 {
        x = plant.rk4_step(&x, &Controls::default(), &Vector3::zeros(), k as f64 * 0.002, 0.002);
    }
    // THEN φ = 1 rad, θ = ψ = 0 to 1e-12
    let e = x.euler_rad();
    assert!((e - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12, "{e:?}");
    // AND GIVEN the published inertia (Jxz ≠ 0) and a tumbling start, WHEN integrated for 10 s,
    // THEN rotational energy and inertial angular momentum are conserved to 1e-9 (relative)
    let j = free.airframe.frame.inertia_kgm2;
    let mut x = RigidState {
        rate_rad_s: Vector3::new(1.0, -0.7, 0.4),
        ..x0
    };
    let energy = |x: &RigidState| 0.5 * x.rate_rad_s.dot(&(j * x.rate_rad_s));
    let momentum = |x: &RigidState| x.attitude.transform_vector(&(j * x.rate_rad_s));
    let (e0, h0) = (energy(&x), momentum(&x));
    for k in 0..5000 {
        x = free.rk4_step(&x, &Controls::default(), &Vector3::zeros(), k as f64 * 0.002, 0.002);
    }
    assert!(((energy(&x) - e0) / e0).abs() < 1e-9);
    assert!((momentum(&x) - h0).norm() / h0.norm() < 1e-9);
}

#[test]
fn truth_coefficients_recomputed_from_truth_forces_match_the_model() {
    // GIVEN a 20 s flight with every effect, light turbulence, a 3-2-1-1 and a doublet
    let cfg = SimConfig {
        turbulence: Some(Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_LIGHT_MPS)),
        schedule: Schedule::default()
            .with(Manoeuvre {
                channel: Channel::Elevator,
                shape: Shape::Multistep3211,
                start_s: 2.0,
                amplitude: 0.05,
                period_s: 0.4,
            })
            .with(Manoeuvre {
                channel: Channel::Aileron,
                shape: Shape::Doublet,
                start_s: 8.0,
                amplitude: 0.1,
                period_s: 0.5,
            }),
        duration_s: 20.0,
        ..SimConfig::default()
    };
    let out = simulate(&cfg).expect("trim");
    let af = &cfg.plant.airframe;
    let j = af.frame.inertia_kgm2;
    for t in &out.truth {
        let e = &t.eval;
        // WHEN the aerodynamic force and moment are rebuilt as the on-board synthesis would —
        // F_A = m a_spec − F_T, M_A = J ω̇ + ω×Jω − M_T — and eq. 1–2 are solved for the coefficients
        let w = t.state.rate_rad_s;
        let f = e.specific_force_mps2 * af.frame.mass_kg - e.thrust_force_n;
        let m = j * e.rate_dot_rad_s2 + w.cross(&(j * w)) - e.thrust_moment_nm;
        let c = coefficients_from(&f, &m, e.qbar_pa, &af.geometry(), e.alpha_rad);
        // THEN they equal the truth model's coefficients to 1e-10
        let (a, b) = (c.to_array(), e.coefficients.to_array());
        for i in 0..6 {
            assert!(
                (a[i] - b[i]).abs() < 1e-10,
                "t {} coefficient {i}: {} vs {}",
                t.t_s,
                a[i],
                b[i]
            );
        }
        // AND the truth coefficients are the truth model evaluated at the recorded regressors
        let again = cfg.plant.truth_at(t.t_s).coefficients(&e.input).to_array();
        assert_eq!(again, b);
    }
}

fn assert_model(got: &CoeffModel, want: &CoeffModel, tol: f64, what: &str) {
    let (g, w) = (got.to_array(), want.to_array());
    for i in 0..10 {
        assert!((g[i] - w[i]).abs() < tol, "{what}[{i}]: {} vs {}", g[i], w[i]);
    }
}

#[test]
fn linearisation_of_the_truth_recovers_the_table_with_effects_off() {
    // GIVEN the skywalker truth with the hidden effects off, and a trimmed flight condition with
    // non-zero rates and surfaces
    let plant = Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::none());
    let x0 = AeroInput {
        alpha_rad: 0.05,
        beta_rad: 0.02,
        p_n: 0.01,
        q_n: -0.01,
        r_n: 0.005,
        aileron_rad: 0.03,
        elevator_rad: -0.02,
        rudder_rad: 0.01,
    };
    // WHEN it is linearised
    let lin = plant.truth.linearise(&x0);
    // THEN every coefficient equals the table (CLα 6.5, Cmα −1.3, Cmq −20, Clp −1, …) to 1e-7
    let table = LinearAero::skywalker_2013_mod();
    for (i, (g, w)) in lin.to_array().iter().zip(table.to_array().iter()).enumerate() {
        assert_model(g, w, 1e-7, &format!("coefficient {i}"));
    }
    assert!(
        (lin.lift.alpha - 6.5).abs() < 1e-7
            && (lin.pitch.alpha + 1.3).abs() < 1e-7
            && (lin.pitch.q_n + 20.0).abs() < 1e-6
    );
    // AND GIVEN only induced drag with e = 0.9, THEN C_Dα² = C_Lα²/(π e AR) and the linear model
    // reproduces the truth's C_D exactly away from x0 (it is a quadratic)
    let mut eff = TruthEffects::none();
    eff.induced_drag_oswald = Some(0.9);
    let p2 = Plant::new(SimAirframe::skywalker_2013_mod(), eff);
    let l2 = p2.truth.linearise(&x0);
    let k = 6.5 * 6.5 / (core::f64::consts::PI * 0.9 * p2.truth.aspect_ratio);
    assert!((l2.drag.alpha2 - k).abs() < 1e-5, "{} vs {k}", l2.drag.alpha2);
    let x1 = AeroInput { alpha_rad: 0.12, ..x0 };
    assert!((l2.drag.eval(&x1) - p2.truth.coefficients(&x1).drag).abs() < 1e-6);
    // AND with every effect on at the trim α, the lift slope differs from 6.5 by less than 1e-6
    // (stall blending is negligible at small α)
    let p3 = Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::all());
    assert!((p3.truth.linearise(&x0).lift.alpha - 6.5).abs() < 1e-6);
}

#[test]
fn parameter_jump_changes_the_truth_at_its_time() {
    // GIVEN a C_m jump (Cmα −1.3 → −0.9, Cmq −20 → −15) at t = 5 s
    let mut cfg = quiet(TruthEffects::none());
    let mut delta = LinearAero::default();
    delta.pitch.alpha = 0.4;
    delta.pitch.q_n = 5.0;
    cfg.plant.jump = Some(ParameterJump { at_s: 5.0, delta });
    cfg.duration_s = 6.0;
    cfg.stabiliser = Some(Stabiliser::default());
    // WHEN the truth is linearised before and after
    let x0 = AeroInput::default();
    let (before, after) = (
        cfg.plant.truth_at(4.99).linearise(&x0),
        cfg.plant.truth_at(5.0).linearise(&x0),
    );
    // THEN the new values hold from 5 s on and the flight still runs
    assert!((before.pitch.alpha + 1.3).abs() < 1e-7 && (after.pitch.alpha + 0.9).abs() < 1e-7);
    assert!((after.pitch.q_n + 15.0).abs() < 1e-6);
    let out = simulate(&cfg).expect("trim");
    assert_eq!(out.truth.len(), 600);
}

#[test]
fn dryden_variance_matches_sigma_and_is_reproducible() {
    // GIVEN moderate MIL-F-8785C turbulence at 100 m (L_u = L_v ≈ 263 m, L_w = 100 m, σ_u = σ_v ≈ 2.13,
    // σ_w ≈ 1.54 m/s), V = 15 m/s
    let t = Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_MODERATE_MPS);
    assert!((t.lengths_m[2] - 100.0).abs() < 1e-9);
    assert!((t.sigma_mps[2] - 0.1 * 30.0 * 1852.0 / 3600.0).abs() < 1e-12);
    // WHEN 10⁶ samples are drawn 0.5 s apart (≈ 25 000 correlation times of the u channel)
    let n = 1_000_000;
    let mut d = Dryden::new(&t, 15.0, 0.5, 7);
    let mut sum = [0.0f64; 3];
    let mut sq = [0.0f64; 3];
    for _ in 0..n {
        let g = d.step();
        for i in 0..3 {
            sum[i] += g[i];
            sq[i] += g[i] * g[i];
        }
    }
    // THEN each sample variance is within 5 % of σ² (its standard error here is ≤ 1.5 %)
    for i in 0..3 {
        let mean = sum[i] / n as f64;
        let var = sq[i] / n as f64 - mean * mean;
        let s2 = t.sigma_mps[i] * t.sigma_mps[i];
        assert!((var / s2 - 1.0).abs() < 0.05, "channel {i}: var {var}, σ² {s2}");
    }
    // AND the same seed gives the same sequence, another seed another
    let seq = |seed| {
        let mut d = Dryden::new(&t, 15.0, 0.01, seed);
        (0..100).map(|_| d.step()).collect::<Vec<_>>()
    };
    assert_eq!(seq(3), seq(3));
    assert_ne!(seq(3), seq(4));
}

#[test]
fn sensor_noise_has_the_configured_statistics_and_runs_are_reproducible() {
    // GIVEN a 30 s stabilised flight with default sensors (biases included), seed 11
    let cfg = SimConfig {
        duration_s: 30.0,
        seed: 11,
        ..SimConfig::default()
    };
    let out = simulate(&cfg).expect("trim");
    let ns = cfg.sensors;
    let b = out.biases;
    // WHEN the errors measured − ideal are collected per channel
    let stats = |f: &Reading| {
        let e: Vec<f64> = out
            .samples
            .iter()
            .zip(&out.truth)
            .map(|(m, t)| f(m) - f(&t.ideal))
            .collect();
        let mean = e.iter().sum::<f64>() / e.len() as f64;
        let sd = (e.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (e.len() - 1) as f64).sqrt();
        (mean, sd)
    };
    // THEN each mean equals the run's bias within 4 standard errors and each sd is within 6 % of σ
    // (3000 samples: the standard error of an sd is 1.3 %)
    let n = out.samples.len() as f64;
    let cases: [(&str, &Reading, f64, f64); 7] = [
        ("accel_x", &|s| s.accel_mps2.x, b.accel_mps2.x, ns.accel_mps2),
        ("gyro_y", &|s| s.gyro_rad_s.y, b.gyro_rad_s.y, ns.gyro_rad_s),
        ("airspeed", &|s| s.airspeed_mps, b.airspeed_mps, ns.airspeed_mps),
        ("alpha", &|s| s.alpha_rad, b.vanes_rad[0], ns.vane_rad),
        ("theta", &|s| s.euler_rad.y, b.euler_rad.y, ns.attitude_rad),
        ("elevator", &|s| s.elevator_rad, b.surfaces_rad[0], ns.surface_rad),
        ("rho", &|s| s.air_density_kgpm3 / 1.213, 0.0, ns.density_rel),
    ];
    for (name, f, bias, sigma) in cases {
        let (mean, sd) = stats(f);
        assert!(
            (mean - bias).abs() < 4.0 * sigma / n.sqrt(),
            "{name}: mean {mean}, bias {bias}"
        );
        assert!((sd / sigma - 1.0).abs() < 0.06, "{name}: sd {sd}, σ {sigma}");
    }
    // AND the propeller speed error is 1 % relative
    let rel: Vec<f64> = out
        .samples
        .iter()
        .zip(&out.truth)
        .map(|(m, t)| m.prop_speed_rad_s / t.ideal.prop_speed_rad_s - 1.0)
        .collect();
    let sd = (rel.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    assert!((sd / 0.01 - 1.0).abs() < 0.06, "prop sd {sd}");
    // AND the same seed reproduces the log exactly, another seed does not
    assert_eq!(simulate(&cfg).expect("trim").samples, out.samples);
    let other = simulate(&SimConfig { seed: 12, ..cfg }).expect("trim");
    assert_ne!(other.samples, out.samples);
}

#[test]
fn manoeuvre_shapes() {
    // GIVEN a doublet, a 3-2-1-1 and a sweep of base period 1 s starting at 2 s
    let m = |shape| Manoeuvre {
        channel: Channel::Elevator,
        shape,
        start_s: 2.0,
        amplitude: 0.1,
        period_s: 1.0,
    };
    let d = m(Shape::Doublet);
    let s = m(Shape::Multistep3211);
    let w = m(Shape::Sweep {
        f0_hz: 0.5,
        f1_hz: 1.5,
        duration_s: 4.0,
    });
    // THEN their values follow the definitions
    let at = |m: &Manoeuvre, ts: &[f64]| ts.iter().map(|&t| m.value(t)).collect::<Vec<_>>();
    assert_eq!(at(&d, &[1.9, 2.5, 3.5, 4.1]), vec![0.0, 0.1, -0.1, 0.0]);
    assert_eq!(
        at(&s, &[2.5, 4.9, 5.5, 6.9, 7.5, 8.5, 9.1]),
        vec![0.1, 0.1, -0.1, -0.1, 0.1, -0.1, 0.0]
    );
    assert_eq!((d.end_s(), s.end_s(), w.end_s()), (4.0, 9.0, 6.0));
    // sweep phase at t = 2 s after start: 0.5·2 + 1·4/8 = 1.5 cycles → sin(3π) = 0
    assert!(w.value(4.0).abs() < 1e-12 && w.value(6.5) == 0.0);
    let sched = Schedule::default().with(d).with(Manoeuvre {
        channel: Channel::Throttle,
        ..m(Shape::Step)
    });
    let u = sched.input(2.5);
    assert_eq!((u.elevator_rad, u.throttle), (0.1, 0.1));
}

fn small_log() -> (Vec<SensorSample<f64>>, Vec<TruthSample>) {
    let cfg = SimConfig {
        duration_s: 0.5,
        seed: 5,
        ..SimConfig::default()
    };
    let out = simulate(&cfg).expect("trim");
    (out.samples, out.truth)
}

#[test]
fn csv_round_trip_is_exact_and_truth_columns_are_ignored_on_read() {
    // GIVEN 50 noisy samples
    let (samples, truth) = small_log();
    // WHEN written and read back (with and without truth columns)
    let mut buf = Vec::new();
    write_log(&mut buf, "mem.csv", &samples).expect("write");
    let text = String::from_utf8(buf.clone()).expect("utf8");
    let back = read_log(buf.as_slice(), "mem.csv").expect("read");
    let mut buf2 = Vec::new();
    write_log_with_truth(&mut buf2, "mem.csv", &samples, &truth).expect("write");
    let back2 = read_log(buf2.as_slice(), "mem.csv").expect("read");
    // THEN the header is the documented one and the samples are bit-for-bit identical
    assert_eq!(text.lines().next(), Some(COLUMNS.join(",").as_str()));
    assert!(text.starts_with("t_s,dt_s,accel_mps2_x,accel_mps2_y,accel_mps2_z,gyro_rad_s_x"));
    assert_eq!(back, samples);
    assert_eq!(back2, samples);
    assert!(String::from_utf8(buf2)
        .expect("utf8")
        .lines()
        .next()
        .is_some_and(|h| h.contains("truth_coef_pitch")));
    assert!(matches!(
        write_log_with_truth(&mut Vec::new(), "x", &samples, &truth[1..]),
        Err(LogError::LengthMismatch { .. })
    ));
}

#[test]
fn csv_bad_files_give_the_documented_errors() {
    // GIVEN a valid log as text
    let (samples, _) = small_log();
    let mut buf = Vec::new();
    write_log(&mut buf, "f.csv", &samples[..3]).expect("write");
    let good = String::from_utf8(buf).expect("utf8");
    let lines: Vec<&str> = good.lines().collect();
    let read = |t: &str| read_log(t.as_bytes(), "flight.csv");
    // WHEN a column is missing THEN MissingColumn names the file and the column
    let no_alpha = good.replacen("alpha_rad", "alpha_deg", 1);
    let e = read(&no_alpha).expect_err("missing");
    assert_eq!(
        e,
        LogError::MissingColumn {
            file: "flight.csv".into(),
            column: "alpha_rad".into()
        }
    );
    assert_eq!(e.to_string(), "flight.csv: missing column 'alpha_rad'");
    // WHEN a cell is not a number, or NaN, THEN BadCell names file, line and column
    for bad in ["abc", "NaN", "inf", ""] {
        let mut cells: Vec<String> = lines[2].split(',').map(String::from).collect();
        cells[9] = bad.into();
        let text = format!("{}\n{}\n{}\n{}\n", lines[0], lines[1], cells.join(","), lines[3]);
        let e = read(&text).expect_err("bad cell");
        assert_eq!(
            e,
            LogError::BadCell {
                file: "flight.csv".into(),
                line: 3,
                column: 10,
                name: "alpha_rad".into(),
                text: bad.into()
            }
        );
        assert!(e.to_string().starts_with("flight.csv:3:10: column 'alpha_rad'"), "{e}");
    }
    // WHEN time does not increase THEN NonMonotonicTime names the line
    let text = format!("{}\n{}\n{}\n{}\n", lines[0], lines[1], lines[3], lines[2]);
    let e = read(&text).expect_err("time");
    assert!(matches!(e, LogError::NonMonotonicTime { line: 4, .. }), "{e:?}");
    assert!(e.to_string().starts_with("flight.csv:4: time"), "{e}");
    let text = format!("{}\n{}\n{}\n", lines[0], lines[1], lines[1]);
    assert!(matches!(read(&text), Err(LogError::NonMonotonicTime { line: 3, .. })));
    // WHEN a row is short, the file is empty, or a column repeats THEN the matching error
    let text = format!(
        "{}\n{}\n{}\n",
        lines[0],
        lines[1],
        &lines[2][..lines[2].rfind(',').unwrap_or(0)]
    );
    assert!(matches!(
        read(&text),
        Err(LogError::FieldCount {
            line: 3,
            expected: 20,
            found: 19,
            ..
        })
    ));
    assert_eq!(
        read(""),
        Err(LogError::Empty {
            file: "flight.csv".into()
        })
    );
    assert!(matches!(
        read(&format!("t_s,{}", good)),
        Err(LogError::DuplicateColumn { .. })
    ));
    // AND a file that does not exist gives an Io error naming it
    let e = aerosid::io::log::read_log_file(std::path::Path::new("/nonexistent/x.csv")).expect_err("io");
    assert!(e.to_string().starts_with("/nonexistent/x.csv: "), "{e}");
}

#[test]
fn dryden_autocorrelation_has_the_dryden_shape() {
    // GIVEN moderate turbulence at 100 m, V = 15 m/s, sampled every 0.1 L_u/V
    let t = Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_MODERATE_MPS);
    let v = 15.0;
    let dt = 0.1 * t.lengths_m[0] / v;
    let mut d = Dryden::new(&t, v, dt, 21);
    let n = 1_000_000;
    let g: Vec<Vector3<f64>> = (0..n).map(|_| d.step()).collect();
    // WHEN the normalised autocorrelation at lag 10 samples (τ = L_u/V) is estimated
    let lag = 10;
    for i in 0..3 {
        let c0 = g.iter().map(|x| x[i] * x[i]).sum::<f64>() / n as f64;
        let ck = g.iter().zip(&g[lag..]).map(|(a, b)| a[i] * b[i]).sum::<f64>() / (n - lag) as f64;
        // THEN it matches the Dryden correlation e^{−x} (u) or (1 − x/2)e^{−x} (v, w),
        // x = Vτ/L, within 0.02 (the estimate's standard error here is about 0.005)
        let x = v * lag as f64 * dt / t.lengths_m[i];
        let want = if i == 0 {
            (-x).exp()
        } else {
            (1.0 - x / 2.0) * (-x).exp()
        };
        assert!((ck / c0 - want).abs() < 0.02, "channel {i}: {} vs {want}", ck / c0);
    }
}

#[test]
fn airframe_file_round_trips_and_reports_errors_with_line_and_column() {
    // GIVEN the Rascal written as a key = value file
    let text = aerosid_sim::airframe_file::airframe_to_text(&SimAirframe::rascal_110());
    // WHEN it is parsed back (over the skywalker base) THEN it is the Rascal exactly, and it trims
    assert_eq!(parse_airframe(&text, "r.txt"), Ok(SimAirframe::rascal_110()));
    let small = "base = rascal_110   # the 6.6 kg airframe\n\nname = heavy rascal\nmass_kg = 7.5\npitch.alpha = -0.9\n";
    let a = parse_airframe(small, "h.txt").expect("parse");
    assert_eq!(
        (a.name.as_str(), a.frame.mass_kg, a.aero.pitch.alpha, a.aero.lift.alpha),
        ("heavy rascal", 7.5, -0.9, 5.0)
    );
    let cfg = SimConfig {
        plant: Plant::new(a, TruthEffects::all()),
        airspeed_mps: 20.0,
        duration_s: 1.0,
        ..SimConfig::default()
    };
    assert!(simulate(&cfg).is_ok());
    // WHEN a file is wrong THEN the error names file, line and column
    let cases = [
        ("mass_kg = 2\n  wingspan = 3\n", "a.txt:2:3: unknown key `wingspan`"),
        ("mass_kg =  two\n", "a.txt:1:12: `two` is not a finite number"),
        ("mass_kg = NaN\n", "a.txt:1:11: `NaN` is not a finite number"),
        ("mass_kg 2\n", "a.txt:1:1: expected `key = value`"),
        ("mass_kg =\n", "a.txt:1:10: missing value for `mass_kg`"),
        (
            "mass_kg = 2\nmass_kg = 3\n",
            "a.txt:2:1: `mass_kg` already set on line 1",
        ),
        (
            "mass_kg = 2\nbase = rascal_110\n",
            "a.txt:2:1: `base` must come before every other key",
        ),
        (
            "base = cessna\n",
            "a.txt:1:8: unknown base `cessna` (skywalker_2013_mod or rascal_110)",
        ),
        ("# c\nmass_kg = -1\n", "a.txt:2:11: `mass_kg` must be positive, got -1"),
        ("lift.gamma = 1\n", "a.txt:1:1: unknown key `lift.gamma`"),
        (
            "jxz_kgm2 = 2\n",
            "a.txt:1:12: inertia tensor not positive definite (Jx·Jz ≤ Jxz²)",
        ),
    ];
    for (text, msg) in cases {
        let e = parse_airframe(text, "a.txt").expect_err(text);
        assert_eq!(e.to_string(), msg);
    }
    let e = read_airframe(std::path::Path::new("/nonexistent/a.txt")).expect_err("io");
    assert!(e.to_string().starts_with("/nonexistent/a.txt:0:0: "), "{e}");
}

#[test]
fn steady_wind_trim_is_air_relative_and_thrust_is_reconstructible_from_rpm_and_air_data() {
    // GIVEN a 5 m/s headwind from the north (air moving south) and the skywalker heading north
    let mut cfg = quiet(TruthEffects::all());
    cfg.plant.wind_ned_mps = Vector3::new(-5.0, 0.0, 0.0);
    cfg.duration_s = 20.0;
    // WHEN it flies 20 s trimmed, open loop
    let out = simulate(&cfg).expect("trim");
    let last = out.truth.last().expect("samples");
    // THEN airspeed stays 15 m/s, the ground track advances at 10 m/s and altitude holds
    assert!(
        (last.eval.airspeed_mps - 15.0).abs() < 0.01,
        "{}",
        last.eval.airspeed_mps
    );
    let north = last.state.position_ned_m.x;
    assert!((north - 10.0 * last.t_s).abs() < 0.1, "north {north}");
    assert!((last.state.altitude_m() - 100.0).abs() < 0.05);
    // AND the thrust rebuilt the on-board way — from propeller speed, airspeed, α, β and density of
    // the ideal sample, `V_x = V cos β cos(α + θ_p)` — equals the truth thrust
    let pr = &cfg.plant.airframe.frame.propeller;
    for t in &out.truth {
        let s = &t.ideal;
        let vx = s.airspeed_mps * s.beta_rad.cos() * (s.alpha_rad + pr.pitch_rad).cos();
        let p = aerosid_sim::propulsion::propeller(pr, s.prop_speed_rad_s, vx, s.air_density_kgpm3);
        assert!((p.thrust_n - t.eval.prop.thrust_n).abs() < 1e-10 * t.eval.prop.thrust_n.abs().max(1.0));
    }
}

#[test]
fn stall_blending_moves_lift_and_drag_to_the_flat_plate() {
    // GIVEN the stall blend of README §1 (M = 50, α₀ = 0.4712)
    let st = StallBlend::default();
    let mut eff = TruthEffects::none();
    eff.stall = Some(st);
    let truth = Plant::new(SimAirframe::skywalker_2013_mod(), eff).truth;
    // THEN σ is ≈ 0 in attached flow, ½ at ±α₀ and ≈ 1 well past it
    assert!(st.sigma(0.0) < 1e-9 && st.sigma(0.25) < 2e-5);
    assert!((st.sigma(0.4712) - 0.5).abs() < 1e-6 && (st.sigma(-0.4712) - 0.5).abs() < 1e-6);
    assert!(st.sigma(0.8) > 1.0 - 1e-6);
    // AND at α = 0.8 rad the coefficients are the flat plate's, at 0.1 rad the linear model's (to 1e-5,
    // 1e-6: σ(0.1) ≈ 1e-8)
    let at = |a: f64| {
        truth.coefficients(&AeroInput {
            alpha_rad: a,
            ..AeroInput::default()
        })
    };
    let (s, c) = 0.8f64.sin_cos();
    assert!((at(0.8).lift - 2.0 * s * s * c).abs() < 1e-5 && (at(0.8).drag - 2.0 * s * s * s).abs() < 1e-5);
    assert!((at(0.1).lift - 1.05).abs() < 1e-6 && (at(0.1).drag - 0.104).abs() < 1e-6);
}
