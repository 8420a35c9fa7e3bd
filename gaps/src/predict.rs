//! Coefficient prediction: the aerodynamic models a gap analysis identified (its `report.json`,
//! schema `aerosid-gaps/3`) applied to another flight.
//!
//! The other flight goes through the analysis's own pre-processing (`preprocess` of the crate root: the
//! α/β source, the compatibility check and its sensor corrections, the air data the report used)
//! and synthesis ([`super::model::synthesise`]); each saved term's column is formed by
//! [`Term::column`] with the report's reference values (`term_refs`; a report without them takes
//! the new flight's, and says so). The baseline and extended models are evaluated with their saved
//! parameters and scored against the synthesised coefficient with the workflow's metrics
//! ([`aerosid_report::fit::output_fit`]: RMS, R², Theil's U). A coefficient the new flight cannot
//! synthesise, or a term it cannot form, is listed as not predicted with the reason.
//! Schema of `prediction.json`: `docs/model-gaps.md`.

use super::airdata::AirDataChoice;
use super::compat::Compatibility;
use super::model::{Signal, Table, Term, TermRefs, COEFFICIENTS};
use super::simulate::{ModelSet, Simulation};
use super::{check_input, percentile, preprocess, signal, GapSettings, Levels};
use crate::io::flow_angles::WindFitSettings;
use crate::io::measured::MeasuredFlight;
use crate::plot::{Colour, Figure, Line, Panel};
use aerosid_report::fit::{output_fit, OutputFit};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The schema of the report this module reads.
pub const REPORT_SCHEMA: &str = "aerosid-gaps/3";
/// The schema of `prediction.json`.
pub const SCHEMA: &str = "aerosid-gaps-prediction/1";

/// One model (`baseline` or `extended`) of a coefficient as saved: terms and values.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedFit {
    /// Term names as the report writes them, with their estimates.
    pub parameters: Vec<(String, f64)>,
}

/// One coefficient of a saved report.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedCoefficient {
    /// `C_L` …
    pub name: String,
    /// The baseline.
    pub baseline: SavedFit,
    /// The extended model.
    pub extended: SavedFit,
}

/// What the prediction needs from a gap report.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedReport {
    /// The report's file.
    pub path: String,
    /// The identification flight.
    pub source: String,
    /// The aircraft it was identified on.
    pub aircraft: String,
    /// The air-data sentence of the report (`air data: measured …`).
    pub air_data: String,
    /// Whether the compatibility check ran.
    pub compatibility: bool,
    /// The test levels of the analysis (`criterion`; the defaults for a report without them):
    /// the compatibility check on the predicted flight takes the same.
    pub levels: Levels,
    /// The terms' reference values, when the report saved them.
    pub refs: Option<TermRefs>,
    /// Per coefficient.
    pub coefficients: Vec<SavedCoefficient>,
}

/// Whether a saved JSON file is a gap report (it has a `schema` field; the `identification.json`
/// of `aerosid fem` has none). Errors: unreadable file or not JSON.
pub fn is_gap_report(path: &Path) -> Result<bool, String> {
    let v = read_json(path)?;
    Ok(v.get("schema").is_some())
}

fn read_json(path: &Path) -> Result<Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: not JSON: {e}", path.display()))
}

