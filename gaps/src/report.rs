//! The report of the model-gap analysis: a terminal table a person reads, SVG figures, and the JSON
//! document a script reads (schema `aerosid-gaps/3`, described in `docs/model-gaps.md`).

use super::{CoefficientGap, GapReport};
use crate::plot::{Colour, Figure, Line, Panel, PlotError};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The report's label: the data file's name without its extension (each file's, for pooled
/// manoeuvres), or the source as given when it is not a file (a simulated flight).
pub fn label(r: &GapReport) -> String {
    let stem = |s: &str| {
        let p = Path::new(s);
        match p.file_stem() {
            Some(st) if p.is_file() => st.to_string_lossy().into_owned(),
            _ => s.to_string(),
        }
    };
    if r.manoeuvres.len() > 1 {
        let mut names: Vec<String> = Vec::new();
        for m in &r.manoeuvres {
            let n = stem(&m.source);
            if !names.contains(&n) {
                names.push(n);
            }
        }
        names.join(", ")
    } else {
        stem(&r.source)
    }
}

/// A held-out R² as every part of the report writes it (three decimals; "–" when not computed),
/// so that the table and the verdicts show the same figure.
pub fn r2_text(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3}")
    } else {
        "–".into()
    }
}

/// `value ± σ unit` to five decimals, or "not determined" when either is not finite.
fn estimate(value: f64, sigma: f64, unit: &str) -> String {
    if value.is_finite() && sigma.is_finite() {
        format!(
            "{value:+.5} ± {sigma:.5}{}",
            if unit.is_empty() {
                String::new()
            } else {
                format!(" {unit}")
            }
        )
    } else {
        "not determined (no finite standard error)".into()
    }
}

/// A t² to one decimal, or "–" when not computed.
fn t2_text(t2: f64) -> String {
    if t2.is_finite() {
        format!("{t2:.1}")
    } else {
        "–".into()
    }
}

/// Why a `t²` threshold is what it is, in words: the Bonferroni level over `m` candidates and
/// Student's t with `blocks − 1` degrees of freedom (the block sandwich's σ is estimated from that
/// many blocks; with few of them it is itself uncertain and only a large `t²` is significant).
pub fn threshold_words(t2: f64, alpha: f64, m: usize, blocks: usize, block_s: f64) -> String {
    let dof = blocks.saturating_sub(1).max(1);
    let base = format!(
        "t² > {}: the two-sided level α = {alpha} divided among {m} candidates (Bonferroni), Student's t with {dof} degree{} of freedom ({blocks} blocks of {block_s:.0} s)",
        t2_text(t2),
        if dof == 1 { "" } else { "s" }
    );
    if dof < 10 {
        format!("{base}; few blocks, so the standard errors are themselves uncertain and only a very large t² is significant — a longer flight or more manoeuvres lower the threshold")
    } else {
        base
    }
}

/// The terminal table: the header and notes, then its sections.
pub fn table(r: &GapReport) -> String {
    let mut s = String::new();
    header(&mut s, r);
    if r.manoeuvres.len() > 1 {
        manoeuvre_table(&mut s, r);
    }
    s.push_str(&crate::io::quality::table(&r.data_quality));
    compatibility_section(&mut s, r);
    coefficient_table(&mut s, r);
    verdicts(&mut s, r);
    estimates(&mut s, r);
    simulation_section(&mut s, r);
    verdict_section(&mut s, r);
    s
}

/// The table's first lines: the source, aircraft, segments, tests, and the notes, once each.
fn header(s: &mut String, r: &GapReport) {
    let _ = writeln!(s, "model-gap analysis — {}", label(r));
    if label(r) != r.source {
        let _ = writeln!(s, "data: {}", r.source);
    }
    let _ = writeln!(
        s,
        "aircraft {}; identification {:.1}–{:.1} s, held out {:.1}–{:.1} s; {} candidates tested; threshold {}; held-out gain one-sided at {}",
        r.aircraft,
        r.identification_s[0],
        r.identification_s[1],
        r.validation_s[0],
        r.validation_s[1],
        r.candidates_tested,
        threshold_words(
            r.threshold_t2,
            r.settings.alpha,
            r.candidates_tested,
            r.threshold_blocks,
            r.settings.cv.block_s
        ),
        r.settings.cv.gain_alpha
    );
    let mut seen: Vec<&String> = Vec::new();
    for n in r.notes.iter().chain(&r.compatibility.notes) {
        if !seen.contains(&n) {
            seen.push(n);
            let _ = writeln!(s, "note: {n}");
        }
    }
}

