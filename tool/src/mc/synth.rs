//! The six synthetic aerodynamic coefficients as Monte Carlo measurands (seed paper 000, eq. 1–2
//! solved for the coefficients), with default input ranges and sensor errors for the
//! `skywalker_2013_mod` airframe (`shared/data/aircraft/README.md` §1).
//!
//! Host-side `f64` transcription, written plainly so it can be read against the paper; the on-board
//! synthesis in `aerosid-core` is written separately and the two are to be unified later.
//!
//! Conventions: body frame FRD; `a_*` is the *specific force* an accelerometer at the CG measures
//! (`(F_A + F_T)/m`, gravity excluded); `C_L`, `C_D` are in stability axes (body forces rotated by
//! `α` only) and `C_Y` is the body-axis side force, as in the simulator the paper used (Beard &
//! McLain's convention). With `X, Y, Z` the aerodynamic body forces and `q̄ = ½ ρ V²`:
//!
//! * `X = m a_x − T_x`, `Y = m a_y`, `Z = m a_z − T_z` (thrust `T` from measured RPM, below);
//! * `C_L = (X sin α − Z cos α)/(q̄ S)`, `C_D = −(X cos α + Z sin α)/(q̄ S)`, `C_Y = Y/(q̄ S)`;
//! * `M_A = J ω̇ + ω × J ω − M_T` with `J` the inertia tensor (`J_xz` product) and `M_T` the thrust
//!   moment `r_T × T` plus the propeller reaction torque about `x`;
//! * `C_l = L_A/(q̄ S b)`, `C_m = M_A/(q̄ S c̄)`, `C_n = N_A/(q̄ S b)`.
//!
//! Propeller (ground-test model of the airframe data): `n = RPM/60`, `J = V cos α cos β/(n D)`,
//! `T = C_T(J) ρ n² D⁴`, `Q = C_P(J) ρ n² D⁵/(2π)`; the thrust acts along `(cos θ_T, 0, −sin θ_T)`
//! from `r_T`.
//!
//! Surface deflections do not enter eq. 1–2 (they are regressors of eq. 3), so their error
//! ([`Sensors::surface_rad`]) is carried here only for the regressor entries of `W_T`.

use super::{ErrorKind, Input, Problem};

/// Index of each Monte Carlo input in [`default_problem`] and the measurands.
pub mod idx {
    /// Specific force x (m/s²).
    pub const AX: usize = 0;
    /// Specific force y (m/s²).
    pub const AY: usize = 1;
    /// Specific force z (m/s²).
    pub const AZ: usize = 2;
    /// Roll rate p (rad/s).
    pub const P: usize = 3;
    /// Pitch rate q (rad/s).
    pub const Q: usize = 4;
    /// Yaw rate r (rad/s).
    pub const R: usize = 5;
    /// Roll acceleration ṗ (rad/s²).
    pub const PDOT: usize = 6;
    /// Pitch acceleration q̇ (rad/s²).
    pub const QDOT: usize = 7;
    /// Yaw acceleration ṙ (rad/s²).
    pub const RDOT: usize = 8;
    /// Angle of attack α (rad).
    pub const ALPHA: usize = 9;
    /// Sideslip β (rad).
    pub const BETA: usize = 10;
    /// Airspeed V (m/s).
    pub const V: usize = 11;
    /// Air density ρ (kg/m³).
    pub const RHO: usize = 12;
    /// Propeller speed (rev/min).
    pub const RPM: usize = 13;
    /// Number of inputs.
    pub const N: usize = 14;
}

/// Airframe constants the synthesis needs (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct Airframe {
    /// Mass (kg), known exactly.
    pub mass_kg: f64,
    /// Wing reference area S (m²).
    pub s_m2: f64,
    /// Wingspan b (m).
    pub b_m: f64,
    /// Mean aerodynamic chord c̄ (m).
    pub c_m: f64,
    /// Inertia `[J_x, J_y, J_z, J_xz]` (kg m²); `J_xz` enters `J` as `−J_xz` off the diagonal.
    pub inertia_kgm2: [f64; 4],
    /// Propeller diameter D (m).
    pub prop_d_m: f64,
    /// `C_T(J) = c₀ + c₁ J + c₂ J²`.
    pub ct: [f64; 3],
    /// `C_P(J) = c₀ + c₁ J + c₂ J²`.
    pub cp: [f64; 3],
    /// Thrust point relative to the CG, FRD (m).
    pub thrust_pos_m: [f64; 3],
    /// Thrust-line pitch θ_T (rad); the line is `(cos θ_T, 0, −sin θ_T)`.
    pub thrust_pitch_rad: f64,
    /// Sign of the propeller reaction torque on the airframe about `x` (−1: the propeller turns
    /// positively about `x`, the airframe gets `−Q`).
    pub prop_torque_sign: f64,
}

