//! MAVLink: checksum, golden frames, encode→parse round trip, parser robustness, soak, and the
//! actuator source.
//!
//! Golden frames: generated with pymavlink 2.4.50 (`pip install pymavlink`, `dialects.v20.ardupilotmega`
//! / `dialects.v10.ardupilotmega`, `MAVLink(…).<msg>_encode(…).pack(mav)`) in a one-off script, and
//! pasted here. `ESC_STATUS` is not in that release (it is `<wip/>` in `common.xml`), so its frame
//! came from pymavlink's own generator (`mavgen --lang=Python3 --wire-protocol=2.0`) run on the
//! message's published definition (`index` u8, `time_usec` u64, `rpm` int32\[4\], `voltage`
//! float\[4\], `current` float\[4\]), which also gives `CRC_EXTRA` 10.

use aerosid_core::mavlink::crc::crc16_mcrf4xx;
use aerosid_core::mavlink::frame::{frame_crc, truncated_len, MAV_COMP_ID_ONBOARD_COMPUTER, MAX_FRAME_LEN};
use aerosid_core::mavlink::messages::{
    Attitude, DebugFloatArray, EscStatus, Heartbeat, MavMessage, Message, NamedValueFloat, Rpm, ServoOutputRaw,
};
use aerosid_core::mavlink::parser::Version;
use aerosid_core::mavlink::surfaces::{RpmSource, ServoCalibration, ThrottleCalibration};
use aerosid_core::mavlink::telemetry::slot;
use aerosid_core::mavlink::{
    CoefficientReport, EncodeError, Encoder, Frame, MavlinkSurfaces, Parser, SurfaceConfig, SurfaceError,
    SurfaceSource, Telemetry,
};

// ---- golden frames (pymavlink 2.4.50) ----

/// `heartbeat_encode(18, 8, 0, 0, 4, 3)`, system 1, component 191, seq 0.
const HEARTBEAT: [u8; 21] = [
    0xFD, 0x09, 0x00, 0x00, 0x00, 0x01, 0xBF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x12, 0x08, 0x00, 0x04, 0x03,
    0xAE, 0xC6,
];

/// `debug_float_array_encode(123456789, b'CL', 0, data)`, system 1, component 191, seq 1, with
/// `data` = θ [0.25, 4.5, 0.5, −0.75], σ [0.01, 0.125, 0.0625, 0.03125], k 4, λ 0.995, health 5,
/// refused 17, n_θ 4 in the documented slots.
const DEBUG_FLOAT_ARRAY: [u8; 100] = [
    0xFD, 0x58, 0x00, 0x00, 0x01, 0x01, 0xBF, 0x5E, 0x01, 0x00, 0x15, 0xCD, 0x5B, 0x07, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x43, 0x4C, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E, 0x00, 0x00, 0x90, 0x40,
    0x00, 0x00, 0x00, 0x3F, 0x00, 0x00, 0x40, 0xBF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0A, 0xD7, 0x23,
    0x3C, 0x00, 0x00, 0x00, 0x3E, 0x00, 0x00, 0x80, 0x3D, 0x00, 0x00, 0x00, 0x3D, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x80, 0x40, 0x52, 0xB8, 0x7E, 0x3F, 0x00, 0x00, 0xA0, 0x40, 0x00, 0x00, 0x88, 0x41, 0x00,
    0x00, 0x80, 0x40, 0x5C, 0xAC,
];

/// `named_value_float_encode(1000, b'CL_th0', 0.25)`, system 1, component 191, seq 2 (payload
/// truncated to 14 bytes: the name's trailing NULs).
const NAMED_VALUE_FLOAT: [u8; 26] = [
    0xFD, 0x0E, 0x00, 0x00, 0x02, 0x01, 0xBF, 0xFB, 0x00, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3E, 0x43,
    0x4C, 0x5F, 0x74, 0x68, 0x30, 0xA2, 0x4A,
];

/// `servo_output_raw_encode(5000000, 0, 1500, 1600, 1400, 1550, 1100, 0, 0, 0, 1700, 0…)`,
/// system 1, component 1, seq 7 (payload truncated to 23 bytes after `servo9_raw`).
const SERVO_OUTPUT_RAW: [u8; 35] = [
    0xFD, 0x17, 0x00, 0x00, 0x07, 0x01, 0x01, 0x24, 0x00, 0x00, 0x40, 0x4B, 0x4C, 0x00, 0xDC, 0x05, 0x40, 0x06, 0x78,
    0x05, 0x0E, 0x06, 0x4C, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xA4, 0x06, 0xA1, 0x74,
];

/// `rpm_encode(6000.0, -1.0)`, system 1, component 1, seq 8.
const RPM: [u8; 20] = [
    0xFD, 0x08, 0x00, 0x00, 0x08, 0x01, 0x01, 0xE2, 0x00, 0x00, 0x00, 0x80, 0xBB, 0x45, 0x00, 0x00, 0x80, 0xBF, 0xA3,
    0xA0,
];

/// `esc_status_encode(0, 123456, [6000, 0, 0, 0], [12.5, 0, 0, 0], [3.25, 0, 0, 0])`, system 1,
/// component 1, seq 9 (mavgen-generated module, see the file doc).
const ESC_STATUS: [u8; 56] = [
    0xFD, 0x2C, 0x00, 0x00, 0x09, 0x01, 0x01, 0x23, 0x01, 0x00, 0x40, 0xE2, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x70,
    0x17, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x48, 0x41,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x50, 0x40, 0xFE, 0x05,
];

/// `attitude_encode(123456, 0.1, -0.25, 3.0, 0.5, 0, 0)`, system 1, component 1, seq 12 (payload
/// truncated to 20 bytes: the zero `pitchspeed`, `yawspeed`).
const ATTITUDE_TRUNCATED: [u8; 32] = [
    0xFD, 0x14, 0x00, 0x00, 0x0C, 0x01, 0x01, 0x1E, 0x00, 0x00, 0x40, 0xE2, 0x01, 0x00, 0xCD, 0xCC, 0xCC, 0x3D, 0x00,
    0x00, 0x80, 0xBE, 0x00, 0x00, 0x40, 0x40, 0x00, 0x00, 0x00, 0x3F, 0x87, 0x67,
];

