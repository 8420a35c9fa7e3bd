//! A user-defined model for the filter error / output error method, read from a TOML file.
//!
//! The core's filter ([`aerosid_core::fem::FilterError`]) is generic over compile-time dimensions;
//! a model read at run time is run in it at fixed maximum sizes ([`MAX_X`] states, [`MAX_U`]
//! inputs, [`MAX_Y`] outputs, [`MAX_P`] free parameters) with the unused entries padded so that
//! they carry no information: a padded state has `ẋ = 0`, no process noise and unit variance; a
//! padded output is `y = h = 0` with unit noise variance (its row of `C`, `D` is zero, so its
//! gain is exactly zero); a padded parameter has a zero sensitivity column and a unit prior
//! variance, which the Kalman update of eq. 10–12 never touches (its gain row is `P̄_p Hᵀ…` with a
//! block-diagonal `P̄_p` and a zero column of `H`). The active block is therefore the same
//! computation as a model compiled at its exact size (checked on the HFB-320 in
//! `tests/workflow.rs`).
//!
//! # File format
//! ```toml
//! name = "HFB-320 longitudinal"
//!
//! [data]                 # how a data file is read
//! file = "../data/flight/hfb320_1_10.asc"   # default data file, relative to this file's folder
//! columns = 20           # numbers on every line (a line with another count is refused)
//! time_column = 1        # 1-based
//! # Without `columns` and `time_column` the inputs and outputs name measured channels instead,
//! # and a data file is read as `aerosid gaps` reads it (`crate::io::read_measured_with`):
//! # with = "../data/maps/hfb320.map"   # default companion: column map or aircraft file
//!
//! [constants]            # numbers, in order; each may be used by the later ones and the equations
//! V0 = 104.67
//! mass = "aircraft.mass_kg"  # a value of the data's aircraft file (see `AIRCRAFT_CONSTANTS`)
//!
//! [definitions]          # intermediate expressions, in order; each may use the earlier ones
//! qbar = "0.5*rho*V^2"
//!
//! [[states]]             # ẋ = f(x, u, p): one equation per state
//! name = "V"
//! equation = "-qbar*SoM*CD + g*sin(alpha - theta)"
//! initial = "V"          # a number, or the name of an output whose first measured value starts it
//! process_noise = 0.358553   # F of Q = F Fᵀ (diagonal), default 0
//! initial_variance = 1.7587e-2 # default: the noise variance of the output named in `initial`
//!
//! [[inputs]]
//! name = "de"
//! column = 2             # with [data] columns; or `channel = "$2"`, or a combination of columns
//! scale = 1.0            # multiplies the column (e.g. 0.017453292519943295 for degrees → rad)
//! # Named channels (no [data] columns): `channel = "elevator"` (a `Quantity` name as column
//! # maps write it, or a project CSV column such as `elevator_rad`), or a derived input, a linear
//! # combination as column maps write one: `channel = "0.5*thrust + 0.5*thrust_difference"`.
//!
//! [[outputs]]            # y = h(x, u, p)
//! name = "V"
//! equation = "V"
//! column = 5             # or `channel = "airspeed"` (as for an input)
//! noise_variance = 1.7587e-2
//!
//! [[parameters]]
//! name = "CD0"
//! start = 5.67516e-3
//! fixed = false          # a fixed parameter keeps its start value and is not estimated
//! prior_sigma = 0.01     # default: Bauer–Andrisani max(0.25|start|, estimation.prior_sigma_floor)
//! reference = 0.122688   # optional published value; the report gives |estimate − reference|/σ
//!
//! [estimation]
//! method = "filter-error"      # or "output-error" (no process noise, no state correction)
//! iteration = "recursive"      # one pass of the on-line filter (seed 001), or "gauss-newton"
//! integrator = "rk4"           # "euler" (seed 001 eq. 3), "rk2", "rk4"
//! input_hold = "linear"        # "zero" or "linear"
//! sensitivity = "propagated"   # or "one-step" (seed 001 eq. 6)
//! ```
//! A linear model may instead be written as matrices: a `[linear]` table with `A`, `B`, `C`, `D`
//! (arrays of rows; entries numbers or expression strings such as `"1 + Zq"`) and optional bias
//! vectors `f0`, `h0`; the state and output equations are then `ẋ = A x + B u + f0`,
//! `y = C x + D u + h0` and the `equation` keys are left out.
//!
//! Expressions are parsed by the `exmex` crate (`+ - * / ^`, `sin cos tan exp ln sqrt abs …`,
//! `PI`); names are letters, digits and `_`. Every error names the file, the field and the fix.

use crate::io::colmap::{parse_terms, Expr, Source};
use crate::io::measured::{Aircraft, Quantity};
use crate::io::project_csv::csv_column;
use aerosid_core::fem::{InputHold, Integrator, Model, Sensitivity};
use exmex::prelude::*;
use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Most states a model file may have.
pub const MAX_X: usize = 8;
/// Most inputs (a physical model with measured states as inputs — airspeed, attitude, the other
/// axis's rates, β, propeller speed, density — beside the surfaces needs nine).
pub const MAX_U: usize = 10;
/// Most outputs.
pub const MAX_Y: usize = 10;
/// Most free (estimated) parameters.
pub const MAX_P: usize = 16;

/// The state vector of a user model (padded).
pub type XVec = SVector<f64, MAX_X>;
/// The input vector (padded).
pub type UVec = SVector<f64, MAX_U>;
/// The output vector (padded).
pub type YVec = SVector<f64, MAX_Y>;
/// The free-parameter vector (padded).
pub type PVec = SVector<f64, MAX_P>;

/// How a state starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Initial {
    /// A given value.
    Value(f64),
    /// The first measured value of the named output.
    Output(String),
}

