//! Data compatibility (issue 6 §2.1): flight-path reconstruction from the inertial measurements, and
//! the sensor errors that make the air data and attitude disagree with it.
//!
//! ## Method
//! Output-error estimation on the kinematic equations (Klein & Morelli, *Aircraft System
//! Identification*, 2006, ch. 10, eq. 10.4–10.15; Jategaonkar, *Flight Vehicle System
//! Identification*, 2nd ed., ch. 10): the measured accelerations and rates are the **inputs** of the
//! exact rigid-body kinematics, the air data and attitude the **outputs**; initial states and sensor
//! errors are fitted by Gauss–Newton (finite-difference sensitivities, residual weighting by the
//! inverse residual variance of each output, re-estimated every iteration, as in the output-error
//! method of Klein & Morelli §6.2). Two parts:
//!
//! * **Attitude**: `φ̇ = p + (q sin φ + r cos φ) tan θ`, `θ̇ = q cos φ − r sin φ`,
//!   `ψ̇ = (q sin φ + r cos φ)/cos θ`, rates corrected by gyro biases; outputs the measured `φ, θ, ψ`
//!   (longitudinal data: `θ̇ = q`).
//! * **Velocity**: `u̇ = a_x − g sin θ + r v − q w`, `v̇ = a_y + g cos θ sin φ + p w − r u`,
//!   `ẇ = a_z + g cos θ cos φ + q u − p v` with accelerometer biases; outputs
//!   `V_m = (1+k_V)V(t−τ_V) + b_V`, `α_m = (1+k_α)α_v(t−τ_α) + b_α`, `β_m` likewise, where `α_v`, `β_v`
//!   are the angles of the local velocity `v + ω × r_vane` at the vane (known position plus an
//!   estimated `Δx`) — the upwash of a vane ahead of the wing shows as `k_α`. **Reading**: the
//!   gravity terms use the *measured* attitude, not the reconstructed one: with a MEMS gyro
//!   (0.005 rad/s white noise) the integrated attitude random-walks by ~0.004 rad in 90 s, which
//!   `g` turns into metres per second of velocity drift, while the measured attitude's white error
//!   integrates to centimetres per second. Steady air is assumed (turbulence shows as
//!   coloured output residuals, which the coloured-residual covariance below accounts for; wind is
//!   not estimated).
//!
//! ## Which sensor errors: stepwise, as the aerodynamic terms
//! The baseline fits only the initial states (perfect sensors). Every sensor-error parameter is a
//! candidate; at the converged fit each is scored by the partial test of its sensitivity column
//! against the weighted residuals, linearised about the fit ([`super::regress::partial_test`], the
//! score form of the F-test), with standard errors from the coloured-residual covariance. The best
//! candidate above the threshold enters, the model is refitted, and the others are scored again
//! (forward selection, Klein & Morelli §5.4.1), at most `max_added` times. Integration is RK4 with
//! inputs interpolated linearly between samples.

use super::regress::{ols, partial_test};
use super::signal::{mean, shift};
use crate::io::measured::{MeasuredFlight, Quantity};
use nalgebra::Vector3;

/// Standard gravity, m/s².
const G_MPS2: f64 = 9.806_65;

/// A sensor-error parameter of the compatibility model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum SensorParam {
    /// Additive bias of a channel (its unit).
    Bias(Quantity),
    /// Relative scale factor error `k` (`measured = (1+k) true`).
    Scale(Quantity),
    /// Time delay of a channel, s.
    Delay(Quantity),
    /// Unknown extra x position of a vane, m (`Alpha` or `Beta`).
    VaneX(Quantity),
}

impl SensorParam {
    /// The channel.
    pub fn channel(&self) -> Quantity {
        match *self {
            Self::Bias(q) | Self::Scale(q) | Self::Delay(q) | Self::VaneX(q) => q,
        }
    }
    /// Short name for reports, e.g. `bias(Alpha)`.
    pub fn name(&self) -> String {
        match self {
            Self::Bias(q) => format!("bias({q:?})"),
            Self::Scale(q) => format!("scale({q:?})"),
            Self::Delay(q) => format!("delay({q:?})"),
            Self::VaneX(q) => format!("vane_x({q:?})"),
        }
    }
    /// Unit of the estimate.
    pub fn unit(&self) -> &'static str {
        match self {
            Self::Bias(q) => unit_of(*q),
            Self::Scale(_) => "-",
            Self::Delay(_) => "s",
            Self::VaneX(_) => "m",
        }
    }
    fn fd_step(&self) -> f64 {
        match self {
            Self::Bias(q) => match q {
                Quantity::Airspeed => 1e-2,
                Quantity::AccelX | Quantity::AccelY | Quantity::AccelZ => 1e-3,
                _ => 1e-5,
            },
            Self::Scale(_) => 1e-4,
            Self::Delay(_) => 2e-3,
            Self::VaneX(_) => 1e-2,
        }
    }
}

