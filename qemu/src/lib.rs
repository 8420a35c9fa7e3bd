//! # aerosid-qemu
//!
//! The firmware under QEMU and the host's model of it: build the `qemu` board, replay a flight log
//! through it, and read back what it sent (MAVLink on USART1), what it logged (defmt over
//! semihosting) and what each sample cost (TIM2 instruction counts).
//!
//! Its own crate, depending on the core only, because two jobs need it: the `aerosid` tool
//! (`aerosid replay LOG.csv --qemu`) and the host tests (`host-tests/tests/qemu_replay.rs`,
//! `qemu_faults.rs`, `fem_qemu.rs`); the tests depend on the tool, so the harness cannot live in
//! either without a cycle.
//!
//! The run: `qemu-system-arm -machine netduinoplus2 -icount shift=0,align=off,sleep=off` (one TIM2
//! tick per guest instruction; TOOLCHAIN.md) in a scratch folder holding `replay.bin` and,
//! optionally, the faults to inject (`faults.bin`, [`FaultEvent`]) and the autopilot's MAVLink
//! stream (`autopilot.bin`, [`autopilot_stream`]); the firmware writes `icount.bin` there over
//! semihosting and its telemetry to `-serial file:telemetry.bin`.
//!
//! [`emulate`] is the host's model of what the firmware does with the same input: the sensor
//! layer (injected faults, the per-chip fault counters and re-initialisations, the autopilot link,
//! the stuck-sensor check), the sampler (dropped samples still numbered), the estimator's sequence
//! check and the `f32` pipeline, and the health report the firmware sends. The chip and link
//! counters and the report's assembly are the core's (`aerosid_core::harness`, tested there), the
//! same code the firmware runs; what is modelled here is the order of the firmware's stages.
//!
//! ```
//! use aerosid_core::aero::SensorSample;
//! use aerosid_qemu::{emulate, Scenario};
//! // What the firmware would send after a log of level samples at 100 Hz (no QEMU needed).
//! let samples: Vec<SensorSample<f32>> = (0..50)
//!     .map(|k| SensorSample {
//!         t_s: k as f32 * 0.01,
//!         dt_s: 0.01,
//!         airspeed_mps: 15.0,
//!         air_density_kgpm3: 1.2,
//!         ..SensorSample::default()
//!     })
//!     .collect();
//! let sent = emulate(&Scenario::clean(&samples))?;
//! assert_eq!(sent.processed, samples.len());
//! # Ok::<(), aerosid_qemu::QemuError>(())
//! ```

use aerosid_core::aero::model::{channel, ChannelMask};
use aerosid_core::aero::{model::idx, onboard, Admission, SensorSample, SequenceCheck, StuckDetector};
use aerosid_core::harness::{health_report, ChipHealth, LinkHealth, SampleCounts, SensorHealth};
use aerosid_core::mavlink::messages::{Attitude, Rpm, ServoOutputRaw};
use aerosid_core::mavlink::telemetry::HealthReport;
use aerosid_core::mavlink::{telemetry::reports, CoefficientReport, Encoder, MavlinkSurfaces, Message, Parser};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use aerosid_core::harness::{fault_chip, fault_kind};
pub use aerosid_core::harness::{FAULT_RECORD_BYTES, MAX_FAULTS, PERIOD_PROBE, PROBES, PROBE_NAMES};

/// Stack high-water mark of the QEMU firmware (painted stack), the regression budget of every
/// QEMU run (`tests/qemu_replay.rs`, `tests/qemu_faults.rs`): measured 4 216 B on the replay and
/// 4 112 B on the fault run with the firmware built for size around its opt-level 3 estimator step
/// (root `Cargo.toml`; the size-optimised telemetry and boot code keep larger frames: 3 784 B and
/// 3 776 B with the whole firmware at opt-level 3). How it is measured: docs/benchmarks.md, "Firmware
/// size and RAM".
pub const STACK_BUDGET_BYTES: u32 = 4_450;

