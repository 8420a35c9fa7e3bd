//! The α-free mode: angle of attack and sideslip estimated from the ground velocity, the attitude
//! and a wind estimate, for the many small UAVs that log no α/β vanes.
//!
//! **Wind triangle.** With `v_g` the ground (inertial) velocity, NED, and `w` the wind (velocity
//! of the air, NED), the air-relative velocity is
//!
//! ```text
//! v_a,NED = v_g − w,        v_a,body = Rᵀ(φ, θ, ψ) · v_a,NED = (u, v, w_b)      (Euler 3-2-1, FRD)
//! V = |v_a|,   α = atan2(w_b, u),   β = asin(v / V)
//! ```
//!
//! **Wind and pitot scale from the data** ([`fit_wind`]): the horizontal wind `(w_N, w_E)`
//! (constant, or piecewise constant over blocks of [`WindFitSettings::block_s`]) and a pitot scale
//! factor `k` (true airspeed = `k` × logged airspeed) are fitted by Gauss–Newton so that
//!
//! ```text
//! r_i = k·V_m,i − sqrt((v_N,i − w_N)² + (v_E,i − w_E)² + v_D,i²)  →  min Σ r_i²
//! ```
//!
//! — the "wind triangle" or GPS airspeed calibration of flight testing (the multi-leg method of
//! D. Gray, *Using GPS to Accurately Establish True Airspeed (TAS)*, National Test Pilot School),
//! solved here as one least-squares problem over every sample rather than three or four legs. The vertical wind is
//! assumed zero (the GPS climb rate is taken as the air-relative one): a thermal or a wave shows
//! as an α error of `w_z / V`.
//!
//! **Observability.** The wind and the scale separate only when the heading changes: flown on
//! one heading, a head wind and a pitot scale error look the same. The fit is refused (α/β are
//! then not estimated, and the report says why) when, in any block, the heading covers less than
//! [`WindFitSettings::min_heading_span_rad`] (90°), when the regressors' condition number exceeds
//! [`WindFitSettings::max_condition`], when the wind's or the scale's σ is too large, or when the
//! scale is not a plausible pitot calibration.
//!
//! **Covariance.** `Σ = s² (JᵀJ)⁻¹ · n / n_eff`, `s²` the residual variance, `n_eff` the number of
//! independent residuals: the residuals are gusts and pitot noise, correlated over the turbulence's
//! time scale, so `n_eff = n / (1 + 2 Σ_k ρ_k)` from the residuals' autocorrelation `ρ_k` (summed
//! while positive). Without that factor a 100-Hz log would claim a wind known to mm/s.
//!
//! **α/β uncertainty** ([`FlowAngles::alpha_sigma_rad`]): the wind's covariance propagated to α
//! and β (their gradient with respect to `w_N, w_E`, averaged over the flight), plus the turbulence
//! the constant wind does not follow: a gust of the size of the airspeed residual's RMS `σ_r`
//! (less the pitot's own white noise), taken as isotropic, is an angle error of `σ_r / V` in α
//! and in β; and the attitude's white
//! noise (pitch for α, yaw for β; from third differences), which passes one for one. Not
//! modelled: GPS velocity noise and latency (a few cm/s and ~0.1–0.2 s), a slowly varying
//! attitude error (a bias of the attitude is a bias of α or β), vertical wind.
//!
//! **No airspeed.** The wind cannot then be separated from the data: the autopilot's own wind
//! estimate ([`Quantity::WindNorth`], [`Quantity::WindEast`]) is used when logged, its uncertainty
//! unknown (the report says so); otherwise α and β cannot be estimated.

use super::measured::{MeasuredFlight, Quantity};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// The share of a white noise's σ that the gap analysis's smoothing passes: a quadratic
/// Savitzky–Golay filter over ±0.1 s (21 samples at 100 Hz) has a noise gain √(Σc²) ≈ 0.42; 0.45
/// rounds it up.
pub const SMOOTHED_WHITE_SHARE: f64 = 0.45;

/// Where the analysis takes α and β from (`aerosid gaps --flow-angles`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FlowAngleChoice {
    /// The vanes when logged, else estimated when possible.
    #[default]
    Auto,
    /// The vanes only (no estimate; without vanes, no α or β).
    Vanes,
    /// Estimated from the ground velocity, attitude and wind, even when vanes are logged (they
    /// are then replaced; for comparison).
    Estimated,
    /// Neither: any vane channel is dropped.
    None,
}

impl FlowAngleChoice {
    /// Command-line name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Vanes => "vanes",
            Self::Estimated => "estimated",
            Self::None => "none",
        }
    }

    /// From a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        [Self::Auto, Self::Vanes, Self::Estimated, Self::None]
            .into_iter()
            .find(|c| c.name() == s)
    }
}

