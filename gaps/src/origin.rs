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
//!   when β is estimated. In the other coefficients `α̇` is no identity, but it still carries the
//!   measured lift, and in turbulence that lift holds the gust's share, which an estimated α (the
//!   ground velocity less a slowly updated wind) does not see: the fit takes `α̇` for the gust's
//!   effect (a pitching moment that follows the lift), not for a downwash lag. On simulated test
//!   cards with estimated α and β and no planted effect, `α̇_n` in `C_m` and `β̇_n` in `C_l`, `C_n`
//!   passed both the `t²` and the held-out-manoeuvre tests on 5, 9 and 7 of 20 cards
//!   (docs/benchmarks.md, "Pooled manoeuvres"), so with an estimated flow angle its rate is offered
//!   in no coefficient: a real `C_mα̇` is then missed, not invented. **Reading**: every estimator
//!   of α or β this project meets works from the inertial data (GPS or navigation-filter
//!   velocity, attitude, a wind estimate), so any estimated α or β is taken as inertial.
//! * **No product that restates the drag's rotation error** ([`barred_terms`]). Drag is the
//!   measured force rotated into stability axes by α: `D = −(F_x cos α + F_z sin α)`, and
//!   `∂D/∂α = L`, so a drag synthesised with an estimated α carries `C_L·(α̂ − α)` to first
//!   order. `C_L` is linear in α and the estimate's error
//!   follows the manoeuvre (its lag on `α̇ ≈ q`, the gust share it misses), so that error has a
//!   part in `α·q_n`: `α·q_n` in `C_D` fits with a systematic value whatever the airframe. Measured
//!   on the simulated test cards, whose truth has no `α·q_n` in drag (the induced drag `C_L²` of
//!   a lift without a `q` term): its estimate over the 50 cards of the benchmark (the card with its
//!   earlier, smaller inputs) is +12.5 ± 3.4
//!   (mean ± its standard error; +23 in light turbulence, +2 in moderate, where the estimate's
//!   larger error attenuates it), and on one card (seed 7, light, flown in MANUAL) +21 ± 7 with
//!   the estimated α against +3 ± 11 with the true α in its place (docs/model-gaps.md). So with an estimated α, `α·q_n` is not
//!   offered in `C_D`: a real one (a pitch-rate lift `C_Lq` in the induced drag) is missed, not
//!   invented; with a vane it is offered.

use super::model::{Term, COEFFICIENTS};
use crate::io::measured::{MeasuredFlight, Origin, Quantity};

/// The flow channels whose origin the report shows, and each one's origin for the report (kept
/// with the reader's [`Origin`], which the data-quality assessment reports too).
pub use crate::io::measured::{channel_origin, FLOW_CHANNELS};

/// Whether the compatibility check may offer sensor errors (bias, scale, delay, vane position)
/// of channel `q`: not when `q` is an estimate.
pub fn has_sensor_errors(flight: &MeasuredFlight, q: Quantity) -> bool {
    !flight.log.is_estimated(q)
}

/// The library terms not offered to a coefficient (its index into
/// [`super::model::COEFFICIENTS`]) because, with this flight's estimated flow angles, they
/// restate the measured force through a kinematic identity or, `α·q_n` in `C_D`, the drag's
/// rotation error (module doc); each with the reason in words.
///
/// An α estimated from the inertial data (the ground velocity less a slowly updated wind) gives
/// `α̇ = q − γ̇`, and `γ̇` is the measured lift over `m·V`: in C_L the term restates the lift. In
/// the other coefficients it carries the same measured lift, and in turbulence that lift holds
/// the gust's share, which the estimated α does not see — so a fit takes α̇ for the gust's
/// effect on the coefficient (a pitching moment that follows the lift, not a downwash lag). The
/// two cannot be told apart from such a flight, so α̇ is offered nowhere. Likewise β̇ with an
/// estimated β (the measured side force over `m·V` plus `p sin α − r cos α` and gravity).
pub fn barred_terms(flight: &MeasuredFlight) -> Vec<(usize, Term, String)> {
    // (the angle, its rate, the coefficient it restates, its name, the force it carries)
    let rates = [
        (Quantity::Alpha, Term::AlphaDot, 0, "α", "α̇ = q − γ̇ and γ̇ is the measured lift over m·V", "lift", "an α̇ term would restate the measured lift through that identity (size ≈ −4m/(ρSc̄)), not an aerodynamic cause"),
        (Quantity::Beta, Term::BetaDot, 2, "β", "β̇ is the measured side force over m·V plus p sin α − r cos α and gravity", "side force", "a β̇ term would restate the measured side force, not an aerodynamic cause"),
    ];
    const C_D: usize = 1;
    let mut out = Vec::new();
    for (q, term, own, angle, identity, force, restated) in rates {
        let Origin::Estimated { by } = flight.log.origin_of(q) else {
            continue;
        };
        for (i, name) in COEFFICIENTS.iter().enumerate() {
            let why = if i == own {
                restated.to_string()
            } else {
                format!("in {name} it would carry the measured {force}, which in turbulence holds the gust's share that the estimated {angle} misses: its effect cannot be told from the gust's")
            };
            out.push((
                i,
                term,
                format!(
                    "{} not offered in {name}: {angle} is estimated from the inertial data ({by}), so {identity} — {why}",
                    term.name().trim_end_matches("_n")
                ),
            ));
        }
    }
    if let Origin::Estimated { by } = flight.log.origin_of(Quantity::Alpha) {
        out.push((
            C_D,
            Term::AlphaQ,
            format!(
                "α·q not offered in C_D: α is estimated ({by}), and drag is the measured force rotated by α, so C_D carries C_L·(α̂ − α); with C_L linear in α and the estimate's error following the manoeuvre (its lag, the gust share it misses), that error fits α·q_n with a systematic value (module doc of gaps::origin), not an aerodynamic cause"
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
