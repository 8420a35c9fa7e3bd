//! The flight computer's board (STM32F405RG): the sensors on their buses, the autopilot link, the
//! telemetry UART and the DWT cycle counter.
//!
//! ## Pin map (a common F405 flight-controller layout)
//! | function | peripheral | pins (alternate function) | settings |
//! |---|---|---|---|
//! | ICM-42688-P IMU | SPI1 | PA5 SCK, PA6 MISO, PA7 MOSI (AF5); PA4 chip select (GPIO out) | mode 3, 21 MHz |
//! | MS4525DO airspeed (0x28), AS5600 α vane (0x36) | I2C1 | PB6 SCL, PB7 SDA (AF4, open drain) | 400 kHz |
//! | AS5600 β vane (0x36) | I2C2 | PB10 SCL, PB11 SDA (AF4, open drain) | 400 kHz |
//! | telemetry out (MAVLink) | USART1 | PA9 TX (AF7) | 57600 8N1 |
//! | autopilot in (MAVLink) | USART2 | PA3 RX (AF7) | 115200 8N1, RXNE interrupt |
//!
//! The two vanes are the same part at the same fixed address, hence two buses. The I2C pins get the
//! internal pull-ups as well (≈ 40 kΩ; the board's external 2.2–4.7 kΩ set the rise time).
//!
//! ## Bus code: our own, on the PAC — why not `stm32f4xx-hal`
//! `stm32f4xx-hal` 0.23.0 (the newest) resolves with our `stm32f4 = 0.16.0` (one PAC linked) and
//! rustc 1.95, and it would be the project's first choice. It does not fit two rules:
//! * its blocking I2C waits on SB, ADDR, BTF and STOP in unbounded loops (`while … {}`), so a slave
//!   holding SDA low or a missing pull-up hangs the 100 Hz sampling task for good: the project needs
//!   every wait bounded with an error;
//! * its bus constructors take a `Clocks` that only its own `Rcc::freeze` produces (the fields are
//!   private); `freeze` would set the clock tree a second time, with unbounded waits on HSE and PLL
//!   ready and no HSI fallback, against `clocks.rs`; `constrain()` alone says 16 MHz everywhere, so
//!   baud rates and the I2C timing would be wrong.
//!
//! So the embedded-hal 1.0 bus traits are implemented on the registers in [`bus`] (I2C master,
//! SPI1 bus, chip select, delay; every wait bounded) and [`uart`], and the well-kept
//! `embedded-hal-bus` does the device layering: `ExclusiveDevice` makes SPI1 + PA4 an `SpiDevice`
//! (chip select released even when a transfer fails) and `AtomicDevice` shares I2C1 between the
//! airspeed sensor and the α vane.
//!
//! ## Channels of a sample
//! * **accel, gyro** — ICM-42688-P, ±16 g, ±2000 °/s (nothing clips in aerobatics), both at 200 Hz
//!   output data rate (the data-ready flag is always set at 100 Hz reads; the UI filter's default
//!   ODR/4 = 50 Hz bandwidth keeps aliasing low), body FRD through [`IMU_AXIS_MAP`].
//! * **airspeed, air density** — MS4525DO (4525DO-DS5AI001DP: type A, ±1 psi), zero offset averaged
//!   at boot ([`CALIBRATE_AIRSPEED_AT_BOOT`]: the aircraft must be at rest with the pitot covered).
//!   No static-pressure sensor on this board, so the density is `ρ = p_field / (R · T)` with the
//!   configured field pressure [`FIELD_PRESSURE_PA`] (ISA sea level, 101 325 Pa: 1.225 kg/m³ at
//!   15 °C) and the MS4525DO's die temperature `T` as outside air temperature (it sits in the
//!   airflow in the fuselage; a few kelvin error is ≈ 1 % in ρ). The airspeed is true airspeed:
//!   the driver's equivalent airspeed (at 1.225 kg/m³) times `sqrt(1.225 / ρ)`.
//! * **α, β** — AS5600 vanes on I2C1 and I2C2, calibrations [`ALPHA_VANE`], [`BETA_VANE`].
//! * **surfaces, throttle, RPM, Euler angles** — the autopilot's `SERVO_OUTPUT_RAW`, `RPM` and
//!   `ATTITUDE` on USART2 ([`MavlinkSurfaces`], calibrations in `aerosid_core::aero::onboard::AUTOPILOT_LINK`).
//!
//! The calibrations (vane zero counts, servo neutral and gain, …) are placeholders for a typical
//! airframe: set them for the aircraft. Every failed read makes its channels NaN, never a stale
//! value, and counts in [`SensorHealth`]; a channel that repeats its reading bit for bit for
//! its window (a frozen chip, a jammed vane) is set to NaN too ([`Finish`], the core's
//! `StuckDetector`). A chip that fails [`REINIT_AFTER`] reads in a row
//! (0.5 s) is re-initialised: the IMU with its full `init` (WHO_AM_I, soft reset, configuration,
//! ≈ 1.2 ms busy wait inside the sampling task), an I2C chip by resetting its bus peripheral (the
//! MS4525DO and the AS5600 keep no configuration on the chip). A chip absent at boot is retried the
//! same way; boot never stops for a sensor.

