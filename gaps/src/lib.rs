//! The model-gap analysis: what does the identified model get wrong, and why?
//!
//! [`run_gaps`] takes a [`MeasuredFlight`] and, in this order:
//! 1. **Data compatibility** ([`compat`]): flight-path reconstruction by output error on the
//!    kinematic equations, with sensor biases, scale factors, time delays and vane positions chosen
//!    by stepwise regression; on a turbulent vane its scale and delay by instrumental variables
//!    ([`instrumental`]). Errors found are removed from the data before any aerodynamics.
//! 2. **Baseline fit** ([`model`], [`regress`], [`noise`]): the coefficients of eq. 1–2 synthesised
//!    from the corrected, smoothed channels; each fitted to its baseline regressors (eq. 3 by
//!    default, or the model given) by the core's PCA-GTLS ([`aerosid_core::gtls::Gtls`], `f64`)
//!    with `W_T` from a Monte Carlo of the sensors' white noise through the whole chain, on the
//!    identification segment (the first [`GapSettings::identification_fraction`] of the flight).
//! 3. **What the model gets wrong**: the fitted models predict each coefficient on the held-out
//!    rest of the flight, and simulate the motion there ([`simulate`]: forces → V, α, β, moments →
//!    p, q, r; the reconstruction of seed 000's Fig. 4–5); R², RMS and PSE, figures.
//! 4. **The cause**: every candidate of the library ([`model::Term::library`]) is scored by the
//!    partial `t²` of adding it, σ the coloured-residual sandwich of the GTLS estimating equation
//!    ([`regress::sandwich_sigma`]).
//! 5. **Extension**: stepwise regression (forward selection with the removal step) adds the best
//!    candidate while its `t²` exceeds the threshold, the estimator's own fit confirming each
//!    entry; then refit and before/after metrics on the held-out segment, with each new parameter
//!    ± σ.
//! 6. The [`report`] (terminal table, SVG figures, JSON; schema in `docs/model-gaps.md`).
//!
//! The code runs these as one straight pass of stages, each a module of [`pass`] with a typed
//! hand-off (prepare, compatibility, air data, synthesis, selection, validation, report).
//! [`predict`](mod@predict) applies a saved report to another flight (`aerosid predict --gaps`).
//!
//! ```
//! use aerosid_gaps::{run_gaps, GapSettings};
//! use std::path::Path;
//! // The HFB-320 flight-test record vendored with the tool, read through its column map.
//! let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data");
//! let flight = aerosid_read::read_measured(
//!     &data.join("flight/hfb320_1_10.asc"),
//!     &data.join("maps/hfb320.map"),
//! )?;
//! let report = run_gaps(&flight, &GapSettings::default())?;
//! assert!(report.data_quality.supports_verdict);
//! println!("{}", report.verdict);
//! // The document `aerosid gaps` writes as report.json.
//! let json = aerosid_gaps::report::json(&report);
//! assert!(json["coefficients"].is_array());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## The criterion and its threshold
//! A candidate is named when its partial `t²` (the partial F of stepwise regression, Klein &
//! Morelli 2006 §5.4.1, with a coloured-residual σ after Morelli & Klein 1997) exceeds the
//! two-sided critical value at family-wise level `α` (default 0.01, [`Levels`]) with a Bonferroni
//! correction over every candidate tested in the flight (compatibility parameters and all
//! coefficients' library terms): Student t with `G − 1` degrees of freedom for the coefficients'
//! block sandwich (`G` blocks), normal for the compatibility check's many segments; a held-out
//! gain test then confirms each entry. Why: the F-test answers "is this term's effect
//! distinguishable from noise", and the Bonferroni correction keeps the chance of naming anything
//! on a clean flight below `α` however many candidates there are — nominally, if σ is right, which
//! is what the errors-in-variables model and the coloured σ are for (the measured rates:
//! `docs/benchmarks.md`, "Operating points"). Morelli's PSE is reported, not required to fall (see
//! `docs/model-gaps.md`). Measurement causes take precedence over aerodynamic ones (the
//! sensors are cleared before the aerodynamics is blamed), so the **top cause** is the sensor error with the largest
//! final `t²`, else the aerodynamic term with the largest final `t²` over all coefficients.

#![forbid(unsafe_code)]
// Index loops mirror the matrix formulas of the estimators.
#![allow(clippy::needless_range_loop)]

pub mod airdata;
pub mod compat;
pub mod delay_rival;
pub mod detection;
pub mod eks;
pub mod family;
mod fit;
pub use fit::MIN_PREDICTIVE_R2;
pub mod gust;
pub mod held_noise;
pub mod hidden;
mod homogeneity;
pub mod instrumental;
mod intersample;
pub mod low_rate;
mod low_rate_fem;
pub mod model;
pub mod noise;
pub mod oem;
mod oem_lateral;
pub mod oracle;
pub mod origin;
pub mod pass;
pub mod predict;
pub mod quality;
pub mod regress;
pub mod report;
pub mod select;
pub mod sensor_error;
pub mod signal;
pub mod simulate;

// The crates below the analysis under the names its modules use for them (`crate::io::…`,
// `crate::sim::…`, `crate::plot::…`), as in the `aerosid` crate; `crate::gaps::…` is this crate.
#[allow(unused_imports)]
use crate as gaps;
use crate::io::flow_angles::FlowAngleChoice;
use crate::io::measured::MeasuredFlight;
use aerosid_read as io;
use aerosid_report::{html, plot};
use aerosid_sim as sim;
use aerosid_sim::flights;
use airdata::AirDataChoice;
use compat::{Compatibility, SensorParam};
use model::{CauseKind, Signal, Table, Term, TermRefs, COEFFICIENTS};
use noise::{ColumnErrors, MonteCarlo};
use regress::Metrics;
use std::collections::BTreeMap;

