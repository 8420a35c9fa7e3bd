//! Counters shared by the tasks, and the telemetry frames the low-priority `telemetry` task sends.
//!
//! Link: MAVLink 2 on the telemetry UART (layout in `aerosid_core::mavlink`), transmit-only: the
//! firmware never reads USART1 (its receiver is not even enabled) and accepts no command on any
//! link, so nothing received can reset an estimator or change a setting; the only input link is
//! the autopilot's actuator stream on USART2 (`board`). Every [`REPORT_PERIOD_MS`]: the six
//! coefficient reports (`DEBUG_FLOAT_ARRAY` "CL" … "Cn": θ, σ, k, λ_F, health, refused), the
//! health report (`DEBUG_FLOAT_ARRAY` "health", id 100: sample, sensor, stuck-channel and link
//! counters, layout `aerosid_core::mavlink::telemetry::health_slot`) and a `NAMED_VALUE_FLOAT` set
//! of counters; every second a `HEARTBEAT`. At 57 600 baud that is 2 × (600 + 164 + 6 × 30) + 21
//! ≈ 1.91 kB/s of the 5.76 kB/s link (`stack_hw` is the stack high-water mark in bytes, `step_max`
//! and `lock_max` the longest estimator step and estimator-lock hold in counter ticks).

use crate::board::{SensorHealth, TelemetryPort};
use crate::estimate::{Estimator, StepCost, PROBES};
use aerosid_core::aero::model::idx;
use aerosid_core::aero::Pipeline;
use aerosid_core::harness::SampleCounts;
use aerosid_core::mavlink::frame::{CHECKSUM_LEN, HEADER_LEN_V2, MAV_COMP_ID_ONBOARD_COMPUTER};
use aerosid_core::mavlink::messages::{DebugFloatArray, Heartbeat, MavMessage, NamedValueFloat};
use aerosid_core::mavlink::telemetry::{report, HealthReport};
use aerosid_core::mavlink::Telemetry;

/// Coefficient reports every 500 ms (2 Hz).
pub const REPORT_PERIOD_MS: u32 = 500;
/// MAVLink system id (the autopilot's, so ground stations group the co-processor with it).
pub const SYSTEM_ID: u8 = 1;

/// What the tasks count; the `telemetry` task reports a copy. Counters saturate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct Stats {
    /// Samples taken by the `sample` task.
    pub sampled: u32,
    /// Samples dropped: the queue to `estimate` was full (the estimator fell behind), or a fault
    /// injected on the QEMU board dropped them.
    pub dropped: u32,
    /// Samples the estimator processed.
    pub estimated: u32,
    /// Coefficient updates (up to six per sample).
    pub updates: u32,
    /// Cost of the last step (counter ticks per stage).
    pub last: StepCost,
    /// Most ticks of one whole step since boot.
    pub max_step_ticks: u32,
    /// Most ticks the telemetry task held the estimator lock to encode one report part since boot
    /// (the estimate task waits at most this long for it).
    pub max_lock_ticks: u32,
    /// Failed sensor reads, re-initialisations, stuck channels, the autopilot link.
    pub sensors: SensorHealth,
    /// Stack high-water mark, bytes, as the telemetry task last read it — before it takes the
    /// estimator lock: the scan of the painted RAM is ≈ 175 000 instructions, and inside that lock,
    /// where the counters part is encoded, it held the estimate task off that long every period.
    pub stack_hw_bytes: u32,
}

impl Stats {
    /// Counts one sample taken, and whether it made it into the queue.
    pub fn record_sample(&mut self, queued: bool) {
        self.sampled = self.sampled.saturating_add(1);
        if !queued {
            self.dropped = self.dropped.saturating_add(1);
        }
    }

    /// Counts one estimator step.
    pub fn record_step(&mut self, updated: u8, cost: StepCost) {
        self.estimated = self.estimated.saturating_add(1);
        self.updates = self.updates.saturating_add(u32::from(updated));
        self.last = cost;
        self.max_step_ticks = self.max_step_ticks.max(cost.ticks[0]);
    }

