//! The flight computer's board: the sensors on their buses, the telemetry UART, the DWT counter.
//!
//! Provisional: the drivers (`aerosid_core::drivers`) are not wired to the STM32F405's SPI/I2C yet;
//! until they are, every channel reads NaN (counted as a fault), so the pipeline refuses every
//! coefficient and the telemetry says so.

use super::{Counter, SensorFaults, SensorSource, TelemetryPort};
use aerosid_core::aero::SensorSample;
use stm32f4::stm32f405 as pac;

/// The sensors of this board.
pub type Sensors = Unwired;
/// The telemetry port of this board.
pub type Port = NoPort;
/// The step counter of this board.
pub type CycleCounter = Dwt;

/// The board's parts, handed to the tasks by `init`.
pub struct Board {
    /// Sensors.
    pub sensors: Unwired,
    /// Telemetry UART.
    pub telemetry: NoPort,
    /// DWT cycle counter.
    pub counter: Dwt,
    /// Per-sample counts (not recorded on hardware: the telemetry carries the last and the worst).
    pub counts: CountLog,
}

/// Per-sample counts: not recorded on hardware.
pub struct CountLog;

impl CountLog {
    /// Discards one sample's counts.
    pub fn write(&mut self, _counts: &[u32]) {}
}

/// Brings up the board.
pub fn init(_dp: pac::Peripherals, _clocks: &super::clocks::Clocks) -> Board {
    Board {
        sensors: Unwired {
            faults: SensorFaults::default(),
        },
        telemetry: NoPort,
        counter: Dwt,
        counts: CountLog,
    }
}

/// Sensors not yet wired: every read is a fault.
pub struct Unwired {
    faults: SensorFaults,
}

impl SensorSource for Unwired {
    fn read(&mut self, t_s: f32, dt_s: f32) -> Option<SensorSample<f32>> {
        self.faults.imu = self.faults.imu.saturating_add(1);
        let nan = f32::NAN;
        let mut s = SensorSample::from_fields(&[nan; aerosid_core::aero::SAMPLE_FIELDS]);
        s.t_s = t_s;
        s.dt_s = dt_s;
        Some(s)
    }

    fn faults(&self) -> SensorFaults {
        self.faults
    }
}

/// No telemetry UART yet.
pub struct NoPort;

impl TelemetryPort for NoPort {
    fn send(&mut self, _bytes: &[u8]) {}
}

/// DWT CYCCNT (started in `init`).
pub struct Dwt;

impl Counter for Dwt {
    fn now(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}

/// Stops: on hardware there is no exit; breakpoint for an attached probe, then sleep forever.
pub fn halt(_code: i32) -> ! {
    cortex_m::asm::bkpt();
    loop {
        cortex_m::asm::wfi();
    }
}