/// Settings of the analysis. `Default` is what the tests and the command use.
#[derive(Debug, Clone, PartialEq)]
pub struct GapSettings {
    /// Fraction of the samples (from the start) used for identification; the rest is held out.
    /// Default 0.6.
    pub identification_fraction: f64,
    /// Family-wise significance level before the Bonferroni division. Default 0.01.
    pub alpha: f64,
    /// Savitzky–Golay half-width for smoothing, s. Default 0.1 (M = 10 at 100 Hz).
    pub smoothing_half_width_s: f64,
    /// Largest lag of the residual autocorrelation in the coloured-residual covariance, s.
    /// Default [`compat::SEGMENT_S`] (5 s): the reconstructed states carry an initial-state error
    /// that is constant over a whole segment of the flight-path reconstruction, plus the random
    /// walk of the integrated inertial noise, so the residuals of both the compatibility check and
    /// the coefficient fits are correlated over a segment's length. (With 2.5 s the σ of a
    /// gyro or accelerometer bias was understated: clean flights reached `t²` 16–20 for
    /// `bias(YawRate)`, `bias(AccelY)`; with 5 s at most 15.9 over the 60 campaign flights.)
    pub max_lag_s: f64,
    /// The blocked cross-validation of the selection ([`select`]).
    pub cv: select::CvSettings,
    /// Baseline model per coefficient (`None`: eq. 3, [`Term::eq3`]).
    pub baseline: Option<[Vec<Term>; 6]>,
    /// Run the compatibility check. Default true.
    pub compatibility: bool,
    /// The air data of the synthesis and the regressors ([`airdata`]). Default
    /// [`AirDataChoice::Auto`]: the vanes and the inertial reconstruction fused when both exist.
    pub air_data: AirDataChoice,
    /// Remove the sensor errors the compatibility check names (significant, improving the
    /// held-out reconstruction, identifiable in the air of this flight) from the data before the
    /// aerodynamics. Default true; the report says so and shows the baselines as logged beside
    /// them (`as_logged`), so no correction is silent. False: named only.
    pub apply_corrections: bool,
    /// The errors-in-variables model of the fits ([`noise`]): `Some` (default) — PCA-GTLS with
    /// `W_T` from the Monte Carlo; `None` — every column exact (ordinary least squares).
    pub errors_in_variables: Option<MonteCarlo>,
    /// Where α and β come from ([`crate::io::flow_angles`]): default
    /// [`FlowAngleChoice::Auto`] — the vanes when logged, else estimated from the ground velocity,
    /// the attitude and a fitted wind when the data allow it.
    pub flow_angles: FlowAngleChoice,
    /// The highest rate the analysis runs at, Hz: data logged `k ≥ 2` times faster are averaged
    /// in blocks of `k` samples first ([`MeasuredFlight::block_means`], `k = ⌊rate/cap⌋`), and
    /// the report says so. Default [`MAX_ANALYSIS_RATE_HZ`]; `None`: the rate as logged.
    pub max_rate_hz: Option<f64>,
    /// The method of the low-rate path (below [`crate::io::quality::MIN_RATE_HZ`]). Default
    /// [`LowRateMethod::OutputError`]: the filter error method detected more but named input
    /// delays on clean simulated flights (docs/model-gaps.md, "Low-rate data").
    pub low_rate_method: LowRateMethod,
}

/// How the low-rate path fits an axis: output error, or the filter error method (a steady-state
/// Kalman filter in the loop) where the output-error residuals show process noise
/// (docs/model-gaps.md, "Low-rate data").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LowRateMethod {
    /// The filter error method where the likelihood-ratio test finds process noise, else output
    /// error.
    Test,
    /// Output error on every axis.
    #[default]
    OutputError,
    /// The filter error method on every axis where a filter can be formed.
    FilterError,
}

/// The default cap of the analysis rate, Hz. What the analysis resolves lies far below it: the
/// Savitzky–Golay smoothing of 0.1 s half-width passes little above 5 Hz, the rigid-body modes of
/// a small UAV are below 3 Hz, and the delays and blocks are in seconds (a delay is found by
/// interpolated shifts, not whole samples). Measured on the benchmark's 100 Hz simulated flights:
/// the same causes named at 50 Hz but one (a further spurious ΔV/V beside an α-vane delay), in
/// half the time (docs/model-gaps.md, "Analysis rate").
pub const MAX_ANALYSIS_RATE_HZ: f64 = 50.0;

impl Default for GapSettings {
    fn default() -> Self {
        Self {
            identification_fraction: 0.6,
            alpha: 0.01,
            smoothing_half_width_s: 0.1,
            max_lag_s: compat::SEGMENT_S,
            cv: select::CvSettings::default(),
            baseline: None,
            compatibility: true,
            air_data: AirDataChoice::Auto,
            apply_corrections: true,
            errors_in_variables: Some(MonteCarlo::default()),
            flow_angles: FlowAngleChoice::Auto,
            max_rate_hz: Some(MAX_ANALYSIS_RATE_HZ),
            low_rate_method: LowRateMethod::OutputError,
        }
    }
}

