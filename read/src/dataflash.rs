//! ArduPilot DataFlash (`.bin`) → [`MeasuredFlight`].
//!
//! **Parser: written here.** The crates that exist do not fit: the `mavlink` crate parses the
//! telemetry protocol, not DataFlash logs; `ardupilot-binlog` 0.2 (one author) skips corrupt bytes
//! silently, reports no byte offset, and subtracts 3 from a format's declared length without a
//! check (a crafted `FMT` with a length below 3 overflows). The format is small: every message is
//! `0xA3 0x95 TYPE` and a payload whose layout an earlier `FMT` message (type 128, 89 bytes:
//! type, length, 4-char name, 16-char format, 64-char comma-separated labels) declares. This
//! reader walks the file once, every length checked; a byte that does not start a message is
//! skipped up to the next `0xA3 0x95` (a log cut by a power loss or with a corrupt block is the
//! normal case for DataFlash), and the skipped bytes are counted in the warnings with the offset of
//! the first. Nothing panics.
//!
//! Field types (format characters, as ArduPilot's `LogStructure.h` defines them): `b B h H i I f
//! d q Q` the integers and floats of their C types; `c C e E` 16/32-bit integers × 0.01; `L`
//! latitude/longitude, 1e-7 degrees; `M` flight mode (u8); `n N Z` 4/16/64-char strings; `a`
//! 32 × i16.
//!
//! **Units.** ArduPilot 4.x logs say them (`FMTU` gives each field a unit id, `UNIT` names the
//! ids); where they do, the reader converts from the logged unit (`deg` → rad, …) and refuses a
//! unit it cannot convert; older logs are read with the units of `LogStructure.h` (degrees for
//! `ATT` and `AOA`, rad/s and m/s² for `IMU`, m/s for `ARSP`).
//!
//! **Messages** (instance 0 unless [`ReadOptions::instances`] names another: 4.x messages carry an
//! instance field `I`, older ones number the message, `IMU2`):
//!
//! | quantity | message.field |
//! |---|---|
//! | roll/pitch/yaw rate, accel x/y/z | `IMU.GyrX…Z`, `IMU.AccX…Z` |
//! | roll, pitch, yaw | `ATT.Roll`, `ATT.Pitch`, `ATT.Yaw` |
//! | airspeed | `ARSP.Airspeed` (ArduPilot's equivalent airspeed, used as true airspeed: see the warning) |
//! | alpha, beta | `AOA.AOA`, `AOA.SSA`: the autopilot's estimate, not a vane (see below; dropped, with a warning, when every sample is zero) |
//! | altitude | `BARO.Alt` |
//! | throttle | the `RCOU` output whose `SERVOn_FUNCTION` is 70, scaled by `SERVOn_MIN`/`MAX` |
//! | vel_n, vel_e, vel_d (optional) | `XKF1.VN/VE/VD` (EKF3), else `NKF1.VN/VE/VD` (EKF2), else `GPS.Spd`·(cos, sin)`GPS.GCrs` and `GPS.VZ` |
//! | wind_n, wind_e (optional) | `XKF2.VWN/VWE`, else `NKF2.VWN/VWE` (the EKF's wind estimate) |
//!
//! **Origin** ([`LogMeta::origin`]). ArduPilot has no α/β vane driver: `AOA` is written by the
//! AHRS (`AP_AHRS::update_AOA_SSA`), which rotates its navigation filter's ground
//! velocity minus its wind estimate into the body axes and takes `atan(w/u)` and `asin(v/V)` —
//! α and β from the inertial solution, so both are marked estimated. The AHRS sets them to zero
//! while the air-relative speed is below 2 m/s, hence a log that is zero throughout carries none.
//! `ARSP` is the airspeed sensor's own reading (the message is not written without a sensor; the
//! AHRS's synthetic airspeed is not logged in it): a sensor.
//!
//! The EKF's velocity is preferred to the GPS's: it is logged faster, blends the GPS with the
//! IMU, and is the same filter's solution as the `ATT` attitude the α-free mode
//! ([`super::flow_angles`]) rotates it with. The optional channels do not cut the window: one that
//! does not cover it (to within two of its own intervals, held at its ends) or is not finite in
//! it is left out with a warning.
//!
//! Surface outputs (`SERVOn_FUNCTION` 4 aileron, 19 elevator, 21 rudder) are PWM; their throw in
//! radians is the airframe's and is not logged, so they are named in a warning, not read.
//! `PARM` messages are read into [`LogMeta::parameters`]. The window and the resampling are those
//! of the ULog reader ([`super::ulog`]): the in-air window is where the airspeed (else the GPS
//! ground speed) exceeds 0.8 × `ARSPD_FBW_MIN` (8 m/s when not logged); Euler angles are
//! interpolated with the yaw unwrapped, then wrapped to (−π, π].

use super::measured::{Aircraft, LogMeta, MeasuredFlight, Quantity};
use super::ulog::{gap_warning, hold_over_nan, interpolate, longest_run, median, time_grid, TimeBase, Window};
use super::{ReadError, ReadOptions};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;