/// The `SERVO_OUTPUT_RAW` above signed by pymavlink (seq 10, secret key bytes 0…31, link id 3,
/// timestamp 0x0102030405): incompat flag 0x01 and a 13-byte signature after the checksum.
const SERVO_OUTPUT_RAW_SIGNED: [u8; 48] = [
    0xFD, 0x17, 0x01, 0x00, 0x0A, 0x01, 0x01, 0x24, 0x00, 0x00, 0x40, 0x4B, 0x4C, 0x00, 0xDC, 0x05, 0x40, 0x06, 0x78,
    0x05, 0x0E, 0x06, 0x4C, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xA4, 0x06, 0x75, 0xAF, 0x03, 0x05, 0x04,
    0x03, 0x02, 0x01, 0x00, 0x73, 0x43, 0xB7, 0x44, 0x0B, 0xCC,
];

/// The same servo outputs as a MAVLink 1 frame (seq 11; base fields only, 21 bytes).
const SERVO_OUTPUT_RAW_V1: [u8; 29] = [
    0xFE, 0x15, 0x0B, 0x01, 0x01, 0x24, 0x40, 0x4B, 0x4C, 0x00, 0xDC, 0x05, 0x40, 0x06, 0x78, 0x05, 0x0E, 0x06, 0x4C,
    0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x45, 0xEB,
];

/// `global_position_int_encode(1000, 473977420, 85455940, 500000, 20000, 100, -50, 10, 18000)` (#33,
/// unknown to the parser), system 1, component 1, seq 12.
const GLOBAL_POSITION_INT: [u8; 40] = [
    0xFD, 0x1C, 0x00, 0x00, 0x0C, 0x01, 0x01, 0x21, 0x00, 0x00, 0xE8, 0x03, 0x00, 0x00, 0x4C, 0x52, 0x40, 0x1C, 0x44,
    0xF4, 0x17, 0x05, 0x20, 0xA1, 0x07, 0x00, 0x20, 0x4E, 0x00, 0x00, 0x64, 0x00, 0xCE, 0xFF, 0x0A, 0x00, 0x50, 0x46,
    0x85, 0x8C,
];

/// `attitude_encode(1000, 0.1, -0.2, 0.3, 0.01, 0.02, 0.03)` (#30), system 1, component 1, seq 12.
const ATTITUDE: [u8; 40] = [
    0xFD, 0x1C, 0x00, 0x00, 0x0C, 0x01, 0x01, 0x1E, 0x00, 0x00, 0xE8, 0x03, 0x00, 0x00, 0xCD, 0xCC, 0xCC, 0x3D, 0xCD,
    0xCC, 0x4C, 0xBE, 0x9A, 0x99, 0x99, 0x3E, 0x0A, 0xD7, 0x23, 0x3C, 0x0A, 0xD7, 0xA3, 0x3C, 0x8F, 0xC2, 0xF5, 0x3C,
    0xF6, 0xA1,
];

fn servo_outputs() -> ServoOutputRaw {
    let mut servo_raw_us = [0u16; 16];
    servo_raw_us[..5].copy_from_slice(&[1500, 1600, 1400, 1550, 1100]);
    servo_raw_us[8] = 1700;
    ServoOutputRaw {
        time_us: 5_000_000,
        port: 0,
        servo_raw_us,
    }
}

fn report() -> CoefficientReport {
    CoefficientReport {
        coefficient: 0,
        theta: [0.25, 4.5, 0.5, -0.75, 0.0, 0.0],
        sigma: [0.01, 0.125, 0.0625, 0.03125, 0.0, 0.0],
        n_params: 4,
        rank_k: 4,
        lambda_f: 0.995,
        health_flags: 5,
        refused: 17,
    }
}

fn parse_all(parser: &mut Parser, bytes: &[u8]) -> Vec<Frame> {
    let mut out = Vec::new();
    parser.feed(bytes, |f| out.push(*f));
    out
}

fn parse(bytes: &[u8]) -> (Vec<Frame>, Parser) {
    let mut p = Parser::new();
    let frames = parse_all(&mut p, bytes);
    (frames, p)
}

fn servo_of(f: &Frame) -> ServoOutputRaw {
    match f.message {
        Message::ServoOutputRaw(m) => m,
        other => panic!("expected SERVO_OUTPUT_RAW, got {other:?}"),
    }
}

// ---- checksum ----

#[test]
fn crc16_mcrf4xx_check_value() {
    assert_eq!(crc16_mcrf4xx(b"123456789"), 0x6F91);
    assert_eq!(crc16_mcrf4xx(b""), 0xFFFF);
}

#[test]
fn crc_extra_values_match_the_spec() {
    assert_eq!(Heartbeat::SPEC.crc_extra, 50);
    assert_eq!(ServoOutputRaw::SPEC.crc_extra, 222);
    assert_eq!(Rpm::SPEC.crc_extra, 207);
    assert_eq!(NamedValueFloat::SPEC.crc_extra, 170);
    assert_eq!(EscStatus::SPEC.crc_extra, 10);
    assert_eq!(DebugFloatArray::SPEC.crc_extra, 232);
    assert_eq!(Attitude::SPEC.crc_extra, 39);
}