/// The two test levels of the selection (`aerosid gaps --alpha --gain-alpha`): the family-wise
/// level of the significance tests ([`GapSettings::alpha`]) and the one-sided level of each
/// held-out test ([`select::CvSettings::gain_alpha`]). The selection, the compatibility check and
/// the instrumental check all take them; a report records them in its `criterion`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levels {
    /// Family-wise level, Bonferroni over every candidate tested: in `[ALPHA_MIN, 1]`.
    pub alpha: f64,
    /// One-sided level of each candidate's held-out gain test: in `[ALPHA_MIN, 0.5)`.
    pub gain_alpha: f64,
}

impl Default for Levels {
    fn default() -> Self {
        Self::of(&GapSettings::default())
    }
}

impl Levels {
    /// The smallest level taken: below it the critical values leave the range where the quantile
    /// functions are accurate (at 5·10⁻³²⁴ the level is 0 and the threshold infinite).
    pub const ALPHA_MIN: f64 = 1e-12;

    /// The levels of `s`.
    pub fn of(s: &GapSettings) -> Self {
        Self {
            alpha: s.alpha,
            gain_alpha: s.cv.gain_alpha,
        }
    }

    /// `s` with these levels.
    pub fn apply(self, s: GapSettings) -> GapSettings {
        GapSettings {
            alpha: self.alpha,
            cv: select::CvSettings {
                gain_alpha: self.gain_alpha,
                ..s.cv
            },
            ..s
        }
    }

    /// `alpha` if it is a family-wise level in `[ALPHA_MIN, 1]`, else what is wrong.
    pub fn check_alpha(alpha: f64) -> Result<f64, String> {
        if (Self::ALPHA_MIN..=1.0).contains(&alpha) {
            Ok(alpha)
        } else {
            Err(format!("{alpha} is not a level in [{:e}, 1]", Self::ALPHA_MIN))
        }
    }

    /// `gain_alpha` if it is a one-sided level in `[ALPHA_MIN, 0.5)`, else what is wrong.
    pub fn check_gain_alpha(gain_alpha: f64) -> Result<f64, String> {
        if (Self::ALPHA_MIN..0.5).contains(&gain_alpha) {
            Ok(gain_alpha)
        } else {
            Err(format!(
                "{gain_alpha} is not a one-sided level in [{:e}, 0.5)",
                Self::ALPHA_MIN
            ))
        }
    }

    /// The `aerosid gaps` options that set these levels, each with a leading space; empty for the
    /// defaults. The numbers are Rust's shortest text that reads back to the same `f64`.
    pub fn args(self) -> String {
        let d = Self::default();
        let mut out = String::new();
        if self.alpha != d.alpha {
            out += &format!(" --alpha {}", self.alpha);
        }
        if self.gain_alpha != d.gain_alpha {
            out += &format!(" --gain-alpha {}", self.gain_alpha);
        }
        out
    }
}

/// Why the analysis could not run.
#[derive(Debug, Clone, PartialEq)]
pub enum GapError {
    /// Fewer than 200 samples.
    TooShort {
        /// The flight's source.
        source: String,
        /// Samples.
        n: usize,
    },
    /// The time base is not uniform within 1 % (the analysis needs a fixed step).
    NonUniformTime {
        /// The flight's source.
        source: String,
        /// First sample index where the step differs.
        index: usize,
    },
    /// A channel's length differs from the time base, or it holds a non-finite value.
    BadChannel {
        /// The flight's source.
        source: String,
        /// The channel.
        channel: String,
        /// Sample index (the length, for a length mismatch).
        index: usize,
    },
    /// No coefficient could be synthesised.
    NothingToAnalyse {
        /// The flight's source.
        source: String,
        /// Why.
        notes: Vec<String>,
    },
}

impl core::fmt::Display for GapError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort { source, n } => write!(f, "{source}: {n} samples, the analysis needs at least 200"),
            Self::NonUniformTime { source, index } => write!(
                f,
                "{source}: sample {index}: time step differs by more than 1 % from the median (resample first)"
            ),
            Self::BadChannel { source, channel, index } => {
                write!(f, "{source}: channel {channel}: bad value or length at sample {index}")
            }
            Self::NothingToAnalyse { source, notes } => {
                write!(f, "{source}: no coefficient can be synthesised ({})", notes.join("; "))
            }
        }
    }
}

impl std::error::Error for GapError {}

/// One candidate's score for one coefficient (first round of the selection: the candidate added
/// to the baseline alone).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CandidateScore {
    /// The term.
    pub term: String,
    /// The cause it stands for.
    pub kind: CauseKind,
    /// Partial `t²` (block sandwich, [`select`]); 0 when not scored.
    pub t2: f64,
    /// Held-out gain: the mean decrease of the blocks' held-out squared error relative to the
    /// baseline's.
    pub cv_gain: f64,
    /// The sign-flip statistic of the blocks' held-out gains ([`select::gain`]).
    pub cv_gain_z: f64,
    /// The held-out gain against the noise of the held-out residuals ([`select::Design::noise_gain`],
    /// the test a candidate must pass); NaN where not computed (`t²` below the threshold).
    pub cv_noise_z: f64,
    /// Not used by the selection (NaN); kept in the schema.
    pub pse: f64,
    /// Both tests passed: `t²` above the threshold and the held-out gain beyond noise.
    pub significant: bool,
    /// Why the candidate was not scored (`None`: scored).
    pub reason: Option<String>,
    /// Its estimate beside the baseline (NaN when not scored).
    pub value: f64,
    /// The estimate's block-sandwich σ.
    pub sigma: f64,
    /// The smallest `|value|` this flight names with 80 % probability: `(t_need + t₀.₂)·σ`,
    /// `t_need` the larger of the `t²` threshold's root and twice the held-out test's critical
    /// value (a real term's noise-referenced gain is about half its `t`), `t₀.₂` the Student-t
    /// 80 % quantile at the blocks' degrees of freedom. An effect the flight carries, smaller
    /// than this, is more likely missed than found: not identifiable from this flight.
    pub min_detectable: f64,
    /// The oracle's standard error of the estimate: model-based, the candidate alone beside the
    /// baseline ([`oracle`]); NaN when not scored.
    pub oracle_se: f64,
    /// The least |value| a test with the selection's levels names with 80 % probability at
    /// `oracle_se`, divided by the column's reliability ratio ([`oracle`]).
    pub oracle_min_detectable: f64,
    /// `sigma / oracle_se`.
    pub se_ratio: f64,
    /// The reliability ratio `λ` of the column (1 unless built from an estimated flow angle).
    pub oracle_reliability: f64,
}

