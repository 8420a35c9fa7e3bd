//! The low-rate path of the gap analysis: the longitudinal coefficients `C_L`, `C_D`, `C_m`
//! fitted and their candidate causes tested by **output error**, for data logged below
//! [`crate::io::quality::MIN_RATE_HZ`], where the equation-error path (coefficients synthesised by
//! smoothing and differentiating over ±0.1 s) cannot serve.
//!
//! ## The model (a partial output error; reading chosen)
//! The short-period states `x = [α, q]` are simulated; the airspeed, `q̄`, β, the attitude, the
//! roll and yaw rates, the surfaces and the thrust are the measured (corrected) signals of the
//! [`Table`], taken between samples on the paths of [`super::intersample`] (the cubic spline
//! through the samples: phase-free for point samples, and for block means the exact model of the
//! averaging; a linear interpolation makes a false surface delay at 10 Hz). Taking the slow and the lateral states as
//! measured keeps an error of the phugoid or of the lateral model out of the short-period fit (the
//! same reading as [`super::simulate`]'s partial simulations; a full longitudinal simulation drifts
//! on the phugoid within a manoeuvre). The equations are the rigid-body kinematics of the
//! compatibility check with `u = V cos α cos β`, `v = V sin β`, `w = V sin α cos β`:
//!
//! * `α̇ = (u ẇ − w u̇)/(u² + w²)`, which with the aerodynamic force of eq. 1 (stability axes, as
//!   the synthesis: `F_x = q̄S(−C_D cos α + C_L sin α)`, `F_z = q̄S(−C_D sin α − C_L cos α)`)
//!   reduces to `α̇ = q + [−V sin β (p cos α + r sin α) − q̄S C_L/m + (T_z cos α − T_x sin α)/m
//!   + g (cos α cos θ cos φ + sin α sin θ)]/(V cos β)`: `C_D` drops out of `α̇`;
//! * `q̇ = (q̄S c̄ C_m + (r_P × F_A)_y + M_T,y − (ω × Jω)_y)/I_y` (the synthesis's `C_m`, moments
//!   about the reference point `r_P`, the measured aerodynamic force in the transfer term);
//! * outputs `y = [α, q, F_A,x/m, F_A,z/m]` against the measured α, `q` and the
//!   accelerometers' aerodynamic part (`m a_cg − F_T`). No output bias: an α bias is nearly
//!   collinear with the intercepts of `C_L` and `C_m` and, estimated beside them, moved the
//!   α-dependent candidates (on the HFB-320, `α·q_n` in `C_m` at t² 61 with a bias of 0.07 ± 0.03
//!   rad); sensor biases are the compatibility check's, removed before this path.
//!
//! The coefficients are the gap analysis's own terms ([`Term::eval`] on the table's snapshot with
//! the simulated α, `q c̄/(2V)`, the model's `C_L` (for `C_L²` in `C_D`) and the model's `α̇`
//! written into it), linear in the parameters `θ`.
//!
//! ## Estimation
//! Gauss–Newton on `J(θ) = Σ_k e_kᵀ R⁻¹ e_k`, `e_k = y_k − ŷ_k(θ)`, with the output sensitivities
//! `∂ŷ/∂θ` from the forward sensitivity equations `Ṡ = (∂f/∂x) S + ∂f/∂θ` integrated with the
//! states (RK4 on the sample grid; `∂f/∂θ` analytic, `∂f/∂x` and `∂h/∂x` by central differences);
//! each manoeuvre starts from its own measured first sample; a step that does not lower `J` is
//! halved. `R` is the residuals' mean square per output, re-estimated after each fit (the usual
//! relaxation of the output error method, Jategaonkar 2015 §4.4; the same as `aerosid fem`'s
//! `estimate_noise`). The core's filter ([`aerosid_core::fem::FilterError`]) is not used here: its
//! sensitivities of an RK4 step are central differences in every parameter (`2·NP` integrations
//! per sample), five to ten times the cost of the sensitivity equations for the dozens of fits a
//! candidate test makes.
//!
//! **With process noise** (turbulence) the output error leaves the gusts' response in coloured
//! residuals; where an axis's residuals show it (the likelihood-ratio test of `low_rate_fem.rs`),
//! the same estimation runs with a steady-state Kalman filter in the loop — the filter error
//! method with the gain held fixed (`Dynamics::run` with a gain): `e_k` are then the
//! innovations, `R` their covariance, and everything below is unchanged.
//!
//! ## Uncertainty
//! `σ` is the block sandwich `M⁻¹ (Σ_b s̃_b s̃_bᵀ) M⁻¹` (`M = Σ HᵀR⁻¹H`, `s_b = Σ_{k∈b} HᵀR⁻¹e_k`
//! over blocks of [`super::GapSettings::max_lag_s`], bias-reduced as CR2 does for clusters:
//! [`block_sandwich_sigma`]) — a residual-colour correction in the spirit of Morelli & Klein
//! (1997), summing the residual correlation within a block instead of lag by lag. The Cramér–Rao
//! bound `√(M⁻¹)_jj` is reported beside it (`sigma_eq17`) but is not a floor: with `R` the
//! residuals' mean square it assumes white residuals, and on coloured ones it is no lower bound
//! (in moderate turbulence at 10 Hz it exceeded the scatter of `C_m`'s intercept, α and `q_n` by
//! 1.6–2, docs/model-gaps.md). It is σ only when the sandwich cannot be formed.
//!
//! ## Candidates and the held-out test
//! Each candidate of [`Term::offered`] is added to the current model of its coefficient and the
//! model refitted (`R` held at the baseline's so that the criteria compare). It is named when its
//! `t² = (θ/σ)²` exceeds the analysis's threshold *and* it improves the prediction of held-out
//! data beyond noise: the noise-referenced held-out gain `T` of [`select::noise_referenced_gain`]
//! above the one-sided critical value, as the equation-error path. The held-out predictions are
//! those of the fit without the fold, by one Gauss–Newton step from the full fit:
//! `Δθ_f = (M − M_f)⁻¹(g − g_f)` and `ê_k = e_k − H_k Δθ_f` for `k` in the fold (the linearised
//! leave-fold-out; the fit is nearly linear about its optimum). Folds are whole manoeuvres when
//! there are [`select::MIN_PIECES_FOR_FOLDS`] or more, else time blocks of the
//! [`select::CvSettings`]. `T` is formed per output on residuals scaled by `R^{-1/2}` and the
//! outputs' gains and null variances summed (outputs taken as independent). The likelihood gain
//! `N Σ_i ln(R₀,i/R₁,i)` (twice the log-likelihood ratio with `R` estimated) is listed in the
//! notes. Up to [`MAX_ADDED`] terms per coefficient are added, the largest `t²` first; the
//! candidates significant in the same round are listed as the alternatives the data cannot tell
//! apart from it.
//!
//! Not tested here: `α̇` in `C_L` (it makes `α̇` implicit in the state equation).

use super::intersample;
use super::model::{Kinematics, Signal, Snapshot, Table, Term, TermRefs, COEFFICIENTS};
use super::regress::{metrics, ols_theta, Metrics};
use super::select::{self, CvSettings};
use super::signal::sin_cos;
use super::simulate::inertia;
use super::{Added, CandidateScore, CoefficientGap, Homogeneity, ManoeuvreEstimate, ModelFit, Parameter, Traces};
use crate::io::measured::{Aircraft, Sampling};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// The coefficients the low-rate path covers (indices into [`COEFFICIENTS`]).
pub const COVERED: [usize; 3] = [0, 1, 4];

/// Most terms added to one coefficient.
pub const MAX_ADDED: usize = 3;

/// Outputs: α, q, and the aerodynamic specific force along x and z.
pub(super) const NY: usize = 4;
const OUTPUT_NAMES: [&str; NY] = ["α", "q", "F_A,x/m", "F_A,z/m"];

/// The output a coefficient is judged on in the per-coefficient figures: `C_L` → `F_A,z/m`,
/// `C_D` → `F_A,x/m`, `C_m` → `q`.
fn primary_output(coef: usize) -> usize {
    match coef {
        0 => 3,
        1 => 2,
        _ => 1,
    }
}

const G_MPS2: f64 = 9.806_65;
/// Gauss–Newton iterations of a fit.
const MAX_ITERATIONS: usize = 12;
/// Convergence: every parameter moved by less than this many σ.
const TOLERANCE_SIGMA: f64 = 0.01;
/// Rounds of the noise relaxation of the baseline.
const NOISE_ROUNDS: usize = 3;

/// The terms of the model: per parameter, its coefficient and term; and per covered coefficient
/// its `(parameter, term)` pairs.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Spec {
    terms: Vec<(usize, Term)>,
    covered: [usize; 3],
    by_coef: [Vec<(usize, Term)>; 3],
}

impl Spec {
    pub(super) fn new(covered: [usize; 3], terms: Vec<(usize, Term)>) -> Self {
        let by_coef = covered.map(|coef| {
            terms
                .iter()
                .enumerate()
                .filter(|(_, (c, _))| *c == coef)
                .map(|(j, (_, t))| (j, *t))
                .collect()
        });
        Self {
            terms,
            covered,
            by_coef,
        }
    }
    pub(super) fn np(&self) -> usize {
        self.terms.len()
    }
    /// The parameters and terms of each parameter.
    pub(super) fn terms(&self) -> &[(usize, Term)] {
        &self.terms
    }
    /// The `(parameter, term)` pairs of coefficient `coef`.
    pub(super) fn of(&self, coef: usize) -> &[(usize, Term)] {
        match self.covered.iter().position(|c| *c == coef) {
            Some(i) => &self.by_coef[i],
            None => &[],
        }
    }
    /// With `t` added to `coef` (its parameter last, starting at 0).
    fn with(&self, coef: usize, t: Term, th: &[f64]) -> (Spec, Vec<f64>) {
        let mut terms = self.terms.clone();
        terms.push((coef, t));
        let mut th1 = th.to_vec();
        th1.push(0.0);
        (Spec::new(self.covered, terms), th1)
    }
}

/// What the model is run on.
pub(super) struct Plant<'a> {
    m: Measured<'a>,
    alpha_m: &'a [f64],
}

/// What the plants of both axes run on: the table, the aircraft, the measured outputs, and the
/// intersample model of every measured input ([`super::intersample`]).
pub(super) struct Measured<'a> {
    pub(super) table: &'a Table,
    pub(super) kin: &'a Kinematics,
    pub(super) ac: &'a Aircraft,
    pub(super) refs: &'a TermRefs,
    pub(super) j: Matrix3<f64>,
    pub(super) v_m: &'a [f64],
    /// Measured outputs per sample.
    pub(super) y_m: Vec<[f64; NY]>,
    path: Paths,
}

/// The spline curvatures ([`intersample::curvature`]) of every input the plants read between
/// samples, per manoeuvre.
struct Paths {
    signals: Vec<(Signal, Vec<f64>)>,
    v: Vec<f64>,
    qbar: Vec<f64>,
    rates: [Vec<f64>; 3],
    attitude: [Vec<f64>; 2],
    thrust_force: [Vec<f64>; 3],
    thrust_moment: [Vec<f64>; 3],
    aero_force: [Vec<f64>; 3],
    /// The surfaces whose rate signal is the derivative of their path: (surface, rate).
    rate_of: Vec<(Signal, Signal)>,
    h_s: f64,
}

/// One component of a series of vectors.
fn component(x: &[Vector3<f64>], i: usize) -> Vec<f64> {
    x.iter().map(|v| v[i]).collect()
}

