//! Sensors at the output rate: white noise plus a constant bias per run, seeded.

use aerosid_core::aero::SensorSample;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Noise standard deviations and bias standard deviations (each bias drawn once per run from
/// `N(0, bias²)`). Defaults are realistic for a small UAV.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorNoise {
    /// Accelerometer noise, m/s² (default 0.05).
    pub accel_mps2: f64,
    /// Accelerometer bias, m/s² (default 0.02).
    pub accel_bias_mps2: f64,
    /// Gyro noise, rad/s (default 0.005).
    pub gyro_rad_s: f64,
    /// Gyro bias, rad/s (default 0.002).
    pub gyro_bias_rad_s: f64,
    /// Airspeed noise, m/s (default 0.3).
    pub airspeed_mps: f64,
    /// Airspeed bias, m/s (default 0.1).
    pub airspeed_bias_mps: f64,
    /// α and β vane noise, rad (default 0.5°).
    pub vane_rad: f64,
    /// Vane bias, rad (default 0.2°).
    pub vane_bias_rad: f64,
    /// Attitude noise, rad (default 0.5°).
    pub attitude_rad: f64,
    /// Attitude bias, rad (default 0.2°).
    pub attitude_bias_rad: f64,
    /// Relative propeller-speed noise (default 0.01).
    pub prop_speed_rel: f64,
    /// Surface deflection noise, rad (default 0.2°).
    pub surface_rad: f64,
    /// Surface bias, rad (default 0.1°).
    pub surface_bias_rad: f64,
    /// Relative density noise (default 0.005).
    pub density_rel: f64,
}

impl Default for SensorNoise {
    fn default() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            accel_mps2: 0.05,
            accel_bias_mps2: 0.02,
            gyro_rad_s: 0.005,
            gyro_bias_rad_s: 0.002,
            airspeed_mps: 0.3,
            airspeed_bias_mps: 0.1,
            vane_rad: 0.5 * deg,
            vane_bias_rad: 0.2 * deg,
            attitude_rad: 0.5 * deg,
            attitude_bias_rad: 0.2 * deg,
            prop_speed_rel: 0.01,
            surface_rad: 0.2 * deg,
            surface_bias_rad: 0.1 * deg,
            density_rel: 0.005,
        }
    }
}

impl SensorNoise {
    /// Perfect sensors.
    pub fn none() -> Self {
        Self {
            accel_mps2: 0.0,
            accel_bias_mps2: 0.0,
            gyro_rad_s: 0.0,
            gyro_bias_rad_s: 0.0,
            airspeed_mps: 0.0,
            airspeed_bias_mps: 0.0,
            vane_rad: 0.0,
            vane_bias_rad: 0.0,
            attitude_rad: 0.0,
            attitude_bias_rad: 0.0,
            prop_speed_rel: 0.0,
            surface_rad: 0.0,
            surface_bias_rad: 0.0,
            density_rel: 0.0,
        }
    }
    /// Noise only, no biases.
    pub fn without_biases(self) -> Self {
        Self {
            accel_bias_mps2: 0.0,
            gyro_bias_rad_s: 0.0,
            airspeed_bias_mps: 0.0,
            vane_bias_rad: 0.0,
            attitude_bias_rad: 0.0,
            surface_bias_rad: 0.0,
            ..self
        }
    }
}

/// The biases drawn for one run (added to every sample).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorBiases {
    /// Accelerometer, m/s².
    pub accel_mps2: Vector3<f64>,
    /// Gyro, rad/s.
    pub gyro_rad_s: Vector3<f64>,
    /// Airspeed, m/s.
    pub airspeed_mps: f64,
    /// α vane, β vane, rad.
    pub vanes_rad: [f64; 2],
    /// Roll, pitch, yaw, rad.
    pub euler_rad: Vector3<f64>,
    /// Elevator, aileron, rudder, rad.
    pub surfaces_rad: [f64; 3],
}

/// A seeded sensor set.
#[derive(Debug, Clone)]
pub struct SensorModel {
    /// The noise settings.
    pub noise: SensorNoise,
    /// The biases of this run.
    pub biases: SensorBiases,
    rng: ChaCha8Rng,
}

fn wrap_pi(a: f64) -> f64 {
    let t = core::f64::consts::TAU;
    a - t * ((a + core::f64::consts::PI) / t).floor()
}

impl SensorModel {
    /// Draws the biases and prepares the noise stream for `seed`.
    pub fn new(noise: SensorNoise, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut n = |s: f64| -> f64 { s * rng.sample::<f64, _>(StandardNormal) };
        let v3 = |n: &mut dyn FnMut(f64) -> f64, s: f64| Vector3::new(n(s), n(s), n(s));
        let biases = SensorBiases {
            accel_mps2: v3(&mut n, noise.accel_bias_mps2),
            gyro_rad_s: v3(&mut n, noise.gyro_bias_rad_s),
            airspeed_mps: n(noise.airspeed_bias_mps),
            vanes_rad: [n(noise.vane_bias_rad), n(noise.vane_bias_rad)],
            euler_rad: v3(&mut n, noise.attitude_bias_rad),
            surfaces_rad: [
                n(noise.surface_bias_rad),
                n(noise.surface_bias_rad),
                n(noise.surface_bias_rad),
            ],
        };
        rng.set_stream(1);
        Self { noise, biases, rng }
    }

