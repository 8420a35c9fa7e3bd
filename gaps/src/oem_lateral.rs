//! The lateral axis of the low-rate path: `C_Y`, `C_l`, `C_n` fitted and their candidate causes
//! tested by output error below [`crate::io::quality::MIN_RATE_HZ`], with the estimation, σ,
//! held-out test, naming rule and homogeneity test of [`super::oem`].
//!
//! ## The model (a partial output error; reading chosen)
//! The lateral states `x = [β, p, r]` are simulated; the airspeed, `q̄`, α, `q`, the attitude,
//! the surfaces, the thrust and the measured aerodynamic force along x and z are the measured
//! (corrected) signals of the [`Table`], between samples on the paths of `intersample.rs` — the mirror of the
//! longitudinal path, which simulates `[α, q]` and takes the lateral channels as measured. With
//! `u = V cos α cos β`, `v = V sin β`, `w = V sin α cos β` and the rigid-body kinematics of the
//! compatibility check (Stevens & Lewis, *Aircraft Control and Simulation*, 2003, eq. 2.4-3 for
//! `β̇`):
//!
//! * `β̇ = [−F_x cos α sin β + F_y cos β − F_z sin α sin β]/(mV) + p sin α − r cos α
//!   + (g/V)[cos β cos θ sin φ + sin β (cos α sin θ − sin α cos θ cos φ)]`, with
//!   `F = F_A + F_T` (body), `F_A,x`, `F_A,z` the accelerometers' aerodynamic part and
//!   `F_A,y = q̄S C_Y` from the model;
//! * `J ω̇ = q̄S(b C_l, ·, b C_n) + r_P × F_A + M_T − ω × Jω` in its roll and yaw rows, solved with
//!   the `[[I_x, −I_xz], [−I_xz, I_z]]` block of `J` (the products `I_xy`, `I_yz` of a symmetric
//!   aircraft are zero; they are dropped, so `q̇` does not enter);
//! * outputs `y = [β, p, r, F_A,y/m]` against the measured β, `p`, `r` and the lateral
//!   accelerometer's aerodynamic part.
//!
//! The coefficients are the gap analysis's terms ([`Term::eval`]) on the snapshot with the
//! simulated β, `p b/(2V)`, `r b/(2V)` and the model's `β̇ b/(2V)` written into it; `β̇` in `C_Y`
//! is not tested (it makes the β equation implicit).
//!
//! ## β as an output (errors in variables)
//! The terms are evaluated on the *simulated* β, so the measured β — a vane, or an estimate from
//! the inertial velocity and a wind model — enters only as an output and as each manoeuvre's
//! initial state. Its error, the lag of an estimator included, is then measurement error of an
//! output, which the output error treats as noise (a lag colours the residuals: the block
//! sandwich's σ accounts for it), not an error in a regressor that would bias the estimates as in
//! the equation error. No vane errors (scale, bias, position) are estimated in this path; the
//! compatibility check's corrections are applied before it.

use super::model::{Signal, Term, TermRefs};
use super::oem::{Dynamics, Inputs, Measured, ParamJacobian, Point, Setup, Spec, NY};
use super::signal::sin_cos;
use super::simulate::inertia;
use nalgebra::{DMatrix, DVector, Matrix2, Vector2, Vector3};

const G_MPS2: f64 = 9.806_65;

/// The lateral plant.
pub(super) struct Lateral<'a> {
    m: Measured<'a>,
    /// The inverse of the roll–yaw block of `J`.
    j_xz_inv: Matrix2<f64>,
    alpha_m: &'a [f64],
    beta_m: &'a [f64],
}

fn dot(terms: &[(usize, Term)], th: &[f64], s: &super::model::Snapshot, refs: &TermRefs) -> Option<f64> {
    terms.iter().map(|(j, t)| t.eval(s, refs).map(|v| v * th[*j])).sum()
}