/// Settings of the wind / pitot-scale fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindFitSettings {
    /// Piecewise-constant wind over blocks of this length, s (`None`: one wind for the flight).
    /// Each block needs its own heading change; 30–60 s blocks follow a slowly changing wind.
    pub block_s: Option<f64>,
    /// Smallest heading span per block, rad (90°: below it the wind and the pitot scale are
    /// barely separable).
    pub min_heading_span_rad: f64,
    /// Largest condition number of the fit's Jacobian (columns scaled to unit length).
    pub max_condition: f64,
    /// Largest 1-σ of a wind component, m/s.
    pub max_wind_sigma_mps: f64,
    /// Largest 1-σ of the pitot scale.
    pub max_scale_sigma: f64,
    /// Plausible pitot scale factors (outside: knots or km/h logged as m/s, a blocked pitot).
    pub scale_range: (f64, f64),
    /// Samples with a logged airspeed below this are left out of the fit, m/s (a pitot at low
    /// speed reads mostly its offset).
    pub min_airspeed_mps: f64,
}

impl Default for WindFitSettings {
    fn default() -> Self {
        Self {
            block_s: None,
            min_heading_span_rad: PI / 2.0,
            max_condition: 100.0,
            max_wind_sigma_mps: 1.0,
            max_scale_sigma: 0.05,
            scale_range: (0.7, 1.4),
            min_airspeed_mps: 5.0,
        }
    }
}

/// The α-free mode's record (kept apart so that [`MeasuredFlight`]'s log can hold it without
/// depending on the estimator).
pub use super::flow_estimate::{FlowAngles, WindBlock, WindFit};

/// The circular span of a set of angles, rad: 2π less the largest gap between neighbours.
pub fn heading_span(psi: &[f64]) -> f64 {
    let mut a: Vec<f64> = psi
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.rem_euclid(2.0 * PI))
        .collect();
    if a.len() < 2 {
        return 0.0;
    }
    a.sort_by(f64::total_cmp);
    let mut gap = a[0] + 2.0 * PI - a[a.len() - 1];
    for w in a.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    (2.0 * PI - gap).max(0.0)
}

/// The body-axis air velocity `(u, v, w)` of an NED air velocity at Euler angles (3-2-1).
pub fn ned_to_body(v_ned: [f64; 3], roll: f64, pitch: f64, yaw: f64) -> [f64; 3] {
    let (sf, cf) = roll.sin_cos();
    let (st, ct) = pitch.sin_cos();
    let (sp, cp) = yaw.sin_cos();
    let [n, e, d] = v_ned;
    // Rᵀ = R_x(φ)ᵀ R_y(θ)ᵀ R_z(ψ)ᵀ applied to the NED vector.
    let x1 = cp * n + sp * e;
    let y1 = -sp * n + cp * e;
    let z1 = d;
    let x2 = ct * x1 - st * z1;
    let z2 = st * x1 + ct * z1;
    let u = x2;
    let v = cf * y1 + sf * z2;
    let w = -sf * y1 + cf * z2;
    [u, v, w]
}

/// `(α, β, V)` of a ground velocity `v_g` (NED), horizontal wind `(w_N, w_E)` (vertical wind 0)
/// and attitude.
pub fn alpha_beta(v_g: [f64; 3], wind_ne: [f64; 2], roll: f64, pitch: f64, yaw: f64) -> (f64, f64, f64) {
    let va = [v_g[0] - wind_ne[0], v_g[1] - wind_ne[1], v_g[2]];
    let [u, v, w] = ned_to_body(va, roll, pitch, yaw);
    let speed = (u * u + v * v + w * w).sqrt();
    let beta = if speed > 0.0 {
        (v / speed).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    };
    (w.atan2(u), beta, speed)
}

/// Lag-summed autocorrelation factor `1 + 2 Σ ρ_k` of `r` (summed while `ρ_k > 0`, up to n/5).
fn correlation_factor(r: &[f64]) -> f64 {
    let n = r.len();
    let m = r.iter().sum::<f64>() / n.max(1) as f64;
    let c0: f64 = r.iter().map(|x| (x - m) * (x - m)).sum();
    if c0 <= 0.0 {
        return 1.0;
    }
    let mut s = 0.0;
    for k in 1..(n / 5).max(1) {
        let ck: f64 = (k..n).map(|i| (r[i] - m) * (r[i - k] - m)).sum();
        let rho = ck / c0;
        if rho <= 0.0 {
            break;
        }
        s += rho;
    }
    (1.0 + 2.0 * s).max(1.0)
}

