//! Stage 5: each coefficient's baseline fitted by the core's PCA-GTLS and extended by stepwise
//! regression over the candidate library (`analyse_coefficient` in `fit.rs`); below the
//! equation-error path's rate, `C_L`, `C_D`, `C_m` by output error instead ([`crate::oem`]).

use super::air_data::AirData;
use super::compatibility::Compatible;
use super::prepare::Prepared;
use super::synthesis::Synthesised;
use crate::model::COEFFICIENTS;
use crate::{
    delay_rival,
    fit::{analyse_coefficient, SurfaceSampling},
    low_rate, oem, CoefficientGap, GapSettings,
};

/// Every coefficient's fit, extension and verdict.
pub struct Selected {
    /// Per coefficient that could be synthesised, in the order of [`COEFFICIENTS`].
    pub coefficients: Vec<CoefficientGap>,
    /// Whether the low-rate output-error path ran (the data are below the equation-error path's
    /// rate and the path could run).
    pub low_rate: bool,
}

/// [`Selected`] of a synthesised flight; the candidates are tested beyond the gust proxies
/// ([`crate::gust::proxies`]) and an error of any sensor delay removed ([`delay_rival`]).
pub fn select(
    prepared: &Prepared,
    compatible: &Compatible,
    air: &AirData,
    syn: &Synthesised,
    settings: &GapSettings,
    notes: &mut Vec<String>,
) -> Selected {
    let (plan, h) = (&prepared.plan, prepared.h);
    let table = &syn.table;
    let mut coefficients = Vec::new();
    let mut gust_proxies = crate::gust::proxies(table, &syn.refs, &prepared.baselines, plan.n_id, &syn.oracle);
    let rivals = delay_rival::rivals(&delay_rival::Inputs {
        on: delay_rival::Flight {
            flight: &prepared.flight,
            h_s: h,
            compatibility: &compatible.compatibility,
            air: air.air.as_ref(),
            sg_half: plan.sg_half,
            baselines: &prepared.baselines,
            n_id: plan.n_id,
        },
        corr: &compatible.corr,
        table,
        refs: &syn.refs,
    });
    gust_proxies.extend(rivals.columns);
    let surfaces = SurfaceSampling::of(&prepared.flight, h);
    for i in 0..6 {
        let Some(zc) = &table.z[i] else { continue };
        if let Some(g) = analyse_coefficient(
            i,
            zc,
            table,
            &syn.refs,
            &prepared.baselines[i],
            plan.n_id,
            settings.alpha / (2.0 * plan.m as f64),
            plan.max_lag,
            h,
            settings,
            syn.errors[i].as_ref(),
            &syn.pieces,
            &syn.oracle,
            &gust_proxies,
            &surfaces,
        ) {
            let mut g = g;
            g.notes
                .extend(rivals.notes.iter().filter(|(c, _)| *c == i).map(|(_, n)| n.clone()));
            coefficients.push(g);
        }
    }
    // Below the equation-error path's rate, `C_L`, `C_D`, `C_m` by output error ([`low_rate`]).
    let low_rate = 1.0 / h < crate::io::quality::MIN_RATE_HZ;
    let low_rate = low_rate
        && low_rate_path(&mut coefficients, notes, h, settings, || oem::Inputs {
            table,
            aircraft: &prepared.flight.aircraft,
            refs: &syn.refs,
            baselines: &prepared.baselines,
            pieces: &syn.pieces,
            n_id: plan.n_id,
            threshold_t2: plan.threshold_t2,
            threshold_blocks: plan.threshold_blocks,
            cv: settings.cv,
            max_lag_s: settings.max_lag_s,
            sampling: prepared.flight.log.sampling,
        });
    Selected { coefficients, low_rate }
}

/// The low-rate path: `C_L`, `C_D`, `C_m` of `coefficients` replaced by their output-error
/// analysis ([`low_rate::analyse`]); the other coefficients get no verdict and name nothing (the
/// equation-error path differentiates over ±0.1 s, which this rate cannot resolve). False, with a
/// note saying why, when the path cannot run.
fn low_rate_path<'a>(
    coefficients: &mut Vec<CoefficientGap>,
    notes: &mut Vec<String>,
    h: f64,
    settings: &GapSettings,
    inputs: impl FnOnce() -> oem::Inputs<'a>,
) -> bool {
    let rate = 1.0 / h;
    let min = crate::io::quality::MIN_RATE_HZ;
    match low_rate::analyse(&inputs(), settings.low_rate_method) {
        Ok(lr) => {
            let covered: Vec<&str> = lr.covered.iter().map(|&c| COEFFICIENTS[c]).collect();
            coefficients.retain(|c| !covered.contains(&c.name.as_str()));
            for c in coefficients.iter_mut() {
                c.added.clear();
                c.extended = c.baseline.clone();
                c.extended_model = c.baseline_model.clone();
                c.verdict = format!(
                    "no verdict: at {rate:.1} Hz the equation-error path (smoothing and differentiation over ±0.1 s) needs {min} Hz, and the low-rate output-error path covers {} only",
                    covered.join(", ")
                );
            }
            let mut all = lr.coefficients;
            all.append(coefficients);
            all.sort_by_key(|c| COEFFICIENTS.iter().position(|n| *n == c.name));
            *coefficients = all;
            notes.insert(
                0,
                format!(
                    "method: the data are at {rate:.1} Hz, below the {min} Hz the equation-error path needs (it smooths and differentiates over ±0.1 s), so {} are fitted and their candidates tested by {} (the low-rate path, docs/model-gaps.md)",
                    covered.join(", "),
                    match settings.low_rate_method {
                        crate::LowRateMethod::OutputError => "output error",
                        crate::LowRateMethod::FilterError => "the filter error method (process noise)",
                        crate::LowRateMethod::Test =>
                            "the filter error method on an axis whose output-error residuals are coloured beyond chance (a likelihood-ratio test), else output error",
                    }
                ),
            );
            notes.extend(lr.notes);
            true
        }
        Err(why) => {
            notes.insert(
                0,
                format!("method: the data are at {rate:.1} Hz, below {min} Hz, and the low-rate output-error path cannot run: {why}"),
            );
            false
        }
    }
}