mod bus;
mod uart;

use core::convert::Infallible;
use core::sync::atomic::{AtomicBool, Ordering};

use aerosid_core::aero::onboard::AUTOPILOT_LINK;
use aerosid_core::aero::SensorSample;
use aerosid_core::drivers::as5600::{As5600, Direction, VaneConfig};
use aerosid_core::drivers::icm42688::{self, AccelRange, AxisMap, GyroRange, Icm42688, Odr};
use aerosid_core::drivers::ms4525do::{self, Ms4525do};
use aerosid_core::mavlink::MavlinkSurfaces;
use embedded_hal_bus::i2c::{AtomicDevice, AtomicError};
use embedded_hal_bus::spi::{DeviceError, ExclusiveDevice};
use embedded_hal_bus::util::AtomicCell;
use heapless::spsc::Queue;
use nalgebra::Vector3;
use stm32f4::stm32f405 as pac;

use super::{Counter, Finish, LinkHealth, SensorHealth, SensorSource, REINIT_AFTER};
use bus::{ChipSelectPa4, CycleDelay, I2cBus, I2cError, Spi1Bus, SpiError};
pub use uart::AutopilotRx;
use uart::{AutopilotBytes, TelemetryUart};

/// The sensors of this board (in a static: see [`init`]).
pub type Sensors = &'static mut FlightSensors;
/// The telemetry port of this board.
pub type Port = TelemetryUart;
/// The step counter of this board.
pub type CycleCounter = Dwt;

/// Field (static) pressure for the air density, Pa: ISA sea level. Set the airfield's QFE.
pub const FIELD_PRESSURE_PA: f32 = 101_325.0;

/// Average the airspeed sensor's zero offset at boot (50 readings over ≈ 100 ms).
pub const CALIBRATE_AIRSPEED_AT_BOOT: bool = true;

/// IMU mounting: chip X forward, Y right, Z down (change for the board's orientation).
pub const IMU_AXIS_MAP: AxisMap = AxisMap::IDENTITY;

/// α vane: zero at mid-scale, angle growing with the count, plausible within ±35°. Placeholder.
pub const ALPHA_VANE: VaneConfig = VaneConfig {
    zero_count: 2048,
    direction: Direction::CountsIncrease,
    scale: 1.0,
    min_angle_rad: -0.61,
    max_angle_rad: 0.61,
};

/// β vane: as the α vane. Placeholder.
pub const BETA_VANE: VaneConfig = ALPHA_VANE;

/// Autopilot bytes the ring holds (255: heapless keeps one slot free): 22 ms at 115200 baud
/// (11.5 bytes/ms), twice the 10 ms between the `sample` task's drains. The drain comes first in
/// each read, before any sensor I/O (a failing I2C chip may take its bus timeout, ≈ 2 ms each, and
/// an IMU re-initialisation ≈ 1.2 ms, which would otherwise stretch the gap between drains to
/// ≈ 18 ms); only the USART2 handler and SysTick run above the `sample` task, and the `stats` lock
/// it shares is held for a copy. What can still hold it off for longer is defmt: with a probe
/// attached, probe-rs switches RTT to blocking mode, and a log line written into a full RTT buffer
/// waits for the host with interrupts masked (bench runs only). Bytes lost are counted
/// (`RX_LOST`, the health report's `LINK_LOST`).
const RX_RING: usize = 256;

