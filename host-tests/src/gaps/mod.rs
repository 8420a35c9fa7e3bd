//! The model-gap analysis (issue 6 §2): what does the identified model get wrong, and why?
//!
//! [`run_gaps`] takes a [`MeasuredFlight`] and, in the order of the issue:
//! 1. **Data compatibility** ([`compat`]): flight-path reconstruction by output error on the
//!    kinematic equations, with sensor biases, scale factors, time delays and vane positions chosen
//!    by forward selection. Errors found are removed from the data before any aerodynamics.
//! 2. **Baseline fit** ([`model`], [`regress`]): the coefficients of eq. 1–2 synthesised from the
//!    corrected, smoothed channels; each fitted to its baseline regressors (eq. 3 by default, or the
//!    model given) by least squares on the identification segment (the first
//!    [`GapSettings::identification_fraction`] of the flight).
//! 3. **What the model gets wrong**: the fitted model predicts each coefficient on the held-out
//!    rest of the flight (the reconstruction of the seed's Fig. 4–5, here for the coefficients);
//!    R², RMS and PSE on both segments, figures of measured vs predicted and residuals.
//! 4. **The cause**: every candidate of the library ([`model::Term::library`]) is scored by the
//!    partial test `t²` of adding it ([`regress::partial_test`]), with standard errors from the
//!    coloured-residual covariance.
//! 5. **Extension**: forward selection adds the best candidate while `t²` exceeds the threshold
//!    *and* Morelli's PSE decreases; then refit and before/after metrics on the held-out segment,
//!    with each new parameter ± σ.
//! 6. The [`report`] (terminal table, SVG figures, JSON; schema in `docs/model-gaps.md`).
//!
//! ## The criterion and its threshold
//! A candidate is named when its partial `t²` (the partial F of stepwise regression, Klein &
//! Morelli 2006 §5.4.1, with the coloured-residual σ of Morelli & Klein 1997) exceeds the
//! two-sided normal critical value at family-wise level `α = 0.001` with a Bonferroni correction
//! over every candidate tested in the flight (compatibility parameters and all coefficients'
//! library terms), **and** adding it lowers the predicted squared error (Klein & Morelli eq. 5.90).
//! Why: the F-test answers "is this term's effect distinguishable from noise", the Bonferroni
//! correction keeps the chance of naming anything on a clean flight below `α` however many
//! candidates there are, and the PSE requirement refuses terms that are significant only because
//! `N` is large but do not improve the predictive quality by more than their parameter's cost.
//! Where several candidates are significant the largest `t²` enters first (forward selection);
//! measurement causes take precedence over aerodynamic ones (issue 6 §2.1: "before blaming the
//! aerodynamics"), so the **top cause** is the first sensor error found, else the aerodynamic term
//! with the largest `t²` over all coefficients.

pub mod compat;
pub mod hidden;
pub mod model;
pub mod regress;
pub mod report;
pub mod signal;

use crate::io::measured::MeasuredFlight;
use compat::{CompatSettings, Compatibility, SensorParam};
use model::{CauseKind, Corrections, Signal, Table, Term, TermRefs, COEFFICIENTS};
use regress::{metrics, ols, partial_test, predict, Metrics};

/// Settings of the analysis. `Default` is what the tests and the command use.
#[derive(Debug, Clone, PartialEq)]
pub struct GapSettings {
    /// Fraction of the samples (from the start) used for identification; the rest is held out.
    /// Default 0.6.
    pub identification_fraction: f64,
    /// Family-wise significance level before the Bonferroni division. Default 0.001.
    pub alpha: f64,
    /// Savitzky–Golay half-width for smoothing, s. Default 0.1 (M = 10 at 100 Hz).
    pub smoothing_half_width_s: f64,
    /// Largest lag of the residual autocorrelation in the coloured-residual covariance, s.
    /// Default 2.5: half the compatibility check's segment, because the reconstructed flow angles
    /// carry errors that are constant over a segment (initial-state error) and the σ must see them.
    pub max_lag_s: f64,
    /// Most terms added per coefficient. Default 2.
    pub max_added: usize,
    /// Baseline model per coefficient (`None`: eq. 3, [`Term::eq3`]).
    pub baseline: Option<[Vec<Term>; 6]>,
    /// Run the compatibility check. Default true.
    pub compatibility: bool,
    /// Use the compatibility check's reconstructed airspeed and flow angles in the synthesis and
    /// regressors ([`model::synthesise`]). Default true; switch off in turbulence.
    pub reconstructed_air_data: bool,
}