/// A `[[states]]` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateSpec {
    /// Name (used in the equations).
    pub name: String,
    /// Unit, for the report.
    #[serde(default)]
    pub unit: String,
    /// `ẋ` of this state (absent with `[linear]`).
    #[serde(default)]
    pub equation: Option<String>,
    /// How it starts.
    pub initial: Initial,
    /// Its variance at the start; default the noise variance of the output named in `initial`.
    #[serde(default)]
    pub initial_variance: Option<f64>,
    /// Process-noise distribution `F` (σ per √s) of this state: `Q = F²`.
    #[serde(default)]
    pub process_noise: f64,
}

/// An `[[inputs]]` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputSpec {
    /// Name.
    pub name: String,
    /// Unit (after scaling), for the report.
    #[serde(default)]
    pub unit: String,
    /// 1-based column of a file read by column number (`[data] columns`).
    #[serde(default)]
    pub column: Option<usize>,
    /// The measured channel, or a linear combination of channels as a column map writes it
    /// (`0.5*thrust + 0.5*thrust_difference`; `$N` for columns of a file read by number).
    #[serde(default)]
    pub channel: Option<String>,
    /// Factor applied to the column or channel.
    #[serde(default = "one")]
    pub scale: f64,
}

/// An `[[outputs]]` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Name.
    pub name: String,
    /// Unit (after scaling), for the report.
    #[serde(default)]
    pub unit: String,
    /// `y` of this output (absent with `[linear]`).
    #[serde(default)]
    pub equation: Option<String>,
    /// 1-based column of the measurement (`[data] columns`).
    #[serde(default)]
    pub column: Option<usize>,
    /// The measured channel or a linear combination of channels (as for an input).
    #[serde(default)]
    pub channel: Option<String>,
    /// Factor applied to the column or channel.
    #[serde(default = "one")]
    pub scale: f64,
    /// Measurement-noise variance `R` (eq. 2), in the output's (scaled) unit squared.
    pub noise_variance: f64,
}

/// A `[[parameters]]` entry.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamSpec {
    /// Name.
    pub name: String,
    /// Starting value (the value, if fixed).
    pub start: f64,
    /// Held at `start`, not estimated.
    #[serde(default)]
    pub fixed: bool,
    /// σ of the prior; default Bauer–Andrisani.
    #[serde(default)]
    pub prior_sigma: Option<f64>,
    /// A published value to compare with (reported as `|estimate − reference|/σ`).
    #[serde(default)]
    pub reference: Option<f64>,
}

/// The `[data]` table.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSpec {
    /// The default data file, relative to the model file's folder.
    #[serde(default)]
    pub file: Option<String>,
    /// The default companion of a data file read by the measured-data readers: its column map or
    /// aircraft file, relative to the model file's folder.
    #[serde(default)]
    pub with: Option<String>,
    /// Numbers on every line of a file read by column number; absent when the inputs and outputs
    /// name measured channels.
    #[serde(default)]
    pub columns: Option<usize>,
    /// 1-based column of the time, s (with `columns`).
    #[serde(default)]
    pub time_column: Option<usize>,
}

/// How a model's data are read.
#[derive(Debug, Clone, PartialEq)]
pub enum Layout {
    /// Whitespace-separated numbers, no header, `columns` on every line, columns by number.
    Columns {
        /// Numbers on every line.
        columns: usize,
        /// 1-based column of the time.
        time_column: usize,
    },
    /// Any file the measured-data readers read ([`crate::io::read_measured_with`]): the inputs
    /// and outputs name channels. The sources `$k` of [`UserModel::sources`] are 1-based indices
    /// into this list.
    Channels(Vec<Quantity>),
}

/// Which method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Filter error: process noise, state filter (seed 001).
    #[default]
    FilterError,
    /// Output error: no process noise; the state is the model's simulation.
    OutputError,
}

/// How the estimate is iterated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Iteration {
    /// One pass of the recursive filter (seed 001), the parameters carried from segment to segment.
    #[default]
    Recursive,
    /// Gauss–Newton passes to convergence (`fem_batch`).
    GaussNewton,
}

/// The `[estimation]` table.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimationSpec {
    /// Filter or output error.
    #[serde(default)]
    pub method: Method,
    /// Recursive or Gauss–Newton.
    #[serde(default)]
    pub iteration: Iteration,
    /// `euler`, `rk2` or `rk4`.
    #[serde(default = "rk4")]
    pub integrator: String,
    /// `zero` or `linear`.
    #[serde(default = "linear_hold")]
    pub input_hold: String,
    /// `one-step` or `propagated`.
    #[serde(default = "propagated")]
    pub sensitivity: String,
    /// σ floor of the Bauer–Andrisani prior.
    #[serde(default = "floor")]
    pub prior_sigma_floor: f64,
    /// Most Gauss–Newton iterations.
    #[serde(default = "twenty")]
    pub max_iterations: usize,
    /// Convergence: every parameter moved by less than this many σ.
    #[serde(default = "tol")]
    pub tolerance_sigma: f64,
    /// Output error with Gauss–Newton: replace `R` after each pass by the covariance (diagonal) of
    /// the residuals (the usual relaxation of the output error method).
    #[serde(default)]
    pub estimate_noise: bool,
}

impl Default for EstimationSpec {
    fn default() -> Self {
        Self {
            method: Method::default(),
            iteration: Iteration::default(),
            integrator: rk4(),
            input_hold: linear_hold(),
            sensitivity: propagated(),
            prior_sigma_floor: floor(),
            max_iterations: twenty(),
            tolerance_sigma: tol(),
            estimate_noise: false,
        }
    }
}

fn one() -> f64 {
    1.0
}
fn rk4() -> String {
    "rk4".into()
}
fn linear_hold() -> String {
    "linear".into()
}
fn propagated() -> String {
    "propagated".into()
}
fn floor() -> f64 {
    0.05
}
fn twenty() -> usize {
    20
}
fn tol() -> f64 {
    0.01
}

