//! PX4 ULog (`.ulg`) → [`MeasuredFlight`].
//!
//! **Parser.** The `px4-ulog` crate (0.6, kept by the PX4 organisation, `byteorder` its only
//! dependency; chosen over `yule_log`, which pulls `regex`, `env_logger` and `lazy_static` and
//! panics on an over-long array size in a format, and `ulog-rs` 0.0.x, "in development", with a
//! CLI's dependencies in the library). `px4-ulog` checks every data message against its format's
//! size and classifies a cut file, but indexes the payload of a Parameter or AddLogged message
//! before checking its length; so this module first walks the message framing itself
//! (`scan`, every length checked) and refuses a truncated or malformed file with the message
//! index and byte offset before the crate sees it. The same walk reads the logged parameters
//! (`P` messages: `float NAME` or `int32_t NAME`, the first value of each), which the crate's
//! data callback does not deliver. Only the primary data section is read (the appended
//! crash-recovery sections a FlagBits message may point to are ignored).
//!
//! **Topics** (instance 0 of each unless [`ReadOptions::instances`] chooses another):
//!
//! | quantity | topic.field | |
//! |---|---|---|
//! | roll, pitch, yaw | `vehicle_attitude.q[0..3]` (Hamilton, body FRD → NED), Euler 3-2-1 | if present |
//! | roll/pitch/yaw rate | `vehicle_angular_velocity.xyz[0..2]`, else `sensor_combined.gyro_rad[0..2]` | if present |
//! | roll/pitch/yaw accel | `vehicle_angular_velocity.xyz_derivative[0..2]` | if present |
//! | accel x/y/z (specific force) | `vehicle_acceleration.xyz[0..2]`, else `sensor_combined.accelerometer_m_s2[0..2]` | if present |
//! | airspeed (true) | `airspeed_validated.true_airspeed_m_s` or `airspeed.true_airspeed_m_s`, whichever has more messages | if present |
//! | air density, altitude | `vehicle_air_data.rho`, `vehicle_air_data.baro_alt_meter` | if present |
//! | alpha, beta | `airflow_aoa.aoa_rad`, `airflow_slip.slip_rad` (vanes) | if present |
//! | throttle | `actuator_motors.control[0]`, else `actuator_controls_0.control[3]` | if present |
//! | vel_n, vel_e, vel_d (ground velocity, NED) | `vehicle_local_position.vx,vy,vz` (the navigation filter's), else `vehicle_gps_position` or `sensor_gps` `.vel_n_m_s, vel_e_m_s, vel_d_m_s` | optional |
//! | wind_n, wind_e (the autopilot's wind estimate) | `wind`, else `wind_estimate` `.windspeed_north, windspeed_east` | optional |
//!
//! **Origin** ([`LogMeta::origin`]): `airflow_aoa`/`airflow_slip` come from vane sensors. The
//! validated airspeed is marked estimated when its messages say it is ground speed minus the wind
//! estimate or the synthetic airspeed (`airspeed_source` 0 or 4, `selected_airspeed_index` 0 in
//! older logs), not a pitot; a map's `origin.QUANTITY` overrides.
//!
//! The optional channels (for the α-free mode, [`super::flow_angles`]) do not cut the window: a
//! topic that does not cover it (to within two of its own intervals, held at its ends) or is not
//! finite in it is left out, with a warning, rather than shortening the flight or refusing it.
//!
//! A channel the log lacks is simply absent; the data-quality assessment
//! ([`super::quality`]) says what can then not be identified (no airspeed: no coefficient).
//! Surfaces need the airframe's servo mapping (which output, how many radians per unit), so they
//! come from a ULog column map (`format = ulog`, [`super::colmap`]), e.g.
//! `channel.elevator = 0.35*actuator_servos.control[1] rad`; a map channel replaces the built-in
//! one of the same quantity. A map naming a topic or field the log lacks is refused with the list
//! of the log's topics (with their instances) or of the topic's fields.
//!
//! **Time.** Each topic's time is `timestamp_sample` (when the sensor sampled) where the topic
//! has it, else `timestamp` (when it was published), µs since boot → s. A message whose time
//! does not increase over the one kept before it (PX4 republishes a sample with the same
//! `timestamp_sample`) is dropped and counted in the warnings; the first of each time is kept.
//!
//! **Window.** [`ReadOptions::from_s`] / [`ReadOptions::to_s`] (boot time, s, the scale of the
//! output time base) cut the log. Without them the reader keeps the longest stretch the vehicle
//! was in the air: from `vehicle_land_detected.landed` (held between its messages, as PX4
//! publishes it on change), else where the true airspeed exceeds 0.8 × `FW_AIRSPD_STALL` (else
//! `FW_AIRSPD_MIN`; a logged parameter; 8 m/s when neither is logged). A log that never leaves
//! the ground is read whole and marked so ([`LogMeta::airborne`]); [`ReadOptions::whole_log`]
//! turns the gate off.
//!
//! **Resampling.** The output time base is uniform: it starts at the latest first sample of the
//! used topics inside the window and steps by the median interval of the base topic (`time_base`
//! of the map, else the rate topic) in the window, rounded to a microsecond, or by
//! 1/[`ReadOptions::rate_hz`]; it ends at the earliest last sample (no extrapolation). Every
//! field is interpolated linearly in time onto it (no anti-alias filter: a topic logged faster
//! than the base is sampled, one logged slower is joined by straight lines, and the report gives
//! each channel's own rate); the attitude quaternion component-wise between its two neighbouring
//! samples (the second one's sign flipped if they point apart), then normalised (nlerp), then
//! turned into Euler angles. An interval longer than 5 × a topic's median interval is a gap
//! (dropped messages), interpolated across and listed in the warnings. Every used field must be
//! finite inside the window (a NaN is refused with its message, not interpolated over).

use super::colmap::{ColumnMap, Expr, Format, Source};
use super::measured::{LogMeta, MeasuredFlight, Origin, Quantity};
use super::{ReadError, ReadOptions};
use px4_ulog::stream_parser::model::FlattenedFieldType;
use px4_ulog::stream_parser::{DataMessage, LogParser};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

/// The ULog file magic (`ULog` 0x01 0x12 0x35), followed by a version byte and a u64 timestamp.
pub const MAGIC: [u8; 7] = [b'U', b'L', b'o', b'g', 0x01, 0x12, 0x35];

/// An interval longer than this many median intervals of its topic is a gap (dropped messages).
pub const GAP_FACTOR: f64 = 5.0;

/// One data message's place in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    /// Message ordinal in the file (0-based, header not counted).
    index: usize,
    /// Byte offset of the message header.
    offset: usize,
}

/// What [`scan`] finds: data messages' places, the end of the primary section, parameters.
struct Scan {
    places: Vec<Place>,
    end: usize,
    parameters: BTreeMap<String, f64>,
}

/// Walks the message framing of `bytes` (every length checked): the data messages' places, the
/// end of the primary section and the logged parameters (first value of each). Refuses a short
/// or bad header, a message cut by the end of the file, and Parameter/AddLogged messages too
/// short for their own headers.
fn scan(bytes: &[u8], file: &str) -> Result<Scan, ReadError> {
    let e = |m: String| ReadError::new(file, 0, 0, m);
    check_header(bytes).map_err(e)?;
    let mut s = Scan {
        places: Vec::new(),
        end: bytes.len(),
        parameters: BTreeMap::new(),
    };
    let mut pos = 16;
    let mut index = 0usize;
    while pos < s.end {
        let Some(head) = bytes.get(pos..pos + 3) else {
            return Err(e(format!(
                "truncated ULog: message #{index} at byte {pos}: the file ends inside the 3-byte message header"
            )));
        };
        let size = u16::from_le_bytes([head[0], head[1]]) as usize;
        let kind = head[2];
        let Some(payload) = bytes.get(pos + 3..pos + 3 + size) else {
            return Err(e(format!(
                "truncated ULog: message #{index} (type '{}') at byte {pos} declares {size} bytes, the file has {} left",
                kind as char,
                s.end.saturating_sub(pos + 3)
            )));
        };
        s.message(kind, index, pos, payload).map_err(|m| {
            e(format!(
                "malformed ULog: message #{index} (type '{}') at byte {pos}: {m}",
                kind as char
            ))
        })?;
        pos += 3 + size;
        index += 1;
    }
    if pos > s.end {
        return Err(e(format!(
            "malformed ULog: a message runs past the start of the appended data at byte {}",
            s.end
        )));
    }
    Ok(s)
}