/// Instructions of the whole six-coefficient step on its worst sample: the regression budget of
/// the clean replay (`tests/qemu_replay.rs`, measured max 41 584) and the ceiling of the fault run
/// (`tests/qemu_faults.rs`, measured max 43 497, the budget ≈ 5 % above it: no fault, and no
/// garbage on the link, may stall the step). The worst samples run the general secular update, whose square roots, secular
/// evaluations and eigenvector corrections are calls, not inlined copies, for the flash goal
/// (`linalg::secular`; 38 737 and 40 373 with them inlined, docs/performance.md).
pub const STEP_BUDGET_MAX: u32 = 45_700;

/// Whether `defmt-print` (which decodes the firmware's defmt log, and with it the stack figure) is
/// on the `PATH`.
pub fn defmt_print_installed() -> bool {
    Command::new("defmt-print")
        .arg("--version")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Why a QEMU run failed.
#[derive(Debug)]
pub enum QemuError {
    /// A tool is missing or failed; the message says which and how to install it.
    Tool(String),
    /// An I/O error on a named file.
    Io(PathBuf, std::io::Error),
    /// The firmware ran but its output is not what a finished replay leaves.
    Output(String),
}

impl std::fmt::Display for QemuError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Tool(m) | Self::Output(m) => f.write_str(m),
            Self::Io(p, e) => write!(f, "{}: {e}", p.display()),
        }
    }
}

impl std::error::Error for QemuError {}

fn io(p: &Path) -> impl FnOnce(std::io::Error) -> QemuError + '_ {
    move |e| QemuError::Io(p.to_path_buf(), e)
}

/// The workspace root (the folder of the top `Cargo.toml`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Builds the firmware with the `qemu` board (release, thumb target) into `target/qemu` (its own
/// target folder, so a build from inside `cargo test` does not wait on the test's lock); returns
/// the ELF.
pub fn build_firmware() -> Result<PathBuf, QemuError> {
    build_qemu_binary(None)
}

/// Builds the firmware example `name` (`firmware/examples/`) with the QEMU board, as
/// [`build_firmware`]; returns the ELF.
pub fn build_firmware_example(name: &str) -> Result<PathBuf, QemuError> {
    build_qemu_binary(Some(name))
}

fn build_qemu_binary(example: Option<&str>) -> Result<PathBuf, QemuError> {
    let root = workspace_root();
    let target_dir = root.join("target").join("qemu");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(&root)
        .args([
            "build",
            "-p",
            "aerosid-firmware",
            "--target",
            "thumbv7em-none-eabihf",
            "--release",
            "--features",
            "qemu",
        ])
        .args(example.map(|e| vec!["--example", e]).unwrap_or_default())
        .args(
            std::env::var("AEROSID_FW_CONFIG")
                .map(|c| vec!["--config".to_string(), c])
                .unwrap_or_default(),
        )
        .arg("--target-dir")
        .arg(&target_dir)
        .status()
        .map_err(|e| QemuError::Tool(format!("cargo: {e}")))?;
    if !status.success() {
        return Err(QemuError::Tool(format!(
            "firmware build failed ({status}); is the target installed? `rustup target add thumbv7em-none-eabihf`"
        )));
    }
    let release = target_dir.join("thumbv7em-none-eabihf").join("release");
    Ok(match example {
        Some(e) => release.join("examples").join(e),
        None => release.join("aerosid-firmware"),
    })
}

/// Writes the samples as the firmware's binary replay log.
pub fn write_replay(path: &Path, samples: &[SensorSample<f32>]) -> Result<(), QemuError> {
    let mut bytes = Vec::with_capacity(samples.len() * aerosid_core::aero::REPLAY_RECORD_BYTES);
    for s in samples {
        bytes.extend_from_slice(&s.to_replay_record());
    }
    std::fs::write(path, bytes).map_err(io(path))
}

/// What a finished replay left.
#[derive(Debug, Clone)]
pub struct QemuRun {
    /// The last coefficient report of each coefficient received over the telemetry UART, by `idx`.
    pub reports: [Option<CoefficientReport>; idx::COUNT],
    /// The last health report received.
    pub health: Option<HealthReport>,
    /// MAVLink frames received, and frames the parser rejected.
    pub frames: (u32, u32),
    /// The last value of each `NAMED_VALUE_FLOAT` counter received (`samples`, `lock_max`, …).
    pub counters: std::collections::BTreeMap<String, f32>,
    /// Instruction counts per processed sample, `[whole step, synthesis, C_L … C_n]`.
    pub counts: Vec<[u32; PROBES]>,
    /// The defmt log, decoded (empty if `defmt-print` is not installed).
    pub log: String,
    /// QEMU's exit status (0 after a complete replay).
    pub exit_code: Option<i32>,
}