/// The `[linear]` table: `ẋ = A x + B u + f0`, `y = C x + D u + h0`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearSpec {
    /// `NX × NX`.
    #[serde(rename = "A")]
    pub a: Vec<Vec<toml::Value>>,
    /// `NX × NU`.
    #[serde(rename = "B")]
    pub b: Vec<Vec<toml::Value>>,
    /// `NY × NX`.
    #[serde(rename = "C")]
    pub c: Vec<Vec<toml::Value>>,
    /// `NY × NU`; default zero.
    #[serde(rename = "D", default)]
    pub d: Option<Vec<Vec<toml::Value>>>,
    /// State bias, default zero.
    #[serde(default)]
    pub f0: Option<Vec<toml::Value>>,
    /// Output bias, default zero.
    #[serde(default)]
    pub h0: Option<Vec<toml::Value>>,
}

/// The whole file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// A name for the report.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Data layout.
    #[serde(default)]
    pub data: DataSpec,
    /// Named numbers, in order.
    #[serde(default)]
    pub constants: toml::Table,
    /// Named expressions, in order.
    #[serde(default)]
    pub definitions: toml::Table,
    /// States.
    pub states: Vec<StateSpec>,
    /// Inputs.
    #[serde(default)]
    pub inputs: Vec<InputSpec>,
    /// Outputs.
    pub outputs: Vec<OutputSpec>,
    /// Parameters.
    pub parameters: Vec<ParamSpec>,
    /// A linear model in matrix form, instead of the equations.
    #[serde(default)]
    pub linear: Option<LinearSpec>,
    /// Settings.
    #[serde(default)]
    pub estimation: EstimationSpec,
}

/// One compiled expression: the parsed expression and, per variable it uses (in exmex's order),
/// the slot of the environment the value comes from.
#[derive(Debug, Clone)]
struct Compiled {
    expr: FlatEx<f64>,
    slots: Vec<usize>,
}

impl Compiled {
    fn eval(&self, env: &[f64]) -> f64 {
        let mut vals = [0.0; 32];
        let n = self.slots.len();
        for (v, &s) in vals.iter_mut().zip(&self.slots) {
            *v = env[s];
        }
        // Variables counted and the expression checked at load; evaluation of a parsed expression
        // with the right number of values cannot fail, NaN stands for the impossible.
        self.expr.eval(&vals[..n]).unwrap_or(f64::NAN)
    }
}

/// Most distinct names one expression may use.
const MAX_VARS_PER_EXPRESSION: usize = 32;

/// A model read from a file, ready to run in the core's filter (as `&UserModel`).
#[derive(Debug, Clone)]
pub struct UserModel {
    /// The file as read.
    pub file: ModelFile,
    /// Where it was read from (its folder resolves relative paths).
    pub path: PathBuf,
    /// The file's text (stored with an identification so that it can be re-applied).
    pub text: String,
    /// How its data are read.
    pub layout: Layout,
    /// Where each input, then each output, comes from: a combination of the layout's columns
    /// (`Source::Column`), its `factor` the entry's `scale`.
    pub sources: Vec<Expr>,
    /// Environment layout: `[constants | parameters (all) | states | inputs | definitions]`.
    n_const: usize,
    const_values: Vec<f64>,
    /// Constants taken from the data's aircraft file: `(index into const_values, index into
    /// AIRCRAFT_CONSTANTS)`; NaN until [`UserModel::set_aircraft`].
    aircraft_constants: Vec<(usize, usize)>,
    /// Indices (into `file.parameters`) of the free parameters, in order.
    free: Vec<usize>,
    /// Current values of every parameter (fixed ones used as they are).
    values: Vec<f64>,
    defs: Vec<Compiled>,
    state_eqs: Vec<Compiled>,
    output_eqs: Vec<Compiled>,
}

/// Why a model file was refused.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError(pub String);

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ModelError {}

fn err<T>(file: &str, field: &str, msg: impl std::fmt::Display) -> Result<T, ModelError> {
    Err(ModelError(format!("{file}: {field}: {msg}")))
}

fn parse_integrator(s: &str) -> Option<Integrator> {
    match s {
        "euler" => Some(Integrator::Euler),
        "rk2" => Some(Integrator::Rk2),
        "rk4" => Some(Integrator::Rk4),
        _ => None,
    }
}

fn parse_hold(s: &str) -> Option<InputHold> {
    match s {
        "zero" => Some(InputHold::Zero),
        "linear" => Some(InputHold::Linear),
        _ => None,
    }
}

fn parse_sensitivity(s: &str) -> Option<Sensitivity> {
    match s {
        "one-step" => Some(Sensitivity::OneStep),
        "propagated" => Some(Sensitivity::Propagated),
        _ => None,
    }
}

/// A matrix entry of `[linear]` as expression text.
fn entry_text(v: &toml::Value) -> Option<String> {
    match v {
        // Plain decimal (`Display` of an f64 never uses an exponent): the expression parser
        // reads `6.54e-1` as `6.54e - 1`.
        toml::Value::Float(x) if *x == 0.0 => Some("0".into()),
        toml::Value::Float(x) => Some(format!("{x}")),
        toml::Value::Integer(i) => Some(format!("{i}")),
        toml::Value::String(s) => Some(s.clone()),
        _ => None,
    }
}

/// `Σ_j M[i][j]·names[j]` as expression text, checking the shape.
fn linear_row(
    file: &str,
    field: &str,
    m: &[Vec<toml::Value>],
    rows: usize,
    names: &[String],
) -> Result<Vec<String>, ModelError> {
    if m.len() != rows {
        return err(file, field, format!("{} rows; the model has {rows}", m.len()));
    }
    let mut out = Vec::new();
    for (i, row) in m.iter().enumerate() {
        if row.len() != names.len() {
            return err(
                file,
                &format!("{field} row {}", i + 1),
                format!("{} entries; expected {} ({})", row.len(), names.len(), names.join(", ")),
            );
        }
        let mut terms = Vec::new();
        for (j, e) in row.iter().enumerate() {
            let t = entry_text(e).ok_or_else(|| {
                ModelError(format!(
                    "{file}: {field} row {} entry {}: `{e}` is neither a number nor an expression string",
                    i + 1,
                    j + 1
                ))
            })?;
            if t.trim() != "0" {
                terms.push(format!("({t})*{}", names[j]));
            }
        }
        out.push(if terms.is_empty() {
            "0".into()
        } else {
            terms.join(" + ")
        });
    }
    Ok(out)
}