impl Default for GapSettings {
    fn default() -> Self {
        Self {
            identification_fraction: 0.6,
            alpha: 0.001,
            smoothing_half_width_s: 0.1,
            max_lag_s: 2.5,
            max_added: 2,
            baseline: None,
            compatibility: true,
            reconstructed_air_data: true,
        }
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

/// One candidate's score for one coefficient (first round of the selection).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CandidateScore {
    /// The term.
    pub term: String,
    /// The cause it stands for.
    pub kind: CauseKind,
    /// Partial `t²`.
    pub t2: f64,
    /// Identification PSE with the term added.
    pub pse: f64,
    /// Above the threshold and lowering the PSE.
    pub significant: bool,
}

/// One estimated parameter.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Parameter {
    /// The term.
    pub term: String,
    /// Estimate.
    pub value: f64,
    /// Standard error (coloured residuals).
    pub sigma: f64,
}

/// A model fitted to one coefficient.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModelFit {
    /// Parameters.
    pub parameters: Vec<Parameter>,
    /// Metrics on the identification segment.
    pub identification: Metrics,
    /// Metrics of the prediction on the held-out segment.
    pub validation: Metrics,
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
}

/// The analysis of one coefficient.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CoefficientGap {
    /// `C_L` …
    pub name: String,
    /// Baseline terms requested but not available (channel missing).
    pub dropped_terms: Vec<String>,
    /// The baseline.
    pub baseline: ModelFit,
    /// Every candidate's first-round score, best first.
    pub candidates: Vec<CandidateScore>,
    /// Terms added, in order.
    pub added: Vec<Added>,
    /// The extended model (equal to the baseline when nothing was added).
    pub extended: ModelFit,
    /// Time histories for the figures: time, measured, baseline prediction, extended prediction.
    #[serde(skip)]
    pub traces: Traces,
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
    /// Its `t²` when it entered.
    pub t2: f64,
    /// Estimate.
    pub value: f64,
    /// Standard error.
    pub sigma: f64,
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
    /// Settings used.
    pub settings: GapSettings,
    /// The compatibility check.
    pub compatibility: Compatibility,
    /// Per coefficient.
    pub coefficients: Vec<CoefficientGap>,
    /// Causes named, top cause first.
    pub named: Vec<NamedCause>,
    /// Notes (assumptions, skipped steps).
    pub notes: Vec<String>,
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

