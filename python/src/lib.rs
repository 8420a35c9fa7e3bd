//! `aerosid._aerosid`: the Rust side of the Python package. Each function is a thin call into the
//! `aerosid` library (the CLI's functions, with the CLI's error messages); the Python module
//! `aerosid` (aerosid/__init__.py) wraps them into the documented API: pandas frames, dicts of the
//! JSON documents, defaults. The long computations release the GIL, so that threads (a Dask
//! worker's) run them side by side.

use aerosid::batch::{BatchSettings, Row, Status};
use aerosid::gaps::airdata::AirDataChoice;
use aerosid::gaps::{GapSettings, Levels, LowRateMethod};
use aerosid_core::{Estimator, Gtls as CoreGtls, GtlsSettings};
use aerosid_read::flow_angles::FlowAngleChoice;
use aerosid_read::measured::{LogMeta, MeasuredFlight, Quantity};
use aerosid_read::ReadOptions;
use nalgebra::{SMatrix, SVector};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::path::PathBuf;

create_exception!(
    _aerosid,
    AerosidError,
    PyValueError,
    "An error of aerosid: a file that cannot be read (file, line, column and the fix named), an analysis that cannot run, or a setting out of range. The message is the command line's."
);

fn err(e: impl std::fmt::Display) -> PyErr {
    AerosidError::new_err(e.to_string())
}

/// The unit suffix of a quantity's column (`pitch_rate_rad_s`): the project's names (units in
/// names, `/` as `p` where the unit is a ratio of plain units, as in `airspeed_mps`); none for a
/// pure number.
fn unit_suffix(q: Quantity) -> &'static str {
    match q.si_unit() {
        "m/s2" => "_mps2",
        "rad/s" => "_rad_s",
        "rad/s2" => "_rad_s2",
        "m/s" => "_mps",
        "rad" => "_rad",
        "N" => "_n",
        "Pa" => "_pa",
        "kg/m3" => "_kgpm3",
        "m" => "_m",
        _ => "",
    }
}

/// The column name of a quantity in a frame of [`read`].
fn column(q: Quantity) -> String {
    format!("{}{}", q.name(), unit_suffix(q))
}

/// The quantity of a column name (with or without its unit suffix).
fn quantity_of(column_name: &str) -> Option<Quantity> {
    Quantity::ALL
        .iter()
        .copied()
        .find(|&q| column(q) == column_name || q.name() == column_name)
}

/// Every quantity's column name with its SI unit, as `read` names them.
#[pyfunction]
fn columns() -> Vec<(String, &'static str)> {
    Quantity::ALL.iter().map(|&q| (column(q), q.si_unit())).collect()
}

/// The read options of the keyword arguments (`TOPIC=N` instances as in `--instance`).
fn read_options(
    from_s: Option<f64>,
    to_s: Option<f64>,
    whole_log: bool,
    rate_hz: Option<f64>,
    instances: Vec<String>,
) -> PyResult<ReadOptions> {
    let mut o = ReadOptions {
        from_s,
        to_s,
        whole_log,
        rate_hz,
        ..Default::default()
    };
    for spec in &instances {
        o.add_instance(spec).map_err(err)?;
    }
    if let (Some(a), Some(b)) = (from_s, to_s) {
        if a >= b {
            return Err(err(format!("from_s {a} must be before to_s {b}")));
        }
    }
    Ok(o)
}

/// Reads one flight file (`aerosid_read::read_measured_with`).
fn read_flight(py: Python<'_>, data: PathBuf, with: Option<PathBuf>, opts: ReadOptions) -> PyResult<MeasuredFlight> {
    py.detach(|| aerosid_read::read_measured_with(&data, with.as_deref(), &opts))
        .map_err(err)
}