/// The aircraft-file values a model's `[constants]` may take (`mass = "aircraft.mass_kg"`), in SI
/// units as the aircraft file's reader stores them; the inertia with a positive `jxz`.
pub const AIRCRAFT_CONSTANTS: [(&str, AircraftValue); 8] = [
    ("mass_kg", |a| a.mass_kg),
    ("wing_area_m2", |a| a.wing_area_m2),
    ("span_m", |a| a.span_m),
    ("chord_m", |a| a.chord_m),
    ("jx_kgm2", |a| a.inertia_kgm2[(0, 0)]),
    ("jy_kgm2", |a| a.inertia_kgm2[(1, 1)]),
    ("jz_kgm2", |a| a.inertia_kgm2[(2, 2)]),
    ("jxz_kgm2", |a| -a.inertia_kgm2[(0, 2)]),
];

/// Reads one value of an aircraft.
pub type AircraftValue = fn(&Aircraft) -> f64;

fn aircraft_constant_help(a: &str) -> String {
    let names: Vec<String> = AIRCRAFT_CONSTANTS
        .iter()
        .map(|(n, _)| format!("aircraft.{n}"))
        .collect();
    format!(
        "`{a}`: a constant is a number or a value of the data's aircraft file, one of {}",
        names.join(", ")
    )
}

/// The measured channel a model file names: a [`Quantity::name`] (as column maps write it,
/// `pitch_rate`) or a column of the project's CSV log (`gyro_rad_s_y`).
pub fn channel_named(name: &str) -> Option<Quantity> {
    Quantity::from_name(name).or_else(|| Quantity::ALL.iter().copied().find(|q| csv_column(*q) == name))
}

/// The data layout of a model file and the source of each input, then each output: with
/// `[data] columns`, columns by number (`column = N`, or `channel` as a combination of `$N`);
/// without, measured channels by name (`channel`), numbered in the order first named.
fn data_sources(file: &ModelFile, f: &str) -> Result<(Layout, Vec<Expr>), ModelError> {
    let entries: Vec<(String, Option<usize>, Option<&String>, f64)> = file
        .inputs
        .iter()
        .map(|i| (format!("inputs.{}", i.name), i.column, i.channel.as_ref(), i.scale))
        .chain(
            file.outputs
                .iter()
                .map(|o| (format!("outputs.{}", o.name), o.column, o.channel.as_ref(), o.scale)),
        )
        .collect();
    let mut layout = layout_of(&file.data, f)?;
    let mut sources = Vec::new();
    for (what, column, channel, scale) in entries {
        if !(scale.is_finite() && scale != 0.0) {
            return err(f, &format!("{what}.scale"), "must be a finite non-zero number");
        }
        sources.push(Expr {
            terms: source_terms(f, &what, column, channel, &mut layout)?,
            constant: 0.0,
            factor: scale,
            unit: String::new(),
            bias: 0.0,
            line: 0,
        });
    }
    Ok((layout, sources))
}

/// The layout `[data]` gives: columns by number (`columns`, `time_column`), else channels by name.
fn layout_of(data: &DataSpec, f: &str) -> Result<Layout, ModelError> {
    match data.columns {
        Some(columns) => {
            let tc = data.time_column.unwrap_or(0);
            if columns == 0 || tc == 0 || tc > columns {
                return err(f, "data.time_column", format!("must be 1 to data.columns = {columns}"));
            }
            Ok(Layout::Columns {
                columns,
                time_column: tc,
            })
        }
        None => {
            if data.time_column.is_some() {
                return err(
                    f,
                    "data.time_column",
                    "applies to a file read by column number: give data.columns too, or name channels and leave both out",
                );
            }
            Ok(Layout::Channels(Vec::new()))
        }
    }
}

/// The columns entry `what` (an input or output) reads, by its `column` or `channel` in
/// `layout`; a channel named for the first time is added to a layout of channels.
fn source_terms(
    f: &str,
    what: &str,
    column: Option<usize>,
    channel: Option<&String>,
    layout: &mut Layout,
) -> Result<Vec<crate::io::colmap::Term>, ModelError> {
    match (column, channel, layout) {
        (Some(_), Some(_), _) => err(f, what, "give `column` or `channel`, not both"),
        (None, None, Layout::Columns { .. }) => err(f, what, "give `column = N` (or `channel = \"$N\"`)"),
        (None, None, Layout::Channels(_)) => err(
            f,
            what,
            "give `channel` (a measured channel such as \"alpha\", \"pitch_rate\", \"elevator\")",
        ),
        (Some(_), None, Layout::Channels(_)) => err(
            f,
            &format!("{what}.column"),
            "a column number needs [data] columns and time_column (a file without a header); name the channel instead, e.g. channel = \"alpha\"",
        ),
        (Some(col), None, Layout::Columns { columns, .. }) => {
            if col == 0 || col > *columns {
                return err(
                    f,
                    &format!("{what}.column"),
                    format!("{col}: must be 1 to data.columns = {columns}"),
                );
            }
            Ok(vec![crate::io::colmap::Term {
                coef: 1.0,
                source: Source::Column(col),
            }])
        }
        (None, Some(text), Layout::Columns { columns, .. }) => {
            let n = *columns;
            let resolve = |s: &str| match s.strip_prefix('$').map(str::parse::<usize>) {
                Some(Ok(k)) if k >= 1 && k <= n => Ok(Source::Column(k)),
                _ => Err(format!("`{s}`: a file read by column number takes columns $1 … ${n}")),
            };
            measurement_only(f, what, text, parse_terms(text, f, 0, 1, &resolve))
        }
        (None, Some(text), Layout::Channels(used)) => {
            let known = std::cell::RefCell::new(std::mem::take(used));
            let resolve = |s: &str| {
                let q = channel_named(s).ok_or_else(|| {
                    format!("`{s}` is not a measured channel (name it as a column map does: alpha, pitch_rate, elevator, … or as the project CSV's columns: alpha_rad, gyro_rad_s_y, …; docs/measured-data.md)")
                })?;
                let mut k = known.borrow_mut();
                let i = k.iter().position(|c| *c == q).unwrap_or_else(|| {
                    k.push(q);
                    k.len() - 1
                });
                Ok(Source::Column(i + 1))
            };
            let parsed = parse_terms(text, f, 0, 1, &resolve);
            *used = known.into_inner();
            measurement_only(f, what, text, parsed)
        }
    }
}

