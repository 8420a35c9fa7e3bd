//! What the analysis does with where a flow channel comes from ([`Origin`]): a vane, a pitot, or
//! an estimator (the autopilot's α/β from its inertial solution and wind estimate, the α-free
//! mode's wind triangle, a synthetic airspeed).
//!
//! * **No sensor errors of an estimate.** Bias, scale factor, delay and vane position describe a
//!   sensor; an estimated channel has none, so the compatibility check ([`super::compat`]) and
//!   the instrumental-variable test ([`super::instrumental`]) offer none for it
//!   ([`has_sensor_errors`]). The estimate's own error — the wind estimate's, the estimator's lag —
//!   is an error in the variable: the errors-in-variables model ([`super::noise`]) draws every
//!   channel's white noise, the estimate's included, as it does for the α-free mode.
//! * **No kinematic identity named as a cause** ([`barred_terms`]). With α estimated from the
//!   inertial data, `α = θ − γ` and the lift equation `m V γ̇ = L + T sin α − m g cos γ` (Etkin &
//!   Reid, *Dynamics of Flight*, 3rd ed., §4.9, wings level) give
//!   `α̇ = q − (L + T sin α − m g cos γ)/(m V)`: `α̇` is `q` minus the measured lift, so `α̇_n` in
//!   `C_L` fits with the size of the identity, `C_L ≈ −(4m/(ρ S c̄)) α̇_n + …`, whatever the
//!   aerodynamics. Likewise `m V β̇ = Y + m g cos θ sin φ − m V (r cos α − p sin α)` (level
//!   reading of the side-force equation) makes `β̇_n` restate the measured side force in `C_Y`
//!   when β is estimated. The drag equation `m V̇ = T cos α − D − m g sin γ` holds no `γ̇`, so
//!   `α̇` in `C_D` is not an identity and stays a candidate, as `α̇` in `C_m` (the downwash lag)
//!   does. **Reading**: every estimator of α or β this project meets works from the inertial data
//!   (GPS or navigation-filter velocity, attitude, a wind estimate), so any estimated α or β is
//!   taken as inertial.

use super::model::Term;
use crate::io::measured::{MeasuredFlight, Origin, Quantity};
use std::collections::BTreeMap;

/// The flow channels whose origin the report shows.
pub const FLOW_CHANNELS: [Quantity; 3] = [Quantity::Alpha, Quantity::Beta, Quantity::Airspeed];

/// Whether the compatibility check may offer sensor errors (bias, scale, delay, vane position)
/// of channel `q`: not when `q` is an estimate.
pub fn has_sensor_errors(flight: &MeasuredFlight, q: Quantity) -> bool {
    !flight.log.is_estimated(q)
}

/// The library terms not offered to a coefficient (its index into
/// [`super::model::COEFFICIENTS`]) because, with this flight's estimated flow angles, they
/// restate the measured force through a kinematic identity; each with the reason in words.
pub fn barred_terms(flight: &MeasuredFlight) -> Vec<(usize, Term, String)> {
    let mut out = Vec::new();
    let by = |q: Quantity| match flight.log.origin_of(q) {
        Origin::Estimated { by } => Some(by),
        Origin::Sensor => None,
    };
    if let Some(by) = by(Quantity::Alpha) {
        out.push((
            0,
            Term::AlphaDot,
            format!(
                "α̇ not offered in C_L: α is estimated from the inertial data ({by}), so α̇ = q − γ̇ and γ̇ is the measured lift over m·V — an α̇ term would restate the measured lift through that identity (size ≈ −4m/(ρSc̄)), not an aerodynamic cause"
            ),
        ));
    }
    if let Some(by) = by(Quantity::Beta) {
        out.push((
            2,
            Term::BetaDot,
            format!(
                "β̇ not offered in C_Y: β is estimated from the inertial data ({by}), so β̇ is the measured side force over m·V plus p sin α − r cos α and gravity — a β̇ term would restate the measured side force, not an aerodynamic cause"
            ),
        ));
    }
    out
}

/// The report's notes on the flow channels' origins: which are estimated and what the analysis
/// leaves out for them.
pub fn notes(flight: &MeasuredFlight) -> Vec<String> {
    FLOW_CHANNELS
        .iter()
        .filter(|q| flight.get(**q).is_some())
        .filter_map(|q| match flight.log.origin_of(*q) {
            Origin::Estimated { by } => Some(format!(
                "{q:?} is estimated ({by}), not measured by its own sensor: no sensor errors (bias, scale, delay{}) are tested for it, and its error is treated as an error in the variable",
                if matches!(q, Quantity::Alpha | Quantity::Beta) { ", vane position" } else { "" }
            )),
            Origin::Sensor => None,
        })
        .collect()
}

/// Each flow channel present and where it comes from, for the report (`Alpha` →
/// `estimated: ArduPilot AOA.AOA …`, `Airspeed` → `sensor`).
pub fn channel_origin(flight: &MeasuredFlight) -> BTreeMap<String, String> {
    FLOW_CHANNELS
        .iter()
        .filter(|q| flight.get(**q).is_some())
        .map(|q| (format!("{q:?}"), flight.log.origin_of(*q).describe()))
        .collect()
}
