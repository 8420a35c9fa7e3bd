//! The researcher's workflow around a user model ([`crate::usermodel`]): identify on one or more
//! files or segments pooled (each segment its own initial state), with parameters fixed, check on a
//! validation segment or file, save the model as JSON, and apply a saved model to another flight
//! (`aerosid fem` and `aerosid predict`).
//!
//! * **Pooling.** Segments are processed one after the other; the state filter restarts on each
//!   from that segment's first measurement, the parameter filter carries its estimate and
//!   covariance across. For a Gauss–Newton pass (a linear Kalman filter in `p`, see
//!   [`aerosid_core::fem::FilterError::new_pass`]) the chained update equals the normal equations
//!   summed over all segments; for the recursive filter it is the filter run on the records in
//!   turn.
//! * **Output error.** The same filter with no process noise and a state covariance so small
//!   (`10⁻¹²` of the initial variances) that the state gain vanishes: the state is the model's
//!   simulation and `R_p = R`; optionally `R` is replaced after each Gauss–Newton pass by the
//!   residual covariance (Jategaonkar 2015, §4.4's relaxation strategy for the output error method).
//! * **Prediction** is an open-loop simulation of the outputs from the segment's first measured
//!   state with the measured inputs, scored per output by the RMS residual, `R² = 1 − SS_res/SS_tot`
//!   and Theil's inequality coefficient `U = √mean(e²)/(√mean(y²) + √mean(ŷ²))` (0 perfect, 1
//!   useless; Jategaonkar 2015, §10 model validation).
//!
//! Data files are whitespace-separated numbers, laid out as the model file's `[data]` and column
//! entries say. A file whose time column jumps (more than 1.5 sample periods, or backwards) holds
//! several manoeuvres: it is split into segments there, not refused. A column the model reads that
//! is zero on every line is refused (a zero-padded column is a missing channel, not data).

use crate::io::colmap::{Expr, Source};
use crate::io::measured::{Aircraft, Quantity};
use crate::io::{read_measured_with, ReadOptions};
use crate::plot::{Colour, Figure, Line, Panel, PlotError};
use crate::usermodel::{
    Initial, Iteration, Layout, Method, ModelError, PVec, UVec, UserModel, XVec, YVec, MAX_P, MAX_X, MAX_Y,
};
use aerosid_core::fem::{integrate, FemSettings, FilterError, Model};
/// The fit of one output, shared with the gap analysis's prediction (`aerosid-report`).
pub use aerosid_report::fit::{output_fit, OutputFit, THEIL_LEGEND};
use nalgebra::SMatrix;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod markov;

/// A time range, seconds from the first sample of its file: `FROM:TO` on the command line.
pub type Range = (f64, f64);

/// One contiguous piece of a record, in the model's (scaled) units.
#[derive(Debug, Clone)]
pub struct Segment {
    /// Where it came from: `file [from, to] s`.
    pub label: String,
    /// The file.
    pub file: String,
    /// Time from the start of the file, s.
    pub t_s: Vec<f64>,
    /// Inputs per sample.
    pub u: Vec<UVec>,
    /// Measured outputs per sample.
    pub y: Vec<YVec>,
    /// The aircraft of data read with an aircraft file or a column map (`None`: read by column
    /// number, or a log read without one).
    pub aircraft: Option<Aircraft>,
}

/// Parses `FROM:TO` (seconds, `FROM < TO`).
pub fn parse_range(s: &str) -> Result<Range, String> {
    let fix = "write it as FROM:TO in seconds from the file's first sample, e.g. 0:5";
    let (a, b) = s.split_once(':').ok_or_else(|| format!("segment `{s}`: {fix}"))?;
    let a: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("segment `{s}`: `{a}` is not a number; {fix}"))?;
    let b: f64 = b
        .trim()
        .parse()
        .map_err(|_| format!("segment `{s}`: `{b}` is not a number; {fix}"))?;
    if !(a.is_finite() && b.is_finite() && a < b) {
        return Err(format!("segment `{s}`: FROM must be below TO; {fix}"));
    }
    Ok((a, b))
}

/// Parses `NAME=VALUE` of `--fix`.
pub fn parse_fix(s: &str) -> Result<(String, f64), String> {
    let (n, v) = s
        .split_once('=')
        .ok_or_else(|| format!("--fix `{s}`: write it as NAME=VALUE, e.g. --fix Cmq=-34.7"))?;
    let v: f64 = v
        .trim()
        .parse()
        .map_err(|_| format!("--fix `{s}`: `{v}` is not a number"))?;
    Ok((n.trim().to_string(), v))
}

/// The numbers of one record: per row its line (or sample) number and its values by column
/// (`Source::Column(c)` is `values[c − 1]`), the time in column `time_column`.
struct Table {
    /// The data file.
    file: String,
    /// `(line or sample number, values)`.
    rows: Vec<(usize, Vec<f64>)>,
    /// 1-based column of the time.
    time_column: usize,
    /// Read by column number (`file:LINE` in errors) or from channels (`file: sample K`).
    by_number: bool,
    /// The channels of a channel layout, in column order.
    channels: Vec<Quantity>,
    /// The aircraft, if the data came with one.
    aircraft: Option<Aircraft>,
}

impl Table {
    fn at(&self, line: usize) -> String {
        if self.by_number {
            format!("{}:{line}", self.file)
        } else {
            format!("{}: sample {line}", self.file)
        }
    }

    fn column(&self, c: usize) -> String {
        if self.by_number {
            format!("column {c}")
        } else {
            format!("channel `{}`", self.channels[c - 1])
        }
    }
}

/// A file read by column number: every line `columns` numbers.
fn numbered_table(model: &UserModel, path: &Path, columns: usize, time_column: usize) -> Result<Table, String> {
    let f = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| format!("{f}: {e}"))?;
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let mut row = Vec::with_capacity(columns);
        for (c, tok) in line.split_whitespace().enumerate() {
            row.push(
                tok.parse::<f64>()
                    .map_err(|e| format!("{f}:{}: column {}: `{tok}`: {e}", i + 1, c + 1))?,
            );
        }
        if row.len() != columns {
            return Err(format!(
                "{f}:{}: {} columns, the model file {} says data.columns = {} (set it to this file's layout or give the right file)",
                i + 1,
                row.len(),
                model.path.display(),
                columns
            ));
        }
        rows.push((i + 1, row));
    }
    Ok(Table {
        file: f,
        rows,
        time_column,
        by_number: true,
        channels: Vec::new(),
        aircraft: None,
    })
}

/// Any file the measured-data readers read, with its companion: the channels the model names,
/// then the time.
fn channel_table(path: &Path, companion: Option<&Path>, channels: &[Quantity]) -> Result<Table, String> {
    let f = path.display().to_string();
    let flight = read_measured_with(path, companion, &ReadOptions::default()).map_err(|e| e.to_string())?;
    let mut cols = Vec::with_capacity(channels.len());
    for q in channels {
        let v = flight.get(*q).ok_or_else(|| {
            let have: Vec<&str> = flight.channels.keys().map(|c| c.name()).collect();
            format!(
                "{f}: no `{q}` channel, which the model reads; the data have {} (map it in the column map, `channel.{q} = …`, or name another channel in the model file)",
                have.join(", ")
            )
        })?;
        cols.push(v);
    }
    let rows = (0..flight.len())
        .map(|k| {
            let mut row: Vec<f64> = cols.iter().map(|c| c[k]).collect();
            row.push(flight.t_s[k]);
            (k + 1, row)
        })
        .collect();
    Ok(Table {
        file: f,
        rows,
        time_column: channels.len() + 1,
        by_number: false,
        channels: channels.to_vec(),
        aircraft: (!flight.log.aircraft_unknown).then(|| flight.aircraft.clone()),
    })
}

