//! Measured flight data as the model-gap analysis reads it: a time base and a set of named
//! channels, each in SI units and radians, body frame FRD, plus the aircraft's constants.
//!
//! Every reader (the project's CSV log, the column-map files for the shared flight-test data, PX4
//! ULog) produces a [`MeasuredFlight`]; the analysis never sees a file format. A channel that the
//! source does not measure is simply absent ([`MeasuredFlight::get`] returns `None`), so a
//! longitudinal-only test (the HFB-320) and a full 6-DoF log go through the same code.

use aerosid_core::aero::{Airframe, SensorSample};
use nalgebra::{Matrix3, Vector3};
use std::collections::BTreeMap;

/// A measured quantity, always in SI units and radians, body frame FRD.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Quantity {
    /// Specific force along body x at the accelerometer, m/s².
    AccelX,
    /// Specific force along body y, m/s².
    AccelY,
    /// Specific force along body z (≈ −9.81 in level flight), m/s².
    AccelZ,
    /// Roll rate p, rad/s.
    RollRate,
    /// Pitch rate q, rad/s.
    PitchRate,
    /// Yaw rate r, rad/s.
    YawRate,
    /// Measured (or pre-processed) roll acceleration ṗ, rad/s².
    RollAccel,
    /// Pitch acceleration q̇, rad/s².
    PitchAccel,
    /// Yaw acceleration ṙ, rad/s².
    YawAccel,
    /// True airspeed, m/s.
    Airspeed,
    /// Angle of attack, rad (at the vane unless the source says it is corrected to the CG).
    Alpha,
    /// Sideslip angle, rad.
    Beta,
    /// Bank angle φ, rad.
    Roll,
    /// Pitch attitude θ, rad.
    Pitch,
    /// Heading ψ, rad.
    Yaw,
    /// Elevator deflection, rad (positive trailing edge down).
    Elevator,
    /// Aileron deflection, rad (positive right aileron down).
    Aileron,
    /// Rudder deflection, rad (positive trailing edge left).
    Rudder,
    /// Flap deflection, rad.
    Flap,
    /// Throttle command, 0…1.
    Throttle,
    /// Propeller speed, rad/s.
    PropSpeed,
    /// Total thrust along the thrust line, N.
    Thrust,
    /// Left minus right engine thrust of a twin, N (the yaw moment of two engines at `±y_e` is
    /// `y_e·(F_L − F_R)`, see [`ThrustSource::MeasuredTwin`]). Added for the ATTAS and Twin Otter
    /// data, which log each engine.
    ThrustDifference,
    /// Dynamic pressure, Pa.
    DynamicPressure,
    /// Air density, kg/m³.
    AirDensity,
    /// Pressure altitude, m.
    Altitude,
    /// Mach number.
    Mach,
    /// Ground (inertial) velocity, north component, NED, m/s (GPS or the navigation filter).
    VelocityNorth,
    /// Ground velocity, east component, NED, m/s.
    VelocityEast,
    /// Ground velocity, down component, NED, m/s (positive descending).
    VelocityDown,
    /// The autopilot's own wind estimate, north component (velocity of the air), m/s; logged for
    /// comparison and as the wind of last resort when no airspeed is logged
    /// ([`crate::flow_angles`]).
    WindNorth,
    /// The autopilot's wind estimate, east component, m/s.
    WindEast,
}

/// How thrust is known.
#[derive(Debug, Clone, PartialEq)]
pub enum ThrustSource {
    /// A measured [`Quantity::Thrust`] channel, acting at `position_m` along a line pitched
    /// `pitch_rad` (positive nose up) from body x.
    Measured {
        /// Thrust point relative to the CG, body FRD, m.
        position_m: Vector3<f64>,
        /// Thrust line pitch relative to body x, rad.
        pitch_rad: f64,
    },
    /// Two engines mirrored about the x–z plane, the right one at `right_engine_position_m`, the
    /// left one at its mirror image; [`Quantity::Thrust`] is their sum and
    /// [`Quantity::ThrustDifference`] left minus right (ATTAS, Twin Otter).
    MeasuredTwin {
        /// Right engine's thrust point relative to the CG, body FRD, m (`y > 0`).
        right_engine_position_m: Vector3<f64>,
        /// Thrust line pitch relative to body x, rad.
        pitch_rad: f64,
    },
    /// Reconstructed from [`Quantity::PropSpeed`] and the airspeed by a propeller model.
    Propeller(aerosid_core::aero::Propeller<f64>),
    /// Not known (the analysis treats thrust as part of the axial-force coefficient).
    Unknown,
}

/// The aircraft's constants, as an aircraft file states them.
#[derive(Debug, Clone, PartialEq)]
pub struct Aircraft {
    /// A name for reports.
    pub name: String,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Inertia tensor about the CG, body FRD (with `−Jxz` off the diagonal), kg·m².
    pub inertia_kgm2: Matrix3<f64>,
    /// Wing reference area, m².
    pub wing_area_m2: f64,
    /// Span, m.
    pub span_m: f64,
    /// Mean aerodynamic chord, m.
    pub chord_m: f64,
    /// Accelerometer position relative to the CG, body FRD, m.
    pub accel_position_m: Vector3<f64>,
    /// α vane position relative to the CG, body FRD, m.
    pub alpha_vane_position_m: Vector3<f64>,
    /// β vane position relative to the CG, body FRD, m.
    pub beta_vane_position_m: Vector3<f64>,
    /// Airspeed (pitot) position relative to the CG, body FRD, m.
    pub airspeed_position_m: Vector3<f64>,
    /// The point the moment coefficients refer to, relative to the CG, body FRD, m (zero: the CG).
    pub moment_reference_m: Vector3<f64>,
    /// Thrust.
    pub thrust: ThrustSource,
}

