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
//! the logged controls of the channel's plane (elevator and throttle for α, aileron and rudder for
//! β) — the manoeuvre, not the gusts, moves them — each passed through a bank of [`ORDERS`]
//! discrete Laguerre filters with time constant [`LAGUERRE_T_S`] (Wahlberg 1991: an orthonormal
//! basis of the aircraft's response to the control over a few seconds, far fewer columns than a
//! finite impulse response of the same memory). Everything runs on the signals high-passed at
//! [`BAND_HZ`] (zero-phase). The first stage projects the band's `α_kin` on the band's
//! instruments: `α̂` is the part of the inertial flow angle that the controls explain, independent
//! of the gusts. The second stage regresses `d` on `α̂` (scale `k`) and on `−dα̂/dt` (delay `τ`;
//! `α_m(t) = (1+k)α(t−τ) ≈ α + kα − τα̇`). Under "perfect vane" `d` is the gust, independent of
//! both columns, so the regression is an ordinary one with coloured noise: the same statistics as
//! the aerodynamic selection ([`super::select`]) hold — partial `t²` with the block sandwich
//! against Student t, and the held-out gain against the noise of the held-out residuals
//! ([`super::select::Design::noise_gain`]) — at the analysis's per-test level. **Reading**: the
//! first stage is fitted on the whole flight, not per fold (its columns carry no gust, so the
//! held-out blocks' gusts reach `α̂` only through the finite-sample fit of 2 × 9 columns to
//! thousands of samples).
//!
//! **Band**: the logged deflections also carry any stabiliser's or pilot's response to the gusts
//! (a feedback makes the instruments correlated with the noise, the one thing an instrument must
//! not be); that response, like most of the gust energy, sits at the low frequencies of the
//! attitude loops and the phugoid, while the manoeuvre's pulses (0.5–1 s) put their energy above.
//! Measured with a variant of this check (all four controls, the band applied after the first
//! stage) on the campaign's 10 clean simulated flights and JSBSim's 4 clean flights (both flown
//! with a weak attitude hold): at 0.1 Hz `scale(α)` came out −0.04 (sim) and −0.15…−0.39 (JSBSim,
//! `t` to −3.9) on perfect vanes; at 0.6 Hz every clean estimate was within `|t|` 2.3 of zero. A
//! strong rate damper would act inside the band; that is not tested.
//!
//! **Delay**: its test uses the first-order column `−α̂̇`; once it enters, its value is the exact
//! delay `τ` minimising the residual of `d = (1+k)α̂(t−τ) − α̂(t)` (a search over the plausible
//! range; a best fit at the range's edge is refused), since the first-order form underestimates
//! delays of a tenth of the pulse length and leaves a spurious scale factor beside them — so a
//! scale beside a delay is tested, and its value and σ taken, on `d − (α̂(t−τ) − α̂(t))` with the
//! column `α̂(t−τ)`. The σ reported for the delay is the first-order one. A vane `Δx` ahead of its
//! stated position reads `−Δx·q/V`, in the short period nearly a delay `Δx/V`: a delay named here
//! may be either.
//!
//! **Not done**: the airspeed channel (its control-driven part is the throttle's and the phugoid's,
//! at the low frequencies this band removes), the vane position as its own candidate (see the
//! delay), biases (a gust has no mean: the output-error check identifies them in turbulence).
//! When the controls explain less than [`MIN_FIRST_STAGE_R2`] of the band's flow angle the channel
//! is not tested and the note says so: weak instruments make the estimator fall back towards least
//! squares, with its bias. A value outside its kind's physical range is refused, with the reason.

use super::select::{self, CvSettings, Design, SubsetFit};
use super::sensor_error::{Found, ParamScore, SensorParam};
use super::signal::derivative;
use crate::io::measured::{MeasuredFlight, Quantity};

/// Laguerre orders per control.
pub const ORDERS: usize = 8;
/// Time constant of the Laguerre filters, s (the bank spans about `ORDERS · T` of memory).
pub const LAGUERRE_T_S: f64 = 0.5;
/// High-pass corner of both stages, Hz.
pub const BAND_HZ: f64 = 0.6;
/// Least share of the band's flow-angle variance the controls must explain for the channel to be tested.
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

/// The statistics' settings: the per-test two-sided level (the analysis's family-wise level divided
/// by every candidate it tests, as for the aerodynamic terms) and the blocks and folds of the
/// held-out test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IvSettings {
    /// Two-sided level of each partial test.
    pub level: f64,
    /// Blocks, folds and the level of the held-out test.
    pub cv: CvSettings,
}