/// Reads a gap report (`report.json`, schema [`REPORT_SCHEMA`]).
pub fn read_report(path: &Path) -> Result<SavedReport, String> {
    let v = read_json(path)?;
    let p = path.display();
    let schema = v.get("schema").and_then(Value::as_str).unwrap_or("(none)");
    if schema != REPORT_SCHEMA {
        return Err(format!(
            "{p}: schema `{schema}`; predict reads a gap report (schema `{REPORT_SCHEMA}`, the report.json of `aerosid gaps`) or the identification.json of `aerosid fem`"
        ));
    }
    let text = |k: &str| v.get(k).and_then(Value::as_str).unwrap_or_default().to_string();
    let fit = |c: &Value, which: &str, name: &str| -> Result<SavedFit, String> {
        let params = c
            .get(which)
            .and_then(|m| m.get("parameters"))
            .and_then(Value::as_array)
            .ok_or_else(|| format!("{p}: {name}: no `{which}.parameters`"))?;
        let parameters = params
            .iter()
            .map(|q| {
                let term = q.get("term").and_then(Value::as_str);
                // A parameter without a standard error has no estimate (`value` null) but keeps
                // the fit's value, which the fit's prediction uses.
                let value = q
                    .get("value")
                    .and_then(Value::as_f64)
                    .or_else(|| q.get("fit_value").and_then(Value::as_f64));
                match (term, value) {
                    (Some(t), Some(x)) => Ok((t.to_string(), x)),
                    _ => Err(format!(
                        "{p}: {name}: a {which} parameter without a term or a finite value"
                    )),
                }
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(SavedFit { parameters })
    };
    let coefficients = v
        .get("coefficients")
        .and_then(Value::as_array)
        .ok_or_else(|| format!("{p}: no `coefficients`"))?
        .iter()
        .map(|c| {
            let name = c
                .get("name")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("{p}: a coefficient without a name"))?
                .to_string();
            Ok(SavedCoefficient {
                baseline: fit(c, "baseline", &name)?,
                extended: fit(c, "extended", &name)?,
                name,
            })
        })
        .collect::<Result<Vec<_>, String>>()?;
    let refs = v.get("term_refs").and_then(|r| {
        Some(TermRefs {
            alpha_break_rad: r.get("alpha_break_rad")?.as_f64()?,
            airspeed_mps: r.get("airspeed_mps")?.as_f64()?,
            mach: r.get("mach")?.as_f64()?,
        })
    });
    let compatibility = !v
        .get("notes")
        .and_then(Value::as_array)
        .is_some_and(|n| n.iter().any(|s| s.as_str() == Some("compatibility check switched off")));
    let d = Levels::default();
    let level = |key: &str, default: f64| {
        v.get("criterion")
            .and_then(|c| c.get(key))
            .and_then(Value::as_f64)
            .unwrap_or(default)
    };
    let levels = Levels {
        alpha: Levels::check_alpha(level("alpha", d.alpha)).map_err(|e| format!("{p}: criterion.alpha: {e}"))?,
        gain_alpha: Levels::check_gain_alpha(level("gain_alpha", d.gain_alpha))
            .map_err(|e| format!("{p}: criterion.gain_alpha: {e}"))?,
    };
    Ok(SavedReport {
        path: p.to_string(),
        source: text("source"),
        aircraft: text("aircraft"),
        air_data: text("air_data"),
        compatibility,
        levels,
        refs,
        coefficients,
    })
}

/// The air-data choice a report's sentence records (`Auto` when it names none).
fn air_choice(sentence: &str) -> AirDataChoice {
    let word = sentence.strip_prefix("air data: ").unwrap_or("");
    [
        AirDataChoice::Fused,
        AirDataChoice::Reconstructed,
        AirDataChoice::Measured,
    ]
    .into_iter()
    .find(|c| word.starts_with(c.name()))
    .unwrap_or(AirDataChoice::Auto)
}

/// The prediction of one coefficient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoefficientPrediction {
    /// `C_L` …
    pub name: String,
    /// Whether it was predicted.
    pub predicted: bool,
    /// Why not (`None`: predicted).
    pub reason: Option<String>,
    /// The baseline's terms.
    pub baseline_terms: Vec<String>,
    /// The extended model's terms.
    pub extended_terms: Vec<String>,
    /// The baseline's fit on the new flight.
    pub baseline: Option<OutputFit>,
    /// The extended model's fit.
    pub extended: Option<OutputFit>,
    /// Whether the extended model has terms the baseline lacks.
    pub extended_differs: bool,
    /// Whether the extended model predicts this flight with a smaller RMS than the baseline
    /// (`None`: not predicted, or nothing was added).
    pub extension_improves: Option<bool>,
    /// Time, measured (synthesised), baseline and extended predictions, for the figure.
    #[serde(skip)]
    pub traces: Option<[Vec<f64>; 4]>,
}