    /// Counts how long (ticks) a report period held the estimator lock at most.
    pub fn record_lock(&mut self, ticks: u32) {
        self.max_lock_ticks = self.max_lock_ticks.max(ticks);
    }
}

/// The longest MAVLink 2 frame of a message (unsigned, untruncated).
const fn frame_len(spec_max_len: u8) -> usize {
    HEADER_LEN_V2 + spec_max_len as usize + CHECKSUM_LEN
}
/// Bytes of the frame buffer: one part of a report period ([`Part`]) at a time,
/// so the longest any part can be: a full, untruncated `DEBUG_FLOAT_ARRAY` (264 bytes; a
/// coefficient report is 100, the health report 164, the counters and heartbeat together 201).
pub const FRAME_BUFFER: usize = frame_len(<DebugFloatArray as MavMessage>::SPEC.max_len);
/// `NAMED_VALUE_FLOAT` counters per report period ([`Link::encode_counters`]).
const COUNTERS: usize = 6;
/// Bytes of the counters and the heartbeat at most (201).
const COUNTERS_PART: usize = COUNTERS * frame_len(<NamedValueFloat as MavMessage>::SPEC.max_len)
    + frame_len(<Heartbeat as MavMessage>::SPEC.max_len);
const _: () = assert!(COUNTERS_PART <= FRAME_BUFFER);

/// The telemetry writer: the MAVLink encoder and a frame buffer (a static of `init`: returned by
/// value in `Shared`, it would sit in `init`'s frame, which RTIC keeps under every task's first run).
pub struct Link {
    mav: Telemetry,
    buf: &'static mut [u8; FRAME_BUFFER],
    reports_sent: u32,
}

impl Link {
    /// A writer using `buf`.
    pub fn new(buf: &'static mut [u8; FRAME_BUFFER]) -> Self {
        Self {
            mav: Telemetry::new(SYSTEM_ID, MAV_COMP_ID_ONBOARD_COMPUTER),
            buf,
            reports_sent: 0,
        }
    }
}

/// The health report of `stats` and `estimator` ([`aerosid_core::harness::health_report`]).
pub fn health_report(stats: &Stats, estimator: &Estimator) -> HealthReport {
    let counts = SampleCounts {
        sampled: stats.sampled,
        dropped: stats.dropped,
        sequence: *estimator.sequence(),
        invalid_now: estimator.invalid_now(),
        invalid_channel: &estimator.pipeline().health().invalid_channel,
    };
    aerosid_core::harness::health_report(&stats.sensors, &counts)
}

/// One part of a report period ([`Link::encode`]): one frame buffer's worth, encoded under one
/// estimator lock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// The report of one coefficient, by [`idx`] (needs the estimator).
    Coefficient(usize),
    /// The health report (needs the estimator).
    Health,
    /// The counters and, every second period, a heartbeat (needs only the statistics).
    Counters,
}

impl Part {
    /// The parts of one report period, in the order they are sent: `C_L` … `C_n`, health, counters.
    pub const ALL: [Part; idx::COUNT + 2] = [
        Part::Coefficient(idx::LIFT),
        Part::Coefficient(idx::DRAG),
        Part::Coefficient(idx::SIDE),
        Part::Coefficient(idx::ROLL),
        Part::Coefficient(idx::PITCH),
        Part::Coefficient(idx::YAW),
        Part::Health,
        Part::Counters,
    ];
}

impl Link {
    /// Encodes one part of the report into the frame buffer and returns its length; no I/O. The
    /// caller holds the estimator lock only for this (its ceiling is the estimate task's
    /// priority), then sends the bytes with [`transmit`](Self::transmit) after releasing it: at
    /// 57 600 baud a 100-byte coefficient report takes 17 ms on the wire, the six 104 ms, during
    /// which a lock held would stall the estimate task past what the sample queue holds. Each
    /// part in its own (not inlined) function, so that the stack holds one part's frame at a time.
    pub fn encode(&mut self, part: Part, estimator: &Estimator, stats: &Stats, time_us: u64) -> usize {
        match part {
            Part::Coefficient(i) => self.encode_coefficient(estimator.pipeline(), i, time_us),
            Part::Health => self.encode_health(estimator, stats, time_us),
            Part::Counters => self.encode_counters(stats, time_us),
        }
    }