/// A candidate's entry statistics: `(t², sign-flip z, relative held-out gain, T)`.
type Score = (f64, f64, f64, f64);

/// A tested candidate: which (0 scale, 1 delay), its entry statistics, and its value and σ from
/// the same fit.
#[derive(Debug, Clone, Copy)]
struct Entry {
    j: usize,
    score: Score,
    value: f64,
    sigma: f64,
}

/// The controls that are instruments of a channel: the longitudinal ones for α, the lateral
/// ones for β (a control of the other plane moves the channel little and adds columns that only
/// pull the estimate towards least squares).
fn controls_of(channel: Quantity) -> &'static [Quantity] {
    match channel {
        Quantity::Alpha => &[Quantity::Elevator, Quantity::Throttle],
        Quantity::Beta => &[Quantity::Aileron, Quantity::Rudder],
        _ => &[],
    }
}

/// The instruments of a flight: per control of `controls` that is logged, finite and varying, its
/// deviation from the mean and its [`ORDERS`] Laguerre outputs. Also the controls used.
fn instruments(flight: &MeasuredFlight, n: usize, h_s: f64, controls: &[Quantity]) -> (Vec<Vec<f64>>, Vec<Quantity>) {
    let mut z = Vec::new();
    let mut used = Vec::new();
    let a = (-h_s / LAGUERRE_T_S).exp();
    let gain = (1.0 - a * a).sqrt();
    for &q in controls {
        let Some(u) = flight
            .get(q)
            .filter(|u| u.len() == n && u.iter().all(|v| v.is_finite()))
        else {
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
            let prev = std::mem::take(&mut x);
            x = vec![0.0; n];
            for i in 0..n {
                let back = if i > 0 { a * x[i - 1] + prev[i - 1] } else { 0.0 };
                x[i] = back - a * prev[i];
            }
            z.push(prev);
        }
        z.push(x);
        used.push(q);
    }
    (z, used)
}

/// Zero-phase high-pass at [`BAND_HZ`].
fn high_pass(x: &[f64], h_s: f64) -> Vec<f64> {
    minus(x, super::airdata::low_pass(x, BAND_HZ, h_s))
}

/// [`high_pass`] of every channel, the low-passes four at a time ([`super::airdata::low_pass_all`]).
fn high_pass_all(xs: &[Vec<f64>], h_s: f64) -> Vec<Vec<f64>> {
    let lps = super::airdata::low_pass_all(xs, BAND_HZ, h_s);
    xs.iter().zip(lps).map(|(x, lp)| minus(x, lp)).collect()
}