/// Fits the horizontal wind (per block) and the pitot scale to the ground velocity and the
/// logged airspeed (module doc). Every slice has the length of `t_s`. The returned fit lists in
/// [`WindFit::refused`] every reason not to trust it; `Err` only when it cannot be computed at all.
#[allow(clippy::too_many_arguments)]
pub fn fit_wind(
    t_s: &[f64],
    vel_ned: [&[f64]; 3],
    airspeed: &[f64],
    yaw: &[f64],
    s: &WindFitSettings,
) -> Result<WindFit, String> {
    let d = WindData::select(t_s, vel_ned, airspeed, yaw, s)?;
    let (theta, r, j) = d.gauss_newton(d.initial_guess());
    let m = d.use_.len();
    let p = d.parameters();
    let s2 = sum_sq(&r) / (m.saturating_sub(p)).max(1) as f64;
    let factor = correlation_factor(&r);
    let n_eff = m as f64 / factor;
    let jtj = j.transpose() * &j;
    let cov = jtj.clone().try_inverse().map(|inv| inv * (s2 * factor));
    let condition = scaled_condition(&j);
    let sd = |k: usize| cov.as_ref().map_or(f64::INFINITY, |c| c[(k, k)].max(0.0).sqrt());
    let mut refused = Vec::new();
    let blocks = d.blocks(&theta, &sd, s, &mut refused);
    scale_refusals(condition, sd(0), theta[0], s, &mut refused);
    let residual_rms_mps = (sum_sq(&r) / m as f64).sqrt();
    Ok(WindFit {
        blocks,
        pitot_scale: theta[0],
        pitot_scale_sigma: sd(0),
        residual_rms_mps,
        samples: m,
        effective_samples: n_eff,
        condition,
        covariance: cov.map_or_else(Vec::new, |c| c.transpose().as_slice().to_vec()),
        refused,
    })
}

/// Sum of squares.
fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum::<f64>()
}

/// The wind fit's data: the samples it uses and their time blocks (one wind each). The
/// parameters are `[k, w_N(0), w_E(0), w_N(1), …]`.
struct WindData<'a> {
    t_s: &'a [f64],
    vel_ned: [&'a [f64]; 3],
    airspeed: &'a [f64],
    yaw: &'a [f64],
    /// The samples used: airspeed above the minimum, everything finite.
    use_: Vec<usize>,
    t0: f64,
    span: f64,
    /// Blocks.
    nb: usize,
}

