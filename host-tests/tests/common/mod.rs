//! Helpers shared by the integration tests.
#![allow(dead_code)]

use aerosid_core::Real;
use nalgebra::{SMatrix, SVector};

/// A `Vec<f64>` as a fixed-size vector of `T`.
pub fn sv<T: Real, const N: usize>(x: &[f64]) -> SVector<T, N> {
    SVector::<T, N>::from_fn(|i, _| T::lit(x[i]))
}

/// Diagonal `W_T` from standard deviations.
pub fn diag_wt<T: Real, const N: usize>(sigmas: &[f64]) -> SMatrix<T, N, N> {
    SMatrix::<T, N, N>::from_fn(|i, j| {
        if i == j {
            T::lit(sigmas[i] * sigmas[i])
        } else {
            T::zero()
        }
    })
}

/// Row-major `W_T` for the reference.
pub fn diag_wt_rows(sigmas: &[f64]) -> Vec<f64> {
    let n = sigmas.len();
    let mut w = vec![0.0; n * n];
    for i in 0..n {
        w[i * n + i] = sigmas[i] * sigmas[i];
    }
    w
}

/// `max_i |a_i − b_i| / max(‖b‖_∞, floor)`.
pub fn rel_err_norm(a: &[f64], b: &[f64], floor: f64) -> f64 {
    let scale = b.iter().fold(floor, |m, x| m.max(x.abs()));
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

/// `max_i |a_i − b_i| / |b_i|` (componentwise relative; `b_i = 0` compared absolutely).
pub fn rel_err_each(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| if *y == 0.0 { x.abs() } else { (x - y).abs() / y.abs() })
        .fold(0.0, f64::max)
}

/// Pearson correlation of two equally long series.
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}
