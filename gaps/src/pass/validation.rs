//! Stage 6: what the models get wrong on data they were not fitted to — the baseline and the
//! extended models simulate the held-out segment ([`crate::simulate`]), each manoeuvre's
//! estimates and their agreement, and the baselines fitted to the data as logged when sensor
//! errors were removed before the aerodynamics.

use super::air_data::AirData;
use super::compatibility::Compatible;
use super::prepare::Prepared;
use super::selection::Selected;
use super::synthesis::Synthesised;
use crate::model::{self, Corrections, Term, TermRefs, COEFFICIENTS};
use crate::{manoeuvres_of, select, simulate, CoefficientGap, GapSettings, Manoeuvre};

/// The held-out checks of the models.
pub struct Validated {
    /// The simulation of the held-out segment with the baseline and the extended models.
    pub simulation: simulate::Simulation,
    /// The manoeuvres analysed, in their canonical order.
    pub manoeuvres: Vec<Manoeuvre>,
    /// Whether named sensor errors were removed from the data before the aerodynamics.
    pub corrections_applied: bool,
    /// The baseline estimates on the data as logged (`term`, value per coefficient) when they
    /// were.
    pub as_logged: Vec<(String, Vec<(String, f64)>)>,
}

/// [`Validated`] of the selected models.
pub fn validate(
    prepared: &Prepared,
    compatible: &Compatible,
    air: &AirData,
    syn: &Synthesised,
    selected: &Selected,
    settings: &GapSettings,
) -> Validated {
    let Prepared {
        flight,
        h,
        baselines,
        plan,
        ..
    } = prepared;
    let coefficients = &selected.coefficients;
    let (set_b, set_e) = (model_set(coefficients, false), model_set(coefficients, true));
    let simulation = simulate::simulate(
        &syn.table,
        &flight.aircraft,
        *h,
        &syn.refs,
        plan.n_id,
        &syn.pieces,
        [&set_b, &set_e],
    );
    let corrections_applied = settings.apply_corrections && !compatible.compatibility.found.is_empty();
    let as_logged = if corrections_applied {
        // The plan's table is the data as logged with the sensors' air data; other air data need
        // their own synthesis of the uncorrected data.
        let other;
        let table = match &air.air {
            None => &plan.as_logged,
            Some(a) => {
                other = model::synthesise(flight, *h, &Corrections::default(), plan.sg_half, Some(a));
                &other
            }
        };
        baselines_as_logged(table, *h, &syn.refs, baselines, settings)
    } else {
        Vec::new()
    };
    let manoeuvres = manoeuvres_of(flight, &syn.table, &syn.refs, baselines, &syn.errors, plan.n_id);
    Validated {
        simulation,
        manoeuvres,
        corrections_applied,
        as_logged,
    }
}

/// The baseline (`extended == false`) or the extended models of every coefficient analysed.
fn model_set(coefficients: &[CoefficientGap], extended: bool) -> simulate::ModelSet {
    core::array::from_fn(|i| {
        coefficients.iter().find(|c| c.name == COEFFICIENTS[i]).map(|c| {
            if extended {
                c.extended_model.clone()
            } else {
                c.baseline_model.clone()
            }
        })
    })
}

/// The baselines fitted to the data as logged (`table`; least squares over the whole flight),
/// for the report's before-and-after of the sensor corrections.
fn baselines_as_logged(
    table: &model::Table,
    h: f64,
    refs: &TermRefs,
    baselines: &[Vec<Term>; 6],
    settings: &GapSettings,
) -> Vec<(String, Vec<(String, f64)>)> {
    let mut out = Vec::new();
    for i in 0..6 {
        let Some(z) = &table.z[i] else { continue };
        let cols: Vec<(Term, Vec<f64>)> = baselines[i]
            .iter()
            .filter_map(|t| t.column(table, refs).map(|c| (*t, c)))
            .collect();
        let refs_c: Vec<&[f64]> = cols.iter().map(|(_, c)| c.as_slice()).collect();
        let d = select::Design::new(&refs_c, z, h, &settings.cv, None);
        let idx: Vec<usize> = (0..cols.len()).collect();
        if let Ok(f) = d.fit(&idx) {
            out.push((
                COEFFICIENTS[i].to_string(),
                cols.iter()
                    .zip(&f.theta)
                    .map(|((t, _), v)| (t.name().to_string(), *v))
                    .collect(),
            ));
        }
    }
    out
}
