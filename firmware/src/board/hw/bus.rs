//! The embedded-hal 1.0 bus traits on the STM32F405's registers: I2C master (fast mode, 400 kHz),
//! SPI1 master, a GPIO chip select and a busy-wait delay. The drivers in `aerosid_core::drivers` run
//! on top of these; `embedded-hal-bus` shares I2C1 between two chips and wraps SPI1 + chip select
//! into an `SpiDevice`.
//!
//! Every wait on a status flag is bounded by a poll count (constants below) and returns an error
//! when it runs out; nothing here can hang on a dead or stuck bus, and nothing panics.
//!
//! References: RM0090 rev. 19 (STM32F405/7 reference manual) §27 (I2C), §28 (SPI), §8 (GPIO).

use core::convert::Infallible;
use core::ops::Deref;
use core::sync::atomic::{AtomicBool, Ordering};

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::i2c::{self, ErrorKind, NoAcknowledgeSource, Operation};
use embedded_hal::spi::{self, SpiBus};
use stm32f4::stm32f405 as pac;

/// I2C bus clock, Hz (fast mode).
pub const I2C_HZ: u32 = 400_000;

/// Polls of an I2C status flag before [`I2cError::Timeout`]. One poll (an APB1 read and a test) takes
/// ≈ 15 core cycles at 168 MHz, so this is ≈ 2 ms: ≈ 90 byte times at 400 kHz, ample for the clock
/// stretching of the parts on these buses.
const I2C_POLLS: u32 = 20_000;

/// Polls of an SPI status flag before [`SpiError::Timeout`]: one byte takes ≈ 64 core cycles at
/// 21 MHz SCK, so 2 000 polls (≈ 0.2 ms) only run out if the peripheral is dead or misconfigured.
const SPI_POLLS: u32 = 2_000;

/// Highest SCK the ICM-42688-P accepts, Hz (DS-000347 Table 7, "SPI clock frequency", 24 MHz).
pub const SPI_MAX_HZ: u32 = 24_000_000;

// ---------------------------------------------------------------------------------------------
// I2C
// ---------------------------------------------------------------------------------------------

/// Why an I2C transaction failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum I2cError {
    /// The address was not acknowledged (no chip there, or it is busy).
    NackAddress,
    /// A data byte was not acknowledged.
    NackData,
    /// Another master won the bus (ARLO).
    ArbitrationLoss,
    /// A misplaced START or STOP on the bus (BERR), or the bus stayed busy.
    Bus,
    /// Overrun/underrun (OVR; only in slave or no-stretch mode, which are not used).
    Overrun,
    /// A flag did not come within [`I2C_POLLS`] polls: the peripheral was reset.
    Timeout,
}

impl i2c::Error for I2cError {
    fn kind(&self) -> ErrorKind {
        match self {
            I2cError::NackAddress => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address),
            I2cError::NackData => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data),
            I2cError::ArbitrationLoss => ErrorKind::ArbitrationLoss,
            I2cError::Bus => ErrorKind::Bus,
            I2cError::Overrun => ErrorKind::Overrun,
            I2cError::Timeout => ErrorKind::Other,
        }
    }
}

/// How a run of reads or writes ends: the bus is released, or the next run follows a repeated START.
#[derive(Clone, Copy, PartialEq, Eq)]
enum End {
    Stop,
    Restart,
}

/// An I2C peripheral (I2C1…I2C3 share one register layout) as a blocking embedded-hal 1.0 master.
///
/// A transaction follows RM0090 §27.3.3 in polling mode: consecutive operations of one kind form a
/// run (no START between them), each run starts with a (repeated) START and the address, reads use
/// the 1-, 2- and N-byte closing sequences with BTF so that no interrupt can make the last bytes
/// late, and the last run ends with STOP. A timeout or a bus error resets the peripheral (SWRST and
/// reconfiguration), which also frees it from a stuck BUSY state; so does a recovery request
/// ([`I2cBus::new`]'s flag) from the sensor layer.
pub struct I2cBus<I> {
    regs: I,
    pclk1_hz: u32,
    recover: &'static AtomicBool,
}

