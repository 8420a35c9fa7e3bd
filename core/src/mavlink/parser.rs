//! Streaming MAVLink 1/2 parser: one byte in, at most one frame out, bounded buffers, no
//! allocation, never panics on any input.
//!
//! ## Policy
//! * Bytes outside a frame are discarded until a start byte (`0xFD` or `0xFE`).
//! * Known ids ([`super::messages::KNOWN`]) are checked at the header (a MAVLink 1 frame must have
//!   exactly the base length, a MAVLink 2 payload at most the full length, the incompatibility
//!   flags may only hold `0x01` = signed) and by their checksum with `CRC_EXTRA`. A failed check
//!   discards the start byte only and re-scans the bytes that followed it, so a frame swallowed by
//!   a corrupted or truncated one is recovered.
//! * Unknown ids cannot be checked (no `CRC_EXTRA`): the frame is skipped by its length, and the
//!   skip is confirmed only if the next byte is a start byte (an autopilot sends frames back to
//!   back); otherwise the bytes after its start byte are re-scanned. Garbage that looks like an
//!   unknown frame and happens to end on a start byte therefore hides any frame inside it: that is
//!   the limit of what an unverifiable frame allows (see the soak test).
//! * Signed frames (incompatibility flag `0x01`): the 13-byte signature is consumed and *not*
//!   verified (the co-processor holds no key). The checksum does not cover it, so, as for an unknown
//!   frame, it is re-scanned unless a start byte follows it (a truncated signature does not hide the
//!   next frame). The frame is delivered with
//!   [`Header::is_signed`]; this is acceptable because the co-processor accepts no commands: it
//!   only reads actuator outputs and RPM, which an unsigned frame could carry just as well.
//!
//! ## Bounds
//! The current frame is at most [`MAX_FRAME_LEN`] bytes and the re-scan queue holds at most one
//! frame more than that; a re-scan replays at most 279 bytes, so the worst-case work per input byte
//! is bounded.

use super::crc::{accumulate, accumulate_slice, CRC_INIT};
use super::frame::{
    CHECKSUM_LEN, HEADER_LEN_V1, HEADER_LEN_V2, INCOMPAT_SIGNED, MAGIC_V1, MAGIC_V2, MAX_FRAME_LEN, MAX_PAYLOAD_LEN,
    SIGNATURE_LEN,
};
use super::messages::{spec, Message, Payload};

/// Protocol version of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Version {
    /// MAVLink 1 (`0xFE`).
    V1,
    /// MAVLink 2 (`0xFD`).
    V2,
}

/// The header of a received frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// Protocol version.
    pub version: Version,
    /// Payload length on the wire (after MAVLink 2 truncation).
    pub payload_len: u8,
    /// Incompatibility flags (MAVLink 2; 0 for MAVLink 1).
    pub incompat_flags: u8,
    /// Compatibility flags (MAVLink 2; 0 for MAVLink 1).
    pub compat_flags: u8,
    /// Sequence number.
    pub sequence: u8,
    /// Sender system id.
    pub system_id: u8,
    /// Sender component id.
    pub component_id: u8,
    /// Message id.
    pub message_id: u32,
}

impl Header {
    /// The frame carried a (not verified) signature.
    pub fn is_signed(&self) -> bool {
        self.incompat_flags & INCOMPAT_SIGNED != 0
    }
}

/// A received, checksum-verified frame of a known message.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    /// Its header.
    pub header: Header,
    /// Its decoded payload.
    pub message: Message,
}

/// Counters of what the parser saw (wrapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParserStats {
    /// Frames delivered.
    pub frames: u32,
    /// Of those, signed ones (signature skipped, not verified).
    pub signed: u32,
    /// Known-id frames whose checksum failed.
    pub bad_crc: u32,
    /// Known-id frames whose length is impossible for the id (too long, or a MAVLink 1 frame not of
    /// the base length).
    pub bad_length: u32,
    /// MAVLink 2 frames with an unsupported incompatibility flag (dropped, as the spec requires).
    pub bad_incompat_flags: u32,
    /// Unknown-id frames skipped (confirmed by a start byte after them).
    pub unknown_skipped: u32,
    /// Unknown-id frames not followed by a start byte (re-scanned as a false start).
    pub unknown_unconfirmed: u32,
    /// Bytes discarded while looking for a start byte (including rejected start bytes).
    pub discarded_bytes: u32,
}