/// The file is long enough for the ULog header and starts with its magic bytes.
fn check_header(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < 16 {
        return Err(format!(
            "not a ULog: {} bytes, the header alone has 16 (truncated ULog)",
            bytes.len()
        ));
    }
    if bytes[..7] != MAGIC {
        return Err("not a ULog: the file does not start with the ULog magic bytes".into());
    }
    Ok(())
}

impl Scan {
    /// Message `index` (type `kind`, at byte `pos`, its `payload`): a FlagBits message may end
    /// the primary section early, a parameter is kept (its first value), a data message's place
    /// is noted. `Err`: why the message is malformed.
    fn message(&mut self, kind: u8, index: usize, pos: usize, payload: &[u8]) -> Result<(), &'static str> {
        let size = payload.len();
        match kind {
            b'B' => {
                if index != 0 {
                    return Err("FlagBits must be the first message");
                }
                if size < 40 {
                    return Err("FlagBits shorter than 40 bytes");
                }
                // The first appended-data offset ends the primary section.
                let first = u64::from_le_bytes(payload[16..24].try_into().unwrap_or([0; 8])) as usize;
                if first != 0 && first < self.end {
                    self.end = first;
                }
            }
            b'A' if size < 3 => return Err("AddLogged shorter than its 3-byte header"),
            b'P' | b'Q' => {
                let k = if kind == b'P' { 0 } else { 1 };
                match payload.get(k) {
                    Some(&len) if k + 1 + len as usize <= size => {
                        if kind == b'P' {
                            let key = &payload[1..1 + len as usize];
                            let value = &payload[1 + len as usize..];
                            if let Some((name, v)) = parameter(key, value) {
                                self.parameters.entry(name).or_insert(v);
                            }
                        }
                    }
                    _ => return Err("parameter key longer than the message"),
                }
            }
            b'D' => self.places.push(Place { index, offset: pos }),
            _ => {}
        }
        Ok(())
    }
}

/// A parameter message's name and value (`float NAME` → f32, `int32_t NAME` → i32); `None` for
/// another type or a value too short.
fn parameter(key: &[u8], value: &[u8]) -> Option<(String, f64)> {
    let key = std::str::from_utf8(key).ok()?;
    let (ty, name) = key.split_once(' ')?;
    let v4: [u8; 4] = value.get(..4)?.try_into().ok()?;
    let v = match ty {
        "float" => f32::from_le_bytes(v4) as f64,
        "int32_t" => i32::from_le_bytes(v4) as f64,
        _ => return None,
    };
    Some((name.to_string(), v))
}

/// The values of one topic (the chosen instance), every numeric field.
#[derive(Debug, Default)]
struct Topic {
    /// Field names, flattened (`q[0]`).
    names: Vec<String>,
    /// Per field, its samples.
    values: Vec<Vec<f64>>,
    /// Time, µs (`timestamp_sample` if the topic has it, else `timestamp`).
    time_us: Vec<u64>,
    /// Which field the time is.
    time_field: &'static str,
    /// Each sample's message.
    places: Vec<Place>,
}

/// One topic instance of the log as the listing shows it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TopicInfo {
    /// Flattened field names.
    pub fields: Vec<String>,
    /// Messages.
    pub count: usize,
    /// First and last `timestamp`, µs.
    pub span_us: (u64, u64),
}

fn decode(t: &FlattenedFieldType, b: &[u8]) -> Option<f64> {
    use FlattenedFieldType::*;
    let a = |n: usize| b.get(..n);
    Some(match t {
        Int8 => *b.first()? as i8 as f64,
        UInt8 | Bool | Char => *b.first()? as f64,
        Int16 => i16::from_le_bytes(a(2)?.try_into().ok()?) as f64,
        UInt16 => u16::from_le_bytes(a(2)?.try_into().ok()?) as f64,
        Int32 => i32::from_le_bytes(a(4)?.try_into().ok()?) as f64,
        UInt32 => u32::from_le_bytes(a(4)?.try_into().ok()?) as f64,
        Int64 => i64::from_le_bytes(a(8)?.try_into().ok()?) as f64,
        UInt64 => u64::from_le_bytes(a(8)?.try_into().ok()?) as f64,
        Float => f32::from_le_bytes(a(4)?.try_into().ok()?) as f64,
        Double => f64::from_le_bytes(a(8)?.try_into().ok()?),
    })
}

fn decode_u64(b: &[u8]) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(..8)?.try_into().ok()?))
}

/// The topics the built-in mapping reads.
const BUILTIN_TOPICS: [&str; 19] = [
    "vehicle_attitude",
    "vehicle_angular_velocity",
    "sensor_combined",
    "vehicle_acceleration",
    "airspeed_validated",
    "airspeed",
    "vehicle_air_data",
    "airflow_aoa",
    "airflow_slip",
    "actuator_motors",
    "actuator_servos",
    "actuator_controls_0",
    "vehicle_land_detected",
    "actuator_outputs",
    "vehicle_local_position",
    "vehicle_gps_position",
    "sensor_gps",
    "wind",
    "wind_estimate",
];

/// How to decode one wanted message id: topic, time-field offset and name, every field's type
/// and offset.
type Decoder = (String, usize, &'static str, Vec<(FlattenedFieldType, usize)>);

/// Per message id: its catalog key (topic, instance), its `timestamp` offset, and its decoder when
/// the topic is wanted.
type IdEntry = ((String, u8), Option<usize>, Option<Decoder>);

/// What [`collect`] returns: the wanted topics' data and the listing of every topic instance.
type Collected = (BTreeMap<String, Topic>, BTreeMap<(String, u8), TopicInfo>);

/// Reads the data of the `wanted` topics (the instance `instances` names, else 0), and lists
/// every topic instance of the log.
fn collect(
    bytes: &[u8],
    file: &str,
    places: &[Place],
    wanted: &BTreeSet<String>,
    instances: &BTreeMap<String, u8>,
) -> Result<Collected, ReadError> {
    let mut c = Collector {
        file,
        places,
        wanted,
        instances,
        topics: BTreeMap::new(),
        catalog: BTreeMap::new(),
        ids: HashMap::new(),
        k: 0,
        failure: None,
    };
    {
        let mut callback = |m: &DataMessage| c.message(m);
        let mut parser = LogParser::default();
        parser.set_data_message_callback(&mut callback);
        parser.consume_bytes(bytes).map_err(|e| {
            let at = places.get(c.k).map_or(String::new(), |p| {
                format!(" near ULog message #{} at byte {}", p.index, p.offset)
            });
            ReadError::new(file, 0, 0, format!("malformed ULog{at}: {e}"))
        })?;
    }
    if let Some(f) = c.failure {
        return Err(f);
    }
    Ok((c.topics, c.catalog))
}

/// The pass of [`collect`] over the data messages: the wanted topics' data, the catalog of every
/// topic instance, what each message id is (`ids`), the messages seen (`k`) and the first
/// failure (after which the rest is only counted).
struct Collector<'c> {
    file: &'c str,
    places: &'c [Place],
    wanted: &'c BTreeSet<String>,
    instances: &'c BTreeMap<String, u8>,
    topics: BTreeMap<String, Topic>,
    catalog: BTreeMap<(String, u8), TopicInfo>,
    ids: HashMap<u16, IdEntry>,
    k: usize,
    failure: Option<ReadError>,
}

