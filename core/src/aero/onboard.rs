//! The on-board configuration the firmware flies with, in one place so that the host can build the
//! very same pipeline (the QEMU replay test compares the firmware's estimates with a host `f32` run
//! of the same log, bit for bit).
//!
//! Airframe: `skywalker_2013_mod` ([`Airframe::skywalker_2013_mod`]); models: the default regressor
//! sets of eq. 3 with the typical-magnitude weights of eq. 23; `σ_ε`: [`SIGMA_EPS`]; settings:
//! the defaults with the variable forgetting factor for aerodynamic coefficients at
//! [`SAMPLE_RATE_HZ`] ([`VffSettings::for_aero_coefficients`]). Another airframe means another
//! `Airframe`, `σ_ε` and (from the host Monte Carlo) this module's constants.
//!
//! Also here, for the same reason: the stuck-sensor windows ([`stuck_settings`]) and the autopilot
//! link's calibration ([`AUTOPILOT_LINK`]) the firmware's sensor layer uses.

use super::{AeroModels, Airframe, Pipeline, PipelineSettings, StuckSettings};
use crate::mavlink::surfaces::{RpmSource, ServoCalibration, ThrottleCalibration};
use crate::mavlink::SurfaceConfig;
use crate::{Error, Forgetting, Real, VffSettings};

/// Sampling rate of the flight computer, Hz.
pub const SAMPLE_RATE_HZ: f64 = 100.0;

/// `σ_ε` of the six synthetic coefficients (eq. 41), indexed by [`super::model::idx`]: the host
/// Monte Carlo of Section V (eq. 34–41) for the default sensors on `skywalker_2013_mod`, 2¹⁸ draws,
/// seed 1 (`aerosid run` prints it), rounded to 3 significant digits.
pub const SIGMA_EPS: [f64; 6] = [0.0149, 0.0107, 0.00226, 0.00126, 0.0135, 0.00247];

/// The on-board pipeline settings (module doc).
pub fn settings<T: Real>() -> PipelineSettings<T> {
    let mut s = PipelineSettings::default();
    s.gtls.forgetting = Forgetting::Variable(VffSettings::for_aero_coefficients(T::lit(SAMPLE_RATE_HZ)));
    s
}

/// The on-board pipeline (module doc).
pub fn pipeline<T: Real>() -> Result<Pipeline<T>, Error> {
    Pipeline::new(
        Airframe::skywalker_2013_mod(),
        AeroModels::with_sigma_eps(SIGMA_EPS.map(T::lit)),
        settings(),
    )
}

/// Configures `pipeline` in place as the on-board pipeline ([`Pipeline::configure`]: the
/// firmware's static, without the whole pipeline on the boot stack).
pub fn configure<T: Real>(pipeline: &mut Pipeline<T>) -> Result<(), Error> {
    pipeline.configure(
        Airframe::skywalker_2013_mod(),
        AeroModels::with_sigma_eps(SIGMA_EPS.map(T::lit)),
        settings(),
    )
}

/// The stuck-sensor windows of the sensor layer: [`StuckSettings::default`] (IMU 0.2 s, airspeed
/// and vanes 0.5 s at 100 Hz; the autopilot's values, density and `dt` unchecked).
pub fn stuck_settings() -> StuckSettings {
    StuckSettings::default()
}

/// A ±25° surface over ±500 µs of PWM around 1500 µs. Placeholder.
const fn servo(channel: u8, rad_per_us: f32) -> ServoCalibration {
    ServoCalibration {
        channel,
        pwm_neutral_us: 1500.0,
        rad_per_us,
        limits_rad: (-0.44, 0.44),
    }
}

/// The autopilot link: system 1, ArduPilot Plane's default outputs (SERVO1 aileron, SERVO2
/// elevator, SERVO3 throttle, SERVO4 rudder; `SERVOn_FUNCTION`), RPM sensor 1. Stream rates the
/// timeouts assume: `SERVO_OUTPUT_RAW` and `ATTITUDE` ≥ 20 Hz, `RPM` ≥ 4 Hz (ArduPilot
/// `SRn_RC_CHAN`, `SRn_EXTRA1`, `SRn_EXTRA3` on the port wired to the co-processor). The servo
/// calibrations are placeholders for a typical airframe: set them for the aircraft.
pub const AUTOPILOT_LINK: SurfaceConfig = SurfaceConfig {
    source_system_id: 1,
    port: 0,
    elevator: servo(1, 0.000_873),
    aileron: servo(0, 0.000_873),
    aileron_2: None,
    rudder: servo(3, 0.000_873),
    throttle: ThrottleCalibration {
        channel: 2,
        pwm_idle_us: 1100,
        pwm_full_us: 1900,
    },
    pwm_valid_us: [800, 2200],
    servo_timeout_us: 100_000,
    rpm: RpmSource::ArduPilotRpm { sensor: 0 },
    rpm_scale: 1.0,
    rpm_timeout_us: 500_000,
    attitude_timeout_us: 100_000,
};
