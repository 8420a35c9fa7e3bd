//! What a measured flight can support: a data-quality assessment made before the model-gap
//! analysis (from the channels and what the reader learned, [`LogMeta`]) and completed after it
//! (from the regressors and the held-out fit).
//!
//! It answers three questions, in the report's text and JSON (`data_quality`):
//! * **Warnings** — each a sentence: the rate each channel was logged at, the duration, gaps
//!   (dropped messages), repeated timestamps, channels that are constant or zero padding,
//!   saturated controls, nearly collinear regressors (condition number), parameters the data do
//!   not determine (standard error larger than half the estimate).
//! * **What can be identified from what is logged** — per coefficient, whether it can be formed at
//!   all and what is missing: no airspeed → no coefficient (q̄ = ½ρV² normalises every one); no
//!   aircraft file → nothing scaled; no surface deflection → no control derivative of it; no
//!   thrust → C_D holds thrust too (not separable); no α/β vane → no α, β (the analysis's inertial
//!   reconstruction, which assumes steady air per segment, is anchored to a measured α), so no
//!   C_L, C_D and no α or β derivative.
//!   With the α-free mode ([`super::flow_angles`]) α and β are estimated from the ground velocity,
//!   the attitude and a fitted wind; the air data then say so with the wind, the pitot scale and
//!   α's σ, the assumptions are listed in the warnings, and each coefficient's notes give the
//!   uncertainty it inherits (β derivatives flagged weak where the sideslip excitation is under
//!   3 σ).
//!   Where α comes from is [`LogMeta::origin`]: a logged α that is an autopilot's estimate
//!   (ArduPilot's `AOA`, a map's or a CSV column's statement) is reported as estimated, with its
//!   estimator, and `channel_origin` lists each flow channel's origin.
//! * **Whether a verdict is supported** — if not, the reasons, and the gap analysis names nothing
//!   (the model-gap analysis, `aerosid::gaps::run_gaps`, clears its causes and says "no verdict").
//!
//! ## The thresholds, and why
//! * **Time-base rate ≥ 20 Hz.** The analysis smooths and differentiates over ±0.1 s
//!   (`aerosid::gaps::GapSettings::smoothing_half_width_s`); below 20 Hz that window holds fewer
//!   than 2 samples a side.
//! * **Motion channels logged at ≥ 5 Hz** (rates, accelerations, attitude, α, β, surfaces). The
//!   short-period and roll modes of small UAVs lie near 1–2.5 Hz; a channel sampled below twice
//!   that (Nyquist) cannot follow them, and its interpolation is a straight line through them.
//!   Below 25 Hz a warning (10 samples per period of a 2.5 Hz mode).
//! * **Airspeed logged at ≥ 2 Hz.** It scales every coefficient (q̄ ∝ V²); at 1 Hz a climb or a
//!   dive changes it by several m/s between samples.
//! * **Duration ≥ 2 × folds × block** (20 s with the gap analysis's defaults, 5 folds of 2-s
//!   blocks; [`Needs`]): the held-out test needs at least two blocks per fold.
//! * **In the air.** A log whose land detector (or airspeed) says the vehicle never flew supports
//!   nothing aerodynamic.
//! * **The baseline predicts something.** If no coefficient's baseline has a held-out R² above
//!   zero, the model explains nothing on new data, and a "missing term" cannot be told from noise.
//! * **An estimated α good enough to rest a verdict on**: σ_α ≤ 0.035 rad (2°) and α varying by
//!   at least 3 × its σ after the analysis's smoothing (RMS; then an errors-in-variables bias of
//!   the α terms is at most 1/9 ≈ 11 %); an α from the autopilot's wind estimate (unknown σ)
//!   supports none.
//! * Warnings only: condition number of the baseline's regressors (columns scaled to unit length)
//!   above 100, a baseline parameter with |value| < 2σ, a control at its limit for more than 5 %
//!   of the samples.

