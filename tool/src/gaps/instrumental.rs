//! Scale factors and time delays of the flow-angle vanes in turbulence, by instrumental
//! variables.
//!
//! ## Why the output-error check cannot do it
//! A vane measures the flow angle of the air, gusts included; the flight-path reconstruction of
//! [`super::compat`] gives the inertial one (steady air). Their difference `d = α_m − α_kin` is the
//! gust plus the sensor error. But the gust is not independent of `α_kin`: the aircraft responds to
//! it, so a least-squares fit of `d` on `α_kin` (a scale factor) or on `α̇_kin` (a delay) finds
//! "errors" on flights with perfect vanes (on the campaign's clean turbulent flights
//! `scale(α)` and `delay(α)` with `t²` 55–250), and [`super::compat`] refuses them.
//!
//! ## Method
//! Two-stage least squares (Söderström & Stoica, *System Identification*, 1989, ch. 8, the basic
//! IV estimator; Klein & Morelli 2006 §5.3 on errors in the regressors): the **instruments** are
//! the logged control deflections — the manoeuvre, not the gusts, moves them — each passed
//! through a bank of [`ORDERS`] discrete Laguerre filters with time constant [`LAGUERRE_T_S`]
//! (Wahlberg 1991: an orthonormal basis of the aircraft's response to the control over a few
//! seconds, far fewer columns than a finite impulse response of the same memory). The first stage
//! projects `α_kin` on them: `α̂` is the part of the inertial flow angle that the controls
//! explain, independent of the gusts. The second stage regresses `d` on `α̂` (scale `k`) and on
//! `−dα̂/dt` (delay `τ`; `α_m(t) = (1+k)α(t−τ) ≈ α + kα − τα̇`). Under "perfect vane" `d` is the
//! gust, independent of both columns, so the regression is an ordinary one with coloured noise:
//! the same statistics as the aerodynamic selection ([`super::select`]) hold — partial `t²` with
//! the block sandwich against Student t, and the held-out gain against the noise of the held-out
//! residuals ([`super::select::Design::noise_gain`]) — at the compatibility check's level.
//!
//! **Band**: the regression runs on the signals high-passed at [`BAND_HZ`] (zero-phase). The
//! logged deflections also carry any stabiliser's or pilot's response to the gusts (a feedback
//! makes the instruments correlated with the noise, the one thing an instrument must not be); that
//! response, like most of the gust energy, sits at the low frequencies of the attitude loops and
//! the phugoid, while the manoeuvre's pulses (0.5–1 s) put their energy above. Measured with the
//! prototype of this check on the campaign's 10 clean simulated flights and JSBSim's 4 clean
//! flights (both flown with a weak attitude-hold): at 0.1 Hz `scale(α)` came out −0.04 (sim) and
//! −0.15…−0.39 (JSBSim, `t` to −3.9) on perfect vanes; at 0.6 Hz every clean estimate was within
//! `|t|` 2.3 of zero, while the planted scale factors −0.135 and −0.125 came out −0.145 ± 0.031 and
//! −0.110 ± 0.028 and the planted delays 0.143 s and 0.117 s at `t` 13 and 11.
//!
//! **Delay**: its test uses the first-order column `−α̂̇`; once it enters, its value is the exact
//! delay `τ` minimising the residual of `d = (1+k)α̂(t−τ) − α̂(t)` (a search over the plausible
//! range), since the first-order form underestimates delays of a tenth of the pulse length and
//! leaves a spurious scale factor beside them — so a scale tested after the delay is tested on
//! `d − (α̂(t−τ) − α̂(t))` with the column `α̂(t−τ)`. The σ reported for the delay is the
//! first-order one.
//!
//! **Not done**: the airspeed channel (its control-driven part is the throttle's and the phugoid's,
//! at the low frequencies this band removes), the vane position (its column `q̂/V` is the pitch
//! rate, which the gusts move as much as the controls do), biases (a gust has no mean: the
//! output-error check identifies them in turbulence). When the controls explain less than
//! [`MIN_FIRST_STAGE_R2`] of the flow angle's variance the channel is not tested and the note says
//! so: weak instruments make the estimator fall back towards least squares, with its bias.

