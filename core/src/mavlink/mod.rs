//! MAVLink 2 over the co-processor's UART: telemetry out, actuator positions in. No I/O here: frames
//! are written into and parsed from byte slices.
//!
//! ## Why hand-encoded, not the `mavlink` crate
//! Measured in a scratch `thumbv7em-none-eabihf` binary with the firmware's size profile
//! (docs/firmware.md, "MAVLink"): `mavlink` 0.21 (`default-features = false`, `embedded`) adds
//! 20 KB of flash over this codec to encode the firmware's three telemetry messages and 144 KB with
//! the autopilot's messages parsed (its dialect-wide `ser`/`parse` matches are linked whole),
//! against 248 B left in the flight image; and its extension fields (`DEBUG_FLOAT_ARRAY.data`,
//! `SERVO_OUTPUT_RAW.servo9_raw`…) need `mav2-message-extensions`, which does not build without
//! `std`. We need seven messages, so they are written here from the official definitions
//! ([`messages`]), with `CRC_EXTRA` values and payload layouts checked against pymavlink (golden
//! frames in `core/tests/mavlink.rs`).
//!
//! ## Telemetry out (co-processor → autopilot / ground station)
//! * `HEARTBEAT` (#0) at 1 Hz: `type` = `MAV_TYPE_ONBOARD_CONTROLLER` (18), `autopilot` =
//!   `MAV_AUTOPILOT_INVALID` (8), `base_mode` = `custom_mode` = 0, `system_status` from the caller
//!   (`MAV_STATE_STANDBY`/`ACTIVE`), `mavlink_version` 3. Sent with the autopilot's system id and
//!   component id 191 (`MAV_COMP_ID_ONBOARD_COMPUTER`) by default, so ground stations list it as a
//!   component of the vehicle.
//! * One `DEBUG_FLOAT_ARRAY` (#350) per coefficient ([`telemetry::CoefficientReport`]):
//!   `array_id` = coefficient index (`C_L` 0, `C_D` 1, `C_Y` 2, `C_l` 3, `C_m` 4, `C_n` 5, as
//!   [`crate::aero::model::idx`]), `name` = `"CL"`, `"CD"`, `"CY"`, `"Cl"`, `"Cm"`, `"Cn"`,
//!   `time_usec` = the caller's time, µs, and `data` (f32):
//!
//!   | `data[i]` | content |
//!   |---|---|
//!   | 0…5 | `θ_0…θ_5` (unused parameters 0) |
//!   | 6…11 | `σ_0…σ_5` (unused 0, NaN where undefined) |
//!   | 12 | retained rank `k` |
//!   | 13 | forgetting factor `λ_F` |
//!   | 14 | health flags (bits 0…23; an integer, exact in f32) |
//!   | 15 | refused samples (saturates at 2²⁴) |
//!   | 16 | `n_θ` |
//!   | 17…57 | not sent (0, removed by MAVLink 2 payload truncation) |
//!
//!   Payload 20 + 17·4 = 88 bytes, frame 100 bytes. pymavlink/MAVProxy decode it, QGroundControl's
//!   MAVLink Inspector shows and plots it. [`telemetry::Telemetry::named_value`] sends any single
//!   value as `NAMED_VALUE_FLOAT` (#251, ≤ 30 bytes) for tools that only plot those.
//!
//! ### Rate budget (UART 8N1: 10 bits per byte)
//! | stream | bytes/s | of 57600 baud (5760 B/s) | of 115200 baud (11520 B/s) |
//! |---|---|---|---|
//! | heartbeat, 1 Hz | 21 | 0.4 % | 0.2 % |
//! | six reports, 1 Hz | 600 | 10 % | 5 % |
//! | six reports, 2 Hz | 1200 | 21 % | 10 % |
//! | six reports, 5 Hz | 3000 | 52 % | 26 % |
//! | six reports, 10 Hz | 6000 | 104 % (does not fit) | 52 % |
//!
//! Recommended: 2 Hz at 57600, 5 Hz at 115200. When the autopilot forwards these frames to a
//! telemetry radio they also take that radio's bandwidth (a 57600-baud SiK link is shared with
//! the autopilot's own streams): 1 Hz there is the polite default.
//!
//! ## Actuator input (autopilot → co-processor)
//! [`parser::Parser`] is a byte-at-a-time MAVLink 1/2 state machine with bounded buffers (policy
//! in its doc). [`surfaces::MavlinkSurfaces`] keeps the newest `SERVO_OUTPUT_RAW` (#36, PWM µs per
//! output, all 16 outputs) and RPM from ArduPilot's `RPM` (#226, `ardupilotmega.xml`; ArduPilot does
//! not send `ESC_STATUS`) or PX4's `ESC_STATUS` (#291, `common.xml`), and implements
//! [`surfaces::SurfaceSource`] with per-channel linear calibrations and staleness errors; a stamped
//! message whose stamp is not newer than the kept one's (a repeat, a replay) does not refresh it
//! (`surfaces` module doc, "Freshness"). It also
//! keeps the newest `ATTITUDE` (#30) for the attitude the co-processor cannot estimate itself
//! ([`surfaces::MavlinkSurfaces::euler_rad`]). The autopilot must be set to stream
//! `SERVO_OUTPUT_RAW`, `ATTITUDE` (and `RPM`) on that port at the rate the timeouts assume (e.g.
//! ArduPilot `SRn_RC_CHAN`, `SRn_EXTRA1`, `SRn_EXTRA3`).
//!
//! The link is transmit-only for commands: the co-processor decodes no command, mission or
//! parameter message and never acts on one; it sends no command either. MAVLink 2 signatures are
//! skipped, not verified (no key on the co-processor), which is acceptable because nothing it
//! reads can change its behaviour beyond the actuator values an unsigned frame could carry too.

pub mod crc;
pub mod frame;
pub mod messages;
pub mod parser;
pub mod surfaces;
pub mod telemetry;

pub use frame::{EncodeError, Encoder};
pub use messages::Message;
pub use parser::{Frame, Header, Parser, ParserStats};
pub use surfaces::{MavlinkSurfaces, SurfaceConfig, SurfaceError, SurfaceReading, SurfaceSource};
pub use telemetry::{CoefficientReport, Telemetry};
