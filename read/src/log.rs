//! The CSV flight-log layout: a header of named columns, one row per
//! [`SensorSample`], SI units and radians. Column names are the field names of `SensorSample`
//! (core/src/aero/mod.rs), vectors as `<name>_x`, `_y`, `_z` — see [`COLUMNS`].
//!
//! Writing uses Rust's shortest round-trip `{:e}` formatting, so a write/read round trip is exact.
//! Reading accepts the columns in any order and ignores unknown columns (such as the `truth_…`
//! columns of [`write_log_with_truth`]); it refuses a missing column, a cell that is not a finite
//! number, a row with the wrong number of cells and a time that does not increase strictly, each
//! with an error naming the file, the line (1-based, the header is line 1) and the column.

use aerosid_core::aero::SensorSample;
use aerosid_sim::TruthSample;
use std::fmt;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

/// The columns of a sensor log, in the order they are written.
pub const COLUMNS: [&str; N_COLUMNS] = [
    "t_s",
    "dt_s",
    "accel_mps2_x",
    "accel_mps2_y",
    "accel_mps2_z",
    "gyro_rad_s_x",
    "gyro_rad_s_y",
    "gyro_rad_s_z",
    "airspeed_mps",
    "alpha_rad",
    "beta_rad",
    "euler_rad_x",
    "euler_rad_y",
    "euler_rad_z",
    "prop_speed_rad_s",
    "elevator_rad",
    "aileron_rad",
    "rudder_rad",
    "throttle",
    "air_density_kgpm3",
];

/// The number of sensor columns.
pub const N_COLUMNS: usize = aerosid_core::aero::SAMPLE_FIELDS;

/// The truth columns written by [`write_log_with_truth`] after the sensor columns.
pub const TRUTH_COLUMNS: [&str; 41] = [
    "truth_coef_lift",
    "truth_coef_drag",
    "truth_coef_side",
    "truth_coef_roll",
    "truth_coef_pitch",
    "truth_coef_yaw",
    "truth_airspeed_mps",
    "truth_alpha_rad",
    "truth_beta_rad",
    "truth_air_density_kgpm3",
    "truth_qbar_pa",
    "truth_gyro_rad_s_x",
    "truth_gyro_rad_s_y",
    "truth_gyro_rad_s_z",
    "truth_euler_rad_x",
    "truth_euler_rad_y",
    "truth_euler_rad_z",
    "truth_accel_mps2_x",
    "truth_accel_mps2_y",
    "truth_accel_mps2_z",
    "truth_aero_force_n_x",
    "truth_aero_force_n_y",
    "truth_aero_force_n_z",
    "truth_aero_moment_nm_x",
    "truth_aero_moment_nm_y",
    "truth_aero_moment_nm_z",
    "truth_thrust_force_n_x",
    "truth_thrust_force_n_y",
    "truth_thrust_force_n_z",
    "truth_thrust_moment_nm_x",
    "truth_thrust_moment_nm_y",
    "truth_thrust_moment_nm_z",
    "truth_rate_dot_rad_s2_x",
    "truth_rate_dot_rad_s2_y",
    "truth_rate_dot_rad_s2_z",
    "truth_position_ned_m_x",
    "truth_position_ned_m_y",
    "truth_position_ned_m_z",
    "truth_gust_body_mps_x",
    "truth_gust_body_mps_y",
    "truth_gust_body_mps_z",
];

