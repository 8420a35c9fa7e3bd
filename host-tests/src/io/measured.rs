//! Measured flight data as the model-gap analysis (issue 6) reads it: a time base and a set of named
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
    /// Dynamic pressure, Pa.
    DynamicPressure,
    /// Air density, kg/m³.
    AirDensity,
    /// Pressure altitude, m.
    Altitude,
    /// Mach number.
    Mach,
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
}

impl MeasuredFlight {
    /// A channel, if measured.
    pub fn get(&self, q: Quantity) -> Option<&[f64]> {
        self.channels.get(&q).map(|v| v.as_slice())
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
        }
    }
}
