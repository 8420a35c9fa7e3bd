//! The standard messages this module encodes or decodes, hand-written from the official
//! definitions (`common.xml`; `RPM` from `ardupilotmega.xml`).
//!
//! Payload layout (MAVLink serialisation rule): the base fields sorted by the size of their element
//! type, largest first (stable, so fields of one size keep their XML order), then the extension
//! fields in XML order; little-endian. Offsets are given on each struct. `CRC_EXTRA` values were
//! checked against pymavlink 2.4.50's generated dialects (and, for `ESC_STATUS`, which that release
//! leaves out as work-in-progress, against its generator run on the message's definition).

/// Longest payload (the range of the frame's length byte).
pub const MAX_PAYLOAD_LEN: usize = 255;

/// A zero-extended payload: a received payload copied to the front, the rest zero (MAVLink 2
/// trailing-zero truncation and absent extensions both read as zero).
pub type Payload = [u8; MAX_PAYLOAD_LEN];

/// The wire facts of one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MessageSpec {
    /// Message id.
    pub id: u32,
    /// The `CRC_EXTRA` byte (a hash of the message's name and base fields).
    pub crc_extra: u8,
    /// Payload length of the base fields (the exact length of a MAVLink 1 frame).
    pub base_len: u8,
    /// Payload length with every extension field (the longest MAVLink 2 payload).
    pub max_len: u8,
}

/// A message with a fixed id and layout.
pub trait MavMessage {
    /// Its wire facts.
    const SPEC: MessageSpec;
}

/// A message this module can serialise.
pub trait Encode: MavMessage {
    /// Writes the full (untruncated, `SPEC.max_len` bytes) payload into the front of `payload`.
    fn encode_payload(&self, payload: &mut Payload);
}

/// A message this module can deserialise.
pub trait Decode: MavMessage + Sized {
    /// Reads the message from a zero-extended payload.
    fn decode_payload(payload: &Payload) -> Self;
}

// The byte copies below zip the two slices instead of `copy_from_slice`: the lengths agree by
// construction, but the compiler cannot always see it and would keep the length check's panic
// path in the firmware (docs/reliability.md: no reachable panic).

fn put(payload: &mut [u8], at: usize, bytes: &[u8]) {
    if let Some(dst) = payload.get_mut(at..at + bytes.len()) {
        dst.iter_mut().zip(bytes).for_each(|(d, s)| *d = *s);
    }
}

fn get<const N: usize>(payload: &[u8], at: usize) -> [u8; N] {
    let mut out = [0; N];
    if let Some(src) = payload.get(at..at + N) {
        out.iter_mut().zip(src).for_each(|(d, s)| *d = *s);
    }
    out
}

fn get_u16(p: &[u8], at: usize) -> u16 {
    u16::from_le_bytes(get(p, at))
}

fn get_u32(p: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(get(p, at))
}

fn get_i32(p: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(get(p, at))
}

fn get_u64(p: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(get(p, at))
}

fn get_f32(p: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(get(p, at))
}

fn get_u8(p: &[u8], at: usize) -> u8 {
    p.get(at).copied().unwrap_or(0)
}

/// A `char[10]` name: `name` copied, the rest NUL (no terminator when it is 10 bytes long).
/// `None` if `name` is longer than 10 bytes.
pub fn name10(name: &str) -> Option<[u8; 10]> {
    let bytes = name.as_bytes();
    let mut out = [0u8; 10];
    out.get_mut(..bytes.len())?
        .iter_mut()
        .zip(bytes)
        .for_each(|(d, s)| *d = *s);
    Some(out)
}

/// `HEARTBEAT` (#0). Payload: `custom_mode` u32 @0, `type` @4, `autopilot` @5, `base_mode` @6,
/// `system_status` @7, `mavlink_version` @8 (9 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Heartbeat {
    /// Autopilot-specific mode bits.
    pub custom_mode: u32,
    /// `MAV_TYPE`.
    pub mav_type: u8,
    /// `MAV_AUTOPILOT`.
    pub autopilot: u8,
    /// `MAV_MODE_FLAG` bits.
    pub base_mode: u8,
    /// `MAV_STATE`.
    pub system_status: u8,
    /// MAVLink protocol version field (3 for MAVLink 1.0/2).
    pub mavlink_version: u8,
}