/// A complete run of bytes in the frame buffer, kept until the next byte confirms it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// Nothing: `frame` holds a frame being received (or nothing).
    None,
    /// A complete unknown-id frame.
    UnknownFrame,
    /// The signature of a delivered signed frame (not covered by the checksum).
    Signature,
}

const QUEUE_LEN: usize = MAX_FRAME_LEN + 8;

/// The byte-at-a-time parser (module doc).
#[derive(Debug, Clone)]
pub struct Parser {
    frame: [u8; MAX_FRAME_LEN],
    frame_len: usize,
    /// What the bytes in `frame` wait for.
    pending: Pending,
    queue: [u8; QUEUE_LEN],
    q_start: usize,
    q_end: usize,
    stats: ParserStats,
}

impl Default for Parser {
    fn default() -> Self {
        Self::new()
    }
}

impl Parser {
    /// An idle parser.
    pub const fn new() -> Self {
        Self {
            frame: [0; MAX_FRAME_LEN],
            frame_len: 0,
            pending: Pending::None,
            queue: [0; QUEUE_LEN],
            q_start: 0,
            q_end: 0,
            stats: ParserStats {
                frames: 0,
                signed: 0,
                bad_crc: 0,
                bad_length: 0,
                bad_incompat_flags: 0,
                unknown_skipped: 0,
                unknown_unconfirmed: 0,
                discarded_bytes: 0,
            },
        }
    }

    /// The counters.
    pub fn stats(&self) -> &ParserStats {
        &self.stats
    }

    /// Feeds one byte; returns the frame it completes, if any. A single byte can complete more
    /// than one frame (when a re-scan recovers several): after `Some`, call [`Parser::poll`] until
    /// it returns `None`, or use [`Parser::feed`], which does and copies no frame.
    pub fn push(&mut self, byte: u8) -> Option<Frame> {
        self.enqueue(byte);
        self.poll()
    }

    /// Processes bytes already queued by a re-scan; returns the next frame they complete.
    pub fn poll(&mut self) -> Option<Frame> {
        let mut got = None;
        // `step` delivers at most one frame per byte: stop at the first.
        self.drain(&mut |f: &Frame| got = Some(*f), true);
        got
    }

    /// Feeds `bytes` and calls `on_frame` for every frame, in order. The frame is lent, not
    /// returned: its payload is decoded where it lies in the parser's own buffer (no payload copy)
    /// and the frame is built once and not copied on its way to `on_frame` (the sampling task's
    /// stack, docs/benchmarks.md "Static stack bound"; [`Parser::poll`] copies it out).
    pub fn feed(&mut self, bytes: &[u8], mut on_frame: impl FnMut(&Frame)) {
        for &b in bytes {
            self.enqueue(b);
            self.drain(&mut on_frame, false);
        }
    }

    /// Appends `byte` to the re-scan queue.
    fn enqueue(&mut self, byte: u8) {
        if self.q_end >= QUEUE_LEN {
            self.compact(0);
        }
        match self.queue.get_mut(self.q_end) {
            Some(slot) => {
                *slot = byte;
                self.q_end += 1;
            }
            // Unreachable by the bound in the module doc; counted rather than trusted.
            None => self.stats.discarded_bytes = self.stats.discarded_bytes.wrapping_add(1),
        }
    }

    /// Steps through the queued bytes, lending each completed frame to `on_frame`; with
    /// `first_only`, returns after the first frame and keeps the rest queued.
    fn drain(&mut self, on_frame: &mut impl FnMut(&Frame), first_only: bool) {
        while self.q_start < self.q_end {
            let byte = self.queue.get(self.q_start).copied().unwrap_or(0);
            self.q_start += 1;
            if self.step(byte, on_frame) && first_only {
                return;
            }
        }
        self.q_start = 0;
        self.q_end = 0;
    }

