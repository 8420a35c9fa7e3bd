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

use aerosid_core::aero::{SensorSample, StuckDetector};

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
}

// The chips' and the link's counters are the core's: the host's model of this firmware
// (`aerosid_qemu::emulate`) counts with the same types.
pub use aerosid_core::harness::{LinkHealth, SensorHealth, REINIT_AFTER};

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
