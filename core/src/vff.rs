//! Variable forgetting factor (seed 000, Section IV, eq. 24–33), after Paleologu, Benesty & Ciochină
//! (IEEE SPL 2008, the seed's ref. \[19\]).
//!
//! ## The reading of eq. 28
//! Eq. 28 is damaged in the seed (one line printed twice). As printed, `σ_q²` and `σ_ν²` are smoothed
//! with `γ₁` and `σ_ε²` with `γ₂`, where `0 ≪ γ₂ < γ₁ < 1` (eq. 31), i.e. the *noise* power `σ_ε²`
//! would have the *shorter* memory. In ref. \[19\], which eq. 27 follows, it is the other way round: the
//! noise-power estimate uses the longer window and the a priori error power (and the power of `q`) the
//! shorter one, so that after an abrupt change the error power `σ_ν²` rises faster than the noise
//! power `σ_ε²` and `λ_F` drops. **We read eq. 28 as** `σ_q²`, `σ_ν²` on the short window `γ₂`
//! (28a, 28b) and `σ_ε²` on the long window `γ₁` over the residuals *older than the short window*
//! (28c), each a weighted mean over the samples since the statistics started (below).
//! [`Eq28Reading::Literal`] keeps the printed assignment (each power a mean of `q²` or `ν²` over
//! all samples since the start, no minimum weight) for comparison; the host tests show that it
//! finds a parameter jump late.
//!
//! ## 28a–b: means since the start
//! Eq. 28 gives no initial values. Started at 0 (as in ref. \[19\], where the filter's initial
//! error is small), the averages are biased low by the factor `1 − γⁿ` after `n` samples. We divide
//! by the sum of weights instead (the bias correction of an exponential average started at zero):
//!
//! ```text
//! W₂(t)  = γ₂ W₂(t−1) + 1,              W₂ = 0 before the start  (= Σₖ γ₂ᵏ, k = 0 … n−1)
//! σ²(t)  = σ²(t−1) + (x²(t) − σ²(t−1))/W₂(t)    (x = q: 28a;  x = ν: 28b)
//! ```
//!
//! i.e. `σ_ν²(t) = Σₖ γ₂ᵏ ν²(t−k) / Σₖ γ₂ᵏ`: the weights keep eq. 28's shape, the first sample has
//! weight 1, and after a few windows the recursion is eq. 28 itself.
//!
//! ## 28c: the noise before the short window
//! With `σ_ε²` the mean of *all* `ν²` since the start (`γ₁ᵏ` weights), the residuals after a jump
//! enter `σ_ε²` as fast as `σ_ν²` while fewer samples than a long window have passed: `m` samples
//! after a jump that raises the residual power to `R² ≫ σ²`, `n` samples after the start,
//! `σ_ν² ≈ (1 − γ₂ᵐ)R²` and `σ_ε² ≈ mR²/(n + m)`, whose ratio exceeds `γ₀²` only if
//! `n > (γ₀² − 1)/(1 − γ₂)` — 300 samples (3 s) for [`VffSettings::for_aero_coefficients`] at
//! 100 Hz: a jump 300 samples into the data was not detected (median 3 513 samples to settle,
//! `λ = 0.999`: 1 365). Our 28c compares the short window with the noise *before* it (a
//! two-sample test). With the sums over the samples since the start
//! `S₁ = Σₖ γ₁ᵏ ν²(t−k)`, `S₂ = Σₖ γ₂ᵏ ν²(t−k)`, `W₁ = Σₖ γ₁ᵏ`, `W₂ = Σₖ γ₂ᵏ`:
//!
//! ```text
//! σ_ε²(t) = (S₁ − S₂)/(W₁ − W₂) = Σₖ (γ₁ᵏ − γ₂ᵏ) ν²(t−k) / D(t),   D = W₁ − W₂ = Σₖ (γ₁ᵏ − γ₂ᵏ)
//! ```
//!
//! a mean with non-negative weights `γ₁ᵏ − γ₂ᵏ` that are 0 for the current sample and small for the
//! last few (`≈ k(γ₁ − γ₂)`), so `m` samples after a jump carry at most
//! `m − (1 − γ₂ᵐ)/(1 − γ₂) ≈ m²(1 − γ₂)/2` of the weight `D`. It needs no buffer: `S₁ − S₂` and `D`
//! follow `X(t) = γ₁X(t−1) + (γ₁ − γ₂)Y(t−1)` with `Y = S₂`, `W₂` (the new sample cancels), so
//!
//! ```text
//! D(t)     = γ₁ D(t−1) + (γ₁ − γ₂) W₂(t−1)
//! σ_ε²(t)  = σ_ε²(t−1) + ((γ₁ − γ₂) W₂(t−1)/D(t)) · (σ_ν²(t−1) − σ_ε²(t−1))
//! ```
//!
//! — the long-window smoothing of the short window's *previous* power, all terms non-negative (no
//! cancellation in `f32`); once `W₂` has settled the gain is `1 − γ₁`, i.e. eq. 28c with
//! `σ_ν²(t−1)` in place of `ν²(t)`. [`VffStep::power_eps`] is this `σ_ε²`.
//!
//! ## Eq. 32: the threshold and the minimum weight
//! On stationary residuals (white, Gaussian) an exponential mean with weights `wₖ` is
//! `σ²·χ²_d/d`-distributed with `d = (Σw)²/Σw²`: `d₁ = (1 + γ₂)/(1 − γ₂)` for `σ_ν²`, and
//! `d₂ ≥ D` for `σ_ε²` (its weights are below 1); the two sums share almost no weight, so a false
//! drop of `λ_F` (eq. 32 failing) has probability `P(F(d₁, d₂) > γ₀²)` per sample
//! (`= I_{d₂/(d₂+d₁γ₀²)}(d₂/2, d₁/2)`, the regularised incomplete beta function). The target is
//! below `1/268 000` (the stationary samples of the host test's sweep): with `γ₀ = 1.5` and a
//! 15-sample window (`d₁ = 29`), `P(χ²₂₉/29 > 2.25) = 1.3·10⁻⁴` — measured 24 and 26 drops in
//! 268 000 samples. So `γ₀ = 2`, the largest eq. 32 allows (for `n ≤ 3`; larger `n`: "The threshold
//! per dimension" below), and eq. 32 is tested only once `σ_ε²`
//! has a weight `D ≥` [`VffSettings::min_noise_weight_samples`]; until then `λ_F = λ_max` (but
//! for the early test, "Eq. 32 before the noise power has its weight" below):
//! `for_dimension(3)` (`d₁ = 29`): 50 samples, `P(F(29, 50) > 4) = 8.6·10⁻⁶` when the test starts,
//! `1.2·10⁻⁷` at `D = 100` some 50 samples later (`D` tends to 585, `d₂` to 1 228: `1·10⁻¹¹`), of
//! the order of 10⁻⁴ false drops per run in all; `for_aero_coefficients(100)` (`d₁ = 199`):
//! 50 samples, `P(F(199, 50) > 4) = 5.9·10⁻⁸`. A larger weight costs the early changes: `D`
//! reaches 100 only ≈ 125 samples after the statistics start (≈ sample 150 in the host tests),
//! and a jump before that enters `σ_ε²` untested and may never be detected (at sample 150 with a
//! weight of 100: the median settling time 516 samples, with 50: 486; floor 0.9, `λ_max = 0.999`,
//! below).
//! The residuals are neither independent (`θ(t−1)` reuses them) nor exactly Gaussian, so these
//! are a guide; the sweep counts the drops.
//!
//! ## When the statistics start
//! The statistics start at the first sample whose `ν` (eq. 24) is formed with a solution of the
//! estimator — for GTLS a TLS solution (eq. 16: the eq. 21 threshold admits all `n_θ` directions),
//! for RLS an estimate from more than `n_θ` samples of information; until then `λ_F = λ_max`
//! (nothing to test a residual against: before eq. 16 the minimum-norm estimate of eq. 22–23 is the
//! weights' choice in the unexcited directions, not a model whose residuals can signal a change).
//! A sample whose estimate is no solution *before* eq. 32 is tested (`D` below its minimum)
//! restarts them: the first TLS solution, from as few as `n_θ + 1` samples, is often lost again
//! for a few samples, and the minimum-norm residuals of that gap (in the
//! host test: tens of times the noise power) would stay in `σ_ε²` for a long window and hide a jump (measured with
//! `for_aero_coefficients(100)`: a jump at sample 300 settled after 3 467 samples on the median
//! without the restart, 112 with it). Once tested they run on. `Π` (eq. 29–30) is the information
//! of the corrected regressors and is accumulated from the first sample.
//!
//! Measured (host test `forgetting.rs`, `Gtls<T, 3, 0, 4>`, one parameter jumping by −1/3,
//! 10 seeds, `f32` and `f64` alike): the estimate is within 5 % of its new value for good after a
//! median of 63 / 50 / 83 / 110 samples (`for_dimension(3)`, with the hold after a detection,
//! "The hold" below; 86 / 50 / 83 / 119 without it) and 112 / 120 / 112 / 328
//! (`for_aero_coefficients(100)`) for jumps at sample 300 / 1 500 / 5 000 / 20 000
//! (`λ = 0.999`: 1 365 / 2 403 / 2 606 / 2 656), never later than `λ = 0.999` on any seed, with
//! no `λ_F < λ_max` in the 268 000 stationary samples before the jumps.
//!
//! ## The ceiling: changes below eq. 32's limit
//! Eq. 32 forgets only when the short window's residual power exceeds `γ₀² = 4` times the noise
//! power. A change that raises the a priori residual power by less is never detected, and with
//! the seed's `λ_F = 1` the old data are never forgotten: the estimate then moves towards the new
//! model as `1/N`. For errors of `σ` in every column the stationary `ν` (eq. 24, with the corrected
//! regressor) has the power `σ²/(1 + ‖θ‖²)`, and the jump `Δθⱼ` of one parameter raises it by the
//! ratio `R = 1 + Δθⱼ²·mean(x₀ⱼ²)/(σ²(1 + ‖θ‖²))`: a jump of a third of a parameter is invisible to
//! eq. 32 when `‖θ‖` is large against that parameter or the regressor small against the noise.
//! Measured (host test `forgetting.rs`, `early_jump_diagnosis`: `Gtls<f64, 3, 0, 4>`,
//! `for_dimension(3)` with `λ_max = 1`, random sinusoidal regressors and parameters, σ = 0.05, one
//! parameter jumping by −1/3, 100 seeds): the VFF settled later than `λ = 0.999` on 30 / 18 / 15 /
//! 13 / 12 seeds for jumps at 150 / 300 / 600 / 1 500 / 5 000 (up to 4.5 times as late, where not
//! settled within the 6 000 samples run counts as 6 000; without the clip of 28c below: 43 / 28 /
//! 22 / 18 / 20, and with the floor 0.9 47 / 30 / 29 / 22 / 26, among them every seed with `R < 4`,
//! 29–31 of the 100): e.g. `R = 1.5`, `σ_ν²/σ_ε²` 1.3–1.8 for 300 samples after
//! the jump and `λ_F = 1` throughout. No false drop of `λ_F` preceded any of them. The others were
//! near the limit (`R` 4–5) or, at sample 150, jumps before eq. 32 was tested (`R` up to 39; the
//! minimum weight above). A longer short window with a smaller `γ₀` lowers the limit but cannot
//! remove it (60 samples and `γ₀ = 1.41`: still slower on 10–51 seeds).
//!
//! Ref. \[19\] bounds eq. 33 by `λ_max` (the seed by 1). We keep that bound as a setting and
//! [`VffSettings::for_dimension`] sets `λ_max = 0.999`: a change below eq. 32's limit is then
//! forgotten as with a constant `λ = 0.999`, a detected one faster. The price is the seed's reason
//! for `λ_F = 1`: without excitation a constant factor below 1 lets the information fade (the
//! seed's Fig. 2 at t = 460 s), so [`VffSettings::for_aero_coefficients`] (on board, with its
//! 300 s cruises) keeps `λ_max = 1` and the limit above. Measured with `for_dimension` over 100
//! seeds (host test `early_jump_sweep_*`, the same generator; dimensions 3, 5 and 6, every
//! regressor noisy and 6 with an exact intercept, `f32` and `f64`): slower than `λ = 0.999` on no
//! seed; no false drop; medians in `BENCHMARKS.md`.
//!
//! ## Eq. 32: the threshold per dimension
//! The seed gives one `γ₀` (`1 < γ₀ ≤ 2`) whatever the dimension. With `γ₀ = 2` in every dimension
//! the limit above costs more the more parameters share the residual (`‖θ‖²` in `R` grows with
//! `n`): in the early-jump sweep 40–43 of 100 jumps were below it in dimension 5, 35–42 in
//! dimension 6 (29–31 in dimension 3), and the medians to settle were 517–1 114 samples there. But
//! the short window grows with `n` (`5n` samples), so `σ_ν²` has `d₁ = (1 + γ₂)/(1 − γ₂) = 10n − 1`
//! degrees of freedom and a smaller ratio is as unlikely on stationary residuals. **We read `γ₀` as
//! the threshold of a test at a fixed level**: [`VffSettings::for_dimension`] sets `γ₀²` to the
//! quantile of `χ²_d₁/d₁` (the short window against a settled noise power) at the tail probability
//! of `γ₀ = 2`, `d₁ = 29`, i.e. `P(χ²₂₉/29 > 4) = 2.3·10⁻¹²` per sample, by the Wilson–Hilferty
//! approximation `γ₀² = (1 − c + z√c)³`, `c = 2/(9d₁)`, `z = 6.7979` (no special function in the
//! core): `γ₀` = 2 / 1.85 / 1.75 / 1.68 for `n ≤ 3` / 4 / 5 / 6 (exact quantiles 1.854 / 1.757 /
//! 1.686). While `σ_ε²` is young the test is less strict than in dimension 3: when it starts
//! (`D = 50`, `d₂ ≈ 50`) `P(F(d₁, 50) > γ₀²)` = 2.6·10⁻⁵ / 6.2·10⁻⁵ / 1.2·10⁻⁴ for `n` = 4 / 5 / 6
//! (dimension 3: 8.6·10⁻⁶), 50 samples later 4·10⁻⁷ / 1·10⁻⁶ / 2·10⁻⁶; the sweep counts the
//! drops (none; `γ₀ = 1.6` in dimension 5 dropped `λ_F` twice in the 100 stationary runs of 5 000
//! samples, where the residuals are not white: the estimate moves with the slow regressors).
//!
//! ## 28c while eq. 32 holds: the clip
//! A young `σ_ε²` follows `σ_ν²` quickly: its gain `(γ₁ − γ₂)W₂/D` is 1.8 % per sample at `D = 55`
//! in dimension 5 (settled: `1 − γ₁` = 0.1 %), so the excess residual of a change that is not yet
//! above `γ₀²` enters the noise power it is tested against. Measured seed by seed (host test
//! `early_jump_at_150_arming_diagnosis`, jump at sample 150, dimension 5): seed 22, `R = 7.7`,
//! eq. 32 tested from sample 140, `σ_ε²` rose from 3.6·10⁻⁵ to 1.08·10⁻⁴ in the 175 samples after
//! the jump while `σ_ν²/σ_ε²` stayed at 1.8–2.5 (`γ₀² = 3.09`), never detected. **We read eq. 28c's
//! input, once eq. 32 is tested and while it holds (`λ_F(t−1) = λ_max`), as clipped**: `σ_ε²` takes
//! in `min(σ_ν²(t−1), κσ_ε²(t−1))`, `κ =` [`VffSettings::noise_clip`] `= 1.1` in
//! [`VffSettings::for_dimension`] (0, no clip, in [`VffSettings::for_aero_coefficients`]: the
//! on-board path is unchanged). On stationary residuals `σ_ν²/σ²` is `χ²_d₁/d₁` (`d₁ = 49` in
//! dimension 5, standard deviation 0.2), so the clip lowers `σ_ε²` by `E[(X − 1.1)⁺] ≈ 4 %` (6 % in
//! dimension 3): the threshold in units of the true noise is 2–3 % lower. Not clipped while
//! `λ_F < λ_max`: after a detected change `σ_ε²` must take in the residuals of the estimator's own
//! short memory, or it stays below them and holds `λ_F` at its floor (measured without that
//! condition: dimension 6 not settled within 6 000 samples on half the seeds). A lasting rise of the
//! noise power is still taken in, at least by `(κ − 1)·gain` per sample; one above `γ₀²` is
//! detected as a change, as without the clip. Excluding the sample instead of clipping it gave
//! the same medians (`κ = 1.3`: 532 / 712 / 624 at sample 150 in dimensions 5 / 6 / 6 with an exact
//! intercept) but has no such bound. Measured (`early_jump_sweep_full`, 100 seeds, `f32` = `f64`;
//! before the early test below, which changes the jump at 150 only), medians to settle for jumps
//! at 150 / 300 / 600 / 1 500 / 5 000 without → with the clip:
//! dimension 3: 266 / 173 / 179 / 150 / 138 → 201 / 144 / 169 / 129 / 127; dimension 5: 697 / 378 /
//! 233 / 214 / 220 → 525 / 254 / 196 / 205 / 220; dimension 6: 813 / 453 / 286 / 273 / 297 → 712 /
//! 279 / 254 / 269 / 293; 6 with an exact intercept: 818 / 477 / 256 / 284 / 283 → 624 / 308 / 254 /
//! 272 / 276; slower than `λ = 0.999` on no seed, no false drop.
//!
//! Measured before the early test below (`early_jump_at_150_arming_diagnosis`, dimensions 5 / 6):
//! the statistics start at the first TLS solution, sample 75 on the median in dimension 5 (49–149)
//! and 99 in dimension 6 (63–195), and eq. 32 is tested from 76 / 80 samples later (sample 151 /
//! 179 on the median); of the jumps above eq. 32's limit (71 / 72 of 100) 36 / 70 come before it
//! is tested. With the clip those settled after a median of 554 / 565 samples (20 / 35 detected;
//! without: 725 / 746, 9 / 16 detected), the others after 205 / 355 (29 of 35 / 2 of 2 detected).
//! Testing against `σ_ε²` sooner needs a noise power of fewer samples, whose false-drop
//! probability `P(F(d₁, D) > γ₀²)` is 7.5·10⁻⁴ / 1.3·10⁻³ per sample at `D = 30` (at 50:
//! 5.8·10⁻⁵ / 1.1·10⁻⁴), and still missed the target in dimension 6 (median 567 with `D = 30`); a
//! threshold at a fixed level while `σ_ε²` is young (the `F(d₁, D)` quantile at 10⁻⁵ per sample,
//! Paulson's approximation, tested from `D = 20`) is stricter than `γ₀²` up to `D ≈ 100` and gained
//! nothing (533 / 714 / 699). So the minimum weight stays 50, and the samples before it have their
//! own test.
//!
//! ## Eq. 32 before the noise power has its weight: the early test
//! Between the start of the statistics and `D = 50` the noise power is young, but the short
//! windows are not: a jump raises `σ_ν²` above every *earlier* short window, while on stationary
//! residuals of a converging estimator `σ_ν²` falls or stays. **Until eq. 32 is tested against
//! `σ_ε²`, we test it against the smallest `σ_ν²` since the start** (the power before the change,
//! which no residual after it can raise): with [`VffSettings::early_test`] (on in
//! [`VffSettings::for_dimension`], off in [`VffSettings::for_aero_coefficients`]), `λ_F < λ_max`
//! when `σ_ν² > c·γ₀²·m`, `m` the smallest `σ_ν²` of the samples since the start whose short window
//! has gathered [`EARLY_WINDOW_FILL`]` = 0.8` of its full weight `1/(1 − γ₂)` (`W₂(1 − γ₂) ≥ 0.8`,
//! 1.6 windows after the start), `c =` [`EARLY_THRESHOLD`]` = 1.25`, and eq. 33 with `σ_ε² = m`.
//! The minimum of many correlated `χ²_d/d` windows lies below 1, so the test needs the margin `c`
//! and the fill (a window of fewer samples has fewer degrees of freedom). Their false-drop
//! probability per run on white residuals (Monte Carlo, 2–4·10⁵ runs of `ν² ~ χ²₁` from the start
//! to `D = 50`, the sums as above; the host test `early_test_false_drops_on_white_residuals`
//! re-measures the chosen row; the sweeps count the drops on the estimator's own residuals):
//!
//! | fill, `c` | dimension 3 | 5 | 6 | tested from (samples after the start, dims 3 / 5 / 6) |
//! |---|---|---|---|---|
//! | 0.63, 1 | 3.1·10⁻² | 9.8·10⁻³ | 6.0·10⁻³ | 14 / 25 / 30 |
//! | 0.8, 1 | 8.4·10⁻³ | 1.1·10⁻³ | 4.1·10⁻⁴ | 23 / 39 / 47 |
//! | **0.8, 1.25** | 1.4·10⁻³ | 9·10⁻⁵ | 5·10⁻⁶ | 23 / 39 / 47 |
//! | 0.6, 1.5 | 4.2·10⁻³ | 5.8·10⁻⁴ | 1.8·10⁻⁴ | 13 / 22 / 27 |
//! | 0.7, 1.5 | 1.5·10⁻³ | 1.4·10⁻⁴ | 2.5·10⁻⁵ | 17 / 29 / 35 |
//!
//! (`D = 50` is reached 68 / 76 / 80 samples after the start.) The early test holds a fixed
//! reference for at most those ~30–40 samples; after it the usual test against `σ_ε²` (which has
//! taken in every residual since the start, unclipped while `λ_F < λ_max`) takes over, so a
//! detection cannot hold `λ_F` at its floor. The on-board state grows by `m` (4 bytes in `f32`;
//! the flag sits in the padding beside `reading`).
//!
//! Measured (`early_jump_sweep_full`, 100 seeds, `f32` = `f64`): only the jump at 150 changes,
//! median to settle 525 → **502** (dimension 5), 712 → **629** (6), 624 → **578** (6 with an exact
//! intercept), dimension 3 unchanged (201); slower than `λ = 0.999` on no seed; no false drop in
//! any dimension. Seed by seed (`early_jump_at_150_arming_diagnosis`), the jumps above eq. 32's
//! limit that come before `D = 50` settle after a median of 446 / 465 samples (24 of 36 / 38 of
//! 70 detected; before: 554 / 565, 20 / 35). Other fills and thresholds, medians at 150 in
//! dimensions 5 / 6 / 6 exact: 0.6, 2: 517 / 647 / 578; 0.7, 1.5: 493 / 629 / 637; 0.7, 2: 520 /
//! 647 / 624; 0.6, 1.5: 493 / 613 / 550 (one seed slower than `λ = 0.999`, ×1.14) — within the
//! seeds' scatter of each other, so the setting with the lowest false-drop probability stays.
//!
//! ## The clip while the early test holds
//! Until `D = 50` the young `σ_ε²` takes in the residuals unclipped at a gain of several percent
//! per sample, so a change the early test has not (yet) flagged enters the noise power that eq. 32
//! compares with from `D = 50` on, as before the clip of 28c (dimension 6, jump at 150, seed 14
//! with an early test that did not fire: `σ_ε²` doubled between the jump and `D = 50` while `σ_ν²`
//! rose to 4–5 times its level before the jump, and `σ_ν²/σ_ε²` reached `γ₀²` only 35 samples
//! after `D = 50`). **The early test is eq. 32 holding as well**: once it is armed (a filled short
//! window's minimum `m` exists) and while `λ_F = λ_max`, `σ_ε²` takes in
//! `min(σ_ν²(t−1), κσ_ε²(t−1))` as in "28c while eq. 32 holds" — but only while `σ_ε² ≥ m`. A
//! young `σ_ε²` below every filled short window is still catching up with a residual power that is
//! not yet stationary: the stationary power of `ν`, `σ²/(1 + ‖θ‖²)` (above), is that of the current
//! estimate, and the first TLS solutions, from few samples, are far from the settled one. Clipped
//! then, `σ_ε²` stays below the noise and eq. 32 fails on stationary data (measured without the
//! condition: dimension 3, seed 96, the short windows' power rose from about 5·10⁻⁵ to 1.5·10⁻⁴
//! over the first 150 samples, `σ_ε²` was held near 6·10⁻⁵ and `λ_F` dropped at sample 157: one
//! false drop in each sweep from the jump at 300 on, `f32` and `f64`).
//!
//! Measured (`early_jump_sweep_full`, 100 seeds, `f32` = `f64`), medians to settle for jumps at
//! 150 / 300 / 600 / 1 500 / 5 000 before → with the clip while the early test holds:
//!
//! | dimension | before | with |
//! |---|---|---|
//! | 3 | 201 / 144 / 169 / 129 / 127 | 188 / 143 / 169 / 129 / 126 |
//! | 5 | 502 / 254 / 196 / 205 / 220 | 454 / 254 / 196 / 202 / 220 |
//! | 6 | 629 / 279 / 254 / 269 / 293 | 580 / 279 / 258 / 269 / 293 |
//! | 6, intercept exact | 578 / 308 / 254 / 272 / 276 | 565 / 308 / 253 / 272 / 276 |
//!
//! Slower than `λ = 0.999` on no seed, no false drop (`λ = 0.999`: 915 / 1 346 / 1 739 / 2 171 /
//! 2 397 in dimension 5, 894–901 at sample 150 in dimension 6). Seed by seed
//! (`early_jump_at_150_arming_diagnosis`, dimensions 5 / 6), the jumps above eq. 32's limit that
//! come before `D = 50` settle after a median of 377 / 434 samples (25 of 36 / 43 of 70 detected;
//! before: 446 / 465, 24 / 38).
//!
//! ## The early F test
//! The early test arms once a short window is filled (47 samples after the start in dimension 6),
//! and its minimum holds the noise before a change only if that window came before it. A jump
//! closer to the start enters every filled window and, unclipped, the young `σ_ε²`, whose gain is
//! several percent per sample (dimension 6, jump at 150, seed 98, `R = 22`: statistics from sample
//! 123, `σ_ν²/σ_ε²` = 7.1 at the jump, `σ_ε²` from 3.7·10⁻⁵ to 3.3·10⁻⁴ in the 30 samples after it,
//! never detected, settled after 1 086 samples as `λ = 0.999`). But the ratio of the two young
//! means is a test in its own right, at a threshold from the weights they actually have: on white
//! Gaussian residuals each is `σ²·χ²_d/d` with `d = (Σw)²/Σw²`, after `m` samples of statistics
//!
//! ```text
//! d₁ = W₂²/Σₖ γ₂²ᵏ = W₂(1 + γ₂)/(1 + γ₂ᵐ)                  (σ_ν², weights γ₂ᵏ)
//! d₂ = D²/Σₖ (γ₁ᵏ − γ₂ᵏ)²,   Σₖ (γ₁ᵏ − γ₂ᵏ)² = (1 − γ₁²ᵐ)/(1 − γ₁²) − 2(1 − (γ₁γ₂)ᵐ)/(1 − γ₁γ₂)
//!                                              + (1 − γ₂²ᵐ)/(1 − γ₂²)          (σ_ε²)
//! ```
//!
//! with `γ₂ᵐ = 1 − W₂(1 − γ₂)` and `γ₁ᵐ = 1 − (D + W₂)(1 − γ₁)` from the weights already kept (no
//! new state). `σ_ε²`'s weights are below 1 while it is young, so `d₂` exceeds `D` (dimension 6:
//! `m` = 20 / 27 / 35 / 47 samples give `d₁` = 19 / 25 / 31 / 39, `D` = 5.1 / 8.7 / 14 / 22,
//! `d₂` = 15 / 21 / 28 / 39). The two means share little weight (`σ_ε²` has none on the current
//! sample and `≈ k(γ₁ − γ₂)` on the `k`-th before it), so `σ_ν²/σ_ε² ~ F(d₁, d₂)`; shared weight
//! correlates them positively and narrows the ratio, so the `F` quantile errs safe. **Until
//! `σ_ε²` has its minimum weight, eq. 32 also fails when `σ_ν² > F_α(d₁, d₂)·σ_ε²`**, the upper
//! `α = 10⁻⁵` quantile per sample ([`EARLY_F_Z`] `= 4.265`, its standard normal quantile) by
//! Paulson's approximation (`((1 − c₂)y − (1 − c₁))² = z²(c₂y² + c₁)`, `y = F^{1/3}`,
//! `cᵢ = 2/(9dᵢ)`: no special function in the core). Against the exact quantiles (regularised
//! incomplete beta) it errs high where `d₂` is small, i.e. stricter: at the unrounded `(d₁, d₂)` of
//! the four sample counts above, shown rounded as (15, 11) / (25, 21) / (39, 39) / (52, 69), it
//! gives 21.7 / 7.46 / 4.23 / 3.04 against 18.2 / 7.20 / 4.19 / 3.03; below `d₂ ≈ 4.5` it has no root and the test waits. A drop so flagged makes `σ_ε²` before
//! it the early test's minimum `m` (if lower): while `λ_F < λ_max` `σ_ε²` takes in the residuals
//! after the change unclipped and, young, soon reaches them (seed 98 with the F test alone:
//! `λ_F` back at `λ_max` after 2 samples, settled after 808), while `m` holds the power before
//! it until `σ_ε²` has its weight and eq. 32 is tested against it (seed 98: settled after 167).
//! The per-run false-drop probability of the early tests together on white residuals (host test
//! `early_test_false_drops_on_white_residuals`, 10⁵ runs): 1.6·10⁻³ / 1.3·10⁻⁴ / 2·10⁻⁵ in
//! dimensions 3 / 5 / 6 (the minimum alone: 1.4·10⁻³ / 1.1·10⁻⁴ / 2·10⁻⁵).
//!
//! This differs from the fixed-level threshold above, which replaced `γ₀²` while `σ_ε²` was young
//! and took `D` as its degrees of freedom: the F test is an additional way for eq. 32 to fail, at
//! the degrees of freedom `d₂` the young weights have (above `D`), and its drop holds the power
//! before it as the early test's minimum.
//!
//! Measured (`early_jump_sweep_full`, 100 seeds, `f32` = `f64`): the jump at 150 in dimension 6
//! settles after a median of 565 samples with the F test, 580 without it (every regressor noisy;
//! with an exact intercept 565 either way; dimension 5 454 and dimension 3 188 either way); slower
//! than `λ = 0.999` on no seed, no false drop. At `α = 10⁻⁴` (`z = 3.719`): 565 in dimension 6, 578 with the exact intercept; at `10⁻⁶`
//! (`z = 4.753`): 580 / 565, as without the F test. Seed by
//! seed (`early_jump_at_150_arming_diagnosis`, dimension 6), the jumps above eq. 32's limit that
//! come before `D = 50` settle after a median of 403 samples, 44 of 70 detected (without the F
//! test: 434, 43).
//!
//! Without the hold below, jumps at sample 150 in dimension 6 settle after a median of 565
//! samples (target 500; 43 of 100 within 500). Seed by seed (`f64`, every regressor noisy): 29 jumps are
//! below eq. 32's limit (`R < γ₀²`; 26 of them settle later than 500, as `λ = 0.999` does), 46 are
//! detected (9 later than 500), and 25 above the limit are never detected (22 later than 500).
//! Of those 25, 3 come before the statistics start (the first TLS solution after the jump: nothing
//! to test against), 7 within 30 samples after it, and 15 30–75 samples after it. Among the last,
//! seeds 3, 30, 65 and 85 (statistics from sample 77–92): eq. 32 is tested from shortly after the
//! jump with `σ_ε²` clipped, but `σ_ν²/σ_ε²` stays at 1.3–2.7, below `γ₀² = 2.84`, for hundreds of
//! samples: the estimate, from only 150–250 samples, follows the change in part at `λ = 0.999`,
//! so the a priori residual never shows the jump's full `R` (5–7). Evidence of that kind accumulates over many samples; tried and measured, not kept:
//! (1) a reference from before the first TLS solution (the short windows of the minimum-norm
//! residuals of eq. 22–23, their smallest carried into the early test): those windows are
//! 10²–10⁴ times the noise power (dimension 6, the first 40 seeds), so the carried minimum never
//! bound and the medians did not change; (2) the noise power of the information the estimator has
//! gathered as the early test's reference from the first TLS solution on (`ν`'s power under `W_T`,
//! `(W_T a)_z²/(aᵀW_T a)` times the smallest squared singular value of the weighted data over
//! `n_eff − n_θ`, against the short window at a threshold from its degrees of freedom by
//! Wilson–Hilferty, tested from 10 of them): 518 / 633 / 609 at sample 150 in dimensions 5 / 6 /
//! 6 exact, later than with the minimum of the filled windows (which lies below the noise power, so
//! the same ratio flags a change sooner); the a priori power `(W_T a)_z²/(aᵀW_T a)` alone (`W_T`
//! exact in the sweep) is exceeded 1.2–5.2 times by `σ_ν²` in the first 20 samples after the
//! start on stationary data (dimension 6), as much as by many jumps; (3) a one-sided CUSUM of
//! `ν²/σ_ε² − 1.5` dropping `λ_F` to its floor at 30, from `D = 50` on: 448 / 557 / 531 at sample
//! 150 in dimensions 5 / 6 / 6 exact, but `λ_F` dropped before the jump on 40 / 19 / 17 / 10 of
//! the 100 stationary runs of 5 000 samples in dimensions 3 / 5 / 6 / 6 exact (the residuals are
//! not white: the estimate moves with the slow regressors).
//!
//! ## The hold
//! The jumps that *are* detected were not all settled either: in dimension 6 at sample 150, seeds
//! 18, 42, 49 and 59 (`R` 7.2 / 4.9 / 17.9 / 5.8) were detected 125 / 39 / 132 / 23 samples after
//! the jump and settled only after 893 / 580 / 1 174 / 534. Eq. 33's `λ_F` is low only while
//! `σ_ν²/σ_ε²` exceeds `γ₀²`, and both means move at once after a detection: `σ_ε²` takes in the
//! residuals unclipped, and the estimate, forgetting, absorbs the change so that `σ_ν²` falls; eq. 32
//! holds again after a sample or two, and most of the old data are still in the estimate. How much
//! forgetting settles a jump, measured by forcing `λ_F` to its floor for `k` samples from the jump
//! on (an oracle: the jump time known; dimension 6, sample 150, 100 seeds): on every seed,
//! `k` = 5 / 10 / 20 settles after a median of 385 / 227 / 143 samples, but later than
//! `λ = 0.999` on 4 seeds (up to ×1.74; every regressor noisy) and 2–4 (up to ×3.2; an exact
//! intercept), all of them jumps with `R` 1.1–2.5: little is gained by forgetting them, and the
//! estimate is noisier while its memory grows again, which decides when it last leaves the 5 %
//! band; on the seeds
//! with `R ≥ γ₀²` only, `k = 10` settles after 259 / 295 samples, later on no seed. So forgetting
//! where eq. 32 cannot see a change costs seeds against `λ = 0.999` (so does a faster ceiling while
//! the memory is young, `λ_max(t) = 1 − c/(t + 50)`: `c` = 1 / 2 / 3 gave medians 420 / 295 / 260
//! but 4 / 8 / 14 seeds slower), and forgetting more after a detection is what the detected seeds
//! need. **Once eq. 32 is tested against `σ_ε²`, a sample on which it fails starts a hold of
//! [`HOLD_SAMPLES`]` = 10` samples in which `λ_F` is eq. 33's value where eq. 32 still fails and the
//! floor `λ_min` where it holds** (with the early test, i.e. in [`VffSettings::for_dimension`]; the
//! on-board path is unchanged): at most `0.8¹⁰ = 0.11` of the old information is left, against
//! 0.64 or more after a drop of one or two samples at the floor. It changes nothing where eq. 32 never fails
//! (stationary data and the jumps below its limit run as before, sample for sample). A hold from
//! the early test's drops as well (before `D = 50`) gave the same medians at sample 150, so the
//! counter shares its number with the early test's minimum, which is no longer used once eq. 32 is
//! tested against `σ_ε²` (the state does not grow). Holds of 5 / 8 / 15 samples: medians at
//! sample 150 of 511 / 480 / 460 (dimension 6), 501 / 518 / 409 (6 with an exact intercept), and
//! of 8 / 15 samples 408 / 284 in dimension 5, all without a slower seed (`f64`); 10 is the
//! shortest that meets the target in both dimension-6 cases, and the one measured at every jump
//! time.
//!
//! Measured (`early_jump_sweep_full`, 100 seeds, `f32` = `f64`), medians to settle for jumps at
//! 150 / 300 / 600 / 1 500 / 5 000 without → with the hold:
//!
//! | dimension | without | with |
//! |---|---|---|
//! | 3 | 188 / 143 / 169 / 129 / 126 | 158 / 126 / 131 / 108 / 128 |
//! | 5 | 454 / 254 / 196 / 202 / 220 | 362 / 214 / 194 / 221 / 203 |
//! | 6 | 565 / 279 / 258 / 269 / 293 | 465 / 262 / 259 / 279 / 296 |
//! | 6, intercept exact | 565 / 308 / 253 / 272 / 276 | 441 / 274 / 253 / 275 / 279 |
//!
//! Slower than `λ = 0.999` on no seed, no false drop; within 500 samples at sample 150: 53 / 53
//! of 100 in dimension 6 / 6 exact (without the hold: 43 / 46). The later jumps gain little (most
//! were detected soon and forgotten enough already) and some medians rise by up to 19 samples (a
//! shorter memory after the detection, so a noisier estimate near the 5 % band while it grows
//! again), all far below `λ = 0.999`'s 1 268–2 397.
//!
//! What is left: at sample 150 in dimension 6 (`f64`, every regressor noisy) 47 of 100 jumps
//! still settle later than 500 samples, none of them detected: 25 below eq. 32's limit (settling
//! as `λ = 0.999` does, as they must for no seed to be slower: the oracle above) and 22 above it
//! (the young estimate following the change, above); all 47 detected jumps settle within 500. The
//! medians there (465 / 441) meet the target by 3 seeds, not by a margin: what would settle more
//! is a detection of the 22, which none of the tests above gives without false drops.
//!
//! ## The floor
//! Eq. 33 has no lower bound: right after a jump `σ_ν ≫ σ_ε` and `λ_F ≈ σ_q σ_ε/σ_ν` can fall to
//! ~1e-3, which all but erases the estimator's memory. We clamp `λ_F ≥ λ_min`: 0.8 in
//! [`VffSettings::for_dimension`] and [`VffSettings::for_aero_coefficients`] (a memory of ~5 samples
//! while the change is being detected; the information matrix keeps about a third of its weight per
//! 5 rejected samples) and document the effect in the host tests. Measured in the early-jump sweep
//! (`γ₀ = 2`, dimension 3, without the clip of 28c), the median to settle for jumps at 150 / 300 / 600 / 1 500 / 5 000 is
//! 266 / 173 / 179 / 150 / 138 samples with the floor 0.8 and 486 / 339 / 340 / 287 / 272 with 0.9
//! (no seed slower than `λ = 0.999`, no false drop, no loss of excitation); in dimension 5 with
//! `γ₀ = 1.7` a floor of 0.7 settles a little faster again (651 / 273 against 690 / 336 with 0.8,
//! jumps at 150 / 300) but is not measured in every dimension, so 0.8 stays.
//!
//! ## Π and q (eq. 29–30)
//! Eq. 30 prints `x̂₀ᵀx̂₀`; it is the outer product `x̂₀ x̂₀ᵀ` (`Π` is the information matrix of the
//! corrected regressors). We keep `P = Π⁻¹` by the Sherman–Morrison formula, so `q = x̂₀ᵀ P x̂₀` costs
//! `O(n²)`. When the regressors are not excited and `λ_F < 1`, `P` would grow without bound
//! ("wind-up"); the forgetting is not applied to `P` while `trace P` exceeds its initial value.

