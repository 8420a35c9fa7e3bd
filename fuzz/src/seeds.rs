//! The seed corpus (`fuzz/seeds/<target>/`): a few small, valid inputs per target from which
//! libFuzzer mutates. Written by `cargo run --release --manifest-path fuzz/Cargo.toml --features
//! seeds --bin fuzz-seeds` (deterministic: the same files on every run), committed.
//!
//! * `gtls`, `pipeline`: each set-up byte with well-excited model blocks, plus blocks of special
//!   values, repeats, jumps, collinear and stuck columns, timing faults.
//! * `drivers`: a good ICM-42688-P init and read, good MS4525DO and AS5600 frames, and each error
//!   status once.
//! * `mavlink`: the frames the firmware reads (`SERVO_OUTPUT_RAW`, `ATTITUDE`, `RPM`, `ESC_STATUS`)
//!   encoded by the core's encoder, one signed, between garbage and a truncated frame.
//! * `read_log`, `read_project_csv`: 0.3 s of a simulated flight in the project's CSV layout (all
//!   columns; a subset).
//! * `read_aircraft`: the shipped aircraft files; `read_colmap_ascii`: each shipped map with the
//!   first lines of its vendored flight-test file (`tool/data/flight`); `read_ulog`: a ULog of 0.3 s of a simulated flight (a small writer below, from the
//!   ULog format PX4 documents); `read_dataflash`: the first 64 KiB and 24 KiB of the two vendored
//!   ArduPlane logs; `read_mat`: the vendored Twin Otter `.mat`.

use aerosid_core::mavlink::messages::{Attitude, EscStatus, Heartbeat, Rpm, ServoOutputRaw};
use aerosid_core::mavlink::Encoder;
use aerosid_read::log;
use aerosid_sim::{self as sim, SimConfig};

