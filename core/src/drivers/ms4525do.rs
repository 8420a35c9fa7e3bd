//! TE Connectivity (MEAS) **MS4525DO** digital differential-pressure sensor, as the pitot airspeed sensor.
//!
//! The part answers an I2C read with a 4-byte frame (datasheet §1.6.1, "I2C Read_DF", Read_DF4): two
//! status bits and a 14-bit bridge (pressure) count, then an 11-bit temperature count whose last
//! 5 bits are undetermined and masked off. This driver turns the frame into a [`Measurement`]:
//! differential pressure in Pa (pressure output transfer function, type A 10 %–90 % or type B
//! 5 %–95 % of 2¹⁴ counts over the ordered range, e.g. `001PD` = ±1 psi), temperature in °C
//! (temperature output transfer function, 0…2047 counts over −50…150 °C) and the airspeed
//! `V = sqrt(2 Δp / ρ)` after the ground zero offset.
//!
//! The -I parts update continuously (the data-fetch read returns the latest conversion), so one
//! read is one sample; reading faster than the response time returns status `10` (stale), which is
//! an [`Error::Stale`], never a repeated sample.
//!
//! ## Why our own driver
//! We checked the `ms4525do` crate (0.1.0, blocking API behind its `blocking` feature). It does not
//! fit: the transfer function is hard-wired to output type A and the ±1 psi range (with the sign
//! flipped), its error type drops the bus error (`I2cError` without the HAL error), every read
//! needs a `DelayNs` and two frames and reports a stale frame as an invalid status sequence rather
//! than as stale data, its airspeed takes `|Δp|` (a swapped pitot/static pair reads as a positive
//! speed) with a fixed sea-level density, and it has no zero-offset calibration or range check.
//! This module is written from the datasheet.
//!
//! ## Negative differential pressure
//! After the zero offset, `Δp` in `[−noise_band_pa, 0)` is sensor noise around zero airspeed and
//! gives `airspeed_mps = 0`. A `Δp` below `−noise_band_pa` is kept as a reading: the airspeed is
//! returned *signed*, `−sqrt(2 |Δp| / ρ)`. The sensor is healthy (status `00`, in range); a
//! negative speed means reversed flow at the probe or swapped pitot/static tubes, and it stays
//! visible in the logs instead of being folded into a plausible positive speed. The consumer's
//! plausibility gate refuses it (the pipeline's
//! [`min_airspeed_mps`](crate::aero::pipeline::Limits::min_airspeed_mps), 5 m/s by default).

use embedded_hal::delay::DelayNs;
use embedded_hal::i2c::I2c;

/// Default 7-bit I2C address of the `-I` interface option (datasheet, ordering information).
pub const DEFAULT_ADDRESS: u8 = 0x28;

/// Full-scale of the 14-bit bridge count, `2¹⁴ − 1` (pressure output transfer function).
pub const PRESSURE_COUNT_FULL_SCALE: f32 = 16383.0;

/// Full-scale of the 11-bit temperature count, `2¹¹ − 1` (temperature output transfer function).
pub const TEMPERATURE_COUNT_FULL_SCALE: f32 = 2047.0;

/// Pascal per psi (1 psi = 6894.757 Pa).
pub const PA_PER_PSI: f32 = 6894.757;

/// ISA sea-level air density, kg/m³: the default density gives indicated (equivalent) airspeed.
pub const ISA_SEA_LEVEL_DENSITY_KG_M3: f32 = 1.225;

/// Specific gas constant of dry air, J/(kg·K), for [`air_density_kg_m3`].
pub const R_DRY_AIR_J_KG_K: f32 = 287.05;

/// Status bits 15:14 of the first frame byte (datasheet §1.6.1 and the status-bit table).
mod status {
    /// `00`: normal operation, good data packet.
    pub const NORMAL: u8 = 0b00;
    /// `01`: reserved (command mode); never sent in normal operation.
    pub const RESERVED: u8 = 0b01;
    /// `10`: stale data, already fetched since the last conversion.
    pub const STALE: u8 = 0b10;
    /// `11`: fault detected.
    pub const FAULT: u8 = 0b11;
}

/// Mask of the bridge-count bits 13:8 in the first byte (the two status bits above them).
const BRIDGE_MSB_MASK: u8 = 0b0011_1111;
/// Mask of the temperature bits 2:0 in the fourth byte (bits 7:5; the low 5 bits are undetermined).
const TEMPERATURE_LSB_MASK: u8 = 0b1110_0000;

