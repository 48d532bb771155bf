//! How far a simulated signal is from a measured one: the System Identification Toolbox's fit %,
//! RMS and largest error, a residual whiteness test (Ljung–Box), the noise a measured signal
//! carries, and Student's t quantile for the intervals.

use serde::Serialize;

/// Lags the whiteness test looks at (the System Identification Toolbox's `resid` default).
pub const WHITENESS_LAGS: usize = 25;
/// The standard normal's 99.9 % point: each signal's whiteness test at 0.1 %, so that a model
/// with a handful of white signals passes all of them 99 % of the time.
const Z_999: f64 = 3.090_232_306_167_813;
/// The two-sided 95 % point of the standard normal.
const Z_95: f64 = 1.959_963_984_540_054;

/// Whether a residual looks like white noise: Ljung–Box's Q over its autocorrelations at lags
/// 1..=`lags`, against the χ² quantile of `lags` degrees of freedom at 99.9 %.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Whiteness {
    /// Lags tested.
    pub lags: usize,
    /// Ljung–Box Q = N(N+2)·Σ r_l²/(N−l).
    pub ljung_box: f64,
    /// The χ² quantile Q is held to.
    pub threshold: f64,
    /// The largest |autocorrelation| over the lags.
    pub largest: f64,
    /// Q within the threshold: the residual is white at the 0.1 % level.
    pub white: bool,
}

/// One signal's agreement between the measurement and the twin.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalFit {
    /// The plant signal.
    pub signal: String,
    /// Its SI unit.
    pub unit: String,
    /// 100·(1 − ‖y − ŷ‖/‖y − ȳ‖), %: 100 is a perfect match, 0 no better than the mean.
    pub fit_percent: f64,
    /// Root mean square of the residual y − ŷ, in the unit.
    pub rms_error: f64,
    /// Largest |y − ŷ|, in the unit.
    pub max_error: f64,
    /// The residual's whiteness test.
    pub whiteness: Whiteness,
}

/// The fit of `simulated` to `measured` (equal lengths).
pub fn signal_fit(signal: &str, unit: &str, measured: &[f64], simulated: &[f64]) -> SignalFit {
    let n = measured.len().max(1) as f64;
    let mean = measured.iter().sum::<f64>() / n;
    let residual: Vec<f64> = measured.iter().zip(simulated).map(|(y, s)| y - s).collect();
    let error = residual.iter().map(|r| r * r).sum::<f64>().sqrt();
    let spread = measured
        .iter()
        .map(|y| (y - mean).powi(2))
        .sum::<f64>()
        .sqrt();
    let fit_percent = if spread > 0.0 {
        100.0 * (1.0 - error / spread)
    } else if error == 0.0 {
        100.0
    } else {
        f64::NEG_INFINITY
    };
    SignalFit {
        signal: signal.into(),
        unit: unit.into(),
        fit_percent,
        rms_error: error / n.sqrt(),
        max_error: residual.iter().fold(0.0, |m: f64, r| m.max(r.abs())),
        whiteness: whiteness(&residual, WHITENESS_LAGS),
    }
}

/// The whiteness test of a residual over lags 1..=`lags` (fewer when the residual is short:
/// at most a quarter of its length).
pub fn whiteness(residual: &[f64], lags: usize) -> Whiteness {
    whiteness_of(&[residual], lags)
}

/// The whiteness test of a residual cut into pieces (a run's segments: no product across a
/// cut), about the whole residual's mean.
pub fn whiteness_of(pieces: &[&[f64]], lags: usize) -> Whiteness {
    let n: usize = pieces.iter().map(|p| p.len()).sum();
    let lags = lags.min(n / 4).max(1);
    let correlations = autocorrelations(pieces, lags);
    let count = n as f64;
    let q = count
        * (count + 2.0)
        * (correlations.iter().enumerate())
            .map(|(l, r)| r * r / (count - (l + 1) as f64).max(1.0))
            .sum::<f64>();
    let threshold = chi_square_999(lags);
    Whiteness {
        lags,
        ljung_box: q,
        threshold,
        largest: correlations.iter().fold(0.0, |m: f64, c| m.max(c.abs())),
        white: q <= threshold,
    }
}

/// The autocorrelations at lags 1..=`lags` of a series cut into pieces (no product across a
/// cut), about the whole series' mean.
pub fn autocorrelations(pieces: &[&[f64]], lags: usize) -> Vec<f64> {
    let n: usize = pieces.iter().map(|p| p.len()).sum();
    let mean = pieces.iter().flat_map(|p| p.iter()).sum::<f64>() / n.max(1) as f64;
    let variance: f64 = (pieces.iter().flat_map(|p| p.iter()))
        .map(|r| (r - mean).powi(2))
        .sum();
    (1..=lags)
        .map(|lag| {
            let sum: f64 = (pieces.iter().filter(|p| p.len() > lag))
                .map(|p| {
                    (p.iter().zip(&p[lag..]))
                        .map(|(a, b)| (a - mean) * (b - mean))
                        .sum::<f64>()
                })
                .sum();
            match variance > 0.0 {
                true => sum / variance,
                false => 0.0,
            }
        })
        .collect()
}

