//! PX4 ULog (`.ulg`) → [`MeasuredFlight`].
//!
//! **Parser.** The `px4-ulog` crate (0.6, kept by the PX4 organisation, `byteorder` its only
//! dependency; chosen over `yule_log`, which pulls `regex`, `env_logger` and `lazy_static` and
//! panics on an over-long array size in a format, and `ulog-rs` 0.0.x, "in development", with a
//! CLI's dependencies in the library). `px4-ulog` checks every data message against its format's
//! size and classifies a cut file, but indexes the payload of a Parameter or AddLogged message
//! before checking its length; so this module first walks the message framing itself
//! ([`scan`], every length checked) and refuses a truncated or malformed file with the message
//! index and byte offset before the crate sees it. Only the primary data section is read (the
//! appended crash-recovery sections a FlagBits message may point to are ignored).
//!
//! **Topics** (instance 0 of each; time from `timestamp_sample` where the topic has it, else
//! `timestamp`, µs → s):
//!
//! | quantity | topic.field | |
//! |---|---|---|
//! | roll, pitch, yaw | `vehicle_attitude.q[0..3]` (Hamilton, body FRD → NED), Euler 3-2-1 | required |
//! | roll/pitch/yaw rate | `vehicle_angular_velocity.xyz[0..2]`, else `sensor_combined.gyro_rad[0..2]` | required |
//! | roll/pitch/yaw accel | `vehicle_angular_velocity.xyz_derivative[0..2]` | if present |
//! | accel x/y/z (specific force) | `vehicle_acceleration.xyz[0..2]`, else `sensor_combined.accelerometer_m_s2[0..2]` | required |
//! | airspeed (true) | `airspeed_validated.true_airspeed_m_s`, else `airspeed.true_airspeed_m_s` | required |
//! | air density, altitude | `vehicle_air_data.rho`, `vehicle_air_data.baro_alt_meter` | if present |
//! | alpha, beta | `airflow_aoa.aoa_rad`, `airflow_slip.slip_rad` | if present |
//! | throttle | `actuator_motors.control[0]` | if present |
//!
//! Surfaces need the airframe's servo mapping (which output, how many radians per unit), so they
//! come from a ULog column map (`format = ulog`, [`super::colmap`]), e.g.
//! `channel.elevator = 0.35*actuator_servos.control[1] rad`; a map channel replaces the built-in
//! one of the same quantity.
//!
//! **Resampling.** The output time base is the timestamps of one topic: `time_base` of the map, or
//! by default the rate topic (`vehicle_angular_velocity`, else `sensor_combined`), cut to the
//! interval every used topic covers (no extrapolation). Every other field is interpolated
//! linearly in time onto it; the attitude quaternion component-wise between its two
//! neighbouring samples (the second one's sign flipped if they point apart), then normalised (nlerp), then turned into Euler angles. Every used field
//! must be finite (a NaN is refused with its message, not interpolated over) and every used
//! topic's time strictly increasing.

use super::colmap::{ColumnMap, Expr, Format, Source};
use super::measured::{MeasuredFlight, Quantity};
use super::ReadError;
use px4_ulog::stream_parser::model::FlattenedFieldType;
use px4_ulog::stream_parser::{DataMessage, LogParser};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

/// The ULog file magic (`ULog` 0x01 0x12 0x35), followed by a version byte and a u64 timestamp.
pub const MAGIC: [u8; 7] = [b'U', b'L', b'o', b'g', 0x01, 0x12, 0x35];

/// One data message's place in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    /// Message ordinal in the file (0-based, header not counted).
    index: usize,
    /// Byte offset of the message header.
    offset: usize,
}

