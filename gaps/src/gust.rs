//! When an estimated flow angle errs by more than the manoeuvres move it, the force coefficient
//! that angle drives is not identifiable from the manoeuvres: its candidates are not tested, and
//! the report says by how much the angle errs.
//!
//! An autopilot's α and β are the ground velocity less a slowly updated wind estimate
//! ([`super::origin`]); the gust the estimate has not followed is their error, `α̂ = α − α_g`.
//! That error is not white: it is the turbulence itself (Dryden, a low-pass of the gust's scale
//! over the airspeed), so `C_L` fitted on `α̂` keeps in its residual `C_Lα·α_g` — a coloured,
//! unmodelled signal as large as the lift's response to the manoeuvre when `α_g` is as large as
//! the manoeuvre's α. The autopilot's loops answer the same gust (the throttle and the airspeed
//! the energy it adds, the elevator the pitch it causes), so terms built from those channels
//! correlate with it, on held-out manoeuvres too: on the simulated clean test cards in light
//! turbulence `C_T` and `ΔV/V` passed both tests in `C_L` (docs/test-card.md). No test against
//! white or block-coloured noise tells such a term from the gust, and the flight holds no other
//! measurement of the gust than that residual.
//!
//! **Reading chosen.** The oracle takes the estimated angle's error from the force it drives
//! ([`super::oracle`]: `C_L` for α, `C_Y` for β, the whole residual above the coefficient's noise
//! blamed on the angle, an upper bound), `σ_e² = E·v/(â²v + E)` with `E` that excess, `â` the
//! fitted slope and `v` the angle column's variance not explained by the other baseline columns
//! (Fuller 1987 §1.1, the classical error model). The reliability ratio `λ = 1 − σ_e²/v =
//! â²v/(â²v + E)` is then the share of the coefficient's variation beyond the other columns that
//! the estimated angle explains, against the share the angle's error leaves. When `λ < 1/2`
//! ([`MIN_TESTABLE_RELIABILITY`]) the angle errs by more than the manoeuvres move it
//! (`σ_e² > v − σ_e²`): the residual of that coefficient is then mostly the gust, and a
//! candidate's gain there measures its correlation with the gust as much as an effect, so the
//! coefficient's candidates are not tested. The rule applies to the coefficient the error is
//! taken from (`C_L`, `C_Y`), where the reading above puts the whole excess on the angle; the
//! other coefficients keep their tests (there the gust's share is the angle's slope in them
//! times its error, which the data do not bound: measured, see docs/test-card.md). With vanes
//! (`σ_e = 0`) nothing changes.
//!
//! Where the gust acts on another coefficient through the estimated angle, that coefficient's
//! candidates are tested beyond the gust's only measurement, the force's residual ([`proxies`],
//! [`Beyond`]): the residual enters as a nuisance column (partialled out, Frisch–Waugh–Lovell),
//! so a candidate counts only for what it predicts beyond the gust. The proxy is no term and is
//! never named.

use crate::model::{Table, Term, TermRefs, COEFFICIENTS};
use crate::oracle::{self, FlightOracle};
use crate::regress;

/// The least reliability ratio of an estimated angle for the candidates of the coefficient it
/// drives to be tested: below one half the angle's error exceeds the manoeuvres' variation.
pub const MIN_TESTABLE_RELIABILITY: f64 = 0.5;

/// What an estimated angle's error leaves in the coefficient it drives.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleError {
    /// The angle's name.
    pub angle: &'static str,
    /// The error's standard deviation, rad (the oracle's).
    pub error_sd: f64,
    /// The true angle's standard deviation not explained by the other baseline columns, rad.
    pub manoeuvre_sd: f64,
    /// The reliability ratio `λ = 1 − σ_e²/v` (0 when the error exceeds `v`).
    pub reliability: f64,
}