fn unit_of(q: Quantity) -> &'static str {
    match q {
        Quantity::Airspeed => "m/s",
        Quantity::AccelX | Quantity::AccelY | Quantity::AccelZ => "m/s²",
        Quantity::RollRate | Quantity::PitchRate | Quantity::YawRate => "rad/s",
        _ => "rad",
    }
}

/// A candidate's score in one round.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamScore {
    /// The parameter.
    pub param: SensorParam,
    /// Linearised estimate.
    pub value: f64,
    /// Its standard error (coloured residuals).
    pub sigma: f64,
    /// Partial test statistic `t²`.
    pub t2: f64,
}

/// A sensor error found, with its final estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The parameter.
    pub param: SensorParam,
    /// Estimate after the refit.
    pub value: f64,
    /// Standard error after the refit.
    pub sigma: f64,
    /// `t²` when it entered.
    pub t2: f64,
    /// Which part found it (`"attitude"` or `"velocity"`).
    pub part: &'static str,
}

/// The RMS of one output's residual before (perfect sensors) and after (found errors) the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputRms {
    /// The output.
    pub channel: Quantity,
    /// RMS with the baseline (initial states only).
    pub before: f64,
    /// RMS with the sensor errors found.
    pub after: f64,
}

/// The result of the compatibility check.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Compatibility {
    /// What was (not) done and why.
    pub notes: Vec<String>,
    /// First-round scores of every candidate of both parts.
    pub tested: Vec<ParamScore>,
    /// The sensor errors found, in the order they entered.
    pub found: Vec<Found>,
    /// Residual RMS per output.
    pub rms: Vec<OutputRms>,
    /// Reconstructed time histories `(channel, measured, reconstructed with the errors found)`.
    pub traces: Vec<(Quantity, Vec<f64>, Vec<f64>)>,
}

impl Compatibility {
    /// The estimate of a found parameter (0 if not found).
    pub fn value(&self, p: SensorParam) -> f64 {
        self.found.iter().find(|f| f.param == p).map_or(0.0, |f| f.value)
    }
}

/// Settings of the check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompatSettings {
    /// Entry threshold on `t²`.
    pub threshold_t2: f64,
    /// Largest lag of the residual autocorrelation, samples.
    pub max_lag: usize,
    /// Most sensor errors entered per part.
    pub max_added: usize,
}

/// A generic output-error problem: parameters `[fixed…, candidates…]`, a simulation returning one
/// series per output, and the measured outputs.
struct Problem<'a> {
    n_fixed: usize,
    /// Which fixed parameters are fitted (the others stay at their initial value).
    fixed_mask: Vec<bool>,
    fixed_steps: Vec<f64>,
    candidates: Vec<SensorParam>,
    sim: Box<dyn Fn(&[f64]) -> Vec<Vec<f64>> + 'a>,
    measured: Vec<Vec<f64>>,
    outputs: Vec<Quantity>,
}

struct State {
    p: Vec<f64>,
    active: Vec<bool>,
    weights: Vec<f64>,
}