impl Aircraft {
    /// The aircraft of an on-board [`Airframe`], sensors at the CG, thrust from the propeller model.
    pub fn from_airframe(name: &str, frame: &Airframe<f64>) -> Self {
        Self {
            name: name.to_string(),
            mass_kg: frame.mass_kg,
            inertia_kgm2: frame.inertia_kgm2,
            wing_area_m2: frame.wing_area_m2,
            span_m: frame.span_m,
            chord_m: frame.chord_m,
            accel_position_m: Vector3::zeros(),
            alpha_vane_position_m: Vector3::zeros(),
            beta_vane_position_m: Vector3::zeros(),
            airspeed_position_m: Vector3::zeros(),
            moment_reference_m: Vector3::zeros(),
            thrust: ThrustSource::Propeller(frame.propeller),
        }
    }
}

/// One measured flight (or manoeuvre): a strictly increasing time base and the channels measured
/// on it, all of the same length, finite, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFlight {
    /// Where it came from (file path or a generator's name), for reports and errors.
    pub source: String,
    /// Time, s, strictly increasing.
    pub t_s: Vec<f64>,
    /// The measured channels.
    pub channels: BTreeMap<Quantity, Vec<f64>>,
    /// The aircraft.
    pub aircraft: Aircraft,
    /// What the reader knows about the log beyond the channels (rates, window, parameters,
    /// warnings); empty for sources that need none.
    pub log: LogMeta,
}

/// What a reader learned about a log that the channels alone do not say: the rate each channel
/// was logged at before resampling, the window read, whether the vehicle was in the air, the
/// logged parameters, and warnings (dropped samples, gaps, all-zero columns). The data-quality
/// assessment ([`super::quality`]) reads it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LogMeta {
    /// The file format (`PX4 ULog`, `ArduPilot DataFlash`, `MATLAB .mat`, …); empty for the
    /// project's own sources.
    pub format: String,
    /// Per channel, the mean rate of its own samples in the window, Hz, before any resampling
    /// (absent: logged on the time base itself).
    pub logged_rate_hz: BTreeMap<Quantity, f64>,
    /// How the channels were brought onto the time base (`None`: not resampled).
    pub resampling: Option<String>,
    /// The time window read and why (`None`: the whole file).
    pub window: Option<String>,
    /// Whether the log says the vehicle was in the air over the window (`None`: it does not say).
    pub airborne: Option<bool>,
    /// The aircraft's constants are placeholders (no aircraft file given): coefficients cannot be
    /// scaled.
    pub aircraft_unknown: bool,
    /// Logged parameters (name → value).
    pub parameters: BTreeMap<String, f64>,
    /// Warnings from reading (each a sentence naming the topic or message).
    pub warnings: Vec<String>,
    /// Where α and β come from when the α-free mode ([`super::flow_angles::prepare`]) was run:
    /// the vanes, an estimate (with its wind fit and uncertainty) or why there is none
    /// (`None`: not run; the vanes as logged).
    pub flow_angles: Option<super::flow_estimate::FlowAngles>,
    /// Where a channel's values come from, for the channels that are not a sensor's own reading
    /// (absent: measured by a sensor — a vane, a pitot, the IMU). Readers set it where the
    /// format says so (ArduPilot's `AOA`/`SSA`, a PX4 wind-based estimate), a column map or a
    /// CSV column name can state it, and the α-free mode sets it for what it estimates.
    pub origin: BTreeMap<Quantity, Origin>,
    /// The manoeuvres of a pooled flight ([`MeasuredFlight::pool`]), in order on its time base;
    /// empty: one piece, the whole flight. Every time-domain stage of the analysis (smoothing,
    /// differentiation, the flight-path reconstruction's initial states, the block means) runs
    /// per piece, never across a join.
    pub pieces: Vec<Piece>,
    /// How each channel's samples were formed from the signal: what the low-rate analysis's
    /// intersample model and its timing resolution read.
    pub sampling: Sampling,
}

/// How a channel's samples were formed from the continuous signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sampling {
    /// The source does not say (a CSV, a column-mapped file, a resampled log): a sample may be
    /// the signal at its time stamp or a mean over the interval before it, so the time of what a
    /// sample measures is known to half a sample interval only.
    #[default]
    Unstated,
    /// Each sample is the signal at its time stamp (the simulator's samples).
    Points,
    /// Each sample is the signal's mean over its sample interval, stamped at the interval's
    /// centre ([`MeasuredFlight::block_means`] of point samples or of such means).
    CentredMeans,
}

/// One manoeuvre of a pooled flight: where its samples lie on the pooled time base and where
/// they came from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Piece {
    /// The file (or generator) it was read from.
    pub source: String,
    /// First sample on the pooled time base.
    pub start: usize,
    /// One past its last sample.
    pub end: usize,
    /// Its first and last sample's time in the source's own time, s.
    pub span_s: [f64; 2],
    /// Why it starts where it does (the file's start, a `--segment`, a time jump).
    pub cut: String,
}

