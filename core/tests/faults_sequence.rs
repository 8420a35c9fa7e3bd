//! Missed samples (`aero::sequence`): the sample after a gap carries the real time since
//! the last one the pipeline saw, so the differentiator restarts instead of taking a wrong step. In
//! `f32` and `f64`.

use aerosid_core::aero::model::{channel, idx};
use aerosid_core::aero::{onboard, Admission, Refusal, SensorSample, SequenceCheck};
use aerosid_core::Real;
use nalgebra::Vector3;

/// A 100 Hz sample `k` with a sinusoidal pitch rate (so `ω̇` is not zero) and plausible channels.
fn sample<T: Real>(k: u32) -> SensorSample<T> {
    let t = f64::from(k) * 0.01;
    let l = T::lit;
    SensorSample {
        t_s: l(t),
        dt_s: l(0.01),
        accel_mps2: Vector3::new(l(0.3 * (2.0 * t).sin()), l(0.01), l(-9.6 + 0.5 * (1.3 * t).cos())),
        gyro_rad_s: Vector3::new(l(0.02 * (0.7 * t).sin()), l(0.2 * (3.0 * t).sin()), l(0.01)),
        airspeed_mps: l(16.0 + (0.4 * t).sin()),
        alpha_rad: l(0.06 + 0.02 * (3.0 * t).sin()),
        beta_rad: l(0.01 * (0.9 * t).cos()),
        euler_rad: Vector3::new(l(0.0), l(0.05), l(0.0)),
        prop_speed_rad_s: l(600.0 + 20.0 * (0.5 * t).sin()),
        elevator_rad: l(-0.05 + 0.03 * (2.5 * t).sin()),
        aileron_rad: l(0.02 * (1.1 * t).sin()),
        rudder_rad: l(0.01 * (0.8 * t).cos()),
        throttle: l(0.5),
        air_density_kgpm3: l(1.2),
    }
}

const T0_US: u64 = 5_000_000;

fn stamp(k: u32) -> u64 {
    T0_US + u64::from(k) * 10_000
}

fn in_sequence_samples_are_untouched<T: Real>() {
    // GIVEN samples numbered 0, 1, 2, … (wrapping through u32::MAX) WHEN admitted THEN unchanged
    let mut c = SequenceCheck::NEW;
    for (i, seq) in (u32::MAX - 100..=u32::MAX).chain(0..100).enumerate() {
        let mut s = sample::<T>(i as u32);
        let before = s;
        assert_eq!(c.admit(seq, stamp(i as u32), &mut s), Admission::Next, "seq {seq}");
        assert_eq!(s, before);
    }
    assert_eq!(c.health().admitted, 201);
    assert_eq!((c.health().gaps, c.health().missed, c.health().stale), (0, 0, 0));
}

fn a_gap_sets_dt_to_the_real_time_since_the_last_admitted_sample<T: Real>() {
    // GIVEN samples 0…9 admitted, then 10, 11, 12 dropped (the queue was full)
    let mut c = SequenceCheck::NEW;
    for k in 0..10 {
        let mut s = sample::<T>(k);
        c.admit(k, stamp(k), &mut s);
    }
    // WHEN sample 13 arrives, stamped by the sampler with dt 10 ms since sample 12
    let mut s = sample::<T>(13);
    let a = c.admit(13, stamp(13), &mut s);
    // THEN three are missed and dt spans 9 → 13: 40 ms, as the µs stamps say (to the one rounding
    // of the µs-to-s conversion)
    assert_eq!(a, Admission::Gap { missed: 3 });
    assert!(
        (s.dt_s - T::lit(0.04)).abs() <= T::lit(0.04) * T::EPS,
        "dt {:?}",
        s.dt_s
    );
    // … the next sample in sequence is untouched again, and the counters say what happened
    let mut s = sample::<T>(14);
    assert_eq!(c.admit(14, stamp(14), &mut s), Admission::Next);
    assert_eq!(s.dt_s, T::lit(0.01));
    let h = c.health();
    assert_eq!((h.admitted, h.gaps, h.missed, h.stale), (12, 1, 3, 0));
}

fn a_repeated_or_older_sample_is_stale_and_moves_nothing<T: Real>() {
    let mut c = SequenceCheck::NEW;
    for k in 0..5 {
        let mut s = sample::<T>(k);
        c.admit(k, stamp(k), &mut s);
    }
    // A repeat of 4, and 3 again: stale, unchanged, and the check still expects 5.
    for seq in [4, 3, 4u32.wrapping_sub(1 << 31)] {
        let mut s = sample::<T>(seq);
        let before = s;
        assert_eq!(c.admit(seq, stamp(seq), &mut s), Admission::Stale, "seq {seq}");
        assert_eq!(s, before);
    }
    let mut s = sample::<T>(5);
    assert_eq!(c.admit(5, stamp(5), &mut s), Admission::Next);
    assert_eq!(c.health().stale, 3);
    // A clock that did not advance across a gap gives dt 0 (refused by the pipeline's dt check).
    let mut s = sample::<T>(7);
    assert_eq!(c.admit(7, stamp(5), &mut s), Admission::Gap { missed: 1 });
    assert_eq!(s.dt_s, T::zero());
}