impl Problem<'_> {
    fn step(&self, j: usize) -> f64 {
        if j < self.n_fixed {
            self.fixed_steps[j]
        } else {
            self.candidates[j - self.n_fixed].fd_step()
        }
    }

    /// Stacked weighted residual and per-output residual variances.
    fn residual(&self, y: &[Vec<f64>], weights: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut r = Vec::new();
        let mut var = Vec::new();
        for (o, (m, s)) in self.measured.iter().zip(y).enumerate() {
            let d: Vec<f64> = m.iter().zip(s).map(|(a, b)| a - b).collect();
            var.push(d.iter().map(|v| v * v).sum::<f64>() / d.len().max(1) as f64);
            r.extend(d.iter().map(|v| v * weights[o].sqrt()));
        }
        (r, var)
    }

    fn sensitivity(&self, p: &[f64], j: usize, weights: &[f64]) -> Vec<f64> {
        let h = self.step(j);
        let (mut up, mut dn) = (p.to_vec(), p.to_vec());
        up[j] += h;
        dn[j] -= h;
        let (yu, yd) = ((self.sim)(&up), (self.sim)(&dn));
        let mut col = Vec::new();
        for (o, (a, b)) in yu.iter().zip(&yd).enumerate() {
            col.extend(a.iter().zip(b).map(|(x, y)| (x - y) / (2.0 * h) * weights[o].sqrt()));
        }
        col
    }

    /// Gauss–Newton on the active parameters, weights re-estimated each iteration.
    fn fit(&self, st: &mut State) {
        let idx: Vec<usize> = (0..st.p.len()).filter(|&j| st.active[j]).collect();
        let mut y = (self.sim)(&st.p);
        for _ in 0..12 {
            let (_, var) = self.residual(&y, &st.weights);
            st.weights = var.iter().map(|v| 1.0 / v.max(1e-12)).collect();
            let (r, _) = self.residual(&y, &st.weights);
            let cost: f64 = r.iter().map(|v| v * v).sum();
            let cols: Vec<Vec<f64>> = idx.iter().map(|&j| self.sensitivity(&st.p, j, &st.weights)).collect();
            let Some(f) = ols(&cols, &r, r.len(), 0) else {
                return;
            };
            let mut lambda = 1.0;
            let mut improved = false;
            for _ in 0..6 {
                let mut trial = st.p.clone();
                for (k, &j) in idx.iter().enumerate() {
                    trial[j] += lambda * f.theta[k];
                }
                let yt = (self.sim)(&trial);
                let (rt, _) = self.residual(&yt, &st.weights);
                let ct: f64 = rt.iter().map(|v| v * v).sum();
                if ct.is_finite() && ct <= cost {
                    let rel = (cost - ct) / cost.max(1e-300);
                    st.p = trial;
                    y = yt;
                    improved = rel > 1e-9;
                    break;
                }
                lambda *= 0.5;
            }
            if !improved {
                break;
            }
        }
        let (_, var) = self.residual(&y, &st.weights);
        st.weights = var.iter().map(|v| 1.0 / v.max(1e-12)).collect();
    }

    /// Linearised scores of the inactive candidates, and the σ of the active ones.
    fn scores(&self, st: &State, max_lag: usize) -> (Vec<ParamScore>, Vec<(usize, f64)>) {
        let y = (self.sim)(&st.p);
        let (r, _) = self.residual(&y, &st.weights);
        let n_out = self.measured.first().map_or(0, |m| m.len());
        let idx: Vec<usize> = (0..st.p.len()).filter(|&j| st.active[j]).collect();
        let cols: Vec<Vec<f64>> = idx.iter().map(|&j| self.sensitivity(&st.p, j, &st.weights)).collect();
        let sig = ols(&cols, &r, n_out, max_lag)
            .map(|f| idx.iter().zip(f.sigma).map(|(&j, s)| (j, s)).collect())
            .unwrap_or_default();
        let mut out = Vec::new();
        for (c, &param) in self.candidates.iter().enumerate() {
            let j = self.n_fixed + c;
            if st.active[j] {
                continue;
            }
            let col = self.sensitivity(&st.p, j, &st.weights);
            if let Some((f, t2)) = partial_test(&cols, &col, &r, n_out, max_lag) {
                let k = f.theta.len() - 1;
                out.push(ParamScore {
                    param,
                    value: st.p[j] + f.theta[k],
                    sigma: f.sigma[k],
                    t2,
                });
            }
        }
        (out, sig)
    }

    fn rms(&self, p: &[f64]) -> Vec<f64> {
        let y = (self.sim)(p);
        self.measured
            .iter()
            .zip(&y)
            .map(|(m, s)| (m.iter().zip(s).map(|(a, b)| (a - b) * (a - b)).sum::<f64>() / m.len().max(1) as f64).sqrt())
            .collect()
    }
}

