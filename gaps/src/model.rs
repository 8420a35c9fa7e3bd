//! Coefficient synthesis from a [`MeasuredFlight`] (seed 000 eq. 1–2) and the model terms: the
//! regressors of eq. 3 and the library of candidate causes.
//!
//! ## Synthesis (the same equations as [`aerosid_core::aero::synthesise`], on named channels)
//! * Sensor errors found by the compatibility check are removed first (bias, scale, delay), the
//!   air data are moved to the CG exactly (`v_cg = V(cos α cos β, sin β, sin α cos β) − ω × r`
//!   at each sensor's position, α, β, V recomputed; to first order Klein & Morelli eq.
//!   10.12–10.13, `α = α_v − (p y_v − q x_v)/V`) and the accelerometer to the CG
//!   (`a_cg = a − ω̇ × r − ω × (ω × r)`); moments are taken about the moment reference point.
//! * Angular accelerations: a measured `ṗ, q̇, ṙ` channel when present, otherwise the 5-point
//!   central difference of the gyro. Then every channel is smoothed with the same Savitzky–Golay
//!   filter ([`super::signal`]).
//! * `q̄ = ½ρV²` (a `DynamicPressure` channel if measured; `ρ` from `AirDensity`, else from the
//!   ISA at `Altitude`, else sea level — reported as a note).
//! * Thrust: [`ThrustSource::Measured`] along its line at its point, [`ThrustSource::Propeller`]
//!   from `PropSpeed` by the core's propeller model (torque sign −1, the core's default),
//!   [`ThrustSource::Unknown`] zero (thrust then belongs to `C_D`).
//! * `F_A = m a_cg − F_T`; stability axes: `C_D = −(F_x cos α + F_z sin α)/(q̄S)`,
//!   `C_L = (F_x sin α − F_z cos α)/(q̄S)`, `C_Y = F_y/(q̄S)`;
//!   `M_A = J ω̇ + ω × Jω − M_T`, `C_l = M_x/(q̄Sb)`, `C_m = M_y/(q̄Sc̄)`, `C_n = M_z/(q̄Sb)`.
//!
//! A coefficient is synthesised only when its channels are present: `C_L`, `C_D` need `a_x`, `a_z`,
//! `V`, `α`; `C_m` needs `q`, `V`; `C_Y` needs `a_y`; `C_l`, `C_n` need `p`, `r` (plus `q`).

use super::signal::{derivative, sg_smooth, shift, sin_cos};
use crate::io::measured::{MeasuredFlight, Origin, Quantity, ThrustSource};
use crate::sim::atmosphere::isa_density;
use aerosid_core::aero::synthesis::{propeller_output, propulsion_force_moment};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// The six coefficients, in the order of `aerosid_core::aero::model::idx`.
pub const COEFFICIENTS: [&str; 6] = ["C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"];