/// `(source, t_s, [(column, values)], meta)` of a flight file: the channels on the uniform time
/// base, SI units.
#[pyfunction]
#[pyo3(signature = (data, with_=None, from_s=None, to_s=None, whole_log=false, rate_hz=None, instances=vec![]))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn read<'py>(
    py: Python<'py>,
    data: PathBuf,
    with_: Option<PathBuf>,
    from_s: Option<f64>,
    to_s: Option<f64>,
    whole_log: bool,
    rate_hz: Option<f64>,
    instances: Vec<String>,
) -> PyResult<(
    String,
    Bound<'py, PyArray1<f64>>,
    Vec<(String, Bound<'py, PyArray1<f64>>)>,
    Bound<'py, PyDict>,
)> {
    let opts = read_options(from_s, to_s, whole_log, rate_hz, instances)?;
    let f = read_flight(py, data, with_, opts)?;
    let t = PyArray1::from_vec(py, f.t_s.clone());
    let cols = f
        .channels
        .iter()
        .map(|(q, v)| (column(*q), PyArray1::from_slice(py, v)))
        .collect();
    let meta = PyDict::new(py);
    meta.set_item("source", &f.source)?;
    meta.set_item("aircraft", &f.aircraft.name)?;
    meta.set_item("format", &f.log.format)?;
    meta.set_item("aircraft_unknown", f.log.aircraft_unknown)?;
    meta.set_item("window", &f.log.window)?;
    meta.set_item("resampling", &f.log.resampling)?;
    meta.set_item("warnings", &f.log.warnings)?;
    meta.set_item("parameters", &f.log.parameters)?;
    meta.set_item(
        "units",
        f.channels
            .keys()
            .map(|q| (column(*q), q.si_unit()))
            .collect::<BTreeMap<_, _>>(),
    )?;
    Ok((f.source.clone(), t, cols, meta))
}

/// The analysis settings of the keyword arguments (the `gaps` command's options).
#[allow(clippy::too_many_arguments)]
fn settings(
    air_data: &str,
    flow_angles: &str,
    corrections: bool,
    compatibility: bool,
    baseline: Option<&str>,
    max_rate_hz: Option<f64>,
    low_rate_method: &str,
    alpha: f64,
    gain_alpha: f64,
) -> PyResult<GapSettings> {
    let air_data = AirDataChoice::parse(air_data).ok_or_else(|| {
        err(format!(
            "air_data `{air_data}`: give auto, measured, reconstructed or fused"
        ))
    })?;
    let flow_angles = FlowAngleChoice::parse(flow_angles).ok_or_else(|| {
        err(format!(
            "flow_angles `{flow_angles}`: give auto, vanes, estimated or none"
        ))
    })?;
    let baseline = baseline
        .map(aerosid::gaps::model::parse_baseline)
        .transpose()
        .map_err(|e| err(format!("baseline: {e}")))?;
    if let Some(r) = max_rate_hz {
        if !(r.is_finite() && r > 0.0) {
            return Err(err(format!(
                "max_rate_hz {r}: give a positive rate in Hz, or None to analyse at the logged rate"
            )));
        }
    }
    let low_rate_method = match low_rate_method {
        "output-error" => LowRateMethod::OutputError,
        "filter-error" => LowRateMethod::FilterError,
        "test" => LowRateMethod::Test,
        other => {
            return Err(err(format!(
                "low_rate_method `{other}`: give output-error, filter-error or test"
            )))
        }
    };
    let levels = Levels {
        alpha: Levels::check_alpha(alpha).map_err(|e| err(format!("alpha: {e}")))?,
        gain_alpha: Levels::check_gain_alpha(gain_alpha).map_err(|e| err(format!("gain_alpha: {e}")))?,
    };
    Ok(GapSettings {
        air_data,
        flow_angles,
        apply_corrections: corrections,
        compatibility,
        baseline,
        max_rate_hz,
        low_rate_method,
        ..levels.apply(GapSettings::default())
    })
}

/// The analysis of `flight`: report.json's content as JSON text; the files written to `out` when
/// given (report.json, report.txt, figures; a report with status `no_verdict` when the analysis
/// cannot run).
fn analyse(py: Python<'_>, flight: &MeasuredFlight, s: &GapSettings, out: Option<PathBuf>) -> PyResult<String> {
    let result = py.detach(|| match &out {
        Some(dir) => aerosid::batch::analyse(flight, dir, s).outcome.map(|o| o.report),
        None => aerosid::batch::report_value(flight, s),
    });
    result.map(|v| v.to_string()).map_err(err)
}

/// The gap analysis of one flight file, or of several pooled as the manoeuvres of one flight
/// (as the command's repeated `--data`, each cut to every `--segment`); report.json's content as
/// JSON text.
#[pyfunction]
#[pyo3(signature = (data, with_=None, out=None, segments=vec![], from_s=None, to_s=None, whole_log=false, rate_hz=None, instances=vec![], air_data="auto", flow_angles="auto", corrections=true, compatibility=true, baseline=None, max_rate_hz=Some(aerosid::gaps::MAX_ANALYSIS_RATE_HZ), low_rate_method="output-error", alpha=0.01, gain_alpha=0.01))]
#[allow(clippy::too_many_arguments)]
fn gaps_file(
    py: Python<'_>,
    data: Vec<PathBuf>,
    with_: Option<PathBuf>,
    out: Option<PathBuf>,
    segments: Vec<(f64, f64)>,
    from_s: Option<f64>,
    to_s: Option<f64>,
    whole_log: bool,
    rate_hz: Option<f64>,
    instances: Vec<String>,
    air_data: &str,
    flow_angles: &str,
    corrections: bool,
    compatibility: bool,
    baseline: Option<&str>,
    max_rate_hz: Option<f64>,
    low_rate_method: &str,
    alpha: f64,
    gain_alpha: f64,
) -> PyResult<String> {
    let s = settings(
        air_data,
        flow_angles,
        corrections,
        compatibility,
        baseline,
        max_rate_hz,
        low_rate_method,
        alpha,
        gain_alpha,
    )?;
    let opts = read_options(from_s, to_s, whole_log, rate_hz, instances)?;
    if data.is_empty() {
        return Err(err(
            "data: give a flight file, or a list of the files of one flight test to pool",
        ));
    }
    for file in &data {
        let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if with_.is_none() && !matches!(ext.as_deref(), Some("ulg") | Some("bin")) {
            return Err(err(format!(
                "data {} needs aircraft=MAP_OR_AIRCRAFT (only .ulg and .bin logs read without one)",
                file.display()
            )));
        }
    }
    let flight = py
        .detach(|| aerosid_read::read_pooled(&data, with_.as_deref(), &segments, &opts))
        .map_err(err)?;
    analyse(py, &flight, &s, out)
}

/// A flight of named SI channels on a time base (a frame of `read`, or the user's own).
fn frame_flight(
    source: String,
    t_s: PyReadonlyArray1<'_, f64>,
    channels: Vec<(String, PyReadonlyArray1<'_, f64>)>,
    aircraft: Option<PathBuf>,
) -> PyResult<MeasuredFlight> {
    let t_s = t_s.as_slice()?.to_vec();
    let mut map = BTreeMap::new();
    for (name, v) in channels {
        let q = quantity_of(&name).ok_or_else(|| {
            err(format!(
                "column `{name}` is not a channel aerosid knows: give the names `aerosid.columns()` lists (e.g. pitch_rate_rad_s), or drop the column"
            ))
        })?;
        map.insert(q, v.as_slice()?.to_vec());
    }
    let (aircraft, unknown) = match aircraft {
        Some(p) => {
            if p.extension().and_then(|e| e.to_str()) != Some("aircraft") {
                return Err(err(format!(
                    "{}: a frame's aircraft must be an aircraft file (`.aircraft`); a column map describes a file's columns, which a frame has already",
                    p.display()
                )));
            }
            (aerosid_read::aircraft::read_aircraft(&p).map_err(err)?, false)
        }
        None => (aerosid_read::placeholder_aircraft(), true),
    };
    let f = MeasuredFlight {
        source,
        t_s,
        channels: map,
        aircraft,
        log: LogMeta {
            format: "pandas DataFrame".into(),
            aircraft_unknown: unknown,
            ..Default::default()
        },
    };
    f.validate().map_err(|e| err(format!("{}: {e}", f.source)))?;
    Ok(f)
}

/// The gap analysis of a frame's channels; report.json's content as JSON text.
#[pyfunction]
#[pyo3(signature = (source, t_s, channels, aircraft=None, out=None, air_data="auto", flow_angles="auto", corrections=true, compatibility=true, baseline=None, max_rate_hz=Some(aerosid::gaps::MAX_ANALYSIS_RATE_HZ), low_rate_method="output-error", alpha=0.01, gain_alpha=0.01))]
#[allow(clippy::too_many_arguments)]
fn gaps_frame(
    py: Python<'_>,
    source: String,
    t_s: PyReadonlyArray1<'_, f64>,
    channels: Vec<(String, PyReadonlyArray1<'_, f64>)>,
    aircraft: Option<PathBuf>,
    out: Option<PathBuf>,
    air_data: &str,
    flow_angles: &str,
    corrections: bool,
    compatibility: bool,
    baseline: Option<&str>,
    max_rate_hz: Option<f64>,
    low_rate_method: &str,
    alpha: f64,
    gain_alpha: f64,
) -> PyResult<String> {
    let s = settings(
        air_data,
        flow_angles,
        corrections,
        compatibility,
        baseline,
        max_rate_hz,
        low_rate_method,
        alpha,
        gain_alpha,
    )?;
    let flight = frame_flight(source, t_s, channels, aircraft)?;
    analyse(py, &flight, &s, out)
}

/// `aerosid fem`: `(text, files)`.
#[pyfunction]
#[pyo3(signature = (model, out, data=vec![], with_=None, segments=vec![], validate=vec![], validate_segments=vec![], fix=vec![]))]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn fem(
    py: Python<'_>,
    model: PathBuf,
    out: PathBuf,
    data: Vec<PathBuf>,
    with_: Option<PathBuf>,
    segments: Vec<(f64, f64)>,
    validate: Vec<PathBuf>,
    validate_segments: Vec<(f64, f64)>,
    fix: Vec<(String, f64)>,
) -> PyResult<(String, Vec<PathBuf>)> {
    let args = aerosid::workflow::FemArgs {
        model,
        data,
        with: with_,
        segments,
        validate,
        validate_segments,
        fix,
        out,
    };
    py.detach(|| aerosid::workflow::run_fem(&args))
        .map(|r| (r.text, r.files))
        .map_err(err)
}

/// `aerosid predict`: `(text, files)`, with a fem identification.json or a gap report.json.
#[pyfunction]
#[pyo3(signature = (saved, out, data=vec![], with_=None, segments=vec![]))]
fn predict(
    py: Python<'_>,
    saved: PathBuf,
    out: PathBuf,
    data: Vec<PathBuf>,
    with_: Option<PathBuf>,
    segments: Vec<(f64, f64)>,
) -> PyResult<(String, Vec<PathBuf>)> {
    if !aerosid::gaps::predict::is_gap_report(&saved).map_err(err)? {
        return py
            .detach(|| aerosid::workflow::run_predict_with(&saved, &data, with_.as_deref(), &segments, &out))
            .map(|(_, t, f)| (t, f))
            .map_err(err);
    }
    let [file] = data.as_slice() else {
        return Err(err("a gap report predicts one flight: give exactly one data file"));
    };
    if !segments.is_empty() {
        return Err(err(
            "segments are for `fem` models; a gap report predicts the whole data flight",
        ));
    }
    let report = aerosid::gaps::predict::read_report(&saved).map_err(err)?;
    let flight = read_flight(py, file.clone(), with_, ReadOptions::default())?;
    py.detach(|| aerosid::gaps::predict::run(&report, &flight, &out))
        .map(|(_, t, f)| (t, f))
        .map_err(err)
}

/// A summary row as a dict (the columns of summary.jsonl, and `resumed`).
fn row_dict<'py>(py: Python<'py>, r: &Row) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("file", &r.file)?;
    d.set_item("folder", &r.folder)?;
    d.set_item("status", r.status.name())?;
    d.set_item("top_cause", &r.top_cause)?;
    d.set_item("reason", &r.reason)?;
    d.set_item("seconds", r.seconds)?;
    d.set_item("resumed", r.resumed)?;
    Ok(d)
}

