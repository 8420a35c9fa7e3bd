//! # aerosid-read — reading a flight
//!
//! Every flight-log format aerosid takes, read to one [`MeasuredFlight`]: named channels in SI
//! units and radians on one uniform time base, the aircraft's constants, and what the reader
//! learned about the log (rates, window, warnings, where each flow channel comes from). The
//! analyses (the model-gap analysis, user models, the filter error method, the Python package)
//! start from a `MeasuredFlight` and know nothing of file formats; this crate knows nothing of
//! them. It depends on `aerosid-core` (the log row, [`aerosid_core::aero::SensorSample`]) and
//! `aerosid-sim` (the truth columns of a simulated log) only; the `aerosid` crate re-exports it
//! as `aerosid::io`.
//!
//! Reading the vendored HFB-320 flight-test record through its column map:
//!
//! ```
//! use aerosid_read::measured::Quantity;
//! use std::path::Path;
//!
//! let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data");
//! let flight = aerosid_read::read_measured(
//!     &data.join("flight/hfb320_1_10.asc"),
//!     &data.join("maps/hfb320.map"),
//! )?;
//! // 60 s at 0.1 s: 601 samples (tool/data/flight/README.md).
//! assert_eq!(flight.len(), 601);
//! assert!((flight.t_s[1] - flight.t_s[0] - 0.1).abs() < 1e-9);
//! let alpha_rad = flight.get(Quantity::Alpha).expect("the HFB-320 record logs α");
//! assert!(alpha_rad.iter().all(|a| a.abs() < 0.5));
//! # Ok::<(), aerosid_read::ReadError>(())
//! ```
//!
//! The modules:
//! * [`log`] — the project's CSV flight-log layout: one row per
//!   [`aerosid_core::aero::SensorSample`], named columns, SI units, radians.
//! * [`measured`] — measured flight data as the model-gap analysis reads it (named SI channels and
//!   the aircraft's constants), whatever file it came from.
//! * [`aircraft`] — the aircraft file (`key = value`, units in the key names) → [`measured::Aircraft`].
//! * [`colmap`] — column-map files that say how to read a whitespace-separated ASCII flight-test
//!   file (the shared HFB-320, ATTAS and Twin Otter data) or a PX4 ULog.
//! * [`project_csv`] — the project's CSV log, all or a subset of its columns → [`MeasuredFlight`].
//! * [`ulog`] — PX4 ULog (`.ulg`) through the `px4-ulog` crate, topics mapped and resampled
//!   onto a uniform time base, the in-air window found.
//! * [`dataflash`] — ArduPilot DataFlash (`.bin`), the same way.
//! * [`mat`] — MATLAB `.mat` (level 5) through the `matfile` crate, a matrix read through a
//!   column map as an ASCII file is.
//! * [`flow_angles`] — the α-free mode: α and β estimated from the ground velocity, the attitude
//!   and a wind fitted with the pitot scale (wind triangle), when no vane is logged; what it did
//!   is the record of [`flow_estimate`], which a flight's log carries.
//! * [`held`] — channels held by sample-and-hold, found and interpolated.
//! * [`quality`] — what a flight can and cannot support: rates, duration, gaps, saturation,
//!   constant columns, excitation, which coefficients are identifiable from what is logged,
//!   judged against what the analysis needs ([`quality::Needs`]).
//! * [`signal`] — a channel's white-noise level.
//!
//! [`read_measured`] is the single entry point; every reader validates its result with
//! [`MeasuredFlight::validate`], and every error is a [`ReadError`] naming the file and, where it
//! applies, the line and column (or the ULog message). The formats and the checks are documented
//! in `docs/measured-data.md`.

pub mod aircraft;
pub mod colmap;
pub mod dataflash;
pub mod flow_angles;
pub mod flow_estimate;
pub mod held;
pub mod log;
pub mod mat;
pub mod measured;
pub mod project_csv;
pub mod quality;
pub mod signal;
pub mod ulog;

