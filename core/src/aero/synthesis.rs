//! Coefficient synthesis: the six aerodynamic coefficients of one sample, by solving eq. 1–2 of
//! seed 000 for them from what the flight computer measures.
//!
//! ## What is computed (all in SI, body frame FRD)
//! * Dynamic pressure `q̄ = ½ρV²` (eq. 1–2).
//! * Propulsion (seed 000, Section II: "propulsion forces and torques can be modeled through engine
//!   ground tests"; the model of [`Propeller`]): `n = ω/2π`, `J = V_x/(nD)` with `V_x` the airspeed
//!   along the thrust line, `V_x = v·u = V cos β cos(α + θ_p)` (the air-relative velocity in body axes
//!   is `v = V[cos α cos β, sin β, sin α cos β]`), `T = C_T(J) ρ n² D⁴`, `Q = C_P(J) ρ n² D⁵/(2π)`.
//!   The thrust acts along the
//!   pitched thrust line `u = [cos θ_p, 0, −sin θ_p]` (`θ_p` positive nose up) at the mount position
//!   `r`: `F_T = T u`, `M_T = r × F_T + [s_Q Q, 0, 0]` — the torque is a rolling moment with sign
//!   `s_Q` ([`SynthesisSettings::prop_torque_sign`], default `−1`: the reaction on the airframe of a
//!   propeller turning positively about body `+x`, i.e. clockwise seen from behind). With the
//!   propeller stopped (`nD ≤ 10⁻⁹ m/s`) `T = Q = 0`.
//! * Aerodynamic force: the accelerometer at the CG measures the specific force
//!   `a = (F_A + F_T)/m` (gravity is not sensed), so `F_A = m a − F_T`.
//! * Aerodynamic moment from the rigid-body equation `J ω̇ + ω × Jω = M_A + M_T`:
//!   `M_A = J ω̇ + ω × Jω − M_T`, with `ω̇` supplied by the caller (on board: the
//!   [`RateDifferentiator`]).
//! * Eq. 1, frame and signs: `F_A = q̄S[−C_D, C_Y, −C_L]` in the axes chosen by [`ForceAxes`]:
//!   - [`ForceAxes::Stability`] (default; the convention of Beard & McLain and of the seed's
//!     `last_letter` simulator, whose `skywalker_2013_mod` set we use): drag and lift in the stability
//!     frame (body axes rotated by `α` about body `y`), side force along body `y`:
//!     `D = −(F_x cos α + F_z sin α)`, `L = F_x sin α − F_z cos α`, `Y = F_y`.
//!   - [`ForceAxes::Wind`]: the wind frame, `F_w = C_bw F_A` with the body-to-wind rotation
//!     `C_bw = [[cα cβ, sβ, sα cβ], [−cα sβ, cβ, −sα sβ], [−sα, 0, cα]]`, `D = −F_w,x`, `Y = F_w,y`,
//!     `L = −F_w,z`. Both agree at `β = 0`.
//!
//!   `C_D = D/(q̄S)`, `C_Y = Y/(q̄S)`, `C_L = L/(q̄S)`.
//! * Eq. 2 in body axes: `C_l = M_A,x/(q̄Sb)`, `C_m = M_A,y/(q̄Sc̄)`, `C_n = M_A,z/(q̄Sb)`.
//! * Non-dimensional rates (eq. 3): `p_n = p b/(2V)`, `q_n = q c̄/(2V)`, `r_n = r b/(2V)`.
//!
//! ## The differentiator
//! [`RateDifferentiator`] is the 5-point Savitzky–Golay first-derivative filter (a least-squares
//! straight line through the last five gyro samples), `ω̇ ≈ (2ω₀ + ω₋₁ − ω₋₃ − 2ω₋₄)/(10h)`, with `h`
//! the mean of the last four `dt_s`. It is exact on ramps, has exactly linear phase with a **group
//! delay of 2 samples** (`2h`, 20 ms at 100 Hz), gain relative to the ideal differentiator
//! `G(ωh) = (sin ωh + 2 sin 2ωh)/(5ωh) = 1 − 17(ωh)²/30 + 13(ωh)⁴/120 − …` (for `h = 10 ms`:
//! −0.22 % at 1 Hz, −2.0 % at 3 Hz, −5.5 % at 5 Hz), and white-noise gain `√10/(10h) ≈ 0.316/h`
//! (a two-point difference has `√2/h`).
//! The [`Pipeline`](super::pipeline::Pipeline) delays every other channel by the same 2 samples, so
//! the synthesised sample is time-consistent (the identification lags the sensors by 20 ms).