use crate::linalg::slice_finite;
use crate::{Error, Real};
use nalgebra::{SMatrix, SVector};

/// The early test's fill: a short window's `σ_ν²` enters the minimum the early test compares with
/// once its weight `W₂` is this fraction of its full weight `1/(1 − γ₂)` (module doc, "Eq. 32
/// before the noise power has its weight").
pub const EARLY_WINDOW_FILL: f64 = 0.8;
/// The early test's threshold over eq. 32's `γ₀²` (same section).
pub const EARLY_THRESHOLD: f64 = 1.25;

/// The hold: with the early test, once eq. 32 is tested against `σ_ε²`, `λ_F` stays at its
/// floor for this many samples after a sample on which eq. 32 fails, wherever eq. 32 holds again
/// (module doc, "The hold").
pub const HOLD_SAMPLES: f64 = 10.0;

/// The early F test's tail probability per sample, as the upper standard normal quantile `z` of
/// 10⁻⁵ (module doc, "The early F test").
pub const EARLY_F_Z: f64 = 4.265;

/// The early test (module doc, "Eq. 32 before the noise power has its weight" and "The early F
/// test"): the power eq. 32 compares `σ_ν²` with while `σ_ε²` has less than its minimum weight,
/// and the factor on `γ₀²`, if any. Updates the early test's minimum `m` (`snu2_min`): the
/// smallest filled short window, and the noise power before a change the F test flagged.
fn early_reference<T: Real>(
    s: &VffSettings<T>,
    snu2: T,
    seps2: T,
    w_nu: T,
    w_eps: T,
    snu2_min: &mut T,
) -> Option<(T, T)> {
    let z = T::zero();
    let lower = |m: T, x: T| if m > z { m.minr(x) } else { x };
    if w_nu * (T::one() - s.gamma2) >= T::lit(EARLY_WINDOW_FILL) {
        *snu2_min = lower(*snu2_min, snu2);
    }
    let g02 = s.gamma0 * s.gamma0;
    let f = if seps2 > z {
        f_critical(s.gamma1, s.gamma2, w_nu, w_eps)
    } else {
        None
    };
    match f {
        Some(crit) if snu2 > crit * seps2 => {
            *snu2_min = lower(*snu2_min, seps2);
            Some((seps2, crit / g02))
        }
        _ if *snu2_min > z => Some((*snu2_min, T::lit(EARLY_THRESHOLD))),
        _ => f.map(|crit| (seps2, crit / g02)),
    }
}

