//! What the simulation gets wrong: the fitted models simulate the motion on the
//! held-out segment, and the simulated states are compared with the measured ones — the validation
//! of seed 000 §VI.B (Fig. 4–5), which reconstructs α and β of a *different* flight segment with
//! the identified `C_L` and `C_Y` models.
//!
//! ## Two partial simulations (reading chosen)
//! The seed does not say how its α, β were reconstructed. We integrate the equations of motion of
//! each group of coefficients with the measured values of everything else as inputs, so that an
//! error of one group does not show in the other (and a full 6-DoF simulation of a closed-loop
//! flight diverges within seconds without the controller):
//!
//! * **Forces** (`C_L`, `C_D`, and `C_Y` when present) → the body velocity `u, v, w` at the CG:
//!   `u̇ = a_x − g sin θ + r v − q w`, `v̇ = a_y + g cos θ sin φ + p w − r u`,
//!   `ẇ = a_z + g cos θ cos φ + q u − p v` (the kinematics of the compatibility check), with
//!   `a = (F_A + F_T)/m` and `F_A` from the *models* by eq. 1 (stability axes, as the synthesis):
//!   `F_x = q̄S(−C_D cos α + C_L sin α)`, `F_y = q̄S C_Y`, `F_z = q̄S(−C_D sin α − C_L cos α)`,
//!   `q̄ = ½ρV²` of the *simulated* airspeed. The models' α, β and `V` (and the thrust coefficient,
//!   through `q̄`) are the simulated ones; rates, attitude, surfaces, thrust and `α̇` are the
//!   measured (corrected, smoothed) ones. Outputs `V`, α, β.
//! * **Moments** (`C_m`, and `C_l`, `C_n` when present) → `ω̇ = J⁻¹(M_A + M_T − ω × Jω)` with
//!   `M_A = q̄S(b C_l, c̄ C_m, b C_n)` from the models, evaluated at the *simulated* rates; α, β, `V`,
//!   surfaces and thrust measured. With only `C_m`, only `q` is simulated. Outputs `p, q, r`.
//!
//! The held-out segment is cut into pieces of [`super::compat::SEGMENT_S`] (the last one merged
//! into its predecessor when shorter than half of that); each piece starts from the measured
//! (reconstructed) state at its first sample, as the output-error method's separate manoeuvres
//! do. Integration: RK4 on the sample grid with the inputs interpolated linearly. A piece whose
//! state leaves the plausible range (non-finite, `V` below a third or above three times its
//! start, `|α|` above 1.2 rad, a rate above 20 rad/s) is cut there and counted as diverged: the
//! output says where ([`SimulatedOutput::diverged_at_s`]) and carries no R², RMS or PSE for that
//! model set (its metrics are NaN, `null` in JSON) — a figure over the part before the cut would
//! describe a simulation that did not finish.
//!
//! The comparison is against the states the models were fitted on: the reconstructed air data
//! (the "sensor fusion solution" the seed calls ground truth) or the corrected vanes, and the
//! corrected rates. Metrics per output ([`super::regress::metrics`]): R², RMS and PSE, the PSE
//! penalty counting the parameters of every model that drives the output.

use super::compat::SEGMENT_S;
use super::model::{Kinematics, Signal, Table, Term, TermRefs};
use super::regress::{metrics, Metrics};
use super::signal::sin_cos;
use crate::io::measured::Aircraft;
use nalgebra::{Matrix3, Vector3};

/// Standard gravity, m/s².
const G_MPS2: f64 = 9.806_65;

/// A set of fitted models: per coefficient (`C_L`…`C_n`), its terms and estimates.
pub type ModelSet = [Option<Vec<(Term, f64)>>; 6];