/// A source's value on one row.
fn source_value(e: &Expr, row: &[f64]) -> f64 {
    e.eval(e.terms.iter().map(|t| match t.source {
        Source::Column(c) => row[c - 1],
        Source::Field { .. } => f64::NAN,
    }))
}

/// Reads a data file as the model says (its `[data] with` the companion of a channel layout),
/// splits it at time jumps, and cuts the `ranges` (see [`read_segments_with`]).
pub fn read_segments(model: &UserModel, path: &Path, ranges: &[Range]) -> Result<Vec<Segment>, String> {
    read_segments_with(model, path, model.default_companion().as_deref(), ranges)
}

/// Reads a data file as the model says — by column number, or through the measured-data readers
/// with `companion` (a column map or aircraft file) — splits it at time jumps, and cuts the
/// `ranges` (all of each piece if none). Refuses lines with another number of columns,
/// non-numbers, non-finite values in a column the model reads, channels the data lack, columns or
/// channels the model reads that are zero throughout, and segments of fewer than two samples.
pub fn read_segments_with(
    model: &UserModel,
    path: &Path,
    companion: Option<&Path>,
    ranges: &[Range],
) -> Result<Vec<Segment>, String> {
    let table = match &model.layout {
        Layout::Columns { columns, time_column } => numbered_table(model, path, *columns, *time_column)?,
        Layout::Channels(chs) => channel_table(path, companion, chs)?,
    };
    let f = &table.file;
    let rows = &table.rows;
    if rows.len() < 2 {
        return Err(format!("{f}: {} samples; at least two are needed", rows.len()));
    }
    check_used_columns(model, &table)?;
    let tc = table.time_column - 1;
    let t0 = rows[0].1[tc];
    let (dt, pieces) = contiguous_pieces(&table)?;
    let whole = [(f64::NEG_INFINITY, f64::INFINITY)];
    let ranges = if ranges.is_empty() { &whole[..] } else { ranges };
    let mut out = Vec::new();
    for &(from, to) in ranges {
        let mut found = false;
        for piece in &pieces {
            let idx: Vec<usize> = piece
                .clone()
                .filter(|&k| {
                    let t = rows[k].1[tc] - t0;
                    t >= from - 1e-9 * dt && t <= to + 1e-9 * dt
                })
                .collect();
            if idx.is_empty() {
                continue;
            }
            found = true;
            if idx.len() < 2 {
                return Err(format!(
                    "{f}: segment {from}:{to} s holds {} sample of a piece; give a longer segment",
                    idx.len()
                ));
            }
            out.push(segment_of_rows(model, &table, &idx));
        }
        if !found {
            let last = rows[rows.len() - 1].1[tc] - t0;
            return Err(format!(
                "{f}: segment {from}:{to} s has no samples; the file spans 0 to {last:.3} s from its first sample"
            ));
        }
    }
    Ok(out)
}

/// Every column the model reads (the time, each input's and output's) finite on every row and
/// not zero on all of them (a missing, zero-padded channel); the error names the file, the line
/// and the column, and says what to map instead.
fn check_used_columns(model: &UserModel, table: &Table) -> Result<(), String> {
    let f = &table.file;
    let rows = &table.rows;
    let names = model
        .file
        .inputs
        .iter()
        .map(|i| format!("input {}", i.name))
        .chain(model.file.outputs.iter().map(|o| format!("output {}", o.name)));
    let mut used: Vec<(String, usize)> = vec![("time".into(), table.time_column)];
    for (what, e) in names.zip(&model.sources) {
        for t in &e.terms {
            if let Source::Column(c) = t.source {
                used.push((what.clone(), c));
            }
        }
    }
    for (what, col) in &used {
        if let Some((line, _)) = rows.iter().find(|(_, r)| !r[col - 1].is_finite()) {
            return Err(format!(
                "{}: {} ({what}) is not finite",
                table.at(*line),
                table.column(*col)
            ));
        }
        if rows.iter().all(|(_, r)| r[col - 1] == 0.0) {
            return Err(if table.by_number {
                format!(
                    "{f}: column {col} ({what}) is zero on every line: a missing (zero-padded) channel; map {what} to the column that holds it in {}",
                    model.path.display()
                )
            } else {
                format!(
                    "{f}: {} ({what}) is zero on every sample: a missing channel; name one that holds it in {}",
                    table.column(*col),
                    model.path.display()
                )
            });
        }
    }
    Ok(())
}

/// The record's time step (the median forward step, s) and its contiguous pieces of rows: a
/// step above 1.5 dt or not forward starts a new one.
fn contiguous_pieces(table: &Table) -> Result<(f64, Vec<std::ops::Range<usize>>), String> {
    let rows = &table.rows;
    let tc = table.time_column - 1;
    let diffs: Vec<f64> = rows.windows(2).map(|w| w[1].1[tc] - w[0].1[tc]).collect();
    let mut sorted: Vec<f64> = diffs.iter().copied().filter(|d| *d > 0.0).collect();
    sorted.sort_by(f64::total_cmp);
    let dt = *sorted
        .get(sorted.len() / 2)
        .ok_or_else(|| format!("{}: the time never increases", table.file))?;
    let mut pieces: Vec<std::ops::Range<usize>> = Vec::new();
    let mut start = 0;
    for (k, d) in diffs.iter().enumerate() {
        if !(*d > 0.0 && *d < 1.5 * dt) {
            pieces.push(start..k + 1);
            start = k + 1;
        }
    }
    pieces.push(start..rows.len());
    Ok((dt, pieces))
}

/// The segment of the rows `idx` (at least two): time from the record's first sample, the
/// model's inputs and outputs from their sources.
fn segment_of_rows(model: &UserModel, table: &Table, idx: &[usize]) -> Segment {
    let (_, nu, ny) = model.dims();
    let rows = &table.rows;
    let tc = table.time_column - 1;
    let t0 = rows[0].1[tc];
    let t_s: Vec<f64> = idx.iter().map(|&k| rows[k].1[tc] - t0).collect();
    let u = idx
        .iter()
        .map(|&k| {
            let mut v = UVec::zeros();
            for (j, e) in model.sources.iter().enumerate().take(nu) {
                v[j] = source_value(e, &rows[k].1);
            }
            v
        })
        .collect();
    let y = idx
        .iter()
        .map(|&k| {
            let mut v = YVec::zeros();
            for (j, e) in model.sources[nu..].iter().enumerate().take(ny) {
                v[j] = source_value(e, &rows[k].1);
            }
            v
        })
        .collect();
    Segment {
        label: format!("{f} [{:.3}, {:.3}] s", t_s[0], t_s[t_s.len() - 1], f = table.file),
        file: table.file.clone(),
        t_s,
        u,
        y,
        aircraft: table.aircraft.clone(),
    }
}

/// Sets the model's constants taken from the aircraft file from the segments' aircraft (see
/// [`UserModel::set_aircraft`]); a model that takes none is left as it is.
pub fn apply_aircraft(model: &mut UserModel, segments: &[Segment]) -> Result<(), String> {
    if !model.uses_aircraft() {
        return Ok(());
    }
    for s in segments {
        let a = s.aircraft.as_ref().ok_or_else(|| {
            format!(
                "{}: no aircraft file, and {} takes constants from one; give --with AIRCRAFT_OR_MAP",
                s.file,
                model.path.display()
            )
        })?;
        model.set_aircraft(a, &s.file)?;
    }
    Ok(())
}

/// The sample period of the segments (median step), checked to be the same in all (0.1 %).
pub fn sample_period(segments: &[Segment]) -> Result<f64, String> {
    let mut dts = Vec::new();
    for s in segments {
        let mut d: Vec<f64> = s.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        dts.push((d[d.len() / 2], &s.label));
    }
    let (dt, _) = *dts.first().ok_or("no data segments")?;
    if let Some((d, l)) = dts.iter().find(|(d, _)| (d / dt - 1.0).abs() > 1e-3) {
        return Err(format!(
            "{l}: sample period {d} s differs from {dt} s of the first segment; pool records of one rate"
        ));
    }
    Ok(dt)
}