impl Heartbeat {
    /// `MAV_TYPE_ONBOARD_CONTROLLER`.
    pub const MAV_TYPE_ONBOARD_CONTROLLER: u8 = 18;
    /// `MAV_AUTOPILOT_INVALID` (not a flight controller).
    pub const MAV_AUTOPILOT_INVALID: u8 = 8;
    /// `MAV_STATE_STANDBY`.
    pub const MAV_STATE_STANDBY: u8 = 3;
    /// `MAV_STATE_ACTIVE`.
    pub const MAV_STATE_ACTIVE: u8 = 4;

    /// The co-processor's heartbeat: an onboard controller, no autopilot, base and custom mode 0.
    pub const fn onboard_controller(system_status: u8) -> Self {
        Self {
            custom_mode: 0,
            mav_type: Self::MAV_TYPE_ONBOARD_CONTROLLER,
            autopilot: Self::MAV_AUTOPILOT_INVALID,
            base_mode: 0,
            system_status,
            mavlink_version: 3,
        }
    }
}

impl MavMessage for Heartbeat {
    const SPEC: MessageSpec = MessageSpec {
        id: 0,
        crc_extra: 50,
        base_len: 9,
        max_len: 9,
    };
}

impl Encode for Heartbeat {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.custom_mode.to_le_bytes());
        put(
            p,
            4,
            &[
                self.mav_type,
                self.autopilot,
                self.base_mode,
                self.system_status,
                self.mavlink_version,
            ],
        );
    }
}

impl Decode for Heartbeat {
    fn decode_payload(p: &Payload) -> Self {
        Self {
            custom_mode: get_u32(p, 0),
            mav_type: get_u8(p, 4),
            autopilot: get_u8(p, 5),
            base_mode: get_u8(p, 6),
            system_status: get_u8(p, 7),
            mavlink_version: get_u8(p, 8),
        }
    }
}

/// `ATTITUDE` (#30). Payload: `time_boot_ms` u32 @0, `roll` f32 @4, `pitch` f32 @8, `yaw` f32 @12,
/// `rollspeed` f32 @16, `pitchspeed` f32 @20, `yawspeed` f32 @24 (28 bytes). The autopilot's
/// attitude estimate: 3-2-1 Euler angles of the body (FRD) relative to the local NED frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Attitude {
    /// The autopilot's time since boot, ms.
    pub time_boot_ms: u32,
    /// Roll φ, pitch θ, yaw ψ, rad.
    pub euler_rad: [f32; 3],
    /// Body rates p, q, r, rad/s.
    pub rate_rad_s: [f32; 3],
}

impl MavMessage for Attitude {
    const SPEC: MessageSpec = MessageSpec {
        id: 30,
        crc_extra: 39,
        base_len: 28,
        max_len: 28,
    };
}

impl Encode for Attitude {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.time_boot_ms.to_le_bytes());
        for (i, v) in self.euler_rad.iter().chain(self.rate_rad_s.iter()).enumerate() {
            put(p, 4 + 4 * i, &v.to_le_bytes());
        }
    }
}

impl Decode for Attitude {
    fn decode_payload(p: &Payload) -> Self {
        let f = |i: usize| get_f32(p, 4 + 4 * i);
        Self {
            time_boot_ms: get_u32(p, 0),
            euler_rad: [f(0), f(1), f(2)],
            rate_rad_s: [f(3), f(4), f(5)],
        }
    }
}

/// `SERVO_OUTPUT_RAW` (#36). Payload: `time_usec` u32 @0, `servo1_raw`…`servo8_raw` u16 @4…18,
/// `port` u8 @20; extensions `servo9_raw`…`servo16_raw` u16 @21…35 (21 bytes base, 37 with them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoOutputRaw {
    /// The autopilot's timestamp, µs (wraps after 71 min; not used for staleness here).
    pub time_us: u32,
    /// Output port (a set of 8 outputs; 0 = MAIN, 1 = AUX on Pixhawk-class boards).
    pub port: u8,
    /// Pulse widths of outputs 1…16, µs (index 0 = `servo1_raw`; 0 = not sent / disabled).
    pub servo_raw_us: [u16; 16],
}

impl MavMessage for ServoOutputRaw {
    const SPEC: MessageSpec = MessageSpec {
        id: 36,
        crc_extra: 222,
        base_len: 21,
        max_len: 37,
    };
}

impl Encode for ServoOutputRaw {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.time_us.to_le_bytes());
        for (i, us) in self.servo_raw_us.iter().enumerate() {
            let at = if i < 8 { 4 + 2 * i } else { 21 + 2 * (i - 8) };
            put(p, at, &us.to_le_bytes());
        }
        put(p, 20, &[self.port]);
    }
}