/// The comparison of one simulated output.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SimulatedOutput {
    /// The output (`Airspeed`, `Alpha`, `Beta`, `RollRate`, `PitchRate`, `YawRate`).
    pub channel: String,
    /// Unit of the RMS.
    pub unit: &'static str,
    /// With the baseline models (NaN when a piece diverged).
    pub baseline: Metrics,
    /// With the extended models (NaN when a piece diverged).
    pub extended: Metrics,
    /// Pieces cut short as diverged: baseline, extended.
    pub diverged: [usize; 2],
    /// Where each diverged piece was cut, s (on the report's time base): baseline, extended.
    pub diverged_at_s: [Vec<f64>; 2],
}

impl SimulatedOutput {
    /// Whether the simulation with the model set `w` (0 baseline, 1 extended) diverged.
    pub fn diverged_with(&self, w: usize) -> bool {
        self.diverged[w] > 0
    }
}

/// Time histories of one simulated output over the held-out segment.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimulatedTrace {
    /// The output.
    pub channel: String,
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Measured (reconstructed) state.
    pub measured: Vec<f64>,
    /// Simulated with the baseline models (NaN after a divergence).
    pub baseline: Vec<f64>,
    /// Simulated with the extended models.
    pub extended: Vec<f64>,
    /// Start of each piece, s.
    pub piece_starts_s: Vec<f64>,
}

/// The simulation on the held-out segment.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Simulation {
    /// Length of the pieces, s.
    pub piece_s: f64,
    /// Per output.
    pub outputs: Vec<SimulatedOutput>,
    /// For the figure.
    pub traces: Vec<SimulatedTrace>,
    /// What was not simulated and why.
    pub notes: Vec<String>,
}

/// The pieces `[a, b)` of the held-out samples `n_id..n`.
fn pieces(n_id: usize, n: usize, h_s: f64) -> Vec<(usize, usize)> {
    let len = ((SEGMENT_S / h_s).round() as usize).max(10);
    let mut out = Vec::new();
    let mut a = n_id;
    while a + 1 < n {
        let b = (a + len).min(n);
        out.push((a, b));
        a = b;
    }
    if out.len() > 1 {
        let (a, b) = out[out.len() - 1];
        if b - a < len / 2 {
            out.pop();
            let last = out.len() - 1;
            out[last].1 = b;
        }
    }
    out
}

pub(super) fn lerp(x: &[f64], k: usize, frac: f64) -> f64 {
    if frac == 0.0 || k + 1 >= x.len() {
        x[k]
    } else {
        x[k] + frac * (x[k + 1] - x[k])
    }
}

pub(super) fn lerp3(x: &[Vector3<f64>], k: usize, frac: f64) -> Vector3<f64> {
    if frac == 0.0 || k + 1 >= x.len() {
        x[k]
    } else {
        x[k] + (x[k + 1] - x[k]) * frac
    }
}

/// A model's value on a snapshot (`None` if a term is unavailable).
fn model_value(m: &[(Term, f64)], s: &super::model::Snapshot, refs: &TermRefs) -> Option<f64> {
    m.iter().map(|(t, th)| t.eval(s, refs).map(|v| v * th)).sum()
}

/// RK4 over the samples `a..b` (inputs at fractions 0, ½, 1); stops early when `ok` fails.
fn integrate<const N: usize>(
    x0: [f64; N],
    a: usize,
    b: usize,
    h: f64,
    f: impl Fn(&[f64; N], usize, f64) -> Option<[f64; N]>,
    ok: impl Fn(&[f64; N]) -> bool,
) -> (Vec<[f64; N]>, bool) {
    let mut xs = Vec::with_capacity(b - a);
    let mut x = x0;
    let add = |p: &[f64; N], d: &[f64; N], s: f64| -> [f64; N] { core::array::from_fn(|i| p[i] + s * d[i]) };
    for k in a..b {
        if !ok(&x) {
            return (xs, true);
        }
        xs.push(x);
        if k + 1 == b {
            break;
        }
        let step = (|| {
            let k1 = f(&x, k, 0.0)?;
            let k2 = f(&add(&x, &k1, h / 2.0), k, 0.5)?;
            let k3 = f(&add(&x, &k2, h / 2.0), k, 0.5)?;
            let k4 = f(&add(&x, &k3, h), k, 1.0)?;
            Some(core::array::from_fn(|i| {
                x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            }))
        })();
        match step {
            Some(nx) => x = nx,
            None => return (xs, true),
        }
    }
    (xs, false)
}

