//! Fuzz target `drivers`: the three sensor drivers on fake buses whose every transaction fails or
//! succeeds as the fuzz input says and whose every read returns fuzz bytes.
//!
//! ## Input
//! A sequence of operations (a selector byte each): ICM-42688-P `init`, `read`, range and rate
//! setters, axis map; MS4525DO `read`, `calibrate_zero`, `set_config` (floats from
//! [`crate::input::scalar`]: NaN, ±∞, huge, tiny, …); AS5600 `read`, `read_raw_count`,
//! `set_zero_here`, `set_config`. Each bus transaction first takes one byte: below 32 it fails with
//! one of the bus's error kinds (I2C: NACK of address or data, arbitration loss, bus error,
//! overrun; SPI: overrun, mode fault, frame format, chip-select fault); otherwise its reads are
//! filled from the input.
//!
//! ## Invariants
//! * Each `read` result equals an independent decoding of the bytes on the bus, re-typed here from
//!   the datasheets (status bits, invalid markers, saturation, transfer functions, wrap-around):
//!   the same error, or a reading within 1e-6 relative of the value computed in `f64` (values
//!   within 1e-5 of a range limit may be classified either way).
//! * Every reading is finite; raw AS5600 counts are 12-bit; a refused configuration leaves the old
//!   one in force.
//! * Each driver's health counters equal the outcomes counted here.

use crate::input::{scalar, Input};
use aerosid_core::drivers::as5600::{self, As5600, Direction, VaneConfig};
use aerosid_core::drivers::icm42688::{self, AccelRange, AxisMap, GyroRange, Icm42688, Odr, SensorAxis};
use aerosid_core::drivers::ms4525do::{self, Ms4525do, OutputType};
use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::{self, ErrorKind as I2cErrorKind, NoAcknowledgeSource};
use embedded_hal::spi::{self, ErrorKind as SpiErrorKind};
use std::cell::RefCell;

/// Most operations per input.
pub const MAX_OPS: usize = 2000;

/// One bus transaction as the fake bus served it.
#[derive(Debug, Clone, Default)]
pub struct Txn {
    /// Whether it succeeded.
    pub ok: bool,
    /// The bytes its reads returned, in order.
    pub reads: Vec<u8>,
}

/// The state both fake buses share: the input and the log of transactions of the current
/// operation.
pub struct Wire<'a> {
    input: Input<'a>,
    log: Vec<Txn>,
}

impl<'a> Wire<'a> {
    fn begin(&mut self) -> Option<u8> {
        let b = self.input.u8();
        if b < 32 {
            None
        } else {
            Some(b)
        }
    }
}

/// A fake I2C bus.
pub struct FakeI2c<'w, 'a>(pub &'w RefCell<Wire<'a>>);
/// A fake SPI device.
pub struct FakeSpi<'w, 'a>(pub &'w RefCell<Wire<'a>>);
/// A delay that does not wait.
pub struct NoDelay;

impl DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

impl i2c::ErrorType for FakeI2c<'_, '_> {
    type Error = I2cErrorKind;
}

