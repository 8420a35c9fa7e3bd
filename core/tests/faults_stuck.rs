//! The stuck-sensor detector (`aero::stuck`), in `f32` and `f64`.

use aerosid_core::aero::model::channel;
use aerosid_core::aero::{SensorSample, StuckDetector, StuckSettings};
use aerosid_core::Real;
use nalgebra::Vector3;

fn bit(mask: u16) -> usize {
    mask.trailing_zeros() as usize
}

/// A sample whose every channel changes with `k` (a live sensor set).
fn live<T: Real>(k: u32) -> SensorSample<T> {
    let v = |base: f64, step: f64| T::lit(base + step * f64::from(k % 97));
    SensorSample {
        t_s: v(0.0, 0.01),
        dt_s: T::lit(0.01),
        accel_mps2: Vector3::new(v(0.1, 1e-3), v(0.2, 1e-3), v(-9.8, 1e-3)),
        gyro_rad_s: Vector3::new(v(0.0, 1e-4), v(0.01, 1e-4), v(0.0, 1e-4)),
        airspeed_mps: v(15.0, 0.01),
        alpha_rad: v(0.05, 1e-4),
        beta_rad: v(0.0, 1e-4),
        euler_rad: Vector3::new(v(0.0, 1e-4), v(0.05, 1e-4), v(0.0, 1e-4)),
        prop_speed_rad_s: T::lit(600.0),
        elevator_rad: T::lit(-0.05),
        aileron_rad: T::zero(),
        rudder_rad: T::zero(),
        throttle: T::lit(0.5),
        air_density_kgpm3: T::lit(1.2),
    }
}

fn live_sensors_are_never_stuck<T: Real>() {
    // GIVEN live sensors but constant surfaces, throttle, RPM, density and dt (as in steady cruise)
    let mut d = StuckDetector::new(StuckSettings::default());
    // WHEN 10 000 samples pass THEN nothing is stuck (the constant channels are off by default)
    for k in 0..10_000 {
        let mut s = live::<T>(k);
        let before = s;
        assert_eq!(d.apply(&mut s), 0, "sample {k}");
        assert_eq!(s, before, "a live sample was changed");
    }
    assert_eq!(d.health().episodes, [0; channel::COUNT]);
}

fn each_channel_is_caught_at_its_window_and_released_when_it_moves<T: Real>() {
    let settings = StuckSettings::default();
    for ch in [
        channel::ACCEL,
        channel::GYRO,
        channel::AIRSPEED,
        channel::ALPHA,
        channel::BETA,
    ] {
        let w = usize::from(settings.samples[bit(ch)]);
        let mut d = StuckDetector::new(settings);
        // GIVEN channel `ch` frozen at its value of sample 0 for 2w samples, everything else live
        let frozen = live::<T>(0);
        for k in 0..3 * w as u32 {
            let mut s = live::<T>(k);
            let stuck_phase = (k as usize) < 2 * w;
            if stuck_phase {
                match ch {
                    channel::ACCEL => s.accel_mps2 = frozen.accel_mps2,
                    channel::GYRO => s.gyro_rad_s = frozen.gyro_rad_s,
                    channel::AIRSPEED => s.airspeed_mps = frozen.airspeed_mps,
                    channel::ALPHA => s.alpha_rad = frozen.alpha_rad,
                    _ => s.beta_rad = frozen.beta_rad,
                }
            }
            let m = d.apply(&mut s);
            // THEN it is reported stuck exactly from its w-th identical reading while frozen
            let want = stuck_phase && k as usize + 1 >= w;
            assert_eq!(m, if want { ch } else { 0 }, "channel {ch:#x}, sample {k}, window {w}");
            if want {
                let nan = match ch {
                    channel::ACCEL => s.accel_mps2.iter().all(|x| x.to_f64().is_nan()),
                    channel::GYRO => s.gyro_rad_s.iter().all(|x| x.to_f64().is_nan()),
                    channel::AIRSPEED => s.airspeed_mps.to_f64().is_nan(),
                    channel::ALPHA => s.alpha_rad.to_f64().is_nan(),
                    _ => s.beta_rad.to_f64().is_nan(),
                };
                assert!(nan, "stuck channel not set to NaN");
            }
        }
        assert_eq!(d.health().episodes[bit(ch)], 1);
        assert_eq!(d.health().samples[bit(ch)], (w + 1) as u32);
    }
}

fn nan_and_sign_of_zero_end_a_run_and_zero_window_is_off<T: Real>() {
    let mut s = StuckSettings::default();
    s.samples[bit(channel::ALPHA)] = 3;
    s.samples[bit(channel::ACCEL)] = 0;
    let mut d = StuckDetector::new(s);
    let mut x = live::<T>(0);
    x.accel_mps2 = Vector3::zeros();
    x.alpha_rad = T::zero();
    // Two zeros, a NaN (no reading: the run ends), two zeros, a −0 (different bits), two zeros.
    let alphas = [0.0, 0.0, f64::NAN, 0.0, 0.0, -0.0, 0.0, 0.0, 0.0];
    let mut flagged = Vec::new();
    for (k, a) in alphas.iter().enumerate() {
        let mut y = live::<T>(k as u32);
        y.accel_mps2 = x.accel_mps2; // constant, but its check is off
        y.alpha_rad = T::lit(*a);
        if d.check(&y) & channel::ALPHA != 0 {
            flagged.push(k);
        }
    }
    // Only the last run of three +0 readings (samples 6, 7, 8) reaches the window of 3.
    assert_eq!(flagged, vec![8]);
    assert_eq!(d.health().episodes[bit(channel::ACCEL)], 0);
}

macro_rules! both {
    ($($name:ident),*) => {
        mod f32_tests { $(#[test] fn $name() { super::$name::<f32>() })* }
        mod f64_tests { $(#[test] fn $name() { super::$name::<f64>() })* }
    };
}

both!(
    live_sensors_are_never_stuck,
    each_channel_is_caught_at_its_window_and_released_when_it_moves,
    nan_and_sign_of_zero_end_a_run_and_zero_window_is_off
);
