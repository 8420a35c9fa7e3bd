//! Stage 7: the causes named (sensor errors first, then the aerodynamic terms, each list by its
//! final partial `t²`), the data-quality assessment against what the analysis found, the verdict,
//! and the [`GapReport`].

use super::compatibility::Compatible;
use super::prepare::Prepared;
use super::selection::Selected;
use super::synthesis::Synthesised;
use super::validation::Validated;
use crate::model::CauseKind;
use crate::{family, origin, param_kind, quality, select, Added, CoefficientGap, GapReport, GapSettings, NamedCause};

/// The report of the pass.
#[allow(clippy::too_many_arguments)]
pub fn assemble(
    prepared: Prepared,
    compatible: Compatible,
    syn: Synthesised,
    selected: Selected,
    validated: Validated,
    settings: &GapSettings,
    mut notes: Vec<String>,
) -> GapReport {
    let flight = &prepared.flight;
    let plan = &prepared.plan;
    let mut coefficients = selected.coefficients;
    let mut named = named_causes(&compatible, &coefficients);
    // An estimated channel has no sensor errors: the compatibility check offers none
    // (`origin::has_sensor_errors`); the notes say so.
    notes.extend(origin::notes(flight));
    if let Some(note) = manoeuvres_note(validated.manoeuvres.len()) {
        notes.insert(0, note);
    }
    let mut data_quality = quality::assess(flight);
    if selected.low_rate {
        // The rate is what the low-rate path answers; every other reason stands.
        data_quality
            .why_not
            .retain(|r| !(r.starts_with("the time base is") && r.contains("needs at least")));
        data_quality.supports_verdict = data_quality.why_not.is_empty();
    }
    quality::after_analysis(&mut data_quality, &coefficients, &syn.regression);
    let verdict = if data_quality.supports_verdict {
        overall_verdict(&named, &coefficients)
    } else {
        named.clear();
        // The coefficients' own verdicts rest on the same data: none of them stands either.
        for c in &mut coefficients {
            c.verdict = format!(
                "no verdict (the data cannot support one: see the data quality); as computed: {}",
                c.verdict
            );
        }
        format!("no verdict: {}", data_quality.why_not.join("; "))
    };
    let air_data = notes
        .iter()
        .find(|n| n.starts_with("air data:"))
        .cloned()
        .unwrap_or_default();
    let (t, n, n_id) = (&flight.t_s, flight.len(), plan.n_id);
    GapReport {
        source: flight.source.clone(),
        aircraft: flight.aircraft.name.clone(),
        identification_s: [t[0], t[n_id - 1]],
        validation_s: [t[n_id], t[n - 1]],
        candidates_tested: plan.m,
        threshold_t2: plan.threshold_t2,
        threshold_blocks: plan.threshold_blocks,
        settings: settings.clone(),
        compatibility: compatible.compatibility,
        coefficients,
        simulation: validated.simulation,
        named,
        notes,
        air_data,
        corrections_applied: validated.corrections_applied,
        as_logged: validated.as_logged,
        verdict,
        regression: syn.regression,
        data_quality,
        refs: syn.refs,
        manoeuvres: validated.manoeuvres,
    }
}

/// The causes named: the sensor errors the compatibility check found, then the terms added to
/// the coefficients, each list by the partial `t²` of the cause in the final joint fit (the entry
/// order depends on the path of the selection); a surface's delays merged into one cause.
fn named_causes(compatible: &Compatible, coefficients: &[CoefficientGap]) -> Vec<NamedCause> {
    let mut named: Vec<NamedCause> = compatible
        .compatibility
        .found
        .iter()
        .map(|f| NamedCause {
            kind: param_kind(&f.param),
            location: format!("{:?}", f.param.channel()),
            what: f.param.name(),
            t2: t2_of(f.value, f.sigma),
            value: f.value,
            sigma: f.sigma,
            family: None,
            entry: None,
        })
        .collect();
    let mut aero: Vec<NamedCause> = coefficients
        .iter()
        .flat_map(|c| c.added.iter().filter_map(move |a| named_aero(c, a)))
        .collect();
    let final_t2 = |c: &NamedCause| if c.t2.is_finite() { c.t2 } else { -1.0 };
    named.sort_by(|a, b| final_t2(b).total_cmp(&final_t2(a)));
    aero.sort_by(|a, b| final_t2(b).total_cmp(&final_t2(a)));
    // A surface has one delay, though several coefficients may show it: one cause per surface,
    // the strongest, with what the others found.
    for c in aero {
        if c.kind == CauseKind::ControlDelay {
            if let Some(first) = named
                .iter_mut()
                .find(|m| m.kind == CauseKind::ControlDelay && m.location == c.location)
            {
                first.what.push_str(&format!("; also {}", c.what));
                continue;
            }
        }
        named.push(c);
    }
    named
}