impl<'a> Measured<'a> {
    /// The plant's measured side: `table` and its kinematics, the aircraft, the airspeed and the
    /// outputs, each input's path spline per manoeuvre of `pieces`.
    pub(super) fn new(
        table: &'a Table,
        kin: &'a Kinematics,
        (ac, refs, j): (&'a Aircraft, &'a TermRefs, Matrix3<f64>),
        v_m: &'a [f64],
        y_m: Vec<[f64; NY]>,
        pieces: &[(usize, usize)],
    ) -> Self {
        let cv = |x: &[f64]| intersample::curvature(x, pieces);
        let cv3 = |x: &[Vector3<f64>]| -> [Vec<f64>; 3] { core::array::from_fn(|i| cv(&component(x, i))) };
        let n = table.t_s.len();
        let h_s = (table.t_s[n - 1] - table.t_s[0]) / (n - 1).max(1) as f64;
        let rate_of = [
            (Signal::Elevator, Signal::ElevatorRate),
            (Signal::Aileron, Signal::AileronRate),
            (Signal::Rudder, Signal::RudderRate),
        ]
        .into_iter()
        .filter(|(s, r)| table.signals.contains_key(s) && table.signals.contains_key(r))
        .collect();
        let path = Paths {
            signals: table.signals.iter().map(|(s, x)| (*s, cv(x))).collect(),
            v: cv(v_m),
            qbar: cv(&kin.qbar_pa),
            rates: core::array::from_fn(|i| cv(&kin.rates_rad_s[i])),
            attitude: core::array::from_fn(|i| cv(&kin.attitude_rad[i])),
            thrust_force: cv3(&kin.thrust_force_n),
            thrust_moment: cv3(&kin.thrust_moment_nm),
            aero_force: cv3(&kin.aero_force_n),
            rate_of,
            h_s,
        };
        Measured {
            table,
            kin,
            ac,
            refs,
            j,
            v_m,
            y_m,
            path,
        }
    }

    /// The table's snapshot, the airspeed (at least 1 m/s) and `q̄` at sample `k` plus `fr`, each
    /// on its path; a surface's rate the derivative of the surface's path.
    pub(super) fn at(&self, k: usize, fr: f64) -> (Snapshot, f64, f64) {
        let mut s = self.table.snapshot(k, fr);
        let p = &self.path;
        if fr != 0.0 {
            for (sig, c) in &p.signals {
                s[sig.index()] = intersample::at(&self.table.signals[sig], c, k, fr);
            }
        }
        for (surface, rate) in &p.rate_of {
            let (x, c) = (&self.table.signals[surface], self.curv(*surface));
            s[rate.index()] = intersample::slope(x, c, k, fr, p.h_s);
        }
        (
            s,
            intersample::at(self.v_m, &p.v, k, fr).max(1.0),
            intersample::at(&self.kin.qbar_pa, &p.qbar, k, fr),
        )
    }

    fn curv(&self, sig: Signal) -> &[f64] {
        self.path
            .signals
            .iter()
            .find(|(s, _)| *s == sig)
            .map_or(&[], |(_, c)| c.as_slice())
    }

    /// A table signal on its path at sample `k` plus `fr`.
    pub(super) fn signal(&self, sig: Signal, x: &[f64], k: usize, fr: f64) -> f64 {
        intersample::at(x, self.curv(sig), k, fr)
    }

    /// Body rate `i` (p, q, r) on its path.
    pub(super) fn rate(&self, i: usize, k: usize, fr: f64) -> f64 {
        intersample::at(&self.kin.rates_rad_s[i], &self.path.rates[i], k, fr)
    }

    /// Attitude `i` (φ, θ) on its path.
    pub(super) fn attitude(&self, i: usize, k: usize, fr: f64) -> f64 {
        intersample::at(&self.kin.attitude_rad[i], &self.path.attitude[i], k, fr)
    }

    fn vector(x: &[Vector3<f64>], c: &[Vec<f64>; 3], k: usize, fr: f64) -> Vector3<f64> {
        if fr == 0.0 || k + 1 >= x.len() {
            return x[k];
        }
        let g = 1.0 - fr;
        let (a, b) = (g * g * g - g, fr * fr * fr - fr);
        x[k] + (x[k + 1] - x[k]) * fr + Vector3::from_fn(|i, _| c[i][k] * a + c[i][k + 1] * b)
    }

    /// The thrust force (body), N, on its path.
    pub(super) fn thrust_force(&self, k: usize, fr: f64) -> Vector3<f64> {
        Self::vector(&self.kin.thrust_force_n, &self.path.thrust_force, k, fr)
    }

    /// The thrust moment (body), N·m, on its path.
    pub(super) fn thrust_moment(&self, k: usize, fr: f64) -> Vector3<f64> {
        Self::vector(&self.kin.thrust_moment_nm, &self.path.thrust_moment, k, fr)
    }

    /// The measured aerodynamic force (body), N, on its path.
    pub(super) fn aero_force(&self, k: usize, fr: f64) -> Vector3<f64> {
        Self::vector(&self.kin.aero_force_n, &self.path.aero_force, k, fr)
    }
}

/// The model at one point: state derivative, outputs, the three coefficients.
#[derive(Debug, Clone, Copy)]
pub(super) struct Point<S> {
    pub(super) xdot: S,
    pub(super) y: [f64; NY],
    pub(super) coefs: [f64; 3],
}

/// `(∂f/∂θ, ∂h/∂θ)` at a fixed state: `NX × NP` and `NY × NP`.
pub(super) type ParamJacobian = (DMatrix<f64>, DMatrix<f64>);

/// One axis's equations for the output error: its states, its [`NY`] outputs and the three
/// coefficients it covers. The estimation, the σ, the held-out test and the candidate search are
/// the same for every axis ([`analyse_axis`]).
pub(super) trait Dynamics {
    /// The state vector.
    type State: Copy + AsRef<[f64]> + AsMut<[f64]>;
    /// The coefficients covered (indices into [`COEFFICIENTS`]).
    const COVERED: [usize; 3];
    /// The outputs' names.
    const OUTPUTS: [&'static str; NY];
    /// The outputs' units (for the noise note).
    const UNITS: [&'static str; NY];
    /// What is simulated and what is taken as measured, in words.
    const READING: &'static str;
    /// The simulated states, in words.
    const STATES: &'static str;
    /// When set, the simulation restarts from the measured state every this many seconds
    /// within a manoeuvre (`None`: once per manoeuvre).
    const RESTART_S: Option<f64>;
    /// The longest integration step, s: a sample interval is cut into equal RK4 sub-steps no
    /// longer than this (`f64::INFINITY`: one step per sample).
    const MAX_STEP_S: f64;
    /// The output a coefficient is judged on in the per-coefficient figures.
    fn primary_output(coef: usize) -> usize;
    /// Why a candidate cannot be tested by this path (`None`: it can).
    fn untestable(coef: usize, t: Term) -> Option<&'static str>;
    /// The model at state `x`, sample `k` plus `fr`; with `jac`, also `∂f/∂θ` and `∂h/∂θ` at
    /// fixed `x`.
    fn eval(
        &self,
        spec: &Spec,
        x: Self::State,
        k: usize,
        fr: f64,
        th: &[f64],
        jac: bool,
    ) -> Option<(Point<Self::State>, Option<ParamJacobian>)>;
    /// The measured state at sample `k` (a manoeuvre's start).
    fn x0(&self, k: usize) -> Self::State;
    /// Whether the simulated state is in the plausible range.
    fn plausible(&self, x: &Self::State) -> bool;
    /// What the plant runs on.
    fn measured(&self) -> &Measured<'_>;

    /// Measured outputs per sample.
    fn y_m(&self) -> &[[f64; NY]] {
        &self.measured().y_m
    }

    /// The time base, s.
    fn t_s(&self) -> &[f64] {
        &self.measured().table.t_s
    }

    /// `(∂f/∂x, ∂h/∂x)` by central differences.
    fn dx(&self, spec: &Spec, x: Self::State, k: usize, fr: f64, th: &[f64]) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
        let nx = x.as_ref().len();
        let mut a = DMatrix::<f64>::zeros(nx, nx);
        let mut c = DMatrix::<f64>::zeros(NY, nx);
        for i in 0..nx {
            let h = 1e-6 * x.as_ref()[i].abs().max(0.1);
            let (mut xp, mut xm) = (x, x);
            xp.as_mut()[i] += h;
            xm.as_mut()[i] -= h;
            let (up, _) = self.eval(spec, xp, k, fr, th, false)?;
            let (dn, _) = self.eval(spec, xm, k, fr, th, false)?;
            for r in 0..nx {
                a[(r, i)] = (up.xdot.as_ref()[r] - dn.xdot.as_ref()[r]) / (2.0 * h);
            }
            for r in 0..NY {
                c[(r, i)] = (up.y[r] - dn.y[r]) / (2.0 * h);
            }
        }
        Some((a, c))
    }

    /// The simulation of every manoeuvre with `θ`: outputs, coefficients and (with `sens`) the
    /// output sensitivities. With a `gain` `K` (`NX × NY`) it is the filter error method's
    /// one-step prediction instead: at every sample the state is corrected by the innovation,
    /// `x̂ = x̂⁻ + K(y − ŷ⁻)`, and, the gain held fixed, its sensitivity `S = S⁻ − K ∂ŷ⁻/∂θ`
    /// (Jategaonkar 2015, eq. 5.17–5.21 with a steady-state gain); the outputs are the
    /// predictions `ŷ⁻`. `None` when the simulation leaves the plausible range or a term is
    /// unavailable.
    fn run(
        &self,
        spec: &Spec,
        th: &[f64],
        pieces: &[(usize, usize)],
        sens: bool,
        gain: Option<&DMatrix<f64>>,
    ) -> Option<Run> {
        let sim = Simulation {
            plant: self,
            spec,
            th,
            sens,
        };
        let mut out = Run::zeros(self.y_m().len(), spec.np(), sens);
        for &piece in pieces {
            sim.piece(piece, gain, &mut out)?;
        }
        Some(out)
    }

    /// Measured minus simulated outputs.
    fn residuals(&self, run: &Run) -> Vec<[f64; NY]> {
        self.y_m()
            .iter()
            .zip(&run.yhat)
            .map(|(m, p)| core::array::from_fn(|i| m[i] - p[i]))
            .collect()
    }
}

fn dot(terms: &[(usize, Term)], th: &[f64], s: &Snapshot, refs: &TermRefs) -> Option<f64> {
    terms.iter().map(|(j, t)| t.eval(s, refs).map(|v| v * th[*j])).sum()
}

impl Dynamics for Plant<'_> {
    type State = [f64; 2];
    const COVERED: [usize; 3] = COVERED;
    const OUTPUTS: [&'static str; NY] = OUTPUT_NAMES;
    const UNITS: [&'static str; NY] = ["rad", "rad/s", "m/s²", "m/s²"];
    const STATES: &'static str = "α, q";
    const RESTART_S: Option<f64> = None;
    const MAX_STEP_S: f64 = f64::INFINITY;
    const READING: &'static str =
        "α and q simulated from each manoeuvre's first sample, V, β, attitude, p, r, surfaces and thrust as measured";

    fn primary_output(coef: usize) -> usize {
        primary_output(coef)
    }

    fn untestable(coef: usize, t: Term) -> Option<&'static str> {
        (coef == 0 && t == Term::AlphaDot)
            .then_some("not tested by output error: α̇ in C_L makes the α equation implicit")
    }

    fn x0(&self, k: usize) -> [f64; 2] {
        [self.alpha_m[k], self.m.y_m[k][1]]
    }

    fn plausible(&self, x: &[f64; 2]) -> bool {
        x[0].is_finite() && x[1].is_finite() && x[0].abs() < 1.2 && x[1].abs() < 20.0
    }

    fn measured(&self) -> &Measured<'_> {
        &self.m
    }

    /// The model at state `x`, sample `k` plus `fr`; with `jac`, also `∂f/∂θ` (2 × NP) and
    /// `∂h/∂θ` (NY × NP) at fixed `x`.
    fn eval(
        &self,
        spec: &Spec,
        x: [f64; 2],
        k: usize,
        fr: f64,
        th: &[f64],
        jac: bool,
    ) -> Option<(Point<[f64; 2]>, Option<ParamJacobian>)> {
        let (pt, at) = self.point(spec, x, k, fr, th)?;
        if !jac {
            return Some((pt, None));
        }
        Some((pt, Some(self.param_jacobian(spec, th, &at)?)))
    }
}