/// A parsed `channel` expression's terms; refused when it does not parse or adds a constant.
fn measurement_only(
    f: &str,
    what: &str,
    text: &str,
    parsed: Result<(Vec<crate::io::colmap::Term>, f64), crate::io::ReadError>,
) -> Result<Vec<crate::io::colmap::Term>, ModelError> {
    let (terms, constant) = parsed.map_err(|e| channel_error(f, what, text, e))?;
    if constant != 0.0 {
        return err(
            f,
            &format!("{what}.channel"),
            format!("`{text}`: a constant term is not a measurement; give channels only"),
        );
    }
    Ok(terms)
}

/// A `channel` expression's parse error as a model-file error naming the field.
fn channel_error(f: &str, what: &str, text: &str, e: crate::io::ReadError) -> ModelError {
    ModelError(format!(
        "{f}: {what}.channel: `{text}`: {} (write a channel or a combination such as `0.5*thrust + 0.5*thrust_difference`, as in column maps)",
        e.message
    ))
}

impl UserModel {
    /// Reads and checks a model file.
    pub fn read(path: &Path) -> Result<Self, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            ModelError(format!(
                "{}: {e} (give the path of a model file, e.g. tool/models/hfb320.toml)",
                path.display()
            ))
        })?;
        Self::parse(&text, path)
    }

    /// Parses a model file's text; `path` names it in errors and resolves its relative paths.
    ///
    /// The steps, in the order their errors are reported: sizes, parameters, settings, data
    /// sources, outputs and states; the `[linear]` form turned into equations; the names of the
    /// environment; the expressions compiled against it.
    pub fn parse(text: &str, path: &Path) -> Result<Self, ModelError> {
        let f = path.display().to_string();
        let mut file: ModelFile = toml::from_str(text).map_err(|e| ModelError(format!("{f}: {e}")))?;
        check_sizes(&file, &f)?;
        check_parameters(&file, &f)?;
        check_estimation(&file.estimation, &f)?;
        let (layout, sources) = data_sources(&file, &f)?;
        check_outputs(&file, &f)?;
        check_states(&file, &f)?;
        if let Some(lin) = file.linear.clone() {
            expand_linear(&mut file, &lin, &f)?;
        }
        let mut scope = Scope::new(&f);
        let constants = scope.constants(&file)?;
        for p in &file.parameters {
            scope.add(&p.name, format!("parameters.{}", p.name))?;
        }
        for s in &file.states {
            scope.add(&s.name, format!("states.{}", s.name))?;
        }
        for u in &file.inputs {
            scope.add(&u.name, format!("inputs.{}", u.name))?;
        }
        let equations = scope.equations(&file)?;
        let free = free_parameters(&file, &f)?;
        let values = file.parameters.iter().map(|p| p.start).collect();
        Ok(Self {
            file,
            path: path.to_path_buf(),
            text: text.to_string(),
            layout,
            sources,
            n_const: constants.values.len(),
            const_values: constants.values,
            aircraft_constants: constants.from_aircraft,
            free,
            values,
            defs: equations.defs,
            state_eqs: equations.states,
            output_eqs: equations.outputs,
        })
    }

    /// The model file's folder (relative paths inside the file resolve against it).
    pub fn folder(&self) -> PathBuf {
        self.path.parent().map(Path::to_path_buf).unwrap_or_default()
    }

    /// The default data file of `[data] file`, resolved against the model file's folder.
    pub fn default_data(&self) -> Option<PathBuf> {
        self.file.data.file.as_ref().map(|d| self.folder().join(d))
    }

    /// The default companion (column map or aircraft file) of `[data] with`, resolved against the
    /// model file's folder.
    pub fn default_companion(&self) -> Option<PathBuf> {
        self.file.data.with.as_ref().map(|d| self.folder().join(d))
    }

    /// Whether a constant is taken from the data's aircraft file.
    pub fn uses_aircraft(&self) -> bool {
        !self.aircraft_constants.is_empty()
    }

    /// Sets the constants taken from the aircraft file (`source` names it in errors). Refuses a
    /// value the file leaves `unknown`, and one that differs from a value set before (the data of
    /// one run come from one aircraft configuration).
    pub fn set_aircraft(&mut self, aircraft: &Aircraft, source: &str) -> Result<(), String> {
        for &(i, j) in &self.aircraft_constants {
            let (key, get) = AIRCRAFT_CONSTANTS[j];
            let v = get(aircraft);
            let name = self.file.constants.keys().nth(i).map_or("?", |k| k.as_str());
            if !v.is_finite() {
                return Err(format!(
                    "{source}: the aircraft file gives no `{key}` (unknown), which {} takes for constant `{name}`; state it in the aircraft file or give the number in the model",
                    self.path.display()
                ));
            }
            let old = self.const_values[i];
            if old.is_finite() && old != v {
                return Err(format!(
                    "{source}: aircraft `{key}` = {v}, other data of this run had {old} (constant `{name}` of {}); pool data of one aircraft configuration",
                    self.path.display()
                ));
            }
            self.const_values[i] = v;
        }
        Ok(())
    }

    /// Number of states, inputs, outputs.
    pub fn dims(&self) -> (usize, usize, usize) {
        (self.file.states.len(), self.file.inputs.len(), self.file.outputs.len())
    }

    /// The free parameters' indices into `file.parameters`.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// The current value of every parameter.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Fixes the named parameter at `value` (`--fix NAME=VALUE`).
    pub fn fix(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        let f = self.path.display().to_string();
        let Some(i) = self.file.parameters.iter().position(|p| p.name == name) else {
            let known: Vec<&str> = self.file.parameters.iter().map(|p| p.name.as_str()).collect();
            return err(
                &f,
                "--fix",
                format!("`{name}` is not a parameter of the model ({})", known.join(", ")),
            );
        };
        if !value.is_finite() {
            return err(&f, "--fix", format!("{name}: value not finite"));
        }
        self.file.parameters[i].fixed = true;
        self.file.parameters[i].start = value;
        self.values[i] = value;
        self.free.retain(|&j| j != i);
        Ok(())
    }

    /// Sets every parameter's value (e.g. from a saved identification); the free set is unchanged.
    pub fn set_values(&mut self, values: &[f64]) {
        self.values.copy_from_slice(values);
    }

    /// The free parameters' current values, padded.
    pub fn free_vector(&self) -> PVec {
        let mut p = PVec::zeros();
        for (k, &i) in self.free.iter().enumerate() {
            p[k] = self.values[i];
        }
        p
    }

    /// The prior covariance of the free parameters: `prior_sigma²` or Bauer–Andrisani's
    /// `max(0.25|start|, floor)²`; unit on the padding.
    pub fn prior_covariance(&self) -> SMatrix<f64, MAX_P, MAX_P> {
        let mut c = SMatrix::<f64, MAX_P, MAX_P>::identity();
        for (k, &i) in self.free.iter().enumerate() {
            let p = &self.file.parameters[i];
            let s = p
                .prior_sigma
                .unwrap_or((0.25 * p.start.abs()).max(self.file.estimation.prior_sigma_floor));
            c[(k, k)] = s * s;
        }
        c
    }

    /// The settings' integrator, input hold and sensitivity.
    pub fn prediction(&self) -> (Integrator, InputHold, Sensitivity) {
        let e = &self.file.estimation;
        // Checked in `parse`.
        (
            parse_integrator(&e.integrator).unwrap_or_default(),
            parse_hold(&e.input_hold).unwrap_or_default(),
            parse_sensitivity(&e.sensitivity).unwrap_or_default(),
        )
    }

    /// The environment for `(x, u, p)`, definitions evaluated.
    fn env(&self, x: &XVec, u: &UVec, p: &PVec) -> Vec<f64> {
        let (nx, nu, _) = self.dims();
        let mut env = Vec::with_capacity(self.n_const + self.values.len() + nx + nu + self.defs.len());
        env.extend_from_slice(&self.const_values);
        let base = env.len();
        env.extend_from_slice(&self.values);
        for (k, &i) in self.free.iter().enumerate() {
            env[base + i] = p[k];
        }
        env.extend(x.iter().take(nx));
        env.extend(u.iter().take(nu));
        for d in &self.defs {
            let v = d.eval(&env);
            env.push(v);
        }
        env
    }
}