impl CandidateScore {
    /// A candidate that could not be scored, with the reason.
    pub fn unscored(t: Term, coef: usize, reason: String) -> Self {
        Self {
            term: t.name().into(),
            kind: t.kind(coef),
            t2: 0.0,
            cv_gain: 0.0,
            cv_gain_z: 0.0,
            cv_noise_z: f64::NAN,
            pse: f64::NAN,
            significant: false,
            reason: Some(reason),
            value: f64::NAN,
            sigma: f64::NAN,
            min_detectable: f64::NAN,
            oracle_se: f64::NAN,
            oracle_min_detectable: f64::NAN,
            se_ratio: f64::NAN,
            oracle_reliability: f64::NAN,
        }
    }

    /// With the oracle's fields.
    fn with_oracle(self, o: oracle::Oracle) -> Self {
        Self {
            oracle_se: o.se,
            oracle_min_detectable: o.min_detectable,
            se_ratio: o.se_ratio(self.sigma),
            oracle_reliability: o.reliability,
            ..self
        }
    }
}

/// One estimated parameter.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Parameter {
    /// The term.
    pub term: String,
    /// Estimate (PCA-GTLS).
    pub value: f64,
    /// Standard error for coloured residuals (the GTLS sandwich, [`regress::gtls`]).
    pub sigma: f64,
    /// The estimator's own standard error, eq. 17 (white residuals); NaN when eq. 17 does not
    /// apply.
    pub sigma_eq17: f64,
    /// Whether the column was treated as exact (no error in `W_T`).
    pub exact: bool,
    /// Ordinary least squares on the same columns (the cross-check).
    pub ols_value: f64,
}

/// A model fitted to one coefficient.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModelFit {
    /// The estimator: `"PCA-GTLS"` (the core's [`aerosid_core::gtls::Gtls`]), or `"OLS"` when
    /// every column is exact or the errors-in-variables model is switched off.
    pub estimator: String,
    /// How the estimator ended (eq. 21): `"Tls"` when every direction is excited.
    pub solution: String,
    /// Why the fit does not determine every parameter (`None`: it does); its values are then not
    /// reported as estimates.
    pub not_determined: Option<String>,
    /// The output entry of `W_T` ([`regress::corrected_ls`]).
    pub sigma_z2: f64,
    /// Parameters.
    pub parameters: Vec<Parameter>,
    /// Metrics on the identification segment.
    pub identification: Metrics,
    /// Metrics of the prediction on the held-out segment.
    pub validation: Metrics,
}

/// A candidate significant in place of an added term, rejected by the held-out test alone.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Rival {
    /// The candidate.
    pub term: String,
    /// Its partial `t²` in the added term's place.
    pub t2: f64,
    /// The held-out comparison of the model with it against the model as selected (sign-flip
    /// `z`; negative: it predicts worse, beyond the critical value).
    pub cv_z: f64,
}

/// A term added to a coefficient's model.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Added {
    /// The term.
    pub term: String,
    /// The cause.
    pub kind: CauseKind,
    /// `t²` when it entered.
    pub t2: f64,
    /// Estimate in the extended model.
    pub value: f64,
    /// Its standard error.
    pub sigma: f64,
    /// Held-out gain of the extended model over the same model without this term (relative
    /// decrease of the held-out squared error).
    pub cv_gain: f64,
    /// Candidates the data cannot tell apart from this term (in its place they predict the
    /// held-out blocks not significantly worse).
    pub alternatives: Vec<String>,
    /// Candidates that, in its place, would also pass the `t²` test but predict the held-out
    /// blocks significantly worse: the held-out test alone chose this term over them.
    pub rivals: Vec<Rival>,
    /// For a surface-rate term (a delay of that surface): the delay by an exact shift, s — the
    /// model with `δ(t−τ)` in place of `δ` and its rate term, `τ` of least identification error
    /// (`fit::exact_surface_delay`); the rate term's `τ = −θ_δ̇/θ_δ` is its first-order estimate.
    /// `None` for other terms.
    pub exact_delay_s: Option<f64>,
    /// Its family of rival forms, the form named and the forms this flight cannot separate from
    /// it ([`family`]); `None` for a term of no family.
    pub family: Option<family::FamilyChoice>,
}

