//! Coefficient synthesis (seed 000, eq. 1–2), the rate differentiator, the six-estimator pipeline
//! (eq. 3a–3f) and its refusal of bad channels.
//!
//! Forward formulas used to build consistent samples (the same conventions as the core's
//! `aero::synthesis` module doc, written out independently here):
//! * stability axes: `F_A = [−D cα + L sα, Y, −D sα − L cα]`; wind axes: `F_A = C_bwᵀ[−D, Y, −L]`;
//! * `a = (F_A + F_T)/m`, `F_T = T[cos θ_p, 0, −sin θ_p]`, `M_T = r × F_T + [−Q, 0, 0]`, with `T`, `Q`
//!   at the axial speed `V cos β cos(α + θ_p)` (the airspeed along the thrust line);
//! * `ω̇ = J⁻¹(q̄S[bC_l, c̄C_m, bC_n] + M_T − ω × Jω)`.

use aerosid_core::aero::model::{channel, idx};
use aerosid_core::aero::pipeline::Refusal;
use aerosid_core::aero::synthesis::{propeller_output, propulsion_force_moment};
use aerosid_core::aero::{
    synthesise, AeroModels, Airframe, ForceAxes, Pipeline, PipelineSettings, RateDifferentiator, SensorSample,
    SynthesisSettings,
};
use aerosid_core::{Estimator, Real, Solution};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Thrust and torque by the propeller model, written out independently of the core.
fn hand_thrust(rho: f64, vx: f64, w: f64) -> (f64, f64) {
    let (d, ct, cp) = (0.28, [0.1133, -0.0740, -0.1849], [0.0440, 0.0059, -0.0732]);
    let n = w / (2.0 * std::f64::consts::PI);
    let j = vx / (n * d);
    let t = (ct[0] + ct[1] * j + ct[2] * j * j) * rho * n * n * d.powi(4);
    let q = (cp[0] + cp[1] * j + cp[2] * j * j) * rho * n * n * d.powi(5) / (2.0 * std::f64::consts::PI);
    (t, q)
}

/// The flight condition and coefficients of a consistent sample.
#[derive(Clone, Copy)]
struct Case {
    v: f64,
    alpha: f64,
    beta: f64,
    rho: f64,
    omega: [f64; 3],
    prop: f64,
    /// `[C_L, C_D, C_Y, C_l, C_m, C_n]`.
    coef: [f64; 6],
}

/// Body-to-wind rotation `C_bw`.
fn c_bw(a: f64, b: f64) -> Matrix3<f64> {
    let (sa, ca, sb, cb) = (a.sin(), a.cos(), b.sin(), b.cos());
    Matrix3::new(ca * cb, sb, sa * cb, -ca * sb, cb, -sa * sb, -sa, 0.0, ca)
}

/// A sample (f64) and `ω̇` consistent with eq. 1–2 for the case.
fn forward(c: &Case, axes: ForceAxes) -> (SensorSample<f64>, Vector3<f64>) {
    let af = Airframe::<f64>::skywalker_2013_mod();
    let qbar = 0.5 * c.rho * c.v * c.v;
    let qs = qbar * af.wing_area_m2;
    let [cl, cd, cy, croll, cm, cn] = c.coef;
    let (sa, ca) = (c.alpha.sin(), c.alpha.cos());
    let f_a = match axes {
        ForceAxes::Stability => Vector3::new(-cd * ca + cl * sa, cy, -cd * sa - cl * ca) * qs,
        ForceAxes::Wind => c_bw(c.alpha, c.beta).transpose() * Vector3::new(-cd, cy, -cl) * qs,
    };
    let pitch: f64 = -0.08;
    let (t, q) = hand_thrust(c.rho, c.v * c.beta.cos() * (c.alpha + pitch).cos(), c.prop);
    let f_t = Vector3::new(pitch.cos(), 0.0, -pitch.sin()) * t;
    let m_t = Vector3::new(-0.25, 0.0, -0.13).cross(&f_t) + Vector3::new(-q, 0.0, 0.0);
    let m_a = Vector3::new(af.span_m * croll, af.chord_m * cm, af.span_m * cn) * qs;
    let w = Vector3::from(c.omega);
    let jm = af.inertia_kgm2;
    let wdot = jm.try_inverse().unwrap() * (m_a + m_t - w.cross(&(jm * w)));
    let s = SensorSample {
        t_s: 0.0,
        dt_s: 0.01,
        accel_mps2: (f_a + f_t) / af.mass_kg,
        gyro_rad_s: w,
        airspeed_mps: c.v,
        alpha_rad: c.alpha,
        beta_rad: c.beta,
        euler_rad: Vector3::zeros(),
        prop_speed_rad_s: c.prop,
        elevator_rad: 0.0,
        aileron_rad: 0.0,
        rudder_rad: 0.0,
        throttle: 0.5,
        air_density_kgpm3: c.rho,
    };
    (s, wdot)
}

