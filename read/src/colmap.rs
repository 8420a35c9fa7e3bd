//! Column-map files: how to read a flight-test file that is not in the project's layout.
//!
//! A map is a `key = value` text file (`#` comments, as the aircraft file) that says
//! * `format = ascii` (whitespace-separated numbers, no header, one sample per line; exponents of
//!   any width such as `5.008e+001`) or `format = ulog` (a PX4 log, see [`super::ulog`]);
//! * `aircraft = PATH` — the aircraft file ([`super::aircraft`]), relative to the map's folder;
//! * `columns = N` (ascii) — the number of numbers on every line; a line with another count is
//!   refused;
//! * `time = EXPR UNIT` (ascii) — the time, e.g. `time = $1 s`;
//! * `variable = NAME` (ascii, optional) — for a MATLAB `.mat` file read through this map, the
//!   matrix whose columns `$N` are ([`super::mat`]); a text file ignores it;
//! * `time_base = TOPIC` (ulog, optional) — the topic whose timestamps are the output time base;
//! * `channel.QUANTITY = EXPR UNIT` — one measured channel; `QUANTITY` is a
//!   [`Quantity::name`] (`alpha`, `pitch_rate`, …), `UNIT` the unit of `EXPR` (converted to SI,
//!   see [`UNITS`]; it must fit the quantity: `deg` for an angle, `kt` for a speed, …);
//! * `constant.QUANTITY = VALUE UNIT` — a channel the source states as one constant (the HFB-320's
//!   density), the same value at every sample;
//! * `bias.QUANTITY = VALUE` — a constant subtracted after the conversion, in SI units (a
//!   pre-processing step, e.g. the ATTAS sensor biases of the book's flight-path reconstruction);
//! * `origin.QUANTITY = sensor` or `origin.QUANTITY = estimated BY` — where the channel comes
//!   from: its own sensor (the default) or an estimator, `BY` naming it in words (e.g.
//!   `origin.alpha = estimated autopilot EKF, ground velocity minus wind`). An estimated α or β
//!   gets no vane errors in the analysis ([`super::measured::Origin`]). In an ASCII map it needs a
//!   `channel.QUANTITY`; in a ULog map it may also state the origin of a built-in channel;
//! * `description = TEXT` — free text.
//!
//! `EXPR` is a linear combination of sources: terms separated by ` + ` or ` - ` (with spaces), each
//! a source, a number, or `number*source`. A source is `$N` (1-based column, ascii) or
//! `topic.field` (ulog, e.g. `actuator_servos.control[1]`). So a derived channel such as the ATTAS
//! aileron `δa = (DAIL_R − DAIL_L)/2` is `channel.aileron = 0.5*$29 - 0.5*$28 deg`, and a total
//! thrust `channel.thrust = $37 + $38 N`.
//!
//! Every error names the file, the line and the column (1-based); nothing panics.

use super::aircraft::{read_aircraft, G0_MPS2, KG_PER_SLUG, M_PER_FT};
use super::measured::{Aircraft, Invalid, MeasuredFlight, Origin, Quantity};
use super::{key_values, read_text, KeyValue, ReadError};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

/// The physical dimension of a unit or a quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    /// rad.
    Angle,
    /// rad/s.
    AngularRate,
    /// rad/s².
    AngularAcceleration,
    /// m/s.
    Speed,
    /// m/s².
    Acceleration,
    /// Pa.
    Pressure,
    /// kg/m³.
    Density,
    /// m.
    Length,
    /// N.
    Force,
    /// A pure number.
    Ratio,
    /// s.
    Time,
}

const LBF_N: f64 = 0.453_592_37 * G0_MPS2;

