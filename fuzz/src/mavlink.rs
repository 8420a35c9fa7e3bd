//! Fuzz target `mavlink`: the autopilot link's input side — the streaming frame parser
//! (`core/src/mavlink/parser.rs`) and the surfaces/RPM/attitude source built on it
//! (`core/src/mavlink/surfaces.rs`) — fed arbitrary bytes at arbitrary times.
//!
//! ## Input
//! Byte 0: bit 0 accepts any system id (else only 1, as the firmware), bit 1 the RPM source (ArduPilot
//! `RPM` or PX4 `ESC_STATUS`). Then chunks: a length byte, a 16-bit time step (×10 µs; the top bit
//! makes it a step *back*), and that many bytes received at that time.
//!
//! ## Invariants
//! * **Nothing invented**: every frame the parser delivers is a frame present in the input — at some
//!   offset, a start byte, a header whose length fits the message id, a checksum over header and
//!   payload with the id's `CRC_EXTRA` equal to the received one — and decodes to the same message
//!   (found by an independent scan of the whole input, written here from the MAVLink 2 frame layout).
//! * `ParserStats::frames` equals the number of frames delivered, `signed` those with the flag.
//! * `MavlinkSurfaces::receive` and the same frames given one by one to `accept` give identical
//!   results.
//! * Whatever arrived: a deflection `Ok` is finite and within its calibration's limits, the
//!   throttle in `[0, 1]`, the age at most the timeout, the propeller speed finite and `≥ 0`, the
//!   attitude finite.

use crate::input::Input;
use aerosid_core::aero::onboard;
use aerosid_core::mavlink::crc::{accumulate, accumulate_slice, CRC_INIT};
use aerosid_core::mavlink::messages::{spec, Message, Payload};
use aerosid_core::mavlink::surfaces::{RpmSource, ServoCalibration};
use aerosid_core::mavlink::{Frame, MavlinkSurfaces, Parser, SurfaceConfig, SurfaceSource};

/// The firmware's autopilot link settings ([`onboard::AUTOPILOT_LINK`]), with the system id and the
/// RPM source chosen by the input, and a second aileron (so the averaging path is covered too).
pub fn config(any_system: bool, esc: bool) -> SurfaceConfig {
    let mut c = onboard::AUTOPILOT_LINK;
    c.source_system_id = if any_system { 0 } else { c.source_system_id };
    c.aileron_2 = Some(ServoCalibration {
        channel: 4,
        rad_per_us: -c.aileron.rad_per_us,
        ..c.aileron
    });
    if esc {
        c.rpm = RpmSource::EscStatus { esc: 1 };
    }
    c
}

/// Every CRC-valid frame of a known id in `bytes`, at any offset, as `Debug` text of
/// `(header fields, message)` (module doc).
pub fn valid_frames(bytes: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    for p in 0..bytes.len() {
        let b = &bytes[p..];
        let (v2, hl) = match b[0] {
            0xFD => (true, 10),
            0xFE => (false, 6),
            _ => continue,
        };
        if b.len() < hl {
            continue;
        }
        let len = usize::from(b[1]);
        let (incompat, compat, seq, sys, comp, id) = if v2 {
            (b[2], b[3], b[4], b[5], b[6], u32::from_le_bytes([b[7], b[8], b[9], 0]))
        } else {
            (0, 0, b[2], b[3], b[4], u32::from(b[5]))
        };
        let Some(s) = spec(id) else { continue };
        if incompat & !1 != 0 || (v2 && len > usize::from(s.max_len)) || (!v2 && len != usize::from(s.base_len)) {
            continue;
        }
        let end = hl + len;
        if b.len() < end + 2 {
            continue;
        }
        let crc = accumulate(accumulate_slice(CRC_INIT, &b[1..end]), s.crc_extra);
        if crc != u16::from_le_bytes([b[end], b[end + 1]]) {
            continue;
        }
        let mut payload: Payload = [0; 255];
        payload[..len].copy_from_slice(&b[hl..end]);
        let Some(m) = Message::decode(id, &payload) else {
            continue;
        };
        out.push(format!("{v2} {len} {incompat} {compat} {seq} {sys} {comp} {id} {m:?}"));
    }
    out
}