use super::measured::{LogMeta, MeasuredFlight, Quantity, ThrustSource};
use nalgebra::DMatrix;
use serde::Serialize;

/// Below this time-base rate, Hz, no verdict.
pub const MIN_RATE_HZ: f64 = 20.0;
/// Below this logged rate of a motion channel, Hz, no verdict.
pub const MIN_MOTION_RATE_HZ: f64 = 5.0;
/// Below this logged rate of a motion channel, Hz, a warning.
pub const WARN_MOTION_RATE_HZ: f64 = 25.0;
/// Below this logged airspeed rate, Hz, no verdict.
pub const MIN_AIRSPEED_RATE_HZ: f64 = 2.0;
/// Above this condition number of the baseline's scaled regressors, a warning.
pub const WARN_CONDITION: f64 = 100.0;
/// Share of samples at a control's limit above which it is called saturated.
pub const SATURATED_SHARE: f64 = 0.05;
/// Above this 1-σ of an estimated α (no vane), rad, no verdict (2°: about the α excursion of a
/// small UAV's elevator doublet, so a larger error would mask any α term).
pub const MAX_ESTIMATED_ALPHA_SIGMA_RAD: f64 = 0.035;
/// An estimated α or β must vary by at least this many times its σ (RMS) for its derivatives to
/// be told from the estimate's error.
pub const MIN_EXCITATION_OVER_SIGMA: f64 = 3.0;

/// What the analysis that will use a flight needs of it, for the assessment to judge against: the
/// coefficients it forms and the shape of its held-out test. The model-gap analysis states its
/// own (`aerosid::gaps::quality::needs`).
#[derive(Debug, Clone, PartialEq)]
pub struct Needs<'a> {
    /// The aerodynamic coefficients to judge, by name: `C_L`, `C_D`, `C_Y` (forces), `C_l`, `C_m`,
    /// `C_n` (moments).
    pub coefficients: &'a [&'a str],
    /// Folds of the held-out test.
    pub folds: usize,
    /// Block length of the held-out test, s.
    pub block_s: f64,
}

/// Whether one coefficient can be identified from what is logged.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identifiability {
    /// `C_L` …
    pub coefficient: String,
    /// Whether it can be formed and fitted at all.
    pub identifiable: bool,
    /// What is missing or assumed (each a sentence).
    pub notes: Vec<String>,
}

/// The assessment.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct DataQuality {
    /// The file format, as the reader names it.
    pub format: String,
    /// Samples on the time base.
    pub samples: usize,
    /// Duration, s.
    pub duration_s: f64,
    /// Time-base rate, Hz.
    pub rate_hz: f64,
    /// The window read and why.
    pub window: Option<String>,
    /// How the channels were resampled.
    pub resampling: Option<String>,
    /// Where α and β come from.
    pub air_data: String,
    /// The α-free mode's estimate (wind fit, pitot scale, α/β σ, assumptions) or why there is
    /// none; `None` when it was not run.
    pub flow_angles: Option<super::flow_angles::FlowAngles>,
    /// Each flow channel present (`Alpha`, `Beta`, `Airspeed`) and where it comes from
    /// (`sensor`, `estimated: BY`; [`LogMeta::origin`]).
    pub channel_origin: std::collections::BTreeMap<String, String>,
    /// Warnings.
    pub warnings: Vec<String>,
    /// Per coefficient, what can be identified.
    pub coefficients: Vec<Identifiability>,
    /// Whether the data can support a verdict of the gap analysis.
    pub supports_verdict: bool,
    /// Why not (empty when it can).
    pub why_not: Vec<String>,
}

fn name(q: Quantity) -> &'static str {
    q.name()
}

