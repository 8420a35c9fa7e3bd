//! Truth aerodynamics: the linear model of seed 000 eq. 3 plus switchable hidden effects, the
//! force/moment mapping of eq. 1–2, and the linearisation of the truth at a flight condition.
//!
//! Forces (eq. 1): lift and drag act in stability axes, side force along body y:
//! `F_body = q̄S · R_y(α) · [−C_D, C_Y, −C_L]`, i.e. `F_x = q̄S(−C_D cos α + C_L sin α)`,
//! `F_z = q̄S(−C_D sin α − C_L cos α)` (Beard & McLain, as in `last_letter`). Moments (eq. 2) are
//! body axes about the CG: `M = q̄S [b C_l, c̄ C_m, b C_n]`.
//!
//! Hidden effects ([`TruthEffects`], data/aircraft README §1): stall blending to flat-plate values
//! (`σ(α)` with `M`, `α₀`), induced drag `C_L,lin²/(π e AR)`, elevator drag `k|δe|`, drag in `|α|`.
//! Propulsive effects (thrust moment, propeller torque) live in [`super::dynamics`].

use nalgebra::Vector3;

/// The regressors of eq. 3 at one instant (rates already non-dimensional).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AeroInput {
    /// Angle of attack α, rad.
    pub alpha_rad: f64,
    /// Sideslip β, rad.
    pub beta_rad: f64,
    /// `p b/(2V)`.
    pub p_n: f64,
    /// `q c̄/(2V)`.
    pub q_n: f64,
    /// `r b/(2V)`.
    pub r_n: f64,
    /// Aileron δa, rad.
    pub aileron_rad: f64,
    /// Elevator δe, rad.
    pub elevator_rad: f64,
    /// Rudder δr, rad.
    pub rudder_rad: f64,
}

impl AeroInput {
    fn to_array(self) -> [f64; 8] {
        [
            self.alpha_rad,
            self.beta_rad,
            self.p_n,
            self.q_n,
            self.r_n,
            self.aileron_rad,
            self.elevator_rad,
            self.rudder_rad,
        ]
    }
    fn from_array(a: [f64; 8]) -> Self {
        Self {
            alpha_rad: a[0],
            beta_rad: a[1],
            p_n: a[2],
            q_n: a[3],
            r_n: a[4],
            aileron_rad: a[5],
            elevator_rad: a[6],
            rudder_rad: a[7],
        }
    }
}

/// One coefficient linear in the regressors (plus `α²`, used by `C_D`, eq. 3b).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoeffModel {
    /// Intercept.
    pub c0: f64,
    /// Derivative in α, 1/rad.
    pub alpha: f64,
    /// Coefficient of α², 1/rad².
    pub alpha2: f64,
    /// Derivative in β, 1/rad.
    pub beta: f64,
    /// Derivative in `p_n`.
    pub p_n: f64,
    /// Derivative in `q_n`.
    pub q_n: f64,
    /// Derivative in `r_n`.
    pub r_n: f64,
    /// Derivative in δa, 1/rad.
    pub aileron: f64,
    /// Derivative in δe, 1/rad.
    pub elevator: f64,
    /// Derivative in δr, 1/rad.
    pub rudder: f64,
}

impl CoeffModel {
    /// Value at `x`.
    pub fn eval(&self, x: &AeroInput) -> f64 {
        self.c0
            + self.alpha * x.alpha_rad
            + self.alpha2 * x.alpha_rad * x.alpha_rad
            + self.beta * x.beta_rad
            + self.p_n * x.p_n
            + self.q_n * x.q_n
            + self.r_n * x.r_n
            + self.aileron * x.aileron_rad
            + self.elevator * x.elevator_rad
            + self.rudder * x.rudder_rad
    }
    /// All ten numbers in the order c0, α, α², β, p_n, q_n, r_n, δa, δe, δr.
    pub fn to_array(&self) -> [f64; 10] {
        [
            self.c0,
            self.alpha,
            self.alpha2,
            self.beta,
            self.p_n,
            self.q_n,
            self.r_n,
            self.aileron,
            self.elevator,
            self.rudder,
        ]
    }
    fn from_array(a: [f64; 10]) -> Self {
        Self {
            c0: a[0],
            alpha: a[1],
            alpha2: a[2],
            beta: a[3],
            p_n: a[4],
            q_n: a[5],
            r_n: a[6],
            aileron: a[7],
            elevator: a[8],
            rudder: a[9],
        }
    }
    /// Element-wise sum (used by the parameter jump).
    pub fn plus(&self, other: &Self) -> Self {
        let (a, b) = (self.to_array(), other.to_array());
        Self::from_array(core::array::from_fn(|i| a[i] + b[i]))
    }
}