/// The two bytes that start every DataFlash message.
pub const HEAD: [u8; 2] = [0xA3, 0x95];
/// The message type of `FMT`.
const FMT_TYPE: u8 = 128;
/// The total length of an `FMT` message.
const FMT_LEN: usize = 89;

/// A message layout declared by `FMT`.
#[derive(Debug, Clone)]
struct Layout {
    name: String,
    /// Total length, header included.
    len: usize,
    format: Vec<u8>,
    labels: Vec<String>,
}

/// One decoded field.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Num(f64),
    Text(String),
}

fn field_size(c: u8) -> Option<usize> {
    Some(match c {
        b'b' | b'B' | b'M' => 1,
        b'h' | b'H' | b'c' | b'C' => 2,
        b'i' | b'I' | b'f' | b'e' | b'E' | b'L' | b'n' => 4,
        b'd' | b'q' | b'Q' => 8,
        b'N' => 16,
        b'Z' | b'a' => 64,
        _ => return None,
    })
}

fn decode(c: u8, b: &[u8]) -> Value {
    let n = |k: usize| -> [u8; 8] {
        let mut a = [0u8; 8];
        a[..k].copy_from_slice(&b[..k]);
        a
    };
    let text = |b: &[u8]| {
        let end = b.iter().position(|&x| x == 0).unwrap_or(b.len());
        Value::Text(String::from_utf8_lossy(&b[..end]).trim().to_string())
    };
    let i16v = || i16::from_le_bytes([b[0], b[1]]) as f64;
    let u16v = || u16::from_le_bytes([b[0], b[1]]) as f64;
    let i32v = || i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64;
    let u32v = || u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64;
    Value::Num(match c {
        b'b' => b[0] as i8 as f64,
        b'B' | b'M' => b[0] as f64,
        b'h' => i16v(),
        b'H' => u16v(),
        b'c' => i16v() * 0.01,
        b'C' => u16v() * 0.01,
        b'i' => i32v(),
        b'I' => u32v(),
        b'e' => i32v() * 0.01,
        b'E' => u32v() * 0.01,
        b'L' => i32v() * 1e-7,
        b'f' => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        b'd' => f64::from_le_bytes(n(8)),
        b'q' => i64::from_le_bytes(n(8)) as f64,
        b'Q' => u64::from_le_bytes(n(8)) as f64,
        b'n' | b'N' | b'Z' => return text(b),
        _ => f64::NAN,
    })
}

/// The numeric series of one message type (all its fields), per instance.
#[derive(Debug, Default)]
struct Series {
    labels: Vec<String>,
    time_us: Vec<f64>,
    values: Vec<Vec<f64>>,
    /// Byte offset of each message.
    offsets: Vec<usize>,
}

/// Everything one pass over the file collects.
#[derive(Debug, Default)]
struct Log {
    /// (message name, instance) → series.
    series: BTreeMap<(String, u8), Series>,
    parameters: BTreeMap<String, f64>,
    /// Message name → label → unit name (from FMTU + UNIT).
    units: BTreeMap<String, BTreeMap<String, String>>,
    skipped_bytes: usize,
    first_skip: Option<usize>,
    warnings: Vec<String>,
    messages: usize,
}

/// Parses the whole file.
fn parse(bytes: &[u8], file: &str) -> Result<Log, ReadError> {
    let mut layouts: BTreeMap<u8, Layout> = BTreeMap::new();
    let mut sink = Sink::default();
    let mut pos = 0usize;
    if bytes.len() < 3 || bytes[..2] != HEAD {
        return Err(ReadError::new(
            file,
            0,
            0,
            "not an ArduPilot DataFlash log: the file does not start with the message header 0xA3 0x95",
        ));
    }
    let skip = |log: &mut Log, pos: usize| {
        log.first_skip.get_or_insert(pos);
        log.skipped_bytes += 1;
    };
    while pos + 3 <= bytes.len() {
        if bytes[pos..pos + 2] != HEAD {
            skip(&mut sink.log, pos);
            pos += 1;
            continue;
        }
        let ty = bytes[pos + 2];
        let len = match layouts.get(&ty) {
            _ if ty == FMT_TYPE => FMT_LEN,
            Some(l) => l.len,
            None => {
                skip(&mut sink.log, pos);
                pos += 1;
                continue;
            }
        };
        let Some(payload) = bytes.get(pos + 3..pos + len) else {
            // A message cut by the end of the file: the log ends here.
            sink.log.skipped_bytes += bytes.len() - pos;
            sink.log.first_skip.get_or_insert(pos);
            break;
        };
        sink.log.messages += 1;
        if ty == FMT_TYPE {
            fmt_message(payload, pos, &mut layouts, &mut sink.log.warnings);
        } else if let Some(layout) = layouts.get(&ty) {
            sink.data_message(layout, payload, pos);
        } else {
            break;
        }
        pos += len;
    }
    if pos < bytes.len() && pos + 3 > bytes.len() {
        sink.log.skipped_bytes += bytes.len() - pos;
    }
    Ok(sink.with_units(&layouts))
}