use super::compat::{Found, ParamScore, SensorParam};
use super::select::{self, CvSettings, Design, SubsetFit};
use super::signal::derivative;
use crate::io::measured::{MeasuredFlight, Quantity};

/// Laguerre orders per control.
pub const ORDERS: usize = 8;
/// Time constant of the Laguerre filters, s (the bank spans about `ORDERS · T` of memory).
pub const LAGUERRE_T_S: f64 = 0.5;
/// High-pass corner of the second stage, Hz.
pub const BAND_HZ: f64 = 0.6;
/// Least share of the flow angle's variance the controls must explain for the channel to be tested.
pub const MIN_FIRST_STAGE_R2: f64 = 0.2;
/// The range searched for the exact delay, s (the plausible range of [`SensorParam::plausible`]).
const DELAY_RANGE_S: f64 = 0.5;

/// The outcome for one channel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ChannelCheck {
    /// First-round scores of the channel's candidates (scale, delay).
    pub tested: Vec<ParamScore>,
    /// Errors named: significant and improving the held-out fit beyond noise.
    pub found: Vec<Found>,
    /// Errors significant but not improving the held-out fit beyond noise.
    pub rejected: Vec<Found>,
    /// What was done, on which instruments, and the first stage's R².
    pub note: String,
}

/// The statistics' settings: the per-test two-sided level (the compatibility check's family-wise
/// level divided by its candidates) and the blocks and folds of the held-out test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IvSettings {
    /// Two-sided level of each partial test.
    pub level: f64,
    /// Blocks, folds and the level of the held-out test.
    pub cv: CvSettings,
}

/// A candidate's entry statistics: `(t², sign-flip z, relative held-out gain, T)`.
type Score = (f64, f64, f64, f64);

/// The controls used as instruments, in this order.
const CONTROLS: [Quantity; 4] = [
    Quantity::Elevator,
    Quantity::Aileron,
    Quantity::Rudder,
    Quantity::Throttle,
];

/// The instruments of a flight: a constant, then per varying control its deviation from the mean
/// and its [`ORDERS`] Laguerre outputs. Also the names of the controls used.
fn instruments(flight: &MeasuredFlight, n: usize, h_s: f64) -> (Vec<Vec<f64>>, Vec<Quantity>) {
    let mut z = vec![vec![1.0; n]];
    let mut used = Vec::new();
    let a = (-h_s / LAGUERRE_T_S).exp();
    let gain = (1.0 - a * a).sqrt();
    for q in CONTROLS {
        let Some(u) = flight.get(q).filter(|u| u.len() == n) else {
            continue;
        };
        let m = u.iter().sum::<f64>() / n as f64;
        let u: Vec<f64> = u.iter().map(|v| v - m).collect();
        if u.iter().map(|v| v * v).sum::<f64>() <= 1e-12 * n as f64 {
            continue;
        }
        // L₀(z) = √(1−a²)/(1 − a z⁻¹), L_i = L_{i−1}·(z⁻¹ − a)/(1 − a z⁻¹).
        let mut x = vec![0.0; n];
        for i in 0..n {
            x[i] = gain * u[i] + if i > 0 { a * x[i - 1] } else { 0.0 };
        }
        z.push(u);
        for _ in 1..ORDERS {
            let prev = x.clone();
            z.push(prev.clone());
            for i in 0..n {
                let back = if i > 0 { a * x[i - 1] + prev[i - 1] } else { 0.0 };
                x[i] = back - a * prev[i];
            }
        }
        z.push(x);
        used.push(q);
    }
    (z, used)
}