/// A time step larger than this many median steps splits a record into pieces.
pub const JUMP_STEPS: f64 = 5.0;

/// Where a channel's values come from, when not from a sensor measuring that quantity itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// Measured by its own sensor (a vane, a pitot tube, the IMU).
    Sensor,
    /// Computed by an estimator from other channels (the autopilot's α/β from its inertial
    /// solution and a wind estimate, the α-free mode's wind triangle, a synthetic airspeed).
    /// Such a channel has no vane errors (scale, bias, vane delay); its error, lag included, is
    /// an error in the variable, and a candidate that restates the inertial data through a
    /// kinematic identity (α̇ in C_L when α comes from the inertial data) is no aerodynamic cause.
    Estimated {
        /// What estimated it, in words (`ArduPilot AOA message`, `wind triangle (α-free mode)`).
        by: String,
    },
}

impl Origin {
    /// For reports: `sensor` or `estimated: BY`.
    pub fn describe(&self) -> String {
        match self {
            Origin::Sensor => "sensor".into(),
            Origin::Estimated { by } => format!("estimated: {by}"),
        }
    }
}

/// The flow channels whose origin the reports show.
pub const FLOW_CHANNELS: [Quantity; 3] = [Quantity::Alpha, Quantity::Beta, Quantity::Airspeed];

/// Each flow channel present and where it comes from, for the report (`Alpha` →
/// `estimated: ArduPilot AOA.AOA …`, `Airspeed` → `sensor`).
pub fn channel_origin(flight: &MeasuredFlight) -> BTreeMap<String, String> {
    FLOW_CHANNELS
        .iter()
        .filter(|q| flight.get(**q).is_some())
        .map(|q| (format!("{q:?}"), flight.log.origin_of(*q).describe()))
        .collect()
}

impl LogMeta {
    /// Marks channel `q` as an estimator's output, `by` saying which estimator.
    pub fn set_estimated(&mut self, q: Quantity, by: &str) {
        self.origin.insert(q, Origin::Estimated { by: by.to_string() });
    }

    /// Where channel `q` comes from ([`Origin::Sensor`] unless stated otherwise).
    pub fn origin_of(&self, q: Quantity) -> Origin {
        self.origin.get(&q).cloned().unwrap_or(Origin::Sensor)
    }

    /// Whether channel `q` is an estimator's output, not a sensor's reading.
    pub fn is_estimated(&self, q: Quantity) -> bool {
        matches!(self.origin.get(&q), Some(Origin::Estimated { .. }))
    }
}

impl MeasuredFlight {
    /// A channel, if measured.
    pub fn get(&self, q: Quantity) -> Option<&[f64]> {
        self.channels.get(&q).map(|v| v.as_slice())
    }

    /// The flight at `1/k` of its rate: every channel the mean of `k` consecutive samples (the
    /// Euler angles unwrapped within the block first, so a yaw passing ±π averages to the right
    /// heading, wrapped back), the time the block's mean time; an incomplete last block is
    /// dropped. `k ≤ 1`: a copy.
    ///
    /// Why block means (and not a sharper low-pass, then every `k`-th sample): white sensor noise
    /// stays white, with its variance divided by `k` — the noise model of the analysis
    /// (`aerosid::gaps::noise`) and its noise estimates assume white noise; every channel gets
    /// the same treatment, so no channel moves against another; a `k`-mean passes `cos`-shaped
    /// `sin(πfk h)/(k sin(πf h))`, 1 at 0, ≥ 0.97 up to a tenth of the new rate and 0 at the
    /// new rate itself, folding back only what lies between half the new rate and it.
    ///
    /// Block means of point samples (or of centred means) are centred means
    /// ([`Sampling::CentredMeans`]); of samples whose formation is unstated, still unstated.
    pub fn block_means(&self, k: usize) -> MeasuredFlight {
        if k <= 1 {
            return self.clone();
        }
        if self.log.pieces.len() > 1 {
            // Blocks never straddle a join: each piece is averaged alone.
            let parts = self
                .log
                .pieces
                .iter()
                .map(|p| (self.piece(p).block_means(k), p.clone()))
                .collect();
            return Self::concat(parts);
        }
        use core::f64::consts::{PI, TAU};
        let m = self.len() / k;
        let mean = |b: &[f64]| b.iter().sum::<f64>() / k as f64;
        // An angle's samples taken within ±π of the block's first, their mean wrapped back to ±π
        // when the first sample was there. `rem_euclid` is exact, and the identity on `[0, 2π)`,
        // so the usual case skips it.
        let angle_mean = |b: &[f64]| {
            let first = b[0];
            let near = |x: f64| {
                let y = x - first + PI;
                let wrapped = if (0.0..TAU).contains(&y) { y } else { y.rem_euclid(TAU) };
                first + wrapped - PI
            };
            let a = b.iter().map(|&x| near(x)).sum::<f64>() / k as f64;
            if (-PI..=PI).contains(&first) {
                (a + PI).rem_euclid(TAU) - PI
            } else {
                a
            }
        };
        let averaged =
            |v: &[f64], f: &dyn Fn(&[f64]) -> f64| -> Vec<f64> { v.chunks_exact(k).take(m).map(f).collect() };
        let channels = self
            .channels
            .iter()
            .map(|(q, v)| {
                let angle = matches!(q, Quantity::Roll | Quantity::Pitch | Quantity::Yaw);
                (
                    *q,
                    if angle {
                        averaged(v, &angle_mean)
                    } else {
                        averaged(v, &mean)
                    },
                )
            })
            .collect();
        let mut log = self.log.clone();
        if log.sampling == Sampling::Points {
            log.sampling = Sampling::CentredMeans;
        }
        MeasuredFlight {
            source: self.source.clone(),
            t_s: averaged(&self.t_s, &mean),
            channels,
            aircraft: self.aircraft.clone(),
            log,
        }
    }