#[test]
fn golden_attitude_parse_and_encode() {
    let (frames, p) = parse(&ATTITUDE_TRUNCATED);
    assert_eq!(frames.len(), 1, "{:?}", p.stats());
    let expected = Attitude {
        time_boot_ms: 123_456,
        euler_rad: [0.1, -0.25, 3.0],
        rate_rad_s: [0.5, 0.0, 0.0],
    };
    assert_eq!(frames[0].message, Message::Attitude(expected));
    let mut buf = [0u8; MAX_FRAME_LEN];
    let mut e = Encoder::new(1, 1);
    for _ in 0..12 {
        e.encode(&Attitude::default(), &mut buf).unwrap();
    }
    let n = e.encode(&expected, &mut buf).unwrap(); // seq 12
    assert_eq!(&buf[..n], &ATTITUDE_TRUNCATED[..]);
    // The full 28-byte payload.
    let (frames, _) = parse(&ATTITUDE);
    let full = Attitude {
        time_boot_ms: 1000,
        euler_rad: [0.1, -0.2, 0.3],
        rate_rad_s: [0.01, 0.02, 0.03],
    };
    assert_eq!(frames.first().map(|f| f.message), Some(Message::Attitude(full)));
}

// ---- golden frames: encoder ----

#[test]
fn golden_heartbeat() {
    let mut t = Telemetry::new(1, MAV_COMP_ID_ONBOARD_COMPUTER);
    let mut buf = [0u8; 64];
    let n = t.heartbeat(Heartbeat::MAV_STATE_ACTIVE, &mut buf).unwrap();
    assert_eq!(&buf[..n], &HEARTBEAT);
    assert_eq!(t.encoder.sequence(), 1);
}

#[test]
fn golden_coefficient_report_and_named_value() {
    let mut t = Telemetry::new(1, MAV_COMP_ID_ONBOARD_COMPUTER);
    let mut buf = [0u8; 128];
    t.heartbeat(Heartbeat::MAV_STATE_ACTIVE, &mut buf).unwrap();
    let n = t.coefficient(&report(), 123_456_789, &mut buf).unwrap();
    assert_eq!(n, 100);
    assert_eq!(&buf[..n], &DEBUG_FLOAT_ARRAY);
    let n = t.named_value("CL_th0", 0.25, 1000, &mut buf).unwrap();
    assert_eq!(&buf[..n], &NAMED_VALUE_FLOAT);
}

#[test]
fn golden_inbound_messages_encode() {
    let mut buf = [0u8; 64];
    let mut e = Encoder::new(1, 1);
    for _ in 0..7 {
        e.encode(&Rpm::default(), &mut buf).unwrap();
    }
    let n = e.encode(&servo_outputs(), &mut buf).unwrap();
    assert_eq!(&buf[..n], &SERVO_OUTPUT_RAW);
    let n = e.encode(&Rpm { rpm: [6000.0, -1.0] }, &mut buf).unwrap();
    assert_eq!(&buf[..n], &RPM);
    let esc = EscStatus {
        time_us: 123_456,
        index: 0,
        rpm: [6000, 0, 0, 0],
        voltage_v: [12.5, 0.0, 0.0, 0.0],
        current_a: [3.25, 0.0, 0.0, 0.0],
    };
    let n = e.encode(&esc, &mut buf).unwrap();
    assert_eq!(&buf[..n], &ESC_STATUS);
    let n = e.encode(&Rpm::default(), &mut buf).unwrap(); // seq 10
    assert_eq!(n, 13, "all-zero payload keeps one byte");
    let n = e.encode_v1(&servo_outputs(), &mut buf).unwrap();
    assert_eq!(&buf[..n], &SERVO_OUTPUT_RAW_V1);
    assert_eq!(e.encode_v1(&esc, &mut buf), Err(EncodeError::IdNotV1));
}

#[test]
fn encoder_errors_and_sequence_wrap() {
    let mut e = Encoder::new(1, 1);
    let mut small = [0u8; 20];
    assert_eq!(
        e.encode(&Heartbeat::onboard_controller(4), &mut small),
        Err(EncodeError::BufferTooSmall)
    );
    assert_eq!(e.sequence(), 0, "a failed encode does not consume a sequence number");
    let mut buf = [0u8; 32];
    for i in 0..300u32 {
        assert_eq!(u32::from(e.sequence()), i % 256);
        e.encode(&Heartbeat::onboard_controller(4), &mut buf).unwrap();
    }
    let mut t = Telemetry::new(1, 191);
    let bad = CoefficientReport {
        coefficient: 6,
        ..report()
    };
    assert_eq!(
        t.coefficient(&bad, 0, &mut [0u8; 128]),
        Err(EncodeError::UnknownCoefficient)
    );
    assert_eq!(
        t.named_value("longer_than_10", 1.0, 0, &mut buf),
        Err(EncodeError::NameTooLong)
    );
    assert_eq!(
        t.coefficients(&[report(); 6], 0, &mut [0u8; 599]),
        Err(EncodeError::BufferTooSmall)
    );
    assert_eq!(truncated_len(&[0, 0, 0]), 1);
    assert_eq!(truncated_len(&[1, 0, 2, 0, 0]), 3);
}

// ---- golden frames: parser ----

#[test]
fn golden_frames_parse() {
    let mut stream = Vec::new();
    for f in [
        &HEARTBEAT[..],
        &DEBUG_FLOAT_ARRAY,
        &NAMED_VALUE_FLOAT,
        &SERVO_OUTPUT_RAW,
        &RPM,
        &ESC_STATUS,
        &SERVO_OUTPUT_RAW_V1,
    ] {
        stream.extend_from_slice(f);
    }
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 7, "{:?}", p.stats());
    assert_eq!(frames[0].message, Message::Heartbeat(Heartbeat::onboard_controller(4)));
    assert_eq!(frames[0].header.component_id, 191);
    match frames[1].message {
        Message::DebugFloatArray(m) => {
            assert_eq!(&m.name[..3], b"CL\0");
            assert_eq!(m.time_us, 123_456_789);
            assert_eq!(m.data[slot::LAMBDA_F], 0.995);
            assert_eq!(m.data[slot::N_PARAMS], 4.0);
            assert_eq!(m.data[slot::COUNT], 0.0);
        }
        ref other => panic!("{other:?}"),
    }
    match frames[2].message {
        Message::NamedValueFloat(m) => assert_eq!((&m.name, m.value), (b"CL_th0\0\0\0\0", 0.25)),
        ref other => panic!("{other:?}"),
    }
    assert_eq!(servo_of(&frames[3]), servo_outputs());
    assert_eq!(frames[3].header.sequence, 7);
    assert_eq!(frames[4].message, Message::Rpm(Rpm { rpm: [6000.0, -1.0] }));
    match frames[5].message {
        Message::EscStatus(m) => assert_eq!((m.index, m.rpm, m.current_a[0]), (0, [6000, 0, 0, 0], 3.25)),
        ref other => panic!("{other:?}"),
    }
    assert_eq!(frames[6].header.version, Version::V1);
    let mut v1 = servo_outputs();
    v1.servo_raw_us[8] = 0; // MAVLink 1 carries no extension fields
    assert_eq!(servo_of(&frames[6]), v1);
    assert_eq!(p.stats().frames, 7);
    assert_eq!(p.stats().discarded_bytes, 0);
}