/// A FMT message (at byte `pos`): the layout of a message type, kept when its format and length
/// agree (else a warning, and that type's messages are skipped).
fn fmt_message(payload: &[u8], pos: usize, layouts: &mut BTreeMap<u8, Layout>, warnings: &mut Vec<String>) {
    let t = payload[0];
    let l = payload[1] as usize;
    let name = match decode(b'n', &payload[2..6]) {
        Value::Text(s) => s,
        Value::Num(_) => String::new(),
    };
    let format: Vec<u8> = payload[6..22].iter().copied().take_while(|&c| c != 0).collect();
    let labels: Vec<String> = match decode(b'Z', &payload[22..86]) {
        Value::Text(s) => s.split(',').map(|x| x.trim().to_string()).collect(),
        Value::Num(_) => Vec::new(),
    };
    let size: Option<usize> = format.iter().map(|&c| field_size(c)).sum();
    let mut labels = labels;
    labels.resize_with(format.len(), String::new);
    match size {
        _ if t == FMT_TYPE => {}
        Some(sz) if sz + 3 == l => {
            layouts.insert(
                t,
                Layout {
                    name,
                    len: l,
                    format,
                    labels,
                },
            );
        }
        _ => warnings.push(format!(
            "the FMT message at byte {pos} declares `{name}` (type {t}) with format `{}` and length {l}, which do not agree (or an unknown field type): its messages are skipped",
            String::from_utf8_lossy(&format)
        )),
    }
}

/// What the pass collects besides the layouts: the log, the unit names by id (UNIT) and the unit
/// ids of each message type's fields (FMTU, one char per field).
#[derive(Default)]
struct Sink {
    log: Log,
    unit_names: BTreeMap<char, String>,
    fmtu: BTreeMap<u8, String>,
}

impl Sink {
    /// A data message of `layout` at byte `pos`: a parameter, a unit, a field-unit list, and a
    /// sample of its series when it has a time.
    fn data_message(&mut self, layout: &Layout, payload: &[u8], pos: usize) {
        let mut vals = Vec::with_capacity(layout.format.len());
        let mut off = 0;
        for &c in &layout.format {
            let sz = field_size(c).unwrap_or(0);
            vals.push(decode(c, &payload[off..off + sz]));
            off += sz;
        }
        let get = |label: &str| layout.labels.iter().position(|l| l == label).map(|i| &vals[i]);
        match layout.name.as_str() {
            "PARM" => {
                if let (Some(Value::Text(n)), Some(Value::Num(v))) = (get("Name"), get("Value")) {
                    self.log.parameters.entry(n.clone()).or_insert(*v);
                }
            }
            "UNIT" => {
                if let (Some(Value::Num(id)), Some(Value::Text(l))) = (get("Id"), get("Label")) {
                    self.unit_names.insert(*id as u8 as char, l.clone());
                }
            }
            "FMTU" => {
                if let (Some(Value::Num(t)), Some(Value::Text(u))) = (get("FmtType"), get("UnitIds")) {
                    self.fmtu.insert(*t as u8, u.clone());
                }
            }
            _ => {}
        }
        // Time: TimeUS (µs), else TimeMS (ms).
        let time = match (get("TimeUS"), get("TimeMS")) {
            (Some(Value::Num(t)), _) => Some(*t),
            (None, Some(Value::Num(t))) => Some(t * 1000.0),
            _ => None,
        };
        if let Some(t) = time {
            let instance = match get("I").or_else(|| get("C")) {
                Some(Value::Num(i)) => *i as u8,
                _ => 0,
            };
            self.log.push_sample(layout, instance, t, pos, &vals);
        }
    }

    /// The log with each message type's field units (FMTU's ids named by UNIT).
    fn with_units(mut self, layouts: &BTreeMap<u8, Layout>) -> Log {
        for (ty, ids) in &self.fmtu {
            if let Some(l) = layouts.get(ty) {
                let m = self.log.units.entry(l.name.clone()).or_default();
                for (label, id) in l.labels.iter().zip(ids.chars()) {
                    if let Some(u) = self.unit_names.get(&id) {
                        m.insert(label.clone(), u.clone());
                    }
                }
            }
        }
        self.log
    }
}

impl Log {
    /// One sample (time `t` µs, message at byte `pos`) of the series of `layout` at `instance`
    /// (text fields as NaN); a message whose field count differs from the series' is left out.
    fn push_sample(&mut self, layout: &Layout, instance: u8, t: f64, pos: usize, vals: &[Value]) {
        let s = self.series.entry((layout.name.clone(), instance)).or_default();
        if s.labels.is_empty() {
            s.labels = layout.labels.clone();
            s.values = vec![Vec::new(); layout.labels.len()];
        }
        if s.values.len() == vals.len() {
            s.time_us.push(t);
            s.offsets.push(pos);
            for (j, v) in vals.iter().enumerate() {
                s.values[j].push(match v {
                    Value::Num(x) => *x,
                    Value::Text(_) => f64::NAN,
                });
            }
        }
    }
}