/// The analysis of one coefficient.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CoefficientGap {
    /// `C_L` …
    pub name: String,
    /// What the analysis concludes for this coefficient, in words.
    pub verdict: String,
    /// Held-out (blocked cross-validation) R² of the baseline over the whole flight.
    pub cv_r2_baseline: f64,
    /// The same for the extended model.
    pub cv_r2_extended: f64,
    /// The cross-validation's block length for this coefficient, s.
    pub block_s: f64,
    /// The `t²` threshold at this coefficient's number of blocks.
    pub threshold_t2: f64,
    /// The number of blocks `G` of the block sandwich (the threshold is Student's t with `G − 1`
    /// degrees of freedom).
    pub blocks: usize,
    /// Baseline terms requested but not available (channel missing).
    pub dropped_terms: Vec<String>,
    /// The baseline.
    pub baseline: ModelFit,
    /// Every candidate's first-round score, best first.
    pub candidates: Vec<CandidateScore>,
    /// Terms added, in order.
    pub added: Vec<Added>,
    /// What the selection withdrew after it, and why (a term that only fitted a named surface
    /// delay's higher-order terms).
    pub notes: Vec<String>,
    /// The extended model (equal to the baseline when nothing was added).
    pub extended: ModelFit,
    /// Pooled manoeuvres: for every term the selection added, its per-manoeuvre estimates and
    /// their homogeneity test; a term whose estimates disagree is withdrawn (empty for one
    /// record).
    pub homogeneity: Vec<Homogeneity>,
    /// Time histories for the figures: time, measured, baseline prediction, extended prediction.
    #[serde(skip)]
    pub traces: Traces,
    /// The baseline's terms with their estimates (for the simulation).
    #[serde(skip)]
    pub baseline_model: Vec<(Term, f64)>,
    /// The extended model's terms with their estimates.
    #[serde(skip)]
    pub extended_model: Vec<(Term, f64)>,
}

/// One manoeuvre's estimate of an added term.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ManoeuvreEstimate {
    /// Index of the manoeuvre in the report's `manoeuvres`.
    pub manoeuvre: usize,
    /// Estimate on this manoeuvre alone.
    pub value: f64,
    /// Its standard error.
    pub sigma: f64,
}

/// Whether an added term's estimate agrees across manoeuvres: Cochran's Q of the per-manoeuvre
/// estimates (`fit::homogeneity_of`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Homogeneity {
    /// The term.
    pub term: String,
    /// The estimates of the manoeuvres that excite it.
    pub per_manoeuvre: Vec<ManoeuvreEstimate>,
    /// Cochran's Q (`NaN`: fewer than two manoeuvres excite the term).
    pub q: f64,
    /// Its degrees of freedom, `k − 1`.
    pub dof: usize,
    /// `P(χ²_dof > Q)`.
    pub p: f64,
    /// The inverse-variance mean of the per-manoeuvre estimates.
    pub mean: f64,
    /// The estimates agree (`p` at or above the held-out gain level) over two manoeuvres or more.
    pub agrees: bool,
    /// The outcome in words.
    pub reason: String,
}

/// Time histories of one coefficient.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Traces {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Synthesised (measured) coefficient.
    pub measured: Vec<f64>,
    /// Baseline prediction.
    pub baseline: Vec<f64>,
    /// Extended prediction.
    pub extended: Vec<f64>,
    /// Index of the first held-out sample.
    pub split: usize,
}

/// A cause named by the analysis.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NamedCause {
    /// The kind.
    pub kind: CauseKind,
    /// Coefficient (`C_L` …) or sensor channel (`Alpha` …).
    pub location: String,
    /// The term or sensor parameter.
    pub what: String,
    /// Its partial `t²` in the fit of `value` and `sigma`: `(value/sigma)²` (NaN: not determined).
    pub t2: f64,
    /// Estimate.
    pub value: f64,
    /// Standard error.
    pub sigma: f64,
    /// For a term of a family of rival forms: the family, the form and the forms this flight
    /// cannot separate from it, in words ([`family::FamilyChoice::describe`]).
    pub family: Option<String>,
    /// The test it passed: its `t²` when it entered and the threshold, `(entry_t2, threshold)`.
    /// The entry test is the selection's (least squares, block sandwich); `t2` is the final fit's,
    /// whose σ also carries the regressors' errors, so it can be the smaller — the report then
    /// shows both rather than a named cause below its own threshold with no word why.
    pub entry: Option<(f64, f64)>,
}

/// Everything the analysis found.
#[derive(Debug, Clone, PartialEq)]
pub struct GapReport {
    /// The flight's source.
    pub source: String,
    /// The aircraft's name.
    pub aircraft: String,
    /// Identification segment `[t₀, t₁]`, s.
    pub identification_s: [f64; 2],
    /// Held-out segment, s.
    pub validation_s: [f64; 2],
    /// Number of candidates tested (the Bonferroni divisor).
    pub candidates_tested: usize,
    /// The `t²` threshold.
    pub threshold_t2: f64,
    /// The number of blocks of `settings.cv.block_s` the threshold assumes (Student's t with one
    /// degree of freedom fewer).
    pub threshold_blocks: usize,
    /// Settings used.
    pub settings: GapSettings,
    /// The compatibility check.
    pub compatibility: Compatibility,
    /// Per coefficient.
    pub coefficients: Vec<CoefficientGap>,
    /// The simulation of the held-out segment with the baseline and the extended models
    /// ([`simulate`]).
    pub simulation: simulate::Simulation,
    /// Causes named, top cause first.
    pub named: Vec<NamedCause>,
    /// Which air data were used and why.
    pub air_data: String,
    /// Whether named sensor errors were removed from the data before the aerodynamics.
    pub corrections_applied: bool,
    /// The baseline estimates on the data as logged, per coefficient (`term`, value), when the
    /// aerodynamics were fitted to corrected data: the model before the correction.
    pub as_logged: Vec<(String, Vec<(String, f64)>)>,
    /// The overall conclusion, in words.
    pub verdict: String,
    /// Notes (assumptions, skipped steps).
    pub notes: Vec<String>,
    /// The regression problem the coefficients were fitted to (for benchmarks that run other
    /// tools on the same columns).
    pub regression: Regression,
    /// What the data can support ([`crate::io::quality`]); when it cannot support a verdict,
    /// `named` is empty and `verdict` says why.
    pub data_quality: crate::io::quality::DataQuality,
    /// The terms' reference values (from the identification segment), saved so that a prediction
    /// of another flight forms the terms with the same references.
    pub refs: TermRefs,
    /// The manoeuvres analysed (one for a single record), in their canonical order.
    pub manoeuvres: Vec<Manoeuvre>,
}

