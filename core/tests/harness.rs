//! The sensor-health bookkeeping shared by the firmware and the host's model of it
//! (`aerosid_core::harness`): the chip counters' re-initialisation rule and the health report's slots.

use aerosid_core::aero::model::channel;
use aerosid_core::aero::SequenceHealth;
use aerosid_core::harness::{health_report, ChipHealth, LinkHealth, SampleCounts, SensorHealth, REINIT_AFTER};
use aerosid_core::mavlink::telemetry::health_slot as slot;

#[test]
fn a_chip_is_reinitialised_after_every_run_of_reinit_after_failures() {
    let mut c = ChipHealth::default();
    // One good read clears a streak: REINIT_AFTER − 1 failures, a success, then again.
    for _ in 0..2 {
        for _ in 1..REINIT_AFTER {
            assert!(!c.record(false));
        }
        assert!(!c.record(true));
    }
    assert_eq!((c.faults, c.reinits), (2 * u32::from(REINIT_AFTER - 1), 0));
    // A dead chip: a re-initialisation at the REINIT_AFTER-th failure in a row, and again after
    // as many more.
    let mut reinit_at = Vec::new();
    for k in 1..=3 * u32::from(REINIT_AFTER) {
        if c.record(false) {
            reinit_at.push(k);
        }
    }
    let n = u32::from(REINIT_AFTER);
    assert_eq!(reinit_at, vec![n, 2 * n, 3 * n]);
    assert_eq!(c.reinits, 3);
}

#[test]
fn the_health_report_puts_every_counter_in_its_slot() {
    let chip = |faults, reinits| {
        let mut c = ChipHealth::default();
        for _ in 0..faults {
            c.record(false);
        }
        assert_eq!(c.reinits, reinits);
        c
    };
    let n = u32::from(REINIT_AFTER);
    let h = SensorHealth {
        imu: chip(1, 0),
        airspeed: chip(n, 1),
        alpha_vane: chip(2 * n, 2),
        beta_vane: chip(3, 0),
        autopilot_faults: 11,
        link: LinkHealth {
            frames: 21,
            rejected: 22,
            discarded: 23,
            lost: 24,
            not_newer: 25,
        },
        stuck_now: channel::ALPHA,
        stuck_episodes: 31,
        stuck_samples: 32,
    };
    let mut invalid_channel = [0u32; channel::COUNT];
    for (k, v) in invalid_channel.iter_mut().enumerate() {
        *v = 100 + k as u32;
    }
    let counts = SampleCounts {
        sampled: 1000,
        dropped: 3,
        sequence: SequenceHealth {
            gaps: 4,
            missed: 5,
            stale: 6,
            ..SequenceHealth::default()
        },
        invalid_now: channel::BETA,
        invalid_channel: &invalid_channel,
    };
    let v = health_report(&h, &counts).values;
    let expect = [
        (slot::SAMPLED, 1000),
        (slot::DROPPED, 3),
        (slot::GAPS, 4),
        (slot::MISSED, 5),
        (slot::STALE, 6),
        (slot::IMU_FAULTS, 1),
        (slot::IMU_REINITS, 0),
        (slot::AIRSPEED_FAULTS, n),
        (slot::AIRSPEED_REINITS, 1),
        (slot::ALPHA_FAULTS, 2 * n),
        (slot::ALPHA_REINITS, 2),
        (slot::BETA_FAULTS, 3),
        (slot::BETA_REINITS, 0),
        (slot::AUTOPILOT_FAULTS, 11),
        (slot::STUCK_NOW, u32::from(channel::ALPHA)),
        (slot::STUCK_EPISODES, 31),
        (slot::STUCK_SAMPLES, 32),
        (slot::LINK_FRAMES, 21),
        (slot::LINK_REJECTED, 22),
        (slot::LINK_DISCARDED, 23),
        (slot::LINK_LOST, 24),
        (slot::LINK_NOT_NEWER, 25),
        (slot::INVALID_NOW, u32::from(channel::BETA)),
    ];
    for (s, want) in expect {
        assert_eq!(v[s], want, "slot {s}");
    }
    for k in 0..channel::COUNT {
        assert_eq!(v[slot::INVALID + k], 100 + k as u32, "invalid channel {k}");
    }
}
