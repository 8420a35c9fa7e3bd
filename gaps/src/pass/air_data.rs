//! Stage 3: the air data of the regressors — the vanes and pitot as logged, the compatibility
//! check's inertial reconstruction, or their fusion (the vanes below a crossover chosen from the
//! data, the reconstruction above; [`crate::airdata`]).

use crate::airdata::{self, AirDataChoice};
use crate::compat::Compatibility;
use crate::io::measured::{MeasuredFlight, Quantity};
use std::collections::BTreeMap;

/// The air data the synthesis uses.
pub struct AirData {
    /// `Airspeed`, `Alpha`, `Beta` replacing the sensors' (`None`: the sensors as logged); the
    /// synthesis reruns when this is given.
    pub air: Option<BTreeMap<Quantity, Vec<f64>>>,
    /// The fusion's crossovers, Hz.
    pub fuse_cutoffs: Option<BTreeMap<Quantity, f64>>,
}

/// The air data `choice` resolves to on this flight; the note says which and why.
pub fn choose(
    flight: &MeasuredFlight,
    h_s: f64,
    choice: AirDataChoice,
    compat: &Compatibility,
    notes: &mut Vec<String>,
) -> AirData {
    let (air, fuse_cutoffs, note) = choose_air_data(flight, h_s, choice, compat);
    notes.push(note);
    AirData { air, fuse_cutoffs }
}

/// The air data the analysis uses (`None`: the sensors as logged), the fusion's crossovers, and
/// the report's sentence saying which and why.
#[allow(clippy::type_complexity)]
fn choose_air_data(
    flight: &MeasuredFlight,
    h_s: f64,
    choice: AirDataChoice,
    compat: &Compatibility,
) -> (
    Option<BTreeMap<Quantity, Vec<f64>>>,
    Option<BTreeMap<Quantity, f64>>,
    String,
) {
    let vanes = flight.get(Quantity::Alpha).is_some() && flight.get(Quantity::Airspeed).is_some();
    let rec = !compat.air_data.is_empty();
    let turbulent = !compat.turbulent.is_empty();
    let resolved = match choice {
        AirDataChoice::Auto if vanes && rec && !turbulent => AirDataChoice::Fused,
        AirDataChoice::Auto if vanes => AirDataChoice::Measured,
        AirDataChoice::Auto if rec => AirDataChoice::Reconstructed,
        AirDataChoice::Fused if !rec || !vanes => {
            if vanes {
                AirDataChoice::Measured
            } else {
                AirDataChoice::Reconstructed
            }
        }
        AirDataChoice::Reconstructed if !rec => AirDataChoice::Measured,
        c => c,
    };
    let asked = if resolved == choice || choice == AirDataChoice::Auto {
        String::new()
    } else {
        format!(" ({} asked for, not available)", choice.name())
    };
    match resolved {
        AirDataChoice::Fused => {
            let (air, fcs) = airdata::fuse_all(flight, &compat.air_data, h_s, None);
            let list: Vec<String> = fcs.iter().map(|(q, f)| format!("{q:?} {f} Hz")).collect();
            (
                Some(air),
                Some(fcs),
                format!(
                    "air data: fused{asked} — the vanes/pitot below and the inertial reconstruction above a crossover chosen from the data ({}); both are logged",
                    list.join(", ")
                ),
            )
        }
        AirDataChoice::Reconstructed if rec => (
            Some(compat.air_data.clone()),
            None,
            format!(
                "air data: reconstructed{asked} from the accelerometers, gyros and attitude (steady air assumed: gusts are model errors here){}",
                if vanes { "" } else { "; no α vane or airspeed in the log" }
            ),
        ),
        AirDataChoice::Measured if vanes => (
            None,
            None,
            format!(
                "air data: measured{asked} (α, β and airspeed as logged, from vanes, a pitot or an estimator: `channel_origin`){}",
                if !rec {
                    "; no inertial reconstruction possible"
                } else if turbulent {
                    "; turbulence detected, so the reconstruction (which misses the gusts) is not used, nor fused (the gusts it misses would bias the fits)"
                } else {
                    ""
                }
            ),
        ),
        _ => (None, None, "air data: none usable (no vanes and no inertial reconstruction)".into()),
    }
}
