//! The autopilot's part of a sample, on both boards: surfaces, throttle, RPM and attitude from the
//! MAVLink stream ([`MavlinkSurfaces`], configured by [`aerosid_core::aero::onboard::AUTOPILOT_LINK`]).
//! The flight computer feeds it the bytes of USART2; the QEMU board the bytes of a log (`autopilot.bin`).

use aerosid_core::aero::SensorSample;
use aerosid_core::mavlink::{MavlinkSurfaces, SurfaceSource};
use nalgebra::Vector3;

/// Writes what `link` holds at `now_us` into `s`: each missing, stale or out-of-range value NaN.
/// `true` when every one of them (three surfaces, throttle, RPM, three angles) is present.
pub fn fill(link: &mut MavlinkSurfaces, now_us: u64, s: &mut SensorSample<f32>) -> bool {
    let nan = f32::NAN;
    match link.surfaces(now_us) {
        Ok(r) => {
            s.elevator_rad = r.elevator_rad.unwrap_or(nan);
            s.aileron_rad = r.aileron_rad.unwrap_or(nan);
            s.rudder_rad = r.rudder_rad.unwrap_or(nan);
            s.throttle = r.throttle.unwrap_or(nan);
        }
        Err(_) => {
            s.elevator_rad = nan;
            s.aileron_rad = nan;
            s.rudder_rad = nan;
            s.throttle = nan;
        }
    }
    s.prop_speed_rad_s = link.prop_speed_rad_s(now_us).unwrap_or(nan);
    s.euler_rad = match link.euler_rad(now_us) {
        Ok(e) => Vector3::from(e),
        Err(_) => Vector3::from_element(nan),
    };
    [
        s.elevator_rad,
        s.aileron_rad,
        s.rudder_rad,
        s.throttle,
        s.prop_speed_rad_s,
    ]
    .iter()
    .chain(s.euler_rad.iter())
    .all(|v| !v.is_nan())
}