    /// Sends the first `n` bytes of the frame buffer (what [`encode`](Self::encode) returned).
    pub fn transmit(&self, n: usize, port: &mut impl TelemetryPort) {
        port.send(self.buf.get(..n).unwrap_or(&[]));
    }

    #[inline(never)]
    fn encode_coefficient(&mut self, pipeline: &Pipeline<f32>, coefficient: usize, time_us: u64) -> usize {
        let Some(r) = report(pipeline, coefficient) else {
            return 0;
        };
        self.mav
            .coefficient(&r, time_us, self.buf.as_mut_slice())
            .unwrap_or_else(|e| {
                defmt::error!("telemetry: encode {}", e);
                0
            })
    }

    #[inline(never)]
    fn encode_health(&mut self, estimator: &Estimator, stats: &Stats, time_us: u64) -> usize {
        let report = health_report(stats, estimator);
        self.mav
            .health(&report, time_us, self.buf.as_mut_slice())
            .unwrap_or_else(|e| {
                defmt::error!("telemetry: encode {}", e);
                0
            })
    }

    /// The [`COUNTERS`] counters as `NAMED_VALUE_FLOAT`s and every second period a heartbeat, one
    /// after the other in the buffer ([`COUNTERS_PART`] bytes at most, so every one fits).
    #[inline(never)]
    fn encode_counters(&mut self, stats: &Stats, time_us: u64) -> usize {
        let ms = (time_us / 1000) as u32;
        let counters: [(&str, f32); COUNTERS] = [
            ("samples", stats.sampled as f32),
            ("dropped", stats.dropped as f32),
            ("updates", stats.updates as f32),
            ("step_max", stats.max_step_ticks as f32),
            ("lock_max", stats.max_lock_ticks as f32),
            ("stack_hw", stats.stack_hw_bytes as f32),
        ];
        let mut n = 0;
        for (name, value) in counters {
            if let Some(rest) = self.buf.get_mut(n..) {
                if let Ok(k) = self.mav.named_value(name, value, ms, rest) {
                    n += k;
                }
            }
        }
        if self.reports_sent.is_multiple_of(2) {
            if let Some(rest) = self.buf.get_mut(n..) {
                if let Ok(k) = self.mav.heartbeat(MAV_STATE_ACTIVE, rest) {
                    n += k;
                }
            }
        }
        self.reports_sent = self.reports_sent.wrapping_add(1);
        defmt::info!(
            "telemetry: {} samples, {} dropped, {} updates, last step {} ticks (max {})",
            stats.sampled,
            stats.dropped,
            stats.updates,
            stats.last.ticks[0],
            stats.max_step_ticks
        );
        n
    }
}

/// `MAV_STATE_ACTIVE`.
const MAV_STATE_ACTIVE: u8 = 4;

#[cfg(feature = "qemu")]
/// Logs the final estimates with their `f32` bit patterns (for exact comparison on the host).
// Not inlined: built for size, its six report calls go through a register, an indirect call
// the static stack bound resolves by this function's name (firmware/stack-bound.txt).
#[inline(never)]
pub fn log_estimates(pipeline: &Pipeline<f32>) {
    for r in aerosid_core::mavlink::telemetry::reports(pipeline) {
        let n = usize::from(r.n_params).min(r.theta.len());
        defmt::info!(
            "estimate {=u8}: n {=usize}, k {=u8}, λ {=f32}, θ {}, bits {:08x}",
            r.coefficient,
            n,
            r.rank_k,
            r.lambda_f,
            r.theta,
            r.theta.map(f32::to_bits)
        );
    }
}

/// Unused probe count guard (keeps `PROBES` and the record layout in one place).
const _: () = assert!(PROBES == 9);
