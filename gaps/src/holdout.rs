//! The held-out manoeuvres of a pooled flight, stratified by the axis each one excites.
//!
//! The analysis fits its final models on an identification segment and simulates the rest
//! ([`crate::simulate`]); the candidates' held-out tests leave one whole manoeuvre out in turn
//! ([`crate::select::Design::in_pieces`]) and so do not depend on this split. A split that takes
//! the first manoeuvres of the canonical order (sorted by file name) would, on a test card whose
//! rudder records sort last, fit the lateral baselines on no rudder input at all and hold out
//! every rudder manoeuvre. Here each manoeuvre is given the axis it excites — the control (δe, δa,
//! δr, throttle; without controls, the body rate q, p, r) whose spread within it, relative to the
//! spread over the whole flight, is largest — and the manoeuvres of each axis are shared between
//! the identification segment and the held-out rest: of `k` manoeuvres of one axis,
//! `round(k·(1 − fraction))` are held out, at least one when `k ≥ 2` and at most `k − 1`, so that
//! every axis flown twice or more is both fitted and predicted. A lone manoeuvre of its axis is
//! always fitted (held out, its axis would never be fitted). Within an axis the manoeuvres that
//! excite it least are the ones held out (the fit keeps the most informative records). When every
//! axis is flown once, the shortest manoeuvre is held out. The choice reads the data only — not
//! the file names nor the order the files were given in — and the pooled flight is re-laid with
//! the identification manoeuvres first, in their canonical order, then the held-out ones.
//!
//! With fewer than [`select::MIN_PIECES_FOR_FOLDS`] manoeuvres nothing changes: the split is the
//! first `fraction` of the samples, as for one record.

use crate::io::measured::{MeasuredFlight, Quantity};
use crate::select;

/// The controls whose spread tells a manoeuvre's axis, in the order pitch, roll, yaw, speed.
const CONTROLS: [Quantity; 4] = [
    Quantity::Elevator,
    Quantity::Aileron,
    Quantity::Rudder,
    Quantity::Throttle,
];

/// The body rates that tell it when no control is logged (pitch, roll, yaw).
const RATES: [Quantity; 3] = [Quantity::PitchRate, Quantity::RollRate, Quantity::YawRate];

/// Fewest identification and held-out samples (as the single-record split clamps them).
const MIN_ID_SAMPLES: usize = 100;
const MIN_HELD_SAMPLES: usize = 50;

/// One manoeuvre's axis and how strongly it excites it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Excited {
    /// Index into the channels used ([`CONTROLS`] or [`RATES`]).
    axis: usize,
    /// Its spread of that channel over the channel's spread across the whole flight.
    ratio: f64,
}