/// The assessment of a flight before the analysis, against what the analysis `needs`.
///
/// The vendored HFB-320 record judged for the longitudinal coefficients:
///
/// ```
/// use aerosid_read::quality::{assess, table, Needs};
/// use std::path::Path;
///
/// let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data");
/// let flight = aerosid_read::read_measured(
///     &data.join("flight/hfb320_1_10.asc"),
///     &data.join("maps/hfb320.map"),
/// )?;
/// let needs = Needs { coefficients: &["C_L", "C_D", "C_m"], folds: 5, block_s: 2.0 };
/// let q = assess(&flight, &needs);
/// assert_eq!(q.coefficients.len(), 3);
/// assert!(q.coefficients.iter().all(|c| c.identifiable), "{}", table(&q));
/// # Ok::<(), aerosid_read::ReadError>(())
/// ```
pub fn assess(flight: &MeasuredFlight, needs: &Needs) -> DataQuality {
    let meta: &LogMeta = &flight.log;
    let n = flight.len();
    let duration_s = if n >= 2 { flight.t_s[n - 1] - flight.t_s[0] } else { 0.0 };
    let rate_hz = if duration_s > 0.0 {
        (n - 1) as f64 / duration_s
    } else {
        0.0
    };
    let mut found = Findings {
        warnings: meta.warnings.clone(),
        why_not: Vec::new(),
    };
    check_rates(meta, rate_hz, &mut found);
    check_duration_and_aircraft(meta, needs, duration_s, &mut found);
    let logged = Logged {
        flight,
        constant: check_channel_values(flight, &mut found),
    };
    let flow = meta.flow_angles.as_ref();
    let air = air_data(&logged, flow);
    if let Some(f) = flow.filter(|_| air.estimated) {
        check_estimated_alpha(f, &mut found);
    }
    let coefficients: Vec<Identifiability> = needs
        .coefficients
        .iter()
        .map(|&coef| identifiability(coef, &logged, flow.filter(|_| air.estimated)))
        .collect();
    let Findings { warnings, mut why_not } = found;
    if coefficients.iter().all(|c| !c.identifiable) {
        why_not.push("no coefficient can be identified from what is logged (see `coefficients`)".into());
    }
    DataQuality {
        format: meta.format.clone(),
        samples: n,
        duration_s,
        rate_hz,
        window: meta.window.clone(),
        resampling: meta.resampling.clone(),
        air_data: air.text,
        flow_angles: flow.cloned(),
        channel_origin: super::measured::channel_origin(flight),
        warnings,
        coefficients,
        supports_verdict: why_not.is_empty(),
        why_not,
    }
}

/// The warnings and the reasons for no verdict, in the order the checks find them.
struct Findings {
    warnings: Vec<String>,
    why_not: Vec<String>,
}

/// The flight's channels, with those constant at every sample (which carry no information).
struct Logged<'a> {
    flight: &'a MeasuredFlight,
    constant: Vec<Quantity>,
}

impl Logged<'_> {
    /// Whether `q` is logged at all.
    fn has(&self, q: Quantity) -> bool {
        self.flight.get(q).is_some()
    }

    /// Whether `q` is logged and varies.
    fn live(&self, q: Quantity) -> bool {
        self.has(q) && !self.constant.contains(&q)
    }
}