/// The prediction of a flight.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GapsPrediction {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// The report applied.
    pub saved_report: String,
    /// The flight it was identified on.
    pub identified_on: String,
    /// The flight predicted.
    pub data: String,
    /// Its aircraft.
    pub aircraft: String,
    /// Samples of the flight.
    pub samples: usize,
    /// The air data used, in words.
    pub air_data: String,
    /// The reference values used and where they came from (`report` or `new flight`).
    pub term_refs: Value,
    /// Assumptions and pre-processing, in words.
    pub notes: Vec<String>,
    /// Per coefficient of the report.
    pub coefficients: Vec<CoefficientPrediction>,
    /// The output simulation of the whole flight ([`super::simulate`], pieces from the measured
    /// state) with the predicted coefficients' baseline and extended models.
    #[serde(serialize_with = "simulation_json")]
    pub simulation: Simulation,
}

/// The simulation as report.json writes it (`piece_s`, `notes`, `outputs`).
fn simulation_json<S: serde::Serializer>(sim: &Simulation, s: S) -> Result<S::Ok, S::Error> {
    serde_json::json!({
        "piece_s": sim.piece_s,
        "notes": sim.notes,
        "outputs": sim.outputs,
    })
    .serialize(s)
}

/// Why a coefficient is not synthesised, from the channels eq. 1–2 need ([`super::model`]).
fn missing_coefficient(i: usize) -> &'static str {
    match i {
        0 | 1 => "C_L and C_D need a_x, a_z, airspeed and α",
        4 => "C_m needs q and airspeed",
        2 => "C_Y needs a_y and airspeed",
        _ => "C_l and C_n need p, r (and q) and airspeed",
    }
}

/// Evaluates the saved models of `c` on `table`.
fn predict_one(c: &SavedCoefficient, table: &Table, refs: &TermRefs) -> CoefficientPrediction {
    let names = |f: &SavedFit| f.parameters.iter().map(|(t, _)| t.clone()).collect::<Vec<_>>();
    let mut out = CoefficientPrediction {
        name: c.name.clone(),
        predicted: false,
        reason: None,
        baseline_terms: names(&c.baseline),
        extended_terms: names(&c.extended),
        baseline: None,
        extended: None,
        extended_differs: names(&c.extended) != names(&c.baseline),
        extension_improves: None,
        traces: None,
    };
    let Some(i) = COEFFICIENTS.iter().position(|n| *n == c.name) else {
        out.reason = Some(format!("unknown coefficient `{}`", c.name));
        return out;
    };
    let Some(z) = &table.z[i] else {
        out.reason = Some(format!(
            "the flight cannot synthesise {}: {}",
            c.name,
            missing_coefficient(i)
        ));
        return out;
    };
    let eval = |f: &SavedFit| -> Result<Vec<f64>, String> {
        let mut y = vec![0.0; z.len()];
        for (name, value) in &f.parameters {
            let term = Term::parse(name).ok_or_else(|| format!("unknown term `{name}` in the report"))?;
            let col = term.column(table, refs).ok_or_else(|| {
                format!("term `{name}` cannot be formed: a channel it needs is missing from the flight")
            })?;
            for (yk, xk) in y.iter_mut().zip(&col) {
                *yk += value * xk;
            }
        }
        Ok(y)
    };
    match (eval(&c.baseline), eval(&c.extended)) {
        (Ok(b), Ok(e)) => {
            let fb = output_fit(&format!("{} baseline", c.name), "-", z, &b);
            let fe = output_fit(&format!("{} extended", c.name), "-", z, &e);
            out.extension_improves = out.extended_differs.then_some(fe.rms < fb.rms);
            out.predicted = true;
            out.baseline = Some(fb);
            out.extended = Some(fe);
            out.traces = Some([table.t_s.clone(), z.clone(), b, e]);
        }
        (Err(r), _) | (_, Err(r)) => out.reason = Some(r),
    }
    out
}