/// The factor from a logged unit name (ArduPilot's `UNIT` labels) to SI, for a field whose SI
/// unit is `si`.
fn unit_factor(logged: &str, si: &str) -> Option<f64> {
    match (logged, si) {
        ("deg" | "degheading", "rad") => Some(PI / 180.0),
        ("cdeg", "rad") => Some(PI / 18000.0),
        ("rad", "rad") | ("rad/s", "rad/s") | ("m/s", "m/s") | ("m/s/s", "m/s2") | ("m", "m") => Some(1.0),
        ("deg/s", "rad/s") => Some(PI / 180.0),
        ("cm", "m") => Some(0.01),
        _ => None,
    }
}

/// Reads a DataFlash log with `aircraft`.
pub fn read_dataflash(path: &Path, aircraft: Aircraft, opts: &ReadOptions) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    parse_dataflash(&bytes, &file, aircraft, opts)
}

/// The messages and instances of a DataFlash log, one line each (what `--list` prints).
pub fn list_messages(path: &Path) -> Result<String, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    let log = parse(&bytes, &file)?;
    let mut out = String::new();
    for ((name, inst), s) in &log.series {
        let span = (s.time_us.last().unwrap_or(&0.0) - s.time_us.first().unwrap_or(&0.0)) * 1e-6;
        let rate = if span > 0.0 {
            (s.time_us.len() - 1) as f64 / span
        } else {
            0.0
        };
        out += &format!(
            "{name} (instance {inst}): {} messages, {rate:.1} Hz; fields: {}\n",
            s.time_us.len(),
            s.labels.join(", ")
        );
    }
    out += &format!("{} logged parameters\n", log.parameters.len());
    Ok(out)
}

/// A field read: its source name, times (µs) and SI values.
type NamedSeries = (String, Vec<f64>, Vec<f64>);

/// A channel to read: quantity, message, label, SI unit, the factor when the log names no unit.
type Want = (Quantity, &'static str, &'static str, &'static str, f64);

const WANTS: [Want; 13] = [
    (Quantity::RollRate, "IMU", "GyrX", "rad/s", 1.0),
    (Quantity::PitchRate, "IMU", "GyrY", "rad/s", 1.0),
    (Quantity::YawRate, "IMU", "GyrZ", "rad/s", 1.0),
    (Quantity::AccelX, "IMU", "AccX", "m/s2", 1.0),
    (Quantity::AccelY, "IMU", "AccY", "m/s2", 1.0),
    (Quantity::AccelZ, "IMU", "AccZ", "m/s2", 1.0),
    (Quantity::Roll, "ATT", "Roll", "rad", PI / 180.0),
    (Quantity::Pitch, "ATT", "Pitch", "rad", PI / 180.0),
    (Quantity::Yaw, "ATT", "Yaw", "rad", PI / 180.0),
    (Quantity::Airspeed, "ARSP", "Airspeed", "m/s", 1.0),
    (Quantity::Alpha, "AOA", "AOA", "rad", PI / 180.0),
    (Quantity::Beta, "AOA", "SSA", "rad", PI / 180.0),
    (Quantity::Altitude, "BARO", "Alt", "m", 1.0),
];

/// [`read_dataflash`] on bytes already read.
pub fn parse_dataflash(
    bytes: &[u8],
    file: &str,
    aircraft: Aircraft,
    opts: &ReadOptions,
) -> Result<MeasuredFlight, ReadError> {
    let log = parse(bytes, file)?;
    let msgs = Messages { log: &log, opts, file };
    let mut warnings = log.warnings.clone();
    if let Some(w) = skipped_warning(&log) {
        warnings.push(w);
    }
    msgs.check_instances()?;
    let mut raw = msgs.wanted_channels()?;
    let mut optional = msgs.optional_channels(&mut warnings);
    if raw.iter().any(|(q, ..)| *q == Quantity::Airspeed) {
        warnings.push("`ARSP.Airspeed` is ArduPilot's equivalent airspeed; it is used as the true airspeed (no EAS2TAS correction: about 1 % low per 200 m of density altitude)".into());
    }
    drop_zero_flow_angles(&mut raw, &mut warnings);
    let origin = flow_angle_origin(&raw);
    msgs.servo_channels(&mut raw, &mut warnings);
    if raw.is_empty() {
        return Err(msgs.err(format!(
            "no channel this reader knows is in the log (it reads IMU, ATT, ARSP, AOA, BARO, RCOU); messages [instance: count]: {}",
            msgs.names()
        )));
    }
    for (_, src, t, v) in raw.iter_mut().chain(optional.iter_mut()) {
        drop_repeated_times(src, t, v, &mut warnings);
    }
    raw.retain(|(_, _, t, _)| t.len() >= 2);
    let first_us = raw.iter().map(|r| r.2[0]).fold(f64::INFINITY, f64::min);
    let last_us = raw.iter().map(|r| r.2[r.2.len() - 1]).fold(f64::NEG_INFINITY, f64::max);
    let window = msgs.window(&raw, first_us, last_us)?;
    let (base, base_src) = msgs.time_base(&raw, &window)?;
    let mut channels = BTreeMap::new();
    let mut logged_rate_hz = BTreeMap::new();
    for c in &raw {
        let out = msgs.resample_channel(c, &base, &mut warnings)?;
        channels.insert(c.0, out);
        logged_rate_hz.insert(c.0, base.rate_hz(&c.2));
    }
    for c in &optional {
        if let Some(out) = resample_optional(c, &base, &mut warnings) {
            channels.insert(c.0, out);
            logged_rate_hz.insert(c.0, base.rate_hz(&c.2));
        }
    }
    let flight = MeasuredFlight {
        source: file.to_string(),
        t_s: base.grid.iter().map(|t| t * 1e-6).collect(),
        channels,
        aircraft,
        log: LogMeta {
            format: "ArduPilot DataFlash".into(),
            logged_rate_hz,
            resampling: Some(resampling(&base, &base_src, opts)),
            window: window.text,
            airborne: window.airborne,
            aircraft_unknown: false,
            parameters: log.parameters.clone(),
            warnings,
            flow_angles: None,
            origin,
            pieces: Vec::new(),
            sampling: super::measured::Sampling::Unstated,
        },
    };
    flight.validate().map_err(|inv| {
        let src = inv
            .quantity
            .and_then(|q| raw.iter().chain(&optional).find(|r| r.0 == q))
            .map_or(String::new(), |r| format!(" (from `{}`)", r.1));
        msgs.err(inv.describe(&src, &flight.t_s))
    })?;
    Ok(flight)
}

/// A channel read: quantity, source name, times (µs), SI values.
type Channel = (Quantity, String, Vec<f64>, Vec<f64>);

/// The warning for bytes that start no known message, if any were skipped.
fn skipped_warning(log: &Log) -> Option<String> {
    (log.skipped_bytes > 0).then(|| {
        format!(
            "{} byte{} that start no known message skipped (the first at byte {}): a corrupt block or a cut end",
            log.skipped_bytes,
            if log.skipped_bytes == 1 { "" } else { "s" },
            log.first_skip.unwrap_or(0)
        )
    })
}

/// The parsed log, with the instances asked for, as the source of the channels.
struct Messages<'a> {
    log: &'a Log,
    opts: &'a ReadOptions,
    file: &'a str,
}