fn random_case(rng: &mut ChaCha8Rng) -> Case {
    let mut u = |a: f64, b: f64| rng.random_range(a..b);
    Case {
        v: u(8.0, 35.0),
        alpha: u(-0.2, 0.35),
        beta: u(-0.25, 0.25),
        rho: u(0.9, 1.3),
        omega: [u(-2.0, 2.0), u(-1.0, 1.0), u(-1.0, 1.0)],
        prop: u(200.0, 1000.0),
        coef: [
            u(-0.5, 1.5),
            u(0.02, 0.4),
            u(-0.3, 0.3),
            u(-0.1, 0.1),
            u(-0.3, 0.3),
            u(-0.1, 0.1),
        ],
    }
}

/// GIVEN 500 seeded random flight conditions and coefficients, in both force-axes conventions,
/// WHEN a sample is built by the forward eq. 1–2 and synthesised,
/// THEN the six coefficients come back to 1e-10 (f64) and 2e-3 absolute (f32), and the
/// non-dimensional rates are `p b/(2V)`, `q c̄/(2V)`, `r b/(2V)`.
#[test]
fn synthesis_inverts_eq_1_and_2() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let af64 = Airframe::<f64>::skywalker_2013_mod();
    let af32 = Airframe::<f32>::skywalker_2013_mod();
    let (mut worst64, mut worst32) = (0.0f64, 0.0f64);
    for axes in [ForceAxes::Stability, ForceAxes::Wind] {
        let set = SynthesisSettings {
            force_axes: axes,
            ..Default::default()
        };
        let set32 = SynthesisSettings {
            force_axes: axes,
            ..Default::default()
        };
        for _ in 0..500 {
            let c = random_case(&mut rng);
            let (s, wdot) = forward(&c, axes);
            let y = synthesise(&s, &af64, &wdot, &set).unwrap();
            for (got, want) in y.coefficients.as_array().iter().zip(c.coef.iter()) {
                worst64 = worst64.max((got - want).abs());
            }
            let rn = y.rates_n;
            let (b, cc, v) = (af64.span_m, af64.chord_m, c.v);
            assert!((rn.x - c.omega[0] * b / (2.0 * v)).abs() < 1e-15);
            assert!((rn.y - c.omega[1] * cc / (2.0 * v)).abs() < 1e-15);
            assert!((rn.z - c.omega[2] * b / (2.0 * v)).abs() < 1e-15);
            assert!((y.dynamic_pressure_pa - 0.5 * c.rho * v * v).abs() < 1e-12);
            let y32 = synthesise(&SensorSample::cast::<f32>(&s), &af32, &wdot.map(|e| e as f32), &set32).unwrap();
            for (got, want) in y32.coefficients.as_array().iter().zip(c.coef.iter()) {
                worst32 = worst32.max((*got as f64 - want).abs());
            }
        }
    }
    println!("max |ΔC|: f64 {worst64:e}, f32 {worst32:e}");
    assert!(worst64 < 1e-10, "f64 inversion error {worst64:e}");
    assert!(worst32 < 2e-3, "f32 inversion error {worst32:e}");
}

/// GIVEN `β = 0`, THEN the stability- and wind-axes syntheses agree; GIVEN a pure body `+x`
/// aerodynamic force at `α = β = 0` (a sample with thrust removed), THEN `C_D < 0` (eq. 1:
/// `F_A,x = −q̄S C_D`), and a body `−z` force gives `C_L > 0`.
#[test]
fn sign_conventions() {
    let af = Airframe::<f64>::skywalker_2013_mod();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..100 {
        let mut c = random_case(&mut rng);
        c.beta = 0.0;
        let (s, wdot) = forward(&c, ForceAxes::Stability);
        let st = synthesise(&s, &af, &wdot, &SynthesisSettings::default()).unwrap();
        let wind = SynthesisSettings {
            force_axes: ForceAxes::Wind,
            ..Default::default()
        };
        let wi = synthesise(&s, &af, &wdot, &wind).unwrap();
        for (a, b) in st.coefficients.as_array().iter().zip(wi.coefficients.as_array().iter()) {
            assert!((a - b).abs() < 1e-12);
        }
    }
    let s = SensorSample {
        dt_s: 0.01,
        accel_mps2: Vector3::new(1.0, 0.0, -2.0),
        airspeed_mps: 15.0,
        air_density_kgpm3: 1.225,
        ..Default::default()
    };
    let y = synthesise(&s, &af, &Vector3::zeros(), &SynthesisSettings::default()).unwrap();
    assert!(y.propeller.thrust_n == 0.0, "stopped propeller makes no thrust");
    let qs = 0.5 * 1.225 * 225.0 * 0.45;
    assert!((y.coefficients.drag + 2.0 / qs).abs() < 1e-12, "C_D = −F_x/(q̄S)");
    assert!((y.coefficients.lift - 4.0 / qs).abs() < 1e-12, "C_L = −F_z/(q̄S)");
}