impl Dynamics for Lateral<'_> {
    type State = [f64; 3];
    const COVERED: [usize; 3] = [2, 3, 5];
    const OUTPUTS: [&'static str; NY] = ["β", "p", "r", "F_A,y/m"];
    const UNITS: [&'static str; NY] = ["rad", "rad/s", "rad/s", "m/s²"];
    const STATES: &'static str = "β, p, r";
    const RESTART_S: Option<f64> = Some(super::compat::SEGMENT_S);
    /// The roll subsidence of a small UAV is fast (`L_p = q̄Sb² C_lp/(2V I_x)`: about −37 /s for
    /// the skywalker at 15 m/s): RK4 on a 10 Hz grid (`|λ|h` ≈ 3.7, beyond RK4's stability
    /// limit of 2.8) would be unstable; 25 ms keeps `|λ|h` below 1 (RK4's error there about 2 %).
    const MAX_STEP_S: f64 = 0.025;
    const READING: &'static str = "β, p and r simulated from the measured state at each manoeuvre's start and every 5 s within it (RK4 sub-steps of 25 ms), V, α, q, attitude, surfaces, thrust and the x and z aerodynamic force as measured; β enters as an output only (its error, an estimator's lag included, is output noise)";

    /// `C_Y` → `F_A,y/m`, `C_l` → `p`, `C_n` → `r`.
    fn primary_output(coef: usize) -> usize {
        match coef {
            2 => 3,
            3 => 1,
            _ => 2,
        }
    }

    fn untestable(coef: usize, t: Term) -> Option<&'static str> {
        (coef == 2 && t == Term::BetaDot)
            .then_some("not tested by output error: β̇ in C_Y makes the β equation implicit")
    }

    fn x0(&self, k: usize) -> [f64; 3] {
        [self.beta_m[k], self.m.y_m[k][1], self.m.y_m[k][2]]
    }

    fn plausible(&self, x: &[f64; 3]) -> bool {
        x.iter().all(|v| v.is_finite()) && x[0].abs() < 1.0 && x[1].abs() < 20.0 && x[2].abs() < 20.0
    }

    fn measured(&self) -> &Measured<'_> {
        &self.m
    }

    fn eval(
        &self,
        spec: &Spec,
        x: [f64; 3],
        k: usize,
        fr: f64,
        th: &[f64],
        jac: bool,
    ) -> Option<(Point<[f64; 3]>, Option<ParamJacobian>)> {
        let (ac, refs) = (self.m.ac, self.m.refs);
        let (area, span, mass) = (ac.wing_area_m2, ac.span_m, ac.mass_kg);
        let (mut s, v, qbar) = self.m.at(k, fr);
        let [beta, p, r] = x;
        let bn = span / (2.0 * v);
        s[Signal::Beta.index()] = beta;
        s[Signal::PN.index()] = p * bn;
        s[Signal::RN.index()] = r * bn;
        let (ty, tl, tn) = (spec.of(2), spec.of(3), spec.of(5));
        let cy = dot(ty, th, &s, refs)?;
        let al = self.m.signal(Signal::Alpha, self.alpha_m, k, fr);
        let q = self.m.rate(1, k, fr);
        let (sf, cf) = sin_cos(self.m.attitude(0, k, fr));
        let (st, ct) = sin_cos(self.m.attitude(1, k, fr));
        let (sa, ca) = sin_cos(al);
        let (sb, cb) = sin_cos(beta);
        let ft = self.m.thrust_force(k, fr);
        let fa = self.m.aero_force(k, fr);
        let (fx, fz) = (fa.x + ft.x, fa.z + ft.z);
        let k_y = qbar * area * cb / (mass * v);
        let b0 = (-fx * ca * sb - fz * sa * sb + ft.y * cb) / (mass * v) + p * sa - r * ca
            + G_MPS2 / v * (cb * ct * sf + sb * (ca * st - sa * ct * cf));
        let beta_dot = b0 + k_y * cy;
        s[Signal::BetaDotN.index()] = beta_dot * bn;
        let cl = dot(tl, th, &s, refs)?;
        let cn = dot(tn, th, &s, refs)?;
        let om = Vector3::new(p, q, r);
        let rest = ac.moment_reference_m.cross(&fa) + self.m.thrust_moment(k, fr) - om.cross(&(self.m.j * om));
        let k_b = qbar * area * span;
        let wdot = self.j_xz_inv * Vector2::new(k_b * cl + rest.x, k_b * cn + rest.z);
        let k_f = qbar * area / mass;
        let pt = Point {
            xdot: [beta_dot, wdot.x, wdot.y],
            y: [beta, p, r, k_f * cy],
            coefs: [cy, cl, cn],
        };
        if !jac {
            return Some((pt, None));
        }
        let np = spec.np();
        let mut val = DVector::<f64>::zeros(np);
        for (j, (_, t)) in spec.terms().iter().enumerate() {
            val[j] = t.eval(&s, refs)?;
        }
        // C_l and C_n may depend on β̇ (through C_Y): their partial derivatives by central
        // differences of the snapshot's entry.
        let bd_n = beta_dot * bn;
        let partial = |terms: &[(usize, Term)]| -> Option<f64> {
            let h = 1e-6 * bd_n.abs().max(1.0);
            let mut sp = s;
            sp[Signal::BetaDotN.index()] = bd_n + h;
            let up = dot(terms, th, &sp, refs)?;
            sp[Signal::BetaDotN.index()] = bd_n - h;
            let dn = dot(terms, th, &sp, refs)?;
            Some((up - dn) / (2.0 * h))
        };
        let (dcl_dbd, dcn_dbd) = (partial(tl)?, partial(tn)?);
        let mask =
            |coef: usize| DVector::<f64>::from_fn(np, |j, _| if spec.terms()[j].0 == coef { val[j] } else { 0.0 });
        let dcy = mask(2);
        let dbd = &dcy * k_y;
        let dcl = mask(3) + &dbd * (dcl_dbd * bn);
        let dcn = mask(5) + &dbd * (dcn_dbd * bn);
        let ji = &self.j_xz_inv;
        let mut g = DMatrix::<f64>::zeros(3, np);
        g.set_row(0, &dbd.transpose());
        g.set_row(1, &((&dcl * ji[(0, 0)] + &dcn * ji[(0, 1)]) * k_b).transpose());
        g.set_row(2, &((&dcl * ji[(1, 0)] + &dcn * ji[(1, 1)]) * k_b).transpose());
        let mut d = DMatrix::<f64>::zeros(NY, np);
        d.set_row(3, &(&dcy * k_f).transpose());
        Some((pt, Some((g, d))))
    }
}

