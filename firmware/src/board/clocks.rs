//! Clock tree and debug setup of the STM32F405 on the PAC registers: clock tree, debug in sleep, cycle counter.
//!
//! Clock tree (RM0090 §6.2, §6.3.2; datasheet DS8626 table 17 for the limits):
//!
//! | clock | source | frequency |
//! |---|---|---|
//! | PLL input | HSE 8 MHz / M = 4 (HSI 16 MHz / M = 8 if the crystal does not start) | 2 MHz |
//! | VCO | × N = 168 | 336 MHz |
//! | SYSCLK = HCLK (core, SysTick) | VCO / P = 2, AHB / 1 | 168 MHz |
//! | PCLK1 (APB1, max 42 MHz) | HCLK / 4 | 42 MHz (timers 84 MHz) |
//! | PCLK2 (APB2, max 84 MHz) | HCLK / 2 | 84 MHz (timers 168 MHz) |
//! | PLL48CK (USB, SDIO, RNG) | VCO / Q = 7 | 48 MHz |
//!
//! Flash needs 5 wait states at 168 MHz with 2.7–3.6 V (RM0090 table 10), set before the switch.
//! Every wait on a ready flag is bounded: if the crystal, the PLL or the switch does not come up, the
//! chip falls back (HSE → HSI as PLL input; no PLL → HSI 16 MHz) and [`Clocks`] says what it runs on,
//! so the SysTick monotonic is started with the frequency the core really has.

use stm32f4::stm32f405 as pac;

/// External crystal on the board, Hz.
pub const HSE_HZ: u32 = 8_000_000;
/// Internal RC oscillator, Hz.
pub const HSI_HZ: u32 = 16_000_000;
/// Target core clock, Hz.
pub const SYSCLK_HZ: u32 = 168_000_000;

/// PLL input divider for each source, so the VCO input is 2 MHz (RM0090: 2 MHz limits PLL jitter).
const PLLM_HSE: u8 = (HSE_HZ / 2_000_000) as u8;
const PLLM_HSI: u8 = (HSI_HZ / 2_000_000) as u8;
/// VCO multiplier: 2 MHz × 168 = 336 MHz.
const PLLN: u16 = 168;
/// 48 MHz domain divider: 336 MHz / 7 = 48 MHz.
const PLLQ: u8 = 7;

/// Polls of a ready flag before giving up. At 16 MHz (HSI, before the switch) a poll takes a few
/// cycles, so this is roughly 50–100 ms, about ST's `HSE_STARTUP_TIMEOUT` (100 ms); a crystal
/// usually starts in ~2 ms.
const READY_POLLS: u32 = 400_000;

/// What drives SYSCLK after [`init_clocks`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ClockSource {
    /// PLL from the 8 MHz crystal: the nominal configuration.
    HsePll,
    /// PLL from the internal RC (the crystal did not start): same frequencies, worse accuracy.
    HsiPll,
    /// Internal RC directly (the PLL did not lock or the switch failed): 16 MHz.
    Hsi,
}

/// Frequencies after [`init_clocks`], Hz.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct Clocks {
    /// What drives SYSCLK.
    pub source: ClockSource,
    /// Core clock (= HCLK, the SysTick clock), Hz.
    pub sysclk_hz: u32,
    /// APB1 peripheral clock, Hz.
    pub pclk1_hz: u32,
    /// APB2 peripheral clock, Hz.
    pub pclk2_hz: u32,
}

/// Polls `ready` at most [`READY_POLLS`] times; `true` once it holds.
fn wait_for(mut ready: impl FnMut() -> bool) -> bool {
    (0..READY_POLLS).any(|_| ready())
}

