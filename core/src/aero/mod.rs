//! On-board aerodynamics: what the flight computer measures, the airframe constants it knows, and
//! (in the submodules, as they land) the synthesis of the six coefficients of eq. 1–2 and the six
//! estimators of eq. 3.
//!
//! Conventions: SI units and radians; body frame FRD; surface deflections positive trailing edge
//! down (elevator, aileron: right aileron down) and trailing edge left (rudder), so that with the
//! `skywalker_2013_mod` data a positive elevator gives a nose-up moment (`Cmδe > 0` there).

pub mod model;
pub mod onboard;
pub mod pipeline;
pub mod sequence;
pub mod stuck;
pub mod synthesis;

pub use model::{AeroModels, CoefficientModel, Regressor, SensorNoise};
pub use pipeline::{Health, Limits, Pipeline, PipelineSettings, PipelineStep, Refusal, Stage};
pub use sequence::{Admission, SequenceCheck, SequenceHealth};
pub use stuck::{StuckDetector, StuckHealth, StuckSettings};
pub use synthesis::{synthesise, Coefficients, ForceAxes, RateDifferentiator, Synthesis, SynthesisSettings};

use crate::linalg::const_zeros;
use crate::Real;
use nalgebra::{Matrix3, Vector3};

/// One synchronised sample of everything the co-processor measures, at the sampling instant.
///
/// This is also the row of the project's CSV flight-log layout: one column per field, named as the
/// field (vectors as `<name>_x`, `_y`, `_z`), SI units and radians.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorSample<T: Real> {
    /// Time of the sample since the start of the log, s.
    pub t_s: T,
    /// Time since the previous sample, s.
    pub dt_s: T,
    /// Specific force measured by the accelerometer (at the CG), body FRD, m/s².
    pub accel_mps2: Vector3<T>,
    /// Angular rate measured by the gyroscope, body FRD (p, q, r), rad/s.
    pub gyro_rad_s: Vector3<T>,
    /// True airspeed from the differential-pressure sensor, m/s.
    pub airspeed_mps: T,
    /// Angle of attack from the α vane, rad.
    pub alpha_rad: T,
    /// Sideslip angle from the β vane, rad.
    pub beta_rad: T,
    /// Attitude: roll φ, pitch θ, yaw ψ (3-2-1 Euler angles), rad.
    pub euler_rad: Vector3<T>,
    /// Propeller speed, rad/s (from RPM).
    pub prop_speed_rad_s: T,
    /// Elevator deflection, rad.
    pub elevator_rad: T,
    /// Aileron deflection, rad.
    pub aileron_rad: T,
    /// Rudder deflection, rad.
    pub rudder_rad: T,
    /// Throttle command, 0…1.
    pub throttle: T,
    /// Air density, kg/m³ (from static pressure and temperature).
    pub air_density_kgpm3: T,
}

/// A propeller whose thrust and torque the flight computer reconstructs from its speed and the
/// airspeed, as from engine ground tests (seed 000, Section II): `J = V_x/(nD)`, `n = ω/2π`,
/// `T = C_T(J) ρ n² D⁴`, `Q = C_P(J) ρ n² D⁵/(2π)`, with `C_T`, `C_P` quadratic in `J`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Propeller<T: Real> {
    /// Diameter `D`, m.
    pub diameter_m: T,
    /// `C_T(J) = c₀ + c₁J + c₂J²`.
    pub ct: [T; 3],
    /// `C_P(J) = c₀ + c₁J + c₂J²`.
    pub cp: [T; 3],
    /// Thrust point relative to the CG, body FRD, m.
    pub position_m: Vector3<T>,
    /// Thrust line pitch relative to the body x axis, rad (positive nose up).
    pub pitch_rad: T,
}

/// The airframe constants the on-board synthesis needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Airframe<T: Real> {
    /// Mass, kg.
    pub mass_kg: T,
    /// Inertia tensor about the CG in body FRD (with `−Jxz` off the diagonal), kg·m².
    pub inertia_kgm2: Matrix3<T>,
    /// Wing reference area `S`, m².
    pub wing_area_m2: T,
    /// Wing span `b`, m.
    pub span_m: T,
    /// Mean aerodynamic chord `c̄`, m.
    pub chord_m: T,
    /// The propulsion model.
    pub propeller: Propeller<T>,
}

impl<T: Real> Airframe<T> {
    /// The `skywalker_2013_mod` airframe of the seed's simulator (data/aircraft README §1), with its
    /// inertia as published (copied from the Aerosonde set).
    pub fn skywalker_2013_mod() -> Self {
        let l = T::lit;
        let (jx, jy, jz, jxz) = (l(0.8244), l(1.135), l(1.759), l(0.1204));
        Self {
            mass_kg: l(2.0),
            inertia_kgm2: Matrix3::new(jx, T::zero(), -jxz, T::zero(), jy, T::zero(), -jxz, T::zero(), jz),
            wing_area_m2: l(0.45),
            span_m: l(1.88),
            chord_m: l(0.24),
            propeller: Propeller {
                diameter_m: l(0.28),
                ct: [l(0.1133), l(-0.0740), l(-0.1849)],
                cp: [l(0.0440), l(0.0059), l(-0.0732)],
                position_m: Vector3::new(l(-0.25), T::zero(), l(-0.13)),
                pitch_rad: l(-0.08),
            },
        }
    }
}