/// The time-base rate, and each channel's logged rate against what the motion it carries needs.
fn check_rates(meta: &LogMeta, rate_hz: f64, found: &mut Findings) {
    use Quantity::*;
    if rate_hz < MIN_RATE_HZ {
        found.why_not.push(format!(
            "the time base is {rate_hz:.1} Hz; the analysis smooths and differentiates over ±0.1 s and needs at least {MIN_RATE_HZ} Hz"
        ));
    }
    for (&q, &r) in &meta.logged_rate_hz {
        // The ground velocity and the autopilot's wind are slow channels (GPS 5–10 Hz, wind 1 Hz):
        // they feed the α-free mode's wind fit, not the dynamics, and are not held to the motion
        // channels' rates.
        let motion = !matches!(
            q,
            Airspeed
                | AirDensity
                | Altitude
                | Throttle
                | DynamicPressure
                | Mach
                | VelocityNorth
                | VelocityEast
                | VelocityDown
                | WindNorth
                | WindEast
        );
        if r >= rate_hz * 0.99 {
            continue;
        }
        if q == Airspeed && r < MIN_AIRSPEED_RATE_HZ {
            found.why_not.push(format!(
                "the airspeed is logged at {r:.2} Hz: it scales every coefficient (q̄ ∝ V²) and at below {MIN_AIRSPEED_RATE_HZ} Hz the changes between its samples are not in the data"
            ));
        } else if motion && r < MIN_MOTION_RATE_HZ {
            found.why_not.push(format!(
                "`{}` is logged at {r:.2} Hz, below {MIN_MOTION_RATE_HZ} Hz: it cannot follow the short-period and roll modes (1–2.5 Hz)",
                name(q)
            ));
        }
        if r < WARN_MOTION_RATE_HZ {
            found.warnings.push(format!(
                "`{}` logged at {r:.1} Hz, interpolated linearly onto {rate_hz:.1} Hz: motion faster than {:.1} Hz is not in it",
                name(q),
                r / 2.0
            ));
        }
    }
}

/// The duration against the held-out test's, whether the vehicle flew, whether it is known.
fn check_duration_and_aircraft(meta: &LogMeta, needs: &Needs, duration_s: f64, found: &mut Findings) {
    let min_duration = 2.0 * needs.folds as f64 * needs.block_s;
    if duration_s < min_duration {
        found.why_not.push(format!(
            "{duration_s:.1} s of data: the held-out test needs at least two {}-s blocks per fold ({min_duration:.0} s)",
            needs.block_s
        ));
    }
    if meta.airborne == Some(false) {
        found
            .why_not
            .push("the log says the vehicle never left the ground".into());
    }
    if meta.aircraft_unknown {
        found.why_not.push("no aircraft file: mass, inertia and geometry are unknown, so no coefficient can be scaled (give one with --with FILE.aircraft)".into());
    }
}

/// Constant channels (zero padding among them) and saturated controls, as warnings; returns the
/// constant channels.
fn check_channel_values(flight: &MeasuredFlight, found: &mut Findings) -> Vec<Quantity> {
    use Quantity::*;
    let n = flight.len();
    let mut constant = Vec::new();
    for (&q, x) in &flight.channels {
        let (lo, hi) = x
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
        if n >= 2 && hi - lo == 0.0 {
            constant.push(q);
            found.warnings.push(if lo == 0.0 {
                format!(
                    "`{}` is zero at every sample (zero padding: not logged, or no sensor); it carries no information",
                    name(q)
                )
            } else {
                format!(
                    "`{}` is constant ({lo}) at every sample; it carries no information",
                    name(q)
                )
            });
            continue;
        }
        if matches!(q, Elevator | Aileron | Rudder | Flap | Throttle) && hi > lo {
            check_saturation(q, x, (lo, hi), n, found);
        }
    }
    constant
}

/// A warning for each limit (`lo`, `hi`) at which the control `q` sits for more than
/// [`SATURATED_SHARE`] of the flight's `n` samples.
fn check_saturation(q: Quantity, x: &[f64], (lo, hi): (f64, f64), n: usize, found: &mut Findings) {
    let tol = 0.005 * (hi - lo);
    for (edge, what) in [(hi, "maximum"), (lo, "minimum")] {
        let k = x.iter().filter(|v| (**v - edge).abs() <= tol).count();
        if k as f64 > SATURATED_SHARE * n as f64 {
            found.warnings.push(format!(
                "`{}` sits at its {what} {edge:.4} for {:.0} % of the samples (saturated there: its effect is not separable from a constant)",
                name(q),
                100.0 * k as f64 / n as f64
            ));
        }
    }
}

/// Where α comes from, in words, and whether it is the α-free mode's estimate.
struct AirData {
    text: String,
    estimated: bool,
}