use super::{Airframe, Propeller, SensorSample};
use crate::linalg::const_zeros;
use crate::Real;
use nalgebra::Vector3;

/// The axes in which eq. 1 defines `C_D`, `C_Y`, `C_L` (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ForceAxes {
    /// Lift and drag in the stability frame (rotation by `α`), side force along body `y`.
    #[default]
    Stability,
    /// Lift, drag and side force in the wind frame (rotations by `α` and `β`).
    Wind,
}

/// Settings of the synthesis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthesisSettings<T> {
    /// Axes of eq. 1. Default [`ForceAxes::Stability`].
    pub force_axes: ForceAxes,
    /// Sign `s_Q` of the propeller torque as a rolling moment on the airframe, `±1`. Default `−1`
    /// (reaction to a propeller turning positively about body `+x`).
    pub prop_torque_sign: T,
}

impl<T: Real> SynthesisSettings<T> {
    /// A placeholder for `const` initialisers (the stability axes, `s_Q = 0`).
    pub const ZERO: Self = Self {
        force_axes: ForceAxes::Stability,
        prop_torque_sign: T::ZERO,
    };
}

impl<T: Real> Default for SynthesisSettings<T> {
    fn default() -> Self {
        Self {
            force_axes: ForceAxes::Stability,
            prop_torque_sign: -T::one(),
        }
    }
}

/// The propeller's output at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PropellerOutput<T> {
    /// Advance ratio `J = V_x/(nD)` (0 with the propeller stopped).
    pub advance_ratio: T,
    /// Thrust `T`, N (along the thrust line).
    pub thrust_n: T,
    /// Shaft torque `Q`, N·m (magnitude; its sign on the airframe is `s_Q`).
    pub torque_nm: T,
}

/// Thrust and torque of the propeller model (module doc): `axial_speed_mps` is `V_x`.
pub fn propeller_output<T: Real>(
    prop: &Propeller<T>,
    air_density_kgpm3: T,
    axial_speed_mps: T,
    prop_speed_rad_s: T,
) -> PropellerOutput<T> {
    let n = prop_speed_rad_s / T::two_pi();
    let d = prop.diameter_m;
    if !(n * d > T::lit(1e-9)) {
        return PropellerOutput::default();
    }
    let j = axial_speed_mps / (n * d);
    let ct = prop.ct[0] + j * (prop.ct[1] + j * prop.ct[2]);
    let cp = prop.cp[0] + j * (prop.cp[1] + j * prop.cp[2]);
    let rho_n2 = air_density_kgpm3 * n * n;
    let d4 = d * d * d * d;
    PropellerOutput {
        advance_ratio: j,
        thrust_n: ct * rho_n2 * d4,
        torque_nm: cp * rho_n2 * d4 * d / T::two_pi(),
    }
}

/// Thrust force and moment about the CG of the propeller, body FRD (N, N·m).
pub fn propulsion_force_moment<T: Real>(
    prop: &Propeller<T>,
    out: &PropellerOutput<T>,
    prop_torque_sign: T,
) -> (Vector3<T>, Vector3<T>) {
    let (sp, cp) = prop.pitch_rad.sin_cos_fast();
    let u = Vector3::new(cp, T::zero(), -sp);
    let f = u * out.thrust_n;
    let m = prop.position_m.cross(&f) + Vector3::new(prop_torque_sign * out.torque_nm, T::zero(), T::zero());
    (f, m)
}