/// The numbers of states, inputs and outputs within what the filter is built for.
fn check_sizes(file: &ModelFile, f: &str) -> Result<(), ModelError> {
    let (nx, nu, ny) = (file.states.len(), file.inputs.len(), file.outputs.len());
    if nx == 0 || nx > MAX_X {
        return err(f, "states", format!("{nx} states; 1 to {MAX_X} are supported"));
    }
    if nu > MAX_U {
        return err(f, "inputs", format!("{nu} inputs; at most {MAX_U} are supported"));
    }
    if ny == 0 || ny > MAX_Y {
        return err(f, "outputs", format!("{ny} outputs; 1 to {MAX_Y} are supported"));
    }
    Ok(())
}

/// Every parameter's start finite and its prior σ, when given, positive.
fn check_parameters(file: &ModelFile, f: &str) -> Result<(), ModelError> {
    for p in &file.parameters {
        if !p.start.is_finite() {
            return err(f, &format!("parameters.{}.start", p.name), "not a finite number");
        }
        if let Some(s) = p.prior_sigma {
            if !(s > 0.0 && s.is_finite()) {
                return err(f, &format!("parameters.{}.prior_sigma", p.name), "must be > 0");
            }
        }
    }
    Ok(())
}

/// The `[estimation]` settings: names known, numbers positive, noise estimated only where the
/// method can.
fn check_estimation(est: &EstimationSpec, f: &str) -> Result<(), ModelError> {
    for (field, ok) in [
        (
            "estimation.integrator (euler, rk2 or rk4)",
            parse_integrator(&est.integrator).is_some(),
        ),
        (
            "estimation.input_hold (zero or linear)",
            parse_hold(&est.input_hold).is_some(),
        ),
        (
            "estimation.sensitivity (one-step or propagated)",
            parse_sensitivity(&est.sensitivity).is_some(),
        ),
        ("estimation.prior_sigma_floor (> 0)", est.prior_sigma_floor > 0.0),
        ("estimation.tolerance_sigma (> 0)", est.tolerance_sigma > 0.0),
    ] {
        if !ok {
            return err(f, field, "not one of the accepted values");
        }
    }
    if est.estimate_noise && !(est.method == Method::OutputError && est.iteration == Iteration::GaussNewton) {
        return err(
            f,
            "estimation.estimate_noise",
            "only with method = \"output-error\" and iteration = \"gauss-newton\" (the filter error method takes R as given)",
        );
    }
    Ok(())
}

/// Every output's noise variance positive (R positive definite).
fn check_outputs(file: &ModelFile, f: &str) -> Result<(), ModelError> {
    for o in &file.outputs {
        if !(o.noise_variance > 0.0 && o.noise_variance.is_finite()) {
            return err(
                f,
                &format!("outputs.{}.noise_variance", o.name),
                "must be > 0 (R must be positive definite)",
            );
        }
    }
    Ok(())
}