impl<'a> WindData<'a> {
    /// Checks the lengths, selects the samples and cuts the time into blocks.
    fn select(
        t_s: &'a [f64],
        vel_ned: [&'a [f64]; 3],
        airspeed: &'a [f64],
        yaw: &'a [f64],
        s: &WindFitSettings,
    ) -> Result<Self, String> {
        let n = t_s.len();
        if vel_ned.iter().any(|v| v.len() != n) || airspeed.len() != n || yaw.len() != n {
            return Err("the ground velocity, airspeed and yaw are not all as long as the time base".into());
        }
        let use_: Vec<usize> = (0..n)
            .filter(|&i| {
                airspeed[i] > s.min_airspeed_mps
                    && vel_ned.iter().all(|v| v[i].is_finite())
                    && yaw[i].is_finite()
                    && t_s[i].is_finite()
            })
            .collect();
        if use_.len() < 20 {
            return Err(format!(
                "{} samples with a logged airspeed above {} m/s: too few to fit a wind",
                use_.len(),
                s.min_airspeed_mps
            ));
        }
        let t0 = t_s[use_[0]];
        let t_end = t_s[use_[use_.len() - 1]];
        let nb = match s.block_s {
            Some(b) if b > 0.0 && b.is_finite() => (((t_end - t0) / b).round() as usize).max(1),
            _ => 1,
        };
        let span = (t_end - t0).max(1e-9);
        Ok(Self {
            t_s,
            vel_ned,
            airspeed,
            yaw,
            use_,
            t0,
            span,
            nb,
        })
    }

    fn block_of(&self, t: f64) -> usize {
        (((t - self.t0) / self.span * self.nb as f64).floor() as usize).min(self.nb - 1)
    }

    fn parameters(&self) -> usize {
        1 + 2 * self.nb
    }

    /// The start: the linear form |v_g|² = 2 v_g·w + k²V_m² − |w|² (one wind), least squares;
    /// `k = 1`, no wind when it has no positive `k²`.
    fn initial_guess(&self) -> DVector<f64> {
        let (vel_ned, airspeed) = (self.vel_ned, self.airspeed);
        let mut a = DMatrix::<f64>::zeros(self.use_.len(), 4);
        let mut y = DVector::<f64>::zeros(self.use_.len());
        for (r, &i) in self.use_.iter().enumerate() {
            let (vn, ve, vd) = (vel_ned[0][i], vel_ned[1][i], vel_ned[2][i]);
            a[(r, 0)] = 2.0 * vn;
            a[(r, 1)] = 2.0 * ve;
            a[(r, 2)] = airspeed[i] * airspeed[i];
            a[(r, 3)] = -1.0;
            y[r] = vn * vn + ve * ve + vd * vd;
        }
        let mut theta = DVector::<f64>::zeros(self.parameters());
        theta[0] = 1.0;
        if let Ok(sol) = a.clone().svd(true, true).solve(&y, 1e-12) {
            if sol[2] > 0.0 && sol.iter().all(|v| v.is_finite()) {
                theta[0] = sol[2].sqrt();
                for b in 0..self.nb {
                    theta[1 + 2 * b] = sol[0];
                    theta[2 + 2 * b] = sol[1];
                }
            }
        }
        theta
    }

    /// The residuals `k·V_m − |v_g − w|` and their Jacobian at `th`.
    fn residuals(&self, th: &DVector<f64>) -> (Vec<f64>, DMatrix<f64>) {
        let (vel_ned, airspeed) = (self.vel_ned, self.airspeed);
        let mut r = Vec::with_capacity(self.use_.len());
        let mut j = DMatrix::<f64>::zeros(self.use_.len(), self.parameters());
        for (row, &i) in self.use_.iter().enumerate() {
            let b = self.block_of(self.t_s[i]);
            let (wn, we) = (th[1 + 2 * b], th[2 + 2 * b]);
            let (an, ae, ad) = (vel_ned[0][i] - wn, vel_ned[1][i] - we, vel_ned[2][i]);
            let va = (an * an + ae * ae + ad * ad).sqrt().max(1e-6);
            r.push(th[0] * airspeed[i] - va);
            j[(row, 0)] = airspeed[i];
            j[(row, 1 + 2 * b)] = an / va;
            j[(row, 2 + 2 * b)] = ae / va;
        }
        (r, j)
    }

    /// Gauss–Newton with step halving from `theta`: the fit, its residuals and Jacobian.
    fn gauss_newton(&self, mut theta: DVector<f64>) -> (DVector<f64>, Vec<f64>, DMatrix<f64>) {
        let (mut r, mut j) = self.residuals(&theta);
        for _ in 0..50 {
            let jt = j.transpose();
            let g = &jt * DVector::from_column_slice(&r);
            let h = &jt * &j;
            let Some(step) = h.clone().cholesky().map(|c| c.solve(&g)) else {
                break;
            };
            let c0 = sum_sq(&r);
            let mut lambda = 1.0;
            let mut improved = false;
            while lambda > 1e-4 {
                let cand = &theta - &step * lambda;
                let (rc, jc) = self.residuals(&cand);
                if sum_sq(&rc) <= c0 {
                    theta = cand;
                    r = rc;
                    j = jc;
                    improved = true;
                    break;
                }
                lambda *= 0.5;
            }
            if !improved || step.norm() * lambda < 1e-9 {
                break;
            }
        }
        (theta, r, j)
    }

    /// Each block's wind with its σ and heading span; a block whose heading spans too little or
    /// whose wind is too uncertain adds its reason to `refused`. `sd(k)` is parameter `k`'s σ.
    fn blocks(
        &self,
        theta: &DVector<f64>,
        sd: &dyn Fn(usize) -> f64,
        s: &WindFitSettings,
        refused: &mut Vec<String>,
    ) -> Vec<WindBlock> {
        let (t0, span, nb) = (self.t0, self.span, self.nb);
        let mut blocks = Vec::new();
        for b in 0..nb {
            let psi: Vec<f64> = self
                .use_
                .iter()
                .filter(|&&i| self.block_of(self.t_s[i]) == b)
                .map(|&i| self.yaw[i])
                .collect();
            let span_b = heading_span(&psi);
            let (lo, hi) = (t0 + span * b as f64 / nb as f64, t0 + span * (b + 1) as f64 / nb as f64);
            if span_b < s.min_heading_span_rad {
                refused.push(format!(
                    "the heading spans only {:.0}° over {lo:.1}…{hi:.1} s: the wind and the pitot scale separate only with heading changes of at least {:.0}° (fly a turn or a circle)",
                    span_b.to_degrees(),
                    s.min_heading_span_rad.to_degrees()
                ));
            }
            let sig = [sd(1 + 2 * b), sd(2 + 2 * b)];
            if sig.iter().any(|v| v.is_nan() || *v > s.max_wind_sigma_mps) {
                refused.push(format!(
                    "the wind over {lo:.1}…{hi:.1} s is determined only to σ = ({:.2}, {:.2}) m/s (north, east), more than {} m/s",
                    sig[0], sig[1], s.max_wind_sigma_mps
                ));
            }
            blocks.push(WindBlock {
                t_s: [lo, hi],
                wind_ne_mps: [theta[1 + 2 * b], theta[2 + 2 * b]],
                sigma_ne_mps: sig,
                heading_span_deg: span_b.to_degrees(),
            });
        }
        blocks
    }
}

/// The condition number of a Jacobian with its columns scaled to unit length.
fn scaled_condition(j: &DMatrix<f64>) -> f64 {
    let mut js = j.clone();
    for c in 0..js.ncols() {
        let norm = js.column(c).norm();
        if norm > 0.0 {
            js.column_mut(c).scale_mut(1.0 / norm);
        }
    }
    let sv = js.singular_values();
    let (mx, mn) = sv
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), v| (a.max(*v), b.min(*v)));
    if mn > 0.0 {
        mx / mn
    } else {
        f64::INFINITY
    }
}