/// The lateral plant of `inp` with its manoeuvres and folds; `Err` says why the path cannot run
/// on these data.
pub(super) fn setup<'a>(inp: &Inputs<'a>) -> Result<Setup<Lateral<'a>>, String> {
    let table = inp.table;
    let kin = table.kinematics.as_ref().ok_or("no coefficient could be synthesised")?;
    let sig = |s: Signal| table.signals.get(&s).map(Vec::as_slice);
    let (Some(alpha_m), Some(beta_m), Some(v_m)) = (sig(Signal::Alpha), sig(Signal::Beta), sig(Signal::Airspeed))
    else {
        return Err("no α, β or airspeed (β is an output of the lateral model)".into());
    };
    if [2, 3, 5].iter().any(|&c| table.z[c].is_none()) || sig(Signal::PN).is_none() || sig(Signal::RN).is_none() {
        return Err("C_Y, C_l and C_n need β, the airspeed, the three rates and the y accelerometer".into());
    }
    if !kin.attitude_measured {
        return Err("no attitude for the gravity term of β̇".into());
    }
    let j = inertia(inp.aircraft);
    let j_xz = Matrix2::new(j[(0, 0)], j[(0, 2)], j[(2, 0)], j[(2, 2)]);
    let j_xz_inv = match j_xz.try_inverse() {
        Some(m) if j[(0, 0)] > 0.0 && j[(2, 2)] > 0.0 => m,
        _ => return Err("no roll and yaw inertia Ix, Iz in the aircraft file".into()),
    };
    if inp.aircraft.span_m <= 0.0 {
        return Err("no span in the aircraft file".into());
    }
    let mass = inp.aircraft.mass_kg;
    let y_m: Vec<[f64; NY]> = (0..table.t_s.len())
        .map(|k| {
            [
                beta_m[k],
                kin.rates_rad_s[0][k],
                kin.rates_rad_s[2][k],
                kin.aero_force_n[k].y / mass,
            ]
        })
        .collect();
    Ok(Setup::new(
        Lateral {
            m: Measured::new(table, kin, (inp.aircraft, inp.refs, j), v_m, y_m, inp.pieces),
            j_xz_inv,
            alpha_m,
            beta_m,
        },
        inp,
    ))
}

#[cfg(test)]
mod tests {
    use super::super::oem::tests::{assert_sensitivities, Fixture};
    use super::*;
    use nalgebra::DMatrix;

    /// The output sensitivities of the lateral simulation (the chains through `β̇` in `C_l`,
    /// `C_n`, the RK4 sub-steps and the restarts) equal central differences of the simulated
    /// outputs, without and with a state filter in the loop; the tolerance is the longitudinal
    /// test's (`oem.rs`), for the same reasons.
    #[test]
    fn the_lateral_sensitivities_match_differences_of_the_simulation() {
        let fx = Fixture::new();
        let inp = fx.inputs();
        use Term::*;
        // The simulator's airframe (`SimAirframe::skywalker_2013_mod`), with small β̇ and α·β
        // terms (least squares on the synthesised lateral coefficients at 10 Hz can start with
        // an unstable roll mode).
        let lat_at = [
            (2, One, 0.0),
            (2, Beta, -0.98),
            (2, Rudder, -0.2),
            (3, One, 0.0),
            (3, Beta, -0.12),
            (3, P, -1.0),
            (3, R, 0.14),
            (3, Aileron, 0.25),
            (3, Rudder, -0.037),
            (3, BetaDot, 0.05),
            (5, One, 0.0),
            (5, Beta, 0.25),
            (5, P, 0.022),
            (5, R, -1.0),
            (5, Rudder, 0.1),
            (5, BetaDot, -0.05),
            (5, AlphaBeta, 0.5),
        ];
        let lat: Vec<(usize, Term)> = lat_at.iter().map(|(c, t, _)| (*c, *t)).collect();
        let th: Vec<f64> = lat_at.iter().map(|x| x.2).collect();
        let st = setup(&inp).expect("the lateral path runs on this flight");
        let spec = Spec::new([2, 3, 5], lat);
        assert_sensitivities(&st.plant, &spec, &th, &st.pieces, None, 1e-5);
        let mut gain = DMatrix::<f64>::zeros(3, NY);
        for i in 0..3 {
            gain[(i, i)] = 0.3;
        }
        assert_sensitivities(&st.plant, &spec, &th, &st.pieces, Some(&gain), 1e-5);
    }
}
