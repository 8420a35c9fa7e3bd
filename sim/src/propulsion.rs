//! The propeller of seed 000 Section II as the on-board code reconstructs it from RPM and airspeed:
//! `n = ω/2π`, `J = V_x/(nD)`, `T = C_T(J) ρ n² D⁴`, `Q = C_P(J) ρ n² D⁵/(2π)` (data/aircraft README §1).

use aerosid_core::aero::Propeller;
use nalgebra::Vector3;

/// Propeller state and loads at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PropOutput {
    /// Propeller speed ω, rad/s.
    pub speed_rad_s: f64,
    /// Advance ratio `J` (0 when the propeller stands still).
    pub advance_ratio: f64,
    /// Thrust along the thrust axis, N.
    pub thrust_n: f64,
    /// Shaft torque, N·m.
    pub torque_nm: f64,
}

/// Unit thrust direction in body FRD: `(cos θ_p, 0, −sin θ_p)` (θ_p positive nose up).
pub fn thrust_axis(p: &Propeller<f64>) -> Vector3<f64> {
    Vector3::new(p.pitch_rad.cos(), 0.0, -p.pitch_rad.sin())
}

/// Thrust and torque at propeller speed `speed_rad_s`, axial airspeed `axial_mps` (air-relative
/// velocity along the thrust axis) and density `rho`.
pub fn propeller(p: &Propeller<f64>, speed_rad_s: f64, axial_mps: f64, rho: f64) -> PropOutput {
    let n = speed_rad_s / (2.0 * core::f64::consts::PI);
    if n.abs() < 1e-9 {
        return PropOutput::default();
    }
    let d = p.diameter_m;
    let j = axial_mps / (n * d);
    let ct = p.ct[0] + p.ct[1] * j + p.ct[2] * j * j;
    let cp = p.cp[0] + p.cp[1] * j + p.cp[2] * j * j;
    let n2 = n * n;
    PropOutput {
        speed_rad_s,
        advance_ratio: j,
        thrust_n: ct * rho * n2 * d.powi(4),
        torque_nm: cp * rho * n2 * d.powi(5) / (2.0 * core::f64::consts::PI),
    }
}