/// The filter's settings: `Q = diag(F²)` (zero for output error), `R = diag(noise_variance)`
/// (or `r` given), the data's Δt and the file's prediction.
pub fn settings(model: &UserModel, dt_s: f64, r: Option<&[f64]>) -> FemSettings<f64, MAX_X, MAX_Y> {
    let (nx, _, ny) = model.dims();
    let (integrator, input_hold, sensitivity) = model.prediction();
    let mut q_x = SMatrix::<f64, MAX_X, MAX_X>::zeros();
    if model.file.estimation.method == Method::FilterError {
        for i in 0..nx {
            let f = model.file.states[i].process_noise;
            q_x[(i, i)] = f * f;
        }
    }
    let mut r_x = SMatrix::<f64, MAX_Y, MAX_Y>::identity();
    for i in 0..ny {
        r_x[(i, i)] = r.map_or(model.file.outputs[i].noise_variance, |r| r[i]);
    }
    FemSettings {
        q_x,
        r_x,
        dt_s,
        integrator,
        input_hold,
        sensitivity,
    }
}

/// The initial state of a segment and its covariance (output error: `10⁻¹²` of it).
pub fn initial_state(model: &UserModel, seg: &Segment) -> (XVec, SMatrix<f64, MAX_X, MAX_X>) {
    let mut x = XVec::zeros();
    let mut p = SMatrix::<f64, MAX_X, MAX_X>::identity();
    let scale = match model.file.estimation.method {
        Method::FilterError => 1.0,
        Method::OutputError => 1e-12,
    };
    for (i, s) in model.file.states.iter().enumerate() {
        let (value, var) = match &s.initial {
            Initial::Value(v) => (*v, s.initial_variance.unwrap_or(1.0)),
            Initial::Output(name) => {
                // Checked at load: the output exists.
                let j = model.file.outputs.iter().position(|o| &o.name == name).unwrap_or(0);
                (
                    seg.y[0][j],
                    s.initial_variance.unwrap_or(model.file.outputs[j].noise_variance),
                )
            }
        };
        x[i] = value;
        p[(i, i)] = var * scale;
    }
    (x, p)
}

/// The result of [`identify`].
#[derive(Debug, Clone)]
pub struct Identified {
    /// Free parameters (padded).
    pub p: PVec,
    /// Their covariance.
    pub covariance: SMatrix<f64, MAX_P, MAX_P>,
    /// Passes made (1 for the recursive filter).
    pub iterations: usize,
    /// Gauss–Newton converged (always true for the recursive filter).
    pub converged: bool,
    /// The measurement-noise variances used last.
    pub noise_variance: Vec<f64>,
    /// Parameter history of the recursive filter: `(segment, t, p, σ)` per step.
    pub history: Vec<(usize, f64, PVec, PVec)>,
}

fn sigma_of(c: &SMatrix<f64, MAX_P, MAX_P>) -> PVec {
    PVec::from_fn(|i, _| c[(i, i)].max(0.0).sqrt())
}

/// One Gauss–Newton pass over all segments at `p_lin`; the estimate, its covariance and the mean
/// squared prediction error per output.
fn pooled_pass(
    model: &UserModel,
    segments: &[Segment],
    st: &FemSettings<f64, MAX_X, MAX_Y>,
    p_lin: &PVec,
    prior: (PVec, SMatrix<f64, MAX_P, MAX_P>),
) -> Result<(PVec, SMatrix<f64, MAX_P, MAX_P>, YVec), String> {
    let (mut mean, mut cov) = prior;
    let mut dz2 = YVec::zeros();
    let mut n = 0usize;
    for seg in segments {
        let (x0, p_x0) = initial_state(model, seg);
        let mut fem = FilterError::new_pass(model, *st, x0, p_x0, *p_lin, mean, cov)
            .map_err(|e| format!("{}: the filter refused its start ({e:?})", seg.label))?;
        for k in 0..seg.t_s.len() - 1 {
            let step = fem
                .step(&seg.u[k], &seg.u[k + 1], &seg.y[k + 1])
                .map_err(|e| format!("{} at t = {:.3} s: step refused ({e:?})", seg.label, seg.t_s[k + 1]))?;
            dz2 += step.prediction_error.component_mul(&step.prediction_error);
            n += 1;
        }
        mean = *fem.parameters();
        cov = *fem.parameter_covariance();
    }
    Ok((mean, cov, dz2 / n.max(1) as f64))
}

/// The filter error (or output error) method on the segments, pooled, as the model file's
/// `[estimation]` says.
pub fn identify(model: &UserModel, segments: &[Segment]) -> Result<Identified, String> {
    let dt = sample_period(segments)?;
    let est = &model.file.estimation;
    let (_, _, ny) = model.dims();
    let p0 = model.free_vector();
    let c0 = model.prior_covariance();
    let mut r: Vec<f64> = model.file.outputs.iter().map(|o| o.noise_variance).collect();
    match est.iteration {
        Iteration::Recursive => {
            let st = settings(model, dt, None);
            let (mut p, mut c) = (p0, c0);
            let mut history = Vec::new();
            for (si, seg) in segments.iter().enumerate() {
                let (x0, p_x0) = initial_state(model, seg);
                let mut fem = FilterError::new(model, st, x0, p_x0, p, c)
                    .map_err(|e| format!("{}: the filter refused its start ({e:?})", seg.label))?;
                history.push((si, seg.t_s[0], p, sigma_of(&c)));
                for k in 0..seg.t_s.len() - 1 {
                    fem.step(&seg.u[k], &seg.u[k + 1], &seg.y[k + 1])
                        .map_err(|e| format!("{} at t = {:.3} s: step refused ({e:?})", seg.label, seg.t_s[k + 1]))?;
                    history.push((si, seg.t_s[k + 1], *fem.parameters(), fem.parameter_sigma()));
                }
                p = *fem.parameters();
                c = *fem.parameter_covariance();
            }
            Ok(Identified {
                p,
                covariance: c,
                iterations: 1,
                converged: true,
                noise_variance: r,
                history,
            })
        }
        Iteration::GaussNewton => {
            let mut p = p0;
            let mut out = None;
            for it in 0..est.max_iterations.max(1) {
                let st = settings(model, dt, Some(&r));
                let (next, cov, dz2) = pooled_pass(model, segments, &st, &p, (p0, c0))?;
                let moved = (0..model.free().len())
                    .map(|j| (next[j] - p[j]).abs() / cov[(j, j)].max(f64::MIN_POSITIVE).sqrt())
                    .fold(0.0, f64::max);
                p = next;
                let converged = moved < est.tolerance_sigma;
                out = Some(Identified {
                    p,
                    covariance: cov,
                    iterations: it + 1,
                    converged,
                    noise_variance: r.clone(),
                    history: Vec::new(),
                });
                if converged {
                    break;
                }
                if est.estimate_noise && est.method == Method::OutputError {
                    r = (0..ny).map(|i| dz2[i].max(f64::MIN_POSITIVE)).collect();
                }
            }
            out.ok_or_else(|| "no Gauss-Newton pass ran".into())
        }
    }
}

/// The prediction errors of a pass over `seg` with the model at `p` (they do not depend on the
/// parameter prior, which only the parameter update uses).
fn prediction_errors(
    model: &UserModel,
    seg: &Segment,
    st: &FemSettings<f64, MAX_X, MAX_Y>,
    p: &PVec,
) -> Result<Vec<YVec>, String> {
    let (x0, p_x0) = initial_state(model, seg);
    let mut fem = FilterError::new_pass(model, *st, x0, p_x0, *p, *p, model.prior_covariance())
        .map_err(|e| format!("{}: the filter refused its start ({e:?})", seg.label))?;
    (0..seg.t_s.len() - 1)
        .map(|k| {
            fem.step(&seg.u[k], &seg.u[k + 1], &seg.y[k + 1])
                .map(|s| s.prediction_error)
                .map_err(|e| format!("{} at t = {:.3} s: step refused ({e:?})", seg.label, seg.t_s[k + 1]))
        })
        .collect()
}

