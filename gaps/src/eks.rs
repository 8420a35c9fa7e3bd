//! The flight-path reconstruction with wind and sensor-error states: the independent oracle of the
//! air-data sensor errors.
//!
//! ## Why
//! The compatibility check ([`super::compat`]) is output error on the kinematics with steady air:
//! each 5 s segment has its own initial velocity, and the wind shows only as coloured output
//! residuals. The σ it reports for an air-data bias is the model-based σ of that same fit, so
//! `σ_tool/σ_oracle` is 1 by construction there. What the data allow is asked here of a
//! different model — the one of Jategaonkar (*Flight Vehicle System Identification*, 2nd ed.,
//! 2015, ch. 10, data compatibility with an extended Kalman filter) — in which the wind is a state
//! of its own and the sensor errors are constant states: a bias of α is then told from the wind
//! only through the attitude's and the airspeed's variation (the wind is fixed in the earth frame,
//! the bias in the vane's), which is exactly what a flight without GPS velocity offers.
//!
//! ## Model
//! States (20): the inertial velocity in body axes `v = [u, v, w]`, the mean wind in NED
//! `W = [W_N, W_E, W_D]` (a random walk of intensity `q_W`, m²/s³), the gust in body axes as the
//! states of the Dryden forming filters (MIL-F-8785C; `u` first order, `v` and `w` second order
//! with the lead `√3·L/V`; five states, one deviation `σ_g` and one scale length `L` for the three
//! axes, at the flight's mean airspeed), the accelerometer biases `b_a`, and per air-data channel
//! a bias and a scale factor (`b_V, k_V, b_α, k_α, b_β, k_β`, constant). Dynamics, the
//! accelerometers and gyros as inputs (as in the compatibility check, the gravity with the
//! measured attitude): `v̇ = a_m − b_a + g_b(φ, θ) − ω × v`. Measurements: `V_m = (1 + k_V)V + b_V`,
//! `α_m = (1 + k_α)α + b_α`, `β_m = (1 + k_β)β + b_β`, with `V, α, β` of the relative velocity at
//! the sensor `v − C_bn(φ, θ, ψ)·W − C_g·x_g + ω × r_sensor`. This is the flight-path
//! reconstruction with turbulence of Jategaonkar (2015, ch. 10), the gust's spectrum the one a
//! small aircraft meets near the ground.
//!
//! Noise: the measurements' white noise from their third differences
//! ([`crate::io::signal::white_noise_sd`]); the velocity's process noise from the accelerometers',
//! the gyros' (times the airspeed) and the attitude's (times `g`) white noise, each sample's error
//! integrated over one step. **Reading chosen for the wind's parameters**: `q_W`, `σ_g` and `L`
//! are not known from the log, so they are chosen by the innovations' Gaussian likelihood
//! (Schweppe 1965; Jategaonkar §5.5) over grids (`q_W` four decades, `σ_g` 0.1–3.2 m/s and `L`
//! 20–320 m by factors of 2), the sensor errors as states of the extended filter; the σ below is
//! conditional on the chosen wind model.
//!
//! ## What is searched
//! Each filter pass costs a few per cent of the rest of a flight's gap analysis, so the grids
//! are walked, not filled ([`best_wind`]): (`σ_g`, `L`) beside the least `q_W`, then `q_W` with
//! that gust, each by a descent that steps to the better neighbour while one is better. The
//! likelihood is smooth in `log q_W`, `log σ_g`, `log L`, with one valley in the gust's plane
//! along `σ_g²/L` constant (the Dryden spectrum above `V/L` is `∝ σ_g²/L`: the same
//! high-frequency gust), so the gust's descent steps along that valley (`σ_g`×2 with `L`×4) and
//! across it (`L`×2). A mean wind without gust (the random walk alone, its `q_W` walked likewise)
//! is the gust's limit at `σ_g → 0` (calm air) and at `L → ∞` (a wind that wanders slower than
//! any gust of the grid), so it is tried only where the gust's walk ends on the grid's least
//! deviation or its longest scale length (on 3 of the benchmark's 13 JSBSim flights, which end
//! there, the random walk wins). On the 12 turbulent flights of the test below the walk ends on
//! the full grid's optimum every time, with the random walk alone tried or not.
//!
//! ## The bound
//! With the wind model chosen, the constants (accelerometer biases, air-data biases and scales)
//! are states of the extended filter: the estimate is the final state, the σ the root of the
//! final covariance's diagonal, both conditional on the wind model. **Reading chosen**: this is
//! the bound of the filter's linearisation in the constants (Ljung 1979, IEEE TAC 24(1), on the
//! extended filter as a parameter estimator), not the Cramér–Rao bound of the model as written
//! (the filter error method's maximum likelihood, Jategaonkar 2015 ch. 5: Gauss–Newton on the
//! innovations with the constants held, the information matrix of the innovations'
//! sensitivities). On the 12 flights of the test below, at the chosen wind model, the filter's σ
//! is 0.92–1.03 times the Cramér–Rao bound on every flight and parameter, the estimates differ by
//! at most 1.3 of that σ (α's bias; the others at most 0.75), and the test's ratios of RMS error
//! to RMS σ agree to 0.06; on two of the benchmark's flights the σ is 0.81–1.00 times the bound
//! (β's the lowest). The maximum likelihood's sensitivities cost as many filter passes again as
//! the wind's search, so the filter's own bound is taken, within a fifth of the exact one.
//! Manoeuvres pooled into one flight start their velocity and wind afresh (diffuse, the gust at
//! its stationary covariance), the sensor errors carry over.
//!
//! ## What it is worth
//! On 12 seeded clean flights in the campaign's turbulence the RMS error of the estimates is 1.03,
//! 1.41 and 0.98 times the RMS σ for the airspeed's bias, its scale and α's bias, and 0.65, 0.55
//! and 0.48 for the accelerometers' x, z and y biases (the test below): there the σ is the error,
//! or larger. The gust's spectrum is what makes it so: with a random-walk wind (2.1, 2.5, 2.1) or
//! a first-order gust (the airspeed's bias 2.3) it is not. For β's bias and scale it is not
//! either (2.3× and 3.4×), nor for α's scale (7.9×): that estimate is offset by −0.13…−0.20 on
//! every flight, also with the simulator's own gust deviation and length as the wind model, so
//! the offset is a misfit of this reconstruction with the gusts, not the wind's parameters —
//! these σ bound nothing in turbulence. Not a missing
//! term of the vane: the simulator's vane reads `atan2(w_r, u_r)` of the body-axis air velocity
//! at the centre of gravity, gust included, with no upwash and no offset — this model's
//! measurement with the aircraft file's vane position 0. **Reading chosen** for the cause (not
//! tested): the model takes the gust independent of the inertial velocity, while the aircraft
//! answers a gust's α within the short period (its lift moves `w` toward the gust), so the
//! inertial α the scale multiplies is correlated with the gust the filter has to separate from it
//! — a regressor correlated with the noise, whose least-squares slope is biased toward the side
//! where the two cancel (negative here). A model of the lift's response to α (the aerodynamic
//! force as a measurement) would remove it; the calm-air estimates (−0.004…+0.008) are in line.
//! The side force answers a side gust likewise (the weathercock), the same reading for β.

