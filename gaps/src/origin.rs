//! What the analysis does with where a flow channel comes from ([`Origin`]): a vane, a pitot, or
//! an estimator (the autopilot's α/β from its inertial solution and wind estimate, the α-free
//! mode's wind triangle, a synthetic airspeed).
//!
//! * **No sensor errors of an estimate.** Bias, scale factor, delay and vane position describe a
//!   sensor; an estimated channel has none, so the compatibility check ([`super::compat`]) and
//!   the instrumental-variable test ([`super::instrumental`]) offer none for it
//!   ([`has_sensor_errors`]). The estimate's own error — the gust the estimator takes as zero,
//!   its lagged wind, its lag — is an error in the variable ([`estimate_errors`]): a slow error,
//!   not white, of the standard deviation the estimator states (the α-free mode's record: its
//!   wind's uncertainty and the gusts its airspeed residual shows) or, for a foreign estimator
//!   (an autopilot's `AOA`/`SSA`), the one the data allow — the force the true angle drives
//!   (`C_L` for α, `C_Y` for β) holds the part of it the estimate misses, read as the oracle reads
//!   it ([`super::oracle::angle_error_variance`], an upper bound) — with the correlation time of
//!   the angle's variation beyond its coefficient's other terms. The Monte Carlo of
//!   [`super::noise`] draws it as a first-order Gauss–Markov process per manoeuvre beside the
//!   channels' white noise, so `W_T` carries it into every column and coefficient built from the
//!   angle; PCA-GTLS then corrects the attenuation where the data bear it, and where the angle's
//!   error is most of what the manoeuvres move it the term is reported not identifiable
//!   ([`with_estimate_errors`]).
//! * **No kinematic identity named as a cause** ([`barred_terms`]). With α estimated from the
//!   inertial data, `α = θ − γ` and the lift equation `m V γ̇ = L + T sin α − m g cos γ` (Etkin &
//!   Reid, *Dynamics of Flight*, 3rd ed., §4.9, wings level) give
//!   `α̇ = q − (L + T sin α − m g cos γ)/(m V)`: `α̇` is `q` minus the measured lift, so `α̇_n` in
//!   `C_L` fits with the size of the identity, `C_L ≈ −(4m/(ρ S c̄)) α̇_n + …`, whatever the
//!   aerodynamics. Likewise `m V β̇ = Y + m g cos θ sin φ − m V (r cos α − p sin α)` (level
//!   reading of the side-force equation) makes `β̇_n` restate the measured side force in `C_Y`
//!   when β is estimated. In the other coefficients `α̇` is no identity, but it still carries the
//!   measured lift, and in turbulence that lift holds the gust's share, which an estimated α (the
//!   ground velocity less a slowly updated wind) does not see: the fit takes `α̇` for the gust's
//!   effect (a pitching moment that follows the lift), not for a downwash lag. On simulated test
//!   cards with estimated α and β and no planted effect, `α̇_n` in `C_m` and `β̇_n` in `C_l`, `C_n`
//!   passed both the `t²` and the held-out-manoeuvre tests on 5, 9 and 7 of 20 cards
//!   (docs/benchmarks.md, "Pooled manoeuvres"), so with an estimated flow angle its rate is offered
//!   in no coefficient: a real `C_mα̇` is then missed, not invented. **Reading**: every estimator
//!   of α or β this project meets works from the inertial data (GPS or navigation-filter
//!   velocity, attitude, a wind estimate), so any estimated α or β is taken as inertial.
//! * **No product that restates the drag's rotation error** ([`barred_terms`]). Drag is the
//!   measured force rotated into stability axes by α: `D = −(F_x cos α + F_z sin α)`, and
//!   `∂D/∂α = L`, so a drag synthesised with an estimated α carries `C_L·(α̂ − α)` to first
//!   order. `C_L` is linear in α and the estimate's error
//!   follows the manoeuvre (its lag on `α̇ ≈ q`, the gust share it misses), so that error has a
//!   part in `α·q_n`: `α·q_n` in `C_D` fits with a systematic value whatever the airframe. Measured
//!   on the simulated test cards, whose truth has no `α·q_n` in drag (the induced drag `C_L²` of
//!   a lift without a `q` term): its estimate over the 50 cards of the benchmark (the card with its
//!   earlier, smaller inputs) is +12.5 ± 3.4
//!   (mean ± its standard error; +23 in light turbulence, +2 in moderate, where the estimate's
//!   larger error attenuates it), and on one card (seed 7, light, flown in MANUAL) +21 ± 7 with
//!   the estimated α against +3 ± 11 with the true α in its place (docs/model-gaps.md). So with an estimated α, `α·q_n` is not
//!   offered in `C_D`: a real one (a pitch-rate lift `C_Lq` in the induced drag) is missed, not
//!   invented; with a vane it is offered.