fn spread(x: &[f64]) -> f64 {
    let m = crate::signal::mean(x);
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// The axis each piece (sample ranges `pieces`) of `flight` excites; `None` when the flight logs
/// neither a varying control nor a varying body rate.
fn axes(flight: &MeasuredFlight, pieces: &[(usize, usize)]) -> Option<Vec<Excited>> {
    let varying = |qs: &[Quantity]| -> Vec<(usize, Vec<f64>, f64)> {
        qs.iter()
            .enumerate()
            .filter_map(|(k, q)| {
                let v = flight.get(*q)?;
                let s = spread(v);
                (s > 0.0 && s.is_finite()).then(|| (k, v.to_vec(), s))
            })
            .collect()
    };
    let mut channels = varying(&CONTROLS);
    if channels.is_empty() {
        channels = varying(&RATES);
    }
    if channels.is_empty() {
        return None;
    }
    Some(
        pieces
            .iter()
            .map(|&(a, b)| {
                channels
                    .iter()
                    .map(|(k, v, s)| Excited {
                        axis: *k,
                        ratio: spread(&v[a..b]) / s,
                    })
                    .fold(
                        Excited {
                            axis: usize::MAX,
                            ratio: f64::NEG_INFINITY,
                        },
                        |best, e| if e.ratio > best.ratio { e } else { best },
                    )
            })
            .collect(),
    )
}

/// Which pieces are held out (module doc), from their axes and lengths.
fn held_out(excited: &[Excited], lengths: &[usize], fraction: f64) -> Vec<bool> {
    let n = excited.len();
    let mut held = vec![false; n];
    let mut groups: Vec<usize> = excited.iter().map(|e| e.axis).collect();
    groups.sort_unstable();
    groups.dedup();
    for axis in groups {
        let mut members: Vec<usize> = (0..n).filter(|&i| excited[i].axis == axis).collect();
        let k = members.len();
        if k < 2 {
            continue;
        }
        let count = ((k as f64 * (1.0 - fraction)).round() as usize).clamp(1, k - 1);
        // The least excited first; ties (equal spreads) by length, then by position, which is
        // the canonical order and so independent of the order the files were given in.
        members.sort_by(|&i, &j| {
            excited[i]
                .ratio
                .total_cmp(&excited[j].ratio)
                .then(lengths[i].cmp(&lengths[j]))
                .then(i.cmp(&j))
        });
        for &i in &members[..count] {
            held[i] = true;
        }
    }
    if !held.contains(&true) {
        // Every axis flown once: the shortest manoeuvre is held out.
        if let Some(i) = (0..n).min_by_key(|&i| (lengths[i], i)) {
            held[i] = true;
        }
    }
    held
}

/// The held-out pieces of `flight` (one flag per piece of [`MeasuredFlight::pieces`]), or `None`
/// when the flight has fewer than [`select::MIN_PIECES_FOR_FOLDS`] pieces, no signal that tells
/// an axis, or when the split would leave fewer than 100 identification or 50 held-out samples.
pub(crate) fn held_out_pieces(flight: &MeasuredFlight, fraction: f64) -> Option<Vec<bool>> {
    let pieces: Vec<(usize, usize)> = flight.pieces().iter().map(|p| (p.start, p.end)).collect();
    if pieces.len() < select::MIN_PIECES_FOR_FOLDS {
        return None;
    }
    let excited = axes(flight, &pieces)?;
    let lengths: Vec<usize> = pieces.iter().map(|(a, b)| b - a).collect();
    let held = held_out(&excited, &lengths, fraction);
    let n_held: usize = lengths.iter().zip(&held).filter(|(_, h)| **h).map(|(l, _)| l).sum();
    let n_id = flight.len() - n_held;
    (n_id >= MIN_ID_SAMPLES && n_held >= MIN_HELD_SAMPLES).then_some(held)
}

/// `flight` re-laid with its identification pieces first, then the held-out ones (module doc),
/// each group in its canonical order; `None` when nothing moves (fewer than
/// [`select::MIN_PIECES_FOR_FOLDS`] pieces, or the held-out pieces are already last).
pub(crate) fn stratified(flight: &MeasuredFlight, fraction: f64) -> Option<MeasuredFlight> {
    let held = held_out_pieces(flight, fraction)?;
    let pieces = flight.pieces();
    let order: Vec<usize> = (0..pieces.len())
        .filter(|&i| !held[i])
        .chain((0..pieces.len()).filter(|&i| held[i]))
        .collect();
    if order.iter().enumerate().all(|(k, &i)| k == i) {
        return None;
    }
    let n = flight.len();
    let t0 = flight.t_s[0];
    let h = (flight.t_s[n - 1] - t0) / (n - 1).max(1) as f64;
    let mut out = flight.clone();
    out.log.pieces.clear();
    for v in out.channels.values_mut() {
        v.clear();
    }
    for &i in &order {
        let mut p = pieces[i].clone();
        let (a, b) = (p.start, p.end);
        for (q, v) in out.channels.iter_mut() {
            if let Some(src) = flight.channels.get(q) {
                v.extend_from_slice(&src[a..b]);
            }
        }
        p.start = out.log.pieces.last().map_or(0, |l| l.end);
        p.end = p.start + (b - a);
        out.log.pieces.push(p);
    }
    out.t_s = (0..n).map(|i| t0 + i as f64 * h).collect();
    Some(out)
}

/// The identification segment's end on a flight laid out by [`stratified`]: the start of its
/// first held-out piece; `None` when the flight is not split by manoeuvre or its held-out pieces
/// are not its last ones (then the split is the first `fraction` of the samples).
pub(crate) fn identification_end(flight: &MeasuredFlight, fraction: f64) -> Option<usize> {
    let held = held_out_pieces(flight, fraction)?;
    let first = held.iter().position(|h| *h)?;
    if held[first..].iter().all(|h| *h) {
        Some(flight.pieces()[first].start)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(axis: usize, ratio: f64) -> Excited {
        Excited { axis, ratio }
    }

    #[test]
    fn every_axis_flown_twice_is_both_fitted_and_held_out() {
        // GIVEN a card's eight manoeuvres: three elevator, three aileron, two rudder
        let ex = [
            e(1, 1.2),
            e(1, 1.5),
            e(1, 1.1),
            e(0, 1.4),
            e(0, 1.3),
            e(0, 1.6),
            e(2, 1.8),
            e(2, 1.7),
        ];
        let len = [800, 700, 700, 700, 600, 700, 1000, 800];
        // WHEN the held-out manoeuvres are chosen with 60 % for identification
        let held = held_out(&ex, &len, 0.6);
        // THEN one of each axis is held out (round(3·0.4) = round(2·0.4) = 1), the least excited
        assert_eq!(held, [false, false, true, false, true, false, false, true]);
    }

    #[test]
    fn a_lone_manoeuvre_of_its_axis_is_fitted_and_when_all_are_alone_the_shortest_is_held_out() {
        // GIVEN two rudder manoeuvres and one elevator manoeuvre
        let held = held_out(&[e(2, 1.0), e(0, 1.0), e(2, 1.2)], &[500, 500, 500], 0.6);
        // THEN a rudder one is held out, the elevator one fitted
        assert_eq!(held, [true, false, false]);
        // GIVEN one manoeuvre per axis (the ATTAS book case)
        let held = held_out(&[e(1, 1.0), e(0, 1.0), e(2, 1.0)], &[3000, 2000, 2500], 0.6);
        // THEN only the shortest is held out
        assert_eq!(held, [false, true, false]);
    }
}
