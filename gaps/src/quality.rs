//! The data-quality assessment ([`crate::io::quality`]) as the model-gap analysis makes it: against
//! what the analysis needs of a flight ([`needs`]: its six coefficients and its held-out test), and
//! completed after the analysis from the regressors and the held-out fit ([`after_analysis`]).

use super::model::COEFFICIENTS;
use super::select::CvSettings;
use super::{CoefficientGap, Regression};
use crate::io::measured::MeasuredFlight;
use crate::io::quality::{condition_number, DataQuality, Needs, WARN_CONDITION};

/// What the gap analysis needs of a flight: its coefficients and its default held-out test.
pub fn needs() -> Needs<'static> {
    let cv = CvSettings::default();
    Needs {
        coefficients: &COEFFICIENTS,
        folds: cv.folds,
        block_s: cv.block_s,
    }
}

/// The assessment of a flight before the gap analysis ([`crate::io::quality::assess`] against
/// [`needs`]).
pub fn assess(flight: &MeasuredFlight) -> DataQuality {
    crate::io::quality::assess(flight, &needs())
}

/// Completes the assessment from the analysis: the regressors' condition numbers, parameters the
/// data do not determine, and whether the baseline predicts anything on held-out data.
pub fn after_analysis(q: &mut DataQuality, coefficients: &[CoefficientGap], regression: &Regression) {
    for (name, _, base, _) in &regression.coefficients {
        let cols: Vec<&[f64]> = base
            .iter()
            .filter_map(|t| regression.columns.get(t).map(|c| c.as_slice()))
            .collect();
        let k = condition_number(&cols, regression.n_id);
        if k > WARN_CONDITION {
            q.warnings.push(format!(
                "{name}: the baseline's regressors (scaled to unit length) have condition number {k:.0} on the identification segment: nearly collinear, so the estimates trade off against each other (poor excitation)"
            ));
        }
    }
    for c in coefficients {
        let weak: Vec<String> = c
            .baseline
            .parameters
            .iter()
            // NaN σ or value counts as undetermined.
            .filter(|p| p.value.abs() < 2.0 * p.sigma || p.value.is_nan() || p.sigma.is_nan())
            .map(|p| p.term.clone())
            .collect();
        if !weak.is_empty() {
            q.warnings.push(format!(
                "{}: {} not determined by this flight (|estimate| < 2σ)",
                c.name,
                weak.join(", ")
            ));
        }
    }
    let best = coefficients
        .iter()
        .map(|c| c.baseline.validation.r2)
        .filter(|r| r.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    let predicts = best > 0.0;
    if !coefficients.is_empty() && !predicts {
        q.why_not.push(format!(
            "the baseline predicts no coefficient on held-out data (best held-out R² {best:.2}): a missing term cannot be told from noise"
        ));
    }
    q.supports_verdict = q.why_not.is_empty();
}