/// Section 1: the data compatibility, the best sensor-error candidates and those found.
fn compatibility_section(s: &mut String, r: &GapReport) {
    let _ = writeln!(s, "\n1. data compatibility (flight-path reconstruction)");
    let _ = writeln!(s, "   {:<10} {:>12} {:>12}", "output", "RMS before", "RMS after");
    for o in &r.compatibility.rms {
        let _ = writeln!(
            s,
            "   {:<10} {:>12.5} {:>12.5}",
            format!("{:?}", o.channel),
            o.before,
            o.after
        );
    }
    let mut tested = r.compatibility.tested.clone();
    tested.sort_by(|a, b| b.t2.total_cmp(&a.t2));
    if !tested.is_empty() {
        let _ = writeln!(s, "   best candidates (first round; t² = (value/σ)²):");
    }
    for c in tested.iter().take(5) {
        let detect = if c.min_detectable.is_finite() {
            format!(
                "needs |·| ≥ {:.5}, oracle {:.5}",
                c.min_detectable, c.oracle_min_detectable
            )
        } else {
            "not testable by output error in turbulence".to_string()
        };
        let _ = writeln!(
            s,
            "     {:<18} t² {:>10}   {} ({detect})",
            c.param.name(),
            t2_text(c.t2),
            estimate(c.value, c.sigma, c.param.unit()),
        );
    }
    sensor_errors(s, r);
}

/// The sensor errors of section 1 not named, found, and the baselines as logged.
fn sensor_errors(s: &mut String, r: &GapReport) {
    for f in &r.compatibility.rejected {
        let _ = writeln!(
            s,
            "   not named {:<14} {} (t² {}): {}",
            f.param.name(),
            estimate(f.value, f.sigma, f.param.unit()),
            t2_text(f.t2),
            f.why
        );
    }
    if r.compatibility.found.is_empty() {
        let _ = writeln!(s, "   sensor errors found: none");
    }
    for f in &r.compatibility.found {
        let _ = writeln!(
            s,
            "   FOUND {:<18} {} (t² {} in this fit; entered at t² {}; held-out gain {:.1} σ, {} part)",
            f.param.name(),
            estimate(f.value, f.sigma, f.param.unit()),
            t2_text(t2_of(f.value, f.sigma)),
            t2_text(f.t2),
            f.cv_gain_z,
            f.part
        );
    }
    if !r.as_logged.is_empty() {
        let _ = writeln!(
            s,
            "   the aerodynamics below use the data with these errors removed; the baselines as logged:"
        );
        for (name, params) in &r.as_logged {
            let ps: Vec<String> = params.iter().map(|(t, v)| format!("{t} {v:+.4}")).collect();
            let _ = writeln!(s, "     {name}: {}", ps.join(", "));
        }
    }
}

/// Section 2's table: per coefficient, held-out R², RMS, PSE, the best candidate and the terms
/// added.
fn coefficient_table(s: &mut String, r: &GapReport) {
    let _ = writeln!(
        s,
        "\n2. coefficients (held-out R²: blocked cross-validation over the whole flight, the figure of the verdicts; RMS and PSE of the fit on the identification segment)"
    );
    let _ = writeln!(
        s,
        "   {:<5} {:>8} {:>8} | {:>10} {:>10} | {:>10} {:>10} | {:<14} {:>9} | added",
        "coef", "R² base", "R² ext", "RMS base", "RMS ext", "PSE base", "PSE ext", "best candidate", "t²"
    );
    for c in &r.coefficients {
        let best = c.candidates.first();
        let added: Vec<String> = c
            .added
            .iter()
            .map(|a| format!("{} = {} ({:?})", a.term, estimate(a.value, a.sigma, ""), a.kind))
            .collect();
        let _ = writeln!(
            s,
            "   {:<5} {:>8} {:>8} | {:>10.3e} {:>10.3e} | {:>10.3e} {:>10.3e} | {:<14} {:>9} | {}",
            c.name,
            r2_text(c.cv_r2_baseline),
            r2_text(c.cv_r2_extended),
            c.baseline.identification.rms,
            c.extended.identification.rms,
            c.baseline.identification.pse,
            c.extended.identification.pse,
            best.map_or("-".into(), |b| b.term.clone()),
            best.map_or("–".into(), |b| t2_text(b.t2)),
            if added.is_empty() {
                "nothing".into()
            } else {
                added.join(", ")
            }
        );
    }
}