impl<T: Real> SensorSample<T> {
    /// Every field 0 (a `const`, e.g. for the firmware's statics; equal to `default()`).
    pub const ZERO: Self = Self {
        t_s: T::ZERO,
        dt_s: T::ZERO,
        accel_mps2: const_zeros(),
        gyro_rad_s: const_zeros(),
        airspeed_mps: T::ZERO,
        alpha_rad: T::ZERO,
        beta_rad: T::ZERO,
        euler_rad: const_zeros(),
        prop_speed_rad_s: T::ZERO,
        elevator_rad: T::ZERO,
        aileron_rad: T::ZERO,
        rudder_rad: T::ZERO,
        throttle: T::ZERO,
        air_density_kgpm3: T::ZERO,
    };
}

impl<T: Real> Airframe<T> {
    /// Every constant 0: a placeholder for `const` initialisers, replaced before use
    /// ([`Pipeline::configure`](crate::aero::Pipeline::configure)).
    pub const ZERO: Self = Self {
        mass_kg: T::ZERO,
        inertia_kgm2: const_zeros(),
        wing_area_m2: T::ZERO,
        span_m: T::ZERO,
        chord_m: T::ZERO,
        propeller: Propeller {
            diameter_m: T::ZERO,
            ct: [T::ZERO; 3],
            cp: [T::ZERO; 3],
            position_m: const_zeros(),
            pitch_rad: T::ZERO,
        },
    };
}

/// The sample channel by channel ([`model::channel`]).
impl<T: Real> SensorSample<T> {
    /// The measured channel `m` (one bit of [`model::channel`]) of this sample: its three components
    /// (accelerometer, gyroscope) or its one; empty for a mask that is not a single such channel
    /// (`THROTTLE` and the attitude are not among them).
    pub fn channel(&self, m: model::ChannelMask) -> &[T] {
        use model::channel as c;
        match m {
            c::ACCEL => self.accel_mps2.as_slice(),
            c::GYRO => self.gyro_rad_s.as_slice(),
            c::AIRSPEED => core::slice::from_ref(&self.airspeed_mps),
            c::ALPHA => core::slice::from_ref(&self.alpha_rad),
            c::BETA => core::slice::from_ref(&self.beta_rad),
            c::PROP => core::slice::from_ref(&self.prop_speed_rad_s),
            c::ELEVATOR => core::slice::from_ref(&self.elevator_rad),
            c::AILERON => core::slice::from_ref(&self.aileron_rad),
            c::RUDDER => core::slice::from_ref(&self.rudder_rad),
            c::DENSITY => core::slice::from_ref(&self.air_density_kgpm3),
            c::DT => core::slice::from_ref(&self.dt_s),
            _ => &[],
        }
    }

    /// [`Self::channel`], mutable.
    pub fn channel_mut(&mut self, m: model::ChannelMask) -> &mut [T] {
        use model::channel as c;
        match m {
            c::ACCEL => self.accel_mps2.as_mut_slice(),
            c::GYRO => self.gyro_rad_s.as_mut_slice(),
            c::AIRSPEED => core::slice::from_mut(&mut self.airspeed_mps),
            c::ALPHA => core::slice::from_mut(&mut self.alpha_rad),
            c::BETA => core::slice::from_mut(&mut self.beta_rad),
            c::PROP => core::slice::from_mut(&mut self.prop_speed_rad_s),
            c::ELEVATOR => core::slice::from_mut(&mut self.elevator_rad),
            c::AILERON => core::slice::from_mut(&mut self.aileron_rad),
            c::RUDDER => core::slice::from_mut(&mut self.rudder_rad),
            c::DENSITY => core::slice::from_mut(&mut self.air_density_kgpm3),
            c::DT => core::slice::from_mut(&mut self.dt_s),
            _ => &mut [],
        }
    }

    /// Every channel named in `mask` set to NaN: no reading (what a failed or stuck sensor gives).
    pub fn invalidate(&mut self, mask: model::ChannelMask) {
        let nan = T::lit(f64::NAN);
        for b in 0..model::channel::COUNT {
            let m = 1 << b;
            if mask & m != 0 {
                self.channel_mut(m).iter_mut().for_each(|x| *x = nan);
            }
        }
    }
}