/// A baseline from a specification `COEF=term,term;COEF=…` (coefficients as in
/// [`COEFFICIENTS`] or without the underscore, terms as [`Term::parse`] reads them); coefficients
/// not named keep eq. 3. E.g. the HFB-320 book model: `CL=1,alpha,dV;CD=1,alpha,dV;Cm=1,alpha,dV,q,de`.
pub fn parse_baseline(spec: &str) -> Result<[Vec<Term>; 6], String> {
    let mut out: [Vec<Term>; 6] = core::array::from_fn(Term::eq3);
    for part in spec.split(';').map(str::trim).filter(|p| !p.is_empty()) {
        let (coef, terms) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}`: expected COEF=term,term"))?;
        let coef = coef.trim();
        let i = COEFFICIENTS
            .iter()
            .position(|c| *c == coef || c.replace('_', "") == coef)
            .ok_or_else(|| format!("`{coef}`: unknown coefficient (one of {})", COEFFICIENTS.join(", ")))?;
        let mut v = Vec::new();
        for t in terms.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            let term = Term::parse(t).ok_or_else(|| {
                let names: Vec<&str> = Term::ALL.iter().map(|t| t.ascii()).collect();
                format!("`{t}`: unknown term (one of {})", names.join(", "))
            })?;
            if !v.contains(&term) {
                v.push(term);
            }
        }
        if v.is_empty() {
            return Err(format!("`{coef}`: no terms"));
        }
        out[i] = v;
    }
    Ok(out)
}

/// Whether coefficient `i` is longitudinal (`C_L`, `C_D`, `C_m`).
pub fn is_longitudinal(i: usize) -> bool {
    matches!(i, 0 | 1 | 4)
}

/// A synthesised signal of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Signal {
    /// α at the CG, rad.
    Alpha,
    /// β at the CG, rad.
    Beta,
    /// `p b/(2V)`.
    PN,
    /// `q c̄/(2V)`.
    QN,
    /// `r b/(2V)`.
    RN,
    /// δe, rad.
    Elevator,
    /// δa, rad.
    Aileron,
    /// δr, rad.
    Rudder,
    /// V, m/s.
    Airspeed,
    /// Mach number.
    Mach,
    /// Thrust coefficient `T/(q̄S)`.
    ThrustCoeff,
    /// `α̇ c̄/(2V)`.
    AlphaDotN,
    /// `β̇ b/(2V)`.
    BetaDotN,
    /// δė, rad/s (the column of a time delay of the elevator: `δe(t−τ) ≈ δe − τ δė`).
    ElevatorRate,
    /// δȧ, rad/s.
    AileronRate,
    /// δṙ, rad/s.
    RudderRate,
    /// The measured lift coefficient (a regressor of `C_D`: the drag polar's `C_L²`).
    LiftCoeff,
}

impl Signal {
    /// Every signal.
    pub const ALL: [Signal; 17] = [
        Signal::Alpha,
        Signal::Beta,
        Signal::PN,
        Signal::QN,
        Signal::RN,
        Signal::Elevator,
        Signal::Aileron,
        Signal::Rudder,
        Signal::Airspeed,
        Signal::Mach,
        Signal::ThrustCoeff,
        Signal::AlphaDotN,
        Signal::BetaDotN,
        Signal::ElevatorRate,
        Signal::AileronRate,
        Signal::RudderRate,
        Signal::LiftCoeff,
    ];

    /// Position in [`Signal::ALL`].
    pub fn index(self) -> usize {
        Signal::ALL.iter().position(|s| *s == self).unwrap_or(0)
    }
}

/// The value of every signal at one instant (NaN: not available), indexed by [`Signal::index`].
pub type Snapshot = [f64; Signal::ALL.len()];

impl Table {
    /// The signals at sample `k` plus `frac` of a step (linear interpolation; NaN where absent).
    pub fn snapshot(&self, k: usize, frac: f64) -> Snapshot {
        let mut out = [f64::NAN; Signal::ALL.len()];
        for (sig, v) in &self.signals {
            let a = v[k];
            out[sig.index()] = if frac == 0.0 || k + 1 >= v.len() {
                a
            } else {
                a + frac * (v[k + 1] - a)
            };
        }
        out
    }
}

/// Coefficients and signals of a flight, per sample, after correction and smoothing.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// The synthesised coefficients (`None`: channels missing).
    pub z: [Option<Vec<f64>>; 6],
    /// The regressor signals available.
    pub signals: BTreeMap<Signal, Vec<f64>>,
    /// Notes (assumptions taken for missing channels).
    pub notes: Vec<String>,
    /// The quantities eq. 1–2 used besides the coefficients (for the simulation of
    /// [`super::simulate`]); `None` when no coefficient could be synthesised.
    pub kinematics: Option<Kinematics>,
    /// Library terms not offered to a coefficient (index into [`COEFFICIENTS`]) on this flight,
    /// with the reason ([`barred_terms`]).
    pub barred: Vec<(usize, Term, String)>,
}

/// The smoothed, corrected quantities the synthesis used, per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Kinematics {
    /// Body rates `p, q, r`, rad/s (zero where not measured).
    pub rates_rad_s: [Vec<f64>; 3],
    /// Roll and pitch attitude, rad (zero where not measured).
    pub attitude_rad: [Vec<f64>; 2],
    /// Dynamic pressure, Pa.
    pub qbar_pa: Vec<f64>,
    /// Air density `2q̄/V²`, kg/m³.
    pub density_kgpm3: Vec<f64>,
    /// Thrust force (body), N.
    pub thrust_force_n: Vec<Vector3<f64>>,
    /// Thrust moment about the CG (body), N·m.
    pub thrust_moment_nm: Vec<Vector3<f64>>,
    /// Aerodynamic force `m a_cg − F_T` (body), N (zero in an axis without an accelerometer).
    pub aero_force_n: Vec<Vector3<f64>>,
    /// Whether the roll and pitch attitude were measured.
    pub attitude_measured: bool,
}

/// Corrections from the compatibility check.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Corrections {
    /// Additive bias per channel.
    pub bias: BTreeMap<Quantity, f64>,
    /// Scale factor error per channel.
    pub scale: BTreeMap<Quantity, f64>,
    /// Delay per channel, s.
    pub delay_s: BTreeMap<Quantity, f64>,
    /// Extra vane x positions, m (`Alpha`, `Beta`).
    pub vane_dx_m: BTreeMap<Quantity, f64>,
}

/// Builds the table: corrections, CG transfer, derivatives, smoothing (half-width `sg_half`),
/// synthesis.
#[allow(non_snake_case)]
///
/// `air_data`: reconstructed `Airspeed`, `Alpha`, `Beta` at the CG from the compatibility check;
/// when given they replace the (corrected) air-data channels. Why: the airspeed sensor's noise
/// enters both `q̄` (so every coefficient) and any speed regressor, an errors-in-variables
/// correlation that least squares turns into a spurious speed dependence; the reconstructed states
/// carry only the integrated inertial noise.
///
/// A pooled flight ([`MeasuredFlight::pieces`]) is synthesised piece by piece — no smoothing,
/// derivative or CG transfer across a join — and the tables laid end to end.
pub fn synthesise(
    flight: &MeasuredFlight,
    h_s: f64,
    corr: &Corrections,
    sg_half: usize,
    air_data: Option<&BTreeMap<Quantity, Vec<f64>>>,
) -> Table {
    if flight.log.pieces.len() <= 1 {
        return synthesise_piece(flight, h_s, corr, sg_half, air_data);
    }
    let tables: Vec<Table> = flight
        .log
        .pieces
        .iter()
        .map(|p| {
            let air: Option<BTreeMap<Quantity, Vec<f64>>> =
                air_data.map(|a| a.iter().map(|(q, v)| (*q, v[p.start..p.end].to_vec())).collect());
            synthesise_piece(&flight.piece(p), h_s, corr, sg_half, air.as_ref())
        })
        .collect();
    Table::concat(tables)
}

impl Table {
    /// A table of no coefficient and no signal at times `t_s`, with `notes` saying why.
    fn empty(t_s: Vec<f64>, notes: Vec<String>) -> Table {
        Table {
            t_s,
            z: Default::default(),
            signals: BTreeMap::new(),
            notes,
            kinematics: None,
            barred: Vec::new(),
        }
    }

    /// Tables of consecutive pieces end to end: a coefficient or signal is kept when every piece
    /// has it (the pieces log the same channels, so they all do); the notes of every piece, once.
    fn concat(tables: Vec<Table>) -> Table {
        let mut it = tables.into_iter();
        let Some(mut out) = it.next() else {
            return Table::empty(Vec::new(), Vec::new());
        };
        for t in it {
            for b in t.barred {
                if !out.barred.contains(&b) {
                    out.barred.push(b);
                }
            }
            out.t_s.extend(t.t_s);
            for (o, z) in out.z.iter_mut().zip(t.z) {
                match (o.as_mut(), z) {
                    (Some(o), Some(z)) => o.extend(z),
                    _ => *o = None,
                }
            }
            let mut signals = t.signals;
            out.signals.retain(|s, v| match signals.remove(s) {
                Some(x) => {
                    v.extend(x);
                    true
                }
                None => false,
            });
            for n in t.notes {
                if !out.notes.contains(&n) {
                    out.notes.push(n);
                }
            }
            out.kinematics = match (out.kinematics.take(), t.kinematics) {
                (Some(mut a), Some(b)) => {
                    for (x, y) in a.rates_rad_s.iter_mut().zip(b.rates_rad_s) {
                        x.extend(y);
                    }
                    for (x, y) in a.attitude_rad.iter_mut().zip(b.attitude_rad) {
                        x.extend(y);
                    }
                    a.qbar_pa.extend(b.qbar_pa);
                    a.density_kgpm3.extend(b.density_kgpm3);
                    a.thrust_force_n.extend(b.thrust_force_n);
                    a.thrust_moment_nm.extend(b.thrust_moment_nm);
                    a.aero_force_n.extend(b.aero_force_n);
                    a.attitude_measured &= b.attitude_measured;
                    Some(a)
                }
                _ => None,
            };
        }
        out
    }
}

/// The coefficients and signals of one piece of a flight: the channels corrected
/// ([`Corrected`]), the body rates and air data at the CG smoothed, the dynamic pressure, thrust
/// and accelerations at the CG, then the force and moment coefficients and the regressors'
/// signals.
fn synthesise_piece(
    flight: &MeasuredFlight,
    h_s: f64,
    corr: &Corrections,
    sg_half: usize,
    air_data: Option<&BTreeMap<Quantity, Vec<f64>>>,
) -> Table {
    let mut notes = Vec::new();
    let raw = Corrected {
        flight,
        h_s,
        corr,
        air_data,
    };
    let rates = body_rates(&raw, sg_half);
    let air = air_data_at_cg(&raw, &rates.raw, sg_half);
    let controls = controls_of(&raw, sg_half);
    let qbar = dynamic_pressure(flight, &air.v, sg_half, &mut notes);
    let (Some(v), Some(qbar)) = (air.v.clone(), qbar) else {
        notes.push("no airspeed or dynamic pressure: no coefficient can be synthesised".into());
        return Table::empty(flight.t_s.clone(), notes);
    };
    let flow = flow_of(flight, &v, &qbar, &air);
    let thrust = thrust_of(&raw, sg_half, &flow, &mut notes);
    let cg = CgAccel {
        ra: flight.aircraft.accel_position_m,
        accels: controls.accels,
        w: rates.smooth.each_ref().map(|x| or_zeros(x, flight.len())),
        wd: rates.accel.each_ref().map(|x| or_zeros(x, flight.len())),
    };
    let mut z = force_coefficients(flight, &cg, &thrust, air.alpha.is_some(), &flow);
    moment_coefficients(flight, &cg, &thrust, &flow, &rates, &mut z, &mut notes);
    let parts = SignalParts {
        air,
        rates: rates.smooth,
        surfaces: controls.surfaces,
        surface_rates: controls.surface_rates,
    };
    let mut signals = signals_of(flight, sg_half, parts, &z, &cg, &thrust, &flow);
    signals.insert(Signal::Airspeed, v);
    let barred = barred_terms(flight);
    notes.extend(
        barred
            .iter()
            .filter(|(i, ..)| z[*i].is_some())
            .map(|(.., why)| why.clone()),
    );
    Table {
        t_s: flight.t_s.clone(),
        z,
        signals,
        notes,
        barred,
        kinematics: Some(kinematics_of(flight, sg_half, qbar, cg, thrust, flow)),
    }
}

/// `x`, or `n` zeros when absent.
fn or_zeros(x: &Option<Vec<f64>>, n: usize) -> Vec<f64> {
    x.clone().unwrap_or_else(|| vec![0.0; n])
}

/// The surfaces and accelerometers, corrected and smoothed, and the surfaces' rates.
struct Controls {
    /// Elevator, aileron, rudder.
    surfaces: [Option<Vec<f64>>; 3],
    /// Their rates: differentiated before smoothing, as α̇ (the signal module's doc says why).
    surface_rates: [Option<Vec<f64>>; 3],
    /// Specific force at the accelerometer, x, y, z.
    accels: [Option<Vec<f64>>; 3],
}

fn controls_of(raw: &Corrected, sg_half: usize) -> Controls {
    use Quantity::*;
    let sm = |x: Option<Vec<f64>>| x.map(|v| sg_smooth(&v, sg_half));
    let rate = |q: Quantity| raw.get(q).map(|x| sg_smooth(&derivative(&x, raw.h_s), sg_half));
    Controls {
        surfaces: [sm(raw.get(Elevator)), sm(raw.get(Aileron)), sm(raw.get(Rudder))],
        surface_rates: [rate(Elevator), rate(Aileron), rate(Rudder)],
        accels: [sm(raw.get(AccelX)), sm(raw.get(AccelY)), sm(raw.get(AccelZ))],
    }
}

/// The flow of airspeed `v` and dynamic pressure `qbar`, with the flow angles at the CG.
fn flow_of(flight: &MeasuredFlight, v: &[f64], qbar: &[f64], air: &AirAtCg) -> Flow {
    let n = flight.len();
    let vv: Vec<f64> = v.iter().map(|x| x.max(1.0)).collect();
    Flow {
        rho_v: (0..n).map(|i| 2.0 * qbar[i] / (vv[i] * vv[i])).collect(),
        qs: qbar.iter().map(|q| q * flight.aircraft.wing_area_m2).collect(),
        vv,
        al: or_zeros(&air.alpha, n),
        be: or_zeros(&air.beta, n),
    }
}

/// The quantities eq. 1–2 used besides the coefficients, for the held-out simulation.
fn kinematics_of(
    flight: &MeasuredFlight,
    sg_half: usize,
    qbar: Vec<f64>,
    cg: CgAccel,
    thrust: ThrustForces,
    flow: Flow,
) -> Kinematics {
    use Quantity::*;
    let n = flight.len();
    let att = |q: Quantity| or_zeros(&flight.get(q).map(|x| sg_smooth(x, sg_half)), n);
    Kinematics {
        // The aerodynamic force first: it reads the rates and the thrust moved below.
        aero_force_n: (0..n)
            .map(|i| cg.aero_force(i, flight.aircraft.mass_kg, &thrust.f_t[i]))
            .collect(),
        attitude_rad: [att(Roll), att(Pitch)],
        rates_rad_s: cg.w,
        qbar_pa: qbar,
        density_kgpm3: flow.rho_v,
        thrust_force_n: thrust.f_t,
        thrust_moment_nm: thrust.m_t,
        attitude_measured: flight.get(Pitch).is_some(),
    }
}

/// The measured channels with the named sensor errors removed (bias, scale factor, delay), or
/// the reconstructed air data in their place.
struct Corrected<'a> {
    flight: &'a MeasuredFlight,
    h_s: f64,
    corr: &'a Corrections,
    air_data: Option<&'a BTreeMap<Quantity, Vec<f64>>>,
}

impl Corrected<'_> {
    /// Channel `q` corrected, or its reconstruction; `None` when neither exists.
    fn get(&self, q: Quantity) -> Option<Vec<f64>> {
        if let Some(x) = self.air_data.and_then(|a| a.get(&q)) {
            return Some(x.clone());
        }
        let x = self.flight.get(q)?;
        let b = self.corr.bias.get(&q).copied().unwrap_or(0.0);
        let k = self.corr.scale.get(&q).copied().unwrap_or(0.0);
        let v: Vec<f64> = x.iter().map(|m| (m - b) / (1.0 + k)).collect();
        Some(match self.corr.delay_s.get(&q) {
            Some(&tau) => shift(&v, self.h_s, tau),
            None => v,
        })
    }

    /// Whether channel `q` is reconstructed (a CG value already).
    fn reconstructed(&self, q: Quantity) -> bool {
        self.air_data.is_some_and(|a| a.contains_key(&q))
    }
}

/// The body rates `p, q, r`: corrected, smoothed, and their smoothed derivatives (the measured
/// angular accelerations when logged).
struct BodyRates {
    raw: [Option<Vec<f64>>; 3],
    smooth: [Option<Vec<f64>>; 3],
    accel: [Option<Vec<f64>>; 3],
}

fn body_rates(raw: &Corrected, sg_half: usize) -> BodyRates {
    use Quantity::*;
    let sm = |x: Option<Vec<f64>>| x.map(|v| sg_smooth(&v, sg_half));
    let rates = [raw.get(RollRate), raw.get(PitchRate), raw.get(YawRate)];
    let rate_dot = |acc: Quantity, w: &Option<Vec<f64>>| -> Option<Vec<f64>> {
        match raw.flight.get(acc) {
            Some(x) => Some(x.to_vec()),
            None => w.as_ref().map(|w| derivative(w, raw.h_s)),
        }
    };
    let accel = [
        sm(rate_dot(RollAccel, &rates[0])),
        sm(rate_dot(PitchAccel, &rates[1])),
        sm(rate_dot(YawAccel, &rates[2])),
    ];
    BodyRates {
        smooth: rates.clone().map(sm),
        raw: rates,
        accel,
    }
}

/// Airspeed, α and β at the CG, smoothed, and the flow angles' rates.
struct AirAtCg {
    v: Option<Vec<f64>>,
    alpha: Option<Vec<f64>>,
    beta: Option<Vec<f64>>,
    alpha_dot: Option<Vec<f64>>,
    beta_dot: Option<Vec<f64>>,
}

/// Air data moved to the CG (before smoothing), exactly as the book's pre-processing of the
/// ATTAS noseboom data (README s.2): the measured V, α, β give the air-relative velocity at each
/// sensor, `v_s = V (cos α cos β, sin β, sin α cos β)`; the velocity its rotation about the CG
/// induces, `ω × r_s`, is removed, `v_cg = v_s − ω × r_s`, and α, β, V are recomputed from
/// `v_cg`. Each angle uses its own vane's position (plus the `x` offset the compatibility check
/// found), the airspeed the pitot's (`airspeed_*` keys). (Reading chosen: the angle a vane
/// measures is taken with the airspeed and the other angle as measured, i.e. both vanes see the
/// same local velocity apart from the rotation term.) Reconstructed air data are CG values
/// already.
fn air_data_at_cg(raw: &Corrected, rates: &[Option<Vec<f64>>; 3], sg_half: usize) -> AirAtCg {
    use Quantity::*;
    let (ac, n, h_s) = (&raw.flight.aircraft, raw.flight.len(), raw.h_s);
    let sm = |x: Option<Vec<f64>>| x.map(|v| sg_smooth(&v, sg_half));
    let (v_raw, a_raw, b_raw) = (raw.get(Airspeed), raw.get(Alpha), raw.get(Beta));
    let rate = |x: &Option<Vec<f64>>, i: usize| x.as_ref().map_or(0.0, |x| x[i]);
    let omega = |i: usize| Vector3::new(rate(&rates[0], i), rate(&rates[1], i), rate(&rates[2], i));
    let sensor_velocity = |i: usize| -> Option<Vector3<f64>> {
        let vv = v_raw.as_ref()?[i];
        let al = a_raw.as_ref().map_or(0.0, |a| a[i]);
        let be = b_raw.as_ref().map_or(0.0, |b| b[i]);
        let ((sa, ca), (sb, cb)) = (sin_cos(al), sin_cos(be));
        Some(Vector3::new(ca * cb, sb, sa * cb) * vv)
    };
    let dx = |ch: Quantity| Vector3::new(raw.corr.vane_dx_m.get(&ch).copied().unwrap_or(0.0), 0.0, 0.0);
    // The channel `x` of sensor position `r_s` at the CG by `at(v_cg)`, unless reconstructed or
    // at the CG already.
    let at_cg = |x: Option<Vec<f64>>, q: Quantity, r_s: Vector3<f64>, at: &dyn Fn(Vector3<f64>) -> f64| {
        x.map(|x| {
            if raw.reconstructed(q) || r_s == Vector3::zeros() {
                return x;
            }
            (0..n)
                .map(|i| sensor_velocity(i).map_or(x[i], |vs| at(vs - omega(i).cross(&r_s))))
                .collect::<Vec<f64>>()
        })
    };
    let alpha_raw = at_cg(a_raw.clone(), Alpha, ac.alpha_vane_position_m + dx(Alpha), &|v| {
        v.z.atan2(v.x)
    });
    let beta_raw = at_cg(b_raw.clone(), Beta, ac.beta_vane_position_m + dx(Beta), &|v| {
        (v.y / v.norm().max(1e-6)).clamp(-1.0, 1.0).asin()
    });
    let v = sm(at_cg(v_raw.clone(), Airspeed, ac.airspeed_position_m, &|v| v.norm()));
    AirAtCg {
        v,
        alpha_dot: alpha_raw.as_ref().map(|a| sg_smooth(&derivative(a, h_s), sg_half)),
        beta_dot: beta_raw.as_ref().map(|b| sg_smooth(&derivative(b, h_s), sg_half)),
        alpha: sm(alpha_raw),
        beta: sm(beta_raw),
    }
}

/// The dynamic pressure: measured, or from the density (measured, or the ISA at the pressure
/// altitude, else at sea level, said in `notes`) and the airspeed `v`.
fn dynamic_pressure(
    flight: &MeasuredFlight,
    v: &Option<Vec<f64>>,
    sg_half: usize,
    notes: &mut Vec<String>,
) -> Option<Vec<f64>> {
    use Quantity::*;
    let rho: Option<Vec<f64>> = match (flight.get(AirDensity), flight.get(Altitude)) {
        (Some(x), _) => Some(sg_smooth(x, sg_half)),
        (None, Some(h)) => {
            notes.push("air density from the ISA at the pressure altitude".into());
            Some(h.iter().map(|&h| isa_density(h)).collect())
        }
        _ => None,
    };
    match (flight.get(DynamicPressure), &rho, v) {
        (Some(x), _, _) => Some(sg_smooth(x, sg_half)),
        (None, Some(rho), Some(v)) => Some(rho.iter().zip(v).map(|(r, v)| 0.5 * r * v * v).collect()),
        (None, None, Some(v)) => {
            notes.push("no density, dynamic pressure or altitude: ISA sea-level density assumed".into());
            Some(v.iter().map(|v| 0.5 * 1.225 * v * v).collect())
        }
        _ => None,
    }
}

/// The flow at each sample: airspeed (at least 1 m/s), density from the dynamic pressure,
/// `q̄S`, and α, β (zero when not known).
struct Flow {
    vv: Vec<f64>,
    rho_v: Vec<f64>,
    qs: Vec<f64>,
    al: Vec<f64>,
    be: Vec<f64>,
}

/// Thrust at each sample: its size, force and moment about the CG; `known` false when the
/// aircraft's thrust source gives none (then zero).
struct ThrustForces {
    thrust_n: Vec<f64>,
    f_t: Vec<Vector3<f64>>,
    m_t: Vec<Vector3<f64>>,
    known: bool,
}

fn thrust_of(raw: &Corrected, sg_half: usize, flow: &Flow, notes: &mut Vec<String>) -> ThrustForces {
    let (flight, n) = (raw.flight, raw.flight.len());
    let mut t = ThrustForces {
        thrust_n: vec![0.0; n],
        f_t: vec![Vector3::zeros(); n],
        m_t: vec![Vector3::zeros(); n],
        known: true,
    };
    let missing = match &flight.aircraft.thrust {
        // One engine on the thrust line, or a twin whose left engine mirrors the right one (the
        // single engine is a twin with both at `position_m` and no thrust difference).
        ThrustSource::Measured {
            position_m: r_r,
            pitch_rad,
        }
        | ThrustSource::MeasuredTwin {
            right_engine_position_m: r_r,
            pitch_rad,
        } => measured_thrust(flight, sg_half, *r_r, *pitch_rad, &mut t)
            .then_some("thrust declared measured but no Thrust channel: thrust taken as zero"),
        ThrustSource::Propeller(prop) => match raw.get(Quantity::PropSpeed).map(|v| sg_smooth(&v, sg_half)) {
            Some(w) => {
                propeller_thrust(flight, prop, &w, flow, &mut t);
                None
            }
            None => Some("propeller model but no PropSpeed channel: thrust taken as zero"),
        },
        ThrustSource::Unknown => Some("thrust unknown: it is part of C_D and no thrust candidate is tested"),
    };
    if let Some(why) = missing {
        t.known = false;
        notes.push(why.into());
    }
    t
}

/// Measured thrust along the thrust line of pitch `pitch_rad` at `r_r` (a twin: the right
/// engine, the left mirrored, split by the thrust difference when logged). `true` when the
/// Thrust channel is missing.
fn measured_thrust(
    flight: &MeasuredFlight,
    sg_half: usize,
    r_r: Vector3<f64>,
    pitch_rad: f64,
    t: &mut ThrustForces,
) -> bool {
    let Some(tt) = flight.get(Quantity::Thrust) else {
        return true;
    };
    let twin = matches!(flight.aircraft.thrust, ThrustSource::MeasuredTwin { .. });
    let r_l = if twin { Vector3::new(r_r.x, -r_r.y, r_r.z) } else { r_r };
    // F_L − F_R, when measured (0: a symmetric split).
    let dt = flight
        .get(Quantity::ThrustDifference)
        .filter(|_| twin)
        .map(|d| sg_smooth(d, sg_half));
    let tt = sg_smooth(tt, sg_half);
    let u = Vector3::new(pitch_rad.cos(), 0.0, -pitch_rad.sin());
    for i in 0..flight.len() {
        t.thrust_n[i] = tt[i];
        t.f_t[i] = u * tt[i];
        t.m_t[i] = if twin {
            let d = dt.as_ref().map_or(0.0, |d| d[i]);
            r_r.cross(&(u * (0.5 * (tt[i] - d)))) + r_l.cross(&(u * (0.5 * (tt[i] + d))))
        } else {
            r_r.cross(&t.f_t[i])
        };
    }
    false
}

/// Thrust of the propeller model at the measured propeller speed `w`.
fn propeller_thrust(
    flight: &MeasuredFlight,
    prop: &aerosid_core::aero::Propeller<f64>,
    w: &[f64],
    flow: &Flow,
    t: &mut ThrustForces,
) {
    let (sp, cp) = sin_cos(prop.pitch_rad);
    // An estimated β (the inertial velocity less a lagged wind) misses the lateral gust; its
    // error would enter the thrust through cos β̂ — an error of the size of β̂² − β² that follows
    // |β̂| — so the axial speed then takes β as zero (its true share, 1 − cos β, is 0.1 % at
    // 2.5°).
    let beta_axial = !flight.log.is_estimated(Quantity::Beta);
    for i in 0..flight.len() {
        let (sa, ca) = sin_cos(flow.al[i]);
        let cb = if beta_axial { flow.be[i].cos() } else { 1.0 };
        let axial = flow.vv[i] * cb * (ca * cp - sa * sp);
        let o = propeller_output(prop, flow.rho_v[i], axial, w[i]);
        let (f, m) = propulsion_force_moment(prop, &o, -1.0);
        t.thrust_n[i] = o.thrust_n;
        t.f_t[i] = f;
        t.m_t[i] = m;
    }
}

/// The accelerometers moved to the CG: the smoothed specific forces at `ra`, less the rotation's
/// share `ω̇ × r_a + ω × (ω × r_a)` (rates and their derivatives `w`, `wd`, zero when unknown).
struct CgAccel {
    ra: Vector3<f64>,
    accels: [Option<Vec<f64>>; 3],
    w: [Vec<f64>; 3],
    wd: [Vec<f64>; 3],
}

impl CgAccel {
    /// Axis `k` of the specific force at the CG at sample `i`.
    fn at(&self, i: usize, k: usize) -> Option<f64> {
        let a = self.accels[k].as_ref()?[i];
        if self.ra == Vector3::zeros() {
            return Some(a);
        }
        let w = Vector3::new(self.w[0][i], self.w[1][i], self.w[2][i]);
        let wd = Vector3::new(self.wd[0][i], self.wd[1][i], self.wd[2][i]);
        let corr = wd.cross(&self.ra) + w.cross(&w.cross(&self.ra));
        Some(a - corr[k])
    }

    /// The aerodynamic force `m a_cg − F_T` at sample `i` (an axis without its accelerometer:
    /// zero).
    fn aero_force(&self, i: usize, mass_kg: f64, f_t: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.at(i, 0).map_or(0.0, |a| mass_kg * a - f_t.x),
            self.at(i, 1).map_or(0.0, |a| mass_kg * a - f_t.y),
            self.at(i, 2).map_or(0.0, |a| mass_kg * a - f_t.z),
        )
    }
}

/// `C_L`, `C_D` (with α and the x, z accelerometers) and `C_Y` (with the y one); the moment
/// coefficients stay `None`.
fn force_coefficients(
    flight: &MeasuredFlight,
    cg: &CgAccel,
    thrust: &ThrustForces,
    alpha_known: bool,
    flow: &Flow,
) -> [Option<Vec<f64>>; 6] {
    let (n, mass_kg, qs, f_t) = (flight.len(), flight.aircraft.mass_kg, &flow.qs, &thrust.f_t);
    let mut z: [Option<Vec<f64>>; 6] = Default::default();
    if cg.accels[0].is_some() && cg.accels[2].is_some() && alpha_known {
        let mut cl = vec![0.0; n];
        let mut cd = vec![0.0; n];
        for i in 0..n {
            let (Some(ax), Some(az)) = (cg.at(i, 0), cg.at(i, 2)) else {
                continue;
            };
            let fx = mass_kg * ax - f_t[i].x;
            let fz = mass_kg * az - f_t[i].z;
            let (sa, ca) = sin_cos(flow.al[i]);
            cd[i] = -(fx * ca + fz * sa) / qs[i];
            cl[i] = (fx * sa - fz * ca) / qs[i];
        }
        z[0] = Some(cl);
        z[1] = Some(cd);
    }
    if cg.accels[1].is_some() {
        z[2] = Some(
            (0..n)
                .map(|i| (mass_kg * cg.at(i, 1).unwrap_or(0.0) - f_t[i].y) / qs[i])
                .collect(),
        );
    }
    z
}

/// `C_m` (with q) and `C_l`, `C_n` (with p, r, the span and the lateral inertias) into `z`.
///
/// An inertia the aircraft file gives as unknown (the longitudinal HFB-320 test has only Iy)
/// enters as zero in the gyroscopic term `ω × Jω` (reading chosen: for a longitudinal manoeuvre
/// the `(Ix − Iz) p r` and `Ixz (p² − r²)` parts of the pitching moment are second order, and the
/// book's HFB-320 model leaves them out); `C_l`, `C_n` then need the span and Ix, Iz and are not
/// synthesised.
fn moment_coefficients(
    flight: &MeasuredFlight,
    cg: &CgAccel,
    thrust: &ThrustForces,
    flow: &Flow,
    rates: &BodyRates,
    z: &mut [Option<Vec<f64>>; 6],
    notes: &mut Vec<String>,
) {
    let (ac, n) = (&flight.aircraft, flight.len());
    let (b, c, j) = (ac.span_m, ac.chord_m, ac.inertia_kgm2);
    let lateral_rates = rates.raw[0].is_some() && rates.raw[2].is_some();
    let lateral_inertia = [j[(0, 0)], j[(2, 2)], j[(0, 2)]].iter().all(|x| x.is_finite()) && b.is_finite();
    let j_known = j.map(|x| if x.is_finite() { x } else { 0.0 });
    if !lateral_inertia && lateral_rates {
        notes.push(
            "Ix, Iz, Ixz or the span unknown: C_l, C_n not synthesised; the unknown inertias taken as zero in ω × Jω of C_m"
                .into(),
        );
    }
    let lateral_rates = lateral_rates && lateral_inertia;
    let pitch = rates.smooth[1].is_some();
    if !(pitch || lateral_rates) {
        return;
    }
    let mut mom = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for i in 0..n {
        let w = Vector3::new(cg.w[0][i], cg.w[1][i], cg.w[2][i]);
        let wd = Vector3::new(cg.wd[0][i], cg.wd[1][i], cg.wd[2][i]);
        let mut m = j_known * wd + w.cross(&(j_known * w)) - thrust.m_t[i];
        // About the moment reference point `r_P` (README s.2 for the ATTAS):
        // `M_P = M_CG − r_P × F_A` with the aerodynamic force `F_A = m a_cg − F_T`.
        if ac.moment_reference_m != Vector3::zeros() {
            m -= ac
                .moment_reference_m
                .cross(&cg.aero_force(i, ac.mass_kg, &thrust.f_t[i]));
        }
        mom[0][i] = m.x / (flow.qs[i] * b);
        mom[1][i] = m.y / (flow.qs[i] * c);
        mom[2][i] = m.z / (flow.qs[i] * b);
    }
    let [ml, mm, mn] = mom;
    if pitch {
        z[4] = Some(mm);
    }
    if lateral_rates {
        z[3] = Some(ml);
        z[5] = Some(mn);
    }
}

/// What the regressors' signals are made of besides the flow: the air data at the CG, the
/// smoothed body rates, the surfaces (elevator, aileron, rudder) and their rates.
struct SignalParts {
    air: AirAtCg,
    rates: [Option<Vec<f64>>; 3],
    surfaces: [Option<Vec<f64>>; 3],
    surface_rates: [Option<Vec<f64>>; 3],
}

/// The signals of the regressors (all but the airspeed): flow angles, normalised rates,
/// surfaces and their rates, `C_L`, Mach, the thrust coefficient and the normalised flow-angle
/// rates ([`kinematic_flow_rates`] when they can be had).
fn signals_of(
    flight: &MeasuredFlight,
    sg_half: usize,
    parts: SignalParts,
    z: &[Option<Vec<f64>>; 6],
    cg: &CgAccel,
    thrust: &ThrustForces,
    flow: &Flow,
) -> BTreeMap<Signal, Vec<f64>> {
    let (n, vv) = (flight.len(), &flow.vv);
    let (b, c) = (flight.aircraft.span_m, flight.aircraft.chord_m);
    let SignalParts {
        air,
        rates: [p_s, q_s, r_s],
        surfaces,
        surface_rates,
    } = parts;
    let mut signals = BTreeMap::new();
    if let Some(a) = air.alpha {
        signals.insert(Signal::Alpha, a);
    }
    if let Some(bb) = air.beta {
        signals.insert(Signal::Beta, bb);
    }
    // The lateral normalisations need the span (unknown for the longitudinal HFB-320 test).
    if let (Some(x), true) = (&p_s, b.is_finite()) {
        signals.insert(Signal::PN, (0..n).map(|i| x[i] * b / (2.0 * vv[i])).collect());
    }
    if let Some(x) = &q_s {
        signals.insert(Signal::QN, (0..n).map(|i| x[i] * c / (2.0 * vv[i])).collect());
    }
    if let (Some(x), true) = (&r_s, b.is_finite()) {
        signals.insert(Signal::RN, (0..n).map(|i| x[i] * b / (2.0 * vv[i])).collect());
    }
    let named = [Signal::Elevator, Signal::Aileron, Signal::Rudder]
        .into_iter()
        .zip(surfaces)
        .chain(
            [Signal::ElevatorRate, Signal::AileronRate, Signal::RudderRate]
                .into_iter()
                .zip(surface_rates),
        );
    for (sig, x) in named {
        if let Some(x) = x {
            signals.insert(sig, x);
        }
    }
    if let Some(cl) = &z[0] {
        signals.insert(Signal::LiftCoeff, cl.clone());
    }
    if let Some(m) = flight.get(Quantity::Mach) {
        signals.insert(Signal::Mach, sg_smooth(m, sg_half));
    }
    if thrust.known {
        signals.insert(
            Signal::ThrustCoeff,
            (0..n).map(|i| thrust.thrust_n[i] / flow.qs[i]).collect(),
        );
    }
    let (alpha_dot, beta_dot) = match kinematic_flow_rates(flight, sg_half, cg, flow) {
        Some((ad, bd)) if air.alpha_dot.is_some() => (Some(ad), air.beta_dot.map(|_| bd)),
        _ => (air.alpha_dot, air.beta_dot),
    };
    if let Some(x) = alpha_dot {
        signals.insert(Signal::AlphaDotN, (0..n).map(|i| x[i] * c / (2.0 * vv[i])).collect());
    }
    if let (Some(x), true) = (beta_dot, b.is_finite()) {
        signals.insert(Signal::BetaDotN, (0..n).map(|i| x[i] * b / (2.0 * vv[i])).collect());
    }
    signals
}

/// α̇ and β̇ from the kinematics when the accelerations, rates and attitude are measured (Klein &
/// Morelli 2006 §10.1: the flow-angle rates from `u̇, v̇, ẇ` of the rigid-body equations, with
/// `u, v, w` from the measured air data): differentiating a vane amplifies its noise by about
/// `1/h` — on the campaign's flights the differentiated α̇ column was half noise (variance 2× its
/// error variance), the kinematic one is not.
fn kinematic_flow_rates(
    flight: &MeasuredFlight,
    sg_half: usize,
    cg: &CgAccel,
    flow: &Flow,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = flight.len();
    let (th, ph) = (
        sg_smooth(flight.get(Quantity::Pitch)?, sg_half),
        sg_smooth(flight.get(Quantity::Roll)?, sg_half),
    );
    let (_, _) = (cg.accels[0].as_ref()?, cg.accels[2].as_ref()?);
    let (mut ad, mut bd) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let (ax, az) = (cg.at(i, 0)?, cg.at(i, 2)?);
        let ay = cg.at(i, 1).unwrap_or(0.0);
        let (p, q, r) = (cg.w[0][i], cg.w[1][i], cg.w[2][i]);
        let vt = flow.vv[i];
        let (sa, ca) = sin_cos(flow.al[i]);
        let (sb, cb) = sin_cos(flow.be[i]);
        let (u, v, w) = (vt * ca * cb, vt * sb, vt * sa * cb);
        let g = 9.806_65;
        let ((st, ct), (sp, cp)) = (sin_cos(th[i]), sin_cos(ph[i]));
        let udot = ax - g * st + r * v - q * w;
        let vdot = ay + g * ct * sp + p * w - r * u;
        let wdot = az + g * ct * cp + q * u - p * v;
        ad[i] = (u * wdot - w * udot) / (u * u + w * w);
        let vtdot = (u * udot + v * vdot + w * wdot) / vt;
        bd[i] = (vdot * vt - v * vtdot) / (vt * vt * cb.max(0.1));
    }
    Some((ad, bd))
}

/// What kind of cause a term or sensor error stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub enum CauseKind {
    /// α², α³, a stall break: a lift/drag/moment curve that is not linear in α.
    NonlinearAlpha,
    /// A control effect the baseline lacks (|δ|, δ², α·δ, or a missing δ).
    ControlTerm,
    /// α̇ (downwash lag) or β̇.
    AlphaDot,
    /// A thrust term (thrust-line moment, propwash).
    Thrust,
    /// Longitudinal–lateral coupling (α·β, α·p, α·r, β² in a longitudinal coefficient).
    CrossCoupling,
    /// Nonlinear in β within a lateral coefficient (β³).
    NonlinearBeta,
    /// Rate terms beyond eq. 3 (α·q).
    RateNonlinearity,
    /// Airspeed or Mach dependence.
    SpeedDependence,
    /// An eq. 3 regressor missing from the given baseline.
    MissingBaselineTerm,
    /// A sensor bias.
    SensorBias,
    /// A sensor scale factor (e.g. vane upwash).
    ScaleFactor,
    /// A channel's time delay.
    TimeDelay,
    /// A vane not where the aircraft file says (not at the CG).
    VanePosition,
    /// A control surface's time delay (its rate enters the coefficient).
    ControlDelay,
}

/// A model term: an eq. 3 regressor or a candidate of the library.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Term {
    /// 1.
    One,
    /// α.
    Alpha,
    /// α².
    Alpha2,
    /// α³.
    Alpha3,
    /// `(α − α_b)₊²`: a stall break above `α_b`, the 85th percentile of α in the identification data.
    StallBreak,
    /// β.
    Beta,
    /// β².
    Beta2,
    /// |β|.
    AbsBeta,
    /// β³.
    Beta3,
    /// `p b/(2V)`.
    P,
    /// `q c̄/(2V)`.
    Q,
    /// `r b/(2V)`.
    R,
    /// δe.
    Elevator,
    /// δa.
    Aileron,
    /// δr.
    Rudder,
    /// |δe|.
    AbsElevator,
    /// δe².
    Elevator2,
    /// α·q_n.
    AlphaQ,
    /// α·δe.
    AlphaElevator,
    /// α·δa.
    AlphaAileron,
    /// α·β.
    AlphaBeta,
    /// α·p_n.
    AlphaP,
    /// α·r_n.
    AlphaR,
    /// `α̇ c̄/(2V)`.
    AlphaDot,
    /// `β̇ b/(2V)`.
    BetaDot,
    /// `(V − V_ref)/V_ref`, `V_ref` the identification mean.
    Speed,
    /// `M − M_ref`.
    Mach,
    /// Thrust coefficient `T/(q̄S)`.
    Thrust,
    /// `T/(q̄S) · δe` (propwash on the tail).
    ThrustElevator,
    /// `T/(q̄S) · α`: the propeller's P-factor in yaw (at an angle of attack the blades' loads
    /// differ from side to side, so the thrust line moves sideways with α).
    ThrustAlpha,
    /// `T/(q̄S) · β`: the P-factor in pitch (with sideslip the thrust line moves up or down).
    ThrustBeta,
    /// `w·ln(1 + e^{(α−α_b)/w})`, `w` = 0.02 rad: a smooth hinge at `α_b` (the 85th percentile of
    /// α), the lift-curve slope changing over a few degrees — the onset of stall as a smooth
    /// saturation rather than the kink of [`Term::StallBreak`].
    StallHinge,
    /// `C_L²` (the measured lift coefficient squared): the drag polar's induced drag.
    Lift2,
    /// δė: a time delay `τ` of the elevator, `C_δe·δe(t−τ) ≈ C_δe·δe − C_δe τ·δė`.
    ElevatorRate,
    /// δȧ: a time delay of the ailerons.
    AileronRate,
    /// δṙ: a time delay of the rudder.
    RudderRate,
}

/// Lowest Mach number at which a Mach term is offered.
pub const MIN_MACH: f64 = 0.3;

/// Whether a term is offered on a flight whose largest Mach number is `mach_max` and whose thrust
/// is known (`thrust_known`), whatever the model ([`super::family`]'s module docs).
pub fn offered_on_flight(t: Term, mach_max: f64, thrust_known: bool) -> bool {
    use Term::*;
    match t {
        Mach => mach_max >= MIN_MACH,
        Thrust | ThrustElevator | ThrustAlpha | ThrustBeta => thrust_known,
        _ => true,
    }
}

/// The library terms not offered to a coefficient (its index into
/// [`COEFFICIENTS`]) because, with this flight's estimated flow angles, they
/// restate the measured force through a kinematic identity or, `α·q_n` in `C_D`, the drag's
/// rotation error ([`super::origin`]'s module doc); each with the reason in words.
///
/// An α estimated from the inertial data (the ground velocity less a slowly updated wind) gives
/// `α̇ = q − γ̇`, and `γ̇` is the measured lift over `m·V`: in C_L the term restates the lift. In
/// the other coefficients it carries the same measured lift, and in turbulence that lift holds
/// the gust's share, which the estimated α does not see — so a fit takes α̇ for the gust's
/// effect on the coefficient (a pitching moment that follows the lift, not a downwash lag). The
/// two cannot be told apart from such a flight, so α̇ is offered nowhere. Likewise β̇ with an
/// estimated β (the measured side force over `m·V` plus `p sin α − r cos α` and gravity).
pub fn barred_terms(flight: &MeasuredFlight) -> Vec<(usize, Term, String)> {
    // (the angle, its rate, the coefficient it restates, its name, the force it carries)
    let rates = [
        (Quantity::Alpha, Term::AlphaDot, 0, "α", "α̇ = q − γ̇ and γ̇ is the measured lift over m·V", "lift", "an α̇ term would restate the measured lift through that identity (size ≈ −4m/(ρSc̄)), not an aerodynamic cause"),
        (Quantity::Beta, Term::BetaDot, 2, "β", "β̇ is the measured side force over m·V plus p sin α − r cos α and gravity", "side force", "a β̇ term would restate the measured side force, not an aerodynamic cause"),
    ];
    const C_D: usize = 1;
    let mut out = Vec::new();
    for (q, term, own, angle, identity, force, restated) in rates {
        let Origin::Estimated { by } = flight.log.origin_of(q) else {
            continue;
        };
        for (i, name) in COEFFICIENTS.iter().enumerate() {
            let why = if i == own {
                restated.to_string()
            } else {
                format!("in {name} it would carry the measured {force}, which in turbulence holds the gust's share that the estimated {angle} misses: its effect cannot be told from the gust's")
            };
            out.push((
                i,
                term,
                format!(
                    "{} not offered in {name}: {angle} is estimated from the inertial data ({by}), so {identity} — {why}",
                    term.name().trim_end_matches("_n")
                ),
            ));
        }
    }
    if let Origin::Estimated { by } = flight.log.origin_of(Quantity::Alpha) {
        out.push((
            C_D,
            Term::AlphaQ,
            format!(
                "α·q not offered in C_D: α is estimated ({by}), and drag is the measured force rotated by α, so C_D carries C_L·(α̂ − α); with C_L linear in α and the estimate's error following the manoeuvre (its lag, the gust share it misses), that error fits α·q_n with a systematic value (module doc of gaps::origin), not an aerodynamic cause"
            ),
        ));
    }
    out
}

/// Reference values of the terms that need them, from the identification segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermRefs {
    /// α of the stall break, rad.
    pub alpha_break_rad: f64,
    /// Reference airspeed, m/s.
    pub airspeed_mps: f64,
    /// Reference Mach number.
    pub mach: f64,
}

impl TermRefs {
    /// The terms' reference values of `table` on its identification segment (the first `n_id`
    /// samples): the α break at the 85th percentile of α, the mean airspeed and Mach number.
    pub fn of_identification(table: &Table, n_id: usize) -> Self {
        let id_mean = |s: Signal| table.signals.get(&s).map(|v| super::signal::mean(&v[..n_id]));
        Self {
            alpha_break_rad: table
                .signals
                .get(&Signal::Alpha)
                .map_or(0.0, |a| crate::percentile(&a[..n_id], 0.85)),
            airspeed_mps: id_mean(Signal::Airspeed).unwrap_or(1.0).max(1.0),
            mach: id_mean(Signal::Mach).unwrap_or(0.0),
        }
    }
}

impl Term {
    /// The eq. 3 regressors (seed 000 with δa in `C_l`, `C_n`; the core's defaults).
    pub fn eq3(coef: usize) -> Vec<Term> {
        use Term::*;
        match coef {
            0 | 4 => vec![One, Alpha, Q, Elevator],
            1 => vec![One, Alpha, Alpha2, Q, Elevator],
            _ => vec![One, Beta, P, R, Aileron, Rudder],
        }
    }

    /// The [`library`](Self::library) of coefficient `coef` less the terms `table` bars on its
    /// flight ([`Table::barred`]) and those that mean nothing on it
    /// ([`offered_on_flight`]: Mach below compressibility, thrust unknown): the
    /// candidates the analysis offers.
    pub fn offered(coef: usize, table: &Table) -> Vec<Term> {
        let mach_max = table
            .signals
            .get(&Signal::Mach)
            .map_or(0.0, |m| m.iter().copied().fold(0.0, f64::max));
        let thrust_known = table.signals.contains_key(&Signal::ThrustCoeff);
        let mut lib = Self::library(coef);
        lib.retain(|t| {
            !table.barred.iter().any(|(i, b, _)| *i == coef && b == t) && offered_on_flight(*t, mach_max, thrust_known)
        });
        lib
    }

    /// The candidate library of a coefficient (before removing terms already in the model).
    pub fn library(coef: usize) -> Vec<Term> {
        use Term::*;
        // C_L² is a regressor of the drag only (in C_L it is the output itself).
        let mut lib = if is_longitudinal(coef) {
            vec![
                One,
                Alpha,
                Alpha2,
                Alpha3,
                StallBreak,
                Q,
                Elevator,
                AbsElevator,
                Elevator2,
                AlphaElevator,
                AlphaQ,
                AlphaDot,
                Beta2,
                AbsBeta,
                Speed,
                Mach,
                Thrust,
                ThrustElevator,
                StallHinge,
                Lift2,
                ElevatorRate,
                R,
                ThrustBeta,
            ]
        } else {
            vec![
                One,
                Beta,
                P,
                R,
                Aileron,
                Rudder,
                Beta3,
                AlphaBeta,
                AlphaP,
                AlphaR,
                AlphaAileron,
                BetaDot,
                Speed,
                Mach,
                Thrust,
                AileronRate,
                RudderRate,
                Q,
                ThrustAlpha,
            ]
        };
        lib.retain(|t| *t != Lift2 || coef == 1);
        lib
    }

    /// Printable name.
    pub fn name(&self) -> &'static str {
        use Term::*;
        match self {
            One => "1",
            Alpha => "α",
            Alpha2 => "α²",
            Alpha3 => "α³",
            StallBreak => "(α−α_b)₊²",
            Beta => "β",
            Beta2 => "β²",
            AbsBeta => "|β|",
            Beta3 => "β³",
            P => "p_n",
            Q => "q_n",
            R => "r_n",
            Elevator => "δe",
            Aileron => "δa",
            Rudder => "δr",
            AbsElevator => "|δe|",
            Elevator2 => "δe²",
            AlphaQ => "α·q_n",
            AlphaElevator => "α·δe",
            AlphaAileron => "α·δa",
            AlphaBeta => "α·β",
            AlphaP => "α·p_n",
            AlphaR => "α·r_n",
            AlphaDot => "α̇_n",
            BetaDot => "β̇_n",
            Speed => "ΔV/V",
            Mach => "ΔM",
            Thrust => "C_T",
            ThrustElevator => "C_T·δe",
            ThrustAlpha => "C_T·α",
            ThrustBeta => "C_T·β",
            StallHinge => "stall(α)",
            Lift2 => "C_L²",
            ElevatorRate => "δė",
            AileronRate => "δȧ",
            RudderRate => "δṙ",
        }
    }

    /// The cause this term stands for when it is added to coefficient `coef`.
    pub fn kind(&self, coef: usize) -> CauseKind {
        use Term::*;
        match self {
            Alpha2 | Alpha3 | StallBreak | StallHinge | Lift2 => CauseKind::NonlinearAlpha,
            ElevatorRate | AileronRate | RudderRate => CauseKind::ControlDelay,
            AbsElevator | Elevator2 | AlphaElevator | AlphaAileron | Elevator | Aileron | Rudder => {
                CauseKind::ControlTerm
            }
            AlphaDot | BetaDot => CauseKind::AlphaDot,
            Thrust | ThrustElevator | ThrustAlpha | ThrustBeta => CauseKind::Thrust,
            AlphaBeta | AlphaP | AlphaR => CauseKind::CrossCoupling,
            Beta2 | AbsBeta if is_longitudinal(coef) => CauseKind::CrossCoupling,
            Beta2 | AbsBeta | Beta3 => CauseKind::NonlinearBeta,
            AlphaQ => CauseKind::RateNonlinearity,
            // A rate of the other plane: the propeller's gyroscopic moment (yaw with q, pitch
            // with r) or inertial coupling.
            Q if !is_longitudinal(coef) => CauseKind::CrossCoupling,
            P | R if is_longitudinal(coef) => CauseKind::CrossCoupling,
            Speed | Mach => CauseKind::SpeedDependence,
            One | Alpha | Beta | P | Q | R => CauseKind::MissingBaselineTerm,
        }
    }

    /// A product of two different variables (α·q, α·δe, C_T·δe …): the selection's convention
    /// between terms the data cannot tell apart names a term of one variable before such a
    /// product (after the effect hierarchy of Wu & Hamada, *Experiments*, 2009, §4.6).
    pub fn is_interaction(&self) -> bool {
        use Term::*;
        matches!(
            self,
            AlphaQ
                | AlphaElevator
                | AlphaAileron
                | AlphaBeta
                | AlphaP
                | AlphaR
                | ThrustElevator
                | ThrustAlpha
                | ThrustBeta
        )
    }

    /// The term's value at one instant ([`Table::snapshot`], possibly with simulated signals
    /// written into it); `None` when a signal it needs is absent (NaN). Equal to
    /// [`Term::column`] sample by sample.
    pub fn eval(&self, s: &Snapshot, refs: &TermRefs) -> Option<f64> {
        use Term::*;
        let g = |x: Signal| {
            let v = s[x.index()];
            (!v.is_nan()).then_some(v)
        };
        let a = || g(Signal::Alpha);
        let v = match self {
            One => 1.0,
            Alpha => a()?,
            Alpha2 => a()?.powi(2),
            Alpha3 => a()?.powi(3),
            StallBreak => (a()? - refs.alpha_break_rad).max(0.0).powi(2),
            Beta => g(Signal::Beta)?,
            Beta2 => g(Signal::Beta)?.powi(2),
            AbsBeta => g(Signal::Beta)?.abs(),
            Beta3 => g(Signal::Beta)?.powi(3),
            P => g(Signal::PN)?,
            Q => g(Signal::QN)?,
            R => g(Signal::RN)?,
            Elevator => g(Signal::Elevator)?,
            Aileron => g(Signal::Aileron)?,
            Rudder => g(Signal::Rudder)?,
            AbsElevator => g(Signal::Elevator)?.abs(),
            Elevator2 => g(Signal::Elevator)?.powi(2),
            AlphaQ => a()? * g(Signal::QN)?,
            AlphaElevator => a()? * g(Signal::Elevator)?,
            AlphaAileron => a()? * g(Signal::Aileron)?,
            AlphaBeta => a()? * g(Signal::Beta)?,
            AlphaP => a()? * g(Signal::PN)?,
            AlphaR => a()? * g(Signal::RN)?,
            AlphaDot => g(Signal::AlphaDotN)?,
            BetaDot => g(Signal::BetaDotN)?,
            Speed => (g(Signal::Airspeed)? - refs.airspeed_mps) / refs.airspeed_mps,
            Mach => g(Signal::Mach)? - refs.mach,
            Thrust => g(Signal::ThrustCoeff)?,
            ThrustElevator => g(Signal::ThrustCoeff)? * g(Signal::Elevator)?,
            ThrustAlpha => g(Signal::ThrustCoeff)? * a()?,
            ThrustBeta => g(Signal::ThrustCoeff)? * g(Signal::Beta)?,
            StallHinge => stall_hinge(a()?, refs.alpha_break_rad),
            Lift2 => g(Signal::LiftCoeff)?.powi(2),
            ElevatorRate => g(Signal::ElevatorRate)?,
            AileronRate => g(Signal::AileronRate)?,
            RudderRate => g(Signal::RudderRate)?,
        };
        Some(v)
    }

    /// An ASCII name for the command line (`alpha`, `q`, `de`, `dV` …).
    pub fn ascii(&self) -> &'static str {
        use Term::*;
        match self {
            One => "1",
            Alpha => "alpha",
            Alpha2 => "alpha2",
            Alpha3 => "alpha3",
            StallBreak => "stall",
            Beta => "beta",
            Beta2 => "beta2",
            AbsBeta => "absbeta",
            Beta3 => "beta3",
            P => "p",
            Q => "q",
            R => "r",
            Elevator => "de",
            Aileron => "da",
            Rudder => "dr",
            AbsElevator => "absde",
            Elevator2 => "de2",
            AlphaQ => "alpha_q",
            AlphaElevator => "alpha_de",
            AlphaAileron => "alpha_da",
            AlphaBeta => "alpha_beta",
            AlphaP => "alpha_p",
            AlphaR => "alpha_r",
            AlphaDot => "alphadot",
            BetaDot => "betadot",
            Speed => "dV",
            Mach => "dMach",
            Thrust => "CT",
            ThrustElevator => "CT_de",
            ThrustAlpha => "CT_alpha",
            ThrustBeta => "CT_beta",
            StallHinge => "stall_smooth",
            Lift2 => "CL2",
            ElevatorRate => "dedot",
            AileronRate => "dadot",
            RudderRate => "drdot",
        }
    }

    /// The term of a name ([`Term::name`] or [`Term::ascii`]).
    pub fn parse(s: &str) -> Option<Term> {
        Term::ALL.into_iter().find(|t| t.name() == s || t.ascii() == s)
    }

    /// Every term (the union of the libraries and eq. 3).
    pub const ALL: [Term; 36] = [
        Term::One,
        Term::Alpha,
        Term::Alpha2,
        Term::Alpha3,
        Term::StallBreak,
        Term::Beta,
        Term::Beta2,
        Term::AbsBeta,
        Term::Beta3,
        Term::P,
        Term::Q,
        Term::R,
        Term::Elevator,
        Term::Aileron,
        Term::Rudder,
        Term::AbsElevator,
        Term::Elevator2,
        Term::AlphaQ,
        Term::AlphaElevator,
        Term::AlphaAileron,
        Term::AlphaBeta,
        Term::AlphaP,
        Term::AlphaR,
        Term::AlphaDot,
        Term::BetaDot,
        Term::Speed,
        Term::Mach,
        Term::Thrust,
        Term::ThrustElevator,
        Term::ThrustAlpha,
        Term::ThrustBeta,
        Term::StallHinge,
        Term::Lift2,
        Term::ElevatorRate,
        Term::AileronRate,
        Term::RudderRate,
    ];

    /// The term's column, or `None` when a signal it needs is missing.
    pub fn column(&self, t: &Table, refs: &TermRefs) -> Option<Vec<f64>> {
        use Term::*;
        let s = |x: Signal| t.signals.get(&x);
        let n = t.t_s.len();
        let map1 = |x: Signal, f: &dyn Fn(f64) -> f64| s(x).map(|v| v.iter().map(|&a| f(a)).collect());
        let map2 = |x: Signal, y: Signal| Some(s(x)?.iter().zip(s(y)?).map(|(a, b)| a * b).collect());
        match self {
            One => Some(vec![1.0; n]),
            Alpha => s(Signal::Alpha).cloned(),
            Alpha2 => map1(Signal::Alpha, &|a| a * a),
            Alpha3 => map1(Signal::Alpha, &|a| a * a * a),
            StallBreak => {
                let ab = refs.alpha_break_rad;
                map1(Signal::Alpha, &|a| (a - ab).max(0.0).powi(2))
            }
            Beta => s(Signal::Beta).cloned(),
            Beta2 => map1(Signal::Beta, &|a| a * a),
            AbsBeta => map1(Signal::Beta, &|a| a.abs()),
            Beta3 => map1(Signal::Beta, &|a| a * a * a),
            P => s(Signal::PN).cloned(),
            Q => s(Signal::QN).cloned(),
            R => s(Signal::RN).cloned(),
            Elevator => s(Signal::Elevator).cloned(),
            Aileron => s(Signal::Aileron).cloned(),
            Rudder => s(Signal::Rudder).cloned(),
            AbsElevator => map1(Signal::Elevator, &|a| a.abs()),
            Elevator2 => map1(Signal::Elevator, &|a| a * a),
            AlphaQ => map2(Signal::Alpha, Signal::QN),
            AlphaElevator => map2(Signal::Alpha, Signal::Elevator),
            AlphaAileron => map2(Signal::Alpha, Signal::Aileron),
            AlphaBeta => map2(Signal::Alpha, Signal::Beta),
            AlphaP => map2(Signal::Alpha, Signal::PN),
            AlphaR => map2(Signal::Alpha, Signal::RN),
            AlphaDot => s(Signal::AlphaDotN).cloned(),
            BetaDot => s(Signal::BetaDotN).cloned(),
            Speed => {
                let v0 = refs.airspeed_mps;
                map1(Signal::Airspeed, &|v| (v - v0) / v0)
            }
            Mach => {
                let m0 = refs.mach;
                map1(Signal::Mach, &|m| m - m0)
            }
            Thrust => s(Signal::ThrustCoeff).cloned(),
            ThrustElevator => map2(Signal::ThrustCoeff, Signal::Elevator),
            ThrustAlpha => map2(Signal::ThrustCoeff, Signal::Alpha),
            ThrustBeta => map2(Signal::ThrustCoeff, Signal::Beta),
            StallHinge => {
                let ab = refs.alpha_break_rad;
                map1(Signal::Alpha, &|a| stall_hinge(a, ab))
            }
            Lift2 => map1(Signal::LiftCoeff, &|c| c * c),
            ElevatorRate => s(Signal::ElevatorRate).cloned(),
            AileronRate => s(Signal::AileronRate).cloned(),
            RudderRate => s(Signal::RudderRate).cloned(),
        }
    }
}

/// Width of the smooth stall hinge, rad.
const STALL_WIDTH_RAD: f64 = 0.02;

/// The smooth hinge `w·ln(1 + e^{(α−α_b)/w})` of [`Term::StallHinge`] (overflow-free form).
fn stall_hinge(alpha: f64, alpha_b: f64) -> f64 {
    let x = (alpha - alpha_b) / STALL_WIDTH_RAD;
    STALL_WIDTH_RAD * (x.max(0.0) + (-x.abs()).exp().ln_1p())
}