/// Specific gas constant of dry air, J/(kg·K).
const R_AIR: f32 = ms4525do::R_DRY_AIR_J_KG_K;

type I2c1 = I2cBus<pac::I2C1>;
type I2c2 = I2cBus<pac::I2C2>;
type ImuSpi = ExclusiveDevice<Spi1Bus, ChipSelectPa4, CycleDelay>;

/// Recovery requests from the sensor layer to the I2C buses (see [`I2cBus`]).
static I2C1_RECOVER: AtomicBool = AtomicBool::new(false);
static I2C2_RECOVER: AtomicBool = AtomicBool::new(false);

/// The board's parts, handed to the tasks by `init`.
pub struct Board {
    /// The sensors.
    pub sensors: &'static mut FlightSensors,
    /// Telemetry UART (USART1).
    pub telemetry: TelemetryUart,
    /// DWT cycle counter.
    pub counter: Dwt,
    /// Per-sample counts (not recorded on hardware: the telemetry carries the last and the worst).
    pub counts: CountLog,
    /// The USART2 receive interrupt's state (for the `usart2` task in `main.rs`).
    pub autopilot_rx: AutopilotRx,
}

/// Per-sample counts: not recorded on hardware.
pub struct CountLog;

impl CountLog {
    /// Discards one sample's counts.
    pub fn write(&mut self, _counts: &[u32]) {}
}

/// Brings up the board: clocks to the peripherals, pins, buses, UARTs, then the chips. A chip that
/// does not answer is reported and retried by [`FlightSensors::read`]; nothing here stops the boot.
/// Only a second call (a program error: the static buffers are already handed out) halts. The
/// sensors (drivers, link parser, stuck detector) go into a static, built in this function's frame,
/// which is not inlined: RTIC keeps `init`'s own frame under every task's first run
/// (`crate::estimate::Estimator::new`), so what `init` gets back must be small.
#[inline(never)]
pub fn init(dp: pac::Peripherals, clocks: &super::clocks::Clocks) -> Board {
    enable_clocks(&dp.RCC);
    configure_pins(&dp.GPIOA, &dp.GPIOB);

    let mut delay = CycleDelay::new(clocks.sysclk_hz);
    let telemetry = TelemetryUart::new(dp.USART1, clocks.pclk2_hz);

    let Some(ring) = cortex_m::singleton!(: Queue<u8, RX_RING> = Queue::new()) else {
        defmt::error!("board: init called twice");
        halt(4)
    };
    let (producer, consumer) = ring.split();
    let autopilot_rx = uart::autopilot_rx(dp.USART2, clocks.pclk1_hz, producer);

    let i2c1 = I2cBus::new(dp.I2C1, clocks.pclk1_hz, &I2C1_RECOVER);
    let i2c2 = I2cBus::new(dp.I2C2, clocks.pclk1_hz, &I2C2_RECOVER);
    let (Some(i2c1), Some(i2c2)) = (
        cortex_m::singleton!(: AtomicCell<I2c1> = AtomicCell::new(i2c1)),
        cortex_m::singleton!(: AtomicCell<I2c2> = AtomicCell::new(i2c2)),
    ) else {
        defmt::error!("board: init called twice");
        halt(4)
    };
    let i2c1: &'static AtomicCell<I2c1> = i2c1;
    let i2c2: &'static AtomicCell<I2c2> = i2c2;

    let spi = Spi1Bus::new(dp.SPI1, clocks.pclk2_hz);
    let spi = match ExclusiveDevice::new(spi, ChipSelectPa4::new(dp.GPIOA), delay) {
        Ok(d) => d,
        Err(never) => match never {},
    };
    let imu_config = icm42688::Config {
        gyro_range: GyroRange::Dps2000,
        gyro_odr: Odr::Hz200,
        accel_range: AccelRange::G16,
        accel_odr: Odr::Hz200,
        axis_map: IMU_AXIS_MAP,
    };
    let mut imu = Icm42688::new(spi, imu_config);
    match imu.init(&mut delay) {
        Ok(()) => defmt::info!("imu: ICM-42688-P up"),
        Err(e) => defmt::error!("imu: init failed ({}), retried while sampling", imu_error(e)),
    }

    let mut airspeed = Ms4525do::new(AtomicDevice::new(i2c1), ms4525do::DEFAULT_ADDRESS);
    if CALIBRATE_AIRSPEED_AT_BOOT {
        match airspeed.calibrate_zero(&mut delay, 50, 2_000) {
            Ok(offset_pa) => defmt::info!("airspeed: zero offset {=f32} Pa", offset_pa),
            Err(e) => defmt::error!("airspeed: zero calibration failed ({}), offset 0", airspeed_error(e)),
        }
    }
    let mut alpha = As5600::new(AtomicDevice::new(i2c1));
    let mut beta = As5600::new(AtomicDevice::new(i2c2));
    if alpha.set_config(ALPHA_VANE).is_err() {
        defmt::error!("alpha vane: calibration refused");
    }
    if beta.set_config(BETA_VANE).is_err() {
        defmt::error!("beta vane: calibration refused");
    }

    let autopilot = match MavlinkSurfaces::new(AUTOPILOT_LINK) {
        Ok(s) => Some(s),
        Err(e) => {
            defmt::error!("autopilot link: configuration refused ({})", e);
            None
        }
    };

    let Some(sensors) = cortex_m::singleton!(: FlightSensors = FlightSensors {
        imu,
        airspeed,
        alpha,
        beta,
        autopilot,
        rx: consumer,
        delay,
        now_us: 0,
        rx_lost_seen: 0,
        health: SensorHealth::default(),
        finish: Finish::new(),
    }) else {
        defmt::error!("board: init called twice");
        halt(4)
    };
    Board {
        sensors,
        telemetry,
        counter: Dwt,
        counts: CountLog,
        autopilot_rx,
    }
}