/// Every state's process noise finite, its start a number or an output, and its initial
/// variance given or taken from that output.
fn check_states(file: &ModelFile, f: &str) -> Result<(), ModelError> {
    for s in &file.states {
        if !(s.process_noise.is_finite()) {
            return err(f, &format!("states.{}.process_noise", s.name), "not a finite number");
        }
        match &s.initial {
            Initial::Value(v) if !v.is_finite() => {
                return err(f, &format!("states.{}.initial", s.name), "not a finite number")
            }
            Initial::Output(o) if !file.outputs.iter().any(|y| &y.name == o) => {
                return err(
                    f,
                    &format!("states.{}.initial", s.name),
                    format!("`{o}` is not an output"),
                )
            }
            _ => {}
        }
        let var = s.initial_variance.or_else(|| match &s.initial {
            Initial::Output(o) => file.outputs.iter().find(|y| &y.name == o).map(|y| y.noise_variance),
            Initial::Value(_) => None,
        });
        if !matches!(var, Some(v) if v > 0.0 && v.is_finite()) {
            return err(
                f,
                &format!("states.{}.initial_variance", s.name),
                "give a variance > 0 (only a state started from an output takes that output's noise variance)",
            );
        }
    }
    Ok(())
}

/// The `[linear]` form turned into one equation per state (`A x + B u + f0`) and per output
/// (`C x + D u + h0`); a file giving both forms is refused.
fn expand_linear(file: &mut ModelFile, lin: &LinearSpec, f: &str) -> Result<(), ModelError> {
    let (nx, ny) = (file.states.len(), file.outputs.len());
    let xs: Vec<String> = file.states.iter().map(|s| s.name.clone()).collect();
    let us: Vec<String> = file.inputs.iter().map(|s| s.name.clone()).collect();
    let ax = linear_row(f, "linear.A", &lin.a, nx, &xs)?;
    let bu = linear_row(f, "linear.B", &lin.b, nx, &us)?;
    let cx = linear_row(f, "linear.C", &lin.c, ny, &xs)?;
    let du = match &lin.d {
        Some(d) => linear_row(f, "linear.D", d, ny, &us)?,
        None => vec!["0".into(); ny],
    };
    let f0 = linear_bias(f, &lin.f0, nx, "linear.f0")?;
    let h0 = linear_bias(f, &lin.h0, ny, "linear.h0")?;
    for (i, s) in file.states.iter_mut().enumerate() {
        let text = format!("{} + {} + ({})", ax[i], bu[i], f0[i]);
        set_from_linear(f, format!("states.{}.equation", s.name), &mut s.equation, text)?;
    }
    for (i, o) in file.outputs.iter_mut().enumerate() {
        let text = format!("{} + {} + ({})", cx[i], du[i], h0[i]);
        set_from_linear(f, format!("outputs.{}.equation", o.name), &mut o.equation, text)?;
    }
    Ok(())
}

/// An equation set from the `[linear]` form; one the file gives as well is refused.
fn set_from_linear(f: &str, field: String, equation: &mut Option<String>, text: String) -> Result<(), ModelError> {
    if equation.is_some() {
        return err(f, &field, "give either equations or [linear], not both");
    }
    *equation = Some(text);
    Ok(())
}

/// A `[linear]` offset vector (`f0`, `h0`) as `n` expression texts; zeros when absent.
fn linear_bias(f: &str, v: &Option<Vec<toml::Value>>, n: usize, field: &str) -> Result<Vec<String>, ModelError> {
    match v {
        None => Ok(vec!["0".into(); n]),
        Some(v) if v.len() != n => err(f, field, format!("{} entries; expected {n}", v.len())),
        Some(v) => v
            .iter()
            .map(|e| {
                entry_text(e).ok_or_else(|| ModelError(format!("{f}: {field}: `{e}` is not a number or expression")))
            })
            .collect(),
    }
}

/// The indices of the free parameters, at most [`MAX_P`] of them.
fn free_parameters(file: &ModelFile, f: &str) -> Result<Vec<usize>, ModelError> {
    let free: Vec<usize> = (0..file.parameters.len())
        .filter(|&i| !file.parameters[i].fixed)
        .collect();
    if free.len() > MAX_P {
        return err(
            f,
            "parameters",
            format!("{} free parameters; at most {MAX_P} (fix some)", free.len()),
        );
    }
    Ok(free)
}

/// The constants' values in file order: numbers as given, NaN for those taken from the aircraft.
struct Constants {
    values: Vec<f64>,
    /// `(index into values, index into AIRCRAFT_CONSTANTS)`.
    from_aircraft: Vec<(usize, usize)>,
}

/// The compiled expressions: definitions, state equations, output equations.
struct Equations {
    defs: Vec<Compiled>,
    states: Vec<Compiled>,
    outputs: Vec<Compiled>,
}

/// The environment's names as they are declared, each with its slot:
/// `[constants | parameters | states | inputs | definitions]`.
struct Scope<'a> {
    /// The model file's name, for errors.
    f: &'a str,
    slot: HashMap<String, usize>,
}

impl<'a> Scope<'a> {
    fn new(f: &'a str) -> Self {
        Self {
            f,
            slot: HashMap::new(),
        }
    }

    /// Declares `name` (from `field`) in the next slot: a usable name, declared once.
    fn add(&mut self, name: &str, field: String) -> Result<(), ModelError> {
        let parsed = exmex::parse::<f64>(name).ok();
        if !matches!(parsed.as_ref().map(|p| p.var_names()), Some(v) if v.len() == 1 && v[0] == name) {
            return err(self.f, &field, format!("`{name}` is not usable as a name (letters, digits, _; not a function or constant such as sin, PI, E)"));
        }
        if self.slot.contains_key(name) {
            return err(self.f, &field, format!("`{name}` is defined twice (names are shared by constants, parameters, states, inputs and definitions)"));
        }
        let next = self.slot.len();
        self.slot.insert(name.to_string(), next);
        Ok(())
    }

