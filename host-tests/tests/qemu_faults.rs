//! Sensor, bus, timing and link faults injected into the firmware under QEMU:
//! a simulated flight replayed with its autopilot stream on the (emulated) link, garbage on that
//! link, and a schedule of faults the QEMU board applies where the flight computer's sensor layer
//! would meet them (`firmware/src/board/qemu.rs`). The firmware must survive all of it, report
//! each fault in its telemetry health report as documented, and end with exactly the estimates
//! and health figures of the host's model of the same path ([`qemu::emulate`]), bit for bit.
//!
//! Needs `qemu-system-arm` and the thumb target, as `qemu_replay.rs`.

use aerosid_core::aero::model::channel;
use aerosid_core::aero::SensorSample;
use aerosid_core::harness::REINIT_AFTER;
use aerosid_core::mavlink::frame::frame_crc;
use aerosid_core::mavlink::messages::ServoOutputRaw;
use aerosid_core::mavlink::telemetry::{health_bit, health_slot as slot};
use aerosid_core::mavlink::Encoder;
use aerosid_qemu::{self as qemu, Chip, Fault, FaultEvent, Scenario};
use aerosid_sim::{self as sim, flights};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Duration;

const SAMPLES: usize = 2000;

fn flight() -> Vec<SensorSample<f32>> {
    let out = sim::simulate(&flights::main_flight(SAMPLES as f64 / 100.0, 11)).expect("simulation");
    out.samples.iter().map(|s| s.cast::<f32>()).collect()
}

fn ev(first: u32, count: u32, fault: Fault) -> FaultEvent {
    FaultEvent { first, count, fault }
}

/// The fault schedule (record indices of the 100 Hz replay).
fn schedule() -> Vec<FaultEvent> {
    vec![
        // IMU dead for 0.6 s: 60 failed reads, one re-initialisation after 50 in a row
        ev(300, 60, Fault::Bus(Chip::Imu)),
        // airspeed sensor NACKs for 0.1 s
        ev(500, 10, Fault::Bus(Chip::Airspeed)),
        // α vane jammed for 1.2 s
        ev(700, 120, Fault::Stuck(channel::ALPHA)),
        // gyro NaN, airspeed out of range (1e30), accelerometer +∞
        ev(900, 5, Fault::Value(channel::GYRO, f32::NAN)),
        ev(950, 3, Fault::Value(channel::AIRSPEED, 1e30)),
        ev(960, 2, Fault::Value(channel::ACCEL, f32::INFINITY)),
        // three samples dropped (the estimator's queue full)
        ev(1100, 3, Fault::Drop),
        // one sample taken 7 ms late
        ev(1300, 1, Fault::Late(7_000)),
        // β vane dead for 2 s: 200 failed reads, re-initialised every 50
        ev(1400, 200, Fault::Bus(Chip::BetaVane)),
        // the autopilot link's bytes lost for 150 ms (its 100 ms timeouts run out)
        ev(1700, 15, Fault::Bus(Chip::Autopilot)),
    ]
}

fn servo_frame(enc: &mut Encoder, pwm: u16) -> Vec<u8> {
    let mut m = ServoOutputRaw::default();
    m.servo_raw_us[..4].copy_from_slice(&[pwm; 4]);
    let mut buf = [0u8; 64];
    let n = enc.encode(&m, &mut buf).expect("encode");
    buf[..n].to_vec()
}

/// Seeded garbage of every kind before the valid frames of some samples' chunks: random bytes, runs
/// of start bytes, fake headers, a valid frame with a corrupted byte, a truncated frame, a frame
/// claiming more than its message's length, unknown incompatibility flags, a frame from another
/// system with absurd values, and an old frame of the autopilot's replayed. Returns the number of
/// corrupted-checksum frames put in and the chunks where an old chunk was replayed.
fn add_garbage(chunks: &mut [Vec<u8>], rng: &mut ChaCha8Rng) -> (u32, Vec<usize>) {
    let mut other = Encoder::new(7, 1);
    let mut corrupted = 0;
    let mut replayed = Vec::new();
    for k in (40..chunks.len()).step_by(37) {
        let mut g = Vec::new();
        for _ in 0..rng.random_range(1..6) {
            match rng.random_range(0..9) {
                0 => g.extend((0..rng.random_range(1..200)).map(|_| rng.random::<u8>())),
                1 => g.extend(std::iter::repeat_n(0xFD, rng.random_range(1..30))),
                2 => g.extend([0xFD, rng.random(), 0, 0, rng.random(), 1, 1, rng.random(), 0, 0]),
                3 => {
                    // the sample's own frames with the last checksum byte wrong: one bad frame
                    let mut f = chunks[k].clone();
                    let last = f.len() - 1;
                    f[last] ^= 0x5A;
                    g.extend(&f);
                    corrupted += 1;
                }
                4 => {
                    let f = chunks[k].clone();
                    g.extend(&f[..rng.random_range(1..f.len())]);
                }
                5 => {
                    // SERVO_OUTPUT_RAW (at most 37 bytes) claiming 200, with a matching checksum
                    let mut big = vec![0xFD, 200, 0, 0, 9, 1, 1, 36, 0, 0];
                    big.extend(std::iter::repeat_n(0x11, 200));
                    let crc = frame_crc(&big[..10], &big[10..], 222);
                    big.extend_from_slice(&crc.to_le_bytes());
                    g.extend(big);
                }
                6 => {
                    let mut f = servo_frame(&mut other, 1500);
                    f[2] = 0x80; // an incompatibility flag no one knows
                    g.extend(f);
                }
                7 => g.extend(servo_frame(&mut other, 2100)),
                _ => {
                    let old = chunks[k.saturating_sub(30)].clone();
                    g.extend(old);
                    replayed.push(k);
                }
            }
        }
        // Padding of zeros after the garbage: two longest frames' worth, so that a fake header in
        // it cannot claim the sample's own frames (the parser's documented recovery distance).
        g.extend(std::iter::repeat_n(
            0u8,
            2 * aerosid_core::mavlink::frame::MAX_FRAME_LEN,
        ));
        g.extend(&chunks[k]);
        chunks[k] = g;
    }
    (corrupted, replayed)
}