impl Messages<'_> {
    /// An error in the file, at no particular line.
    fn err(&self, m: String) -> ReadError {
        ReadError::new(self.file, 0, 0, m)
    }

    /// The messages and instances in the log with their counts, for error messages.
    fn names(&self) -> String {
        let mut v: Vec<String> = self
            .log
            .series
            .iter()
            .map(|((n, i), s)| format!("{n}[{i}: {}]", s.time_us.len()))
            .collect();
        v.dedup();
        v.join(", ")
    }

    /// A message instance: 4.x `I` field, else the numbered message (`IMU2` is instance 1).
    fn series(&self, msg: &str) -> Option<(String, &Series)> {
        let inst = self.opts.instances.get(msg).copied().unwrap_or(0);
        if let Some(s) = self.log.series.get(&(msg.to_string(), inst)) {
            return Some((format!("{msg}[{inst}]"), s));
        }
        if inst > 0 {
            let numbered = format!("{msg}{}", inst + 1);
            return self.log.series.get(&(numbered.clone(), 0)).map(|s| (numbered, s));
        }
        None
    }

    /// Every instance asked for is in the log.
    fn check_instances(&self) -> Result<(), ReadError> {
        for (msg, inst) in &self.opts.instances {
            if self.series(msg).is_none() {
                return Err(self.err(format!(
                    "instance {inst} of `{msg}` asked for, but the log has no such message instance; messages [instance: count]: {}",
                    self.names()
                )));
            }
        }
        Ok(())
    }

    /// One field in SI units (`default` the factor when the log names no unit); `None` when the
    /// message or the field is not logged, an error when its unit cannot be converted.
    fn field(&self, msg: &str, label: &str, si: &str, default: f64) -> Result<Option<NamedSeries>, ReadError> {
        let Some((src, s)) = self.series(msg) else {
            return Ok(None);
        };
        let Some(j) = s.labels.iter().position(|l| l == label) else {
            return Ok(None);
        };
        let factor = match self.log.units.get(msg).and_then(|m| m.get(label)) {
            Some(u) => unit_factor(u, si).ok_or_else(|| {
                self.err(format!(
                    "`{msg}.{label}` is logged in `{u}` (FMTU/UNIT), which this reader cannot convert to {si}"
                ))
            })?,
            None => default,
        };
        Ok(Some((
            format!("{src}.{label}"),
            s.time_us.clone(),
            s.values[j].iter().map(|v| v * factor).collect(),
        )))
    }

    /// The channels of [`WANTS`] that are logged.
    fn wanted_channels(&self) -> Result<Vec<Channel>, ReadError> {
        let mut raw = Vec::new();
        for (q, msg, label, si, default) in WANTS {
            if let Some((src, t, v)) = self.field(msg, label, si, default)? {
                raw.push((q, src, t, v));
            }
        }
        Ok(raw)
    }

    /// An optional field: one in a unit this reader cannot convert is left out with a warning,
    /// not a reason to refuse the log.
    fn optional_field(
        &self,
        (msg, label, si, default): (&str, &str, &str, f64),
        warnings: &mut Vec<String>,
    ) -> Option<NamedSeries> {
        match self.field(msg, label, si, default) {
            Ok(x) => x,
            Err(e) => {
                warnings.push(format!("{}; this optional channel is not read", e.message));
                None
            }
        }
    }

    /// Optional channels: the ground velocity (α-free mode) and the autopilot's wind.
    fn optional_channels(&self, warnings: &mut Vec<String>) -> Vec<Channel> {
        let mut optional = self.ekf_velocity(warnings);
        if optional.is_empty() {
            optional = self.gps_velocity(warnings);
        }
        for msg in ["XKF2", "NKF2"] {
            if let (Some(n), Some(e)) = (
                self.optional_field((msg, "VWN", "m/s", 1.0), warnings),
                self.optional_field((msg, "VWE", "m/s", 1.0), warnings),
            ) {
                optional.push((Quantity::WindNorth, n.0, n.1, n.2));
                optional.push((Quantity::WindEast, e.0, e.1, e.2));
                break;
            }
        }
        optional
    }

    /// The EKF's velocity (`XKF1`, EKF3, else `NKF1`, EKF2), preferred to the GPS's: it is
    /// logged faster than the GPS (which is 5–10 Hz), blends the GPS with the IMU, and is the same
    /// filter's solution as the `ATT` attitude the α/β estimate rotates it with. Empty when not
    /// logged.
    fn ekf_velocity(&self, warnings: &mut Vec<String>) -> Vec<Channel> {
        for msg in ["XKF1", "NKF1"] {
            if let (Some(n), Some(e), Some(d)) = (
                self.optional_field((msg, "VN", "m/s", 1.0), warnings),
                self.optional_field((msg, "VE", "m/s", 1.0), warnings),
                self.optional_field((msg, "VD", "m/s", 1.0), warnings),
            ) {
                return [
                    (Quantity::VelocityNorth, n),
                    (Quantity::VelocityEast, e),
                    (Quantity::VelocityDown, d),
                ]
                .into_iter()
                .map(|(q, (src, t, v))| (q, src, t, v))
                .collect();
            }
        }
        Vec::new()
    }

    /// The GPS's velocity: `GPS.Spd` and `GPS.GCrs` (ground speed and course over ground) give
    /// north and east, and `GPS.VZ` (down, positive descending, as ArduPilot logs the GPS's NED
    /// velocity) the vertical. Empty when not logged.
    fn gps_velocity(&self, warnings: &mut Vec<String>) -> Vec<Channel> {
        let (Some(spd), Some(crs), Some(vz)) = (
            self.optional_field(("GPS", "Spd", "m/s", 1.0), warnings),
            self.optional_field(("GPS", "GCrs", "rad", PI / 180.0), warnings),
            self.optional_field(("GPS", "VZ", "m/s", 1.0), warnings),
        ) else {
            return Vec::new();
        };
        let north: Vec<f64> = spd.2.iter().zip(&crs.2).map(|(v, c)| v * c.cos()).collect();
        let east: Vec<f64> = spd.2.iter().zip(&crs.2).map(|(v, c)| v * c.sin()).collect();
        vec![
            (
                Quantity::VelocityNorth,
                format!("{} × cos {}", spd.0, crs.0),
                spd.1.clone(),
                north,
            ),
            (
                Quantity::VelocityEast,
                format!("{} × sin {}", spd.0, crs.0),
                spd.1.clone(),
                east,
            ),
            (Quantity::VelocityDown, vz.0, vz.1, vz.2),
        ]
    }

    /// Throttle from the servo output whose function is throttle (`SERVOn_FUNCTION` 70, scaled by
    /// its PWM range); a warning for each surface servo, whose throw in radians is not logged.
    fn servo_channels(&self, raw: &mut Vec<Channel>, warnings: &mut Vec<String>) {
        let params = &self.log.parameters;
        let functions: BTreeMap<usize, i64> = (1..=16)
            .filter_map(|n| params.get(&format!("SERVO{n}_FUNCTION")).map(|f| (n, *f as i64)))
            .collect();
        let Some((src, s)) = self.series("RCOU") else { return };
        for (&n, &f) in &functions {
            let Some(j) = s.labels.iter().position(|l| *l == format!("C{n}")) else {
                continue;
            };
            let p = |k: &str, d: f64| params.get(&format!("SERVO{n}_{k}")).copied().unwrap_or(d);
            match f {
                70 => {
                    let (lo, hi) = (p("MIN", 1100.0), p("MAX", 1900.0));
                    if hi > lo {
                        raw.push((
                            Quantity::Throttle,
                            format!("{src}.C{n} (SERVO{n}_FUNCTION 70, throttle)"),
                            s.time_us.clone(),
                            s.values[j]
                                .iter()
                                .map(|v| ((v - lo) / (hi - lo)).clamp(0.0, 1.0))
                                .collect(),
                        ));
                    }
                }
                4 | 19 | 21 => {
                    let surface = match f {
                        4 => "aileron",
                        19 => "elevator",
                        _ => "rudder",
                    };
                    warnings.push(format!(
                        "`{src}.C{n}` drives the {surface} (SERVO{n}_FUNCTION {f}) as PWM; its throw in radians is the airframe's and not logged, so it is not read: no {surface} derivative"
                    ));
                }
                _ => {}
            }
        }
    }

    /// The window read: the one asked for, else the longest stretch in the air (airspeed, else
    /// GPS ground speed, above a threshold), else the whole log.
    fn window(&self, raw: &[Channel], first_us: f64, last_us: f64) -> Result<Window, ReadError> {
        if let Some((w0, w1, text)) = self.opts.chosen_window(first_us, last_us).map_err(|m| self.err(m))? {
            return Ok(Window::chosen(w0, w1, text));
        }
        let (thr, from) = match self.log.parameters.get("ARSPD_FBW_MIN") {
            Some(v) if *v > 0.0 => (0.8 * v, "0.8 × ARSPD_FBW_MIN"),
            _ => (8.0, "8 m/s, no ARSPD_FBW_MIN logged"),
        };
        let Some((what, t, v)) = self.speed(raw) else {
            return Ok(Window::whole_log(
                "no airspeed or GPS speed: the whole log is read, in the air or not".into(),
                None,
            ));
        };
        // A missing (NaN) airspeed keeps the state before it: the gate does not cut around it, so
        // the read refuses it inside the window rather than hiding it.
        let holds = hold_over_nan(&v, thr);
        Ok(match longest_run(&t, &holds, last_us) {
            Some((a, b)) => Window {
                w0: a,
                w1: b,
                text: Some(format!(
                    "in the air {:.3}…{:.3} s: the longest stretch with {what} above {thr:.1} m/s ({from})",
                    a * 1e-6,
                    b * 1e-6
                )),
                airborne: Some(true),
            },
            None => Window::whole_log(
                format!(
                    "never in the air: {what} never above {thr:.1} m/s ({from}); the whole log is read, on the ground"
                ),
                Some(false),
            ),
        })
    }

    /// The speed that says whether the vehicle is in the air: the airspeed, else the GPS ground
    /// speed; with its name, times (µs) and values.
    fn speed(&self, raw: &[Channel]) -> Option<NamedSeries> {
        raw.iter()
            .find(|r| r.0 == Quantity::Airspeed)
            .map(|r| ("airspeed".to_string(), r.2.clone(), r.3.clone()))
            .or_else(|| {
                let (src, s) = self.series("GPS")?;
                let j = s.labels.iter().position(|l| l == "Spd")?;
                Some((
                    format!("GPS ground speed `{src}.Spd`"),
                    s.time_us.clone(),
                    s.values[j].clone(),
                ))
            })
    }

    /// The uniform time base in the window, and the series that gives the step unless a rate is
    /// asked for: the fastest in the window (the IMU when logged).
    fn time_base(&self, raw: &[Channel], window: &Window) -> Result<(TimeBase, String), ReadError> {
        let lo = raw.iter().map(|r| r.2[0]).fold(window.w0, f64::max).ceil();
        let hi = raw.iter().map(|r| r.2[r.2.len() - 1]).fold(window.w1, f64::min).floor();
        let count_in = |t: &[f64]| t.iter().filter(|x| **x >= lo && **x <= hi).count();
        let Some(base) = raw.iter().max_by_key(|r| count_in(&r.2)) else {
            return Err(self.err("no channel with two samples".into()));
        };
        let base_t: Vec<f64> = base.2.iter().copied().filter(|x| *x >= lo && *x <= hi).collect();
        let h_us = match self.opts.rate_hz {
            Some(r) => (1e6 / r).round().max(1.0),
            None => median(&base_t.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>()).round(),
        };
        // (NaN-safe: a NaN bound or step fails the positive test.)
        let usable = hi > lo && base_t.len() >= 2 && h_us >= 1.0;
        if !usable {
            return Err(self.err(format!(
                "the channels read ({}) overlap in the window over fewer than 2 samples",
                raw.iter().map(|r| r.1.clone()).collect::<Vec<_>>().join(", ")
            )));
        }
        let base_src = base.1.clone();
        let grid = time_grid(lo, hi, h_us, base_t.len(), &base_src).map_err(|m| self.err(m))?;
        Ok((TimeBase { lo, hi, h_us, grid }, base_src))
    }

    /// A channel on the time base: refused when not finite in the window, yaw unwrapped before
    /// the interpolation and wrapped after.
    fn resample_channel(
        &self,
        (q, src, t, v): &Channel,
        base: &TimeBase,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<f64>, ReadError> {
        if let Some((x, at)) = first_non_finite(t, v, base) {
            return Err(self.err(format!(
                "`{src}` is {x} at t = {:.6} s inside the window read; missing samples are refused, not interpolated",
                at * 1e-6
            )));
        }
        if let Some(w) = gap_warning(src, t, base, "", "") {
            warnings.push(w);
        }
        if *q != Quantity::Yaw {
            return Ok(interpolate(t, v, &base.grid));
        }
        let unwrapped = unwrap_angle(v);
        Ok(interpolate(t, &unwrapped, &base.grid)
            .into_iter()
            .map(|x| (x + PI).rem_euclid(2.0 * PI) - PI)
            .collect())
    }
}

