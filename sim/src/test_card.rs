//! A flight-test card of short manoeuvres, as a small UAV is flown and logged: each manoeuvre its
//! own short record that starts from trim with a steady lead-in, in MIL-F-8785C turbulence, logged
//! by [`crate::uav_log`] (staircases, estimated α and β).
//!
//! The card ([`standard_card`]): elevator, aileron and rudder doublets and 3-2-1-1s, and a second
//! elevator and aileron doublet of the opposite sign and another period — eight records of 6–10 s.
//! The periods sit around each mode: the short period of the skywalker at 15 m/s is ≈ 1 s (doublet
//! steps of 0.5–0.8 s, 3-2-1-1 base 0.3 s), the roll subsidence ≈ 0.1 s and the Dutch roll ≈ 2 s
//! (aileron steps of 0.3–0.5 s, rudder 0.4–0.6 s).
//!
//! Amplitudes and mode are what a flight-test team flies on a small UAV (Jategaonkar 2015 ch. 2,
//! Morelli & Klein 2016 ch. 9: inputs large enough that the response stands well above the noise
//! and the turbulence, small enough that the linear model holds): α moves by 3–5° peak, the bank
//! by 15–25°, β by 4–9°. The card is flown in an assisted mode (ArduPlane FBWA): the stabiliser of
//! [`crate::SimConfig`] stays on and the input is injected on the surfaces on top of its output, as
//! a script overriding the servo outputs does. The stabiliser opposes the input (its pitch
//! attitude hold supplies about half of the elevator's motion), so the inputs are sized for the
//! response, not the surface: elevator 0.20–0.25 rad, aileron 0.20–0.25 rad. Flying the same
//! inputs in MANUAL (stabiliser off) gives the same α but lets the pitch attitude and the airspeed
//! wander (the phugoid), and the estimated α's error then follows the airspeed: on four clean cards
//! three named a thrust or speed term in `C_L` or `C_m`, against none of four in FBWA, and none with
//! the true α in place of the estimate (docs/test-card.md, "Mode").

use crate::flights::m;
use crate::uav_log::{log_flight, UavLog, UavLogging};
use crate::{simulate, Channel, Manoeuvre, Schedule, Shape, SimConfig, SimError, SimOutput, TruthSample, Turbulence};

/// The card's turbulence level (MIL-F-8785C low altitude, [`Turbulence::mil_f_8785c_low_altitude`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CardTurbulence {
    /// Wind at 20 ft of 15 kt: at 100 m `σ_w` 0.77 m/s, `σ_u,v` 1.06 m/s.
    Light,
    /// 30 kt: twice the light intensities.
    Moderate,
}

impl CardTurbulence {
    /// Command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Light => "light",
            Self::Moderate => "moderate",
        }
    }

    /// The Dryden settings at `altitude_m` above ground.
    pub fn turbulence(self, altitude_m: f64) -> Turbulence {
        let w20 = match self {
            Self::Light => Turbulence::W20_LIGHT_MPS,
            Self::Moderate => Turbulence::W20_MODERATE_MPS,
        };
        Turbulence::mil_f_8785c_low_altitude(altitude_m, w20)
    }
}

/// One manoeuvre of the card: its input (starting after the lead-in) and its record's length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CardManoeuvre {
    /// A short name, used for the record's file (`elevator_doublet`).
    pub name: &'static str,
    /// The input; `start_s` is the steady lead-in from trim.
    pub manoeuvre: Manoeuvre,
    /// The record's length, s.
    pub duration_s: f64,
}

/// The standard card (module doc): eight manoeuvres, a 1.5 s lead-in each.
pub fn standard_card() -> Vec<CardManoeuvre> {
    let lead = 1.5;
    let c = |name, channel, shape, amplitude, period_s, duration_s| CardManoeuvre {
        name,
        manoeuvre: m(channel, shape, lead, amplitude, period_s),
        duration_s,
    };
    use Channel::*;
    use Shape::*;
    vec![
        c("elevator_doublet", Elevator, Doublet, 0.25, 0.5, 6.0),
        c("elevator_3211", Elevator, Multistep3211, 0.20, 0.3, 7.0),
        c("aileron_doublet", Aileron, Doublet, 0.25, 0.5, 7.0),
        c("aileron_3211", Aileron, Multistep3211, 0.20, 0.3, 8.0),
        c("rudder_doublet", Rudder, Doublet, 0.15, 0.6, 8.0),
        c("rudder_3211", Rudder, Multistep3211, 0.12, 0.4, 10.0),
        c("elevator_doublet_slow", Elevator, Doublet, -0.20, 0.8, 7.0),
        c("aileron_doublet_slow", Aileron, Doublet, -0.20, 0.8, 7.0),
    ]
}

/// What a record's flight did (the truth, not the log): each quantity's RMS and peak deviation
/// from its mean over the lead-in (so a steady trim offset does not count), and the surface the
/// input drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Excursions {
    /// α: RMS, peak, rad.
    pub alpha_rad: (f64, f64),
    /// β: RMS, peak, rad.
    pub beta_rad: (f64, f64),
    /// Bank φ: RMS, peak, rad.
    pub bank_rad: (f64, f64),
    /// p, q, r: RMS, peak, rad/s.
    pub rates_rad_s: [(f64, f64); 3],
    /// Airspeed: RMS, peak, m/s.
    pub airspeed_mps: (f64, f64),
    /// The driven surface (the manoeuvre's channel; throttle in its fraction): RMS, peak, rad.
    pub surface_rad: (f64, f64),
}