impl Collector<'_> {
    /// One data message: counted in the catalog, and its fields appended to its topic when the
    /// topic is wanted.
    fn message(&mut self, m: &DataMessage) {
        let place = self
            .places
            .get(self.k)
            .copied()
            .unwrap_or(Place { index: 0, offset: 0 });
        self.k += 1;
        if self.failure.is_some() {
            return;
        }
        let (catalog, topics) = (&mut self.catalog, &mut self.topics);
        let (wanted, instances) = (self.wanted, self.instances);
        let (key, ts_offset, decoder) = self
            .ids
            .entry(m.msg_id)
            .or_insert_with(|| id_entry(m, catalog, topics, wanted, instances));
        if let Some(info) = catalog.get_mut(key) {
            let t = ts_offset
                .and_then(|o| m.data.get(o..))
                .and_then(decode_u64)
                .unwrap_or(0);
            if info.count == 0 {
                info.span_us = (t, t);
            }
            info.count += 1;
            info.span_us.0 = info.span_us.0.min(t);
            info.span_us.1 = info.span_us.1.max(t);
        }
        let Some((name, time_offset, time_field, layout)) = decoder else {
            return;
        };
        let Some(topic) = topics.get_mut(name.as_str()) else {
            return;
        };
        let Some(t) = m.data.get(*time_offset..).and_then(decode_u64) else {
            self.failure = Some(ReadError::new(
                self.file,
                0,
                0,
                format!(
                    "ULog message #{} at byte {}: `{name}` too short for its `{time_field}`",
                    place.index, place.offset
                ),
            ));
            return;
        };
        for (j, (ty, off)) in layout.iter().enumerate() {
            let v = m.data.get(*off..).and_then(|b| decode(ty, b)).unwrap_or(f64::NAN);
            topic.values[j].push(v);
        }
        topic.time_us.push(t);
        topic.places.push(place);
    }
}

/// What the first message of an id says: its topic instance (entered in `catalog` with its
/// fields), its `timestamp` offset, and, when the topic is `wanted` at the instance asked for
/// (`instances`, else 0) and has a time field, its decoder (the topic entered in `topics`).
fn id_entry(
    m: &DataMessage,
    catalog: &mut BTreeMap<(String, u8), TopicInfo>,
    topics: &mut BTreeMap<String, Topic>,
    wanted: &BTreeSet<String>,
    instances: &BTreeMap<String, u8>,
) -> IdEntry {
    let name = m.flattened_format.message_name().to_string();
    let instance = m.multi_id.value();
    let fields: Vec<_> = m.flattened_format.fields.iter().collect();
    let offset_of = |n: &str| {
        fields
            .iter()
            .find(|f| f.flattened_field_name == n && f.field_type == FlattenedFieldType::UInt64)
            .map(|f| f.offset as usize)
    };
    let ts = offset_of("timestamp");
    let info = catalog.entry((name.clone(), instance)).or_default();
    info.fields = fields.iter().map(|f| f.flattened_field_name.clone()).collect();
    let chosen = instances.get(&name).copied().unwrap_or(0);
    let decoder = if wanted.contains(&name) && instance == chosen {
        let (time_offset, time_field) = match offset_of("timestamp_sample") {
            Some(o) => (Some(o), "timestamp_sample"),
            None => (ts, "timestamp"),
        };
        time_offset.map(|o| {
            let topic = topics.entry(name.clone()).or_default();
            topic.names = fields.iter().map(|f| f.flattened_field_name.clone()).collect();
            topic.values = vec![Vec::new(); fields.len()];
            topic.time_field = time_field;
            let layout = fields
                .iter()
                .map(|f| (f.field_type.clone(), f.offset as usize))
                .collect();
            (name.clone(), o, time_field, layout)
        })
    } else {
        None
    };
    ((name, instance), ts, decoder)
}

/// The topic instances of a ULog, one line each: `name` (instance, messages, rate, time span,
/// fields). What `aerosid gaps --data FILE.ulg --list` prints.
pub fn list_topics(path: &Path) -> Result<String, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    let s = scan(&bytes, &file)?;
    let (_, catalog) = collect(&bytes[..s.end], &file, &s.places, &BTreeSet::new(), &BTreeMap::new())?;
    let mut out = String::new();
    for ((name, inst), info) in &catalog {
        let span = (info.span_us.1 - info.span_us.0) as f64 * 1e-6;
        let rate = if span > 0.0 {
            (info.count - 1) as f64 / span
        } else {
            0.0
        };
        out += &format!(
            "{name} (instance {inst}): {} messages, {rate:.1} Hz, t = {:.3}…{:.3} s; fields: {}\n",
            info.count,
            info.span_us.0 as f64 * 1e-6,
            info.span_us.1 as f64 * 1e-6,
            info.fields.join(", ")
        );
    }
    out += &format!("{} logged parameters\n", s.parameters.len());
    Ok(out)
}