/// What the parameter Jacobian needs of one evaluation of the longitudinal model.
struct Evaluated {
    /// The table's snapshot with the simulated α and `q_n`, the model's `C_L` and `α̇ c̄/(2V)`.
    s: Snapshot,
    cl: f64,
    /// `α̇ c̄/(2V)`.
    alpha_dot_n: f64,
    /// `c̄/(2V)`.
    cn: f64,
    sin_alpha: f64,
    cos_alpha: f64,
    /// `∂α̇/∂C_L = −q̄S/(m V cos β)`.
    k_l: f64,
    /// `∂q̇/∂C_m = q̄S c̄/I_y`.
    k_m: f64,
    /// `q̄S/m`, the aerodynamic specific force per unit coefficient.
    k_f: f64,
}

impl Plant<'_> {
    /// The state derivative `[α̇, q̇]`, the outputs and the coefficients at state `x`, sample
    /// `k` plus `fr` (the module's equations), with what the parameter Jacobian needs.
    fn point(&self, spec: &Spec, x: [f64; 2], k: usize, fr: f64, th: &[f64]) -> Option<(Point<[f64; 2]>, Evaluated)> {
        let (ac, refs) = (self.m.ac, self.m.refs);
        let (area, chord, mass) = (ac.wing_area_m2, ac.chord_m, ac.mass_kg);
        let (mut s, v, qbar) = self.m.at(k, fr);
        let (al, q) = (x[0], x[1]);
        let cn = chord / (2.0 * v);
        s[Signal::Alpha.index()] = al;
        s[Signal::QN.index()] = q * cn;
        let b = s[Signal::Beta.index()];
        let beta = if b.is_nan() { 0.0 } else { b };
        let (tl, td, tm) = (spec.of(0), spec.of(1), spec.of(4));
        let cl = dot(tl, th, &s, refs)?;
        s[Signal::LiftCoeff.index()] = cl;
        let (p, r) = (self.m.rate(0, k, fr), self.m.rate(2, k, fr));
        let (_, cf) = sin_cos(self.m.attitude(0, k, fr));
        let (st, ct) = sin_cos(self.m.attitude(1, k, fr));
        let (sa, ca) = sin_cos(al);
        let (sb, cb) = sin_cos(beta);
        let ft = self.m.thrust_force(k, fr);
        let vcb = v * cb.max(0.1);
        let k_l = -qbar * area / (mass * vcb);
        let a0 = q
            + (-v * sb * (p * ca + r * sa) + (ca * ft.z - sa * ft.x) / mass + G_MPS2 * (ca * ct * cf + sa * st)) / vcb;
        let alpha_dot = a0 + k_l * cl;
        s[Signal::AlphaDotN.index()] = alpha_dot * cn;
        let cd = dot(td, th, &s, refs)?;
        let cm = dot(tm, th, &s, refs)?;
        let iy = self.m.j[(1, 1)];
        let om = Vector3::new(p, q, r);
        let fa_m = self.m.aero_force(k, fr);
        let k_m = qbar * area * chord / iy;
        let qdot = k_m * cm
            + (ac.moment_reference_m.cross(&fa_m).y + self.m.thrust_moment(k, fr).y - om.cross(&(self.m.j * om)).y)
                / iy;
        let k_f = qbar * area / mass;
        let y = [al, q, k_f * (-cd * ca + cl * sa), k_f * (-cd * sa - cl * ca)];
        let pt = Point {
            xdot: [alpha_dot, qdot],
            y,
            coefs: [cl, cd, cm],
        };
        let at = Evaluated {
            s,
            cl,
            alpha_dot_n: alpha_dot * cn,
            cn,
            sin_alpha: sa,
            cos_alpha: ca,
            k_l,
            k_m,
            k_f,
        };
        Some((pt, at))
    }

    /// `∂f/∂θ` (2 × NP) and `∂h/∂θ` (NY × NP) at a fixed state, from the evaluation `at`.
    fn param_jacobian(&self, spec: &Spec, th: &[f64], at: &Evaluated) -> Option<ParamJacobian> {
        let refs = self.m.refs;
        let (td, tm) = (spec.of(1), spec.of(4));
        let (s, cl, cn, sa, ca) = (at.s, at.cl, at.cn, at.sin_alpha, at.cos_alpha);
        let np = spec.np();
        // Direct term values per parameter.
        let mut val = DVector::<f64>::zeros(np);
        for (j, (_, t)) in spec.terms.iter().enumerate() {
            val[j] = t.eval(&s, refs)?;
        }
        // C_D and C_m may depend on C_L (through C_L²) and on α̇: their partial derivatives by
        // central differences of the snapshot's entries.
        let partial = |terms: &[(usize, Term)], sig: Signal, at: f64| -> Option<f64> {
            let h = 1e-6 * at.abs().max(1.0);
            let mut sp = s;
            sp[sig.index()] = at + h;
            let up = dot(terms, th, &sp, refs)?;
            sp[sig.index()] = at - h;
            let dn = dot(terms, th, &sp, refs)?;
            Some((up - dn) / (2.0 * h))
        };
        let ad_n = at.alpha_dot_n;
        let (dcd_dcl, dcd_dad) = (
            partial(td, Signal::LiftCoeff, cl)?,
            partial(td, Signal::AlphaDotN, ad_n)?,
        );
        let (dcm_dcl, dcm_dad) = (
            partial(tm, Signal::LiftCoeff, cl)?,
            partial(tm, Signal::AlphaDotN, ad_n)?,
        );
        let mask = |coef: usize| DVector::<f64>::from_fn(np, |j, _| if spec.terms[j].0 == coef { val[j] } else { 0.0 });
        let dcl = mask(0);
        let dad = &dcl * at.k_l;
        let dcd = mask(1) + &dcl * dcd_dcl + &dad * (dcd_dad * cn);
        let dcm = mask(4) + &dcl * dcm_dcl + &dad * (dcm_dad * cn);
        let mut g = DMatrix::<f64>::zeros(2, np);
        g.set_row(0, &dad.transpose());
        g.set_row(1, &(&dcm * at.k_m).transpose());
        let mut d = DMatrix::<f64>::zeros(NY, np);
        d.set_row(2, &((&dcd * (-ca) + &dcl * sa) * at.k_f).transpose());
        d.set_row(3, &((&dcd * (-sa) - &dcl * ca) * at.k_f).transpose());
        Some((g, d))
    }
}

/// One simulation.
#[derive(Debug, Clone)]
pub(super) struct Run {
    yhat: Vec<[f64; NY]>,
    coefs: Vec<[f64; 3]>,
    /// `∂ŷ_k/∂θ` (empty without sensitivities).
    h: Vec<DMatrix<f64>>,
}

impl Run {
    /// Zero outputs and coefficients for `n` samples, and zero sensitivities of `np` parameters
    /// when `sens`.
    fn zeros(n: usize, np: usize, sens: bool) -> Self {
        Self {
            yhat: vec![[0.0; NY]; n],
            coefs: vec![[0.0; 3]; n],
            h: if sens {
                vec![DMatrix::zeros(NY, np); n]
            } else {
                Vec::new()
            },
        }
    }
}

/// A state derivative and, with sensitivities, the sensitivity's derivative `Ṡ`.
type Derivative<S> = (S, Option<DMatrix<f64>>);

/// What [`Dynamics::run`] integrates: the plant, the model and its parameters, and whether the
/// output sensitivities are carried beside the states.
struct Simulation<'a, D: Dynamics + ?Sized> {
    plant: &'a D,
    spec: &'a Spec,
    th: &'a [f64],
    sens: bool,
}

impl<D: Dynamics + ?Sized> Simulation<'_, D> {
    /// One manoeuvre, samples `a..b`, from its measured first sample: per sample the outputs
    /// (and their sensitivities), with a `gain` the filter's correction, then the step to the
    /// next sample. `None` when the state leaves the plausible range or a term is unavailable.
    fn piece(&self, (a, b): (usize, usize), gain: Option<&DMatrix<f64>>, out: &mut Run) -> Option<()> {
        let mut x = self.plant.x0(a);
        let nx = x.as_ref().len();
        let mut sm = DMatrix::<f64>::zeros(nx, self.spec.np());
        for k in a..b {
            if !self.plant.plausible(&x) {
                return None;
            }
            // Stage 1 of the step shares its point with the output at k.
            let mut first = Some(self.output(x, &sm, k, out)?);
            if let Some(kg) = gain {
                self.correct(kg, k, out, &mut x, &mut sm);
                if !self.plant.plausible(&x) {
                    return None;
                }
                // The first stage is taken again at the corrected state.
                first = None;
            }
            if k + 1 == b {
                break;
            }
            self.step(k, first, &mut x, &mut sm)?;
        }
        Some(())
    }

    /// The outputs, coefficients and (with sensitivities) `∂ŷ_k/∂θ = (∂h/∂x) S + ∂h/∂θ` at
    /// sample `k`, written into `out`; returns the first RK4 stage of the step from `k`.
    fn output(&self, x: D::State, sm: &DMatrix<f64>, k: usize, out: &mut Run) -> Option<Derivative<D::State>> {
        let (spec, th) = (self.spec, self.th);
        let (pt, jac) = self.plant.eval(spec, x, k, 0.0, th, self.sens)?;
        out.yhat[k] = pt.y;
        out.coefs[k] = pt.coefs;
        let stage1 = if self.sens {
            let (g, d) = jac?;
            let (a_x, c_x) = self.plant.dx(spec, x, k, 0.0, th)?;
            out.h[k] = &c_x * sm + d;
            Some(&a_x * sm + g)
        } else {
            None
        };
        Some((pt.xdot, stage1))
    }

    /// The filter's correction at sample `k`, the gain held fixed: `x̂ = x̂⁻ + K(y − ŷ⁻)` and
    /// `S = S⁻ − K ∂ŷ⁻/∂θ`.
    fn correct(&self, kg: &DMatrix<f64>, k: usize, out: &Run, x: &mut D::State, sm: &mut DMatrix<f64>) {
        let innovation = DVector::from_fn(NY, |i, _| self.plant.y_m()[k][i] - out.yhat[k][i]);
        let dx = kg * innovation;
        for (xi, d) in x.as_mut().iter_mut().zip(dx.iter()) {
            *xi += d;
        }
        if self.sens {
            *sm -= kg * &out.h[k];
        }
    }

    /// The state derivative and `Ṡ = (∂f/∂x) S + ∂f/∂θ` at state `xs`, sensitivity `ss`, sample
    /// `k` plus `fr`.
    fn derivative(&self, xs: D::State, ss: &DMatrix<f64>, k: usize, fr: f64) -> Option<Derivative<D::State>> {
        let (p, j) = self.plant.eval(self.spec, xs, k, fr, self.th, self.sens)?;
        let sd = match j {
            Some((g, _)) => {
                let (a_x, _) = self.plant.dx(self.spec, xs, k, fr, self.th)?;
                Some(&a_x * ss + g)
            }
            None => None,
        };
        Some((p.xdot, sd))
    }

    /// The RK4 step of state and sensitivity from sample `k` to `k + 1`, in equal sub-steps of at
    /// most [`Dynamics::MAX_STEP_S`] (the inputs interpolated at their fractions); `first` is the
    /// first stage when the output already took it.
    fn step(
        &self,
        k: usize,
        mut first: Option<Derivative<D::State>>,
        x: &mut D::State,
        sm: &mut DMatrix<f64>,
    ) -> Option<()> {
        let t_s = self.plant.t_s();
        let hs = t_s[k + 1] - t_s[k];
        let m = ((hs / D::MAX_STEP_S).ceil() as usize).max(1);
        let hm = hs / m as f64;
        for j in 0..m {
            let f0 = j as f64 / m as f64;
            let (k1, s1) = match first.take() {
                Some(st) => st,
                None => self.derivative(*x, sm, k, f0)?,
            };
            let fh = f0 + 0.5 / m as f64;
            let f1 = (j + 1) as f64 / m as f64;
            let (k2, s2) = self.derivative(advanced(x, &k1, hm / 2.0), &advanced_sens(sm, &s1, hm / 2.0), k, fh)?;
            let (k3, s3) = self.derivative(advanced(x, &k2, hm / 2.0), &advanced_sens(sm, &s2, hm / 2.0), k, fh)?;
            let (k4, s4) = self.derivative(advanced(x, &k3, hm), &advanced_sens(sm, &s3, hm), k, f1)?;
            for i in 0..x.as_ref().len() {
                x.as_mut()[i] +=
                    hm / 6.0 * (k1.as_ref()[i] + 2.0 * k2.as_ref()[i] + 2.0 * k3.as_ref()[i] + k4.as_ref()[i]);
            }
            if let (Some(s1), Some(s2), Some(s3), Some(s4)) = (s1, s2, s3, s4) {
                *sm += (s1 + (s2 + s3) * 2.0 + s4) * (hm / 6.0);
            }
        }
        Some(())
    }
}