/// The inertia with unknown entries as zero (as the synthesis).
pub(super) fn inertia(ac: &Aircraft) -> Matrix3<f64> {
    ac.inertia_kgm2.map(|x| if x.is_finite() { x } else { 0.0 })
}

/// Simulates both groups with the baseline and the extended models on the held-out samples
/// `n_id..`. `params` counts each coefficient's parameters (baseline, extended) for the PSE.
pub fn simulate(
    table: &Table,
    aircraft: &Aircraft,
    h_s: f64,
    refs: &TermRefs,
    n_id: usize,
    manoeuvres: &[(usize, usize)],
    models: [&ModelSet; 2],
) -> Simulation {
    let mut out = Simulation {
        piece_s: SEGMENT_S,
        ..Simulation::default()
    };
    let n = table.t_s.len();
    let Some(kin) = &table.kinematics else {
        out.notes.push("no coefficient synthesised: nothing to simulate".into());
        return out;
    };
    if n_id + 2 >= n {
        out.notes.push("held-out segment too short to simulate".into());
        return out;
    }
    // Each held-out manoeuvre of a pooled flight is simulated on its own (from its own
    // measured state), in pieces as one record.
    let ps: Vec<(usize, usize)> = manoeuvres
        .iter()
        .filter_map(|&(a, b)| {
            let a = a.max(n_id);
            (b > a + 2).then_some((a, b))
        })
        .flat_map(|(a, b)| pieces(a, b, h_s))
        .collect();
    force_group(table, kin, aircraft, h_s, refs, &ps, models, &mut out);
    moment_group(table, kin, aircraft, h_s, refs, &ps, models, &mut out);
    out
}

/// The time at which a piece `a..b` was cut after `kept` samples.
fn cut_time(table: &Table, a: usize, b: usize, kept: usize) -> f64 {
    table.t_s[(a + kept).min(b - 1)]
}

fn params(models: [&ModelSet; 2], coefs: &[usize]) -> [usize; 2] {
    let count = |m: &ModelSet| coefs.iter().map(|&i| m[i].as_ref().map_or(0, |v| v.len())).sum();
    [count(models[0]), count(models[1])]
}

#[allow(clippy::too_many_arguments)]
fn finish(
    out: &mut Simulation,
    table: &Table,
    ps: &[(usize, usize)],
    channel: &str,
    unit: &'static str,
    measured: &[f64],
    sims: [Vec<f64>; 2],
    diverged_at_s: &[Vec<f64>; 2],
    p: [usize; 2],
) {
    let a = ps[0].0;
    let b = ps[ps.len() - 1].1;
    let meas = &measured[a..b];
    let m = |sim: &[f64], p: usize, diverged: bool| -> Metrics {
        if diverged {
            return Metrics {
                r2: f64::NAN,
                rms: f64::NAN,
                pse: f64::NAN,
                n: 0,
            };
        }
        let (z, zh): (Vec<f64>, Vec<f64>) = meas
            .iter()
            .zip(sim)
            .filter(|(_, s)| s.is_finite())
            .map(|(m, s)| (*m, *s))
            .unzip();
        metrics(&z, &zh, p)
    };
    out.outputs.push(SimulatedOutput {
        channel: channel.into(),
        unit,
        baseline: m(&sims[0], p[0], !diverged_at_s[0].is_empty()),
        extended: m(&sims[1], p[1], !diverged_at_s[1].is_empty()),
        diverged: [diverged_at_s[0].len(), diverged_at_s[1].len()],
        diverged_at_s: diverged_at_s.clone(),
    });
    let [sb, se] = sims;
    out.traces.push(SimulatedTrace {
        channel: channel.into(),
        t_s: table.t_s[a..b].to_vec(),
        measured: meas.to_vec(),
        baseline: sb,
        extended: se,
        piece_starts_s: ps.iter().map(|(a, _)| table.t_s[*a]).collect(),
    });
}

