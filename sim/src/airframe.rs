//! Simulated airframes: the on-board constants ([`Airframe`]) plus the truth aerodynamics, surface
//! limits and the motor (data/aircraft README §1–2).

use super::aero::{Geometry, LinearAero};
use aerosid_core::aero::{Airframe, Propeller};
use nalgebra::{Matrix3, Vector3};

/// Deflection limits `(min, max)` of the three surfaces, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceLimits {
    /// Elevator, rad.
    pub elevator_rad: (f64, f64),
    /// Aileron, rad.
    pub aileron_rad: (f64, f64),
    /// Rudder, rad.
    pub rudder_rad: (f64, f64),
}

/// Everything the simulator needs to know about an airframe.
#[derive(Debug, Clone, PartialEq)]
pub struct SimAirframe {
    /// Name (as in the README).
    pub name: String,
    /// Mass, inertia, geometry and propeller — the constants the on-board code also knows.
    pub frame: Airframe<f64>,
    /// The linear (eq. 3) part of the truth aerodynamics.
    pub aero: LinearAero,
    /// Surface limits.
    pub limits: SurfaceLimits,
    /// Propeller speed at full throttle, rad/s (`ω = δt · max`, no motor lag).
    pub max_prop_speed_rad_s: f64,
}

impl SimAirframe {
    /// `skywalker_2013_mod` (README §1), inertia as published (the Aerosonde values).
    pub fn skywalker_2013_mod() -> Self {
        let lim = (-0.3491, 0.3491);
        Self {
            name: "skywalker_2013_mod".into(),
            frame: Airframe::skywalker_2013_mod(),
            aero: LinearAero::skywalker_2013_mod(),
            limits: SurfaceLimits {
                elevator_rad: lim,
                aileron_rad: lim,
                rudder_rad: lim,
            },
            max_prop_speed_rad_s: 1050.0,
        }
    }

    /// Rascal 110 (README §2), linearised ([`LinearAero::rascal_110`]). The README gives no
    /// propeller curves: we use the skywalker `C_T(J)`, `C_P(J)` on the 18×8 diameter (0.457 m) with
    /// 600 rad/s at full throttle (≈ 42 N static thrust, ≈ 1 kW), thrust line 4 in (0.1016 m) below
    /// the CG and 0.3 m ahead, no pitch — assumptions, not source data.
    pub fn rascal_110() -> Self {
        let z = 0.0;
        Self {
            name: "rascal_110".into(),
            frame: Airframe {
                mass_kg: 6.58,
                inertia_kgm2: Matrix3::new(2.644, z, z, z, 2.102, z, z, z, 2.590),
                wing_area_m2: 0.982,
                span_m: 2.795,
                chord_m: 0.3505,
                propeller: Propeller {
                    diameter_m: 0.457,
                    ct: [0.1133, -0.0740, -0.1849],
                    cp: [0.0440, 0.0059, -0.0732],
                    position_m: Vector3::new(0.3, 0.0, 0.1016),
                    pitch_rad: 0.0,
                },
            },
            aero: LinearAero::rascal_110(),
            limits: SurfaceLimits {
                elevator_rad: (-0.35, 0.30),
                aileron_rad: (-0.35, 0.35),
                rudder_rad: (-0.35, 0.35),
            },
            max_prop_speed_rad_s: 600.0,
        }
    }

    /// Reference geometry for eq. 1–2.
    pub fn geometry(&self) -> Geometry {
        Geometry {
            wing_area_m2: self.frame.wing_area_m2,
            span_m: self.frame.span_m,
            chord_m: self.frame.chord_m,
        }
    }

    /// Aspect ratio `b²/S`.
    pub fn aspect_ratio(&self) -> f64 {
        self.frame.span_m * self.frame.span_m / self.frame.wing_area_m2
    }
}