#[test]
fn faults_and_garbage_under_qemu_are_survived_reported_and_equal_the_host_model() {
    // GIVEN a 20 s flight, its autopilot stream with seeded garbage, and the fault schedule
    let samples = flight();
    assert_eq!(samples.len(), SAMPLES);
    let mut chunks = qemu::autopilot_stream(&samples);
    let mut rng = ChaCha8Rng::seed_from_u64(0x7A17);
    let (corrupted, replayed) = add_garbage(&mut chunks, &mut rng);
    let faults = schedule();
    let scenario = Scenario {
        samples: &samples,
        faults: &faults,
        autopilot: Some(&chunks),
    };
    // WHEN the firmware (QEMU board) runs it, and the host models the same path
    let elf = qemu::build_firmware().expect("firmware build");
    let dir = qemu::workspace_root().join("target").join("qemu-faults");
    let run = qemu::run_scenario(&elf, &scenario, &dir, Duration::from_secs(600)).expect("QEMU run");
    let emu = qemu::emulate(&scenario).expect("host model");
    println!("{}", run.log);

    // THEN QEMU exits 0 after every sample that was not dropped went through the estimator …
    assert_eq!(run.exit_code, Some(0), "QEMU exit status");
    assert_eq!(run.counts.len(), emu.processed, "samples processed");
    assert_eq!(emu.processed, SAMPLES - 3);
    assert_eq!(run.frames.1, 0, "telemetry frames rejected by the ground side");
    // … its health report is the host model's, slot for slot …
    let h = run.health.expect("a health report").values;
    assert_eq!(h, emu.health.values, "health report (firmware vs host model)");
    // … and says what the schedule did, with the documented response to each fault …
    assert_sensor_faults_reported(&h);
    assert_link_faults_reported(&h, &chunks, corrupted, &replayed);
    // … without a stall and within the stack budget …
    assert_no_stall(&run);
    assert_stack_within_budget(&run.log);
    // … and every estimator survived, equal to the host model's bit for bit
    assert_reports_equal_the_host_model(&run, &emu);
}

/// The health report's response to each sensor, bus and timing fault of [`schedule`].
fn assert_sensor_faults_reported(h: &[u32]) {
    // every sample counted; drops counted by the sampler and seen as one gap by the estimator
    assert_eq!(h[slot::SAMPLED], SAMPLES as u32);
    assert_eq!(
        (h[slot::DROPPED], h[slot::GAPS], h[slot::MISSED], h[slot::STALE]),
        (3, 1, 3, 0)
    );
    // bus faults: skip and count; a re-initialisation per REINIT_AFTER failures in a row
    assert_eq!(
        (h[slot::IMU_FAULTS], h[slot::IMU_REINITS]),
        (60, 60 / u32::from(REINIT_AFTER))
    );
    assert_eq!((h[slot::AIRSPEED_FAULTS], h[slot::AIRSPEED_REINITS]), (10, 0));
    assert_eq!((h[slot::ALPHA_FAULTS], h[slot::ALPHA_REINITS]), (0, 0));
    assert_eq!(
        (h[slot::BETA_FAULTS], h[slot::BETA_REINITS]),
        (200, 200 / u32::from(REINIT_AFTER))
    );
    // the jammed vane: caught after its 50-sample window, for the remaining 71 samples
    assert!(
        h[slot::STUCK_EPISODES] >= 1 && h[slot::STUCK_SAMPLES] >= 120 - 49,
        "{h:?}"
    );
    // NaN, ±∞ and out-of-range values, failed and stuck channels: invalid to the pipeline
    let invalid = |m: u16| h[slot::INVALID + m.trailing_zeros() as usize];
    assert!(
        invalid(channel::GYRO) >= 60 + 5,
        "gyro invalid {}",
        invalid(channel::GYRO)
    );
    assert!(invalid(channel::ACCEL) >= 60 + 2);
    assert!(invalid(channel::AIRSPEED) >= 10 + 3);
    assert!(invalid(channel::ALPHA) >= 120 - 49);
    assert!(invalid(channel::BETA) >= 200);
    // the late sample (17 ms, then 3 ms) and the gap (40 ms): dt outside ±50 %
    assert!(invalid(channel::DT) >= 3, "dt invalid {}", invalid(channel::DT));
}