/// One seed: `(target, file name, bytes)`.
type Seed = (&'static str, String, Vec<u8>);

/// Every seed.
pub fn all() -> Vec<Seed> {
    let mut out = core_target_seeds();
    let samples = flight(0.3);
    out.extend(project_csv_seeds(&samples));
    out.extend(shipped_text_seeds());
    out.push(("read_ulog", "flight.ulg".into(), ulog(&samples)));
    out.extend(vendored_binary_seeds());
    out
}

/// The seeds of the core targets (`gtls`, `pipeline`, `drivers`, `mavlink`) and the regressions.
fn core_target_seeds() -> Vec<Seed> {
    let mut out = Vec::new();
    for (name, bytes) in gtls() {
        out.push(("gtls", name, bytes));
    }
    for (name, bytes) in pipeline() {
        out.push(("pipeline", name, bytes));
    }
    for (name, bytes) in drivers() {
        out.push(("drivers", name, bytes));
    }
    for (name, bytes) in mavlink() {
        out.push(("mavlink", name, bytes));
    }
    // Inputs that once broke an invariant (`fuzz/regressions/`), kept as seeds so that every run
    // starts by re-checking them. ms4525do-speed-underflow (libFuzzer crash-2c94843a): a Δp of
    // −3.7e-23 Pa over a huge configured density, whose speed underflows to −0.0 — the oracle's
    // sign check, not the driver, was wrong.
    out.push((
        "drivers",
        "regression-ms4525do-speed-underflow".into(),
        include_bytes!("../regressions/drivers/ms4525do-speed-underflow").to_vec(),
    ));
    out
}

/// The simulated flight `samples` in the project's CSV layout: all columns (`read_log`,
/// `read_project_csv`) and a subset (`read_project_csv`); none if it cannot be written.
fn project_csv_seeds(samples: &[aerosid_core::aero::SensorSample<f64>]) -> Vec<Seed> {
    let mut out = Vec::new();
    let mut csv = Vec::new();
    if log::write_log(&mut csv, "seed.csv", samples).is_ok() {
        out.push(("read_log", "flight.csv".into(), csv.clone()));
        out.push(("read_project_csv", "flight.csv".into(), csv.clone()));
        out.push(("read_project_csv", "subset.csv".into(), subset_csv(&csv)));
    }
    out
}

/// The shipped aircraft files, and each shipped map with the first lines of its vendored
/// flight-test file.
fn shipped_text_seeds() -> Vec<Seed> {
    let mut out = Vec::new();
    let aircraft = [
        ("attas", include_str!("../../tool/data/aircraft/attas.aircraft")),
        ("hfb320", include_str!("../../tool/data/aircraft/hfb320.aircraft")),
        (
            "twin_otter",
            include_str!("../../tool/data/aircraft/twin_otter.aircraft"),
        ),
    ];
    for (n, t) in aircraft {
        out.push(("read_aircraft", format!("{n}.aircraft"), t.as_bytes().to_vec()));
    }
    let maps = [
        (
            "attas",
            include_str!("../../tool/data/maps/attas.map"),
            include_str!("../../tool/data/flight/fAttasElv1_pqrDot.asc"),
        ),
        (
            "hfb320",
            include_str!("../../tool/data/maps/hfb320.map"),
            include_str!("../../tool/data/flight/hfb320_1_10.asc"),
        ),
        (
            "twin_otter",
            include_str!("../../tool/data/maps/twin_otter.map"),
            include_str!("../../tool/data/flight/totter_lon_020213f1_018_fdata.asc"),
        ),
    ];
    for (n, map, data) in maps {
        let lines: String = data.lines().take(12).map(|l| format!("{l}\n")).collect();
        let text = format!("{map}{}{lines}", crate::readers::MAP_DATA_SEPARATOR);
        out.push(("read_colmap_ascii", format!("{n}.txt"), text.into_bytes()));
    }
    out
}

/// The vendored binary logs: the first bytes of the two ArduPlane logs and the Twin Otter `.mat`.
fn vendored_binary_seeds() -> Vec<Seed> {
    let mut out = Vec::new();
    // The two vendored ArduPlane logs, 3.8 (no FMTU) and 4.2 (FMTU/UNIT/MULT), their first bytes:
    // the FMT definitions, the parameters and the first seconds of messages, so each run is quick.
    let dataflash: [(&str, &[u8], usize); 2] = [
        (
            "pymavlink_test.bin",
            include_bytes!("../../tool/data/logs/pymavlink_test.BIN"),
            65_536,
        ),
        (
            "pyflightcoach_center_0003.bin",
            include_bytes!("../../tool/data/logs/pyflightcoach_center_0003.bin"),
            24_576,
        ),
    ];
    for (n, bytes, keep) in dataflash {
        out.push(("read_dataflash", n.into(), bytes[..keep.min(bytes.len())].to_vec()));
    }
    // The Twin Otter's `.mat` whole (its variables are compressed: a prefix does not inflate).
    out.push((
        "read_mat",
        "totter_lon_020213f1_018.mat".into(),
        include_bytes!("../../tool/data/flight/totter_lon_020213f1_018.mat").to_vec(),
    ));
    out
}

fn flight(seconds: f64) -> Vec<aerosid_core::aero::SensorSample<f64>> {
    let cfg = SimConfig {
        duration_s: seconds,
        seed: 7,
        ..aerosid_sim::flights::main_flight(seconds, 7)
    };
    sim::simulate(&cfg).map(|o| o.samples).unwrap_or_default()
}

fn subset_csv(csv: &[u8]) -> Vec<u8> {
    // Columns 0..12 only (time, accelerometer, gyro, air data, attitude x).
    let text = String::from_utf8_lossy(csv);
    let mut out = String::new();
    for line in text.lines() {
        let cells: Vec<&str> = line.split(',').take(12).collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out.into_bytes()
}

fn gtls() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for setup in [0u8, 1, 2, 3, 4, 5, 8, 9, 16, 17, 24, 25, 0x20, 0x41] {
        let mut b = vec![setup];
        b.extend_from_slice(&[1, 2, 3, 1, 0x10, 0xF0, 0x08, 0, 0, 0, 0, 0, 0, 0, 0]); // W_T
        b.extend_from_slice(&[3, 3, 3, 3, 3, 3]); // weights
        b.push(2); // s/n = 1
                   // A 1021-sample model block, a repeat, a scale jump, specials, a collinear block.
        b.extend_from_slice(&[5, 1, 2, 3, 4, 255, 16, 8, 248, 32, 0xF0, 0x10, 4]);
        b.extend_from_slice(&[3, 40]);
        b.extend_from_slice(&[4, 6]);
        b.extend_from_slice(&[0, 12, 0, 4, 0, 1, 13, 0, 2, 3, 5, 4, 7, 9, 3, 10, 2, 11, 0, 0, 128, 63]);
        b.extend_from_slice(&[0x85, 9, 9, 9, 9, 100, 32, 16, 8, 4, 2, 1, 3]);
        b.extend_from_slice(&[6, 0b100]);
        b.extend_from_slice(&[5, 7, 7, 7, 7, 60, 24, 24, 24, 24, 24, 24, 5]);
        b.extend_from_slice(&[7, 0xD0, 0x07]);
        out.push((format!("setup-{setup:02x}"), b));
    }
    out
}

fn pipeline() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for setup in [0u8, 1] {
        let mut b = vec![setup, 1, 2, 3, 4, 5, 6, 7, 8];
        for _ in 0..4 {
            b.extend_from_slice(&[0, 255]); // 256 generated samples
        }
        b.extend_from_slice(&[3, 0x00, 0x01, 0x00, 0x0, 0]); // accel x NaN
        b.extend_from_slice(&[0, 50]);
        b.extend_from_slice(&[6, 8, 0x00, 0x02]); // airspeed stuck for 512 samples
        b.extend_from_slice(&[0, 255, 0, 255]);
        b.extend_from_slice(&[7, 1]); // dt doubled (a missed sample)
        b.extend_from_slice(&[0, 100, 5, 30, 0x85, 10]);
        b.extend_from_slice(&[7, 5, 3, 0, 100]);
        b.extend_from_slice(&[
            4, 0xFF, 0xFF, 0x0F, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20,
        ]);
        b.extend_from_slice(&[0, 255]);
        out.push((format!("onboard-{}", if setup == 0 { "f32" } else { "f64" }), b));
    }
    out
}