/// `x + h·d`, component by component.
fn advanced<S: Copy + AsRef<[f64]> + AsMut<[f64]>>(x: &S, d: &S, h: f64) -> S {
    let mut o = *x;
    for (o, d) in o.as_mut().iter_mut().zip(d.as_ref()) {
        *o += h * d;
    }
    o
}

/// `S + h·Ṡ`; `S` itself without sensitivities.
fn advanced_sens(s: &DMatrix<f64>, d: &Option<DMatrix<f64>>, h: f64) -> DMatrix<f64> {
    match d {
        Some(d) => s + d * h,
        None => s.clone(),
    }
}

/// A Gauss–Newton iterate: the parameters, their simulation and its residuals.
struct Iterate {
    th: Vec<f64>,
    run: Run,
    e: Vec<[f64; NY]>,
}

/// A converged fit.
#[derive(Debug, Clone)]
struct Fit {
    spec: Spec,
    th: Vec<f64>,
    run: Run,
    e: Vec<[f64; NY]>,
    /// `Σ HᵀWH`.
    m: DMatrix<f64>,
    /// `Σ HᵀWe`.
    g: DVector<f64>,
    /// Output weights `1/R`.
    w: [f64; NY],
    /// Block-sandwich σ (never below the Cramér–Rao bound).
    sigma: Vec<f64>,
    /// Cramér–Rao σ.
    sigma_crb: Vec<f64>,
    converged: bool,
}

fn cost(e: &[[f64; NY]], w: &[f64; NY]) -> f64 {
    e.iter().map(|r| (0..NY).map(|i| w[i] * r[i] * r[i]).sum::<f64>()).sum()
}

/// The residuals' mean square per output (floored).
pub(super) fn noise_of(e: &[[f64; NY]]) -> [f64; NY] {
    let n = e.len().max(1) as f64;
    core::array::from_fn(|i| (e.iter().map(|r| r[i] * r[i]).sum::<f64>() / n).max(1e-18))
}

/// `(Σ HᵀWH, Σ HᵀWe)` over the samples of `ranges`.
fn normal(
    run: &Run,
    e: &[[f64; NY]],
    w: &[f64; NY],
    ranges: &[(usize, usize)],
    np: usize,
) -> (DMatrix<f64>, DVector<f64>) {
    let mut m = DMatrix::<f64>::zeros(np, np);
    let mut g = DVector::<f64>::zeros(np);
    let wm = DMatrix::<f64>::from_diagonal(&DVector::from_column_slice(w));
    for &(a, b) in ranges {
        for k in a..b {
            let h = &run.h[k];
            let hw = h.transpose() * &wm;
            m += &hw * h;
            g += &hw * DVector::from_column_slice(&e[k]);
        }
    }
    (m, g)
}

/// The block sandwich σ of an output-error fit (module doc, "Uncertainty"): `M⁻¹ (Σ_b s̃_b s̃_bᵀ) M⁻¹`
/// with each block's score `s_b = Σ_{k∈b} HᵀWe_k` bias-reduced as CR2 does for clusters
/// ([`super::regress::cr2_score`]: `s̃_b = L(I − L⁻¹M_bL⁻ᵀ)^{−1/2}L⁻¹s_b`, `M = LLᵀ`): at the estimate
/// the residual of a block is partly absorbed by the fit, in proportion to the block's share of
/// the information, which biases the plain block sum low. `None` when `M` is not positive
/// definite or a block carries a direction alone (the caller then states the Cramér–Rao bound).
fn block_sandwich_sigma(
    run: &Run,
    e: &[[f64; NY]],
    w: &[f64; NY],
    m: &DMatrix<f64>,
    inv: &DMatrix<f64>,
    blocks: &[(usize, usize)],
) -> Option<Vec<f64>> {
    let np = m.nrows();
    let l = m.clone().cholesky()?.l();
    let mut meat = DMatrix::<f64>::zeros(np, np);
    for &blk in blocks {
        let (m_b, s_b) = normal(run, e, w, &[blk], np);
        let s = super::regress::cr2_score(&l, &m_b, &s_b)?;
        meat += &s * s.transpose();
    }
    let sw = inv * meat * inv;
    Some((0..np).map(|j| sw[(j, j)].max(0.0).sqrt()).collect())
}

/// An axis's plant with the manoeuvres, the sandwich blocks and the held-out folds.
pub(super) struct Setup<D> {
    pub(super) plant: D,
    /// The simulated pieces (each starting from the measured state).
    pub(super) pieces: Vec<(usize, usize)>,
    /// Sandwich blocks.
    sandwich: Vec<(usize, usize)>,
    /// Held-out blocks and their fold.
    blocks: Vec<(usize, usize)>,
    fold: Vec<usize>,
    folds: usize,
    /// How the folds were formed, in words.
    fold_note: String,
    /// The filter error method's steady-state gain (`NX × NY`); `None`: output error.
    gain: Option<DMatrix<f64>>,
    /// With the filter error method, per fold the gain tuned without that fold's data: the
    /// filter that predicts the fold in the held-out test (`low_rate_fem.rs`).
    fold_gains: Vec<DMatrix<f64>>,
}

impl<D: Dynamics> Setup<D> {
    /// Gauss–Newton from `th0` with the output weights `w`.
    fn fit(&self, spec: &Spec, th0: Vec<f64>, w: [f64; NY]) -> Result<Fit, String> {
        let np = spec.np();
        let all = [(0, self.plant.y_m().len())];
        let (Iterate { th, run, e }, converged) = self.gauss_newton(spec, th0, &w)?;
        let (m, g) = normal(&run, &e, &w, &all, np);
        let inv = m
            .clone()
            .cholesky()
            .ok_or("the parameters are not identifiable from this flight (singular information matrix)")?
            .inverse();
        let sigma_crb: Vec<f64> = (0..np).map(|j| inv[(j, j)].max(0.0).sqrt()).collect();
        let sigma = block_sandwich_sigma(&run, &e, &w, &m, &inv, &self.sandwich).unwrap_or_else(|| sigma_crb.clone());
        Ok(Fit {
            spec: spec.clone(),
            th,
            run,
            e,
            m,
            g,
            w,
            sigma,
            sigma_crb,
            converged,
        })
    }

    /// Gauss–Newton on `J(θ)` from `th0`: the last accepted iterate and whether it converged
    /// (every parameter moved by less than [`TOLERANCE_SIGMA`] σ, or a step that no halving
    /// could make lower `J` after moving by less than 1 σ).
    fn gauss_newton(&self, spec: &Spec, th0: Vec<f64>, w: &[f64; NY]) -> Result<(Iterate, bool), String> {
        let np = spec.np();
        let all = [(0, self.plant.y_m().len())];
        let run = self
            .plant
            .run(spec, &th0, &self.pieces, true, self.gain.as_ref())
            .ok_or("the simulation with the starting values leaves the plausible range")?;
        let e = self.plant.residuals(&run);
        let mut it = Iterate { th: th0, run, e };
        let mut converged = false;
        for _ in 0..MAX_ITERATIONS {
            let (m, g) = normal(&it.run, &it.e, w, &all, np);
            let Some(ch) = m.clone().cholesky() else {
                return Err(
                    "the parameters are not identifiable from this flight (singular information matrix)".into(),
                );
            };
            let delta = ch.solve(&g);
            let inv_diag = ch.inverse().diagonal();
            let (step, accepted) = self.line_search(spec, &delta, w, &mut it);
            let moved = (0..np)
                .map(|j| (step * delta[j]).abs() / inv_diag[j].max(f64::MIN_POSITIVE).sqrt())
                .fold(0.0, f64::max);
            if !accepted || moved < TOLERANCE_SIGMA {
                converged = accepted || moved < 1.0;
                break;
            }
        }
        Ok((it, converged))
    }

    /// The Gauss–Newton step `delta` from `it`, halved until it lowers `J` (at most 8 tries):
    /// `it` moved there, and the step's fraction and whether it was accepted.
    fn line_search(&self, spec: &Spec, delta: &DVector<f64>, w: &[f64; NY], it: &mut Iterate) -> (f64, bool) {
        let c0 = cost(&it.e, w);
        let mut step = 1.0;
        for _ in 0..8 {
            let th1: Vec<f64> = it.th.iter().zip(delta.iter()).map(|(t, d)| t + step * d).collect();
            if let Some(r1) = self.plant.run(spec, &th1, &self.pieces, true, self.gain.as_ref()) {
                let e1 = self.plant.residuals(&r1);
                if cost(&e1, w) <= c0 {
                    *it = Iterate {
                        th: th1,
                        run: r1,
                        e: e1,
                    };
                    return (step, true);
                }
            }
            step *= 0.5;
        }
        (step, false)
    }

    /// The sample interval, s (the mean over the record).
    pub(super) fn step_s(&self) -> f64 {
        match self.plant.t_s() {
            [first, .., last] => (last - first) / (self.plant.t_s().len() - 1) as f64,
            _ => f64::NAN,
        }
    }

    /// Runs the filter error method from now on: the steady-state gain `k` (`NX × NY`) for the
    /// estimation, and `fold_gains`, one per fold, tuned without that fold, for the held-out test.
    pub(super) fn set_gain(&mut self, k: DMatrix<f64>, fold_gains: Vec<DMatrix<f64>>) {
        self.gain = Some(k);
        self.fold_gains = fold_gains;
    }

    /// The number of held-out folds.
    pub(super) fn folds(&self) -> usize {
        self.folds
    }

    /// The sample ranges of the blocks of fold `fold` (`held_out == true`) or of all the other
    /// folds (the identification data when `fold` is held out).
    pub(super) fn fold_ranges(&self, fold: usize, held_out: bool) -> Vec<(usize, usize)> {
        self.blocks
            .iter()
            .zip(&self.fold)
            .filter(|(_, &k)| (k == fold) == held_out)
            .map(|(b, _)| *b)
            .collect()
    }

    /// The output-error baseline `base` refitted without fold `fold` (one Gauss–Newton step on
    /// the other folds' data, as the held-out test does) and its residuals over the record;
    /// `None` when the fold leaves the parameters unidentifiable or the simulation fails.
    pub(super) fn without_fold(&self, base: &OutputErrorBaseline, fold: usize) -> Option<(Vec<f64>, Residuals)> {
        let f = &base.fit;
        let (mf, gf) = normal(&f.run, &f.e, &f.w, &self.fold_ranges(fold, true), f.spec.np());
        let delta = (&f.m - mf).cholesky()?.solve(&(&f.g - gf));
        let th: Vec<f64> = f.th.iter().zip(delta.iter()).map(|(t, d)| t + d).collect();
        let run = self.plant.run(&f.spec, &th, &self.pieces, false, None)?;
        Some((th, self.plant.residuals(&run)))
    }