/// The early F test's critical value (module doc, "The early F test"): the upper quantile of
/// `F(d₁, d₂)` at [`EARLY_F_Z`], with `d₁`, `d₂` the effective degrees of freedom of `σ_ν²` and
/// `σ_ε²` from their weights `W₂` (`w2`) and `D` (`d`), by Paulson's approximation; `None` where
/// that has no root (`d₂` too small).
fn f_critical<T: Real>(g1: T, g2: T, w2: T, d: T) -> Option<T> {
    let (z, one, two) = (T::zero(), T::one(), T::lit(2.0));
    // γ₂ᵐ and γ₁ᵐ after m samples: W₂ = (1 − γ₂ᵐ)/(1 − γ₂), W₁ = D + W₂ = (1 − γ₁ᵐ)/(1 − γ₁).
    let p2 = (one - w2 * (one - g2)).maxr(z);
    let p1 = (one - (d + w2) * (one - g1)).maxr(z);
    // σ_ν²: weights γ₂ᵏ, d₁ = W₂²/Σγ₂²ᵏ = W₂(1 + γ₂)/(1 + γ₂ᵐ).
    let d1 = w2 * (one + g2) / (one + p2);
    // σ_ε²: weights γ₁ᵏ − γ₂ᵏ, d₂ = D²/Σw², Σw² = Σγ₁²ᵏ − 2Σ(γ₁γ₂)ᵏ + Σγ₂²ᵏ.
    let sum_w2 = (one - p1 * p1) / ((one - g1) * (one + g1)) - two * (one - p1 * p2) / (one - g1 * g2)
        + (one - p2 * p2) / ((one - g2) * (one + g2));
    if sum_w2 <= z || !sum_w2.finite() {
        return None;
    }
    let d2 = d * d / sum_w2;
    // Paulson: ((1 − c₂)y − (1 − c₁))² = z²(c₂y² + c₁), y = F^(1/3), cᵢ = 2/(9dᵢ), the larger root.
    let nine = T::lit(9.0);
    let (c1, c2) = (two / (nine * d1), two / (nine * d2));
    let (a, b) = (one - c1, one - c2);
    let zz = T::lit(EARLY_F_Z * EARLY_F_Z);
    let lead = b * b - zz * c2;
    let disc = a * a * b * b - lead * (a * a - zz * c1);
    if lead <= z || disc < z || !disc.finite() {
        return None;
    }
    let y = (a * b + disc.root()) / lead;
    Some(y * y * y)
}

