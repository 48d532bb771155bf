//! Local polynomial fits of a logged signal: its value and rate at one instant, from the rows
//! around it, with their standard errors under the signal's noise. A segment's start state is
//! read off the data this way where no velocity is logged (and a logged one is smoothed alike).

use nalgebra::{DMatrix, DVector};

/// Degree of the local polynomial: a cubic leaves a rate unbiased through a constant jerk, which
/// a linkage's positions have over a few tens of milliseconds.
const DEGREE: usize = 3;
/// A cubic follows its window while the rows scatter about it by at most this many σ.
const FOLLOWS: f64 = 1.5;

/// A value and its rate at one instant, with their standard errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalValue {
    /// The value, in the signal's unit.
    pub value: f64,
    /// Its rate, per second.
    pub rate: f64,
    /// The value's standard error.
    pub value_error: f64,
    /// The rate's standard error, per second.
    pub rate_error: f64,
    /// The rows' scatter about the cubic, in the signal's unit.
    pub spread: f64,
}

/// The rows of `places` (sorted, in samples) within `half` samples of `at`, or the `2·half`
/// after it (or before it) where the data end on one side: the fit's window.
fn window(places: &[f64], at: f64, half: f64) -> std::ops::Range<usize> {
    let first = places.first().copied().unwrap_or(0.0);
    let last = places.last().copied().unwrap_or(0.0);
    let (lo, hi) = if at - half < first {
        (at, at + 2.0 * half)
    } else if at + half > last {
        (at - 2.0 * half, at)
    } else {
        (at - half, at + half)
    };
    let start = places.partition_point(|&p| p < lo - 1e-9);
    let end = places.partition_point(|&p| p <= hi + 1e-9);
    start..end
}

/// The local fit at `at` (in samples) of the rows (`places` in samples, sorted; `values`) within
/// `half` samples of it, for rows of noise `sigma`; `period` turns rates into per second. `None`
/// when the window holds fewer than two rows.
pub fn fit_at(
    places: &[f64],
    values: &[f64],
    at: f64,
    half: f64,
    sigma: f64,
    period: f64,
) -> Option<LocalValue> {
    let rows = window(places, at, half);
    let n = rows.len();
    if n < 2 {
        return None;
    }
    let degree = DEGREE.min(n - 1);
    let scale = half.max(1.0);
    let basis = DMatrix::from_fn(n, degree + 1, |r, c| {
        ((places[rows.start + r] - at) / scale).powi(c as i32)
    });
    let y = DVector::from_iterator(n, values[rows].iter().copied());
    let normal = basis.transpose() * &basis;
    let inverse = normal.clone().try_inverse()?;
    let coefficients = &inverse * (basis.transpose() * &y);
    let unit = |i: usize| inverse[(i, i)].max(0.0).sqrt() * sigma;
    let misfit = (&basis * &coefficients - &y).norm_squared();
    Some(LocalValue {
        value: coefficients[0],
        rate: coefficients[1] / (scale * period),
        value_error: unit(0),
        rate_error: unit(1) / (scale * period),
        spread: (misfit / (n - degree).max(1) as f64).sqrt(),
    })
}

/// The local fit at `at` over the widest window, from `least` samples each side doubling up to
/// `most`, whose rows the cubic still follows within their noise (a fast vibration narrows it;
/// noise alone widens it, to average more rows).
pub fn fit_adaptive(
    places: &[f64],
    values: &[f64],
    at: f64,
    [least, most]: [f64; 2],
    sigma: f64,
    period: f64,
) -> Option<LocalValue> {
    let mut half = least;
    let mut best = fit_at(places, values, at, half, sigma, period)?;
    if best.spread > FOLLOWS * sigma {
        return Some(through(places, values, at, period).unwrap_or(best));
    }
    while half * 2.0 <= most {
        half *= 2.0;
        match fit_at(places, values, at, half, sigma, period) {
            Some(fit) if fit.spread <= FOLLOWS * sigma => best = fit,
            _ => break,
        }
    }
    Some(best)
}

/// Where not even the narrowest cubic follows the rows within their noise (a vibration a few
/// rows long, data without noise): the row at `at` itself, and the rate of the parabola through
/// it and its neighbours (one-sided at the data's ends). `None` where `at` is not a row.
pub fn through(places: &[f64], values: &[f64], at: f64, period: f64) -> Option<LocalValue> {
    let r = places.partition_point(|&p| p < at - 1e-9);
    if r >= places.len() || (places[r] - at).abs() > 1e-9 || places.len() < 3 {
        return None;
    }
    // The parabola through three rows about r, differentiated at r.
    let m = r.clamp(1, places.len() - 2);
    let (t, y) = (&places[m - 1..m + 2], &values[m - 1..m + 2]);
    let x = places[r];
    // d/dx of the Lagrange basis of row i: ((x − t_j) + (x − t_k)) / ((t_i − t_j)(t_i − t_k)).
    let rate: f64 = (0..3)
        .map(|i| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            y[i] * ((x - t[j]) + (x - t[k])) / ((t[i] - t[j]) * (t[i] - t[k]))
        })
        .sum();
    Some(LocalValue {
        value: values[r],
        rate: rate / period,
        value_error: 0.0,
        rate_error: 0.0,
        spread: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cubic_is_read_exactly_in_the_middle_and_at_the_ends() {
        let period = 1e-3;
        let places: Vec<f64> = (0..200).map(|k| k as f64).collect();
        let signal = |t: f64| 0.3 + 2.0 * t - 4.0 * t * t + 7.0 * t * t * t;
        let values: Vec<f64> = places.iter().map(|&p| signal(p * period)).collect();
        for at in [0.0, 57.0, 199.0] {
            let fit = fit_at(&places, &values, at, 20.0, 1e-4, period).unwrap();
            let t = at * period;
            assert!((fit.value - signal(t)).abs() < 1e-12, "{at}");
            let rate = 2.0 - 8.0 * t + 21.0 * t * t;
            assert!(
                (fit.rate - rate).abs() < 1e-9,
                "{at}: {} for {rate}",
                fit.rate
            );
            assert!(fit.rate_error > 0.0 && fit.value_error < 1e-4);
        }
    }

    #[test]
    fn the_row_itself_and_its_parabola_s_rate() {
        let places = [0.0, 1.0, 3.0, 4.0];
        let values: Vec<f64> = places.iter().map(|p| 2.0 + p * p).collect();
        for (at, rate) in [(0.0, 0.0), (1.0, 2.0), (4.0, 8.0)] {
            let row = through(&places, &values, at, 0.5).unwrap();
            assert_eq!(row.value, 2.0 + at * at);
            assert!((row.rate - rate / 0.5).abs() < 1e-12, "{at}: {}", row.rate);
        }
        assert!(through(&places, &values, 2.0, 0.5).is_none());
    }

    #[test]
    fn rows_with_gaps_and_too_few_rows() {
        let places = [0.0, 1.0, 3.5, 7.0, 10.0];
        let values: Vec<f64> = places.iter().map(|p| 1.0 + 0.5 * p).collect();
        let fit = fit_at(&places, &values, 3.5, 10.0, 1.0, 0.01).unwrap();
        assert!((fit.value - 2.75).abs() < 1e-12 && (fit.rate - 50.0).abs() < 1e-9);
        assert!(fit_at(&places[..1], &values[..1], 0.0, 5.0, 1.0, 0.01).is_none());
    }
}