impl i2c::I2c for FakeI2c<'_, '_> {
    fn transaction(&mut self, _address: u8, operations: &mut [i2c::Operation<'_>]) -> Result<(), Self::Error> {
        let mut w = self.0.borrow_mut();
        let Some(b) = w.begin() else {
            let e = match w.input.u8() % 6 {
                0 => I2cErrorKind::NoAcknowledge(NoAcknowledgeSource::Address),
                1 => I2cErrorKind::NoAcknowledge(NoAcknowledgeSource::Data),
                2 => I2cErrorKind::ArbitrationLoss,
                3 => I2cErrorKind::Bus,
                4 => I2cErrorKind::Overrun,
                _ => I2cErrorKind::Other,
            };
            w.log.push(Txn::default());
            return Err(e);
        };
        let _ = b;
        let mut t = Txn {
            ok: true,
            reads: Vec::new(),
        };
        for op in operations.iter_mut() {
            if let i2c::Operation::Read(buf) = op {
                for x in buf.iter_mut() {
                    *x = w.input.u8();
                    t.reads.push(*x);
                }
            }
        }
        w.log.push(t);
        Ok(())
    }
}

impl spi::ErrorType for FakeSpi<'_, '_> {
    type Error = SpiErrorKind;
}

impl spi::SpiDevice for FakeSpi<'_, '_> {
    fn transaction(&mut self, operations: &mut [spi::Operation<'_, u8>]) -> Result<(), Self::Error> {
        let mut w = self.0.borrow_mut();
        if w.begin().is_none() {
            let e = match w.input.u8() % 5 {
                0 => SpiErrorKind::Overrun,
                1 => SpiErrorKind::ModeFault,
                2 => SpiErrorKind::FrameFormat,
                3 => SpiErrorKind::ChipSelectFault,
                _ => SpiErrorKind::Other,
            };
            w.log.push(Txn::default());
            return Err(e);
        }
        let mut t = Txn {
            ok: true,
            reads: Vec::new(),
        };
        for op in operations.iter_mut() {
            match op {
                spi::Operation::Read(buf) | spi::Operation::TransferInPlace(buf) => {
                    for x in buf.iter_mut() {
                        *x = w.input.u8();
                        t.reads.push(*x);
                    }
                }
                spi::Operation::Transfer(read, _) => {
                    for x in read.iter_mut() {
                        *x = w.input.u8();
                        t.reads.push(*x);
                    }
                }
                _ => {}
            }
        }
        w.log.push(t);
        Ok(())
    }
}

/// `|got − want| ≤ 1e-6·|want| + 1e-30`.
fn close(got: f32, want: f64) -> bool {
    (f64::from(got) - want).abs() <= 1e-6 * want.abs() + 1e-30
}

#[derive(Default)]
struct IcmCounts {
    ok: u32,
    bus: u32,
    not_ready: u32,
    invalid: u32,
    saturated: u32,
}

#[derive(Default)]
struct MsCounts {
    ok: u32,
    bus: u32,
    stale: u32,
    faults: u32,
    out_of_range: u32,
}

impl MsCounts {
    fn add(&mut self, o: &MsCounts) {
        self.ok += o.ok;
        self.bus += o.bus;
        self.stale += o.stale;
        self.faults += o.faults;
        self.out_of_range += o.out_of_range;
    }
}

#[derive(Default)]
struct AsCounts {
    ok: u32,
    bus: u32,
    missing: u32,
    weak: u32,
    strong: u32,
    out_of_range: u32,
}

/// The fuzz entry point: operations on the three drivers until the input ends or [`MAX_OPS`],
/// each checked against the oracles, and the health counters after each.
pub fn run(data: &[u8]) {
    let wire = RefCell::new(Wire {
        input: Input::new(data),
        log: Vec::new(),
    });
    let mut rig = Rig::new(&wire);
    let mut ops = 0;
    while let Some(op) = rig.next_op(ops) {
        ops += 1;
        rig.apply(op);
        rig.assert_health();
    }
}

/// The three drivers on one fake wire, and their outcomes as counted here.
struct Rig<'w, 'a> {
    wire: &'w RefCell<Wire<'a>>,
    imu: Icm42688<FakeSpi<'w, 'a>>,
    air: Ms4525do<FakeI2c<'w, 'a>>,
    vane: As5600<FakeI2c<'w, 'a>>,
    ic: IcmCounts,
    mc: MsCounts,
    ac: AsCounts,
}

impl<'w, 'a> Rig<'w, 'a> {
    fn new(wire: &'w RefCell<Wire<'a>>) -> Self {
        Self {
            wire,
            imu: Icm42688::new(FakeSpi(wire), icm42688::Config::default()),
            air: Ms4525do::new(FakeI2c(wire), ms4525do::DEFAULT_ADDRESS),
            vane: As5600::new(FakeI2c(wire)),
            ic: IcmCounts::default(),
            mc: MsCounts::default(),
            ac: AsCounts::default(),
        }
    }