    /// The method that runs, in words.
    fn method(&self) -> &'static str {
        if self.gain.is_some() {
            "filter error"
        } else {
            "output error"
        }
    }

    /// The innovations (measured minus one-step predicted outputs) of the filter with gain `k`
    /// at `θ`; `None` when the filtered simulation leaves the plausible range.
    pub(super) fn innovations(&self, spec: &Spec, th: &[f64], k: &DMatrix<f64>) -> Option<Vec<[f64; NY]>> {
        let run = self.plant.run(spec, th, &self.pieces, false, Some(k))?;
        Some(self.plant.residuals(&run))
    }

    /// `(∂f/∂x, ∂h/∂x)` at `θ` averaged over the samples of `ranges` at the measured states (up
    /// to about 200 evenly spaced samples): the linearisation of the steady-state filter. `None`
    /// when no sample gives both.
    pub(super) fn mean_jacobians(
        &self,
        spec: &Spec,
        th: &[f64],
        ranges: &[(usize, usize)],
    ) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
        let n: usize = ranges.iter().map(|(a, b)| b - a).sum();
        let mut sum: Option<(DMatrix<f64>, DMatrix<f64>)> = None;
        let mut count = 0.0;
        let samples = ranges.iter().flat_map(|&(a, b)| a..b);
        for k in samples.step_by((n / 200).max(1)) {
            let x = self.plant.x0(k);
            if !self.plant.plausible(&x) {
                continue;
            }
            let Some((a, c)) = self.plant.dx(spec, x, k, 0.0, th) else {
                continue;
            };
            sum = Some(match sum {
                Some((sa, sc)) => (sa + a, sc + c),
                None => (a, c),
            });
            count += 1.0;
        }
        sum.map(|(a, c)| (a / count, c / count))
    }

    /// The baseline fit with the noise relaxation.
    fn fit_relaxed(&self, spec: &Spec, th0: Vec<f64>) -> Result<Fit, String> {
        let run = self
            .plant
            .run(spec, &th0, &self.pieces, false, self.gain.as_ref())
            .ok_or("the simulation with the equation-error starting values leaves the plausible range")?;
        let mut r = noise_of(&self.plant.residuals(&run));
        let mut fit = self.fit(spec, th0, r.map(|x| 1.0 / x))?;
        for _ in 0..NOISE_ROUNDS {
            let r1 = noise_of(&fit.e);
            let change = (0..NY).map(|i| (r1[i] / r[i] - 1.0).abs()).fold(0.0, f64::max);
            r = r1;
            if change < 0.01 {
                break;
            }
            fit = self.fit(spec, fit.th.clone(), r.map(|x| 1.0 / x))?;
        }
        Ok(fit)
    }

    /// Held-out residuals per block (linearised leave-fold-out), scaled by `√w`.
    fn held_out(&self, f: &Fit) -> Option<HeldOut> {
        let np = f.spec.np();
        let all = [(0, self.plant.y_m().len())];
        let mut out = vec![Vec::new(); self.blocks.len()];
        for fold in 0..self.folds {
            let ranges = self.fold_ranges(fold, true);
            if ranges.is_empty() {
                continue;
            }
            // With the filter error method the fold is predicted by the filter tuned without it:
            // the innovations and sensitivities of that filter at the fit's θ.
            let own;
            let (run, e, m, g) = match self.fold_gains.get(fold) {
                Some(k) => {
                    let run = self.plant.run(&f.spec, &f.th, &self.pieces, true, Some(k))?;
                    let e = self.plant.residuals(&run);
                    let (m, g) = normal(&run, &e, &f.w, &all, np);
                    own = (run, e, m, g);
                    (&own.0, &own.1, &own.2, &own.3)
                }
                None => (&f.run, &f.e, &f.m, &f.g),
            };
            let (mf, gf) = normal(run, e, &f.w, &ranges, np);
            let delta = (m - mf).cholesky()?.solve(&(g - gf));
            for (bi, (&(a, b), &k)) in self.blocks.iter().zip(&self.fold).enumerate() {
                if k != fold {
                    continue;
                }
                out[bi] = (a..b)
                    .map(|s| {
                        let pred = &run.h[s] * &delta;
                        core::array::from_fn(|i| (e[s][i] - pred[i]) * f.w[i].sqrt())
                    })
                    .collect();
            }
        }
        Some(out)
    }
}

/// The held-out comparison of model 1 against model 0 (both scaled by model 0's weights).
struct Comparison {
    /// Noise-referenced gain `T`.
    t: f64,
    /// Sign-flip `z` and the relative gain ([`select::gain`]).
    z: f64,
    rel: f64,
}

fn compare(h0: &[Vec<[f64; NY]>], h1: &[Vec<[f64; NY]>]) -> Comparison {
    let sse = |h: &[Vec<[f64; NY]>], i: Option<usize>| -> Vec<f64> {
        h.iter()
            .map(|b| {
                b.iter()
                    .map(|r| match i {
                        Some(i) => r[i] * r[i],
                        None => r.iter().map(|x| x * x).sum(),
                    })
                    .sum()
            })
            .collect()
    };
    let (z, rel) = select::gain(&sse(h0, None), &sse(h1, None));
    let (mut sum, mut var) = (0.0, 0.0);
    for i in 0..NY {
        let (s0, s1) = (sse(h0, Some(i)), sse(h1, Some(i)));
        let delta: Vec<Vec<f64>> = h0
            .iter()
            .zip(h1)
            .map(|(b0, b1)| b0.iter().zip(b1).map(|(r0, r1)| r0[i] - r1[i]).collect())
            .collect();
        let resid: Vec<Vec<f64>> = h1.iter().map(|b| b.iter().map(|r| r[i]).collect()).collect();
        let t_i = select::noise_referenced_gain(&delta, &resid, &s0, &s1);
        let s_i: f64 = s0.iter().zip(&s1).map(|(a, b)| a - b).sum();
        if t_i != 0.0 && s_i != 0.0 {
            sum += s_i;
            var += (s_i / t_i).powi(2);
        }
    }
    Comparison {
        t: if var > 0.0 { sum / var.sqrt() } else { 0.0 },
        z,
        rel,
    }
}

/// Held-out residuals per block, scaled by `√w`.
type HeldOut = Vec<Vec<[f64; NY]>>;

/// A candidate's score, with its fit, held-out residuals and likelihood gain when scored.
type Scored = (CandidateScore, Option<(Fit, HeldOut, f64)>);

/// Per coefficient: its first-round candidates, the terms added, notes, and the surface delays
/// not decided at this rate (each with its reason).
type CoefficientResult = (usize, Vec<CandidateScore>, Vec<Added>, Vec<String>, Vec<String>);

/// What the low-rate path found: the covered coefficients' analyses and the notes.
#[derive(Debug, Clone)]
pub struct LowRate {
    /// The coefficients analysed (`C_L`, `C_D`, `C_m`, `C_Y`, `C_l`, `C_n`: those the data allow).
    pub coefficients: Vec<CoefficientGap>,
    /// Their indices into [`COEFFICIENTS`].
    pub covered: Vec<usize>,
    /// What was done, in words.
    pub notes: Vec<String>,
}

/// Everything the path needs from the analysis.
pub struct Inputs<'a> {
    /// The corrected, synthesised table.
    pub table: &'a Table,
    /// The aircraft.
    pub aircraft: &'a Aircraft,
    /// The terms' references.
    pub refs: &'a TermRefs,
    /// Baseline terms per coefficient.
    pub baselines: &'a [Vec<Term>; 6],
    /// The manoeuvres (sample ranges).
    pub pieces: &'a [(usize, usize)],
    /// Samples of the identification segment.
    pub n_id: usize,
    /// The `t²` threshold.
    pub threshold_t2: f64,
    /// The number of blocks the threshold was set for (its Student's t has one fewer degrees of
    /// freedom), reported with it.
    pub threshold_blocks: usize,
    /// Cross-validation settings.
    pub cv: CvSettings,
    /// Sandwich block length, s.
    pub max_lag_s: f64,
    /// How the flight's samples were formed: why a surface delay within half an interval is not
    /// decided ([`intersample::why_unresolved`]).
    pub sampling: Sampling,
}

/// The longitudinal plant, the manoeuvres, the sandwich blocks and the folds of `inp`; `Err` says
/// why the path cannot run on these data.
pub(super) fn setup<'a>(inp: &Inputs<'a>) -> Result<Setup<Plant<'a>>, String> {
    let table = inp.table;
    let kin = table.kinematics.as_ref().ok_or("no coefficient could be synthesised")?;
    let (alpha_m, v_m) = match (table.signals.get(&Signal::Alpha), table.signals.get(&Signal::Airspeed)) {
        (Some(a), Some(v)) => (a, v),
        _ => return Err("no α or airspeed".into()),
    };
    if COVERED.iter().any(|&c| table.z[c].is_none()) || !table.signals.contains_key(&Signal::QN) {
        return Err("C_L, C_D and C_m need α, the airspeed, the pitch rate and the x and z accelerometers".into());
    }
    if !kin.attitude_measured {
        return Err("no attitude for the gravity terms of α̇".into());
    }
    let j = inertia(inp.aircraft);
    if j[(1, 1)] <= 0.0 {
        return Err("no pitch inertia Iy in the aircraft file".into());
    }
    let n = table.t_s.len();
    let mass = inp.aircraft.mass_kg;
    let y_m: Vec<[f64; NY]> = (0..n)
        .map(|k| {
            [
                alpha_m[k],
                kin.rates_rad_s[1][k],
                kin.aero_force_n[k].x / mass,
                kin.aero_force_n[k].z / mass,
            ]
        })
        .collect();
    Ok(Setup::new(
        Plant {
            m: Measured::new(table, kin, (inp.aircraft, inp.refs, j), v_m, y_m, inp.pieces),
            alpha_m,
        },
        inp,
    ))
}

impl<D: Dynamics> Setup<D> {
    /// The plant with the manoeuvres of `inp`, the sandwich blocks and the held-out folds.
    pub(super) fn new(plant: D, inp: &Inputs) -> Self {
        let t_s = &inp.table.t_s;
        let n = t_s.len();
        let h_s = (t_s[n - 1] - t_s[0]) / (n - 1).max(1) as f64;
        let cut = |len_s: f64| -> Vec<(usize, usize)> {
            let len = ((len_s / h_s).round() as usize).max(2);
            let mut out = Vec::new();
            for &(a, b) in inp.pieces {
                let mut s = a;
                while s < b {
                    let e = if b - s < len + len / 2 { b } else { s + len };
                    out.push((s, e));
                    s = e;
                }
            }
            out
        };
        let (blocks, fold, folds, fold_note) = if inp.pieces.len() >= select::MIN_PIECES_FOR_FOLDS {
            let f: Vec<usize> = (0..inp.pieces.len()).collect();
            (
                inp.pieces.to_vec(),
                f,
                inp.pieces.len(),
                "whole manoeuvres held out (leave one out)".to_string(),
            )
        } else {
            let b = cut(inp.cv.block_s);
            let folds = inp.cv.folds.max(2);
            let f: Vec<usize> = (0..b.len()).map(|i| i % folds).collect();
            (
                b,
                f,
                folds,
                format!("blocks of {:.1} s in {folds} folds held out", inp.cv.block_s),
            )
        };
        Setup {
            plant,
            pieces: match D::RESTART_S {
                Some(len_s) => cut(len_s),
                None => inp.pieces.to_vec(),
            },
            sandwich: cut(inp.max_lag_s),
            blocks,
            fold,
            folds,
            fold_note,
            gain: None,
            fold_gains: Vec::new(),
        }
    }
}

/// The output-error analysis of one axis's three coefficients: the baseline, the candidates, the
/// final joint fit and, with pooled manoeuvres, the homogeneity of every added term.
pub(super) fn analyse_axis<D: Dynamics>(inp: &Inputs, setup: Setup<D>) -> Result<LowRate, String> {
    let Baseline { spec, th0, dropped } = baseline_spec::<D>(inp)?;
    let base = setup.fit_relaxed(&spec, th0)?;
    let h_base = setup
        .held_out(&base)
        .ok_or("a fold leaves the baseline's parameters unidentifiable")?;
    let axis = Axis::new(inp, &setup, base, h_base);
    let notes = axis.notes();
    let mut current = axis.base.clone();
    let mut h_current = axis.h_base.clone();
    let per_coef: Vec<CoefficientResult> = D::COVERED
        .iter()
        .map(|&c| axis.select(c, &mut current, &mut h_current))
        .collect();
    // The final joint model, its noise relaxed.
    let fin = if current.spec == axis.base.spec {
        axis.base.clone()
    } else {
        setup.fit_relaxed(&current.spec, current.th.clone())?
    };
    let (fin, homogeneity) = axis.homogeneous(fin)?;
    let h_fin = setup
        .held_out(&fin)
        .ok_or("a fold leaves the final model unidentifiable")?;
    let coefficients = per_coef
        .into_iter()
        .map(|r| axis.gap(r, &dropped, &fin, &h_fin, &homogeneity))
        .collect();
    Ok(LowRate {
        coefficients,
        covered: D::COVERED.to_vec(),
        notes,
    })
}

