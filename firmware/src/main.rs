//! aerosid firmware: RTIC 2 wiring for the STM32F405 (Cortex-M4F, 168 MHz).
//!
//! A sample flows one way, through a bounded queue:
//!
//! | task | priority | does |
//! |---|---|---|
//! | `sample` | 3 (highest) | every 10 ms (100 Hz): reads the sensors (`board::SensorSource`), timestamps, queues; never blocks |
//! | `estimate` | 2 | runs the six-coefficient pipeline on each queued sample where it lies (`estimate.rs`), timed stage by stage |
//! | `telemetry` | 1 | every 500 ms: MAVLink coefficient reports, counters, heartbeat (`telemetry.rs`) |
//! | `usart2` | 4 (hardware, flight computer only) | each byte from the autopilot into the board's ring (`board/`) |
//! | `idle` | — | sleeps in WFI |
//!
//! The samples wait in a lock-free single-producer single-consumer queue (`heapless::spsc`) that
//! the estimate task reads in place; an rtic-sync channel of one-byte tokens, one per queued
//! sample, wakes it. (A channel carrying the 104-byte samples themselves costs ≈ 1 900
//! instructions per sample of `memcpy` across the two tasks: rtic-sync copies a value into its
//! slot, out of it and out of the `recv` future.) A token is sent before its sample is
//! queued, and the sampling task, above the estimate task, does both without yielding, so a
//! received token always finds its sample: the queue holds at most the channel's tokens plus the
//! sample being processed. If the estimator falls behind, the channel fills and `sample` drops (and
//! counts) samples instead of waiting: the sampling period never slips. Under the `qemu` feature
//! the board replays a log
//! instead of reading sensors (`board/`): `sample` then waits for room in the channel (a replay
//! must not drop samples) and does not wait for the period, and the end of the log ends the run
//! with a final report and QEMU's exit status. This file is wiring only.
//!
//! On the host (`target_os` other than `"none"`) the crate compiles to a stub `fn main() {}`, so
//! `cargo build --workspace` works on x86_64; build the firmware with `cargo fw-build`.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]
// No panic path of ours (docs/reliability.md; the release image is audited by `aerosid
// panic-audit`): the core's denials, and no slice indexing that could fail.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

#[cfg(target_os = "none")]
mod board;
#[cfg(target_os = "none")]
mod estimate;
#[cfg(target_os = "none")]
mod sample;
#[cfg(target_os = "none")]
mod telemetry;

#[cfg(all(target_os = "none", not(feature = "qemu")))]
use defmt_rtt as _;
#[cfg(all(target_os = "none", feature = "qemu"))]
use defmt_semihosting as _;
// Under QEMU the `semihosting` crate's panic handler prints the message and exits with status 101.

/// The flight computer's panic handler (none is expected: `aerosid panic-audit` lists every panic
/// path left in the image, firmware/panic-allow.txt): logs where over defmt, then stops at a
/// permanent `udf` with the interrupts off, as panic-probe does (a debugger or probe-rs sees the
/// fault). panic-probe's `print-defmt` printed the message through `core::fmt`, 2 KB of flash for
/// its formatting machinery (the 128 KiB STM32F4 parts are the flash goal); the source location
/// needs none of it and says where to look.
#[cfg(all(target_os = "none", not(feature = "qemu")))]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    match info.location() {
        Some(at) => defmt::error!("panicked at {=str}:{=u32}", at.file(), at.line()),
        None => defmt::error!("panicked"),
    }
    cortex_m::asm::udf()
}

/// Host stub: the firmware only exists for `thumbv7em-none-eabihf`.
#[cfg(not(target_os = "none"))]
fn main() {}