/// The six coefficients `C_L, C_D, C_Y, C_l, C_m, C_n` at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Coefficients {
    /// Lift `C_L`.
    pub lift: f64,
    /// Drag `C_D`.
    pub drag: f64,
    /// Side force `C_Y`.
    pub side: f64,
    /// Rolling moment `C_l`.
    pub roll: f64,
    /// Pitching moment `C_m`.
    pub pitch: f64,
    /// Yawing moment `C_n`.
    pub yaw: f64,
}

impl Coefficients {
    /// `[C_L, C_D, C_Y, C_l, C_m, C_n]`.
    pub fn to_array(&self) -> [f64; 6] {
        [self.lift, self.drag, self.side, self.roll, self.pitch, self.yaw]
    }
}

/// The linear aerodynamic model (eq. 3, with every regressor allowed in every coefficient).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinearAero {
    /// `C_L` (eq. 3a).
    pub lift: CoeffModel,
    /// `C_D` (eq. 3b).
    pub drag: CoeffModel,
    /// `C_Y` (eq. 3c).
    pub side: CoeffModel,
    /// `C_l` (eq. 3d).
    pub roll: CoeffModel,
    /// `C_m` (eq. 3e).
    pub pitch: CoeffModel,
    /// `C_n` (eq. 3f).
    pub yaw: CoeffModel,
}

impl LinearAero {
    /// data/aircraft README §1 (`CD0 + CDα·α`, the 2020 code).
    pub fn skywalker_2013_mod() -> Self {
        let z = CoeffModel::default();
        Self {
            lift: CoeffModel {
                c0: 0.40,
                alpha: 6.5,
                ..z
            },
            drag: CoeffModel {
                c0: 0.09,
                alpha: 0.14,
                ..z
            },
            side: CoeffModel {
                beta: -0.98,
                rudder: -0.2,
                ..z
            },
            roll: CoeffModel {
                beta: -0.12,
                p_n: -1.0,
                r_n: 0.14,
                aileron: 0.25,
                rudder: -0.037,
                ..z
            },
            pitch: CoeffModel {
                c0: 0.01,
                alpha: -1.3,
                q_n: -20.0,
                elevator: 1.0,
                ..z
            },
            yaw: CoeffModel {
                beta: 0.25,
                p_n: 0.022,
                r_n: -1.0,
                rudder: 0.1,
                ..z
            },
        }
    }
    /// data/aircraft README §2, linearised: `C_D = 0.028 + 0.04 C_L²` expanded about `C_L0 = 0.25`
    /// (`C_D0 0.0305, C_Dα 0.1, C_Dα² 1.0`; the `|α|` and `|β|` kinks dropped), `C_mα` −0.85 (the
    /// CG-referenced value the README quotes), `C_m0` 0 (not given), `C_mα̇` dropped.
    pub fn rascal_110() -> Self {
        let z = CoeffModel::default();
        Self {
            lift: CoeffModel {
                c0: 0.25,
                alpha: 5.0,
                elevator: 0.2,
                ..z
            },
            drag: CoeffModel {
                c0: 0.0305,
                alpha: 0.1,
                alpha2: 1.0,
                ..z
            },
            side: CoeffModel { beta: -1.0, ..z },
            roll: CoeffModel {
                beta: -0.1,
                p_n: -0.4,
                r_n: 0.15,
                aileron: 0.13,
                rudder: 0.01,
                ..z
            },
            pitch: CoeffModel {
                alpha: -0.85,
                q_n: -12.0,
                elevator: -0.5,
                ..z
            },
            yaw: CoeffModel {
                c0: 0.0007,
                beta: 0.12,
                r_n: -0.15,
                aileron: -0.03,
                rudder: -0.05,
                ..z
            },
        }
    }
    /// The six coefficients at `x`.
    pub fn eval(&self, x: &AeroInput) -> Coefficients {
        Coefficients {
            lift: self.lift.eval(x),
            drag: self.drag.eval(x),
            side: self.side.eval(x),
            roll: self.roll.eval(x),
            pitch: self.pitch.eval(x),
            yaw: self.yaw.eval(x),
        }
    }
    /// Coefficient-wise sum.
    pub fn plus(&self, d: &Self) -> Self {
        Self {
            lift: self.lift.plus(&d.lift),
            drag: self.drag.plus(&d.drag),
            side: self.side.plus(&d.side),
            roll: self.roll.plus(&d.roll),
            pitch: self.pitch.plus(&d.pitch),
            yaw: self.yaw.plus(&d.yaw),
        }
    }
    /// The six models in the order L, D, Y, l, m, n.
    pub fn to_array(&self) -> [CoeffModel; 6] {
        [self.lift, self.drag, self.side, self.roll, self.pitch, self.yaw]
    }
}

