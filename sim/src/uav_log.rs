//! A small UAV autopilot's log of a simulated flight: each channel sampled at its own rate, with
//! its own lag and timestamp jitter, then resampled onto one common grid by sample-and-hold (the
//! staircases a log converter such as ArduPilot's `mavlogdump`/MATLAB import or PX4's
//! `ulog2csv` + `interp1(..., 'previous')` produces), and no vanes: α and β are *estimated* the way
//! ArduPilot's AHRS does.
//!
//! # The estimated flow angles
//!
//! ArduPilot computes `AOA` and `SSA` in `AP_AHRS::update_AOA_SSA` from the EKF's inertial velocity
//! minus its wind estimate, rotated into body axes: `α̂ = atan2(v_z, v_x)`, `β̂ = asin(v_y/|v|)`
//! (`AP_AHRS/LogStructure.h`: "Angle of Attack calculated from airspeed, wind vector, velocity
//! vector"); ArduPlane logs them in the `AOA` message at 10 Hz (`update_logging1`, with
//! `LOG_BITMASK` ATTITUDE_MED). The wind is EKF3's: two horizontal states (NED north and east,
//! `AP_NavEKF3` states 22–23, process noise `EK3_WIND_P_NSE`), no vertical wind, updated slowly from
//! the airspeed and sideslip fusion. Modelled here as
//!
//! * EKF velocity: the true inertial velocity plus white noise ([`UavLogging::ekf_velocity_noise_mps`]);
//!   the EKF's output predictor compensates the GPS delay, so it is current;
//! * wind estimate: the true horizontal wind (mean plus gust, NED) through a first-order low-pass
//!   of time constant [`UavLogging::wind_time_constant_s`] (tens of seconds, the slow convergence
//!   of the EKF's wind states), started converged on the mean wind, plus a constant error per
//!   record drawn from `N(0, wind_error_mps²)` per horizontal axis; vertical wind estimated as 0;
//! * attitude: the logged attitude's (noisy) values.
//!
//! So `α̂ − α ≈ ((w − ŵ)_body)_z / V`: in turbulence the vertical gust (σ_w / V ≈ 3° in light
//! turbulence at 15 m/s) is an error of α̂, not a change of α̂ — the error in the variable that an
//! analysis of such logs must carry.
//!
//! # Rates, lags and jitter (defaults, [`UavLogging::default`])
//!
//! | channel | rate | lag | jitter | why |
//! |---|---|---|---|---|
//! | IMU (accel, gyro) | 50 Hz | 10 ms | 1 ms | a 50 Hz `IMU` log of the filtered sensors; a 20 Hz low-pass (`INS_GYRO_FILTER`, `INS_ACCEL_FILTER`) delays ≈ 8–11 ms |
//! | attitude | 25 Hz | 20 ms | 2 ms | `ATT` between the 10 Hz ATTITUDE_MED and loop-rate ATTITUDE_FAST settings; EKF output |
//! | GPS velocity | 5 Hz | 200 ms | 10 ms | a u-blox receiver at 5 Hz; ArduPilot's GPS lag setting (`GPS_DELAY_MS`) is of the order of 200 ms |
//! | airspeed | 10 Hz | 50 ms | 5 ms | an `ARSP` log at 10 Hz; tubing and filtering |
//! | servo outputs, throttle | 25 Hz | 0 | 2 ms | the surface positions, logged every 40 ms |
//! | α̂, β̂ | 10 Hz | 20 ms | 2 ms | the `AOA` message (above) |
//! | air density (baro) | 10 Hz | 50 ms | 5 ms | `BARO` |
//! | propeller speed | 10 Hz | 50 ms | 5 ms | ESC telemetry or an RPM sensor (`RPM`, `ESC` messages at ≈ 10 Hz) |
//!
//! A channel's sample stamped `s` holds the signal at `s − lag + ε`, `ε` uniform in ±jitter (the
//! scheduler's slip between reading and stamping); its first stamp is a seeded phase in
//! `(jitter, period − jitter)` before the grid's start, so every grid point has a value and a 50 Hz
//! channel on the 50 Hz grid changes at every point. The servo channels log the surface positions
//! (ideal servo feedback), not the commands: a surface lag is then present only where it is planted.