impl Decode for ServoOutputRaw {
    fn decode_payload(p: &Payload) -> Self {
        let mut servo_raw_us = [0u16; 16];
        for (i, us) in servo_raw_us.iter_mut().enumerate() {
            let at = if i < 8 { 4 + 2 * i } else { 21 + 2 * (i - 8) };
            *us = get_u16(p, at);
        }
        Self {
            time_us: get_u32(p, 0),
            port: get_u8(p, 20),
            servo_raw_us,
        }
    }
}

/// ArduPilot's `RPM` (#226, `ardupilotmega.xml`). Payload: `rpm1` f32 @0, `rpm2` f32 @4 (8 bytes).
/// ArduPilot sends −1 for a sensor that is not healthy.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rpm {
    /// RPM sensors 1 and 2, rev/min.
    pub rpm: [f32; 2],
}

impl MavMessage for Rpm {
    const SPEC: MessageSpec = MessageSpec {
        id: 226,
        crc_extra: 207,
        base_len: 8,
        max_len: 8,
    };
}

impl Encode for Rpm {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.rpm[0].to_le_bytes());
        put(p, 4, &self.rpm[1].to_le_bytes());
    }
}

impl Decode for Rpm {
    fn decode_payload(p: &Payload) -> Self {
        Self {
            rpm: [get_f32(p, 0), get_f32(p, 4)],
        }
    }
}

/// `ESC_STATUS` (#291, `common.xml`, streamed by PX4). Payload: `time_usec` u64 @0, `rpm` i32\[4\]
/// @8, `voltage` f32\[4\] @24, `current` f32\[4\] @40, `index` u8 @56 (57 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EscStatus {
    /// The autopilot's timestamp, µs.
    pub time_us: u64,
    /// Index of the first ESC in this message (0, 4, 8, …).
    pub index: u8,
    /// Motor speed of ESCs `index…index+3`, rev/min (negative: reverse rotation).
    pub rpm: [i32; 4],
    /// Voltage of each ESC, V.
    pub voltage_v: [f32; 4],
    /// Current of each ESC, A.
    pub current_a: [f32; 4],
}

impl MavMessage for EscStatus {
    const SPEC: MessageSpec = MessageSpec {
        id: 291,
        crc_extra: 10,
        base_len: 57,
        max_len: 57,
    };
}

impl Encode for EscStatus {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.time_us.to_le_bytes());
        for i in 0..4 {
            put(p, 8 + 4 * i, &self.rpm[i].to_le_bytes());
            put(p, 24 + 4 * i, &self.voltage_v[i].to_le_bytes());
            put(p, 40 + 4 * i, &self.current_a[i].to_le_bytes());
        }
        put(p, 56, &[self.index]);
    }
}

impl Decode for EscStatus {
    fn decode_payload(p: &Payload) -> Self {
        let mut m = Self {
            time_us: get_u64(p, 0),
            index: get_u8(p, 56),
            ..Self::default()
        };
        for i in 0..4 {
            m.rpm[i] = get_i32(p, 8 + 4 * i);
            m.voltage_v[i] = get_f32(p, 24 + 4 * i);
            m.current_a[i] = get_f32(p, 40 + 4 * i);
        }
        m
    }
}

/// `NAMED_VALUE_FLOAT` (#251). Payload: `time_boot_ms` u32 @0, `value` f32 @4, `name` char\[10\] @8
/// (18 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NamedValueFloat {
    /// Time since boot, ms.
    pub time_boot_ms: u32,
    /// Name, NUL-padded (see [`name10`]).
    pub name: [u8; 10],
    /// Value.
    pub value: f32,
}

impl MavMessage for NamedValueFloat {
    const SPEC: MessageSpec = MessageSpec {
        id: 251,
        crc_extra: 170,
        base_len: 18,
        max_len: 18,
    };
}

impl Encode for NamedValueFloat {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.time_boot_ms.to_le_bytes());
        put(p, 4, &self.value.to_le_bytes());
        put(p, 8, &self.name);
    }
}

impl Decode for NamedValueFloat {
    fn decode_payload(p: &Payload) -> Self {
        Self {
            time_boot_ms: get_u32(p, 0),
            value: get_f32(p, 4),
            name: get(p, 8),
        }
    }
}

/// Number of floats in `DEBUG_FLOAT_ARRAY.data`.
pub const DEBUG_FLOAT_ARRAY_LEN: usize = 58;