use measured::{Aircraft, MeasuredFlight, ThrustSource};
use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

/// What went wrong reading measured data: `file:line:column: message`, with `line` and `column`
/// left out where they do not apply (0). An error about a whole data column (a unit check) has
/// line 0 and the column set; its message names the column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadError {
    /// The file at fault (the data file, the map or the aircraft file).
    pub file: String,
    /// Line, 1-based; 0 when not about one line (a ULog, a missing key, the whole file).
    pub line: usize,
    /// Column, 1-based (a data column, or the character position in a map or aircraft file); 0 when
    /// not about one column.
    pub column: usize,
    /// What is wrong (for a data column, it names the column's quantity; for a ULog, the message
    /// index, byte offset and topic).
    pub message: String,
}

impl ReadError {
    /// An error about `file` at `line`, `column` (0: not applicable).
    pub fn new(file: &str, line: usize, column: usize, message: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            line,
            column,
            message: message.into(),
        }
    }
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}", self.line)?;
            if self.column > 0 {
                write!(f, ":{}", self.column)?;
            }
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ReadError {}

/// One `key = value` line of a map or aircraft file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct KeyValue<'a> {
    /// Line, 1-based.
    pub line: usize,
    /// The key, trimmed.
    pub key: &'a str,
    /// Column of the key's first character, 1-based.
    pub key_col: usize,
    /// The value, trimmed (comment removed).
    pub value: &'a str,
    /// Column of the value's first character, 1-based.
    pub value_col: usize,
}

/// Splits `text` into `key = value` lines: `#` starts a comment, blank lines are skipped, and a
/// line without `=` or with an empty key or value is an error naming its line and column.
pub(crate) fn key_values<'a>(text: &'a str, file: &str) -> Result<Vec<KeyValue<'a>>, ReadError> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.split('#').next().unwrap_or("");
        if content.trim().is_empty() {
            continue;
        }
        let key_col = content.chars().take_while(|c| c.is_whitespace()).count() + 1;
        let Some(eq) = content.find('=') else {
            return Err(ReadError::new(file, line, key_col, "expected `key = value`"));
        };
        let key = content[..eq].trim();
        let rest = &content[eq + 1..];
        let value = rest.trim();
        let value_col = content[..eq + 1].chars().count() + rest.chars().take_while(|c| c.is_whitespace()).count() + 1;
        if key.is_empty() {
            return Err(ReadError::new(file, line, key_col, "missing key before `=`"));
        }
        if value.is_empty() {
            return Err(ReadError::new(
                file,
                line,
                value_col,
                format!("missing value for `{key}`"),
            ));
        }
        if let Some(prev) = out.iter().find(|kv: &&KeyValue| kv.key == key) {
            return Err(ReadError::new(
                file,
                line,
                key_col,
                format!("`{key}` already set on line {}", prev.line),
            ));
        }
        out.push(KeyValue {
            line,
            key,
            key_col,
            value,
            value_col,
        });
    }
    Ok(out)
}

/// Reads a file to a string, the error naming the file.
pub(crate) fn read_text(path: &Path) -> Result<String, ReadError> {
    std::fs::read_to_string(path).map_err(|e| ReadError::new(&path.display().to_string(), 0, 0, e.to_string()))
}

/// How to read an autopilot log (PX4 ULog, ArduPilot DataFlash): the time window, the topic
/// instances, the output rate. `Default`: the in-air window, instance 0 of every topic, the rate
/// of the rate topic.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ReadOptions {
    /// Start of the window, s, on the log's time base (boot time, as the report prints it).
    pub from_s: Option<f64>,
    /// End of the window, s.
    pub to_s: Option<f64>,
    /// Read the whole log: no automatic in-air window.
    pub whole_log: bool,
    /// The instance to read per topic (ULog multi-instance topics; DataFlash `I`/`C` instance
    /// fields); a topic not named is read at instance 0.
    pub instances: BTreeMap<String, u8>,
    /// Output rate, Hz (default: the rate topic's median rate).
    pub rate_hz: Option<f64>,
}