/// Residuals per sample and output.
pub(super) type Residuals = Vec<[f64; NY]>;

/// The output-error baseline of an axis (its terms with a column, the noise relaxed) — what the
/// process-noise test of `low_rate_fem.rs` starts from.
pub(super) struct OutputErrorBaseline {
    fit: Fit,
}

impl OutputErrorBaseline {
    /// The terms.
    pub(super) fn spec(&self) -> &Spec {
        &self.fit.spec
    }
    /// The estimate `θ`.
    pub(super) fn th(&self) -> &[f64] {
        &self.fit.th
    }
    /// The residuals per sample.
    pub(super) fn e(&self) -> &[[f64; NY]] {
        &self.fit.e
    }
}

/// The output-error baseline of an axis; `Err` when it cannot be fitted.
pub(super) fn output_error_baseline<D: Dynamics>(
    inp: &Inputs,
    setup: &Setup<D>,
) -> Result<OutputErrorBaseline, String> {
    let Baseline { spec, th0, .. } = baseline_spec::<D>(inp)?;
    let fit = setup.fit_relaxed(&spec, th0)?;
    Ok(OutputErrorBaseline { fit })
}

/// An axis's baseline before its fit.
struct Baseline {
    /// The terms with a column.
    spec: Spec,
    /// Their start: least squares on the synthesised coefficients.
    th0: Vec<f64>,
    /// Per coefficient, the baseline terms without a column or untestable on the axis.
    dropped: Vec<Vec<String>>,
}

/// The baseline: terms with a column, started from least squares on the synthesised
/// coefficients (the equation error at this rate: a start, not an answer); the terms dropped per
/// coefficient.
fn baseline_spec<D: Dynamics>(inp: &Inputs) -> Result<Baseline, String> {
    let table = inp.table;
    let mut terms = Vec::new();
    let mut th0 = Vec::new();
    let mut dropped: Vec<Vec<String>> = vec![Vec::new(); 6];
    for c in D::COVERED {
        let mut cols = Vec::new();
        for t in &inp.baselines[c] {
            match t.column(table, inp.refs) {
                Some(col) if D::untestable(c, *t).is_none() => {
                    terms.push((c, *t));
                    cols.push(col);
                }
                _ => dropped[c].push(t.name().to_string()),
            }
        }
        let z = table.z[c].as_ref().ok_or("coefficient missing")?;
        let start = ols_theta(&cols, z).unwrap_or_else(|| vec![0.0; cols.len()]);
        th0.extend(start);
    }
    Ok(Baseline {
        spec: Spec::new(D::COVERED, terms),
        th0,
        dropped,
    })
}

/// One axis's analysis after its baseline fit: the inputs, the plant and folds, the baseline and
/// its held-out residuals, and the tests' critical values.
struct Axis<'a, D> {
    inp: &'a Inputs<'a>,
    setup: &'a Setup<D>,
    base: Fit,
    h_base: HeldOut,
    /// The held-out test's critical value (`G − 1` degrees of freedom, `G` the folds' blocks).
    gain_crit: f64,
    /// `min_detectable / σ`.
    t_detect: f64,
    /// The sample interval, s.
    h_s: f64,
}

impl<'a, D: Dynamics> Axis<'a, D> {
    fn new(inp: &'a Inputs<'a>, setup: &'a Setup<D>, base: Fit, h_base: HeldOut) -> Self {
        let t_s = &inp.table.t_s;
        let n = t_s.len();
        let g = setup.blocks.len();
        let gain_crit = select::student_t_upper_quantile(inp.cv.gain_alpha, (g as f64 - 1.0).max(1.0));
        Self {
            inp,
            setup,
            base,
            h_base,
            gain_crit,
            t_detect: select::detection_factor(inp.threshold_t2, gain_crit, g as f64 - 1.0),
            h_s: (t_s[n - 1] - t_s[0]) / (n - 1).max(1) as f64,
        }
    }

    /// The axis's notes: the method, the baseline's output noise and its colour, the folds.
    fn notes(&self) -> Vec<String> {
        let (inp, base) = (self.inp, &self.base);
        let r0 = noise_of(&base.e);
        let one_s = ((1.0 / self.h_s).round() as usize).max(1);
        let noise: Vec<String> = (0..NY)
            .map(|i| {
                format!(
                    "{} {:.2e} ({})², autocorrelation {:.2} at one sample, {:.2} at 1 s",
                    D::OUTPUTS[i],
                    r0[i],
                    D::UNITS[i],
                    autocorrelation(&base.e, i, 1, inp.pieces),
                    autocorrelation(&base.e, i, one_s, inp.pieces)
                )
            })
            .collect();
        let mut notes = vec![format!(
            "{} ({}): {}; R relaxed to the residuals' mean square ({}); held-out: {}, the fits without a fold by one Gauss–Newton step",
            self.setup.method(),
            D::COVERED.map(|c| COEFFICIENTS[c]).join(", "),
            D::READING,
            noise.join(", "),
            self.setup.fold_note
        )];
        if !base.converged {
            notes.push("the baseline's Gauss–Newton iterations did not converge within their limit".into());
        }
        notes.push(self.timing_note());
        notes
    }

    /// The intersample model and the timing resolution of a surface delay, in words.
    fn timing_note(&self) -> String {
        let how = match self.inp.sampling {
            Sampling::Points => "point samples (the signal at each time stamp)",
            Sampling::CentredMeans => "means over each sample interval, stamped at its centre",
            Sampling::Unstated => "not stated by the source",
        };
        format!(
            "intersample model: the samples are {how}; the inputs are taken between samples on the cubic spline through them (phase-free; for interval means it is the mean-preserving reconstruction with averaged outputs), a surface's rate as its derivative; a surface delay within ±{:.0} ms, half the {:.0} ms interval, is not decided at this rate: {}",
            1e3 * intersample::timing_resolution_s(self.h_s),
            1e3 * self.h_s,
            intersample::why_unresolved(self.inp.sampling)
        )
    }

    /// Forward selection on coefficient `c` from the current joint model (`current`, its held-out
    /// residuals `h_current`), which each added term extends.
    fn select(&self, c: usize, current: &mut Fit, h_current: &mut HeldOut) -> CoefficientResult {
        let mut first_round: Option<Vec<CandidateScore>> = None;
        let mut added: Vec<Added> = Vec::new();
        let mut cnotes: Vec<String> = Vec::new();
        let mut undecided: Vec<String> = Vec::new();
        for round in 0..MAX_ADDED {
            let mut scored: Vec<Scored> = Term::offered(c, self.inp.table)
                .into_iter()
                .filter_map(|t| self.score(c, t, current, h_current))
                .collect();
            for (s, fit) in &mut scored {
                let why = fit
                    .as_ref()
                    .filter(|_| s.significant)
                    .and_then(|(f, ..)| self.undecided_delay(c, f));
                if let Some(why) = why {
                    s.significant = false;
                    if !undecided.contains(&why) {
                        cnotes.push(why.clone());
                        undecided.push(why);
                    }
                }
            }
            scored.sort_by(|a, b| b.0.t2.total_cmp(&a.0.t2));
            cnotes.extend(likelihood_notes(c, round, &scored));
            let names_sig: Vec<String> = scored
                .iter()
                .filter(|(s, _)| s.significant)
                .map(|(s, _)| s.term.clone())
                .collect();
            let best = scored.iter().position(|(s, _)| s.significant);
            if first_round.is_none() {
                first_round = Some(scored.iter().map(|(s, _)| s.clone()).collect());
            }
            let Some(mut bi) = best else { break };
            let family = lowest_form(c, &scored, &mut bi);
            let (score, fit) = scored.swap_remove(bi);
            let Some((fit1, h1, _)) = fit else { break };
            added.push(Added {
                term: score.term.clone(),
                kind: score.kind,
                t2: score.t2,
                value: score.value,
                sigma: score.sigma,
                cv_gain: score.cv_gain,
                alternatives: names_sig.into_iter().filter(|n| *n != score.term).collect(),
                rivals: Vec::new(),
                exact_delay_s: None,
                family,
            });
            *current = fit1;
            *h_current = h1;
        }
        self.undecided_after_selection(c, current, h_current, &mut added, &mut undecided);
        cnotes.extend(
            undecided
                .iter()
                .filter(|w| !cnotes.contains(w))
                .cloned()
                .collect::<Vec<_>>(),
        );
        (c, first_round.unwrap_or_default(), added, cnotes, undecided)
    }

    /// A surface-rate term added before its surface's own term (a control term missing from the
    /// baseline) is a delay only in the model that has both: checked there, and when within the
    /// timing resolution dropped from the added terms and the model refitted without it.
    fn undecided_after_selection(
        &self,
        c: usize,
        current: &mut Fit,
        h_current: &mut HeldOut,
        added: &mut Vec<Added>,
        undecided: &mut Vec<String>,
    ) {
        let rates: Vec<usize> = (0..current.spec.terms.len())
            .filter(|&j| {
                let (cc, t) = current.spec.terms[j];
                cc == c && added.iter().any(|a| a.term == t.name())
            })
            .collect();
        for j in rates.into_iter().rev() {
            let Some(why) = self.undecided_delay_at(c, current, j) else {
                continue;
            };
            let mut terms = current.spec.terms.clone();
            let mut th = current.th.clone();
            let (_, t) = terms.remove(j);
            th.remove(j);
            let spec = Spec::new(current.spec.covered, terms);
            let Ok(f) = self.setup.fit(&spec, th, self.base.w) else {
                continue;
            };
            let Some(h) = self.setup.held_out(&f) else {
                continue;
            };
            *current = f;
            *h_current = h;
            added.retain(|a| a.term != t.name());
            if !undecided.contains(&why) {
                undecided.push(why);
            }
        }
    }

    /// Why the surface-rate term last added to coefficient `c` in `fit` is not decided at this
    /// rate: the delay it stands for, `τ = −θ_δ̇/θ_δ` (the first-order form `δ(t − τ) ≈ δ − τ δ̇`
    /// with the surface's own term in the same coefficient), lies within the timing the samples
    /// leave unresolved ([`intersample::timing_resolution_s`]). `None` for any other
    /// term, without the surface's own term, or beyond the resolution.
    fn undecided_delay(&self, c: usize, fit: &Fit) -> Option<String> {
        self.undecided_delay_at(c, fit, fit.spec.terms.len().checked_sub(1)?)
    }

    /// [`Self::undecided_delay`] of parameter `j` of `fit`.
    fn undecided_delay_at(&self, c: usize, fit: &Fit, j: usize) -> Option<String> {
        let (cc, t) = *fit.spec.terms.get(j)?;
        let surface = match t {
            Term::ElevatorRate => Term::Elevator,
            Term::AileronRate => Term::Aileron,
            Term::RudderRate => Term::Rudder,
            _ => return None,
        };
        let resolution = intersample::timing_resolution_s(self.h_s);
        let js = fit.spec.terms.iter().position(|&(k, u)| k == cc && u == surface)?;
        let tau = -fit.th[j] / fit.th[js];
        if cc != c || !tau.is_finite() || tau.abs() > resolution {
            return None;
        }
        Some(format!(
            "{} (a {} of {:.0} ms of {}): not decided at this rate — within ±{:.0} ms, half the {:.0} ms sample interval: {}",
            t.name(),
            if tau >= 0.0 { "delay" } else { "lead" },
            1e3 * tau.abs(),
            surface.name(),
            1e3 * resolution,
            1e3 * self.h_s,
            intersample::why_unresolved(self.inp.sampling)
        ))
    }