/// The units a map may name: spelling, dimension and factor to SI.
pub const UNITS: &[(&str, Dimension, f64)] = &[
    ("rad", Dimension::Angle, 1.0),
    ("deg", Dimension::Angle, PI / 180.0),
    ("rad/s", Dimension::AngularRate, 1.0),
    ("deg/s", Dimension::AngularRate, PI / 180.0),
    ("rpm", Dimension::AngularRate, 2.0 * PI / 60.0),
    ("rad/s2", Dimension::AngularAcceleration, 1.0),
    ("deg/s2", Dimension::AngularAcceleration, PI / 180.0),
    ("m/s", Dimension::Speed, 1.0),
    ("ft/s", Dimension::Speed, M_PER_FT),
    ("kt", Dimension::Speed, 1852.0 / 3600.0),
    ("km/h", Dimension::Speed, 1.0 / 3.6),
    ("m/s2", Dimension::Acceleration, 1.0),
    ("ft/s2", Dimension::Acceleration, M_PER_FT),
    ("g", Dimension::Acceleration, G0_MPS2),
    ("Pa", Dimension::Pressure, 1.0),
    ("hPa", Dimension::Pressure, 100.0),
    ("kPa", Dimension::Pressure, 1000.0),
    ("lbf/ft2", Dimension::Pressure, LBF_N / (M_PER_FT * M_PER_FT)),
    ("kg/m3", Dimension::Density, 1.0),
    (
        "slug/ft3",
        Dimension::Density,
        KG_PER_SLUG / (M_PER_FT * M_PER_FT * M_PER_FT),
    ),
    ("m", Dimension::Length, 1.0),
    ("ft", Dimension::Length, M_PER_FT),
    ("N", Dimension::Force, 1.0),
    ("lbf", Dimension::Force, LBF_N),
    ("1", Dimension::Ratio, 1.0),
    ("%", Dimension::Ratio, 0.01),
    ("s", Dimension::Time, 1.0),
    ("ms", Dimension::Time, 1e-3),
    ("us", Dimension::Time, 1e-6),
];

/// The dimension of a quantity.
pub fn dimension(q: Quantity) -> Dimension {
    use Quantity::*;
    match q {
        AccelX | AccelY | AccelZ => Dimension::Acceleration,
        RollRate | PitchRate | YawRate | PropSpeed => Dimension::AngularRate,
        RollAccel | PitchAccel | YawAccel => Dimension::AngularAcceleration,
        Airspeed | VelocityNorth | VelocityEast | VelocityDown | WindNorth | WindEast => Dimension::Speed,
        Alpha | Beta | Roll | Pitch | Yaw | Elevator | Aileron | Rudder | Flap => Dimension::Angle,
        Throttle | Mach => Dimension::Ratio,
        Thrust | ThrustDifference => Dimension::Force,
        DynamicPressure => Dimension::Pressure,
        AirDensity => Dimension::Density,
        Altitude => Dimension::Length,
    }
}

/// Where a term's number comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// A column of an ASCII file, 1-based.
    Column(usize),
    /// A field of a ULog topic (instance 0), e.g. `actuator_servos`, `control[1]`.
    Field {
        /// The topic.
        topic: String,
        /// The (flattened) field name.
        field: String,
    },
}

/// One term `coef·source`.
#[derive(Debug, Clone, PartialEq)]
pub struct Term {
    /// The coefficient.
    pub coef: f64,
    /// The source.
    pub source: Source,
}

/// A channel expression: `factor·(Σ coef·source + constant) − bias`, in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// The terms.
    pub terms: Vec<Term>,
    /// The constant term, in the source unit.
    pub constant: f64,
    /// The unit's factor to SI.
    pub factor: f64,
    /// The unit as written.
    pub unit: String,
    /// Subtracted after the conversion (SI).
    pub bias: f64,
    /// The map line that defined it.
    pub line: usize,
}

impl Expr {
    /// The SI value from the sources' values (in the order of `terms`).
    pub fn eval(&self, values: impl Iterator<Item = f64>) -> f64 {
        let s: f64 = self.terms.iter().zip(values).map(|(t, v)| t.coef * v).sum();
        self.factor * (s + self.constant) - self.bias
    }