use crate::{SimOutput, TruthSample};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// How one channel is sampled before the resampling onto the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelTiming {
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Lag between the physical quantity and its logged sample, s (negative: the log leads).
    pub lag_s: f64,
    /// Half-width of the uniform timestamp jitter, s.
    pub jitter_s: f64,
}

impl ChannelTiming {
    const fn new(rate_hz: f64, lag_s: f64, jitter_s: f64) -> Self {
        Self {
            rate_hz,
            lag_s,
            jitter_s,
        }
    }
}

/// The logger and estimator model (module doc for the defaults and their sources).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UavLogging {
    /// The common grid every channel is held onto, Hz.
    pub grid_hz: f64,
    /// Accelerometers and gyros.
    pub imu: ChannelTiming,
    /// Roll, pitch, yaw.
    pub attitude: ChannelTiming,
    /// GPS velocity, NED.
    pub gps_velocity: ChannelTiming,
    /// Pitot airspeed.
    pub airspeed: ChannelTiming,
    /// Surface positions and throttle.
    pub servo: ChannelTiming,
    /// The estimated α and β.
    pub flow_angles: ChannelTiming,
    /// Air density (from the barometer).
    pub baro: ChannelTiming,
    /// Propeller speed (ESC telemetry or an RPM sensor).
    pub rpm: ChannelTiming,
    /// Time constant of the wind estimate's low-pass, s.
    pub wind_time_constant_s: f64,
    /// Standard deviation of the wind estimate's constant error per horizontal axis, m/s.
    pub wind_error_mps: f64,
    /// White noise of the EKF velocity used for α̂ and β̂, m/s.
    pub ekf_velocity_noise_mps: f64,
    /// White noise of the logged GPS velocity, m/s.
    pub gps_velocity_noise_mps: f64,
}

impl Default for UavLogging {
    fn default() -> Self {
        Self {
            grid_hz: 50.0,
            imu: ChannelTiming::new(50.0, 0.010, 0.001),
            attitude: ChannelTiming::new(25.0, 0.020, 0.002),
            gps_velocity: ChannelTiming::new(5.0, 0.200, 0.010),
            airspeed: ChannelTiming::new(10.0, 0.050, 0.005),
            servo: ChannelTiming::new(25.0, 0.0, 0.002),
            flow_angles: ChannelTiming::new(10.0, 0.020, 0.002),
            baro: ChannelTiming::new(10.0, 0.050, 0.005),
            rpm: ChannelTiming::new(10.0, 0.050, 0.005),
            wind_time_constant_s: 30.0,
            wind_error_mps: 0.5,
            ekf_velocity_noise_mps: 0.05,
            gps_velocity_noise_mps: 0.1,
        }
    }
}

/// One record as the autopilot logs it, on the common grid; every channel in SI units, body FRD,
/// NED for velocities. The `truth_*` channels are the instantaneous truth at the grid times (for
/// tests and scoring; a reader ignores them).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UavLog {
    /// Grid times, s (from 0).
    pub t_s: Vec<f64>,
    /// Specific force x, y, z, m/s².
    pub accel_mps2: [Vec<f64>; 3],
    /// Body rates p, q, r, rad/s.
    pub gyro_rad_s: [Vec<f64>; 3],
    /// Roll, pitch, yaw, rad (yaw wrapped to ±π).
    pub euler_rad: [Vec<f64>; 3],
    /// GPS velocity north, east, down, m/s.
    pub vel_ned_mps: [Vec<f64>; 3],
    /// Pitot airspeed, m/s.
    pub airspeed_mps: Vec<f64>,
    /// Estimated α, rad.
    pub alpha_est_rad: Vec<f64>,
    /// Estimated β, rad.
    pub beta_est_rad: Vec<f64>,
    /// Elevator, aileron, rudder, rad.
    pub surfaces_rad: [Vec<f64>; 3],
    /// Throttle, 0–1.
    pub throttle: Vec<f64>,
    /// Air density, kg/m³.
    pub air_density_kgpm3: Vec<f64>,
    /// Propeller speed, rad/s.
    pub prop_speed_rad_s: Vec<f64>,
    /// True α, rad.
    pub truth_alpha_rad: Vec<f64>,
    /// True β, rad.
    pub truth_beta_rad: Vec<f64>,
    /// True airspeed, m/s.
    pub truth_airspeed_mps: Vec<f64>,
}