    /// The measured sample from the ideal one (the throttle command is exact; angles wrapped).
    pub fn measure(&mut self, ideal: &SensorSample<f64>) -> SensorSample<f64> {
        let s = self.noise;
        let b = self.biases;
        let rng = &mut self.rng;
        let mut n = |sd: f64| -> f64 { sd * rng.sample::<f64, _>(StandardNormal) };
        let accel = ideal.accel_mps2 + b.accel_mps2 + Vector3::new(n(s.accel_mps2), n(s.accel_mps2), n(s.accel_mps2));
        let gyro = ideal.gyro_rad_s + b.gyro_rad_s + Vector3::new(n(s.gyro_rad_s), n(s.gyro_rad_s), n(s.gyro_rad_s));
        let airspeed = ideal.airspeed_mps + b.airspeed_mps + n(s.airspeed_mps);
        let alpha = ideal.alpha_rad + b.vanes_rad[0] + n(s.vane_rad);
        let beta = ideal.beta_rad + b.vanes_rad[1] + n(s.vane_rad);
        let e = ideal.euler_rad + b.euler_rad;
        let euler = Vector3::new(
            wrap_pi(e.x + n(s.attitude_rad)),
            e.y + n(s.attitude_rad),
            wrap_pi(e.z + n(s.attitude_rad)),
        );
        let prop = ideal.prop_speed_rad_s * (1.0 + n(s.prop_speed_rel));
        let elevator = ideal.elevator_rad + b.surfaces_rad[0] + n(s.surface_rad);
        let aileron = ideal.aileron_rad + b.surfaces_rad[1] + n(s.surface_rad);
        let rudder = ideal.rudder_rad + b.surfaces_rad[2] + n(s.surface_rad);
        let rho = ideal.air_density_kgpm3 * (1.0 + n(s.density_rel));
        SensorSample {
            t_s: ideal.t_s,
            dt_s: ideal.dt_s,
            accel_mps2: accel,
            gyro_rad_s: gyro,
            airspeed_mps: airspeed,
            alpha_rad: alpha,
            beta_rad: beta,
            euler_rad: euler,
            prop_speed_rad_s: prop,
            elevator_rad: elevator,
            aileron_rad: aileron,
            rudder_rad: rudder,
            throttle: ideal.throttle,
            air_density_kgpm3: rho,
        }
    }
}

/// A sensor channel a [`SensorFault`] acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultChannel {
    /// The α vane, rad.
    Alpha,
    /// The β vane, rad.
    Beta,
    /// Airspeed, m/s.
    Airspeed,
    /// Accelerometer x, m/s².
    AccelX,
    /// Accelerometer y, m/s².
    AccelY,
    /// Accelerometer z, m/s².
    AccelZ,
    /// Gyro p, rad/s.
    RollRate,
    /// Gyro q, rad/s.
    PitchRate,
    /// Gyro r, rad/s.
    YawRate,
}

impl FaultChannel {
    fn get(self, s: &SensorSample<f64>) -> f64 {
        match self {
            Self::Alpha => s.alpha_rad,
            Self::Beta => s.beta_rad,
            Self::Airspeed => s.airspeed_mps,
            Self::AccelX => s.accel_mps2.x,
            Self::AccelY => s.accel_mps2.y,
            Self::AccelZ => s.accel_mps2.z,
            Self::RollRate => s.gyro_rad_s.x,
            Self::PitchRate => s.gyro_rad_s.y,
            Self::YawRate => s.gyro_rad_s.z,
        }
    }
    fn set(self, s: &mut SensorSample<f64>, v: f64) {
        match self {
            Self::Alpha => s.alpha_rad = v,
            Self::Beta => s.beta_rad = v,
            Self::Airspeed => s.airspeed_mps = v,
            Self::AccelX => s.accel_mps2.x = v,
            Self::AccelY => s.accel_mps2.y = v,
            Self::AccelZ => s.accel_mps2.z = v,
            Self::RollRate => s.gyro_rad_s.x = v,
            Self::PitchRate => s.gyro_rad_s.y = v,
            Self::YawRate => s.gyro_rad_s.z = v,
        }
    }
}

/// A systematic sensor error beyond the per-run biases of [`SensorNoise`] (the
/// measurement causes the model-gap analysis must find). Applied to the ideal sample before noise:
/// first the delay, then the scale factor, then the bias.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SensorFault {
    /// `measured = (1 + factor) · true` (e.g. a vane in the wing's upwash).
    Scale {
        /// The channel.
        channel: FaultChannel,
        /// Relative scale error.
        factor: f64,
    },
    /// `measured = true + value` (channel units).
    Bias {
        /// The channel.
        channel: FaultChannel,
        /// The bias, in the channel's unit.
        value: f64,
    },
    /// `measured(t) = true(t − delay_s)` (linear interpolation between output samples; before the
    /// first sample the first value).
    Delay {
        /// The channel.
        channel: FaultChannel,
        /// The delay, s (≥ 0).
        delay_s: f64,
    },
}

/// Applies `faults` to the ideal sample `history[k]`, reading earlier ideal samples of `history`
/// (one per output period `dt_s`) for delays.
pub fn apply_faults(faults: &[SensorFault], history: &[SensorSample<f64>], k: usize, dt_s: f64) -> SensorSample<f64> {
    let mut s = history[k];
    for f in faults {
        if let SensorFault::Delay { channel, delay_s } = *f {
            let back = (delay_s / dt_s).max(0.0);
            let whole = back.floor() as usize;
            let frac = back - back.floor();
            let v = if whole >= k {
                channel.get(&history[0])
            } else {
                let a = channel.get(&history[k - whole]);
                let b = channel.get(&history[k - whole - 1]);
                a + frac * (b - a)
            };
            channel.set(&mut s, v);
        }
    }
    for f in faults {
        match *f {
            SensorFault::Scale { channel, factor } => {
                let v = channel.get(&s) * (1.0 + factor);
                channel.set(&mut s, v);
            }
            SensorFault::Bias { channel, value } => {
                let v = channel.get(&s) + value;
                channel.set(&mut s, v);
            }
            SensorFault::Delay { .. } => {}
        }
    }
    s
}