/// What went wrong reading or writing a log. Every variant names the file.
#[derive(Debug, Clone, PartialEq)]
pub enum LogError {
    /// The operating system refused (open, read, write).
    Io {
        /// The file.
        file: String,
        /// The system's message.
        message: String,
    },
    /// No header line.
    Empty {
        /// The file.
        file: String,
    },
    /// A required column is not in the header.
    MissingColumn {
        /// The file.
        file: String,
        /// The column's name.
        column: String,
    },
    /// A column name appears twice in the header.
    DuplicateColumn {
        /// The file.
        file: String,
        /// The column's name.
        column: String,
    },
    /// A row has a different number of cells than the header.
    FieldCount {
        /// The file.
        file: String,
        /// Line, 1-based.
        line: usize,
        /// Cells in the header.
        expected: usize,
        /// Cells in the row.
        found: usize,
    },
    /// A cell is not a finite number.
    BadCell {
        /// The file.
        file: String,
        /// Line, 1-based.
        line: usize,
        /// Column, 1-based.
        column: usize,
        /// The column's name.
        name: String,
        /// The cell's text.
        text: String,
    },
    /// `t_s` does not increase strictly.
    NonMonotonicTime {
        /// The file.
        file: String,
        /// Line, 1-based.
        line: usize,
        /// The time on this line, s.
        t_s: f64,
        /// The time on the previous row, s.
        previous_s: f64,
    },
    /// [`write_log_with_truth`] got different numbers of samples and truth records.
    LengthMismatch {
        /// The file.
        file: String,
        /// Samples.
        samples: usize,
        /// Truth records.
        truth: usize,
    },
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { file, message } => write!(f, "{file}: {message}"),
            Self::Empty { file } => write!(f, "{file}: empty log (no header line)"),
            Self::MissingColumn { file, column } => write!(f, "{file}: missing column '{column}'"),
            Self::DuplicateColumn { file, column } => write!(f, "{file}: duplicate column '{column}'"),
            Self::FieldCount {
                file,
                line,
                expected,
                found,
            } => {
                write!(f, "{file}:{line}: {found} cells, the header has {expected}")
            }
            Self::BadCell {
                file,
                line,
                column,
                name,
                text,
            } => {
                write!(
                    f,
                    "{file}:{line}:{column}: column '{name}': '{text}' is not a finite number"
                )
            }
            Self::NonMonotonicTime {
                file,
                line,
                t_s,
                previous_s,
            } => {
                write!(
                    f,
                    "{file}:{line}: time {t_s} s does not increase (previous row {previous_s} s)"
                )
            }
            Self::LengthMismatch { file, samples, truth } => {
                write!(f, "{file}: {samples} samples but {truth} truth records")
            }
        }
    }
}

impl std::error::Error for LogError {}

fn sensor_row(s: &SensorSample<f64>) -> [f64; N_COLUMNS] {
    // The CSV column order is the core's field order (`SensorSample::to_fields`).
    s.to_fields()
}

fn from_row(r: &[f64; N_COLUMNS]) -> SensorSample<f64> {
    SensorSample::from_fields(r)
}

fn truth_row(t: &TruthSample) -> [f64; 41] {
    let e = &t.eval;
    let c = e.coefficients;
    let v = [
        &t.state.rate_rad_s,
        &t.ideal.euler_rad,
        &e.specific_force_mps2,
        &e.aero_force_n,
        &e.aero_moment_nm,
        &e.thrust_force_n,
        &e.thrust_moment_nm,
        &e.rate_dot_rad_s2,
        &t.state.position_ned_m,
        &t.gust_body_mps,
    ];
    let head = [
        c.lift,
        c.drag,
        c.side,
        c.roll,
        c.pitch,
        c.yaw,
        e.airspeed_mps,
        e.alpha_rad,
        e.beta_rad,
        e.density_kgpm3,
        e.qbar_pa,
    ];
    core::array::from_fn(|i| if i < 11 { head[i] } else { v[(i - 11) / 3][(i - 11) % 3] })
}

fn io_err(file: &str, e: &std::io::Error) -> LogError {
    LogError::Io {
        file: file.to_string(),
        message: e.to_string(),
    }
}

fn write_cells<W: Write>(w: &mut W, file: &str, cells: &[f64]) -> Result<(), LogError> {
    let mut line = String::with_capacity(cells.len() * 24);
    for (i, x) in cells.iter().enumerate() {
        if i > 0 {
            line.push(',');
        }
        line.push_str(&format!("{x:e}"));
    }
    line.push('\n');
    w.write_all(line.as_bytes()).map_err(|e| io_err(file, &e))
}

/// Writes a sensor log to `w` (`file` names it in errors).
pub fn write_log<W: Write>(w: &mut W, file: &str, samples: &[SensorSample<f64>]) -> Result<(), LogError> {
    let header = COLUMNS.join(",") + "\n";
    w.write_all(header.as_bytes()).map_err(|e| io_err(file, &e))?;
    for s in samples {
        write_cells(w, file, &sensor_row(s))?;
    }
    w.flush().map_err(|e| io_err(file, &e))
}

