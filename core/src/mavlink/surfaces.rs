//! Actuator input: control-surface deflections, throttle and propeller speed from the autopilot's
//! `SERVO_OUTPUT_RAW` and RPM messages, with staleness reported as an error; and the autopilot's
//! attitude (`ATTITUDE`, Euler angles), which the co-processor has no sensors to estimate itself
//! ([`MavlinkSurfaces::euler_rad`]).
//!
//! The deflection is the commanded one (the servo's PWM), as it reaches the co-processor: servo lag
//! and linkage play are not in it. Each surface has a linear calibration `δ = (pwm − pwm_neutral) ·
//! rad_per_us`, clamped to its mechanical limits (the surface saturates there whatever the PWM);
//! a PWM outside the plausible range (`pwm_valid_us`, e.g. 0 = output disabled) is an error for that
//! channel.
//!
//! ## Freshness
//! A value is fresh while the newest message that carried it arrived less than its timeout ago.
//! A message stamped by the autopilot (`SERVO_OUTPUT_RAW.time_usec`, `ATTITUDE.time_boot_ms`,
//! `ESC_STATUS.time_usec`) replaces the kept one only when its stamp is newer — a repeat of the
//! kept stamp carries nothing new whatever its values (an autopilot whose output task froze while
//! its telemetry streams on, a router re-sending a buffered frame), and an older stamp is a replay.
//! Such a frame is counted ([`MavlinkSurfaces::not_newer_frames`]) and does not refresh the
//! reception time, so a stream of repeats goes stale after the timeout like a silent link — the
//! stuck-channel detector cannot catch this, since surfaces legitimately hold still in cruise.
//! Readings chosen and tested (`core/tests/mavlink.rs`,
//! `repeated_or_older_stamps_do_not_refresh_the_surfaces`):
//! * *newer* is serial-number arithmetic (RFC 1982): `stamp − kept`, wrapping, read as signed, is
//!   positive — so the 32-bit µs stamp's wrap every 71.6 min is crossed without a stale gap;
//! * once the kept message is stale any stamp is taken: an autopilot that rebooted restarts its
//!   clock, and the kept message has gone stale long before the reboot is over;
//! * a stamp of 0 (on either side) is *not stamped* and always taken, so that an autopilot that
//!   does not stamp these messages still works, without this protection.
//!
//! ArduPilot's `RPM` carries no stamp: it is taken as it comes.

use super::messages::{Attitude, Message, ServoOutputRaw};
use super::parser::{Frame, Parser, ParserStats};
use crate::aero::SensorSample;
use nalgebra::Vector3;

/// Why an actuator reading is not available.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SurfaceError {
    /// No message of the source received yet.
    NoData,
    /// The newest message is older than the timeout.
    Stale {
        /// Its age, µs.
        age_us: u64,
    },
    /// The caller's time is earlier than the newest message's reception time.
    TimeWentBackwards,
    /// The channel's PWM is outside the plausible range (0 = output disabled).
    PwmOutOfRange {
        /// Servo output index (0 = `servo1_raw`).
        channel: u8,
        /// The pulse width, µs.
        pwm_us: u16,
    },
    /// The RPM is negative (ArduPilot's `RPM` sends −1 for an unhealthy sensor; reverse rotation
    /// is not a flight condition here) or not finite.
    RpmInvalid,
    /// No RPM source is configured.
    NoRpmSource,
    /// An `ATTITUDE` angle is not finite.
    AttitudeInvalid,
    /// A calibration or setting is outside its documented range.
    InvalidCalibration,
}

impl core::fmt::Display for SurfaceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NoData => f.write_str("no actuator message received yet"),
            Self::Stale { age_us } => write!(f, "actuator message is stale ({age_us} us old)"),
            Self::TimeWentBackwards => f.write_str("time is earlier than the last reception"),
            Self::PwmOutOfRange { channel, pwm_us } => write!(f, "servo output {channel} PWM {pwm_us} us out of range"),
            Self::RpmInvalid => f.write_str("RPM negative or not finite"),
            Self::NoRpmSource => f.write_str("no RPM source configured"),
            Self::AttitudeInvalid => f.write_str("attitude angle not finite"),
            Self::InvalidCalibration => f.write_str("calibration outside its documented range"),
        }
    }
}