/// One manoeuvre of the analysis: where it came from and what it excites.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Manoeuvre {
    /// Its file (or generator).
    pub source: String,
    /// First and last sample's time in the file's own time, s.
    pub span_s: [f64; 2],
    /// Why it starts where it does (the file's start, a `--segment`, a time jump).
    pub cut: String,
    /// Samples at the analysis rate.
    pub samples: usize,
    /// First and last sample on the pooled time base of the report's figures and `regression`.
    pub pooled_s: [f64; 2],
    /// Standard deviation over the manoeuvre of α, β, the normalised rates p̂, q̂, r̂, the
    /// surfaces and the thrust coefficient (by `Signal` name; rad or dimensionless).
    pub std: BTreeMap<String, f64>,
    /// The baseline regressors it excites (`C_m: q`…): variation within the manoeuvre at least
    /// `fit::MIN_EXCITATION`× the column's error variance (every column exact: 10 % of its variation
    /// over all manoeuvres).
    pub excites: Vec<String>,
    /// Whether its samples are in the identification segment (else held out).
    pub identification: bool,
}

/// One coefficient of a [`Regression`]: name, synthesised values, baseline terms, candidate terms.
pub type RegressionCoefficient = (String, Vec<f64>, Vec<Term>, Vec<Term>);

/// The coefficients and every term's column, as the selection saw them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Regression {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Samples of the identification segment.
    pub n_id: usize,
    /// Per coefficient (`C_L` …): the synthesised coefficient, the baseline's terms and the
    /// library's terms that have a column.
    pub coefficients: Vec<RegressionCoefficient>,
    /// Every term's column.
    pub columns: BTreeMap<Term, Vec<f64>>,
}

impl GapReport {
    /// The top cause (`None`: nothing missing).
    pub fn top_cause(&self) -> Option<&NamedCause> {
        self.named.first()
    }
}

fn param_kind(p: &SensorParam) -> CauseKind {
    match p {
        SensorParam::Bias(_) => CauseKind::SensorBias,
        SensorParam::Scale(_) => CauseKind::ScaleFactor,
        SensorParam::Delay(_) => CauseKind::TimeDelay,
        SensorParam::VaneX(_) => CauseKind::VanePosition,
    }
}

/// The flight at the analysis rate: its block means ([`MeasuredFlight::block_means`]) when it was
/// logged at twice `max_rate_hz` or faster, with the report's note saying so; `None` when
/// it is analysed as logged (slower, no cap, or fewer than [`MIN_SAMPLES`] samples after
/// averaging). The time base is uniform ([`check_input`] passed).
fn at_analysis_rate(flight: &MeasuredFlight, max_rate_hz: Option<f64>) -> Option<(MeasuredFlight, String)> {
    let n = flight.len();
    let cap = max_rate_hz.filter(|c| c.is_finite() && *c > 0.0)?;
    if n < 2 {
        return None;
    }
    let h = (flight.t_s[n - 1] - flight.t_s[0]) / (n - 1) as f64;
    let rate = 1.0 / h;
    // A relative tolerance: 100 Hz logged as steps of 0.010000001 s is still twice 50 Hz.
    let k = (rate / cap * (1.0 + 1e-6)).floor();
    if k < 2.0 || k.is_nan() || n / (k as usize) < MIN_SAMPLES {
        return None;
    }
    let k = k as usize;
    let note = format!(
        "analysed at {:.4} Hz: the {:.4} Hz data averaged in blocks of {k} samples (white sensor noise stays white, its variance divided by {k}; the smoothing and the rigid-body modes lie below 5 Hz; the cap is {cap} Hz, `--max-rate` changes it)",
        rate / k as f64,
        rate
    );
    Some((flight.block_means(k), note))
}

/// Fewest samples the analysis runs on.
const MIN_SAMPLES: usize = 200;

fn check_input(flight: &MeasuredFlight) -> Result<f64, GapError> {
    let n = flight.len();
    let src = || flight.source.clone();
    if n < MIN_SAMPLES {
        return Err(GapError::TooShort { source: src(), n });
    }
    let mut dts: Vec<f64> = flight.t_s.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_by(f64::total_cmp);
    let h = dts[dts.len() / 2];
    for (i, w) in flight.t_s.windows(2).enumerate() {
        let d = w[1] - w[0];
        if !(d.is_finite() && (d - h).abs() <= 0.01 * h && h > 0.0) {
            return Err(GapError::NonUniformTime {
                source: src(),
                index: i + 1,
            });
        }
    }
    for (q, v) in &flight.channels {
        if v.len() != n {
            return Err(GapError::BadChannel {
                source: src(),
                channel: format!("{q:?}"),
                index: v.len(),
            });
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(GapError::BadChannel {
                source: src(),
                channel: format!("{q:?}"),
                index: i,
            });
        }
    }
    Ok(h)
}