/// Runs the firmware `elf` under QEMU on `samples` in the scratch folder `dir`, with a wall-clock
/// `timeout` (the run is deterministic; the timeout only guards against a hang).
pub fn run(elf: &Path, samples: &[SensorSample<f32>], dir: &Path, timeout: Duration) -> Result<QemuRun, QemuError> {
    run_scenario(elf, &Scenario::clean(samples), dir, timeout)
}

/// [`run`] with the scenario's faults and autopilot stream.
pub fn run_scenario(elf: &Path, scenario: &Scenario<'_>, dir: &Path, timeout: Duration) -> Result<QemuRun, QemuError> {
    write_inputs(scenario, dir)?;
    let defmt_path = dir.join("defmt.bin");
    let status = run_qemu(elf, dir, &defmt_path, timeout)?;
    let telemetry = read_telemetry(&dir.join("telemetry.bin"))?;
    let counts = read_counts(&dir.join("icount.bin"))?;
    let log = decode_defmt(elf, &defmt_path).unwrap_or_default();
    Ok(QemuRun {
        reports: telemetry.reports,
        health: telemetry.health,
        frames: telemetry.frames,
        counters: telemetry.counters,
        counts,
        log,
        exit_code: status.code(),
    })
}

/// The scenario's files in the scratch folder `dir` (`replay.bin`, and `faults.bin` and
/// `autopilot.bin` when it has them), the outputs of an earlier run removed.
fn write_inputs(scenario: &Scenario<'_>, dir: &Path) -> Result<(), QemuError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    write_replay(&dir.join("replay.bin"), scenario.samples)?;
    for f in [
        "icount.bin",
        "telemetry.bin",
        "defmt.bin",
        "faults.bin",
        "autopilot.bin",
    ] {
        let _ = std::fs::remove_file(dir.join(f));
    }
    if !scenario.faults.is_empty() {
        write_faults(&dir.join("faults.bin"), scenario.faults)?;
    }
    if let Some(chunks) = scenario.autopilot {
        let p = dir.join("autopilot.bin");
        let mut bytes = Vec::new();
        for c in chunks {
            let n = u16::try_from(c.len()).map_err(|_| QemuError::Output("autopilot chunk over 65535 bytes".into()))?;
            bytes.extend_from_slice(&n.to_le_bytes());
            bytes.extend_from_slice(c);
        }
        std::fs::write(&p, bytes).map_err(io(&p))?;
    }
    Ok(())
}

/// QEMU on `elf` in `dir` (module doc), its defmt stream into `defmt_path`, until it exits or
/// `timeout` passes (then killed, an error).
fn run_qemu(elf: &Path, dir: &Path, defmt_path: &Path, timeout: Duration) -> Result<ExitStatus, QemuError> {
    let defmt_out = std::fs::File::create(defmt_path).map_err(io(defmt_path))?;
    let mut child = Command::new("qemu-system-arm")
        .current_dir(dir)
        .args([
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "file:telemetry.bin",
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0,align=off,sleep=off",
            "-kernel",
        ])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(defmt_out)
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| {
            QemuError::Tool(format!(
                "qemu-system-arm: {e} (install: `apt-get install -y qemu-system-arm`)"
            ))
        })?;
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(s)) => return Ok(s),
            Ok(None) if start.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(QemuError::Output(format!("QEMU did not finish within {timeout:?}")));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(QemuError::Tool(format!("waiting for QEMU: {e}"))),
        }
    }
}

/// What the telemetry UART carried: the last report of each coefficient and of the health, the
/// frames received and rejected, the last value of each named counter.
struct Telemetry {
    reports: [Option<CoefficientReport>; idx::COUNT],
    health: Option<HealthReport>,
    frames: (u32, u32),
    counters: std::collections::BTreeMap<String, f32>,
}