/// `x − lp`, sample by sample.
fn minus(x: &[f64], lp: Vec<f64>) -> Vec<f64> {
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

/// Least duration of a flight for the check, s.
const MIN_DURATION_S: f64 = 20.0;

/// Checks the scale factor and delay of `channel` (`Alpha` or `Beta`): `measured` the vane,
/// `kinematic` the flight-path reconstruction's flow angle at the vane (biases found removed, no
/// scale or delay of the vane in it).
///
/// The steps: the data usable, the first stage (the controls as instruments of the band's
/// reconstruction), the second-stage regression of the vane's error on the fitted angle and its
/// rate, each candidate scored alone, the forward selection with the removal step, the
/// verdicts.
pub fn check_channel(
    flight: &MeasuredFlight,
    h_s: f64,
    channel: Quantity,
    measured: &[f64],
    kinematic: &[f64],
    s: &IvSettings,
) -> ChannelCheck {
    let mut out = ChannelCheck::default();
    let stage =
        match usable(h_s, channel, measured, kinematic).and_then(|()| first_stage(flight, h_s, channel, kinematic)) {
            Ok(stage) => stage,
            Err(note) => {
                out.note = note;
                return out;
            }
        };
    let iv = Iv::new(stage.yh, measured, kinematic, h_s, s);
    let params = [SensorParam::Scale(channel), SensorParam::Delay(channel)];
    let singles: Vec<Option<SubsetFit>> = (0..2).map(|j| iv.design.fit(&[j]).ok()).collect();
    out.tested.extend(iv.tested(&singles, params));
    let (Some(f_scale), Some(f_delay)) = (&singles[0], &singles[1]) else {
        out.note = format!("{channel:?}: the instrumental regression cannot be fitted on this flight (too few blocks, or a column without variance)");
        return out;
    };
    let selected = iv.select(f_scale, f_delay);
    iv.verdicts(&mut out, &selected, params);
    out.note = format!(
        "{channel:?}: scale and delay tested by instrumental variables (instruments: {} through {ORDERS} Laguerre filters of {LAGUERRE_T_S} s; first stage R² {:.2} above {BAND_HZ} Hz; t² threshold {:.1}, held-out T > {:.2})",
        stage.names.join(", "),
        stage.r2,
        iv.threshold,
        iv.crit
    );
    out
}

/// Whether the data can be tested at all: the note saying why not otherwise.
fn usable(h_s: f64, channel: Quantity, measured: &[f64], kinematic: &[f64]) -> Result<(), String> {
    let n = measured.len();
    let finite = |x: &[f64]| x.iter().all(|v| v.is_finite());
    if kinematic.len() != n
        || n as f64 * h_s < MIN_DURATION_S
        || !h_s.is_finite()
        || !finite(measured)
        || !finite(kinematic)
    {
        return Err(format!(
            "{channel:?}: scale and delay not tested by instrumental variables (needs {MIN_DURATION_S} s of finite vane and reconstruction)"
        ));
    }
    Ok(())
}

/// The first stage: the band's reconstruction fitted by the band's instruments.
struct FirstStage {
    /// The fitted (instrumented) flow angle in the band.
    yh: Vec<f64>,
    /// The share of the band's reconstruction the instruments explain.
    r2: f64,
    /// The controls used as instruments.
    names: Vec<String>,
}

/// First stage in the band: the band's reconstruction projected on the band's instruments
/// (two-stage least squares on the high-passed signals); the note when the controls are missing
/// or too weak.
fn first_stage(flight: &MeasuredFlight, h_s: f64, channel: Quantity, kinematic: &[f64]) -> Result<FirstStage, String> {
    let n = kinematic.len();
    let (z, used) = instruments(flight, n, h_s, controls_of(channel));
    if used.is_empty() {
        return Err(format!(
            "{channel:?}: scale and delay not tested by instrumental variables (needs logged controls)"
        ));
    }
    let zh = high_pass_all(&z, h_s);
    let kh = high_pass(kinematic, h_s);
    let kk: f64 = kh.iter().map(|v| v * v).sum();
    let fitted: Option<Vec<f64>> = super::regress::ols_theta(&zh, &kh).map(|th| {
        (0..n)
            .map(|i| zh.iter().zip(&th).map(|(c, t)| c[i] * t).sum())
            .collect()
    });
    let names: Vec<String> = used.iter().map(|q| format!("{q:?}")).collect();
    let r2 = fitted.as_ref().map_or(f64::NAN, |f| {
        1.0 - kh.iter().zip(f).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / kk
    });
    let (Some(yh), true) = (fitted, kk > 0.0 && r2 >= MIN_FIRST_STAGE_R2) else {
        return Err(format!(
            "{channel:?}: the controls ({}) explain {:.0} % of the reconstructed flow angle above {BAND_HZ} Hz (< {:.0} %): too weak as instruments, scale and delay not identifiable from this flight",
            names.join(", "),
            100.0 * if r2.is_finite() { r2 } else { 0.0 },
            100.0 * MIN_FIRST_STAGE_R2
        ));
    };
    Ok(FirstStage { yh, r2, names })
}

/// The second stage: the band's vane error `d` regressed on the fitted angle `ŷ` (a scale) and
/// `−ŷ̇` (a delay), with its thresholds.
struct Iv<'a> {
    yh: Vec<f64>,
    d: Vec<f64>,
    design: Design,
    h_s: f64,
    s: &'a IvSettings,
    /// Degrees of freedom of the block statistics.
    dof: f64,
    /// The partial `t²` threshold.
    threshold: f64,
    /// The held-out test's critical value.
    crit: f64,
}

/// The entries of the forward selection: entered, refused, and the exact delay when one was
/// fitted (`Some(None)`: no minimum inside the range).
struct Selected {
    entered: Vec<Entry>,
    refused: Vec<Entry>,
    tau: Option<Option<f64>>,
}

