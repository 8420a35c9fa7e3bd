//! Models for the filter error method: the HFB-320 longitudinal model of the flight-data README
//! (Jategaonkar's test case 4), the longitudinal model of seed 001's example (Section 4, with the
//! `α̇` derivatives kept apart from `q`), and that model with the turbulence as Dryden-shaped states
//! (the "dynamic compensation with colored process noise" of the seed's conclusion).

use super::Model;
use crate::Real;
use nalgebra::{SMatrix, SVector};

/// Standard gravity, m/s².
const G_MPS2: f64 = 9.80665;

/// HFB-320 Hansa Jet, longitudinal (flight-data README §1).
///
/// States `x = [V, α, θ, q]` (m/s, rad, rad, rad/s); inputs `u = [δe, F]` (rad, N); outputs
/// `y = [V, α, θ, q, q̇, a_x, a_z]`; parameters
/// `p = [CD0, CDV, CDα, CL0, CLV, CLα, Cm0, CmV, Cmα, Cmq, Cmδe]` of
/// `CD = CD0 + CDV·V/V0 + CDα·α`, `CL = CL0 + CLV·V/V0 + CLα·α`,
/// `Cm = Cm0 + CmV·V/V0 + Cmα·α + Cmq·q·(c̄/2)/V0 + Cmδe·δe`. State equations (flat earth,
/// wings level): `V̇ = −q̄(S/m)CD + g sin(α−θ) + (F/m)cos(α+σT)`,
/// `α̇ = −q̄(S/m)CL/V + q + (g/V)cos(α−θ) − F sin(α+σT)/(mV)`, `θ̇ = q`,
/// `q̇ = q̄(S c̄/Iy)Cm + k_F F`; outputs `a_x = q̄(S/m)CX + F cos σT/m`, `a_z = q̄(S/m)CZ − F sin σT/m`
/// with `CX = CL sin α − CD cos α`, `CZ = −CL cos α − CD sin α`. `∂f/∂p` and `∂h/∂p` are analytic
/// (the model is linear in `p`); `∂/∂x` by central differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hfb320<T> {
    /// Reference speed `V0`, m/s (104.67).
    pub v0_mps: T,
    /// Half chord `c̄/2`, m (1.215).
    pub half_chord_m: T,
    /// Air density, kg/m³ (0.792, constant).
    pub rho_kgpm3: T,
    /// Mass, kg (7472).
    pub mass_kg: T,
    /// `S/m`, m²/kg (4.028e-3).
    pub s_over_m: T,
    /// `S c̄/Iy`, m³/(kg·m²) (8.0027e-4).
    pub sc_over_iy: T,
    /// Thrust inclination `σT`, rad (0.0524).
    pub sigma_t_rad: T,
    /// Thrust pitching moment per newton `k_F`, rad/s² per N (−7.0153e-6).
    pub thrust_moment: T,
}

impl<T: Real> Default for Hfb320<T> {
    /// The README's constants.
    fn default() -> Self {
        let l = T::lit;
        Self {
            v0_mps: l(104.67),
            half_chord_m: l(1.215),
            rho_kgpm3: l(0.792),
            mass_kg: l(7472.0),
            s_over_m: l(4.028e-3),
            sc_over_iy: l(8.0027e-4),
            sigma_t_rad: l(0.0524),
            thrust_moment: l(-7.0153e-6),
        }
    }
}

/// Indices of the HFB-320 parameters.
pub mod hfb320_idx {
    /// Names in order.
    pub const NAMES: [&str; 11] = [
        "CD0", "CDV", "CDalpha", "CL0", "CLV", "CLalpha", "Cm0", "CmV", "Cmalpha", "Cmq", "Cmde",
    ];
}

impl<T: Real> Hfb320<T> {
    /// `(q̄, rD, rL, rm)`: dynamic pressure and the regressors of CD, CL, Cm.
    fn regressors(&self, x: &SVector<T, 4>, u: &SVector<T, 2>) -> (T, [T; 3], [T; 3], [T; 5]) {
        let (v, alpha, q) = (x[0], x[1], x[3]);
        let qbar = T::lit(0.5) * self.rho_kgpm3 * v * v;
        let vn = v / self.v0_mps;
        let rd = [T::one(), vn, alpha];
        let rm = [T::one(), vn, alpha, q * self.half_chord_m / self.v0_mps, u[0]];
        (qbar, rd, rd, rm)
    }