/// A series at the simulator's output period, read at any time by linear interpolation, held
/// at its ends (the flight starts from trim, so the first value stands for the time before).
struct Series<'a> {
    v: &'a [f64],
    dt: f64,
}

impl Series<'_> {
    fn at(&self, t: f64) -> f64 {
        let x = (t / self.dt).max(0.0);
        let i = x.floor() as usize;
        if i + 1 >= self.v.len() {
            return self.v[self.v.len() - 1];
        }
        let f = x - i as f64;
        self.v[i] + f * (self.v[i + 1] - self.v[i])
    }
}

/// Samples `v` (period `dt`) as `timing` says and holds the samples onto `n` grid points of period
/// `grid_dt`. The phase and the jitter come from `rng`.
fn sample_and_hold(
    v: &[f64],
    dt: f64,
    timing: &ChannelTiming,
    grid_dt: f64,
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<f64> {
    let period = 1.0 / timing.rate_hz;
    let j = timing.jitter_s.clamp(0.0, 0.25 * period);
    let series = Series { v, dt };
    let phase = j + (period - 2.0 * j) * rng.random::<f64>();
    // Stamps s_k = phase − period + k·period; the first lies before the grid's start.
    let stamp = |k: usize| phase - period + k as f64 * period;
    let draw = |k: usize, rng: &mut ChaCha8Rng| {
        let eps = j * (2.0 * rng.random::<f64>() - 1.0);
        series.at(stamp(k) - timing.lag_s + eps)
    };
    let mut k = 0;
    let mut held = draw(0, rng);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let g = i as f64 * grid_dt;
        // A grid point exactly on a stamp takes that sample (tolerance: rounding of the sums).
        while stamp(k + 1) <= g + 1e-9 {
            k += 1;
            held = draw(k, rng);
        }
        out.push(held);
    }
    out
}

fn unwrap(v: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let mut offset = 0.0_f64;
    for (i, &x) in v.iter().enumerate() {
        if i > 0 {
            let d: f64 = x + offset - out[i - 1];
            offset -= core::f64::consts::TAU * (d / core::f64::consts::TAU).round();
        }
        out.push(x + offset);
    }
    out
}

fn wrap_pi(a: f64) -> f64 {
    let t = core::f64::consts::TAU;
    a - t * ((a + core::f64::consts::PI) / t).floor()
}

/// The true wind at a truth sample, NED: the mean wind plus the body-axis gust rotated to NED.
pub fn true_wind_ned_mps(mean_wind_ned_mps: &Vector3<f64>, s: &TruthSample) -> Vector3<f64> {
    mean_wind_ned_mps + s.state.attitude.transform_vector(&s.gust_body_mps)
}

/// The autopilot's wind estimate over the flight (module doc): the horizontal true wind through a
/// first-order low-pass of time constant `tau_s` (exact discretisation at `dt_s`), started on the
/// mean wind, plus the constant `error_ned_mps`; vertical 0.
pub fn wind_estimate_ned_mps(
    truth: &[TruthSample],
    mean_wind_ned_mps: &Vector3<f64>,
    dt_s: f64,
    tau_s: f64,
    error_ned_mps: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    let a = 1.0 - (-dt_s / tau_s).exp();
    let mut state = Vector3::new(mean_wind_ned_mps.x, mean_wind_ned_mps.y, 0.0);
    truth
        .iter()
        .map(|s| {
            let out = state + Vector3::new(error_ned_mps.x, error_ned_mps.y, 0.0);
            let w = true_wind_ned_mps(mean_wind_ned_mps, s);
            state += a * (Vector3::new(w.x, w.y, 0.0) - state);
            out
        })
        .collect()
}

