//! Frame constants and the MAVLink 2 (and, for ids below 256, MAVLink 1) frame encoder.
//!
//! MAVLink 2 frame: `0xFD, len, incompat_flags, compat_flags, seq, sysid, compid, msgid[3] (LE),
//! payload[len], crc[2] (LE)`, then a 13-byte signature when `incompat_flags & 0x01`.
//! MAVLink 1 frame: `0xFE, len, seq, sysid, compid, msgid, payload[len], crc[2]`.

use super::crc::{accumulate, accumulate_slice, CRC_INIT};
pub use super::messages::MAX_PAYLOAD_LEN;
use super::messages::{Encode, Payload};

/// MAVLink 2 start byte.
pub const MAGIC_V2: u8 = 0xFD;
/// MAVLink 1 start byte.
pub const MAGIC_V1: u8 = 0xFE;
/// MAVLink 2 header length (magic included).
pub const HEADER_LEN_V2: usize = 10;
/// MAVLink 1 header length (magic included).
pub const HEADER_LEN_V1: usize = 6;
/// Checksum length.
pub const CHECKSUM_LEN: usize = 2;
/// Signature length (link id, 48-bit timestamp, 48-bit signature).
pub const SIGNATURE_LEN: usize = 13;
/// Longest frame (signed MAVLink 2 with a 255-byte payload): 280 bytes.
pub const MAX_FRAME_LEN: usize = HEADER_LEN_V2 + MAX_PAYLOAD_LEN + CHECKSUM_LEN + SIGNATURE_LEN;
/// The only incompatibility flag defined: the frame is signed.
pub const INCOMPAT_SIGNED: u8 = 0x01;
/// `MAV_COMP_ID_ONBOARD_COMPUTER`, the default component id of the co-processor.
pub const MAV_COMP_ID_ONBOARD_COMPUTER: u8 = 191;

/// Why a frame was not written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The output buffer is shorter than the frame; nothing was written past its length and the
    /// sequence number was not consumed.
    BufferTooSmall,
    /// A MAVLink 1 frame was asked for a message id above 255.
    IdNotV1,
    /// A coefficient index outside `0..6` (see [`crate::aero::model::idx`]).
    UnknownCoefficient,
    /// A name longer than the 10 bytes of a `char[10]` field.
    NameTooLong,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "output buffer too small for the frame",
            Self::IdNotV1 => "message id does not fit a MAVLink 1 frame",
            Self::UnknownCoefficient => "coefficient index outside 0..6",
            Self::NameTooLong => "name longer than 10 bytes",
        })
    }
}

/// MAVLink 2 payload length after trailing-zero truncation: trailing zero bytes are dropped, but at
/// least one byte is kept (as the reference implementations do).
pub fn truncated_len(payload: &[u8]) -> usize {
    payload
        .iter()
        .rposition(|&b| b != 0)
        .map_or(1, |i| i + 1)
        .min(payload.len())
}

/// Writes frames with one system/component id and a wrapping sequence number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Encoder {
    /// Sender system id (usually the autopilot's, so ground stations group the co-processor with
    /// the vehicle).
    pub system_id: u8,
    /// Sender component id.
    pub component_id: u8,
    sequence: u8,
}

impl Encoder {
    /// An encoder whose first frame has sequence number 0.
    pub const fn new(system_id: u8, component_id: u8) -> Self {
        Self {
            system_id,
            component_id,
            sequence: 0,
        }
    }

    /// Sequence number of the next frame.
    pub fn sequence(&self) -> u8 {
        self.sequence
    }

    /// Writes `msg` as an unsigned MAVLink 2 frame (payload truncated) at the front of `out`;
    /// returns the frame length.
    pub fn encode<M: Encode>(&mut self, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
        let mut payload: Payload = [0; MAX_PAYLOAD_LEN];
        msg.encode_payload(&mut payload);
        let full = payload
            .get(..usize::from(M::SPEC.max_len))
            .ok_or(EncodeError::BufferTooSmall)?;
        let len = truncated_len(full);
        let body = full.get(..len).ok_or(EncodeError::BufferTooSmall)?;
        let total = HEADER_LEN_V2 + len + CHECKSUM_LEN;
        let frame = out.get_mut(..total).ok_or(EncodeError::BufferTooSmall)?;
        let id = M::SPEC.id.to_le_bytes();
        let header = [
            MAGIC_V2,
            len as u8,
            0,
            0,
            self.sequence,
            self.system_id,
            self.component_id,
            id[0],
            id[1],
            id[2],
        ];
        finish(frame, &header, body, M::SPEC.crc_extra);
        self.sequence = self.sequence.wrapping_add(1);
        Ok(total)
    }

    /// Writes `msg` as a MAVLink 1 frame (base fields only, no truncation): for ids below 256, e.g.
    /// to test a receiver or feed a MAVLink 1 link.
    pub fn encode_v1<M: Encode>(&mut self, msg: &M, out: &mut [u8]) -> Result<usize, EncodeError> {
        let id = u8::try_from(M::SPEC.id).map_err(|_| EncodeError::IdNotV1)?;
        let mut payload: Payload = [0; MAX_PAYLOAD_LEN];
        msg.encode_payload(&mut payload);
        let len = usize::from(M::SPEC.base_len);
        let body = payload.get(..len).ok_or(EncodeError::BufferTooSmall)?;
        let total = HEADER_LEN_V1 + len + CHECKSUM_LEN;
        let frame = out.get_mut(..total).ok_or(EncodeError::BufferTooSmall)?;
        let header = [
            MAGIC_V1,
            len as u8,
            self.sequence,
            self.system_id,
            self.component_id,
            id,
        ];
        finish(frame, &header, body, M::SPEC.crc_extra);
        self.sequence = self.sequence.wrapping_add(1);
        Ok(total)
    }
}

/// Fills `frame` (header + body + 2 bytes long) with the header, the body and the checksum.
fn finish(frame: &mut [u8], header: &[u8], body: &[u8], crc_extra: u8) {
    let crc = frame_crc(header, body, crc_extra).to_le_bytes();
    for (dst, src) in frame.iter_mut().zip(header.iter().chain(body).chain(crc.iter())) {
        *dst = *src;
    }
}

/// The checksum of a frame: header bytes after the magic, the payload, then `crc_extra`.
pub fn frame_crc(header: &[u8], payload: &[u8], crc_extra: u8) -> u16 {
    let crc = accumulate_slice(CRC_INIT, header.get(1..).unwrap_or(&[]));
    accumulate(accumulate_slice(crc, payload), crc_extra)
}