    /// The first column the expression reads (ASCII), for error messages.
    pub fn first_column(&self) -> Option<usize> {
        self.terms.iter().find_map(|t| match t.source {
            Source::Column(c) => Some(c),
            Source::Field { .. } => None,
        })
    }
}

/// The file layout a map describes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Whitespace-separated numbers, no header.
    Ascii,
    /// PX4 ULog.
    Ulog,
}

/// A parsed column map.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnMap {
    /// The map file (for errors).
    pub file: String,
    /// The layout.
    pub format: Format,
    /// Numbers per line (ASCII).
    pub columns: usize,
    /// The time (ASCII).
    pub time: Option<Expr>,
    /// The time-base topic (ULog).
    pub time_base: Option<String>,
    /// The channels, in the order given.
    pub channels: Vec<(Quantity, Expr)>,
    /// The aircraft.
    pub aircraft: Aircraft,
    /// The matrix of a MATLAB `.mat` file whose columns `$N` name (`variable = fdata`; optional,
    /// see [`super::mat`]).
    pub variable: Option<String>,
    /// Where channels come from, as the map states it (`origin.QUANTITY`).
    pub origin: BTreeMap<Quantity, Origin>,
}

impl ColumnMap {
    /// The ULog map used with a bare aircraft file: the standard topics only (see [`super::ulog`]).
    pub fn ulog_default(aircraft: Aircraft) -> Self {
        Self {
            file: String::from("(built-in ULog map)"),
            format: Format::Ulog,
            columns: 0,
            time: None,
            time_base: None,
            channels: Vec::new(),
            aircraft,
            variable: None,
            origin: BTreeMap::new(),
        }
    }
}

/// Parses the value of an `origin.QUANTITY` key: `sensor` or `estimated BY`.
fn parse_origin(value: &str, file: &str, line: usize, col: usize) -> Result<Origin, ReadError> {
    let (word, rest) = value.split_once(char::is_whitespace).unwrap_or((value, ""));
    match (word, rest.trim()) {
        ("sensor", "") => Ok(Origin::Sensor),
        ("estimated", by) if !by.is_empty() => Ok(Origin::Estimated { by: by.to_string() }),
        ("estimated", _) => Err(ReadError::new(
            file,
            line,
            col,
            "`estimated` needs what estimated it, in words (e.g. `estimated autopilot EKF, ground velocity minus wind`)",
        )),
        _ => Err(ReadError::new(
            file,
            line,
            col,
            format!("`{value}`: an origin is `sensor` or `estimated BY` (BY: what estimated it)"),
        )),
    }
}