/// The reasons not to trust the pitot scale (and with it the winds): a fit whose regressors
/// trade off (`condition`), a scale too uncertain (`scale_sigma`) or implausible (`scale`).
fn scale_refusals(condition: f64, scale_sigma: f64, scale: f64, s: &WindFitSettings, refused: &mut Vec<String>) {
    if condition.is_nan() || condition > s.max_condition {
        refused.push(format!(
            "the fit's regressors (scaled) have condition number {condition:.0}, above {}: the wind and the pitot scale trade off against each other",
            s.max_condition
        ));
    }
    if scale_sigma.is_nan() || scale_sigma > s.max_scale_sigma {
        refused.push(format!(
            "the pitot scale is determined only to σ = {:.3}, more than {}",
            scale_sigma, s.max_scale_sigma
        ));
    }
    if !(s.scale_range.0..=s.scale_range.1).contains(&scale) {
        refused.push(format!(
            "the fitted pitot scale {:.3} is outside the plausible {}…{} (airspeed in knots or km/h, or a blocked or leaking pitot?)",
            scale, s.scale_range.0, s.scale_range.1
        ));
    }
}

/// The estimated channels: α, β (rad), and the per-sample wind used.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// α, rad.
    pub alpha_rad: Vec<f64>,
    /// β, rad.
    pub beta_rad: Vec<f64>,
    /// `|v_g − w|`, m/s.
    pub airspeed_mps: Vec<f64>,
    /// What was done.
    pub info: FlowAngles,
}

fn std_dev(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt()
}

/// The vertical-wind and rigid-attitude assumptions, stated in every estimate.
fn assumptions(source: &str) -> Vec<String> {
    vec![
        format!("α, β from the wind triangle v_air = v_gnd − w with the ground velocity, the logged attitude (Euler 3-2-1, body FRD) and the wind from the {source}"),
        "vertical wind assumed 0: a thermal or wave of w_z m/s is an α error of w_z/V".into(),
        "gusts are not followed: the wind is constant (per block); their effect is in the stated σ".into(),
        "GPS velocity noise and latency and a slow attitude error are not modelled (an attitude bias is an α or β bias one for one)".into(),
        "no vane offset or position: the estimate is at the CG".into(),
    ]
}

/// Estimates α and β of `flight` (module doc). `Err` with the reasons when it cannot: no ground
/// velocity, no attitude, no airspeed and no autopilot wind, or a wind fit that cannot be trusted
/// (the fit is then in the returned [`FlowAngles`]).
pub fn estimate(flight: &MeasuredFlight, s: &WindFitSettings) -> Result<Estimate, Box<FlowAngles>> {
    use Quantity::*;
    let n = flight.len();
    let mut info = FlowAngles {
        status: "not estimated".into(),
        ..FlowAngles::default()
    };
    let autopilot = match (flight.get(WindNorth), flight.get(WindEast)) {
        (Some(a), Some(b)) => Some((a, b)),
        _ => None,
    };
    info.autopilot_wind_ne_mps = autopilot.map(|(a, b)| {
        let m = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
        [m(a), m(b)]
    });
    let Some((vel, att)) = velocity_and_attitude(flight, &mut info) else {
        return Err(Box::new(info));
    };
    let Some(w) = wind_per_sample(flight, vel, att[2], autopilot, s, &mut info) else {
        return Err(Box::new(info));
    };
    let a = Angles::of(vel, att, &w);
    // Angles beyond 0.6 rad over more than 5 % of the samples: on the ground, or a wrong wind.
    let wild = a.alpha.iter().chain(&a.beta).filter(|x| x.abs() > 0.6).count();
    if wild as f64 > 0.05 * 2.0 * n as f64 {
        info.why_not.push(format!(
            "the estimate gives |α| or |β| above 0.6 rad at {wild} of {} values: the vehicle is not flying in the window, or the velocity, attitude or wind is wrong",
            2 * n
        ));
        return Err(Box::new(info));
    }
    if w.cov.is_some() {
        angle_sigmas(flight, att, &a, w.turbulence_mps, &mut info);
    }
    info.alpha_excitation_rad = std_dev(&a.alpha);
    info.beta_excitation_rad = std_dev(&a.beta);
    info.status = "estimated".into();
    info.assumptions = assumptions(&info.wind_source);
    info.summary = summary(&info);
    Ok(Estimate {
        alpha_rad: a.alpha,
        beta_rad: a.beta,
        airspeed_mps: a.speed,
        info,
    })
}