/// How the channels were resampled, in words; `base_src` the series whose median interval set
/// the step.
fn resampling(base: &TimeBase, base_src: &str, opts: &ReadOptions) -> String {
    format!(
        "uniform {:.2} Hz ({} µs step: {}), linear interpolation in time (yaw unwrapped), no anti-alias filter; {} samples",
        1e6 / base.h_us,
        base.h_us,
        if opts.rate_hz.is_some() {
            "the rate asked for".to_string()
        } else {
            format!("the median interval of `{base_src}`")
        },
        base.grid.len()
    )
}

/// An α/β that is zero throughout was never computed (no air-relative speed above 2 m/s): it is
/// dropped with a warning.
fn drop_zero_flow_angles(raw: &mut Vec<Channel>, warnings: &mut Vec<String>) {
    raw.retain(|(q, src, _, v)| {
        let zero = matches!(q, Quantity::Alpha | Quantity::Beta) && v.iter().all(|x| *x == 0.0);
        if zero {
            warnings.push(format!(
                "`{src}` is zero in every message: the autopilot did not compute it (zero padding); not read"
            ));
        }
        !zero
    });
}

/// The α and β from ArduPilot's `AOA` message are its estimate, not a vane's.
fn flow_angle_origin(raw: &[Channel]) -> BTreeMap<Quantity, super::measured::Origin> {
    let mut origin = BTreeMap::new();
    for (q, src, ..) in raw {
        if matches!(q, Quantity::Alpha | Quantity::Beta) && src.starts_with("AOA") {
            origin.insert(
                *q,
                super::measured::Origin::Estimated {
                    by: format!("ArduPilot `{src}` (the AHRS's EKF ground velocity minus its wind estimate; no vane)"),
                },
            );
        }
    }
    origin
}