#[test]
fn telemetry_round_trip() {
    let mut t = Telemetry::new(42, 191);
    let mut reports = [report(); 6];
    for (i, r) in reports.iter_mut().enumerate() {
        r.coefficient = i as u8;
        r.n_params = 1 + i as u8;
        r.theta = core::array::from_fn(|j| (i * 10 + j) as f32 * 0.5 - 3.0);
        r.sigma = core::array::from_fn(|j| if j == 2 { f32::NAN } else { (j + 1) as f32 * 0.01 });
        r.health_flags = 0x00AB_CDEF;
        r.refused = u32::MAX;
    }
    let mut buf = [0u8; 700];
    let mut n = t.heartbeat(3, &mut buf).unwrap();
    n += t.coefficients(&reports, 77, &mut buf[n..]).unwrap();
    assert!(n <= 21 + 600);
    let (frames, p) = parse(&buf[..n]);
    assert_eq!(frames.len(), 7, "{:?}", p.stats());
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(
            (f.header.sequence, f.header.system_id, f.header.component_id),
            (k as u8, 42, 191)
        );
    }
    for (r, f) in reports.iter().zip(&frames[1..]) {
        let Message::DebugFloatArray(m) = f.message else {
            panic!("{f:?}")
        };
        let names = ["CL", "CD", "CY", "Cl", "Cm", "Cn"];
        assert_eq!(&m.name[..2], names[usize::from(r.coefficient)].as_bytes());
        assert_eq!(m.array_id, u16::from(r.coefficient));
        assert_eq!(m.time_us, 77);
        let n = usize::from(r.n_params);
        for j in 0..6 {
            let (th, sg) = if j < n { (r.theta[j], r.sigma[j]) } else { (0.0, 0.0) };
            assert_eq!(m.data[slot::THETA + j], th);
            assert!(m.data[slot::SIGMA + j] == sg || (sg.is_nan() && m.data[slot::SIGMA + j].is_nan()));
        }
        assert_eq!(m.data[slot::RANK_K], f32::from(r.rank_k));
        assert_eq!(m.data[slot::LAMBDA_F], r.lambda_f);
        assert_eq!(m.data[slot::HEALTH_FLAGS] as u32, 0x00AB_CDEF);
        assert_eq!(m.data[slot::REFUSED], 16_777_216.0, "saturates at 2^24");
        assert_eq!(m.data[slot::N_PARAMS], f32::from(r.n_params));
    }
}

#[test]
fn health_report_round_trip() {
    use aerosid_core::mavlink::telemetry::{health_slot, HealthReport, HEALTH_ARRAY_ID};
    // GIVEN a health report with a distinct value in every slot, one of them above 2^24
    let mut h = HealthReport::default();
    for (i, v) in h.values.iter_mut().enumerate() {
        *v = 1000 * i as u32 + 7;
    }
    h.values[health_slot::SAMPLED] = u32::MAX;
    // WHEN it is sent and parsed
    let mut t = Telemetry::new(1, 191);
    let mut buf = [0u8; 300];
    let n = t.health(&h, 99, &mut buf).unwrap();
    assert!(n <= 12 + 20 + 4 * health_slot::COUNT, "{n} bytes");
    let (frames, _) = parse(&buf[..n]);
    assert_eq!(frames.len(), 1);
    let Message::DebugFloatArray(m) = frames[0].message else {
        panic!("{:?}", frames[0])
    };
    // THEN it is the health report (not a coefficient's), every value as sent, the large one
    // saturated at 2^24, and a coefficient report is not mistaken for it
    assert_eq!(
        (m.array_id, &m.name[..6], m.time_us),
        (HEALTH_ARRAY_ID, &b"health"[..], 99)
    );
    let back = HealthReport::from_debug_float_array(&m).expect("a health report");
    let mut want = h;
    want.values[health_slot::SAMPLED] = 1 << 24;
    assert_eq!(back, want);
    let c = report().to_debug_float_array(0).unwrap();
    assert_eq!(HealthReport::from_debug_float_array(&c), None);
}

// ---- parser robustness ----

#[test]
fn garbage_prefix_and_split_pushes() {
    let mut stream = vec![0x00, 0x55, 0xAA, 0x13, 0x37, 0xFF, 0x10];
    stream.extend_from_slice(&SERVO_OUTPUT_RAW);
    stream.extend_from_slice(&RPM);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 2);
    assert_eq!(p.stats().discarded_bytes, 7);
    // The same bytes in uneven chunks through one parser, and one byte at a time through `push`.
    let mut p = Parser::new();
    let mut got = Vec::new();
    for chunk in stream.chunks(3) {
        got.extend(parse_all(&mut p, chunk));
    }
    assert_eq!(got, frames);
    let mut p = Parser::new();
    let got: Vec<Frame> = stream.iter().filter_map(|&b| p.push(b)).collect();
    assert_eq!(got, frames);
}

#[test]
fn bad_crc_counted_and_resync() {
    let mut bad = SERVO_OUTPUT_RAW;
    bad[12] ^= 0x01;
    let mut stream = bad.to_vec();
    stream.extend_from_slice(&RPM);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].message.id(), 226);
    assert_eq!(p.stats().bad_crc, 1);
    // A wrong checksum byte itself.
    let mut bad = RPM;
    bad[19] ^= 0x80;
    let mut stream = bad.to_vec();
    stream.extend_from_slice(&SERVO_OUTPUT_RAW);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(p.stats().bad_crc, 1);
}