/// The ground velocity (north, east, down) and the attitude (roll, pitch, yaw); `None` (the
/// reason in `info`) when any is not logged.
#[allow(clippy::type_complexity)]
fn velocity_and_attitude<'f>(
    flight: &'f MeasuredFlight,
    info: &mut FlowAngles,
) -> Option<([&'f [f64]; 3], [&'f [f64]; 3])> {
    use Quantity::*;
    let vel = [
        flight.get(VelocityNorth),
        flight.get(VelocityEast),
        flight.get(VelocityDown),
    ];
    let att = [flight.get(Roll), flight.get(Pitch), flight.get(Yaw)];
    let missing: Vec<&str> = vel
        .iter()
        .zip([VelocityNorth, VelocityEast, VelocityDown])
        .chain(att.iter().zip([Roll, Pitch, Yaw]))
        .filter(|(c, _)| c.is_none())
        .map(|(_, q)| q.name())
        .collect();
    if !missing.is_empty() {
        info.why_not.push(format!(
            "α and β cannot be estimated without a vane: no {} logged (the estimate needs the ground velocity vel_n/e/d and the attitude)",
            missing.join(", ")
        ));
        return None;
    }
    let (Some(vn), Some(ve), Some(vd)) = (vel[0], vel[1], vel[2]) else {
        return None;
    };
    let (Some(roll), Some(pitch), Some(yaw)) = (att[0], att[1], att[2]) else {
        return None;
    };
    Some(([vn, ve, vd], [roll, pitch, yaw]))
}

/// The wind at every sample: fitted (with its covariance and the fit's residual, the
/// turbulence) when the airspeed is logged, else the autopilot's estimate.
struct SampleWind {
    wind: Vec<[f64; 2]>,
    /// Per sample `[c_NN, c_NE, c_EE]` (`None`: unknown).
    cov: Option<Vec<[f64; 3]>>,
    turbulence_mps: f64,
}

/// The wind per sample and its source (in `info`, with the fit); `None` (the reasons in `info`)
/// when there is none to trust.
fn wind_per_sample(
    flight: &MeasuredFlight,
    vel: [&[f64]; 3],
    yaw: &[f64],
    autopilot: Option<(&[f64], &[f64])>,
    s: &WindFitSettings,
    info: &mut FlowAngles,
) -> Option<SampleWind> {
    let n = flight.len();
    match (flight.get(Quantity::Airspeed), autopilot) {
        (Some(v_m), _) => {
            info.wind_source = "wind-triangle fit".into();
            let fit = match fit_wind(&flight.t_s, vel, v_m, yaw, s) {
                Ok(f) => f,
                Err(e) => {
                    info.why_not.push(format!("the wind cannot be fitted: {e}"));
                    return None;
                }
            };
            if !fit.refused.is_empty() {
                info.why_not.extend(fit.refused.iter().cloned());
                if autopilot.is_some() {
                    info.why_not.push("the autopilot's logged wind estimate is not used instead: it faces the same observability limit and comes without an uncertainty".into());
                }
                info.fit = Some(fit);
                return None;
            }
            let w = fitted_wind(&fit, &flight.t_s);
            info.fit = Some(fit);
            Some(w)
        }
        (None, Some((wn, we))) => {
            info.wind_source = "autopilot wind estimate".into();
            let mut wind: Vec<[f64; 2]> = vec![[0.0; 2]; n];
            for k in 0..n {
                wind[k] = [wn[k], we[k]];
            }
            Some(SampleWind {
                wind,
                cov: None,
                turbulence_mps: f64::NAN,
            })
        }
        (None, None) => {
            info.why_not.push("no airspeed logged, so the wind cannot be separated from the ground velocity, and the autopilot logged no wind estimate (PX4 `wind`/`wind_estimate`, ArduPilot `XKF2.VWN/VWE`): α and β cannot be estimated".into());
            None
        }
    }
}

/// A wind fit's block wind and its covariance at every time of `t_s`.
fn fitted_wind(fit: &WindFit, t_s: &[f64]) -> SampleWind {
    let p = 1 + 2 * fit.blocks.len();
    let t0 = fit.blocks[0].t_s[0];
    let t1 = fit.blocks[fit.blocks.len() - 1].t_s[1];
    let nb = fit.blocks.len();
    let mut wind: Vec<[f64; 2]> = vec![[0.0; 2]; t_s.len()];
    let mut cov = Vec::with_capacity(t_s.len());
    for (k, &t) in t_s.iter().enumerate() {
        let b = (((t - t0) / (t1 - t0).max(1e-9) * nb as f64).floor().max(0.0) as usize).min(nb - 1);
        wind[k] = fit.blocks[b].wind_ne_mps;
        let c = |i: usize, j: usize| fit.covariance.get(i * p + j).copied().unwrap_or(f64::NAN);
        let (i, j) = (1 + 2 * b, 2 + 2 * b);
        cov.push([c(i, i), c(i, j), c(j, j)]);
    }
    SampleWind {
        wind,
        cov: Some(cov),
        turbulence_mps: fit.residual_rms_mps,
    }
}