use crate::io::measured::{MeasuredFlight, Origin, Quantity};
use std::collections::BTreeMap;

/// The flow channels whose origin the report shows, and each one's origin for the report (kept
/// with the reader's [`Origin`], which the data-quality assessment reports too).
pub use crate::io::measured::{channel_origin, FLOW_CHANNELS};

/// The library terms an estimated flow angle bars (module doc): what the synthesis records in
/// its table, so that the candidates offered leave them out.
pub use super::model::barred_terms;

/// Whether the compatibility check may offer sensor errors (bias, scale, delay, vane position)
/// of channel `q`: not when `q` is an estimate.
pub fn has_sensor_errors(flight: &MeasuredFlight, q: Quantity) -> bool {
    !flight.log.is_estimated(q)
}

/// The report's notes on the flow channels' origins: which are estimated and what the analysis
/// leaves out for them.
pub fn notes(flight: &MeasuredFlight) -> Vec<String> {
    FLOW_CHANNELS
        .iter()
        .filter(|q| flight.get(**q).is_some())
        .filter_map(|q| match flight.log.origin_of(*q) {
            Origin::Estimated { by } => Some(format!(
                "{q:?} is estimated ({by}), not measured by its own sensor: no sensor errors (bias, scale, delay{}) are tested for it, and its error is treated as an error in the variable",
                if matches!(q, Quantity::Alpha | Quantity::Beta) { ", vane position" } else { "" }
            )),
            Origin::Sensor => None,
        })
        .collect()
}

/// The slow error of an estimated flow angle as the errors-in-variables model
/// ([`super::noise`]) draws it: a first-order Gauss–Markov process (exponential autocorrelation)
/// of this standard deviation and correlation time, independent between manoeuvres.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateError {
    /// Standard deviation, rad.
    pub sd_rad: f64,
    /// Correlation time, s.
    pub correlation_time_s: f64,
    /// Where the standard deviation comes from, in words.
    pub source: String,
}

/// The estimated flow angles, each with its symbol, the baseline term it enters and the force
/// coefficient (index into [`super::model::COEFFICIENTS`]) that the true angle drives.
const ESTIMATED_ANGLES: [(Quantity, &str, super::model::Term, usize); 2] = [
    (Quantity::Alpha, "α", super::model::Term::Alpha, 0),
    (Quantity::Beta, "β", super::model::Term::Beta, 2),
];