/// Which assignment of the smoothing constants in eq. 28 to use (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Eq28Reading {
    /// `σ_q², σ_ν²` on the short window `γ₂`, `σ_ε²` on the long window `γ₁` (ref. \[19\]). Default.
    Paleologu,
    /// As printed: `σ_q², σ_ν²` on `γ₁`, `σ_ε²` on `γ₂`.
    Literal,
}

/// Settings of the variable forgetting factor. All are dimensionless.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VffSettings<T> {
    /// `γ₁` of eq. 28/31, the long smoothing constant (`0 ≪ γ₂ < γ₁ < 1`).
    pub gamma1: T,
    /// `γ₂` of eq. 28/31, the short smoothing constant.
    pub gamma2: T,
    /// `γ₀` of eq. 32 (`1 < γ₀ ≤ 2`): `λ_F = λ_max` while `σ_ν ≤ γ₀ σ_ε`.
    pub gamma0: T,
    /// `ς` of eq. 33, in the units of the residual `ν` (prevents division by zero).
    pub varsigma: T,
    /// Floor on `λ_F` (not in the seed; see the module doc). `0 < λ_min ≤ λ_max`.
    pub lambda_min: T,
    /// Ceiling on `λ_F` (the seed uses 1, ref. \[19\] `λ_max`; module doc, "The ceiling").
    pub lambda_max: T,
    /// Initial `Π(0) = π₀·I` of eq. 30 (in squared regressor units); `P(0) = I/π₀`.
    pub pi0: T,
    /// Weight (in samples) the old-noise power `σ_ε²` must have gathered before eq. 32 may switch
    /// (not in the seed; module doc); `λ_F = λ_max` until then. Our reading of eq. 28 only;
    /// `0 < value < 1/(1 − γ₁) − 1/(1 − γ₂)`, the weight `σ_ε²` tends to (positive: the first
    /// sample has no noise before it).
    pub min_noise_weight_samples: T,
    /// The clip of what the old-noise power `σ_ε²` takes in while eq. 32 holds (not in the seed;
    /// module doc, "28c while eq. 32 holds"): once eq. 32 is tested (against `σ_ε²`, or by the
    /// early test while `σ_ε²` is not below its minimum: module doc, "The clip while the early
    /// test holds") and while `λ_F = λ_max`, `σ_ε²` takes in `min(σ_ν²(t−1), κ·σ_ε²(t−1))`.
    /// `κ > 1`, or 0 for no clip. Our reading of eq. 28 only.
    pub noise_clip: T,
    /// The reading of the damaged eq. 28.
    pub reading: Eq28Reading,
    /// The early test (not in the seed; module doc, "Eq. 32 before the noise power has its
    /// weight" and "The early F test"): until `σ_ε²` has [`Self::min_noise_weight_samples`],
    /// `σ_ν²` is compared with [`EARLY_THRESHOLD`]` · γ₀²` times the smallest `σ_ν²` since the
    /// statistics started among the short windows filled to [`EARLY_WINDOW_FILL`] of their full
    /// weight, and with `σ_ε²` at the `F` quantile of the two means' degrees of freedom; once
    /// eq. 32 is tested against `σ_ε²`, the hold of [`HOLD_SAMPLES`] at the floor after a sample
    /// on which it fails (module doc, "The hold"). Our reading of eq. 28
    /// only. (A `bool` beside `reading`: it takes no room in the on-board state.) Without the
    /// crate's `early-test` feature the test is not built and this flag is ignored.
    pub early_test: bool,
}