/// α, β and the airspeed of every sample, and the sums over the samples of the variance the
/// wind's uncertainty puts into α and β (0 when the wind has no covariance).
struct Angles {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    speed: Vec<f64>,
    var_a: f64,
    var_b: f64,
}

impl Angles {
    fn of(vel: [&[f64]; 3], att: [&[f64]; 3], w: &SampleWind) -> Self {
        let ([vn, ve, vd], [roll, pitch, yaw], wind) = (vel, att, &w.wind);
        let n = wind.len();
        let mut out = Self {
            alpha: Vec::with_capacity(n),
            beta: Vec::with_capacity(n),
            speed: Vec::with_capacity(n),
            var_a: 0.0,
            var_b: 0.0,
        };
        for k in 0..n {
            let vg = [vn[k], ve[k], vd[k]];
            let (a, b, v) = alpha_beta(vg, wind[k], roll[k], pitch[k], yaw[k]);
            out.alpha.push(a);
            out.beta.push(b);
            out.speed.push(v);
            if let Some(cov) = &w.cov {
                // Gradient with respect to (w_N, w_E) by central differences (0.01 m/s).
                let d = 0.01;
                let at =
                    |dn: f64, de: f64| alpha_beta(vg, [wind[k][0] + dn, wind[k][1] + de], roll[k], pitch[k], yaw[k]);
                let (an, bn, _) = at(d, 0.0);
                let (an2, bn2, _) = at(-d, 0.0);
                let (ae, be, _) = at(0.0, d);
                let (ae2, be2, _) = at(0.0, -d);
                let ga = [(an - an2) / (2.0 * d), (ae - ae2) / (2.0 * d)];
                let gb = [(bn - bn2) / (2.0 * d), (be - be2) / (2.0 * d)];
                let [cnn, cne, cee] = cov[k];
                let q = |g: [f64; 2]| g[0] * g[0] * cnn + 2.0 * g[0] * g[1] * cne + g[1] * g[1] * cee;
                out.var_a += q(ga);
                out.var_b += q(gb);
            }
        }
        out
    }
}

/// The σ of α and β (raw and smoothed) in `info`: the wind's uncertainty, the gusts (the fit's
/// residual `turbulence_mps` less the pitot's white noise, over the mean airspeed) and the
/// attitude's (`att`: roll, pitch, yaw) white noise.
fn angle_sigmas(flight: &MeasuredFlight, att: [&[f64]; 3], a: &Angles, turbulence_mps: f64, info: &mut FlowAngles) {
    let n = flight.len();
    let [_, pitch, yaw] = att;
    let v_mean = a.speed.iter().sum::<f64>() / n.max(1) as f64;
    // The gusts: the airspeed residual less the pitot's own white noise (third differences),
    // which is no error of α or β.
    let pitot_white = flight
        .get(Quantity::Airspeed)
        .map_or(0.0, crate::signal::white_noise_sd)
        * info.fit.as_ref().map_or(1.0, |f| f.pitot_scale);
    let gust = (turbulence_mps * turbulence_mps - pitot_white * pitot_white)
        .max(0.0)
        .sqrt();
    let turb = gust / v_mean.max(1.0);
    // The attitude's white noise passes one for one (pitch into α, yaw into β); estimated
    // from its third differences.
    let theta_noise = crate::signal::white_noise_sd(pitch);
    let psi_noise = crate::signal::white_noise_sd(yaw);
    let (wa, wb) = (a.var_a / n as f64, a.var_b / n as f64);
    info.alpha_sigma_rad = (wa + turb * turb + theta_noise * theta_noise).sqrt();
    info.beta_sigma_rad = (wb + turb * turb + psi_noise * psi_noise).sqrt();
    let k = SMOOTHED_WHITE_SHARE;
    info.alpha_sigma_smoothed_rad = (wa + turb * turb + (k * theta_noise).powi(2)).sqrt();
    info.beta_sigma_smoothed_rad = (wb + turb * turb + (k * psi_noise).powi(2)).sqrt();
}