/// The topic list of an error message: every topic with its instances.
fn topic_names(catalog: &BTreeMap<(String, u8), TopicInfo>) -> String {
    let mut by_name: BTreeMap<&str, Vec<String>> = BTreeMap::new();
    for ((name, inst), info) in catalog {
        by_name
            .entry(name.as_str())
            .or_default()
            .push(format!("{inst}: {} msgs", info.count));
    }
    if by_name.is_empty() {
        return "(no data messages)".into();
    }
    by_name
        .iter()
        .map(|(n, v)| format!("{n} [{}]", v.join(", ")))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Linear interpolation of `(t, x)` (t strictly increasing) at `tq` (inside `[t₀, t_end]`),
/// advancing the search cursor `j`.
fn interp(t: &[f64], x: &[f64], tq: f64, j: &mut usize) -> f64 {
    while *j + 1 < t.len() && t[*j + 1] < tq {
        *j += 1;
    }
    if *j + 1 >= t.len() {
        return x[t.len() - 1];
    }
    let (t0, t1) = (t[*j], t[*j + 1]);
    if tq <= t0 {
        return x[*j];
    }
    let w = (tq - t0) / (t1 - t0);
    x[*j] + w * (x[*j + 1] - x[*j])
}

/// Euler angles 3-2-1 (roll, pitch, yaw) of a unit quaternion `[w, x, y, z]` rotating body to NED.
pub fn quaternion_to_euler(q: [f64; 4]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// A source resolved: topic and field index.
struct Resolved<'a> {
    topic: &'a str,
    field: usize,
}

/// Where PX4's validated airspeed came from, when not (only) from a pitot: `Some(what)` if any
/// message of `airspeed_validated` has an estimator as its source. Each message names its source:
/// `airspeed_source` (PX4 1.15 on: −1 disabled, 0 ground speed minus the wind estimate, 1–3 an
/// airspeed sensor, 4 synthetic, from the thrust and the attitude) or, before it,
/// `selected_airspeed_index` (−1 invalid, 0 ground speed minus wind, 1–3 a sensor). With source 0
/// or 4 the topic's `true_airspeed_m_s` is the estimator's value, not a pitot's, so the channel is
/// an estimate (its errors are no pitot's scale or lag). A topic without either field says
/// nothing: taken as the sensor's.
fn airspeed_validated_origin(tp: &Topic) -> Option<String> {
    let field = ["airspeed_source", "selected_airspeed_index"]
        .into_iter()
        .find_map(|name| tp.names.iter().position(|n| n == name).map(|i| (name, i)))?;
    let sources = tp.values.get(field.1)?;
    let estimated = |code: f64| code == 0.0 || (field.0 == "airspeed_source" && code == 4.0);
    let n = sources.iter().filter(|c| estimated(**c)).count();
    if n == 0 {
        return None;
    }
    Some(format!(
        "PX4 airspeed_validated, {n} of {} messages from ground speed minus the wind estimate or the synthetic airspeed (`{}` 0{})",
        sources.len(),
        field.0,
        if field.0 == "airspeed_source" { " or 4" } else { "" }
    ))
}

/// The median of `x` (0 when empty).
pub(crate) fn median(x: &[f64]) -> f64 {
    let mut v: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The longest interval over which `state(t)` holds, with `state` held from each sample to the
/// next (the last one to `end`): `(start, end)`, or `None` if it never holds.
pub(crate) fn longest_run(t: &[f64], holds: &[bool], end: f64) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    let mut start: Option<f64> = None;
    for i in 0..t.len() {
        match (holds[i], start) {
            (true, None) => start = Some(t[i]),
            (false, Some(s)) => {
                if best.is_none_or(|(a, b)| t[i] - s > b - a) {
                    best = Some((s, t[i]));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        if best.is_none_or(|(a, b)| end - s > b - a) {
            best = Some((s, end));
        }
    }
    best
}

/// `x > threshold` per sample, a non-finite sample keeping the state before it (false at the
/// start).
pub(crate) fn hold_over_nan(x: &[f64], threshold: f64) -> Vec<bool> {
    let mut state = false;
    x.iter()
        .map(|v| {
            if v.is_finite() {
                state = *v > threshold;
            }
            state
        })
        .collect()
}

/// The gaps of a sample-time series inside `[lo, hi]`: intervals longer than [`GAP_FACTOR`] ×
/// the median interval, as (count, longest, where it starts).
pub(crate) fn gaps(t: &[f64], lo: f64, hi: f64) -> Option<(usize, f64, f64)> {
    let inside: Vec<f64> = t.iter().copied().filter(|&x| x >= lo && x <= hi).collect();
    let d: Vec<f64> = inside.windows(2).map(|w| w[1] - w[0]).collect();
    let med = median(&d);
    let mut out: Option<(usize, f64, f64)> = None;
    for (i, &di) in d.iter().enumerate() {
        if med > 0.0 && di > GAP_FACTOR * med {
            let e = out.get_or_insert((0, 0.0, 0.0));
            e.0 += 1;
            if di > e.1 {
                e.1 = di;
                e.2 = inside[i];
            }
        }
    }
    out
}

/// The most output samples per sample of the base series in the window. The output grid is sized
/// from the window's time span, which one corrupt time stamp can make astronomically long (a flipped
/// high byte of a 64-bit `TimeUS` is years); bounding it by the samples the file actually holds
/// keeps every allocation proportional to the file. 16 allows a gap of 15 base intervals per
/// sample on average, or `--rate` at 16 × the logged rate, far beyond any real log.
pub(crate) const MAX_GRID_PER_SAMPLE: f64 = 16.0;

/// The uniform output grid `lo, lo + h_us, …, ≤ hi` (µs), refused when it would hold more than
/// [`MAX_GRID_PER_SAMPLE`] × `base_samples` points (`base` names the series in the message).
pub(crate) fn time_grid(lo: f64, hi: f64, h_us: f64, base_samples: usize, base: &str) -> Result<Vec<f64>, String> {
    let n = ((hi - lo) / h_us).floor() + 1.0;
    // (NaN-safe: a NaN count fails the test.)
    if !(n >= 1.0 && n <= MAX_GRID_PER_SAMPLE * base_samples as f64) {
        return Err(format!(
            "the window {:.6}…{:.6} s at a {:.0} µs step would be {n:.0} samples, more than {MAX_GRID_PER_SAMPLE} × the {base_samples} samples of `{base}` in it: a time stamp is corrupt or the log has a long gap (choose a window with --from/--to), or --rate asks for more than {MAX_GRID_PER_SAMPLE} × the logged rate",
            lo * 1e-6,
            hi * 1e-6,
            h_us
        ));
    }
    Ok((0..n as usize).map(|k| lo + k as f64 * h_us).collect())
}

/// Reads a ULog through `map` (`format = ulog`; [`ColumnMap::ulog_default`] for the built-in
/// topics only) with the default [`ReadOptions`] (the in-air window, instance 0 of every topic).
pub fn read_ulog(path: &Path, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    read_ulog_with(path, map, &ReadOptions::default())
}

/// [`read_ulog`] with options.
pub fn read_ulog_with(path: &Path, map: &ColumnMap, opts: &ReadOptions) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    parse_ulog_with(&bytes, &file, map, opts)
}

/// [`read_ulog`] on bytes already read (`file` names them in errors).
pub fn parse_ulog(bytes: &[u8], file: &str, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    parse_ulog_with(bytes, file, map, &ReadOptions::default())
}

/// [`parse_ulog`] with options.
pub fn parse_ulog_with(
    bytes: &[u8],
    file: &str,
    map: &ColumnMap,
    opts: &ReadOptions,
) -> Result<MeasuredFlight, ReadError> {
    if map.format != Format::Ulog {
        return Err(ReadError::new(&map.file, 0, 0, "not a ULog map (`format = ulog`)"));
    }
    let err = |m: String| ReadError::new(file, 0, 0, m);
    let Decoded {
        scan: s,
        topics,
        catalog,
        mut warnings,
    } = decode_topics(bytes, file, map, opts)?;
    let log = Topics {
        topics: &topics,
        catalog: &catalog,
        file,
        opts,
    };
    let src = log.sources(map, &mut warnings)?;
    let timing = log.timing(&src, map, &s.parameters, &mut warnings)?;
    let (channels, logged_rate_hz) = resample_channels(&topics, &timing, &src, &mut warnings).map_err(err)?;
    let flight = MeasuredFlight {
        source: file.to_string(),
        t_s: timing.base.grid.iter().map(|t| t * 1e-6).collect(),
        channels,
        aircraft: map.aircraft.clone(),
        log: LogMeta {
            format: "PX4 ULog".into(),
            logged_rate_hz,
            resampling: Some(resampling(&timing.base, timing.base_topic, opts)),
            window: timing.window.text,
            airborne: timing.window.airborne,
            aircraft_unknown: false,
            parameters: s.parameters,
            warnings,
            flow_angles: None,
            origin: src.builtin.origin.clone(),
            pieces: Vec::new(),
            sampling: super::measured::Sampling::Unstated,
        },
    };
    flight.validate().map_err(|inv| {
        let src_text = inv.quantity.map_or(String::new(), |q| {
            source_of(
                q,
                &topics,
                map,
                &src.mapped,
                src.builtin.channels.iter().chain(&src.optional),
            )
        });
        err(inv.describe(&src_text, &flight.t_s))
    })?;
    Ok(flight)
}

/// The log decoded: its scan (the parameters), the topics (a repeated time dropped, with a
/// warning) and the catalog of every topic instance.
struct Decoded {
    scan: Scan,
    topics: BTreeMap<String, Topic>,
    catalog: BTreeMap<(String, u8), TopicInfo>,
    warnings: Vec<String>,
}

/// Scans and decodes the topics the reader and `map` use, at the instances `opts` asks for
/// (each of which must be in the log).
fn decode_topics(bytes: &[u8], file: &str, map: &ColumnMap, opts: &ReadOptions) -> Result<Decoded, ReadError> {
    let s = scan(bytes, file)?;
    let (mut topics, catalog) = collect(&bytes[..s.end], file, &s.places, &wanted_topics(map), &opts.instances)?;
    check_instances(opts, &catalog).map_err(|m| ReadError::new(file, 0, 0, m))?;
    let mut warnings = Vec::new();
    for (name, tp) in topics.iter_mut() {
        drop_repeated_times(name, tp, &mut warnings);
    }
    Ok(Decoded {
        scan: s,
        topics,
        catalog,
        warnings,
    })
}

/// Where every channel is read from: the built-in and optional fields, the attitude quaternion
/// and the map's channels (which replace the built-in ones of their quantity).
struct Sources<'m, 't> {
    builtin: Builtin,
    optional: Vec<(Quantity, Resolved<'static>)>,
    attitude: Option<[Resolved<'static>; 4]>,
    mapped: Vec<Mapped<'m, 't>>,
}

/// The time base of the read: the topic that sets its step, the used topics' times (µs), the
/// window and the grid.
struct Timing<'t> {
    base_topic: &'t str,
    times: BTreeMap<&'t str, Vec<f64>>,
    window: Window,
    base: TimeBase,
}

impl<'t> Topics<'t> {
    /// The channels' sources; an error naming the log's topics when it has none this reader
    /// knows.
    fn sources<'m>(&self, map: &'m ColumnMap, warnings: &mut Vec<String>) -> Result<Sources<'m, 't>, ReadError> {
        let mut builtin = self.builtin_channels(warnings);
        let mut optional = self.optional_channels();
        let mut attitude = self.attitude();
        let mapped = self.map_channels(map)?;
        map_overrides(map, &mut builtin, &mut optional, &mut attitude);
        if builtin.channels.is_empty() && attitude.is_none() && mapped.is_empty() {
            return Err(self.err(format!(
                "no channel this reader knows is in the log (it reads vehicle_attitude, vehicle_angular_velocity or sensor_combined, vehicle_acceleration, airspeed_validated or airspeed, vehicle_air_data, airflow_aoa/airflow_slip, actuator_motors; a `format = ulog` map names others); topics in the log [instance: messages]: {}",
                topic_names(self.catalog)
            )));
        }
        Ok(Sources {
            builtin,
            optional,
            attitude,
            mapped,
        })
    }

    /// The window and the uniform time base of the used topics, each of them checked finite
    /// (and its gaps warned of) in the window.
    fn timing(
        &self,
        src: &Sources<'_, 't>,
        map: &ColumnMap,
        parameters: &BTreeMap<String, f64>,
        warnings: &mut Vec<String>,
    ) -> Result<Timing<'t>, ReadError> {
        let mut used = used_fields(&src.builtin.channels, src.attitude.as_ref(), &src.mapped);
        let base_topic = self.base_topic(map, src.builtin.rates_topic, &used)?;
        used.entry(base_topic).or_default();
        let times: BTreeMap<&str, Vec<f64>> = used
            .keys()
            .map(|name| (*name, self.topics[*name].time_us.iter().map(|&t| t as f64).collect()))
            .collect();
        let window = self.window(parameters, &src.builtin.channels, &times)?;
        let base = time_base(&times, base_topic, &window, self.opts).map_err(|m| self.err(m))?;
        for (name, fields) in &used {
            check_in_window(name, fields, &self.topics[*name], &times[*name], &base, warnings)
                .map_err(|m| self.err(m))?;
        }
        Ok(Timing {
            base_topic,
            times,
            window,
            base,
        })
    }
}

/// Every channel on the time base with the rate it was logged at: the built-in ones, the
/// attitude's Euler angles, the map's channels, the optional ones (where their topic covers the
/// window); a warning when the surfaces do not move.
#[allow(clippy::type_complexity)]
fn resample_channels(
    topics: &BTreeMap<String, Topic>,
    timing: &Timing,
    src: &Sources,
    warnings: &mut Vec<String>,
) -> Result<(BTreeMap<Quantity, Vec<f64>>, BTreeMap<Quantity, f64>), String> {
    let (times, base) = (&timing.times, &timing.base);
    let mut channels: BTreeMap<Quantity, Vec<f64>> = BTreeMap::new();
    let mut logged_rate_hz = BTreeMap::new();
    let resample = |r: &Resolved| interpolate(&times[r.topic], &topics[r.topic].values[r.field], &base.grid);
    for (q, r) in &src.builtin.channels {
        channels.insert(*q, resample(r));
        logged_rate_hz.insert(*q, base.rate_hz(&times[r.topic]));
    }
    if let Some(a) = &src.attitude {
        let topic = a[0].topic;
        let euler = attitude_euler(&topics[topic], &times[topic], a, &base.grid)?;
        for (q, v) in [Quantity::Roll, Quantity::Pitch, Quantity::Yaw].into_iter().zip(euler) {
            channels.insert(q, v);
            logged_rate_hz.insert(q, base.rate_hz(&times[topic]));
        }
    }
    for (q, e, rs) in &src.mapped {
        let cols: Vec<Vec<f64>> = rs.iter().map(resample).collect();
        channels.insert(
            *q,
            (0..base.grid.len())
                .map(|k| e.eval(cols.iter().map(|c| c[k])))
                .collect(),
        );
        if let Some(r) = rs.first() {
            logged_rate_hz.insert(*q, base.rate_hz(&times[r.topic]));
        }
    }
    for (q, v, rate_hz) in read_optional(topics, &src.optional, base, warnings) {
        channels.insert(q, v);
        logged_rate_hz.insert(q, rate_hz);
    }
    if let Some(w) = surface_warning(topics, &channels) {
        warnings.push(w);
    }
    Ok((channels, logged_rate_hz))
}

/// A map channel replaces the built-in of the same quantity; the map's channels are its own
/// sources, and what it says of a channel's origin holds.
fn map_overrides(
    map: &ColumnMap,
    builtin: &mut Builtin,
    optional: &mut Vec<(Quantity, Resolved<'static>)>,
    attitude: &mut Option<[Resolved<'static>; 4]>,
) {
    let map_has = |q: Quantity| map.channels.iter().any(|(c, _)| *c == q);
    builtin.channels.retain(|(q, _)| !map_has(*q));
    builtin.origin.retain(|q, _| !map_has(*q));
    builtin.origin.extend(map.origin.iter().map(|(q, o)| (*q, o.clone())));
    optional.retain(|(q, _)| !map_has(*q));
    if map_has(Quantity::Roll) || map_has(Quantity::Pitch) || map_has(Quantity::Yaw) {
        *attitude = None;
    }
}

/// Where channel `q` was read from, for an error message: the map's first source, the built-in
/// or optional field (`read`), else the attitude quaternion.
fn source_of<'a, 't: 'a>(
    q: Quantity,
    topics: &BTreeMap<String, Topic>,
    map: &ColumnMap,
    mapped: &[Mapped<'_, 't>],
    mut read: impl Iterator<Item = &'a (Quantity, Resolved<'t>)>,
) -> String {
    if let Some((_, _, rs)) = mapped.iter().find(|(c, _, _)| *c == q) {
        rs.first()
            .map_or(String::new(), |r| format!(" (from `{}`, map {})", r.topic, map.file))
    } else if let Some((_, r)) = read.find(|(c, _)| *c == q) {
        format!(" (from `{}.{}`)", r.topic, topics[r.topic].names[r.field])
    } else {
        " (from `vehicle_attitude.q`)".to_string()
    }
}

/// The topics to decode: the built-in ones, those the map reads, and its time base.
fn wanted_topics(map: &ColumnMap) -> BTreeSet<String> {
    let mut wanted: BTreeSet<String> = BUILTIN_TOPICS.iter().map(|s| s.to_string()).collect();
    for (_, e) in &map.channels {
        for t in &e.terms {
            if let Source::Field { topic, .. } = &t.source {
                wanted.insert(topic.clone());
            }
        }
    }
    if let Some(b) = &map.time_base {
        wanted.insert(b.clone());
    }
    wanted
}

/// Every topic instance asked for is in the log.
fn check_instances(opts: &ReadOptions, catalog: &BTreeMap<(String, u8), TopicInfo>) -> Result<(), String> {
    for (name, inst) in &opts.instances {
        if !catalog.contains_key(&(name.clone(), *inst)) {
            return Err(format!(
                "instance {inst} of `{name}` asked for, but the log has no such topic instance; topics in the log [instance: messages]: {}",
                topic_names(catalog)
            ));
        }
    }
    Ok(())
}

/// Time strictly increasing: a repeated (or earlier) time is dropped, the first kept, with a
/// warning.
fn drop_repeated_times(name: &str, tp: &mut Topic, warnings: &mut Vec<String>) {
    let n = tp.time_us.len();
    let mut keep = Vec::with_capacity(n);
    let mut last: Option<u64> = None;
    for (i, &t) in tp.time_us.iter().enumerate() {
        if last.is_none_or(|l| t > l) {
            keep.push(i);
            last = Some(t);
        }
    }
    if keep.len() < n {
        warnings.push(format!(
            "`{name}`: {} of {n} messages have a `{}` not later than the message before (a repeated sample); dropped, the first of each time kept",
            n - keep.len(),
            tp.time_field
        ));
        tp.time_us = keep.iter().map(|&i| tp.time_us[i]).collect();
        tp.places = keep.iter().map(|&i| tp.places[i]).collect();
        for v in tp.values.iter_mut() {
            *v = keep.iter().map(|&i| v[i]).collect();
        }
    }
}

/// The decoded topics, as the source of the channels.
struct Topics<'t> {
    topics: &'t BTreeMap<String, Topic>,
    catalog: &'t BTreeMap<(String, u8), TopicInfo>,
    file: &'t str,
    opts: &'t ReadOptions,
}

/// The built-in channels found in the log, the topic of the rates, and the channels' origins.
struct Builtin {
    channels: Vec<(Quantity, Resolved<'static>)>,
    rates_topic: Option<&'static str>,
    origin: BTreeMap<Quantity, Origin>,
}

/// A map channel: its quantity, expression and resolved sources.
type Mapped<'m, 't> = (Quantity, &'m Expr, Vec<Resolved<'t>>);

impl<'t> Topics<'t> {
    fn err(&self, m: String) -> ReadError {
        ReadError::new(self.file, 0, 0, m)
    }

    /// A field of a built-in topic that has messages.
    fn field(&self, topic: &'static str, name: &str) -> Option<Resolved<'static>> {
        let t = self.topics.get(topic).filter(|t| !t.time_us.is_empty())?;
        let i = t.names.iter().position(|n| n == name)?;
        Some(Resolved { topic, field: i })
    }

    /// The first of `cands` (topic, vector) whose components `[0]`, `[1]`, `[2]` are all logged.
    fn pick3(&self, cands: &[(&'static str, &str)]) -> Option<[Resolved<'static>; 3]> {
        for (topic, base) in cands {
            if let (Some(a), Some(b), Some(c)) = (
                self.field(topic, &format!("{base}[0]")),
                self.field(topic, &format!("{base}[1]")),
                self.field(topic, &format!("{base}[2]")),
            ) {
                return Some([a, b, c]);
            }
        }
        None
    }

    /// The channels this reader knows by their PX4 topics.
    fn builtin_channels(&self, warnings: &mut Vec<String>) -> Builtin {
        let mut builtin: Vec<(Quantity, Resolved<'static>)> = Vec::new();
        let rates = self.pick3(&[("vehicle_angular_velocity", "xyz"), ("sensor_combined", "gyro_rad")]);
        let rates_topic = rates.as_ref().map(|r| r[0].topic);
        if let Some([a, b, c]) = rates {
            builtin.extend([
                (Quantity::RollRate, a),
                (Quantity::PitchRate, b),
                (Quantity::YawRate, c),
            ]);
        }
        if let Some([a, b, c]) = self.pick3(&[("vehicle_angular_velocity", "xyz_derivative")]) {
            builtin.extend([
                (Quantity::RollAccel, a),
                (Quantity::PitchAccel, b),
                (Quantity::YawAccel, c),
            ]);
        }
        if let Some([a, b, c]) = self.pick3(&[
            ("vehicle_acceleration", "xyz"),
            ("sensor_combined", "accelerometer_m_s2"),
        ]) {
            builtin.extend([(Quantity::AccelX, a), (Quantity::AccelY, b), (Quantity::AccelZ, c)]);
        }
        // Where the channels come from (`LogMeta::origin`). `airflow_aoa` and `airflow_slip` are
        // published by PX4's vane drivers (an AS5600-type angle sensor on a vane): sensors. The
        // validated airspeed may be an estimator's (see `airspeed_validated_origin`).
        let mut origin = BTreeMap::new();
        if let Some(r) = self.airspeed(warnings) {
            if r.topic == "airspeed_validated" {
                if let Some(by) = self.topics.get(r.topic).and_then(airspeed_validated_origin) {
                    origin.insert(Quantity::Airspeed, Origin::Estimated { by });
                }
            }
            builtin.push((Quantity::Airspeed, r));
        }
        for (q, topic, name) in [
            (Quantity::AirDensity, "vehicle_air_data", "rho"),
            (Quantity::Altitude, "vehicle_air_data", "baro_alt_meter"),
            (Quantity::Alpha, "airflow_aoa", "aoa_rad"),
            (Quantity::Beta, "airflow_slip", "slip_rad"),
        ] {
            if let Some(r) = self.field(topic, name) {
                builtin.push((q, r));
            }
        }
        if let Some(r) = self
            .field("actuator_motors", "control[0]")
            .or_else(|| self.field("actuator_controls_0", "control[3]"))
        {
            builtin.push((Quantity::Throttle, r));
        }
        Builtin {
            channels: builtin,
            rates_topic,
            origin,
        }
    }

    /// Of the two airspeed topics, the one with more messages (PX4 logs `airspeed_validated` at
    /// 1 Hz by default but the raw `airspeed` sometimes faster); ties go to the validated one.
    fn airspeed(&self, warnings: &mut Vec<String>) -> Option<Resolved<'static>> {
        let count = |t: &str| self.topics.get(t).map_or(0, |x| x.time_us.len());
        match (
            self.field("airspeed_validated", "true_airspeed_m_s"),
            self.field("airspeed", "true_airspeed_m_s"),
        ) {
            (Some(_), Some(raw)) if count("airspeed") > count("airspeed_validated") => {
                warnings.push(format!(
                    "true airspeed from `airspeed` ({} messages) rather than `airspeed_validated` ({}): the raw sensor topic is logged faster",
                    count("airspeed"),
                    count("airspeed_validated")
                ));
                Some(raw)
            }
            (Some(v), _) => Some(v),
            (None, raw) => raw,
        }
    }

    /// Optional channels (the ground velocity for the α-free mode, the autopilot's wind for
    /// comparison): they do not cut the window; one that does not cover it is left out, with a
    /// warning.
    fn optional_channels(&self) -> Vec<(Quantity, Resolved<'static>)> {
        let mut optional = Vec::new();
        let velocity = [
            ("vehicle_local_position", ["vx", "vy", "vz"]),
            ("vehicle_gps_position", ["vel_n_m_s", "vel_e_m_s", "vel_d_m_s"]),
            ("sensor_gps", ["vel_n_m_s", "vel_e_m_s", "vel_d_m_s"]),
        ]
        .into_iter()
        .find_map(|(topic, names)| match names.map(|n| self.field(topic, n)) {
            [Some(a), Some(b), Some(c)] => Some([a, b, c]),
            _ => None,
        });
        if let Some([a, b, c]) = velocity {
            optional.extend([
                (Quantity::VelocityNorth, a),
                (Quantity::VelocityEast, b),
                (Quantity::VelocityDown, c),
            ]);
        }
        let wind = ["wind", "wind_estimate"].into_iter().find_map(|topic| {
            match (
                self.field(topic, "windspeed_north"),
                self.field(topic, "windspeed_east"),
            ) {
                (Some(a), Some(b)) => Some([a, b]),
                _ => None,
            }
        });
        if let Some([a, b]) = wind {
            optional.extend([(Quantity::WindNorth, a), (Quantity::WindEast, b)]);
        }
        optional
    }

    /// The attitude quaternion's four components.
    fn attitude(&self) -> Option<[Resolved<'static>; 4]> {
        match ["q[0]", "q[1]", "q[2]", "q[3]"].map(|n| self.field("vehicle_attitude", n)) {
            [Some(a), Some(b), Some(c), Some(d)] => Some([a, b, c, d]),
            _ => None,
        }
    }

    /// The map's channels, each `topic.field` source resolved.
    fn map_channels<'m>(&self, map: &'m ColumnMap) -> Result<Vec<Mapped<'m, 't>>, ReadError> {
        let mut mapped = Vec::new();
        for (q, e) in &map.channels {
            let mut rs = Vec::new();
            for t in &e.terms {
                let Source::Field { topic, field: name } = &t.source else {
                    return Err(ReadError::new(
                        &map.file,
                        e.line,
                        0,
                        "a ULog map names `topic.field` sources",
                    ));
                };
                rs.push(self.resolve(map, *q, e.line, topic, name)?);
            }
            mapped.push((*q, e, rs));
        }
        Ok(mapped)
    }

    /// The source `topic.name` of the map's channel `q` (on `line`), in the chosen instance.
    fn resolve(
        &self,
        map: &ColumnMap,
        q: Quantity,
        line: usize,
        topic: &str,
        name: &str,
    ) -> Result<Resolved<'t>, ReadError> {
        let chosen = self.opts.instances.get(topic).copied().unwrap_or(0);
        let Some((key, tp)) = self.topics.get_key_value(topic).filter(|(_, t)| !t.time_us.is_empty()) else {
            let others: Vec<String> = self
                .catalog
                .keys()
                .filter(|(n, _)| n == topic)
                .map(|(_, i)| i.to_string())
                .collect();
            let why = if others.is_empty() {
                format!("the log has no topic `{topic}`")
            } else {
                format!(
                    "the log has instance(s) {} of `{topic}` but not {chosen} (choose one with --instance {topic}=N)",
                    others.join(", ")
                )
            };
            return Err(self.err(format!(
                "ULog topic `{topic}` (instance {chosen}) read by `channel.{q}` ({}:{line}) is missing: {why}; topics in the log [instance: messages]: {}",
                map.file,
                topic_names(self.catalog)
            )));
        };
        let Some(i) = tp.names.iter().position(|n| n == name) else {
            return Err(self.err(format!(
                "ULog topic `{topic}` has no field `{name}`, read by `channel.{q}` ({}:{line}); its fields: {}",
                map.file,
                tp.names.join(", ")
            )));
        };
        Ok(Resolved {
            topic: key.as_str(),
            field: i,
        })
    }

    /// The topic whose median interval sets the step: the map's time base, else the rates'
    /// topic when used, else the used topic with the most messages.
    fn base_topic(
        &self,
        map: &ColumnMap,
        rates_topic: Option<&'static str>,
        used: &BTreeMap<&'t str, BTreeSet<usize>>,
    ) -> Result<&'t str, ReadError> {
        Ok(match &map.time_base {
            Some(b) => match self
                .topics
                .get_key_value(b.as_str())
                .filter(|(_, t)| !t.time_us.is_empty())
            {
                Some((k, _)) => k.as_str(),
                None => {
                    return Err(self.err(format!(
                        "time_base topic `{b}` is not in the log; topics in the log [instance: messages]: {}",
                        topic_names(self.catalog)
                    )))
                }
            },
            None => match rates_topic.filter(|t| used.contains_key(t)) {
                Some(t) => t,
                None => used
                    .keys()
                    .copied()
                    .max_by_key(|t| self.topics[*t].time_us.len())
                    .unwrap_or_default(),
            },
        })
    }

    /// The window read, µs: the one asked for, else the longest stretch in the air (by the land
    /// detector, else the airspeed), else the whole log. `times`: the used topics' times.
    fn window(
        &self,
        parameters: &BTreeMap<String, f64>,
        builtin: &[(Quantity, Resolved)],
        times: &BTreeMap<&str, Vec<f64>>,
    ) -> Result<Window, ReadError> {
        let first_us = times
            .values()
            .filter_map(|t| t.first())
            .copied()
            .fold(f64::INFINITY, f64::min);
        let last_us = times
            .values()
            .filter_map(|t| t.last())
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        if let Some((w0, w1, text)) = self.opts.chosen_window(first_us, last_us).map_err(|m| self.err(m))? {
            return Ok(Window::chosen(w0, w1, text));
        }
        let airspeed = builtin.iter().find(|(q, _)| *q == Quantity::Airspeed).map(|(_, r)| r);
        let (run, how) = self.in_the_air(parameters, airspeed, last_us);
        Ok(match run {
            Some((a, b)) => Window {
                w0: a,
                w1: b,
                text: Some(format!(
                    "in the air {:.3}…{:.3} s: the longest stretch with {how}",
                    a * 1e-6,
                    b * 1e-6
                )),
                airborne: Some(true),
            },
            None if how.is_empty() => Window::whole_log(
                "no land detector and no airspeed: the whole log is read, in the air or not".into(),
                None,
            ),
            None => Window::whole_log(
                format!("never in the air by {how}: the whole log is read, on the ground"),
                Some(false),
            ),
        })
    }

    /// The longest stretch in the air, µs, and by what (empty when the log has neither a land
    /// detector nor an airspeed).
    fn in_the_air(
        &self,
        parameters: &BTreeMap<String, f64>,
        airspeed: Option<&Resolved>,
        last_us: f64,
    ) -> (Option<(f64, f64)>, String) {
        if let Some(r) = &self.field("vehicle_land_detected", "landed") {
            let tp = &self.topics[r.topic];
            let t: Vec<f64> = tp.time_us.iter().map(|&t| t as f64).collect();
            let holds: Vec<bool> = tp.values[r.field].iter().map(|v| *v == 0.0).collect();
            return (
                longest_run(&t, &holds, last_us),
                "`vehicle_land_detected.landed` false".to_string(),
            );
        }
        let Some(r) = airspeed else {
            return (None, String::new());
        };
        let (thr, from) = match (parameters.get("FW_AIRSPD_STALL"), parameters.get("FW_AIRSPD_MIN")) {
            (Some(v), _) if *v > 0.0 => (0.8 * v, "0.8 × FW_AIRSPD_STALL"),
            (_, Some(v)) if *v > 0.0 => (0.8 * v, "0.8 × FW_AIRSPD_MIN"),
            _ => (8.0, "8 m/s, no FW_AIRSPD_STALL or FW_AIRSPD_MIN logged"),
        };
        let tp = &self.topics[r.topic];
        let t: Vec<f64> = tp.time_us.iter().map(|&t| t as f64).collect();
        // A missing (NaN) airspeed keeps the state before it: the gate does not cut around it, so
        // the read refuses it inside the window rather than hiding it.
        let holds = hold_over_nan(&tp.values[r.field], thr);
        (
            longest_run(&t, &holds, last_us),
            format!("true airspeed above {thr:.1} m/s ({from})"),
        )
    }
}

/// The topics used and their fields.
fn used_fields<'t>(
    builtin: &[(Quantity, Resolved<'t>)],
    attitude: Option<&[Resolved<'t>; 4]>,
    mapped: &[Mapped<'_, 't>],
) -> BTreeMap<&'t str, BTreeSet<usize>> {
    let mut used: BTreeMap<&str, BTreeSet<usize>> = BTreeMap::new();
    let resolved = builtin
        .iter()
        .map(|(_, r)| r)
        .chain(attitude.into_iter().flatten())
        .chain(mapped.iter().flat_map(|(_, _, rs)| rs));
    for r in resolved {
        used.entry(r.topic).or_default().insert(r.field);
    }
    used
}

/// The uniform time base in the window: the step is the base topic's median interval in it, or
/// the rate asked for. `times`: the used topics' times.
fn time_base(
    times: &BTreeMap<&str, Vec<f64>>,
    base_topic: &str,
    window: &Window,
    opts: &ReadOptions,
) -> Result<TimeBase, String> {
    let lo = times.values().map(|t| t[0]).fold(window.w0, f64::max).ceil();
    let hi = times.values().map(|t| t[t.len() - 1]).fold(window.w1, f64::min).floor();
    let base_t: Vec<f64> = times[base_topic]
        .iter()
        .copied()
        .filter(|t| *t >= lo && *t <= hi)
        .collect();
    let h_us = match opts.rate_hz {
        Some(r) => (1e6 / r).round().max(1.0),
        None => median(&base_t.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>()).round(),
    };
    // (NaN-safe: a NaN bound or step fails the positive test.)
    let usable = hi > lo && base_t.len() >= 2 && h_us >= 1.0;
    if !usable {
        return Err(format!(
            "the used topics ({}) overlap in the window over fewer than 2 samples of `{base_topic}`",
            times.keys().copied().collect::<Vec<_>>().join(", ")
        ));
    }
    let grid = time_grid(lo, hi, h_us, base_t.len(), base_topic)?;
    Ok(TimeBase { lo, hi, h_us, grid })
}

/// A used topic's fields finite over the samples the interpolation touches (an error names the
/// first missing run); a warning for its gaps in the window.
fn check_in_window(
    name: &str,
    fields: &BTreeSet<usize>,
    tp: &Topic,
    t: &[f64],
    base: &TimeBase,
    warnings: &mut Vec<String>,
) -> Result<(), String> {
    let i0 = t.partition_point(|&x| x < base.lo).saturating_sub(1);
    let i1 = (t.partition_point(|&x| x <= base.hi) + 1).min(t.len());
    for &f in fields {
        if let Some(i) = tp.values[f][i0..i1].iter().position(|v| !v.is_finite()).map(|i| i + i0) {
            let run = tp.values[f][i..].iter().take_while(|v| !v.is_finite()).count();
            let p = tp.places[i];
            return Err(format!(
                "ULog message #{} at byte {}: `{name}.{}` is {} (a run of {run} message{}) inside the window read; missing samples are refused, not interpolated (cut them off with --from/--to)",
                p.index,
                p.offset,
                tp.names[f],
                tp.values[f][i],
                if run == 1 { "" } else { "s" }
            ));
        }
    }
    if let Some(w) = gap_warning(name, t, base, " in the window", "dropped messages; ") {
        warnings.push(w);
    }
    Ok(())
}

/// Roll, pitch and yaw on the `grid` from the attitude quaternion `a` of topic `tp` (times `t`):
/// interpolated component-wise on the shorter arc, normalised, converted.
fn attitude_euler(tp: &Topic, t: &[f64], a: &[Resolved; 4], grid: &[f64]) -> Result<[Vec<f64>; 3], String> {
    let comps: Vec<&Vec<f64>> = a.iter().map(|r| &tp.values[r.field]).collect();
    let mut euler = [Vec::new(), Vec::new(), Vec::new()];
    let mut j = 0;
    for (k, &tq) in grid.iter().enumerate() {
        while j + 1 < t.len() && t[j + 1] < tq {
            j += 1;
        }
        let at = |i: usize| [comps[0][i], comps[1][i], comps[2][i], comps[3][i]];
        let q0 = at(j);
        let q = if j + 1 < t.len() && tq > t[j] {
            let mut q1 = at(j + 1);
            if q0.iter().zip(&q1).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
                q1 = q1.map(|v| -v);
            }
            let w = (tq - t[j]) / (t[j + 1] - t[j]);
            [0, 1, 2, 3].map(|i| q0[i] + w * (q1[i] - q0[i]))
        } else {
            q0
        };
        let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm < 1e-6 {
            let p = tp.places[j];
            return Err(format!(
                "ULog message #{} at byte {}: `vehicle_attitude.q` has zero norm (output sample {k})",
                p.index, p.offset
            ));
        }
        let e = quaternion_to_euler(q.map(|v| v / norm));
        for i in 0..3 {
            euler[i].push(e[i]);
        }
    }
    Ok(euler)
}

/// The optional channels on the time base, each with its logged rate: read where their topic
/// covers the window (to within two of its own intervals; held at its ends) and is finite there;
/// else left out, with a warning.
fn read_optional(
    topics: &BTreeMap<String, Topic>,
    optional: &[(Quantity, Resolved)],
    base: &TimeBase,
    warnings: &mut Vec<String>,
) -> Vec<(Quantity, Vec<f64>, f64)> {
    let mut by_topic: BTreeMap<&str, Vec<&(Quantity, Resolved)>> = BTreeMap::new();
    for o in optional {
        by_topic.entry(o.1.topic).or_default().push(o);
    }
    let mut out = Vec::new();
    for (name, fields) in by_topic {
        let tp = &topics[name];
        let t: Vec<f64> = tp.time_us.iter().map(|&x| x as f64).collect();
        if let Some(w) = optional_unusable(name, tp, &t, &fields, base) {
            warnings.push(w);
            continue;
        }
        if let Some(w) = gap_warning(name, &t, base, " in the window", "dropped messages; ") {
            warnings.push(w);
        }
        for (q, r) in fields {
            out.push((*q, interpolate(&t, &tp.values[r.field], &base.grid), base.rate_hz(&t)));
        }
    }
    out
}

/// Why an optional topic is not read (it does not cover the window, or is not finite in it), or
/// `None` when it is.
fn optional_unusable(
    name: &str,
    tp: &Topic,
    t: &[f64],
    fields: &[&(Quantity, Resolved)],
    base: &TimeBase,
) -> Option<String> {
    let (lo, hi) = (base.lo, base.hi);
    let dt = median(&t.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>());
    let what: Vec<&str> = fields.iter().map(|(q, _)| q.name()).collect();
    if t.len() < 2 || t[0] > lo + 2.0 * dt || t[t.len() - 1] < hi - 2.0 * dt {
        return Some(format!(
            "`{name}` ({}) covers {:.3}…{:.3} s, not the window {:.3}…{:.3} s: not read (choose a window inside it with --from/--to to read it)",
            what.join(", "),
            t.first().copied().unwrap_or(0.0) * 1e-6,
            t.last().copied().unwrap_or(0.0) * 1e-6,
            lo * 1e-6,
            hi * 1e-6
        ));
    }
    let i0 = t.partition_point(|&x| x < lo).saturating_sub(1);
    let i1 = (t.partition_point(|&x| x <= hi) + 1).min(t.len());
    let (r, i) = fields.iter().find_map(|(_, r)| {
        tp.values[r.field][i0..i1]
            .iter()
            .position(|v| !v.is_finite())
            .map(|i| (r, i + i0))
    })?;
    let p = tp.places[i];
    Some(format!(
        "ULog message #{} at byte {}: `{name}.{}` is {} inside the window: `{name}` ({}) not read",
        p.index,
        p.offset,
        tp.names[r.field],
        tp.values[r.field][i],
        what.join(", ")
    ))
}

/// A warning when no surface is mapped but the log has actuator topics (whose throw in radians
/// the airframe sets).
fn surface_warning(topics: &BTreeMap<String, Topic>, channels: &BTreeMap<Quantity, Vec<f64>>) -> Option<String> {
    let surfaces = [Quantity::Elevator, Quantity::Aileron, Quantity::Rudder];
    if surfaces.iter().any(|q| channels.contains_key(q)) {
        return None;
    }
    let present: Vec<&str> = ["actuator_servos", "actuator_controls_0", "actuator_outputs"]
        .into_iter()
        .filter(|t| topics.get(*t).is_some_and(|x| !x.time_us.is_empty()))
        .collect();
    (!present.is_empty()).then(|| {
        format!(
            "no surface deflection mapped: the log has {} (normalised commands or PWM), but their throw in radians is the airframe's; map them in a `format = ulog` map, e.g. `channel.elevator = K*actuator_controls_0.control[1] rad`",
            present.iter().map(|t| format!("`{t}`")).collect::<Vec<_>>().join(", ")
        )
    })
}

/// How the channels were resampled, in words.
fn resampling(base: &TimeBase, base_topic: &str, opts: &ReadOptions) -> String {
    let base_rate = 1e6 / base.h_us;
    let h_us = base.h_us;
    format!(
        "uniform {base_rate:.2} Hz ({h_us} µs step: {}), every field linearly interpolated in time (the attitude quaternion normalised after interpolation), no anti-alias filter; {} samples",
        if opts.rate_hz.is_some() {
            "the rate asked for".to_string()
        } else {
            format!("the median interval of `{base_topic}`")
        },
        base.grid.len()
    )
}

/// The warning for a series' gaps longer than [`GAP_FACTOR`] × its median interval in the
/// window, if any; `scope` and `cause` as the reader words them (` in the window`, `dropped
/// messages; `).
pub(crate) fn gap_warning(name: &str, t: &[f64], base: &TimeBase, scope: &str, cause: &str) -> Option<String> {
    let (count, longest, at) = gaps(t, base.lo, base.hi)?;
    Some(format!(
        "`{name}`: {count} gap{} longer than {GAP_FACTOR} × its median interval{scope}, the longest {:.3} s from t = {:.3} s ({cause}interpolated across)",
        if count == 1 { "" } else { "s" },
        longest * 1e-6,
        at * 1e-6
    ))
}

/// The window read: from `w0` to `w1` (µs), why, and whether the vehicle flew in it.
pub(crate) struct Window {
    pub(crate) w0: f64,
    pub(crate) w1: f64,
    pub(crate) text: Option<String>,
    pub(crate) airborne: Option<bool>,
}

impl Window {
    /// The window the user chose (`--from/--to`, `--whole-log`): whether the vehicle flew in it
    /// is not judged.
    pub(crate) fn chosen(w0: f64, w1: f64, text: Option<String>) -> Self {
        Self {
            w0,
            w1,
            text,
            airborne: None,
        }
    }

    /// The whole log, for the reason `text`; `airborne`: whether the vehicle flew (`None`: no
    /// way to tell).
    pub(crate) fn whole_log(text: String, airborne: Option<bool>) -> Self {
        Self {
            w0: f64::NEG_INFINITY,
            w1: f64::INFINITY,
            text: Some(text),
            airborne,
        }
    }
}

/// The uniform time base: the window's bounds `lo`…`hi` (µs), the step and the grid.
pub(crate) struct TimeBase {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) h_us: f64,
    pub(crate) grid: Vec<f64>,
}

impl TimeBase {
    /// The rate, Hz, at which a series with times `t` (µs) is logged in the window (a series
    /// with one sample in a 1-s window: 1 Hz).
    pub(crate) fn rate_hz(&self, t: &[f64]) -> f64 {
        let k = t.iter().filter(|x| **x >= self.lo && **x <= self.hi).count();
        k as f64 / ((self.hi - self.lo + self.h_us) * 1e-6)
    }
}

/// `(t, x)` interpolated linearly at the times of `grid` (held at its ends).
pub(crate) fn interpolate(t: &[f64], x: &[f64], grid: &[f64]) -> Vec<f64> {
    let mut j = 0;
    grid.iter().map(|&tq| interp(t, x, tq, &mut j)).collect()
}
