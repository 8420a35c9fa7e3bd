//! The two UARTs: USART1 sends the telemetry, USART2 receives the autopilot's MAVLink stream.
//!
//! USART2 receives by interrupt (RXNE) into a lock-free single-producer single-consumer ring
//! ([`heapless::spsc`]): the interrupt handler ([`AutopilotRx::on_interrupt`], bound in `main.rs` as
//! the `usart2` hardware task) is the producer, the sampling task drains it in
//! [`super::Sensors`]'s `read`. Polling RXNE in `read` instead would keep one byte per 10 ms sample
//! period while 115 arrive at 115200 baud (11.5 bytes/ms).

use core::sync::atomic::{AtomicU32, Ordering};

use heapless::spsc::{Consumer, Producer};
use stm32f4::stm32f405 as pac;

use crate::board::TelemetryPort;

/// Telemetry baud rate (USART1, to the autopilot's telemetry input or a radio).
pub const TELEMETRY_BAUD: u32 = 57_600;
/// Autopilot link baud rate (USART2, from the autopilot's MAVLink port).
pub const AUTOPILOT_BAUD: u32 = 115_200;

/// Polls of TXE before a telemetry message is given up: a byte takes 174 µs at 57600 baud
/// (≈ 29 000 core cycles); 100 000 polls (≈ 1 ms) only run out if the UART is dead.
const TXE_POLLS: u32 = 100_000;

/// Received bytes lost since boot: ring full or receiver overrun (ORE). Read by the sensor layer.
pub static RX_LOST: AtomicU32 = AtomicU32::new(0);

/// BRR for `baud` from the peripheral clock (16× oversampling: BRR = f_pclk / baud in 12.4 fixed
/// point, rounded; RM0090 §30.3.4). 84 MHz / 57600 → 1458 (0.02 % error); 42 MHz / 115200 → 365
/// (0.1 %).
fn brr(pclk_hz: u32, baud: u32) -> (u16, u8) {
    let div = (pclk_hz + baud / 2) / baud.max(1);
    (((div >> 4) & 0xFFF) as u16, (div & 0xF) as u8)
}

/// USART1 TX as a [`TelemetryPort`] (8N1).
pub struct TelemetryUart {
    usart: pac::USART1,
    /// Messages cut short by a TXE timeout.
    aborted: u32,
}

impl TelemetryUart {
    /// Configures USART1 (clock enabled and PA9 set by the caller) from the APB2 clock `pclk2_hz`.
    pub fn new(usart: pac::USART1, pclk2_hz: u32) -> Self {
        let (mantissa, fraction) = brr(pclk2_hz, TELEMETRY_BAUD);
        usart
            .brr()
            .write(|w| w.div_mantissa().set(mantissa).div_fraction().set(fraction));
        usart.cr1().write(|w| w.ue().enabled().te().enabled());
        Self { usart, aborted: 0 }
    }
}

impl TelemetryPort for TelemetryUart {
    /// Blocks for the UART (174 µs a byte at 57600 baud); a byte whose TXE does not come within
    /// [`TXE_POLLS`] ends the call: the rest of that report part (the receiver's MAVLink parser
    /// drops the partial frame).
    fn send(&mut self, bytes: &[u8]) {
        for b in bytes {
            if !(0..TXE_POLLS).any(|_| self.usart.sr().read().txe().bit_is_set()) {
                self.aborted = self.aborted.saturating_add(1);
                if self.aborted.is_power_of_two() {
                    defmt::warn!("telemetry: USART1 TXE timeout, {=u32} messages cut", self.aborted);
                }
                return;
            }
            self.usart.dr().write(|w| w.dr().set(u16::from(*b)));
        }
    }
}

/// Configures USART2 for reception with the RXNE interrupt (clock enabled and PA3 set by the caller).
pub fn autopilot_rx(usart: pac::USART2, pclk1_hz: u32, ring: Producer<'static, u8>) -> AutopilotRx {
    let (mantissa, fraction) = brr(pclk1_hz, AUTOPILOT_BAUD);
    usart
        .brr()
        .write(|w| w.div_mantissa().set(mantissa).div_fraction().set(fraction));
    usart
        .cr1()
        .write(|w| w.ue().enabled().re().enabled().rxneie().enabled());
    AutopilotRx { usart, ring }
}

/// The USART2 receive side, owned by the `usart2` interrupt task.
pub struct AutopilotRx {
    usart: pac::USART2,
    ring: Producer<'static, u8>,
}

impl AutopilotRx {
    /// The USART2 interrupt: moves the received byte into the ring. Reading SR then DR clears
    /// RXNE and the error flags (ORE, NF, FE, PE; RM0090 §30.6.1); a byte with a framing or noise
    /// error is still passed on (the MAVLink checksum rejects its frame).
    pub fn on_interrupt(&mut self) {
        let sr = self.usart.sr().read();
        let byte = self.usart.dr().read().dr().bits() as u8;
        let mut lost = u32::from(sr.ore().bit_is_set());
        if sr.rxne().bit_is_set() && self.ring.enqueue(byte).is_err() {
            lost += 1;
        }
        if lost > 0 {
            RX_LOST.fetch_add(lost, Ordering::Relaxed);
        }
    }
}

/// The consumer side of the ring, kept by the sensors.
pub type AutopilotBytes = Consumer<'static, u8>;
