//! Stage 4: the coefficients of eq. 1–2 synthesised from the corrected, smoothed channels
//! ([`crate::model`]), the terms' reference values and columns, and every column's errors in
//! variables from a Monte Carlo of the sensors' white noise ([`crate::noise`]).

use super::air_data::AirData;
use super::compatibility::Compatible;
use super::prepare::{Plan, Prepared};
use crate::io::measured::MeasuredFlight;
use crate::model::{self, Corrections, Table, Term, TermRefs, COEFFICIENTS};
use crate::noise::{self, ColumnErrors};
use crate::{oracle, GapError, GapSettings, Regression};

/// The regression problem of every coefficient.
pub struct Synthesised {
    /// The coefficients and signals, on corrected data with the chosen air data.
    pub table: Table,
    /// The terms' reference values, from the identification segment.
    pub refs: TermRefs,
    /// Each coefficient's baseline terms followed by the library terms offered to it.
    pub all_terms: [Vec<Term>; 6],
    /// The errors in variables of every column a coefficient may fit (none without
    /// [`GapSettings::errors_in_variables`]).
    pub errors: [Option<ColumnErrors>; 6],
    /// The coefficients and every term's column, as the selection sees them.
    pub regression: Regression,
    /// The manoeuvres' sample ranges.
    pub pieces: Vec<(usize, usize)>,
    /// The columns' error variances from estimated flow angles ([`oracle::FlightOracle`]).
    pub oracle: oracle::FlightOracle,
}

/// The aerodynamics' table: the plan's as-logged table when nothing changes it (no correction,
/// the sensors' air data), else synthesised again on the corrected data with the chosen air data.
pub fn table(flight: &MeasuredFlight, h: f64, plan: &Plan, compatible: &Compatible, air: &AirData) -> Table {
    if compatible.corr == Corrections::default() && air.air.is_none() {
        plan.as_logged.clone()
    } else {
        model::synthesise(flight, h, &compatible.corr, plan.sg_half, air.air.as_ref())
    }
}

/// [`Synthesised`] of a prepared flight; refused when no coefficient can be synthesised.
pub fn synthesise(
    prepared: &Prepared,
    compatible: &Compatible,
    air: &AirData,
    settings: &GapSettings,
    notes: &mut Vec<String>,
) -> Result<Synthesised, GapError> {
    let Prepared {
        flight,
        h,
        baselines,
        plan,
        ..
    } = prepared;
    let (h, sg_half, n_id) = (*h, plan.sg_half, plan.n_id);
    let table = table(flight, h, plan, compatible, air);
    notes.extend(table.notes.iter().cloned());
    if table.z.iter().all(|z| z.is_none()) {
        return Err(GapError::NothingToAnalyse {
            source: flight.source.clone(),
            notes: std::mem::take(notes),
        });
    }
    let refs = TermRefs::of_identification(&table, n_id);
    let all_terms = all_terms(baselines, &table);
    let pieces: Vec<(usize, usize)> = flight.pieces().iter().map(|p| (p.start, p.end)).collect();
    let errors: [Option<ColumnErrors>; 6] = match &settings.errors_in_variables {
        Some(mc) => {
            let (estimate_errors, estimate_notes) =
                crate::origin::estimate_errors(flight, &table, &refs, baselines, &pieces, n_id, sg_half, h);
            notes.extend(estimate_notes);
            let syn = noise::Synthesis {
                flight,
                h_s: h,
                corrections: &compatible.corr,
                sg_half,
                compat: air.air.as_ref().map(|_| &compatible.compatibility),
                fuse_cutoffs: air.fuse_cutoffs.as_ref(),
                refs: &refs,
                n_id,
                estimate_errors: &estimate_errors,
            };
            notes.push(monte_carlo_note(&syn, &table, mc));
            let errors = noise::column_errors(&syn, &table, &all_terms, mc);
            if estimate_errors.is_empty() {
                errors
            } else {
                let est = noise::estimate_error_moments(&syn, &table, &all_terms, mc);
                let (errors, why) = crate::origin::with_estimate_errors(
                    flight,
                    &table,
                    &refs,
                    baselines,
                    errors,
                    &est,
                    &estimate_errors,
                    syn.replicas(&table, mc),
                    n_id,
                    h,
                );
                notes.extend(why);
                errors
            }
        }
        None => Default::default(),
    };
    let regression = regression_of(&table, &refs, baselines, &all_terms, n_id);
    let oracle = oracle::FlightOracle::new(flight, &table, &refs, baselines, &errors, &all_terms);
    notes.extend(oracle.note());
    Ok(Synthesised {
        table,
        refs,
        all_terms,
        errors,
        regression,
        pieces,
        oracle,
    })
}

/// Each coefficient's baseline terms followed by the library terms offered to it: every column
/// whose errors in variables the analysis may need.
fn all_terms(baselines: &[Vec<Term>; 6], table: &Table) -> [Vec<Term>; 6] {
    core::array::from_fn(|i| {
        let mut v = baselines[i].clone();
        for t in Term::offered(i, table) {
            if !v.contains(&t) {
                v.push(t);
            }
        }
        v
    })
}

/// What the Monte Carlo of the errors in variables is, in words.
fn monte_carlo_note(syn: &noise::Synthesis, table: &Table, mc: &noise::MonteCarlo) -> String {
    format!(
        "fits by PCA-GTLS (aerosid_core::gtls::Gtls) with W_T from a {}-replica Monte Carlo of the sensors' white noise{}",
        syn.replicas(table, mc),
        match syn.compat {
            Some(_) => String::new(),
            None => format!(
                " (measured air data: enough for {} smoothing windows of draws, docs/model-gaps.md)",
                noise::WINDOW_DRAWS
            ),
        }
    )
}

/// The coefficients and every term's column that has one, as the selection sees them.
fn regression_of(
    table: &Table,
    refs: &TermRefs,
    baselines: &[Vec<Term>; 6],
    all_terms: &[Vec<Term>; 6],
    n_id: usize,
) -> Regression {
    let mut regression = Regression {
        t_s: table.t_s.clone(),
        n_id,
        ..Regression::default()
    };
    for i in 0..6 {
        let Some(zc) = &table.z[i] else { continue };
        let mut base = Vec::new();
        let mut lib = Vec::new();
        for t in all_terms[i].iter() {
            if let Some(c) = t.column(table, refs) {
                if baselines[i].contains(t) {
                    base.push(*t);
                } else {
                    lib.push(*t);
                }
                regression.columns.entry(*t).or_insert(c);
            }
        }
        regression
            .coefficients
            .push((COEFFICIENTS[i].to_string(), zc.clone(), base, lib));
    }
    regression
}