    /// Candidate `t` of coefficient `c` added to the current model: its score, and the fit, the
    /// held-out residuals and the likelihood gain when it could be fitted; `None` when it is in
    /// the model already or has no column.
    fn score(&self, c: usize, t: Term, current: &Fit, h_current: &HeldOut) -> Option<Scored> {
        let (inp, setup) = (self.inp, self.setup);
        if current.spec.terms.contains(&(c, t)) {
            return None;
        }
        if let Some(why) = D::untestable(c, t) {
            return Some((CandidateScore::unscored(t, c, why.into()), None));
        }
        t.column(inp.table, inp.refs)?;
        let (s1, th1) = current.spec.with(c, t, &current.th);
        let fit1 = match setup.fit(&s1, th1, self.base.w) {
            Ok(f) => f,
            Err(e) => return Some((CandidateScore::unscored(t, c, e), None)),
        };
        let Some(h1) = setup.held_out(&fit1) else {
            return Some((
                CandidateScore::unscored(t, c, "a fold leaves the extended model unidentifiable".into()),
                None,
            ));
        };
        let j = s1.np() - 1;
        let (value, sigma) = (fit1.th[j], fit1.sigma[j]);
        let t2 = (value / sigma).powi(2);
        let cmp = compare(h_current, &h1);
        let r1 = noise_of(&fit1.e);
        let r_cur = noise_of(&current.e);
        let n_all = inp.table.t_s.len() as f64;
        let lik = n_all * (0..NY).map(|i| (r_cur[i] / r1[i]).ln()).sum::<f64>();
        let significant = t2 > inp.threshold_t2 && cmp.z > 0.0 && cmp.t > self.gain_crit;
        Some((
            CandidateScore {
                term: t.name().into(),
                kind: t.kind(c),
                t2,
                cv_gain: cmp.rel,
                cv_gain_z: cmp.z,
                cv_noise_z: cmp.t,
                pse: f64::NAN,
                significant,
                reason: None,
                value,
                sigma,
                min_detectable: self.t_detect * sigma,
                // The oracle ([`super::oracle`]) is an equation-error construction; this
                // path reports none.
                oracle_se: f64::NAN,
                oracle_min_detectable: f64::NAN,
                se_ratio: f64::NAN,
                oracle_reliability: f64::NAN,
            },
            Some((fit1, h1, lik)),
        ))
    }

    /// Pooled manoeuvres: an added term stays only when its per-manoeuvre estimates agree; the
    /// final model refitted without those that do not, and every added term's judgement.
    fn homogeneous(&self, fin: Fit) -> Result<(Fit, Vec<(usize, Homogeneity)>), String> {
        let (inp, base) = (self.inp, &self.base);
        let mut homogeneity: Vec<(usize, Homogeneity)> = Vec::new();
        if inp.pieces.len() < select::MIN_PIECES_FOR_FOLDS || fin.spec == base.spec {
            return Ok((fin, homogeneity));
        }
        let max_lag = (inp.max_lag_s / self.h_s).round() as usize;
        for (j, (c, t)) in fin.spec.terms.iter().enumerate().skip(base.spec.np()) {
            let per = per_manoeuvre(&fin, j, inp.pieces, max_lag);
            homogeneity.push((
                *c,
                super::homogeneity::judge(t.name().to_string(), per, inp.cv.gain_alpha),
            ));
        }
        let refused: Vec<(usize, Term)> = fin
            .spec
            .terms
            .iter()
            .skip(base.spec.np())
            .zip(&homogeneity)
            .filter(|(_, (_, h))| !h.agrees)
            .map(|(ct, _)| *ct)
            .collect();
        if refused.is_empty() {
            return Ok((fin, homogeneity));
        }
        let (terms, th): (Vec<(usize, Term)>, Vec<f64>) = fin
            .spec
            .terms
            .iter()
            .zip(&fin.th)
            .filter(|(ct, _)| !refused.contains(ct))
            .map(|(ct, t)| (*ct, *t))
            .unzip();
        let spec = Spec::new(D::COVERED, terms);
        let fin = if spec == base.spec {
            base.clone()
        } else {
            self.setup.fit_relaxed(&spec, th)?
        };
        Ok((fin, homogeneity))
    }

    /// Coefficient `c`'s gap from its selection (`r`), the final model `fin` and its held-out
    /// residuals, and the homogeneity judgements: the added terms confirmed, both models' fits,
    /// the verdict.
    fn gap(
        &self,
        r: CoefficientResult,
        dropped: &[Vec<String>],
        fin: &Fit,
        h_fin: &HeldOut,
        homogeneity: &[(usize, Homogeneity)],
    ) -> CoefficientGap {
        let (inp, setup, base) = (self.inp, self.setup, &self.base);
        let (c, candidates, mut added, mut cnotes, undecided) = r;
        let homogeneity: Vec<Homogeneity> = homogeneity
            .iter()
            .filter(|(cc, _)| *cc == c)
            .map(|(_, h)| h.clone())
            .collect();
        let refused: Vec<&Homogeneity> = homogeneity.iter().filter(|h| !h.agrees).collect();
        for h in &refused {
            cnotes.push(format!("{} not confirmed: {}", h.term, h.reason));
        }
        added.retain(|a| !refused.iter().any(|h| h.term == a.term));
        let o = D::primary_output(c);
        let meas: Vec<f64> = setup.plant.y_m().iter().map(|y| y[o]).collect();
        for a in &mut added {
            if let Some(j) = fin.spec.terms.iter().position(|(cc, t)| *cc == c && t.name() == a.term) {
                a.value = fin.th[j];
                a.sigma = fin.sigma[j];
            }
        }
        let traces = self.traces(c, fin);
        let (r2b, r2e) = self.held_out_r2(o, &meas, fin, h_fin);
        let method = self.setup.method();
        let mut verdict = verdict(method, D::OUTPUTS[o], &added, &refused, r2b, r2e);
        if !undecided.is_empty() {
            let why = undecided.join("; ");
            verdict = if added.is_empty() && refused.is_empty() {
                format!(
                    "not decided at this rate ({method}): {why}; no other candidate improves the held-out prediction of {} beyond noise; held-out R² {r2b:.3}",
                    D::OUTPUTS[o]
                )
            } else {
                format!("{verdict}; not decided at this rate: {why}")
            };
        }
        let model_of = |f: &Fit| -> Vec<(Term, f64)> { f.spec.of(c).iter().map(|(j, t)| (*t, f.th[*j])).collect() };
        CoefficientGap {
            name: COEFFICIENTS[c].to_string(),
            verdict,
            cv_r2_baseline: r2b,
            cv_r2_extended: r2e,
            block_s: self.block_s(),
            threshold_t2: inp.threshold_t2,
            blocks: inp.threshold_blocks,
            dropped_terms: dropped[c].clone(),
            baseline: self.model_fit(c, &meas, base, &self.h_base),
            candidates,
            added,
            notes: cnotes,
            extended: self.model_fit(c, &meas, fin, h_fin),
            homogeneity,
            traces,
            baseline_model: model_of(base),
            extended_model: model_of(fin),
        }
    }

    /// The held-out R² of the primary output `o` (measured `meas`) of the baseline and of the
    /// final fit `fin` (held-out residuals `h_fin`), each residual weighted by its fit's `1/R`.
    fn held_out_r2(&self, o: usize, meas: &[f64], fin: &Fit, h_fin: &HeldOut) -> (f64, f64) {
        let n = self.inp.table.t_s.len();
        let mean = meas.iter().sum::<f64>() / n as f64;
        let sst: f64 = meas.iter().map(|v| (v - mean).powi(2)).sum::<f64>().max(1e-300);
        let cv_r2 = |f: &Fit, h: &[Vec<[f64; NY]>]| -> f64 {
            let sse: f64 = h.iter().flatten().map(|r| r[o] * r[o] / f.w[o]).sum();
            1.0 - sse / sst
        };
        (cv_r2(&self.base, &self.h_base), cv_r2(fin, h_fin))
    }

    /// Coefficient `c` synthesised and as the baseline and the final fit `fin` model it.
    fn traces(&self, c: usize, fin: &Fit) -> Traces {
        let table = self.inp.table;
        let n_id = self.inp.n_id.min(table.t_s.len());
        let ci = D::COVERED.iter().position(|x| *x == c).unwrap_or(0);
        Traces {
            t_s: table.t_s.clone(),
            measured: table.z[c].clone().unwrap_or_default(),
            baseline: self.base.run.coefs.iter().map(|v| v[ci]).collect(),
            extended: fin.run.coefs.iter().map(|v| v[ci]).collect(),
            split: n_id,
        }
    }

    /// The held-out blocks' length, s (NaN when the folds are whole manoeuvres).
    fn block_s(&self) -> f64 {
        let (inp, setup) = (self.inp, self.setup);
        if setup.folds == inp.pieces.len() && inp.pieces.len() >= select::MIN_PIECES_FOR_FOLDS {
            f64::NAN
        } else {
            inp.cv.block_s
        }
    }

    /// Fit `f` of coefficient `c` as the report shows it: its parameters, and the prediction of
    /// the primary output `meas` on the identification segment and held out on the validation
    /// segment (residuals `h`).
    fn model_fit(&self, c: usize, meas: &[f64], f: &Fit, h: &[Vec<[f64; NY]>]) -> ModelFit {
        let n = self.inp.table.t_s.len();
        let n_id = self.inp.n_id.min(n);
        let o = D::primary_output(c);
        let parameters: Vec<Parameter> = f
            .spec
            .of(c)
            .iter()
            .map(|(j, t)| Parameter {
                term: t.name().into(),
                value: f.th[*j],
                sigma: f.sigma[*j],
                sigma_eq17: f.sigma_crb[*j],
                exact: true,
                ols_value: f64::NAN,
            })
            .collect();
        let p = parameters.len();
        let pred: Vec<f64> = f.run.yhat.iter().map(|y| y[o]).collect();
        // Held-out predictions of the validation segment: measured − held-out residual.
        let mut ho = vec![f64::NAN; n];
        for (bi, &(a, _)) in self.setup.blocks.iter().enumerate() {
            for (s, r) in h[bi].iter().enumerate() {
                ho[a + s] = meas[a + s] - r[o] / f.w[o].sqrt();
            }
        }
        let (zv, hv): (Vec<f64>, Vec<f64>) = (n_id..n)
            .map(|k| (meas[k], ho[k]))
            .filter(|(_, h)| h.is_finite())
            .unzip();
        ModelFit {
            estimator: format!(
                "{} (Gauss–Newton; {} simulated{}; judged on {})",
                self.setup.method(),
                D::STATES,
                if self.setup.gain.is_some() {
                    ", corrected by a steady-state Kalman filter"
                } else {
                    ""
                },
                D::OUTPUTS[o]
            ),
            solution: if f.converged { "converged" } else { "iteration limit" }.into(),
            not_determined: None,
            sigma_z2: 1.0 / f.w[o],
            parameters,
            identification: metrics(&meas[..n_id], &pred[..n_id], p),
            validation: if zv.is_empty() {
                Metrics {
                    r2: f64::NAN,
                    rms: f64::NAN,
                    pse: f64::NAN,
                    n: 0,
                }
            } else {
                metrics(&zv, &hv, p)
            },
        }
    }
}

/// The notes on a round's three strongest candidates: their likelihood gain beside `t²` and `T`.
fn likelihood_notes(c: usize, round: usize, scored: &[Scored]) -> Vec<String> {
    let mut out = Vec::new();
    for (s, f) in scored.iter().take(3) {
        if let Some((_, _, lik)) = f {
            out.push(format!(
                "{}{}: candidate {} likelihood gain 2ΔlnL {lik:.1} (t² {:.1}, held-out T {:.2})",
                COEFFICIENTS[c],
                if round == 0 {
                    String::new()
                } else {
                    format!(" (round {})", round + 1)
                },
                s.term,
                s.t2,
                s.cv_noise_z
            ));
        }
    }
    out
}

