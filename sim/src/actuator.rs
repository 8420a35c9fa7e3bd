//! Control-surface servos: a first-order lag with a rate limit, solved exactly between commands.
//!
//! Without it the simulated surfaces jump at every output sample (the commands are held per
//! period), so the pitch acceleration `q̇` jumps too: no differentiator of the sampled gyro can
//! follow a step in `q̇`, and the synthetic `C_m` then carries errors of up to ~0.1 on the samples
//! around each step, correlated with `δe` — measured: batch OLS of noise-free synthetic `C_m` on
//! noise-free regressors over elevator 3-2-1-1s and doublets gave `C_mα −2.96, C_mq −2.4` for a truth
//! of `−1.3, −20`. Real surfaces move continuously, so the truth should too.
//!
//! The servo follows a held command `c` from position `δ₀`: at the rate limit `R` while
//! `|c − δ| > R τ`, then exponentially with time constant `τ` (the two phases meet with equal
//! rate). The position is an exact function of time inside the period, so RK4 sees a continuous
//! surface (`rk4_step_with`). Throttle has no lag here (the motor's is much shorter than a servo's,
//! and thrust is reconstructed on board from the measured propeller speed).

use super::dynamics::Controls;

/// Servo dynamics of the three surfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Servo {
    /// First-order time constant `τ`, s (default 0.04: a ~4 Hz bandwidth, typical of a digital
    /// hobby servo under load).
    pub time_constant_s: f64,
    /// Rate limit `R`, rad/s (default 6.0 ≈ 0.17 s per 60°, a common small-servo rating).
    pub rate_limit_rad_s: f64,
}

impl Default for Servo {
    fn default() -> Self {
        Self {
            time_constant_s: 0.04,
            rate_limit_rad_s: 6.0,
        }
    }
}

impl Servo {
    /// Position `t_s` after starting at `from` with the command `cmd` held.
    pub fn position(&self, from: f64, cmd: f64, t_s: f64) -> f64 {
        let (tau, rate) = (self.time_constant_s, self.rate_limit_rad_s);
        if !(tau > 0.0 && rate > 0.0) || t_s <= 0.0 {
            return if t_s <= 0.0 { from } else { cmd };
        }
        let e = cmd - from;
        let ramp_s = (e.abs() - rate * tau) / rate;
        if ramp_s > 0.0 {
            if t_s <= ramp_s {
                return from + e.signum() * rate * t_s;
            }
            let d = from + e.signum() * rate * ramp_s;
            return cmd + (d - cmd) * (-(t_s - ramp_s) / tau).exp();
        }
        cmd + (from - cmd) * (-t_s / tau).exp()
    }

    /// Surface positions `t_s` after `from` with the commands `cmd` held (throttle: the command).
    pub fn controls(&self, from: &Controls, cmd: &Controls, t_s: f64) -> Controls {
        Controls {
            elevator_rad: self.position(from.elevator_rad, cmd.elevator_rad, t_s),
            aileron_rad: self.position(from.aileron_rad, cmd.aileron_rad, t_s),
            rudder_rad: self.position(from.rudder_rad, cmd.rudder_rad, t_s),
            throttle: cmd.throttle,
        }
    }
}