/// Stall blending of lift and drag towards flat-plate values (README §1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StallBlend {
    /// Transition sharpness `M` (50 in `last_letter`).
    pub m: f64,
    /// Stall angle `α₀`, rad (0.4712 in `last_letter`).
    pub alpha0_rad: f64,
}

impl Default for StallBlend {
    fn default() -> Self {
        Self {
            m: 50.0,
            alpha0_rad: 0.4712,
        }
    }
}

impl StallBlend {
    /// The blending weight `σ(α)` ∈ [0, 1] (0 attached flow, 1 flat plate).
    pub fn sigma(&self, alpha: f64) -> f64 {
        let a = (-self.m * (alpha - self.alpha0_rad)).exp();
        let b = (self.m * (alpha + self.alpha0_rad)).exp();
        (1.0 + a + b) / ((1.0 + a) * (1.0 + b))
    }
}

/// The effects of the truth model beyond eq. 3, each switchable and sized. `None`/`false` = off.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TruthEffects {
    /// Stall blending of `C_L`, `C_D` to flat plate: `C_L = (1−σ)C_L,lin + σ 2 sign α sin²α cos α`,
    /// `C_D = (1−σ)C_D,lin + σ 2|sin³α|` (the README writes `2 sign(α) sin³α`, negative drag for
    /// α < 0; we use the magnitude — equal for α > 0).
    pub stall: Option<StallBlend>,
    /// Oswald factor `e` of an added induced drag `C_L,lin²/(π e AR)`.
    pub induced_drag_oswald: Option<f64>,
    /// Elevator drag `k |δe|`, `k` in 1/rad.
    pub elevator_drag_per_rad: Option<f64>,
    /// Use `C_Dα |α|` instead of `C_Dα α` (the later `last_letter` code).
    pub drag_abs_alpha: bool,
    /// Thrust acting at the propeller mount (off: thrust through the CG, no moment).
    pub thrust_moment: bool,
    /// Propeller reaction torque `−Q` about body x (a propeller turning clockwise seen from behind).
    pub prop_torque: bool,
    /// A quadratic lift term `C_Lα² α²` (1/rad²) added to the linear lift before the drag effects
    /// (a lift-curve nonlinearity eq. 3a lacks). Off by default.
    pub lift_alpha2_per_rad2: Option<f64>,
    /// A downwash-lag pitching moment `C_mα̇ · α̇ c̄/(2V)`. `α̇` is the rate of the
    /// air-relative angle of attack (steady air; the gust is held over an output period), formed in
    /// [`super::dynamics::Plant::evaluate`] from the body acceleration. Off by default.
    pub pitch_alpha_dot: Option<f64>,
    /// A cross-coupling rolling moment `C_lαβ · α β` (1/rad²): the dihedral effect growing with
    /// angle of attack. Off by default.
    pub roll_alpha_beta_per_rad2: Option<f64>,
    /// A pitching moment `C_mβ² · β²` (1/rad²): sideslip changing the pitching moment (a V-tail,
    /// fuselage crossflow). Off by default.
    pub pitch_beta2_per_rad2: Option<f64>,
}

impl TruthEffects {
    /// Every hidden effect off: the truth is exactly eq. 3 (and thrust acts through the CG).
    pub fn none() -> Self {
        Self::default()
    }
    /// The `last_letter`-like default: stall (M 50, α₀ 0.4712), induced drag with e = 0.9, elevator
    /// drag 0.05/rad, the thrust moment of the mount and the propeller torque.
    pub fn all() -> Self {
        Self {
            stall: Some(StallBlend::default()),
            induced_drag_oswald: Some(0.9),
            elevator_drag_per_rad: Some(0.05),
            drag_abs_alpha: false,
            thrust_moment: true,
            prop_torque: true,
            lift_alpha2_per_rad2: None,
            pitch_alpha_dot: None,
            roll_alpha_beta_per_rad2: None,
            pitch_beta2_per_rad2: None,
        }
    }
}

/// An abrupt change of the linear coefficients (simulated damage) at a given time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterJump {
    /// Time of the change, s.
    pub at_s: f64,
    /// Added to the linear model from `at_s` on.
    pub delta: LinearAero,
}

/// The truth aerodynamics: linear part, hidden effects, aspect ratio (for induced drag).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthAero {
    /// The eq. 3 part.
    pub linear: LinearAero,
    /// The hidden effects.
    pub effects: TruthEffects,
    /// Aspect ratio `b²/S`.
    pub aspect_ratio: f64,
}