#[test]
fn truncated_frame_followed_by_a_good_one() {
    for cut in 1..SERVO_OUTPUT_RAW.len() {
        let mut stream = SERVO_OUTPUT_RAW[..cut].to_vec();
        stream.extend_from_slice(&RPM);
        stream.extend_from_slice(&HEARTBEAT);
        let (frames, p) = parse(&stream);
        let ids: Vec<u32> = frames.iter().map(|f| f.message.id()).collect();
        assert_eq!(ids, [226, 0], "cut at {cut}: {:?}", p.stats());
    }
}

#[test]
fn oversized_length_rejected_at_the_header() {
    // A known id with a payload longer than the message (37 bytes at most for SERVO_OUTPUT_RAW).
    let mut bad = SERVO_OUTPUT_RAW;
    bad[1] = 200;
    let mut stream = bad.to_vec();
    stream.extend_from_slice(&RPM);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(p.stats().bad_length, 1);
    // The full 255 on an unknown id swallows what follows until the skip fails to be confirmed.
    let mut bad = GLOBAL_POSITION_INT;
    bad[1] = 255;
    let mut stream = bad.to_vec();
    for _ in 0..5 {
        stream.extend_from_slice(&HEARTBEAT);
        stream.extend_from_slice(&SERVO_OUTPUT_RAW);
    }
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 10, "{:?}", p.stats());
    // MAVLink 1 frames must have exactly the base length.
    let mut bad = SERVO_OUTPUT_RAW_V1;
    bad[1] = 23;
    let mut stream = bad.to_vec();
    stream.extend_from_slice(&SERVO_OUTPUT_RAW_V1);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(p.stats().bad_length, 1);
}

#[test]
fn unknown_id_skipped() {
    let mut stream = GLOBAL_POSITION_INT.to_vec();
    stream.extend_from_slice(&SERVO_OUTPUT_RAW);
    stream.extend_from_slice(&GLOBAL_POSITION_INT);
    stream.extend_from_slice(&RPM);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 2);
    assert_eq!(p.stats().unknown_skipped, 2);
    assert_eq!(p.stats().discarded_bytes, 0);
    // An unknown id whose payload holds start bytes is skipped whole.
    let mut e = Encoder::new(1, 1);
    let mut odd = GLOBAL_POSITION_INT;
    odd[7] = 0x7F; // id 127: unknown
    odd[14] = 0xFD;
    odd[20] = 0xFE;
    let mut stream = odd.to_vec();
    let mut buf = [0u8; 64];
    let n = e.encode(&Heartbeat::onboard_controller(4), &mut buf).unwrap();
    stream.extend_from_slice(&buf[..n]);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(p.stats().unknown_skipped, 1);
}

#[test]
fn signed_frame_signature_skipped() {
    let mut stream = SERVO_OUTPUT_RAW_SIGNED.to_vec();
    stream.extend_from_slice(&RPM);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 2);
    assert!(frames[0].header.is_signed());
    assert_eq!(servo_of(&frames[0]), servo_outputs());
    assert!(!frames[1].header.is_signed());
    assert_eq!(p.stats().signed, 1);
    assert_eq!(p.stats().discarded_bytes, 0);
    // A signature truncated to 5 bytes: the frame itself is intact (its checksum does not cover the
    // signature) and the next frame, whose first bytes were taken for the signature, is re-scanned.
    let mut stream = SERVO_OUTPUT_RAW_SIGNED[..SERVO_OUTPUT_RAW_SIGNED.len() - 8].to_vec();
    stream.extend_from_slice(&RPM);
    stream.extend_from_slice(&HEARTBEAT);
    let (frames, _) = parse(&stream);
    let ids: Vec<u32> = frames.iter().map(|f| f.message.id()).collect();
    assert_eq!(ids, [36, 226, 0]);
}

#[test]
fn unsupported_incompat_flag_dropped() {
    let mut bad = HEARTBEAT;
    bad[2] = 0x02;
    let crc = frame_crc(&bad[..10], &bad[10..19], 50).to_le_bytes();
    bad[19..].copy_from_slice(&crc);
    let mut stream = bad.to_vec();
    stream.extend_from_slice(&HEARTBEAT);
    let (frames, p) = parse(&stream);
    assert_eq!(frames.len(), 1);
    assert_eq!(p.stats().bad_incompat_flags, 1);
}

/// xorshift64* (Vigna), seeded: the soak's byte source.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
}

/// 10⁶ random bytes with valid frames interleaved. Every delivered frame must be one that was
/// inserted, in order (no false frame passes a checksum), and nearly all are recovered: a frame is
/// lost only when random bytes before it mimic an unknown-id frame that spans it and ends on a start
/// byte (module doc of the parser), or when garbage straddles into it.
#[test]
fn soak_random_bytes_with_interleaved_frames() {
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
    let mut enc = Encoder::new(1, 1);
    let mut stream = Vec::with_capacity(1_100_000);
    let mut inserted = Vec::new();
    let mut buf = [0u8; MAX_FRAME_LEN];
    let mut garbage = 0usize;
    while garbage < 1_000_000 {
        let run = (rng.next() % 200) as usize;
        for _ in 0..run {
            stream.push(rng.next() as u8);
        }
        garbage += run;
        let mut s = servo_outputs();
        s.time_us = rng.next() as u32;
        s.servo_raw_us[0] = 1000 + (rng.next() % 1000) as u16;
        let n = match rng.next() % 4 {
            0 => enc
                .encode(
                    &Rpm {
                        rpm: [(rng.next() % 9000) as f32, -1.0],
                    },
                    &mut buf,
                )
                .unwrap(),
            1 => enc.encode_v1(&s, &mut buf).unwrap(),
            _ => enc.encode(&s, &mut buf).unwrap(),
        };
        stream.extend_from_slice(&buf[..n]);
        let (frames, _) = parse(&buf[..n]);
        inserted.push(frames[0]);
        // Sometimes a run of valid frames back to back, as an autopilot sends them.
        if rng.next().is_multiple_of(3) {
            let n = enc.encode(&Heartbeat::default(), &mut buf).unwrap();
            stream.extend_from_slice(&buf[..n]);
            inserted.push(parse(&buf[..n]).0[0]);
        }
    }
    let (frames, p) = parse(&stream);
    // In order, and a subsequence of what was inserted.
    let mut it = inserted.iter();
    for f in &frames {
        assert!(it.any(|i| i == f), "a frame that was never inserted: {f:?}");
    }
    let recovered = frames.len() as f64 / inserted.len() as f64;
    println!(
        "soak: {} of {} frames recovered ({:.4}), {:?}",
        frames.len(),
        inserted.len(),
        recovered,
        p.stats()
    );
    assert!(recovered > 0.99, "recovered {recovered}"); // measured 0.9948 (13411 of 13481)
}