/// The note on pooled manoeuvres and how they are held out; `None` for one record.
fn manoeuvres_note(count: usize) -> Option<String> {
    if count <= 1 {
        return None;
    }
    let folds = if count >= select::MIN_PIECES_FOR_FOLDS {
        "the held-out data are whole manoeuvres (leave one manoeuvre out; the first fits of the baselines on the manoeuvres before the identification split, the rest held out), and an added term must agree across the manoeuvres that excite it (Cochran's Q at the held-out gain level)".to_string()
    } else {
        format!(
            "fewer than {} manoeuvres: a whole manoeuvre cannot be held out, so the held-out data are time blocks within each manoeuvre as for one record",
            select::MIN_PIECES_FOR_FOLDS
        )
    };
    Some(format!(
        "{count} manoeuvres pooled, each its own piece (smoothing, derivatives and the flight-path reconstruction's initial states per manoeuvre, never across a join); {folds}"
    ))
}

/// A term added to a coefficient, as a named cause; `None` when a value it would name cannot be
/// computed (not finite). A surface-rate term is a time delay of that surface:
/// `C_δ·δ(t−τ) ≈ C_δ·δ − C_δτ·δ̇`, so `τ = −θ_δ̇/θ_δ` with `θ_δ` from the same fit (the selection
/// offers the rate only with its surface in the model, [`family`]). Its σ by the delta method,
/// `Var τ = (σ_δ̇² + τ²σ_δ² + 2τ·cov)/θ_δ²`, with the covariance bounded by `|cov| ≤ σ_δ̇σ_δ`
/// (Cauchy–Schwarz; the fit reports standard errors, not the covariance): `σ_τ = (σ_δ̇ +
/// |τ|σ_δ)/|θ_δ|`, an upper bound. The exact-shift delay, when found, takes the same σ.
fn named_aero(c: &CoefficientGap, a: &Added) -> Option<NamedCause> {
    let surface = match a.term.as_str() {
        "δė" => Some(("Elevator", "δe")),
        "δȧ" => Some(("Aileron", "δa")),
        "δṙ" => Some(("Rudder", "δr")),
        _ => None,
    };
    let family = a.family.as_ref().map(family::FamilyChoice::describe);
    if let Some((loc, sym)) = surface {
        let d = c.extended.parameters.iter().find(|p| p.term == sym)?;
        let first_order = -a.value / d.value;
        let tau = a.exact_delay_s.unwrap_or(first_order);
        // σ of τ by the delta method with the unknown covariance of the pair bounded: an upper
        // bound, never smaller than the rate term's own relative error gives.
        let sigma = (a.sigma + tau.abs() * d.sigma) / d.value.abs();
        if !(tau.is_finite() && sigma.is_finite()) {
            return None;
        }
        let how = match a.exact_delay_s {
            Some(_) => format!("exact shift; first order {first_order:.3} s from"),
            None => "from".to_string(),
        };
        return Some(NamedCause {
            kind: a.kind,
            location: loc.into(),
            what: format!(
                "delay({sym}) {:.3} ± {:.3} s ({how} {} {} = {:+.4}, {sym} = {:+.4})",
                tau, sigma, c.name, a.term, a.value, d.value
            ),
            t2: t2_of(tau, sigma),
            value: tau,
            sigma,
            family,
            entry: Some((a.t2, c.threshold_t2)),
        });
    }
    (a.value.is_finite() && a.sigma.is_finite()).then(|| NamedCause {
        kind: a.kind,
        location: c.name.clone(),
        what: a.term.clone(),
        t2: t2_of(a.value, a.sigma),
        value: a.value,
        sigma: a.sigma,
        family,
        entry: Some((a.t2, c.threshold_t2)),
    })
}

/// `(value/σ)²`, the partial `t²` of an estimate in the fit it comes from; NaN when `σ` is not a
/// finite positive number (the fit does not determine it).
fn t2_of(value: f64, sigma: f64) -> f64 {
    if sigma.is_finite() && sigma > 0.0 && value.is_finite() {
        (value / sigma).powi(2)
    } else {
        f64::NAN
    }
}

/// The report's conclusion in one sentence.
fn overall_verdict(named: &[NamedCause], coefficients: &[CoefficientGap]) -> String {
    let unpredicted: Vec<&str> = coefficients
        .iter()
        .filter(|c| {
            c.verdict.starts_with("the model does not predict") || c.verdict.starts_with("not identifiable from these")
        })
        .map(|c| c.name.as_str())
        .collect();
    let undecided: Vec<&str> = coefficients
        .iter()
        .filter(|c| c.verdict.starts_with("not decided"))
        .map(|c| c.name.as_str())
        .collect();
    let mut tail = String::new();
    if !unpredicted.is_empty() {
        tail += &format!(
            "; {} not predicted by the model, so their causes are not identifiable from this flight",
            unpredicted.join(", ")
        );
    }
    if !undecided.is_empty() {
        tail += &format!(
            "; {}: a candidate is significant but this flight cannot confirm it on held-out data (see the verdicts)",
            undecided.join(", ")
        );
    }
    match named.first() {
        None if tail.is_empty() => "nothing missing: the baseline predicts the held-out data within noise".to_string(),
        None => format!("no cause named{tail}"),
        Some(top) => format!(
            "{} cause{} named, top: {:?} in {}: {}{}{tail}",
            named.len(),
            if named.len() == 1 { "" } else { "s" },
            top.kind,
            top.location,
            top.what,
            top.family.as_ref().map(|f| format!(" — {f}")).unwrap_or_default()
        ),
    }
}
