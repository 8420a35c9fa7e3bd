//! Counters shared by the tasks, and the telemetry frames the low-priority `telemetry` task sends.
//!
//! Link: MAVLink 2 on the telemetry UART (layout in `aerosid_core::mavlink`), transmit-only (the
//! co-processor accepts no commands). Every [`REPORT_PERIOD_MS`]: the six coefficient reports
//! (`DEBUG_FLOAT_ARRAY` "CL" … "Cn": θ, σ, k, λ_F, health, refused) and a `NAMED_VALUE_FLOAT` set
//! of counters; every second a `HEARTBEAT`. At 57 600 baud that is 2 × (600 + 5 × 30) + 21 ≈ 1.3 kB/s
//! of the 5.76 kB/s link (`stack_hw` is the stack high-water mark in bytes).

use crate::board::{SensorFaults, TelemetryPort};
use crate::estimate::{StepCost, PROBES};
use aerosid_core::aero::Pipeline;
use aerosid_core::mavlink::{frame::MAV_COMP_ID_ONBOARD_COMPUTER, telemetry::reports, Telemetry};

/// Coefficient reports every 500 ms (2 Hz).
pub const REPORT_PERIOD_MS: u32 = 500;
/// MAVLink system id (the autopilot's, so ground stations group the co-processor with it).
pub const SYSTEM_ID: u8 = 1;

/// What the tasks count; the `telemetry` task reports a copy. Counters saturate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct Stats {
    /// Samples taken by the `sample` task.
    pub sampled: u32,
    /// Samples dropped because the channel to `estimate` was full (the estimator fell behind).
    pub dropped: u32,
    /// Samples the estimator processed.
    pub estimated: u32,
    /// Coefficient updates (up to six per sample).
    pub updates: u32,
    /// Cost of the last step (counter ticks per stage).
    pub last: StepCost,
    /// Most ticks of one whole step since boot.
    pub max_step_ticks: u32,
    /// Failed sensor reads.
    pub faults: SensorFaults,
}

impl Stats {
    /// Counts one sample taken, and whether it made it into the channel.
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
}

/// The telemetry writer: the MAVLink encoder and a frame buffer.
pub struct Link {
    mav: Telemetry,
    buf: [u8; 640],
    reports_sent: u32,
}

impl Default for Link {
    fn default() -> Self {
        Self {
            mav: Telemetry::new(SYSTEM_ID, MAV_COMP_ID_ONBOARD_COMPUTER),
            buf: [0; 640],
            reports_sent: 0,
        }
    }
}

impl Link {
    /// Sends the six coefficient reports of `pipeline` and the counters, and every second report
    /// period a heartbeat.
    pub fn send(&mut self, pipeline: &Pipeline<f32>, stats: &Stats, time_us: u64, port: &mut impl TelemetryPort) {
        let reports = reports(pipeline);
        match self.mav.coefficients(&reports, time_us, &mut self.buf) {
            Ok(n) => port.send(&self.buf[..n.min(self.buf.len())]),
            Err(e) => defmt::error!("telemetry: encode {}", e),
        }
        let ms = (time_us / 1000) as u32;
        let counters: [(&str, f32); 5] = [
            ("samples", stats.sampled as f32),
            ("dropped", stats.dropped as f32),
            ("updates", stats.updates as f32),
            ("step_max", stats.max_step_ticks as f32),
            ("stack_hw", crate::board::stack::high_water_bytes() as f32),
        ];
        for (name, value) in counters {
            if let Ok(n) = self.mav.named_value(name, value, ms, &mut self.buf) {
                port.send(&self.buf[..n.min(self.buf.len())]);
            }
        }
        if self.reports_sent.is_multiple_of(2) {
            if let Ok(n) = self.mav.heartbeat(MAV_STATE_ACTIVE, &mut self.buf) {
                port.send(&self.buf[..n.min(self.buf.len())]);
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
    }
}

/// `MAV_STATE_ACTIVE`.
const MAV_STATE_ACTIVE: u8 = 4;

#[cfg(feature = "qemu")]
/// Logs the final estimates with their `f32` bit patterns (for exact comparison on the host).
pub fn log_estimates(pipeline: &Pipeline<f32>) {
    for r in reports(pipeline) {
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
const _: () = assert!(PROBES == 8);