use super::sensor_error::SensorParam;
use crate::io::measured::{MeasuredFlight, Quantity};
use crate::io::signal::white_noise_sd;
use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};

/// Standard gravity, m/s².
const G_MPS2: f64 = 9.806_65;
/// Number of states.
const N: usize = 20;
/// The first of the mean wind's states (NED, m/s).
const MEAN: usize = 3;
/// The first of the gust's states: the Dryden forming filters' (one of `u`, two each of `v` and
/// `w`), body axes.
const GUST: usize = 6;
/// Number of the gust's states.
const NG: usize = 5;
/// The first of the accelerometer biases' states (m/s²).
const ACC: usize = GUST + NG;
/// The sensor-error states after the velocity, the winds and the accelerometer biases: the
/// airspeed's, α's and β's bias and scale.
const AIR: [(usize, Quantity); 3] = [
    (ACC + 3, Quantity::Airspeed),
    (ACC + 5, Quantity::Alpha),
    (ACC + 7, Quantity::Beta),
];
/// The grid of the mean wind's random-walk intensity, m²/s³.
pub const MEAN_Q_GRID: [f64; 5] = [1e-4, 1e-3, 1e-2, 1e-1, 1.0];
/// The grid of the gust's standard deviation (every axis), m/s.
pub const GUST_SD_GRID: [f64; 6] = [0.1, 0.2, 0.4, 0.8, 1.6, 3.2];
/// The grid of the gust's scale length (every axis), m.
pub const GUST_LENGTH_GRID: [f64; 5] = [20.0, 40.0, 80.0, 160.0, 320.0];
/// Prior standard deviations: the wind (m/s), the relative velocity (m/s), the accelerometer
/// biases (m/s²), the airspeed bias (m/s), the angles' biases (rad), the scale factors: wide
/// against what a flight determines, so that the posterior is the data's.
const PRIOR_SD: [f64; 6] = [10.0, 1.0, 0.5, 3.0, 0.2, 0.3];

type Mat = [[f64; N]; N];

/// The wind model: a mean wind in the earth frame (a random walk) and a gust in body axes with
/// the Dryden spectra (MIL-F-8785C: `u` first order, `v` and `w` second order with the lead
/// `√3·L/V`), one deviation and one scale length for the three axes, at the flight's mean
/// airspeed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindModel {
    /// The mean wind's random-walk intensity, m²/s³.
    pub mean_q: f64,
    /// The gust's stationary standard deviation, m/s (0: no gust).
    pub gust_sd_mps: f64,
    /// The gust's scale length, m.
    pub gust_length_m: f64,
}

impl WindModel {
    /// Its description in a report's note.
    pub fn describe(&self) -> String {
        if self.gust_sd_mps > 0.0 {
            format!(
                "mean wind a random walk of {:.0e} m²/s³, Dryden gust σ {} m/s, L {} m, by maximum likelihood",
                self.mean_q, self.gust_sd_mps, self.gust_length_m
            )
        } else {
            format!(
                "a random walk of {:.0e} m²/s³ and no gust, by maximum likelihood",
                self.mean_q
            )
        }
    }
}

/// The reconstruction's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Reconstruction {
    /// The wind model chosen.
    pub wind: WindModel,
    /// Every sensor error's estimate and standard error.
    pub params: Vec<(SensorParam, f64, f64)>,
}

impl Reconstruction {
    /// The estimate and σ of `p`, when it is a state of the reconstruction.
    pub fn get(&self, p: SensorParam) -> Option<(f64, f64)> {
        self.params.iter().find(|(q, _, _)| *q == p).map(|&(_, v, s)| (v, s))
    }
}