/// The control surfaces and throttle at one instant; each channel can fail on its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceReading {
    /// Elevator deflection, rad.
    pub elevator_rad: Result<f32, SurfaceError>,
    /// Aileron deflection, rad.
    pub aileron_rad: Result<f32, SurfaceError>,
    /// Rudder deflection, rad.
    pub rudder_rad: Result<f32, SurfaceError>,
    /// Throttle, 0…1.
    pub throttle: Result<f32, SurfaceError>,
    /// Age of the message the values come from, µs.
    pub age_us: u64,
}

/// Where the firmware's sampling task gets the actuator channels of a
/// [`crate::aero::SensorSample`]; the board layer owns the implementation (e.g. [`MavlinkSurfaces`]).
pub trait SurfaceSource {
    /// The surfaces and throttle at `now_us` (the caller's monotonic time, µs). `Err` when there
    /// is no fresh data at all; stale values are never returned.
    fn surfaces(&mut self, now_us: u64) -> Result<SurfaceReading, SurfaceError>;

    /// Propeller speed at `now_us`, rad/s; `Err` when stale, absent or invalid.
    fn prop_speed_rad_s(&mut self, now_us: u64) -> Result<f32, SurfaceError>;
}

/// Linear calibration of one surface servo.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoCalibration {
    /// Servo output index in `SERVO_OUTPUT_RAW` (0 = `servo1_raw` … 15 = `servo16_raw`).
    pub channel: u8,
    /// PWM at zero deflection, µs.
    pub pwm_neutral_us: f32,
    /// Deflection per µs, rad/µs, with the sign that maps to the airframe's convention.
    pub rad_per_us: f32,
    /// Mechanical deflection limits `(min, max)`, rad.
    pub limits_rad: (f32, f32),
}

impl ServoCalibration {
    /// Deflection for `pwm_us`, clamped to the limits, rad.
    ///
    /// `max` then `min`, not `f32::clamp`: `clamp` panics when `min > max` (which
    /// [`SurfaceConfig::validate`] excludes, but the compiler cannot see it), and that panic's
    /// message brings ≈ 20 KB of float formatting into the firmware.
    pub fn deflection_rad(&self, pwm_us: u16) -> f32 {
        ((f32::from(pwm_us) - self.pwm_neutral_us) * self.rad_per_us)
            .max(self.limits_rad.0)
            .min(self.limits_rad.1)
    }

    fn valid(&self) -> bool {
        self.channel < 16
            && self.pwm_neutral_us.is_finite()
            && self.rad_per_us.is_finite()
            && self.rad_per_us != 0.0
            && self.limits_rad.0.is_finite()
            && self.limits_rad.1.is_finite()
            && self.limits_rad.0 < self.limits_rad.1
    }
}

/// Throttle from a PWM range: `(pwm − idle)/(full − idle)`, clamped to 0…1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ThrottleCalibration {
    /// Servo output index (0 = `servo1_raw`).
    pub channel: u8,
    /// PWM at zero throttle, µs.
    pub pwm_idle_us: u16,
    /// PWM at full throttle, µs.
    pub pwm_full_us: u16,
}

impl ThrottleCalibration {
    /// Throttle for `pwm_us`, 0…1.
    pub fn throttle(&self, pwm_us: u16) -> f32 {
        let span = f32::from(self.pwm_full_us) - f32::from(self.pwm_idle_us);
        ((f32::from(pwm_us) - f32::from(self.pwm_idle_us)) / span).clamp(0.0, 1.0)
    }

    fn valid(&self) -> bool {
        self.channel < 16 && self.pwm_idle_us != self.pwm_full_us
    }
}

/// Which message carries the propeller's RPM.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RpmSource {
    /// None: [`SurfaceSource::prop_speed_rad_s`] returns [`SurfaceError::NoRpmSource`].
    None,
    /// ArduPilot's `RPM` (#226), sensor 0 (`rpm1`) or 1 (`rpm2`).
    ArduPilotRpm {
        /// 0 or 1.
        sensor: u8,
    },
    /// `ESC_STATUS` (#291, PX4), ESC number `esc` (0-based; the message with `index ≤ esc <
    /// index + 4` carries it).
    EscStatus {
        /// 0-based ESC number.
        esc: u8,
    },
}

