//! The QEMU board (`netduinoplus2`, an emulated STM32F405): the same application, fed from a flight
//! log instead of sensors.
//!
//! * **Sensors**: `replay.bin` in QEMU's working directory, read over semihosting: binary records of
//!   [`REPLAY_RECORD_BYTES`] (the [`SensorSample`] fields as little-endian `f32`, CSV column order),
//!   written by the host from a CSV log (`aerosid replay-bin`). The end of the file ends the run.
//!   Each finished sample goes through the same stuck-sensor check as on the flight computer
//!   ([`super::Finish`]).
//! * **Fault injection** (optional): `faults.bin`, up to [`MAX_FAULTS`] records of
//!   [`FAULT_RECORD_BYTES`] ([`Fault`]), each acting on a range of replay records: a chip's reads
//!   fail (its channels NaN; counted, and after [`super::REINIT_AFTER`] failures in a row a
//!   re-initialisation is counted, as [`super::ChipHealth`] does on the flight computer), a channel
//!   stuck at its first value or forced to a value (NaN, ±∞, out of range), a sample dropped as if
//!   the estimator's queue were full, a sample taken late.
//! * **Autopilot link** (optional): `autopilot.bin`, per replay record a little-endian `u16` length
//!   and that many bytes of the autopilot's MAVLink stream (valid frames, and whatever garbage the
//!   host put in), fed to the same [`MavlinkSurfaces`] as the flight computer's USART2 bytes, with
//!   the same calibration ([`aerosid_core::aero::onboard::AUTOPILOT_LINK`]); the surfaces,
//!   throttle, RPM and attitude of the sample then come from the link ([`MavlinkSurfaces::fill`]),
//!   not from the record. Without the file they come from the record.
//! * **Telemetry**: USART1's data register; QEMU's `-serial file:…` (or `stdio`) receives the bytes.
//!   QEMU's STM32F2xx USART model sends each byte written to DR at once and keeps TXE set.
//! * **Counter**: TIM2 free-running with PSC = 0, ARR = 2³² − 1. Under `-icount shift=0,align=off,
//!   sleep=off` it advances exactly one tick per guest instruction (TOOLCHAIN.md), so the estimator's
//!   cost is an instruction count, identical from run to run.
//! * **Per-sample counts**: `icount.bin`, one record per processed sample of
//!   [`crate::estimate::PROBES`] little-endian `u32` (whole step, synthesis, six coefficients,
//!   the whole firmware since the previous sample), written over semihosting outside the timed
//!   region of the step (inside the period: the write is part of what this board executes per
//!   sample).

use super::{Counter, Finish, LinkHealth, SensorHealth, SensorSource, TelemetryPort};
use aerosid_core::aero::model::channel;
use aerosid_core::aero::onboard::AUTOPILOT_LINK;
use aerosid_core::aero::{SensorSample, REPLAY_RECORD_BYTES};
use aerosid_core::harness::ChipHealth;
use aerosid_core::mavlink::MavlinkSurfaces;
use semihosting::fs::File;
use semihosting::io::{Read, Write};
use stm32f4::stm32f405 as pac;

/// The sensors of this board (in a static: see [`init`]).
pub type Sensors = &'static mut Replay;
/// The telemetry port of this board.
pub type Port = Usart;
/// The step counter of this board.
pub type CycleCounter = Tim2Counter;

pub use aerosid_core::harness::{fault_chip as chip, fault_kind as kind, FAULT_RECORD_BYTES, MAX_FAULTS};

/// One fault record of `faults.bin` (module doc).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fault {
    first: u32,
    count: u32,
    kind: u8,
    target: u8,
    param: [u8; 4],
    /// The value a stuck channel keeps (captured at its first record).
    hold: [f32; 3],
}

impl Fault {
    fn parse(b: &[u8; FAULT_RECORD_BYTES]) -> Self {
        let [f0, f1, f2, f3, c0, c1, c2, c3, kind, target, _, _, p0, p1, p2, p3] = *b;
        Self {
            first: u32::from_le_bytes([f0, f1, f2, f3]),
            count: u32::from_le_bytes([c0, c1, c2, c3]),
            kind,
            target,
            param: [p0, p1, p2, p3],
            hold: [0.0; 3],
        }
    }

    fn active(&self, k: u32) -> bool {
        k >= self.first && k - self.first < self.count
    }
}

/// The board's parts, handed to the tasks by `init`.
pub struct Board {
    /// The replay log.
    pub sensors: &'static mut Replay,
    /// USART1.
    pub telemetry: Usart,
    /// TIM2.
    pub counter: Tim2Counter,
    /// Per-sample instruction counts.
    pub counts: CountLog,
}