fn percentile(x: &[f64], p: f64) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return 0.0;
    }
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// The analysis of a measured flight (the hook every front end calls: simulated flights, and file
/// readers producing [`MeasuredFlight`]): the stages of [`pass`] in order, each handing the next
/// its result; the notes, in the report's order, go along.
pub fn run_gaps(flight: &MeasuredFlight, settings: &GapSettings) -> Result<GapReport, GapError> {
    let prepared = pass::prepare::prepare(flight, settings)?;
    let (flight, h) = (&prepared.flight, prepared.h);
    let mut notes: Vec<String> = prepared.rate_note.iter().cloned().collect();
    let mut compatible = pass::compatibility::check(flight, h, settings, &prepared.plan, &mut notes);
    let air = pass::air_data::choose(flight, h, settings.air_data, &compatible.compatibility, &mut notes);
    pass::compatibility::refine_delays(
        &mut compatible,
        flight,
        h,
        &air,
        &prepared.plan,
        &prepared.baselines,
        &mut notes,
    );
    let synthesised = pass::synthesis::synthesise(&prepared, &compatible, &air, settings, &mut notes)?;
    let selected = pass::selection::select(&prepared, &compatible, &air, &synthesised, settings, &mut notes);
    let validated = pass::validation::validate(&prepared, &compatible, &air, &synthesised, &selected, settings);
    Ok(pass::report::assemble(
        prepared,
        compatible,
        synthesised,
        selected,
        validated,
        settings,
        notes,
    ))
}

/// Signals whose spread over a manoeuvre the report lists: α, β, the rates and the surfaces (the
/// first eight of [`Signal::ALL`]), and the thrust coefficient.
fn spread_signals() -> impl Iterator<Item = &'static Signal> {
    Signal::ALL[..8].iter().chain([&Signal::ThrustCoeff])
}

/// The manoeuvres of the flight ([`Manoeuvre`]).
fn manoeuvres_of(
    flight: &MeasuredFlight,
    table: &Table,
    refs: &TermRefs,
    baselines: &[Vec<Term>; 6],
    errors: &[Option<ColumnErrors>; 6],
    n_id: usize,
) -> Vec<Manoeuvre> {
    let var = |x: &[f64]| {
        let m = signal::mean(x);
        x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len().max(1) as f64
    };
    let mut columns: Vec<(String, Vec<f64>, f64, f64)> = Vec::new();
    for i in 0..6 {
        if table.z[i].is_none() {
            continue;
        }
        for t in baselines[i].iter().filter(|t| **t != Term::One) {
            if let Some(c) = t.column(table, refs) {
                let err = errors[i].as_ref().map_or(0.0, |e| e.variance(t));
                let pooled = var(&c);
                columns.push((format!("{}: {}", COEFFICIENTS[i], t.name()), c, err, pooled));
            }
        }
    }
    flight
        .pieces()
        .iter()
        .map(|p| {
            let r = p.start..p.end;
            let std = spread_signals()
                .filter_map(|s| {
                    let v = table.signals.get(s)?;
                    Some((format!("{s:?}"), var(&v[r.clone()]).sqrt()))
                })
                .collect();
            let excites = columns
                .iter()
                .filter(|(_, c, err, pooled)| {
                    let v = var(&c[r.clone()]);
                    if *err > 0.0 {
                        v >= fit::MIN_EXCITATION * err
                    } else {
                        v > 0.0 && v >= 0.1 * pooled
                    }
                })
                .map(|(name, ..)| name.clone())
                .collect();
            Manoeuvre {
                source: p.source.clone(),
                span_s: p.span_s,
                cut: p.cut.clone(),
                samples: p.end - p.start,
                pooled_s: [table.t_s[p.start], table.t_s[p.end - 1]],
                std,
                excites,
                identification: p.end <= n_id,
            }
        })
        .collect()
}

/// The analysis's pre-processing of a flight up to the coefficients' table — the compatibility
/// check, the sensor corrections, the air data and the synthesis, as [`run_gaps`] does them
/// ([`predict`] applies the same to another flight).
pub(crate) struct Preprocessed {
    /// The compatibility check.
    pub compatibility: Compatibility,
    /// The synthesised coefficients and signals.
    pub table: Table,
    /// What was done, in words.
    pub notes: Vec<String>,
}