/// Errors of the MS4525DO driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<CommE> {
    /// The I2C bus reported an error (NACK, arbitration loss, …).
    Bus(CommE),
    /// Status `10`: the frame was already fetched since the last conversion (read too fast).
    Stale,
    /// Status `11`: the sensor reports a fault (e.g. broken bridge, EEPROM error).
    Fault,
    /// Status `01`: reserved (command mode), which the part does not send in normal operation.
    ReservedStatus,
    /// The bridge count lies outside the calibrated output span of the configured output type
    /// (the pressure is outside the sensor range, or the bridge is open or shorted).
    OutOfRange,
    /// A configuration value is out of its documented range; the previous configuration is kept.
    InvalidConfig,
}

/// Output type: the fraction of the 14-bit count span that maps the ordered pressure range
/// (datasheet, pressure output transfer function; letter after the range in the part number).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputType {
    /// Type A: 10 % to 90 % of 16383 counts.
    A,
    /// Type B: 5 % to 95 % of 16383 counts.
    B,
}

impl OutputType {
    /// The (low, high) fractions of full scale that correspond to `p_min` and `p_max`.
    pub fn span_fractions(self) -> (f32, f32) {
        match self {
            OutputType::A => (0.10, 0.90),
            OutputType::B => (0.05, 0.95),
        }
    }
}

/// Driver configuration, cached in the driver and validated by [`Ms4525do::set_config`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Output type A or B.
    pub output_type: OutputType,
    /// Pressure at the low end of the output span, psi (`−1` for `001PD`, `0` for a gauge part).
    pub p_min_psi: f32,
    /// Pressure at the high end of the output span, psi (`+1` for `001PD`).
    pub p_max_psi: f32,
    /// Air density used for [`Measurement::airspeed_mps`], kg/m³. The default (ISA sea level)
    /// gives indicated/equivalent airspeed; set the current density (see [`air_density_kg_m3`])
    /// for true airspeed.
    pub air_density_kg_m3: f32,
    /// Differential pressure read at rest on the ground, Pa, subtracted from every reading
    /// (see [`Ms4525do::calibrate_zero`]).
    pub zero_offset_pa: f32,
    /// Half-width of the band around zero, Pa, in which a negative `Δp` is noise and gives zero
    /// airspeed (module doc, "Negative differential pressure"). `≥ 0`.
    pub noise_band_pa: f32,
}

impl Default for Config {
    /// The common airspeed part 4525DO-DS5AI001DP: type A, ±1 psi, ISA density, no offset,
    /// 5 Pa noise band (about 5 counts on the ±1 psi range).
    fn default() -> Self {
        Self {
            output_type: OutputType::A,
            p_min_psi: -1.0,
            p_max_psi: 1.0,
            air_density_kg_m3: ISA_SEA_LEVEL_DENSITY_KG_M3,
            zero_offset_pa: 0.0,
            noise_band_pa: 5.0,
        }
    }
}

/// Bounds of a valid [`Config`] beyond finiteness: every reading computed with it is then finite
/// (the `drivers` fuzz target found that a subnormal density — finite and positive — gave an
/// infinite airspeed, and a huge pressure range an infinite pressure). The widest MS4525DO range is
/// 150 psi; 0.01 kg/m³ is the air density near 30 km.
pub mod limits {
    /// Largest `|p_min_psi|`, `|p_max_psi|`, psi.
    pub const MAX_RANGE_PSI: f32 = 1000.0;
    /// Smallest air density, kg/m³.
    pub const MIN_DENSITY_KG_M3: f32 = 0.01;
    /// Largest `|zero_offset_pa|` and `noise_band_pa`, Pa.
    pub const MAX_OFFSET_PA: f32 = 1.0e6;
}

impl Config {
    fn is_valid(&self) -> bool {
        let range = |p: f32| p.is_finite() && p.abs() <= limits::MAX_RANGE_PSI;
        range(self.p_min_psi)
            && range(self.p_max_psi)
            && self.p_min_psi < self.p_max_psi
            && self.air_density_kg_m3.is_finite()
            && self.air_density_kg_m3 >= limits::MIN_DENSITY_KG_M3
            && self.zero_offset_pa.is_finite()
            && self.zero_offset_pa.abs() <= limits::MAX_OFFSET_PA
            && self.noise_band_pa.is_finite()
            && self.noise_band_pa >= 0.0
            && self.noise_band_pa <= limits::MAX_OFFSET_PA
    }

