//! The autopilot link as an input: malformed, truncated, oversized, replayed frames
//! and garbage on USART2, through the parser (`mavlink::parser`) and the surfaces source
//! (`mavlink::surfaces`) the firmware's sampling task drains the UART into.
//!
//! The link is receive-only for data and accepts no command (`mavlink` module doc): nothing on it
//! can reset an estimator or change a setting. What it can do is carry actuator values; these
//! tests pin down that garbage cannot crash, wedge or fool the receiver: every malformed frame is
//! dropped and counted, the frames after it are recovered, and the surfaces stay within their
//! calibration.

use aerosid_core::aero::onboard;
use aerosid_core::mavlink::frame::{frame_crc, MAX_FRAME_LEN};
use aerosid_core::mavlink::messages::{Heartbeat, ServoOutputRaw};
use aerosid_core::mavlink::surfaces::RpmSource;
use aerosid_core::mavlink::{Encoder, MavlinkSurfaces, Message, Parser, SurfaceConfig, SurfaceError, SurfaceSource};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn servo_frame(enc: &mut Encoder, elevator_us: u16) -> Vec<u8> {
    let mut m = ServoOutputRaw::default();
    m.servo_raw_us[..4].copy_from_slice(&[1500, elevator_us, 1500, 1500]);
    let mut buf = [0u8; 64];
    let n = enc.encode(&m, &mut buf).expect("encode");
    buf[..n].to_vec()
}

fn heartbeat(enc: &mut Encoder) -> Vec<u8> {
    let mut buf = [0u8; 64];
    let n = enc.encode(&Heartbeat::onboard_controller(4), &mut buf).expect("encode");
    buf[..n].to_vec()
}

fn parse(bytes: &[u8]) -> (Vec<Message>, Parser) {
    let mut p = Parser::new();
    let mut out = Vec::new();
    p.feed(bytes, |f| out.push(f.message));
    (out, p)
}

/// The firmware's autopilot link ([`onboard::AUTOPILOT_LINK`]) without an RPM source.
fn config() -> SurfaceConfig {
    SurfaceConfig {
        rpm: RpmSource::None,
        ..onboard::AUTOPILOT_LINK
    }
}

#[test]
fn a_corrupted_checksum_drops_only_that_frame() {
    let mut enc = Encoder::new(1, 1);
    let mut bad = servo_frame(&mut enc, 1600);
    let n = bad.len();
    bad[n - 1] ^= 0x5A;
    let good = servo_frame(&mut enc, 1700);
    let (msgs, p) = parse(&[bad, good].concat());
    assert_eq!(msgs.len(), 1);
    assert!(matches!(msgs[0], Message::ServoOutputRaw(m) if m.servo_raw_us[1] == 1700));
    assert_eq!((p.stats().bad_crc, p.stats().frames), (1, 1));
}

#[test]
fn a_truncated_frame_does_not_swallow_the_next_one() {
    // Every cut of a frame, followed by a whole frame: the whole frame is always delivered.
    let mut enc = Encoder::new(1, 1);
    let first = servo_frame(&mut enc, 1600);
    let second = servo_frame(&mut enc, 1700);
    for cut in 1..first.len() {
        let (msgs, _) = parse(&[&first[..cut], &second[..]].concat());
        assert!(
            msgs.iter()
                .any(|m| matches!(m, Message::ServoOutputRaw(s) if s.servo_raw_us[1] == 1700)),
            "cut at {cut}: the next frame was lost"
        );
        assert!(
            !msgs
                .iter()
                .any(|m| matches!(m, Message::ServoOutputRaw(s) if s.servo_raw_us[1] == 1600)),
            "cut at {cut}: a truncated frame was delivered"
        );
    }
}