    /// The next operation's selector byte, with the transaction log cleared; `None` when the
    /// input is used up or `ops` reached [`MAX_OPS`].
    fn next_op(&self, ops: usize) -> Option<u8> {
        let mut w = self.wire.borrow_mut();
        if w.input.is_empty() || ops >= MAX_OPS {
            return None;
        }
        w.log.clear();
        Some(w.input.u8())
    }

    /// The transactions of the current operation.
    fn log(&self) -> Vec<Txn> {
        self.wire.borrow().log.clone()
    }

    /// One operation (module doc, "Input"), checked.
    fn apply(&mut self, op: u8) {
        match op % 12 {
            0 => self.icm_init(),
            1..=3 => self.icm_read(),
            4 => self.icm_configure(),
            5..=6 => self.ms_read(),
            7 => self.ms_calibrate_zero(),
            8 => self.ms_set_config(),
            9 => self.as_read(),
            10 => self.as_raw_count_or_zero_here(),
            _ => self.as_set_config(),
        }
    }

    fn icm_init(&mut self) {
        let r = self.imu.init(&mut NoDelay);
        icm_init_oracle(&self.log(), &r, &mut self.ic);
    }

    fn icm_read(&mut self) {
        let r = self.imu.read();
        icm_read_oracle(&self.log(), &r, self.imu.config(), &mut self.ic);
    }

    /// A range or rate setter (one register write, its outcome checked) or an axis map (no bus
    /// transaction), chosen by the next byte.
    fn icm_configure(&mut self) {
        let sel = self.wire.borrow_mut().input.u8();
        let before = *self.imu.config();
        let r = self.icm_setter(sel);
        if sel % 5 < 4 {
            let log = self.log();
            assert_eq!(log.len(), 1, "a setter is one write");
            match (&r, log[0].ok) {
                (Ok(()), true) => {}
                (Err(icm42688::Error::Bus(_)), false) => {
                    self.ic.bus += 1;
                    assert_eq!(
                        *self.imu.config(),
                        before,
                        "a failed write changed the cached configuration"
                    );
                }
                _ => panic!("setter outcome {r:?} for a bus that said {}", log[0].ok),
            }
        }
    }

    /// The setter `sel` picks: `sel % 5` which, `sel >> 3` its value.
    fn icm_setter(&mut self, sel: u8) -> Result<(), icm42688::Error<SpiErrorKind>> {
        let imu = &mut self.imu;
        match sel % 5 {
            0 => imu.set_gyro_range(
                [
                    GyroRange::Dps2000,
                    GyroRange::Dps1000,
                    GyroRange::Dps500,
                    GyroRange::Dps250,
                ][usize::from(sel >> 3) % 4],
            ),
            1 => imu.set_accel_range(
                [AccelRange::G16, AccelRange::G8, AccelRange::G4, AccelRange::G2][usize::from(sel >> 3) % 4],
            ),
            2 => imu.set_gyro_odr([Odr::Hz1000, Odr::Hz200, Odr::Hz100, Odr::Hz8000][usize::from(sel >> 3) % 4]),
            3 => imu.set_accel_odr([Odr::Hz1000, Odr::Hz200, Odr::Hz100, Odr::Hz500][usize::from(sel >> 3) % 4]),
            _ => {
                let axes = [
                    SensorAxis::PlusX,
                    SensorAxis::MinusX,
                    SensorAxis::PlusY,
                    SensorAxis::MinusY,
                    SensorAxis::PlusZ,
                    SensorAxis::MinusZ,
                ];
                let b = self.wire.borrow_mut().input.u16();
                let pick = |k: u16| axes[usize::from(k % 6)];
                if let Some(m) = AxisMap::new(pick(b), pick(b / 6), pick(b / 36)) {
                    imu.set_axis_map(m);
                }
                Ok(())
            }
        }
    }

