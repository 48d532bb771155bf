//! Whether a fitted model explains its data, apart from whether its solver converged: the
//! weighted residuals' variance σ̂² (1 when the residuals are the noise), each signal's fit %
//! and whether its residual is white (Ljung–Box, pooled over the segments). A model that does
//! not fit gets intervals widened by the residuals' own autocorrelation (a Newey–West sandwich),
//! marked, and advice on what to try.

use super::metrics::{autocorrelations, whiteness_of, SignalFit, WHITENESS_LAGS};
use super::problem::Problem;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// σ̂² above this: the residuals are larger than the noise the signals carry.
pub const VARIANCE_FITS: f64 = 2.0;
/// A signal the twin follows to this fit % leaves a residual at the data's own precision,
/// whatever its whiteness (noise-free data replayed on their own model).
const EXACT_FIT: f64 = 100.0 - 1e-4;
/// A quantised signal's residual within this share of its step is the quantisation alone.
const QUANTISED_RESIDUAL: f64 = 0.6;
/// Longest lag the sandwich estimate sums.
const MAX_BANDWIDTH: usize = 500;

/// One fitted signal's part of the verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalVerdict {
    /// The plant signal.
    pub signal: String,
    /// Its fit % over the runs (after).
    pub fit_percent: f64,
    /// Ljung–Box Q of its weighted residual over 25 lags, pooled over the segments…
    pub ljung_box: f64,
    /// …and the value above which it is not white.
    pub threshold: f64,
    /// Whether its residual is white (or is its quantisation alone).
    pub white: bool,
    /// The data's quantisation step, where the signal is logged on a lattice, SI.
    pub quantum: Option<f64>,
}

/// Whether the model explains the data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// σ̂² ≤ [`VARIANCE_FITS`] and every signal's residual white.
    pub fits: bool,
    /// σ̂², the weighted residuals' variance.
    pub residual_variance: f64,
    /// Per fitted signal.
    pub signals: Vec<SignalVerdict>,
    /// Why it does not fit, one line each.
    pub reasons: Vec<String>,
    /// What to try.
    pub advice: Vec<String>,
}

impl Verdict {
    /// `fits` or `does not fit`.
    pub fn word(&self) -> &'static str {
        match self.fits {
            true => "fits",
            false => "does not fit",
        }
    }

    /// The verdict in one line, its figures after it.
    pub fn line(&self) -> String {
        let fit: Vec<String> = (self.signals.iter())
            .map(|s| format!("{} {:.2} %", s.signal, s.fit_percent))
            .collect();
        let white = match self.signals.iter().all(|s| s.white) {
            true => "residuals white".to_string(),
            false => {
                let not: Vec<&str> = (self.signals.iter().filter(|s| !s.white))
                    .map(|s| s.signal.as_str())
                    .collect();
                format!("residuals not white ({})", not.join(", "))
            }
        };
        format!(
            "verdict: {} (σ̂² = {:.4}, fit {}, {white})",
            self.word(),
            self.residual_variance,
            fit.join(", ")
        )
    }
}

/// The verdict on `problem` at residuals `residuals` (per segment, signal-major, weighted), of
/// variance σ̂² `variance`, with the fits after the solve `fits` (per fitted signal).
pub fn judge(
    problem: &Problem,
    residuals: &[Vec<f64>],
    variance: f64,
    fits: &[SignalFit],
) -> Verdict {
    let outputs = problem.outputs.len();
    let mut signals = Vec::with_capacity(outputs);
    for (o, fit) in fits.iter().enumerate() {
        let test = whiteness_of(&series_of(residuals, outputs, o), WHITENESS_LAGS);
        let quantum = quantum(problem, o);
        let within = quantum.is_some_and(|step| fit.rms_error <= QUANTISED_RESIDUAL * step);
        signals.push(SignalVerdict {
            signal: fit.signal.clone(),
            fit_percent: fit.fit_percent,
            ljung_box: test.ljung_box,
            threshold: test.threshold,
            white: test.white || within || fit.fit_percent >= EXACT_FIT,
            quantum,
        });
    }
    let mut reasons = Vec::new();
    if variance.is_nan() || variance > VARIANCE_FITS {
        reasons.push(format!(
            "σ̂² = {variance:.4e}: the residuals are {:.3}× the signals' noise σ (a fit leaves them at 1×)",
            variance.sqrt()
        ));
    }
    for s in signals.iter().filter(|s| !s.white) {
        reasons.push(format!(
            "{}'s residual is not white (Ljung–Box Q = {:.1} > {:.1}): it holds motion the model does not explain",
            s.signal, s.ljung_box, s.threshold
        ));
    }
    Verdict {
        fits: reasons.is_empty(),
        residual_variance: variance,
        advice: advice(problem, &reasons),
        signals,
        reasons,
    }
}

