//! The low-rate path's entry: below [`crate::io::quality::MIN_RATE_HZ`] the coefficients are
//! fitted and their candidates tested by output error, one axis at a time — the longitudinal
//! `C_L`, `C_D`, `C_m` ([`super::oem`]) and the lateral `C_Y`, `C_l`, `C_n`
//! (`oem_lateral.rs`) — each where the data allow it. Both axes share the estimation of
//! `oem.rs`; this module only dispatches to them and joins their results, so neither axis
//! module refers to the other's dispatch.

use super::oem::{self, Inputs, LowRate};
use super::oem_lateral;

/// The low-rate analysis: each axis where the data allow it. `Err` says why neither can run.
pub fn analyse(inp: &Inputs) -> Result<LowRate, String> {
    let lon = oem::setup(inp).and_then(|s| oem::analyse_axis(inp, s));
    let lat = oem_lateral::setup(inp).and_then(|s| oem::analyse_axis(inp, s));
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