/// Section 2's verdicts, each with its threshold where it is not the report's.
fn verdicts(s: &mut String, r: &GapReport) {
    let _ = writeln!(s, "\n   verdicts:");
    // The coefficients' own thresholds (at their number of blocks) where they are not the one
    // above: once when they share one, else per coefficient.
    let own = |c: &CoefficientGap| {
        (c.blocks > 0 && c.threshold_t2 != r.threshold_t2).then(|| {
            threshold_words(
                c.threshold_t2,
                r.settings.alpha,
                r.candidates_tested,
                c.blocks,
                c.block_s,
            )
        })
    };
    let thresholds: Vec<Option<String>> = r.coefficients.iter().map(own).collect();
    let shared = thresholds.windows(2).all(|w| w[0] == w[1]);
    if let (true, Some(Some(t))) = (shared, thresholds.first()) {
        let _ = writeln!(s, "   the coefficients' tests: threshold {t}");
    }
    for (c, own) in r.coefficients.iter().zip(&thresholds) {
        coefficient_verdict(s, c, own.as_ref().filter(|_| !shared));
    }
}

/// One coefficient's verdict (`own`: its threshold, when said per coefficient), what the flight
/// could have found, the terms it cannot tell apart, the rivals and the notes.
fn coefficient_verdict(s: &mut String, c: &CoefficientGap, own: Option<&String>) {
    let _ = writeln!(s, "   {:<5} {}", c.name, c.verdict);
    if let Some(t) = own {
        let _ = writeln!(s, "         threshold {t}");
    }
    reach(s, c);
    for a in c.added.iter().filter(|a| !a.alternatives.is_empty()) {
        let _ = writeln!(
            s,
            "         {} cannot be told apart on this flight from: {}",
            a.term,
            a.alternatives.join(", ")
        );
    }
    for a in c.added.iter().filter(|a| !a.rivals.is_empty()) {
        let r: Vec<String> = a
            .rivals
            .iter()
            .map(|r| format!("{} (t² {:.0}, held-out z {:.1})", r.term, r.t2, r.cv_z))
            .collect();
        let _ = writeln!(
            s,
            "         {} predicts the held-out blocks better than (each significant in its place): {}",
            a.term,
            r.join(", ")
        );
    }
    for n in &c.notes {
        let _ = writeln!(s, "         {n}");
    }
}

/// Where nothing was added to `c`, what the flight could have found: the strongest candidates
/// with the smallest effect it names with 80 % probability.
fn reach(s: &mut String, c: &CoefficientGap) {
    if c.added.is_empty() {
        let reach: Vec<String> = c
            .candidates
            .iter()
            .filter(|k| k.min_detectable.is_finite() && k.value.is_finite() && k.sigma.is_finite())
            .take(3)
            .map(|k| {
                format!(
                    "{} {} ± {} (needs |·| ≥ {})",
                    k.term,
                    sig3(k.value, true),
                    sig3(k.sigma, false),
                    sig3(k.min_detectable, false)
                )
            })
            .collect();
        if !reach.is_empty() {
            let _ = writeln!(
                s,
                "         strongest candidates and the least this flight detects: {}",
                reach.join(", ")
            );
        }
    }
}

/// Section 2's estimates of each extended model.
fn estimates(s: &mut String, r: &GapReport) {
    let _ = writeln!(
        s,
        "\n   estimates (the estimator named ± coloured-residual σ [PCA-GTLS: eq. 17 σ; output error: the Cramér–Rao bound]; OLS cross-check beside PCA-GTLS):"
    );
    for c in &r.coefficients {
        let f = &c.extended;
        // OLS has no "solution" of eq. 21 to report.
        if f.solution == "LeastSquares" {
            let _ = writeln!(s, "   {} ({}):", c.name, f.estimator);
        } else {
            let _ = writeln!(s, "   {} ({}, {}):", c.name, f.estimator, f.solution);
        }
        if let Some(why) = &f.not_determined {
            let _ = writeln!(s, "     not determined: {why}");
        }
        for p in &f.parameters {
            let eq17 = if p.sigma_eq17.is_finite() {
                format!("[{:.5}]", p.sigma_eq17)
            } else {
                "[–]".into()
            };
            // Output error has no least-squares cross-check (and no exact columns).
            let ols = if p.ols_value.is_finite() {
                format!("OLS {:>12.5}{}", p.ols_value, if p.exact { "  (exact)" } else { "" })
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "     {:<10} {:>28} {:<11} {}",
                p.term,
                estimate(p.value, p.sigma, ""),
                eq17,
                ols
            );
        }
    }
}