    /// The pieces of the flight: [`LogMeta::pieces`], or one covering every sample.
    pub fn pieces(&self) -> Vec<Piece> {
        if !self.log.pieces.is_empty() {
            return self.log.pieces.clone();
        }
        let n = self.len();
        let span = [
            self.t_s.first().copied().unwrap_or(0.0),
            self.t_s.last().copied().unwrap_or(0.0),
        ];
        vec![Piece {
            source: self.source.clone(),
            start: 0,
            end: n,
            span_s: span,
            cut: "the whole record".into(),
        }]
    }

    /// The samples of piece `p` as a flight of their own (no pieces).
    pub fn piece(&self, p: &Piece) -> MeasuredFlight {
        let r = p.start..p.end;
        let mut log = self.log.clone();
        log.pieces.clear();
        MeasuredFlight {
            source: p.source.clone(),
            t_s: self.t_s[r.clone()].to_vec(),
            channels: self.channels.iter().map(|(q, v)| (*q, v[r.clone()].to_vec())).collect(),
            aircraft: self.aircraft.clone(),
            log,
        }
    }

    /// The samples from `from_s` to `to_s`, seconds from the first sample (`--segment`); `None`
    /// when fewer than two samples fall inside.
    pub fn window(&self, from_s: f64, to_s: f64) -> Option<MeasuredFlight> {
        let t0 = *self.t_s.first()?;
        let a = self.t_s.iter().position(|t| t - t0 >= from_s)?;
        let b = self.t_s.iter().rposition(|t| t - t0 <= to_s)? + 1;
        (b >= a + 2).then(|| {
            let mut f = self.piece(&Piece {
                source: self.source.clone(),
                start: a,
                end: b,
                span_s: [self.t_s[a], self.t_s[b - 1]],
                cut: String::new(),
            });
            f.log.window = Some(format!("{from_s} to {to_s} s from the first sample (--segment)"));
            f
        })
    }

    /// The record cut where its time jumps: a step above [`JUMP_STEPS`] median steps starts a new
    /// piece (an interrupted log, or manoeuvres spliced into one file). Each piece is
    /// `(flight, why it starts there)`; a record without jumps is one piece.
    pub fn split_at_jumps(&self) -> Vec<(MeasuredFlight, String)> {
        let n = self.len();
        if n < 3 {
            return vec![(self.clone(), "the file's start".into())];
        }
        let mut dts: Vec<f64> = self.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        let h = dts[dts.len() / 2];
        let mut cuts = vec![0];
        for i in 1..n {
            let d = self.t_s[i] - self.t_s[i - 1];
            // A NaN step counts as a jump.
            if d.is_nan() || d > JUMP_STEPS * h {
                cuts.push(i);
            }
        }
        cuts.push(n);
        cuts.windows(2)
            .map(|w| {
                let why = if w[0] == 0 {
                    "the file's start".to_string()
                } else {
                    format!(
                        "a time jump from {:.4} s to {:.4} s (more than {JUMP_STEPS} median steps of {h:.4} s)",
                        self.t_s[w[0] - 1],
                        self.t_s[w[0]]
                    )
                };
                let mut f = self.piece(&Piece {
                    source: self.source.clone(),
                    start: w[0],
                    end: w[1],
                    span_s: [self.t_s[w[0]], self.t_s[w[1] - 1]],
                    cut: String::new(),
                });
                f.log.window = self.log.window.clone();
                (f, why)
            })
            .collect()
    }

    /// Several manoeuvres as one flight: the pieces sorted canonically (by source, then start
    /// time) so that nothing downstream depends on the order they were given in, then laid end
    /// to end on a pooled uniform time base (each piece keeps its own span in
    /// [`Piece::span_s`]). One piece is returned as it is (no pieces recorded). Every piece must
    /// have the same channels, aircraft and step (within 1 %).
    pub fn pool(mut parts: Vec<(MeasuredFlight, String)>) -> Result<MeasuredFlight, String> {
        if parts.is_empty() {
            return Err("no manoeuvre to pool".into());
        }
        parts.sort_by(|(a, _), (b, _)| {
            a.source.cmp(&b.source).then(
                a.t_s
                    .first()
                    .copied()
                    .unwrap_or(0.0)
                    .total_cmp(&b.t_s.first().copied().unwrap_or(0.0)),
            )
        });
        if parts.len() == 1 {
            return Ok(parts.pop().map(|(f, _)| f).unwrap_or_else(|| unreachable!()));
        }
        let step = |f: &MeasuredFlight| {
            let n = f.len();
            if n < 2 {
                f64::NAN
            } else {
                (f.t_s[n - 1] - f.t_s[0]) / (n - 1) as f64
            }
        };
        let (first, _) = &parts[0];
        let h = step(first);
        for (f, _) in &parts[1..] {
            let where_ = || format!("{} ({:.3}–{:.3} s)", f.source, f.t_s[0], f.t_s[f.len() - 1]);
            if f.len() < 2 || (step(f) - h).abs() > 0.01 * h {
                return Err(format!(
                    "{}: its step {:.5} s differs from {:.5} s of {}: pooled manoeuvres must share one rate (resample them to one rate, e.g. the reader's --rate)",
                    where_(),
                    step(f),
                    h,
                    first.source
                ));
            }
            let keys = |f: &MeasuredFlight| f.channels.keys().copied().collect::<Vec<_>>();
            if keys(f) != keys(first) {
                return Err(format!(
                    "{}: channels {:?} differ from {:?} of {}: pooled manoeuvres must log the same channels",
                    where_(),
                    keys(f),
                    keys(first),
                    first.source
                ));
            }
            if f.aircraft != first.aircraft {
                return Err(format!(
                    "{}: another aircraft than {} ({} vs {}): give every file the same aircraft",
                    where_(),
                    first.source,
                    f.aircraft.name,
                    first.aircraft.name
                ));
            }
        }
        let parts = parts
            .into_iter()
            .map(|(f, cut)| {
                let piece = Piece {
                    source: f.source.clone(),
                    start: 0,
                    end: f.len(),
                    span_s: [f.t_s[0], f.t_s[f.len() - 1]],
                    cut,
                };
                (f, piece)
            })
            .collect();
        Ok(Self::concat(parts))
    }