    fn coefficients(&self, x: &SVector<T, 4>, u: &SVector<T, 2>, p: &SVector<T, 11>) -> (T, T, T, T) {
        let (qbar, rd, rl, rm) = self.regressors(x, u);
        let cd = p[0] * rd[0] + p[1] * rd[1] + p[2] * rd[2];
        let cl = p[3] * rl[0] + p[4] * rl[1] + p[5] * rl[2];
        let cm = p[6] * rm[0] + p[7] * rm[1] + p[8] * rm[2] + p[9] * rm[3] + p[10] * rm[4];
        (qbar, cd, cl, cm)
    }
}

impl<T: Real> Model<T, 4, 2, 7, 11> for Hfb320<T> {
    fn f(&self, x: &SVector<T, 4>, u: &SVector<T, 2>, p: &SVector<T, 11>) -> SVector<T, 4> {
        let (v, alpha, theta, q) = (x[0], x[1], x[2], x[3]);
        let thrust = u[1];
        let (qbar, cd, cl, cm) = self.coefficients(x, u, p);
        let g = T::lit(G_MPS2);
        let f_over_m = thrust / self.mass_kg;
        let (sat, cat) = (alpha + self.sigma_t_rad).sin_cos_fast();
        let gamma_term = (alpha - theta).sin_cos_fast();
        SVector::<T, 4>::new(
            -qbar * self.s_over_m * cd + g * gamma_term.0 + f_over_m * cat,
            -qbar * self.s_over_m * cl / v + q + g / v * gamma_term.1 - f_over_m * sat / v,
            q,
            qbar * self.sc_over_iy * cm + self.thrust_moment * thrust,
        )
    }

    fn h(&self, x: &SVector<T, 4>, u: &SVector<T, 2>, p: &SVector<T, 11>) -> SVector<T, 7> {
        let xdot = self.f(x, u, p);
        let (qbar, cd, cl, _) = self.coefficients(x, u, p);
        let alpha = x[1];
        let (sa, ca) = alpha.sin_cos_fast();
        let (ss, cs) = self.sigma_t_rad.sin_cos_fast();
        let f_over_m = u[1] / self.mass_kg;
        let cx = cl * sa - cd * ca;
        let cz = -cl * ca - cd * sa;
        SVector::<T, 7>::from_column_slice(&[
            x[0],
            x[1],
            x[2],
            x[3],
            xdot[3],
            qbar * self.s_over_m * cx + f_over_m * cs,
            qbar * self.s_over_m * cz - f_over_m * ss,
        ])
    }

    fn df_dp(&self, x: &SVector<T, 4>, u: &SVector<T, 2>, _p: &SVector<T, 11>) -> SMatrix<T, 4, 11> {
        let (qbar, rd, rl, rm) = self.regressors(x, u);
        let v = x[0];
        let mut j = SMatrix::<T, 4, 11>::zeros();
        for k in 0..3 {
            j[(0, k)] = -qbar * self.s_over_m * rd[k];
            j[(1, 3 + k)] = -qbar * self.s_over_m * rl[k] / v;
        }
        for k in 0..5 {
            j[(3, 6 + k)] = qbar * self.sc_over_iy * rm[k];
        }
        j
    }

    fn dh_dp(&self, x: &SVector<T, 4>, u: &SVector<T, 2>, p: &SVector<T, 11>) -> SMatrix<T, 7, 11> {
        let (qbar, rd, rl, _) = self.regressors(x, u);
        let jf = self.df_dp(x, u, p);
        let (sa, ca) = x[1].sin_cos_fast();
        let k = qbar * self.s_over_m;
        let mut j = SMatrix::<T, 7, 11>::zeros();
        for c in 0..11 {
            j[(4, c)] = jf[(3, c)];
        }
        for i in 0..3 {
            // a_x: CX = CL sin α − CD cos α; a_z: CZ = −CL cos α − CD sin α.
            j[(5, i)] = -k * ca * rd[i];
            j[(5, 3 + i)] = k * sa * rl[i];
            j[(6, i)] = -k * sa * rd[i];
            j[(6, 3 + i)] = -k * ca * rl[i];
        }
        j
    }
}