/// GIVEN the skywalker propeller at ω = 600 rad/s, V_x = 15 m/s, ρ = 1.225 kg/m³,
/// THEN J, T, Q and the thrust pitching moment equal the hand-computed values
/// (n = 95.493 rev/s, J = 15/(n·0.28) = 0.56100, C_T = 0.1133 − 0.0740J − 0.1849J² = 0.013594,
/// T = C_T ρ n² D⁴ = 0.93341 N, Q = C_P ρ n² D⁵/2π = 0.074268 N·m,
/// F = T[cos 0.08, 0, sin 0.08], M_y = r_z F_x − r_x F_z = −0.13·0.93043 + 0.25·0.074593 = −0.10231 N·m),
/// and the torque is the rolling moment `−Q`.
#[test]
fn thrust_model_matches_hand_values() {
    let af = Airframe::<f64>::skywalker_2013_mod();
    let out = propeller_output(&af.propeller, 1.225, 15.0, 600.0);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * b.abs();
    assert!(close(out.advance_ratio, 0.5609986881410345));
    assert!(close(out.thrust_n, 0.9334108012579911));
    assert!(close(out.torque_nm, 0.07426809249599886));
    let (f, m) = propulsion_force_moment(&af.propeller, &out, -1.0);
    assert!(close(f.x, 0.9304254793752608) && close(f.z, 0.07459323853005263) && f.y == 0.0);
    assert!(close(m.y, -0.10230700268627074));
    assert!(close(m.x, -0.07426809249599886) && m.z.abs() < 1e-18);
    let out32 = propeller_output(&Airframe::<f32>::skywalker_2013_mod().propeller, 1.225f32, 15.0, 600.0);
    assert!((out32.thrust_n as f64 - 0.9334108012579911).abs() < 1e-5);
    let (t, q) = hand_thrust(1.225, 15.0, 600.0);
    assert!(close(t, out.thrust_n) && close(q, out.torque_nm));
}

macro_rules! differentiator_tests {
    ($name:ident, $t:ty, $tol:expr) => {
        mod $name {
            use super::*;
            type T = $t;

            /// GIVEN a gyro ramp `ω = a + b t` at h = 10 ms, THEN ω̇ = b exactly once five samples are
            /// held (not before), and a bad `dt_s` restarts the window for four samples.
            #[test]
            fn ramp_is_exact_and_gap_restarts() {
                let mut d = RateDifferentiator::<T>::new();
                let b = Vector3::new(0.3, -1.2, 2.5);
                for k in 0..10 {
                    let t = k as f64 * 0.01;
                    let w = Vector3::new(0.1 + 0.3 * t, -0.2 - 1.2 * t, 0.05 + 2.5 * t).map(|e| e as T);
                    d.push(&w, 0.01, true, true);
                    assert_eq!(d.ready(), k >= 4);
                    if let Some(wd) = d.derivative() {
                        assert!((wd.map(|e| e as f64) - b).amax() < $tol, "{wd:?}");
                    }
                }
                d.push(&Vector3::zeros(), 0.05, true, false);
                for _ in 0..4 {
                    assert!(d.derivative().is_none());
                    d.push(&Vector3::zeros(), 0.01, true, true);
                }
                assert!(d.ready());
                d.push(&Vector3::zeros(), 0.01, false, true);
                assert!(!d.ready());
            }

            /// GIVEN `q = sin(2πf t)` at f = 1, 3, 5 Hz and h = 10 ms,
            /// THEN the estimate is `G(ωh)·2πf·cos(2πf(t − 2h))` with the documented
            /// `G = (sin ωh + 2 sin 2ωh)/(5ωh)` (group delay exactly 2 samples).
            #[test]
            fn sine_response_has_documented_gain_and_delay() {
                assert_eq!(RateDifferentiator::<T>::DELAY_SAMPLES, 2);
                let h = 0.01;
                for f in [1.0, 3.0, 5.0] {
                    let w = 2.0 * std::f64::consts::PI * f;
                    let g = RateDifferentiator::<f64>::gain(w * h);
                    let x2 = (w * h) * (w * h);
                    let series = 1.0 - 17.0 * x2 / 30.0 + 13.0 * x2 * x2 / 120.0;
                    assert!((g - series).abs() < 2e-5, "G {g} vs series {series}");
                    let mut d = RateDifferentiator::<T>::new();
                    for k in 0..200 {
                        let t = k as f64 * h;
                        d.push(&Vector3::new(0.0, (w * t).sin() as T, 0.0), h as T, true, true);
                        if let Some(wd) = d.derivative() {
                            let want = g * w * (w * (t - 2.0 * h)).cos();
                            assert!((wd.y as f64 - want).abs() < $tol * w, "f {f}: {} vs {want}", wd.y);
                        }
                    }
                }
            }
        }
    };
}
differentiator_tests!(diff_f64, f64, 1e-9);
differentiator_tests!(diff_f32, f32, 2e-3);