/// Where α comes from ([`LogMeta::origin`]): an estimator's α — the α-free mode's, whose
/// uncertainty it states, or the autopilot's, whose it does not — or a vane.
fn air_data(logged: &Logged, flow: Option<&super::flow_angles::FlowAngles>) -> AirData {
    use Quantity::*;
    let meta = &logged.flight.log;
    let estimated = flow.is_some_and(|f| f.status == "estimated") && logged.live(Alpha);
    let other_estimate = match meta.origin_of(Alpha) {
        super::measured::Origin::Estimated { by } if !estimated && logged.live(Alpha) => Some(by),
        _ => None,
    };
    let no_vane = "no α/β vane: none. The analysis's inertial reconstruction (`--air-data reconstructed`) integrates the accelerometers and gyros with steady air assumed per 5-s segment, but anchors each segment to a measured α (`gaps::compat::velocity_problem`), so without a vane there is no α or β: C_L and C_D (wind axes) and every α or β term are not identified";
    let text = if estimated {
        let f = flow.map_or(String::new(), |f| f.summary.clone());
        format!("estimated (no vane used): {f}")
    } else if let Some(by) = &other_estimate {
        format!(
            "estimated (no vane): α from {by}; its error, lag included, is not stated by the log: the gap analysis bounds it from the force the true α drives and carries it in the errors-in-variables model (its notes give the σ and correlation time, and a term the data cannot correct is listed as not identifiable), and α̇ is not offered in C_L (the lift restated)"
        )
    } else if logged.live(Alpha) {
        "measured: α (and β where logged) from vanes, airspeed from the pitot".to_string()
    } else {
        match flow {
            Some(f) if f.status == "off" => format!("{no_vane} ({})", f.summary),
            Some(f) if !f.why_not.is_empty() => format!(
                "{no_vane}. The α-free estimate (GPS velocity, attitude, wind) was not made: {}",
                f.why_not.join("; ")
            ),
            _ => no_vane.to_string(),
        }
    };
    AirData { text, estimated }
}

/// The α-free mode's assumptions as warnings, and whether its α is good enough to rest a verdict
/// on (σ and excitation).
fn check_estimated_alpha(f: &super::flow_angles::FlowAngles, found: &mut Findings) {
    for a in &f.assumptions {
        found.warnings.push(format!("α-free mode: {a}"));
    }
    if f.alpha_sigma_rad > MAX_ESTIMATED_ALPHA_SIGMA_RAD {
        found.why_not.push(format!(
            "the estimated α is uncertain to σ ≈ {:.3} rad ({:.1}°), more than {:.3} rad: a missing α term could not be told from the wind estimate's error",
            f.alpha_sigma_rad,
            f.alpha_sigma_rad.to_degrees(),
            MAX_ESTIMATED_ALPHA_SIGMA_RAD
        ));
    } else if !f.alpha_sigma_rad.is_finite() {
        found.why_not.push("the estimated α comes from the autopilot's wind estimate, whose uncertainty is unknown: no verdict rests on it".into());
    }
    if f.alpha_excitation_rad < MIN_EXCITATION_OVER_SIGMA * f.alpha_sigma_smoothed_rad {
        found.why_not.push(format!(
            "the estimated α varies by {:.3} rad RMS, less than {MIN_EXCITATION_OVER_SIGMA} × its σ after smoothing ({:.3} rad; gusts the constant wind does not follow): the α terms cannot be told from the estimate's error, and their fits would be biased low (errors in variables)",
            f.alpha_excitation_rad, f.alpha_sigma_smoothed_rad
        ));
    }
}