/// The telemetry file parsed ([`Telemetry`]).
fn read_telemetry(tel_path: &Path) -> Result<Telemetry, QemuError> {
    let tel = std::fs::read(tel_path).map_err(io(tel_path))?;
    let mut parser = Parser::new();
    let mut last: [Option<CoefficientReport>; idx::COUNT] = [None; idx::COUNT];
    let mut health = None;
    let mut frames = 0u32;
    let mut counters = std::collections::BTreeMap::new();
    parser.feed(&tel, |f| {
        frames += 1;
        match f.message {
            Message::DebugFloatArray(m) => {
                if let Some(h) = HealthReport::from_debug_float_array(&m) {
                    health = Some(h);
                } else if let Some(slot) = last.get_mut(usize::from(m.array_id)) {
                    *slot = Some(CoefficientReport::from_debug_float_array(&m));
                }
            }
            Message::NamedValueFloat(m) => {
                let name = m.name.split(|&b| b == 0).next().unwrap_or(&[]);
                counters.insert(String::from_utf8_lossy(name).into_owned(), m.value);
            }
            _ => {}
        }
    });
    let rejected = parser.stats().bad_crc.saturating_add(parser.stats().bad_length);
    Ok(Telemetry {
        reports: last,
        health,
        frames: (frames, rejected),
        counters,
    })
}

/// The instruction counts per processed sample (`icount.bin`: [`PROBES`] little-endian `u32`
/// per sample).
fn read_counts(cnt_path: &Path) -> Result<Vec<[u32; PROBES]>, QemuError> {
    let raw = std::fs::read(cnt_path).map_err(io(cnt_path))?;
    Ok(raw
        .chunks_exact(4 * PROBES)
        .map(|rec| {
            let mut c = [0u32; PROBES];
            for (v, b) in c.iter_mut().zip(rec.chunks_exact(4)) {
                *v = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
            c
        })
        .collect())
}

/// Decodes the defmt stream with `defmt-print` (`cargo install defmt-print --locked`), if installed.
fn decode_defmt(elf: &Path, stream: &Path) -> Option<String> {
    let input = std::fs::File::open(stream).ok()?;
    let out = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .stdin(input)
        .output()
        .ok()?;
    Some(String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr))
}

/// The host's `f32` run of the firmware's path ([`emulate`], no faults, surfaces from the log) over
/// the same samples: the six reports the firmware should send at the end.
pub fn host_reports(samples: &[SensorSample<f32>]) -> Result<[CoefficientReport; idx::COUNT], QemuError> {
    Ok(emulate(&Scenario::clean(samples))?.reports)
}

/// What the QEMU board is given: the replay log, the faults to inject and, optionally, the
/// autopilot's MAVLink stream (one chunk of bytes per replay record).
#[derive(Debug, Clone, Copy)]
pub struct Scenario<'a> {
    /// The replay log.
    pub samples: &'a [SensorSample<f32>],
    /// Faults, by replay record.
    pub faults: &'a [FaultEvent],
    /// Per record, the bytes of the autopilot link fed before it is read; `None`: the surfaces,
    /// throttle, RPM and attitude come from the log.
    pub autopilot: Option<&'a [Vec<u8>]>,
}

impl<'a> Scenario<'a> {
    /// The log alone.
    pub fn clean(samples: &'a [SensorSample<f32>]) -> Self {
        Self {
            samples,
            faults: &[],
            autopilot: None,
        }
    }
}

/// A chip of the flight computer (the target of a [`Fault::Bus`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chip {
    /// ICM-42688-P: accelerometer and gyro.
    Imu = fault_chip::IMU as isize,
    /// MS4525DO: airspeed and density.
    Airspeed = fault_chip::AIRSPEED as isize,
    /// AS5600 α vane.
    AlphaVane = fault_chip::ALPHA as isize,
    /// AS5600 β vane.
    BetaVane = fault_chip::BETA as isize,
    /// The autopilot link: the record's bytes are lost.
    Autopilot = fault_chip::AUTOPILOT as isize,
}

/// A fault the QEMU board injects (firmware `board::qemu`, `faults.bin`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    /// Every read of the chip fails (a NACK, arbitration loss, SPI error…): its channels NaN.
    Bus(Chip),
    /// The channel (one [`channel`] bit) keeps its value of the first record.
    Stuck(ChannelMask),
    /// The channel reads this value (NaN, ±∞, out of range).
    Value(ChannelMask, f32),
    /// The sample is dropped as if the estimator's queue were full.
    Drop,
    /// The first record's sample is taken this many µs late.
    Late(u32),
}