/// Longitudinal truth for the pipeline tests: the linear `C_m` of eq. 3e with the skywalker
/// values, driven by prescribed `α(t)`, `δe(t)`, `V(t)`; `q` integrated (RK4, 1 ms) from
/// `J_y q̇ = q̄Sc̄ C_m + M_T,y` (p = r = 0), so each sample satisfies eq. 2 exactly.
struct PitchTruth {
    cm: [f64; 4],
    q: f64,
    t: f64,
}

impl PitchTruth {
    const RHO: f64 = 1.225;
    /// At rest (`q = 0`, `t = 0`) with the skywalker's `C_m` ([`CM_TRUTH`]).
    fn at_rest() -> Self {
        Self {
            cm: CM_TRUTH,
            q: 0.0,
            t: 0.0,
        }
    }
    const PROP: f64 = 600.0;
    fn alpha(t: f64) -> f64 {
        use std::f64::consts::PI;
        0.05 + 0.04 * (2.0 * PI * 0.3 * t).sin() + 0.02 * (2.0 * PI * 1.1 * t + 1.0).sin()
    }
    fn elevator(t: f64) -> f64 {
        use std::f64::consts::PI;
        0.03 * (2.0 * PI * 0.7 * t + 0.5).sin() + 0.02 * (2.0 * PI * 1.7 * t).sin()
    }
    fn airspeed(t: f64) -> f64 {
        15.0 + (2.0 * std::f64::consts::PI * 0.05 * t).sin()
    }
    fn qdot(&self, t: f64, q: f64) -> f64 {
        let af = Airframe::<f64>::skywalker_2013_mod();
        let (v, a) = (Self::airspeed(t), Self::alpha(t));
        let qn = q * af.chord_m / (2.0 * v);
        let cm = self.cm[0] + self.cm[1] * a + self.cm[2] * qn + self.cm[3] * Self::elevator(t);
        let qbar = 0.5 * Self::RHO * v * v;
        let p: f64 = -0.08;
        let (th, _) = hand_thrust(Self::RHO, v * (a + p).cos(), Self::PROP);
        let my_t = -0.13 * th * p.cos() - 0.25 * th * p.sin();
        (qbar * af.wing_area_m2 * af.chord_m * cm + my_t) / af.inertia_kgm2[(1, 1)]
    }
    /// Advances by `dt` (RK4 in 10 substeps).
    fn advance(&mut self, dt: f64) {
        let h = dt / 10.0;
        for _ in 0..10 {
            let (t, q) = (self.t, self.q);
            let k1 = self.qdot(t, q);
            let k2 = self.qdot(t + h / 2.0, q + h / 2.0 * k1);
            let k3 = self.qdot(t + h / 2.0, q + h / 2.0 * k2);
            let k4 = self.qdot(t + h, q + h * k3);
            self.q += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            self.t += h;
        }
    }
    /// The measured sample now, with seeded sensor noise of the given σ (α, gyro, surfaces).
    fn sample(&self, rng: &mut ChaCha8Rng, sig: [f64; 3]) -> SensorSample<f64> {
        let n = |rng: &mut ChaCha8Rng, s: f64| {
            if s > 0.0 {
                Normal::new(0.0, s).unwrap().sample(rng)
            } else {
                0.0
            }
        };
        let t = self.t;
        SensorSample {
            t_s: t,
            dt_s: 0.01,
            accel_mps2: Vector3::new(0.5, 0.0, -9.8),
            gyro_rad_s: Vector3::new(n(rng, sig[1]), self.q + n(rng, sig[1]), n(rng, sig[1])),
            airspeed_mps: Self::airspeed(t),
            alpha_rad: Self::alpha(t) + n(rng, sig[0]),
            beta_rad: 0.0,
            euler_rad: Vector3::zeros(),
            prop_speed_rad_s: Self::PROP,
            elevator_rad: Self::elevator(t) + n(rng, sig[2]),
            aileron_rad: 0.0,
            rudder_rad: 0.0,
            throttle: 0.5,
            air_density_kgpm3: Self::RHO,
        }
    }
}