#[test]
fn oversized_and_wrong_length_frames_are_refused_at_the_header() {
    let mut enc = Encoder::new(1, 1);
    let good = heartbeat(&mut enc);
    // A MAVLink 2 SERVO_OUTPUT_RAW (max 37 bytes) claiming 200 bytes, with a checksum that would
    // match: refused at the header, never buffered to its claimed end.
    let mut big = vec![0xFD, 200, 0, 0, 9, 1, 1, 36, 0, 0];
    big.extend(std::iter::repeat_n(0x11, 200));
    let crc = frame_crc(&big[..10], &big[10..], 222);
    big.extend_from_slice(&crc.to_le_bytes());
    // A MAVLink 1 HEARTBEAT with 5 instead of its 9 bytes.
    let mut short_v1 = vec![0xFE, 5, 3, 1, 1, 0, 1, 2, 3, 4, 5];
    let crc = frame_crc(&short_v1[..6], &short_v1[6..], 50);
    short_v1.extend_from_slice(&crc.to_le_bytes());
    // An unknown id with the longest payload (255): skipped whole by its length.
    let mut unknown = vec![0xFD, 255, 0, 0, 1, 1, 1, 0x34, 0x12, 0];
    unknown.extend(std::iter::repeat_n(0x22, 255 + 2));
    let (msgs, p) = parse(&[big, good.clone(), short_v1, good.clone(), unknown, good].concat());
    assert_eq!(msgs.len(), 3, "the three heartbeats");
    assert!(msgs.iter().all(|m| matches!(m, Message::Heartbeat(_))));
    assert_eq!(p.stats().bad_length, 2);
    assert_eq!(p.stats().unknown_skipped, 1);
}

#[test]
fn a_replayed_frame_is_accepted_as_new_data_and_nothing_else() {
    // The link has no replay protection (no key, no command accepted): a replayed SERVO_OUTPUT_RAW
    // is the same actuator values again, delivered and kept as the newest, which is what a wire
    // from the autopilot can carry anyway. It cannot make a stale reading fresh beyond its own
    // timeout, and it changes nothing but those values.
    let mut enc = Encoder::new(1, 1);
    let frame = servo_frame(&mut enc, 1600);
    let mut s = MavlinkSurfaces::new(config()).expect("config");
    s.receive(&frame, 1_000_000);
    assert!(s.surfaces(1_050_000).is_ok());
    assert!(matches!(s.surfaces(1_200_000), Err(SurfaceError::Stale { .. })));
    s.receive(&frame, 1_300_000); // the replay
    let r = s.surfaces(1_300_000).expect("the replayed values");
    assert!((r.elevator_rad.expect("elevator") - 100.0 * 0.000_873).abs() < 1e-6);
    assert!(matches!(s.surfaces(1_401_000), Err(SurfaceError::Stale { .. })));
    assert_eq!(s.parser_stats().frames, 2);
}

#[test]
fn frames_from_another_system_or_port_are_ignored() {
    let mut other = Encoder::new(7, 1);
    let mut s = MavlinkSurfaces::new(config()).expect("config");
    s.receive(&servo_frame(&mut other, 1600), 1_000_000);
    assert_eq!(s.surfaces(1_000_000).err(), Some(SurfaceError::NoData));
}

/// Seeded garbage of every kind: random bytes, runs of start bytes, fake headers.
fn garbage(rng: &mut ChaCha8Rng, len: usize) -> Vec<u8> {
    let mut g = Vec::with_capacity(len);
    while g.len() < len {
        match rng.random_range(0..4) {
            0 => g.push(rng.random()),
            1 => g.extend(std::iter::repeat_n(0xFD, rng.random_range(1..20))),
            2 => g.extend([
                0xFD,
                rng.random(),
                rng.random_range(0..2),
                0,
                rng.random(),
                1,
                1,
                rng.random(),
                0,
                0,
            ]),
            _ => g.extend([0xFE, rng.random(), rng.random(), 1, 1, rng.random()]),
        }
    }
    g.truncate(len);
    g
}