/// Peripheral clocks: GPIOA, GPIOB, SPI1, USART1 (APB2), I2C1, I2C2, USART2 (APB1).
fn enable_clocks(rcc: &pac::RCC) {
    rcc.ahb1enr().modify(|_, w| w.gpioaen().set_bit().gpioben().set_bit());
    rcc.apb2enr().modify(|_, w| w.spi1en().set_bit().usart1en().set_bit());
    rcc.apb1enr()
        .modify(|_, w| w.i2c1en().set_bit().i2c2en().set_bit().usart2en().set_bit());
    // RM0090 §6.3.13 note: a read-back delays the first access to the newly clocked peripherals.
    let _ = rcc.apb1enr().read();
}

/// The pin map of the module doc.
fn configure_pins(gpioa: &pac::GPIOA, gpiob: &pac::GPIOB) {
    // PA4: chip select, high (deselected) before it becomes an output.
    gpioa.bsrr().write(|w| w.bs4().set_bit());
    gpioa.otyper().modify(|_, w| w.ot4().push_pull());
    gpioa.ospeedr().modify(|_, w| {
        w.ospeedr4().high_speed();
        w.ospeedr5().very_high_speed();
        w.ospeedr6().very_high_speed();
        w.ospeedr7().very_high_speed()
    });
    gpioa.afrl().modify(|_, w| {
        w.afrl3().af7(); // USART2 RX
        w.afrl5().af5(); // SPI1 SCK
        w.afrl6().af5(); // SPI1 MISO
        w.afrl7().af5() // SPI1 MOSI
    });
    gpioa.afrh().modify(|_, w| w.afrh9().af7()); // USART1 TX
    gpioa.pupdr().modify(|_, w| w.pupdr3().pull_up()); // idle-high RX line if unplugged
    gpioa.moder().modify(|_, w| {
        w.moder3().alternate();
        w.moder4().output();
        w.moder5().alternate();
        w.moder6().alternate();
        w.moder7().alternate();
        w.moder9().alternate()
    });

    // PB6/PB7 (I2C1), PB10/PB11 (I2C2): AF4, open drain, pull-up.
    gpiob.otyper().modify(|_, w| {
        w.ot6().open_drain();
        w.ot7().open_drain();
        w.ot10().open_drain();
        w.ot11().open_drain()
    });
    gpiob.pupdr().modify(|_, w| {
        w.pupdr6().pull_up();
        w.pupdr7().pull_up();
        w.pupdr10().pull_up();
        w.pupdr11().pull_up()
    });
    gpiob.ospeedr().modify(|_, w| {
        w.ospeedr6().medium_speed();
        w.ospeedr7().medium_speed();
        w.ospeedr10().medium_speed();
        w.ospeedr11().medium_speed()
    });
    gpiob.afrl().modify(|_, w| w.afrl6().af4().afrl7().af4());
    gpiob.afrh().modify(|_, w| w.afrh10().af4().afrh11().af4());
    gpiob.moder().modify(|_, w| {
        w.moder6().alternate();
        w.moder7().alternate();
        w.moder10().alternate();
        w.moder11().alternate()
    });
}