impl<T: Real> VffSettings<T> {
    /// Every number 0 and the first reading: not valid settings (`validate` refuses them), a
    /// placeholder for `const` initialisers whose bytes are all zero (so is
    /// `Forgetting::Variable` holding it; `Forgetting::Constant` is stored in `reading`'s niche
    /// and is not). See [`crate::aero::Pipeline::PLACEHOLDER`].
    pub const ZERO: Self = Self {
        gamma1: T::ZERO,
        gamma2: T::ZERO,
        gamma0: T::ZERO,
        varsigma: T::ZERO,
        lambda_min: T::ZERO,
        lambda_max: T::ZERO,
        pi0: T::ZERO,
        min_noise_weight_samples: T::ZERO,
        noise_clip: T::ZERO,
        reading: Eq28Reading::Paleologu,
        early_test: false,
    };

    /// Defaults for `n` parameters: `γ₂ = 1 − 1/(5·max(n, 3))`, `γ₁ = 1 − 1/(200n)`, `γ₀` from the
    /// short window's degrees of freedom (2 for `n ≤ 3`, 1.85 / 1.75 / 1.68 for `n` = 4 / 5 / 6;
    /// module doc, "Eq. 32: the threshold per dimension"), eq. 32 tested from a noise weight of 50
    /// samples, the noise power's input clipped at `1.1·σ_ε²` while eq. 32 holds (module doc, "28c
    /// while eq. 32 holds"), `ς = 1e-9`, `λ ∈ [0.8, 0.999]`, `π₀ = 1e-2`. The ceiling `λ_max = 0.999` forgets the
    /// changes eq. 32 cannot detect (module doc, "The ceiling"); the seed's `λ_max = 1` keeps all
    /// information where the excitation stops.
    ///
    /// Ref. \[19\] uses windows of `K·L` samples with `K_α = 2`, `K_β ≥ 5K_α` for echo cancellers with
    /// `L` in the hundreds; for the 3–7 parameters of an aerodynamic coefficient those windows are far
    /// too short for the noise estimate, which then catches up with the error power before the
    /// estimator has forgotten the old model. The host test `forgetting.rs` (jump of one slope by
    /// −1/3 after 5000 samples, `n = 4`) measured, with the noise power a mean over all samples and
    /// `γ₀ = 1.5`: windows `(2n, 10n)` with floor 0.9 re-converge in 2789 samples (slower than a
    /// constant `λ = 0.999`, 2685); `(5n, 10n)` never detect; `(5n, 200n)` re-converge in 155. With
    /// the noise before the short window, `γ₀ = 2` and the minimum weight (module doc), the same
    /// test re-converges in 168 samples, no false alarm, all directions kept excited; the sweep
    /// (`n = 3`) in the module doc. The short window is at least 15 samples so that `σ_ν²` has
    /// `d₁ ≥ 29` degrees of freedom: with `5n` samples, `n = 1` (`d₁ = 9`) would drop `λ_F` with
    /// probability `P(F(9, 100) > 4) = 2·10⁻⁴` per sample, `n = 2` (`d₁ = 19`) `3·10⁻⁶`.
    /// At 100 Hz and `n = 5` the windows are 0.25 s and 10 s.
    pub fn for_dimension(n: usize) -> Self {
        let short = T::lit(5.0 * n.max(3) as f64);
        let n = T::lit(n.max(1) as f64);
        // γ₀² = the Wilson–Hilferty quantile of χ²_d₁/d₁, d₁ = (1 + γ₂)/(1 − γ₂) = 2·short − 1, at
        // the tail probability of `γ₀ = 2` with `d₁ = 29`: (1 − c + z√c)³, c = 2/(9d₁), z = 6.7979
        // (6.79781 makes d₁ = 29 give 4; rounded up, so that n ≤ 3 gives exactly the ceiling 2).
        let c = T::lit(2.0) / (T::lit(9.0) * (T::lit(2.0) * short - T::one()));
        let cube_root = T::one() - c + T::lit(6.7979) * c.root();
        Self {
            gamma1: T::one() - T::one() / (T::lit(200.0) * n),
            gamma2: T::one() - T::one() / short,
            gamma0: (cube_root * cube_root * cube_root).root().minr(T::lit(2.0)),
            varsigma: T::lit(1e-9),
            lambda_min: T::lit(0.8),
            lambda_max: T::lit(0.999),
            pi0: T::lit(1e-2),
            min_noise_weight_samples: T::lit(50.0),
            noise_clip: T::lit(1.1),
            reading: Eq28Reading::Paleologu,
            early_test: cfg!(feature = "early-test"),
        }
    }