/// Zero-phase high-pass at [`BAND_HZ`].
fn high_pass(x: &[f64], h_s: f64) -> Vec<f64> {
    let lp = super::airdata::low_pass(x, BAND_HZ, h_s);
    x.iter().zip(lp).map(|(a, b)| a - b).collect()
}

/// The empty model as a [`SubsetFit`]: every held-out prediction 0, each block's SSE its `Σd²`.
fn empty_fit(design: &Design, d: &[f64]) -> SubsetFit {
    SubsetFit {
        cols: Vec::new(),
        theta: Vec::new(),
        sigma: Vec::new(),
        cv_sse: design
            .blocks
            .iter()
            .map(|&(a, b)| d[a..b].iter().map(|v| v * v).sum())
            .collect(),
        cv_theta: vec![Vec::new(); design.folds],
    }
}

/// Checks the scale factor and delay of `channel` (`Alpha` or `Beta`): `measured` the vane,
/// `kinematic` the flight-path reconstruction's flow angle at the vane (biases found removed, no
/// scale or delay of the vane in it).
pub fn check_channel(
    flight: &MeasuredFlight,
    h_s: f64,
    channel: Quantity,
    measured: &[f64],
    kinematic: &[f64],
    s: &IvSettings,
) -> ChannelCheck {
    let mut out = ChannelCheck::default();
    let n = measured.len();
    let (z, used) = instruments(flight, n, h_s);
    if kinematic.len() != n || used.is_empty() || n < 20 * (1.0 / h_s) as usize {
        out.note = format!(
            "{channel:?}: scale and delay not tested by instrumental variables (needs logged controls and 20 s of data)"
        );
        return out;
    }
    let Some(theta) = super::regress::ols_theta(&z, kinematic) else {
        out.note = format!("{channel:?}: the control instruments are linearly dependent; scale and delay not tested");
        return out;
    };
    let fitted: Vec<f64> = (0..n)
        .map(|i| z.iter().zip(&theta).map(|(c, t)| c[i] * t).sum())
        .collect();
    let var = |x: &[f64]| {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        x.iter().map(|v| (v - m).powi(2)).sum::<f64>()
    };
    let resid: Vec<f64> = kinematic.iter().zip(&fitted).map(|(a, b)| a - b).collect();
    let r2 = 1.0 - var(&resid) / var(kinematic).max(1e-300);
    let names: Vec<String> = used.iter().map(|q| format!("{q:?}")).collect();
    if r2 < MIN_FIRST_STAGE_R2 {
        out.note = format!(
            "{channel:?}: the controls ({}) explain {:.0} % of the reconstructed flow angle (< {:.0} %): too weak as instruments, scale and delay not identifiable from this flight",
            names.join(", "),
            100.0 * r2,
            100.0 * MIN_FIRST_STAGE_R2
        );
        return out;
    }
    let d = high_pass(
        &measured.iter().zip(kinematic).map(|(m, k)| m - k).collect::<Vec<_>>(),
        h_s,
    );
    let yh = high_pass(&fitted, h_s);
    let ydot: Vec<f64> = derivative(&yh, h_s).iter().map(|v| -v).collect();
    let design = Design::new(&[&yh, &ydot], &d, h_s, &s.cv, None);
    let g = design.n_blocks();
    let dof = (g as f64 - 1.0).max(1.0);
    let threshold = select::student_t_upper_quantile(s.level / 2.0, dof).powi(2);
    let crit = select::student_t_upper_quantile(s.cv.gain_alpha, dof);
    let params = [SensorParam::Scale(channel), SensorParam::Delay(channel)];
    let empty = empty_fit(&design, &d);
    // Round 1: each candidate alone.
    let singles: Vec<Option<SubsetFit>> = (0..2).map(|j| design.fit(&[j]).ok()).collect();
    for (j, f) in singles.iter().enumerate() {
        if let Some(f) = f {
            out.tested.push(ParamScore {
                param: params[j],
                value: f.theta[0],
                sigma: f.sigma[0],
                t2: f.t2(0),
            });
        }
    }
    // A candidate's entry: its partial t², the sign-flip direction of its held-out gain, the gain
    // relative to the smaller model, and the gain against the held-out noise (T).
    let judge = |design: &Design, f0: &SubsetFit, f1: &SubsetFit, k: usize| -> Score {
        let t2 = f1.t2(k);
        let (z, rel) = select::gain(&f0.cv_sse, &f1.cv_sse);
        let noise = if t2 > threshold && z > 0.0 {
            design.noise_gain(f0, f1)
        } else {
            f64::NAN
        };
        (t2, z, rel, noise)
    };
    let passes = |(t2, z, _, noise): Score| t2 > threshold && z > 0.0 && noise > crit;
    // Forward selection over the two candidates in the order of their t² alone, then the removal
    // step. A scale tested after the delay is tested against the exact delay (the first-order
    // column leaves a spurious scale beside a real delay: on a 0.10 s delay, t² 36).
    let mut entered: Vec<(usize, Score)> = Vec::new();
    let mut significant: Vec<(usize, Score)> = Vec::new();
    let (mut values, mut sigmas) = ([0.0; 2], [f64::NAN; 2]);
    let order = {
        let mut o: Vec<usize> = (0..2).filter(|&j| singles[j].is_some()).collect();
        o.sort_by(|&a, &b| {
            let t = |j: usize| singles[j].as_ref().map_or(0.0, |f| f.t2(0));
            t(b).total_cmp(&t(a))
        });
        o
    };
    let mut current = empty.clone();
    for &j in &order {
        if j == 0 && entered.iter().any(|e| e.0 == 1) {
            let (tau, _) = exact_delay(&d, &yh, h_s, false);
            let shifted = super::signal::shift(&yh, h_s, -tau);
            let rest: Vec<f64> = (0..n).map(|i| d[i] + yh[i] - shifted[i]).collect();
            let d2 = Design::new(&[&shifted], &rest, h_s, &s.cv, None);
            let Ok(f) = d2.fit(&[0]) else {
                continue;
            };
            let score = judge(&d2, &empty_fit(&d2, &rest), &f, 0);
            if passes(score) {
                entered.push((0, score));
                sigmas[0] = f.sigma[0];
            } else if score.0 > threshold {
                significant.push((0, score));
            }
            continue;
        }
        let mut cols: Vec<usize> = entered.iter().map(|e| e.0).collect();
        cols.push(j);
        let Ok(f) = design.fit(&cols) else {
            continue;
        };
        let score = judge(&design, &current, &f, cols.len() - 1);
        if passes(score) {
            entered.push((j, score));
            current = f;
        } else if score.0 > threshold {
            significant.push((j, score));
        }
    }
    if entered.len() == 2 && entered[0].0 == 0 {
        // The scale entered first leaves if the delay explains it.
        if let Ok(f) = design.fit(&[1]) {
            let score = judge(&design, &f, &current, 0);
            if !passes(score) {
                entered.remove(0);
                significant.push((0, score));
                current = f;
            }
        }
    }
    for (k, &c) in current.cols.iter().enumerate() {
        values[c] = current.theta[k];
        sigmas[c] = current.sigma[k];
    }
    if entered.iter().any(|e| e.0 == 1) {
        let with_scale = entered.iter().any(|e| e.0 == 0);
        let (tau, k) = exact_delay(&d, &yh, h_s, with_scale);
        values[1] = tau;
        if with_scale {
            values[0] = k;
        }
    }
    let found = |j: usize, (t2, _z, rel, noise): (f64, f64, f64, f64), why: String| Found {
        param: params[j],
        value: values[j],
        sigma: sigmas[j],
        t2,
        part: "instrumental",
        cv_gain_z: noise,
        cv_gain: rel,
        why,
    };
    for &(j, sc) in &entered {
        out.found.push(found(j, sc, String::new()));
    }
    for &(j, sc) in &significant {
        let fit = singles[j].as_ref();
        let mut f = found(j, sc, format!(
            "significant with the control instruments but does not improve the held-out fit beyond noise (gain T {:.1} ≤ {crit:.1})",
            if sc.3.is_finite() { sc.3 } else { 0.0 }
        ));
        if !entered.iter().any(|e| e.0 == j) {
            if let Some(fit) = fit {
                f.value = fit.theta[0];
                f.sigma = fit.sigma[0];
            }
        }
        out.rejected.push(f);
    }
    out.note = format!(
        "{channel:?}: scale and delay tested by instrumental variables (instruments: {} through {ORDERS} Laguerre filters of {LAGUERRE_T_S} s; first stage R² {r2:.2}; band above {BAND_HZ} Hz; t² threshold {threshold:.1}, held-out T > {crit:.2})",
        names.join(", ")
    );
    out
}