impl AngleError {
    /// The estimated angle of coefficient `i` (α in `C_L`, β in `C_Y`) in its baseline
    /// `terms`/`cols` (every sample, as the oracle takes them); `None` for the other
    /// coefficients, without the angle's term, or when the angle is measured (error SD 0).
    pub fn of(i: usize, terms: &[Term], cols: &[Vec<f64>], flight_oracle: &FlightOracle) -> Option<Self> {
        let (angle, name, sd) = match i {
            0 => (Term::Alpha, "α", flight_oracle.angle_sd[0]),
            2 => (Term::Beta, "β", flight_oracle.angle_sd[1]),
            _ => return None,
        };
        let k = terms.iter().position(|t| *t == angle).filter(|_| sd > 0.0)?;
        let others = regress::without(cols, k);
        let v = oracle::partial_variance(&others, &cols[k])?;
        (v.is_finite() && v > 0.0).then(|| Self {
            angle: name,
            error_sd: sd,
            manoeuvre_sd: (v - sd * sd).max(0.0).sqrt(),
            reliability: (1.0 - sd * sd / v).max(0.0),
        })
    }

    /// Whether the error exceeds the manoeuvres' variation ([`MIN_TESTABLE_RELIABILITY`]).
    pub fn dominates(&self) -> bool {
        self.reliability < MIN_TESTABLE_RELIABILITY
    }

    /// The verdict of coefficient `i` when its candidates are not tested.
    pub fn verdict(&self, i: usize) -> String {
        let n = self.angle;
        format!(
            "not identifiable from these manoeuvres: the estimated {n} errs by up to {:.2}° RMS (the {c} residual above its noise, an upper bound) against {:.2}° RMS of manoeuvre {n} beyond the other baseline terms (reliability {:.2} < {MIN_TESTABLE_RELIABILITY}), so {c} holds the gust the estimate misses more than the manoeuvre's response, and a candidate's gain there cannot be told from the gust's: none is tested (the candidates are scored for the record only)",
            self.error_sd.to_degrees(),
            self.manoeuvre_sd.to_degrees(),
            self.reliability,
            c = COEFFICIENTS[i]
        )
    }
}

/// Where each estimated angle's gust proxy enters: `(coefficient the proxy is taken from,
/// coefficient whose candidates are tested beyond it)`. The lift's residual (the gust the
/// estimated α misses, `C_Lα·(α − α̂)`) enters the drag, which is synthesised by rotating the
/// measured force through α̂ and so carries the lift times that same error; the side force's
/// residual (the β gust) enters the rolling moment. **Reading chosen, measured**
/// (docs/test-card.md): the pitching and yawing moments get no proxy. In `C_n`, whose baseline
/// has no δa, the side force's misfit of its own δa term passes through the proxy into the
/// candidate δa (named on 16 of 20 clean cards); in `C_m` the lift's residual named α·q_n on a
/// clean card and missed a planted thrust moment (`C_T` in `C_m`) named without it.
pub const PROXY_TARGETS: [(usize, usize); 2] = [(0, 1), (2, 3)];

/// The gust proxies of a flight, `(coefficient whose candidates they judge, column)`
/// ([`PROXY_TARGETS`]): for each estimated angle, the baseline residual of the force coefficient
/// it drives (`C_L` for α, `C_Y` for β). The flight holds no other measurement of the gust the
/// estimate misses: the residual is that gust through the angle's slope, plus the force's noise
/// and any effect missing from its baseline.
///
/// A proxy enters a coefficient only when every term of its own baseline is in that
/// coefficient's baseline: what the proxy's fit leaves of those terms is then absorbed by the
/// coefficient's baseline and cannot pass into a candidate. The residual's baseline is fitted on
/// the identification samples only (the first `n_id`), sample by sample with no smoothing (so
/// nothing crosses a manoeuvre's join), centred on those samples and scaled to unit RMS there.
pub fn proxies(
    table: &Table,
    refs: &TermRefs,
    baselines: &[Vec<Term>; 6],
    n_id: usize,
    flight_oracle: &FlightOracle,
) -> Vec<(usize, Vec<f64>)> {
    PROXY_TARGETS
        .into_iter()
        .filter(|(from, to)| {
            let sd = flight_oracle.angle_sd[usize::from(*from == 2)];
            sd > 0.0 && baselines[*from].iter().all(|t| baselines[*to].contains(t))
        })
        .filter_map(|(from, to)| {
            Some((
                to,
                residual(table.z[from].as_ref()?, &baselines[from], table, refs, n_id)?,
            ))
        })
        .collect()
}