    /// The parts end to end on a uniform time base of the first part's step, starting at its
    /// first time; the pieces recorded with their new sample ranges.
    fn concat(parts: Vec<(MeasuredFlight, Piece)>) -> MeasuredFlight {
        let mut out = parts[0].0.clone();
        out.log.pieces.clear();
        let n0 = out.len();
        let h = if n0 > 1 {
            (out.t_s[n0 - 1] - out.t_s[0]) / (n0 - 1) as f64
        } else {
            1.0
        };
        let t0 = out.t_s.first().copied().unwrap_or(0.0);
        out.t_s.clear();
        for v in out.channels.values_mut() {
            v.clear();
        }
        if parts.iter().any(|(f, _)| f.log.sampling != out.log.sampling) {
            out.log.sampling = Sampling::Unstated;
        }
        let mut sources: Vec<String> = Vec::new();
        for (f, mut p) in parts {
            let start = out.t_s.len();
            out.t_s.extend((0..f.len()).map(|i| t0 + (start + i) as f64 * h));
            for (q, v) in &f.channels {
                if let Some(o) = out.channels.get_mut(q) {
                    o.extend_from_slice(v);
                }
            }
            for w in &f.log.warnings {
                if !out.log.warnings.contains(w) {
                    out.log.warnings.push(w.clone());
                }
            }
            p.start = start;
            p.end = out.t_s.len();
            if !sources.contains(&p.source) {
                sources.push(p.source.clone());
            }
            out.log.pieces.push(p);
        }
        out.source = sources.join(" + ");
        out.log.window = None;
        out
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// A flight from the project's own sensor samples (the simulator's logs, `aerosid simulate`):
    /// every channel of [`SensorSample`] becomes a channel here.
    pub fn from_samples(source: &str, samples: &[SensorSample<f64>], aircraft: Aircraft) -> Self {
        use Quantity::*;
        let col = |f: &dyn Fn(&SensorSample<f64>) -> f64| samples.iter().map(f).collect::<Vec<_>>();
        let mut channels = BTreeMap::new();
        channels.insert(AccelX, col(&|s| s.accel_mps2.x));
        channels.insert(AccelY, col(&|s| s.accel_mps2.y));
        channels.insert(AccelZ, col(&|s| s.accel_mps2.z));
        channels.insert(RollRate, col(&|s| s.gyro_rad_s.x));
        channels.insert(PitchRate, col(&|s| s.gyro_rad_s.y));
        channels.insert(YawRate, col(&|s| s.gyro_rad_s.z));
        channels.insert(Airspeed, col(&|s| s.airspeed_mps));
        channels.insert(Alpha, col(&|s| s.alpha_rad));
        channels.insert(Beta, col(&|s| s.beta_rad));
        channels.insert(Roll, col(&|s| s.euler_rad.x));
        channels.insert(Pitch, col(&|s| s.euler_rad.y));
        channels.insert(Yaw, col(&|s| s.euler_rad.z));
        channels.insert(PropSpeed, col(&|s| s.prop_speed_rad_s));
        channels.insert(Elevator, col(&|s| s.elevator_rad));
        channels.insert(Aileron, col(&|s| s.aileron_rad));
        channels.insert(Rudder, col(&|s| s.rudder_rad));
        channels.insert(Throttle, col(&|s| s.throttle));
        channels.insert(AirDensity, col(&|s| s.air_density_kgpm3));
        Self {
            source: source.to_string(),
            t_s: col(&|s| s.t_s),
            channels,
            aircraft,
            // The simulator's samples are the sensors' readings at the sample instant.
            log: LogMeta {
                sampling: Sampling::Points,
                ..LogMeta::default()
            },
        }
    }
}

impl Quantity {
    /// Every quantity, in declaration order.
    pub const ALL: [Quantity; 32] = [
        Quantity::AccelX,
        Quantity::AccelY,
        Quantity::AccelZ,
        Quantity::RollRate,
        Quantity::PitchRate,
        Quantity::YawRate,
        Quantity::RollAccel,
        Quantity::PitchAccel,
        Quantity::YawAccel,
        Quantity::Airspeed,
        Quantity::Alpha,
        Quantity::Beta,
        Quantity::Roll,
        Quantity::Pitch,
        Quantity::Yaw,
        Quantity::Elevator,
        Quantity::Aileron,
        Quantity::Rudder,
        Quantity::Flap,
        Quantity::Throttle,
        Quantity::PropSpeed,
        Quantity::Thrust,
        Quantity::ThrustDifference,
        Quantity::DynamicPressure,
        Quantity::AirDensity,
        Quantity::Altitude,
        Quantity::Mach,
        Quantity::VelocityNorth,
        Quantity::VelocityEast,
        Quantity::VelocityDown,
        Quantity::WindNorth,
        Quantity::WindEast,
    ];

