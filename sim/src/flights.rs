//! The flights of the seed's simulation results (seed 000 Section VI-A, Fig. 1–2) and of the
//! main job, shared by the host tests (`tests/paper.rs`, `tests/coverage.rs`) and the `aerosid`
//! command.

use crate::*;

/// The default sensor noise without biases: seed 000 Section VI-A corrupts its virtual sensors
/// with white noise only, and Section V's assumption A takes systematic errors as known and
/// removed. (Realistic biases — 0.2° on the vanes, 0.1 m/s on the pitot — shift `C_D0` by a few
/// per cent whatever the estimator; that is a calibration question, not Fig. 1's.)
pub fn white_noise_sensors() -> SensorNoise {
    SensorNoise::default().without_biases()
}

/// A manoeuvre.
pub fn m(channel: Channel, shape: Shape, start_s: f64, amplitude: f64, period_s: f64) -> Manoeuvre {
    Manoeuvre {
        channel,
        shape,
        start_s,
        amplitude,
        period_s,
    }
}

/// Cruise `cruise_s`, then longitudinal excitation until the end: every 8 s an elevator 3-2-1-1
/// (0.4 s steps, ±0.2 rad) and a 4 s doublet (±0.3 rad) as in [`fig2_config`] — the slow doublet
/// swings `α` by ±0.05 rad quasi-statically, which is what separates `α²` from `α`: the
/// curvature `(α − ᾱ)²` must exceed the `α²` channel's noise `2α₀σ_α ≈ 9·10⁻⁴` (eq. 21).
pub fn fig1_config(cruise_s: f64, duration_s: f64, seed: u64) -> SimConfig {
    let mut schedule = Schedule::default();
    let mut t = cruise_s;
    while t + 8.0 <= duration_s {
        schedule = schedule
            .with(m(Channel::Elevator, Shape::Multistep3211, t, 0.2, 0.4))
            .with(m(Channel::Elevator, Shape::Doublet, t + 2.6, 0.3, 4.0));
        t += 8.0;
    }
    // The V-shaped elevator drag `k|δe|` is outside eq. 3b (no linear δe term can represent it);
    // it is a model gap for the model-gap analysis, not a test of the estimator under noise, so it is off here.
    // Induced drag stays: its `α²` part is what gives the truth a `C_Dα²` (the skywalker's own
    // `C_Dα²` is 0).
    let eff = TruthEffects {
        elevator_drag_per_rad: None,
        ..TruthEffects::all()
    };
    SimConfig {
        plant: Plant::new(SimAirframe::skywalker_2013_mod(), eff),
        sensors: white_noise_sensors(),
        turbulence: Some(Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_LIGHT_MPS)),
        schedule,
        duration_s,
        seed,
        ..SimConfig::default()
    }
}

/// The `C_m` change of the Fig. 2 flight and of the long run's first jump (damage or a
/// configuration change): `ΔC_m0 = 0.005`, `ΔCmα = 0.4`, `ΔCmq = 4`.
pub fn pitch_jump() -> LinearAero {
    LinearAero {
        pitch: CoeffModel {
            c0: 0.005,
            alpha: 0.4,
            q_n: 4.0,
            ..CoeffModel::default()
        },
        ..LinearAero::default()
    }
}

/// Elevator excitation until `excite_until_s` — every 8 s a 3-2-1-1 (0.4 s steps, ±0.2 rad) and,
/// from 2.6 s later, a 4 s doublet (±0.3 rad; with the trim elevator it may touch the ±0.349 rad
/// stop) — a jump of the `C_m` parameters at `jump_s`, then unexcited cruise until `duration_s`.
///
/// Why this input: `α` and `q` are 0.91 correlated under the stabiliser, and the least excited
/// direction of the whitened regressors is nearly `α` against the 0.5° vane noise. The slow doublet
/// moves `α` quasi-statically with little `q`, which separates them; the amplitude is what lets
/// that direction stay above the eq. 21 threshold through 300 s of cruise (with `λ_F = 1` the
/// threshold grows as `2√N` while an unexcited direction's `σ²` grows only by the noise, so a
/// direction survives a cruise of `N_c` samples only if `σ² ≳ 4(N + N_c) − N_c` at its start).
pub fn fig2_config(jump_s: f64, excite_until_s: f64, duration_s: f64, seed: u64) -> SimConfig {
    let mut schedule = Schedule::default();
    let mut t = 2.0;
    while t + 8.0 <= excite_until_s {
        schedule = schedule
            .with(m(Channel::Elevator, Shape::Multistep3211, t, 0.2, 0.4))
            .with(m(Channel::Elevator, Shape::Doublet, t + 2.6, 0.3, 4.0));
        t += 8.0;
    }
    let mut plant = Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::all());
    plant.jump = Some(ParameterJump {
        at_s: jump_s,
        delta: pitch_jump(),
    });
    SimConfig {
        plant,
        schedule,
        duration_s,
        seed,
        ..SimConfig::default()
    }
}

/// The main job's flight (the tool's `report` module): the default skywalker with every hidden effect, light
/// Dryden turbulence and the default sensors (noise and per-run biases); 20 s of cruise, then every
/// 8 s an elevator 3-2-1-1 (0.4 s steps, ±0.2 rad) and 4 s doublet (±0.3 rad), an aileron 3-2-1-1
/// (0.3 s steps, ±0.15 rad) and a 2 s rudder doublet (±0.2 rad), until `duration_s`.
pub fn main_flight(duration_s: f64, seed: u64) -> SimConfig {
    let mut schedule = Schedule::default();
    let mut t = 20.0;
    while t + 8.0 <= duration_s {
        schedule = schedule
            .with(m(Channel::Elevator, Shape::Multistep3211, t, 0.2, 0.4))
            .with(m(Channel::Elevator, Shape::Doublet, t + 2.6, 0.3, 4.0))
            .with(m(Channel::Aileron, Shape::Multistep3211, t + 0.5, 0.15, 0.3))
            .with(m(Channel::Rudder, Shape::Doublet, t + 4.5, 0.2, 2.0));
        t += 8.0;
    }
    SimConfig {
        turbulence: Some(Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_LIGHT_MPS)),
        schedule,
        duration_s,
        seed,
        ..SimConfig::default()
    }
}