fn parse_number(s: &str) -> Option<f64> {
    s.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Parses `EXPR UNIT` (the value of a `time` or `channel.` key) at `col` of `line`.
fn parse_expr(
    value: &str,
    file: &str,
    line: usize,
    col: usize,
    format: Format,
    columns: usize,
    want: Dimension,
) -> Result<Expr, ReadError> {
    let err = |c: usize, m: String| ReadError::new(file, line, c, m);
    let (body, unit) = match value.rsplit_once(char::is_whitespace) {
        Some((b, u)) => (b.trim_end(), u),
        None => return Err(err(col, format!("`{value}`: expected `EXPR UNIT` (e.g. `$6 deg`)"))),
    };
    let unit_col = col + value.len() - unit.len();
    let Some(&(_, dim, factor)) = UNITS.iter().find(|(u, _, _)| *u == unit) else {
        let known: Vec<&str> = UNITS.iter().map(|(u, _, _)| *u).collect();
        return Err(err(
            unit_col,
            format!("unknown unit `{unit}` (one of {})", known.join(" ")),
        ));
    };
    if dim != want {
        let fits: Vec<&str> = UNITS
            .iter()
            .filter(|(_, d, _)| *d == want)
            .map(|(u, _, _)| *u)
            .collect();
        return Err(err(
            unit_col,
            format!(
                "unit `{unit}` does not fit this quantity (use one of {})",
                fits.join(" ")
            ),
        ));
    }
    let resolve = |factor: &str| match (format, factor.strip_prefix('$')) {
        (Format::Ascii, Some(n)) => match n.parse::<usize>() {
            Ok(k) if k >= 1 && k <= columns => Ok(Source::Column(k)),
            _ => Err(format!("`{factor}`: column must be $1 … ${columns}")),
        },
        (Format::Ascii, None) => Err(format!("`{factor}` is neither a number nor a column `$N`")),
        (Format::Ulog, Some(_)) => Err(format!("`{factor}`: a ULog map names `topic.field`, not columns")),
        (Format::Ulog, None) => match factor.split_once('.') {
            Some((topic, field)) if !topic.is_empty() && !field.is_empty() => Ok(Source::Field {
                topic: topic.to_string(),
                field: field.to_string(),
            }),
            _ => Err(format!("`{factor}` is neither a number nor `topic.field`")),
        },
    };
    let (terms, constant) = parse_terms(body, file, line, col, &resolve)?;
    Ok(Expr {
        terms,
        constant,
        factor,
        unit: unit.to_string(),
        bias: 0.0,
        line,
    })
}

/// Parses the linear combination `EXPR` of a map (terms separated by ` + ` or ` - ` with spaces,
/// each a source, a number or `number*source`) at `col` of `line`; `resolve` turns a source's text
/// into a [`Source`] or says why it cannot. Also the reader of a model file's derived inputs
/// (`aerosid::usermodel`), whose sources are columns or measured channels.
pub fn parse_terms(
    body: &str,
    file: &str,
    line: usize,
    col: usize,
    resolve: &dyn Fn(&str) -> Result<Source, String>,
) -> Result<(Vec<Term>, f64), ReadError> {
    let err = |c: usize, m: String| ReadError::new(file, line, c, m);
    // Terms: split at " + " / " - " (spaces required, so `1e-3` and `-$2` stay whole).
    let mut terms = Vec::new();
    let mut constant = 0.0;
    let mut sign = 1.0;
    let mut pos = 0usize;
    let toks: Vec<&str> = body.split(' ').collect();
    let mut offsets = Vec::with_capacity(toks.len());
    for t in &toks {
        offsets.push(pos);
        pos += t.len() + 1;
    }
    let mut expect_term = true;
    for (t, off) in toks.iter().zip(offsets) {
        let c = col + off;
        if t.is_empty() {
            continue;
        }
        if !expect_term {
            match *t {
                "+" => sign = 1.0,
                "-" => sign = -1.0,
                _ => return Err(err(c, format!("expected ` + ` or ` - ` before `{t}`"))),
            }
            expect_term = true;
            continue;
        }
        expect_term = false;
        let (neg, t) = match t.strip_prefix('-') {
            Some(r) if r.starts_with('$') || r.chars().next().is_some_and(|ch| ch.is_ascii_alphabetic()) => (-1.0, r),
            _ => (1.0, *t),
        };
        let mut coef = sign * neg;
        let mut source: Option<Source> = None;
        for factor in t.split('*') {
            if let Some(v) = parse_number(factor) {
                coef *= v;
                continue;
            }
            if source.is_some() {
                return Err(err(c, format!("`{t}`: a term has at most one source")));
            }
            source = Some(resolve(factor).map_err(|m| err(c, m))?);
        }
        match source {
            Some(source) => terms.push(Term { coef, source }),
            None => constant += coef,
        }
        sign = 1.0;
    }
    if expect_term {
        return Err(err(col, format!("`{body}`: incomplete expression")));
    }
    if terms.is_empty() {
        return Err(err(col, format!("`{body}` reads no source")));
    }
    Ok((terms, constant))
}

/// Parses `VALUE UNIT` (a `constant.` key).
fn parse_constant(value: &str, file: &str, line: usize, col: usize, want: Dimension) -> Result<Expr, ReadError> {
    let err = |c: usize, m: String| ReadError::new(file, line, c, m);
    let Some((num, unit)) = value.split_once(char::is_whitespace) else {
        return Err(err(
            col,
            format!("`{value}`: expected `VALUE UNIT` (e.g. `0.792 kg/m3`)"),
        ));
    };
    let unit = unit.trim();
    let unit_col = col + value.len() - unit.len();
    let Some(v) = parse_number(num) else {
        return Err(err(col, format!("`{num}` is not a finite number")));
    };
    let Some(&(_, dim, factor)) = UNITS.iter().find(|(u, _, _)| *u == unit) else {
        return Err(err(unit_col, format!("unknown unit `{unit}`")));
    };
    if dim != want {
        return Err(err(unit_col, format!("unit `{unit}` does not fit this quantity")));
    }
    Ok(Expr {
        terms: Vec::new(),
        constant: v,
        factor,
        unit: unit.to_string(),
        bias: 0.0,
        line,
    })
}

/// Parses a column map from `text`; `dir` is the map's folder (the aircraft path is relative to
/// it).
pub fn parse_map(text: &str, file: &str, dir: &Path) -> Result<ColumnMap, ReadError> {
    let kvs = key_values(text, file)?;
    let format = map_format(&kvs, file)?;
    let columns = map_columns(&kvs, format, file)?;
    let aircraft = map_aircraft(&kvs, file, dir)?;
    let mut e = MapEntries::default();
    for kv in &kvs {
        e.read(kv, file, format, columns)?;
    }
    let MapEntries {
        time,
        time_base,
        variable,
        mut channels,
        biases,
        origins,
    } = e;
    apply_biases(biases, &mut channels, format, file)?;
    let origin = origins_checked(origins, &channels, format, file)?;
    if format == Format::Ascii && time.is_none() {
        return Err(ReadError::new(file, 0, 0, "missing key `time` (e.g. `time = $1 s`)"));
    }
    Ok(ColumnMap {
        file: file.to_string(),
        format,
        columns,
        time,
        time_base,
        channels,
        aircraft,
        variable,
        origin,
    })
}

/// The map's `format` (required).
fn map_format(kvs: &[KeyValue], file: &str) -> Result<Format, ReadError> {
    match kvs.iter().find(|kv| kv.key == "format") {
        Some(kv) => match kv.value {
            "ascii" => Ok(Format::Ascii),
            "ulog" => Ok(Format::Ulog),
            v => Err(ReadError::new(
                file,
                kv.line,
                kv.value_col,
                format!("unknown format `{v}` (ascii or ulog)"),
            )),
        },
        None => Err(ReadError::new(file, 0, 0, "missing key `format` (ascii or ulog)")),
    }
}

/// The numbers per line of an ASCII file (required for `format = ascii`, refused for ULog: 0).
fn map_columns(kvs: &[KeyValue], format: Format, file: &str) -> Result<usize, ReadError> {
    match (format, kvs.iter().find(|kv| kv.key == "columns")) {
        (Format::Ascii, Some(kv)) => match kv.value.parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(ReadError::new(
                file,
                kv.line,
                kv.value_col,
                format!("`{}` is not a positive column count", kv.value),
            )),
        },
        (Format::Ascii, None) => Err(ReadError::new(file, 0, 0, "missing key `columns` (numbers per line)")),
        (Format::Ulog, Some(kv)) => Err(ReadError::new(
            file,
            kv.line,
            kv.key_col,
            "`columns` applies to `format = ascii` only",
        )),
        (Format::Ulog, None) => Ok(0),
    }
}