/// The inputs the filter needs, per sample.
struct Inputs<'a> {
    acc: [Vec<f64>; 3],
    rates: [Vec<f64>; 3],
    att: [Vec<f64>; 3],
    /// `C_bn` of the measured attitude per sample: the same in every filter pass.
    c_bn: Vec<Matrix3<f64>>,
    meas: [Option<&'a [f64]>; 3],
    r_sensor: [Vector3<f64>; 3],
    meas_var: [f64; 3],
    vel_q: f64,
    pieces: Vec<(usize, usize)>,
    h_s: f64,
    speed_mps: f64,
    lateral: bool,
}

/// One filter pass's result: the innovations' negative log-likelihood, the final state and
/// covariance.
type Pass = (f64, [f64; N], Mat);

/// The reconstruction of `flight` at step `h_s`, the gyros less `gyro_bias` (the attitude part's
/// estimate); `None` without accelerometer x/z, pitch rate, pitch, airspeed and α, or when every
/// candidate wind model fails.
pub fn reconstruct(flight: &MeasuredFlight, h_s: f64, gyro_bias: [f64; 3]) -> Option<Reconstruction> {
    let inputs = inputs(flight, h_s, gyro_bias)?;
    let (wind, (_, x, p)) = best_wind(&inputs)?;
    let at = |i: usize| (x[i], p[i][i].sqrt());
    let with = |p: SensorParam, i: usize| (p, at(i).0, at(i).1);
    let mut params = vec![
        with(SensorParam::Bias(Quantity::AccelX), ACC),
        with(SensorParam::Bias(Quantity::AccelZ), ACC + 2),
    ];
    if inputs.lateral {
        params.push(with(SensorParam::Bias(Quantity::AccelY), ACC + 1));
    }
    for (k, (i, q)) in AIR.iter().enumerate() {
        if inputs.meas[k].is_some() && super::origin::has_sensor_errors(flight, *q) {
            params.push(with(SensorParam::Bias(*q), *i));
            params.push(with(SensorParam::Scale(*q), i + 1));
        }
    }
    Some(Reconstruction { wind, params })
}

/// The filter's inputs from `flight` ([`reconstruct`]).
fn inputs(flight: &MeasuredFlight, h_s: f64, gyro_bias: [f64; 3]) -> Option<Inputs<'_>> {
    use Quantity::*;
    let n = flight.len();
    let zeros = vec![0.0; n];
    let get = |q: Quantity| flight.get(q);
    let (ax, az, q_m, theta) = (get(AccelX)?, get(AccelZ)?, get(PitchRate)?, get(Pitch)?);
    let (v_m, a_m) = (get(Airspeed)?, get(Alpha)?);
    let lateral = [RollRate, YawRate, Roll, AccelY].iter().all(|q| get(*q).is_some());
    let or0 = |q: Quantity| get(q).filter(|_| lateral).unwrap_or(&zeros);
    let rates = [
        or0(RollRate).iter().map(|x| x - gyro_bias[0]).collect(),
        q_m.iter().map(|x| x - gyro_bias[1]).collect(),
        or0(YawRate).iter().map(|x| x - gyro_bias[2]).collect(),
    ];
    let beta = get(Beta).filter(|_| lateral);
    let wn = |x: &[f64]| white_noise_sd(x).powi(2);
    let speed = v_m.iter().sum::<f64>() / n.max(1) as f64;
    let gyro_var = wn(q_m)
        + if lateral {
            wn(or0(RollRate)) + wn(or0(YawRate))
        } else {
            0.0
        };
    let att_var = wn(theta) + if lateral { wn(or0(Roll)) } else { 0.0 };
    let acc_var = [wn(ax), if lateral { wn(or0(AccelY)) } else { 0.0 }, wn(az)]
        .iter()
        .fold(0.0f64, |m, v| m.max(*v));
    let ac = &flight.aircraft;
    let inputs = Inputs {
        acc: [ax.to_vec(), or0(AccelY).to_vec(), az.to_vec()],
        rates,
        att: [
            or0(Roll).to_vec(),
            theta.to_vec(),
            get(Yaw).filter(|_| lateral).unwrap_or(&zeros).to_vec(),
        ],
        c_bn: Vec::new(),
        meas: [Some(v_m), Some(a_m), beta],
        r_sensor: [
            ac.airspeed_position_m,
            ac.alpha_vane_position_m,
            ac.beta_vane_position_m,
        ],
        meas_var: [
            wn(v_m).max(1e-4),
            wn(a_m).max(1e-8),
            beta.map_or(1.0, |b| wn(b).max(1e-8)),
        ],
        // Per step: each sample's white error integrated over one step.
        vel_q: h_s * h_s * (acc_var + G_MPS2 * G_MPS2 * att_var + speed * speed * gyro_var),
        pieces: flight.pieces().iter().map(|p| (p.start, p.end)).collect(),
        h_s,
        speed_mps: speed,
        lateral,
    };
    let c_bn = (0..n)
        .map(|k| ned_to_body(inputs.att[0][k], inputs.att[1][k], inputs.att[2][k]))
        .collect();
    Some(Inputs { c_bn, ..inputs })
}