/// Sets up TIM2 and USART1, opens the replay log, the fault schedule, the autopilot stream and the
/// count file. The replay state (≈ 2.5 KB: the faults, the link's parser, a chunk buffer, the
/// stuck detector) goes into a static, built in this function's frame, which is not inlined: RTIC
/// keeps `init`'s own frame under every task's first run (`crate::estimate::Estimator::new`), so
/// what `init` gets back must be small.
#[inline(never)]
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
    let replay = match File::open(c"replay.bin") {
        Ok(f) => Some(f),
        Err(_) => {
            defmt::error!("qemu: cannot open replay.bin over semihosting");
            None
        }
    };
    let counts = File::create(c"icount.bin").ok();
    if counts.is_none() {
        defmt::error!("qemu: cannot create icount.bin over semihosting");
    }
    let mut faults = [Fault::default(); MAX_FAULTS];
    let mut n_faults = 0;
    if let Ok(mut f) = File::open(c"faults.bin") {
        let mut rec = [0u8; FAULT_RECORD_BYTES];
        for slot in faults.iter_mut() {
            if f.read_exact(&mut rec).is_err() {
                break;
            }
            *slot = Fault::parse(&rec);
            n_faults += 1;
        }
        defmt::info!("qemu: {=usize} injected faults", n_faults);
    }
    let link = match File::open(c"autopilot.bin") {
        Ok(f) => match MavlinkSurfaces::new(AUTOPILOT_LINK) {
            Ok(m) => Some((f, m)),
            Err(e) => {
                defmt::error!("qemu: autopilot link configuration refused ({})", e);
                None
            }
        },
        Err(_) => None,
    };
    let Some(sensors) = cortex_m::singleton!(: Replay = Replay {
        file: replay,
        records: 0,
        faults,
        n_faults,
        link,
        chunk: [0; CHUNK],
        late_carry_s: 0.0,
        t_us: 0,
        drop: false,
        health: SensorHealth::default(),
        finish: Finish::new(),
    }) else {
        defmt::error!("qemu: init called twice");
        halt(4)
    };
    Board {
        sensors,
        telemetry: Usart { usart },
        counter: Tim2Counter { tim2 },
        counts: CountLog { file: counts },
    }
}

/// Bytes of `autopilot.bin` fed to the parser at a time.
const CHUNK: usize = 256;

/// The replay log as a [`SensorSource`], with the injected faults and the autopilot stream.
pub struct Replay {
    file: Option<File>,
    records: u32,
    faults: [Fault; MAX_FAULTS],
    n_faults: usize,
    /// `autopilot.bin` and the MAVLink receiver it feeds.
    link: Option<(File, MavlinkSurfaces)>,
    chunk: [u8; CHUNK],
    /// What a late sample took from the next one's `dt_s`, s.
    late_carry_s: f32,
    /// Time stamp of the last record, µs (from its `t_s`).
    t_us: u64,
    /// The last record is to be dropped.
    drop: bool,
    health: SensorHealth,
    finish: Finish,
}

impl Replay {
    /// Records read so far.
    pub fn records(&self) -> u32 {
        self.records
    }

    /// Feeds this record's bytes of `autopilot.bin` to the link (or, when `lost`, counts them as
    /// lost) and writes the link's values into `s`. After the end of the stream nothing is fed
    /// (the link goes stale).
    #[inline(never)]
    fn autopilot(&mut self, s: &mut SensorSample<f32>, lost: bool) {
        let Some((file, link)) = self.link.as_mut() else {
            return;
        };
        let mut len = [0u8; 2];
        let mut left = if file.read_exact(&mut len).is_ok() {
            usize::from(u16::from_le_bytes(len))
        } else {
            0
        };
        while left > 0 {
            let n = left.min(CHUNK);
            let Some(buf) = self.chunk.get_mut(..n) else {
                break;
            };
            if file.read_exact(buf).is_err() {
                break;
            }
            if lost {
                self.health.link.lost = self.health.link.lost.saturating_add(n as u32);
            } else {
                link.receive(buf, self.t_us);
            }
            left -= n;
        }
        let ok = link.fill(self.t_us, s);
        if !ok {
            self.health.autopilot_faults = self.health.autopilot_faults.saturating_add(1);
        }
        let lost = self.health.link.lost;
        self.health.link = LinkHealth::from_link(link, lost);
    }
}

/// The time stamp of a replayed sample, µs: its `t_s` rounded (0 for a negative or NaN `t_s`).
fn stamp_us(t_s: f32) -> u64 {
    (f64::from(t_s) * 1e6 + 0.5) as u64
}