/// What the force group's equations run on: the table, its kinematics, the aircraft and the
/// terms' references; `lateral` when β is simulated (a measured β and `C_Y` models).
struct ForcePlant<'a> {
    table: &'a Table,
    kin: &'a Kinematics,
    ac: &'a Aircraft,
    refs: &'a TermRefs,
    lateral: bool,
}

impl ForcePlant<'_> {
    /// The body velocity's derivative `u̇, v̇, ẇ` at `x = [u, v, w]`, sample `k` plus `fr`:
    /// the models' `C_L`, `C_D` (and `C_Y`) at the simulated α, V (and β) with `q̄` from the
    /// simulated airspeed, the measured thrust, rates and attitude. `None` when a term is
    /// unavailable.
    fn velocity_rate(&self, m: &ModelSet, x: &[f64; 3], k: usize, fr: f64) -> Option<[f64; 3]> {
        let (kin, refs, lateral) = (self.kin, self.refs, self.lateral);
        let vel = Vector3::new(x[0], if lateral { x[1] } else { 0.0 }, x[2]);
        let vv = vel.norm().max(1e-3);
        let al = vel.z.atan2(vel.x);
        let be = (vel.y / vv).clamp(-1.0, 1.0).asin();
        let mut s = self.table.snapshot(k, fr);
        let qbar_m = lerp(&kin.qbar_pa, k, fr);
        let rho = lerp(&kin.density_kgpm3, k, fr);
        let qbar = 0.5 * rho * vv * vv;
        s[Signal::Alpha.index()] = al;
        s[Signal::Airspeed.index()] = vv;
        if lateral {
            s[Signal::Beta.index()] = be;
        }
        let ct = Signal::ThrustCoeff.index();
        if !s[ct].is_nan() {
            s[ct] *= qbar_m / qbar.max(1e-9);
        }
        let cl = model_value(m[0].as_ref()?, &s, refs)?;
        let cd = model_value(m[1].as_ref()?, &s, refs)?;
        let cy = if lateral {
            model_value(m[2].as_ref()?, &s, refs)?
        } else {
            0.0
        };
        let (sa, ca) = sin_cos(al);
        let qs = qbar * self.ac.wing_area_m2;
        let fa = Vector3::new(qs * (-cd * ca + cl * sa), qs * cy, qs * (-cd * sa - cl * ca));
        let acc = (fa + lerp3(&kin.thrust_force_n, k, fr)) / self.ac.mass_kg;
        let om = Vector3::new(
            lerp(&kin.rates_rad_s[0], k, fr),
            lerp(&kin.rates_rad_s[1], k, fr),
            lerp(&kin.rates_rad_s[2], k, fr),
        );
        let (sf, cf) = sin_cos(lerp(&kin.attitude_rad[0], k, fr));
        let (st, cth) = sin_cos(lerp(&kin.attitude_rad[1], k, fr));
        let g = Vector3::new(-st, cth * sf, cth * cf) * G_MPS2;
        let d = acc + g - om.cross(&vel);
        Some([d.x, if lateral { d.y } else { 0.0 }, d.z])
    }

    /// Airspeed, α and β of each of a piece's `len` samples from the simulated velocities
    /// (NaN past a divergence), appended to `sims`.
    fn push_flow(&self, xs: &[[f64; 3]], len: usize, sims: &mut [Vec<f64>; 3]) {
        for k in 0..len {
            let (vv, al, be) = match xs.get(k) {
                Some(x) => {
                    let vel = Vector3::new(x[0], if self.lateral { x[1] } else { 0.0 }, x[2]);
                    let vv = vel.norm();
                    (vv, vel.z.atan2(vel.x), (vel.y / vv.max(1e-3)).clamp(-1.0, 1.0).asin())
                }
                None => (f64::NAN, f64::NAN, f64::NAN),
            };
            sims[0].push(vv);
            sims[1].push(al);
            sims[2].push(be);
        }
    }
}