/// A coefficient's verdict on the low-rate path by `method`, judged on `output`: the terms added
/// and those whose estimates do not agree across the manoeuvres, with the held-out R² before and
/// after.
fn verdict(method: &str, output: &str, added: &[Added], refused: &[&Homogeneity], r2b: f64, r2e: f64) -> String {
    let not_confirmed = refused.iter().map(|h| h.term.as_str()).collect::<Vec<_>>().join(", ");
    if added.is_empty() && !refused.is_empty() {
        format!(
            "not confirmed ({method}): {not_confirmed} predicted held-out manoeuvres better, but its estimates do not agree across the manoeuvres (see `homogeneity`); held-out R² of {output} {r2b:.3}"
        )
    } else if added.is_empty() {
        format!(
            "nothing missing ({method}): no candidate improves the held-out prediction of {output} beyond noise; held-out R² {r2b:.3}"
        )
    } else if !refused.is_empty() {
        format!(
            "extended ({method}): {}; held-out R² of {output} {r2b:.3} → {r2e:.3}; not confirmed (estimates do not agree across manoeuvres): {not_confirmed}",
            added.iter().map(|a| a.term.as_str()).collect::<Vec<_>>().join(", ")
        )
    } else {
        format!(
            "extended ({method}): {}; held-out R² of {output} {r2b:.3} → {r2e:.3}",
            added.iter().map(|a| a.term.as_str()).collect::<Vec<_>>().join(", ")
        )
    }
}

/// The autocorrelation of output `i`'s residuals at `lag` samples, lags within each piece: how
/// coloured the output error's residuals are (white: near 0 at every lag).
fn autocorrelation(e: &[[f64; NY]], i: usize, lag: usize, pieces: &[(usize, usize)]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for &(a, b) in pieces {
        num += (a..b.saturating_sub(lag)).map(|k| e[k][i] * e[k + lag][i]).sum::<f64>();
        den += (a..b).map(|k| e[k][i] * e[k][i]).sum::<f64>();
    }
    if den > 0.0 {
        num / den
    } else {
        f64::NAN
    }
}

/// The estimates of parameter `j` of the fit `f` on each manoeuvre of `pieces` where it is
/// excited: one Gauss–Newton step in that parameter alone from the pooled fit, the others held at
/// their pooled estimates (as the equation-error path's [`super::fit::homogeneity_of`] holds them: one
/// manoeuvre seldom excites every baseline term), `θ_m = θ_j + Σ xᵀe / Σ xᵀx` with `x` the
/// parameter's output sensitivities and `e` the residuals, both scaled by `R^{-1/2}`. Its σ is
/// Morelli & Klein's (1997) coloured-residual correction per output with the residual
/// autocovariance pooled over the manoeuvres (lags within each, up to `max_lag`, Bartlett
/// weights), the same reading as the equation-error path's. A manoeuvre excites the parameter
/// when its mean `xᵀx` per sample is at least 10 % of the pooled mean.
fn per_manoeuvre(f: &Fit, j: usize, pieces: &[(usize, usize)], max_lag: usize) -> Vec<ManoeuvreEstimate> {
    let sw = f.w.map(f64::sqrt);
    let x = |k: usize, i: usize| f.run.h[k][(i, j)] * sw[i];
    let e = |k: usize, i: usize| f.e[k][i] * sw[i];
    let n: usize = pieces.iter().map(|(a, b)| b - a).sum();
    let mut r = vec![[0.0; NY]; max_lag + 1];
    for &(a, b) in pieces {
        for (l, rl) in r.iter_mut().enumerate() {
            for k in a..b.saturating_sub(l) {
                for (i, v) in rl.iter_mut().enumerate() {
                    *v += e(k, i) * e(k + l, i) / n.max(1) as f64;
                }
            }
        }
    }
    let sxx_of = |a: usize, b: usize| -> f64 { (a..b).map(|k| (0..NY).map(|i| x(k, i).powi(2)).sum::<f64>()).sum() };
    let pooled = pieces.iter().map(|&(a, b)| sxx_of(a, b)).sum::<f64>() / n.max(1) as f64;
    let mut out = Vec::new();
    for (m, &(a, b)) in pieces.iter().enumerate() {
        let sxx = sxx_of(a, b);
        if b <= a || sxx / ((b - a) as f64) < 0.1 * pooled || sxx <= 0.0 {
            continue;
        }
        let sxe: f64 = (a..b).map(|k| (0..NY).map(|i| x(k, i) * e(k, i)).sum::<f64>()).sum();
        let mut num = 0.0;
        for (l, rl) in r.iter().enumerate().take(b - a) {
            let w = if l == 0 {
                1.0
            } else {
                2.0 * (1.0 - l as f64 / (max_lag + 1) as f64)
            };
            for (i, ri) in rl.iter().enumerate() {
                num += w * ri * (a..b - l).map(|k| x(k, i) * x(k + l, i)).sum::<f64>();
            }
        }
        if num <= 0.0 {
            num = (0..NY)
                .map(|i| r[0][i] * (a..b).map(|k| x(k, i).powi(2)).sum::<f64>())
                .sum();
        }
        out.push(ManoeuvreEstimate {
            manoeuvre: m,
            value: f.th[j] + sxe / sxx,
            sigma: num.sqrt() / sxx,
        });
    }
    out
}

/// The family rule of the equation-error path ([`family`](super::family)) in the form this path
/// can afford: among the significant candidates of the best one's family of rival forms, the
/// lowest-order form is named (`best` moved to it) and the other significant forms are listed as
/// ones this flight cannot separate. Reading: the output-error fits are not compared form against
/// form on held-out data, so a higher form never displaces a lower one here — the conservative
/// side of "the lowest order wins unless another predicts better beyond noise".
fn lowest_form<F>(c: usize, scored: &[(CandidateScore, F)], best: &mut usize) -> Option<super::family::FamilyChoice> {
    let term_of = |name: &str| Term::library(c).into_iter().find(|t| t.name() == name);
    let fam = super::family::Family::of(term_of(&scored[*best].0.term)?, c)?;
    let members: Vec<(usize, usize)> = scored
        .iter()
        .enumerate()
        .filter(|(_, (s, _))| s.significant)
        .filter_map(|(i, (s, _))| {
            let t = term_of(&s.term)?;
            (super::family::Family::of(t, c) == Some(fam)).then(|| (fam.order(t), i))
        })
        .collect();
    let (_, lowest) = *members.iter().min()?;
    *best = lowest;
    Some(super::family::FamilyChoice {
        family: fam.name().to_string(),
        form: scored[lowest].0.term.clone(),
        cannot_separate: members
            .iter()
            .filter(|(_, i)| *i != lowest)
            .map(|(_, i)| scored[*i].0.term.clone())
            .collect(),
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::gaps::{hidden, preprocess, GapSettings};
    use nalgebra::DMatrix;

    /// `θ` of `terms` by least squares on the synthesised coefficients: a plausible point,
    /// coefficient by coefficient.
    pub(crate) fn ls_start(table: &Table, refs: &TermRefs, covered: [usize; 3], terms: &[(usize, Term)]) -> Vec<f64> {
        let mut th = Vec::new();
        for c in covered {
            let cols: Vec<Vec<f64>> = terms
                .iter()
                .filter(|(cc, _)| *cc == c)
                .map(|(_, t)| t.column(table, refs).expect("the column exists"))
                .collect();
            th.extend(ols_theta(&cols, table.z[c].as_ref().expect("synthesised")).expect("regular"));
        }
        th
    }

    /// Every column of the output sensitivities equals central differences of the simulated
    /// outputs (relative tolerance per column, see the tests).
    pub(crate) fn assert_sensitivities<D: Dynamics>(
        plant: &D,
        spec: &Spec,
        th: &[f64],
        pieces: &[(usize, usize)],
        gain: Option<&DMatrix<f64>>,
        tol: f64,
    ) {
        let run = plant
            .run(spec, th, pieces, true, gain)
            .expect("the simulation stays in range");
        let n = plant.y_m().len();
        for j in 0..spec.np() {
            let step = 1e-6 * th[j].abs().max(1.0);
            let at = |d: f64| {
                let mut t = th.to_vec();
                t[j] += d;
                plant.run(spec, &t, pieces, false, gain).expect("in range").yhat
            };
            let (up, dn) = (at(step), at(-step));
            let (mut err, mut norm) = (0.0, 0.0);
            for k in 0..n {
                for i in 0..NY {
                    let fd = (up[k][i] - dn[k][i]) / (2.0 * step);
                    err += (run.h[k][(i, j)] - fd).powi(2);
                    norm += fd * fd;
                }
            }
            assert!(
                err.sqrt() <= tol * norm.sqrt(),
                "{:?}: |H − FD| {:.3e}, |FD| {:.3e}",
                spec.terms[j],
                err.sqrt(),
                norm.sqrt()
            );
        }
    }

    /// A simulated 20 s flight in light turbulence averaged to 10 Hz, synthesised, with the
    /// eq. 3 baselines: what the plants of both axes run on in the tests.
    pub(crate) struct Fixture {
        f: crate::io::measured::MeasuredFlight,
        pre: crate::gaps::Preprocessed,
        refs: TermRefs,
        baselines: [Vec<Term>; 6],
        pieces: [(usize, usize); 1],
        s: GapSettings,
    }

    impl Fixture {
        pub(crate) fn new() -> Self {
            let fast = hidden::flight(None, 20.0, 7, true).expect("the simulator flies");
            let f = fast.block_means(10);
            let h = f.t_s[1] - f.t_s[0];
            let s = GapSettings::default();
            let baselines: [Vec<Term>; 6] = core::array::from_fn(Term::eq3);
            let pre = preprocess(&f, h, &s, &baselines);
            let refs = TermRefs {
                alpha_break_rad: 0.1,
                airspeed_mps: 18.0,
                mach: 0.0,
            };
            let pieces = [(0, f.len())];
            Self {
                f,
                pre,
                refs,
                baselines,
                pieces,
                s,
            }
        }

        pub(crate) fn inputs(&self) -> Inputs<'_> {
            Inputs {
                table: &self.pre.table,
                aircraft: &self.f.aircraft,
                refs: &self.refs,
                baselines: &self.baselines,
                pieces: &self.pieces,
                n_id: self.f.len() * 6 / 10,
                threshold_t2: 20.0,
                threshold_blocks: 10,
                cv: self.s.cv,
                max_lag_s: self.s.max_lag_s,
                sampling: self.f.log.sampling,
            }
        }
    }

    /// The output sensitivities of the longitudinal simulation (the forward sensitivity equations
    /// integrated with the states, with the chains through `C_L²` in `C_D` and `α̇` in `C_m`)
    /// equal central differences of the simulated outputs, without and with a state filter in
    /// the loop (the filter error method's gain, here a fixed correction of α and `q` by their
    /// own innovations). RK4 applied to the states and sensitivities together differentiates the
    /// discrete step exactly, and the filter's update is linear in the state; what differs is the
    /// central differences inside (`∂f/∂x`, the chain partials: relative steps 10⁻⁶, errors
    /// ~10⁻¹⁰) and this test's own (relative step 10⁻⁶ of `θ`): a relative tolerance of 10⁻⁵ per
    /// column leaves room for both. The lateral axis: `oem_lateral.rs`.
    #[test]
    fn the_sensitivities_match_differences_of_the_simulation() {
        let fx = Fixture::new();
        let inp = fx.inputs();
        use Term::*;
        let lon = vec![
            (0, One),
            (0, Alpha),
            (0, Q),
            (0, Elevator),
            (1, One),
            (1, Lift2),
            (1, AlphaDot),
            (4, One),
            (4, Alpha),
            (4, Q),
            (4, Elevator),
            (4, AlphaDot),
        ];
        let th = ls_start(inp.table, inp.refs, COVERED, &lon);
        let st = setup(&inp).expect("the longitudinal path runs on this flight");
        let spec = Spec::new(COVERED, lon);
        assert_sensitivities(&st.plant, &spec, &th, inp.pieces, None, 1e-5);
        let mut gain = DMatrix::<f64>::zeros(2, NY);
        gain[(0, 0)] = 0.3;
        gain[(1, 1)] = 0.3;
        assert_sensitivities(&st.plant, &spec, &th, inp.pieces, Some(&gain), 1e-5);
    }
}