/// The χ² quantile of `dof` degrees of freedom at the 99.9 % point (Wilson–Hilferty).
pub fn chi_square_999(dof: usize) -> f64 {
    let k = dof.max(1) as f64;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + Z_999 * a.sqrt()).powi(3)
}

/// The standard deviation of the noise on a sampled signal, from its differences: for a
/// smooth signal under white noise of σ, the second difference y[k+1] − 2y[k] + y[k−1] has
/// variance 6σ² and the fourth 70σ², the smooth part's share being the signal's curvature (or
/// its third derivative's) over the rows. The smaller of the two, so that a curved signal
/// logged slowly (a ram every 10 ms) is not taken for noise. Quantisation reads as its own noise.
pub fn noise_level(values: &[f64]) -> f64 {
    match difference_noise(values) {
        Some((second, Some(fourth))) => second.min(fourth),
        Some((second, None)) => second,
        None => 0.0,
    }
}

/// Whether a signal's differences look like white noise on it: its fourth differences as
/// large as its second ones say (within a factor of two). Not so for data without noise, or a
/// vibration only a few rows long, whose differences are the signal's own: their "noise" is
/// only an upper bound, and the rows are better taken as they are than smoothed.
pub fn noise_resolved(values: &[f64]) -> bool {
    match difference_noise(values) {
        Some((second, Some(fourth))) => second > 0.0 && fourth >= 0.5 * second,
        _ => false,
    }
}

/// The noise σ the second differences say (variance 6σ² under white noise), and the fourth
/// (70σ²) where there are five values; `None` under three.
fn difference_noise(values: &[f64]) -> Option<(f64, Option<f64>)> {
    let rms = |coefficients: &[f64]| -> f64 {
        let windows = values.windows(coefficients.len());
        let count = windows.len().max(1) as f64;
        let sum: f64 = windows
            .map(|w| {
                w.iter()
                    .zip(coefficients)
                    .map(|(v, c)| v * c)
                    .sum::<f64>()
                    .powi(2)
            })
            .sum();
        (sum / count).sqrt()
    };
    if values.len() < 3 {
        return None;
    }
    let second = rms(&[1.0, -2.0, 1.0]) / 6f64.sqrt();
    let fourth = (values.len() >= 5).then(|| rms(&[1.0, -4.0, 6.0, -4.0, 1.0]) / 70f64.sqrt());
    Some((second, fourth))
}

/// Student's t two-sided 95 % quantile for `dof` degrees of freedom: the Cornish–Fisher series
/// in 1/dof about the normal quantile (Abramowitz & Stegun 26.7.5), within 1e-4 of the exact
/// value from 5 degrees of freedom on; the normal quantile beyond 1e6.
pub fn t_quantile_95(dof: usize) -> f64 {
    let z = Z_95;
    if dof == 0 {
        return f64::INFINITY;
    }
    let v = dof as f64;
    let z3 = z.powi(3);
    let z5 = z.powi(5);
    let z7 = z.powi(7);
    let z9 = z.powi(9);
    let g1 = (z3 + z) / 4.0;
    let g2 = (5.0 * z5 + 16.0 * z3 + 3.0 * z) / 96.0;
    let g3 = (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / 384.0;
    let g4 = (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z) / 92160.0;
    z + g1 / v + g2 / v.powi(2) + g3 / v.powi(3) + g4 / v.powi(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_is_100_for_a_perfect_match_and_0_for_the_mean() {
        let y = [1.0, 2.0, 4.0, 3.0];
        assert_eq!(signal_fit("y", "m", &y, &y).fit_percent, 100.0);
        let mean = [2.5; 4];
        assert!(signal_fit("y", "m", &y, &mean).fit_percent.abs() < 1e-12);
    }

    #[test]
    fn white_noise_passes_and_a_sine_fails_the_whiteness_test() {
        let mut noise = crate::sensors::Noise::new(7);
        let white: Vec<f64> = (0..5000).map(|_| noise.gaussian()).collect();
        assert!(whiteness(&white, WHITENESS_LAGS).white);
        let sine: Vec<f64> = (0..5000).map(|k| (k as f64 * 0.05).sin()).collect();
        let test = whiteness(&sine, WHITENESS_LAGS);
        assert!(!test.white && test.largest > 0.9, "{test:?}");
    }

    #[test]
    fn the_noise_level_of_a_noisy_ramp_is_its_sigma() {
        let mut noise = crate::sensors::Noise::new(3);
        let values: Vec<f64> = (0..20_000)
            .map(|k| 0.3 * k as f64 * 1e-3 + 0.01 * noise.gaussian())
            .collect();
        let sigma = noise_level(&values);
        assert!((sigma / 0.01 - 1.0).abs() < 0.03, "{sigma}");
    }

    #[test]
    fn t_quantiles_match_the_tables() {
        // Tables of Student's t, two-sided 95 %.
        for (dof, table) in [
            (5, 2.570_582),
            (10, 2.228_139),
            (30, 2.042_272),
            (1000, 1.962_339),
        ] {
            assert!((t_quantile_95(dof) - table).abs() < 2e-3, "{dof}");
        }
    }
}