/// Walks the message framing of `bytes` (every length checked): the data messages' places and the
/// end of the primary section. Refuses a short or bad header, a message cut by the end of the
/// file, and Parameter/AddLogged messages too short for their own headers.
fn scan(bytes: &[u8], file: &str) -> Result<(Vec<Place>, usize), ReadError> {
    let e = |m: String| ReadError::new(file, 0, 0, m);
    if bytes.len() < 16 {
        return Err(e(format!(
            "not a ULog: {} bytes, the header alone has 16 (truncated ULog)",
            bytes.len()
        )));
    }
    if bytes[..7] != MAGIC {
        return Err(e("not a ULog: the file does not start with the ULog magic bytes".into()));
    }
    let mut end = bytes.len();
    let mut pos = 16;
    let mut index = 0usize;
    let mut data = Vec::new();
    while pos < end {
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
                end.saturating_sub(pos + 3)
            )));
        };
        let bad = |m: &str| {
            e(format!(
                "malformed ULog: message #{index} (type '{}') at byte {pos}: {m}",
                kind as char
            ))
        };
        match kind {
            b'B' => {
                if index != 0 {
                    return Err(bad("FlagBits must be the first message"));
                }
                if size < 40 {
                    return Err(bad("FlagBits shorter than 40 bytes"));
                }
                // The first appended-data offset ends the primary section.
                let first = u64::from_le_bytes(payload[16..24].try_into().unwrap_or([0; 8])) as usize;
                if first != 0 && first < end {
                    end = first;
                }
            }
            b'A' if size < 3 => return Err(bad("AddLogged shorter than its 3-byte header")),
            b'P' | b'Q' => {
                let k = if kind == b'P' { 0 } else { 1 };
                match payload.get(k) {
                    Some(&len) if k + 1 + len as usize <= size => {}
                    _ => return Err(bad("parameter key longer than the message")),
                }
            }
            b'D' => data.push(Place { index, offset: pos }),
            _ => {}
        }
        pos += 3 + size;
        index += 1;
    }
    if pos > end {
        return Err(e(format!(
            "malformed ULog: a message runs past the start of the appended data at byte {end}"
        )));
    }
    Ok((data, end))
}

