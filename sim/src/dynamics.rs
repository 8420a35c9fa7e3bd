//! The nonlinear 6-DoF rigid body (FRD body, NED earth, quaternion attitude body→NED) and its RK4
//! integrator, with the forces of the truth aerodynamics, the propeller and gravity.
//!
//! `m(v̇ + ω×v) = F_A + F_T + m Rᵀ g e_z`, `J ω̇ + ω×Jω = M_A + M_T`, `q̇ = ½ q ⊗ (0, ω)`,
//! `ṗ_NED = R v` (R: body→NED). Air-relative velocity `v_r = v − Rᵀ w_NED − g_body` (steady wind,
//! body-axis gusts); `V = |v_r|`, `α = atan2(w_r, u_r)`, `β = asin(v_r/V)`.

use super::aero::{force_moment, AeroInput, Coefficients, ParameterJump, TruthAero};
use super::airframe::SimAirframe;
use super::atmosphere::isa_density;
use super::propulsion::{propeller, thrust_axis, PropOutput};
use nalgebra::{Matrix3, Quaternion, SVector, UnitQuaternion, Vector3};

/// Standard gravity, m/s².
pub const G_MPS2: f64 = 9.806_65;

/// Control inputs held over an output period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Controls {
    /// Elevator, rad (trailing edge down positive).
    pub elevator_rad: f64,
    /// Aileron, rad (right aileron down positive).
    pub aileron_rad: f64,
    /// Rudder, rad (trailing edge left positive).
    pub rudder_rad: f64,
    /// Throttle, 0…1.
    pub throttle: f64,
}

/// The rigid-body state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidState {
    /// Position in NED, m (altitude = −z).
    pub position_ned_m: Vector3<f64>,
    /// Inertial velocity in body axes (u, v, w), m/s.
    pub velocity_body_mps: Vector3<f64>,
    /// Attitude, body → NED.
    pub attitude: UnitQuaternion<f64>,
    /// Body rates (p, q, r), rad/s.
    pub rate_rad_s: Vector3<f64>,
}

type Packed = SVector<f64, 13>;

impl RigidState {
    fn pack(&self) -> Packed {
        let q = self.attitude.quaternion();
        let mut x = Packed::zeros();
        x.fixed_rows_mut::<3>(0).copy_from(&self.position_ned_m);
        x.fixed_rows_mut::<3>(3).copy_from(&self.velocity_body_mps);
        x[6] = q.w;
        x[7] = q.i;
        x[8] = q.j;
        x[9] = q.k;
        x.fixed_rows_mut::<3>(10).copy_from(&self.rate_rad_s);
        x
    }
    fn unpack(x: &Packed) -> Self {
        Self {
            position_ned_m: x.fixed_rows::<3>(0).into_owned(),
            velocity_body_mps: x.fixed_rows::<3>(3).into_owned(),
            attitude: UnitQuaternion::new_normalize(Quaternion::new(x[6], x[7], x[8], x[9])),
            rate_rad_s: x.fixed_rows::<3>(10).into_owned(),
        }
    }
    /// Roll, pitch, yaw (3-2-1), rad.
    pub fn euler_rad(&self) -> Vector3<f64> {
        let (r, p, y) = self.attitude.euler_angles();
        Vector3::new(r, p, y)
    }
    /// Altitude above the NED origin, m.
    pub fn altitude_m(&self) -> f64 {
        -self.position_ned_m.z
    }
}

/// Everything evaluated at one state: air data, truth coefficients, forces, derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation {
    /// Airspeed `V`, m/s.
    pub airspeed_mps: f64,
    /// α, rad.
    pub alpha_rad: f64,
    /// β, rad.
    pub beta_rad: f64,
    /// Density, kg/m³.
    pub density_kgpm3: f64,
    /// Dynamic pressure `½ρV²`, Pa.
    pub qbar_pa: f64,
    /// The regressors (with normalised rates and saturated surfaces).
    pub input: AeroInput,
    /// The truth coefficients (zero when aerodynamics are off).
    pub coefficients: Coefficients,
    /// Aerodynamic force, body, N.
    pub aero_force_n: Vector3<f64>,
    /// Aerodynamic moment about the CG, body, N·m.
    pub aero_moment_nm: Vector3<f64>,
    /// Propeller force, body, N.
    pub thrust_force_n: Vector3<f64>,
    /// Propeller moment about the CG (mount offset and torque), body, N·m.
    pub thrust_moment_nm: Vector3<f64>,
    /// Propeller state.
    pub prop: PropOutput,
    /// Specific force `(F_A + F_T)/m`, body, m/s² (what an accelerometer at the CG measures).
    pub specific_force_mps2: Vector3<f64>,
    /// Body velocity derivative, m/s².
    pub velocity_dot_mps2: Vector3<f64>,
    /// Angular acceleration, rad/s².
    pub rate_dot_rad_s2: Vector3<f64>,
}

