//! Sensor drivers over embedded-hal 1.0 buses, for the co-processor's sampling task.
//!
//! Each driver is generic over `embedded_hal::i2c::I2c` or `embedded_hal::spi::SpiDevice`, owns its
//! bus handle (release it with `release`/`destroy`), and turns register bytes into SI readings.
//! A bus error, a NACK, a stale or out-of-range reading is an `Err`, never a sample: the sampling
//! task marks the channel bad in the [`crate::aero::SensorSample`] it builds, and the pipeline refuses
//! only the coefficients that need that channel.

pub mod as5600;
pub mod ms4525do;