fn drivers() -> Vec<(String, Vec<u8>)> {
    let ok = 0xFFu8; // a transaction byte ≥ 32: it succeeds
    let mut b = Vec::new();
    // ICM init: WHO_AM_I = 0x47, four writes.
    b.extend_from_slice(&[0, ok, 0x47, ok, ok, ok, ok]);
    // ICM read: DATA_RDY, burst (temp, accel, gyro) big-endian.
    b.extend_from_slice(&[
        1, ok, 0x08, ok, 0x0A, 0x00, 0x00, 0x10, 0xFF, 0xF0, 0xF8, 0x00, 0x00, 0x20, 0xFF, 0xE0, 0x00, 0x05,
    ]);
    // ICM read: not ready; then a bus error.
    b.extend_from_slice(&[1, ok, 0x00, 1, 3, 2]);
    // MS4525DO: status 00 count 8292, temperature 767; stale; fault; out of range.
    b.extend_from_slice(&[5, ok, 0x20, 0x64, 0x5F, 0xFF]);
    b.extend_from_slice(&[
        5, ok, 0x80, 0x64, 0x5F, 0xFF, 5, ok, 0xC0, 0, 0, 0, 5, ok, 0x00, 0x01, 0, 0,
    ]);
    // MS4525DO zero calibration over 3 good frames.
    b.extend_from_slice(&[
        7, 3, ok, 0x20, 0x00, 0x5F, 0xFF, ok, 0x20, 0x02, 0x5F, 0xFF, ok, 0x1F, 0xFE, 0x5F, 0xFF,
    ]);
    // AS5600 read: magnet detected, raw 0x0800; weak; strong; missing; NACK.
    b.extend_from_slice(&[
        9, ok, 0x20, ok, 0x08, 0x00, 9, ok, 0x10, 9, ok, 0x08, 9, ok, 0x00, 9, 5, 0,
    ]);
    // AS5600 set_zero_here, set_config, read again.
    b.extend_from_slice(&[
        10, 1, ok, 0x20, ok, 0x07, 0xF0, 11, 0x00, 0x08, 0, 20, 0, 0x10, 20, 0xF0, 0xF0, 20, 0x10, 0x10,
    ]);
    b.extend_from_slice(&[9, ok, 0x20, ok, 0x08, 0x10]);
    // MS4525DO config with extreme floats, then a read.
    b.extend_from_slice(&[
        8, 0, 12, 0, 4, 12, 0, 4, 12, 0, 1, 12, 0, 0, 12, 0, 1, 5, ok, 0x20, 0x64, 0x5F, 0xFF,
    ]);
    vec![("session".into(), b)]
}

