//! Sensor drivers over embedded-hal 1.0 buses, for the co-processor's sampling task.
//!
//! Each driver is generic over `embedded_hal::i2c::I2c` or `embedded_hal::spi::SpiDevice`, owns its
//! bus handle (release it with `release`/`destroy`), and turns register bytes into SI readings.
//! A bus error, a NACK, a stale or out-of-range reading is an `Err`, never a sample: the sampling
//! task marks the channel bad in the [`crate::aero::SensorSample`] it builds, and the pipeline refuses
//! only the coefficients that need that channel.
//!
//! * [`icm42688`] — TDK InvenSense ICM-42688-P gyroscope + accelerometer over SPI.
//! * [`ms4525do`] — TE MS4525DO differential-pressure airspeed sensor over I2C.
//! * [`as5600`] — ams AS5600 magnetic encoder as an α or β vane over I2C, with zero/direction
//!   calibration.
//!
//! The control surfaces, throttle and propeller speed reach the co-processor from the autopilot as
//! MAVLink frames on a UART: [`crate::mavlink::surfaces`] behind the `SurfaceSource` trait.

pub mod as5600;
pub mod icm42688;
pub mod ms4525do;