    /// Moves the queued bytes to start at `at`.
    fn compact(&mut self, at: usize) {
        let n = self.q_end - self.q_start;
        if at + n <= QUEUE_LEN && copy_within(&mut self.queue, self.q_start, self.q_end, at) {
            self.q_start = at;
            self.q_end = at + n;
        }
    }

    /// Puts `bytes` back in front of the queue.
    fn unread(&mut self, bytes_from: usize, bytes_to: usize) {
        let n = bytes_to.saturating_sub(bytes_from);
        if self.q_start < n {
            self.compact(n);
        }
        if self.q_start >= n {
            let start = self.q_start - n;
            if let (Some(dst), Some(src)) = (
                self.queue.get_mut(start..self.q_start),
                self.frame.get(bytes_from..bytes_to),
            ) {
                copy(dst, src);
                self.q_start = start;
                return;
            }
        }
        // Unreachable by the bound in the module doc.
        self.stats.discarded_bytes = self.stats.discarded_bytes.wrapping_add(n as u32);
    }

    /// Drops the start byte of the current frame and re-scans the rest.
    fn reject(&mut self) {
        self.stats.discarded_bytes = self.stats.discarded_bytes.wrapping_add(1);
        let len = self.frame_len;
        self.frame_len = 0;
        self.pending = Pending::None;
        self.unread(1, len);
    }

    fn byte(&self, i: usize) -> u8 {
        self.frame.get(i).copied().unwrap_or(0)
    }

    /// One byte through the frame state machine; a completed frame is lent to `on_frame` (at most
    /// one per byte) and `true` returned.
    fn step(&mut self, byte: u8, on_frame: &mut impl FnMut(&Frame)) -> bool {
        let is_magic = byte == MAGIC_V2 || byte == MAGIC_V1;
        match self.pending {
            Pending::None => {}
            _ if is_magic => {
                if self.pending == Pending::UnknownFrame {
                    self.stats.unknown_skipped = self.stats.unknown_skipped.wrapping_add(1);
                }
                self.pending = Pending::None;
                self.frame_len = 0;
            }
            Pending::UnknownFrame => {
                self.stats.unknown_unconfirmed = self.stats.unknown_unconfirmed.wrapping_add(1);
                // Re-scan the frame's bytes after its start, then this byte.
                self.q_start = self.q_start.saturating_sub(1);
                self.reject();
                return false;
            }
            Pending::Signature => {
                // The "signature" may have been the start of the next frame (a truncated signature):
                // re-scan it, then this byte.
                self.q_start = self.q_start.saturating_sub(1);
                let len = self.frame_len;
                self.frame_len = 0;
                self.pending = Pending::None;
                self.unread(0, len);
                return false;
            }
        }
        if self.frame_len == 0 {
            if is_magic {
                self.frame[0] = byte;
                self.frame_len = 1;
            } else {
                self.stats.discarded_bytes = self.stats.discarded_bytes.wrapping_add(1);
            }
            return false;
        }
        match self.frame.get_mut(self.frame_len) {
            Some(slot) => *slot = byte,
            None => {
                self.reject();
                return false;
            }
        }
        self.frame_len += 1;

        let v2 = self.byte(0) == MAGIC_V2;
        let header_len = if v2 { HEADER_LEN_V2 } else { HEADER_LEN_V1 };
        if self.frame_len < header_len {
            return false;
        }
        let header = self.header(v2);
        let known = spec(header.message_id);
        let payload_len = usize::from(header.payload_len);
        if self.frame_len == header_len {
            if header.incompat_flags & !INCOMPAT_SIGNED != 0 {
                self.stats.bad_incompat_flags = self.stats.bad_incompat_flags.wrapping_add(1);
                self.reject();
                return false;
            }
            if let Some(s) = known {
                let fits = if v2 {
                    header.payload_len <= s.max_len
                } else {
                    header.payload_len == s.base_len
                };
                if !fits {
                    self.stats.bad_length = self.stats.bad_length.wrapping_add(1);
                    self.reject();
                    return false;
                }
            }
        }
        let signature = if header.is_signed() { SIGNATURE_LEN } else { 0 };
        if self.frame_len < header_len + payload_len + CHECKSUM_LEN + signature {
            return false;
        }

        let Some(s) = known else {
            self.pending = Pending::UnknownFrame;
            return false;
        };
        let body_end = header_len + payload_len;
        let crc = accumulate(
            accumulate_slice(CRC_INIT, self.frame.get(1..body_end).unwrap_or(&[])),
            s.crc_extra,
        );
        let received = u16::from_le_bytes([self.byte(body_end), self.byte(body_end + 1)]);
        if crc != received {
            self.stats.bad_crc = self.stats.bad_crc.wrapping_add(1);
            self.reject();
            return false;
        }
        // Decoded in place: the payload's bytes stay where they are in `frame`, the tail after
        // them is zeroed (MAVLink 2 truncates trailing zeros; `header_len + MAX_PAYLOAD_LEN` ≤
        // `MAX_FRAME_LEN`), and a signature is first set aside. No payload copy on the stack.
        let mut signature_bytes = [0u8; SIGNATURE_LEN];
        if signature > 0 {
            let sig_start = body_end + CHECKSUM_LEN;
            if let Some(src) = self.frame.get(sig_start..sig_start + SIGNATURE_LEN) {
                copy(&mut signature_bytes, src);
            }
        }
        if let Some(tail) = self.frame.get_mut(body_end..header_len + MAX_PAYLOAD_LEN) {
            tail.fill(0);
        }
        let message = self
            .frame
            .get(header_len..header_len + MAX_PAYLOAD_LEN)
            .and_then(|p| <&Payload>::try_from(p).ok())
            .and_then(|p| Message::decode(header.message_id, p));
        self.frame_len = 0;
        if signature > 0 {
            // Keep the signature until the next byte shows it was one (module doc).
            if let Some(dst) = self.frame.get_mut(..SIGNATURE_LEN) {
                copy(dst, &signature_bytes);
            }
            self.frame_len = SIGNATURE_LEN;
            self.pending = Pending::Signature;
        }
        let Some(message) = message else {
            return false;
        };
        self.stats.frames = self.stats.frames.wrapping_add(1);
        if header.is_signed() {
            self.stats.signed = self.stats.signed.wrapping_add(1);
        }
        on_frame(&Frame { header, message });
        true
    }