/// Runs a problem: baseline fit, forward selection of sensor errors. Returns (tested in the first
/// round, found, rms before/after, final parameters).
fn run(prob: &Problem, p0: Vec<f64>, s: &CompatSettings, part: &'static str) -> (Vec<ParamScore>, Vec<Found>, Vec<OutputRms>, Vec<f64>) {
    let n = p0.len();
    let mut st = State {
        p: p0,
        active: (0..n).map(|j| j < prob.n_fixed && prob.fixed_mask[j]).collect(),
        weights: vec![1.0; prob.measured.len()],
    };
    prob.fit(&mut st);
    let before = prob.rms(&st.p);
    let mut first = None;
    let mut entered: Vec<(usize, f64)> = Vec::new();
    for _ in 0..s.max_added {
        let (scores, _) = prob.scores(&st, s.max_lag);
        let best = scores
            .iter()
            .filter(|c| c.t2.is_finite())
            .max_by(|a, b| a.t2.total_cmp(&b.t2))
            .cloned();
        if first.is_none() {
            first = Some(scores);
        }
        match best {
            Some(b) if b.t2 > s.threshold_t2 => {
                let j = prob.n_fixed + prob.candidates.iter().position(|c| *c == b.param).unwrap_or(0);
                st.active[j] = true;
                st.p[j] = b.value;
                prob.fit(&mut st);
                entered.push((j, b.t2));
            }
            _ => break,
        }
    }
    let (_, sig) = prob.scores(&st, s.max_lag);
    let found = entered
        .iter()
        .map(|&(j, t2)| Found {
            param: prob.candidates[j - prob.n_fixed],
            value: st.p[j],
            sigma: sig.iter().find(|(k, _)| *k == j).map_or(f64::NAN, |x| x.1),
            t2,
            part,
        })
        .collect();
    let after = prob.rms(&st.p);
    let rms = prob
        .outputs
        .iter()
        .zip(before.iter().zip(&after))
        .map(|(&channel, (&b, &a))| OutputRms { channel, before: b, after: a })
        .collect();
    (first.unwrap_or_default(), found, rms, st.p)
}

/// RK4 over the sample grid with the inputs linearly interpolated; `f(x, k, frac)` is the state
/// derivative at sample `k` plus `frac` of a step.
fn integrate<const N: usize>(x0: [f64; N], n: usize, h: f64, f: impl Fn(&[f64; N], usize, f64) -> [f64; N]) -> Vec<[f64; N]> {
    let mut xs = Vec::with_capacity(n);
    let mut x = x0;
    let add = |a: &[f64; N], b: &[f64; N], s: f64| -> [f64; N] { core::array::from_fn(|i| a[i] + s * b[i]) };
    for k in 0..n {
        xs.push(x);
        if k + 1 == n {
            break;
        }
        let k1 = f(&x, k, 0.0);
        let k2 = f(&add(&x, &k1, h / 2.0), k, 0.5);
        let k3 = f(&add(&x, &k2, h / 2.0), k, 0.5);
        let k4 = f(&add(&x, &k3, h), k, 1.0);
        x = core::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    xs
}

fn lerp(x: &[f64], k: usize, frac: f64) -> f64 {
    if frac == 0.0 || k + 1 >= x.len() {
        x[k]
    } else {
        x[k] + frac * (x[k + 1] - x[k])
    }
}

/// Unwraps an angle series (removes 2π jumps).
fn unwrap(x: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len());
    let mut off = 0.0;
    for (i, &v) in x.iter().enumerate() {
        if i > 0 {
            let d = v + off - out[i - 1];
            if d > core::f64::consts::PI {
                off -= core::f64::consts::TAU;
            } else if d < -core::f64::consts::PI {
                off += core::f64::consts::TAU;
            }
        }
        out.push(v + off);
    }
    out
}

