//! CRC-16/MCRF4XX (the "X.25" checksum of the MAVLink spec): polynomial 0x1021 reflected (0x8408),
//! initial value 0xFFFF, input and output reflected, no final XOR. Check value: `"123456789"` →
//! `0x6F91`.
//!
//! A frame's checksum covers every byte after the magic up to the end of the payload, then the
//! message's `CRC_EXTRA` byte (which makes a receiver with a different field layout reject the frame).

/// Initial value of the accumulator.
pub const CRC_INIT: u16 = 0xFFFF;

/// Accumulates one byte into `crc` (bytewise form of the reflected 0x8408 polynomial).
#[inline]
pub fn accumulate(crc: u16, byte: u8) -> u16 {
    let mut t = byte ^ (crc & 0xFF) as u8;
    t ^= t << 4;
    let t = u16::from(t);
    (crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4)
}

/// Accumulates every byte of `data` into `crc`.
#[inline]
pub fn accumulate_slice(crc: u16, data: &[u8]) -> u16 {
    data.iter().fold(crc, |c, &b| accumulate(c, b))
}

/// CRC-16/MCRF4XX of `data` from the initial value.
pub fn crc16_mcrf4xx(data: &[u8]) -> u16 {
    accumulate_slice(CRC_INIT, data)
}