/// Section 3: the simulation of the held-out segment.
fn simulation_section(s: &mut String, r: &GapReport) {
    let sim = &r.simulation;
    let _ = writeln!(
        s,
        "\n3. simulation of the held-out segment with the fitted models ({:.0} s pieces from the measured state)",
        sim.piece_s
    );
    for n in &sim.notes {
        let _ = writeln!(s, "   note: {n}");
    }
    if !sim.outputs.is_empty() {
        let _ = writeln!(
            s,
            "   {:<10} {:>8} {:>10} {:>10} | {:>8} {:>10} {:>10} | unit",
            "output", "R² base", "RMS base", "PSE base", "R² ext", "RMS ext", "PSE ext"
        );
    }
    for o in &sim.outputs {
        let cols = |m: &super::regress::Metrics, diverged: bool| {
            if diverged {
                format!("{:>8} {:>10} {:>10}", "diverged", "–", "–")
            } else {
                format!("{:>8.4} {:>10.3e} {:>10.3e}", m.r2, m.rms, m.pse)
            }
        };
        let _ = writeln!(
            s,
            "   {:<10} {} | {} | {}",
            o.channel,
            cols(&o.baseline, o.diverged_with(0)),
            cols(&o.extended, o.diverged_with(1)),
            o.unit
        );
    }
    for o in &sim.outputs {
        for (w, name) in [(0, "baseline"), (1, "extended")] {
            if o.diverged_with(w) {
                let at: Vec<String> = o.diverged_at_s[w].iter().map(|t| format!("{t:.1}")).collect();
                let _ = writeln!(
                    s,
                    "   {} with the {name} models diverged at t = {} s (the state left the plausible range; no R², RMS or PSE)",
                    o.channel,
                    at.join(", ")
                );
            }
        }
    }
}

/// Section 4: the verdict and the causes named.
fn verdict_section(s: &mut String, r: &GapReport) {
    // One verdict; where the data cannot support one, the reasons stand once, under the data
    // quality above.
    if r.data_quality.supports_verdict {
        let _ = writeln!(s, "\n4. verdict\n   {}", r.verdict);
    } else {
        let _ = writeln!(
            s,
            "\n4. verdict\n   no verdict: these data cannot support one (the reasons are listed under the data quality above)"
        );
    }
    for (k, c) in r.named.iter().enumerate() {
        let _ = writeln!(
            s,
            "   {} {:?} in {}: {} = {} (t² {}{})",
            if k == 0 { "TOP" } else { "   " },
            c.kind,
            c.location,
            c.what,
            estimate(c.value, c.sigma, ""),
            t2_text(c.t2),
            entry_text(c)
        );
    }
}

/// Where a named cause's final `t²` is below the threshold it passed at entry, both tests in
/// words; empty otherwise.
fn entry_text(c: &super::NamedCause) -> String {
    match c.entry {
        Some((entry, threshold)) if entry.is_finite() && c.t2.partial_cmp(&threshold) != Some(std::cmp::Ordering::Greater) => format!(
            " in the final fit, whose σ carries the regressors' errors too; it entered at t² {} > {} in the selection's least-squares fit",
            t2_text(entry),
            t2_text(threshold)
        ),
        _ => String::new(),
    }
}

/// `(value/σ)²`; NaN when either is not finite.
fn t2_of(value: f64, sigma: f64) -> f64 {
    (value / sigma).powi(2)
}

