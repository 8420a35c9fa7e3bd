//! The firmware under QEMU: build the `qemu` board, replay a flight log through it, and read back
//! what it sent (MAVLink on USART1), what it logged (defmt over semihosting) and what each sample
//! cost (TIM2 instruction counts). Used by `tests/qemu_replay.rs` and `aerosid qemu`.
//!
//! The run: `qemu-system-arm -machine netduinoplus2 -icount shift=0,align=off,sleep=off` (one TIM2
//! tick per guest instruction; TOOLCHAIN.md) in a scratch folder holding `replay.bin`; the firmware
//! writes `icount.bin` there over semihosting and its telemetry to `-serial file:telemetry.bin`.

use aerosid_core::aero::{model::idx, onboard, SensorSample};
use aerosid_core::mavlink::{telemetry::reports, CoefficientReport, Message, Parser};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Probes per sample in `icount.bin`: whole step, synthesis, six coefficients (firmware's
/// `estimate::PROBES`).
pub const PROBES: usize = 8;

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
    /// MAVLink frames received, and frames the parser rejected.
    pub frames: (u32, u32),
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
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    write_replay(&dir.join("replay.bin"), samples)?;
    for f in ["icount.bin", "telemetry.bin", "defmt.bin"] {
        let _ = std::fs::remove_file(dir.join(f));
    }
    let defmt_path = dir.join("defmt.bin");
    let defmt_out = std::fs::File::create(&defmt_path).map_err(io(&defmt_path))?;
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
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if start.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(QemuError::Output(format!("QEMU did not finish within {timeout:?}")));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(QemuError::Tool(format!("waiting for QEMU: {e}"))),
        }
    };

    let tel_path = dir.join("telemetry.bin");
    let tel = std::fs::read(&tel_path).map_err(io(&tel_path))?;
    let mut parser = Parser::new();
    let mut last: [Option<CoefficientReport>; idx::COUNT] = [None; idx::COUNT];
    let mut frames = 0u32;
    parser.feed(&tel, |f| {
        frames += 1;
        if let Message::DebugFloatArray(m) = f.message {
            if let Some(slot) = last.get_mut(usize::from(m.array_id)) {
                *slot = Some(CoefficientReport::from_debug_float_array(&m));
            }
        }
    });
    let rejected = parser.stats().bad_crc.saturating_add(parser.stats().bad_length);

    let cnt_path = dir.join("icount.bin");
    let raw = std::fs::read(&cnt_path).map_err(io(&cnt_path))?;
    let counts = raw
        .chunks_exact(4 * PROBES)
        .map(|rec| {
            let mut c = [0u32; PROBES];
            for (v, b) in c.iter_mut().zip(rec.chunks_exact(4)) {
                *v = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
            c
        })
        .collect();

    let log = decode_defmt(elf, &defmt_path).unwrap_or_default();
    Ok(QemuRun {
        reports: last,
        frames: (frames, rejected),
        counts,
        log,
        exit_code: status.code(),
    })
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

/// The host's `f32` run of the on-board pipeline ([`onboard::pipeline`]) over the same samples:
/// the six reports the firmware should send at the end.
pub fn host_reports(samples: &[SensorSample<f32>]) -> Result<[CoefficientReport; idx::COUNT], QemuError> {
    let mut p = onboard::pipeline::<f32>().map_err(|e| QemuError::Output(format!("on-board configuration: {e:?}")))?;
    for s in samples {
        p.process(s);
    }
    Ok(reports(&p))
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