/// Sets up the clock tree for 168 MHz (see the module doc) and returns what it achieved.
///
/// Never blocks forever and never panics: on a timeout it falls back as described in the module doc.
pub fn init_clocks(rcc: &pac::RCC, flash: &pac::FLASH, pwr: &pac::PWR) -> Clocks {
    let on_hsi = Clocks {
        source: ClockSource::Hsi,
        sysclk_hz: HSI_HZ,
        pclk1_hz: HSI_HZ,
        pclk2_hz: HSI_HZ,
    };

    // Regulator voltage scale 1 (needed above 144 MHz); VOS can only change while the PLL is off.
    rcc.apb1enr().modify(|_, w| w.pwren().set_bit());
    let _ = rcc.apb1enr().read(); // RM0090 §6.3.13 note: a read-back delays the first PWR access.
    pwr.cr().modify(|_, w| w.vos().scale1());

    // Flash: 5 wait states, prefetch, instruction and data caches — before raising the clock.
    flash.acr().modify(|_, w| {
        w.latency().ws5();
        w.prften().set_bit();
        w.icen().set_bit();
        w.dcen().set_bit()
    });
    if !flash.acr().read().latency().is_ws5() {
        return on_hsi;
    }

    // Crystal first, the internal RC as PLL input if it does not start.
    rcc.cr().modify(|_, w| w.hseon().on());
    let (source, pllm) = if wait_for(|| rcc.cr().read().hserdy().bit_is_set()) {
        (ClockSource::HsePll, PLLM_HSE)
    } else {
        rcc.cr().modify(|_, w| w.hseon().off());
        (ClockSource::HsiPll, PLLM_HSI)
    };

    rcc.pllcfgr().write(|w| {
        if source == ClockSource::HsePll {
            w.pllsrc().hse();
        } else {
            w.pllsrc().hsi();
        }
        w.pllp().div2();
        // SAFETY: M = 4 or 8, N = 168 and Q = 7 are within the fields' valid ranges
        // (M 2..=63, N 50..=432, Q 2..=15; RM0090 §6.3.2).
        unsafe {
            w.pllm().bits(pllm);
            w.plln().bits(PLLN);
            w.pllq().bits(PLLQ)
        }
    });
    rcc.cr().modify(|_, w| w.pllon().on());
    if !wait_for(|| rcc.cr().read().pllrdy().bit_is_set()) {
        rcc.cr().modify(|_, w| w.pllon().off());
        return on_hsi;
    }

    // Bus prescalers first (AHB / 1, APB1 / 4, APB2 / 2), then the switch to the PLL.
    rcc.cfgr().modify(|_, w| {
        w.hpre().div1();
        w.ppre1().div4();
        w.ppre2().div2()
    });
    rcc.cfgr().modify(|_, w| w.sw().pll());
    if !wait_for(|| rcc.cfgr().read().sws().is_pll()) {
        rcc.cfgr().modify(|_, w| {
            w.sw().hsi();
            w.ppre1().div1();
            w.ppre2().div1()
        });
        return on_hsi;
    }

    Clocks {
        source,
        sysclk_hz: SYSCLK_HZ,
        pclk1_hz: SYSCLK_HZ / 4,
        pclk2_hz: SYSCLK_HZ / 2,
    }
}

/// Keeps the debug port usable while `idle` sleeps in WFI, so a probe can still read the RTT buffer.
///
/// DBG_SLEEP keeps HCLK running in Sleep mode (RM0090 §38.16.3); a running DMA1 clock keeps the AHB
/// bus matrix awake, the usual workaround for RTT reads stalling during WFI on STM32. Both cost a
/// little power in sleep only.
pub fn keep_debug_in_sleep(dbgmcu: &pac::DBGMCU, rcc: &pac::RCC) {
    dbgmcu.cr().modify(|_, w| w.dbg_sleep().set_bit());
    rcc.ahb1enr().modify(|_, w| w.dma1en().set_bit());
}

/// Starts the DWT cycle counter (CYCCNT, core clock cycles, wraps every ~25.6 s at 168 MHz).
///
/// Read it with `cortex_m::peripheral::DWT::cycle_count()`; difference readings with `wrapping_sub`.
/// Not emulated by QEMU (reads 0 there).
pub fn enable_cycle_counter(dcb: &mut cortex_m::peripheral::DCB, dwt: &mut cortex_m::peripheral::DWT) {
    dcb.enable_trace();
    dwt.enable_cycle_counter();
}