/// The exact delay `τ` (and the scale `k` when `with_scale`, else 0) minimising
/// `‖d − ((1+k)ŷ(t−τ) − ŷ(t))‖²`: a search at sample resolution over ±[`DELAY_RANGE_S`], refined by
/// a parabola through the best sample and its neighbours.
fn exact_delay(d: &[f64], yh: &[f64], h_s: f64, with_scale: bool) -> (f64, f64) {
    let n = d.len();
    let steps = (DELAY_RANGE_S / h_s).round() as i64;
    // Interior samples only, so that every shift sees data.
    let lo = steps.unsigned_abs() as usize;
    let hi = n.saturating_sub(lo);
    if hi <= lo + 10 {
        return (0.0, 0.0);
    }
    let sse = |shift: f64| -> (f64, f64) {
        let s = super::signal::shift(yh, h_s, -shift);
        let (mut sy, mut ss) = (0.0, 0.0);
        for i in lo..hi {
            sy += (d[i] + yh[i]) * s[i];
            ss += s[i] * s[i];
        }
        let one_plus_k = if with_scale && ss > 0.0 { sy / ss } else { 1.0 };
        let e: f64 = (lo..hi).map(|i| (d[i] + yh[i] - one_plus_k * s[i]).powi(2)).sum();
        (e, one_plus_k - 1.0)
    };
    let costs: Vec<(f64, f64)> = (-steps..=steps).map(|k| sse(k as f64 * h_s)).collect();
    let best = (0..costs.len())
        .min_by(|&a, &b| costs[a].0.total_cmp(&costs[b].0))
        .unwrap_or(0);
    let mut tau = (best as i64 - steps) as f64 * h_s;
    if best > 0 && best + 1 < costs.len() {
        let (a, b, c) = (costs[best - 1].0, costs[best].0, costs[best + 1].0);
        let den = a - 2.0 * b + c;
        if den > 0.0 {
            tau += 0.5 * (a - c) / den * h_s;
        }
    }
    (tau, sse(tau).1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const H: f64 = 0.01;

    /// A 90 s flight of a first-order "aircraft" whose flow angle weathercocks into the air:
    /// `α̇_kin = −(α_kin + g − 0.5 δe)/0.3 s` (the gust `g` is first-order coloured noise with a
    /// 2.5 s correlation time and σ 0.012 rad — the campaign's 0.3 m/s at 20 m/s plus margin),
    /// elevator pulses of 0.6 s every 4 s (random sign, 0.1 rad: α steps of 0.05 rad), the vane
    /// `(1+k)(α_kin + g)(t − τ)` with 0.002 rad white noise, the reconstruction `α_kin` with
    /// 0.0005 rad. Returns the flight (elevator only), the vane and the reconstruction.
    fn flight(seed: u64, k: f64, tau_s: f64) -> (MeasuredFlight, Vec<f64>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 9000;
        let mut normal = move || -> f64 {
            // Box–Muller (one of the pair).
            let (u1, u2): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random_range(0.0..1.0));
            (-2.0 * u1.ln()).sqrt() * (2.0 * core::f64::consts::PI * u2).cos()
        };
        let pulse = (0.6 / H) as usize;
        let period = (4.0 / H) as usize;
        let signs: Vec<f64> = (0..n / period + 1)
            .map(|_| if normal() > 0.0 { 1.0 } else { -1.0 })
            .collect();
        let de: Vec<f64> = (0..n)
            .map(|i| {
                if i % period < pulse {
                    0.1 * signs[i / period]
                } else {
                    0.0
                }
            })
            .collect();
        let a_g = (-H / 2.5f64).exp();
        let mut g = vec![0.0; n];
        for i in 1..n {
            g[i] = a_g * g[i - 1] + 0.012 * (1.0 - a_g * a_g).sqrt() * normal();
        }
        let mut alpha = vec![0.0; n];
        for i in 1..n {
            alpha[i] = alpha[i - 1] - H * (alpha[i - 1] + g[i - 1] - 0.5 * de[i - 1]) / 0.3;
        }
        let air: Vec<f64> = alpha.iter().zip(&g).map(|(a, b)| a + b).collect();
        let vane: Vec<f64> = super::super::signal::shift(&air, H, -tau_s)
            .iter()
            .map(|v| (1.0 + k) * v + 0.002 * normal())
            .collect();
        let kin: Vec<f64> = alpha.iter().map(|v| v + 0.0005 * normal()).collect();
        (blank(n, de), vane, kin)
    }

    /// A flight of `n` samples on [`H`] with this elevator and no other channel.
    fn blank(n: usize, elevator: Vec<f64>) -> MeasuredFlight {
        let frame = aerosid_sim::SimAirframe::skywalker_2013_mod().frame;
        MeasuredFlight {
            source: "test".into(),
            t_s: (0..n).map(|i| i as f64 * H).collect(),
            channels: [(Quantity::Elevator, elevator)].into_iter().collect(),
            aircraft: crate::io::measured::Aircraft::from_airframe("test", &frame),
            log: Default::default(),
        }
    }

    fn settings() -> IvSettings {
        IvSettings {
            level: 1e-4,
            cv: CvSettings::default(),
        }
    }

    #[test]
    fn a_perfect_vane_in_gusts_biases_least_squares_but_not_the_instruments() {
        // GIVEN ten seeded gusty flights with a perfect vane
        let (mut ls, mut iv) = (Vec::new(), Vec::new());
        for seed in 0..10 {
            let (f, vane, kin) = flight(seed, 0.0, 0.0);
            // WHEN least squares fits a scale factor to vane − reconstruction in the same band,
            // and the instrumental check runs
            let d = high_pass(&vane.iter().zip(&kin).map(|(a, b)| a - b).collect::<Vec<_>>(), H);
            let design = Design::new(&[&high_pass(&kin, H)], &d, H, &settings().cv, None);
            let fit = design.fit(&[0]).expect("fits");
            ls.push(fit.theta[0]);
            let r = check_channel(&f, H, Quantity::Alpha, &vane, &kin, &settings());
            // THEN the instruments name nothing
            assert!(r.found.is_empty(), "seed {seed}: {:?} ({})", r.found, r.note);
            assert_eq!(r.tested.len(), 2, "{}", r.note);
            iv.push((r.tested[0].value, r.tested[0].sigma));
        }
        // AND least squares is biased by the gust response — negative on every flight, −0.05 or
        // beyond on average (measured −0.08) — while the instrumental estimates average to zero
        // within 3 standard errors of their mean
        assert!(ls.iter().all(|k| *k < 0.0), "least squares {ls:?}");
        let mean_ls = ls.iter().sum::<f64>() / 10.0;
        assert!(mean_ls < -0.05, "least squares mean {mean_ls}");
        let mean_iv = iv.iter().map(|x| x.0).sum::<f64>() / 10.0;
        let se = (iv.iter().map(|x| x.1 * x.1).sum::<f64>() / 10.0).sqrt() / 10f64.sqrt();
        assert!(mean_iv.abs() < 3.0 * se, "instrumental mean {mean_iv} ± {se}");
    }

    #[test]
    fn a_vane_delay_and_a_scale_factor_are_found_with_their_size() {
        // GIVEN gusty flights with a 0.10 s vane delay, and with a −0.15 scale factor
        let one = |r: &ChannelCheck, seed: u64| {
            assert_eq!(
                r.found.len(),
                1,
                "seed {seed}: {:?} {:?} {:?} {}",
                r.found,
                r.tested,
                r.rejected,
                r.note
            );
            r.found[0].clone()
        };
        for seed in 20..23 {
            let (f, vane, kin) = flight(seed, 0.0, 0.10);
            // WHEN checked
            let r = check_channel(&f, H, Quantity::Alpha, &vane, &kin, &settings());
            // THEN the delay is named alone, its exact value within 0.02 s (a fifth of it; the
            // first-order σ is a few ms)
            let d = one(&r, seed);
            assert_eq!(d.param, SensorParam::Delay(Quantity::Alpha));
            assert!((d.value - 0.10).abs() < 0.02, "τ {}", d.value);
            let (f, vane, kin) = flight(seed, -0.15, 0.0);
            let r = check_channel(&f, H, Quantity::Alpha, &vane, &kin, &settings());
            // AND the scale factor within 3σ
            let s = one(&r, seed);
            assert_eq!(s.param, SensorParam::Scale(Quantity::Alpha));
            assert!((s.value + 0.15).abs() < 3.0 * s.sigma, "k {} ± {}", s.value, s.sigma);
        }
    }

    #[test]
    fn without_controls_or_with_weak_instruments_nothing_is_tested_and_the_note_says_why() {
        // GIVEN a flight with no logged control, and one whose elevator does not move the flow angle
        let (mut f, vane, kin) = flight(3, 0.0, 0.1);
        let moved = f.channels.remove(&Quantity::Elevator).expect("elevator");
        let r = check_channel(&f, H, Quantity::Alpha, &vane, &kin, &settings());
        // THEN nothing is tested, with the reason
        assert!(r.tested.is_empty() && r.found.is_empty());
        assert!(r.note.contains("needs logged controls"), "{}", r.note);
        let shuffled: Vec<f64> = moved.iter().rev().copied().collect();
        f.channels.insert(Quantity::Elevator, shuffled);
        let r = check_channel(&f, H, Quantity::Alpha, &vane, &kin, &settings());
        assert!(r.tested.is_empty() && r.found.is_empty());
        assert!(r.note.contains("too weak as instruments"), "{}", r.note);
    }

    #[test]
    fn the_laguerre_impulse_responses_are_orthonormal() {
        // GIVEN a unit impulse on the elevator (long enough for every response to die out:
        // 20 000 samples against a memory of a few hundred)
        let n = 20_000;
        let mut u = vec![0.0; n];
        u[10] = 1.0;
        let f = blank(n, u);
        // WHEN the instruments are built
        let (z, used) = instruments(&f, n, H);
        // THEN the Laguerre outputs (columns 2…) are orthonormal: Σ lᵢ(k) lⱼ(k) = δᵢⱼ, up to the
        // de-meaned input's constant −1/n, which every filter passes with its DC gain
        // G = √((1+a)/(1−a)) ≈ 10 and changes each sum by at most 3G²/n (≈ 0.015)
        assert_eq!(used, vec![Quantity::Elevator]);
        assert_eq!(z.len(), 2 + ORDERS);
        let a = (-H / LAGUERRE_T_S).exp();
        let tol = 3.0 * (1.0 + a) / (1.0 - a) / n as f64;
        for i in 2..z.len() {
            for j in 2..z.len() {
                let dot: f64 = z[i].iter().zip(&z[j]).map(|(a, b)| a * b).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < tol, "⟨L{}, L{}⟩ = {dot}", i - 2, j - 2);
            }
        }
    }
}
