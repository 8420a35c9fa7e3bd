//! The QEMU board (`netduinoplus2`, an emulated STM32F405): the same application, fed from a flight
//! log instead of sensors.
//!
//! * **Sensors**: `replay.bin` in QEMU's working directory, read over semihosting: binary records of
//!   [`REPLAY_RECORD_BYTES`] (the [`SensorSample`] fields as little-endian `f32`, CSV column order),
//!   written by the host from a CSV log (`aerosid replay-bin`). The end of the file ends the run.
//! * **Telemetry**: USART1's data register; QEMU's `-serial file:…` (or `stdio`) receives the bytes.
//!   QEMU's STM32F2xx USART model sends each byte written to DR at once and keeps TXE set.
//! * **Counter**: TIM2 free-running with PSC = 0, ARR = 2³² − 1. Under `-icount shift=0,align=off,
//!   sleep=off` it advances exactly one tick per guest instruction (TOOLCHAIN.md), so the estimator's
//!   cost is an instruction count, identical from run to run.
//! * **Per-sample counts**: `icount.bin`, one record per processed sample of
//!   [`crate::estimate::PROBES`] little-endian `u32` (whole step, synthesis, six coefficients),
//!   written over semihosting outside the timed region.

use super::{Counter, SensorFaults, SensorSource, TelemetryPort};
use aerosid_core::aero::{SensorSample, REPLAY_RECORD_BYTES};
use semihosting::fs::File;
use semihosting::io::{Read, Write};
use stm32f4::stm32f405 as pac;

/// The sensors of this board.
pub type Sensors = Replay;
/// The telemetry port of this board.
pub type Port = Usart;
/// The step counter of this board.
pub type CycleCounter = Tim2Counter;

/// The board's parts, handed to the tasks by `init`.
pub struct Board {
    /// The replay log.
    pub sensors: Replay,
    /// USART1.
    pub telemetry: Usart,
    /// TIM2.
    pub counter: Tim2Counter,
    /// Per-sample instruction counts.
    pub counts: CountLog,
}

/// Sets up TIM2 and USART1, opens the replay log and the count file.
pub fn init(dp: pac::Peripherals, _clocks: &super::clocks::Clocks) -> Board {
    dp.RCC.apb1enr().modify(|_, w| w.tim2en().set_bit());
    dp.RCC.apb2enr().modify(|_, w| w.usart1en().set_bit());
    let tim2 = dp.TIM2;
    tim2.psc().write(|w| w.psc().set(0));
    tim2.arr().write(|w| w.arr().set(u32::MAX));
    tim2.egr().write(|w| w.ug().set_bit());
    tim2.cr1().modify(|_, w| w.cen().set_bit());
    let usart = dp.USART1;
    usart.cr1().modify(|_, w| w.ue().set_bit().te().set_bit());
    let open = |name: &core::ffi::CStr| match File::open(name) {
        Ok(f) => Some(f),
        Err(_) => {
            defmt::error!(
                "qemu: cannot open {=str} over semihosting",
                name.to_str().unwrap_or("?")
            );
            None
        }
    };
    let counts = File::create(c"icount.bin").ok();
    if counts.is_none() {
        defmt::error!("qemu: cannot create icount.bin over semihosting");
    }
    Board {
        sensors: Replay {
            file: open(c"replay.bin"),
            records: 0,
            faults: SensorFaults::default(),
        },
        telemetry: Usart { usart },
        counter: Tim2Counter { tim2 },
        counts: CountLog { file: counts },
    }
}

/// The replay log as a [`SensorSource`].
pub struct Replay {
    file: Option<File>,
    records: u32,
    faults: SensorFaults,
}

impl Replay {
    /// Records read so far.
    pub fn records(&self) -> u32 {
        self.records
    }
}

impl SensorSource for Replay {
    /// The next record; the log's own `t_s`, `dt_s` stand (they are what the sensors timestamped),
    /// so the arguments are unused here.
    fn read(&mut self, _t_s: f32, _dt_s: f32) -> Option<SensorSample<f32>> {
        let file = self.file.as_mut()?;
        let mut rec = [0u8; REPLAY_RECORD_BYTES];
        match file.read_exact(&mut rec) {
            Ok(()) => {
                self.records = self.records.saturating_add(1);
                Some(SensorSample::from_replay_record(&rec))
            }
            // The end of the log (or a truncated last record) ends the run.
            Err(_) => None,
        }
    }

    fn faults(&self) -> SensorFaults {
        self.faults
    }
}

/// USART1 as a [`TelemetryPort`].
pub struct Usart {
    usart: pac::USART1,
}

impl TelemetryPort for Usart {
    fn send(&mut self, bytes: &[u8]) {
        for b in bytes {
            // Bounded wait for TXE (QEMU keeps it set; on silicon it takes one character time).
            let mut polls = 0u32;
            while self.usart.sr().read().txe().bit_is_clear() && polls < 100_000 {
                polls += 1;
            }
            self.usart.dr().write(|w| w.dr().set(u16::from(*b)));
        }
    }
}

/// TIM2 as a [`Counter`] (instructions under `-icount shift=0`).
pub struct Tim2Counter {
    tim2: pac::TIM2,
}

impl Counter for Tim2Counter {
    fn now(&self) -> u32 {
        self.tim2.cnt().read().bits()
    }
}

/// The per-sample count file.
pub struct CountLog {
    file: Option<File>,
}

impl CountLog {
    /// Appends one sample's counts.
    pub fn write(&mut self, counts: &[u32]) {
        if let Some(f) = self.file.as_mut() {
            let mut buf = [0u8; 4 * crate::estimate::PROBES];
            for (chunk, c) in buf.chunks_exact_mut(4).zip(counts.iter()) {
                chunk.copy_from_slice(&c.to_le_bytes());
            }
            let n = (4 * counts.len()).min(buf.len());
            if f.write_all(&buf[..n]).is_err() {
                self.file = None;
            }
        }
    }
}

/// Ends the QEMU run with `code` as QEMU's exit status.
pub fn halt(code: i32) -> ! {
    semihosting::process::exit(code)
}