    /// The snake-case name used in column-map files and error messages (`pitch_rate`).
    pub fn name(self) -> &'static str {
        use Quantity::*;
        match self {
            AccelX => "accel_x",
            AccelY => "accel_y",
            AccelZ => "accel_z",
            RollRate => "roll_rate",
            PitchRate => "pitch_rate",
            YawRate => "yaw_rate",
            RollAccel => "roll_accel",
            PitchAccel => "pitch_accel",
            YawAccel => "yaw_accel",
            Airspeed => "airspeed",
            Alpha => "alpha",
            Beta => "beta",
            Roll => "roll",
            Pitch => "pitch",
            Yaw => "yaw",
            Elevator => "elevator",
            Aileron => "aileron",
            Rudder => "rudder",
            Flap => "flap",
            Throttle => "throttle",
            PropSpeed => "prop_speed",
            Thrust => "thrust",
            ThrustDifference => "thrust_difference",
            DynamicPressure => "dynamic_pressure",
            AirDensity => "air_density",
            Altitude => "altitude",
            Mach => "mach",
            VelocityNorth => "vel_n",
            VelocityEast => "vel_e",
            VelocityDown => "vel_d",
            WindNorth => "wind_n",
            WindEast => "wind_e",
        }
    }

    /// The quantity of a [`Quantity::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|q| q.name() == name)
    }

    /// The SI unit the channel is stored in (`rad/s`, `1` for a pure number).
    pub fn si_unit(self) -> &'static str {
        use Quantity::*;
        match self {
            AccelX | AccelY | AccelZ => "m/s2",
            RollRate | PitchRate | YawRate => "rad/s",
            RollAccel | PitchAccel | YawAccel => "rad/s2",
            Airspeed | VelocityNorth | VelocityEast | VelocityDown | WindNorth | WindEast => "m/s",
            Alpha | Beta | Roll | Pitch | Yaw | Elevator | Aileron | Rudder | Flap => "rad",
            Throttle | Mach => "1",
            PropSpeed => "rad/s",
            Thrust | ThrustDifference => "N",
            DynamicPressure => "Pa",
            AirDensity => "kg/m3",
            Altitude => "m",
        }
    }
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why [`MeasuredFlight::validate`] refuses a flight: the sample (0-based index into `t_s`, if
/// one sample is at fault) and the channel (if one is), which a reader turns into a file line and
/// column.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// The first offending sample, 0-based.
    pub sample: Option<usize>,
    /// The offending channel (`None`: the time base or the whole flight).
    pub quantity: Option<Quantity>,
    /// What is wrong.
    pub message: String,
}