/// `DEBUG_FLOAT_ARRAY` (#350). Payload: `time_usec` u64 @0, `array_id` u16 @8, `name` char\[10\]
/// @10; extension `data` f32\[58\] @20 (20 bytes base, 252 with it).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DebugFloatArray {
    /// Timestamp, µs.
    pub time_us: u64,
    /// Array id.
    pub array_id: u16,
    /// Name, NUL-padded (see [`name10`]).
    pub name: [u8; 10],
    /// The values (unused trailing entries 0, so MAVLink 2 truncation drops them).
    pub data: [f32; DEBUG_FLOAT_ARRAY_LEN],
}

impl Default for DebugFloatArray {
    fn default() -> Self {
        Self {
            time_us: 0,
            array_id: 0,
            name: [0; 10],
            data: [0.0; DEBUG_FLOAT_ARRAY_LEN],
        }
    }
}

impl MavMessage for DebugFloatArray {
    const SPEC: MessageSpec = MessageSpec {
        id: 350,
        crc_extra: 232,
        base_len: 20,
        max_len: 252,
    };
}

impl Encode for DebugFloatArray {
    fn encode_payload(&self, p: &mut Payload) {
        put(p, 0, &self.time_us.to_le_bytes());
        put(p, 8, &self.array_id.to_le_bytes());
        put(p, 10, &self.name);
        for (i, v) in self.data.iter().enumerate() {
            put(p, 20 + 4 * i, &v.to_le_bytes());
        }
    }
}

impl Decode for DebugFloatArray {
    fn decode_payload(p: &Payload) -> Self {
        let mut m = Self {
            time_us: get_u64(p, 0),
            array_id: get_u16(p, 8),
            name: get(p, 10),
            ..Self::default()
        };
        for (i, v) in m.data.iter_mut().enumerate() {
            *v = get_f32(p, 20 + 4 * i);
        }
        m
    }
}

/// A decoded message of one of the known ids.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message {
    /// `HEARTBEAT` (#0).
    Heartbeat(Heartbeat),
    /// `ATTITUDE` (#30).
    Attitude(Attitude),
    /// `SERVO_OUTPUT_RAW` (#36).
    ServoOutputRaw(ServoOutputRaw),
    /// `RPM` (#226).
    Rpm(Rpm),
    /// `NAMED_VALUE_FLOAT` (#251).
    NamedValueFloat(NamedValueFloat),
    /// `ESC_STATUS` (#291).
    EscStatus(EscStatus),
    /// `DEBUG_FLOAT_ARRAY` (#350).
    DebugFloatArray(DebugFloatArray),
}

/// The messages the parser knows (every other id is skipped unverified).
pub const KNOWN: [MessageSpec; 7] = [
    Heartbeat::SPEC,
    Attitude::SPEC,
    ServoOutputRaw::SPEC,
    Rpm::SPEC,
    NamedValueFloat::SPEC,
    EscStatus::SPEC,
    DebugFloatArray::SPEC,
];

/// The wire facts of message `id`, if it is known.
pub fn spec(id: u32) -> Option<MessageSpec> {
    KNOWN.iter().copied().find(|s| s.id == id)
}

impl Message {
    /// Decodes a zero-extended payload of message `id` (`None` for an unknown id).
    pub fn decode(id: u32, payload: &Payload) -> Option<Self> {
        Some(match id {
            0 => Self::Heartbeat(Heartbeat::decode_payload(payload)),
            30 => Self::Attitude(Attitude::decode_payload(payload)),
            36 => Self::ServoOutputRaw(ServoOutputRaw::decode_payload(payload)),
            226 => Self::Rpm(Rpm::decode_payload(payload)),
            251 => Self::NamedValueFloat(NamedValueFloat::decode_payload(payload)),
            291 => Self::EscStatus(EscStatus::decode_payload(payload)),
            350 => Self::DebugFloatArray(DebugFloatArray::decode_payload(payload)),
            _ => return None,
        })
    }

    /// The message id.
    pub fn id(&self) -> u32 {
        match self {
            Self::Heartbeat(_) => Heartbeat::SPEC.id,
            Self::Attitude(_) => Attitude::SPEC.id,
            Self::ServoOutputRaw(_) => ServoOutputRaw::SPEC.id,
            Self::Rpm(_) => Rpm::SPEC.id,
            Self::NamedValueFloat(_) => NamedValueFloat::SPEC.id,
            Self::EscStatus(_) => EscStatus::SPEC.id,
            Self::DebugFloatArray(_) => DebugFloatArray::SPEC.id,
        }
    }
}