const CM_TRUTH: [f64; 4] = [0.01, -1.3, -20.0, 1.0];

fn pipeline<T: Real>(sigma_eps: [f64; 6]) -> Pipeline<T> {
    let models = AeroModels::with_sigma_eps(sigma_eps.map(T::lit));
    Pipeline::new(Airframe::skywalker_2013_mod(), models, PipelineSettings::default()).unwrap()
}

macro_rules! pipeline_tests {
    ($name:ident, $t:ty, $tol:expr) => {
        mod $name {
            use super::*;
            type T = $t;

            /// GIVEN the unconfigured placeholder (the firmware's static before boot) and a pipeline
            /// whose configuration failed, WHEN samples arrive, THEN every coefficient is refused as
            /// `NotConfigured` and nothing changes, the health counters included; AND configured
            /// in place, the placeholder equals `Pipeline::new`'s pipeline and processes the same
            /// samples to the same results.
            #[test]
            fn unconfigured_pipeline_refuses_every_sample_and_configures_in_place() {
                let mut rng = ChaCha8Rng::seed_from_u64(11);
                let mut truth = PitchTruth::at_rest();
                let conv = |s: &SensorSample<f64>| s.cast::<$t>();
                let samples: Vec<_> = (0..20)
                    .map(|_| {
                        truth.advance(0.01);
                        conv(&truth.sample(&mut rng, [0.0; 3]))
                    })
                    .collect();
                let models = AeroModels::with_sigma_eps([0.01; 6].map(<T as Real>::lit));
                let mut bad_settings = PipelineSettings::<T>::default();
                bad_settings.limits.nominal_dt_s = 0.0;
                let mut failed = pipeline::<T>([0.01; 6]);
                assert!(failed
                    .configure(Airframe::skywalker_2013_mod(), models, bad_settings)
                    .is_err());
                assert_eq!(
                    failed,
                    Pipeline::PLACEHOLDER,
                    "a failed configure leaves the placeholder"
                );
                let mut p = Pipeline::<T>::PLACEHOLDER;
                for s in &samples {
                    for q in [&mut p, &mut failed] {
                        let step = q.process(s);
                        assert_eq!(step.status, [Err(Refusal::NotConfigured); idx::COUNT]);
                        assert_eq!(step.synthesis, None);
                        assert_eq!(*q, Pipeline::PLACEHOLDER, "an unconfigured pipeline changed");
                    }
                }
                assert_eq!(p.health().samples, 0);
                p.configure(
                    Airframe::skywalker_2013_mod(),
                    models,
                    PipelineSettings::default(),
                )
                .unwrap();
                let mut fresh = pipeline::<T>([0.01; 6]);
                assert_eq!(p, fresh);
                let mut updated = 0;
                for s in &samples {
                    let (a, b) = (p.process(s), fresh.process(s));
                    assert_eq!(a, b);
                    updated += a.status.iter().filter(|r| r.is_ok()).count();
                }
                assert!(updated > 0, "the configured pipeline never updated");
            }

            /// GIVEN a running pipeline, WHEN a sample with NaN α arrives, THEN (two samples later, when
            /// it is the centre of the delay line) `C_L`, `C_D`, `C_m` are refused for the α channel —
            /// the forces once, `C_m` for the five centres whose prefilter window holds the sample —
            /// and their estimators are bit-identical to before, while `C_Y`, `C_l`, `C_n` update (with
            /// the propeller's axial-speed fallback counted).
            #[test]
            fn nan_alpha_is_refused_only_where_needed() {
                let mut rng = ChaCha8Rng::seed_from_u64(3);
                let mut truth = PitchTruth::at_rest();
                let mut p = pipeline::<T>([0.01; 6]);
                let conv = |s: &SensorSample<f64>| s.cast::<$t>();
                for _ in 0..50 {
                    truth.advance(0.01);
                    p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                }
                truth.advance(0.01);
                let mut bad = conv(&truth.sample(&mut rng, [0.0; 3]));
                bad.alpha_rad = <T>::NAN;
                p.process(&bad);
                truth.advance(0.01);
                p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                let before = p.clone();
                truth.advance(0.01);
                let step = p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                for i in [idx::LIFT, idx::DRAG, idx::PITCH] {
                    assert_eq!(
                        step.status[i],
                        Err(Refusal::Channels(channel::ALPHA)),
                        "coefficient {i}"
                    );
                }
                // The forces need α of the centre sample only; C_m's prefilter window (5 samples)
                // has held the bad sample for 3 centres so far (it entered as the newest).
                assert_eq!(p.health().coefficients[idx::LIFT].refused_channels, 1);
                assert_eq!(p.health().coefficients[idx::DRAG].refused_channels, 1);
                assert_eq!(p.health().coefficients[idx::PITCH].refused_channels, 3);
                for i in [idx::SIDE, idx::ROLL, idx::YAW] {
                    assert!(step.status[i].is_ok(), "coefficient {i}: {:?}", step.status[i]);
                    assert_eq!(p.health().coefficients[i].refused_channels, 0);
                }
                assert!(p.lift() == before.lift() && p.drag() == before.drag() && p.pitch() == before.pitch());
                assert!(p.side() != before.side() && p.roll() != before.roll() && p.yaw() != before.yaw());
                let bits = |a: &[T]| a.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(p.pitch().theta().as_slice()),
                    bits(before.pitch().theta().as_slice())
                );
                assert_eq!(
                    p.health().invalid_channel[channel::ALPHA.trailing_zeros() as usize],
                    1
                );
                assert_eq!(p.health().axial_speed_fallbacks, 1);
                // Two more centres see the bad sample in C_m's window (oldest slot), then C_m updates
                // again.
                for _ in 0..2 {
                    truth.advance(0.01);
                    let s = p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                    assert_eq!(s.status[idx::PITCH], Err(Refusal::Channels(channel::ALPHA)));
                }
                truth.advance(0.01);
                let s = p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                assert!(s.status[idx::PITCH].is_ok(), "{:?}", s.status[idx::PITCH]);
                assert_eq!(p.health().coefficients[idx::PITCH].refused_channels, 5);
            }

            /// GIVEN a running pipeline, WHEN one `dt_s` is 3× nominal, THEN the force coefficients keep
            /// updating while the moments are refused (warm-up) until the differentiator window holds
            /// five consecutive good samples again.
            #[test]
            fn bad_dt_refuses_moments_only() {
                let mut rng = ChaCha8Rng::seed_from_u64(4);
                let mut truth = PitchTruth::at_rest();
                let mut p = pipeline::<T>([0.01; 6]);
                let conv = |s: &SensorSample<f64>| s.cast::<$t>();
                for _ in 0..20 {
                    truth.advance(0.01);
                    p.process(&conv(&truth.sample(&mut rng, [0.0; 3])));
                }
                let mut refused = 0;
                for k in 0..10 {
                    truth.advance(0.01);
                    let mut s = conv(&truth.sample(&mut rng, [0.0; 3]));
                    if k == 0 {
                        s.dt_s = 0.03;
                    }
                    let step = p.process(&s);
                    assert!(step.status[idx::LIFT].is_ok() && step.status[idx::SIDE].is_ok());
                    if step.status[idx::PITCH] == Err(Refusal::Warmup) {
                        refused += 1;
                    }
                }
                assert_eq!(refused, 4, "moments wait for four more samples");
                assert_eq!(
                    p.health().invalid_channel[channel::DT.trailing_zeros() as usize],
                    1
                );
            }

            /// GIVEN 60 s at 100 Hz of the pitch truth (`C_m0 0.01, C_mα −1.3, C_mq −20, C_mδe 1.0`)
            /// with sensor noise σ_α = 0.0087 rad, σ_gyro = 0.005 rad/s, σ_δ = 0.0035 rad (the
            /// defaults of `SensorNoise`) and `σ_ε(C_m) = 0.012` (the differentiator's noise gain on
            /// the gyro), WHEN fed through the pipeline, for 5 seeds, THEN `C_m` is fully excited
            /// (eq. 16 solution) and every parameter is recovered within the stated tolerance: 3 % on
            /// `C_mα` and `C_mδe`, 5 % on `C_mq`, 0.003 on `C_m0`.
            #[test]
            fn recovers_pitch_parameters_end_to_end() {
                let conv = |s: &SensorSample<f64>| s.cast::<$t>();
                for seed in 0..5u64 {
                    let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
                    let mut truth = PitchTruth::at_rest();
                    let mut p = pipeline::<T>([0.05, 0.05, 0.05, 0.01, 0.012, 0.01]);
                    for _ in 0..6000 {
                        truth.advance(0.01);
                        p.process(&conv(&truth.sample(&mut rng, [0.0087, 0.005, 0.0035])));
                    }
                    let th = p.pitch().theta().map(|e| e as f64);
                    let rel = |i: usize| ((th[i] - CM_TRUTH[i]) / CM_TRUTH[i]).abs();
                    println!(
                        "seed {seed}: C_m estimate {:?} (truth {:?}); rel. errors {:.4} {:.4} {:.4}",
                        th.as_slice(),
                        CM_TRUTH,
                        rel(1),
                        rel(2),
                        rel(3)
                    );
                    assert_eq!(p.pitch().solution(), Solution::Tls);
                    assert_eq!(p.pitch().excited(), 3, "all three noisy directions excited");
                    assert!((th[0] - CM_TRUTH[0]).abs() < 0.003);
                    assert!(rel(1) < 0.03 && rel(2) < 0.05 && rel(3) < 0.03);
                    assert_eq!(p.health().coefficients[idx::PITCH].updates, 6000 - 4);
                }
            }
        }
    };
}
pipeline_tests!(pipe_f64, f64, 1.0);
pipeline_tests!(pipe_f32, f32, 1.0);