/// The measured α and airspeed the force group needs, or the note why it is not simulated.
fn force_inputs<'a>(
    table: &'a Table,
    kin: &Kinematics,
    models: [&ModelSet; 2],
) -> Result<(&'a [f64], &'a [f64]), &'static str> {
    let (Some(alpha), Some(v_m)) = (table.signals.get(&Signal::Alpha), table.signals.get(&Signal::Airspeed)) else {
        return Err("forces not simulated: no α or airspeed");
    };
    if models.iter().any(|m| m[0].is_none() || m[1].is_none()) {
        return Err("forces not simulated: no C_L or C_D model");
    }
    if !kin.attitude_measured {
        return Err("forces not simulated: no attitude for the gravity terms");
    }
    Ok((alpha, v_m))
}

/// The body velocity simulated from each piece's measured airspeed, α and β with both model
/// sets; airspeed, α (and β) against the measured.
#[allow(clippy::too_many_arguments)]
fn force_group(
    table: &Table,
    kin: &Kinematics,
    ac: &Aircraft,
    h_s: f64,
    refs: &TermRefs,
    ps: &[(usize, usize)],
    models: [&ModelSet; 2],
    out: &mut Simulation,
) {
    let (alpha, v_m) = match force_inputs(table, kin, models) {
        Ok(inputs) => inputs,
        Err(note) => return out.notes.push(note.into()),
    };
    let beta = table.signals.get(&Signal::Beta);
    let lateral = beta.is_some() && models.iter().all(|m| m[2].is_some());
    let zeros = vec![0.0; table.t_s.len()];
    let beta_m = beta.unwrap_or(&zeros);
    let plant = ForcePlant {
        table,
        kin,
        ac,
        refs,
        lateral,
    };
    let mut sims: [[Vec<f64>; 3]; 2] = Default::default();
    let mut diverged: [Vec<f64>; 2] = Default::default();
    for (w, m) in models.iter().enumerate() {
        for &(a, b) in ps {
            let (v0, a0, b0) = (v_m[a], alpha[a], beta_m[a]);
            let x0 = [v0 * a0.cos() * b0.cos(), v0 * b0.sin(), v0 * a0.sin() * b0.cos()];
            let f = |x: &[f64; 3], k: usize, fr: f64| plant.velocity_rate(m, x, k, fr);
            let ok = |x: &[f64; 3]| {
                let vv = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
                x.iter().all(|v| v.is_finite()) && vv > v0 / 3.0 && vv < 3.0 * v0 && x[2].atan2(x[0]).abs() < 1.2
            };
            let (xs, div) = integrate(x0, a, b, h_s, f, ok);
            if div {
                diverged[w].push(cut_time(table, a, b, xs.len()));
            }
            plant.push_flow(&xs, b - a, &mut sims[w]);
        }
    }
    let p = params(models, &[0, 1, 2]);
    let [[vb, ab, bb], [ve, ae, be]] = sims;
    finish(out, table, ps, "Airspeed", "m/s", v_m, [vb, ve], &diverged, p);
    finish(out, table, ps, "Alpha", "rad", alpha, [ab, ae], &diverged, p);
    if lateral {
        finish(out, table, ps, "Beta", "rad", beta_m, [bb, be], &diverged, p);
    }
}

/// What the moment group's equations run on when all three rates are simulated: the table, its
/// kinematics, the aircraft, the terms' references, the measured airspeed and the inertia.
struct MomentPlant<'a> {
    table: &'a Table,
    kin: &'a Kinematics,
    ac: &'a Aircraft,
    refs: &'a TermRefs,
    v_m: &'a [f64],
    j: Matrix3<f64>,
    j_inv: Matrix3<f64>,
}