/// The compatibility check of a flight (uniform time base `h_s`).
pub fn check(flight: &MeasuredFlight, h_s: f64, s: &CompatSettings) -> Compatibility {
    use Quantity::*;
    let mut out = Compatibility::default();
    let n = flight.len();
    let zeros = vec![0.0; n];
    let get = |q: Quantity| flight.get(q);
    let (Some(q_m), Some(theta_m)) = (get(PitchRate), get(Pitch)) else {
        out.notes.push("no pitch rate or pitch attitude: compatibility check not performed".into());
        return out;
    };
    let lateral = get(RollRate).is_some() && get(YawRate).is_some() && get(Roll).is_some();
    let p_m = get(RollRate).unwrap_or(&zeros);
    let r_m = get(YawRate).unwrap_or(&zeros);
    let phi_m = get(Roll).unwrap_or(&zeros);
    // ---- Part A: attitude.
    let psi_m = get(Yaw).filter(|_| lateral).map(unwrap);
    let mut outputs = vec![Pitch];
    let mut measured = vec![theta_m.to_vec()];
    let mut cands = vec![SensorParam::Bias(PitchRate)];
    if lateral {
        outputs.insert(0, Roll);
        measured.insert(0, phi_m.to_vec());
        cands.insert(0, SensorParam::Bias(RollRate));
        cands.push(SensorParam::Bias(YawRate));
    }
    if let Some(psi) = &psi_m {
        outputs.push(Yaw);
        measured.push(psi.clone());
    }
    let n_fixed = 3;
    let cands_a = cands.clone();
    let bias_of = move |p: &[f64], q: Quantity| -> f64 {
        cands_a
            .iter()
            .position(|c| *c == SensorParam::Bias(q))
            .map_or(0.0, |i| p[n_fixed + i])
    };
    let outs_a = outputs.clone();
    let sim_a = {
        let bias_of = bias_of.clone();
        move |p: &[f64]| -> Vec<Vec<f64>> {
            let (bp, bq, br) = (bias_of(p, RollRate), bias_of(p, PitchRate), bias_of(p, YawRate));
            let xs = integrate([p[0], p[1], p[2]], n, h_s, |x, k, fr| {
                let (pp, qq, rr) = (lerp(p_m, k, fr) - bp, lerp(q_m, k, fr) - bq, lerp(r_m, k, fr) - br);
                if !lateral {
                    return [0.0, qq, 0.0];
                }
                let (sf, cf) = x[0].sin_cos();
                let (st, ct) = x[1].sin_cos();
                let ct = if ct.abs() < 1e-3 { 1e-3f64.copysign(ct) } else { ct };
                [pp + (qq * sf + rr * cf) * st / ct, qq * cf - rr * sf, (qq * sf + rr * cf) / ct]
            });
            outs_a
                .iter()
                .map(|o| {
                    let i = match o {
                        Roll => 0,
                        Pitch => 1,
                        _ => 2,
                    };
                    xs.iter().map(|x| x[i]).collect()
                })
                .collect()
        }
    };
    let p0 = {
        let mut p = vec![phi_m[0], theta_m[0], psi_m.as_ref().map_or(0.0, |v| v[0])];
        p.extend(cands.iter().map(|_| 0.0));
        p
    };
    let prob_a = Problem {
        n_fixed,
        fixed_mask: vec![lateral, true, psi_m.is_some()],
        fixed_steps: vec![1e-5; 3],
        candidates: cands.clone(),
        sim: Box::new(sim_a),
        measured,
        outputs: outputs.clone(),
    };
    let (tested, found, rms, p_a) = run(&prob_a, p0, s, "attitude");
    let gyro_bias = [
        bias_of(&p_a, RollRate),
        bias_of(&p_a, PitchRate),
        bias_of(&p_a, YawRate),
    ];
    out.tested.extend(tested);
    out.found.extend(found);
    out.rms.extend(rms);
    // ---- Part B: velocity and air data.
    let (Some(ax), Some(az), Some(v_m), Some(a_m)) = (get(AccelX), get(AccelZ), get(Airspeed), get(Alpha)) else {
        out.notes.push("no accelerometer x/z, airspeed or α: air-data compatibility not checked".into());
        return out;
    };
    let lat_v = lateral && get(AccelY).is_some();
    let ay = get(AccelY).unwrap_or(&zeros);
    let beta_m = get(Beta).filter(|_| lat_v);
    let mut outputs = vec![Airspeed, Alpha];
    let mut measured = vec![v_m.to_vec(), a_m.to_vec()];
    let mut cands = vec![
        SensorParam::Bias(AccelX),
        SensorParam::Bias(AccelZ),
        SensorParam::Bias(Airspeed),
        SensorParam::Scale(Airspeed),
        SensorParam::Delay(Airspeed),
        SensorParam::Bias(Alpha),
        SensorParam::Scale(Alpha),
        SensorParam::Delay(Alpha),
        SensorParam::VaneX(Alpha),
    ];
    if lat_v {
        cands.push(SensorParam::Bias(AccelY));
    }
    if let Some(b) = beta_m {
        outputs.push(Beta);
        measured.push(b.to_vec());
        cands.extend([
            SensorParam::Bias(Beta),
            SensorParam::Scale(Beta),
            SensorParam::Delay(Beta),
            SensorParam::VaneX(Beta),
        ]);
    }
    let ac = &flight.aircraft;
    let (rv_a, rv_b) = (ac.alpha_vane_position_m, ac.beta_vane_position_m);
    let cands_b = cands.clone();
    let par = move |p: &[f64], c: SensorParam| -> f64 {
        cands_b.iter().position(|x| *x == c).map_or(0.0, |i| p[3 + i])
    };
    let pc: Vec<f64> = p_m.iter().map(|v| v - gyro_bias[0]).collect();
    let qc: Vec<f64> = q_m.iter().map(|v| v - gyro_bias[1]).collect();
    let rc: Vec<f64> = r_m.iter().map(|v| v - gyro_bias[2]).collect();
    let (pc, qc, rc) = (&pc, &qc, &rc);
    let outs_b = outputs.clone();
    let sim_b = move |p: &[f64]| -> Vec<Vec<f64>> {
        use SensorParam as S;
        let (bx, by, bz) = (par(p, S::Bias(AccelX)), par(p, S::Bias(AccelY)), par(p, S::Bias(AccelZ)));
        let xs = integrate([p[0], p[1], p[2]], n, h_s, |x, k, fr| {
            let w = Vector3::new(lerp(pc, k, fr), lerp(qc, k, fr), lerp(rc, k, fr));
            let (sf, cf) = lerp(phi_m, k, fr).sin_cos();
            let (st, ct) = lerp(theta_m, k, fr).sin_cos();
            let a = Vector3::new(lerp(ax, k, fr) - bx, lerp(ay, k, fr) - by, lerp(az, k, fr) - bz);
            let g = Vector3::new(-st, ct * sf, ct * cf) * G_MPS2;
            let v = Vector3::new(x[0], if lat_v { x[1] } else { 0.0 }, x[2]);
            let d = a + g - w.cross(&v);
            [d.x, if lat_v { d.y } else { 0.0 }, d.z]
        });
        outs_b
            .iter()
            .map(|o| {
                let base: Vec<f64> = xs
                    .iter()
                    .enumerate()
                    .map(|(k, x)| {
                        let w = Vector3::new(pc[k], qc[k], rc[k]);
                        let v = Vector3::new(x[0], x[1], x[2]);
                        match o {
                            Airspeed => v.norm(),
                            Alpha => {
                                let r = rv_a + Vector3::new(par(p, S::VaneX(Alpha)), 0.0, 0.0);
                                let l = v + w.cross(&r);
                                l.z.atan2(l.x)
                            }
                            _ => {
                                let r = rv_b + Vector3::new(par(p, S::VaneX(Beta)), 0.0, 0.0);
                                let l = v + w.cross(&r);
                                (l.y / l.norm().max(1e-6)).clamp(-1.0, 1.0).asin()
                            }
                        }
                    })
                    .collect();
                let delayed = shift(&base, h_s, -par(p, S::Delay(*o)));
                let (k, b) = (par(p, S::Scale(*o)), par(p, S::Bias(*o)));
                delayed.iter().map(|y| (1.0 + k) * y + b).collect()
            })
            .collect()
    };
    let k0 = 10.min(n);
    let (v0, al0) = (mean(&v_m[..k0]), mean(&a_m[..k0]));
    let be0 = beta_m.map_or(0.0, |b| mean(&b[..k0]));
    let mut p0 = vec![v0 * al0.cos() * be0.cos(), v0 * be0.sin(), v0 * al0.sin() * be0.cos()];
    p0.extend(cands.iter().map(|_| 0.0));
    let prob_b = Problem {
        n_fixed: 3,
        fixed_mask: vec![true, lat_v, true],
        fixed_steps: vec![1e-3; 3],
        candidates: cands,
        sim: Box::new(sim_b),
        measured: measured.clone(),
        outputs: outputs.clone(),
    };
    let (tested, found, rms, p_b) = run(&prob_b, p0, s, "velocity");
    out.tested.extend(tested);
    out.found.extend(found);
    out.rms.extend(rms);
    let y = (prob_b.sim)(&p_b);
    for ((o, m), yy) in outputs.iter().zip(measured).zip(y) {
        out.traces.push((*o, m, yy));
    }
    out
}