    fn ms_read(&mut self) {
        let r = self.air.read();
        ms_read_oracle(&self.log(), &r, self.air.config(), &mut self.mc);
    }

    /// `calibrate_zero` over up to 8 reads: each read counted as [`ms_read_oracle`] would; the
    /// offset finite and in force after success, the old one after failure.
    fn ms_calibrate_zero(&mut self) {
        let n = u16::from(self.wire.borrow_mut().input.u8() % 9);
        let before = *self.air.config();
        let r = self.air.calibrate_zero(&mut NoDelay, n, 100);
        // Every transaction was one counted read; classify each as `ms_read_oracle` would.
        let mut sub = MsCounts::default();
        for t in &self.log() {
            ms_classify(t, &before, &mut sub);
        }
        self.mc.add(&sub);
        match r {
            Ok(offset) => {
                assert!(offset.is_finite(), "zero offset {offset}");
                assert_eq!(self.air.config().zero_offset_pa.to_bits(), offset.to_bits());
            }
            Err(_) => assert_eq!(
                self.air.config().zero_offset_pa.to_bits(),
                before.zero_offset_pa.to_bits()
            ),
        }
    }

    /// A configuration from the input; a refused one leaves the driver as it was.
    fn ms_set_config(&mut self) {
        let c = ms_config(&mut self.wire.borrow_mut().input);
        let before = *self.air.config();
        if self.air.set_config(c).is_err() {
            assert_eq!(
                format!("{:?}", self.air.config()),
                format!("{before:?}"),
                "refused config changed the driver"
            );
        }
    }

    fn as_read(&mut self) {
        let r = self.vane.read();
        as_oracle(
            &self.log(),
            r.map(|x| (x.raw_count, Some(x.angle_rad))),
            self.vane.config(),
            true,
            &mut self.ac,
        );
    }

    /// `read_raw_count`, or `set_zero_here` in the direction the next byte says (its calibration
    /// checked); either way the two transactions checked as a raw read.
    fn as_raw_count_or_zero_here(&mut self) {
        let dir = self.wire.borrow_mut().input.u8();
        let r = if dir & 1 == 0 {
            self.vane.read_raw_count()
        } else {
            let d = if dir & 2 == 0 {
                Direction::CountsIncrease
            } else {
                Direction::CountsDecrease
            };
            let old = *self.vane.config();
            let r = self.vane.set_zero_here(d);
            match r {
                Ok(c) => assert_eq!((self.vane.config().zero_count, self.vane.config().direction), (c, d)),
                Err(_) => assert_eq!(*self.vane.config(), old, "failed set_zero_here changed the calibration"),
            }
            r
        };
        as_oracle(
            &self.log(),
            r.map(|c| (c, None)),
            self.vane.config(),
            false,
            &mut self.ac,
        );
    }

    /// A configuration from the input; a refused one leaves the driver as it was.
    fn as_set_config(&mut self) {
        let c = vane_config(&mut self.wire.borrow_mut().input);
        let before = *self.vane.config();
        if self.vane.set_config(c).is_err() {
            assert_eq!(*self.vane.config(), before, "refused vane config changed the driver");
        }
    }