/// Applies `report` to `flight` (read by [`crate::io::read_measured_with`]).
pub fn predict(report: &SavedReport, flight: &MeasuredFlight) -> Result<GapsPrediction, String> {
    let settings = GapSettings {
        air_data: air_choice(&report.air_data),
        compatibility: report.compatibility,
        ..report.levels.apply(GapSettings::default())
    };
    let prepared = crate::io::flow_angles::prepare(flight, settings.flow_angles, &WindFitSettings::default());
    let flight = &prepared;
    let h = check_input(flight).map_err(|e| e.to_string())?;
    let pre = preprocess(flight, h, &settings, &saved_baselines(report));
    let table = pre.table;
    let mut notes = prediction_notes(pre.notes, &pre.compatibility);
    let (refs, from) = term_refs(report, &table, &mut notes);
    let coefficients: Vec<CoefficientPrediction> = report
        .coefficients
        .iter()
        .map(|c| predict_one(c, &table, &refs))
        .collect();
    let [set_b, set_e] = saved_model_sets(report, &coefficients);
    let simulation = super::simulate::simulate(
        &table,
        &flight.aircraft,
        h,
        &refs,
        0,
        &flight.pieces().iter().map(|p| (p.start, p.end)).collect::<Vec<_>>(),
        [&set_b, &set_e],
    );
    let air_data = notes
        .iter()
        .find(|n| n.starts_with("air data:"))
        .cloned()
        .unwrap_or_default();
    Ok(GapsPrediction {
        schema: SCHEMA,
        saved_report: report.path.clone(),
        identified_on: report.source.clone(),
        data: flight.source.clone(),
        aircraft: flight.aircraft.name.clone(),
        samples: flight.len(),
        air_data,
        term_refs: serde_json::json!({
            "alpha_break_rad": refs.alpha_break_rad,
            "airspeed_mps": refs.airspeed_mps,
            "mach": refs.mach,
            "from": from,
        }),
        notes,
        coefficients,
        simulation,
    })
}

/// The report's baselines (they set the candidate count, so the compatibility check's
/// threshold, as in the analysis); eq. 3 for a coefficient the report does not hold.
fn saved_baselines(report: &SavedReport) -> [Vec<Term>; 6] {
    core::array::from_fn(|i| {
        report
            .coefficients
            .iter()
            .find(|c| c.name == COEFFICIENTS[i])
            .map(|c| {
                c.baseline
                    .parameters
                    .iter()
                    .filter_map(|(t, _)| Term::parse(t))
                    .collect()
            })
            .unwrap_or_else(|| Term::eq3(i))
    })
}

/// The preprocessing's notes for a prediction. The analysis's note on its corrections points at
/// its `as_logged` list, which a prediction has not: say instead which sensor errors of this
/// flight were removed; then the compatibility check's own notes.
fn prediction_notes(pre_notes: Vec<String>, compatibility: &Compatibility) -> Vec<String> {
    let mut notes: Vec<String> = pre_notes
        .into_iter()
        .filter(|n| !n.starts_with("the sensor errors named are removed"))
        .collect();
    if !compatibility.found.is_empty() {
        // A delay refined within its interval is removed at the refined value, which its own
        // note (`… removed at …, not at the estimate …`) gives: say so instead of a second value.
        let refined = |name: &str| notes.iter().any(|n| n.starts_with(&format!("{name} removed at ")));
        let names: Vec<String> = compatibility
            .found
            .iter()
            .map(|f| {
                let name = f.param.name();
                if refined(&name) {
                    format!("{name} (as refined: the note above)")
                } else {
                    format!("{name} = {:.4}", f.value)
                }
            })
            .collect();
        notes.push(format!(
            "sensor errors the compatibility check finds in this flight are removed before the synthesis, as the analysis does: {}",
            names.join(", ")
        ));
    }
    notes.extend(compatibility.notes.iter().cloned());
    notes
}