// ---- actuator source ----

fn config() -> SurfaceConfig {
    SurfaceConfig {
        source_system_id: 1,
        port: 0,
        // Elevator on output 2: 500 µs of travel = 0.5 rad, trailing edge down for lower PWM.
        elevator: ServoCalibration {
            channel: 1,
            pwm_neutral_us: 1500.0,
            rad_per_us: -0.001,
            limits_rad: (-0.35, 0.35),
        },
        aileron: ServoCalibration {
            channel: 0,
            pwm_neutral_us: 1500.0,
            rad_per_us: 0.0008,
            limits_rad: (-0.4, 0.4),
        },
        aileron_2: None,
        rudder: ServoCalibration {
            channel: 3,
            pwm_neutral_us: 1520.0,
            rad_per_us: 0.001,
            limits_rad: (-0.5, 0.5),
        },
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
        attitude_timeout_us: 200_000,
    }
}

fn frame_bytes(msg: &impl aerosid_core::mavlink::messages::Encode, system_id: u8) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = Encoder::new(system_id, 1).encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-6
}

#[test]
fn surface_calibration() {
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    s.receive(&SERVO_OUTPUT_RAW, 1_000_000);
    let r = s.surfaces(1_020_000).unwrap();
    assert_eq!(r.age_us, 20_000);
    assert!(close(r.elevator_rad.unwrap(), -0.1)); // 1600 µs
    assert!(close(r.aileron_rad.unwrap(), 0.0)); // 1500 µs
    assert!(close(r.rudder_rad.unwrap(), 0.03)); // 1550 µs
    assert!(close(r.throttle.unwrap(), 0.375)); // 1400 µs
                                                // Saturation at the limits, and a disabled output (PWM 0) is an error for that channel only.
    let mut m = servo_outputs();
    m.time_us += 1_000_000;
    m.servo_raw_us[1] = 2100;
    m.servo_raw_us[2] = 2000;
    m.servo_raw_us[3] = 0;
    s.receive(&frame_bytes(&m, 1), 2_000_000);
    let r = s.surfaces(2_000_000).unwrap();
    assert_eq!(r.elevator_rad, Ok(-0.35));
    assert_eq!(r.throttle, Ok(1.0));
    assert_eq!(r.rudder_rad, Err(SurfaceError::PwmOutOfRange { channel: 3, pwm_us: 0 }));
    assert!(r.aileron_rad.is_ok());
    // Two aileron servos, opposite signs, averaged.
    let mut c = config();
    c.aileron_2 = Some(ServoCalibration {
        channel: 4,
        pwm_neutral_us: 1500.0,
        rad_per_us: -0.0008,
        limits_rad: (-0.4, 0.4),
    });
    let mut s = MavlinkSurfaces::new(c).unwrap();
    let mut m = servo_outputs();
    m.servo_raw_us[0] = 1625; // +0.1
    m.servo_raw_us[4] = 1375; // +0.1 through the negative sign
    s.receive(&frame_bytes(&m, 1), 0);
    assert!(close(s.surfaces(0).unwrap().aileron_rad.unwrap(), 0.1));
}

#[test]
fn surface_staleness_and_filters() {
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    assert_eq!(s.surfaces(0), Err(SurfaceError::NoData));
    s.receive(&SERVO_OUTPUT_RAW, 1_000_000);
    assert!(s.surfaces(1_100_000).is_ok());
    assert_eq!(s.surfaces(1_100_001), Err(SurfaceError::Stale { age_us: 100_001 }));
    assert_eq!(s.surfaces(999_999), Err(SurfaceError::TimeWentBackwards));
    // A fresh frame from another system, or on another port, does not refresh.
    s.receive(&frame_bytes(&servo_outputs(), 2), 2_000_000);
    let mut aux = servo_outputs();
    aux.port = 1;
    s.receive(&frame_bytes(&aux, 1), 2_000_000);
    assert!(matches!(s.surfaces(2_000_000), Err(SurfaceError::Stale { .. })));
    // Nor does a corrupted one.
    let mut bad = SERVO_OUTPUT_RAW;
    bad[15] ^= 0x40;
    s.receive(&bad, 2_000_000);
    assert!(matches!(s.surfaces(2_000_000), Err(SurfaceError::Stale { .. })));
    assert_eq!(s.parser_stats().bad_crc, 1);
    // A good frame of ours with a new stamp does (a repeated stamp would not:
    // `repeated_timestamps_do_not_refresh_the_surfaces`).
    let mut next = servo_outputs();
    next.time_us += 1_000_000;
    s.receive(&frame_bytes(&next, 1), 2_000_000);
    assert!(s.surfaces(2_000_000).is_ok());
}