/// A fault over `count` replay records from record `first` (0-based).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultEvent {
    /// First record.
    pub first: u32,
    /// Records.
    pub count: u32,
    /// The fault.
    pub fault: Fault,
}

impl FaultEvent {
    fn active(&self, k: u32) -> bool {
        k >= self.first && k - self.first < self.count
    }

    /// The firmware's fault record ([`FAULT_RECORD_BYTES`]).
    pub fn to_record(&self) -> [u8; FAULT_RECORD_BYTES] {
        let bit = |m: ChannelMask| m.trailing_zeros() as u8;
        let (kind, target, param) = match self.fault {
            Fault::Bus(c) => (fault_kind::BUS, c as u8, [0; 4]),
            Fault::Stuck(m) => (fault_kind::STUCK, bit(m), [0; 4]),
            Fault::Value(m, v) => (fault_kind::VALUE, bit(m), v.to_le_bytes()),
            Fault::Drop => (fault_kind::DROP, 0, [0; 4]),
            Fault::Late(us) => (fault_kind::LATE, 0, us.to_le_bytes()),
        };
        let mut r = [0u8; FAULT_RECORD_BYTES];
        r[0..4].copy_from_slice(&self.first.to_le_bytes());
        r[4..8].copy_from_slice(&self.count.to_le_bytes());
        r[8] = kind;
        r[9] = target;
        r[12..16].copy_from_slice(&param);
        r
    }
}

/// Writes `faults.bin`.
pub fn write_faults(path: &Path, faults: &[FaultEvent]) -> Result<(), QemuError> {
    if faults.len() > MAX_FAULTS {
        return Err(QemuError::Output(format!(
            "{} faults, the firmware reads {MAX_FAULTS}",
            faults.len()
        )));
    }
    let bytes: Vec<u8> = faults.iter().flat_map(|f| f.to_record()).collect();
    std::fs::write(path, bytes).map_err(io(path))
}

/// The autopilot's MAVLink stream for `samples`, one chunk per sample as the firmware's sensor
/// layer would find it in its receive ring: a `SERVO_OUTPUT_RAW` (PWM of the sample's surfaces and
/// throttle through [`onboard::AUTOPILOT_LINK`]'s calibration, rounded to the µs) and an
/// `ATTITUDE` every sample, an ArduPilot `RPM` every fifth, from system 1.
pub fn autopilot_stream(samples: &[SensorSample<f32>]) -> Vec<Vec<u8>> {
    let cfg = onboard::AUTOPILOT_LINK;
    let mut enc = Encoder::new(cfg.source_system_id, 1);
    let pwm = |rad: f32, c: &aerosid_core::mavlink::surfaces::ServoCalibration| -> u16 {
        (f64::from(c.pwm_neutral_us) + f64::from(rad) / f64::from(c.rad_per_us))
            .round()
            .clamp(0.0, 65535.0) as u16
    };
    let mut buf = [0u8; 300];
    samples
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let mut chunk = Vec::new();
            let mut servo = ServoOutputRaw {
                time_us: (k as u32).wrapping_mul(10_000),
                port: cfg.port,
                ..ServoOutputRaw::default()
            };
            let t = &cfg.throttle;
            servo.servo_raw_us[usize::from(cfg.elevator.channel)] = pwm(s.elevator_rad, &cfg.elevator);
            servo.servo_raw_us[usize::from(cfg.aileron.channel)] = pwm(s.aileron_rad, &cfg.aileron);
            servo.servo_raw_us[usize::from(cfg.rudder.channel)] = pwm(s.rudder_rad, &cfg.rudder);
            servo.servo_raw_us[usize::from(t.channel)] = (f64::from(t.pwm_idle_us)
                + f64::from(s.throttle) * f64::from(t.pwm_full_us - t.pwm_idle_us))
            .round()
            .clamp(0.0, 65535.0) as u16;
            if let Ok(n) = enc.encode(&servo, &mut buf) {
                chunk.extend_from_slice(&buf[..n]);
            }
            let att = Attitude {
                time_boot_ms: (k as u32).wrapping_mul(10),
                euler_rad: [s.euler_rad.x, s.euler_rad.y, s.euler_rad.z],
                ..Attitude::default()
            };
            if let Ok(n) = enc.encode(&att, &mut buf) {
                chunk.extend_from_slice(&buf[..n]);
            }
            if k % 5 == 0 {
                let rpm = Rpm {
                    rpm: [s.prop_speed_rad_s * (60.0 / std::f32::consts::TAU), 0.0],
                };
                if let Ok(n) = enc.encode(&rpm, &mut buf) {
                    chunk.extend_from_slice(&buf[..n]);
                }
            }
            chunk
        })
        .collect()
}