/// The real FFT of `x` zero-padded to `m` (`m/2 + 1` bins).
fn spectrum(
    planner: &mut realfft::RealFftPlanner<f64>,
    x: &[f64],
    m: usize,
) -> Vec<realfft::num_complex::Complex<f64>> {
    let fft = planner.plan_fft_forward(m);
    let mut input = vec![0.0; m];
    input[..x.len()].copy_from_slice(x);
    let mut out = fft.make_output_vec();
    // The lengths are the plan's own: the transform cannot fail.
    if fft.process(&mut input, &mut out).is_err() {
        out.fill(realfft::num_complex::Complex::new(f64::NAN, 0.0));
    }
    out
}

/// `Σᵢ Σⱼ Sᵢᵀ W R_vv(j−i) W Sⱼ` over one segment ([`coloured_covariance`]): `v` the residuals,
/// `sens[p][i]` the sensitivity of `vᵢ` to parameter `p`, `w` the diagonal of `W`,
/// `R_vv(k) = (1/N) Σᵢ vᵢ vᵢ₊ₖᵀ` over every lag of the segment. By FFT of the series zero-padded to
/// `M ≥ 2N` (no circular wrap): with `g_{a,p} = w_a S_{·,a,p}` and `u_p(f) = Σ_a G*_{a,p}(f) V_a(f)`,
/// the sum is `(1/(N M)) Σ_f Re(u_p(f) u_q(f)*)` over the full spectrum (Parseval).
fn lag_sandwich(
    planner: &mut realfft::RealFftPlanner<f64>,
    v: &[YVec],
    sens: &[Vec<YVec>],
    w: &[f64],
) -> nalgebra::DMatrix<f64> {
    use realfft::num_complex::Complex;
    let (n, np) = (v.len(), sens.len());
    let mut out = nalgebra::DMatrix::zeros(np, np);
    if n == 0 {
        return out;
    }
    let m = (2 * n).next_power_of_two();
    let mut u = vec![vec![Complex::new(0.0, 0.0); m / 2 + 1]; np];
    for (a, &wa) in w.iter().enumerate() {
        let va: Vec<f64> = v.iter().map(|e| e[a]).collect();
        let vf = spectrum(planner, &va, m);
        for (uj, s) in u.iter_mut().zip(sens) {
            let ga: Vec<f64> = s.iter().map(|e| wa * e[a]).collect();
            let gf = spectrum(planner, &ga, m);
            for (uf, (g, x)) in uj.iter_mut().zip(gf.iter().zip(&vf)) {
                *uf += g.conj() * x;
            }
        }
    }
    let last = m / 2;
    for i in 0..np {
        for j in 0..=i {
            let x: f64 = (0..=last)
                .map(|f| {
                    let c = if f == 0 || f == last { 1.0 } else { 2.0 };
                    c * (u[i][f] * u[j][f].conj()).re
                })
                .sum::<f64>()
                / (m as f64 * n as f64);
            out[(i, j)] = x;
            out[(j, i)] = x;
        }
    }
    out
}

/// The parameter covariance of `id` corrected for coloured residuals (Morelli & Klein 1997,
/// "Accuracy of aerodynamic model parameters estimated from flight test data", J. Guidance 20(1);
/// Klein & Morelli 2006 §6.2, eq. 6.55–6.56 for output error):
/// `Cov θ̂ = M⁻¹ [P₀⁻¹ + Σᵢ Σⱼ Sᵢᵀ W R_vv(i−j) W Sⱼ] M⁻¹`, `M = P₀⁻¹ + Σᵢ Sᵢᵀ W Sᵢ`, with `Sᵢ` the
/// sensitivity of the prediction error `vᵢ` to the free parameters at the estimate, `W` the
/// estimator's weighting and `R_vv(k) = (1/N) Σ vᵢ vᵢ₊ₖᵀ` the residual autocorrelation of each
/// segment (every lag within a segment, none across segments: pooled manoeuvres are independent).
/// With white residuals of covariance `W⁻¹` the middle term is `M` and this is the Cramér–Rao bound
/// the filter reports; output-error residuals carry turbulence and model error, coloured over the
/// manoeuvre, and the bound then understates the scatter several times (docs/fem.md).
///
/// Readings: `W = R⁻¹` for output error (the filter's `R_p` is `R` there); for the filter error
/// method `R_p = C P Cᵀ + R` is not returned by the filter, and its steady-state value is taken as
/// the sample covariance of the innovations (diagonal, as `R`). `Sᵢ` is the central difference of
/// the prediction errors of passes at `θ̂ ± δ eⱼ` (`δ` 1 % of the reported σ: small against the
/// uncertainty, large against rounding); for the filter error method it includes the gain's change.
/// The prior `P₀` enters as pseudo-data with white errors. The lag sums are formed by FFT of the
/// segment zero-padded to twice its length (no circular wrap): `Σₖ r_g(k) r_v(k) = (1/M) Σ_f G_f* V_f`
/// (Parseval), `O(N log N)` per parameter and output instead of `O(N²)`.
pub fn coloured_covariance(
    model: &UserModel,
    segments: &[Segment],
    id: &Identified,
) -> Result<SMatrix<f64, MAX_P, MAX_P>, String> {
    let Some(parts) = residual_parts(model, segments, id)? else {
        return Ok(id.covariance);
    };
    let mut meat = parts.prior_info.clone();
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    for (v, sens) in &parts.per_seg {
        if !v.is_empty() {
            meat += lag_sandwich(&mut planner, v, sens, &parts.w);
        }
    }
    sandwich(id, &parts.info, &meat)
}

/// What both coloured-residual covariances start from: per segment the residuals at the estimate
/// and their sensitivities (`sens[p][i]`), the weighting's diagonal `w`, the information
/// `M = P₀⁻¹ + Σ Sᵀ W S` and the prior's `P₀⁻¹` (`None`: no free parameter).
struct ResidualParts {
    per_seg: Vec<(Vec<YVec>, Vec<Vec<YVec>>)>,
    w: Vec<f64>,
    info: nalgebra::DMatrix<f64>,
    prior_info: nalgebra::DMatrix<f64>,
}