/// The six synthetic coefficients of eq. 1–2 (dimensionless).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Coefficients<T> {
    /// `C_L`.
    pub lift: T,
    /// `C_D`.
    pub drag: T,
    /// `C_Y`.
    pub side: T,
    /// `C_l` (rolling moment).
    pub roll: T,
    /// `C_m` (pitching moment).
    pub pitch: T,
    /// `C_n` (yawing moment).
    pub yaw: T,
}

impl<T: Copy> Coefficients<T> {
    /// In the order of [`idx`](super::model::idx): `[C_L, C_D, C_Y, C_l, C_m, C_n]`.
    pub fn as_array(&self) -> [T; 6] {
        [self.lift, self.drag, self.side, self.roll, self.pitch, self.yaw]
    }
}

/// Everything the synthesis of one sample produces.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Synthesis<T: Real> {
    /// Time of the synthesised sample, s.
    pub t_s: T,
    /// Dynamic pressure `q̄ = ½ρV²`, Pa.
    pub dynamic_pressure_pa: T,
    /// The coefficients of eq. 1–2.
    pub coefficients: Coefficients<T>,
    /// Non-dimensional rates `[p_n, q_n, r_n]` (eq. 3).
    pub rates_n: Vector3<T>,
    /// Aerodynamic force `F_A`, body FRD, N.
    pub force_aero_n: Vector3<T>,
    /// Aerodynamic moment `M_A` about the CG, body FRD, N·m.
    pub moment_aero_nm: Vector3<T>,
    /// The propeller's state.
    pub propeller: PropellerOutput<T>,
}

/// Eq. 1–2 solved for the coefficients, for one sample and the angular acceleration
/// `omega_dot_rad_s2` (body FRD, rad/s²) at the same instant.
///
/// Pure arithmetic: non-finite channels give non-finite outputs (the pipeline checks channels
/// before and uses only the coefficients whose channels are valid). Errors: `airspeed_mps` or
/// `air_density_kgpm3` not positive → [`Error::OutOfRange`](crate::Error::OutOfRange) with
/// `index` 0 (the coefficients would divide by `q̄ = 0`).
#[allow(non_snake_case)]
pub fn synthesise<T: Real>(
    s: &SensorSample<T>,
    airframe: &Airframe<T>,
    omega_dot_rad_s2: &Vector3<T>,
    settings: &SynthesisSettings<T>,
) -> Result<Synthesis<T>, crate::Error> {
    let V = s.airspeed_mps;
    if !(V > T::zero() && s.air_density_kgpm3 > T::zero()) {
        return Err(crate::Error::OutOfRange { index: 0 });
    }
    let two = T::lit(2.0);
    let qbar = s.air_density_kgpm3 * V * V / two;
    let (sa, ca) = s.alpha_rad.sin_cos_fast();
    let (sb, cb) = s.beta_rad.sin_cos_fast();
    let (sp, cp) = airframe.propeller.pitch_rad.sin_cos_fast();
    // cos(α + θ_p) by the addition theorem: no third transcendental call.
    let axial_mps = V * cb * (ca * cp - sa * sp);
    let prop = propeller_output(&airframe.propeller, s.air_density_kgpm3, axial_mps, s.prop_speed_rad_s);
    let (f_t, m_t) = propulsion_force_moment(&airframe.propeller, &prop, settings.prop_torque_sign);
    let f_a = s.accel_mps2 * airframe.mass_kg - f_t;
    let w = s.gyro_rad_s;
    let jw = airframe.inertia_kgm2 * w;
    let m_a = airframe.inertia_kgm2 * omega_dot_rad_s2 + w.cross(&jw) - m_t;
    let (drag, side, lift) = match settings.force_axes {
        ForceAxes::Stability => (-(f_a.x * ca + f_a.z * sa), f_a.y, f_a.x * sa - f_a.z * ca),
        ForceAxes::Wind => {
            let fw_x = ca * cb * f_a.x + sb * f_a.y + sa * cb * f_a.z;
            let fw_y = -ca * sb * f_a.x + cb * f_a.y - sa * sb * f_a.z;
            let fw_z = -sa * f_a.x + ca * f_a.z;
            (-fw_x, fw_y, -fw_z)
        }
    };
    let qs = qbar * airframe.wing_area_m2;
    let (b, c) = (airframe.span_m, airframe.chord_m);
    Ok(Synthesis {
        t_s: s.t_s,
        dynamic_pressure_pa: qbar,
        coefficients: Coefficients {
            lift: lift / qs,
            drag: drag / qs,
            side: side / qs,
            roll: m_a.x / (qs * b),
            pitch: m_a.y / (qs * c),
            yaw: m_a.z / (qs * b),
        },
        rates_n: Vector3::new(w.x * b / (two * V), w.y * c / (two * V), w.z * b / (two * V)),
        force_aero_n: f_a,
        moment_aero_nm: m_a,
        propeller: prop,
    })
}