/// The manoeuvres of a pooled analysis and, per added term, its per-manoeuvre estimates.
fn manoeuvre_table(s: &mut String, r: &GapReport) {
    let _ = writeln!(s, "\nmanoeuvres ({}, in canonical order)", r.manoeuvres.len());
    for (k, m) in r.manoeuvres.iter().enumerate() {
        let _ = writeln!(
            s,
            "   #{k} {} {:.2}–{:.2} s, {} samples, {} ({}); excites {}",
            m.source,
            m.span_s[0],
            m.span_s[1],
            m.samples,
            if m.identification { "identification" } else { "held out" },
            m.cut,
            if m.excites.is_empty() {
                "no baseline regressor".to_string()
            } else {
                m.excites.join(", ")
            }
        );
    }
    for c in &r.coefficients {
        for h in &c.homogeneity {
            let per: Vec<String> = h
                .per_manoeuvre
                .iter()
                .map(|e| format!("#{} {}±{}", e.manoeuvre, sig3(e.value, true), sig3(e.sigma, false)))
                .collect();
            let _ = writeln!(s, "   {} {}: {}; {}", c.name, h.term, per.join(", "), h.reason);
        }
    }
}

/// The JSON document (schema `aerosid-gaps/3`).
pub fn json(r: &GapReport) -> Value {
    let f = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let compat = &r.compatibility;
    let mut doc = json!({
        "schema": "aerosid-gaps/3",
        "source": r.source,
        "label": label(r),
        "aircraft": r.aircraft,
        "segments": {
            "identification_s": [f(r.identification_s[0]), f(r.identification_s[1])],
            "validation_s": [f(r.validation_s[0]), f(r.validation_s[1])],
        },
        "criterion": {
            "statistic": "partial t² (block sandwich, Student t with G−1 dof) and held-out gain on blocks (blocked cross-validation), forward selection with removal",
            "alpha": r.settings.alpha,
            "block_s": r.settings.cv.block_s,
            "folds": r.settings.cv.folds,
            "gain_alpha": r.settings.cv.gain_alpha,
            "candidates_tested": r.candidates_tested,
            "threshold_t2": f(r.threshold_t2),
            "threshold_blocks": r.threshold_blocks,
            "threshold_why": threshold_words(r.threshold_t2, r.settings.alpha, r.candidates_tested, r.threshold_blocks, r.settings.cv.block_s),
            "pse_must_decrease": false,
        },
        "notes": r.notes.iter().chain(&compat.notes).collect::<Vec<_>>(),
        "air_data": r.air_data,
        "manoeuvres": r.manoeuvres,
        "channel_origin": r.data_quality.channel_origin,
        "term_refs": {
            "alpha_break_rad": f(r.refs.alpha_break_rad),
            "airspeed_mps": f(r.refs.airspeed_mps),
            "mach": f(r.refs.mach),
        },
        "corrections_applied": r.corrections_applied,
        "verdict": r.verdict,
        "data_quality": r.data_quality,
        "compatibility": {
            "outputs": compat.rms.iter().map(|o| json!({
                "channel": format!("{:?}", o.channel), "rms_before": f(o.before), "rms_after": f(o.after),
            })).collect::<Vec<_>>(),
            "tested": compat.tested.iter().map(|c| json!({
                "parameter": c.param.name(), "channel": format!("{:?}", c.param.channel()),
                "kind": format!("{:?}", super::param_kind(&c.param)), "unit": c.param.unit(),
                "value": f(c.value), "sigma": f(c.sigma), "t2": f(c.t2), "part": c.part,
                "significant": c.t2 > r.threshold_t2,
                "min_detectable": f(c.min_detectable),
                "oracle_se": f(c.oracle_se), "oracle_min_detectable": f(c.oracle_min_detectable),
                "se_ratio": f(c.sigma / c.oracle_se),
            })).collect::<Vec<_>>(),
            "found": compat.found.iter().map(|c| found_json(c, false)).collect::<Vec<_>>(),
            "rejected": compat.rejected.iter().map(|c| found_json(c, true)).collect::<Vec<_>>(),
            "turbulent": compat.turbulent.iter().map(|(q, sd)| json!({
                "channel": format!("{q:?}"), "wind_sd": f(*sd),
            })).collect::<Vec<_>>(),
        },
        "as_logged": r.as_logged.iter().map(|(name, params)| json!({
            "name": name,
            "parameters": params.iter().map(|(t, v)| json!({"term": t, "value": f(*v)})).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "coefficients": r.coefficients.iter().map(coef_json).collect::<Vec<_>>(),
        "simulation": {
            "piece_s": r.simulation.piece_s,
            "notes": r.simulation.notes,
            "outputs": r.simulation.outputs,
        },
        "named": r.named.iter().map(|c| {
            let mut v = json!({
                "kind": c.kind, "location": c.location, "what": c.what,
                "t2": f(c.t2), "value": f(c.value), "sigma": f(c.sigma), "family": c.family,
                "entry_t2": c.entry.map(|e| f(e.0)), "threshold_t2": c.entry.map(|e| f(e.1)),
            });
            undetermined_to_null(&mut v);
            v
        }).collect::<Vec<_>>(),
        "top_cause": r.top_cause().map(|c| json!({
            "kind": c.kind, "location": c.location, "what": c.what, "t2": f(c.t2),
        })),
    });
    add_status(&mut doc, r.data_quality.supports_verdict, &r.data_quality.why_not);
    doc
}

/// The machine-readable verdict status of a report.json: `"status": "verdict"` when the data
/// support a verdict, else `"no_verdict"`, and `"reasons"` (each once; empty with a verdict). Every
/// report.json carries it, also the one of a flight the analysis could not run on.
pub fn add_status(doc: &mut Value, verdict: bool, reasons: &[String]) {
    let mut once: Vec<&String> = Vec::new();
    for r in reasons.iter().filter(|_| !verdict) {
        if !once.contains(&r) {
            once.push(r);
        }
    }
    if let Value::Object(m) = doc {
        m.insert("status".into(), json!(if verdict { "verdict" } else { "no_verdict" }));
        m.insert("reasons".into(), json!(once));
    }
}

/// A found (or rejected, with its reason) sensor error.
fn found_json(c: &super::compat::Found, with_why: bool) -> Value {
    let f = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let mut v = json!({
        "parameter": c.param.name(), "channel": format!("{:?}", c.param.channel()),
        "kind": format!("{:?}", super::param_kind(&c.param)), "unit": c.param.unit(),
        "value": f(c.value), "sigma": f(c.sigma), "t2": f(c.t2), "part": c.part,
        "cv_gain": f(c.cv_gain), "cv_gain_z": f(c.cv_gain_z),
    });
    if with_why {
        v["why"] = json!(c.why);
    }
    v
}

fn coef_json(c: &CoefficientGap) -> Value {
    // serde_json writes NaN as null; an estimate without a finite σ is not an estimate: its value
    // is null too, with the reason.
    let mut baseline = json!(c.baseline);
    let mut extended = json!(c.extended);
    for fit in [&mut baseline, &mut extended] {
        if let Some(ps) = fit.get_mut("parameters").and_then(Value::as_array_mut) {
            ps.iter_mut().for_each(undetermined_to_null);
        }
    }
    let mut added = json!(c.added);
    if let Some(a) = added.as_array_mut() {
        a.iter_mut().for_each(undetermined_to_null);
    }
    json!({
        "name": c.name,
        "verdict": c.verdict,
        "cv_r2_baseline": c.cv_r2_baseline,
        "cv_r2_extended": c.cv_r2_extended,
        "block_s": c.block_s,
        "threshold_t2": c.threshold_t2,
        "dropped_terms": c.dropped_terms,
        "blocks": c.blocks,
        "baseline": baseline,
        "candidates": c.candidates,
        "added": added,
        "notes": c.notes,
        "extended": extended,
        "homogeneity": c.homogeneity,
    })
}

/// An estimate (`value`, `sigma`) whose σ is not finite: `value` null and `not_determined` saying
/// why.
fn undetermined_to_null(v: &mut Value) {
    if v.get("sigma").and_then(Value::as_f64).is_none() {
        // The fit's own value stays for what uses the fit, not the estimate: its prediction
        // (`predict`).
        if let Some(x) = v.get("value").filter(|x| x.is_number()).cloned() {
            v["fit_value"] = x;
        }
        v["value"] = Value::Null;
        v["not_determined"] = json!("no finite standard error: the fit does not determine this estimate");
    }
}

/// `x` to three significant digits (fixed point from 0.01 to 10⁴, else an exponent).
fn sig3(x: f64, signed: bool) -> String {
    let a = x.abs();
    if !a.is_finite() {
        return "–".into();
    }
    let body = if a == 0.0 || (0.01..1e4).contains(&a) {
        let decimals = (2.0 - a.log10().floor()).clamp(0.0, 3.0) as usize;
        format!("{a:.decimals$}")
    } else {
        format!("{a:.2e}")
    };
    let sign = if x < 0.0 {
        "-"
    } else if signed {
        "+"
    } else {
        ""
    };
    format!("{sign}{body}")
}

/// Writes `report.json`, `report.txt`, the figures and `report.html` (crate::html) into `dir`;
/// returns the files written.
pub fn write(r: &GapReport, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| ReportError::Io(dir.to_path_buf(), e))?;
    let mut files = Vec::new();
    let j = dir.join("report.json");
    let text = serde_json::to_string_pretty(&json(r)).map_err(|e| ReportError::Json(e.to_string()))?;
    std::fs::write(&j, text).map_err(|e| ReportError::Io(j.clone(), e))?;
    files.push(j);
    let t = dir.join("report.txt");
    std::fs::write(&t, table(r)).map_err(|e| ReportError::Io(t.clone(), e))?;
    files.push(t);
    for c in &r.coefficients {
        let p = dir.join(format!("gap_{}.svg", c.name.replace('_', "")));
        coefficient_figure(c).write_svg(&p).map_err(ReportError::Plot)?;
        files.push(p);
    }
    if !r.simulation.traces.is_empty() {
        let p = dir.join("simulation.svg");
        simulation_figure(&r.simulation)
            .write_svg(&p)
            .map_err(ReportError::Plot)?;
        files.push(p);
    }
    if !r.compatibility.traces.is_empty() {
        let p = dir.join("compatibility.svg");
        compatibility_figure(r).write_svg(&p).map_err(ReportError::Plot)?;
        files.push(p);
    }
    files.push(crate::html::write_gaps(&dir.join("report.json"), &files).map_err(ReportError::Html)?);
    Ok(files)
}

/// The flight-path reconstruction: per output, measured vs reconstructed (with the sensor errors
/// found removed) and the residual, in the output's unit; the identification / held-out split marked.
pub fn compatibility_figure(r: &GapReport) -> Figure {
    let n = r.compatibility.traces.first().map_or(0, |t| t.1.len());
    let first = r.coefficients.first().filter(|c| c.traces.t_s.len() == n);
    let t: Vec<f64> = first.map_or_else(|| (0..n).map(|i| i as f64).collect(), |c| c.traces.t_s.clone());
    let mut fig = Figure::new(if first.is_some() { "time [s]" } else { "sample" })
        .title("flight-path reconstruction: measured vs reconstructed (sensor errors found removed)");
    if let Some(c) = first {
        fig = fig.split_at(c.traces.t_s.get(c.traces.split).copied().unwrap_or(f64::NAN));
    }
    for (q, m, y) in &r.compatibility.traces {
        let unit = quantity_unit(*q);
        let res: Vec<f64> = m.iter().zip(y).map(|(a, b)| a - b).collect();
        fig = fig
            .panel(
                Panel::new(format!("{q:?}"), format!("{q:?} [{unit}]"))
                    .line(Line::new("measured", &t, m, Colour::GREY))
                    .line(Line::new("reconstructed", &t, y, Colour::BLUE)),
            )
            .panel(
                Panel::new(format!("{q:?} residual"), format!("measured − reconstructed [{unit}]")).line(Line::new(
                    "residual",
                    &t,
                    &res,
                    Colour::VERMILLION,
                )),
            );
    }
    fig
}

/// The SI unit of a logged quantity, for axis labels.
fn quantity_unit(q: crate::io::measured::Quantity) -> &'static str {
    use crate::io::measured::Quantity as Q;
    match q {
        Q::AccelX | Q::AccelY | Q::AccelZ => "m/s²",
        Q::RollRate | Q::PitchRate | Q::YawRate | Q::PropSpeed => "rad/s",
        Q::RollAccel | Q::PitchAccel | Q::YawAccel => "rad/s²",
        Q::Airspeed | Q::VelocityNorth | Q::VelocityEast | Q::VelocityDown | Q::WindNorth | Q::WindEast => "m/s",
        Q::Alpha | Q::Beta | Q::Roll | Q::Pitch | Q::Yaw => "rad",
        Q::Elevator | Q::Aileron | Q::Rudder | Q::Flap => "rad",
        Q::Throttle | Q::Mach => "–",
        Q::Thrust => "N",
        Q::ThrustDifference => "N·m",
        Q::DynamicPressure => "Pa",
        Q::AirDensity => "kg/m³",
        Q::Altitude => "m",
    }
}

/// The held-out segment simulated with the baseline and the extended models: per output, the
/// measured (reconstructed) state and both simulations, and both errors.
pub fn simulation_figure(sim: &super::simulate::Simulation) -> Figure {
    simulation_figure_titled(
        sim,
        &format!(
            "held-out segment simulated with the fitted models ({:.0} s pieces, each from the measured state)",
            sim.piece_s
        ),
    )
}

/// [`simulation_figure`] with another title (the prediction of another flight).
pub fn simulation_figure_titled(sim: &super::simulate::Simulation, title: &str) -> Figure {
    let mut fig = Figure::new("time [s]").title(title);
    for (tr, o) in sim.traces.iter().zip(&sim.outputs) {
        let eb: Vec<f64> = tr.measured.iter().zip(&tr.baseline).map(|(a, b)| a - b).collect();
        let ee: Vec<f64> = tr.measured.iter().zip(&tr.extended).map(|(a, b)| a - b).collect();
        fig = fig
            .panel(
                Panel::new(
                    format!("{} measured vs simulated", tr.channel),
                    format!("{} [{}]", tr.channel, o.unit),
                )
                .line(Line::new("measured", &tr.t_s, &tr.measured, Colour::GREY))
                .line(Line::new("baseline", &tr.t_s, &tr.baseline, Colour::BLUE))
                .line(Line::new("extended", &tr.t_s, &tr.extended, Colour::VERMILLION).dashed()),
            )
            .panel(
                Panel::new(
                    format!("{} error", tr.channel),
                    format!("measured − simulated [{}]", o.unit),
                )
                .line(Line::new(
                    format!("baseline (RMS {:.2e}, R² {:.3})", o.baseline.rms, o.baseline.r2),
                    &tr.t_s,
                    &eb,
                    Colour::BLUE,
                ))
                .line(Line::new(
                    format!("extended (RMS {:.2e}, R² {:.3})", o.extended.rms, o.extended.r2),
                    &tr.t_s,
                    &ee,
                    Colour::VERMILLION,
                )),
            );
    }
    fig
}

/// Measured vs baseline and extended predictions, and both residuals, of one coefficient.
pub fn coefficient_figure(c: &CoefficientGap) -> Figure {
    let tr = &c.traces;
    let rb: Vec<f64> = tr.measured.iter().zip(&tr.baseline).map(|(a, b)| a - b).collect();
    let re: Vec<f64> = tr.measured.iter().zip(&tr.extended).map(|(a, b)| a - b).collect();
    let added: Vec<&str> = c.added.iter().map(|a| a.term.as_str()).collect();
    let t_split = tr.t_s.get(tr.split).copied().unwrap_or(f64::NAN);
    Figure::new("time [s]")
        .title(format!(
            "{}: synthesised vs predicted; added: {}",
            c.name,
            if added.is_empty() {
                "nothing".into()
            } else {
                added.join(", ")
            }
        ))
        .split_at(t_split)
        .panel(
            Panel::new(format!("{} measured vs predicted", c.name), format!("{} [–]", c.name))
                .line(Line::new("synthesised (eq. 1–2)", &tr.t_s, &tr.measured, Colour::GREY))
                .line(Line::new("baseline", &tr.t_s, &tr.baseline, Colour::BLUE))
                .line(Line::new("extended", &tr.t_s, &tr.extended, Colour::VERMILLION).dashed()),
        )
        .panel(
            Panel::new("residuals", "measured − predicted [–]")
                .line(Line::new(
                    format!("baseline (held-out RMS {:.2e})", c.baseline.validation.rms),
                    &tr.t_s,
                    &rb,
                    Colour::BLUE,
                ))
                .line(Line::new(
                    format!("extended (held-out RMS {:.2e})", c.extended.validation.rms),
                    &tr.t_s,
                    &re,
                    Colour::VERMILLION,
                )),
        )
}

/// Why the report could not be written.
#[derive(Debug)]
pub enum ReportError {
    /// A file or directory could not be written.
    Io(PathBuf, std::io::Error),
    /// JSON serialisation failed.
    Json(String),
    /// A figure failed.
    Plot(PlotError),
    /// The HTML page failed.
    Html(crate::html::HtmlError),
}

impl core::fmt::Display for ReportError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Io(p, e) => write!(f, "{}: {e}", p.display()),
            Self::Json(e) => write!(f, "JSON: {e}"),
            Self::Plot(e) => write!(f, "figure: {e}"),
            Self::Html(e) => write!(f, "report.html: {e}"),
        }
    }
}

impl std::error::Error for ReportError {}