impl Excursions {
    /// The excursions of `out`, a flight of manoeuvre `m` (its lead-in ends at `m.start_s`).
    pub fn of(out: &SimOutput, m: &Manoeuvre) -> Self {
        let tr = &out.truth;
        let lead = tr.iter().take_while(|t| t.t_s < m.start_s).count().max(1);
        let stat = |f: &dyn Fn(&TruthSample) -> f64| {
            let m0 = tr[..lead].iter().map(f).sum::<f64>() / lead as f64;
            let (mut ss, mut pk) = (0.0f64, 0.0f64);
            for t in tr {
                let d = f(t) - m0;
                ss += d * d;
                pk = pk.max(d.abs());
            }
            ((ss / tr.len().max(1) as f64).sqrt(), pk)
        };
        Self {
            alpha_rad: stat(&|t| t.eval.alpha_rad),
            beta_rad: stat(&|t| t.eval.beta_rad),
            bank_rad: stat(&|t| t.state.euler_rad().x),
            rates_rad_s: [
                stat(&|t| t.state.rate_rad_s.x),
                stat(&|t| t.state.rate_rad_s.y),
                stat(&|t| t.state.rate_rad_s.z),
            ],
            airspeed_mps: stat(&|t| t.eval.airspeed_mps),
            surface_rad: stat(&|t| match m.channel {
                Channel::Elevator => t.controls.elevator_rad,
                Channel::Aileron => t.controls.aileron_rad,
                Channel::Rudder => t.controls.rudder_rad,
                Channel::Throttle => t.controls.throttle,
            }),
        }
    }
}

/// One flown and logged record of the card.
#[derive(Debug, Clone, PartialEq)]
pub struct CardRecord {
    /// The manoeuvre flown.
    pub manoeuvre: CardManoeuvre,
    /// What the flight did.
    pub excursions: Excursions,
    /// The seed of its turbulence and sensor noise.
    pub seed: u64,
    /// The log.
    pub log: UavLog,
}

/// The seed of record `i` of a card with seed `seed` (distinct records, reproducible).
pub fn record_seed(seed: u64, i: usize) -> u64 {
    seed.wrapping_mul(1000).wrapping_add(i as u64)
}

/// Flies every manoeuvre of `card` from trim with `base`'s plant, stabiliser, sensors, turbulence
/// and faults (its schedule and duration replaced by the manoeuvre's), and logs each with `logging`;
/// `elevator_lead_s` as in [`log_flight`]. Record `i` uses [`record_seed`]`(seed, i)` for the
/// flight and the logger.
pub fn fly_card(
    base: &SimConfig,
    card: &[CardManoeuvre],
    logging: &UavLogging,
    elevator_lead_s: f64,
    seed: u64,
) -> Result<Vec<CardRecord>, SimError> {
    card.iter()
        .enumerate()
        .map(|(i, c)| {
            let s = record_seed(seed, i);
            let cfg = SimConfig {
                schedule: Schedule::default().with(c.manoeuvre),
                duration_s: c.duration_s,
                seed: s,
                ..base.clone()
            };
            let out = simulate(&cfg)?;
            let log = log_flight(&out, &cfg.plant.wind_ned_mps, logging, elevator_lead_s, s ^ 0x05EE_D106);
            Ok(CardRecord {
                manoeuvre: *c,
                excursions: Excursions::of(&out, &c.manoeuvre),
                seed: s,
                log,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The card has 6–10 manoeuvres of 5–12 s, each ending inside its record with at least 3 s
    /// of free response, and covers doublets and 3-2-1-1s on every surface.
    #[test]
    fn the_card_is_a_short_manoeuvre_card() {
        let card = standard_card();
        assert!((6..=10).contains(&card.len()));
        for c in &card {
            assert!((5.0..=12.0).contains(&c.duration_s), "{}", c.name);
            assert!(c.manoeuvre.end_s() + 3.0 <= c.duration_s, "{}", c.name);
            assert!(c.manoeuvre.start_s >= 1.0, "{}: lead-in", c.name);
        }
        for ch in [Channel::Elevator, Channel::Aileron, Channel::Rudder] {
            for sh in [Shape::Doublet, Shape::Multistep3211] {
                assert!(
                    card.iter()
                        .any(|c| c.manoeuvre.channel == ch && c.manoeuvre.shape == sh),
                    "{ch:?} {sh:?}"
                );
            }
        }
    }

    /// The card moves the aircraft as a flight-test card of a small UAV does (module doc): on
    /// every elevator record α peaks 2–5° from trim, on every aileron record the bank 15–30°, on
    /// every rudder record β 3–10°; in light turbulence, a clean plant, seed 7. The bands are the
    /// flight-test practice the card is made to (the module doc's references); light turbulence
    /// alone moves α by ≈ 0.5° RMS, so an elevator input that peaks below 2° is not excitation.
    #[test]
    fn the_card_moves_alpha_bank_and_sideslip_as_a_test_card_does() {
        use crate::{Plant, SimAirframe, TruthEffects};
        let base = SimConfig {
            plant: Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::none()),
            turbulence: Some(CardTurbulence::Light.turbulence(100.0)),
            ..SimConfig::default()
        };
        let deg = 180.0 / core::f64::consts::PI;
        let card = standard_card();
        let logging = UavLogging::default();
        for r in fly_card(&base, &card, &logging, 0.0, 7).expect("the card flies") {
            let e = r.excursions;
            let (band, got) = match r.manoeuvre.manoeuvre.channel {
                Channel::Elevator => ((2.0, 5.0), e.alpha_rad.1 * deg),
                Channel::Aileron => ((15.0, 30.0), e.bank_rad.1 * deg),
                _ => ((3.0, 10.0), e.beta_rad.1 * deg),
            };
            assert!(
                (band.0..=band.1).contains(&got),
                "{}: peak {got:.1}° outside {band:?}",
                r.manoeuvre.name
            );
        }
    }
}