fn frame<M: aerosid_core::mavlink::messages::Encode>(enc: &mut Encoder, m: &M) -> Vec<u8> {
    let mut buf = [0u8; 300];
    match enc.encode(m, &mut buf) {
        Ok(n) => buf[..n].to_vec(),
        Err(_) => Vec::new(),
    }
}

fn mavlink() -> Vec<(String, Vec<u8>)> {
    let mut enc = Encoder::new(1, 1);
    let mut servo = ServoOutputRaw::default();
    servo.servo_raw_us[..5].copy_from_slice(&[1500, 1450, 1300, 1520, 1550]);
    let att = Attitude {
        time_boot_ms: 1000,
        euler_rad: [0.05, 0.02, 1.0],
        ..Attitude::default()
    };
    let rpm = Rpm { rpm: [6000.0, 0.0] };
    let esc = EscStatus {
        index: 0,
        rpm: [5000, 5900, 0, 0],
        ..EscStatus::default()
    };
    let stream: Vec<Vec<u8>> = vec![
        frame(&mut enc, &servo),
        frame(&mut enc, &att),
        frame(&mut enc, &rpm),
        frame(&mut enc, &esc),
        frame(&mut enc, &Heartbeat::onboard_controller(4)),
    ];
    // Chunks: [len, dt lo, dt hi, bytes…] (see crate::mavlink).
    let chunk = |bytes: &[u8], dt: u16| {
        let mut c = vec![bytes.len().min(255) as u8];
        c.extend_from_slice(&dt.to_le_bytes());
        c.extend_from_slice(&bytes[..bytes.len().min(255)]);
        c
    };
    let mut clean = vec![1u8];
    for f in &stream {
        clean.extend(chunk(f, 500));
    }
    let mut noisy = vec![3u8];
    noisy.extend(chunk(&[0x55, 0xFD, 0x09, 0x00, 0xFE, 0x12], 100));
    for (i, f) in stream.iter().enumerate() {
        let mut f = f.clone();
        if i == 1 {
            // Signed: flag, 13 signature bytes (not verified by the parser).
            f[2] |= 1;
            let n = f.len();
            let crc = aerosid_core::mavlink::frame::frame_crc(&f[..10], &f[10..n - 2], 39);
            f[n - 2..].copy_from_slice(&crc.to_le_bytes());
            f.extend_from_slice(&[7; 13]);
        }
        noisy.extend(chunk(&f[..f.len() / 2], 300));
        noisy.extend(chunk(&f[f.len() / 2..], 300));
    }
    noisy.extend(chunk(&stream[0][..7], 100)); // truncated
    noisy.extend(chunk(&stream[0], 20000));
    vec![("clean".into(), clean), ("noisy".into(), noisy)]
}