/// What to try when the model does not fit.
fn advice(problem: &Problem, reasons: &[String]) -> Vec<String> {
    if reasons.is_empty() {
        return Vec::new();
    }
    let mut advice = vec![
        "fit another parameter the runs excite (a damping, a friction, a link's inertia or centre of mass) beside these".to_string(),
    ];
    if problem.length > 0.0 {
        advice.push(format!(
            "shorter segments (--segment {}), where an open-loop replay drifts",
            problem.length / 2.0
        ));
    } else {
        advice
            .push("segments (--segment 1), logging the positions that place the mechanism".into());
    }
    if !problem.replayer.closed_loop {
        advice.push("--closed-loop, where the logged commands are not what reached the machine (a drive's own loop, a logger slower than the control)".into());
    }
    advice.push("check each signal's noise (--noise NAME=SIGMA) and units".into());
    advice
}

/// Signal `o`'s residuals, one slice per segment.
fn series_of(residuals: &[Vec<f64>], outputs: usize, o: usize) -> Vec<&[f64]> {
    (residuals.iter())
        .map(|r| {
            let n = r.len() / outputs.max(1);
            &r[o * n..(o + 1) * n]
        })
        .collect()
}

/// The step of the lattice a fitted signal's logged values lie on (an encoder's count), if
/// they lie on one: the real greatest common divisor of their differences.
fn quantum(problem: &Problem, o: usize) -> Option<f64> {
    let i = problem.outputs[o];
    let mut step = 0.0_f64;
    let mut size = 0.0_f64;
    for trace in &problem.traces {
        let (_, values) = trace.observed(i)?;
        for pair in values.windows(2) {
            size = size.max(pair[0].abs());
            let d = (pair[1] - pair[0]).abs();
            if d > 0.0 {
                step = real_gcd(step, d, 1e-9 * d.max(step));
            }
        }
    }
    let tolerance = 1e-12 * size.max(1.0);
    (step > 1e3 * tolerance).then_some(step)
}

/// The greatest common divisor of two non-negative reals, to `tolerance` (0 when none above it).
fn real_gcd(a: f64, b: f64, tolerance: f64) -> f64 {
    let (mut a, mut b) = (a.max(b), a.min(b));
    for _ in 0..64 {
        if b <= tolerance {
            return a;
        }
        (a, b) = (b, a % b);
    }
    0.0
}