impl TruthAero {
    /// The truth coefficients at `x`.
    pub fn coefficients(&self, x: &AeroInput) -> Coefficients {
        let mut c = self.linear.eval(x);
        let a = x.alpha_rad;
        let e = &self.effects;
        if let Some(k) = e.lift_alpha2_per_rad2 {
            c.lift += k * a * a;
        }
        if let Some(k) = e.roll_alpha_beta_per_rad2 {
            c.roll += k * a * x.beta_rad;
        }
        if let Some(k) = e.pitch_beta2_per_rad2 {
            c.pitch += k * x.beta_rad * x.beta_rad;
        }
        if e.drag_abs_alpha {
            c.drag += self.linear.drag.alpha * (a.abs() - a);
        }
        if let Some(osw) = e.induced_drag_oswald {
            c.drag += c.lift * c.lift / (core::f64::consts::PI * osw * self.aspect_ratio);
        }
        if let Some(k) = e.elevator_drag_per_rad {
            c.drag += k * x.elevator_rad.abs();
        }
        if let Some(st) = e.stall {
            let s = st.sigma(a);
            let (sa, ca) = a.sin_cos();
            c.lift = (1.0 - s) * c.lift + s * 2.0 * a.signum() * sa * sa * ca;
            c.drag = (1.0 - s) * c.drag + s * 2.0 * (sa * sa * sa).abs();
        }
        c
    }

    /// The eq. 3 coefficients of the truth at `x0`: first derivatives by central differences
    /// (step 1e-6), `C_Dα²` from the second difference in α (step 1e-3, exact for a quadratic), and
    /// intercepts so the linear model passes through the truth at `x0`. Only `C_D` gets an α² term.
    pub fn linearise(&self, x0: &AeroInput) -> LinearAero {
        let base = x0.to_array();
        let f = |v: [f64; 8]| self.coefficients(&AeroInput::from_array(v)).to_array();
        let f0 = f(base);
        let mut slopes = [[0.0; 8]; 6];
        let h = 1e-6;
        for j in 0..8 {
            let (mut up, mut dn) = (base, base);
            up[j] += h;
            dn[j] -= h;
            let (fu, fd) = (f(up), f(dn));
            for i in 0..6 {
                slopes[i][j] = (fu[i] - fd[i]) / (2.0 * h);
            }
        }
        let h2 = 1e-3;
        let (mut up, mut dn) = (base, base);
        up[0] += h2;
        dn[0] -= h2;
        let drag_a2 = (f(up)[1] - 2.0 * f0[1] + f(dn)[1]) / (2.0 * h2 * h2);
        let model = |i: usize| {
            let a2 = if i == 1 { drag_a2 } else { 0.0 };
            let s = slopes[i];
            let alpha = s[0] - 2.0 * a2 * base[0];
            let mut c0 = f0[i] - a2 * base[0] * base[0] - alpha * base[0];
            for j in 1..8 {
                c0 -= s[j] * base[j];
            }
            CoeffModel::from_array([c0, alpha, a2, s[1], s[2], s[3], s[4], s[5], s[6], s[7]])
        };
        LinearAero {
            lift: model(0),
            drag: model(1),
            side: model(2),
            roll: model(3),
            pitch: model(4),
            yaw: model(5),
        }
    }
}

/// Reference geometry for eq. 1–2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Wing area `S`, m².
    pub wing_area_m2: f64,
    /// Span `b`, m.
    pub span_m: f64,
    /// Mean chord `c̄`, m.
    pub chord_m: f64,
}

/// Eq. 1–2: body-frame aerodynamic force (N) and moment (N·m) from the coefficients.
pub fn force_moment(c: &Coefficients, qbar_pa: f64, g: &Geometry, alpha_rad: f64) -> (Vector3<f64>, Vector3<f64>) {
    let qs = qbar_pa * g.wing_area_m2;
    let (sa, ca) = alpha_rad.sin_cos();
    let f = Vector3::new(
        qs * (-c.drag * ca + c.lift * sa),
        qs * c.side,
        qs * (-c.drag * sa - c.lift * ca),
    );
    let m = Vector3::new(qs * g.span_m * c.roll, qs * g.chord_m * c.pitch, qs * g.span_m * c.yaw);
    (f, m)
}

/// Eq. 1–2 solved for the coefficients (the inverse of [`force_moment`]).
pub fn coefficients_from(
    f: &Vector3<f64>,
    m: &Vector3<f64>,
    qbar_pa: f64,
    g: &Geometry,
    alpha_rad: f64,
) -> Coefficients {
    let qs = qbar_pa * g.wing_area_m2;
    let (sa, ca) = alpha_rad.sin_cos();
    Coefficients {
        drag: -(f.x * ca + f.z * sa) / qs,
        lift: (f.x * sa - f.z * ca) / qs,
        side: f.y / qs,
        roll: m.x / (qs * g.span_m),
        pitch: m.y / (qs * g.chord_m),
        yaw: m.z / (qs * g.span_m),
    }
}
