//! The contract between the firmware and the host tools that run it under QEMU and model it
//! (`aerosid_qemu`): every constant both sides need, and the sensor-health bookkeeping and health
//! report both run (the firmware on its boards, the host's model of it on a scenario), written
//! once here, so the firmware and the harness that checks it cannot drift apart.

use crate::aero::model::{channel, idx, ChannelMask};
use crate::aero::sequence::SequenceHealth;
use crate::mavlink::telemetry::{health_slot as slot, HealthReport};
use crate::mavlink::MavlinkSurfaces;

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

/// The read outcomes of one chip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChipHealth {
    /// Failed reads since boot (saturating).
    pub faults: u32,
    /// Re-initialisations since boot (saturating).
    pub reinits: u32,
    /// Failed reads in a row.
    streak: u16,
}

impl ChipHealth {
    /// Counts one read; `true` when the chip has now failed [`REINIT_AFTER`] times in a row and
    /// is to be re-initialised (counted here). The streak then starts again, so a dead chip is
    /// retried every [`REINIT_AFTER`] samples.
    #[inline]
    pub fn record(&mut self, ok: bool) -> bool {
        if ok {
            self.streak = 0;
            return false;
        }
        self.faults = self.faults.saturating_add(1);
        self.streak = self.streak.saturating_add(1);
        if self.streak >= REINIT_AFTER {
            self.streak = 0;
            self.reinits = self.reinits.saturating_add(1);
            true
        } else {
            false
        }
    }
}

/// The autopilot link's receive counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkHealth {
    /// Frames received (any message, any sender).
    pub frames: u32,
    /// Frames rejected: bad checksum, impossible length, unknown incompatibility flags.
    pub rejected: u32,
    /// Bytes discarded while looking for a frame.
    pub discarded: u32,
    /// Received bytes lost (receiver overrun or full ring).
    pub lost: u32,
    /// Frames not kept because their stamp was not newer than the kept frame's (repeats, replays).
    pub not_newer: u32,
}

impl LinkHealth {
    /// The counters of the link's parser and surfaces source, and `lost` bytes.
    #[inline]
    pub fn from_link(link: &MavlinkSurfaces, lost: u32) -> Self {
        let stats = link.parser_stats();
        Self {
            frames: stats.frames,
            rejected: stats
                .bad_crc
                .saturating_add(stats.bad_length)
                .saturating_add(stats.bad_incompat_flags),
            discarded: stats.discarded_bytes,
            lost,
            not_newer: link.not_newer_frames(),
        }
    }
}

/// What the sensor layer reports (each counter saturates).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorHealth {
    /// IMU (gyro and accelerometer).
    pub imu: ChipHealth,
    /// Airspeed sensor (airspeed and, from its temperature, air density).
    pub airspeed: ChipHealth,
    /// α vane.
    pub alpha_vane: ChipHealth,
    /// β vane.
    pub beta_vane: ChipHealth,
    /// Samples with a surface, the throttle, the RPM or the attitude missing or stale.
    pub autopilot_faults: u32,
    /// The autopilot link.
    pub link: LinkHealth,
    /// Channels stuck at the last sample.
    pub stuck_now: ChannelMask,
    /// Times a channel became stuck, all channels (`StuckHealth::episodes` summed).
    pub stuck_episodes: u32,
    /// Samples with a channel stuck, summed over the channels (`StuckHealth::samples`).
    pub stuck_samples: u32,
}

/// The counts of the sampling task and the estimator that go into a health report beside the
/// sensors'.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleCounts<'a> {
    /// Samples taken.
    pub sampled: u32,
    /// Samples dropped (the estimator's queue full).
    pub dropped: u32,
    /// The sequence check's counters (gaps, missed, stale).
    pub sequence: SequenceHealth,
    /// Channels invalid in the last processed sample.
    pub invalid_now: ChannelMask,
    /// Samples with each channel invalid (the pipeline's `Health::invalid_channel`).
    pub invalid_channel: &'a [u32; channel::COUNT],
}

/// The health report the firmware sends (its slots in [`slot`]) from the sensors' health and the
/// sample counts.
#[inline]
pub fn health_report(h: &SensorHealth, counts: &SampleCounts<'_>) -> HealthReport {
    let mut r = HealthReport::default();
    let v = &mut r.values;
    let seq = &counts.sequence;
    let chips: [(&ChipHealth, usize, usize); 4] = [
        (&h.imu, slot::IMU_FAULTS, slot::IMU_REINITS),
        (&h.airspeed, slot::AIRSPEED_FAULTS, slot::AIRSPEED_REINITS),
        (&h.alpha_vane, slot::ALPHA_FAULTS, slot::ALPHA_REINITS),
        (&h.beta_vane, slot::BETA_FAULTS, slot::BETA_REINITS),
    ];
    v[slot::SAMPLED] = counts.sampled;
    v[slot::DROPPED] = counts.dropped;
    v[slot::GAPS] = seq.gaps;
    v[slot::MISSED] = seq.missed;
    v[slot::STALE] = seq.stale;
    for (c, faults, reinits) in chips {
        if let Some(o) = v.get_mut(faults) {
            *o = c.faults;
        }
        if let Some(o) = v.get_mut(reinits) {
            *o = c.reinits;
        }
    }
    v[slot::AUTOPILOT_FAULTS] = h.autopilot_faults;
    v[slot::STUCK_NOW] = u32::from(h.stuck_now);
    v[slot::STUCK_EPISODES] = h.stuck_episodes;
    v[slot::STUCK_SAMPLES] = h.stuck_samples;
    v[slot::LINK_FRAMES] = h.link.frames;
    v[slot::LINK_REJECTED] = h.link.rejected;
    v[slot::LINK_DISCARDED] = h.link.discarded;
    v[slot::LINK_LOST] = h.link.lost;
    v[slot::LINK_NOT_NEWER] = h.link.not_newer;
    v[slot::INVALID_NOW] = u32::from(counts.invalid_now);
    for (o, c) in v[slot::INVALID..slot::INVALID + channel::COUNT]
        .iter_mut()
        .zip(counts.invalid_channel.iter())
    {
        *o = *c;
    }
    r
}
