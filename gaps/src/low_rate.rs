//! The low-rate path's entry: below [`crate::io::quality::MIN_RATE_HZ`] the coefficients are
//! fitted and their candidates tested by output error, or by the filter error method where an
//! axis's output-error residuals show process noise (`low_rate_fem.rs`), one axis at a
//! time — the longitudinal `C_L`, `C_D`, `C_m` ([`super::oem`]) and the lateral `C_Y`, `C_l`,
//! `C_n` (`oem_lateral.rs`) — each where the data allow it. Both axes share the estimation
//! of `oem.rs`; this module only chooses the method, dispatches to the axes and joins their
//! results, so neither axis module refers to the other.

use super::low_rate_fem;
use super::oem::{self, Dynamics, Inputs, LowRate, Setup};
use super::oem_lateral;
use crate::LowRateMethod;

/// The low-rate analysis: each axis where the data allow it, by the method `method` chooses.
/// `Err` says why neither can run.
pub fn analyse(inp: &Inputs, method: LowRateMethod) -> Result<LowRate, String> {
    let lon = axis(inp, oem::setup(inp), method);
    let lat = axis(inp, oem_lateral::setup(inp), method);
    match (lon, lat) {
        (Err(a), Err(b)) => Err(format!("longitudinal: {a}; lateral: {b}")),
        (Ok(mut lr), Err(b)) => {
            lr.notes.push(format!(
                "C_Y, C_l, C_n not covered: the lateral output error cannot run: {b}"
            ));
            Ok(lr)
        }
        (Err(a), Ok(mut lr)) => {
            lr.notes.insert(
                0,
                format!("C_L, C_D, C_m not covered: the longitudinal output error cannot run: {a}"),
            );
            Ok(lr)
        }
        (Ok(mut lr), Ok(lat)) => {
            lr.coefficients.extend(lat.coefficients);
            lr.covered.extend(lat.covered);
            lr.notes.extend(lat.notes);
            Ok(lr)
        }
    }
}

/// One axis: the process-noise test on its output-error baseline, then its analysis by the
/// method chosen, the choice and its reason first in its notes.
fn axis<D: Dynamics>(inp: &Inputs, setup: Result<Setup<D>, String>, method: LowRateMethod) -> Result<LowRate, String> {
    let mut setup = setup?;
    let decision = low_rate_fem::decide(inp, &setup, method)?;
    if let Some((k, fold_gains)) = decision.gain {
        setup.set_gain(k, fold_gains);
    }
    let mut lr = oem::analyse_axis(inp, setup)?;
    lr.notes.insert(0, decision.note);
    Ok(lr)
}