/// The terms' reference values and where they came from: the report's, else the predicted
/// flight's (with a note saying so).
fn term_refs(report: &SavedReport, table: &Table, notes: &mut Vec<String>) -> (TermRefs, &'static str) {
    match report.refs {
        Some(r) => (r, "report"),
        None => {
            notes.push(
                "the report saved no reference values (term_refs): α_break, V_ref and M_ref are taken from the predicted flight"
                    .into(),
            );
            let mean = |s: Signal| table.signals.get(&s).map(|v| signal::mean(v));
            let r = TermRefs {
                alpha_break_rad: table.signals.get(&Signal::Alpha).map_or(0.0, |a| percentile(a, 0.85)),
                airspeed_mps: mean(Signal::Airspeed).unwrap_or(1.0).max(1.0),
                mach: mean(Signal::Mach).unwrap_or(0.0),
            };
            (r, "new flight")
        }
    }
}

/// The baseline and the extended model sets the simulation takes: the models of the predicted
/// coefficients (every term formed); the others are left to the measured values, as in the
/// analysis.
fn saved_model_sets(report: &SavedReport, coefficients: &[CoefficientPrediction]) -> [ModelSet; 2] {
    let model_set = |extended: bool| -> ModelSet {
        core::array::from_fn(|i| {
            let saved = report.coefficients.iter().find(|c| c.name == COEFFICIENTS[i])?;
            coefficients.iter().find(|c| c.name == COEFFICIENTS[i] && c.predicted)?;
            let fit = if extended { &saved.extended } else { &saved.baseline };
            fit.parameters
                .iter()
                .map(|(t, v)| Some((Term::parse(t)?, *v)))
                .collect()
        })
    };
    [model_set(false), model_set(true)]
}

/// The terminal table.
pub fn table(p: &GapsPrediction) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "gap report {} (identified on {})", p.saved_report, p.identified_on);
    let _ = writeln!(
        s,
        "applied to {} ({} samples, aircraft {})",
        p.data, p.samples, p.aircraft
    );
    let _ = writeln!(s, "{}", p.air_data);
    let _ = writeln!(
        s,
        "{:<5} {:<9} {:>7} {:>11} {:>8} {:>8}  extension",
        "coef", "model", "samples", "RMS", "R²", "Theil U"
    );
    let _ = writeln!(s, "{}", aerosid_report::fit::THEIL_LEGEND);
    for c in &p.coefficients {
        match (&c.baseline, &c.extended) {
            (Some(b), Some(e)) => {
                let verdict = match c.extension_improves {
                    None => "none (nothing added)",
                    Some(true) => "improves",
                    Some(false) => "does not improve",
                };
                for (label, f, v) in [("baseline", b, ""), ("extended", e, verdict)] {
                    let _ = writeln!(
                        s,
                        "{:<5} {:<9} {:>7} {:>11.4e} {:>8.4} {:>8.4}  {v}",
                        c.name, label, f.samples, f.rms, f.r2, f.theil_u
                    );
                }
            }
            _ => {
                let _ = writeln!(s, "{:<5} not predicted: {}", c.name, c.reason.as_deref().unwrap_or(""));
            }
        }
    }
    if !p.simulation.outputs.is_empty() {
        let _ = writeln!(
            s,
            "output simulation of the flight ({:.0} s pieces from the measured state)",
            p.simulation.piece_s
        );
        let _ = writeln!(
            s,
            "{:<10} {:>8} {:>11} | {:>8} {:>11} | diverged",
            "output", "R² base", "RMS base", "R² ext", "RMS ext"
        );
        for o in &p.simulation.outputs {
            // A diverged simulation has no R² or RMS ([`super::simulate`]): it says where it was cut.
            let cols = |m: &super::regress::Metrics, w: usize| {
                if o.diverged_with(w) {
                    let at: Vec<String> = o.diverged_at_s[w].iter().map(|t| format!("{t:.1}")).collect();
                    format!("diverged at t = {} s", at.join(", "))
                } else {
                    format!("{:>8.4} {:>11.4e}", m.r2, m.rms)
                }
            };
            let _ = writeln!(
                s,
                "{:<10} {} | {} | {}/{} ({})",
                o.channel,
                cols(&o.baseline, 0),
                cols(&o.extended, 1),
                o.diverged[0],
                o.diverged[1],
                o.unit
            );
        }
    }
    for n in p.notes.iter().chain(&p.simulation.notes) {
        if !n.starts_with("air data:") {
            let _ = writeln!(s, "note: {n}");
        }
    }
    s
}