fn residual_parts(model: &UserModel, segments: &[Segment], id: &Identified) -> Result<Option<ResidualParts>, String> {
    use nalgebra::DMatrix;
    let dt = sample_period(segments)?;
    let np = model.free().len();
    let (_, _, ny) = model.dims();
    if np == 0 {
        return Ok(None);
    }
    let st = settings(model, dt, Some(&id.noise_variance));
    let sigma = sigma_of(&id.covariance);
    let steps: Vec<PVec> = (0..np)
        .map(|j| {
            let s = 0.01 * sigma[j];
            let d = if s.is_finite() && s > 0.0 {
                s
            } else {
                1e-6 * id.p[j].abs().max(1.0)
            };
            PVec::from_fn(|i, _| if i == j { d } else { 0.0 })
        })
        .collect();
    // Residuals and sensitivities per segment.
    let mut per_seg = Vec::with_capacity(segments.len());
    for seg in segments {
        let v = prediction_errors(model, seg, &st, &id.p)?;
        let mut sens = Vec::with_capacity(np);
        for d in &steps {
            let hi = prediction_errors(model, seg, &st, &(id.p + d))?;
            let lo = prediction_errors(model, seg, &st, &(id.p - d))?;
            let h = d.max() * 2.0;
            // S = ∂v/∂θ (the sign does not matter in the sandwich).
            sens.push(hi.iter().zip(&lo).map(|(a, b)| (a - b) / h).collect::<Vec<YVec>>());
        }
        per_seg.push((v, sens));
    }
    // The weighting.
    let w: Vec<f64> = match model.file.estimation.method {
        Method::OutputError => (0..ny).map(|i| 1.0 / st.r_x[(i, i)]).collect(),
        Method::FilterError => {
            let (mut s2, mut n) = (vec![0.0; ny], 0usize);
            for (v, _) in &per_seg {
                for e in v {
                    for (i, s) in s2.iter_mut().enumerate() {
                        *s += e[i] * e[i];
                    }
                }
                n += v.len();
            }
            s2.iter().map(|s| n as f64 / s.max(f64::MIN_POSITIVE)).collect()
        }
    };
    let c0 = model.prior_covariance();
    let prior_info = DMatrix::from_fn(np, np, |i, j| if i == j { 1.0 / c0[(i, i)] } else { 0.0 });
    let mut info = prior_info.clone();
    for (v, sens) in &per_seg {
        for a in 0..ny {
            for i in 0..np {
                for j in 0..=i {
                    let x: f64 = (0..v.len()).map(|k| sens[i][k][a] * w[a] * sens[j][k][a]).sum();
                    info[(i, j)] += x;
                    if i != j {
                        info[(j, i)] += x;
                    }
                }
            }
        }
    }
    Ok(Some(ResidualParts {
        per_seg,
        w,
        info,
        prior_info,
    }))
}

/// `M⁻¹ meat M⁻¹` written over the free block of `id`'s covariance.
fn sandwich(
    id: &Identified,
    info: &nalgebra::DMatrix<f64>,
    meat: &nalgebra::DMatrix<f64>,
) -> Result<SMatrix<f64, MAX_P, MAX_P>, String> {
    let bread = info
        .clone()
        .try_inverse()
        .ok_or("the information matrix of the estimate is singular: a parameter has no sensitivity")?;
    let cov = &bread * meat * &bread;
    let mut out = id.covariance;
    for i in 0..cov.nrows() {
        for j in 0..cov.ncols() {
            out[(i, j)] = cov[(i, j)];
        }
    }
    Ok(out)
}

/// The turbulence's correlation fitted to the residual ([`markov`]): per output the correlation
/// time, s, the kernel, and the share of the weighted residual variance that is correlated (the
/// rest white).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GustNoise {
    /// Per output, the correlation time of its correlated part, s.
    pub correlation_times_s: Vec<f64>,
    /// Per output, the correlated share of its variance, `C_aa / (C_aa + D_a)`.
    pub correlated_share: Vec<f64>,
    /// Per output, whether its correlated part is band-pass (no power at zero frequency) rather
    /// than first-order Gauss–Markov ([`markov`]'s module doc).
    pub band_pass: Vec<bool>,
}

/// The parameter covariance of `id` with each output's residual modelled as a correlated process
/// (a first-order Gauss–Markov or a band-pass kernel, with its own correlation time; between two
/// outputs the geometric mean of their correlations) plus white noise, fitted through the fit's residual maker ([`markov`]'s
/// module doc): `Cov θ̂ = M⁻¹ [P₀⁻¹ + Σ S̃ᵀ Σ̂ S̃] M⁻¹`. Where the model cannot be fitted (fewer
/// than four samples, a singular moment system or a non-finite fit) the Morelli–Klein covariance
/// ([`coloured_covariance`]), and the second value is `None`.
pub fn gust_covariance(
    model: &UserModel,
    segments: &[Segment],
    id: &Identified,
) -> Result<(SMatrix<f64, MAX_P, MAX_P>, Option<GustNoise>), String> {
    use nalgebra::DMatrix;
    let Some(parts) = residual_parts(model, segments, id)? else {
        return Ok((id.covariance, None));
    };
    let (_, _, ny) = model.dims();
    let np = parts.info.nrows();
    let root_w: Vec<f64> = parts.w.iter().map(|w| w.sqrt()).collect();
    let weighted: Vec<markov::WeightedSegment> = parts
        .per_seg
        .iter()
        .map(|(v, sens)| markov::WeightedSegment {
            v: DMatrix::from_fn(v.len() * ny, 1, |r, _| root_w[r % ny] * v[r / ny][r % ny]),
            s: DMatrix::from_fn(v.len() * ny, np, |r, p| root_w[r % ny] * sens[p][r / ny][r % ny]),
        })
        .collect();
    let bread = parts
        .info
        .clone()
        .try_inverse()
        .ok_or("the information matrix of the estimate is singular: a parameter has no sensitivity")?;
    match markov::fit(&weighted, ny, &bread, sample_period(segments)?, None) {
        Some(g) => {
            let meat = &parts.prior_info + &g.meat;
            let noise = GustNoise {
                correlation_times_s: g.tau_s,
                band_pass: g.band_pass,
                correlated_share: (0..ny)
                    .map(|a| {
                        let m = g.markov[(a, a)];
                        let t = m + g.white[a];
                        if t > 0.0 {
                            m / t
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            };
            Ok((sandwich(id, &parts.info, &meat)?, Some(noise)))
        }
        None => Ok((coloured_covariance(model, segments, id)?, None)),
    }
}

/// The open-loop simulation of a segment's outputs with the model's current parameters.
pub fn simulate(model: &UserModel, seg: &Segment, dt_s: f64) -> Vec<YVec> {
    let (integrator, hold, _) = model.prediction();
    let p = model.free_vector();
    let (mut x, _) = initial_state(model, seg);
    let mut ys = Vec::with_capacity(seg.t_s.len());
    for k in 0..seg.t_s.len() {
        ys.push(Model::h(&model, &x, &seg.u[k], &p));
        if k + 1 < seg.t_s.len() {
            x = integrate::<f64, &UserModel, MAX_X, { crate::usermodel::MAX_U }, MAX_Y, MAX_P>(
                &model,
                integrator,
                hold,
                dt_s,
                &x,
                &seg.u[k],
                &seg.u[k + 1],
                &p,
            );
        }
    }
    ys
}

/// RMS, R², Theil's U per output over the segments (pooled) from measured and simulated outputs.
pub fn fit_metrics(model: &UserModel, segments: &[Segment], sims: &[Vec<YVec>]) -> Vec<OutputFit> {
    let (_, _, ny) = model.dims();
    (0..ny)
        .map(|i| {
            let meas: Vec<f64> = segments.iter().flat_map(|s| s.y.iter().map(move |y| y[i])).collect();
            let pred: Vec<f64> = sims.iter().flat_map(|s| s.iter().map(move |y| y[i])).collect();
            output_fit(&model.file.outputs[i].name, &model.file.outputs[i].unit, &meas, &pred)
        })
        .collect()
}

/// One parameter of a saved identification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedParameter {
    /// Name.
    pub name: String,
    /// Value.
    pub value: f64,
    /// σ corrected for coloured residuals ([`gust_covariance`]; null for a fixed parameter).
    pub sigma: Option<f64>,
    /// The Cramér–Rao σ of white residuals, the filter's own covariance (null for a fixed
    /// parameter, and in files saved before it was recorded).
    #[serde(default)]
    pub sigma_white: Option<f64>,
    /// Held, not estimated.
    pub fixed: bool,
    /// Starting value.
    pub start: f64,
    /// The model file's published value, if it gives one.
    #[serde(default)]
    pub reference: Option<f64>,
}

/// What `aerosid fem` writes (`identification.json`) and `aerosid predict` reads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedModel {
    /// The model file, relative to the folder of the saved JSON (absolute once read by
    /// [`SavedModel::read`]).
    pub model_file: String,
    /// The model's name.
    pub model_name: String,
    /// The model file's text (the saved model does not depend on the file staying as it was).
    pub model_toml: String,
    /// `filter-error` or `output-error`.
    pub method: String,
    /// `recursive` or `gauss-newton`.
    pub iteration: String,
    /// Passes made.
    pub iterations: usize,
    /// Converged.
    pub converged: bool,
    /// The segments identified on.
    pub data: Vec<String>,
    /// The data files identified on, relative to the folder of the saved JSON (absolute once read
    /// by [`SavedModel::read`]): `predict` without `--data` applies the model to them.
    #[serde(default)]
    pub data_files: Vec<String>,
    /// Their companion (column map or aircraft file), if read through one; relative likewise.
    #[serde(default)]
    pub with: Option<String>,
    /// The sample period, s.
    pub dt_s: f64,
    /// Every parameter.
    pub parameters: Vec<SavedParameter>,
    /// Measurement-noise variances used (estimated, with `estimate_noise`).
    pub noise_variance: Vec<f64>,
    /// Simulation fit on the identification segments.
    pub fit: Vec<OutputFit>,
    /// Validation segments, if any.
    pub validation_data: Vec<String>,
    /// Simulation fit on them.
    pub validation: Vec<OutputFit>,
}

impl SavedModel {
    /// Reads a saved model (`identification.json`), its paths resolved against the JSON's folder,
    /// so that it applies from any working directory.
    pub fn read(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut saved: SavedModel = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}: {e} (give the identification.json that `aerosid fem` wrote)",
                path.display()
            )
        })?;
        let dir = path.parent().unwrap_or(Path::new(""));
        let resolve = |p: &str| dir.join(p).display().to_string();
        // A saved model without `data_files` holds the model path as given to `fem` (relative to
        // where it ran), and is read as it is.
        if !saved.data_files.is_empty() {
            saved.model_file = resolve(&saved.model_file);
        }
        saved.data_files = saved.data_files.iter().map(|p| resolve(p)).collect();
        saved.with = saved.with.as_deref().map(resolve);
        Ok(saved)
    }

    /// The saved model ready to simulate: the stored text parsed (relative paths against the
    /// original model file's folder) and every parameter set to its saved value.
    pub fn model(&self) -> Result<UserModel, String> {
        let mut m = UserModel::parse(&self.model_toml, Path::new(&self.model_file)).map_err(|e| e.0)?;
        for sp in &self.parameters {
            if sp.fixed && !m.file.parameters.iter().any(|p| p.name == sp.name && p.fixed) {
                m.fix(&sp.name, sp.value).map_err(|e| e.0)?;
            }
        }
        if m.file.parameters.len() != self.parameters.len() {
            return Err(format!(
                "saved model: {} parameters, its model text has {}",
                self.parameters.len(),
                m.file.parameters.len()
            ));
        }
        let values: Vec<f64> = m
            .file
            .parameters
            .iter()
            .map(|p| {
                self.parameters
                    .iter()
                    .find(|s| s.name == p.name)
                    .map(|s| s.value)
                    .ok_or_else(|| format!("saved model: parameter {} has no saved value", p.name))
            })
            .collect::<Result<_, _>>()?;
        m.set_values(&values);
        Ok(m)
    }
}