// Dispatchers: interrupts of peripherals this board does not use (FSMC is not bonded out on the
// 64-pin STM32F405RG; CAN2 is unused). One per software-task priority level.
#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4::stm32f405, peripherals = true, dispatchers = [FSMC, CAN2_RX1, CAN2_SCE])]
mod app {
    use crate::board::{self, SensorSource};
    use crate::estimate::Estimator;
    use crate::sample::{Sample, Sampler};
    use crate::telemetry::{Link, Part, Stats, REPORT_PERIOD_MS};
    use heapless::spsc::{Consumer, Producer, Queue};
    use rtic_monotonics::systick::prelude::*;
    use rtic_sync::{
        channel::{Receiver, Sender},
        make_channel,
    };

    // SysTick monotonic at 1 kHz: 1 ms ticks. Its 32-bit tick count covers 49.7 days of uptime.
    systick_monotonic!(Mono, 1_000);

    /// Sampling period: 100 Hz.
    const SAMPLE_PERIOD_MS: u32 = 10;
    /// Tokens the channel holds (all four: rtic-sync's channel keeps no slot free), so samples
    /// queued and not yet taken up: 40 ms of slack for the estimator before samples are dropped.
    /// What holds the estimator back is its own step (≤ 42 877 instructions on the replay, 44 838
    /// on the fault run) and one telemetry encoding under the estimator lock (`lock_max`,
    /// ≤ 15 456): together ≈ 1.1 ms at 168 MHz even at 3 cycles per
    /// instruction (docs/performance.md).
    const SAMPLE_QUEUE: usize = 4;
    /// Slots of the sample queue: the channel's tokens, the sample being processed, and the one
    /// slot `heapless::spsc::Queue` keeps free.
    const SAMPLE_SLOTS: usize = SAMPLE_QUEUE + 2;
    /// µs per monotonic tick (1 kHz).
    const US_PER_TICK: u64 = 1_000;