impl Airframe {
    /// `skywalker_2013_mod` (aircraft README §1). The inertia is the one in the data set (copied
    /// from the Aerosonde, large for a 2 kg airframe), kept to match the paper.
    pub fn skywalker_2013_mod() -> Self {
        Self {
            mass_kg: 2.0,
            s_m2: 0.45,
            b_m: 1.88,
            c_m: 0.24,
            inertia_kgm2: [0.8244, 1.135, 1.759, 0.1204],
            prop_d_m: 0.28,
            ct: [0.1133, -0.0740, -0.1849],
            cp: [0.0440, 0.0059, -0.0732],
            thrust_pos_m: [-0.25, 0.0, -0.13],
            thrust_pitch_rad: -0.08,
            prop_torque_sign: -1.0,
        }
    }

    /// Thrust force (N, FRD) and moment about the CG (N m, FRD) from the input vector `x`.
    pub fn propulsion(&self, x: &[f64]) -> ([f64; 3], [f64; 3]) {
        let n = x[idx::RPM] / 60.0;
        if n <= 0.0 {
            return ([0.0; 3], [0.0; 3]);
        }
        let d = self.prop_d_m;
        let j = x[idx::V] * x[idx::ALPHA].cos() * x[idx::BETA].cos() / (n * d);
        let poly = |c: &[f64; 3]| c[0] + c[1] * j + c[2] * j * j;
        let rho_n2 = x[idx::RHO] * n * n;
        let t = poly(&self.ct) * rho_n2 * d.powi(4);
        let q = poly(&self.cp) * rho_n2 * d.powi(5) / (2.0 * std::f64::consts::PI);
        let f = [t * self.thrust_pitch_rad.cos(), 0.0, -t * self.thrust_pitch_rad.sin()];
        let r = self.thrust_pos_m;
        let m = [
            r[1] * f[2] - r[2] * f[1] + self.prop_torque_sign * q,
            r[2] * f[0] - r[0] * f[2],
            r[0] * f[1] - r[1] * f[0],
        ];
        (f, m)
    }
}

/// The six synthesised coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coefficient {
    /// Lift `C_L`.
    CL,
    /// Drag `C_D`.
    CD,
    /// Side force `C_Y`.
    CY,
    /// Rolling moment `C_l`.
    Cl,
    /// Pitching moment `C_m`.
    Cm,
    /// Yawing moment `C_n`.
    Cn,
}

impl Coefficient {
    /// All six, in the order of eq. 3a–3f.
    pub const ALL: [Coefficient; 6] = [
        Coefficient::CL,
        Coefficient::CD,
        Coefficient::CY,
        Coefficient::Cl,
        Coefficient::Cm,
        Coefficient::Cn,
    ];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Coefficient::CL => "C_L",
            Coefficient::CD => "C_D",
            Coefficient::CY => "C_Y",
            Coefficient::Cl => "C_l",
            Coefficient::Cm => "C_m",
            Coefficient::Cn => "C_n",
        }
    }
}