/// Whether one coefficient can be formed from what is logged, and what is missing or assumed;
/// `estimate` is the α-free mode's estimate when α comes from it.
fn identifiability(coef: &str, logged: &Logged, estimate: Option<&super::flow_angles::FlowAngles>) -> Identifiability {
    use Quantity::*;
    let flight = logged.flight;
    let mut notes = Vec::new();
    let mut ok = true;
    if !logged.live(Airspeed) {
        ok = false;
        notes.push("no airspeed logged: q̄ = ½ρV² is unknown, so no coefficient".into());
    }
    if flight.log.aircraft_unknown {
        ok = false;
        notes.push("no aircraft file: cannot be scaled".into());
    }
    if matches!(coef, "C_L" | "C_D" | "C_Y") {
        ok &= force_notes(coef, logged, estimate, &mut notes);
    } else {
        ok &= moment_notes(coef, logged, &mut notes);
    }
    let thrust_known =
        logged.has(Thrust) || (matches!(flight.aircraft.thrust, ThrustSource::Propeller(_)) && logged.live(PropSpeed));
    if coef == "C_D" && !thrust_known {
        notes
            .push("no thrust logged or modelled: C_D here holds thrust as well (drag and thrust not separable)".into());
    }
    surface_notes(coef, logged, &mut notes);
    if !logged.live(Alpha) && matches!(coef, "C_m") {
        notes.push("no α: no α derivative (C_mα), the moment is fitted to rates and controls only".into());
    }
    if matches!(coef, "C_Y" | "C_l" | "C_n") && !logged.live(Beta) {
        notes.push("no β: no β derivative (no vane)".into());
    }
    if let Some(f) = estimate {
        estimate_notes(coef, f, &mut notes);
    }
    Identifiability {
        coefficient: coef.to_string(),
        identifiable: ok,
        notes,
    }
}

/// A force coefficient's needs: the accelerations, and α for the wind axes; false when it cannot
/// be formed.
fn force_notes(
    coef: &str,
    logged: &Logged,
    estimate: Option<&super::flow_angles::FlowAngles>,
    notes: &mut Vec<String>,
) -> bool {
    use Quantity::*;
    let mut ok = true;
    let need: &[Quantity] = match coef {
        "C_Y" => &[AccelY],
        _ => &[AccelX, AccelZ],
    };
    for q in need {
        if !logged.live(*q) {
            ok = false;
            notes.push(format!("no `{}`: the force is not measured", name(*q)));
        }
    }
    if matches!(coef, "C_L" | "C_D") {
        if let Some(f) = estimate {
            notes.push(format!(
                "α estimated, not measured (σ ≈ {:.3} rad): the wind axes and the α derivatives carry that uncertainty",
                f.alpha_sigma_rad
            ));
        }
    }
    if matches!(coef, "C_L" | "C_D") && !logged.live(Alpha) {
        ok = false;
        notes.push("no α: the wind axes are unknown (no vane, and the inertial reconstruction needs one)".into());
    }
    ok
}

/// A moment coefficient's needs: the rates, and for the rolling and yawing moments the lateral
/// inertia; false when it cannot be formed.
fn moment_notes(coef: &str, logged: &Logged, notes: &mut Vec<String>) -> bool {
    use Quantity::*;
    let mut ok = true;
    let need: &[Quantity] = match coef {
        "C_m" => &[PitchRate],
        _ => &[RollRate, PitchRate, YawRate],
    };
    for q in need {
        if !logged.live(*q) {
            ok = false;
            notes.push(format!("no `{}`: the moment is not measured", name(*q)));
        }
    }
    let inertia = logged.flight.aircraft.inertia_kgm2;
    let lateral_inertia = inertia[(0, 0)].is_finite() && inertia[(2, 2)].is_finite() && inertia[(0, 2)].is_finite();
    if coef != "C_m" && !lateral_inertia {
        ok = false;
        notes
            .push("Jx, Jz or Jxz unknown in the aircraft file: the rolling and yawing moments cannot be formed".into());
    }
    ok
}