/// The aircraft file the map names (required), read relative to the map's folder `dir`.
fn map_aircraft(kvs: &[KeyValue], file: &str, dir: &Path) -> Result<Aircraft, ReadError> {
    match kvs.iter().find(|kv| kv.key == "aircraft") {
        Some(kv) => read_aircraft(&dir.join(kv.value)).map_err(|e| {
            if e.line == 0 && e.message.contains("No such file") {
                ReadError::new(file, kv.line, kv.value_col, format!("aircraft file: {e}"))
            } else {
                e
            }
        }),
        None => Err(ReadError::new(file, 0, 0, "missing key `aircraft` (the aircraft file)")),
    }
}

/// The map's keys other than `format`, `columns` and `aircraft`, each checked on its own.
#[derive(Default)]
struct MapEntries {
    time: Option<Expr>,
    time_base: Option<String>,
    variable: Option<String>,
    channels: Vec<(Quantity, Expr)>,
    /// `bias.Q`: quantity, value, line, key column.
    biases: Vec<(Quantity, f64, usize, usize)>,
    /// `origin.Q`: quantity, origin, line, key column.
    origins: Vec<(Quantity, Origin, usize, usize)>,
}

impl MapEntries {
    /// Reads one key.
    fn read(&mut self, kv: &KeyValue, file: &str, format: Format, columns: usize) -> Result<(), ReadError> {
        let refuse = |why: &str| Err(ReadError::new(file, kv.line, kv.key_col, why));
        match kv.key {
            "format" | "columns" | "aircraft" | "description" => {}
            "variable" => {
                if format == Format::Ulog {
                    return refuse("`variable` applies to `format = ascii` (a `.mat` matrix) only");
                }
                self.variable = Some(kv.value.to_string());
            }
            "time" => {
                if format == Format::Ulog {
                    return refuse("a ULog map sets `time_base = TOPIC`, not `time`");
                }
                self.time = Some(parse_expr(
                    kv.value,
                    file,
                    kv.line,
                    kv.value_col,
                    format,
                    columns,
                    Dimension::Time,
                )?);
            }
            "time_base" => {
                if format == Format::Ascii {
                    return refuse("`time_base` applies to `format = ulog` only");
                }
                self.time_base = Some(kv.value.to_string());
            }
            _ => self.read_quantity_key(kv, file, format, columns)?,
        }
        Ok(())
    }