/// What the `fem` command takes.
#[derive(Debug, Clone, Default)]
pub struct FemArgs {
    /// The model file.
    pub model: PathBuf,
    /// Data files (default: the model's `[data] file`).
    pub data: Vec<PathBuf>,
    /// The companion of the data and validation files read by the measured-data readers: a column
    /// map or aircraft file (default: the model's `[data] with` when `data` is empty, the model's
    /// own file read; none for other files, as for `gaps`).
    pub with: Option<PathBuf>,
    /// Segments of each data file (default: all of it).
    pub segments: Vec<Range>,
    /// Validation files.
    pub validate: Vec<PathBuf>,
    /// Validation segments (of the validation files, or of the data files if none).
    pub validate_segments: Vec<Range>,
    /// Parameters to fix.
    pub fix: Vec<(String, f64)>,
    /// Output folder.
    pub out: PathBuf,
}

fn load_segments(
    model: &UserModel,
    files: &[PathBuf],
    companion: Option<&Path>,
    ranges: &[Range],
) -> Result<Vec<Segment>, String> {
    let mut segs = Vec::new();
    for f in files {
        segs.extend(read_segments_with(model, f, companion, ranges)?);
    }
    Ok(segs)
}

/// `path` relative to the folder `dir` (both made absolute, symbolic links resolved), or absolute
/// when the two share no folder but the root (a data set elsewhere on the disk stays found when
/// the output folder moves). A dozen lines instead of a path-diffing crate: the paths are
/// canonical, so comparing components is all it takes.
fn relative_to(path: &Path, dir: &Path) -> String {
    let (Ok(p), Ok(d)) = (path.canonicalize(), dir.canonicalize()) else {
        return std::path::absolute(path)
            .unwrap_or_else(|_| path.to_path_buf())
            .display()
            .to_string();
    };
    let (pc, dc): (Vec<_>, Vec<_>) = (p.components().collect(), d.components().collect());
    let common = pc.iter().zip(&dc).take_while(|(a, b)| a == b).count();
    if !pc[..common]
        .iter()
        .any(|c| matches!(c, std::path::Component::Normal(_)))
    {
        return p.display().to_string();
    }
    let mut rel = PathBuf::new();
    for _ in common..dc.len() {
        rel.push("..");
    }
    for c in &pc[common..] {
        rel.push(c);
    }
    rel.display().to_string()
}