#[test]
fn garbage_never_panics_and_the_stream_after_it_is_recovered() {
    // GIVEN 300 seeded bursts of garbage (up to 4 kB each) on the link, each followed by 30 valid
    // frames back to back (as the autopilot sends them)
    let mut rng = ChaCha8Rng::seed_from_u64(0xA7);
    let mut enc = Encoder::new(1, 1);
    let mut s = MavlinkSurfaces::new(config()).expect("config");
    let mut t_us = 1_000_000u64;
    let mut worst_lost_bytes = 0usize;
    for burst in 0..300 {
        let len = rng.random_range(1..4096);
        let g = garbage(&mut rng, len);
        let frames: Vec<Vec<u8>> = (0..30)
            .map(|i| servo_frame(&mut enc, 1000 + (burst * 30 + i) as u16 % 1000))
            .collect();
        let stream: Vec<u8> = [g.clone(), frames.concat()].concat();
        let mut p = Parser::new();
        let mut got = Vec::new();
        p.feed(&stream, |f| {
            if let Message::ServoOutputRaw(m) = f.message {
                got.push(m.servo_raw_us[1]);
            }
        });
        // THEN every frame that starts more than two frame lengths (2·280 bytes) after the garbage
        // is delivered: a fake header in the garbage can claim at most one frame's length, and the
        // re-scan after an unconfirmed one finds the real frames again.
        let mut offset = g.len();
        for (i, f) in frames.iter().enumerate() {
            let want = 1000 + (burst * 30 + i) as u16 % 1000;
            if offset >= g.len() + 2 * MAX_FRAME_LEN {
                assert!(
                    got.contains(&want),
                    "burst {burst}: frame {i} at byte {offset} lost after {} bytes of garbage",
                    g.len()
                );
            } else if !got.contains(&want) {
                worst_lost_bytes = worst_lost_bytes.max(offset + f.len() - g.len());
            }
            offset += f.len();
        }
        // AND the surfaces fed the same stream stay in their calibration
        s.receive(&stream, t_us);
        if let Ok(r) = s.surfaces(t_us) {
            for v in [r.elevator_rad, r.aileron_rad, r.rudder_rad].into_iter().flatten() {
                assert!(v.is_finite() && (-0.44..=0.44).contains(&v), "deflection {v}");
            }
        }
        t_us += 10_000;
    }
    println!("most valid bytes lost after a garbage burst: {worst_lost_bytes}");
}

#[test]
fn a_megabyte_of_start_bytes_and_fake_headers_is_parsed_to_the_end() {
    // The worst case for the re-scan: every byte a start byte or a header claiming a long unknown
    // frame. The parser's work per byte is bounded (parser.rs, "Bounds"); this run must end, count
    // every byte, and still deliver the frame at the end.
    let mut rng = ChaCha8Rng::seed_from_u64(0xA8);
    let mut stream = Vec::new();
    while stream.len() < 1 << 20 {
        if rng.random_bool(0.5) {
            stream.push(0xFD);
        } else {
            stream.extend([0xFD, 255, 0, 0, 0, 1, 1, 0x77, 0x77, 0]);
        }
    }
    let mut enc = Encoder::new(1, 1);
    stream.extend(std::iter::repeat_n(0u8, MAX_FRAME_LEN));
    stream.extend(servo_frame(&mut enc, 1234));
    let (msgs, p) = parse(&stream);
    assert!(msgs
        .iter()
        .any(|m| matches!(m, Message::ServoOutputRaw(s) if s.servo_raw_us[1] == 1234)));
    // The only frame is the real one; the rest was rejected (bad flags, unconfirmed or skipped
    // unknown frames, discarded bytes), every rejection counted.
    assert_eq!(p.stats().frames, 1, "{:?}", p.stats());
    let st = p.stats();
    assert!(
        st.bad_incompat_flags + st.unknown_unconfirmed + st.unknown_skipped + st.discarded_bytes > 100_000,
        "{st:?}"
    );
}