/// The IMU's error without the SPI device layer (for the log).
fn imu_error(e: icm42688::Error<DeviceError<SpiError, Infallible>>) -> icm42688::Error<SpiError> {
    use icm42688::Error as E;
    match e {
        E::Bus(DeviceError::Spi(e)) => E::Bus(e),
        E::Bus(DeviceError::Cs(never)) => match never {},
        E::WrongDevice(id) => E::WrongDevice(id),
        E::NotReady => E::NotReady,
        E::InvalidData => E::InvalidData,
        E::Saturated => E::Saturated,
    }
}

/// The airspeed sensor's error without the bus-sharing layer (for the log; `Busy`, a program
/// error since one task owns both devices, shows as a bus error).
fn airspeed_error(e: ms4525do::Error<AtomicError<I2cError>>) -> ms4525do::Error<I2cError> {
    use ms4525do::Error as E;
    match e {
        E::Bus(AtomicError::Other(e)) => E::Bus(e),
        E::Bus(AtomicError::Busy) => E::Bus(I2cError::Bus),
        E::Stale => E::Stale,
        E::Fault => E::Fault,
        E::ReservedStatus => E::ReservedStatus,
        E::OutOfRange => E::OutOfRange,
        E::InvalidConfig => E::InvalidConfig,
    }
}

/// The sensors on their buses and the autopilot link, as a [`SensorSource`].
pub struct FlightSensors {
    imu: Icm42688<ImuSpi>,
    airspeed: Ms4525do<AtomicDevice<'static, I2c1>>,
    alpha: As5600<AtomicDevice<'static, I2c1>>,
    beta: As5600<AtomicDevice<'static, I2c2>>,
    autopilot: Option<MavlinkSurfaces>,
    rx: AutopilotBytes,
    delay: CycleDelay,
    /// Time of the current sample, µs since boot: the sum of the `dt_s` (the sampler's µs
    /// differences, so exact), for the autopilot messages' ages.
    now_us: u64,
    rx_lost_seen: u32,
    health: SensorHealth,
    /// The stuck-sensor check on the finished sample.
    finish: Finish,
}

impl FlightSensors {
    /// Drains the USART2 ring into the MAVLink parser, stamping the bytes with `now_us` (they arrived
    /// within the last sample period, so ages read up to 10 ms short). Bounded: at most a ring's
    /// worth of bytes per sample (more than arrive in a period at 115200 baud), so a flood on the
    /// link cannot hold the sampling task; the parser's work per byte is bounded too.
    fn receive_autopilot(&mut self) {
        let mut chunk = [0u8; 64];
        for _ in 0..RX_RING.div_ceil(64) {
            let mut n = 0;
            for slot in chunk.iter_mut() {
                match self.rx.dequeue() {
                    Some(b) => {
                        *slot = b;
                        n += 1;
                    }
                    None => break,
                }
            }
            if n == 0 {
                break;
            }
            if let (Some(link), Some(bytes)) = (self.autopilot.as_mut(), chunk.get(..n)) {
                link.receive(bytes, self.now_us);
            }
        }
        let lost = uart::RX_LOST.load(Ordering::Relaxed);
        if lost != self.rx_lost_seen {
            defmt::warn!("autopilot link: {=u32} received bytes lost", lost);
            self.rx_lost_seen = lost;
        }
    }
}