/// The control derivatives a coefficient loses for each surface not logged or not moved.
fn surface_notes(coef: &str, logged: &Logged, notes: &mut Vec<String>) {
    use Quantity::*;
    let surfaces: &[(Quantity, &str)] = match coef {
        "C_L" | "C_m" => &[(Elevator, "elevator")],
        "C_Y" => &[(Rudder, "rudder")],
        "C_l" | "C_n" => &[(Aileron, "aileron"), (Rudder, "rudder")],
        _ => &[],
    };
    for (q, s) in surfaces {
        if !logged.live(*q) {
            notes.push(format!(
                "no {s} deflection {}: no {s} derivative",
                if logged.has(*q) { "variation" } else { "logged" }
            ));
        }
    }
}

/// The uncertainty a coefficient inherits from the α-free mode's α and β.
fn estimate_notes(coef: &str, f: &super::flow_angles::FlowAngles, notes: &mut Vec<String>) {
    if coef == "C_m" {
        notes.push(format!(
            "C_mα from the estimated α (σ ≈ {:.3} rad, α varies by {:.3} rad RMS)",
            f.alpha_sigma_rad, f.alpha_excitation_rad
        ));
    }
    if matches!(coef, "C_Y" | "C_l" | "C_n") {
        let weak = f.beta_excitation_rad.is_nan()
            || f.beta_excitation_rad < MIN_EXCITATION_OVER_SIGMA * f.beta_sigma_smoothed_rad;
        notes.push(format!(
            "β estimated (σ ≈ {:.3} rad; β varies by {:.3} rad RMS){}",
            f.beta_sigma_rad,
            f.beta_excitation_rad,
            if weak {
                format!(": the sideslip excitation is under {MIN_EXCITATION_OVER_SIGMA} × the estimate's σ, so the β derivatives are weakly determined (fly rudder doublets)")
            } else {
                String::new()
            }
        ));
    }
}

/// The condition number of `cols` (each scaled to unit length) over their first `n` samples
/// (ratio of the largest to the smallest singular value); infinite when a column is zero.
pub fn condition_number(cols: &[&[f64]], n: usize) -> f64 {
    if cols.is_empty() || n == 0 {
        return f64::NAN;
    }
    let mut m = DMatrix::<f64>::zeros(n, cols.len());
    for (j, c) in cols.iter().enumerate() {
        let norm = c[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return f64::INFINITY;
        }
        for i in 0..n {
            m[(i, j)] = c[i] / norm;
        }
    }
    let sv = m.singular_values();
    let (mx, mn) = sv
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), v| (a.max(*v), b.min(*v)));
    if mn > 0.0 {
        mx / mn
    } else {
        f64::INFINITY
    }
}

/// The assessment as text, one item a line.
pub fn table(q: &DataQuality) -> String {
    let mut s = String::new();
    s += &format!(
        "data quality — {}{} samples, {:.2} s, {:.1} Hz\n",
        if q.format.is_empty() {
            String::new()
        } else {
            format!("{}: ", q.format)
        },
        q.samples,
        q.duration_s,
        q.rate_hz
    );
    if let Some(w) = &q.window {
        s += &format!("   window: {w}\n");
    }
    if let Some(r) = &q.resampling {
        s += &format!("   resampled: {r}\n");
    }
    s += &format!("   air data: {}\n", q.air_data);
    if !q.channel_origin.is_empty() {
        let list: Vec<String> = q.channel_origin.iter().map(|(c, o)| format!("{c} {o}")).collect();
        s += &format!("   channel origin: {}\n", list.join("; "));
    }
    for w in &q.warnings {
        s += &format!("   warning: {w}\n");
    }
    s += "   identifiable from what is logged:\n";
    for c in &q.coefficients {
        s += &format!(
            "     {:<4} {:<3} {}\n",
            c.coefficient,
            if c.identifiable { "yes" } else { "no" },
            c.notes.join("; ")
        );
    }
    if q.supports_verdict {
        s += "   the data can support a verdict\n";
    } else {
        s += "   NO VERDICT: these data cannot support one:\n";
        for w in &q.why_not {
            s += &format!("     - {w}\n");
        }
    }
    s
}
