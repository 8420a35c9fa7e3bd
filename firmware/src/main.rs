//! aerosid firmware: RTIC 2 wiring for the STM32F405 (Cortex-M4F, 168 MHz).
//!
//! A sample flows one way, through a bounded channel:
//!
//! | task | priority | does |
//! |---|---|---|
//! | `sample` | 3 (highest) | every 10 ms (100 Hz): timestamps a sample and `try_send`s it; never blocks |
//! | `estimate` | 2 | receives each sample and runs [`estimate::step`] on it, timed with DWT CYCCNT |
//! | `telemetry` | 1 | once per second: reports the counters ([`telemetry::Stats`]) |
//! | `idle` | — | sleeps in WFI |
//!
//! If the estimator falls behind, the channel fills and `sample` drops (and counts) samples instead
//! of waiting: the sampling period never slips. This file is wiring only; the bodies live in
//! [`board`], [`sample`], [`estimate`] and [`telemetry`].
//!
//! On the host (`target_os` other than `"none"`) the crate compiles to a stub `fn main() {}`, so
//! `cargo build --workspace` works on x86_64; build the firmware with `cargo fw-build`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod board;
#[cfg(target_os = "none")]
mod estimate;
#[cfg(target_os = "none")]
mod sample;
#[cfg(target_os = "none")]
mod telemetry;

#[cfg(target_os = "none")]
use defmt_rtt as _;
#[cfg(target_os = "none")]
use panic_probe as _;

/// Host stub: the firmware only exists for `thumbv7em-none-eabihf`.
#[cfg(not(target_os = "none"))]
fn main() {}

// Dispatchers: interrupts of peripherals this board does not use (FSMC is not bonded out on the
// 64-pin STM32F405RG; CAN2 is unused). One per software-task priority level.
#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4::stm32f405, peripherals = true, dispatchers = [FSMC, CAN2_RX1, CAN2_SCE])]
mod app {
    use crate::{board, sample::Sample, sample::Sampler, telemetry::Stats};
    use cortex_m::peripheral::DWT;
    use rtic_monotonics::systick::prelude::*;
    use rtic_sync::{
        channel::{Receiver, Sender},
        make_channel,
    };

    // SysTick monotonic at 1 kHz: 1 ms ticks. Its 32-bit tick count covers 49.7 days of uptime.
    // (A literal: the macro needs the rate both as a `u32` and as a `u64` const generic.)
    systick_monotonic!(Mono, 1_000);

    /// Sampling period: 100 Hz.
    const SAMPLE_PERIOD_MS: u32 = 10;
    /// Telemetry period: 1 Hz.
    const TELEMETRY_PERIOD_MS: u32 = 1_000;
    /// Samples the channel holds: 80 ms of slack for the estimator before samples are dropped.
    const SAMPLE_QUEUE: usize = 8;

    /// µs per monotonic tick (1 kHz).
    const US_PER_TICK: u64 = 1_000;

    // defmt timestamps, ms since boot (0 until the monotonic starts).
    defmt::timestamp!("{=u32:ms}", Mono::now().duration_since_epoch().as_ticks());

    #[shared]
    struct Shared {
        stats: Stats,
    }

    #[local]
    struct Local {
        tx: Sender<'static, Sample, SAMPLE_QUEUE>,
        rx: Receiver<'static, Sample, SAMPLE_QUEUE>,
        sampler: Sampler,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut core = cx.core;

        let clocks = board::init_clocks(&dp.RCC, &dp.FLASH, &dp.PWR);
        board::keep_debug_in_sleep(&dp.DBGMCU, &dp.RCC);
        board::enable_cycle_counter(&mut core.DCB, &mut core.DWT);
        Mono::start(core.SYST, clocks.sysclk_hz);

        defmt::info!(
            "aerosid-firmware {=str}, aerosid-core {=str}; clocks {}",
            env!("CARGO_PKG_VERSION"),
            aerosid_core::VERSION,
            clocks
        );
        if clocks.source != board::ClockSource::HsePll {
            defmt::warn!("clock tree not on the crystal PLL: timing is less accurate");
        }

        let (tx, rx) = make_channel!(Sample, SAMPLE_QUEUE);

        // Each task is spawned exactly once, here, so these cannot fail; check anyway.
        if sample::spawn().is_err() || estimate::spawn().is_err() || telemetry::spawn().is_err() {
            defmt::error!("init: a task was already running");
        }

        (
            Shared {
                stats: Stats::default(),
            },
            Local {
                tx,
                rx,
                sampler: Sampler::default(),
            },
        )
    }

    /// Sleeps until an interrupt; the tasks do all the work.
    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// 100 Hz: timestamp, push, nothing else. A full channel drops the sample (counted), never waits.
    #[task(priority = 3, local = [tx, sampler], shared = [stats])]
    async fn sample(mut cx: sample::Context) {
        let nominal_dt_s = SAMPLE_PERIOD_MS as f32 * 1e-3;
        let mut next = Mono::now();
        loop {
            let t_us = u64::from(Mono::now().duration_since_epoch().as_ticks()) * US_PER_TICK;
            let sample = cx.local.sampler.take(t_us, nominal_dt_s);
            let queued = cx.local.tx.try_send(sample).is_ok();
            cx.shared.stats.lock(|stats| stats.record_sample(queued));

            next += SAMPLE_PERIOD_MS.millis();
            Mono::delay_until(next).await;
        }
    }

    /// Runs the estimator on every sample, timing each step in core cycles.
    #[task(priority = 2, local = [rx], shared = [stats])]
    async fn estimate(mut cx: estimate::Context) {
        while let Ok(sample) = cx.local.rx.recv().await {
            let start = DWT::cycle_count();
            let result = crate::estimate::step(&sample);
            let cycles = DWT::cycle_count().wrapping_sub(start);
            cx.shared.stats.lock(|stats| stats.record_step(result, cycles));
        }
        defmt::error!("estimate: sample channel closed");
    }

    /// 1 Hz: reports a copy of the counters (the lock is held only for the copy).
    #[task(priority = 1, shared = [stats])]
    async fn telemetry(mut cx: telemetry::Context) {
        let mut next = Mono::now();
        loop {
            next += TELEMETRY_PERIOD_MS.millis();
            Mono::delay_until(next).await;
            let stats = cx.shared.stats.lock(|stats| *stats);
            crate::telemetry::report(&stats);
        }
    }
}