impl<'a> Iv<'a> {
    fn new(yh: Vec<f64>, measured: &[f64], kinematic: &[f64], h_s: f64, s: &'a IvSettings) -> Self {
        let d = high_pass(
            &measured.iter().zip(kinematic).map(|(m, k)| m - k).collect::<Vec<_>>(),
            h_s,
        );
        let ydot: Vec<f64> = derivative(&yh, h_s).iter().map(|v| -v).collect();
        let design = Design::new(&[&yh, &ydot], &d, h_s, &s.cv, None);
        let dof = (design.n_blocks() as f64 - 1.0).max(1.0);
        let threshold = select::student_t_upper_quantile(s.level / 2.0, dof).powi(2);
        let crit = select::student_t_upper_quantile(s.cv.gain_alpha, dof);
        Self {
            yh,
            d,
            design,
            h_s,
            s,
            dof,
            threshold,
            crit,
        }
    }

    /// Each candidate's first-round score alone, with the tool's and the oracle's least
    /// detectable sizes.
    fn tested(&self, singles: &[Option<SubsetFit>], params: [SensorParam; 2]) -> Vec<ParamScore> {
        let (s, h_s, n) = (self.s, self.h_s, self.d.len());
        let factor = super::select::detection_factor(self.threshold, self.crit, self.dof);
        // The oracle (docs/model-gaps.md): the same single-column regression's model-based σ,
        // coloured residuals up to a block's length.
        let oracle_factor = super::detection::detection_factor(s.level / 2.0, s.cv.gain_alpha);
        let lag = ((s.cv.block_s / h_s).round() as usize).max(1);
        let ydot: Vec<f64> = derivative(&self.yh, h_s).iter().map(|v| -v).collect();
        let mut out = Vec::new();
        for (j, (f, col)) in singles.iter().zip([&self.yh, &ydot]).enumerate() {
            if let Some(f) = f {
                let oracle_se = super::regress::ols_sigma(std::slice::from_ref(col), &self.d, n, lag, Some(0))
                    .map_or(f64::NAN, |o| o.sigma[0]);
                out.push(ParamScore {
                    param: params[j],
                    value: f.theta[0],
                    sigma: f.sigma[0],
                    t2: f.t2(0),
                    part: "instrumental",
                    min_detectable: factor * f.sigma[0],
                    oracle_se,
                    oracle_min_detectable: oracle_factor * oracle_se,
                });
            }
        }
        out
    }

    /// A candidate's entry: its partial t², the sign-flip direction of its held-out gain, the gain
    /// relative to the smaller model, and the gain against the held-out noise (T).
    fn judge(&self, design: &Design, f0: &SubsetFit, f1: &SubsetFit, k: usize) -> Score {
        let t2 = f1.t2(k);
        let (z, rel) = select::gain(&f0.cv_sse, &f1.cv_sse);
        let noise = if t2 > self.threshold && z > 0.0 {
            design.noise_gain(f0, f1)
        } else {
            f64::NAN
        };
        (t2, z, rel, noise)
    }

    fn passes(&self, (t2, z, _, noise): Score) -> bool {
        t2 > self.threshold && z > 0.0 && noise > self.crit
    }

    /// Candidate `j` fitted alone (`f`) against the empty model.
    fn alone(&self, j: usize, f: &SubsetFit) -> Entry {
        Entry {
            j,
            score: self.judge(&self.design, &empty_fit(&self.design, &self.d), f, 0),
            value: f.theta[0],
            sigma: f.sigma[0],
        }
    }

    /// The scale given an exact delay τ: `d + ŷ − ŷ(t−τ) = k·ŷ(t−τ) + noise` (the first-order
    /// delay column leaves a spurious scale beside a real delay: on a 0.10 s delay, t² 36).
    fn scale_given(&self, tau: Option<f64>) -> Option<Entry> {
        let (yh, d, h_s) = (&self.yh, &self.d, self.h_s);
        let shifted = super::signal::shift(yh, h_s, -tau?);
        let rest: Vec<f64> = (0..d.len()).map(|i| d[i] + yh[i] - shifted[i]).collect();
        let d2 = Design::new(&[&shifted], &rest, h_s, &self.s.cv, None);
        let f = d2.fit(&[0]).ok()?;
        Some(Entry {
            j: 0,
            score: self.judge(&d2, &empty_fit(&d2, &rest), &f, 0),
            value: f.theta[0],
            sigma: f.sigma[0],
        })
    }

    /// The exact delay of the vane error, with or without a scale beside it.
    fn exact_delay(&self, with_scale: bool) -> Option<f64> {
        exact_delay(&self.d, &self.yh, self.h_s, with_scale)
    }