/// The residual of `z` on the columns of `terms` fitted on the first `n_id` samples, over every
/// sample, centred and scaled to unit RMS on those samples; `None` when a column is missing or the
/// fit fails.
fn residual(z: &[f64], terms: &[Term], table: &Table, refs: &TermRefs, n_id: usize) -> Option<Vec<f64>> {
    let cols: Vec<Vec<f64>> = terms.iter().map(|t| t.column(table, refs)).collect::<Option<_>>()?;
    let n_fit = n_id.min(z.len());
    let id: Vec<Vec<f64>> = cols.iter().map(|c| c[..n_fit].to_vec()).collect();
    let theta = regress::ols_theta(&id, &z[..n_fit])?;
    let r: Vec<f64> = (0..z.len())
        .map(|k| z[k] - cols.iter().zip(&theta).map(|(c, th)| c[k] * th).sum::<f64>())
        .collect();
    let mean = r[..n_fit].iter().sum::<f64>() / n_fit as f64;
    let rms = (r[..n_fit].iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n_fit as f64).sqrt();
    (rms.is_finite() && rms > 0.0).then(|| r.iter().map(|x| (x - mean) / rms).collect())
}

/// A coefficient's regression with the gust proxies partialled out (Frisch–Waugh–Lovell): the
/// output and every column less its projection on the proxies, the projection fitted on the
/// identification samples. A candidate's estimate is then the one it would have beside the proxies
/// as nuisance columns, and its tests count only what it predicts beyond the gust; the proxies
/// are no terms, never named. Constant columns (the ones) are left as they are: the proxies are
/// centred on the fitted samples, so their projection there is zero.
pub struct Beyond {
    /// The output.
    pub z: Vec<f64>,
    /// The baseline's columns.
    pub base: Vec<Vec<f64>>,
    /// The candidates' columns.
    pub library: Vec<(Term, Vec<f64>)>,
}