impl SensorSource for FlightSensors {
    fn read(&mut self, t_s: f32, dt_s: f32) -> Option<SensorSample<f32>> {
        let nan = f32::NAN;
        let mut s = SensorSample::from_fields(&[nan; aerosid_core::aero::SAMPLE_FIELDS]);
        s.t_s = t_s;
        s.dt_s = dt_s;
        // Saturating float-to-int cast: a NaN or negative dt adds 0.
        self.now_us = self.now_us.saturating_add((dt_s * 1e6 + 0.5) as u64);

        // The autopilot's bytes first, before any sensor I/O can delay the drain (`RX_RING`).
        self.receive_autopilot();

        // IMU.
        let imu = self.imu.read();
        if let Ok(r) = &imu {
            s.accel_mps2 = Vector3::from(r.accel_mps2);
            s.gyro_rad_s = Vector3::from(r.gyro_rad_s);
        }
        if self.health.imu.record(imu.is_ok()) {
            match self.imu.init(&mut self.delay) {
                Ok(()) => defmt::warn!("imu: re-initialised"),
                Err(e) => defmt::warn!("imu: re-init failed ({})", imu_error(e)),
            }
        }

        // Airspeed and density.
        let air = self.airspeed.read();
        if let Ok(m) = &air {
            let rho = FIELD_PRESSURE_PA / (R_AIR * (m.temperature_c + 273.15));
            if rho.is_finite() && rho > 0.0 {
                s.air_density_kgpm3 = rho;
                s.airspeed_mps = m.airspeed_mps * libm::sqrtf(ms4525do::ISA_SEA_LEVEL_DENSITY_KG_M3 / rho);
            }
        }
        if self.health.airspeed.record(air.is_ok()) {
            defmt::warn!("airspeed: {=u16} failed reads, I2C1 reset", REINIT_AFTER);
            I2C1_RECOVER.store(true, Ordering::Relaxed);
        }

        // Vanes.
        let alpha = self.alpha.read();
        if let Ok(r) = &alpha {
            s.alpha_rad = r.angle_rad;
        }
        if self.health.alpha_vane.record(alpha.is_ok()) {
            defmt::warn!("alpha vane: {=u16} failed reads, I2C1 reset", REINIT_AFTER);
            I2C1_RECOVER.store(true, Ordering::Relaxed);
        }
        let beta = self.beta.read();
        if let Ok(r) = &beta {
            s.beta_rad = r.angle_rad;
        }
        if self.health.beta_vane.record(beta.is_ok()) {
            defmt::warn!("beta vane: {=u16} failed reads, I2C2 reset", REINIT_AFTER);
            I2C2_RECOVER.store(true, Ordering::Relaxed);
        }

        // The autopilot: surfaces, throttle, RPM, attitude (from the bytes drained above).
        let now_us = self.now_us;
        let autopilot_ok = match self.autopilot.as_mut() {
            Some(link) => {
                let ok = link.fill(now_us, &mut s);
                self.health.link = LinkHealth::from_link(link, self.rx_lost_seen);
                ok
            }
            None => false,
        };
        if !autopilot_ok {
            self.health.autopilot_faults = self.health.autopilot_faults.saturating_add(1);
        }

        // A sensor stuck at one reading: its channels NaN.
        self.finish.apply(&mut s, &mut self.health);
        Some(s)
    }

    fn health(&self) -> SensorHealth {
        self.health
    }
}

/// DWT CYCCNT (started in `main`'s init before [`init`]).
pub struct Dwt;

impl Counter for Dwt {
    fn now(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }
}

/// Stops: on hardware there is no exit; a breakpoint if a probe is attached (without one, BKPT would
/// be a HardFault), then sleep forever.
pub fn halt(code: i32) -> ! {
    defmt::error!("halt({=i32})", code);
    if cortex_m::peripheral::DCB::is_debugger_attached() {
        cortex_m::asm::bkpt();
    }
    loop {
        cortex_m::asm::wfi();
    }
}