    /// Settings for the aerodynamic coefficients of a pipeline sampled at `sample_rate_hz`: a 1 s
    /// short window (`γ₂`), a 40 s long window (`γ₁`), `γ₀ = 2` (the largest eq. 32 allows), a
    /// floor of 0.8 and the seed's ceiling `λ_max = 1` (no forgetting without a detected change, so
    /// that a cruise without excitation keeps the information; module doc, "The ceiling").
    ///
    /// [`Self::for_dimension`] was tuned on white residuals. The synthetic moment coefficients'
    /// residuals are not white: the differentiator's noise is correlated over ±4 samples (lag
    /// correlations 0.4, −0.1, −0.4, −0.4), which halves the degrees of freedom of a power estimate,
    /// and the residual grows during manoeuvres (synthesis errors at surface transients); with the
    /// noise power a mean over all samples and `γ₀ = 1.5`, `for_dimension(4)` fired on 30 samples of
    /// the 300 s unexcited cruise of the Fig. 2 flight (host test `paper.rs`, C_m, `n_θ = 4`) and
    /// lost the excitation. The 1 s window gives `σ_ν²` `d₁ = 199` (≈ 100 with the correlation) and
    /// eq. 32 is tested from a noise weight of 50 samples (module doc: `P(F(199, 50) > 4) = 6·10⁻⁸`
    /// per sample). Measured on that flight: `λ_F < 1` on no sample of any coefficient before the
    /// jump or in the cruise; the jump of the `C_m` parameters detected after 1.7 s, the old model
    /// forgotten to `Πλ ≈ 3·10⁻⁶` within 5 s (floor 0.9: `3·10⁻⁴`, and `C_mα` within 5 % for good
    /// 0.7 s later, 11.1 s against 10.4 s after the jump).
    pub fn for_aero_coefficients(sample_rate_hz: T) -> Self {
        let f = if sample_rate_hz > T::zero() && sample_rate_hz.finite() {
            sample_rate_hz
        } else {
            T::lit(100.0)
        };
        Self {
            gamma1: T::one() - T::one() / (T::lit(40.0) * f),
            gamma2: T::one() - T::one() / f,
            gamma0: T::lit(2.0),
            lambda_min: T::lit(0.8),
            lambda_max: T::one(),
            min_noise_weight_samples: T::lit(50.0),
            noise_clip: T::zero(),
            early_test: false,
            ..Self::for_dimension(1)
        }
    }

