//! A flight-test card of short manoeuvres, as a small UAV is flown and logged: each manoeuvre its
//! own short record that starts from trim with a steady lead-in, in MIL-F-8785C turbulence, logged
//! by [`crate::uav_log`] (staircases, estimated α and β).
//!
//! The card ([`standard_card`]): elevator, aileron and rudder doublets and 3-2-1-1s, and a second
//! elevator and aileron doublet of the opposite sign and another period — eight records of 6–10 s.
//! The periods sit around each mode: the short period of the skywalker at 15 m/s is ≈ 1 s (doublet
//! steps of 0.5–0.8 s, 3-2-1-1 base 0.3 s), the roll subsidence ≈ 0.1 s and the Dutch roll ≈ 2 s
//! (aileron steps of 0.3–0.5 s, rudder 0.4–0.6 s). Amplitudes move α by a few degrees and roll the
//! aircraft by 10–30°, what a pilot flies on a small UAV. The stabiliser of [`crate::SimConfig`] stays
//! on: the card is flown in an assisted mode (ArduPlane FBWA), so the inputs add to the autopilot's.

use crate::flights::m;
use crate::uav_log::{log_flight, UavLog, UavLogging};
use crate::{simulate, Channel, Manoeuvre, Schedule, Shape, SimConfig, SimError, Turbulence};

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
        c("elevator_doublet", Elevator, Doublet, 0.10, 0.5, 6.0),
        c("elevator_3211", Elevator, Multistep3211, 0.08, 0.3, 7.0),
        c("aileron_doublet", Aileron, Doublet, 0.12, 0.5, 7.0),
        c("aileron_3211", Aileron, Multistep3211, 0.10, 0.3, 8.0),
        c("rudder_doublet", Rudder, Doublet, 0.15, 0.6, 8.0),
        c("rudder_3211", Rudder, Multistep3211, 0.12, 0.4, 10.0),
        c("elevator_doublet_slow", Elevator, Doublet, -0.08, 0.8, 7.0),
        c("aileron_doublet_slow", Aileron, Doublet, -0.10, 0.8, 7.0),
    ]
}

/// One flown and logged record of the card.
#[derive(Debug, Clone, PartialEq)]
pub struct CardRecord {
    /// The manoeuvre flown.
    pub manoeuvre: CardManoeuvre,
    /// The seed of its turbulence and sensor noise.
    pub seed: u64,
    /// The log.
    pub log: UavLog,
}

/// The seed of record `i` of a card with seed `seed` (distinct records, reproducible).
pub fn record_seed(seed: u64, i: usize) -> u64 {
    seed.wrapping_mul(1000).wrapping_add(i as u64)
}

/// Flies every manoeuvre of `card` from trim with `base`'s plant, sensors, turbulence and faults
/// (its schedule and duration replaced by the manoeuvre's), and logs each with `logging`;
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
}