/// The causal 5-point Savitzky–Golay differentiator of the gyro (module doc): group delay
/// [`Self::DELAY_SAMPLES`] samples, exact on ramps.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RateDifferentiator<T: Real> {
    /// Gyro samples, newest first, rad/s.
    window: [Vector3<T>; 5],
    /// `dt_s` of the four newest samples (each the gap to its predecessor), newest first, s.
    dt_s: [T; 4],
    /// Consecutive valid samples in the window (0…5).
    run: u8,
}

impl<T: Real> RateDifferentiator<T> {
    /// Group delay of the estimate, in samples (`2h`).
    pub const DELAY_SAMPLES: usize = 2;
    /// Window length.
    pub const LEN: usize = 5;

    /// An empty differentiator.
    pub const fn new() -> Self {
        Self {
            window: [const_zeros(); 5],
            dt_s: [T::ZERO; 4],
            run: 0,
        }
    }

    /// Forgets the window (after a gap or an invalid gyro sample).
    pub fn reset(&mut self) {
        self.run = 0;
    }

    /// Appends a gyro sample. `gap_ok`: the sample's `dt_s` is valid (else the window restarts with
    /// this sample); `gyro_ok`: the gyro channel is valid (else the window is emptied).
    pub fn push(&mut self, gyro_rad_s: &Vector3<T>, dt_s: T, gyro_ok: bool, gap_ok: bool) {
        if !gyro_ok {
            self.run = 0;
            return;
        }
        if !gap_ok {
            self.run = 0;
        }
        for i in (1..Self::LEN).rev() {
            self.window[i] = self.window[i - 1];
        }
        self.window[0] = *gyro_rad_s;
        for i in (1..4).rev() {
            self.dt_s[i] = self.dt_s[i - 1];
        }
        // After an invalid gap this sample starts a new window, and its gap (to a sample outside
        // the window) is shifted out before the window is full: it is never used, so it is stored as
        // 0 rather than as the invalid (possibly NaN) value — the state stays finite.
        self.dt_s[0] = if gap_ok { dt_s } else { T::zero() };
        self.run = (self.run + 1).min(Self::LEN as u8);
    }

    /// Whether a full window of consecutive valid samples is held.
    pub fn ready(&self) -> bool {
        self.run as usize >= Self::LEN
    }

    /// `ω̇` at the centre of the window ([`Self::DELAY_SAMPLES`] samples before the newest), rad/s²;
    /// `None` until [`Self::ready`].
    pub fn derivative(&self) -> Option<Vector3<T>> {
        if !self.ready() {
            return None;
        }
        let h = (self.dt_s[0] + self.dt_s[1] + self.dt_s[2] + self.dt_s[3]) / T::lit(4.0);
        if !(h > T::zero()) {
            return None;
        }
        let w = &self.window;
        let two = T::lit(2.0);
        Some((w[0] * two + w[1] - w[3] - w[4] * two) / (T::lit(10.0) * h))
    }

    /// Gain of the filter relative to the ideal differentiator at `ωh` (rad per sample):
    /// `(sin ωh + 2 sin 2ωh)/(5ωh)`; 1 at `ωh → 0`.
    pub fn gain(omega_h: T) -> T {
        if omega_h.abs() < T::lit(1e-6) {
            return T::one();
        }
        (omega_h.sin() + T::lit(2.0) * (T::lit(2.0) * omega_h).sin()) / (T::lit(5.0) * omega_h)
    }
}