/// What [`emulate`] predicts the firmware sends at the end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emulation {
    /// The six coefficient reports.
    pub reports: [CoefficientReport; idx::COUNT],
    /// The health report.
    pub health: HealthReport,
    /// Samples the pipeline processed.
    pub processed: usize,
    /// The pipeline's own counters.
    pub pipeline_health: aerosid_core::aero::Health,
}

/// The host's model of the firmware on a scenario (module doc): what it sends at the end.
pub fn emulate(sc: &Scenario<'_>) -> Result<Emulation, QemuError> {
    let mut fw = FirmwareModel::new(sc)?;
    for (k, rec) in sc.samples.iter().enumerate() {
        fw.record(sc, k, rec);
    }
    Ok(fw.finish())
}

/// The chips' channels, by [`Chip`] (the autopilot has none).
const CHIP_CHANNELS: [ChannelMask; 4] = [
    channel::ACCEL | channel::GYRO,
    channel::AIRSPEED | channel::DENSITY,
    channel::ALPHA,
    channel::BETA,
];

/// The firmware's stages as [`emulate`] models them, with their counters.
struct FirmwareModel {
    pipeline: aerosid_core::aero::Pipeline<f32>,
    stuck: StuckDetector,
    sequence: SequenceCheck,
    link: Option<MavlinkSurfaces>,
    chips: [ChipHealth; 4],
    /// Per fault, the values a stuck channel holds.
    holds: Vec<[f32; 3]>,
    sampled: u32,
    dropped: u32,
    autopilot_faults: u32,
    link_lost: u32,
    stuck_now: u16,
    invalid_now: u16,
    processed: usize,
    /// How late the previous sample was taken, s (the next sample's `dt` is that much shorter).
    late_carry_s: f32,
}

/// A replay record after the faults active at it: the sample, its time stamp (µs), whether it is
/// dropped and which chips ([`Chip`]) fail.
struct Faulted {
    sample: SensorSample<f32>,
    t_us: u64,
    drop: bool,
    failing: [bool; 5],
}

impl FirmwareModel {
    fn new(sc: &Scenario<'_>) -> Result<Self, QemuError> {
        let pipeline =
            onboard::pipeline::<f32>().map_err(|e| QemuError::Output(format!("on-board configuration: {e:?}")))?;
        let link = match sc.autopilot {
            Some(_) => Some(
                MavlinkSurfaces::new(onboard::AUTOPILOT_LINK)
                    .map_err(|e| QemuError::Output(format!("autopilot link: {e:?}")))?,
            ),
            None => None,
        };
        Ok(Self {
            pipeline,
            stuck: StuckDetector::new(onboard::stuck_settings()),
            sequence: SequenceCheck::NEW,
            link,
            chips: [ChipHealth::default(); 4],
            holds: vec![[0.0; 3]; sc.faults.len()],
            sampled: 0,
            dropped: 0,
            autopilot_faults: 0,
            link_lost: 0,
            stuck_now: 0,
            invalid_now: 0,
            processed: 0,
            late_carry_s: 0.0,
        })
    }