/// The longitudinal model of seed 001's example (Section 4, eq. 14): states
/// `x = [V, α, q, θ, h]`, input `u = [δe]`, outputs `y = x`, parameters
/// `p = [CL0, CLα, CLα̇, CLδe, Cm0, Cmα, Cmα̇, Cmq, Cmδe]` of
/// `CL = CL0 + CLα α + CLα̇ α̇ c̄/(2V) + CLδe δe`,
/// `Cm = Cm0 + Cmα α + Cmα̇ α̇ c̄/(2V) + Cmq q c̄/(2V) + Cmδe δe`, with a known drag polar
/// `CD = CD0 + CDα α` and constant thrust along the body x axis (the paper: no compressibility,
/// constant density). State equations (flat earth, point mass in the vertical plane plus pitch):
/// `V̇ = (T cos α − D)/m − g sin(θ − α)`, `α̇ = q − (L + T sin α − m g cos(θ − α))/(mV)`,
/// `q̇ = M/I_y`, `θ̇ = q`, `ḣ = V sin(θ − α)`. `L` contains `α̇`, so `α̇` is solved from the
/// (linear) equation `α̇ (1 + q̄ S CLα̇ c̄/(2V)/(mV)) = q − (L(α̇ = 0) + T sin α − m g cos(θ − α))/(mV)`.
/// Jacobians by central differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Longitudinal<T> {
    /// Mass, kg.
    pub mass_kg: T,
    /// Pitch inertia, kg·m².
    pub iy_kgm2: T,
    /// Wing area, m².
    pub wing_area_m2: T,
    /// Mean aerodynamic chord, m.
    pub chord_m: T,
    /// Air density, kg/m³ (constant).
    pub rho_kgpm3: T,
    /// Thrust, N (constant, along the body x axis).
    pub thrust_n: T,
    /// `CD0` of the known drag polar.
    pub cd0: T,
    /// `CDα` of the known drag polar, per rad.
    pub cd_alpha: T,
}

impl<T: Real> Longitudinal<T> {
    /// Nelson's Douglas A-4D at Mach 0.8, 35 000 ft (aircraft README §3): S 24.15 m², c̄ 3.3 m,
    /// m 7 970 kg, I_y 35 116 kg m², ρ 0.380 kg/m³; drag `CD = 0.03 + 0.30 α` (assumed: the seed
    /// estimates lift and moment only), thrust to be set to the trim value by the caller.
    pub fn a4d() -> Self {
        let l = T::lit;
        Self {
            mass_kg: l(7970.0),
            iy_kgm2: l(35_116.0),
            wing_area_m2: l(24.15),
            chord_m: l(3.3),
            rho_kgpm3: l(0.380),
            thrust_n: l(0.0),
            cd0: l(0.03),
            cd_alpha: l(0.30),
        }
    }

    /// Table 1's true values `[CL0, CLα, CLα̇, CLδe, Cm0, Cmα, Cmα̇, Cmq, Cmδe]`.
    pub const TABLE1_TRUE: [f64; 9] = [0.30, 3.45, 1.20, 0.40, 0.00, -0.41, -1.65, -4.30, -0.60];
    /// Table 1's initial values.
    pub const TABLE1_INITIAL: [f64; 9] = [0.345, 3.986, 0.952, 0.486, 0.000, -0.349, -1.898, -3.655, -0.690];
    /// Table 1's seed estimates.
    pub const TABLE1_SEED: [f64; 9] = [
        0.29741, 3.54006, 0.85384, 0.39602, 0.00038, -0.41918, -1.90584, -3.71197, -0.60317,
    ];
    /// Table 1's seed standard deviations.
    pub const TABLE1_SEED_SIGMA: [f64; 9] = [
        0.00065, 0.02088, 0.23322, 0.03628, 0.00078, 0.02363, 0.48069, 0.77615, 0.04429,
    ];
    /// Parameter names.
    pub const NAMES: [&'static str; 9] = [
        "CL0",
        "CLalpha",
        "CLalphadot",
        "CLde",
        "Cm0",
        "Cmalpha",
        "Cmalphadot",
        "Cmq",
        "Cmde",
    ];