    fn header(&self, v2: bool) -> Header {
        let b = |i| self.byte(i);
        if v2 {
            Header {
                version: Version::V2,
                payload_len: b(1),
                incompat_flags: b(2),
                compat_flags: b(3),
                sequence: b(4),
                system_id: b(5),
                component_id: b(6),
                message_id: u32::from_le_bytes([b(7), b(8), b(9), 0]),
            }
        } else {
            Header {
                version: Version::V1,
                payload_len: b(1),
                incompat_flags: 0,
                compat_flags: 0,
                sequence: b(2),
                system_id: b(3),
                component_id: b(4),
                message_id: u32::from(b(5)),
            }
        }
    }
}

/// `dst.copy_from_slice(src)` for slices the caller made the same length, without the length
/// check's panic path (the compiler cannot always see that the lengths agree; the release firmware
/// is shown to have no reachable panic, docs/reliability.md).
fn copy(dst: &mut [u8], src: &[u8]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

/// `buf.copy_within(from..to, at)`, or nothing (`false`) if a range is out of bounds. Byte by byte
/// through `get` (forwards or backwards, as the overlap needs), so there is no panic path: the
/// compiler keeps `copy_within`'s own bounds assertion even behind the same checks.
fn copy_within(buf: &mut [u8], from: usize, to: usize, at: usize) -> bool {
    let Some(n) = to.checked_sub(from) else {
        return false;
    };
    if to > buf.len() || at > buf.len() - n {
        return false;
    }
    let mut move_one = |i: usize| {
        if let Some(v) = buf.get(from + i).copied() {
            if let Some(d) = buf.get_mut(at + i) {
                *d = v;
            }
        }
    };
    if at <= from {
        (0..n).for_each(&mut move_one);
    } else {
        (0..n).rev().for_each(&mut move_one);
    }
    true
}