    /// What the `sample` task sends: a sample was queued, or the replay ended.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Msg {
        /// The next sample is in the queue.
        Sample,
        /// The sensor source ended (replay only).
        End,
    }

    defmt::timestamp!("{=u32:ms}", Mono::now().duration_since_epoch().as_ticks());

    #[shared]
    struct Shared {
        stats: Stats,
        estimator: Estimator,
        out: Out,
    }

    /// The telemetry UART and its MAVLink writer (shared by the periodic and the final report).
    pub struct Out {
        port: board::Port,
        link: Link,
    }

    #[local]
    struct Local {
        tx: Sender<'static, Msg, SAMPLE_QUEUE>,
        rx: Receiver<'static, Msg, SAMPLE_QUEUE>,
        queue_in: Producer<'static, Sample>,
        queue_out: Consumer<'static, Sample>,
        sampler: Sampler,
        sensors: board::Sensors,
        counts: board::CountLog,
        #[cfg(not(feature = "qemu"))]
        autopilot_rx: board::AutopilotRx,
    }

    #[init(local = [
        pipeline: aerosid_core::aero::Pipeline<f32> = aerosid_core::aero::Pipeline::PLACEHOLDER,
        step: aerosid_core::aero::PipelineStep<f32> = aerosid_core::aero::PipelineStep::WARMUP,
        frames: [u8; crate::telemetry::FRAME_BUFFER] = [0; crate::telemetry::FRAME_BUFFER],
        queue: Queue<Sample, SAMPLE_SLOTS> = Queue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        board::stack::paint();
        let mut core = cx.core;
        let clocks = board::clocks::init_clocks(&cx.device.RCC, &cx.device.FLASH, &cx.device.PWR);
        board::clocks::keep_debug_in_sleep(&cx.device.DBGMCU, &cx.device.RCC);
        board::clocks::enable_cycle_counter(&mut core.DCB, &mut core.DWT);
        Mono::start(core.SYST, clocks.sysclk_hz);
        defmt::info!(
            "aerosid-firmware {=str}, aerosid-core {=str}; clocks {}",
            env!("CARGO_PKG_VERSION"),
            aerosid_core::VERSION,
            clocks
        );
        let b = board::init(cx.device, &clocks);

        let estimator = match Estimator::new(cx.local.pipeline, cx.local.step, b.counter) {
            Ok(e) => e,
            Err(e) => {
                // A configuration error is a build defect; stop here, visibly.
                defmt::error!("init: estimator configuration refused: {}", e);
                board::halt(2)
            }
        };
        let (tx, rx) = make_channel!(Msg, SAMPLE_QUEUE);
        let (queue_in, queue_out) = cx.local.queue.split();
        if sample::spawn().is_err() || estimate::spawn().is_err() || telemetry::spawn().is_err() {
            defmt::error!("init: a task was already running");
        }
        (
            Shared {
                stats: Stats::default(),
                estimator,
                out: Out {
                    port: b.telemetry,
                    link: Link::new(cx.local.frames),
                },
            },
            Local {
                tx,
                rx,
                queue_in,
                queue_out,
                sampler: Sampler::default(),
                sensors: b.sensors,
                counts: b.counts,
                #[cfg(not(feature = "qemu"))]
                autopilot_rx: b.autopilot_rx,
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

    /// 100 Hz: read, timestamp, queue. A full channel drops the sample (counted), never waits.
    #[task(priority = 3, local = [tx, queue_in, sampler, sensors], shared = [stats])]
    async fn sample(mut cx: sample::Context) {
        let nominal_dt_s = SAMPLE_PERIOD_MS as f32 * 1e-3;
        let mut next = Mono::now();
        loop {
            let now_us = u64::from(Mono::now().duration_since_epoch().as_ticks()) * US_PER_TICK;
            let (t_s, dt_s) = cx.local.sampler.stamp(now_us, nominal_dt_s);
            let Some(sensors) = cx.local.sensors.read(t_s, dt_s) else {
                let _ = cx.local.tx.send(Msg::End).await;
                return;
            };
            let t_us = cx.local.sensors.time_us(now_us);
            let seq = cx.local.sampler.next_seq();
            // Fault injection exists on the QEMU board only.
            #[cfg(feature = "qemu")]
            let injected_drop = cx.local.sensors.drop_injected();
            #[cfg(not(feature = "qemu"))]
            let injected_drop = false;
            let queued = if injected_drop {
                false
            } else {
                // The token first, then (no yield between: the estimate task cannot run) the
                // sample; with room for a token there is room for its sample (`SAMPLE_SLOTS`).
                #[cfg(feature = "qemu")]
                let token = cx.local.tx.send(Msg::Sample).await.is_ok();
                #[cfg(not(feature = "qemu"))]
                let token = cx.local.tx.try_send(Msg::Sample).is_ok();
                // Built in the call (a `Sample` bound first was one more 104-byte copy).
                token && cx.local.queue_in.enqueue(Sample { seq, t_us, sensors }).is_ok()
            };
            cx.shared.stats.lock(|stats| {
                stats.record_sample(queued);
                // Written in place (a local copy first cost one more 80-byte `memcpy` per sample).
                stats.sensors = cx.local.sensors.health();
            });
            #[cfg(not(feature = "qemu"))]
            {
                next += SAMPLE_PERIOD_MS.millis();
                Mono::delay_until(next).await;
            }
            #[cfg(feature = "qemu")]
            let _ = &mut next;
        }
    }

    /// USART2 receive interrupt: the autopilot's MAVLink bytes into the board's ring (a few dozen
    /// cycles; above `sample`, so no byte is lost while the sensors are read).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = USART2, priority = 4, local = [autopilot_rx])]
    fn usart2(cx: usart2::Context) {
        cx.local.autopilot_rx.on_interrupt();
    }

    /// Runs the estimator on every sample, timing each stage with the board's counter.
    #[task(priority = 2, local = [rx, queue_out, counts], shared = [stats, estimator])]
    async fn estimate(mut cx: estimate::Context) {
        while let Ok(msg) = cx.local.rx.recv().await {
            match msg {
                Msg::Sample => {
                    // Read in place, removed once processed. (Were the queue ever to refuse a sample
                    // whose token went out — `SAMPLE_SLOTS` rules it out — the tokens would run one
                    // ahead: each sample still processed once and in order, the last token finding
                    // the queue empty.)
                    let queue = &mut *cx.local.queue_out;
                    if let Some(sample) = queue.peek() {
                        if let Some((updated, cost)) = cx.shared.estimator.lock(|e| e.step(sample)) {
                            cx.shared.stats.lock(|stats| stats.record_step(updated, cost));
                            cx.local.counts.write(&cost.ticks);
                        }
                        let _ = queue.dequeue();
                    }
                }
                Msg::End => {
                    #[cfg(feature = "qemu")]
                    {
                        let stats = cx.shared.stats.lock(|s| *s);
                        cx.shared
                            .estimator
                            .lock(|e| crate::telemetry::log_estimates(e.pipeline()));
                        defmt::info!(
                            "replay done: {} samples, {} updates, stack high water {=u32} B",
                            stats.estimated,
                            stats.updates,
                            board::stack::high_water_bytes()
                        );
                        if final_report::spawn().is_err() {
                            board::halt(3);
                        }
                    }
                    return;
                }
            }
        }
    }

    /// Every [`REPORT_PERIOD_MS`]: the MAVLink reports (the pipeline is locked only to read it).
    #[task(priority = 1, shared = [stats, estimator, out])]
    async fn telemetry(mut cx: telemetry::Context) {
        let mut next = Mono::now();
        loop {
            next += REPORT_PERIOD_MS.millis();
            Mono::delay_until(next).await;
            report(&mut cx.shared.estimator, &mut cx.shared.out, &mut cx.shared.stats);
        }
    }

    /// One report period, stamped now, of a copy of the statistics: each part encoded with the
    /// estimator locked (no I/O under the lock, so the estimate task waits only for the encoding),
    /// then sent with the lock released. How long the lock was held (counter ticks) goes into the
    /// shared statistics and into the copy, so the counters part (sent last) includes this
    /// period's other parts; its own hold (it needs no estimator, but encoded outside the lock its
    /// frame would sit under the estimate task's: +336 B of stack bound) counts from the next
    /// period on. The stack high-water scan, ≈ 175 000 instructions, runs before any lock is taken
    /// (inside the counters part it made `lock_max` 184 981 on the replay's second period).
    fn report(
        estimator: &mut impl rtic::Mutex<T = Estimator>,
        out: &mut impl rtic::Mutex<T = Out>,
        shared_stats: &mut impl rtic::Mutex<T = Stats>,
    ) {
        // Before any other lock: the scan is long (`Stats::stack_hw_bytes`).
        let stack_hw_bytes = board::stack::high_water_bytes();
        let mut stats = shared_stats.lock(|s| {
            s.stack_hw_bytes = stack_hw_bytes;
            *s
        });
        let t_us = u64::from(Mono::now().duration_since_epoch().as_ticks()) * US_PER_TICK;
        for part in Part::ALL {
            let (n, held) = estimator.lock(|e| {
                out.lock(|o| {
                    let start = e.now();
                    let n = o.link.encode(part, e, &stats, t_us);
                    (n, e.now().wrapping_sub(start))
                })
            });
            stats.record_lock(held);
            shared_stats.lock(|s| s.record_lock(held));
            out.lock(|o| o.link.transmit(n, &mut o.port));
        }
    }

    /// The end of a replay: two last report periods, then QEMU exits with status 0. Two, because a
    /// period's counters part reports the lock holds of the parts before it: the second period's
    /// `lock_max` covers every part of the first, the counters part included (the replay keeps
    /// the estimate task busy, so no periodic report runs before the end).
    #[cfg(feature = "qemu")]
    #[task(priority = 1, shared = [stats, estimator, out])]
    async fn final_report(mut cx: final_report::Context) {
        report(&mut cx.shared.estimator, &mut cx.shared.out, &mut cx.shared.stats);
        report(&mut cx.shared.estimator, &mut cx.shared.out, &mut cx.shared.stats);
        board::halt(0)
    }
}
