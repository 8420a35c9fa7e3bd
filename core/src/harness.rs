//! The contract between the firmware and the host tools that run it under QEMU and model it
//! (`aerosid_qemu`): every constant both sides need, written once here, so the firmware and
//! the harness that checks it cannot drift apart.

use crate::aero::model::idx;

/// Timing probes per sample in the firmware's count file (`icount.bin` under QEMU): the whole
/// step, the synthesis stage, one per coefficient, then the whole firmware since the previous
/// sample ([`PERIOD_PROBE`]).
pub const PROBES: usize = 3 + idx::COUNT;

/// The probe holding the counter ticks from the previous sample's step start to this one's: the
/// whole firmware per sample (the step, the sample queue, the sampling task, the count file,
/// interrupts); 0 for the first sample.
pub const PERIOD_PROBE: usize = PROBES - 1;

/// The probes' names, in the count file's order.
pub const PROBE_NAMES: [&str; PROBES] = [
    "step",
    "synthesis",
    "C_L",
    "C_D",
    "C_Y",
    "C_l",
    "C_m",
    "C_n",
    "firmware",
];

/// Failed reads in a row after which the firmware re-initialises a chip, and retries every this
/// many samples while it keeps failing (0.5 s at 100 Hz).
pub const REINIT_AFTER: u16 = 50;

/// Most fault records the QEMU board reads from `faults.bin`.
pub const MAX_FAULTS: usize = 32;

/// Bytes of one fault record: first record index `u32`, number of records `u32`, kind `u8`
/// ([`fault_kind`]), target `u8`, two reserved bytes, parameter (`f32` value or `u32` µs), all
/// little-endian.
pub const FAULT_RECORD_BYTES: usize = 16;

/// Fault kinds (byte 8 of a fault record).
pub mod fault_kind {
    /// The reads of chip `target` fail ([`super::fault_chip`]).
    pub const BUS: u8 = 1;
    /// Channel `target` (a bit position of the pipeline's channel mask) keeps its value of the
    /// first record.
    pub const STUCK: u8 = 2;
    /// Channel `target` reads the parameter (an `f32`).
    pub const VALUE: u8 = 3;
    /// The sample is dropped as if the estimator's queue were full.
    pub const DROP: u8 = 4;
    /// The first record's sample is taken the parameter (µs, `u32`) late: its `t_s`, `dt_s` and
    /// time stamp later by that much, the next sample's `dt_s` shorter by it.
    pub const LATE: u8 = 5;
}

/// Chips (the target of a [`fault_kind::BUS`] fault).
pub mod fault_chip {
    /// ICM-42688-P: accelerometer and gyro.
    pub const IMU: u8 = 0;
    /// MS4525DO: airspeed and (from its temperature) density.
    pub const AIRSPEED: u8 = 1;
    /// AS5600 α vane.
    pub const ALPHA: u8 = 2;
    /// AS5600 β vane.
    pub const BETA: u8 = 3;
    /// The autopilot link: the record's bytes of `autopilot.bin` are lost.
    pub const AUTOPILOT: u8 = 4;
}
