//! How well a prediction matches the measurement, output by output: RMS, R² and Theil's U
//! (Jategaonkar 2015, §10 model validation), the same definitions for every prediction the tool
//! scores (the user model's simulation and the gap analysis's extended model on another flight).

use serde::{Deserialize, Serialize};

/// Fit of one output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputFit {
    /// Output name.
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// Samples scored.
    pub samples: usize,
    /// RMS of measured − predicted.
    pub rms: f64,
    /// `1 − SS_res/SS_tot`.
    pub r2: f64,
    /// Theil's inequality coefficient.
    pub theil_u: f64,
}

/// RMS of `meas − pred`, R² = `1 − SS_res/SS_tot` and Theil's U = `RMS/(RMS(meas) + RMS(pred))`
/// of one output (the same definitions for every prediction the tool scores).
pub fn output_fit(name: &str, unit: &str, meas: &[f64], pred: &[f64]) -> OutputFit {
    let n = meas.len() as f64;
    let mean = meas.iter().sum::<f64>() / n;
    let ss_tot: f64 = meas.iter().map(|m| (m - mean).powi(2)).sum();
    let ss_res: f64 = meas.iter().zip(pred).map(|(m, p)| (m - p).powi(2)).sum();
    let rms = (ss_res / n).sqrt();
    let rms_m = (meas.iter().map(|m| m * m).sum::<f64>() / n).sqrt();
    let rms_p = (pred.iter().map(|p| p * p).sum::<f64>() / n).sqrt();
    OutputFit {
        name: name.to_string(),
        unit: unit.to_string(),
        samples: meas.len(),
        rms,
        r2: 1.0 - ss_res / ss_tot,
        theil_u: rms / (rms_m + rms_p),
    }
}

/// What R² and Theil's U each measure, printed under every table that shows both: they can
/// disagree (a U of 0.03 beside an R² of −23 on an output whose level is large and matched).
pub const THEIL_LEGEND: &str = "    (R² scores the variation about the measured mean; Theil's U the signals themselves, level included, Jategaonkar 2015 §10: a small U beside a low R² means the level is matched and the variation is not)";