/// Settings of [`MavlinkSurfaces`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SurfaceConfig {
    /// Accept frames only from this system id (0: any).
    pub source_system_id: u8,
    /// `SERVO_OUTPUT_RAW.port` the channels are on (0 = MAIN).
    pub port: u8,
    /// Elevator.
    pub elevator: ServoCalibration,
    /// Aileron (for two aileron servos, this one and `aileron_2` are averaged; give each the sign
    /// that makes it read the airframe's `δa`).
    pub aileron: ServoCalibration,
    /// Second aileron servo, if any.
    pub aileron_2: Option<ServoCalibration>,
    /// Rudder.
    pub rudder: ServoCalibration,
    /// Throttle.
    pub throttle: ThrottleCalibration,
    /// Plausible PWM range `[min, max]`, µs (outside: [`SurfaceError::PwmOutOfRange`]).
    pub pwm_valid_us: [u16; 2],
    /// A `SERVO_OUTPUT_RAW` older than this is stale, µs.
    pub servo_timeout_us: u64,
    /// The RPM source.
    pub rpm: RpmSource,
    /// Propeller revolutions per reported revolution (1 for a direct drive).
    pub rpm_scale: f32,
    /// An RPM older than this is stale, µs.
    pub rpm_timeout_us: u64,
    /// An `ATTITUDE` older than this is stale, µs.
    pub attitude_timeout_us: u64,
}

impl SurfaceConfig {
    /// Checks every calibration and setting.
    pub fn validate(&self) -> Result<(), SurfaceError> {
        let rpm_ok = match self.rpm {
            RpmSource::None => true,
            RpmSource::ArduPilotRpm { sensor } => sensor < 2,
            RpmSource::EscStatus { .. } => true,
        };
        let ok = self.elevator.valid()
            && self.aileron.valid()
            && self.aileron_2.is_none_or(|a| a.valid())
            && self.rudder.valid()
            && self.throttle.valid()
            && self.pwm_valid_us[0] < self.pwm_valid_us[1]
            && self.servo_timeout_us > 0
            && self.rpm_timeout_us > 0
            && self.attitude_timeout_us > 0
            && rpm_ok
            && self.rpm_scale.is_finite()
            && self.rpm_scale > 0.0;
        if ok {
            Ok(())
        } else {
            Err(SurfaceError::InvalidCalibration)
        }
    }
}

/// [`SurfaceSource`] fed by the autopilot's MAVLink stream.
#[derive(Debug, Clone)]
pub struct MavlinkSurfaces {
    config: SurfaceConfig,
    parser: Parser,
    /// Newest `SERVO_OUTPUT_RAW` of the configured port and when it arrived, µs.
    servo: Option<(ServoOutputRaw, u64)>,
    /// Newest RPM of the configured source (rev/min, as reported), when it arrived, µs, and the
    /// autopilot's stamp of it, µs (`ESC_STATUS`; 0 for ArduPilot's `RPM`, which has none).
    rpm: Option<(f32, u64, u64)>,
    /// Newest `ATTITUDE` and when it arrived, µs.
    attitude: Option<(Attitude, u64)>,
    /// Stamped frames of a configured source not kept because their stamp is not newer than the
    /// kept frame's (module doc, "Freshness"); wrapping.
    not_newer: u32,
}

impl MavlinkSurfaces {
    /// A source with `config` (validated).
    pub fn new(config: SurfaceConfig) -> Result<Self, SurfaceError> {
        config.validate()?;
        Ok(Self {
            config,
            parser: Parser::new(),
            servo: None,
            rpm: None,
            attitude: None,
            not_newer: 0,
        })
    }

    /// Frames not kept because their stamp is not newer than the kept frame's while that one is
    /// still fresh — repeats and replays (module doc, "Freshness"): `SERVO_OUTPUT_RAW` of the
    /// configured port, `ATTITUDE`, `ESC_STATUS` of the configured ESC, from the configured system.
    /// Wrapping.
    pub fn not_newer_frames(&self) -> u32 {
        self.not_newer
    }

    /// The settings.
    pub fn config(&self) -> &SurfaceConfig {
        &self.config
    }

    /// The parser's counters.
    pub fn parser_stats(&self) -> &ParserStats {
        self.parser.stats()
    }