/// The wind model of the largest innovations' likelihood (Schweppe 1965; Jategaonkar §5.5), the
/// constants as states: over the mean wind's intensities without gust and every gust of the grids
/// beside the least intensity, then the intensity again with the gust chosen (a random walk alone
/// absorbs the gust's high frequencies, so the gust is tried beside a nearly still mean wind).
/// Each of the three searches walks its grid ([`descend`]) instead of filling it: the likelihood
/// is smooth and single-peaked in `log q_W`, `log σ_g` and `log L`, so the walk ends on the grid's
/// own optimum at a third of the filter passes.
fn best_wind(inp: &Inputs) -> Option<(WindModel, Pass)> {
    let mut seen: Vec<(WindModel, Option<Pass>)> = Vec::new();
    let mut nll = |w: WindModel| {
        let pass = match seen.iter().find(|(v, _)| *v == w) {
            Some((_, pass)) => pass.as_ref().map(|p| p.0),
            None => {
                let pass = filter(inp, &w);
                let v = pass.as_ref().map(|p| p.0);
                seen.push((w, pass));
                v
            }
        };
        pass.unwrap_or(f64::INFINITY)
    };
    search_wind(&mut nll);
    seen.into_iter()
        .filter_map(|(w, pass)| pass.map(|p| (w, p)))
        .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
}

/// The wind model a walk over the grids ends on, `nll` the innovations' negative log-likelihood
/// of a model: the mean wind's intensities without gust, every gust of the grids beside the least
/// intensity, then the intensity again with the gust chosen (a random walk alone absorbs the
/// gust's high frequencies, so the gust is tried beside a nearly still mean wind).
fn search_wind(nll: &mut impl FnMut(WindModel) -> f64) -> WindModel {
    let still = |q: usize| WindModel {
        mean_q: MEAN_Q_GRID[q],
        gust_sd_mps: 0.0,
        gust_length_m: 1.0,
    };
    let gusty = |q: usize, s: usize, l: usize| WindModel {
        mean_q: MEAN_Q_GRID[q],
        gust_sd_mps: GUST_SD_GRID[s],
        gust_length_m: GUST_LENGTH_GRID[l],
    };
    let [s, l] = descend(
        [GUST_SD_GRID.len() / 2, GUST_LENGTH_GRID.len() / 2],
        [GUST_SD_GRID.len(), GUST_LENGTH_GRID.len()],
        &[[1, 2], [0, 1]],
        |[s, l]| nll(gusty(0, s, l)),
    );
    if s == 0 || l + 1 == GUST_LENGTH_GRID.len() {
        let [q0] = descend([MEAN_Q_GRID.len() / 2], [MEAN_Q_GRID.len()], &[[1]], |[q]| {
            nll(still(q))
        });
        if nll(still(q0)) <= nll(gusty(0, s, l)) {
            return still(q0);
        }
    }
    let [q] = descend([0], [MEAN_Q_GRID.len()], &[[1]], |[q]| nll(gusty(q, s, l)));
    gusty(q, s, l)
}

/// The grid point of the least `f` reached from `start` by a descent over indices below `len`:
/// along each direction of `dirs` in turn it moves to the better neighbour while one is better,
/// until a sweep moves none. Where `f` has one minimum along every line of the directions through
/// the path this is the grid's minimum.
fn descend<const D: usize>(
    start: [usize; D],
    len: [usize; D],
    dirs: &[[isize; D]],
    mut f: impl FnMut([usize; D]) -> f64,
) -> [usize; D] {
    let mut at = start;
    let mut best = f(at);
    let shift = |at: [usize; D], dir: [isize; D], sign: isize| {
        let mut out = at;
        for d in 0..D {
            let i = at[d] as isize + sign * dir[d];
            if i < 0 || i >= len[d] as isize {
                return None;
            }
            out[d] = i as usize;
        }
        Some(out)
    };
    loop {
        let mut moved = false;
        for dir in dirs {
            loop {
                let mut step = None;
                for cand in [-1, 1].into_iter().filter_map(|sign| shift(at, *dir, sign)) {
                    let v = f(cand);
                    if v < best {
                        best = v;
                        step = Some(cand);
                    }
                }
                match step {
                    Some(cand) => {
                        at = cand;
                        moved = true;
                    }
                    None => break,
                }
            }
        }
        if !moved {
            return at;
        }
    }
}

/// `C_bn`, NED to body, of the Euler angles.
fn ned_to_body(phi: f64, theta: f64, psi: f64) -> Matrix3<f64> {
    let (sf, cf) = phi.sin_cos();
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = psi.sin_cos();
    Matrix3::new(
        ct * cp,
        ct * sp,
        -st,
        sf * st * cp - cf * sp,
        sf * st * sp + cf * cp,
        sf * ct,
        cf * st * cp + sf * sp,
        cf * st * sp - sf * cp,
        cf * ct,
    )
}

/// The gust's forming filters discretised at the filter's step: `x_g ← Φ·x_g + w`, `cov w = Q`,
/// the gust `C·x_g`, the stationary covariance `P₀`; the exact discretisation of the simulator's
/// (`Φ = e^{AΔt}` in closed form, `Q = P₀ − ΦP₀Φᵀ`), so a sampled gust has the continuous
/// process's statistics. Without lateral measurements the side gust is left out (its rows 0).
struct Gust {
    phi: SMatrix<f64, NG, NG>,
    q: SMatrix<f64, NG, NG>,
    c: SMatrix<f64, 3, NG>,
    p0: SMatrix<f64, NG, NG>,
}

