//! Signal statistics the readers need: the white-noise level of a logged channel, from which the
//! α-free mode ([`crate::flow_angles`]) states the noise of what it estimates (the model-gap
//! analysis uses the same estimate for its errors-in-variables model).

/// The standard deviation of the white noise on `x`, from its third differences: for white noise
/// `e` of variance `σ²`, `Δ³e = e₃ − 3e₂ + 3e₁ − e₀` has variance `20σ²`, while a signal smooth at
/// the sampling rate contributes little to `Δ³`. A robust scale (median absolute value / 0.6745)
/// keeps the steps of a control input and the 2π wraps of a heading out of the estimate. 0 for a
/// series shorter than 8 samples or one that is piecewise constant (a commanded throttle).
pub fn white_noise_sd(x: &[f64]) -> f64 {
    if x.len() < 8 {
        return 0.0;
    }
    let mut d: Vec<f64> = x
        .windows(4)
        .map(|w| (w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]).abs())
        .collect();
    let mid = d.len() / 2;
    let (_, m, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    *m / 0.674_489_75 / 20f64.sqrt()
}