/// Times strictly increasing: messages with a time not later than the one before are dropped,
/// with a warning.
fn drop_repeated_times(src: &str, t: &mut Vec<f64>, v: &mut Vec<f64>, warnings: &mut Vec<String>) {
    let mut keep = Vec::with_capacity(t.len());
    let mut last = f64::NEG_INFINITY;
    for (i, &ti) in t.iter().enumerate() {
        if ti > last {
            keep.push(i);
            last = ti;
        }
    }
    if keep.len() < t.len() {
        warnings.push(format!(
            "`{src}`: {} of {} messages with a time not later than the message before; dropped",
            t.len() - keep.len(),
            t.len()
        ));
        *t = keep.iter().map(|&i| t[i]).collect();
        *v = keep.iter().map(|&i| v[i]).collect();
    }
}

/// The first value that is not finite among the samples that enter the window's interpolation
/// (one either side of it), with its time (µs).
fn first_non_finite(t: &[f64], v: &[f64], base: &TimeBase) -> Option<(f64, f64)> {
    let i0 = t.partition_point(|&x| x < base.lo).saturating_sub(1);
    let i1 = (t.partition_point(|&x| x <= base.hi) + 1).min(t.len());
    v[i0..i1]
        .iter()
        .position(|x| !x.is_finite())
        .map(|i| (v[i0 + i], t[i0 + i]))
}