    fn validate(&self) -> Result<(), Error> {
        let z = T::zero();
        let one = T::one();
        let ok = self.gamma2 > z
            && self.gamma2 < one
            && self.gamma1 > z
            && self.gamma1 < one
            && self.gamma0 > one
            && self.gamma0 <= T::lit(2.0)
            && self.varsigma > z
            && self.varsigma.finite()
            && self.lambda_min > z
            && self.lambda_min <= self.lambda_max
            && self.lambda_max <= one
            && self.gamma2 < self.gamma1
            && self.pi0 > z
            && self.pi0.finite()
            && self.min_noise_weight_samples > z
            && self.min_noise_weight_samples < one / (one - self.gamma1) - one / (one - self.gamma2)
            && (self.noise_clip == z || (self.noise_clip > one && self.noise_clip.finite()));
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidSetting)
        }
    }
}

/// State of the variable forgetting factor for `N` regressors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vff<T: Real, const N: usize> {
    settings: VffSettings<T>,
    /// `P = Π⁻¹` (eq. 29–30).
    p: SMatrix<T, N, N>,
    p_trace_max: T,
    /// `σ_q²`, `σ_ν²`, `σ_ε²` of eq. 28 (weighted means, module doc).
    sq2: T,
    snu2: T,
    seps2: T,
    /// The smallest `σ_ν²` of a short window filled to [`EARLY_WINDOW_FILL`] since
    /// the statistics started, while eq. 32 is not yet tested against `σ_ε²` (0: none yet); from
    /// then on, with the early test, the samples left of the hold after a detection (module doc,
    /// "The hold"; one number for both, so that the state does not grow).
    snu2_min: T,
    /// The sums of weights (in samples) of the means `σ_q²`, `σ_ν²` and of `σ_ε²` since the
    /// statistics started: `W₂` and `D` in our reading, the sums over `γ₁` and `γ₂` in the literal
    /// one; both 0 until they start.
    weight_nu: T,
    weight_eps: T,
    lambda: T,
}

/// The values of one VFF step (for plots and tests). The powers are kept squared (eq. 28 as it
/// smooths them); eq. 32 compares them squared and only eq. 33 needs their square roots, so the
/// step takes none unless `λ_F` leaves `λ_max`. [`Self::sigma_q`] etc. give the roots.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VffStep<T> {
    /// `q(t)` of eq. 29.
    pub q: T,
    /// `σ_q²` of eq. 28a after the step (0 until the statistics start and after a restart, as the
    /// other powers).
    pub power_q: T,
    /// `σ_ν²` of eq. 28b (a priori residual power).
    pub power_nu: T,
    /// `σ_ε²` of eq. 28c: in our reading the noise power before the short window (module doc; 0
    /// on the first sample of the statistics, which has none before it).
    pub power_eps: T,
    /// `λ_F(t)` (eq. 32–33, clamped to `[λ_min, λ_max]`).
    pub lambda: T,
}

impl<T: Real> VffStep<T> {
    /// `σ_q`.
    pub fn sigma_q(&self) -> T {
        self.power_q.root()
    }
    /// `σ_ν`.
    pub fn sigma_nu(&self) -> T {
        self.power_nu.root()
    }
    /// `σ_ε`.
    pub fn sigma_eps(&self) -> T {
        self.power_eps.root()
    }
}

impl<T: Real, const N: usize> Vff<T, N> {
    /// Every number 0 ([`VffSettings::ZERO`], `P = 0`): storage only, for
    /// [`crate::Gtls::PLACEHOLDER`]; never updated.
    pub(crate) const ZEROED: Self = Self {
        settings: VffSettings::ZERO,
        p: crate::linalg::const_zeros(),
        p_trace_max: T::ZERO,
        sq2: T::ZERO,
        snu2: T::ZERO,
        seps2: T::ZERO,
        snu2_min: T::ZERO,
        weight_nu: T::ZERO,
        weight_eps: T::ZERO,
        lambda: T::ZERO,
    };