/// α̂ and β̂ as ArduPilot's AHRS computes them: the velocity over the air, `v − ŵ` (NED), in body
/// axes by the attitude `euler_rad` (roll, pitch, yaw), then `atan2(v_z, v_x)` and `asin(v_y/|v|)`.
pub fn estimated_flow_angles(
    vel_ned_mps: &Vector3<f64>,
    wind_ned_mps: &Vector3<f64>,
    euler_rad: &Vector3<f64>,
) -> (f64, f64) {
    let r = nalgebra::Rotation3::from_euler_angles(euler_rad.x, euler_rad.y, euler_rad.z);
    let v = r.inverse_transform_vector(&(vel_ned_mps - wind_ned_mps));
    let n = v.norm();
    let beta = if n > 1e-9 {
        (v.y / n).clamp(-1.0, 1.0).asin()
    } else {
        0.0
    };
    (v.z.atan2(v.x), beta)
}

/// Logs a simulated flight as the small UAV's autopilot does (module doc). `mean_wind_ned_mps` is
/// the plant's mean wind; `elevator_lead_s` (≥ 0) makes the logged elevator lead the surface by
/// that time (a log stamped at command time; 0 for none). Seeded: the phases, jitter, noise and
/// the wind estimate's error come from `seed`.
pub fn log_flight(
    out: &SimOutput,
    mean_wind_ned_mps: &Vector3<f64>,
    logging: &UavLogging,
    elevator_lead_s: f64,
    seed: u64,
) -> UavLog {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dt = out.samples.get(1).map_or(0.01, |s| s.t_s) - out.samples.first().map_or(0.0, |s| s.t_s);
    let dt = if dt > 0.0 { dt } else { 0.01 };
    let duration = out.samples.len() as f64 * dt;
    let grid_dt = 1.0 / logging.grid_hz;
    let n = (duration / grid_dt).floor() as usize;
    let est = estimate_air_data(out, mean_wind_ned_mps, logging, dt, &mut rng);
    let mut hold = |v: &[f64], timing: &ChannelTiming| sample_and_hold(v, dt, timing, grid_dt, n, &mut rng);
    let mut log = UavLog::default();
    hold_inertial(&mut log, out, logging, &est.gps_ned_mps, &mut hold);
    hold_air_and_controls(&mut log, out, logging, &est, elevator_lead_s, &mut hold);
    log.t_s = (0..n).map(|i| i as f64 * grid_dt).collect();
    let truth_at = |f: &dyn Fn(&TruthSample) -> f64| -> Vec<f64> {
        let v: Vec<f64> = out.truth.iter().map(f).collect();
        let s = Series { v: &v, dt };
        log.t_s.iter().map(|&t| s.at(t)).collect()
    };
    log.truth_alpha_rad = truth_at(&|s| s.eval.alpha_rad);
    log.truth_beta_rad = truth_at(&|s| s.eval.beta_rad);
    log.truth_airspeed_mps = truth_at(&|s| s.eval.airspeed_mps);
    log
}

/// What the autopilot estimates at the source rate: α̂ and β̂ from the EKF velocity and the
/// lagged wind estimate, and the noisy GPS velocity (NED).
struct EstimatedAir {
    alpha_rad: Vec<f64>,
    beta_rad: Vec<f64>,
    gps_ned_mps: [Vec<f64>; 3],
}