/// One panel per predicted coefficient: synthesised vs baseline and extended predictions.
pub fn figure(p: &GapsPrediction) -> Figure {
    let mut fig = Figure::new("time [s]").title(format!("{}: coefficients predicted by {}", p.data, p.saved_report));
    for c in &p.coefficients {
        let (Some([t, z, b, e]), Some(fb), Some(fe)) = (&c.traces, &c.baseline, &c.extended) else {
            continue;
        };
        fig = fig.panel(
            Panel::new(c.name.clone(), c.name.clone())
                .line(Line::new("synthesised (eq. 1–2)", t, z, Colour::GREY))
                .line(Line::new(format!("baseline (R² {:.3})", fb.r2), t, b, Colour::BLUE))
                .line(Line::new(format!("extended (R² {:.3})", fe.r2), t, e, Colour::VERMILLION).dashed()),
        );
    }
    fig
}

/// Writes `prediction.json` and, when anything was predicted, `prediction.svg` into `out`.
pub fn write(p: &GapsPrediction, out: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let jp = out.join("prediction.json");
    let text = serde_json::to_string_pretty(p).map_err(|e| e.to_string())?;
    std::fs::write(&jp, text).map_err(|e| format!("{}: {e}", jp.display()))?;
    let mut files = vec![jp];
    if p.coefficients.iter().any(|c| c.predicted) {
        let sp = out.join("prediction.svg");
        figure(p).write_svg(&sp).map_err(|e| format!("{}: {e}", sp.display()))?;
        files.push(sp);
    }
    if !p.simulation.traces.is_empty() {
        let sp = out.join("prediction_simulation.svg");
        let title = format!(
            "{} simulated with the saved models ({:.0} s pieces, each from the measured state)",
            p.data, p.simulation.piece_s
        );
        super::report::simulation_figure_titled(&p.simulation, &title)
            .write_svg(&sp)
            .map_err(|e| format!("{}: {e}", sp.display()))?;
        files.push(sp);
    }
    Ok(files)
}

/// `aerosid predict` of a gap report (read first by [`read_report`], so that a wrong report is
/// refused before the flight is read): predict, write; returns the table and the files.
pub fn run(
    report: &SavedReport,
    flight: &MeasuredFlight,
    out: &Path,
) -> Result<(GapsPrediction, String, Vec<PathBuf>), String> {
    let p = predict(report, flight)?;
    let files = write(&p, out)?;
    let text = table(&p);
    Ok((p, text, files))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gap report with no coefficients and `criterion` as given, written to a temporary file
    /// named by `tag` and read back.
    fn read_with(tag: &str, criterion: Option<Value>) -> Result<SavedReport, String> {
        let mut v = serde_json::json!({"schema": REPORT_SCHEMA, "coefficients": []});
        if let Some(c) = criterion {
            v["criterion"] = c;
        }
        let path = std::env::temp_dir().join(format!("aerosid-predict-{tag}-{}.json", std::process::id()));
        std::fs::write(&path, v.to_string()).expect("temporary report written");
        let r = read_report(&path);
        let _ = std::fs::remove_file(&path);
        r
    }

    #[test]
    fn the_report_levels_are_the_prediction_levels() {
        // GIVEN reports analysed at other levels, at none recorded, and at a level out of range
        let set = read_with("set", Some(serde_json::json!({"alpha": 0.05, "gain_alpha": 0.2}))).expect("read");
        let old = read_with("old", None).expect("read");
        let bad = read_with("bad", Some(serde_json::json!({"alpha": 2.0})));
        // THEN the prediction's compatibility check takes the report's levels, the defaults when
        // it has none, and a level out of range is refused with the field named
        assert_eq!(
            set.levels,
            Levels {
                alpha: 0.05,
                gain_alpha: 0.2
            }
        );
        assert_eq!(old.levels, Levels::default());
        let e = bad.expect_err("alpha 2 refused");
        assert!(e.contains("criterion.alpha"), "{e}");
    }
}