impl<I> I2cBus<I>
where
    I: Deref<Target = pac::i2c1::RegisterBlock>,
{
    /// Configures the peripheral (clock enabled and pins set by the caller) for [`I2C_HZ`] from the
    /// APB1 clock `pclk1_hz`. Setting `recover` makes the next transaction reset the peripheral first.
    pub fn new(regs: I, pclk1_hz: u32, recover: &'static AtomicBool) -> Self {
        let bus = Self {
            regs,
            pclk1_hz,
            recover,
        };
        bus.configure();
        bus
    }

    /// FREQ, CCR and TRISE for fast mode at [`I2C_HZ`] (RM0090 §27.6.2, §27.6.8, §27.6.9), then enable.
    fn configure(&self) {
        let r = &*self.regs;
        r.cr1().write(|w| w.pe().clear_bit());
        // FREQ: the APB1 clock in MHz, 2..=42 on the F405 (42 at our 42 MHz, 16 on the HSI fallback).
        let freq_mhz = (self.pclk1_hz / 1_000_000).clamp(2, 42) as u8;
        // SAFETY: FREQ is a 6-bit field; the value is clamped to its valid range 2..=42 (RM0090 §27.6.2).
        r.cr2().write(|w| unsafe { w.freq().bits(freq_mhz) });
        // Fast mode, duty 2:1: T_high = CCR·T_pclk, T_low = 2·CCR·T_pclk, so CCR = pclk / (3·f_SCL),
        // rounded up (never faster than 400 kHz): 35 at 42 MHz (exactly 400 kHz).
        let ccr = self.pclk1_hz.div_ceil(3 * I2C_HZ).clamp(1, 0xFFF) as u16;
        // SAFETY: CCR is a 12-bit field and the value is clamped to 1..=0xFFF (RM0090 §27.6.8).
        r.ccr()
            .write(|w| unsafe { w.f_s().set_bit().duty().clear_bit().ccr().bits(ccr) });
        // Maximum rise time in fast mode 300 ns: TRISE = 300 ns · f_pclk + 1 (13 at 42 MHz).
        let trise = (u32::from(freq_mhz) * 300 / 1000 + 1) as u8;
        r.trise().write(|w| w.trise().set(trise));
        r.cr1().write(|w| w.pe().set_bit());
    }

    /// Software reset (SWRST), then the configuration again.
    fn reset(&self) {
        let r = &*self.regs;
        r.cr1().write(|w| w.swrst().set_bit());
        r.cr1().write(|w| w.swrst().clear_bit());
        self.configure();
    }

    /// Polls SR1 until `ready` holds, checking the error flags on every poll.
    fn wait(&self, ready: impl Fn(&pac::i2c1::sr1::R) -> bool) -> Result<(), I2cError> {
        let r = &*self.regs;
        for _ in 0..I2C_POLLS {
            let sr1 = r.sr1().read();
            if sr1.berr().bit_is_set() {
                r.sr1().write(|w| w.berr().clear());
                r.cr1().modify(|_, w| w.stop().set_bit());
                return Err(I2cError::Bus);
            }
            if sr1.arlo().bit_is_set() {
                // The other master owns the bus: no STOP from us (RM0090 §27.3.4).
                r.sr1().write(|w| w.arlo().clear());
                return Err(I2cError::ArbitrationLoss);
            }
            if sr1.af().bit_is_set() {
                r.sr1().write(|w| w.af().clear());
                r.cr1().modify(|_, w| w.stop().set_bit());
                return Err(I2cError::NackData);
            }
            if sr1.ovr().bit_is_set() {
                r.sr1().write(|w| w.ovr().clear());
                r.cr1().modify(|_, w| w.stop().set_bit());
                return Err(I2cError::Overrun);
            }
            if ready(&sr1) {
                return Ok(());
            }
        }
        r.cr1().modify(|_, w| w.stop().set_bit());
        Err(I2cError::Timeout)
    }

    /// Polls until `done` holds (a register other than SR1), or [`I2cError::Timeout`].
    fn wait_until(&self, done: impl Fn(&pac::i2c1::RegisterBlock) -> bool) -> Result<(), I2cError> {
        if (0..I2C_POLLS).any(|_| done(&self.regs)) {
            Ok(())
        } else {
            Err(I2cError::Timeout)
        }
    }

    /// (Repeated) START, the address with the R/W bit, and the wait for ADDR (SR1 read; the caller
    /// clears ADDR by reading SR2 at the right moment).
    fn start(&self, address: u8, read: bool) -> Result<(), I2cError> {
        let r = &*self.regs;
        r.cr1().modify(|_, w| w.start().set_bit());
        self.wait(|sr1| sr1.sb().bit_is_set())?;
        r.dr().write(|w| w.dr().set((address << 1) | u8::from(read)));
        self.wait(|sr1| sr1.addr().bit_is_set()).map_err(|e| match e {
            I2cError::NackData => I2cError::NackAddress,
            other => other,
        })
    }

    fn end(&self, end: End) {
        self.regs.cr1().modify(|_, w| match end {
            End::Stop => w.stop().set_bit(),
            End::Restart => w.start().set_bit(),
        });
    }

    /// Writes the bytes of a run of write operations (after ADDR).
    fn write_run(&self, ops: &[Operation<'_>], end: End) -> Result<(), I2cError> {
        let r = &*self.regs;
        let _ = r.sr2().read(); // clears ADDR
        let mut sent = false;
        for op in ops {
            if let Operation::Write(bytes) = op {
                for b in bytes.iter() {
                    self.wait(|sr1| sr1.tx_e().bit_is_set())?;
                    r.dr().write(|w| w.dr().set(*b));
                    sent = true;
                }
            }
        }
        if sent {
            self.wait(|sr1| sr1.btf().bit_is_set())?;
        }
        self.end(end);
        Ok(())
    }

    /// Reads a run of read operations (after ADDR) with the closing sequences of RM0090 §27.3.3:
    /// 1 byte: ACK off before ADDR is cleared, STOP right after (with interrupts off, errata ES0182
    /// §2.5.1); 2 bytes: ACK off and POS on before ADDR is cleared, STOP when BTF; N > 2: ACK off when
    /// BTF with 3 bytes left, STOP when BTF with 2 left.
    fn read_run(&self, ops: &mut [Operation<'_>], end: End) -> Result<(), I2cError> {
        let r = &*self.regs;
        let n: usize = ops
            .iter()
            .map(|op| match op {
                Operation::Read(buf) => buf.len(),
                Operation::Write(_) => 0,
            })
            .sum();
        if n == 0 {
            let _ = r.sr2().read(); // clears ADDR
            self.end(end);
            return Ok(());
        }
        match n {
            1 => r.cr1().modify(|_, w| w.ack().clear_bit()),
            2 => r.cr1().modify(|_, w| w.ack().clear_bit().pos().set_bit()),
            _ => r.cr1().modify(|_, w| w.ack().set_bit()),
        };
        if n == 1 {
            cortex_m::interrupt::free(|_| {
                let _ = r.sr2().read(); // clears ADDR
                self.end(end);
            });
        } else {
            let _ = r.sr2().read(); // clears ADDR
        }
        let mut done = 0usize;
        let result = ops.iter_mut().try_for_each(|op| {
            let Operation::Read(buf) = op else {
                return Ok(());
            };
            buf.iter_mut().try_for_each(|byte| {
                let left = n.saturating_sub(done);
                if n > 2 && left == 3 {
                    self.wait(|sr1| sr1.btf().bit_is_set())?;
                    r.cr1().modify(|_, w| w.ack().clear_bit());
                }
                if n >= 2 && left == 2 {
                    self.wait(|sr1| sr1.btf().bit_is_set())?;
                    self.end(end);
                }
                self.wait(|sr1| sr1.rx_ne().bit_is_set())?;
                *byte = r.dr().read().dr().bits();
                done += 1;
                Ok(())
            })
        });
        r.cr1().modify(|_, w| w.pos().clear_bit().ack().clear_bit());
        result
    }

    fn run(&mut self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), I2cError> {
        self.wait_until(|r| r.sr2().read().busy().bit_is_clear())
            .map_err(|_| I2cError::Bus)?;
        let mut rest = operations;
        while !rest.is_empty() {
            let reading = matches!(rest.first(), Some(Operation::Read(_)));
            let len = rest
                .iter()
                .take_while(|op| matches!(op, Operation::Read(_)) == reading)
                .count();
            // `len ≤ rest.len()` (a count of `rest`'s elements); the checked split has no panic path.
            let Some((run, tail)) = core::mem::take(&mut rest).split_at_mut_checked(len) else {
                return Err(I2cError::Bus);
            };
            rest = tail;
            let end = if rest.is_empty() { End::Stop } else { End::Restart };
            self.start(address, reading)?;
            if reading {
                self.read_run(run, end)?;
            } else {
                self.write_run(run, end)?;
            }
        }
        // The STOP bit clears when the STOP condition has been sent.
        self.wait_until(|r| r.cr1().read().stop().bit_is_clear())
    }
}

impl<I> i2c::ErrorType for I2cBus<I> {
    type Error = I2cError;
}

impl<I> i2c::I2c for I2cBus<I>
where
    I: Deref<Target = pac::i2c1::RegisterBlock>,
{
    fn transaction(&mut self, address: u8, operations: &mut [Operation<'_>]) -> Result<(), I2cError> {
        if self.recover.swap(false, Ordering::Relaxed) {
            self.reset();
        }
        let result = self.run(address, operations);
        if matches!(result, Err(I2cError::Timeout | I2cError::Bus)) {
            self.reset();
        }
        result
    }
}

// ---------------------------------------------------------------------------------------------
// SPI
// ---------------------------------------------------------------------------------------------

/// Why an SPI transfer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum SpiError {
    /// A received byte was overwritten before it was read (OVR).
    Overrun,
    /// Mode fault (MODF): NSS pulled low by another master; the master mode is restored.
    ModeFault,
    /// TXE, RXNE or BSY did not come within the poll bound.
    Timeout,
}

impl spi::Error for SpiError {
    fn kind(&self) -> spi::ErrorKind {
        match self {
            SpiError::Overrun => spi::ErrorKind::Overrun,
            SpiError::ModeFault => spi::ErrorKind::ModeFault,
            SpiError::Timeout => spi::ErrorKind::Other,
        }
    }
}

/// SPI1 as an 8-bit full-duplex master bus (chip select handled by the `SpiDevice` on top).
///
/// Mode 3 (CPOL = 1, CPHA = 1; the ICM-42688-P takes mode 0 or 3, DS-000347 §9.3), MSB first,
/// software NSS, SCK = PCLK2 / the smallest power-of-two divider that keeps it ≤ [`SPI_MAX_HZ`]:
/// 84 MHz / 4 = 21 MHz nominally (8 MHz on the HSI fallback).
pub struct Spi1Bus {
    regs: pac::SPI1,
}

impl Spi1Bus {
    /// Configures SPI1 (clock enabled and pins set by the caller) from the APB2 clock `pclk2_hz`.
    pub fn new(regs: pac::SPI1, pclk2_hz: u32) -> Self {
        let bus = Self { regs };
        bus.configure(pclk2_hz);
        bus
    }

    fn configure(&self, pclk2_hz: u32) {
        let r = &self.regs;
        r.cr1().write(|w| w.spe().disabled());
        r.cr1().write(|w| {
            let w = w.cpol().idle_high().cpha().second_edge().mstr().master();
            let w = w.ssm().enabled().ssi().slave_not_selected().lsbfirst().msbfirst();
            let w = w.dff().eight_bit().bidimode().unidirectional();
            let br = w.br();
            if pclk2_hz / 2 <= SPI_MAX_HZ {
                br.div2()
            } else if pclk2_hz / 4 <= SPI_MAX_HZ {
                br.div4()
            } else if pclk2_hz / 8 <= SPI_MAX_HZ {
                br.div8()
            } else {
                br.div16()
            }
        });
        r.cr1().modify(|_, w| w.spe().enabled());
    }

    /// Polls SR until `ready`, checking OVR and MODF.
    fn wait(&self, ready: impl Fn(&pac::spi1::sr::R) -> bool) -> Result<(), SpiError> {
        let r = &self.regs;
        for _ in 0..SPI_POLLS {
            let sr = r.sr().read();
            if sr.ovr().bit_is_set() {
                // Cleared by reading DR then SR (RM0090 §28.4.8).
                let _ = r.dr().read();
                let _ = r.sr().read();
                return Err(SpiError::Overrun);
            }
            if sr.modf().bit_is_set() {
                // Cleared by the SR read above and a write to CR1; MSTR and SPE are set again.
                r.cr1().modify(|_, w| w.mstr().master().spe().enabled());
                return Err(SpiError::ModeFault);
            }
            if ready(&sr) {
                return Ok(());
            }
        }
        Err(SpiError::Timeout)
    }

    /// Sends one byte and returns the byte clocked in meanwhile.
    fn exchange(&mut self, out: u8) -> Result<u8, SpiError> {
        self.wait(|sr| sr.txe().bit_is_set())?;
        self.regs.dr().write(|w| w.dr().set(u16::from(out)));
        self.wait(|sr| sr.rxne().bit_is_set())?;
        Ok(self.regs.dr().read().dr().bits() as u8)
    }
}

impl spi::ErrorType for Spi1Bus {
    type Error = SpiError;
}

impl SpiBus<u8> for Spi1Bus {
    fn read(&mut self, words: &mut [u8]) -> Result<(), SpiError> {
        words.iter_mut().try_for_each(|w| {
            *w = self.exchange(0)?;
            Ok(())
        })
    }

    fn write(&mut self, words: &[u8]) -> Result<(), SpiError> {
        words.iter().try_for_each(|w| self.exchange(*w).map(|_| ()))
    }

    fn transfer(&mut self, read: &mut [u8], write: &[u8]) -> Result<(), SpiError> {
        for i in 0..read.len().max(write.len()) {
            let got = self.exchange(write.get(i).copied().unwrap_or(0))?;
            if let Some(r) = read.get_mut(i) {
                *r = got;
            }
        }
        Ok(())
    }

    fn transfer_in_place(&mut self, words: &mut [u8]) -> Result<(), SpiError> {
        words.iter_mut().try_for_each(|w| {
            *w = self.exchange(*w)?;
            Ok(())
        })
    }

    fn flush(&mut self) -> Result<(), SpiError> {
        self.wait(|sr| sr.bsy().bit_is_clear())
    }
}

/// The ICM-42688-P chip select, PA4 (push-pull, idle high).
pub struct ChipSelectPa4 {
    gpioa: pac::GPIOA,
}

impl ChipSelectPa4 {
    /// PA4 must already be a push-pull output (see `init`).
    pub fn new(gpioa: pac::GPIOA) -> Self {
        Self { gpioa }
    }
}

impl PinErrorType for ChipSelectPa4 {
    type Error = Infallible;
}

impl OutputPin for ChipSelectPa4 {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.gpioa.bsrr().write(|w| w.br4().set_bit());
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.gpioa.bsrr().write(|w| w.bs4().set_bit());
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Delay
// ---------------------------------------------------------------------------------------------

/// Busy-wait delay in core cycles (`cortex_m::asm::delay`, at least the requested time).
#[derive(Clone, Copy)]
pub struct CycleDelay {
    sysclk_hz: u32,
}

impl CycleDelay {
    /// A delay for a core running at `sysclk_hz`.
    pub fn new(sysclk_hz: u32) -> Self {
        Self { sysclk_hz }
    }
}

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = u64::from(ns) * u64::from(self.sysclk_hz) / 1_000_000_000 + 1;
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX));
    }
}