    /// Differential pressure, Pa, of a 14-bit bridge count (pressure output transfer function):
    /// `P = (count − f_lo·16383)·(P_max − P_min)/((f_hi − f_lo)·16383) + P_min`, in psi, times
    /// [`PA_PER_PSI`]. `None` when the count lies outside `[f_lo·16383, f_hi·16383]`.
    pub fn pressure_pa(&self, count: u16) -> Option<f32> {
        let (lo, hi) = self.output_type.span_fractions();
        let count_lo = lo * PRESSURE_COUNT_FULL_SCALE;
        let count_hi = hi * PRESSURE_COUNT_FULL_SCALE;
        let c = f32::from(count);
        if c < count_lo || c > count_hi {
            return None;
        }
        let psi = (c - count_lo) * (self.p_max_psi - self.p_min_psi) / (count_hi - count_lo) + self.p_min_psi;
        Some(psi * PA_PER_PSI)
    }
}

/// Temperature, °C, of an 11-bit temperature count (temperature output transfer function):
/// `T = count·200/2047 − 50`.
pub fn temperature_c(count: u16) -> f32 {
    f32::from(count) * 200.0 / TEMPERATURE_COUNT_FULL_SCALE - 50.0
}

/// Airspeed, m/s, from a differential pressure and an air density: `V = sqrt(2 Δp / ρ)`, signed as
/// `Δp` (a negative `Δp` gives `−sqrt(2 |Δp| / ρ)`). No noise band: see [`Measurement::airspeed_mps`].
pub fn airspeed_mps(differential_pressure_pa: f32, air_density_kg_m3: f32) -> f32 {
    let v = libm::sqrtf(2.0 * libm::fabsf(differential_pressure_pa) / air_density_kg_m3);
    if differential_pressure_pa < 0.0 {
        -v
    } else {
        v
    }
}

/// Air density, kg/m³, from static pressure and outside air temperature (ideal gas,
/// `ρ = p / (R T)`), for true airspeed.
pub fn air_density_kg_m3(static_pressure_pa: f32, temperature_c: f32) -> f32 {
    static_pressure_pa / (R_DRY_AIR_J_KG_K * (temperature_c + 273.15))
}

/// One good reading.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// Differential pressure after the zero offset, Pa (positive: pitot above static).
    pub pressure_pa: f32,
    /// Differential pressure before the zero offset, Pa (what the transfer function gives).
    pub raw_pressure_pa: f32,
    /// Sensor (die) temperature, °C.
    pub temperature_c: f32,
    /// Airspeed, m/s, from `pressure_pa` and the configured density; `0` inside the noise band
    /// below zero, negative below it (module doc, "Negative differential pressure").
    pub airspeed_mps: f32,
    /// The 14-bit bridge count.
    pub pressure_count: u16,
    /// The 11-bit temperature count.
    pub temperature_count: u16,
}

/// Read counters, for telemetry. They saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Good readings returned.
    pub ok: u32,
    /// Bus errors (NACK and others).
    pub bus_errors: u32,
    /// Stale frames (status `10`).
    pub stale: u32,
    /// Fault frames (status `11`) and reserved status `01`.
    pub faults: u32,
    /// Bridge counts outside the output span.
    pub out_of_range: u32,
}

/// MS4525DO driver over a blocking embedded-hal 1.0 I2C bus.
#[derive(Debug)]
pub struct Ms4525do<I2C> {
    i2c: I2C,
    address: u8,
    config: Config,
    health: Health,
}