    /// Each driver's health counters equal the outcomes counted here.
    fn assert_health(&self) {
        let (ic, mc, ac) = (&self.ic, &self.mc, &self.ac);
        let h = self.imu.health();
        assert_eq!(
            (h.reads_ok, h.bus_errors, h.not_ready, h.invalid, h.saturated),
            (ic.ok, ic.bus, ic.not_ready, ic.invalid, ic.saturated),
            "ICM-42688-P health counters"
        );
        let h = self.air.health();
        assert_eq!(
            (h.ok, h.bus_errors, h.stale, h.faults, h.out_of_range),
            (mc.ok, mc.bus, mc.stale, mc.faults, mc.out_of_range),
            "MS4525DO health counters"
        );
        let h = self.vane.health();
        assert_eq!(
            (
                h.ok,
                h.bus_errors,
                h.magnet_missing,
                h.magnet_too_weak,
                h.magnet_too_strong,
                h.out_of_range
            ),
            (ac.ok, ac.bus, ac.missing, ac.weak, ac.strong, ac.out_of_range),
            "AS5600 health counters"
        );
    }
}

/// An MS4525DO configuration from the input (floats from [`scalar`]).
fn ms_config(inp: &mut Input<'_>) -> ms4525do::Config {
    ms4525do::Config {
        output_type: if inp.u8() & 1 == 0 {
            OutputType::A
        } else {
            OutputType::B
        },
        p_min_psi: scalar::<f32>(inp, 1.0, 1e6).0,
        p_max_psi: scalar::<f32>(inp, 1.0, 1e6).0,
        air_density_kg_m3: scalar::<f32>(inp, 1.0, 1e6).0,
        zero_offset_pa: scalar::<f32>(inp, 100.0, 1e6).0,
        noise_band_pa: scalar::<f32>(inp, 5.0, 1e6).0,
    }
}

/// An AS5600 vane configuration from the input (floats from [`scalar`]).
fn vane_config(inp: &mut Input<'_>) -> VaneConfig {
    VaneConfig {
        zero_count: inp.u16() % 4200,
        direction: if inp.u8() & 1 == 0 {
            Direction::CountsIncrease
        } else {
            Direction::CountsDecrease
        },
        scale: scalar::<f32>(inp, 1.0, 1e6).0,
        min_angle_rad: scalar::<f32>(inp, 1.0, 1e6).0,
        max_angle_rad: scalar::<f32>(inp, 1.0, 1e6).0,
    }
}

fn icm_init_oracle<E: core::fmt::Debug>(log: &[Txn], r: &Result<(), icm42688::Error<E>>, c: &mut IcmCounts) {
    // WHO_AM_I read, then DEVICE_CONFIG, GYRO_CONFIG0, ACCEL_CONFIG0, PWR_MGMT0 writes; stops at the
    // first failure or a wrong id.
    let first = &log[0];
    if !first.ok {
        c.bus += 1;
        assert!(matches!(r, Err(icm42688::Error::Bus(_))), "{r:?}");
        assert_eq!(log.len(), 1);
        return;
    }
    let id = first.reads.first().copied().unwrap_or(0);
    if id != 0x47 {
        assert!(
            matches!(r, Err(icm42688::Error::WrongDevice(x)) if *x == id),
            "id {id:#x}: {r:?}"
        );
        assert_eq!(log.len(), 1);
        return;
    }
    match log[1..].iter().position(|t| !t.ok) {
        Some(i) => {
            c.bus += 1;
            assert_eq!(log.len(), i + 2, "init went on after a failed write");
            assert!(matches!(r, Err(icm42688::Error::Bus(_))), "{r:?}");
        }
        None => {
            assert_eq!(log.len(), 5, "init is one read and four writes");
            assert!(r.is_ok(), "{r:?}");
        }
    }
}

fn axis(a: SensorAxis, v: &[f64; 3]) -> f64 {
    match a {
        SensorAxis::PlusX => v[0],
        SensorAxis::MinusX => -v[0],
        SensorAxis::PlusY => v[1],
        SensorAxis::MinusY => -v[1],
        SensorAxis::PlusZ => v[2],
        SensorAxis::MinusZ => -v[2],
    }
}

fn icm_read_oracle<E: core::fmt::Debug>(
    log: &[Txn],
    r: &Result<icm42688::Reading, icm42688::Error<E>>,
    cfg: &icm42688::Config,
    c: &mut IcmCounts,
) {
    use icm42688::Error as E;
    if !log[0].ok {
        c.bus += 1;
        assert!(matches!(r, Err(E::Bus(_))), "{r:?}");
        return;
    }
    if log[0].reads[0] & 0x08 == 0 {
        c.not_ready += 1;
        assert!(matches!(r, Err(E::NotReady)), "DATA_RDY clear: {r:?}");
        assert_eq!(log.len(), 1);
        return;
    }
    let burst = &log[1];
    if !burst.ok {
        c.bus += 1;
        assert!(matches!(r, Err(E::Bus(_))), "{r:?}");
        return;
    }
    assert_eq!(burst.reads.len(), 14, "burst TEMP_DATA1..=GYRO_DATA_Z0");
    let w = |i: usize| i16::from_be_bytes([burst.reads[2 * i], burst.reads[2 * i + 1]]);
    let (t, a, g) = (w(0), [w(1), w(2), w(3)], [w(4), w(5), w(6)]);
    let all_marker = |v: &[i16; 3]| v.iter().all(|x| *x == i16::MIN);
    if t == i16::MIN || all_marker(&a) || all_marker(&g) {
        c.invalid += 1;
        assert!(matches!(r, Err(E::InvalidData)), "invalid marker: {r:?}");
        return;
    }
    if a.iter().chain(g.iter()).any(|x| *x == i16::MIN || x.abs() == i16::MAX) {
        c.saturated += 1;
        assert!(matches!(r, Err(E::Saturated)), "full scale: {r:?}");
        return;
    }
    let Ok(reading) = r else {
        panic!("a good burst refused: {r:?}");
    };
    c.ok += 1;
    icm_check_reading(reading, t, &a, &g, cfg);
}

/// A reading accepted from the burst's temperature `t`, accelerometer `a` and gyro `g` words:
/// each axis scaled by the configured full scale and mapped to the body axes, the temperature
/// `t/132.48 + 25` °C, all within the rounding of `f32`.
fn icm_check_reading(reading: &icm42688::Reading, t: i16, a: &[i16; 3], g: &[i16; 3], cfg: &icm42688::Config) {
    let g_fs: f64 = [2000.0, 1000.0, 500.0, 250.0][cfg.gyro_range as usize];
    let a_fs = [16.0, 8.0, 4.0, 2.0][cfg.accel_range as usize];
    let av = a.map(|x| f64::from(x) * a_fs * 9.80665 / 32768.0);
    let gv = g.map(|x| f64::from(x) * g_fs.to_radians() / 32768.0);
    let map = cfg.axis_map.body_axes();
    for (i, &m) in map.iter().enumerate() {
        assert!(
            close(reading.accel_mps2[i], axis(m, &av)),
            "accel {i}: {reading:?} vs {av:?}"
        );
        assert!(
            close(reading.gyro_rad_s[i], axis(m, &gv)),
            "gyro {i}: {reading:?} vs {gv:?}"
        );
    }
    // The temperature is `t/132.48 + 25` in f32: its rounding is relative to the 25 °C offset.
    let want_t = f64::from(t) / 132.48 + 25.0;
    assert!(
        (f64::from(reading.temperature_c) - want_t).abs() <= 1e-6 * (25.0 + want_t.abs()),
        "temperature {reading:?} vs {want_t}"
    );
}

/// What one Read_DF4 transaction must give, counted.
fn ms_classify(t: &Txn, cfg: &ms4525do::Config, c: &mut MsCounts) -> Expect {
    if !t.ok {
        c.bus += 1;
        return Expect::Bus;
    }
    let b = &t.reads;
    match b[0] >> 6 {
        0 => {}
        2 => {
            c.stale += 1;
            return Expect::Stale;
        }
        _ => {
            c.faults += 1;
            return Expect::Fault;
        }
    }
    let count = (u16::from(b[0] & 0x3F) << 8) | u16::from(b[1]);
    let (lo, hi) = match cfg.output_type {
        OutputType::A => (0.1, 0.9),
        OutputType::B => (0.05, 0.95),
    };
    // The driver compares in f32: the span limits as f32 products.
    let (clo, chi) = (f64::from(lo as f32 * 16383.0), f64::from(hi as f32 * 16383.0));
    let cf = f64::from(count);
    if cf < clo || cf > chi {
        c.out_of_range += 1;
        return Expect::OutOfRange;
    }
    c.ok += 1;
    let psi =
        (cf - clo) * (f64::from(cfg.p_max_psi) - f64::from(cfg.p_min_psi)) / (chi - clo) + f64::from(cfg.p_min_psi);
    let temp_count = (u16::from(b[2]) << 3) | u16::from((b[3] & 0xE0) >> 5);
    Expect::Ok {
        raw_pa: psi * 6894.757,
        count,
        temp_c: f64::from(temp_count) * 200.0 / 2047.0 - 50.0,
        temp_count,
    }
}

enum Expect {
    Bus,
    Stale,
    Fault,
    OutOfRange,
    Ok {
        raw_pa: f64,
        count: u16,
        temp_c: f64,
        temp_count: u16,
    },
}

fn ms_read_oracle<E: core::fmt::Debug>(
    log: &[Txn],
    r: &Result<ms4525do::Measurement, ms4525do::Error<E>>,
    cfg: &ms4525do::Config,
    c: &mut MsCounts,
) {
    use ms4525do::Error as E;
    assert_eq!(log.len(), 1, "a read is one transaction");
    match (ms_classify(&log[0], cfg, c), r) {
        (Expect::Bus, Err(E::Bus(_))) | (Expect::Stale, Err(E::Stale)) | (Expect::OutOfRange, Err(E::OutOfRange)) => {}
        (Expect::Fault, Err(E::Fault | E::ReservedStatus)) => {}
        (
            Expect::Ok {
                raw_pa,
                count,
                temp_c,
                temp_count,
            },
            Ok(m),
        ) => {
            assert_eq!((m.pressure_count, m.temperature_count), (count, temp_count));
            let span = (f64::from(cfg.p_max_psi) - f64::from(cfg.p_min_psi)).abs() * 6894.757;
            assert!(
                // f32 rounding relative to the range, plus 1 µPa absolute: with a range of 1e-38 psi
                // (valid, if absurd) the f32 arithmetic is in subnormals, where the relative error
                // is large but the absolute one far below anything physical.
                (f64::from(m.raw_pressure_pa) - raw_pa).abs() <= 1e-5 * (span + raw_pa.abs()) + 1e-6,
                "pressure {m:?} vs {raw_pa}"
            );
            assert!(
                close(m.temperature_c, temp_c) || (f64::from(m.temperature_c) - temp_c).abs() < 1e-4,
                "{m:?}"
            );
            for v in [m.pressure_pa, m.raw_pressure_pa, m.temperature_c, m.airspeed_mps] {
                assert!(v.is_finite(), "non-finite measurement {m:?} (config {cfg:?})");
            }
            // Signed airspeed: negative exactly below the noise band, zero inside it — or where
            // `2|Δp|/ρ` underflows f32 (a tiny Δp over a huge density), whose speed is 0 to f32;
            // -0.0 and +0.0 are both "zero" here (crash-2c94843a: Δp −3.7e-23 Pa, speed −0.0).
            let below = m.pressure_pa < -cfg.noise_band_pa;
            let in_band = m.pressure_pa < 0.0 && !below;
            let speed_f64 = (2.0 * f64::from(m.pressure_pa).abs() / f64::from(cfg.air_density_kg_m3)).sqrt();
            if m.airspeed_mps == 0.0 {
                assert!(
                    in_band || speed_f64 < 1e-20 || m.pressure_pa == 0.0,
                    "zero airspeed {m:?} outside the noise band {} (speed {speed_f64})",
                    cfg.noise_band_pa
                );
            } else {
                assert!(!in_band, "non-zero airspeed {m:?} inside the noise band");
                assert!(
                    (m.airspeed_mps < 0.0) == below,
                    "airspeed sign {m:?} (noise band {})",
                    cfg.noise_band_pa
                );
            }
        }
        (_, r) => panic!("MS4525DO result {r:?} disagrees with the frame {:?}", log[0]),
    }
}

fn as_oracle<E: core::fmt::Debug>(
    log: &[Txn],
    r: Result<(u16, Option<f32>), as5600::Error<E>>,
    cfg: &VaneConfig,
    with_angle: bool,
    c: &mut AsCounts,
) {
    use as5600::Error as E;
    if !log[0].ok {
        c.bus += 1;
        assert!(matches!(r, Err(E::Bus(_))), "{r:?}");
        return;
    }
    if !as_magnet_ok(log[0].reads[0], &r, c) {
        return;
    }
    if !log[1].ok {
        c.bus += 1;
        assert!(matches!(r, Err(E::Bus(_))), "{r:?}");
        return;
    }
    let raw = u16::from_be_bytes([log[1].reads[0], log[1].reads[1]]) & 0x0FFF;
    if !with_angle {
        c.ok += 1;
        assert_eq!(r.map(|x| x.0).ok(), Some(raw), "raw count");
        return;
    }
    as_angle_oracle(raw, r, cfg, c);
}

/// Whether the STATUS byte says the magnet is in range (the read goes on); otherwise the error
/// the driver must give for it, counted.
fn as_magnet_ok<T: core::fmt::Debug, E: core::fmt::Debug>(
    status: u8,
    r: &Result<T, as5600::Error<E>>,
    c: &mut AsCounts,
) -> bool {
    use as5600::Error as E;
    match status & 0x38 {
        0x20 => return true,
        0x10 | 0x30 => {
            c.weak += 1;
            assert!(matches!(r, Err(E::MagnetTooWeak)), "status {status:#x}: {r:?}");
        }
        0x08 | 0x28 => {
            c.strong += 1;
            assert!(matches!(r, Err(E::MagnetTooStrong)), "status {status:#x}: {r:?}");
        }
        0x00 => {
            c.missing += 1;
            assert!(matches!(r, Err(E::MagnetMissing)), "status {status:#x}: {r:?}");
        }
        _ => {
            c.missing += 1;
            assert!(
                matches!(r, Err(E::InvalidStatus(b)) if *b == status),
                "status {status:#x}: {r:?}"
            );
        }
    }
    false
}

/// The angle of `raw` under `cfg` (wrap-around, direction, scale; in `f64`) against the driver's
/// result: accepted inside `[min, max]` and above −π, refused outside (either within 1e-5 of an
/// edge), counted.
fn as_angle_oracle<E: core::fmt::Debug>(
    raw: u16,
    r: Result<(u16, Option<f32>), as5600::Error<E>>,
    cfg: &VaneConfig,
    c: &mut AsCounts,
) {
    use as5600::Error as E;
    let mut d = (i32::from(raw) - i32::from(cfg.zero_count)).rem_euclid(4096);
    if d > 2048 {
        d -= 4096;
    }
    if cfg.direction == Direction::CountsDecrease && d != 2048 {
        d = -d;
    }
    let angle = f64::from(cfg.scale) * f64::from(d) * core::f64::consts::TAU / 4096.0;
    let (lo, hi) = (f64::from(cfg.min_angle_rad), f64::from(cfg.max_angle_rad));
    let pi = core::f64::consts::PI;
    let inside = angle >= lo && angle <= hi && angle > -pi;
    let edge = [lo, hi, -pi]
        .iter()
        .any(|e| (angle - e).abs() <= 1e-5 * (1.0 + angle.abs()));
    match r {
        Ok((count, Some(a))) => {
            assert!(inside || edge, "angle {a} outside [{lo}, {hi}] accepted");
            assert_eq!(count, raw);
            assert!(a.is_finite() && close(a, angle), "angle {a} vs {angle}");
            c.ok += 1;
        }
        Err(E::OutOfRange) => {
            assert!(!inside || edge, "angle {angle} inside [{lo}, {hi}] refused");
            c.out_of_range += 1;
        }
        r => panic!("AS5600 result {r:?} for raw count {raw}"),
    }
}