/// Synthesises coefficient `c` (eq. 1–2 solved for it) from the input vector `x` (see [`idx`]).
#[allow(non_snake_case)]
pub fn synthesise(a: &Airframe, c: Coefficient, x: &[f64]) -> f64 {
    // qbar: dynamic pressure (Pa); (X, Z): aerodynamic body forces (N); (L, M, N): aerodynamic
    // body moments (N m).
    let qbar = 0.5 * x[idx::RHO] * x[idx::V] * x[idx::V];
    let (ft, mt) = a.propulsion(x);
    let m = a.mass_kg;
    let (sa, ca) = x[idx::ALPHA].sin_cos();
    match c {
        Coefficient::CL | Coefficient::CD | Coefficient::CY => {
            let X = m * x[idx::AX] - ft[0];
            let Y = m * x[idx::AY] - ft[1];
            let Z = m * x[idx::AZ] - ft[2];
            let den = qbar * a.s_m2;
            match c {
                Coefficient::CL => (X * sa - Z * ca) / den,
                Coefficient::CD => -(X * ca + Z * sa) / den,
                _ => Y / den,
            }
        }
        Coefficient::Cl | Coefficient::Cm | Coefficient::Cn => {
            let [jx, jy, jz, jxz] = a.inertia_kgm2;
            let (p, q, r) = (x[idx::P], x[idx::Q], x[idx::R]);
            let (pd, qd, rd) = (x[idx::PDOT], x[idx::QDOT], x[idx::RDOT]);
            match c {
                Coefficient::Cl => {
                    let L = jx * pd - jxz * rd + (jz - jy) * q * r - jxz * p * q - mt[0];
                    L / (qbar * a.s_m2 * a.b_m)
                }
                Coefficient::Cm => {
                    let M = jy * qd + (jx - jz) * p * r + jxz * (p * p - r * r) - mt[1];
                    M / (qbar * a.s_m2 * a.c_m)
                }
                _ => {
                    let N = jz * rd - jxz * pd + (jy - jx) * p * q + jxz * q * r - mt[2];
                    N / (qbar * a.s_m2 * a.b_m)
                }
            }
        }
    }
}

/// Sensor error standard deviations (white noise, biases assumed removed — the paper's assumption A).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensors {
    /// Accelerometer (m/s²). Default 0.05.
    pub accel_mps2: f64,
    /// Gyro (rad/s). Default 0.005.
    pub gyro_rad_s: f64,
    /// Angular acceleration from the on-board differentiator (rad/s²). Default
    /// `0.005 · √10/(10·0.01) = 0.158`: the white-noise gain `√10/(10·dt) = 31.6 s⁻¹` of the on-board
    /// 5-point Savitzky–Golay slope (`aerosid_core::aero::RateDifferentiator`) at 100 Hz. (An
    /// earlier default assumed an 8-sample slope, 15.43 s⁻¹, and understated σ_ε of the moment
    /// coefficients: measured on synthesised C_m, 0.0136 against 0.0083.)
    pub ang_accel_rad_s2: f64,
    /// Pitot airspeed (m/s). Default 0.3.
    pub airspeed_mps: f64,
    /// α and β vanes (rad). Default 0.5° = 0.00873.
    pub vane_rad: f64,
    /// Surface deflections (rad). Default 0.2° = 0.00349. Not an input of eq. 1–2.
    pub surface_rad: f64,
    /// Propeller speed, relative (of reading). Default 0.01.
    pub rpm_rel: f64,
    /// Air density from static pressure and temperature, relative. Default 0.005 (an assumption:
    /// 1 hPa and 1 K give about 0.1 % and 0.35 %).
    pub density_rel: f64,
}

impl Default for Sensors {
    fn default() -> Self {
        Self {
            accel_mps2: 0.05,
            gyro_rad_s: 0.005,
            ang_accel_rad_s2: 0.005 * 10f64.sqrt() / (10.0 * 0.01),
            airspeed_mps: 0.3,
            vane_rad: 0.5_f64.to_radians(),
            surface_rad: 0.2_f64.to_radians(),
            rpm_rel: 0.01,
            density_rel: 0.005,
        }
    }
}

