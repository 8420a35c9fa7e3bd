//! The filter error method on the MCU: the HFB-320 filter (4 states, 7 outputs,
//! 11 parameters, `f32`) run over a record under QEMU, each step's instruction count read from
//! TIM2. Not part of the flight firmware: a separate example of the `qemu` board, driven by
//! `host-tests/tests/fem_qemu.rs`.
//!
//! * **Input** `fem_steps.bin` in QEMU's working directory, read over semihosting, little-endian
//!   `f32`: a header of [`HEADER_WORDS`] — the filter's settings and start (`Q_x` and `R_x`
//!   diagonals, `Δt`, integrator, input hold, sensitivity, `x̂₀`, `P_x0` diagonal, `p₀`, `P_p0`
//!   diagonal, and 0 for the recursive filter or 1 for one Gauss–Newton pass linearised at `p₀`,
//!   `FilterError::new_pass`) — then one record of [`STEP_WORDS`] per step: `u(t)`, `u(t + Δt)`,
//!   `y(t + Δt)`.
//! * **Output** `fem_out.bin`: one little-endian `u32` per step, the TIM2 ticks of
//!   `FilterError::step` (one tick per guest instruction under `-icount shift=0,align=off,
//!   sleep=off`, TOOLCHAIN.md), then the final estimate, its σ, and the health counters as `u32`.
//! * **Exit status** 0 after the whole record; 2 if a file cannot be opened or is short.
//!
//! Build: `cargo build -p aerosid-firmware --target thumbv7em-none-eabihf --release --features qemu
//! --example fem_count`.
#![no_std]
#![no_main]

use aerosid_core::fem::models::Hfb320;
use aerosid_core::fem::{FemSettings, FilterError, InputHold, Integrator, Sensitivity};
use cortex_m_rt::entry;
use defmt_semihosting as _;
use nalgebra::{SMatrix, SVector};
use semihosting::fs::File;
use semihosting::io::{Read, Write};
use stm32f4::stm32f405 as pac;

/// States, inputs, outputs, parameters of the HFB-320 model.
const NX: usize = 4;
const NU: usize = 2;
const NY: usize = 7;
const NP: usize = 11;
/// Header words: Q (NX), R (NY), Δt, integrator, hold, sensitivity, x̂₀ (NX), P_x0 (NX), p₀ (NP),
/// P_p0 (NP), recursive (0) or pass (1).
const HEADER_WORDS: usize = NX + NY + 4 + NX + NX + NP + NP + 1;
/// Words per step: u, u_next, y.
const STEP_WORDS: usize = NU + NU + NY;

/// Reads `N` little-endian `f32`; `None` at the end of the file.
fn read_words<const N: usize>(file: &mut File) -> Option<[f32; N]> {
    let mut bytes = [0u8; 4];
    let mut out = [0.0f32; N];
    for w in out.iter_mut() {
        let mut got = 0;
        while got < 4 {
            match file.read(&mut bytes[got..]) {
                Ok(0) | Err(_) => return None,
                Ok(n) => got += n,
            }
        }
        *w = f32::from_le_bytes(bytes);
    }
    Some(out)
}

fn integrator(code: f32) -> Integrator {
    match code as u32 {
        1 => Integrator::Rk2,
        2 => Integrator::Rk4,
        _ => Integrator::Euler,
    }
}

fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

#[entry]
fn main() -> ! {
    let Some(dp) = pac::Peripherals::take() else { exit(2) };
    // TIM2 free-running, PSC = 0, ARR = 2³² − 1: one tick per guest instruction under -icount.
    dp.RCC.apb1enr().modify(|_, w| w.tim2en().set_bit());
    let tim2 = dp.TIM2;
    tim2.psc().write(|w| w.psc().set(0));
    tim2.arr().write(|w| w.arr().set(u32::MAX));
    tim2.egr().write(|w| w.ug().set_bit());
    tim2.cr1().modify(|_, w| w.cen().set_bit());

    let (Ok(mut input), Ok(mut output)) = (File::open(c"fem_steps.bin"), File::create(c"fem_out.bin")) else {
        exit(2)
    };
    let Some(h) = read_words::<HEADER_WORDS>(&mut input) else {
        exit(2)
    };
    let mut k = 0;
    let mut take = |n: usize| {
        let s = &h[k..k + n];
        k += n;
        s
    };
    let q = SMatrix::<f32, NX, NX>::from_diagonal(&SVector::from_column_slice(take(NX)));
    let r = SMatrix::<f32, NY, NY>::from_diagonal(&SVector::from_column_slice(take(NY)));
    let codes = take(4);
    let settings = FemSettings {
        q_x: q,
        r_x: r,
        dt_s: codes[0],
        integrator: integrator(codes[1]),
        input_hold: if codes[2] as u32 == 1 {
            InputHold::Linear
        } else {
            InputHold::Zero
        },
        sensitivity: if codes[3] as u32 == 1 {
            Sensitivity::Propagated
        } else {
            Sensitivity::OneStep
        },
    };
    let x0 = SVector::<f32, NX>::from_column_slice(take(NX));
    let p_x0 = SMatrix::<f32, NX, NX>::from_diagonal(&SVector::from_column_slice(take(NX)));
    let p0 = SVector::<f32, NP>::from_column_slice(take(NP));
    let p_p0 = SMatrix::<f32, NP, NP>::from_diagonal(&SVector::from_column_slice(take(NP)));
    let model = Hfb320::<f32>::default();
    let made = if take(1)[0] as u32 == 1 {
        FilterError::new_pass(model, settings, x0, p_x0, p0, p0, p_p0)
    } else {
        FilterError::new(model, settings, x0, p_x0, p0, p_p0)
    };
    let Ok(mut fem) = made else { exit(2) };

    while let Some(s) = read_words::<STEP_WORDS>(&mut input) {
        let u = SVector::<f32, NU>::from_column_slice(&s[..NU]);
        let un = SVector::<f32, NU>::from_column_slice(&s[NU..2 * NU]);
        let y = SVector::<f32, NY>::from_column_slice(&s[2 * NU..]);
        let start = tim2.cnt().read().bits();
        let _ = core::hint::black_box(fem.step(&u, &un, &y));
        let ticks = tim2.cnt().read().bits().wrapping_sub(start);
        if output.write_all(&ticks.to_le_bytes()).is_err() {
            exit(2)
        }
    }
    let sigma = fem.parameter_sigma();
    for v in fem.parameters().iter().chain(sigma.iter()) {
        if output.write_all(&v.to_le_bytes()).is_err() {
            exit(2)
        }
    }
    let health = fem.health();
    for c in [health.steps, health.refused_input, health.refused_numerical] {
        if output.write_all(&c.to_le_bytes()).is_err() {
            exit(2)
        }
    }
    exit(0)
}