    /// Replay record `k`: faults, the chips, the autopilot link, the stuck-sensor check, the
    /// sampler's drop, the sequence check and the pipeline.
    fn record(&mut self, sc: &Scenario<'_>, k: usize, rec: &SensorSample<f32>) {
        let Faulted {
            sample: mut s,
            t_us,
            drop,
            failing,
        } = self.inject_faults(sc.faults, k as u32, rec);
        for (c, (model, bits)) in self.chips.iter_mut().zip(CHIP_CHANNELS).enumerate() {
            if failing[c] {
                s.invalidate(bits);
            }
            model.record(!failing[c]);
        }
        if let (Some(link), Some(chunks)) = (self.link.as_mut(), sc.autopilot) {
            let chunk = chunks.get(k).map_or(&[][..], Vec::as_slice);
            if failing[Chip::Autopilot as usize] {
                self.link_lost += chunk.len() as u32;
            } else {
                link.receive(chunk, t_us);
            }
            let all = link.fill(t_us, &mut s);
            if !all {
                self.autopilot_faults += 1;
            }
        }
        self.stuck_now = self.stuck.apply(&mut s);
        self.sampled += 1;
        if drop {
            self.dropped += 1;
            return;
        }
        if self.sequence.admit(k as u32, t_us, &mut s) == Admission::Stale {
            return;
        }
        self.pipeline.process(&s);
        self.invalid_now = !self.pipeline.settings().limits.valid_channels(&s) & channel::ALL;
        self.processed += 1;
    }

    /// Record `k32` with the faults active at it applied (a stuck channel holds its value of the
    /// fault's first record; a late sample's delay is carried into the next `dt`).
    fn inject_faults(&mut self, faults: &[FaultEvent], k32: u32, rec: &SensorSample<f32>) -> Faulted {
        let mut s = *rec;
        s.dt_s -= self.late_carry_s;
        self.late_carry_s = 0.0;
        let mut t_us = (f64::from(s.t_s) * 1e6 + 0.5) as u64;
        let mut drop = false;
        let mut failing = [false; 5];
        for (f, hold) in faults.iter().zip(self.holds.iter_mut()).filter(|(f, _)| f.active(k32)) {
            match f.fault {
                Fault::Bus(c) => failing[c as usize] = true,
                Fault::Stuck(m) => {
                    let ch = s.channel_mut(m);
                    if k32 == f.first {
                        hold[..ch.len()].copy_from_slice(ch);
                    }
                    let n = ch.len();
                    ch.copy_from_slice(&hold[..n]);
                }
                Fault::Value(m, v) => s.channel_mut(m).iter_mut().for_each(|x| *x = v),
                Fault::Drop => drop = true,
                Fault::Late(us) if k32 == f.first => {
                    let late_s = us as f32 * 1e-6;
                    s.t_s += late_s;
                    s.dt_s += late_s;
                    t_us += u64::from(us);
                    self.late_carry_s = late_s;
                }
                Fault::Late(_) => {}
            }
        }
        Faulted {
            sample: s,
            t_us,
            drop,
            failing,
        }
    }

    /// What the firmware sends at the end: the coefficient reports and the health report.
    fn finish(self) -> Emulation {
        let sensors = SensorHealth {
            imu: self.chips[0],
            airspeed: self.chips[1],
            alpha_vane: self.chips[2],
            beta_vane: self.chips[3],
            autopilot_faults: self.autopilot_faults,
            link: match &self.link {
                Some(link) => LinkHealth::from_link(link, self.link_lost),
                None => LinkHealth {
                    lost: self.link_lost,
                    ..LinkHealth::default()
                },
            },
            stuck_now: self.stuck_now,
            stuck_episodes: self.stuck.health().episodes.iter().sum(),
            stuck_samples: self.stuck.health().samples.iter().sum(),
        };
        let counts = SampleCounts {
            sampled: self.sampled,
            dropped: self.dropped,
            sequence: *self.sequence.health(),
            invalid_now: self.invalid_now,
            invalid_channel: &self.pipeline.health().invalid_channel,
        };
        Emulation {
            reports: reports(&self.pipeline),
            health: health_report(&sensors, &counts),
            processed: self.processed,
            pipeline_health: *self.pipeline.health(),
        }
    }
}

/// Minimum, median and maximum of one probe over the samples where it ran (non-zero counts).
pub fn stats(counts: &[[u32; PROBES]], probe: usize) -> Option<(u32, u32, u32)> {
    let mut v: Vec<u32> = counts.iter().map(|c| c[probe]).filter(|c| *c > 0).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_unstable();
    Some((v[0], v[v.len() / 2], v[v.len() - 1]))
}