fn batch_settings(out: PathBuf, with_: Option<PathBuf>, force: bool, jobs: usize) -> BatchSettings {
    let mut s = BatchSettings::new(out);
    s.with = with_;
    s.force = force;
    s.jobs = jobs;
    s.progress = false;
    s
}

/// One log of a batch (`aerosid::batch::run_one`): its folder under `out`, its row.
#[pyfunction]
#[pyo3(signature = (file, out, with_=None, force=false))]
fn batch_one<'py>(
    py: Python<'py>,
    file: PathBuf,
    out: PathBuf,
    with_: Option<PathBuf>,
    force: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let s = batch_settings(out, with_, force, 1);
    let row = py.detach(|| aerosid::batch::run_one(&file, &s));
    row_dict(py, &row)
}

/// A summary row's field.
fn get<'py>(d: &Bound<'py, PyDict>, k: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(k)?.ok_or_else(|| err(format!("a summary row needs `{k}`")))
}

/// The summary.csv and summary.jsonl of rows (dicts of `batch_one`) in `out`.
#[pyfunction]
fn write_summary(out: PathBuf, rows: Vec<Bound<'_, PyDict>>) -> PyResult<()> {
    let rows = rows
        .iter()
        .map(|d| {
            let status: String = get(d, "status")?.extract()?;
            Ok(Row {
                file: get(d, "file")?.extract()?,
                folder: get(d, "folder")?.extract()?,
                status: Status::parse(&status)
                    .ok_or_else(|| err(format!("status `{status}`: give verdict, no_verdict or error")))?,
                top_cause: get(d, "top_cause")?.extract()?,
                reason: get(d, "reason")?.extract()?,
                seconds: get(d, "seconds")?.extract()?,
                resumed: d
                    .get_item("resumed")?
                    .map(|v| v.extract())
                    .transpose()?
                    .unwrap_or(false),
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    std::fs::create_dir_all(&out).map_err(|e| err(format!("{}: {e}", out.display())))?;
    aerosid::batch::write_summary(&out, &rows).map_err(err)
}

/// The folder of a log in a batch (`aerosid::batch::folder_name`).
#[pyfunction]
fn folder_name(file: PathBuf) -> String {
    aerosid::batch::folder_name(&file)
}

/// The on-board estimator, recursive PCA-GTLS (`aerosid_core::Gtls`), for `f64` and the
/// dimensions a notebook needs: `n` parameters (1–6), the first `n_exact` (0 or 1) on exact
/// regressors. `Gtls` is generic over its dimensions at compile time, so each pair is its own type;
/// this enum holds one of them.
macro_rules! any_gtls {
    ($($v:ident = ($nt:literal, $ne:literal, $na:literal)),* $(,)?) => {
        #[allow(clippy::large_enum_variant)]
        enum AnyGtls {
            $($v(Box<CoreGtls<f64, $nt, $ne, $na>>),)*
        }

        /// The `(n, n_exact)` pairs supported.
        const DIMS: &[(usize, usize)] = &[$(($nt, $ne)),*];

        impl AnyGtls {
            fn new(n: usize, n_exact: usize, w_t: &[f64], weights: &[f64], s: GtlsSettings<f64>) -> Result<Self, String> {
                match (n, n_exact) {
                    $(($nt, $ne) => {
                        let w = SMatrix::<f64, $na, $na>::from_row_slice(w_t);
                        let wt = SVector::<f64, $nt>::from_column_slice(weights);
                        CoreGtls::new(&w, &wt, s).map(|g| Self::$v(Box::new(g))).map_err(|e| format!("Gtls: {e}"))
                    })*
                    _ => Err(format!(
                        "Gtls: n = {n}, n_exact = {n_exact} is not built in: n in 1..=6 with n_exact 0, or n in 2..=6 with n_exact 1"
                    )),
                }
            }

            fn update(&mut self, row: &[f64]) -> Result<aerosid_core::Step<f64>, aerosid_core::Error> {
                match self {
                    $(Self::$v(g) => g.update(&SVector::<f64, $nt>::from_column_slice(&row[..$nt]), row[$nt]),)*
                }
            }

            fn theta(&self) -> Vec<f64> {
                match self {
                    $(Self::$v(g) => g.theta().iter().copied().collect(),)*
                }
            }

            fn covariance(&self) -> Result<(usize, Vec<f64>), aerosid_core::Error> {
                match self {
                    $(Self::$v(g) => g.covariance().map(|c| ($nt, c.transpose().iter().copied().collect())),)*
                }
            }

            fn excited(&self) -> usize {
                match self {
                    $(Self::$v(g) => g.excited(),)*
                }
            }

            fn lambda(&self) -> f64 {
                match self {
                    $(Self::$v(g) => g.lambda(),)*
                }
            }

            fn effective_samples(&self) -> f64 {
                match self {
                    $(Self::$v(g) => g.effective_samples(),)*
                }
            }

            fn health(&self) -> aerosid_core::GtlsHealth {
                match self {
                    $(Self::$v(g) => *g.health(),)*
                }
            }
        }
    };
}

any_gtls!(
    N1 = (1, 0, 2),
    N2 = (2, 0, 3),
    N3 = (3, 0, 4),
    N4 = (4, 0, 5),
    N5 = (5, 0, 6),
    N6 = (6, 0, 7),
    N2E1 = (2, 1, 2),
    N3E1 = (3, 1, 3),
    N4E1 = (4, 1, 4),
    N5E1 = (5, 1, 5),
    N6E1 = (6, 1, 6),
);

/// The recursive PCA-GTLS estimator (Algorithm 1 of the paper; `aerosid_core::Gtls`).
#[pyclass(name = "Gtls", module = "aerosid")]
struct Gtls {
    inner: AnyGtls,
    n: usize,
    n_exact: usize,
    rejected: u64,
}

#[pymethods]
impl Gtls {
    #[new]
    #[pyo3(signature = (n, n_exact=0, w_t=None, weights=None, snr=1.0, forgetting=1.0, max_abs_input=1e6))]
    fn new(
        n: usize,
        n_exact: usize,
        w_t: Option<PyReadonlyArray2<'_, f64>>,
        weights: Option<PyReadonlyArray1<'_, f64>>,
        snr: f64,
        forgetting: f64,
        max_abs_input: f64,
    ) -> PyResult<Self> {
        if !DIMS.contains(&(n, n_exact)) {
            return Err(err(format!(
                "Gtls: n = {n}, n_exact = {n_exact} is not built in: n in 1..=6 with n_exact 0, or n in 2..=6 with n_exact 1"
            )));
        }
        let na = n - n_exact + 1;
        let w_t: Vec<f64> = match w_t {
            Some(a) => {
                let v = a.as_array();
                if v.shape() != [na, na] {
                    return Err(err(format!(
                        "Gtls: w_t has shape {:?}; the noisy block [x_noisy, z] needs {na}×{na}",
                        v.shape()
                    )));
                }
                v.iter().copied().collect()
            }
            None => (0..na * na)
                .map(|i| if i % (na + 1) == 0 { 1.0 } else { 0.0 })
                .collect(),
        };
        let weights: Vec<f64> = match weights {
            Some(a) => {
                let v = a.as_slice()?.to_vec();
                if v.len() != n {
                    return Err(err(format!("Gtls: {} weights given; n = {n} needed", v.len())));
                }
                v
            }
            None => vec![1.0; n],
        };
        if !(forgetting > 0.0 && forgetting <= 1.0) {
            return Err(err(format!("Gtls: forgetting {forgetting} outside (0, 1]")));
        }
        let s = GtlsSettings {
            snr,
            max_abs_input,
            reorth_tol: 0.0,
            forgetting: aerosid_core::Forgetting::Constant(forgetting),
        };
        let inner = AnyGtls::new(n, n_exact, &w_t, &weights, s).map_err(err)?;
        Ok(Self {
            inner,
            n,
            n_exact,
            rejected: 0,
        })
    }

    /// One sample `row = [x_1 … x_n, z]`; False (state unchanged) when refused.
    fn update(&mut self, row: PyReadonlyArray1<'_, f64>) -> PyResult<bool> {
        let r = row.as_slice()?;
        if r.len() != self.n + 1 {
            return Err(err(format!(
                "Gtls.update: a row of {} values; [x_1 … x_{}, z] needs {}",
                r.len(),
                self.n,
                self.n + 1
            )));
        }
        Ok(self.step(r))
    }

    /// Samples as rows of an `(m, n + 1)` array; the number accepted.
    fn update_many(&mut self, py: Python<'_>, rows: PyReadonlyArray2<'_, f64>) -> PyResult<usize> {
        let a = rows.as_array();
        if a.ncols() != self.n + 1 {
            return Err(err(format!(
                "Gtls.update_many: rows of {} values; [x_1 … x_{}, z] needs {}",
                a.ncols(),
                self.n,
                self.n + 1
            )));
        }
        let data: Vec<f64> = a.iter().copied().collect();
        let w = self.n + 1;
        Ok(py.detach(|| data.chunks_exact(w).filter(|r| self.step(r)).count()))
    }

    /// The parameter estimate θ̂.
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.theta())
    }

    /// The standard errors of θ̂ (eq. 17), NaN while not every parameter is excited.
    #[getter]
    fn sigma<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let s = match self.inner.covariance() {
            Ok((n, c)) => (0..n).map(|i| c[i * n + i].max(0.0).sqrt()).collect(),
            Err(_) => vec![f64::NAN; self.n],
        };
        PyArray1::from_vec(py, s)
    }

    /// The covariance of θ̂ (eq. 17), an n×n array; None while not every parameter is excited.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.inner
            .covariance()
            .ok()
            .map(|(n, c)| PyArray1::from_vec(py, c).reshape([n, n]))
            .transpose()
    }

    /// Excited directions k of the noisy regressors (eq. 21); n - n_exact when all are.
    #[getter]
    fn excited(&self) -> usize {
        self.inner.excited()
    }

    /// The forgetting factor applied to the next sample.
    #[getter]
    fn forgetting(&self) -> f64 {
        self.inner.lambda()
    }

    /// Σ Π λ, the effective number of samples.
    #[getter]
    fn effective_samples(&self) -> f64 {
        self.inner.effective_samples()
    }

    /// Samples refused (non-finite, beyond max_abs_input, or a rolled-back update).
    #[getter]
    fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The numerical events handled: updates, reorthonormalisations, nongeneric, secular_not_converged.
    #[getter]
    fn health<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let h = self.inner.health();
        let d = PyDict::new(py);
        d.set_item("updates", h.updates)?;
        d.set_item("reorthonormalisations", h.reorthonormalisations)?;
        d.set_item("nongeneric", h.nongeneric)?;
        d.set_item("secular_not_converged", h.secular_not_converged)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!(
            "Gtls(n={}, n_exact={}, excited={}, effective_samples={:.1})",
            self.n,
            self.n_exact,
            self.inner.excited(),
            self.inner.effective_samples()
        )
    }
}

impl Gtls {
    fn step(&mut self, row: &[f64]) -> bool {
        let ok = self.inner.update(row).is_ok();
        if !ok {
            self.rejected += 1;
        }
        ok
    }
}

#[pymodule]
fn _aerosid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("AerosidError", m.py().get_type::<AerosidError>())?;
    m.add_class::<Gtls>()?;
    m.add_function(wrap_pyfunction!(columns, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(gaps_file, m)?)?;
    m.add_function(wrap_pyfunction!(gaps_frame, m)?)?;
    m.add_function(wrap_pyfunction!(fem, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(batch_one, m)?)?;
    m.add_function(wrap_pyfunction!(write_summary, m)?)?;
    m.add_function(wrap_pyfunction!(folder_name, m)?)?;
    Ok(())
}