impl Gust {
    fn new(inp: &Inputs, wind: &WindModel) -> Self {
        let (h, sd) = (inp.h_s, wind.gust_sd_mps);
        let rate = inp.speed_mps.max(1.0) / wind.gust_length_m.max(1e-3);
        let mut phi = SMatrix::<f64, NG, NG>::zeros();
        let mut p0 = SMatrix::<f64, NG, NG>::zeros();
        let mut c = SMatrix::<f64, 3, NG>::zeros();
        // u: first order, stationary σ².
        phi[(0, 0)] = (-rate * h).exp();
        p0[(0, 0)] = sd * sd;
        c[(0, 0)] = 1.0;
        // v, w: a double pole at −V/L, zero at −V/(√3·L); unit white input in controllable form,
        // `A = [[0, 1], [−r², −2r]]`, stationary `P = diag(1/(4r³), 1/(4r))`, the output row
        // `[1, √3/r]` scaled to a stationary deviation `σ` (its unscaled variance is `1/r³`).
        let a = Matrix2::new(0.0, 1.0, -rate * rate, -2.0 * rate);
        let ph2 = (Matrix2::identity() + (a + Matrix2::identity() * rate) * h) * (-rate * h).exp();
        let p2 = Matrix2::new(1.0 / (4.0 * rate.powi(3)), 0.0, 0.0, 1.0 / (4.0 * rate));
        let row = Vector2::new(1.0, 3f64.sqrt() / rate) * (sd * rate.powf(1.5));
        for (axis, first) in [(1usize, 1usize), (2, 3)] {
            if axis == 1 && !inp.lateral {
                continue;
            }
            phi.fixed_view_mut::<2, 2>(first, first).copy_from(&ph2);
            p0.fixed_view_mut::<2, 2>(first, first).copy_from(&p2);
            c.fixed_view_mut::<1, 2>(axis, first).copy_from(&row.transpose());
        }
        if sd <= 0.0 {
            p0.fill(0.0);
        }
        let q = p0 - phi * p0 * phi.transpose();
        Self { phi, q, c, p0 }
    }
}

/// The gust's states that state `r`'s transition mixes: `Φ` is block-diagonal (`u` alone, the
/// two states of `v`, the two of `w`), so the time update skips the blocks' zeros (the same
/// numbers at a third of the gust's arithmetic).
fn gust_block(r: usize) -> std::ops::Range<usize> {
    match r {
        0 => 0..1,
        1 | 2 => 1..3,
        _ => 3..5,
    }
}

/// The diffuse start of a piece at sample `k`: velocity from the measured air data, winds 0, the
/// gust's states at their stationary covariance, the velocity's covariance that of the mean wind
/// rotated into the body plus the gust's and the relative velocity's (`v = v_r + C_bn·W + C_g·x_g`).
fn start_piece(inp: &Inputs, gust: &Gust, k: usize, x: &mut [f64; N], p: &mut Mat) {
    let v = inp.meas[0].map_or(15.0, |m| m[k]);
    let a = inp.meas[1].map_or(0.0, |m| m[k]);
    let b = inp.meas[2].map_or(0.0, |m| m[k]);
    let vr = Vector3::new(v * a.cos() * b.cos(), v * b.sin(), v * a.sin() * b.cos());
    for i in 0..3 {
        x[i] = vr[i];
        x[MEAN + i] = 0.0;
    }
    for xg in &mut x[GUST..GUST + NG] {
        *xg = 0.0;
    }
    for r in 0..ACC {
        for c in 0..N {
            p[r][c] = 0.0;
            p[c][r] = 0.0;
        }
    }
    let c = inp.c_bn[k];
    let sw2 = PRIOR_SD[0] * PRIOR_SD[0];
    let cpc = c * c.transpose() * sw2;
    let cp = gust.c * gust.p0;
    let cpg = cp * gust.c.transpose();
    for r in 0..3 {
        for s in 0..3 {
            p[r][s] = cpc[(r, s)] + cpg[(r, s)] + if r == s { PRIOR_SD[1] * PRIOR_SD[1] } else { 0.0 };
            // cov(v, W) = C·P_W.
            p[r][MEAN + s] = c[(r, s)] * sw2;
            p[MEAN + s][r] = c[(r, s)] * sw2;
        }
        p[MEAN + r][MEAN + r] = sw2;
        // cov(v, x_g) = C_g·P₀.
        for j in 0..NG {
            p[r][GUST + j] = cp[(r, j)];
            p[GUST + j][r] = cp[(r, j)];
        }
    }
    for i in 0..NG {
        for j in 0..NG {
            p[GUST + i][GUST + j] = gust.p0[(i, j)];
        }
    }
}