#[test]
fn repeated_or_older_stamps_do_not_refresh_the_surfaces() {
    let stamped = |time_us: u32, elevator_pwm: u16| {
        let mut m = servo_outputs();
        m.time_us = time_us;
        m.servo_raw_us[1] = elevator_pwm;
        frame_bytes(&m, 1)
    };
    // GIVEN servo outputs stamped 5 000 000 µs by the autopilot, received at 1 s
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    s.receive(&SERVO_OUTPUT_RAW, 1_000_000);
    assert!(s.surfaces(1_050_000).is_ok());
    // WHEN the same stamp keeps arriving (the autopilot's outputs frozen, its telemetry not), with
    // other values even, and an older frame is replayed
    s.receive(&SERVO_OUTPUT_RAW, 1_050_000);
    s.receive(&stamped(5_000_000, 1900), 1_070_000);
    s.receive(&stamped(4_700_000, 1800), 1_090_000);
    // THEN the surfaces keep the first frame's values and age, go stale at its timeout, and the
    // three frames are counted
    let r = s.surfaces(1_090_000).unwrap();
    assert_eq!(r.age_us, 90_000);
    assert!(close(r.elevator_rad.unwrap(), -0.1), "{r:?}");
    assert_eq!(s.surfaces(1_100_001), Err(SurfaceError::Stale { age_us: 100_001 }));
    assert_eq!(s.not_newer_frames(), 3);
    // … a newer stamp refreshes them
    s.receive(&stamped(5_010_000, 1700), 1_200_000);
    assert!(close(s.surfaces(1_200_000).unwrap().elevator_rad.unwrap(), -0.2));
    // … an older stamp is taken once the kept frame is stale (the autopilot rebooted and its
    // clock started again), not before
    s.receive(&stamped(20_000, 1500), 1_300_000);
    assert_eq!(s.not_newer_frames(), 4);
    s.receive(&stamped(20_000, 1500), 1_300_001);
    assert_eq!(s.surfaces(1_300_001).unwrap().age_us, 0);
    assert_eq!(s.not_newer_frames(), 4);
    // … the 32-bit µs stamp wraps after 71.6 min: the frame after the wrap is newer
    s.receive(&stamped(u32::MAX - 4_999, 1500), 1_500_000);
    s.receive(&stamped(5_000, 1550), 1_510_000);
    assert!(close(s.surfaces(1_510_000).unwrap().elevator_rad.unwrap(), -0.05));
    assert_eq!(s.surfaces(1_510_000).unwrap().age_us, 0);
    // … a frame stamped 0 (not stamped) is always taken, and never counted
    for k in 0..3u64 {
        s.receive(&stamped(0, 1500), 1_600_000 + k * 50_000);
    }
    assert_eq!(s.surfaces(1_700_000).unwrap().age_us, 0);
    // … nor are another system's or another port's frames counted
    s.receive(&stamped(1, 1500), 1_700_000);
    s.receive(&stamped(1, 1500), 1_710_000);
    assert_eq!(s.not_newer_frames(), 5);
    let mut aux = servo_outputs();
    aux.time_us = 1;
    aux.port = 1;
    s.receive(&frame_bytes(&aux, 1), 1_720_000);
    let mut other = servo_outputs();
    other.time_us = 1;
    s.receive(&frame_bytes(&other, 2), 1_730_000);
    assert_eq!(s.not_newer_frames(), 5);

    // The attitude: ATTITUDE_TRUNCATED is stamped 123 456 ms.
    s.receive(&ATTITUDE_TRUNCATED, 2_000_000);
    s.receive(&ATTITUDE_TRUNCATED, 2_150_000);
    assert!(matches!(s.euler_rad(2_200_001), Err(SurfaceError::Stale { .. })));
    assert_eq!(s.not_newer_frames(), 6);
    let newer = Attitude {
        time_boot_ms: 123_466,
        euler_rad: [0.0, 0.1, 0.2],
        ..Attitude::default()
    };
    s.receive(&frame_bytes(&newer, 1), 2_200_000);
    assert_eq!(s.euler_rad(2_200_001), Ok([0.0, 0.1, 0.2]));

    // ESC_STATUS (stamped 123 456 µs) as the RPM source; ArduPilot's RPM has no stamp.
    let mut c = config();
    c.rpm = RpmSource::EscStatus { esc: 0 };
    let mut s = MavlinkSurfaces::new(c).unwrap();
    s.receive(&ESC_STATUS, 0);
    s.receive(&ESC_STATUS, 400_000);
    assert!(matches!(s.prop_speed_rad_s(500_001), Err(SurfaceError::Stale { .. })));
    assert_eq!(s.not_newer_frames(), 1);
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    s.receive(&RPM, 0);
    s.receive(&RPM, 400_000);
    assert!(s.prop_speed_rad_s(500_001).is_ok());
    assert_eq!(s.not_newer_frames(), 0);
}

#[test]
fn prop_speed_from_rpm_sources() {
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    assert_eq!(s.prop_speed_rad_s(0), Err(SurfaceError::NoData));
    s.receive(&RPM, 10);
    let w = s.prop_speed_rad_s(10).unwrap();
    assert!((w - 6000.0 * core::f32::consts::TAU / 60.0).abs() < 1e-3, "{w}");
    assert!(matches!(
        s.prop_speed_rad_s(10 + 500_001),
        Err(SurfaceError::Stale { .. })
    ));
    // ArduPilot's −1 (unhealthy) on sensor 2.
    let mut c = config();
    c.rpm = RpmSource::ArduPilotRpm { sensor: 1 };
    let mut s = MavlinkSurfaces::new(c).unwrap();
    s.receive(&RPM, 10);
    assert_eq!(s.prop_speed_rad_s(10), Err(SurfaceError::RpmInvalid));
    // ESC_STATUS: ESC 5 is in the message with index 4, slot 1; half-speed gearbox.
    let mut c = config();
    c.rpm = RpmSource::EscStatus { esc: 5 };
    c.rpm_scale = 0.5;
    let mut s = MavlinkSurfaces::new(c).unwrap();
    s.receive(&ESC_STATUS, 0); // index 0: not ours
    assert_eq!(s.prop_speed_rad_s(0), Err(SurfaceError::NoData));
    let esc = EscStatus {
        index: 4,
        rpm: [1, 3000, 2, 3],
        ..EscStatus::default()
    };
    s.receive(&frame_bytes(&esc, 1), 0);
    assert!(close(
        s.prop_speed_rad_s(0).unwrap(),
        1500.0 * core::f32::consts::TAU / 60.0
    ));
    let mut c = config();
    c.rpm = RpmSource::None;
    let mut s = MavlinkSurfaces::new(c).unwrap();
    assert_eq!(s.prop_speed_rad_s(0), Err(SurfaceError::NoRpmSource));
}