    /// Files a candidate tested on its own: entered if it passes, else refused.
    fn file(&self, e: Entry, sel: &mut Selected) -> bool {
        let ok = self.passes(e.score);
        if ok {
            sel.entered.push(e)
        } else {
            sel.refused.push(e)
        }
        ok
    }

    /// Forward selection in the order of the candidates' t² alone, then the removal step.
    fn select(&self, f_scale: &SubsetFit, f_delay: &SubsetFit) -> Selected {
        let mut sel = Selected {
            entered: Vec::new(),
            refused: Vec::new(),
            tau: None,
        };
        if f_delay.t2(0) >= f_scale.t2(0) {
            let e = self.alone(1, f_delay);
            if self.passes(e.score) {
                let t = self.exact_delay(false);
                sel.tau = Some(t);
                sel.entered.push(e);
                if let Some(sc) = self.scale_given(t) {
                    self.file(sc, &mut sel);
                }
            } else {
                sel.refused.push(e);
                self.file(self.alone(0, f_scale), &mut sel);
            }
        } else {
            let e = self.alone(0, f_scale);
            if self.passes(e.score) {
                sel.entered.push(e);
                self.delay_beside_scale(f_scale, &mut sel);
            } else {
                sel.refused.push(e);
                if self.file(self.alone(1, f_delay), &mut sel) {
                    sel.tau = Some(self.exact_delay(false));
                }
            }
        }
        sel
    }

    /// The delay tested beside an entered scale (`f_scale`), and the removal step on the scale.
    fn delay_beside_scale(&self, f_scale: &SubsetFit, sel: &mut Selected) {
        let Ok(joint) = self.design.fit(&[0, 1]) else {
            return;
        };
        let ed = Entry {
            j: 1,
            score: self.judge(&self.design, f_scale, &joint, 1),
            value: joint.theta[1],
            sigma: joint.sigma[1],
        };
        if !self.passes(ed.score) {
            sel.refused.push(ed);
            return;
        }
        let t = self.exact_delay(true);
        sel.tau = Some(t);
        sel.entered.push(ed);
        // Removal: the scale stays only if it passes given the exact delay (kept as
        // it is when the delay has no minimum inside the range: then the delay is
        // refused below).
        match self.scale_given(t) {
            Some(sc) if self.passes(sc.score) => sel.entered[0] = sc,
            Some(sc) => {
                // Without the scale, the delay is the one fitted alone.
                sel.entered.remove(0);
                sel.refused.push(sc);
                sel.tau = Some(self.exact_delay(false));
            }
            None => {}
        }
    }

    /// The entered candidates as found or rejected (a delay at the range's edge, a value outside
    /// its kind's range), and the refused ones that were significant, with the reason.
    fn verdicts(&self, out: &mut ChannelCheck, sel: &Selected, params: [SensorParam; 2]) {
        let to_found = |e: &Entry, why: String| Found {
            param: params[e.j],
            value: e.value,
            sigma: e.sigma,
            t2: e.score.0,
            part: "instrumental",
            cv_gain_z: e.score.3,
            cv_gain: e.score.2,
            why,
        };
        for e in &sel.entered {
            let mut f = to_found(e, String::new());
            if e.j == 1 {
                match sel.tau {
                    Some(Some(t)) => f.value = t,
                    _ => {
                        f.why = format!(
                            "the delay's best fit lies at the edge of the ±{DELAY_RANGE_S} s searched: not a sensor delay (the reconstruction of this channel fails)"
                        )
                    }
                }
            }
            if f.why.is_empty() && !f.param.plausible(f.value) {
                f.why = format!(
                    "{} = {:.3} is outside the physical range of its kind: the reconstruction of this channel fails, not this sensor",
                    f.param.name(),
                    f.value
                );
            }
            if f.why.is_empty() {
                out.found.push(f);
            } else {
                out.rejected.push(f);
            }
        }
        let crit = self.crit;
        for e in sel.refused.iter().filter(|e| e.score.0 > self.threshold) {
            let why = if e.score.1 > 0.0 {
                format!(
                    "significant with the control instruments but does not improve the held-out fit beyond noise (gain T {:.1} ≤ {crit:.1})",
                    e.score.3
                )
            } else {
                "significant with the control instruments but its held-out gain is not positive".to_string()
            };
            out.rejected.push(to_found(e, why));
        }
    }
}

