//! Candidates only where they mean something: a missing control term is named as that term, never
//! as a delay of a surface the model does not have, and every named value is finite.

use aerosid::gaps::hidden::{self, HiddenEffect, HiddenKind};
use aerosid::gaps::model::CauseKind;
use aerosid::gaps::{run_gaps, GapReport, GapSettings};

#[test]
fn a_missing_adverse_yaw_term_is_named_as_itself_not_as_an_aileron_delay() {
    // GIVEN a short (30 s) turbulent simulated flight with adverse yaw C_nδa = −0.01 and the
    // campaign's C_n baseline without δa (`aerosid gaps --simulate adverse-yaw --seed 4 --size
    // -0.01 --seconds 30`): on this flight δȧ alone fits C_n better than δa alone (t² 130
    // against 81), so a selection that offered the aileron rate without the aileron named
    // "delay(δa) NaN s"
    let effect = HiddenEffect {
        kind: HiddenKind::AdverseYaw,
        size: -0.01,
        channel: None,
    };
    // WHEN the gap analysis runs
    let (r, summary) = analyse_planted(&effect, 30.0, 4);
    // THEN no aileron delay is named, C_n δa is, and every named value and σ is finite
    assert!(
        !r.named
            .iter()
            .any(|c| c.kind == CauseKind::ControlDelay && c.location == "Aileron"),
        "{summary:#?}"
    );
    assert!(
        r.named.iter().any(|c| c.location == "C_n" && c.what == "δa"),
        "{summary:#?}"
    );
    assert!(
        r.named.iter().all(|c| c.value.is_finite() && c.sigma.is_finite()),
        "{summary:#?}"
    );
    // and its estimate is the planted one within 4σ (the entry threshold at this flight's
    // Bonferroni level is about t = 4.5, so a named term is at least that far from zero)
    let cn = r.named.iter().find(|c| c.what == "δa").expect("named");
    assert!((cn.value - effect.size).abs() < 4.0 * cn.sigma, "{summary:#?}");
    // and the δȧ candidate of C_n, never offered without δa, is either scored after δa entered
    // or says why it waited
    let c_n = r.coefficients.iter().find(|c| c.name == "C_n").expect("C_n analysed");
    let rate = c_n.candidates.iter().find(|c| c.term == "δȧ").expect("listed");
    assert!(
        rate.reason.as_deref().is_none_or(|w| !w.contains("NaN")),
        "{:?}",
        rate.reason
    );
}

/// A turbulent simulated flight of `seconds` with `effect` planted (seed `seed`), analysed with
/// the campaign's baseline for it; the report and its named causes as lines.
pub(crate) fn analyse_planted(effect: &HiddenEffect, seconds: f64, seed: u64) -> (GapReport, Vec<String>) {
    let flight = hidden::flight(Some(effect), seconds, seed, true).expect("the simulator flies");
    let settings = GapSettings {
        baseline: Some(HiddenEffect::baseline(Some(effect))),
        ..GapSettings::default()
    };
    let r = run_gaps(&flight, &settings).expect("the analysis runs");
    let summary = r
        .named
        .iter()
        .map(|c| format!("{:?} {} {} = {} ± {}", c.kind, c.location, c.what, c.value, c.sigma))
        .collect();
    (r, summary)
}