/// The pipeline's size in f32 (the MCU build), printed for the report.
#[test]
fn pipeline_size() {
    let n32 = std::mem::size_of::<Pipeline<f32>>();
    let n64 = std::mem::size_of::<Pipeline<f64>>();
    println!("size_of Pipeline<f32> = {n32} B, Pipeline<f64> = {n64} B");
    println!(
        "  of which (f32): RateDifferentiator {} B, SensorSample {} B, Gtls<4,1,4> {} B, Gtls<5,1,5> {} B, \
         Gtls<6,1,6> {} B",
        std::mem::size_of::<RateDifferentiator<f32>>(),
        std::mem::size_of::<SensorSample<f32>>(),
        std::mem::size_of::<aerosid_core::Gtls<f32, 4, 1, 4>>(),
        std::mem::size_of::<aerosid_core::Gtls<f32, 5, 1, 5>>(),
        std::mem::size_of::<aerosid_core::Gtls<f32, 6, 1, 6>>()
    );
    assert!(n32 < 8192);
    // The goal: the six estimators' state ≤ 4 KB (measured 2·460 + 624 + 3·820 = 4 004 B; the
    // dimension-6 state holds two `V` buffers, see `sizes.rs`).
    let six = 2 * std::mem::size_of::<aerosid_core::Gtls<f32, 4, 1, 4>>()
        + std::mem::size_of::<aerosid_core::Gtls<f32, 5, 1, 5>>()
        + 3 * std::mem::size_of::<aerosid_core::Gtls<f32, 6, 1, 6>>();
    println!("six estimators: {six} B");
    assert!(six <= 4096, "six estimators {six} B");
}