impl Invalid {
    /// The reader's message for a flight that fails [`MeasuredFlight::validate`]: the channel (or
    /// "time"), where it came from (`src`, e.g. `` (from `IMU.GyrX`)``, or empty) and the output
    /// sample with its time on `t_s`.
    pub fn describe(&self, src: &str, t_s: &[f64]) -> String {
        let at = self.sample.map_or(String::new(), |k| {
            format!(" at output sample {k} (t = {:.6} s)", t_s[k])
        });
        format!(
            "{}{src}{at}: {}",
            self.quantity.map_or("time".to_string(), |q| q.name().to_string()),
            self.message
        )
    }
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(q) = self.quantity {
            write!(f, "{q}: ")?;
        }
        if let Some(i) = self.sample {
            write!(f, "sample {i}: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for Invalid {}

/// Standard gravity, m/s² (used only by the plausibility bounds of [`MeasuredFlight::validate`]).
const G0_MPS2: f64 = 9.80665;

/// Share of samples beyond a "soft" bound that [`MeasuredFlight::validate`] takes as a unit
/// error (5 %): a real flight may pass a bound briefly, a channel in the wrong unit does so for
/// most of the record.
const SOFT_SHARE: f64 = 0.05;

/// The plausibility bounds of one channel (module doc of `docs/measured-data.md`, "checks").
struct Bounds {
    /// Any sample beyond `[hard.0, hard.1]` is refused.
    hard: (f64, f64),
    /// More than [`SOFT_SHARE`] of the samples with `|x| > soft` is refused.
    soft: f64,
    /// What a failure most likely means.
    hint: &'static str,
}

fn bounds(q: Quantity) -> Option<Bounds> {
    use std::f64::consts::PI;
    use Quantity::*;
    let b = |lo: f64, hi: f64, soft: f64, hint| {
        Some(Bounds {
            hard: (lo, hi),
            soft,
            hint,
        })
    };
    match q {
        Alpha | Beta | Elevator | Aileron | Rudder | Flap => b(-PI, PI, 1.5, "degrees given as radians?"),
        Pitch => b(-PI / 2.0 - 1e-6, PI / 2.0 + 1e-6, 1.5, "degrees given as radians?"),
        Roll => b(-PI - 1e-6, PI + 1e-6, PI, "degrees given as radians?"),
        Yaw => b(
            f64::NEG_INFINITY,
            f64::INFINITY,
            2.0 * PI + 0.1,
            "degrees given as radians?",
        ),
        RollRate | PitchRate | YawRate => b(-20.0, 20.0, 5.0, "deg/s given as rad/s?"),
        RollAccel | PitchAccel | YawAccel => b(-200.0, 200.0, 50.0, "deg/s² given as rad/s²?"),
        // A pitot at rest reads a few m/s either side of zero (the differential-pressure offset), so
        // a negative airspeed on the ground is not a unit error; −20 m/s is.
        Airspeed => b(-20.0, 350.0, 350.0, "ft/s or km/h given as m/s?"),
        AirDensity => b(0.1, 1.6, 1.6, "slug/ft³ given as kg/m³?"),
        // A small UAV's ground speed stays well below 150 m/s; a log in km/h or cm/s passes it.
        VelocityNorth | VelocityEast | VelocityDown => b(-150.0, 150.0, 100.0, "km/h, knots or cm/s given as m/s?"),
        WindNorth | WindEast => b(-60.0, 60.0, 40.0, "km/h or knots given as m/s?"),
        DynamicPressure => b(-500.0, 1.0e5, 1.0e5, "hPa or kPa given as Pa?"),
        Throttle => b(-0.05, 1.05, 1.05, "percent given as a fraction 0…1?"),
        Mach => b(0.0, 3.0, 3.0, "not a Mach number?"),
        Altitude => b(-1000.0, 30_000.0, 30_000.0, "not metres?"),
        PropSpeed => b(0.0, 2500.0, 2500.0, "rpm given as rad/s?"),
        AccelX | AccelY | AccelZ => b(-30.0 * G0_MPS2, 30.0 * G0_MPS2, 15.0 * G0_MPS2, "g given as m/s²?"),
        Thrust | ThrustDifference => None,
    }
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// Least-squares scale `k` of `y ≈ k·x + c` and the correlation of `x` and `y`.
fn scale_and_correlation(x: &[f64], y: &[f64]) -> (f64, f64) {
    let (mx, my) = (mean(x), mean(y));
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
        sxy += (a - mx) * (b - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return (f64::NAN, 0.0);
    }
    (sxy / sxx, sxy / (sxx * syy).sqrt())
}

/// Central differences of `x` over `t` at the inner samples.
fn central_difference(t: &[f64], x: &[f64]) -> Vec<f64> {
    (1..t.len().saturating_sub(1))
        .map(|i| (x[i + 1] - x[i - 1]) / (t[i + 1] - t[i - 1]))
        .collect()
}

impl MeasuredFlight {
    /// Checks a flight before analysis: at least two samples, every channel as long as the time
    /// base, the time finite and strictly increasing, every value finite (a non-finite value is
    /// refused, never interpolated), and the unit plausibility checks of `docs/measured-data.md`:
    /// * per channel, hard bounds on every sample and soft bounds that more than 5 % of the samples
    ///   may not pass (e.g. `|α| > 1.5 rad` over many samples: degrees given as radians);
    /// * the accelerometer: the mean specific-force magnitude between 0.5 g and 3 g (g or ft/s²
    ///   given as m/s²; with only `accel_z`, the mean `|a_z|` between 0.3 g and 3 g);
    /// * the dynamic pressure against the airspeed: the median implied `ρ = 2q̄/V²` (V > 10 m/s)
    ///   between 0.1 and 1.6 kg/m³ (sea level to ≈ 17 km) (lbf/ft² given as Pa);
    /// * derivative consistency: a measured rate against the central difference of its
    ///   integral — `q̇` against `dq/dt`, `ṗ` against `dp/dt`, `ṙ` against `dr/dt`, and `dθ/dt`
    ///   against `q cos φ − r sin φ` (Euler kinematics, 3-2-1) — must have a least-squares scale
    ///   between 0.5 and 2 where the two correlate (correlation > 0.5): a factor 57.3 means one of
    ///   the pair is in degrees.
    ///
    /// Airspeed in knots against m/s (factor 1.94) and thrust in lbf against N cannot be told
    /// from the data and are not checked.
    pub fn validate(&self) -> Result<(), Invalid> {
        let inv = |sample, quantity, message: String| Invalid {
            sample,
            quantity,
            message,
        };
        let n = self.t_s.len();
        if n < 2 {
            return Err(inv(None, None, format!("{n} samples; at least 2 are needed")));
        }
        for (i, t) in self.t_s.iter().enumerate() {
            if !t.is_finite() {
                return Err(inv(Some(i), None, format!("time {t} is not finite")));
            }
            if i > 0 && *t <= self.t_s[i - 1] {
                return Err(inv(
                    Some(i),
                    None,
                    format!("time {t} s does not increase (previous sample {} s)", self.t_s[i - 1]),
                ));
            }
        }
        for (&q, x) in &self.channels {
            if x.len() != n {
                return Err(inv(
                    None,
                    Some(q),
                    format!("{} samples, the time base has {n}", x.len()),
                ));
            }
            if let Some(i) = x.iter().position(|v| !v.is_finite()) {
                let run = x[i..].iter().take_while(|v| !v.is_finite()).count();
                return Err(inv(
                    Some(i),
                    Some(q),
                    format!(
                        "non-finite value {} (a run of {run} sample{}); missing samples are refused, not interpolated",
                        x[i],
                        if run == 1 { "" } else { "s" }
                    ),
                ));
            }
            if let Some(b) = bounds(q) {
                if let Some(i) = x.iter().position(|v| *v < b.hard.0 || *v > b.hard.1) {
                    return Err(inv(
                        Some(i),
                        Some(q),
                        format!(
                            "{} {} is outside the plausible range [{}, {}] ({})",
                            x[i],
                            q.si_unit(),
                            b.hard.0,
                            b.hard.1,
                            b.hint
                        ),
                    ));
                }
                let beyond = x.iter().filter(|v| v.abs() > b.soft).count();
                if beyond as f64 > SOFT_SHARE * n as f64 {
                    let i = x.iter().position(|v| v.abs() > b.soft);
                    return Err(inv(
                        i,
                        Some(q),
                        format!(
                            "{beyond} of {n} samples have |value| > {} {} ({})",
                            b.soft,
                            q.si_unit(),
                            b.hint
                        ),
                    ));
                }
            }
        }
        self.check_accelerometer()?;
        self.check_dynamic_pressure()?;
        self.check_derivatives()
    }

    fn check_accelerometer(&self) -> Result<(), Invalid> {
        use Quantity::*;
        let (lo, hi, what, q, mags): (f64, f64, &str, Quantity, Vec<f64>) =
            match (self.get(AccelX), self.get(AccelY), self.get(AccelZ)) {
                (Some(x), Some(y), Some(z)) => (
                    0.5,
                    3.0,
                    "specific-force magnitude",
                    AccelZ,
                    (0..x.len())
                        .map(|i| (x[i] * x[i] + y[i] * y[i] + z[i] * z[i]).sqrt())
                        .collect(),
                ),
                (_, _, Some(z)) => (0.3, 3.0, "|accel_z|", AccelZ, z.iter().map(|v| v.abs()).collect()),
                _ => return Ok(()),
            };
        let m = mean(&mags) / G0_MPS2;
        if !(lo..=hi).contains(&m) {
            return Err(Invalid {
                sample: None,
                quantity: Some(q),
                message: format!(
                    "mean {what} is {:.3} g, outside [{lo}, {hi}] g (g or ft/s² given as m/s²?)",
                    m
                ),
            });
        }
        Ok(())
    }

    fn check_dynamic_pressure(&self) -> Result<(), Invalid> {
        let (Some(qbar), Some(v)) = (self.get(Quantity::DynamicPressure), self.get(Quantity::Airspeed)) else {
            return Ok(());
        };
        let mut rho: Vec<f64> = qbar
            .iter()
            .zip(v)
            .filter(|(_, v)| **v > 10.0)
            .map(|(q, v)| 2.0 * q / (v * v))
            .collect();
        if rho.is_empty() {
            return Ok(());
        }
        rho.sort_by(f64::total_cmp);
        let med = rho[rho.len() / 2];
        if !(0.1..=1.6).contains(&med) {
            return Err(Invalid {
                sample: None,
                quantity: Some(Quantity::DynamicPressure),
                message: format!(
                    "the dynamic pressure and the airspeed imply a median density 2q̄/V² = {med:.4} kg/m³, outside [0.1, 1.6] (lbf/ft² or hPa given as Pa, or the airspeed not in m/s?)"
                ),
            });
        }
        Ok(())
    }

    fn check_derivatives(&self) -> Result<(), Invalid> {
        use Quantity::*;
        let t = &self.t_s;
        let mut pairs: Vec<(Quantity, Quantity, Vec<f64>, Vec<f64>)> = Vec::new();
        for (acc, rate) in [(RollAccel, RollRate), (PitchAccel, PitchRate), (YawAccel, YawRate)] {
            if let (Some(a), Some(r)) = (self.get(acc), self.get(rate)) {
                pairs.push((acc, rate, a[1..a.len() - 1].to_vec(), central_difference(t, r)));
            }
        }
        if let (Some(theta), Some(q)) = (self.get(Pitch), self.get(PitchRate)) {
            let phi = self.get(Roll);
            let r = self.get(YawRate);
            let kin: Vec<f64> = (1..t.len() - 1)
                .map(|i| match (phi, r) {
                    (Some(phi), Some(r)) => q[i] * phi[i].cos() - r[i] * phi[i].sin(),
                    _ => q[i],
                })
                .collect();
            pairs.push((PitchRate, Pitch, kin, central_difference(t, theta)));
        }
        for (measured, integral, x, dy) in pairs {
            // `dy ≈ k·x`: k is 1 when both are in the same unit, 57.3 or 1/57.3 when one is in
            // degrees. Only judged where the two clearly move together (correlation > 0.5).
            let (k, rho) = scale_and_correlation(&x, &dy);
            if rho > 0.5 && !(0.5..=2.0).contains(&k) {
                return Err(Invalid {
                    sample: None,
                    quantity: Some(measured),
                    message: format!(
                        "the derivative of `{integral}` is {k:.3} × `{measured}` (correlation {rho:.2}); the two should agree within a factor 2 (one of them in degrees?)"
                    ),
                });
            }
        }
        Ok(())
    }
}