fn check_input(flight: &MeasuredFlight) -> Result<f64, GapError> {
    let n = flight.len();
    let src = || flight.source.clone();
    if n < 200 {
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
/// readers producing [`MeasuredFlight`]).
pub fn run_gaps(flight: &MeasuredFlight, settings: &GapSettings) -> Result<GapReport, GapError> {
    let h = check_input(flight)?;
    let n = flight.len();
    let max_lag = ((settings.max_lag_s / h).round() as usize).max(1);
    let sg_half = (settings.smoothing_half_width_s / h).round() as usize;
    let n_id = ((n as f64 * settings.identification_fraction).round() as usize).clamp(100, n - 50);
    // The candidate count (Bonferroni divisor) needs the table; synthesise once uncorrected to
    // learn which signals exist (the corrected table has the same signals).
    let probe = model::synthesise(flight, h, &Corrections::default(), sg_half, None);
    let baseline_of = |i: usize| -> Vec<Term> {
        match &settings.baseline {
            Some(b) => b[i].clone(),
            None => Term::eq3(i),
        }
    };
    let refs_probe = TermRefs {
        alpha_break_rad: 0.0,
        airspeed_mps: 1.0,
        mach: 0.0,
    };
    let mut n_aero = 0usize;
    for i in 0..6 {
        if probe.z[i].is_none() {
            continue;
        }
        let base = baseline_of(i);
        n_aero += Term::library(i)
            .iter()
            .filter(|t| !base.contains(t) && t.column(&probe, &refs_probe).is_some())
            .count();
    }
    let n_compat_est = if settings.compatibility {
        compat_candidate_count(flight)
    } else {
        0
    };
    let m = (n_aero + n_compat_est).max(1);
    let z = signal::normal_upper_quantile(settings.alpha / (2.0 * m as f64));
    let threshold_t2 = z * z;
    let mut notes = Vec::new();
    // 1. Compatibility.
    let cs = CompatSettings {
        threshold_t2,
        max_lag,
        max_added: 3,
    };
    let compatibility = if settings.compatibility {
        compat::check(flight, h, &cs)
    } else {
        Compatibility {
            notes: vec!["compatibility check switched off".into()],
            ..Compatibility::default()
        }
    };
    let mut corr = Corrections::default();
    for f in &compatibility.found {
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
    // 2–5. Aerodynamics on the corrected data.
    let air =
        (settings.reconstructed_air_data && !compatibility.air_data.is_empty()).then_some(&compatibility.air_data);
    if air.is_some() {
        notes.push("regressors use the reconstructed airspeed and flow angles (steady air assumed)".into());
    }
    let table = model::synthesise(flight, h, &corr, sg_half, air);
    notes.extend(table.notes.iter().cloned());
    if table.z.iter().all(|z| z.is_none()) {
        return Err(GapError::NothingToAnalyse {
            source: flight.source.clone(),
            notes,
        });
    }
    let id_mean = |s: Signal| table.signals.get(&s).map(|v| signal::mean(&v[..n_id]));
    let refs = TermRefs {
        alpha_break_rad: table
            .signals
            .get(&Signal::Alpha)
            .map_or(0.0, |a| percentile(&a[..n_id], 0.85)),
        airspeed_mps: id_mean(Signal::Airspeed).unwrap_or(1.0).max(1.0),
        mach: id_mean(Signal::Mach).unwrap_or(0.0),
    };
    let mut coefficients = Vec::new();
    for i in 0..6 {
        let Some(zc) = &table.z[i] else { continue };
        if let Some(g) = analyse_coefficient(
            i,
            zc,
            &table,
            &refs,
            &baseline_of(i),
            n_id,
            threshold_t2,
            max_lag,
            settings,
        ) {
            coefficients.push(g);
        }
    }
    // Verdict.
    let mut named: Vec<NamedCause> = compatibility
        .found
        .iter()
        .map(|f| NamedCause {
            kind: param_kind(&f.param),
            location: format!("{:?}", f.param.channel()),
            what: f.param.name(),
            t2: f.t2,
            value: f.value,
            sigma: f.sigma,
        })
        .collect();
    let mut aero: Vec<NamedCause> = coefficients
        .iter()
        .flat_map(|c| {
            c.added.iter().map(|a| NamedCause {
                kind: a.kind,
                location: c.name.clone(),
                what: a.term.clone(),
                t2: a.t2,
                value: a.value,
                sigma: a.sigma,
            })
        })
        .collect();
    aero.sort_by(|a, b| b.t2.total_cmp(&a.t2));
    named.extend(aero);
    let t = &flight.t_s;
    Ok(GapReport {
        source: flight.source.clone(),
        aircraft: flight.aircraft.name.clone(),
        identification_s: [t[0], t[n_id - 1]],
        validation_s: [t[n_id], t[n - 1]],
        candidates_tested: m,
        threshold_t2,
        settings: settings.clone(),
        compatibility,
        coefficients,
        named,
        notes,
    })
}

/// How many sensor-error candidates the compatibility check will test on this flight.
fn compat_candidate_count(flight: &MeasuredFlight) -> usize {
    use crate::io::measured::Quantity::*;
    let has = |q| flight.get(q).is_some();
    if !(has(PitchRate) && has(Pitch)) {
        return 0;
    }
    let lateral = has(RollRate) && has(YawRate) && has(Roll);
    let mut c = if lateral { 3 } else { 1 };
    if has(AccelX) && has(AccelZ) && has(Airspeed) && has(Alpha) {
        c += 9;
        if lateral && has(AccelY) {
            c += 1;
            if has(Beta) {
                c += 4;
            }
        }
    }
    c
}

#[allow(clippy::too_many_arguments)]
fn analyse_coefficient(
    i: usize,
    zc: &[f64],
    table: &Table,
    refs: &TermRefs,
    base: &[Term],
    n_id: usize,
    threshold_t2: f64,
    max_lag: usize,
    settings: &GapSettings,
) -> Option<CoefficientGap> {
    let n = zc.len();
    let mut dropped = Vec::new();
    let mut terms = Vec::new();
    let mut cols_full = Vec::new();
    for t in base {
        match t.column(table, refs) {
            Some(c) => {
                terms.push(*t);
                cols_full.push(c);
            }
            None => dropped.push(t.name().to_string()),
        }
    }
    let id = |c: &Vec<f64>| c[..n_id].to_vec();
    let z_id = &zc[..n_id];
    let z_val = &zc[n_id..];
    let fit_model = |cols_full: &[Vec<f64>], terms: &[Term]| -> Option<(ModelFit, Vec<f64>, regress::Fit)> {
        let cols: Vec<Vec<f64>> = cols_full.iter().map(id).collect();
        let f = ols(&cols, z_id, n_id, max_lag)?;
        let pred = predict(cols_full, &f.theta);
        let p = terms.len();
        let mf = ModelFit {
            parameters: terms
                .iter()
                .zip(f.theta.iter().zip(&f.sigma))
                .map(|(t, (v, s))| Parameter {
                    term: t.name().into(),
                    value: *v,
                    sigma: *s,
                })
                .collect(),
            identification: metrics(z_id, &pred[..n_id], p),
            validation: metrics(z_val, &pred[n_id..], p),
        };
        Some((mf, pred, f))
    };
    let (baseline, base_pred, _) = fit_model(&cols_full, &terms)?;
    // Candidate columns.
    let library: Vec<(Term, Vec<f64>)> = Term::library(i)
        .into_iter()
        .filter(|t| !terms.contains(t))
        .filter_map(|t| t.column(table, refs).map(|c| (t, c)))
        .collect();
    let mut candidates = Vec::new();
    let mut added: Vec<(Term, f64)> = Vec::new();
    for round in 0..settings.max_added {
        let cols: Vec<Vec<f64>> = cols_full.iter().map(id).collect();
        let mut best: Option<(Term, f64, f64)> = None;
        for (t, c) in &library {
            if terms.contains(t) {
                continue;
            }
            let Some((f, t2)) = partial_test(&cols, &c[..n_id], z_id, n_id, max_lag) else {
                continue;
            };
            let zhat: Vec<f64> = z_id.iter().zip(&f.residual).map(|(a, r)| a - r).collect();
            let pse = metrics(z_id, &zhat, cols.len() + 1).pse;
            let significant = t2 > threshold_t2;
            if round == 0 {
                candidates.push(CandidateScore {
                    term: t.name().into(),
                    kind: t.kind(i),
                    t2,
                    pse,
                    significant,
                });
            }
            if significant && best.as_ref().is_none_or(|b| t2 > b.1) {
                best = Some((*t, t2, pse));
            }
        }
        let Some((t, t2, _)) = best else { break };
        let c = library.iter().find(|(x, _)| *x == t).map(|x| x.1.clone())?;
        terms.push(t);
        cols_full.push(c);
        added.push((t, t2));
    }
    candidates.sort_by(|a, b| b.t2.total_cmp(&a.t2));
    let (extended, ext_pred, ext_fit) = fit_model(&cols_full, &terms)?;
    let p0 = terms.len() - added.len();
    let added = added
        .iter()
        .enumerate()
        .map(|(k, (t, t2))| Added {
            term: t.name().into(),
            kind: t.kind(i),
            t2: *t2,
            value: ext_fit.theta[p0 + k],
            sigma: ext_fit.sigma[p0 + k],
        })
        .collect();
    Some(CoefficientGap {
        name: COEFFICIENTS[i].into(),
        dropped_terms: dropped,
        baseline,
        candidates,
        added,
        extended,
        traces: Traces {
            t_s: table.t_s.clone(),
            measured: zc.to_vec(),
            baseline: base_pred,
            extended: ext_pred,
            split: n_id.min(n),
        },
    })
}
