//! How far a simulated signal is from a measured one: the System Identification Toolbox's fit %,
//! RMS and largest error, a residual whiteness test, the noise a measured signal carries, and
//! Student's t quantile for the intervals.

use serde::Serialize;

/// Lags the whiteness test looks at (the toolbox's `resid` default).
pub const WHITENESS_LAGS: usize = 25;
/// The two-sided 99 % point of the standard normal: the whiteness band is ±this/√N.
const Z_99: f64 = 2.575_829_303_548_901;
/// The two-sided 95 % point of the standard normal.
const Z_95: f64 = 1.959_963_984_540_054;

/// Whether a residual looks like white noise: its autocorrelation at lags 1..=`lags` against
/// the 99 % band ±2.576/√N of a white sequence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Whiteness {
    /// Lags tested.
    pub lags: usize,
    /// The band's half-width, 2.576/√N.
    pub band: f64,
    /// The largest |autocorrelation| over the lags.
    pub largest: f64,
    /// Lags whose autocorrelation falls outside the band.
    pub outside: usize,
    /// No lag outside the band: the residual is white at the 99 % level.
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

/// The whiteness test of a residual over lags 1..=`lags` (fewer when the residual is short).
pub fn whiteness(residual: &[f64], lags: usize) -> Whiteness {
    let n = residual.len();
    let band = Z_99 / (n.max(1) as f64).sqrt();
    let mean = residual.iter().sum::<f64>() / n.max(1) as f64;
    let centred: Vec<f64> = residual.iter().map(|r| r - mean).collect();
    let variance: f64 = centred.iter().map(|r| r * r).sum();
    let lags = lags.min(n.saturating_sub(1));
    let correlations: Vec<f64> = (1..=lags)
        .map(|lag| {
            if variance == 0.0 {
                return 0.0;
            }
            let sum: f64 = centred
                .iter()
                .zip(&centred[lag..])
                .map(|(a, b)| a * b)
                .sum();
            sum / variance
        })
        .collect();
    let outside = correlations.iter().filter(|c| c.abs() > band).count();
    Whiteness {
        lags,
        band,
        largest: correlations.iter().fold(0.0, |m: f64, c| m.max(c.abs())),
        outside,
        white: outside == 0,
    }
}

/// The standard deviation of the noise on a sampled signal, from its second differences: for a
/// smooth signal under white noise of σ, y[k+1] − 2y[k] + y[k−1] has variance 6σ² (the smooth
/// part's share, ÿ·T², is negligible at a control period). Quantisation reads as its own noise.
pub fn noise_level(values: &[f64]) -> f64 {
    if values.len() < 3 {
        return 0.0;
    }
    let sum: f64 = values
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).powi(2))
        .sum();
    (sum / (values.len() - 2) as f64 / 6.0).sqrt()
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
        assert!(!test.white && test.outside == WHITENESS_LAGS);
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