/// The default Monte Carlo problem for `skywalker_2013_mod` in cruise and manoeuvring flight:
/// ranges (eq. 38), copula correlations (eq. 36) and independent sensor errors (eq. 39).
///
/// Ranges: specific force `a_x ∈ [−3, 5]`, `a_y ∈ [−2, 2]`, `a_z ∈ [−15, −5]` m/s² (load factor
/// 0.5–1.5); `p ∈ [−1, 1]`, `q, r ∈ [−0.5, 0.5]` rad/s; `ṗ ∈ [−3, 3]`, `q̇ ∈ [−2, 2]`,
/// `ṙ ∈ [−1.5, 1.5]` rad/s²; `α ∈ [−0.05, 0.20]`, `β ∈ [−0.1, 0.1]` rad; `V ∈ [12, 22]` m/s;
/// `ρ ∈ [1.10, 1.23]` kg/m³; RPM `∈ [6000, 10000]` (`ω = δ_t·1050` rad/s tops out at 10 027 RPM;
/// the data set's `C_T(J)` crosses zero at `J = 0.61`, so lower RPM at these speeds is windmilling).
///
/// Copula correlations (level-flight trends): `ρ(α, V) = −0.6`, `ρ(α, a_z) = −0.5`,
/// `ρ(V, RPM) = +0.5`, `ρ(a_x, RPM) = +0.3`.
pub fn default_problem(s: &Sensors) -> Problem {
    use idx::*;
    let abs = |name, lo, hi| Input {
        name,
        range: [lo, hi],
        error_kind: ErrorKind::Absolute,
    };
    let rel = |name, lo, hi| Input {
        name,
        range: [lo, hi],
        error_kind: ErrorKind::Relative,
    };
    let inputs = vec![
        abs("accel_x_mps2", -3.0, 5.0),
        abs("accel_y_mps2", -2.0, 2.0),
        abs("accel_z_mps2", -15.0, -5.0),
        abs("rate_p_rad_s", -1.0, 1.0),
        abs("rate_q_rad_s", -0.5, 0.5),
        abs("rate_r_rad_s", -0.5, 0.5),
        abs("ang_accel_p_rad_s2", -3.0, 3.0),
        abs("ang_accel_q_rad_s2", -2.0, 2.0),
        abs("ang_accel_r_rad_s2", -1.5, 1.5),
        abs("alpha_rad", -0.05, 0.20),
        abs("beta_rad", -0.1, 0.1),
        abs("airspeed_mps", 12.0, 22.0),
        rel("density_kg_m3", 1.10, 1.23),
        rel("prop_rpm", 6000.0, 10000.0),
    ];
    let mut sigma = [0.0; N];
    sigma[AX] = s.accel_mps2;
    sigma[AY] = s.accel_mps2;
    sigma[AZ] = s.accel_mps2;
    sigma[P] = s.gyro_rad_s;
    sigma[Q] = s.gyro_rad_s;
    sigma[R] = s.gyro_rad_s;
    sigma[PDOT] = s.ang_accel_rad_s2;
    sigma[QDOT] = s.ang_accel_rad_s2;
    sigma[RDOT] = s.ang_accel_rad_s2;
    sigma[ALPHA] = s.vane_rad;
    sigma[BETA] = s.vane_rad;
    sigma[V] = s.airspeed_mps;
    sigma[RHO] = s.density_rel;
    sigma[RPM] = s.rpm_rel;
    let mut p = Problem::independent(inputs, &sigma);
    p.set_corr(ALPHA, V, -0.6);
    p.set_corr(ALPHA, AZ, -0.5);
    p.set_corr(V, RPM, 0.5);
    p.set_corr(AX, RPM, 0.3);
    p
}

/// One row of the σ_ε table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoefficientSigma {
    /// Which coefficient.
    pub coefficient: Coefficient,
    /// The Monte Carlo result (eq. 40–41).
    pub mc: super::McResult,
    /// First-order (Taylor) σ at the centre of the ranges, for comparison.
    pub taylor_centre: f64,
}

/// `σ_ε` (eq. 41) of all six coefficients, each from `settings.draws` draws with the same seed
/// (common random numbers across coefficients).
pub fn coefficient_sigmas(
    airframe: &Airframe,
    problem: &Problem,
    settings: &super::McSettings,
) -> Result<Vec<CoefficientSigma>, super::McError> {
    let x0 = problem.centre();
    Coefficient::ALL
        .iter()
        .map(|&c| {
            let f = |x: &[f64]| synthesise(airframe, c, x);
            let mc = super::run(problem, settings, f)?;
            Ok(CoefficientSigma {
                coefficient: c,
                mc,
                taylor_centre: super::taylor_sigma(problem, &x0, &f),
            })
        })
        .collect()
}