/// Draws the wind estimate's error, the EKF velocity noise and the GPS noise from `rng` (in
/// that order) and forms [`EstimatedAir`] at the source interval `dt`.
fn estimate_air_data(
    out: &SimOutput,
    mean_wind_ned_mps: &Vector3<f64>,
    logging: &UavLogging,
    dt: f64,
    rng: &mut ChaCha8Rng,
) -> EstimatedAir {
    let gauss = |sd: f64, rng: &mut ChaCha8Rng| sd * rng.sample::<f64, _>(StandardNormal);
    let wind_error = Vector3::new(
        gauss(logging.wind_error_mps, rng),
        gauss(logging.wind_error_mps, rng),
        0.0,
    );
    let wind_est = wind_estimate_ned_mps(
        &out.truth,
        mean_wind_ned_mps,
        dt,
        logging.wind_time_constant_s,
        &wind_error,
    );
    let vel_true: Vec<Vector3<f64>> = out
        .truth
        .iter()
        .map(|s| s.state.attitude.transform_vector(&s.state.velocity_body_mps))
        .collect();
    let mut alpha_rad = Vec::with_capacity(vel_true.len());
    let mut beta_rad = Vec::with_capacity(vel_true.len());
    for (k, v) in vel_true.iter().enumerate() {
        let noise = Vector3::new(
            gauss(logging.ekf_velocity_noise_mps, rng),
            gauss(logging.ekf_velocity_noise_mps, rng),
            gauss(logging.ekf_velocity_noise_mps, rng),
        );
        let (a, b) = estimated_flow_angles(&(v + noise), &wind_est[k], &out.samples[k].euler_rad);
        alpha_rad.push(a);
        beta_rad.push(b);
    }
    let gps_ned_mps: [Vec<f64>; 3] = core::array::from_fn(|i| {
        vel_true
            .iter()
            .map(|v| v[i] + gauss(logging.gps_velocity_noise_mps, rng))
            .collect()
    });
    EstimatedAir {
        alpha_rad,
        beta_rad,
        gps_ned_mps,
    }
}

/// One channel of the simulated sensor samples.
fn column(out: &SimOutput, f: &dyn Fn(&aerosid_core::aero::SensorSample<f64>) -> f64) -> Vec<f64> {
    out.samples.iter().map(f).collect()
}

/// The IMU, the attitude and the GPS velocity held on the log's grid by `hold` (in that order:
/// `hold` draws each channel's phase and jitter).
fn hold_inertial(
    log: &mut UavLog,
    out: &SimOutput,
    logging: &UavLogging,
    gps_ned_mps: &[Vec<f64>; 3],
    hold: &mut impl FnMut(&[f64], &ChannelTiming) -> Vec<f64>,
) {
    let col = |f: &dyn Fn(&aerosid_core::aero::SensorSample<f64>) -> f64| column(out, f);
    let imu = logging.imu;
    log.accel_mps2 = [
        hold(&col(&|s| s.accel_mps2.x), &imu),
        hold(&col(&|s| s.accel_mps2.y), &imu),
        hold(&col(&|s| s.accel_mps2.z), &imu),
    ];
    log.gyro_rad_s = [
        hold(&col(&|s| s.gyro_rad_s.x), &imu),
        hold(&col(&|s| s.gyro_rad_s.y), &imu),
        hold(&col(&|s| s.gyro_rad_s.z), &imu),
    ];
    let att = logging.attitude;
    log.euler_rad = [
        hold(&col(&|s| s.euler_rad.x), &att).into_iter().map(wrap_pi).collect(),
        hold(&col(&|s| s.euler_rad.y), &att),
        hold(&unwrap(&col(&|s| s.euler_rad.z)), &att)
            .into_iter()
            .map(wrap_pi)
            .collect(),
    ];
    log.vel_ned_mps = [
        hold(&gps_ned_mps[0], &logging.gps_velocity),
        hold(&gps_ned_mps[1], &logging.gps_velocity),
        hold(&gps_ned_mps[2], &logging.gps_velocity),
    ];
}