/// The slow error of every estimated flow angle (module doc, "Estimate errors"), and the notes
/// that say what was found or why an angle's error is not modelled. `baselines` are the
/// coefficients' baseline terms; the moments are taken over the identification samples `0..n_id`
/// of `pieces`; `sg_half` is the smoothing half-width (samples), `h_s` the time step.
#[allow(clippy::too_many_arguments)]
pub fn estimate_errors(
    flight: &MeasuredFlight,
    table: &super::model::Table,
    refs: &super::model::TermRefs,
    baselines: &[Vec<super::model::Term>; 6],
    pieces: &[(usize, usize)],
    n_id: usize,
    sg_half: usize,
    h_s: f64,
) -> (BTreeMap<Quantity, EstimateError>, Vec<String>) {
    let mut out = BTreeMap::new();
    let mut notes = Vec::new();
    for (q, sym, angle, i) in ESTIMATED_ANGLES {
        if !flight.log.is_estimated(q) || flight.get(q).is_none() {
            continue;
        }
        let force = super::model::COEFFICIENTS[i];
        let Some(z) = table.z[i].as_ref() else {
            notes.push(format!("the error of the estimated {sym} is not modelled: {force} is not synthesised, and the estimate's error is read from the {force} it drives"));
            continue;
        };
        let n = n_id.min(z.len());
        let present: Vec<(super::model::Term, Vec<f64>)> = baselines[i]
            .iter()
            .filter_map(|t| t.column(table, refs).map(|c| (*t, c[..n].to_vec())))
            .collect();
        let Some(k) = present.iter().position(|(t, _)| *t == angle) else {
            notes.push(format!("the error of the estimated {sym} is not modelled: {force}'s baseline has no {sym} term to read it from"));
            continue;
        };
        let cols: Vec<Vec<f64>> = present.into_iter().map(|(_, c)| c).collect();
        let z = &z[..n];
        let white = super::signal::white_noise_sd(z).powi(2);
        // The angle's variation beyond the other baseline columns: where the estimate's error
        // matters (it dominates that variation) its autocorrelation is the error's.
        let others = super::regress::without(&cols, k);
        let partial: Vec<f64> = match super::regress::ols_theta(&others, &cols[k]) {
            Some(th) if !others.is_empty() => (0..n)
                .map(|j| cols[k][j] - others.iter().zip(&th).map(|(c, t)| c[j] * t).sum::<f64>())
                .collect(),
            _ => cols[k].clone(),
        };
        let id_pieces: Vec<(usize, usize)> = pieces
            .iter()
            .filter(|(a, _)| *a < n)
            .map(|&(a, b)| (a, b.min(n)))
            .collect();
        let angle_white = super::signal::white_noise_sd(&partial).powi(2);
        let Some(tau_s) = slow_correlation_time(&partial, angle_white, &id_pieces, sg_half, h_s) else {
            notes.push(format!("the error of the estimated {sym} is not modelled: its variation beyond {force}'s other baseline terms has no slow part to read a correlation time from"));
            continue;
        };
        let stated = flight.log.flow_angles.as_ref().and_then(|f| {
            let (sd, attitude) = match q {
                Quantity::Alpha => (f.alpha_sigma_rad, Quantity::Pitch),
                _ => (f.beta_sigma_rad, Quantity::Yaw),
            };
            let white = flight.get(attitude).map_or(0.0, super::signal::white_noise_sd);
            (f.status == "estimated" && sd.is_finite()).then(|| (sd * sd - white * white).max(0.0).sqrt())
        });
        let (sd_rad, source) = match stated {
            Some(sd) => (sd, "the α-free mode's own statement (its wind's uncertainty and the gusts its airspeed residual shows)".to_string()),
            None => match super::oracle::angle_error_variance(&cols, k, z, white) {
                Some(v) => (v.sqrt(), format!("the part of {force}'s residual above its white noise, read as the {force} the true {sym} drives and the estimate misses (an upper bound: a missing term's share is counted too)")),
                None => {
                    notes.push(format!("the error of the estimated {sym} is not modelled: its {force} term is not determined"));
                    continue;
                }
            },
        };
        notes.push(format!(
            "the estimated {sym}'s error is an error in the variable: σ = {sd_rad:.3} rad ({:.1}°) from {source}, correlated over {tau_s:.1} s (the time the estimated {sym}'s variation beyond {force}'s other terms takes to fall to 1/e of its autocorrelation beyond the smoothing window, the error's where the error dominates), drawn in the Monte Carlo's replicas and added to the errors in variables of every coefficient that can bear the correction",
            sd_rad.to_degrees()
        ));
        out.insert(
            q,
            EstimateError {
                sd_rad,
                correlation_time_s: tau_s,
                source,
            },
        );
    }
    (out, notes)
}