/// A minimal ULog writer: header (magic, version, start time), flag bits, formats, subscriptions,
/// data messages (`[u16 size][u8 type][payload]`).
struct Ulog {
    bytes: Vec<u8>,
}

impl Ulog {
    fn msg(&mut self, kind: u8, payload: &[u8]) {
        self.bytes.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        self.bytes.push(kind);
        self.bytes.extend_from_slice(payload);
    }
}

/// The topics of the seed ULog: name, format fields, floats per message.
const ULOG_TOPICS: [(&str, &str, usize); 6] = [
    ("vehicle_attitude", "uint64_t timestamp;float[4] q;", 4),
    (
        "vehicle_angular_velocity",
        "uint64_t timestamp;uint64_t timestamp_sample;float[3] xyz;",
        3,
    ),
    (
        "vehicle_acceleration",
        "uint64_t timestamp;uint64_t timestamp_sample;float[3] xyz;",
        3,
    ),
    (
        "airspeed_validated",
        "uint64_t timestamp;float indicated_airspeed_m_s;float true_airspeed_m_s;",
        2,
    ),
    (
        "vehicle_air_data",
        "uint64_t timestamp;float baro_alt_meter;float rho;",
        2,
    ),
    ("actuator_motors", "uint64_t timestamp;float[12] control;", 12),
];

fn ulog(samples: &[aerosid_core::aero::SensorSample<f64>]) -> Vec<u8> {
    let start_us = 1_000_000u64;
    let mut w = Ulog {
        bytes: b"ULog\x01\x12\x35\x01".to_vec(),
    };
    w.bytes.extend_from_slice(&start_us.to_le_bytes());
    w.msg(b'B', &[0u8; 40]);
    for (name, fields, _) in &ULOG_TOPICS {
        w.msg(b'F', format!("{name}:{fields}").as_bytes());
    }
    for (i, (name, _, _)) in ULOG_TOPICS.iter().enumerate() {
        let mut a = vec![0u8];
        a.extend_from_slice(&(i as u16).to_le_bytes());
        a.extend_from_slice(name.as_bytes());
        w.msg(b'A', &a);
    }
    for s in samples {
        let t_us = start_us + (s.t_s * 1e6).round() as u64;
        let values = ulog_values(s);
        for (i, (_, fields, _)) in ULOG_TOPICS.iter().enumerate() {
            let mut p = (i as u16).to_le_bytes().to_vec();
            for _ in 0..fields.matches("uint64_t").count() {
                p.extend_from_slice(&t_us.to_le_bytes());
            }
            for v in &values[i] {
                p.extend_from_slice(&(*v as f32).to_le_bytes());
            }
            w.msg(b'D', &p);
        }
    }
    w.bytes
}

/// A sample's floats per topic of [`ULOG_TOPICS`] (the attitude as a quaternion from the 3-2-1
/// Euler angles).
fn ulog_values(s: &aerosid_core::aero::SensorSample<f64>) -> [Vec<f64>; 6] {
    let (sr, cr) = (0.5 * s.euler_rad.x).sin_cos();
    let (sp, cp) = (0.5 * s.euler_rad.y).sin_cos();
    let (sy, cy) = (0.5 * s.euler_rad.z).sin_cos();
    let q = [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ];
    let mut motors = [0.0; 12];
    motors[0] = s.throttle;
    [
        q.to_vec(),
        vec![s.gyro_rad_s.x, s.gyro_rad_s.y, s.gyro_rad_s.z],
        vec![s.accel_mps2.x, s.accel_mps2.y, s.accel_mps2.z],
        vec![s.airspeed_mps, s.airspeed_mps],
        vec![100.0, s.air_density_kgpm3],
        motors.to_vec(),
    ]
}