impl MomentPlant<'_> {
    /// The rates' derivative `ṗ, q̇, ṙ` at `x = [p, q, r]`, sample `k` plus `fr`: the models'
    /// `C_l`, `C_m`, `C_n` at the simulated normalised rates, Euler's equation about the CG.
    /// `None` when a term is unavailable.
    fn rate_derivative(&self, m: &ModelSet, x: &[f64; 3], k: usize, fr: f64) -> Option<[f64; 3]> {
        let (kin, refs, j) = (self.kin, self.refs, self.j);
        let (s_area, b_m, c_m) = (self.ac.wing_area_m2, self.ac.span_m, self.ac.chord_m);
        let mut s = self.table.snapshot(k, fr);
        let vv = lerp(self.v_m, k, fr).max(1.0);
        s[Signal::PN.index()] = x[0] * b_m / (2.0 * vv);
        s[Signal::QN.index()] = x[1] * c_m / (2.0 * vv);
        s[Signal::RN.index()] = x[2] * b_m / (2.0 * vv);
        let qs = lerp(&kin.qbar_pa, k, fr) * s_area;
        let cl = model_value(m[3].as_ref()?, &s, refs)?;
        let cm = model_value(m[4].as_ref()?, &s, refs)?;
        let cn = model_value(m[5].as_ref()?, &s, refs)?;
        let om = Vector3::new(x[0], x[1], x[2]);
        // The models give the moments about the reference point `r_P`; about the CG
        // `M = M_P + r_P × F_A` (the measured aerodynamic force).
        let m_p = Vector3::new(qs * b_m * cl, qs * c_m * cm, qs * b_m * cn);
        let mom = m_p
            + self.ac.moment_reference_m.cross(&lerp3(&kin.aero_force_n, k, fr))
            + lerp3(&kin.thrust_moment_nm, k, fr)
            - om.cross(&(j * om));
        let d = self.j_inv * mom;
        Some([d.x, d.y, d.z])
    }

    /// `p, q, r` of every piece with each model set (NaN past a divergence) and, per model set,
    /// the times the simulation diverged.
    fn simulate(&self, models: [&ModelSet; 2], ps: &[(usize, usize)], h_s: f64) -> ([[Vec<f64>; 3]; 2], [Vec<f64>; 2]) {
        let rates = &self.kin.rates_rad_s;
        let mut sims: [[Vec<f64>; 3]; 2] = Default::default();
        let mut diverged: [Vec<f64>; 2] = Default::default();
        for (w, m) in models.iter().enumerate() {
            for &(a, b) in ps {
                let x0 = [rates[0][a], rates[1][a], rates[2][a]];
                let f = |x: &[f64; 3], k: usize, fr: f64| self.rate_derivative(m, x, k, fr);
                let ok = |x: &[f64; 3]| x.iter().all(|v| v.is_finite() && v.abs() < 20.0);
                let (xs, div) = integrate(x0, a, b, h_s, f, ok);
                if div {
                    diverged[w].push(cut_time(self.table, a, b, xs.len()));
                }
                for k in 0..(b - a) {
                    for c in 0..3 {
                        sims[w][c].push(xs.get(k).map_or(f64::NAN, |x| x[c]));
                    }
                }
            }
        }
        (sims, diverged)
    }
}