/// The correlation time of the slow part of a residual: beyond the smoothing window
/// (`first = 2·sg_half + 1` samples, over which the coefficient's white noise and the fast part
/// of the residual are correlated) the autocovariance `R(l)`, summed within the pieces, is taken
/// as the slow error's exponential, and the time it takes to fall from `R(first)` to
/// `R(first)/e` is its correlation time. **Reading**: the residual's fast part (the synthesised
/// coefficient's smoothed noise, the gust's high frequencies the fit leaves) is not the
/// estimate's error, which follows the wind the estimator has not caught up with. `None` when the
/// residual holds no slow part (`R(0) ≤ white`, or `R(first) ≤ 0`); the longest lag tried is half
/// the longest piece, which is the correlation time taken when `R` has not fallen by then (an
/// error nearly constant within a manoeuvre).
fn slow_correlation_time(
    residual: &[f64],
    white: f64,
    pieces: &[(usize, usize)],
    sg_half: usize,
    h_s: f64,
) -> Option<f64> {
    let whole = [(0, residual.len())];
    let pieces = if pieces.is_empty() { &whole[..] } else { pieces };
    let longest = pieces.iter().map(|(a, b)| b - a).max()?;
    let r = |l: usize| -> f64 {
        let (mut s, mut c) = (0.0, 0usize);
        for &(a, b) in pieces {
            for j in a..b.saturating_sub(l) {
                s += residual[j] * residual[j + l];
                c += 1;
            }
        }
        s / c.max(1) as f64
    };
    let first = 2 * sg_half + 1;
    let r_first = r(first);
    if r(0) <= white || r_first <= 0.0 || first >= longest / 2 {
        return None;
    }
    let lag = (first..longest / 2)
        .find(|&l| r(l) <= r_first * (-1.0f64).exp())
        .unwrap_or(longest / 2);
    Some((lag - first).max(1) as f64 * h_s)
}

/// A first-order Gauss–Markov draw of standard deviation `sd` and correlation time `tau_s` on
/// samples `h_s` apart, stationary from its first sample: `e₀ ~ N(0, sd²)`,
/// `eₖ₊₁ = φ eₖ + √(1 − φ²) sd εₖ`, `φ = exp(−h/τ)` (white for `τ = 0`).
pub fn gauss_markov<R: rand::Rng>(len: usize, sd: f64, tau_s: f64, h_s: f64, rng: &mut R) -> Vec<f64> {
    use rand_distr::{Distribution, StandardNormal};
    let phi = if tau_s > 0.0 { (-h_s / tau_s).exp() } else { 0.0 };
    let drive = sd * (1.0 - phi * phi).sqrt();
    let mut e = Vec::with_capacity(len);
    let mut x = 0.0;
    for k in 0..len {
        let w: f64 = StandardNormal.sample(&mut *rng);
        x = if k == 0 { sd * w } else { phi * x + drive * w };
        e.push(x);
    }
    e
}

