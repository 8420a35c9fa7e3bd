//! Excitation manoeuvres (doublet, 3-2-1-1, linear sweep, step) on each control, and schedules.

use super::dynamics::Controls;

/// The control a manoeuvre acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Elevator, rad.
    Elevator,
    /// Aileron, rad.
    Aileron,
    /// Rudder, rad.
    Rudder,
    /// Throttle, fraction.
    Throttle,
}

/// The input shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// `+A` for Δt, `−A` for Δt (Δt = base period).
    Doublet,
    /// `+A` 3Δt, `−A` 2Δt, `+A` Δt, `−A` Δt.
    Multistep3211,
    /// `A sin(2π(f₀t + (f₁−f₀)t²/(2T)))` over `duration_s` (linear frequency sweep).
    Sweep {
        /// Start frequency, Hz.
        f0_hz: f64,
        /// End frequency, Hz.
        f1_hz: f64,
        /// Duration `T`, s.
        duration_s: f64,
    },
    /// `+A` for Δt (a throttle step and back).
    Step,
}

/// One manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Manoeuvre {
    /// The control.
    pub channel: Channel,
    /// The shape.
    pub shape: Shape,
    /// Start time, s.
    pub start_s: f64,
    /// Amplitude (rad, or throttle fraction).
    pub amplitude: f64,
    /// Base period Δt, s (unused by the sweep).
    pub period_s: f64,
}

impl Manoeuvre {
    /// The input at `t_s` (0 outside the manoeuvre).
    pub fn value(&self, t_s: f64) -> f64 {
        let t = t_s - self.start_s;
        if t < 0.0 {
            return 0.0;
        }
        let k = t / self.period_s;
        let a = self.amplitude;
        match self.shape {
            Shape::Doublet => {
                if k < 1.0 {
                    a
                } else if k < 2.0 {
                    -a
                } else {
                    0.0
                }
            }
            Shape::Multistep3211 => {
                if k < 3.0 {
                    a
                } else if k < 5.0 {
                    -a
                } else if k < 6.0 {
                    a
                } else if k < 7.0 {
                    -a
                } else {
                    0.0
                }
            }
            Shape::Step => {
                if k < 1.0 {
                    a
                } else {
                    0.0
                }
            }
            Shape::Sweep {
                f0_hz,
                f1_hz,
                duration_s,
            } => {
                if t >= duration_s {
                    0.0
                } else {
                    let ph = f0_hz * t + (f1_hz - f0_hz) * t * t / (2.0 * duration_s);
                    a * (2.0 * core::f64::consts::PI * ph).sin()
                }
            }
        }
    }

    /// End time, s.
    pub fn end_s(&self) -> f64 {
        self.start_s
            + match self.shape {
                Shape::Doublet => 2.0 * self.period_s,
                Shape::Multistep3211 => 7.0 * self.period_s,
                Shape::Step => self.period_s,
                Shape::Sweep { duration_s, .. } => duration_s,
            }
    }
}

/// A set of manoeuvres whose inputs add up (on top of trim and stabiliser).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Schedule {
    /// The manoeuvres.
    pub manoeuvres: Vec<Manoeuvre>,
}

impl Schedule {
    /// Adds a manoeuvre (builder style).
    pub fn with(mut self, m: Manoeuvre) -> Self {
        self.manoeuvres.push(m);
        self
    }
    /// The summed input increments at `t_s`.
    pub fn input(&self, t_s: f64) -> Controls {
        let mut u = Controls::default();
        for m in &self.manoeuvres {
            let v = m.value(t_s);
            match m.channel {
                Channel::Elevator => u.elevator_rad += v,
                Channel::Aileron => u.aileron_rad += v,
                Channel::Rudder => u.rudder_rad += v,
                Channel::Throttle => u.throttle += v,
            }
        }
        u
    }
}
