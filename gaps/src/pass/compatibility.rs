//! Stage 2: the flight-path reconstruction by output error on the kinematic equations
//! ([`crate::compat`]) and the sensor errors it names, which are removed before any aerodynamics
//! unless [`GapSettings::apply_corrections`] is off.

use super::prepare::Plan;
use crate::compat::{self, CompatSettings, Compatibility, SensorParam};
use crate::io::measured::MeasuredFlight;
use crate::model::Corrections;
use crate::{instrumental, GapSettings};

/// The compatibility check and what it corrects.
pub struct Compatible {
    /// The check (its reconstruction of the air data, the errors found, its notes).
    pub compatibility: Compatibility,
    /// The sensor errors removed before the synthesis (none when the corrections are switched
    /// off): the synthesis reruns on corrected data when this is not empty.
    pub corr: Corrections,
}

/// The compatibility check of `flight` at the plan's threshold; a note when errors are removed.
pub fn check(
    flight: &MeasuredFlight,
    h: f64,
    settings: &GapSettings,
    plan: &Plan,
    notes: &mut Vec<String>,
) -> Compatible {
    let cs = CompatSettings {
        threshold_t2: plan.compat_threshold_t2,
        max_lag: plan.max_lag,
        max_added: 3,
        gain_alpha: settings.cv.gain_alpha,
        iv: instrumental::IvSettings {
            level: settings.alpha / plan.m as f64,
            cv: settings.cv,
        },
    };
    let compatibility = if settings.compatibility {
        compat::check(flight, h, &cs)
    } else {
        Compatibility {
            notes: vec!["compatibility check switched off".into()],
            ..Compatibility::default()
        }
    };
    let corr = if settings.apply_corrections {
        if !compatibility.found.is_empty() {
            notes.push("the sensor errors named are removed from the data before the aerodynamics; the baselines as logged are listed beside (`as_logged`)".into());
        }
        corrections_of(&compatibility)
    } else {
        Corrections::default()
    };
    Compatible { compatibility, corr }
}

/// The delays named, refined within their interval by the aerodynamic baselines before they are
/// removed ([`crate::delay_rival::refine`]); a note when one moved.
pub fn refine_delays(
    compatible: &mut Compatible,
    flight: &MeasuredFlight,
    h: f64,
    air: &super::air_data::AirData,
    plan: &Plan,
    baselines: &[Vec<crate::model::Term>; 6],
    notes: &mut Vec<String>,
) {
    let on = crate::delay_rival::Flight {
        flight,
        h_s: h,
        compatibility: &compatible.compatibility,
        air: air.air.as_ref(),
        sg_half: plan.sg_half,
        baselines,
        n_id: plan.n_id,
    };
    let refined = crate::delay_rival::refine(&on, &mut compatible.corr);
    notes.extend(refined);
}

/// The corrections of the sensor errors the compatibility check named.
fn corrections_of(c: &Compatibility) -> Corrections {
    let mut corr = Corrections::default();
    for f in &c.found {
        match f.param {
            SensorParam::Bias(q) => {
                corr.bias.insert(q, f.value);
            }
            SensorParam::Scale(q) => {
                corr.scale.insert(q, f.value);
            }
            SensorParam::Delay(q) => {
                corr.delay_s.insert(q, f.value);
            }
            SensorParam::VaneX(q) => {
                corr.vane_dx_m.insert(q, f.value);
            }
        }
    }
    corr
}