/// Each coefficient's errors in variables with the estimated flow angles' slow errors added
/// (`white` plus `est`, the Monte Carlo's moments of the two, [`super::noise`]) where the data
/// can bear the correction, and the notes for the report.
///
/// An estimated angle enters its own term in every coefficient whose baseline holds it (`C_Lα`,
/// `C_mα`, `C_Dα` …; `C_Yβ`, `C_lβ`, `C_nβ`). Where the estimate's error variance `W` is most of
/// the angle's variation `v` that the coefficient's other baseline columns leave (its partial
/// variance), the reliability ratio `λ = 1 − W/v` (Fuller 1987 §1.1, §1.2.1) is near 0: the
/// least-squares slope is the true one times `λ`, and the correction divides by a `λ` known only
/// to the precision of `W`. A variance estimated from `D` independent draws has the relative
/// standard error `√(2/D)` (as for [`super::noise::WINDOW_DRAWS`]), so `λ` has the standard error
/// `(1 − λ)·√(2/D)`, `D` the replicas' independent stretches of the error (`T/(2τ)` per replica
/// over the identification time `T`, for the exponential autocorrelation of correlation time
/// `τ`). A term whose `λ` is below two of its standard errors (not told from 0 at about 95 %), or
/// whose variation is less than the analysis's excitation margin (`v < 4·W`, eq. 21 with the
/// margin of `fit::MIN_EXCITATION`: `λ < 3/4`, below which a fold of the held-out test may be left
/// with singular corrected normal equations), is **not identifiable** from the estimated angle on this flight: that coefficient keeps the
/// white-noise model (a correction by a `λ` indistinguishable from 0 leaves singular normal
/// equations and would refuse the whole baseline, whose other terms the data do determine), the
/// term is listed in [`super::noise::ColumnErrors::not_identifiable`] (the report gives its value
/// no standard error) and the report says why. Elsewhere the coefficient's `W_T` carries the
/// estimate's error and PCA-GTLS corrects the attenuation.
#[allow(clippy::too_many_arguments)]
pub fn with_estimate_errors(
    flight: &MeasuredFlight,
    table: &super::model::Table,
    refs: &super::model::TermRefs,
    baselines: &[Vec<super::model::Term>; 6],
    white: [Option<super::noise::ColumnErrors>; 6],
    est: &[Option<super::noise::ColumnErrors>; 6],
    estimate_errors: &BTreeMap<Quantity, EstimateError>,
    replicas: usize,
    n_id: usize,
    h_s: f64,
) -> ([Option<super::noise::ColumnErrors>; 6], Vec<String>) {
    let mut notes = Vec::new();
    let mut out: [Option<super::noise::ColumnErrors>; 6] = Default::default();
    for (i, (w, e)) in white.into_iter().zip(est).enumerate() {
        let (Some(w), Some(e)) = (w, e) else {
            continue;
        };
        let both = w.plus(e);
        let mut unidentifiable = Vec::new();
        for (q, sym, angle, _) in ESTIMATED_ANGLES {
            let Some(ee) = estimate_errors.get(&q).filter(|_| flight.log.is_estimated(q)) else {
                continue;
            };
            // Independent stretches of the error: `T/(2τ)` per replica for an exponential
            // autocorrelation over the identification time `T`.
            let draws = replicas as f64 * n_id as f64 * h_s / (2.0 * ee.correlation_time_s);
            let Some(r) = reliability_of(table, refs, &baselines[i], angle, &both, n_id, draws) else {
                continue;
            };
            if r.lambda < (2.0 * r.lambda_se).max(1.0 - 1.0 / super::fit::MIN_EXCITATION) {
                let name = super::model::COEFFICIENTS[i];
                notes.push(format!(
                    "{name}: the {sym} term is not identifiable from the estimated {sym} on this flight — the estimate's error variance is {:.0} % of {sym}'s variation that the other terms leave (reliability ratio λ = {:.2} ± {:.2}; a correction needs it clear of 0 by two of its standard errors and at least 0.75, the analysis's excitation margin), so a fit states the derivative times a factor the data do not pin down: its value is no estimate and gets no standard error (fly vanes, or manoeuvres that move {sym} well beyond the estimate's error)",
                    100.0 * r.error_share,
                    r.lambda,
                    r.lambda_se
                ));
                unidentifiable.push(angle);
            }
        }
        out[i] = Some(if unidentifiable.is_empty() {
            both
        } else {
            super::noise::ColumnErrors {
                not_identifiable: unidentifiable,
                ..w
            }
        });
    }
    (out, notes)
}

