//! The project's CSV log ([`super::log`]) as a [`MeasuredFlight`], with all or only some channels.
//!
//! A log with every column of [`COLUMNS`] (what `aerosid simulate` writes) is read by
//! [`super::log::read_log`] and turned into a flight by [`MeasuredFlight::from_samples`]. A log with
//! only some of them (a real UAV that has no vanes, say) is read here: `t_s` is required, every
//! other column is optional, and the quantities that [`SensorSample`] does not carry have columns
//! of their own ([`csv_column`]: `roll_accel_rad_s2`, `thrust_n`, `dynamic_pressure_pa`, …).
//! Unknown columns (such as `dt_s` and the simulator's `truth_…` columns) are ignored. Either way
//! the flight is checked by [`MeasuredFlight::validate`], errors naming the line and column.
//!
//! An estimator's α, β or airspeed (no vane, no pitot) has a column of its own,
//! [`ESTIMATED_COLUMNS`] (`alpha_est_rad`, `beta_est_rad`, `airspeed_est_mps`): read as the same
//! quantity, with its origin recorded as estimated ([`super::measured::Origin`]). Channels held
//! between samples (sample-and-hold staircases) are found and interpolated at their true rate
//! ([`super::held`]).
//!
//! [`SensorSample`]: aerosid_core::aero::SensorSample

use super::log::{read_log, LogError, COLUMNS};
use super::measured::{Aircraft, MeasuredFlight, Quantity};
use super::{read_text, ReadError};
use std::collections::BTreeMap;
use std::path::Path;

/// The CSV column of each quantity: the [`COLUMNS`] name where the sensor log has one, else the
/// quantity's name with its SI unit.
pub fn csv_column(q: Quantity) -> &'static str {
    use Quantity::*;
    match q {
        AccelX => "accel_mps2_x",
        AccelY => "accel_mps2_y",
        AccelZ => "accel_mps2_z",
        RollRate => "gyro_rad_s_x",
        PitchRate => "gyro_rad_s_y",
        YawRate => "gyro_rad_s_z",
        Airspeed => "airspeed_mps",
        Alpha => "alpha_rad",
        Beta => "beta_rad",
        Roll => "euler_rad_x",
        Pitch => "euler_rad_y",
        Yaw => "euler_rad_z",
        PropSpeed => "prop_speed_rad_s",
        Elevator => "elevator_rad",
        Aileron => "aileron_rad",
        Rudder => "rudder_rad",
        Throttle => "throttle",
        AirDensity => "air_density_kgpm3",
        RollAccel => "roll_accel_rad_s2",
        PitchAccel => "pitch_accel_rad_s2",
        YawAccel => "yaw_accel_rad_s2",
        Flap => "flap_rad",
        Thrust => "thrust_n",
        ThrustDifference => "thrust_difference_n",
        DynamicPressure => "dynamic_pressure_pa",
        Altitude => "altitude_m",
        Mach => "mach",
        VelocityNorth => "vel_ned_mps_n",
        VelocityEast => "vel_ned_mps_e",
        VelocityDown => "vel_ned_mps_d",
        WindNorth => "wind_ned_mps_n",
        WindEast => "wind_ned_mps_e",
    }
}

/// The columns that hold an estimator's output rather than a sensor's reading: the same quantity
/// as the plain column (`alpha_rad`, `beta_rad`, `airspeed_mps`), marked
/// [`super::measured::Origin::Estimated`] (an autopilot's α from its inertial solution and wind
/// estimate, a synthetic airspeed). When a log has both, the sensor's column is read and the
/// estimate is ignored with a warning.
pub const ESTIMATED_COLUMNS: [(Quantity, &str); 3] = [
    (Quantity::Alpha, "alpha_est_rad"),
    (Quantity::Beta, "beta_est_rad"),
    (Quantity::Airspeed, "airspeed_est_mps"),
];

/// The column a quantity is read from in a log with the header `names`: its plain column, else
/// its estimated one ([`ESTIMATED_COLUMNS`]).
fn column_in(q: Quantity, names: &[&str]) -> Option<(usize, &'static str)> {
    let plain = csv_column(q);
    let est = ESTIMATED_COLUMNS.iter().find(|(e, _)| *e == q).map(|(_, n)| *n);
    [Some(plain), est]
        .into_iter()
        .flatten()
        .find_map(|c| names.iter().position(|n| *n == c).map(|j| (j, c)))
}

fn from_log_error(e: LogError) -> ReadError {
    match e {
        LogError::Io { file, message } => ReadError::new(&file, 0, 0, message),
        LogError::Empty { file } => ReadError::new(&file, 1, 0, "empty log (no header line)"),
        LogError::MissingColumn { file, column } => ReadError::new(&file, 1, 0, format!("missing column '{column}'")),
        LogError::DuplicateColumn { file, column } => {
            ReadError::new(&file, 1, 0, format!("duplicate column '{column}'"))
        }
        LogError::FieldCount {
            file,
            line,
            expected,
            found,
        } => ReadError::new(&file, line, 0, format!("{found} cells, the header has {expected}")),
        LogError::BadCell {
            file,
            line,
            column,
            name,
            text,
        } => ReadError::new(
            &file,
            line,
            column,
            format!("column '{name}': '{text}' is not a finite number"),
        ),
        LogError::NonMonotonicTime {
            file,
            line,
            t_s,
            previous_s,
        } => ReadError::new(
            &file,
            line,
            1,
            format!("column 't_s': time {t_s} s does not increase (previous row {previous_s} s)"),
        ),
        LogError::LengthMismatch { file, samples, truth } => {
            ReadError::new(&file, 0, 0, format!("{samples} samples but {truth} truth records"))
        }
    }
}