/// The Newey–West covariance of the unknowns at the solution, in their own units: the
/// Gauss–Newton bread `(JᵀJ)⁻¹` around the scores' long-run covariance, each segment's signal
/// a series with Bartlett weights up to its residual's correlation length. `jacobian` is of the
/// stacked weighted residuals (segments in order, signal-major within each).
pub fn sandwich(
    problem: &Problem,
    residuals: &[Vec<f64>],
    jacobian: &DMatrix<f64>,
) -> Option<DMatrix<f64>> {
    let p = jacobian.ncols();
    let outputs = problem.outputs.len().max(1);
    let scale: Vec<f64> = problem.unknowns.iter().map(|u| u.scale).collect();
    let scaled = jacobian * DMatrix::from_diagonal(&DVector::from_column_slice(&scale));
    let bread = (scaled.transpose() * &scaled).try_inverse()?;
    let mut meat = DMatrix::<f64>::zeros(p, p);
    let mut offset = 0;
    for (s, segment) in residuals.iter().enumerate() {
        let active: Vec<usize> = (0..p).filter(|&j| problem.affects(j, s)).collect();
        let n = segment.len() / outputs;
        for o in 0..outputs {
            let series = &segment[o * n..(o + 1) * n];
            let bandwidth = correlation_length(series).min(n / 2);
            let m = active.len();
            let mut scores = vec![0.0; n * m];
            for (t, r) in series.iter().enumerate() {
                let row = offset + o * n + t;
                for (a, &j) in active.iter().enumerate() {
                    scores[t * m + a] = scaled[(row, j)] * r;
                }
            }
            let block = long_run(&scores, m, bandwidth);
            for (a, &i) in active.iter().enumerate() {
                for (b, &k) in active.iter().enumerate() {
                    meat[(i, k)] += block[a * m + b];
                }
            }
        }
        offset += segment.len();
    }
    let covariance = &bread * meat * &bread;
    Some(DMatrix::from_fn(p, p, |i, k| {
        covariance[(i, k)] * scale[i] * scale[k]
    }))
}

/// Σ_t s_t s_tᵀ + Σ_lag w_lag Σ_t (s_t s_{t−lag}ᵀ + s_{t−lag} s_tᵀ) of scores `n × m` (row-major),
/// Bartlett weights up to `bandwidth`: m × m, row-major.
fn long_run(scores: &[f64], m: usize, bandwidth: usize) -> Vec<f64> {
    let n = scores.len() / m.max(1);
    let mut block = vec![0.0; m * m];
    for lag in 0..=bandwidth.min(n.saturating_sub(1)) {
        let weight = 1.0 - lag as f64 / (bandwidth + 1) as f64;
        for t in lag..n {
            let (now, then) = (
                &scores[t * m..(t + 1) * m],
                &scores[(t - lag) * m..(t - lag + 1) * m],
            );
            for a in 0..m {
                for b in 0..m {
                    block[a * m + b] += match lag {
                        0 => now[a] * then[b],
                        _ => weight * (now[a] * then[b] + then[a] * now[b]),
                    };
                }
            }
        }
    }
    block
}

/// The first lag at which a series' autocorrelation falls below 0.05, at most
/// [`MAX_BANDWIDTH`].
fn correlation_length(series: &[f64]) -> usize {
    let correlations = autocorrelations(&[series], MAX_BANDWIDTH.min(series.len() / 2));
    (correlations.iter().position(|r| r.abs() < 0.05)).unwrap_or(correlations.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_passes_ljung_box_across_cuts_and_a_drift_fails() {
        let mut noise = crate::sensors::Noise::new(11);
        let white: Vec<f64> = (0..4000).map(|_| noise.gaussian()).collect();
        assert!(whiteness_of(&[&white[..2000], &white[2000..]], WHITENESS_LAGS).white);
        let drift: Vec<f64> = (0..4000).map(|k| (k as f64 * 0.01).sin()).collect();
        let test = whiteness_of(&[&drift], WHITENESS_LAGS);
        assert!(test.ljung_box > 10.0 * test.threshold);
    }

    #[test]
    fn chi_square_quantile_matches_the_tables() {
        // χ² tables, 99.9 %: 25 dof 52.620, 10 dof 29.588.
        assert!((super::super::metrics::chi_square_999(25) - 52.620).abs() < 0.2);
        assert!((super::super::metrics::chi_square_999(10) - 29.588).abs() < 0.3);
    }

    #[test]
    fn an_encoders_lattice_is_found() {
        let step = std::f64::consts::TAU / 10_000.0;
        let a = real_gcd(0.0, 9.0 * step, 1e-9);
        let b = real_gcd(a, 10.0 * step, 1e-9 * 10.0 * step);
        assert!((b - step).abs() < 1e-12, "{b}");
    }
}