    /// Reads a `channel.Q`, `constant.Q`, `bias.Q` or `origin.Q` key.
    fn read_quantity_key(
        &mut self,
        kv: &KeyValue,
        file: &str,
        format: Format,
        columns: usize,
    ) -> Result<(), ReadError> {
        let key = kv.key;
        let (kind, name) = key.split_once('.').unwrap_or((key, ""));
        let q = match (kind, Quantity::from_name(name)) {
            ("channel" | "bias" | "constant" | "origin", Some(q)) => q,
            ("channel" | "bias" | "constant" | "origin", None) => {
                return Err(ReadError::new(
                    file,
                    kv.line,
                    kv.key_col + kind.len() + 1,
                    format!("unknown quantity `{name}`"),
                ))
            }
            _ => {
                return Err(ReadError::new(
                    file,
                    kv.line,
                    kv.key_col,
                    format!("unknown key `{key}`"),
                ))
            }
        };
        if kind == "origin" {
            let o = parse_origin(kv.value, file, kv.line, kv.value_col)?;
            self.origins.push((q, o, kv.line, kv.key_col));
            return Ok(());
        }
        if self.channels.iter().any(|(c, _)| *c == q) && kind != "bias" {
            return Err(ReadError::new(
                file,
                kv.line,
                kv.key_col,
                format!("`{q}` is set twice (as a channel and a constant)"),
            ));
        }
        if kind == "channel" {
            let e = parse_expr(kv.value, file, kv.line, kv.value_col, format, columns, dimension(q))?;
            self.channels.push((q, e));
        } else if kind == "constant" {
            self.channels
                .push((q, parse_constant(kv.value, file, kv.line, kv.value_col, dimension(q))?));
        } else {
            let Some(b) = parse_number(kv.value) else {
                return Err(ReadError::new(
                    file,
                    kv.line,
                    kv.value_col,
                    format!(
                        "`{}` is not a finite number (a bias is in SI units, no unit written)",
                        kv.value
                    ),
                ));
            };
            self.biases.push((q, b, kv.line, kv.key_col));
        }
        Ok(())
    }
}