/// The result of [`run_fem`].
#[derive(Debug, Clone)]
pub struct FemRun {
    /// The saved model (also written to `identification.json`).
    pub saved: SavedModel,
    /// A text report.
    pub text: String,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// `aerosid fem`: identify, validate, save, plot.
pub fn run_fem(args: &FemArgs) -> Result<FemRun, String> {
    let mut model = UserModel::read(&args.model).map_err(|e: ModelError| e.0)?;
    for (n, v) in &args.fix {
        model.fix(n, *v).map_err(|e| e.0)?;
    }
    let (data, companion) = data_and_companion(args, &model)?;
    let segs = load_segments(&model, &data, companion.as_deref(), &args.segments)?;
    apply_aircraft(&mut model, &segs)?;
    let dt = sample_period(&segs)?;
    let id = identify(&model, &segs)?;
    let estimates = set_estimates(&mut model, &segs, &id)?;
    let sims: Vec<_> = segs.iter().map(|s| simulate(&model, s, dt)).collect();
    let fit = fit_metrics(&model, &segs, &sims);
    let identification = Fitted { segs, sims, fit };
    let validation = validate(args, &mut model, &data, companion.as_deref(), dt)?;
    let est = &model.file.estimation;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let saved = SavedModel {
        model_file: relative_to(&args.model, &args.out),
        model_name: model.file.name.clone(),
        model_toml: model.text.clone(),
        method: match est.method {
            Method::FilterError => "filter-error",
            Method::OutputError => "output-error",
        }
        .into(),
        iteration: match est.iteration {
            Iteration::Recursive => "recursive",
            Iteration::GaussNewton => "gauss-newton",
        }
        .into(),
        iterations: id.iterations,
        converged: id.converged,
        data: identification.segs.iter().map(|s| s.label.clone()).collect(),
        data_files: data.iter().map(|d| relative_to(d, &args.out)).collect(),
        with: companion.as_deref().map(|c| relative_to(c, &args.out)),
        dt_s: dt,
        parameters: saved_parameters(&model, &estimates),
        noise_variance: id.noise_variance.clone(),
        fit: identification.fit.clone(),
        validation_data: validation.segs.iter().map(|s| s.label.clone()).collect(),
        validation: validation.fit.clone(),
    };
    let files = write_fem_outputs(&args.out, &model, &saved, &identification, &validation, &id.history)?;
    let text = report_text(&saved);
    Ok(FemRun { saved, text, files })
}

/// The data files (`--data`, else the model's `[data] file`) and their companion. The model's
/// `[data] with` belongs to its `[data] file`; other files name theirs, as for `gaps` (a map
/// describes one file layout).
fn data_and_companion(args: &FemArgs, model: &UserModel) -> Result<(Vec<PathBuf>, Option<PathBuf>), String> {
    let data = if args.data.is_empty() {
        vec![model.default_data().ok_or_else(|| {
            format!(
                "{}: no data: give --data FILE or set [data] file in the model file",
                args.model.display()
            )
        })?]
    } else {
        args.data.clone()
    };
    let companion = match (&args.with, args.data.is_empty()) {
        (Some(w), _) => Some(w.clone()),
        (None, true) => model.default_companion(),
        (None, false) => None,
    };
    Ok((data, companion))
}

/// Every parameter's value and standard deviations (coloured residuals, white residuals; `None`
/// for a fixed one), indexed as the model's parameters.
struct Estimates {
    values: Vec<f64>,
    sigma: Vec<Option<f64>>,
    sigma_white: Vec<Option<f64>>,
}

/// Puts the identified values into the model and returns them with their standard deviations.
fn set_estimates(model: &mut UserModel, segs: &[Segment], id: &Identified) -> Result<Estimates, String> {
    let mut values = model.values().to_vec();
    let sig = sigma_of(&gust_covariance(model, segs, id)?.0);
    let sig_white = sigma_of(&id.covariance);
    let mut sigma = vec![None; values.len()];
    let mut sigma_white = vec![None; values.len()];
    for (k, &i) in model.free().iter().enumerate() {
        values[i] = id.p[k];
        sigma[i] = Some(sig[k]);
        sigma_white[i] = Some(sig_white[k]);
    }
    model.set_values(&values);
    Ok(Estimates {
        values,
        sigma,
        sigma_white,
    })
}

/// Segments, their simulations by the identified model, and each output's fit.
struct Fitted {
    segs: Vec<Segment>,
    sims: Vec<Vec<YVec>>,
    fit: Vec<OutputFit>,
}

/// The validation segments (`--validate` files, else the identification's files when only
/// `--validate-segment` is given; none without either) simulated by the identified model.
fn validate(
    args: &FemArgs,
    model: &mut UserModel,
    data: &[PathBuf],
    companion: Option<&Path>,
    dt: f64,
) -> Result<Fitted, String> {
    let val_files = if args.validate.is_empty() && !args.validate_segments.is_empty() {
        data.to_vec()
    } else {
        args.validate.clone()
    };
    let segs = if val_files.is_empty() {
        Vec::new()
    } else {
        load_segments(model, &val_files, companion, &args.validate_segments)?
    };
    apply_aircraft(model, &segs)?;
    let sims: Vec<_> = segs.iter().map(|s| simulate(model, s, dt)).collect();
    let fit = if segs.is_empty() {
        Vec::new()
    } else {
        fit_metrics(model, &segs, &sims)
    };
    Ok(Fitted { segs, sims, fit })
}

/// The saved parameters: name, estimate, standard deviations, and the model file's settings.
fn saved_parameters(model: &UserModel, e: &Estimates) -> Vec<SavedParameter> {
    model
        .file
        .parameters
        .iter()
        .enumerate()
        .map(|(i, p)| SavedParameter {
            name: p.name.clone(),
            value: e.values[i],
            sigma: e.sigma[i],
            sigma_white: e.sigma_white[i],
            fixed: p.fixed,
            start: p.start,
            reference: p.reference,
        })
        .collect()
}

/// Writes `identification.json` and the figures (identification fit, validation fit when
/// validated, parameter history of the recursive filter when it kept one) into `out`.
fn write_fem_outputs(
    out: &Path,
    model: &UserModel,
    saved: &SavedModel,
    identification: &Fitted,
    validation: &Fitted,
    history: &[(usize, f64, PVec, PVec)],
) -> Result<Vec<PathBuf>, String> {
    let json_path = out.join("identification.json");
    let json = serde_json::to_string_pretty(saved).map_err(|e| e.to_string())?;
    std::fs::write(&json_path, json).map_err(|e| format!("{}: {e}", json_path.display()))?;
    let mut files = vec![json_path];
    let write = |name: &str, figure: Figure| -> Result<PathBuf, String> {
        let path = out.join(name);
        figure
            .write_svg(&path)
            .map_err(|e: PlotError| format!("{}: {e:?}", path.display()))?;
        Ok(path)
    };
    let title = |what: &str| format!("{}: {what} data", model.file.name);
    files.push(write(
        "identification_fit.svg",
        fit_figure(
            model,
            &title("identification"),
            &identification.segs,
            &identification.sims,
        ),
    )?);
    if !validation.segs.is_empty() {
        files.push(write(
            "validation_fit.svg",
            fit_figure(model, &title("validation"), &validation.segs, &validation.sims),
        )?);
    }
    if !history.is_empty() {
        files.push(write("parameters.svg", history_figure(model, history))?);
    }
    Ok(files)
}

/// The saved model as a text report.
pub fn report_text(s: &SavedModel) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} ({}, {}; {} pass(es), {})",
        s.model_name,
        s.method,
        s.iteration,
        s.iterations,
        if s.converged { "converged" } else { "NOT converged" }
    );
    for d in &s.data {
        let _ = writeln!(out, "  data: {d}");
    }
    let _ = writeln!(
        out,
        "{:>12} {:>14} {:>12} {:>12} {:>14} {:>14} {:>7}",
        "parameter", "estimate", "σ", "σ white", "start", "reference", "|Δ|/σ"
    );
    for p in &s.parameters {
        let sig = p.sigma.map_or("fixed".to_string(), |v| format!("{v:.5}"));
        let white = p.sigma_white.map_or(String::new(), |v| format!("{v:.5}"));
        let (r, z) = match (p.reference, p.sigma) {
            (Some(r), Some(sg)) => (format!("{r:+.6}"), format!("{:.2}", (p.value - r).abs() / sg)),
            (Some(r), None) => (format!("{r:+.6}"), String::new()),
            _ => (String::new(), String::new()),
        };
        let _ = writeln!(
            out,
            "{:>12} {:>+14.6} {:>12} {white:>12} {:>+14.6} {r:>14} {z:>7}",
            p.name, p.value, sig, p.start
        );
    }
    fit_table(&mut out, "simulation on the identification data:", &s.fit);
    if !s.validation.is_empty() {
        for d in &s.validation_data {
            let _ = writeln!(out, "  validation: {d}");
        }
        fit_table(&mut out, "simulation on the validation data:", &s.validation);
    }
    out
}

pub fn fit_table(out: &mut String, title: &str, fits: &[OutputFit]) {
    let _ = writeln!(out, "{title}");
    let _ = writeln!(
        out,
        "{:>10} {:>8} {:>12} {:>8} {:>8}",
        "output", "samples", "RMS", "R²", "Theil U"
    );
    for f in fits {
        let _ = writeln!(
            out,
            "{:>10} {:>8} {:>12.4e} {:>8.4} {:>8.4}",
            f.name, f.samples, f.rms, f.r2, f.theil_u
        );
    }
    let _ = writeln!(out, "{THEIL_LEGEND}");
}