    /// `α̇` at `(x, u, p)` (the implicit lift equation solved).
    pub fn alpha_dot(&self, x: &SVector<T, 5>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> T {
        let (v, alpha, q, theta) = (x[0], x[1], x[2], x[3]);
        let qbar_s = T::lit(0.5) * self.rho_kgpm3 * v * v * self.wing_area_m2;
        let chat = self.chord_m / (T::lit(2.0) * v);
        let mv = self.mass_kg * v;
        let l0 = qbar_s * (p[0] + p[1] * alpha + p[3] * u[0]);
        let g = T::lit(G_MPS2);
        let (sa, _) = alpha.sin_cos_fast();
        let (_, cg) = (theta - alpha).sin_cos_fast();
        let rhs = q - (l0 + self.thrust_n * sa - self.mass_kg * g * cg) / mv;
        rhs / (T::one() + qbar_s * p[2] * chat / mv)
    }
}

impl<T: Real> Model<T, 5, 1, 5, 9> for Longitudinal<T> {
    fn f(&self, x: &SVector<T, 5>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> SVector<T, 5> {
        let (v, alpha, q, theta) = (x[0], x[1], x[2], x[3]);
        let qbar_s = T::lit(0.5) * self.rho_kgpm3 * v * v * self.wing_area_m2;
        let chat = self.chord_m / (T::lit(2.0) * v);
        let ad = self.alpha_dot(x, u, p);
        let cd = self.cd0 + self.cd_alpha * alpha;
        let cm = p[4] + p[5] * alpha + p[6] * ad * chat + p[7] * q * chat + p[8] * u[0];
        let g = T::lit(G_MPS2);
        let (_, ca) = alpha.sin_cos_fast();
        let (sg, _) = (theta - alpha).sin_cos_fast();
        SVector::<T, 5>::new(
            (self.thrust_n * ca - qbar_s * cd) / self.mass_kg - g * sg,
            ad,
            qbar_s * self.chord_m * cm / self.iy_kgm2,
            q,
            v * sg,
        )
    }

    fn h(&self, x: &SVector<T, 5>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SVector<T, 5> {
        *x
    }

    fn dh_dx(&self, _x: &SVector<T, 5>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SMatrix<T, 5, 5> {
        SMatrix::<T, 5, 5>::identity()
    }

    fn dh_dp(&self, _x: &SVector<T, 5>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SMatrix<T, 5, 9> {
        SMatrix::<T, 5, 9>::zeros()
    }
}

impl<T: Real> Longitudinal<T> {
    /// Specific force along body z (what a z accelerometer at the CG reads), m/s²:
    /// `−(L cos α + D sin α)/m` with `L` including the `α̇` term (thrust is along body x).
    pub fn specific_force_z(&self, x: &SVector<T, 5>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> T {
        let (v, alpha) = (x[0], x[1]);
        let qbar_s = T::lit(0.5) * self.rho_kgpm3 * v * v * self.wing_area_m2;
        let chat = self.chord_m / (T::lit(2.0) * v);
        let ad = self.alpha_dot(x, u, p);
        let cl = p[0] + p[1] * alpha + p[2] * ad * chat + p[3] * u[0];
        let cd = self.cd0 + self.cd_alpha * alpha;
        let (sa, ca) = alpha.sin_cos_fast();
        -(qbar_s * (cl * ca + cd * sa)) / self.mass_kg
    }
}

/// [`Longitudinal`] with the turbulence as states shaped exactly like the Dryden filters of
/// MIL-F-8785C that the Table 1 simulator uses: `x = [V, α, q, θ, h, u_g, w₁, w₂]`, with
/// `u̇_g = −τ_u u_g + ω_u` (first order, `τ_u = V₀/L_u`) and the second-order vertical channel
/// `ẇ₁ = w₂`, `ẇ₂ = −τ_w² w₁ − 2τ_w w₂ + ω_w`, `w_g = τ_w^{3/2}(w₁ + √3 w₂/τ_w)` (`τ_w = V₀/L_w`;
/// the Dryden transfer function `σ_w √(L_w/(πV₀))·(1 + √3 L_w s/V₀)/(1 + L_w s/V₀)²` in
/// controllable form, scaled so that a unit-intensity `ω_w` gives `σ_w = 1`). The process noise of
/// the filter is then `Q = diag(…, 2σ_u²τ_u, 0, σ_w²)` on the gust states. The aerodynamics see the
/// air-relative `V_a = V − u_g`, `α_a = α + w_g/V`. Outputs: the five flight states
/// (`Model<T, 8, 1, 5, 9>`) or those and the body-z specific force of
/// [`Longitudinal::specific_force_z`] (`Model<T, 8, 1, 6, 9>`). Jacobians by central differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalDryden<T> {
    /// The aircraft.
    pub base: Longitudinal<T>,
    /// `τ_u = V₀/L_u`, 1/s.
    pub tau_u_per_s: T,
    /// `τ_w = V₀/L_w`, 1/s.
    pub tau_w_per_s: T,
}

impl<T: Real> LongitudinalDryden<T> {
    /// The vertical gust `w_g` of the state, m/s.
    pub fn gust_w_mps(&self, x: &SVector<T, 8>) -> T {
        let tau = self.tau_w_per_s;
        tau * tau.root() * (x[6] + T::lit(3.0).root() * x[7] / tau)
    }

    /// The air-relative flight state `[V − u_g, α + w_g/V, q, θ, h]`.
    fn air_relative(&self, x: &SVector<T, 8>) -> SVector<T, 5> {
        SVector::<T, 5>::new(x[0] - x[5], x[1] + self.gust_w_mps(x) / x[0], x[2], x[3], x[4])
    }

    fn dynamics(&self, x: &SVector<T, 8>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> SVector<T, 8> {
        let d = self.base.f(&self.air_relative(x), u, p);
        let (sg, _) = (x[3] - x[1]).sin_cos_fast();
        let (tu, tw) = (self.tau_u_per_s, self.tau_w_per_s);
        SVector::<T, 8>::from_column_slice(&[
            d[0],
            d[1],
            d[2],
            x[2],
            x[0] * sg,
            -tu * x[5],
            x[7],
            -tw * tw * x[6] - T::lit(2.0) * tw * x[7],
        ])
    }
}

impl<T: Real> Model<T, 8, 1, 5, 9> for LongitudinalDryden<T> {
    fn f(&self, x: &SVector<T, 8>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> SVector<T, 8> {
        self.dynamics(x, u, p)
    }

    fn h(&self, x: &SVector<T, 8>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SVector<T, 5> {
        SVector::<T, 5>::new(x[0], x[1], x[2], x[3], x[4])
    }

    fn dh_dx(&self, _x: &SVector<T, 8>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SMatrix<T, 5, 8> {
        SMatrix::<T, 5, 8>::identity()
    }

    fn dh_dp(&self, _x: &SVector<T, 8>, _u: &SVector<T, 1>, _p: &SVector<T, 9>) -> SMatrix<T, 5, 9> {
        SMatrix::<T, 5, 9>::zeros()
    }
}

impl<T: Real> Model<T, 8, 1, 6, 9> for LongitudinalDryden<T> {
    fn f(&self, x: &SVector<T, 8>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> SVector<T, 8> {
        self.dynamics(x, u, p)
    }

    fn h(&self, x: &SVector<T, 8>, u: &SVector<T, 1>, p: &SVector<T, 9>) -> SVector<T, 6> {
        let az = self.base.specific_force_z(&self.air_relative(x), u, p);
        SVector::<T, 6>::new(x[0], x[1], x[2], x[3], x[4], az)
    }
}