    /// Declares the constants and reads their values (a number, or `aircraft.NAME`).
    fn constants(&mut self, file: &ModelFile) -> Result<Constants, ModelError> {
        let f = self.f;
        let mut values = Vec::new();
        let mut from_aircraft = Vec::new();
        for (k, v) in &file.constants {
            self.add(k, format!("constants.{k}"))?;
            let x = match v {
                toml::Value::Float(x) => *x,
                toml::Value::Integer(i) => *i as f64,
                toml::Value::String(a) => match AIRCRAFT_CONSTANTS
                    .iter()
                    .position(|(name, _)| a.strip_prefix("aircraft.") == Some(*name))
                {
                    Some(j) => {
                        from_aircraft.push((values.len(), j));
                        f64::NAN
                    }
                    None => return err(f, &format!("constants.{k}"), aircraft_constant_help(a)),
                },
                _ => return err(f, &format!("constants.{k}"), "must be a number"),
            };
            values.push(x);
        }
        Ok(Constants { values, from_aircraft })
    }

    /// Compiles `text` against the names declared so far.
    fn compile(&self, text: &str, field: &str) -> Result<Compiled, ModelError> {
        let f = self.f;
        let expr = exmex::parse::<f64>(text).map_err(|e| ModelError(format!("{f}: {field}: `{text}`: {e}")))?;
        if expr.var_names().len() > MAX_VARS_PER_EXPRESSION {
            return err(
                f,
                field,
                format!("uses more than {MAX_VARS_PER_EXPRESSION} names; split it with [definitions]"),
            );
        }
        let mut slots = Vec::new();
        for v in expr.var_names() {
            match self.slot.get(v) {
                Some(&s) => slots.push(s),
                None => {
                    return err(
                        f,
                        field,
                        format!("`{v}` is not a constant, parameter, state, input or earlier definition"),
                    )
                }
            }
        }
        Ok(Compiled { expr, slots })
    }

    /// Compiles the definitions (each declared after its own expression, so it sees only earlier
    /// ones), then the state and output equations.
    fn equations(&mut self, file: &ModelFile) -> Result<Equations, ModelError> {
        let f = self.f;
        let mut defs = Vec::new();
        for (k, v) in &file.definitions {
            let toml::Value::String(text) = v else {
                return err(f, &format!("definitions.{k}"), "must be an expression string");
            };
            defs.push(self.compile(text, &format!("definitions.{k}"))?);
            self.add(k, format!("definitions.{k}"))?;
        }
        let equation = |name: &str, equation: Option<&str>, kind: &str| -> Result<Compiled, ModelError> {
            let field = format!("{kind}.{name}.equation");
            let text = equation.ok_or_else(|| ModelError(format!("{f}: {field}: missing (or give [linear])")))?;
            self.compile(text, &field)
        };
        let states = file
            .states
            .iter()
            .map(|s| equation(&s.name, s.equation.as_deref(), "states"))
            .collect::<Result<_, _>>()?;
        let outputs = file
            .outputs
            .iter()
            .map(|o| equation(&o.name, o.equation.as_deref(), "outputs"))
            .collect::<Result<_, _>>()?;
        Ok(Equations { defs, states, outputs })
    }
}

impl Model<f64, MAX_X, MAX_U, MAX_Y, MAX_P> for &UserModel {
    fn f(&self, x: &XVec, u: &UVec, p: &PVec) -> XVec {
        let env = self.env(x, u, p);
        let mut out = XVec::zeros();
        for (i, e) in self.state_eqs.iter().enumerate() {
            out[i] = e.eval(&env);
        }
        out
    }

    fn h(&self, x: &XVec, u: &UVec, p: &PVec) -> YVec {
        let env = self.env(x, u, p);
        let mut out = YVec::zeros();
        for (i, e) in self.output_eqs.iter().enumerate() {
            out[i] = e.eval(&env);
        }
        out
    }

    // The Jacobians by central differences over the active entries only (the padding contributes
    // exact zeros), with the core's step.
    fn df_dx(&self, x: &XVec, u: &UVec, p: &PVec) -> SMatrix<f64, MAX_X, MAX_X> {
        active_difference(x, self.dims().0, |xx| self.f(xx, u, p))
    }
    fn df_dp(&self, x: &XVec, u: &UVec, p: &PVec) -> SMatrix<f64, MAX_X, MAX_P> {
        active_difference(p, self.free.len(), |pp| self.f(x, u, pp))
    }
    fn dh_dx(&self, x: &XVec, u: &UVec, p: &PVec) -> SMatrix<f64, MAX_Y, MAX_X> {
        active_difference(x, self.dims().0, |xx| self.h(xx, u, p))
    }
    fn dh_dp(&self, x: &XVec, u: &UVec, p: &PVec) -> SMatrix<f64, MAX_Y, MAX_P> {
        active_difference(p, self.free.len(), |pp| self.h(x, u, pp))
    }
}

/// [`aerosid_core::fem::central_difference`] over the first `n` entries of `v` (the rest zero
/// columns): the same step `ε^{1/3}·max(|v_j|, 1)`.
fn active_difference<const N: usize, const M: usize>(
    v: &SVector<f64, N>,
    n: usize,
    mut g: impl FnMut(&SVector<f64, N>) -> SVector<f64, M>,
) -> SMatrix<f64, M, N> {
    let base = f64::EPSILON.cbrt();
    let mut jac = SMatrix::<f64, M, N>::zeros();
    for j in 0..n.min(N) {
        let h = base * v[j].abs().max(1.0);
        let (mut vp, mut vm) = (*v, *v);
        vp[j] += h;
        vm[j] -= h;
        let d = vp[j] - vm[j];
        jac.set_column(j, &((g(&vp) - g(&vm)) / d));
    }
    jac
}