#[test]
fn euler_angles_from_attitude() {
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    assert_eq!(s.euler_rad(0), Err(SurfaceError::NoData));
    s.receive(&ATTITUDE_TRUNCATED, 1_000);
    assert_eq!(s.euler_rad(1_000), Ok([0.1, -0.25, 3.0]));
    assert_eq!(s.euler_rad(201_000), Ok([0.1, -0.25, 3.0]));
    assert!(matches!(s.euler_rad(201_001), Err(SurfaceError::Stale { .. })));
    assert_eq!(s.euler_rad(999), Err(SurfaceError::TimeWentBackwards));
    // Another system's attitude is not ours.
    let mut s = MavlinkSurfaces::new(config()).unwrap();
    s.receive(&frame_bytes(&Attitude::default(), 2), 0);
    assert_eq!(s.euler_rad(0), Err(SurfaceError::NoData));
    // A NaN angle is refused.
    let nan = Attitude {
        euler_rad: [0.0, f32::NAN, 0.0],
        ..Attitude::default()
    };
    s.receive(&frame_bytes(&nan, 1), 0);
    assert_eq!(s.euler_rad(0), Err(SurfaceError::AttitudeInvalid));
}

#[test]
fn fill_writes_the_autopilot_channels_and_nan_for_each_missing_one() {
    use aerosid_core::aero::SensorSample;
    // Which of elevator, aileron, rudder, throttle, RPM, φ, θ, ψ hold a number.
    let present = |s: &SensorSample<f32>| -> Vec<bool> {
        let (e, p) = (s.euler_rad, s.prop_speed_rad_s);
        let values = vec![
            s.elevator_rad,
            s.aileron_rad,
            s.rudder_rad,
            s.throttle,
            p,
            e.x,
            e.y,
            e.z,
        ];
        values.into_iter().map(|v| !v.is_nan()).collect()
    };
    // GIVEN a link that has received nothing WHEN a sample is filled THEN every autopilot channel
    // is NaN (the sensors' own channels untouched) and the fill reports it
    let mut link = MavlinkSurfaces::new(config()).unwrap();
    let mut s = SensorSample::<f32> {
        airspeed_mps: 17.0,
        elevator_rad: 0.2,
        ..SensorSample::default()
    };
    assert!(!link.fill(0, &mut s));
    assert_eq!(present(&s), vec![false; 8]);
    assert_eq!(s.airspeed_mps, 17.0);
    // … with servo outputs, RPM and attitude fresh, every channel is the calibrated value
    link.receive(&SERVO_OUTPUT_RAW, 1_000_000);
    link.receive(&RPM, 1_000_000);
    link.receive(&ATTITUDE_TRUNCATED, 1_000_000);
    assert!(link.fill(1_020_000, &mut s));
    assert!(close(s.elevator_rad, -0.1) && close(s.rudder_rad, 0.03) && close(s.throttle, 0.375));
    assert!((s.prop_speed_rad_s - 6000.0 * core::f32::consts::TAU / 60.0).abs() < 1e-3);
    assert_eq!([s.euler_rad.x, s.euler_rad.y, s.euler_rad.z], [0.1, -0.25, 3.0]);
    // … once the servo outputs are stale but attitude and RPM are not, only the surfaces and the
    // throttle are NaN
    assert!(!link.fill(1_150_000, &mut s));
    assert_eq!(present(&s), [vec![false; 4], vec![true; 4]].concat());
    // … and a single disabled output (PWM 0) invalidates that surface alone (the autopilot's clock
    // has moved on with ours)
    let mut m = servo_outputs();
    m.time_us += 150_000;
    m.servo_raw_us[3] = 0;
    link.receive(&frame_bytes(&m, 1), 1_150_000);
    assert!(!link.fill(1_150_000, &mut s));
    assert_eq!(present(&s), vec![true, true, false, true, true, true, true, true]);
}

#[test]
fn surface_config_validation() {
    assert!(config().validate().is_ok());
    let mut c = config();
    c.elevator.channel = 16;
    assert_eq!(MavlinkSurfaces::new(c).err(), Some(SurfaceError::InvalidCalibration));
    let mut c = config();
    c.rudder.limits_rad = (0.5, -0.5);
    assert!(c.validate().is_err());
    let mut c = config();
    c.throttle.pwm_full_us = c.throttle.pwm_idle_us;
    assert!(c.validate().is_err());
    let mut c = config();
    c.rpm = RpmSource::ArduPilotRpm { sensor: 2 };
    assert!(c.validate().is_err());
    let mut c = config();
    c.aileron.rad_per_us = f32::NAN;
    assert!(c.validate().is_err());
}

#[test]
fn coefficient_report_survives_debug_float_array_round_trip() {
    use aerosid_core::mavlink::CoefficientReport;
    let r = CoefficientReport {
        coefficient: 4,
        theta: [0.01, -1.3, -20.0, 1.0, 0.0, 0.0],
        sigma: [1e-4, 0.008, 0.07, f32::NAN, 0.0, 0.0],
        n_params: 4,
        rank_k: 3,
        lambda_f: 0.9995,
        health_flags: 0b101,
        refused: 12,
    };
    let back = CoefficientReport::from_debug_float_array(&r.to_debug_float_array(1_000).expect("encode"));
    assert!(back.same_estimate_bits(&r));
    assert_eq!((back.coefficient, back.health_flags, back.refused), (4, 0b101, 12));
}