/// Conversion between scalar types (e.g. an `f64` simulator log replayed through the `f32`
/// on-board path): every field is rounded to the nearest value of `U`.
impl<T: Real> SensorSample<T> {
    /// The same sample in scalar type `U`.
    pub fn cast<U: Real>(&self) -> SensorSample<U> {
        let c = |x: T| U::lit(x.to_f64());
        let v = |x: &Vector3<T>| x.map(c);
        SensorSample {
            t_s: c(self.t_s),
            dt_s: c(self.dt_s),
            accel_mps2: v(&self.accel_mps2),
            gyro_rad_s: v(&self.gyro_rad_s),
            airspeed_mps: c(self.airspeed_mps),
            alpha_rad: c(self.alpha_rad),
            beta_rad: c(self.beta_rad),
            euler_rad: v(&self.euler_rad),
            prop_speed_rad_s: c(self.prop_speed_rad_s),
            elevator_rad: c(self.elevator_rad),
            aileron_rad: c(self.aileron_rad),
            rudder_rad: c(self.rudder_rad),
            throttle: c(self.throttle),
            air_density_kgpm3: c(self.air_density_kgpm3),
        }
    }
}

impl<T: Real> Airframe<T> {
    /// The same airframe in scalar type `U` (every constant rounded to the nearest value of `U`).
    pub fn cast<U: Real>(&self) -> Airframe<U> {
        let c = |x: T| U::lit(x.to_f64());
        let p = &self.propeller;
        Airframe {
            mass_kg: c(self.mass_kg),
            inertia_kgm2: self.inertia_kgm2.map(c),
            wing_area_m2: c(self.wing_area_m2),
            span_m: c(self.span_m),
            chord_m: c(self.chord_m),
            propeller: Propeller {
                diameter_m: c(p.diameter_m),
                ct: p.ct.map(c),
                cp: p.cp.map(c),
                position_m: p.position_m.map(c),
                pitch_rad: c(p.pitch_rad),
            },
        }
    }
}

/// Number of scalar fields of a [`SensorSample`] (vectors count three), in the CSV column order.
pub const SAMPLE_FIELDS: usize = 20;

/// Bytes of one binary replay record: the [`SAMPLE_FIELDS`] fields of a [`SensorSample`] as
/// little-endian `f32`, in the CSV column order (the firmware's QEMU replay reads these; the host
/// writes them from a CSV log, so the target needs no text parsing).
pub const REPLAY_RECORD_BYTES: usize = SAMPLE_FIELDS * 4;

impl<T: Real> SensorSample<T> {
    /// The fields in the CSV column order: `t_s, dt_s, accel_mps2_{x,y,z}, gyro_rad_s_{x,y,z},
    /// airspeed_mps, alpha_rad, beta_rad, euler_rad_{x,y,z}, prop_speed_rad_s, elevator_rad,
    /// aileron_rad, rudder_rad, throttle, air_density_kgpm3`.
    pub fn to_fields(&self) -> [T; SAMPLE_FIELDS] {
        let (a, g, e) = (&self.accel_mps2, &self.gyro_rad_s, &self.euler_rad);
        [
            self.t_s,
            self.dt_s,
            a.x,
            a.y,
            a.z,
            g.x,
            g.y,
            g.z,
            self.airspeed_mps,
            self.alpha_rad,
            self.beta_rad,
            e.x,
            e.y,
            e.z,
            self.prop_speed_rad_s,
            self.elevator_rad,
            self.aileron_rad,
            self.rudder_rad,
            self.throttle,
            self.air_density_kgpm3,
        ]
    }

    /// The sample from its fields in the CSV column order ([`Self::to_fields`]).
    pub fn from_fields(f: &[T; SAMPLE_FIELDS]) -> Self {
        Self {
            t_s: f[0],
            dt_s: f[1],
            accel_mps2: Vector3::new(f[2], f[3], f[4]),
            gyro_rad_s: Vector3::new(f[5], f[6], f[7]),
            airspeed_mps: f[8],
            alpha_rad: f[9],
            beta_rad: f[10],
            euler_rad: Vector3::new(f[11], f[12], f[13]),
            prop_speed_rad_s: f[14],
            elevator_rad: f[15],
            aileron_rad: f[16],
            rudder_rad: f[17],
            throttle: f[18],
            air_density_kgpm3: f[19],
        }
    }
}

impl SensorSample<f32> {
    /// The binary replay record ([`REPLAY_RECORD_BYTES`]).
    pub fn to_replay_record(&self) -> [u8; REPLAY_RECORD_BYTES] {
        let mut out = [0u8; REPLAY_RECORD_BYTES];
        for (chunk, v) in out.chunks_exact_mut(4).zip(self.to_fields().iter()) {
            chunk.copy_from_slice(&v.to_le_bytes());
        }
        out
    }

    /// The sample of a binary replay record ([`REPLAY_RECORD_BYTES`]); bit-exact inverse of
    /// [`Self::to_replay_record`] (NaN payloads included).
    pub fn from_replay_record(b: &[u8; REPLAY_RECORD_BYTES]) -> Self {
        let mut f = [0.0f32; SAMPLE_FIELDS];
        for (v, chunk) in f.iter_mut().zip(b.chunks_exact(4)) {
            *v = f32::from_le_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
        }
        Self::from_fields(&f)
    }
}