impl Beyond {
    /// The regression of coefficient `i` (output `z`, baseline `base`, candidates `library`)
    /// beyond the proxies that enter it ([`proxies`]); `None` when there is none.
    pub fn new(
        i: usize,
        proxies: &[(usize, Vec<f64>)],
        z: &[f64],
        base: &[Vec<f64>],
        library: &[(Term, Vec<f64>)],
        n_id: usize,
    ) -> Option<Self> {
        let p: Vec<&[f64]> = proxies
            .iter()
            .filter(|(to, c)| *to == i && c.len() == z.len())
            .map(|(_, c)| c.as_slice())
            .collect();
        if p.is_empty() {
            return None;
        }
        let n_fit = n_id.min(z.len());
        let id: Vec<Vec<f64>> = p.iter().map(|c| c[..n_fit].to_vec()).collect();
        let partial = |c: &[f64]| -> Vec<f64> {
            let constant = c.iter().all(|x| *x == c[0]);
            match regress::ols_theta(&id, &c[..n_fit]).filter(|_| !constant) {
                Some(g) => (0..c.len())
                    .map(|k| c[k] - p.iter().zip(&g).map(|(q, gj)| q[k] * gj).sum::<f64>())
                    .collect(),
                None => c.to_vec(),
            }
        };
        Some(Self {
            z: partial(z),
            base: base.iter().map(|c| partial(c)).collect(),
            library: library.iter().map(|(t, c)| (*t, partial(c))).collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// `C_L = 1 + 6.5·α` fitted on `[1, α̂]`, `α̂ = α + e`, α of SD 0.02 rad and `e` of SD `sd_e`
    /// (white, independent): the oracle's error of α taken from it, then the [`AngleError`].
    fn lift(sd_e: f64, seed: u64) -> AngleError {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let n = 4000;
        let (mut z, mut alpha_m) = (Vec::new(), Vec::new());
        for _ in 0..n {
            let (alpha, e) = (0.02 * nd.sample(&mut rng), sd_e * nd.sample(&mut rng));
            z.push(1.0 + 6.5 * alpha);
            alpha_m.push(alpha + e);
        }
        let cols = vec![vec![1.0; n], alpha_m];
        let var = oracle::angle_error_variance(&cols, 1, &z, 0.0).unwrap();
        let oracle = FlightOracle {
            angle_sd: [var.sqrt(), 0.0],
            ..FlightOracle::default()
        };
        AngleError::of(0, &[Term::One, Term::Alpha], &cols, &oracle).unwrap()
    }

    /// The error twice the manoeuvre's α (reliability 0.2): `C_L` is not tested. The error's SD
    /// comes back from the residual (0.04), the manoeuvre's α (0.02) and `λ` (0.2). Tolerances:
    /// 10 % of each, several times the ≈ 2 % scatter of variances from 4000 samples.
    #[test]
    fn an_angle_error_larger_than_the_manoeuvre_bars_the_lift_candidates() {
        let a = lift(0.04, 1);
        assert!((a.error_sd - 0.04).abs() < 0.004, "{a:?}");
        assert!((a.manoeuvre_sd - 0.02).abs() < 0.002, "{a:?}");
        assert!((a.reliability - 0.2).abs() < 0.02 && a.dominates(), "{a:?}");
        assert!(a.verdict(0).starts_with("not identifiable from these manoeuvres"));
    }

    /// The error half the manoeuvre's α (reliability 0.8): `C_L` is tested.
    #[test]
    fn a_small_angle_error_keeps_the_lift_candidates_tested() {
        let a = lift(0.01, 2);
        assert!((a.reliability - 0.8).abs() < 0.05 && !a.dominates(), "{a:?}");
    }

    /// A candidate that follows the gust (`c = g + w`) but has no effect of its own: regressed
    /// with the gust in the output (`z = 2x + g + n`) it takes a slope near one; beyond the
    /// gust's proxy (`g` plus its own noise, from another coefficient) the slope falls to a
    /// fraction of that, and the baseline's `x` keeps its slope. A coefficient the proxy does not
    /// enter is left as it is. Expected: 0.8 before (`cov(g, c)/var(c)`); after, with the proxy's
    /// noise (SD 0.1 against the gust's 1), ≈ 0.04 (that noise, partialled out of both, is what
    /// they then share). Tolerances: 0.15 and 0.1, several times the ≈ 0.01–0.02 scatter of these
    /// slopes with 4000 samples.
    #[test]
    fn a_candidate_that_follows_the_gust_counts_nothing_beyond_its_proxy() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let n = 4000;
        let (mut x, mut g, mut c, mut z, mut proxy) = (vec![], vec![], vec![], vec![], vec![]);
        for _ in 0..n {
            let (xi, gi) = (nd.sample(&mut rng), nd.sample(&mut rng));
            x.push(xi);
            g.push(gi);
            c.push(gi + 0.5 * nd.sample(&mut rng));
            z.push(2.0 * xi + gi + 0.1 * nd.sample(&mut rng));
            proxy.push(gi + 0.1 * nd.sample(&mut rng));
        }
        let slopes = |z: &[f64], x: &[f64], c: &[f64]| regress::ols_theta(&[x.to_vec(), c.to_vec()], z).unwrap();
        let before = slopes(&z, &x, &c);
        assert!((before[1] - 0.8).abs() < 0.15, "{before:?}");
        let library = vec![(Term::Thrust, c.clone())];
        let proxies = vec![(1usize, proxy)];
        let b = Beyond::new(1, &proxies, &z, &[x.clone()], &library, n).unwrap();
        let after = slopes(&b.z, &b.base[0], &b.library[0].1);
        assert!(after[1].abs() < 0.1 && (after[0] - 2.0).abs() < 0.15, "{after:?}");
        assert!(Beyond::new(4, &proxies, &z, &[x], &library, n).is_none());
    }

    /// With a vane (error SD 0), and in a coefficient the angle does not drive, nothing.
    #[test]
    fn a_measured_angle_or_another_coefficient_gives_nothing() {
        let cols = vec![vec![1.0; 3], vec![0.1, 0.2, 0.4]];
        let terms = [Term::One, Term::Alpha];
        assert!(AngleError::of(0, &terms, &cols, &FlightOracle::default()).is_none());
        let oracle = FlightOracle {
            angle_sd: [0.05, 0.0],
            ..FlightOracle::default()
        };
        assert!(AngleError::of(0, &terms, &cols, &oracle).is_some());
        assert!(AngleError::of(4, &terms, &cols, &oracle).is_none());
    }
}