/// The plant: airframe, truth aerodynamics, wind, switches.
#[derive(Debug, Clone, PartialEq)]
pub struct Plant {
    /// The airframe.
    pub airframe: SimAirframe,
    /// The truth aerodynamics (its `linear` part is normally `airframe.aero`).
    pub truth: TruthAero,
    /// Optional simulated damage.
    pub jump: Option<ParameterJump>,
    /// Steady wind, NED, m/s (velocity of the air).
    pub wind_ned_mps: Vector3<f64>,
    /// Gravity, m/s².
    pub gravity_mps2: f64,
    /// Aerodynamic forces and moments on (off: a body in vacuum).
    pub aerodynamics: bool,
    /// Propeller on.
    pub propulsion: bool,
}

impl Plant {
    /// The airframe with its own aerodynamics and the given effects, no wind, standard gravity.
    pub fn new(airframe: SimAirframe, effects: super::aero::TruthEffects) -> Self {
        let truth = TruthAero {
            linear: airframe.aero,
            effects,
            aspect_ratio: airframe.aspect_ratio(),
        };
        Self {
            airframe,
            truth,
            jump: None,
            wind_ned_mps: Vector3::zeros(),
            gravity_mps2: G_MPS2,
            aerodynamics: true,
            propulsion: true,
        }
    }

    /// The truth aerodynamics in force at time `t_s` (after the jump, the changed coefficients).
    pub fn truth_at(&self, t_s: f64) -> TruthAero {
        match &self.jump {
            Some(j) if t_s >= j.at_s => TruthAero {
                linear: self.truth.linear.plus(&j.delta),
                ..self.truth
            },
            _ => self.truth,
        }
    }

    /// Surfaces clipped to their limits, throttle to 0…1.
    pub fn saturate(&self, u: &Controls) -> Controls {
        let l = &self.airframe.limits;
        Controls {
            elevator_rad: u.elevator_rad.clamp(l.elevator_rad.0, l.elevator_rad.1),
            aileron_rad: u.aileron_rad.clamp(l.aileron_rad.0, l.aileron_rad.1),
            rudder_rad: u.rudder_rad.clamp(l.rudder_rad.0, l.rudder_rad.1),
            throttle: u.throttle.clamp(0.0, 1.0),
        }
    }