fn key(f: &Frame) -> String {
    let h = &f.header;
    let v2 = h.version == aerosid_core::mavlink::parser::Version::V2;
    format!(
        "{v2} {} {} {} {} {} {} {} {:?}",
        h.payload_len,
        h.incompat_flags,
        h.compat_flags,
        h.sequence,
        h.system_id,
        h.component_id,
        h.message_id,
        f.message
    )
}

fn check_source(s: &mut MavlinkSurfaces, now_us: u64) -> String {
    let c = *s.config();
    let r = s.surfaces(now_us);
    if let Ok(r) = &r {
        assert!(r.age_us <= c.servo_timeout_us, "age {} beyond the timeout", r.age_us);
        for (v, cal) in [
            (r.elevator_rad, c.elevator),
            (r.aileron_rad, c.aileron),
            (r.rudder_rad, c.rudder),
        ] {
            if let Ok(v) = v {
                assert!(
                    v.is_finite() && v >= cal.limits_rad.0.min(-0.44) && v <= cal.limits_rad.1.max(0.44),
                    "deflection {v}"
                );
            }
        }
        if let Ok(t) = r.throttle {
            assert!((0.0..=1.0).contains(&t), "throttle {t}");
        }
    }
    let rpm = s.prop_speed_rad_s(now_us);
    if let Ok(w) = rpm {
        assert!(w.is_finite() && w >= 0.0, "propeller speed {w} rad/s");
    }
    let e = s.euler_rad(now_us);
    if let Ok(e) = e {
        assert!(e.iter().all(|a| a.is_finite()), "attitude {e:?}");
    }
    format!("{r:?} {rpm:?} {e:?}")
}

/// The fuzz entry point.
pub fn run(data: &[u8]) {
    let mut inp = Input::new(data);
    let setup = inp.u8();
    let cfg = config(setup & 1 != 0, setup & 2 != 0);
    let (Ok(mut a), Ok(mut b)) = (MavlinkSurfaces::new(cfg), MavlinkSurfaces::new(cfg)) else {
        panic!("the firmware's surface configuration is refused");
    };
    let mut parser = Parser::new();
    let mut stream = Vec::new();
    let mut delivered = Vec::new();
    let mut signed = 0u32;
    let mut now_us: u64 = 1_000_000;
    while !inp.is_empty() {
        let n = usize::from(inp.u8());
        let dt = inp.u16();
        let step = u64::from(dt & 0x7FFF) * 10;
        now_us = if dt & 0x8000 != 0 {
            now_us.saturating_sub(step)
        } else {
            now_us + step
        };
        let mut chunk = vec![0u8; n.min(inp.remaining())];
        inp.fill(&mut chunk);
        stream.extend_from_slice(&chunk);
        a.receive(&chunk, now_us);
        parser.feed(&chunk, |f| {
            if f.header.is_signed() {
                signed += 1;
            }
            b.accept(f, now_us);
            delivered.push(key(f));
        });
        let (ra, rb) = (check_source(&mut a, now_us), check_source(&mut b, now_us));
        assert_eq!(ra, rb, "receive() and parse + accept() disagree");
        let later = now_us + u64::from(inp.u8()) * 4000;
        assert_eq!(check_source(&mut a, later), check_source(&mut b, later));
    }
    let st = parser.stats();
    assert_eq!(st.frames as usize, delivered.len(), "ParserStats::frames");
    assert_eq!(st.signed, signed, "ParserStats::signed");
    assert_eq!(a.parser_stats(), st, "the two parsers saw the same bytes");
    if !delivered.is_empty() {
        let valid = valid_frames(&stream);
        for d in &delivered {
            assert!(valid.contains(d), "delivered a frame not in the input: {d}");
        }
    }
}