/// Reads a project CSV log (all or some channels) with its aircraft.
pub fn read_project_csv(path: &Path, aircraft: Aircraft) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    parse_project_csv(&text, &file, aircraft)
}

/// [`read_project_csv`] on text already read (`file` names it in errors).
pub fn parse_project_csv(text: &str, file: &str, aircraft: Aircraft) -> Result<MeasuredFlight, ReadError> {
    let Some(header) = text.lines().next() else {
        return Err(ReadError::new(file, 1, 0, "empty log (no header line)"));
    };
    let names: Vec<&str> = header.trim_end_matches('\r').split(',').map(str::trim).collect();
    let extra: Vec<Quantity> = Quantity::ALL
        .iter()
        .copied()
        .filter(|q| !COLUMNS.contains(&csv_column(*q)) && names.contains(&csv_column(*q)))
        .collect();
    let complete = COLUMNS.iter().all(|c| names.contains(c));
    // Data rows' line numbers (1-based), for mapping a sample index back to its line.
    let row_lines: Vec<usize> = text
        .lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, _)| i + 1)
        .collect();
    let flight = if complete && extra.is_empty() {
        let samples = read_log(text.as_bytes(), file).map_err(from_log_error)?;
        MeasuredFlight::from_samples(file, &samples, aircraft)
    } else {
        read_subset(text, file, &names, aircraft)?
    };
    flight.validate().map_err(|inv| {
        let line = inv.sample.and_then(|i| row_lines.get(i)).copied().unwrap_or(0);
        let (column, col_name) = match inv.quantity {
            Some(q) => column_in(q, &names).map_or((0, csv_column(q)), |(j, c)| (j + 1, c)),
            None => (names.iter().position(|n| *n == "t_s").map_or(0, |j| j + 1), "t_s"),
        };
        ReadError::new(file, line, column, format!("column '{col_name}': {}", inv.message))
    })?;
    let mut flight = flight;
    for (q, est) in ESTIMATED_COLUMNS {
        if !names.contains(&est) {
            continue;
        }
        if names.contains(&csv_column(q)) {
            flight.log.warnings.push(format!(
                "column '{est}' (an estimate of {q}) ignored: the log also has '{}', the sensor's reading, which is read",
                csv_column(q)
            ));
        } else {
            flight
                .log
                .set_estimated(q, &format!("column '{est}' of the log (an estimator's output)"));
        }
    }
    super::held::resolve(&mut flight);
    Ok(flight)
}

fn read_subset(text: &str, file: &str, names: &[&str], aircraft: Aircraft) -> Result<MeasuredFlight, ReadError> {
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(ReadError::new(file, 1, i + 1, format!("duplicate column '{n}'")));
        }
    }
    let Some(t_col) = names.iter().position(|n| *n == "t_s") else {
        return Err(ReadError::new(file, 1, 0, "missing column 't_s'"));
    };
    let cols: Vec<(Quantity, usize)> = Quantity::ALL
        .iter()
        .filter_map(|q| column_in(*q, names).map(|(j, _)| (*q, j)))
        .collect();
    if cols.is_empty() {
        return Err(ReadError::new(
            file,
            1,
            0,
            "no measured channel among the columns (see `csv_column` / docs/measured-data.md)",
        ));
    }
    let mut t_s = Vec::new();
    let mut data: Vec<Vec<f64>> = vec![Vec::new(); cols.len()];
    for (i, l) in text.lines().enumerate().skip(1) {
        let line = i + 1;
        let l = l.trim_end_matches('\r');
        if l.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = l.split(',').collect();
        if cells.len() != names.len() {
            return Err(ReadError::new(
                file,
                line,
                0,
                format!("{} cells, the header has {}", cells.len(), names.len()),
            ));
        }
        let cell = |j: usize| -> Result<f64, ReadError> {
            let text = cells[j].trim();
            match text.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(ReadError::new(
                    file,
                    line,
                    j + 1,
                    format!("column '{}': '{text}' is not a finite number", names[j]),
                )),
            }
        };
        t_s.push(cell(t_col)?);
        for (k, (_, j)) in cols.iter().enumerate() {
            data[k].push(cell(*j)?);
        }
    }
    let channels: BTreeMap<Quantity, Vec<f64>> = cols.iter().map(|(q, _)| *q).zip(data).collect();
    Ok(MeasuredFlight {
        source: file.to_string(),
        t_s,
        channels,
        aircraft,
        log: Default::default(),
    })
}