    /// Evaluates forces and derivatives at `x` (controls are saturated here).
    #[allow(non_snake_case)]
    pub fn evaluate(&self, x: &RigidState, u: &Controls, gust_body_mps: &Vector3<f64>, t_s: f64) -> Evaluation {
        let af = &self.airframe;
        let u = self.saturate(u);
        let R = x.attitude.to_rotation_matrix();
        let vr = x.velocity_body_mps - R.inverse_transform_vector(&self.wind_ned_mps) - gust_body_mps;
        let V = vr.norm();
        let alpha = vr.z.atan2(vr.x);
        let beta = if V > 1e-9 {
            (vr.y / V).clamp(-1.0, 1.0).asin()
        } else {
            0.0
        };
        let rho = isa_density(x.altitude_m());
        let qbar = 0.5 * rho * V * V;
        let w = &x.rate_rad_s;
        let (b, c) = (af.frame.span_m, af.frame.chord_m);
        let half_v = if V > 1e-3 { 2.0 * V } else { f64::INFINITY };
        let input = AeroInput {
            alpha_rad: alpha,
            beta_rad: beta,
            p_n: w.x * b / half_v,
            q_n: w.y * c / half_v,
            r_n: w.z * b / half_v,
            aileron_rad: u.aileron_rad,
            elevator_rad: u.elevator_rad,
            rudder_rad: u.rudder_rad,
        };
        let (coefficients, aero_force_n, aero_moment_nm) = if self.aerodynamics {
            let co = self.truth_at(t_s).coefficients(&input);
            let (f, m) = force_moment(&co, qbar, &af.geometry(), alpha);
            (co, f, m)
        } else {
            (Coefficients::default(), Vector3::zeros(), Vector3::zeros())
        };
        let pr = &af.frame.propeller;
        let (prop, thrust_force_n, thrust_moment_nm) = if self.propulsion {
            let axis = thrust_axis(pr);
            let prop = propeller(pr, u.throttle * af.max_prop_speed_rad_s, vr.dot(&axis), rho);
            let f = axis * prop.thrust_n;
            let mut m = Vector3::zeros();
            if self.truth.effects.thrust_moment {
                m += pr.position_m.cross(&f);
            }
            if self.truth.effects.prop_torque {
                m.x -= prop.torque_nm;
            }
            (prop, f, m)
        } else {
            (PropOutput::default(), Vector3::zeros(), Vector3::zeros())
        };
        let mass = af.frame.mass_kg;
        let J: Matrix3<f64> = af.frame.inertia_kgm2;
        let specific = (aero_force_n + thrust_force_n) / mass;
        let g_body = R.inverse_transform_vector(&Vector3::new(0.0, 0.0, self.gravity_mps2));
        let velocity_dot = specific + g_body - w.cross(&x.velocity_body_mps);
        // Downwash lag: `α̇ = (u_r ẇ − w_r u̇)/(u_r² + w_r²)` with the air-relative
        // velocity's rate equal to the body acceleration (wind steady, gust held over the step). The
        // forces do not depend on `α̇`, so there is no algebraic loop.
        let (mut coefficients, mut aero_moment_nm) = (coefficients, aero_moment_nm);
        if let (Some(cm_ad), true) = (self.truth.effects.pitch_alpha_dot, self.aerodynamics) {
            let den = vr.x * vr.x + vr.z * vr.z;
            if den > 1e-6 && V > 1e-3 {
                let alpha_dot = (vr.x * velocity_dot.z - vr.z * velocity_dot.x) / den;
                let dcm = cm_ad * alpha_dot * c / (2.0 * V);
                coefficients.pitch += dcm;
                aero_moment_nm.y += qbar * af.frame.wing_area_m2 * c * dcm;
            }
        }
        let moment = aero_moment_nm + thrust_moment_nm - w.cross(&(J * w));
        let rate_dot = J.lu().solve(&moment).unwrap_or_else(Vector3::zeros);
        Evaluation {
            airspeed_mps: V,
            alpha_rad: alpha,
            beta_rad: beta,
            density_kgpm3: rho,
            qbar_pa: qbar,
            input,
            coefficients,
            aero_force_n,
            aero_moment_nm,
            thrust_force_n,
            thrust_moment_nm,
            prop,
            specific_force_mps2: specific,
            velocity_dot_mps2: velocity_dot,
            rate_dot_rad_s2: rate_dot,
        }
    }

    fn derivative(&self, x: &Packed, u: &Controls, gust: &Vector3<f64>, t_s: f64) -> Packed {
        let s = RigidState::unpack(x);
        let e = self.evaluate(&s, u, gust, t_s);
        let mut d = Packed::zeros();
        d.fixed_rows_mut::<3>(0)
            .copy_from(&s.attitude.transform_vector(&s.velocity_body_mps));
        d.fixed_rows_mut::<3>(3).copy_from(&e.velocity_dot_mps2);
        // q̇ = ½ q ⊗ (0, ω), with the un-normalised stage quaternion.
        let q = Quaternion::new(x[6], x[7], x[8], x[9]);
        let qd = q * Quaternion::from_imag(s.rate_rad_s) * 0.5;
        d[6] = qd.w;
        d[7] = qd.i;
        d[8] = qd.j;
        d[9] = qd.k;
        d.fixed_rows_mut::<3>(10).copy_from(&e.rate_dot_rad_s2);
        d
    }

    /// One classical RK4 step of `dt_s` with controls and gust held; the quaternion is renormalised.
    pub fn rk4_step(
        &self,
        x: &RigidState,
        u: &Controls,
        gust_body_mps: &Vector3<f64>,
        t_s: f64,
        dt_s: f64,
    ) -> RigidState {
        self.rk4_step_with(x, |_| *u, gust_body_mps, t_s, dt_s)
    }

    /// One classical RK4 step of `dt_s` with the controls a function of the time since the step's
    /// start (continuous servo positions, [`super::actuator`]) and the gust held.
    pub fn rk4_step_with(
        &self,
        x: &RigidState,
        u: impl Fn(f64) -> Controls,
        gust_body_mps: &Vector3<f64>,
        t_s: f64,
        dt_s: f64,
    ) -> RigidState {
        let x0 = x.pack();
        let h = dt_s;
        let (u0, um, u1) = (u(0.0), u(h / 2.0), u(h));
        let k1 = self.derivative(&x0, &u0, gust_body_mps, t_s);
        let k2 = self.derivative(&(x0 + k1 * (h / 2.0)), &um, gust_body_mps, t_s + h / 2.0);
        let k3 = self.derivative(&(x0 + k2 * (h / 2.0)), &um, gust_body_mps, t_s + h / 2.0);
        let k4 = self.derivative(&(x0 + k3 * h), &u1, gust_body_mps, t_s + h);
        RigidState::unpack(&(x0 + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0)))
    }
}