/// Measured vs simulated and the residual, per output, all segments one after the other.
fn fit_figure(model: &UserModel, title: &str, segs: &[Segment], sims: &[Vec<YVec>]) -> Figure {
    let mut fig = Figure::new("t from the start of the file (s)").title(title);
    for (i, o) in model.file.outputs.iter().enumerate() {
        let label = if o.unit.is_empty() {
            o.name.clone()
        } else {
            format!("{} ({})", o.name, o.unit)
        };
        // NaN between segments splits the lines there.
        let mut tt = Vec::new();
        let (mut m, mut p) = (Vec::new(), Vec::new());
        for (s, y) in segs.iter().zip(sims) {
            for k in 0..s.t_s.len() {
                tt.push(s.t_s[k]);
                m.push(s.y[k][i]);
                p.push(y[k][i]);
            }
            tt.push(f64::NAN);
            m.push(f64::NAN);
            p.push(f64::NAN);
        }
        let r: Vec<f64> = m.iter().zip(&p).map(|(a, b)| a - b).collect();
        fig = fig
            .panel(
                Panel::new(label.clone(), label.clone())
                    .line(Line::new("measured", &tt, &m, Colour::BLACK))
                    .line(Line::new("model", &tt, &p, Colour::BLUE)),
            )
            .panel(Panel::new(format!("{} residual", o.name), "residual").line(Line::new(
                "measured − model",
                &tt,
                &r,
                Colour::VERMILLION,
            )));
    }
    fig
}

/// The recursive filter's free parameters ±σ against time (segments one after the other).
fn history_figure(model: &UserModel, history: &[(usize, f64, PVec, PVec)]) -> Figure {
    let mut fig = Figure::new("t from the start of the file (s)").title(format!(
        "{}: parameter estimates ±σ (recursive filter)",
        model.file.name
    ));
    for (k, &i) in model.free().iter().enumerate() {
        // NaN where a new segment starts splits the lines there.
        let (mut t, mut est, mut sig) = (Vec::new(), Vec::new(), Vec::new());
        for (j, (seg, time, p, s)) in history.iter().enumerate() {
            if j > 0 && history[j - 1].0 != *seg {
                t.push(f64::NAN);
                est.push(f64::NAN);
                sig.push(f64::NAN);
            }
            t.push(*time);
            est.push(p[k]);
            sig.push(s[k]);
        }
        let name = &model.file.parameters[i].name;
        fig = fig.panel(
            Panel::new(name.clone(), name.clone())
                .band(crate::plot::Band::around("±σ", &t, &est, &sig, 1.0, Colour::BLUE))
                .line(Line::new("estimate", &t, &est, Colour::BLUE)),
        );
    }
    fig
}

/// What `aerosid predict` returns.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Prediction {
    /// The saved identification applied.
    pub saved_model: String,
    /// The segments predicted.
    pub data: Vec<String>,
    /// Fit per output.
    pub fit: Vec<OutputFit>,
}

/// `aerosid predict`: apply a saved model (`identification.json`) to other data; writes
/// `prediction.json` and `prediction.svg` into `out` ([`run_predict_with`] with the companion the
/// model was identified with).
pub fn run_predict(
    saved_path: &Path,
    data: &[PathBuf],
    ranges: &[Range],
    out: &Path,
) -> Result<(Prediction, String, Vec<PathBuf>), String> {
    run_predict_with(saved_path, data, None, ranges, out)
}

/// `aerosid predict` with a companion: without `data`, the files the model was identified on
/// (stored with it, resolved against the JSON's folder, so from any working directory) and,
/// unless `with` says otherwise, their companion; `data` are read with `with` (a column map or
/// aircraft file; none for a `.ulg`/`.bin` read without one).
pub fn run_predict_with(
    saved_path: &Path,
    data: &[PathBuf],
    with: Option<&Path>,
    ranges: &[Range],
    out: &Path,
) -> Result<(Prediction, String, Vec<PathBuf>), String> {
    let saved = SavedModel::read(saved_path)?;
    let mut model = saved.model()?;
    let (files, companion) = if !data.is_empty() {
        (data.to_vec(), with.map(Path::to_path_buf))
    } else if !saved.data_files.is_empty() {
        (
            saved.data_files.iter().map(PathBuf::from).collect(),
            with.map(Path::to_path_buf)
                .or_else(|| saved.with.as_ref().map(PathBuf::from)),
        )
    } else {
        let file = model
            .default_data()
            .ok_or_else(|| format!("{}: no data: give --data FILE", saved_path.display()))?;
        (
            vec![file],
            with.map(Path::to_path_buf).or_else(|| model.default_companion()),
        )
    };
    let segs = load_segments(&model, &files, companion.as_deref(), ranges)?;
    apply_aircraft(&mut model, &segs)?;
    let dt = sample_period(&segs)?;
    if (dt / saved.dt_s - 1.0).abs() > 1e-3 {
        return Err(format!(
            "{}: sample period {dt} s, the model was identified at {} s; resample the data to it",
            files[0].display(),
            saved.dt_s
        ));
    }
    let sims: Vec<_> = segs.iter().map(|s| simulate(&model, s, dt)).collect();
    let fit = fit_metrics(&model, &segs, &sims);
    let pred = Prediction {
        saved_model: saved_path.display().to_string(),
        data: segs.iter().map(|s| s.label.clone()).collect(),
        fit,
    };
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let jp = out.join("prediction.json");
    std::fs::write(&jp, serde_json::to_string_pretty(&pred).map_err(|e| e.to_string())?)
        .map_err(|e| format!("{}: {e}", jp.display()))?;
    let sp = out.join("prediction.svg");
    fit_figure(&model, &format!("{}: prediction", model.file.name), &segs, &sims)
        .write_svg(&sp)
        .map_err(|e| format!("{}: {e:?}", sp.display()))?;
    let mut txt = String::new();
    let _ = writeln!(txt, "{} applied to:", saved.model_name);
    for d in &pred.data {
        let _ = writeln!(txt, "  {d}");
    }
    fit_table(&mut txt, "simulation:", &pred.fit);
    Ok((pred, txt, vec![jp, sp]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The FFT lag sums of the coloured-residual sandwich equal the direct double sum
    /// `Σᵢ Σⱼ Sᵢᵀ W R_vv(j−i) W Sⱼ`, `R_vv(k) = (1/N) Σₜ vₜ vₜ₊ₖᵀ` (cross-output terms included).
    #[test]
    fn the_fft_sandwich_equals_the_direct_sums() {
        // GIVEN seeded coloured residuals of two outputs and three parameters' sensitivities
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let (n, ny, np) = (37, 2, 3);
        let mut v = vec![YVec::zeros(); n];
        let mut prev = [0.0; 2];
        for e in v.iter_mut() {
            for a in 0..ny {
                prev[a] = 0.8 * prev[a] + rng.random_range(-1.0..1.0);
                e[a] = prev[a] + 0.3 * prev[1 - a];
            }
        }
        let sens: Vec<Vec<YVec>> = (0..np)
            .map(|_| {
                (0..n)
                    .map(|_| YVec::from_fn(|i, _| if i < ny { rng.random_range(-1.0..1.0) } else { 0.0 }))
                    .collect()
            })
            .collect();
        let w = [2.0, 0.5];
        // WHEN both are formed
        let fft = lag_sandwich(&mut realfft::RealFftPlanner::new(), &v, &sens, &w);
        let r = |a: usize, b: usize, k: isize| -> f64 {
            // R_ab(k) = (1/N) Σ_t v_{t,a} v_{t+k,b}; R_ab(−k) = R_ba(k).
            if k < 0 {
                return (0..n - (-k) as usize)
                    .map(|t| v[t][b] * v[t + (-k) as usize][a])
                    .sum::<f64>()
                    / n as f64;
            }
            (0..n - k as usize).map(|t| v[t][a] * v[t + k as usize][b]).sum::<f64>() / n as f64
        };
        // THEN they agree to rounding
        for p in 0..np {
            for q in 0..np {
                let mut direct = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        for a in 0..ny {
                            for b in 0..ny {
                                direct +=
                                    sens[p][i][a] * w[a] * r(a, b, j as isize - i as isize) * w[b] * sens[q][j][b];
                            }
                        }
                    }
                }
                assert!(
                    (fft[(p, q)] - direct).abs() < 1e-10 * direct.abs().max(1.0),
                    "{p},{q}: {} vs {direct}",
                    fft[(p, q)]
                );
            }
        }
    }
}