/// Sets each `bias.Q` on its `channel.Q` (which must exist).
fn apply_biases(
    biases: Vec<(Quantity, f64, usize, usize)>,
    channels: &mut [(Quantity, Expr)],
    format: Format,
    file: &str,
) -> Result<(), ReadError> {
    for (q, b, line, col) in biases {
        match channels.iter_mut().find(|(c, _)| *c == q) {
            Some((_, e)) => e.bias = b,
            None if format == Format::Ulog => {
                // A bias on a built-in ULog channel: kept as a channel-less bias is not supported.
                return Err(ReadError::new(
                    file,
                    line,
                    col,
                    format!("`bias.{q}` needs a `channel.{q}` in this map"),
                ));
            }
            None => {
                return Err(ReadError::new(
                    file,
                    line,
                    col,
                    format!("`bias.{q}` has no `channel.{q}`"),
                ))
            }
        }
    }
    Ok(())
}

/// The `origin.Q` keys by quantity; in an ASCII map each needs its `channel.Q`.
fn origins_checked(
    origins: Vec<(Quantity, Origin, usize, usize)>,
    channels: &[(Quantity, Expr)],
    format: Format,
    file: &str,
) -> Result<BTreeMap<Quantity, Origin>, ReadError> {
    let mut origin = BTreeMap::new();
    for (q, o, line, col) in origins {
        if format == Format::Ascii && !channels.iter().any(|(c, _)| *c == q) {
            return Err(ReadError::new(
                file,
                line,
                col,
                format!("`origin.{q}` has no `channel.{q}`"),
            ));
        }
        origin.insert(q, o);
    }
    Ok(origin)
}

/// Reads a column map file.
pub fn read_map(path: &Path) -> Result<ColumnMap, ReadError> {
    let text = read_text(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse_map(&text, &path.display().to_string(), dir)
}

/// Reads a whitespace-separated ASCII flight-test file through its map (`format = ascii`).
pub fn read_ascii(path: &Path, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    parse_ascii(&text, &file, map)
}

/// [`read_ascii`] on text already read (`file` names it in errors).
pub fn parse_ascii(text: &str, file: &str, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    if map.format != Format::Ascii {
        return Err(ReadError::new(&map.file, 0, 0, "not an ASCII map (`format = ascii`)"));
    }
    let Some(time) = &map.time else {
        return Err(ReadError::new(&map.file, 0, 0, "missing key `time`"));
    };
    let used = used_columns(time, map);
    let lines: Vec<(usize, Vec<&str>)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| (i + 1, l.split_whitespace().collect()))
        .collect();
    let mut t_s = Vec::with_capacity(lines.len());
    let mut chans: Vec<Vec<f64>> = vec![Vec::with_capacity(lines.len()); map.channels.len()];
    let mut row = vec![0.0; map.columns + 1];
    for k in 0..lines.len() {
        read_row(&lines, k, &used, &mut row, file, map)?;
        let value = |e: &Expr| {
            e.eval(e.terms.iter().map(|t| match t.source {
                Source::Column(c) => row[c],
                Source::Field { .. } => f64::NAN,
            }))
        };
        t_s.push(value(time));
        for (j, (_, e)) in map.channels.iter().enumerate() {
            chans[j].push(value(e));
        }
    }
    let mut channels = BTreeMap::new();
    for ((q, _), v) in map.channels.iter().zip(chans) {
        channels.insert(*q, v);
    }
    let flight = MeasuredFlight {
        source: file.to_string(),
        t_s,
        channels,
        aircraft: map.aircraft.clone(),
        log: Default::default(),
    };
    flight
        .validate()
        .map_err(|inv| invalid_at(&inv, &lines, time, file, map))?;
    let mut flight = flight;
    flight.log.origin = map.origin.clone();
    super::held::resolve(&mut flight);
    Ok(flight)
}