/// One forward pass with the wind model `wind`: the innovations' negative log-likelihood, the
/// final state and covariance; `None` when the filter diverges (a non-positive innovation
/// variance or a non-finite state).
fn filter(inp: &Inputs, wind: &WindModel) -> Option<Pass> {
    let mut x = [0.0; N];
    let mut p: Mat = [[0.0; N]; N];
    let sd = PRIOR_SD;
    let prior = [
        (ACC, sd[2]),
        (ACC + 1, sd[2]),
        (ACC + 2, sd[2]),
        (AIR[0].0, sd[3]),
        (AIR[0].0 + 1, sd[5]),
        (AIR[1].0, sd[4]),
        (AIR[1].0 + 1, sd[5]),
        (AIR[2].0, sd[4]),
        (AIR[2].0 + 1, sd[5]),
    ];
    for (i, s) in prior {
        p[i][i] = s * s;
    }
    let h = inp.h_s;
    let gust = Gust::new(inp, wind);
    let mut nll = 0.0;
    for &(start, end) in &inp.pieces {
        if end <= start {
            continue;
        }
        start_piece(inp, &gust, start, &mut x, &mut p);
        // The first second of a piece sets the diffuse states: not in the likelihood.
        let settle = start + (1.0 / h).round() as usize;
        for k in start..end {
            let c = inp.c_bn[k];
            let w = Vector3::new(inp.rates[0][k], inp.rates[1][k], inp.rates[2][k]);
            let v = Vector3::new(x[0], x[1], x[2]);
            let xg = SMatrix::<f64, NG, 1>::from_column_slice(&x[GUST..GUST + NG]);
            let wind_b = c * Vector3::new(x[MEAN], x[MEAN + 1], x[MEAN + 2]) + gust.c * xg;
            for (m, meas) in inp.meas.iter().enumerate() {
                let Some(y) = meas.map(|s| s[k]).filter(|y| y.is_finite()) else {
                    continue;
                };
                let vr = v - wind_b + w.cross(&inp.r_sensor[m]);
                let (val, grad) = air_of(m, &vr)?;
                let (bi, ki) = (AIR[m].0, AIR[m].0 + 1);
                let pred = (1.0 + x[ki]) * val + x[bi];
                // H: ∂/∂v = (1+k)·∇, ∂/∂W = −(1+k)·∇·C_bn, ∂/∂x_g = −(1+k)·∇·C_g, ∂/∂b = 1,
                // ∂/∂k = val.
                let mut hrow = [0.0; N];
                let gk = grad * (1.0 + x[ki]);
                let gw = -(gk.transpose() * c);
                let gg = -(gk.transpose() * gust.c);
                for i in 0..3 {
                    hrow[i] = gk[i];
                    hrow[MEAN + i] = gw[i];
                }
                for j in 0..NG {
                    hrow[GUST + j] = gg[j];
                }
                hrow[bi] = 1.0;
                hrow[ki] = val;
                let nu = y - pred;
                let s = update(&mut x, &mut p, &hrow, nu, inp.meas_var[m])?;
                if k >= settle {
                    nll += s.ln() + nu * nu / s;
                }
            }
            if k + 1 < end {
                predict(inp, wind, &gust, k, &mut x, &mut p);
            }
            if !x.iter().all(|v| v.is_finite()) {
                return None;
            }
        }
    }
    Some((nll, x, p))
}

/// `V`, `α` or `β` (`m` = 0, 1, 2) of the relative velocity and its gradient.
fn air_of(m: usize, vr: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
    let (u, v, w) = (vr.x, vr.y, vr.z);
    let speed = vr.norm();
    let uw2 = u * u + w * w;
    if !(speed > 1.0 && uw2 > 1e-6) {
        return None;
    }
    Some(match m {
        0 => (speed, vr / speed),
        1 => (w.atan2(u), Vector3::new(-w, 0.0, u) / uw2),
        _ => {
            let uw = uw2.sqrt();
            let s2 = speed * speed;
            (
                (v / speed).clamp(-1.0, 1.0).asin(),
                Vector3::new(-u * v / (s2 * uw), uw / s2, -v * w / (s2 * uw)),
            )
        }
    })
}

/// The scalar measurement update (Joseph form not needed: the update below keeps `P` exactly
/// symmetric); returns the innovation variance.
fn update(x: &mut [f64; N], p: &mut Mat, hrow: &[f64; N], nu: f64, r: f64) -> Option<f64> {
    // H is 0 but for the velocity, the winds and the channel's bias and scale.
    let mut nz = [0usize; N];
    let mut count = 0;
    for j in (0..N).filter(|&j| hrow[j] != 0.0) {
        nz[count] = j;
        count += 1;
    }
    let mut ph = [0.0; N];
    for (i, row) in p.iter().enumerate() {
        ph[i] = nz[..count].iter().map(|&j| row[j] * hrow[j]).sum();
    }
    let s = hrow.iter().zip(&ph).map(|(a, b)| a * b).sum::<f64>() + r;
    if !(s.is_finite() && s > 0.0) {
        return None;
    }
    for i in 0..N {
        x[i] += ph[i] / s * nu;
    }
    // P ← P − g·gᵀ with g = P·hᵀ/√s: each product is the same both sides of the diagonal, so P
    // stays exactly symmetric, and the rows are updated whole (contiguous, no division inside).
    let root = s.sqrt();
    let mut g = [0.0; N];
    for (gi, phi) in g.iter_mut().zip(&ph) {
        *gi = phi / root;
    }
    for (row, gi) in p.iter_mut().zip(&g) {
        for (pij, gj) in row.iter_mut().zip(&g) {
            *pij -= gi * gj;
        }
    }
    Some(s)
}