impl ReadOptions {
    /// Parses `TOPIC=N` (an `--instance` argument) into [`ReadOptions::instances`].
    pub fn add_instance(&mut self, spec: &str) -> Result<(), String> {
        let (topic, n) = spec
            .split_once('=')
            .ok_or_else(|| format!("--instance `{spec}`: expected TOPIC=N, e.g. airspeed=1"))?;
        let n: u8 = n
            .trim()
            .parse()
            .map_err(|_| format!("--instance `{spec}`: `{n}` is not an instance number 0…255"))?;
        self.instances.insert(topic.trim().to_string(), n);
        Ok(())
    }
}

/// A window of a log on its own clock, µs: from, to, and what chose it (for the data-quality
/// report; `None` for the whole log).
pub(crate) type LogWindow = (f64, f64, Option<String>);

impl ReadOptions {
    /// The window the user chose (`--from/--to`, or `--whole-log`) for a log whose data span
    /// `first_us…last_us`; `Ok(None)` when the reader is to find the in-air window itself. A
    /// `--from/--to` outside the data is refused with the log's span.
    pub(crate) fn chosen_window(&self, first_us: f64, last_us: f64) -> Result<Option<LogWindow>, String> {
        if self.from_s.is_some() || self.to_s.is_some() {
            let a = self.from_s.map_or(f64::NEG_INFINITY, |v| v * 1e6);
            let b = self.to_s.map_or(f64::INFINITY, |v| v * 1e6);
            if a >= b || a > last_us || b < first_us {
                return Err(format!(
                    "the window --from {} --to {} s does not overlap the log's data, {:.3}…{:.3} s (boot time, as the report prints it)",
                    self.from_s.map_or("start".into(), |v| v.to_string()),
                    self.to_s.map_or("end".into(), |v| v.to_string()),
                    first_us * 1e-6,
                    last_us * 1e-6
                ));
            }
            let what = format!(
                "--from/--to: {:.3}…{:.3} s",
                a.max(first_us) * 1e-6,
                b.min(last_us) * 1e-6
            );
            Ok(Some((a, b, Some(what))))
        } else if self.whole_log {
            Ok(Some((f64::NEG_INFINITY, f64::INFINITY, None)))
        } else {
            Ok(None)
        }
    }
}

/// The aircraft used when a log comes without an aircraft file: unit mass, inertia and geometry,
/// so that the channels can be read and their quality judged; no coefficient is scaled by it, and
/// [`measured::LogMeta::aircraft_unknown`] says so.
pub fn placeholder_aircraft() -> Aircraft {
    Aircraft {
        name: "unknown (no aircraft file: unit mass, inertia and geometry)".into(),
        mass_kg: 1.0,
        inertia_kgm2: nalgebra::Matrix3::identity(),
        wing_area_m2: 1.0,
        span_m: 1.0,
        chord_m: 1.0,
        accel_position_m: nalgebra::Vector3::zeros(),
        alpha_vane_position_m: nalgebra::Vector3::zeros(),
        beta_vane_position_m: nalgebra::Vector3::zeros(),
        airspeed_position_m: nalgebra::Vector3::zeros(),
        moment_reference_m: nalgebra::Vector3::zeros(),
        thrust: ThrustSource::Unknown,
    }
}