    /// A new VFF with `λ_F(0) = λ_max`.
    pub fn new(settings: VffSettings<T>) -> Result<Self, Error> {
        settings.validate()?;
        let p = SMatrix::<T, N, N>::identity() / settings.pi0;
        Ok(Self {
            settings,
            p,
            p_trace_max: p.trace(),
            sq2: T::zero(),
            snu2: T::zero(),
            seps2: T::zero(),
            snu2_min: T::zero(),
            weight_nu: T::zero(),
            weight_eps: T::zero(),
            lambda: settings.lambda_max,
        })
    }

    /// Whether the statistics of eq. 28 have started (module doc); `λ_F = λ_max` until they have.
    pub fn started(&self) -> bool {
        self.weight_nu > T::zero()
    }

    /// The current `λ_F`, to be applied to the next sample.
    pub fn lambda(&self) -> T {
        self.lambda
    }

    /// The settings in force.
    pub fn settings(&self) -> &VffSettings<T> {
        &self.settings
    }

    /// One step of eq. 28–33 with the TLS-corrected regressor `x̂₀(t)` and the a priori residual
    /// `ν(t)` of eq. 24. Uses `λ_F(t−1)` in eq. 30 and returns the new `λ_F(t)`.
    ///
    /// `solved`: whether the estimate `θ(t−1)` that `ν` was formed with is a solution to test the
    /// model against (a TLS solution for GTLS). The statistics of eq. 28 start at the first such
    /// sample; in our reading a sample without one restarts them until eq. 32 is tested, then they
    /// run on. Until they start only `Π` is updated and `λ_F = λ_max` (module doc).
    ///
    /// Inputs must be finite (the estimator checks them); a non-finite intermediate leaves the state
    /// unchanged and returns `None`.
    pub fn update(&mut self, x0: &SVector<T, N>, nu: T, solved: bool) -> Option<VffStep<T>> {
        let s = self.settings;
        let one = T::one();
        // P x̂₀ (P symmetric: Σ_j P[:, j] x_j over its columns).
        let pc = &self.p.data.0;
        let mut px = [T::zero(); N];
        for j in 0..N {
            let col = &pc[j];
            let xj = x0[j];
            for i in 0..N {
                px[i] += col[i] * xj;
            }
        }
        let mut q = T::zero(); // eq. 29
        for i in 0..N {
            q += x0[i] * px[i];
        }
        let (mut sq2, mut snu2, mut seps2, mut snu2_min) = (self.sq2, self.snu2, self.seps2, self.snu2_min);
        let (mut w_nu, mut w_eps) = (self.weight_nu, self.weight_eps);
        let mut lambda_new = s.lambda_max;
        // Our reading restarts the statistics on a sample whose estimate is no solution while
        // eq. 32 is not yet tested (module doc); the literal one runs on from the first solution.
        let z = T::zero();
        let settling = s.reading == Eq28Reading::Paleologu && w_eps < s.min_noise_weight_samples;
        if !solved && settling {
            (sq2, snu2, seps2, snu2_min, w_nu, w_eps) = (z, z, z, z, z, z);
        } else if solved || self.started() {
            // The power eq. 32 compares σ_ν² with (σ_ε², or the early test's minimum), if any, and
            // the factor on γ₀².
            let reference = match s.reading {
                Eq28Reading::Paleologu => {
                    // 28a–b: means over the short window, weight W₂(t) = γ₂W₂(t−1) + 1 (gain 1 on
                    // the first sample). 28c: the old-noise mean, its weight D(t) = γ₁D(t−1) +
                    // (γ₁ − γ₂)W₂(t−1) taking in σ_ν²(t−1) (module doc).
                    let inflow = (s.gamma1 - s.gamma2) * w_nu;
                    // While eq. 32 is tested and holds, what σ_ε² takes in is clipped at κσ_ε²
                    // (module doc, "28c while eq. 32 holds"); tested means against σ_ε² or by the
                    // early test (a filled short window's minimum exists, `snu2_min > 0`) while σ_ε²
                    // is not below that minimum (module doc, "The clip while the early test holds").
                    // (The order of the comparisons keeps the firmware's code, without the early
                    // test, as it was.)
                    let calm = s.noise_clip > T::zero()
                        && (w_eps >= s.min_noise_weight_samples
                            || (cfg!(feature = "early-test") && snu2_min > z && seps2 >= snu2_min))
                        && self.lambda >= s.lambda_max;
                    let snu2_prev = if calm { snu2.minr(s.noise_clip * seps2) } else { snu2 };
                    w_nu = s.gamma2 * w_nu + one;
                    let g = one / w_nu;
                    sq2 = (one - g) * sq2 + g * (q * q); // 28a
                    snu2 = (one - g) * snu2 + g * (nu * nu); // 28b
                    w_eps = s.gamma1 * w_eps + inflow;
                    if w_eps > T::zero() {
                        let g_eps = inflow / w_eps;
                        seps2 = (one - g_eps) * seps2 + g_eps * snu2_prev; // 28c
                    }
                    if w_eps >= s.min_noise_weight_samples {
                        Some((seps2, one))
                    } else if cfg!(feature = "early-test") && s.early_test {
                        early_reference(&s, snu2, seps2, w_nu, w_eps, &mut snu2_min)
                    } else {
                        None
                    }
                }
                Eq28Reading::Literal => {
                    // As printed: 28a–b on γ₁, 28c on γ₂, each a mean over the samples so far.
                    w_nu = s.gamma1 * w_nu + one;
                    w_eps = s.gamma2 * w_eps + one;
                    let (g, g_eps) = (one / w_nu, one / w_eps);
                    sq2 = (one - g) * sq2 + g * (q * q);
                    snu2 = (one - g) * snu2 + g * (nu * nu);
                    seps2 = (one - g_eps) * seps2 + g_eps * (nu * nu);
                    Some((seps2, one))
                }
            };
            // Eq. 32 (σ_ν ≤ γ₀σ_ε, compared squared), else eq. 33.
            lambda_new = match reference {
                Some((r, c)) if snu2 > c * s.gamma0 * s.gamma0 * r => {
                    let (sig_q, sig_nu, sig_eps) = (sq2.root(), snu2.root(), r.root());
                    (sig_q * sig_eps / (s.varsigma + (sig_nu - sig_eps).abs())).minr(s.lambda_max)
                }
                _ => s.lambda_max,
            }
            .maxr(s.lambda_min);
            // The hold after a detection (module doc, "The hold"): once eq. 32 is tested against
            // σ_ε², `snu2_min` counts the samples left of it.
            #[cfg(feature = "early-test")]
            if s.early_test && s.reading == Eq28Reading::Paleologu && w_eps >= s.min_noise_weight_samples {
                let left = if self.weight_eps >= s.min_noise_weight_samples {
                    snu2_min
                } else {
                    z
                };
                snu2_min = if lambda_new < s.lambda_max {
                    if left > z {
                        left - one
                    } else {
                        T::lit(HOLD_SAMPLES)
                    }
                } else if left > z {
                    lambda_new = s.lambda_min;
                    left - one
                } else {
                    z
                };
            }
        }
        // Eq. 30 by Sherman–Morrison with λ_F(t−1): P ← (P − P x xᵀ P / (λ + q)) / λ, the division
        // by λ skipped while it would raise trace P above its initial value (module doc).
        let lam_old = self.lambda;
        let g = one / (lam_old + q);
        let mut trace = T::zero();
        for i in 0..N {
            trace += pc[i][i] - px[i] * px[i] * g;
        }
        let scale = if trace / lam_old <= self.p_trace_max {
            one / lam_old
        } else {
            one
        };
        // P stays positive semi-definite with trace ≤ its initial trace, so its entries are
        // bounded: finite P x̂₀, powers, λ and trace make the new P finite.
        // (σ_ν²'s minimum is one of the finite σ_ν².)
        let finite = slice_finite(&px) && slice_finite(&[q, g, sq2, snu2, seps2, w_nu, w_eps, lambda_new, trace]);
        if !finite {
            return None;
        }
        // The new P over the upper triangle, mirrored (exactly symmetric).
        let pm = &mut self.p.data.0;
        for j in 0..N {
            let pj = px[j] * g;
            for i in 0..j + 1 {
                let val = (pm[j][i] - px[i] * pj) * scale;
                pm[j][i] = val;
                pm[i][j] = val;
            }
        }
        self.sq2 = sq2;
        self.snu2 = snu2;
        self.seps2 = seps2;
        self.snu2_min = snu2_min;
        self.weight_nu = w_nu;
        self.weight_eps = w_eps;
        self.lambda = lambda_new;
        Some(VffStep {
            q,
            power_q: sq2,
            power_nu: snu2,
            power_eps: seps2,
            lambda: lambda_new,
        })
    }
}