/// Runs the on-board pipeline over samples `0..n` without those in `drop`, optionally through the
/// sequence check; returns the status of the moment coefficient `C_m` and the force `C_L` at each
/// processed sample.
fn run<T: Real>(n: u32, drop: &[u32], check: bool) -> Vec<(u32, bool, Option<Refusal>, Option<Refusal>)> {
    let mut p = onboard::pipeline::<T>().expect("on-board pipeline");
    let mut c = SequenceCheck::NEW;
    let mut out = Vec::new();
    for k in (0..n).filter(|k| !drop.contains(k)) {
        let mut s = sample::<T>(k);
        let gap = check && matches!(c.admit(k, stamp(k), &mut s), Admission::Gap { .. });
        let dt_ok = p.settings().limits.valid_channels(&s) & channel::DT != 0;
        let step = p.process(&s);
        out.push((
            k,
            dt_ok && !gap,
            step.status[idx::PITCH].err(),
            step.status[idx::LIFT].err(),
        ));
    }
    out
}

fn after_a_drop_the_differentiator_restarts_and_the_forces_go_on<T: Real>() {
    // GIVEN 300 samples with 120 and 121 dropped
    let with = run::<T>(300, &[120, 121], true);
    let without = run::<T>(300, &[120, 121], false);
    // WHEN they pass the sequence check THEN sample 122's dt (30 ms) is refused by the dt check …
    let dt_accepted_at_122 = with.iter().find(|e| e.0 == 122).map(|e| e.1);
    assert_eq!(dt_accepted_at_122, Some(false), "the gap's dt was accepted");
    // … the moments wait for a full window again (the sample synthesised two later is the first
    // centre after the gap; 4 more samples refill the differentiator's window), while C_L, which
    // needs no dt, goes on updating
    let pitch_refused: Vec<(u32, Refusal)> = with
        .iter()
        .filter(|e| e.0 >= 122)
        .filter_map(|e| e.2.map(|r| (e.0, r)))
        .collect();
    assert!(!pitch_refused.is_empty(), "C_m was not refused after the gap");
    for (k, r) in &pitch_refused {
        assert!(*k < 140, "C_m still refused at sample {k}");
        let dt_or_warmup = match r {
            Refusal::Warmup => true,
            Refusal::Channels(m) => m & channel::DT != 0,
            Refusal::Estimator(_) | Refusal::NotConfigured => false,
        };
        assert!(dt_or_warmup, "sample {k}: C_m refused as {r:?}");
    }
    assert!(
        with.iter().filter(|e| e.0 >= 122).all(|e| e.3.is_none()),
        "C_L refused after the gap"
    );
    // … and without the check the 10 ms stamp across a 30 ms gap is taken at its word: no
    // refusal at all, so the moments update on an ω̇ computed with the wrong step
    assert!(without.iter().filter(|e| e.0 >= 122).all(|e| e.2.is_none()));
}

fn admit_stamp_agrees_with_admit_without_touching_the_sample<T: Real>() {
    // GIVEN two checks fed the same numbers — in order, a gap, repeats, an older one, wrapping —
    let seqs: [u32; 10] = [u32::MAX - 1, u32::MAX, 0, 4, 4, 2, 5, 9, 1 << 31, 10];
    let mut by_sample = SequenceCheck::NEW;
    let mut by_stamp = SequenceCheck::NEW;
    for (i, &seq) in seqs.iter().enumerate() {
        let t_us = stamp(i as u32 * 3);
        let mut s = sample::<T>(i as u32);
        let dt_before = s.dt_s;
        // WHEN one admits the sample and the other only its number and time stamp
        let a = by_sample.admit(seq, t_us, &mut s);
        let (b, dt_s) = by_stamp.admit_stamp::<T>(seq, t_us);
        // THEN the admissions, the counters and the dt agree: `dt_s` is what `admit` wrote, and
        // `None` exactly where `admit` left the sample's own
        assert_eq!(a, b, "seq {seq}");
        assert_eq!(by_sample, by_stamp, "seq {seq}");
        match dt_s {
            Some(dt) => {
                assert!(matches!(b, Admission::Gap { .. }), "seq {seq}: a dt without a gap");
                assert_eq!(dt.to_f64().to_bits(), s.dt_s.to_f64().to_bits(), "seq {seq}");
            }
            None => assert_eq!(s.dt_s.to_f64().to_bits(), dt_before.to_f64().to_bits(), "seq {seq}"),
        }
    }
    assert!(
        by_stamp.health().gaps >= 2 && by_stamp.health().stale >= 2,
        "{:?}",
        by_stamp.health()
    );
}

macro_rules! both {
    ($($name:ident),*) => {
        mod f32_tests { $(#[test] fn $name() { super::$name::<f32>() })* }
        mod f64_tests { $(#[test] fn $name() { super::$name::<f64>() })* }
    };
}

both!(
    in_sequence_samples_are_untouched,
    a_gap_sets_dt_to_the_real_time_since_the_last_admitted_sample,
    a_repeated_or_older_sample_is_stale_and_moves_nothing,
    admit_stamp_agrees_with_admit_without_touching_the_sample,
    after_a_drop_the_differentiator_restarts_and_the_forces_go_on
);