/// The airspeed, the estimated α and β, the surfaces, throttle, air density and propeller speed
/// held on the log's grid by `hold` (in that order); the logged elevator leads the surface by
/// `elevator_lead_s`.
fn hold_air_and_controls(
    log: &mut UavLog,
    out: &SimOutput,
    logging: &UavLogging,
    est: &EstimatedAir,
    elevator_lead_s: f64,
    hold: &mut impl FnMut(&[f64], &ChannelTiming) -> Vec<f64>,
) {
    let col = |f: &dyn Fn(&aerosid_core::aero::SensorSample<f64>) -> f64| column(out, f);
    log.airspeed_mps = hold(&col(&|s| s.airspeed_mps), &logging.airspeed);
    log.alpha_est_rad = hold(&est.alpha_rad, &logging.flow_angles);
    log.beta_est_rad = hold(&est.beta_rad, &logging.flow_angles);
    let servo = logging.servo;
    let elevator_timing = ChannelTiming {
        lag_s: servo.lag_s - elevator_lead_s.max(0.0),
        ..servo
    };
    log.surfaces_rad = [
        hold(&col(&|s| s.elevator_rad), &elevator_timing),
        hold(&col(&|s| s.aileron_rad), &servo),
        hold(&col(&|s| s.rudder_rad), &servo),
    ];
    log.throttle = hold(&col(&|s| s.throttle), &servo);
    log.air_density_kgpm3 = hold(&col(&|s| s.air_density_kgpm3), &logging.baro);
    log.prop_speed_rad_s = hold(&col(&|s| s.prop_speed_rad_s), &logging.rpm);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Number of value changes of a held series.
    fn changes(v: &[f64]) -> usize {
        v.windows(2).filter(|w| w[0] != w[1]).count()
    }

    /// A ramp sampled at 10 Hz and held on a 50 Hz grid changes 10 times a second, each value the
    /// ramp at its stamp minus the lag (within the jitter's slope), and never ahead of the signal.
    #[test]
    fn a_ramp_is_held_at_its_rate_with_its_lag() {
        let dt = 0.01;
        let v: Vec<f64> = (0..1000).map(|k| k as f64 * dt).collect();
        let timing = ChannelTiming::new(10.0, 0.05, 0.005);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let held = sample_and_hold(&v, dt, &timing, 0.02, 500, &mut rng);
        // 10 s at 10 Hz: 99 or 100 stamps in (0, 9.98] s (by the phase), the first before it.
        assert!((99..=100).contains(&changes(&held)), "{}", changes(&held));
        for (i, h) in held.iter().enumerate() {
            let g = i as f64 * 0.02;
            // Held at most one period plus lag plus jitter behind the ramp, never ahead of g − lag + jitter.
            assert!(*h <= g - 0.05 + 0.005 + 1e-9 || *h == 0.0, "grid {g}: {h}");
            assert!(*h >= g - 0.1 - 0.05 - 0.005 - 1e-9 || *h == 0.0, "grid {g}: {h}");
        }
    }

    /// A 50 Hz channel on the 50 Hz grid takes a new sample at every grid point (after the first
    /// 0.1 s, where samples from before the flight's start all read its first value).
    #[test]
    fn a_grid_rate_channel_changes_every_point() {
        let dt = 0.01;
        let v: Vec<f64> = (0..500).map(|k| (k as f64 * 0.37).sin()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let held = sample_and_hold(&v, dt, &ChannelTiming::new(50.0, 0.01, 0.001), 0.02, 250, &mut rng);
        assert_eq!(changes(&held[5..]), 244);
    }

    /// With no wind, no wind error and the true attitude, the estimated flow angles are the true
    /// ones (to rounding): the estimator's only errors are the ones modelled.
    #[test]
    fn the_estimate_is_exact_without_wind_or_errors() {
        let e = Vector3::new(0.2, 0.05, 1.0);
        let (alpha, beta) = (0.07_f64, -0.03_f64);
        let v_body = 15.0 * Vector3::new(alpha.cos() * beta.cos(), beta.sin(), alpha.sin() * beta.cos());
        let r = nalgebra::Rotation3::from_euler_angles(e.x, e.y, e.z);
        let (a, b) = estimated_flow_angles(&r.transform_vector(&v_body), &Vector3::zeros(), &e);
        assert!((a - alpha).abs() < 1e-12 && (b - beta).abs() < 1e-12, "{a} {b}");
    }
}