/// Reads the manoeuvres of a flight test as one pooled flight ([`MeasuredFlight::pool`]): every
/// file with the same companion and options, each cut to every `segment` (seconds from its first
/// sample; none: the whole file), each part split where its time jumps
/// ([`MeasuredFlight::split_at_jumps`]), the pieces sorted canonically. One file without
/// segments or jumps is returned as read.
///
/// The three ATTAS manoeuvres (aileron, elevator, rudder inputs) pooled into one flight, as
/// `aerosid gaps --data A --data B --data C --with attas.map` reads them:
///
/// ```
/// use aerosid_read::{read_pooled, ReadOptions};
/// use std::path::Path;
///
/// let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data");
/// let files: Vec<_> = ["fAttasAil1_pqrDot.asc", "fAttasElv1_pqrDot.asc", "fAttasRud1_pqrDot.asc"]
///     .iter()
///     .map(|f| data.join("flight").join(f))
///     .collect();
/// let map = data.join("maps/attas.map");
/// let pooled = read_pooled(&files, Some(&map), &[], &ReadOptions::default())?;
/// assert_eq!(pooled.log.pieces.len(), 3);
/// assert_eq!(pooled.log.pieces.last().map(|p| p.end), Some(pooled.len()));
/// # Ok::<(), String>(())
/// ```
pub fn read_pooled(
    data: &[std::path::PathBuf],
    companion: Option<&Path>,
    segments: &[(f64, f64)],
    opts: &ReadOptions,
) -> Result<MeasuredFlight, String> {
    let mut parts = Vec::new();
    for file in data {
        let flight = read_measured_with(file, companion, opts).map_err(|e| e.to_string())?;
        let windows: Vec<(MeasuredFlight, String)> = if segments.is_empty() {
            vec![(flight, String::new())]
        } else {
            segments
                .iter()
                .map(|&(a, b)| {
                    flight
                        .window(a, b)
                        .map(|w| (w, format!("--segment {a}:{b}")))
                        .ok_or_else(|| {
                            format!(
                                "{}: --segment {a}:{b} holds fewer than two samples (the file spans {:.3} s from its first sample); give FROM:TO in seconds from the first sample",
                                file.display(),
                                flight.t_s.last().unwrap_or(&0.0) - flight.t_s.first().unwrap_or(&0.0)
                            )
                        })
                })
                .collect::<Result<_, _>>()?
        };
        for (w, seg) in windows {
            for (piece, why) in w.split_at_jumps() {
                let cut = if seg.is_empty() {
                    why
                } else if why == "the file's start" {
                    seg.clone()
                } else {
                    format!("{seg}, then {why}")
                };
                parts.push((piece, cut));
            }
        }
    }
    MeasuredFlight::pool(parts)
}

/// Reads measured flight data with the default [`ReadOptions`] (see [`read_measured_with`]).
pub fn read_measured(data: &Path, companion: &Path) -> Result<MeasuredFlight, ReadError> {
    read_measured_with(data, Some(companion), &ReadOptions::default())
}