/// [`Preprocessed`] of a checked flight with time step `h`: the stages of [`pass`] up to the
/// table.
pub(crate) fn preprocess(
    flight: &MeasuredFlight,
    h: f64,
    settings: &GapSettings,
    baselines: &[Vec<Term>; 6],
) -> Preprocessed {
    let plan = pass::prepare::plan(flight, h, settings, baselines);
    let mut notes = Vec::new();
    let mut compatible = pass::compatibility::check(flight, h, settings, &plan, &mut notes);
    let air = pass::air_data::choose(flight, h, settings.air_data, &compatible.compatibility, &mut notes);
    pass::compatibility::refine_delays(&mut compatible, flight, h, &air, &plan, baselines, &mut notes);
    let table = pass::synthesis::table(flight, h, &plan, &compatible, &air);
    notes.extend(table.notes.iter().cloned());
    Preprocessed {
        compatibility: compatible.compatibility,
        table,
        notes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::measured::Quantity;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn levels_give_the_options_that_set_them() {
        // GIVEN the default levels and others
        let d = Levels::default();
        let other = Levels {
            alpha: 0.03,
            gain_alpha: 0.1 + 0.2,
        };
        // THEN the defaults need no option, and the others' options read back to the same levels
        assert_eq!(d.args(), "");
        assert_eq!(d, Levels::of(&GapSettings::default()));
        let args = other.args();
        let words: Vec<&str> = args.split_whitespace().collect();
        assert_eq!(words.len(), 4, "{args}");
        assert_eq!(words[0], "--alpha");
        assert_eq!(words[2], "--gain-alpha");
        let alpha = Levels::check_alpha(words[1].parse().expect("a number")).expect("in range");
        let gain = Levels::check_gain_alpha(words[3].parse().expect("a number")).expect("in range");
        assert_eq!(
            Levels {
                alpha,
                gain_alpha: gain
            },
            other
        );
        // AND apply sets both in the settings
        assert_eq!(Levels::of(&other.apply(GapSettings::default())), other);
        // AND out-of-range levels are refused
        for bad in [0.0, -0.1, 1.5, f64::NAN, 1e-13] {
            assert!(Levels::check_alpha(bad).is_err(), "{bad}");
        }
        for bad in [0.0, 0.5, f64::INFINITY] {
            assert!(Levels::check_gain_alpha(bad).is_err(), "{bad}");
        }
    }

    /// A flight of `n` samples on a uniform step `h_s` with a pitch rate of white noise (σ 0.01),
    /// a ramp on the elevator and a yaw turning through ±π.
    fn uniform(n: usize, h_s: f64) -> MeasuredFlight {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.01).expect("σ > 0");
        let frame = aerosid_sim::SimAirframe::skywalker_2013_mod().frame;
        let yaw = (0..n)
            .map(|i| {
                (3.0 + 0.01 * i as f64 + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
                    - core::f64::consts::PI
            })
            .collect();
        MeasuredFlight {
            source: "test".into(),
            t_s: (0..n).map(|i| 5.0 + i as f64 * h_s).collect(),
            channels: [
                (Quantity::PitchRate, (0..n).map(|_| noise.sample(&mut rng)).collect()),
                (Quantity::Elevator, (0..n).map(|i| 1e-3 * i as f64).collect()),
                (Quantity::Yaw, yaw),
            ]
            .into_iter()
            .collect(),
            aircraft: crate::io::measured::Aircraft::from_airframe("test", &frame),
            log: Default::default(),
        }
    }

    #[test]
    fn a_fast_flight_is_averaged_to_the_cap_and_white_noise_stays_white() {
        // GIVEN 100 s at 200 Hz and the default cap of 50 Hz
        let f = uniform(20_001, 0.005);
        // WHEN brought to the analysis rate
        let (g, note) = at_analysis_rate(&f, Some(MAX_ANALYSIS_RATE_HZ)).expect("averaged");
        // THEN blocks of 4: 5 000 samples (the last, incomplete block dropped) 0.02 s apart,
        // stamped at their blocks' mean time, and the report's note says so
        assert_eq!(g.len(), 5_000);
        assert!((g.t_s[0] - 5.0075).abs() < 1e-12 && (g.t_s[1] - g.t_s[0] - 0.02).abs() < 1e-12);
        assert!(
            note.contains("analysed at 50.0000 Hz") && note.contains("blocks of 4"),
            "{note}"
        );
        // AND a ramp keeps its values at the new times (a mean of a line is the line)
        let de = g.get(Quantity::Elevator).expect("elevator");
        assert!((de[10] - 1e-3 * (40.0 + 1.5)).abs() < 1e-12);
        // AND white noise stays white with its variance divided by 4: over 5 000 samples the
        // variance is within 3 of its standard errors (√(2/5000) ≈ 2 %) of 0.0001/4, and the
        // lag-1 correlation within 3/√5000 ≈ 0.042 of 0
        let q = g.get(Quantity::PitchRate).expect("rate");
        let m = q.iter().sum::<f64>() / q.len() as f64;
        let var = q.iter().map(|v| (v - m).powi(2)).sum::<f64>() / q.len() as f64;
        assert!(
            (var / 2.5e-5 - 1.0).abs() < 3.0 * (2.0f64 / 5000.0).sqrt(),
            "variance {var}"
        );
        let r1 = q.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / (q.len() as f64 * var);
        assert!(r1.abs() < 3.0 / 5000f64.sqrt(), "lag-1 correlation {r1}");
        // AND a yaw crossing ±π averages to the heading between its samples, within ±π
        let y = g.get(Quantity::Yaw).expect("yaw");
        for (i, v) in y.iter().enumerate() {
            let want = (3.0 + 0.01 * (4 * i) as f64 + 0.015 + core::f64::consts::PI).rem_euclid(core::f64::consts::TAU)
                - core::f64::consts::PI;
            assert!((v - want).abs() < 1e-9, "yaw {i}: {v} for {want}");
        }
    }

    #[test]
    fn a_flight_at_or_below_twice_the_cap_or_without_one_is_analysed_as_logged() {
        // GIVEN flights at 50, 99 and 100 Hz (stamped with float steps) and the cap of 50 Hz
        for (rate, averaged) in [(50.0, false), (99.0, false), (100.0, true)] {
            let f = uniform(2_000, 1.0 / rate);
            // WHEN brought to the analysis rate THEN only twice the cap or more is averaged
            assert_eq!(at_analysis_rate(&f, Some(50.0)).is_some(), averaged, "{rate} Hz");
            // AND no cap, or a result shorter than the analysis needs, keeps the flight as logged
            assert!(at_analysis_rate(&f, None).is_none());
        }
        assert!(at_analysis_rate(&uniform(600, 0.005), Some(50.0)).is_none());
    }
}