/// The one-sentence description of an estimate (or of why there is none).
fn summary(f: &FlowAngles) -> String {
    if f.status != "estimated" {
        return format!("α, β not estimated: {}", f.why_not.join("; "));
    }
    let sig = |x: f64| {
        if x.is_finite() {
            format!("{x:.3} rad ({:.1}°)", x.to_degrees())
        } else {
            "unknown".into()
        }
    };
    let wind = match &f.fit {
        Some(fit) => {
            let b = &fit.blocks;
            let w = if b.len() == 1 {
                format!(
                    "w_N = {:.2} ± {:.2} m/s, w_E = {:.2} ± {:.2} m/s",
                    b[0].wind_ne_mps[0], b[0].sigma_ne_mps[0], b[0].wind_ne_mps[1], b[0].sigma_ne_mps[1]
                )
            } else {
                format!(
                    "{} blocks, w_N {:.2}…{:.2} m/s, w_E {:.2}…{:.2} m/s, σ ≤ {:.2} m/s",
                    b.len(),
                    b.iter().map(|x| x.wind_ne_mps[0]).fold(f64::INFINITY, f64::min),
                    b.iter().map(|x| x.wind_ne_mps[0]).fold(f64::NEG_INFINITY, f64::max),
                    b.iter().map(|x| x.wind_ne_mps[1]).fold(f64::INFINITY, f64::min),
                    b.iter().map(|x| x.wind_ne_mps[1]).fold(f64::NEG_INFINITY, f64::max),
                    b.iter().flat_map(|x| x.sigma_ne_mps).fold(0.0f64, f64::max)
                )
            };
            format!(
                "{w}, pitot scale {:.3} ± {:.3}, heading span {:.0}°, airspeed residual {:.2} m/s RMS",
                fit.pitot_scale,
                fit.pitot_scale_sigma,
                fit.blocks
                    .iter()
                    .map(|b| b.heading_span_deg)
                    .fold(f64::INFINITY, f64::min),
                fit.residual_rms_mps
            )
        }
        None => "the autopilot's own wind estimate as logged, its uncertainty unknown".into(),
    };
    let ap = match (&f.fit, f.autopilot_wind_ne_mps) {
        (Some(_), Some([n, e])) => format!("; the autopilot's mean wind estimate ({n:.2}, {e:.2}) m/s for comparison"),
        _ => String::new(),
    };
    let smoothed = if f.alpha_sigma_smoothed_rad.is_finite() {
        format!(
            " ({:.3} rad after the analysis's smoothing)",
            f.alpha_sigma_smoothed_rad
        )
    } else {
        String::new()
    };
    format!(
        "α, β estimated from GPS velocity, attitude and a wind estimate ({wind}; vertical wind assumed 0; α σ ≈ {}{smoothed}, β σ ≈ {}){ap}",
        sig(f.alpha_sigma_rad),
        sig(f.beta_sigma_rad)
    )
}

/// The flight the analysis uses under `choice`: with estimated α/β inserted when the choice asks
/// for them and they can be estimated, and [`super::measured::LogMeta::flow_angles`] saying what
/// was done. Never fails: when α/β cannot be estimated the flight keeps no α/β and the
/// metadata says why.
pub fn prepare(flight: &MeasuredFlight, choice: FlowAngleChoice, s: &WindFitSettings) -> MeasuredFlight {
    let mut f = flight.clone();
    let vanes = flight.get(Quantity::Alpha).is_some();
    // A logged α that is itself an estimate (the autopilot's) is used as logged, and said so.
    let logged = match flight.log.origin_of(Quantity::Alpha) {
        crate::measured::Origin::Estimated { by } => format!("α, β as logged: estimated by {by}, not vanes"),
        crate::measured::Origin::Sensor => "α, β from the vanes".to_string(),
    };
    let off = |why: &str| FlowAngles {
        status: "off".into(),
        summary: why.to_string(),
        ..FlowAngles::default()
    };
    match choice {
        FlowAngleChoice::None => {
            f.channels.remove(&Quantity::Alpha);
            f.channels.remove(&Quantity::Beta);
            f.log.flow_angles = Some(off("α, β not used (--flow-angles none): any vane channel dropped"));
        }
        FlowAngleChoice::Vanes => {
            f.log.flow_angles = Some(FlowAngles {
                status: if vanes { "vanes" } else { "off" }.into(),
                ..off(&if vanes {
                    format!("{logged} (--flow-angles vanes)")
                } else {
                    "no vane and --flow-angles vanes: α, β not estimated".to_string()
                })
            });
        }
        FlowAngleChoice::Auto if vanes => {
            f.log.flow_angles = Some(FlowAngles {
                status: "vanes".into(),
                ..off(&logged)
            });
        }
        FlowAngleChoice::Auto | FlowAngleChoice::Estimated => match estimate(flight, s) {
            Ok(e) => {
                f.channels.insert(Quantity::Alpha, e.alpha_rad);
                f.channels.insert(Quantity::Beta, e.beta_rad);
                for q in [Quantity::Alpha, Quantity::Beta] {
                    f.log.set_estimated(q, "wind triangle (α-free mode)");
                }
                let mut info = e.info;
                if vanes {
                    info.assumptions
                        .push("the logged vanes are replaced by the estimate (--flow-angles estimated)".into());
                }
                f.log.flow_angles = Some(info);
            }
            Err(mut info) => {
                if vanes {
                    // Estimated asked for and impossible: the vanes are not used either, so the
                    // analysis does not silently fall back.
                    f.channels.remove(&Quantity::Alpha);
                    f.channels.remove(&Quantity::Beta);
                    info.why_not
                        .push("the logged vanes are not used (--flow-angles estimated)".into());
                }
                info.summary = summary(&info);
                f.log.flow_angles = Some(*info);
            }
        },
    }
    f
}