/// The link's figures: lost bytes counted, its values stale past their timeout, garbage
/// (`corrupted` bad-checksum frames, old chunks replayed at `replayed`) rejected.
fn assert_link_faults_reported(h: &[u32], chunks: &[Vec<u8>], corrupted: u32, replayed: &[usize]) {
    let lost: usize = chunks[1700..1715].iter().map(Vec::len).sum();
    assert_eq!(h[slot::LINK_LOST] as usize, lost);
    assert!(
        h[slot::AUTOPILOT_FAULTS] >= 5,
        "autopilot faults {}",
        h[slot::AUTOPILOT_FAULTS]
    );
    assert!(
        h[slot::LINK_REJECTED] >= corrupted,
        "{} rejected < {corrupted}",
        h[slot::LINK_REJECTED]
    );
    assert!(h[slot::LINK_DISCARDED] > 0);
    // replays of a chunk 30 samples old (its SERVO_OUTPUT_RAW and ATTITUDE stamped 300 ms before
    // the kept ones) are not kept while the kept ones are fresh, i.e. outside the lost bytes'
    // window and its timeouts (lost 1700..1715, the attitude's 200 ms timeout after that): two
    // frames each at least (a copy of the sample's own frames put in before them adds more)
    let fresh_replays = replayed.iter().filter(|&&k| !(1700..1740).contains(&k)).count() as u32;
    assert!(fresh_replays > 0, "the seeded garbage holds no replay");
    assert!(
        h[slot::LINK_NOT_NEWER] >= 2 * fresh_replays,
        "{} not newer < 2 × {fresh_replays} replays",
        h[slot::LINK_NOT_NEWER]
    );
    println!(
        "link: {} frames, {} rejected ({corrupted} corrupted put in), {} bytes discarded, {} lost, {} not newer ({} replays put in)",
        h[slot::LINK_FRAMES],
        h[slot::LINK_REJECTED],
        h[slot::LINK_DISCARDED],
        h[slot::LINK_LOST],
        h[slot::LINK_NOT_NEWER],
        replayed.len()
    );
}

/// No sample's step beyond the clean replay's worst-case budget (garbage on the link is parsed
/// in the sampling task, not in the step; a fault makes a step shorter).
fn assert_no_stall(run: &qemu::QemuRun) {
    for (p, name) in qemu::PROBE_NAMES.iter().enumerate() {
        if let Some((lo, med, hi)) = qemu::stats(&run.counts, p) {
            println!("instructions {name:>9}: min {lo:6} median {med:6} max {hi:6}");
        }
    }
    let (_, _, max) = qemu::stats(&run.counts, 0).expect("counts");
    assert!(
        max <= qemu::STEP_BUDGET_MAX,
        "max step {max} > {} instructions",
        qemu::STEP_BUDGET_MAX
    );
}

/// Within the clean replay's stack budget, the link's parser on it too (the figure is in the
/// defmt log whenever defmt-print is installed, as scripts/test.sh does).
fn assert_stack_within_budget(log: &str) {
    let stack = log.find("stack high water ").and_then(|at| {
        log[at + 17..]
            .split_whitespace()
            .next()
            .and_then(|b| b.parse::<u32>().ok())
    });
    match stack {
        Some(bytes) => {
            println!("stack high water: {bytes} B");
            let budget = qemu::STACK_BUDGET_BYTES;
            assert!(bytes > 0 && bytes <= budget, "stack {bytes} B > {budget} B");
        }
        None => assert!(
            !qemu::defmt_print_installed(),
            "no stack figure in the defmt log although defmt-print is installed"
        ),
    }
}

/// The firmware's final reports equal the host model's bit for bit, are finite, and flag the
/// channel refusals.
fn assert_reports_equal_the_host_model(run: &qemu::QemuRun, emu: &qemu::Emulation) {
    for (i, (fw, want)) in run.reports.iter().zip(emu.reports.iter()).enumerate() {
        let fw = fw.expect("a report for every coefficient");
        let n = usize::from(want.n_params);
        println!(
            "coefficient {i}: k {} refused {} θ {:?}",
            fw.rank_k,
            fw.refused,
            &fw.theta[..n]
        );
        assert!(
            fw.same_estimate_bits(want),
            "coefficient {i}: {fw:?}\n  vs host {want:?}"
        );
        assert_eq!(
            (fw.health_flags, fw.refused),
            (want.health_flags, want.refused),
            "coefficient {i}"
        );
        assert!(
            fw.theta[..n].iter().all(|v| v.is_finite()),
            "coefficient {i}: θ {:?}",
            fw.theta
        );
        assert!(fw.health_flags & health_bit::CHANNEL_REFUSALS != 0, "coefficient {i}");
        assert!(fw.health_flags & health_bit::NO_UPDATES == 0, "coefficient {i}");
    }
}