/// Reads measured flight data, dispatching on the data file's extension:
/// * `.csv` — the project's CSV log ([`project_csv`]); `companion` is an aircraft file;
/// * `.asc` / `.txt` / `.dat` — a whitespace-separated ASCII file; `companion` is its column map
///   ([`colmap`], `format = ascii`), which names the aircraft file;
/// * `.mat` — a MATLAB level-5 file ([`mat`]); `companion` is a column map as for ASCII;
/// * `.ulg` — a PX4 ULog ([`ulog`]); `companion` is an aircraft file (the standard topics only) or a
///   ULog column map (`format = ulog`: the standard topics plus the surfaces and throttle it maps);
/// * `.bin` — an ArduPilot DataFlash log ([`dataflash`]); `companion` an aircraft file.
///
/// The companion's kind is told by its extension: `.aircraft` or `.map`. An autopilot log (`.ulg`,
/// `.bin`) may come without one: its channels are read with a placeholder aircraft
/// ([`placeholder_aircraft`]), which the quality assessment reports.
///
/// A PX4 ULog read without a companion file, its whole log instead of the in-air window:
///
/// ```
/// use aerosid_read::{read_measured_with, ReadOptions};
/// use aerosid_read::measured::Quantity;
/// use std::path::Path;
///
/// let log = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tool/data/logs/pyulog_sample_log_small.ulg");
/// let opts = ReadOptions { whole_log: true, ..ReadOptions::default() };
/// let flight = read_measured_with(&log, None, &opts)?;
/// assert!(flight.log.aircraft_unknown);
/// assert!(flight.get(Quantity::PitchRate).is_some());
/// # Ok::<(), aerosid_read::ReadError>(())
/// ```
pub fn read_measured_with(
    data: &Path,
    companion: Option<&Path>,
    opts: &ReadOptions,
) -> Result<MeasuredFlight, ReadError> {
    let data_ext = extension(data);
    let Some(companion) = companion else {
        return read_without_companion(data, data_ext.as_deref(), opts);
    };
    let companion_is_map = match extension(companion).as_deref() {
        Some("map") => true,
        Some("aircraft") => false,
        _ => {
            return Err(companion_error(
                companion,
                "the companion file must be a column map (`.map`) or an aircraft file (`.aircraft`)",
            ))
        }
    };
    match (data_ext.as_deref(), companion_is_map) {
        (Some("csv"), true) => Err(companion_error(
            companion,
            "a project CSV log has named SI columns and needs an aircraft file, not a column map",
        )),
        (Some("csv"), false) => project_csv::read_project_csv(data, aircraft::read_aircraft(companion)?),
        (Some("asc") | Some("txt") | Some("dat"), false) => Err(companion_error(
            companion,
            "an ASCII flight-test file needs a column map (`.map`) saying which column is which",
        )),
        (Some("asc") | Some("txt") | Some("dat"), true) => colmap::read_ascii(data, &colmap::read_map(companion)?),
        (Some("mat"), false) => Err(companion_error(
            companion,
            "a `.mat` file needs a column map (`.map`, `format = ascii`) saying which column of which matrix is which",
        )),
        (Some("mat"), true) => mat::read_mat(data, &colmap::read_map(companion)?),
        (Some("ulg"), true) => ulog::read_ulog_with(data, &colmap::read_map(companion)?, opts),
        (Some("ulg"), false) => {
            let aircraft = aircraft::read_aircraft(companion)?;
            ulog::read_ulog_with(data, &colmap::ColumnMap::ulog_default(aircraft), opts)
        }
        (Some("bin"), true) => Err(companion_error(
            companion,
            "an ArduPilot DataFlash log is read with an aircraft file (`.aircraft`); its messages are built in",
        )),
        (Some("bin"), false) => dataflash::read_dataflash(data, aircraft::read_aircraft(companion)?, opts),
        _ => Err(ReadError::new(
            &data.display().to_string(),
            0,
            0,
            "unknown data file type (expected .csv, .asc/.txt/.dat, .mat, .ulg or .bin)",
        )),
    }
}

/// A file's extension, lower case.
fn extension(p: &Path) -> Option<String> {
    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// An error of the companion file as a whole.
fn companion_error(companion: &Path, message: &str) -> ReadError {
    ReadError::new(&companion.display().to_string(), 0, 0, message)
}

/// A log read without a companion file (`.ulg` and `.bin` only): the placeholder aircraft, and
/// the log says so.
fn read_without_companion(
    data: &Path,
    data_ext: Option<&str>,
    opts: &ReadOptions,
) -> Result<MeasuredFlight, ReadError> {
    let mut f = match data_ext {
        Some("ulg") => ulog::read_ulog_with(data, &colmap::ColumnMap::ulog_default(placeholder_aircraft()), opts)?,
        Some("bin") => dataflash::read_dataflash(data, placeholder_aircraft(), opts)?,
        _ => {
            return Err(ReadError::new(
                &data.display().to_string(),
                0,
                0,
                "this data file needs a companion file (`--with`): a column map (`.map`) or an aircraft file (`.aircraft`); only `.ulg` and `.bin` logs can be read without one",
            ))
        }
    };
    f.log.aircraft_unknown = true;
    Ok(f)
}
