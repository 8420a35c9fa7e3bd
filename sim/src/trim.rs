//! Trim for straight level flight: Newton on `(α, δe, δt, δa, δr, φ)` so that the six body
//! accelerations vanish with `θ = α`, `β = 0`, zero rates (finite-difference Jacobian).

use super::dynamics::{Controls, Plant, RigidState};
use nalgebra::{SMatrix, SVector, UnitQuaternion, Vector3};

/// A trimmed flight condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trim {
    /// The initial state.
    pub state: RigidState,
    /// The trim controls.
    pub controls: Controls,
    /// Trim α (= θ), rad.
    pub alpha_rad: f64,
    /// Trim bank angle, rad (non-zero only with lateral asymmetry such as the propeller torque).
    pub roll_rad: f64,
    /// Largest residual acceleration (m/s², rad/s²) at the solution.
    pub residual: f64,
}

/// Why trim failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrimError {
    /// The Jacobian was singular at iteration `n`.
    Singular(usize),
    /// No convergence; the residual reached.
    NoConvergence(f64),
    /// Converged outside the throttle or surface limits (`(α, δe, δt, δa, δr, φ)`).
    OutOfLimits([f64; 6]),
}

impl core::fmt::Display for TrimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Singular(n) => write!(f, "trim: singular Jacobian at iteration {n}"),
            Self::NoConvergence(r) => write!(f, "trim: no convergence (residual {r:e})"),
            Self::OutOfLimits(z) => write!(f, "trim: solution outside the limits (α, δe, δt, δa, δr, φ) = {z:?}"),
        }
    }
}

impl std::error::Error for TrimError {}

fn build(
    plant: &Plant,
    z: &SVector<f64, 6>,
    airspeed_mps: f64,
    altitude_m: f64,
    heading_rad: f64,
) -> (RigidState, Controls) {
    let att = UnitQuaternion::from_euler_angles(z[5], z[0], heading_rad);
    let air_body = Vector3::new(airspeed_mps * z[0].cos(), 0.0, airspeed_mps * z[0].sin());
    let v = air_body + att.inverse_transform_vector(&plant.wind_ned_mps);
    let state = RigidState {
        position_ned_m: Vector3::new(0.0, 0.0, -altitude_m),
        velocity_body_mps: v,
        attitude: att,
        rate_rad_s: Vector3::zeros(),
    };
    let controls = Controls {
        elevator_rad: z[1],
        throttle: z[2],
        aileron_rad: z[3],
        rudder_rad: z[4],
    };
    (state, controls)
}

fn residual(plant: &Plant, z: &SVector<f64, 6>, v: f64, h: f64, psi: f64) -> SVector<f64, 6> {
    let (s, u) = build(plant, z, v, h, psi);
    let e = plant.evaluate(&s, &u, &Vector3::zeros(), 0.0);
    let mut r = SVector::<f64, 6>::zeros();
    r.fixed_rows_mut::<3>(0).copy_from(&e.velocity_dot_mps2);
    r.fixed_rows_mut::<3>(3).copy_from(&e.rate_dot_rad_s2);
    r
}

/// Trims `plant` for straight level flight at `airspeed_mps`, `altitude_m`, heading `heading_rad`
/// (steady wind included; time 0 coefficients).
pub fn trim_level(plant: &Plant, airspeed_mps: f64, altitude_m: f64, heading_rad: f64) -> Result<Trim, TrimError> {
    let mut z = SVector::<f64, 6>::from([0.05, 0.0, 0.6, 0.0, 0.0, 0.0]);
    let mut r = residual(plant, &z, airspeed_mps, altitude_m, heading_rad);
    for it in 0..60 {
        if r.amax() < 1e-11 {
            break;
        }
        let mut jac = SMatrix::<f64, 6, 6>::zeros();
        for j in 0..6 {
            let mut zp = z;
            let hstep = 1e-7;
            zp[j] += hstep;
            let rp = residual(plant, &zp, airspeed_mps, altitude_m, heading_rad);
            jac.set_column(j, &((rp - r) / hstep));
        }
        let dz = jac.lu().solve(&(-r)).ok_or(TrimError::Singular(it))?;
        // Damped step: at most 0.1 in any unknown.
        let scale = (0.1 / dz.amax()).min(1.0);
        z += dz * scale;
        r = residual(plant, &z, airspeed_mps, altitude_m, heading_rad);
    }
    if !r.amax().is_finite() || r.amax() >= 1e-8 {
        return Err(TrimError::NoConvergence(r.amax()));
    }
    let (state, controls) = build(plant, &z, airspeed_mps, altitude_m, heading_rad);
    if plant.saturate(&controls) != controls {
        return Err(TrimError::OutOfLimits(z.into()));
    }
    Ok(Trim {
        state,
        controls,
        alpha_rad: z[0],
        roll_rad: z[5],
        residual: r.amax(),
    })
}