/// The columns the map reads, each with the first quantity that reads it (for messages).
fn used_columns(time: &Expr, map: &ColumnMap) -> BTreeMap<usize, String> {
    let mut used: BTreeMap<usize, String> = BTreeMap::new();
    for t in &time.terms {
        if let Source::Column(c) = t.source {
            used.entry(c).or_insert_with(|| "time".into());
        }
    }
    for (q, e) in &map.channels {
        for t in &e.terms {
            if let Source::Column(c) = t.source {
                used.entry(c).or_insert_with(|| q.name().into());
            }
        }
    }
    used
}

/// Reads the `used` columns of row `k` of `lines` (line number, cells) into `row` (indexed by
/// column): the row must have the map's column count, and each cell read must be a finite
/// number (a run of missing samples is named).
fn read_row(
    lines: &[(usize, Vec<&str>)],
    k: usize,
    used: &BTreeMap<usize, String>,
    row: &mut [f64],
    file: &str,
    map: &ColumnMap,
) -> Result<(), ReadError> {
    let n_cols = map.columns;
    let (line, cells) = &lines[k];
    if cells.len() != n_cols {
        let col = if cells.len() < n_cols {
            cells.len() + 1
        } else {
            n_cols + 1
        };
        return Err(ReadError::new(
            file,
            *line,
            col,
            format!(
                "{} numbers on this line, the map ({}) says {n_cols}{}",
                cells.len(),
                map.file,
                used.get(&col)
                    .map_or(String::new(), |q| format!(" (column {col} is `{q}`)"))
            ),
        ));
    }
    for (&c, what) in used {
        let cell = cells[c - 1];
        match cell.parse::<f64>() {
            Ok(v) if v.is_finite() => row[c] = v,
            Ok(v) => {
                // A missing sample: report the run it starts.
                let run = lines[k..]
                    .iter()
                    .take_while(|(_, cs)| {
                        cs.get(c - 1)
                            .and_then(|s| s.parse::<f64>().ok())
                            .is_some_and(|x| !x.is_finite())
                    })
                    .count();
                let last = lines[k + run - 1].0;
                return Err(ReadError::new(
                    file,
                    *line,
                    c,
                    format!(
                        "column {c} (`{what}`): non-finite value `{cell}` ({v}), a run of {run} row{} (lines {line}–{last}); missing samples are refused, not interpolated",
                        if run == 1 { "" } else { "s" }
                    ),
                ));
            }
            Err(_) => {
                return Err(ReadError::new(
                    file,
                    *line,
                    c,
                    format!("column {c} (`{what}`): `{cell}` is not a number"),
                ))
            }
        }
    }
    Ok(())
}

/// A flight's invalidity as an error at the file's line and the map's first column of the
/// channel (or the time) at fault.
fn invalid_at(inv: &Invalid, lines: &[(usize, Vec<&str>)], time: &Expr, file: &str, map: &ColumnMap) -> ReadError {
    let line = inv.sample.and_then(|i| lines.get(i)).map_or(0, |(l, _)| *l);
    let column = match inv.quantity {
        Some(q) => map
            .channels
            .iter()
            .find(|(c, _)| *c == q)
            .and_then(|(_, e)| e.first_column()),
        None => time.first_column(),
    }
    .unwrap_or(0);
    let what = inv.quantity.map_or("time".to_string(), |q| q.name().to_string());
    let msg = inv.message.clone();
    ReadError::new(
        file,
        line,
        column,
        format!("column {column} (`{what}`, map {}): {msg}", map.file),
    )
}