/// The time update from sample `k` to `k + 1` (Euler step of `v̇ = a − b_a + g_b − ω × v`, the
/// gust's exact step `x_g ← Φ·x_g`, the mean wind a random walk): `F = I` but for the velocity
/// rows, `[I − h[ω×] | 0 | 0 | −h·I | 0]`, and the gust's block `Φ`.
fn predict(inp: &Inputs, wind: &WindModel, gust: &Gust, k: usize, x: &mut [f64; N], p: &mut Mat) {
    let h = inp.h_s;
    let w = Vector3::new(inp.rates[0][k], inp.rates[1][k], inp.rates[2][k]);
    // g_b = C_bn·[0, 0, g]: `[−sin θ, sin φ cos θ, cos φ cos θ]·g`.
    let gb = inp.c_bn[k].column(2) * G_MPS2;
    let v = Vector3::new(x[0], x[1], x[2]);
    let acc = Vector3::new(
        inp.acc[0][k] - x[ACC],
        inp.acc[1][k] - x[ACC + 1],
        inp.acc[2][k] - x[ACC + 2],
    );
    let mut dv = acc + gb - w.cross(&v);
    if !inp.lateral {
        dv.y = 0.0;
    }
    for i in 0..3 {
        x[i] += h * dv[i];
    }
    let xg = gust.phi * SMatrix::<f64, NG, 1>::from_column_slice(&x[GUST..GUST + NG]);
    x[GUST..GUST + NG].copy_from_slice(xg.as_slice());
    // M = I − h[ω×] (rows of the velocity), −h on the accelerometer biases.
    let wx = Matrix3::new(0.0, -w.z, w.y, w.z, 0.0, -w.x, -w.y, w.x, 0.0);
    let mut m = Matrix3::identity() - wx * h;
    if !inp.lateral {
        m.row_mut(1).copy_from(&Vector3::new(0.0, 1.0, 0.0).transpose());
    }
    let lat = if inp.lateral { 1.0 } else { 0.0 };
    let bias_gain = [h, h * lat, h];
    // A = F·P: the velocity rows and the gust's change.
    let mut rows = [[0.0; N]; 3];
    for (r, row) in rows.iter_mut().enumerate() {
        for (c, out) in row.iter_mut().enumerate() {
            *out = (0..3).map(|j| m[(r, j)] * p[j][c]).sum::<f64>() - bias_gain[r] * p[ACC + r][c];
        }
    }
    let mut grows = [[0.0; N]; NG];
    for (r, row) in grows.iter_mut().enumerate() {
        let block = gust_block(r);
        for (c, out) in row.iter_mut().enumerate() {
            *out = block.clone().map(|j| gust.phi[(r, j)] * p[GUST + j][c]).sum::<f64>();
        }
    }
    p[..3].copy_from_slice(&rows);
    p[GUST..GUST + NG].copy_from_slice(&grows);
    // P' = A·Fᵀ: the velocity columns and the gust's change.
    for row in p.iter_mut() {
        let old = [row[0], row[1], row[2], row[ACC], row[ACC + 1], row[ACC + 2]];
        for c in 0..3 {
            row[c] = (0..3).map(|j| m[(c, j)] * old[j]).sum::<f64>() - bias_gain[c] * old[3 + c];
        }
        let mut og = [0.0; NG];
        og.copy_from_slice(&row[GUST..GUST + NG]);
        for c in 0..NG {
            row[GUST + c] = gust_block(c).map(|j| gust.phi[(c, j)] * og[j]).sum::<f64>();
        }
    }
    for i in 0..3 {
        p[i][i] += inp.vel_q;
        p[MEAN + i][MEAN + i] += wind.mean_q * h;
    }
    for i in 0..NG {
        for j in 0..NG {
            p[GUST + i][GUST + j] += gust.q[(i, j)];
        }
    }
    if !inp.lateral {
        // No lateral measurement: the side velocity is free within a metre per second a second.
        p[1][1] += h;
    }
}

#[cfg(test)]
mod tests {
    use super::super::hidden::{self, HiddenEffect, HiddenKind};
    use super::*;
    use crate::sim::FaultChannel;

    fn alpha_bias_flight(bias: f64, seed: u64) -> MeasuredFlight {
        let e = HiddenEffect {
            kind: HiddenKind::SensorBias,
            size: bias,
            channel: Some(FaultChannel::Alpha),
        };
        hidden::flight(Some(&e), 60.0, seed, true).unwrap().block_means(2)
    }

    /// A planted α-vane bias of 0.035 rad in the campaign's turbulence is recovered within 3σ
    /// (a seeded flight: the estimate's error against its own σ, normal), the σ well below the
    /// bias, and the airspeed's bias within 3σ of 0 (none planted).
    #[test]
    fn recovers_a_planted_alpha_bias_within_three_sigma() {
        let f = alpha_bias_flight(0.035, 11);
        let h = f.t_s[1] - f.t_s[0];
        let r = reconstruct(&f, h, [0.0; 3]).expect("a reconstruction");
        let (b, s) = r.get(SensorParam::Bias(Quantity::Alpha)).unwrap();
        eprintln!("bias(α) {b:.4} ± {s:.4} rad, wind: {}", r.wind.describe());
        assert!((b - 0.035).abs() < 3.0 * s, "bias(α) {b} ± {s}");
        assert!(s < 0.035 / 3.0, "σ {s}");
        let (bv, sv) = r.get(SensorParam::Bias(Quantity::Airspeed)).unwrap();
        assert!(bv.abs() < 3.0 * sv, "bias(V) {bv} ± {sv}");
    }