/// GIVEN the default sensor specifications, THEN `W_T` of each model is as documented: `σ²` of each
/// noisy regressor in order, the rate normalisation at `V₀`, the `α`–`α²` block at `α₀`, `σ_ε²` last,
/// and it stays positive definite at `α₀ = 0` (so the pipeline builds). A model whose intercept is not
/// first is refused.
#[test]
fn error_covariance_from_sensor_specs() {
    use aerosid_core::aero::{CoefficientModel, Regressor, SensorNoise};
    let af = Airframe::<f64>::skywalker_2013_mod();
    let m = AeroModels::<f64>::with_sigma_eps([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
    let n = SensorNoise::<f64>::default();
    let w = m.drag.error_covariance(&n, af.span_m, af.chord_m);
    let sa2 = n.alpha_rad * n.alpha_rad;
    let a0 = n.nominal_alpha_rad;
    assert_eq!(w[(0, 0)], sa2);
    assert!((w[(0, 1)] - 2.0 * a0 * sa2).abs() < 1e-18 && w[(1, 0)] == w[(0, 1)]);
    assert!((w[(1, 1)] - (4.0 * a0 * a0 * sa2 + 2.0 * sa2 * sa2)).abs() < 1e-18);
    let sq = n.gyro_rad_s * af.chord_m / (2.0 * n.nominal_airspeed_mps);
    assert!((w[(2, 2)] - sq * sq).abs() < 1e-20);
    assert_eq!(w[(3, 3)], n.surface_rad * n.surface_rad);
    assert!((w[(4, 4)] - 0.04).abs() < 1e-15);
    let wl = m.roll.error_covariance(&n, af.span_m, af.chord_m);
    let sp = n.gyro_rad_s * af.span_m / (2.0 * n.nominal_airspeed_mps);
    assert!((wl[(1, 1)] - sp * sp).abs() < 1e-20 && (wl[(2, 2)] - sp * sp).abs() < 1e-20);
    assert!((wl[(5, 5)] - 0.16).abs() < 1e-15);
    let n0 = SensorNoise {
        nominal_alpha_rad: 0.0,
        ..n
    };
    assert!(m.drag.error_covariance(&n0, af.span_m, af.chord_m).cholesky().is_some());
    let settings = PipelineSettings {
        noise: n0,
        ..Default::default()
    };
    assert!(Pipeline::new(af, m, settings).is_ok());
    let mut bad = m;
    bad.lift = CoefficientModel::new(
        [
            Regressor::Alpha,
            Regressor::One,
            Regressor::PitchRateN,
            Regressor::Elevator,
        ],
        0.1,
    );
    assert_eq!(
        Pipeline::new(af, bad, PipelineSettings::default()).err(),
        Some(aerosid_core::Error::InvalidSetting)
    );
}

/// GIVEN stability axes (default), THEN `C_Y` needs no angle of attack; GIVEN wind axes, THEN all three
/// force coefficients need both `α` and `β`; the moments never need `α` unless a regressor does.
#[test]
fn needed_channels_follow_the_axes() {
    let p = pipeline::<f64>([0.01; 6]);
    assert_eq!(p.needed_channels(idx::SIDE) & channel::ALPHA, 0);
    assert_ne!(p.needed_channels(idx::LIFT) & channel::ALPHA, 0);
    assert_eq!(p.needed_channels(idx::ROLL) & channel::ALPHA, 0);
    assert_ne!(
        p.needed_channels(idx::ROLL) & channel::AILERON,
        0,
        "δa in C_l by default"
    );
    assert_ne!(
        p.needed_channels(idx::YAW) & channel::AILERON,
        0,
        "δa in C_n by default"
    );
    let mut settings = PipelineSettings::default();
    settings.synthesis.force_axes = ForceAxes::Wind;
    let models = AeroModels::with_sigma_eps([0.01; 6]);
    let w = Pipeline::new(Airframe::<f64>::skywalker_2013_mod(), models, settings).unwrap();
    for i in [idx::LIFT, idx::DRAG, idx::SIDE] {
        assert_eq!(
            w.needed_channels(i) & (channel::ALPHA | channel::BETA),
            channel::ALPHA | channel::BETA
        );
    }
}

/// GIVEN the on-board `f32` pipeline after 20 s of a simulated flight (every coefficient updated),
/// THEN the one-at-a-time report the firmware sends (`telemetry::report`) equals the six-at-once
/// `reports` bit for bit (θ, σ, k, λ_F, flags), and an index past `C_n` has none.
#[test]
fn one_report_at_a_time_equals_all_six() {
    use aerosid_core::mavlink::telemetry::{report, reports};
    let flight = aerosid_sim::flights::main_flight(20.0, 11);
    let out = aerosid_sim::simulate(&flight).expect("simulation");
    let mut p = aerosid_core::aero::onboard::pipeline::<f32>().expect("on-board pipeline");
    for s in &out.samples {
        p.process(&s.cast::<f32>());
    }
    let all = reports(&p);
    for (i, r) in all.iter().enumerate() {
        let one = report(&p, i).expect("a report for every coefficient");
        assert!(p.health().coefficients[i].updates > 0, "coefficient {i} never updated");
        assert_eq!(one.coefficient, r.coefficient);
        assert_eq!(
            (one.n_params, one.rank_k, one.health_flags),
            (r.n_params, r.rank_k, r.health_flags)
        );
        assert_eq!(one.lambda_f.to_bits(), r.lambda_f.to_bits());
        assert_eq!(
            one.theta.map(f32::to_bits),
            r.theta.map(f32::to_bits),
            "coefficient {i}: θ"
        );
        assert_eq!(
            one.sigma.map(f32::to_bits),
            r.sigma.map(f32::to_bits),
            "coefficient {i}: σ"
        );
    }
    assert!(report(&p, idx::COUNT).is_none());
}