impl<I2C, E> Ms4525do<I2C>
where
    I2C: I2c<Error = E>,
{
    /// A driver at `address` (0x28 for the `-I` option; `-J` 0x36, `-K` 0x46, `-0`…`-9`
    /// 0x48…0x51) with the default [`Config`] (type A, ±1 psi). No bus traffic.
    pub fn new(i2c: I2C, address: u8) -> Self {
        Self {
            i2c,
            address,
            config: Config::default(),
            health: Health::default(),
        }
    }

    /// Give the bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }

    /// The cached configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Replace the configuration; an invalid one (non-finite values, `p_min ≥ p_max`, a density
    /// below [`limits::MIN_DENSITY_KG_M3`], a range, offset or noise band beyond [`limits`], a
    /// negative noise band) is refused with [`Error::InvalidConfig`] and the old one kept.
    pub fn set_config(&mut self, config: Config) -> Result<(), Error<E>> {
        if !config.is_valid() {
            return Err(Error::InvalidConfig);
        }
        self.config = config;
        Ok(())
    }

    /// Set the zero offset, Pa (a finite value, else [`Error::InvalidConfig`]).
    pub fn set_zero_offset_pa(&mut self, zero_offset_pa: f32) -> Result<(), Error<E>> {
        self.set_config(Config {
            zero_offset_pa,
            ..self.config
        })
    }

    /// Set the air density used for the airspeed, kg/m³ (finite and `> 0`, else
    /// [`Error::InvalidConfig`]).
    pub fn set_air_density_kg_m3(&mut self, air_density_kg_m3: f32) -> Result<(), Error<E>> {
        self.set_config(Config {
            air_density_kg_m3,
            ..self.config
        })
    }

    /// The read counters.
    pub fn health(&self) -> Health {
        self.health
    }

    /// Read one frame (Read_DF4, 4 bytes) and convert it. Every outcome is counted in [`Health`].
    ///
    /// # Errors
    /// [`Error::Bus`], [`Error::Stale`], [`Error::Fault`], [`Error::ReservedStatus`],
    /// [`Error::OutOfRange`].
    pub fn read(&mut self) -> Result<Measurement, Error<E>> {
        let result = self.read_uncounted();
        let h = &mut self.health;
        let counter = match result {
            Ok(_) => &mut h.ok,
            Err(Error::Bus(_)) => &mut h.bus_errors,
            Err(Error::Stale) => &mut h.stale,
            Err(Error::Fault) | Err(Error::ReservedStatus) => &mut h.faults,
            Err(Error::OutOfRange) | Err(Error::InvalidConfig) => &mut h.out_of_range,
        };
        *counter = counter.saturating_add(1);
        result
    }

    /// Average `samples` good readings at rest on the ground (no wind at the probe) and store the
    /// mean raw differential pressure as the zero offset; returns it, Pa.
    ///
    /// Waits `interval_us` before each read so that the sensor has a new conversion. A stale
    /// frame is not counted and is read again; at most `4·samples` reads are made, then
    /// [`Error::Stale`]. Any other error stops the calibration. On error the previous offset is
    /// kept. `samples == 0` is [`Error::InvalidConfig`].
    pub fn calibrate_zero<D: DelayNs>(
        &mut self,
        delay: &mut D,
        samples: u16,
        interval_us: u32,
    ) -> Result<f32, Error<E>> {
        if samples == 0 {
            return Err(Error::InvalidConfig);
        }
        let max_reads = u32::from(samples) * 4;
        let mut sum_pa = 0.0f32;
        let mut good: u16 = 0;
        let mut reads: u32 = 0;
        while good < samples {
            if reads >= max_reads {
                return Err(Error::Stale);
            }
            reads += 1;
            delay.delay_us(interval_us);
            match self.read() {
                Ok(m) => {
                    sum_pa += m.raw_pressure_pa;
                    good += 1;
                }
                Err(Error::Stale) => {}
                Err(e) => return Err(e),
            }
        }
        let offset_pa = sum_pa / f32::from(samples);
        self.set_zero_offset_pa(offset_pa)?;
        Ok(offset_pa)
    }

    fn read_uncounted(&mut self) -> Result<Measurement, Error<E>> {
        let mut frame = [0u8; 4];
        self.i2c.read(self.address, &mut frame).map_err(Error::Bus)?;
        let [b0, b1, b2, b3] = frame;
        match b0 >> 6 {
            status::NORMAL => {}
            status::STALE => return Err(Error::Stale),
            status::FAULT => return Err(Error::Fault),
            status::RESERVED => return Err(Error::ReservedStatus),
            _ => return Err(Error::ReservedStatus),
        }
        let pressure_count = (u16::from(b0 & BRIDGE_MSB_MASK) << 8) | u16::from(b1);
        let temperature_count = (u16::from(b2) << 3) | u16::from((b3 & TEMPERATURE_LSB_MASK) >> 5);
        let raw_pressure_pa = self.config.pressure_pa(pressure_count).ok_or(Error::OutOfRange)?;
        let pressure_pa = raw_pressure_pa - self.config.zero_offset_pa;
        let airspeed = if pressure_pa < 0.0 && pressure_pa >= -self.config.noise_band_pa {
            0.0
        } else {
            airspeed_mps(pressure_pa, self.config.air_density_kg_m3)
        };
        Ok(Measurement {
            pressure_pa,
            raw_pressure_pa,
            temperature_c: temperature_c(temperature_count),
            airspeed_mps: airspeed,
            pressure_count,
            temperature_count,
        })
    }
}