    /// Parses `bytes` received at `now_us` and keeps what they carry.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) {
        let Self {
            config,
            parser,
            servo,
            rpm,
            attitude,
            not_newer,
        } = self;
        parser.feed(bytes, |frame| {
            keep(config, servo, rpm, attitude, not_newer, frame, now_us)
        });
    }

    /// Keeps what `frame` (parsed elsewhere, received at `now_us`) carries, if it is for us.
    pub fn accept(&mut self, frame: &Frame, now_us: u64) {
        keep(
            &self.config,
            &mut self.servo,
            &mut self.rpm,
            &mut self.attitude,
            &mut self.not_newer,
            frame,
            now_us,
        );
    }

    /// Writes what the link holds at `now_us` into the autopilot's channels of `s` — the three
    /// surfaces, throttle, RPM and the three Euler angles — each missing, stale or out-of-range one
    /// NaN, so the pipeline refuses exactly the coefficients that need it. `true` when every one
    /// of them is present. Both firmware boards fill their samples with it, and the host's model of
    /// the firmware (`aerosid_qemu::emulate`) does too.
    #[inline]
    pub fn fill(&mut self, now_us: u64, s: &mut SensorSample<f32>) -> bool {
        let nan = f32::NAN;
        match self.surfaces(now_us) {
            Ok(r) => {
                s.elevator_rad = r.elevator_rad.unwrap_or(nan);
                s.aileron_rad = r.aileron_rad.unwrap_or(nan);
                s.rudder_rad = r.rudder_rad.unwrap_or(nan);
                s.throttle = r.throttle.unwrap_or(nan);
            }
            Err(_) => {
                s.elevator_rad = nan;
                s.aileron_rad = nan;
                s.rudder_rad = nan;
                s.throttle = nan;
            }
        }
        s.prop_speed_rad_s = self.prop_speed_rad_s(now_us).unwrap_or(nan);
        s.euler_rad = match self.euler_rad(now_us) {
            Ok(e) => Vector3::from(e),
            Err(_) => Vector3::from_element(nan),
        };
        [
            s.elevator_rad,
            s.aileron_rad,
            s.rudder_rad,
            s.throttle,
            s.prop_speed_rad_s,
        ]
        .iter()
        .chain(s.euler_rad.iter())
        .all(|v| !v.is_nan())
    }

    /// The autopilot's attitude at `now_us`: roll φ, pitch θ, yaw ψ (3-2-1 Euler angles of body FRD
    /// relative to NED), rad, from the newest `ATTITUDE`. `Err` when none arrived, when it is older
    /// than [`SurfaceConfig::attitude_timeout_us`], or when an angle is not finite
    /// ([`SurfaceError::AttitudeInvalid`]).
    pub fn euler_rad(&self, now_us: u64) -> Result<[f32; 3], SurfaceError> {
        let (m, rx_us) = self.attitude.ok_or(SurfaceError::NoData)?;
        age(rx_us, now_us, self.config.attitude_timeout_us)?;
        if m.euler_rad.iter().all(|a| a.is_finite()) {
            Ok(m.euler_rad)
        } else {
            Err(SurfaceError::AttitudeInvalid)
        }
    }

    fn pwm(&self, m: &ServoOutputRaw, channel: u8) -> Result<u16, SurfaceError> {
        let pwm_us = m.servo_raw_us.get(usize::from(channel)).copied().unwrap_or(0);
        let [lo, hi] = self.config.pwm_valid_us;
        if (lo..=hi).contains(&pwm_us) {
            Ok(pwm_us)
        } else {
            Err(SurfaceError::PwmOutOfRange { channel, pwm_us })
        }
    }

    fn surface(&self, m: &ServoOutputRaw, c: &ServoCalibration) -> Result<f32, SurfaceError> {
        self.pwm(m, c.channel).map(|p| c.deflection_rad(p))
    }
}