/// The channel at bit position `bit` of `s`: up to three components.
fn channel_mut(s: &mut SensorSample<f32>, bit: u8) -> &mut [f32] {
    s.channel_mut(1u16 << (bit % 16))
}

/// A chip's reads this record: `ok`, else its channels NaN. Counted as on the flight computer; a
/// re-initialisation there is a reset of the chip or its bus, here only counted and logged.
#[inline(never)]
fn chip_read(health: &mut ChipHealth, ok: bool, name: &str, s: &mut SensorSample<f32>, bits: u16) {
    if !ok {
        s.invalidate(bits);
    }
    if health.record(ok) {
        defmt::warn!(
            "qemu: {=str}: {=u16} failed reads, re-initialised",
            name,
            super::REINIT_AFTER
        );
    }
}

impl SensorSource for Replay {
    /// The next record, with the faults active at it; the log's own `t_s`, `dt_s` stand (they are
    /// what the sensors timestamped), so the arguments are unused here.
    #[inline(never)]
    fn read(&mut self, _t_s: f32, _dt_s: f32) -> Option<SensorSample<f32>> {
        let file = self.file.as_mut()?;
        let mut rec = [0u8; REPLAY_RECORD_BYTES];
        // The end of the log (or a truncated last record) ends the run.
        file.read_exact(&mut rec).ok()?;
        let k = self.records;
        self.records = self.records.saturating_add(1);
        let mut s = SensorSample::from_replay_record(&rec);
        s.dt_s -= self.late_carry_s;
        self.late_carry_s = 0.0;
        self.t_us = stamp_us(s.t_s);
        self.drop = false;
        let mut failing = [false; 5];
        let n = self.n_faults.min(MAX_FAULTS);
        for f in self.faults.iter_mut().take(n).filter(|f| f.active(k)) {
            let param = f32::from_le_bytes(f.param);
            match f.kind {
                kind::BUS => {
                    if let Some(c) = failing.get_mut(usize::from(f.target)) {
                        *c = true;
                    }
                }
                kind::STUCK => {
                    let ch = channel_mut(&mut s, f.target);
                    if k == f.first {
                        for (h, v) in f.hold.iter_mut().zip(ch.iter()) {
                            *h = *v;
                        }
                    }
                    for (v, h) in ch.iter_mut().zip(f.hold.iter()) {
                        *v = *h;
                    }
                }
                kind::VALUE => channel_mut(&mut s, f.target).iter_mut().for_each(|v| *v = param),
                kind::DROP => self.drop = true,
                kind::LATE if k == f.first => {
                    let late_us = u32::from_le_bytes(f.param);
                    let late_s = late_us as f32 * 1e-6;
                    s.t_s += late_s;
                    s.dt_s += late_s;
                    self.t_us = self.t_us.saturating_add(u64::from(late_us));
                    self.late_carry_s = late_s;
                }
                _ => {}
            }
        }
        let ok = |c: u8| !failing.get(usize::from(c)).copied().unwrap_or(false);
        let h = &mut self.health;
        chip_read(&mut h.imu, ok(chip::IMU), "imu", &mut s, channel::ACCEL | channel::GYRO);
        let airspeed_bits = channel::AIRSPEED | channel::DENSITY;
        chip_read(&mut h.airspeed, ok(chip::AIRSPEED), "airspeed", &mut s, airspeed_bits);
        chip_read(&mut h.alpha_vane, ok(chip::ALPHA), "alpha vane", &mut s, channel::ALPHA);
        chip_read(&mut h.beta_vane, ok(chip::BETA), "beta vane", &mut s, channel::BETA);
        // Checked here, not in `autopilot`: its frame (the link's parser and frame) is not needed
        // on the stack of a replay without a link.
        if self.link.is_some() {
            self.autopilot(&mut s, !ok(chip::AUTOPILOT));
        }
        self.finish.apply(&mut s, &mut self.health);
        Some(s)
    }

    fn health(&self) -> SensorHealth {
        self.health
    }

    fn time_us(&self, _sampler_us: u64) -> u64 {
        self.t_us
    }
}

impl Replay {
    /// Fault injection, a test hook of this board only (not part of [`SensorSource`]): the sample
    /// just read is to be dropped as if the estimator's queue were full.
    pub fn drop_injected(&self) -> bool {
        self.drop
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
            if f.write_all(buf.get(..n).unwrap_or(&[])).is_err() {
                self.file = None;
            }
        }
    }
}

/// Ends the QEMU run with `code` as QEMU's exit status.
pub fn halt(code: i32) -> ! {
    semihosting::process::exit(code)
}