    /// The reconstruction's σ is the error of its estimate on clean turbulent flights: on 12
    /// seeded clean flights of 90 s in the campaign's turbulence (no planted sensor error; the
    /// truth is the biases the simulator drew for the flight, its scales 0) the RMS error of the
    /// airspeed's bias and scale and of α's bias lies within 0.7–1.5 of the RMS of their σ, and
    /// that of the accelerometers' biases at most 1.54. An honest σ gives a ratio within
    /// `sqrt(χ²₁₂/12)`'s 99 % interval 0.51–1.54; the band is narrower below so that a σ inflated
    /// by half fails (the accelerometers' σ, measured conservative, is held only to not being
    /// too small). α's scale and β's bias and scale are not within it (a misfit of the model with
    /// the gusts that no σ of a single flight shows): the test asserts that they stay outside, so
    /// that a model which repairs them must also change the documentation. The output-error
    /// check's own first-round estimates and σ beside them are printed. docs/model-gaps.md, "The
    /// oracle", rests on these numbers:
    /// `cargo test -p aerosid-gaps --lib eks::tests::clean_flights -- --nocapture`.
    #[test]
    fn clean_flights_errors_are_within_the_reconstructions_sigma() {
        use crate::compat::{self, CompatSettings};
        use crate::sim::sensors::SensorModel;
        let params = [
            SensorParam::Bias(Quantity::Airspeed),
            SensorParam::Scale(Quantity::Airspeed),
            SensorParam::Bias(Quantity::Alpha),
            SensorParam::Scale(Quantity::Alpha),
        ];
        // Beside them, the truth 0 (the simulator's sensors without biases): the accelerometers'
        // biases, whose σ is not too small, the ratio at most the 99 % bound 1.54 (measured
        // 0.65, 0.55, 0.48: a conservative σ), and β's bias and scale, whose σ is (measured 2.3
        // and 3.4), asserted outside like α's scale.
        let more = [
            SensorParam::Bias(Quantity::AccelX),
            SensorParam::Bias(Quantity::AccelZ),
            SensorParam::Bias(Quantity::AccelY),
            SensorParam::Bias(Quantity::Beta),
            SensorParam::Scale(Quantity::Beta),
        ];
        let mut more_sums = [[0.0f64; 2]; 5];
        // Per parameter: Σ error², Σ σ², and the same of the output-error check's first round.
        let mut sums = [[0.0f64; 4]; 4];
        let seeds = 12;
        for seed in 1..=seeds {
            let cfg = hidden::config(None, 90.0, seed, true);
            let drawn = SensorModel::new(cfg.sensors, cfg.seed).biases;
            let truth = [drawn.airspeed_mps, 0.0, drawn.vanes_rad[0], 0.0];
            let f = hidden::flight(None, 90.0, seed, true).unwrap().block_means(2);
            let h = f.t_s[1] - f.t_s[0];
            let r = reconstruct(&f, h, [0.0; 3]).expect("a reconstruction");
            let cs = CompatSettings {
                threshold_t2: 16.0,
                max_lag: ((compat::SEGMENT_S / h).round() as usize).max(1),
                max_added: 3,
                gain_alpha: 0.01,
                iv: crate::instrumental::IvSettings {
                    level: 0.001,
                    cv: Default::default(),
                },
            };
            let c = compat::check(&f, h, &cs);
            eprintln!("seed {seed}: wind {}", r.wind.describe());
            for (i, p) in more.iter().enumerate() {
                let (v, s) = r.get(*p).expect("a sensor-error state");
                more_sums[i][0] += v * v;
                more_sums[i][1] += s * s;
            }
            for (i, p) in params.iter().enumerate() {
                let (v, s) = r.get(*p).expect("an air-data state");
                let t = c.tested.iter().find(|t| t.param == *p).expect("a tested candidate");
                eprintln!("  {p:?}: {:+.4} ± {:.4} (truth {:+.4})", v, s, truth[i]);
                for (j, x) in [v - truth[i], s, t.value - truth[i], t.sigma].iter().enumerate() {
                    sums[i][j] += x * x;
                }
            }
        }
        let root_mean = |s: &[f64]| s.iter().map(|x| (x / seeds as f64).sqrt()).collect::<Vec<_>>();
        let pair = |e: f64, s: f64| format!("RMS error {e:.5}, RMS σ {s:.5} (ratio {:.2})", e / s);
        for (p, s) in more.iter().zip(more_sums) {
            let rms = root_mean(&s);
            eprintln!("{p:?}: reconstruction {}", pair(rms[0], rms[1]));
            let ratio = rms[0] / rms[1];
            if matches!(
                p,
                SensorParam::Bias(Quantity::Beta) | SensorParam::Scale(Quantity::Beta)
            ) {
                assert!(ratio > 1.54, "{p:?}: RMS error {} against σ {}", rms[0], rms[1]);
            } else {
                assert!(ratio <= 1.54, "{p:?}: RMS error {} against σ {}", rms[0], rms[1]);
            }
        }
        for (p, s) in params.iter().zip(sums) {
            let rms = root_mean(&s);
            eprintln!(
                "{p:?}: reconstruction {}; output error {}",
                pair(rms[0], rms[1]),
                pair(rms[2], rms[3])
            );
            let ratio = rms[0] / rms[1];
            if *p == SensorParam::Scale(Quantity::Alpha) {
                // Not attained: the vane's scale is offset on every flight (−0.13…−0.20), also
                // with the simulator's own gust spectrum and intensity as the wind model.
                assert!(ratio > 1.54, "{p:?}: RMS error {} against σ {}", rms[0], rms[1]);
            } else {
                assert!(
                    (0.7..=1.5).contains(&ratio),
                    "{p:?}: RMS error {} against σ {}",
                    rms[0],
                    rms[1]
                );
            }
        }
    }

    #[test]
    fn air_angles_gradients_match_finite_differences() {
        let vr = Vector3::new(15.0, 1.2, 0.9);
        for m in 0..3 {
            let (f0, g) = air_of(m, &vr).unwrap();
            for i in 0..3 {
                let mut d = vr;
                d[i] += 1e-6;
                let fd = (air_of(m, &d).unwrap().0 - f0) / 1e-6;
                assert!((fd - g[i]).abs() < 1e-6, "m {m} i {i}: {fd} against {}", g[i]);
            }
        }
    }
}