/// An angle term's reliability ratio in one coefficient's baseline fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reliability {
    /// The error variance over the partial variance.
    pub error_share: f64,
    /// `1 − error_share` (may be negative: the error exceeds the variation).
    pub lambda: f64,
    /// Its standard error from the Monte Carlo's precision.
    pub lambda_se: f64,
}

/// The reliability ratio of `angle`'s column among `baseline`'s columns (`None` when the
/// baseline has no such term, its columns are missing or its error is not modelled).
fn reliability_of(
    table: &super::model::Table,
    refs: &super::model::TermRefs,
    baseline: &[super::model::Term],
    angle: super::model::Term,
    e: &super::noise::ColumnErrors,
    n_id: usize,
    draws: f64,
) -> Option<Reliability> {
    let k = baseline.iter().position(|t| *t == angle)?;
    let w = e.variance(&angle);
    if e.is_exact(&angle) {
        return None;
    }
    let cols: Vec<Vec<f64>> = baseline
        .iter()
        .map(|t| t.column(table, refs).map(|c| c[..n_id.min(c.len())].to_vec()))
        .collect::<Option<_>>()?;
    let others = super::regress::without(&cols, k);
    let v = super::oracle::partial_variance(&others, &cols[k])?;
    if v.is_nan() || v <= 0.0 {
        return None;
    }
    let share = w / v;
    let lambda = 1.0 - share;
    Some(Reliability {
        error_share: share,
        lambda,
        lambda_se: share.max(0.0) * (2.0 / draws.max(1.0)).sqrt(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The draw's variance and its autocorrelation at one correlation time: the sample moments
    /// of 200 000 samples of a process correlated over 50 samples hold about 2 000 independent
    /// stretches, so the variance is within ±3.2 % (1 σ) and the autocorrelation within ±0.03:
    /// bounds of 4 σ.
    #[test]
    fn the_gauss_markov_draw_has_its_variance_and_correlation_time() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        let (sd, tau, h) = (0.1, 1.0, 0.02);
        let e = gauss_markov(200_000, sd, tau, h, &mut rng);
        let n = e.len() as f64;
        let var = e.iter().map(|x| x * x).sum::<f64>() / n;
        assert!(
            (var / (sd * sd) - 1.0).abs() < 0.13,
            "variance ratio {}",
            var / (sd * sd)
        );
        let l = (tau / h) as usize;
        let r = e.iter().zip(&e[l..]).map(|(a, b)| a * b).sum::<f64>() / (n - l as f64) / var;
        assert!((r - (-1.0f64).exp()).abs() < 0.12, "autocorrelation at τ {r}");
    }

    /// The correlation time read from a residual that holds a slow error beside white noise of
    /// twice its variance, in four pieces: the white part does not shorten it. The crossing of
    /// `1/e` is found to within the autocorrelation's scatter (±0.05 at 4 000 samples over 25-sample
    /// stretches gives ±15 % in the lag): bounds of ±35 %.
    #[test]
    fn the_slow_correlation_time_is_read_past_the_white_noise() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (h, tau) = (0.02, 0.5);
        let mut x = Vec::new();
        let mut pieces = Vec::new();
        for _ in 0..4 {
            let a = x.len();
            let slow = gauss_markov(1000, 1.0, tau, h, &mut rng);
            let white = gauss_markov(1000, 2f64.sqrt(), 0.0, h, &mut rng);
            x.extend(slow.iter().zip(&white).map(|(s, w)| s + w));
            pieces.push((a, x.len()));
        }
        let got = slow_correlation_time(&x, 2.0, &pieces, 2, h).expect("a slow part");
        assert!((got / tau - 1.0).abs() < 0.35, "correlation time {got} s for {tau} s");
        // Without a slow part there is none to read.
        let white = gauss_markov(4000, 1.0, 0.0, h, &mut rng);
        assert_eq!(slow_correlation_time(&white, 1.5, &pieces, 2, h), None);
    }
}