/// An angle with its 2π jumps removed.
fn unwrap_angle(v: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.len());
    let mut offset = 0.0;
    for (i, &x) in v.iter().enumerate() {
        if i > 0 {
            let d = x - v[i - 1];
            if d > PI {
                offset -= 2.0 * PI;
            } else if d < -PI {
                offset += 2.0 * PI;
            }
        }
        out.push(x + offset);
    }
    out
}

/// An optional channel on the time base: read where it covers the window (to within two of its
/// own intervals, held at its ends) and is finite in it; else `None`, with a warning.
fn resample_optional((q, src, t, v): &Channel, base: &TimeBase, warnings: &mut Vec<String>) -> Option<Vec<f64>> {
    let (lo, hi) = (base.lo, base.hi);
    let dt = median(&t.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>());
    if t.len() < 2 || t[0] > lo + 2.0 * dt || t[t.len() - 1] < hi - 2.0 * dt {
        warnings.push(format!(
            "`{src}` ({q}) covers {:.3}…{:.3} s, not the window {:.3}…{:.3} s: not read (choose a window inside it with --from/--to to read it)",
            t.first().copied().unwrap_or(0.0) * 1e-6,
            t.last().copied().unwrap_or(0.0) * 1e-6,
            lo * 1e-6,
            hi * 1e-6
        ));
        return None;
    }
    if let Some((x, at)) = first_non_finite(t, v, base) {
        warnings.push(format!(
            "`{src}` is {x} at t = {:.6} s inside the window: {q} not read",
            at * 1e-6
        ));
        return None;
    }
    if let Some(w) = gap_warning(src, t, base, "", "") {
        warnings.push(w);
    }
    Some(interpolate(t, v, &base.grid))
}