/// The body rates simulated from each piece's measured rates with both model sets, against the
/// measured; only `q` ([`moment_group_q`]) without the lateral models, normalised rates or a
/// full inertia.
#[allow(clippy::too_many_arguments)]
fn moment_group(
    table: &Table,
    kin: &Kinematics,
    ac: &Aircraft,
    h_s: f64,
    refs: &TermRefs,
    ps: &[(usize, usize)],
    models: [&ModelSet; 2],
    out: &mut Simulation,
) {
    if models.iter().any(|m| m[4].is_none()) || !table.signals.contains_key(&Signal::QN) {
        out.notes.push("moments not simulated: no C_m model".into());
        return;
    }
    let lateral = models.iter().all(|m| m[3].is_some() && m[5].is_some())
        && table.signals.contains_key(&Signal::PN)
        && table.signals.contains_key(&Signal::RN);
    let Some(v_m) = table.signals.get(&Signal::Airspeed) else {
        return;
    };
    let j = inertia(ac);
    let Some(j_inv) = j.try_inverse() else {
        // Longitudinal aircraft file: only Iy.
        if !(lateral || j[(1, 1)] > 0.0) {
            out.notes.push("moments not simulated: no Iy".into());
            return;
        }
        return moment_group_q(table, kin, ac, h_s, refs, ps, models, out);
    };
    if !lateral {
        return moment_group_q(table, kin, ac, h_s, refs, ps, models, out);
    }
    let plant = MomentPlant {
        table,
        kin,
        ac,
        refs,
        v_m,
        j,
        j_inv,
    };
    let (sims, diverged) = plant.simulate(models, ps, h_s);
    let p = params(models, &[3, 4, 5]);
    let [[pb, qb, rb], [pe, qe, re]] = sims;
    for (c, channel, pair) in [
        (0, "RollRate", [pb, pe]),
        (1, "PitchRate", [qb, qe]),
        (2, "YawRate", [rb, re]),
    ] {
        finish(
            out,
            table,
            ps,
            channel,
            "rad/s",
            &kin.rates_rad_s[c],
            pair,
            &diverged,
            p,
        );
    }
}

/// Only `q` simulated (`C_m`; `p`, `r` measured; `q̇ = (M_y − (ω × Jω)_y)/Iy`).
#[allow(clippy::too_many_arguments)]
fn moment_group_q(
    table: &Table,
    kin: &Kinematics,
    ac: &Aircraft,
    h_s: f64,
    refs: &TermRefs,
    ps: &[(usize, usize)],
    models: [&ModelSet; 2],
    out: &mut Simulation,
) {
    let Some(v_m) = table.signals.get(&Signal::Airspeed) else {
        return;
    };
    let j = inertia(ac);
    let iy = j[(1, 1)];
    let (s_area, c_m) = (ac.wing_area_m2, ac.chord_m);
    let mut sims: [Vec<f64>; 2] = Default::default();
    let mut diverged: [Vec<f64>; 2] = Default::default();
    for (w, m) in models.iter().enumerate() {
        for &(a, b) in ps {
            let f = |x: &[f64; 1], k: usize, fr: f64| -> Option<[f64; 1]> {
                let mut s = table.snapshot(k, fr);
                let vv = lerp(v_m, k, fr).max(1.0);
                s[Signal::QN.index()] = x[0] * c_m / (2.0 * vv);
                let qs = lerp(&kin.qbar_pa, k, fr) * s_area;
                let cm = model_value(m[4].as_ref()?, &s, refs)?;
                let om = Vector3::new(lerp(&kin.rates_rad_s[0], k, fr), x[0], lerp(&kin.rates_rad_s[2], k, fr));
                let my = qs * c_m * cm
                    + ac.moment_reference_m.cross(&lerp3(&kin.aero_force_n, k, fr)).y
                    + lerp3(&kin.thrust_moment_nm, k, fr).y
                    - om.cross(&(j * om)).y;
                Some([my / iy])
            };
            let ok = |x: &[f64; 1]| x[0].is_finite() && x[0].abs() < 20.0;
            let (xs, div) = integrate([kin.rates_rad_s[1][a]], a, b, h_s, f, ok);
            if div {
                diverged[w].push(cut_time(table, a, b, xs.len()));
            }
            for k in 0..(b - a) {
                sims[w].push(xs.get(k).map_or(f64::NAN, |x| x[0]));
            }
        }
    }
    let p = params(models, &[4]);
    let [qb, qe] = sims;
    finish(
        out,
        table,
        ps,
        "PitchRate",
        "rad/s",
        &kin.rates_rad_s[1],
        [qb, qe],
        &diverged,
        p,
    );
}
