//! Whether an added term's estimate agrees across manoeuvres: the judgement shared by the
//! equation-error path ([`super::fit::homogeneity_of`]) and the output-error path ([`super::oem`]),
//! each of which forms its own per-manoeuvre estimates.

use super::{select, Homogeneity, ManoeuvreEstimate};

/// The homogeneity of `term` from its per-manoeuvre estimates `per`: Cochran's Q
/// ([`select::cochran_q`]) against the χ² quantile at `level` (the held-out gain level). With
/// fewer than two manoeuvres exciting the term the agreement cannot be tested, and the term does
/// not count as agreeing.
pub(super) fn judge(term: String, per: Vec<ManoeuvreEstimate>, level: f64) -> Homogeneity {
    let est: Vec<(f64, f64)> = per.iter().map(|e| (e.value, e.sigma)).collect();
    match select::cochran_q(&est) {
        Some((q, mean, p)) => {
            let agrees = p >= level;
            let reason = if agrees {
                format!(
                    "the estimates of {} manoeuvres agree (Cochran's Q = {q:.2}, {} dof, p = {p:.3} ≥ {level})",
                    est.len(),
                    est.len() - 1
                )
            } else {
                format!(
                    "its estimates disagree across the {} manoeuvres that excite it (Cochran's Q = {q:.2}, {} dof, p = {p:.2e} < {level}): the gain is not one effect the manoeuvres share",
                    est.len(),
                    est.len() - 1
                )
            };
            Homogeneity {
                term,
                per_manoeuvre: per,
                q,
                dof: est.len() - 1,
                p,
                mean,
                agrees,
                reason,
            }
        }
        None => Homogeneity {
            term,
            q: f64::NAN,
            dof: 0,
            p: f64::NAN,
            mean: per.first().map_or(f64::NAN, |e| e.value),
            agrees: false,
            reason: format!(
                "excited in {} manoeuvre(s) only: its agreement across manoeuvres cannot be tested; more manoeuvres exciting it would decide",
                per.len()
            ),
            per_manoeuvre: per,
        },
    }
}