/// The values of one topic (instance 0), every numeric field.
#[derive(Debug, Default)]
struct Topic {
    /// Field names, flattened (`q[0]`).
    names: Vec<String>,
    /// Index of the time field in `names`.
    time_field: usize,
    /// Per field, its samples.
    values: Vec<Vec<f64>>,
    /// Time, µs.
    time_us: Vec<u64>,
    /// Each sample's message.
    places: Vec<Place>,
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
const BUILTIN_TOPICS: [&str; 11] = [
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
];

/// How to decode one wanted message id: topic, time-field offset, every field's type and offset.
type Decoder = (String, usize, Vec<(FlattenedFieldType, usize)>);

/// Reads the instance-0 data of `wanted` topics.
fn collect(
    bytes: &[u8],
    file: &str,
    places: &[Place],
    wanted: &BTreeSet<String>,
) -> Result<BTreeMap<String, Topic>, ReadError> {
    let mut topics: BTreeMap<String, Topic> = BTreeMap::new();
    // msg_id → topic name (None: not wanted or not instance 0), with the time field's offset.
    let mut ids: HashMap<u16, Option<Decoder>> = HashMap::new();
    let mut k = 0usize;
    let mut failure: Option<ReadError> = None;
    {
        let mut callback = |m: &DataMessage| {
            let place = places.get(k).copied().unwrap_or(Place { index: 0, offset: 0 });
            k += 1;
            if failure.is_some() {
                return;
            }
            let entry = ids.entry(m.msg_id).or_insert_with(|| {
                let name = m.flattened_format.message_name();
                if m.multi_id.value() != 0 || !wanted.contains(name) {
                    return None;
                }
                let fields: Vec<_> = m.flattened_format.fields.iter().collect();
                let time = fields
                    .iter()
                    .position(|f| {
                        f.flattened_field_name == "timestamp_sample" && f.field_type == FlattenedFieldType::UInt64
                    })
                    .or_else(|| {
                        fields.iter().position(|f| {
                            f.flattened_field_name == "timestamp" && f.field_type == FlattenedFieldType::UInt64
                        })
                    })?;
                let topic = topics.entry(name.to_string()).or_default();
                topic.names = fields.iter().map(|f| f.flattened_field_name.clone()).collect();
                topic.values = vec![Vec::new(); fields.len()];
                topic.time_field = time;
                let layout = fields
                    .iter()
                    .map(|f| (f.field_type.clone(), f.offset as usize))
                    .collect();
                Some((name.to_string(), fields[time].offset as usize, layout))
            });
            let Some((name, time_offset, layout)) = entry else {
                return;
            };
            let Some(topic) = topics.get_mut(name.as_str()) else {
                return;
            };
            let Some(t) = m.data.get(*time_offset..).and_then(decode_u64) else {
                failure = Some(ReadError::new(
                    file,
                    0,
                    0,
                    format!(
                        "ULog message #{} at byte {}: `{name}` too short for its timestamp",
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
        };
        let mut parser = LogParser::default();
        parser.set_data_message_callback(&mut callback);
        parser.consume_bytes(bytes).map_err(|e| {
            let at = places.get(k).map_or(String::new(), |p| {
                format!(" near ULog message #{} at byte {}", p.index, p.offset)
            });
            ReadError::new(file, 0, 0, format!("malformed ULog{at}: {e}"))
        })?;
    }
    if let Some(f) = failure {
        return Err(f);
    }
    Ok(topics)
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

/// Reads a ULog through `map` (`format = ulog`; [`ColumnMap::ulog_default`] for the built-in
/// topics only).
pub fn read_ulog(path: &Path, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| ReadError::new(&file, 0, 0, e.to_string()))?;
    parse_ulog(&bytes, &file, map)
}

/// [`read_ulog`] on bytes already read (`file` names them in errors).
pub fn parse_ulog(bytes: &[u8], file: &str, map: &ColumnMap) -> Result<MeasuredFlight, ReadError> {
    if map.format != Format::Ulog {
        return Err(ReadError::new(&map.file, 0, 0, "not a ULog map (`format = ulog`)"));
    }
    let err = |m: String| ReadError::new(file, 0, 0, m);
    let (places, end) = scan(bytes, file)?;
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
    let topics = collect(&bytes[..end], file, &places, &wanted)?;
    let has = |t: &str| topics.get(t).is_some_and(|x| !x.time_us.is_empty());
    let field = |topic: &'static str, name: &str| -> Option<Resolved<'static>> {
        let t = topics.get(topic)?;
        let i = t.names.iter().position(|n| n == name)?;
        Some(Resolved { topic, field: i })
    };
    // Built-in channel sources: (quantity, candidate (topic, field) list, required).
    let missing = |what: &str, options: &str| {
        err(format!(
            "required ULog topic missing: {what} (needs {options}); topics in the log: {}",
            topics.keys().cloned().collect::<Vec<_>>().join(", ")
        ))
    };
    let mut builtin: Vec<(Quantity, Resolved)> = Vec::new();
    let pick3 = |cands: &[(&'static str, &str)]| -> Option<[Resolved<'static>; 3]> {
        for (topic, base) in cands {
            if let (Some(a), Some(b), Some(c)) = (
                field(topic, &format!("{base}[0]")),
                field(topic, &format!("{base}[1]")),
                field(topic, &format!("{base}[2]")),
            ) {
                return Some([a, b, c]);
            }
        }
        None
    };
    let map_has = |q: Quantity| map.channels.iter().any(|(c, _)| *c == q);
    let rates = pick3(&[("vehicle_angular_velocity", "xyz"), ("sensor_combined", "gyro_rad")]);
    let rates_topic = rates.as_ref().map(|r| r[0].topic);
    match rates {
        Some([a, b, c]) => builtin.extend([
            (Quantity::RollRate, a),
            (Quantity::PitchRate, b),
            (Quantity::YawRate, c),
        ]),
        None if map_has(Quantity::PitchRate) => {}
        None => {
            return Err(missing(
                "angular rates",
                "vehicle_angular_velocity.xyz[3] or sensor_combined.gyro_rad[3]",
            ))
        }
    }
    if let Some([a, b, c]) = pick3(&[("vehicle_angular_velocity", "xyz_derivative")]) {
        builtin.extend([
            (Quantity::RollAccel, a),
            (Quantity::PitchAccel, b),
            (Quantity::YawAccel, c),
        ]);
    }
    match pick3(&[
        ("vehicle_acceleration", "xyz"),
        ("sensor_combined", "accelerometer_m_s2"),
    ]) {
        Some([a, b, c]) => builtin.extend([(Quantity::AccelX, a), (Quantity::AccelY, b), (Quantity::AccelZ, c)]),
        None if map_has(Quantity::AccelZ) => {}
        None => {
            return Err(missing(
                "accelerations",
                "vehicle_acceleration.xyz[3] or sensor_combined.accelerometer_m_s2[3]",
            ))
        }
    }
    match field("airspeed_validated", "true_airspeed_m_s").or_else(|| field("airspeed", "true_airspeed_m_s")) {
        Some(r) => builtin.push((Quantity::Airspeed, r)),
        None if map_has(Quantity::Airspeed) => {}
        None => {
            return Err(missing(
                "true airspeed",
                "airspeed_validated.true_airspeed_m_s or airspeed.true_airspeed_m_s",
            ))
        }
    }
    for (q, topic, name) in [
        (Quantity::AirDensity, "vehicle_air_data", "rho"),
        (Quantity::Altitude, "vehicle_air_data", "baro_alt_meter"),
        (Quantity::Alpha, "airflow_aoa", "aoa_rad"),
        (Quantity::Beta, "airflow_slip", "slip_rad"),
        (Quantity::Throttle, "actuator_motors", "control[0]"),
    ] {
        if let Some(r) = field(topic, name) {
            builtin.push((q, r));
        }
    }
    let attitude = ["q[0]", "q[1]", "q[2]", "q[3]"].map(|n| field("vehicle_attitude", n));
    let attitude = match attitude {
        [Some(a), Some(b), Some(c), Some(d)] => Some([a, b, c, d]),
        _ if map_has(Quantity::Pitch) => None,
        _ => return Err(missing("attitude", "vehicle_attitude.q[4]")),
    };
    // Map channels: resolve `topic.field`.
    let mut mapped: Vec<(Quantity, &Expr, Vec<Resolved>)> = Vec::new();
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
            let Some(tp) = topics.get(topic.as_str()).filter(|t| !t.time_us.is_empty()) else {
                return Err(err(format!(
                    "required ULog topic missing: `{topic}` (instance 0), read by `channel.{q}` ({}:{})",
                    map.file, e.line
                )));
            };
            let Some(i) = tp.names.iter().position(|n| n == name) else {
                return Err(err(format!(
                    "ULog topic `{topic}` has no field `{name}`, read by `channel.{q}` ({}:{}); its fields: {}",
                    map.file,
                    e.line,
                    tp.names.join(", ")
                )));
            };
            let (key, _) = topics
                .get_key_value(topic.as_str())
                .ok_or_else(|| err(format!("topic `{topic}`")))?;
            rs.push(Resolved {
                topic: key.as_str(),
                field: i,
            });
        }
        mapped.push((*q, e, rs));
    }
    // A map channel replaces the built-in of the same quantity.
    builtin.retain(|(q, _)| !map_has(*q));
    let attitude = if map_has(Quantity::Roll) || map_has(Quantity::Pitch) || map_has(Quantity::Yaw) {
        None
    } else {
        attitude
    };
    // Time base.
    let base_topic: &str = match &map.time_base {
        Some(b) if has(b) => b.as_str(),
        Some(b) => return Err(err(format!("time_base topic `{b}` is not in the log (instance 0)"))),
        None => match rates_topic {
            Some(t) => t,
            None => return Err(err("no time base: set `time_base = TOPIC` in the map".into())),
        },
    };
    // Topics used, their times in s, strictly increasing, every used field finite.
    let mut used: BTreeMap<&str, BTreeSet<usize>> = BTreeMap::new();
    used.entry(base_topic).or_default();
    for (_, r) in &builtin {
        used.entry(r.topic).or_default().insert(r.field);
    }
    if let Some(a) = &attitude {
        for r in a {
            used.entry(r.topic).or_default().insert(r.field);
        }
    }
    for (_, _, rs) in &mapped {
        for r in rs {
            used.entry(r.topic).or_default().insert(r.field);
        }
    }
    let mut times: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    for (name, fields) in &used {
        let Some(tp) = topics.get(*name) else {
            return Err(err(format!("topic `{name}` is not in the log")));
        };
        for i in 1..tp.time_us.len() {
            if tp.time_us[i] <= tp.time_us[i - 1] {
                let p = tp.places[i];
                return Err(err(format!(
                    "ULog message #{} at byte {}: `{name}` time {} µs does not increase (previous {} µs)",
                    p.index,
                    p.offset,
                    tp.time_us[i],
                    tp.time_us[i - 1]
                )));
            }
        }
        for &f in fields {
            if let Some(i) = tp.values[f].iter().position(|v| !v.is_finite()) {
                let run = tp.values[f][i..].iter().take_while(|v| !v.is_finite()).count();
                let p = tp.places[i];
                return Err(err(format!(
                    "ULog message #{} at byte {}: `{name}.{}` is {} (a run of {run} message{}); missing samples are refused, not interpolated",
                    p.index,
                    p.offset,
                    tp.names[f],
                    tp.values[f][i],
                    if run == 1 { "" } else { "s" }
                )));
            }
        }
        times.insert(*name, tp.time_us.iter().map(|&t| t as f64 * 1e-6).collect());
    }
    let lo = times.values().map(|t| t[0]).fold(f64::NEG_INFINITY, f64::max);
    let hi = times.values().map(|t| t[t.len() - 1]).fold(f64::INFINITY, f64::min);
    let base: Vec<f64> = times[base_topic]
        .iter()
        .copied()
        .filter(|t| *t >= lo && *t <= hi)
        .collect();
    if base.len() < 2 {
        return Err(err(format!(
            "the used topics ({}) overlap in time over fewer than 2 samples of `{base_topic}`",
            used.keys().copied().collect::<Vec<_>>().join(", ")
        )));
    }
    let resample = |r: &Resolved| -> Vec<f64> {
        let (t, x) = (&times[r.topic], &topics[r.topic].values[r.field]);
        let mut j = 0;
        base.iter().map(|&tq| interp(t, x, tq, &mut j)).collect()
    };
    let mut channels: BTreeMap<Quantity, Vec<f64>> = BTreeMap::new();
    for (q, r) in &builtin {
        channels.insert(*q, resample(r));
    }
    if let Some(a) = &attitude {
        let topic = a[0].topic;
        let t = &times[topic];
        let comps: Vec<&Vec<f64>> = a.iter().map(|r| &topics[topic].values[r.field]).collect();
        let mut euler = [Vec::new(), Vec::new(), Vec::new()];
        let mut j = 0;
        for (k, &tq) in base.iter().enumerate() {
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
                let p = topics[topic].places[j];
                return Err(err(format!(
                    "ULog message #{} at byte {}: `vehicle_attitude.q` has zero norm (output sample {k})",
                    p.index, p.offset
                )));
            }
            let q = q.map(|v| v / norm);
            let e = quaternion_to_euler(q);
            for i in 0..3 {
                euler[i].push(e[i]);
            }
        }
        let [r, p, y] = euler;
        channels.insert(Quantity::Roll, r);
        channels.insert(Quantity::Pitch, p);
        channels.insert(Quantity::Yaw, y);
    }
    for (q, e, rs) in &mapped {
        let cols: Vec<Vec<f64>> = rs.iter().map(resample).collect();
        channels.insert(*q, (0..base.len()).map(|k| e.eval(cols.iter().map(|c| c[k]))).collect());
    }
    let flight = MeasuredFlight {
        source: file.to_string(),
        t_s: base,
        channels,
        aircraft: map.aircraft.clone(),
    };
    flight.validate().map_err(|inv| {
        let src = inv.quantity.map_or(String::new(), |q| {
            if let Some((_, _, rs)) = mapped.iter().find(|(c, _, _)| *c == q) {
                rs.first()
                    .map_or(String::new(), |r| format!(" (from `{}`, map {})", r.topic, map.file))
            } else if let Some((_, r)) = builtin.iter().find(|(c, _)| *c == q) {
                format!(" (from `{}.{}`)", r.topic, topics[r.topic].names[r.field])
            } else {
                " (from `vehicle_attitude.q`)".to_string()
            }
        });
        let at = inv.sample.map_or(String::new(), |k| {
            format!(" at output sample {k} (t = {:.6} s)", flight.t_s[k])
        });
        err(format!(
            "{}{src}{at}: {}",
            inv.quantity.map_or("time".to_string(), |q| q.name().to_string()),
            inv.message
        ))
    })?;
    Ok(flight)
}