/// The exact delay `τ` minimising `‖d − ((1+k)ŷ(t−τ) − ŷ(t))‖²` (`k` fitted when `with_scale`,
/// else 0): a search at sample resolution over ±[`DELAY_RANGE_S`], refined by a parabola through
/// the best sample and its neighbours. `None` when the best sample is at the edge of the range
/// (no minimum inside it).
fn exact_delay(d: &[f64], yh: &[f64], h_s: f64, with_scale: bool) -> Option<f64> {
    let n = d.len();
    let steps = (DELAY_RANGE_S / h_s).round() as i64;
    // Interior samples only, so that every shift sees data.
    let lo = steps.unsigned_abs() as usize;
    let hi = n.saturating_sub(lo);
    if hi <= lo + 10 || steps < 2 {
        return None;
    }
    let sse = |shift: f64| -> f64 {
        let s = super::signal::shift(yh, h_s, -shift);
        let (mut sy, mut ss) = (0.0, 0.0);
        for i in lo..hi {
            sy += (d[i] + yh[i]) * s[i];
            ss += s[i] * s[i];
        }
        let one_plus_k = if with_scale && ss > 0.0 { sy / ss } else { 1.0 };
        (lo..hi).map(|i| (d[i] + yh[i] - one_plus_k * s[i]).powi(2)).sum()
    };
    let costs: Vec<f64> = (-steps..=steps).map(|k| sse(k as f64 * h_s)).collect();
    let best = (0..costs.len()).min_by(|&a, &b| costs[a].total_cmp(&costs[b]))?;
    if best == 0 || best + 1 == costs.len() {
        return None;
    }
    let mut tau = (best as i64 - steps) as f64 * h_s;
    let (a, b, c) = (costs[best - 1], costs[best], costs[best + 1]);
    let den = a - 2.0 * b + c;
    if den > 0.0 {
        tau += 0.5 * (a - c) / den * h_s;
    }
    Some(tau)
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
        let (z, used) = instruments(&f, n, H, &[Quantity::Elevator]);
        // THEN the Laguerre outputs (columns 1…) are orthonormal: Σ lᵢ(k) lⱼ(k) = δᵢⱼ, up to the
        // de-meaned input's constant −1/n, which every filter passes with its DC gain
        // G = √((1+a)/(1−a)) ≈ 10 and changes each sum by at most 3G²/n (≈ 0.015)
        assert_eq!(used, vec![Quantity::Elevator]);
        assert_eq!(z.len(), 1 + ORDERS);
        let a = (-H / LAGUERRE_T_S).exp();
        let tol = 3.0 * (1.0 + a) / (1.0 - a) / n as f64;
        for i in 1..z.len() {
            for j in 1..z.len() {
                let dot: f64 = z[i].iter().zip(&z[j]).map(|(a, b)| a * b).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < tol, "⟨L{}, L{}⟩ = {dot}", i - 1, j - 1);
            }
        }
    }

    #[test]
    fn a_stuck_vane_nan_samples_and_a_short_flight_name_nothing_and_do_not_panic() {
        // GIVEN a gusty flight whose vane is stuck (constant), one with a NaN sample in the vane,
        // and one of 10 s
        let (f, vane, kin) = flight(4, 0.0, 0.0);
        let stuck = vec![0.05; vane.len()];
        let r = check_channel(&f, H, Quantity::Alpha, &stuck, &kin, &settings());
        // THEN the stuck vane is not named as a scale factor (its fit, k ≈ −1, is outside the
        // physical range and refused with the reason) and nothing panics
        assert!(r.found.is_empty(), "{:?}", r.found);
        assert!(r.rejected.iter().all(|x| !x.why.is_empty()), "{:?}", r.rejected);
        let mut bad = vane.clone();
        bad[100] = f64::NAN;
        let r = check_channel(&f, H, Quantity::Alpha, &bad, &kin, &settings());
        assert!(r.found.is_empty() && r.tested.is_empty());
        assert!(r.note.contains("finite"), "{}", r.note);
        let short = 1000;
        let r = check_channel(
            &blank(short, f.channels[&Quantity::Elevator][..short].to_vec()),
            H,
            Quantity::Alpha,
            &vane[..short],
            &kin[..short],
            &settings(),
        );
        assert!(r.found.is_empty() && r.tested.is_empty());
        assert!(r.note.contains("20 s"), "{}", r.note);
    }
}