/// Keeps the servo outputs, the attitude or the RPM `frame` carries, if it is from the configured
/// source; a frame for us whose stamp is not newer than the kept frame's, which is still fresh, is
/// not kept but counted in `not_newer` (module doc, "Freshness").
fn keep(
    config: &SurfaceConfig,
    servo: &mut Option<(ServoOutputRaw, u64)>,
    rpm: &mut Option<(f32, u64, u64)>,
    attitude: &mut Option<(Attitude, u64)>,
    not_newer: &mut u32,
    frame: &Frame,
    now_us: u64,
) {
    if config.source_system_id != 0 && frame.header.system_id != config.source_system_id {
        return;
    }
    let taken = match (&frame.message, config.rpm) {
        (Message::ServoOutputRaw(m), _) if m.port == config.port => {
            let kept = servo.as_ref().map(|(k, rx)| (k.time_us, *rx));
            let take = takes(m.time_us, kept, now_us, config.servo_timeout_us);
            if take {
                *servo = Some((*m, now_us));
            }
            take
        }
        (Message::Attitude(m), _) => {
            let kept = attitude.as_ref().map(|(k, rx)| (k.time_boot_ms, *rx));
            let take = takes(m.time_boot_ms, kept, now_us, config.attitude_timeout_us);
            if take {
                *attitude = Some((*m, now_us));
            }
            take
        }
        (Message::Rpm(m), RpmSource::ArduPilotRpm { sensor }) => {
            if let Some(&r) = m.rpm.get(usize::from(sensor)) {
                *rpm = Some((r, now_us, 0));
            }
            true
        }
        (Message::EscStatus(m), RpmSource::EscStatus { esc }) => {
            match esc.checked_sub(m.index).and_then(|i| m.rpm.get(usize::from(i))) {
                Some(&r) => {
                    let kept = rpm.as_ref().map(|&(_, rx, stamp)| (stamp, rx));
                    let take = takes(m.time_us, kept, now_us, config.rpm_timeout_us);
                    if take {
                        *rpm = Some((r as f32, now_us, m.time_us));
                    }
                    take
                }
                None => true,
            }
        }
        _ => true,
    };
    if !taken {
        *not_newer = not_newer.wrapping_add(1);
    }
}

/// An autopilot's message stamp: wrapping serial-number comparison (RFC 1982).
trait Stamp: Copy + PartialEq + Default {
    /// 0: the sender does not stamp this message.
    fn unstamped(self) -> bool {
        self == Self::default()
    }
    /// `self` later than `other`: their wrapping difference, read as signed, is positive.
    fn newer_than(self, other: Self) -> bool;
}

impl Stamp for u32 {
    fn newer_than(self, other: Self) -> bool {
        (self.wrapping_sub(other) as i32) > 0
    }
}

impl Stamp for u64 {
    fn newer_than(self, other: Self) -> bool {
        (self.wrapping_sub(other) as i64) > 0
    }
}

/// Whether a message stamped `stamp`, received at `now_us`, replaces the kept one (`kept`: its
/// stamp and reception time, µs) whose timeout is `timeout_us` (module doc, "Freshness").
fn takes<S: Stamp>(stamp: S, kept: Option<(S, u64)>, now_us: u64, timeout_us: u64) -> bool {
    match kept {
        None => true,
        Some((k, rx_us)) => {
            stamp.unstamped() || k.unstamped() || now_us.saturating_sub(rx_us) > timeout_us || stamp.newer_than(k)
        }
    }
}

/// Age of a reception at `rx_us`, checked against `timeout_us`.
fn age(rx_us: u64, now_us: u64, timeout_us: u64) -> Result<u64, SurfaceError> {
    let age_us = now_us.checked_sub(rx_us).ok_or(SurfaceError::TimeWentBackwards)?;
    if age_us > timeout_us {
        Err(SurfaceError::Stale { age_us })
    } else {
        Ok(age_us)
    }
}

impl SurfaceSource for MavlinkSurfaces {
    fn surfaces(&mut self, now_us: u64) -> Result<SurfaceReading, SurfaceError> {
        let (m, rx_us) = self.servo.ok_or(SurfaceError::NoData)?;
        let age_us = age(rx_us, now_us, self.config.servo_timeout_us)?;
        let c = &self.config;
        let aileron_rad = match c.aileron_2 {
            None => self.surface(&m, &c.aileron),
            Some(a2) => self
                .surface(&m, &c.aileron)
                .and_then(|a| Ok(0.5 * (a + self.surface(&m, &a2)?))),
        };
        Ok(SurfaceReading {
            elevator_rad: self.surface(&m, &c.elevator),
            aileron_rad,
            rudder_rad: self.surface(&m, &c.rudder),
            throttle: self.pwm(&m, c.throttle.channel).map(|p| c.throttle.throttle(p)),
            age_us,
        })
    }

    fn prop_speed_rad_s(&mut self, now_us: u64) -> Result<f32, SurfaceError> {
        if self.config.rpm == RpmSource::None {
            return Err(SurfaceError::NoRpmSource);
        }
        let (rpm, rx_us, _) = self.rpm.ok_or(SurfaceError::NoData)?;
        age(rx_us, now_us, self.config.rpm_timeout_us)?;
        if !(rpm >= 0.0) || !rpm.is_finite() {
            return Err(SurfaceError::RpmInvalid);
        }
        Ok(rpm * self.config.rpm_scale * (core::f32::consts::TAU / 60.0))
    }
}
