//! The board layer: everything that differs between the flight computer and its QEMU stand-in.
//!
//! The application (`main.rs`, [`crate::estimate`], [`crate::telemetry`]) sees only three things:
//! a [`SensorSource`] that yields one [`SensorSample`] per sampling period, a [`TelemetryPort`] that
//! sends bytes, and a [`Counter`] that times the estimator. Two boards provide them:
//!
//! | board | feature | sensors | telemetry | counter |
//! |---|---|---|---|---|
//! | [`hw`] (STM32F405 flight computer) | default | ICM-42688-P (SPI1), MS4525DO + α vane (I2C1), β vane (I2C2), surfaces/RPM from the autopilot (MAVLink on USART2) | MAVLink on USART1 | DWT cycles |
//! | [`qemu`] (`netduinoplus2`) | `qemu` | a binary replay log read over semihosting | MAVLink on USART1 (QEMU `-serial`) | TIM2 instructions (`-icount shift=0`) |
//!
//! Swapping the board swaps nothing else: the same tasks, channel, pipeline and telemetry run.

pub mod clocks;
#[cfg(not(feature = "qemu"))]
pub mod hw;
#[cfg(feature = "qemu")]
pub mod qemu;
pub mod stack;

#[cfg(not(feature = "qemu"))]
pub use hw::{halt, init, AutopilotRx, CountLog, CycleCounter, Port, Sensors};
#[cfg(feature = "qemu")]
pub use qemu::{halt, init, CountLog, CycleCounter, Port, Sensors};
/// No autopilot link under QEMU. The RTIC macro names a `#[cfg]`-gated local resource's type even
/// where the resource is configured out, so the name must resolve; the type has no values.
#[cfg(feature = "qemu")]
pub enum AutopilotRx {}

use aerosid_core::aero::model::ChannelMask;
use aerosid_core::aero::{SensorSample, StuckDetector};
use aerosid_core::mavlink::MavlinkSurfaces;

/// Where samples come from.
pub trait SensorSource {
    /// Reads every sensor once for the sampling instant `t_s` (s since boot) with `dt_s` since the
    /// previous sample. A channel whose sensor failed (bus error, stale, out of range, stuck) is
    /// NaN — never a stale or invented value — so the pipeline refuses exactly the coefficients
    /// that need it. `None` when the source has ended (the end of a replay log; never on
    /// hardware).
    fn read(&mut self, t_s: f32, dt_s: f32) -> Option<SensorSample<f32>>;

    /// Failed reads, re-initialisations and stuck channels since boot, for the telemetry health
    /// report.
    fn health(&self) -> SensorHealth;

    /// The time stamp of the sample last read, µs since boot, on the clock its `dt_s` was measured
    /// with: the sampler's (`sampler_us`) on hardware; the log's own under QEMU, where the log's
    /// `t_s`, `dt_s` stand.
    fn time_us(&self, sampler_us: u64) -> u64 {
        sampler_us
    }

    /// Fault injection (QEMU board only; never on hardware): the sample just read is to be dropped
    /// as if the estimator's queue were full.
    fn drop_injected(&self) -> bool {
        false
    }
}

pub use aerosid_core::harness::REINIT_AFTER;

/// The read outcomes of one chip.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
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

/// The last stage of every board's `read`: the stuck-sensor check on the finished sample
/// ([`StuckDetector`], windows of [`aerosid_core::aero::onboard::stuck_settings`]).
pub struct Finish {
    detector: StuckDetector,
}

impl Finish {
    /// A check with no history.
    pub fn new() -> Self {
        Self {
            detector: StuckDetector::new(aerosid_core::aero::onboard::stuck_settings()),
        }
    }

    /// Sets every stuck channel of `s` to NaN and records it in `health`.
    #[inline(never)]
    pub fn apply(&mut self, s: &mut SensorSample<f32>, health: &mut SensorHealth) {
        let stuck = self.detector.apply(s);
        if stuck & !health.stuck_now != 0 {
            defmt::warn!("sensors: channels {=u16:#x} stuck", stuck & !health.stuck_now);
        }
        health.stuck_now = stuck;
        let sum = |v: &[u32]| v.iter().fold(0u32, |a, e| a.saturating_add(*e));
        health.stuck_episodes = sum(&self.detector.health().episodes);
        health.stuck_samples = sum(&self.detector.health().samples);
    }
}

/// Where telemetry bytes go (a UART).
pub trait TelemetryPort {
    /// Sends `bytes`; blocks only for the time the UART needs to take them.
    fn send(&mut self, bytes: &[u8]);
}

/// A free-running 32-bit counter for timing the estimator: DWT cycles on hardware, TIM2
/// instructions under QEMU. Differences with `wrapping_sub`.
pub trait Counter {
    /// The counter now.
    fn now(&self) -> u32;
}