/// Writes a sensor log with the [`TRUTH_COLUMNS`] appended (still readable by [`read_log`]).
pub fn write_log_with_truth<W: Write>(
    w: &mut W,
    file: &str,
    samples: &[SensorSample<f64>],
    truth: &[TruthSample],
) -> Result<(), LogError> {
    if samples.len() != truth.len() {
        return Err(LogError::LengthMismatch {
            file: file.to_string(),
            samples: samples.len(),
            truth: truth.len(),
        });
    }
    let mut header = COLUMNS.join(",");
    header.push(',');
    header.push_str(&TRUTH_COLUMNS.join(","));
    header.push('\n');
    w.write_all(header.as_bytes()).map_err(|e| io_err(file, &e))?;
    for (s, t) in samples.iter().zip(truth) {
        let mut cells = sensor_row(s).to_vec();
        cells.extend_from_slice(&truth_row(t));
        write_cells(w, file, &cells)?;
    }
    w.flush().map_err(|e| io_err(file, &e))
}

/// Writes a sensor log to the file at `path`.
pub fn write_log_file(path: &Path, samples: &[SensorSample<f64>]) -> Result<(), LogError> {
    let name = path.display().to_string();
    let f = std::fs::File::create(path).map_err(|e| io_err(&name, &e))?;
    write_log(&mut std::io::BufWriter::new(f), &name, samples)
}

/// Reads a sensor log from `r` (`file` names it in errors).
///
/// A log written with [`write_log`] reads back exactly:
///
/// ```
/// use aerosid_core::aero::SensorSample;
/// use aerosid_read::log::{read_log, write_log};
///
/// let samples: Vec<SensorSample<f64>> = (0..3)
///     .map(|i| SensorSample { t_s: 0.01 * i as f64, dt_s: 0.01, airspeed_mps: 18.5, ..Default::default() })
///     .collect();
/// let mut csv = Vec::new();
/// write_log(&mut csv, "flight.csv", &samples)?;
/// assert_eq!(read_log(csv.as_slice(), "flight.csv")?, samples);
/// # Ok::<(), aerosid_read::log::LogError>(())
/// ```
pub fn read_log<R: std::io::Read>(r: R, file: &str) -> Result<Vec<SensorSample<f64>>, LogError> {
    let mut lines = BufReader::new(r).lines();
    let header = match lines.next() {
        Some(l) => l.map_err(|e| io_err(file, &e))?,
        None => return Err(LogError::Empty { file: file.to_string() }),
    };
    let names: Vec<&str> = header.trim_end_matches('\r').split(',').map(str::trim).collect();
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(LogError::DuplicateColumn {
                file: file.to_string(),
                column: n.to_string(),
            });
        }
    }
    let mut index = [0usize; N_COLUMNS];
    for (k, col) in COLUMNS.iter().enumerate() {
        index[k] = names
            .iter()
            .position(|n| n == col)
            .ok_or_else(|| LogError::MissingColumn {
                file: file.to_string(),
                column: col.to_string(),
            })?;
    }
    let mut out = Vec::new();
    let mut previous: Option<f64> = None;
    for (i, l) in lines.enumerate() {
        let line_no = i + 2;
        let l = l.map_err(|e| io_err(file, &e))?;
        let l = l.trim_end_matches('\r');
        if l.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = l.split(',').collect();
        if cells.len() != names.len() {
            return Err(LogError::FieldCount {
                file: file.to_string(),
                line: line_no,
                expected: names.len(),
                found: cells.len(),
            });
        }
        let mut row = [0.0; N_COLUMNS];
        for (k, &j) in index.iter().enumerate() {
            let text = cells[j].trim();
            row[k] = match text.parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => {
                    return Err(LogError::BadCell {
                        file: file.to_string(),
                        line: line_no,
                        column: j + 1,
                        name: names[j].to_string(),
                        text: text.to_string(),
                    })
                }
            };
        }
        if let Some(p) = previous {
            if row[0] <= p {
                return Err(LogError::NonMonotonicTime {
                    file: file.to_string(),
                    line: line_no,
                    t_s: row[0],
                    previous_s: p,
                });
            }
        }
        previous = Some(row[0]);
        out.push(from_row(&row));
    }
    Ok(out)
}

/// Reads a sensor log from the file at `path`.
pub fn read_log_file(path: &Path) -> Result<Vec<SensorSample<f64>>, LogError> {
    let name = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| io_err(&name, &e))?;
    read_log(f, &name)
}
