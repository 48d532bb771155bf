//! One mode fitted to a measured receptance around its peak: the rational fraction
//! H(s) = (b₀ + b₁s) / (s² + a₁s + a₀), s = iω, by linear least squares on
//! H·(s² + a₁s + a₀) = b₀ + b₁s (Levy's method), over the lines whose magnitude is at least half
//! the peak's. The pole gives ωₙ = √a₀ and ζ = a₁/(2ωₙ); the residue at the pole
//! p = −ζωₙ + iω_d is (b₀ + b₁p)/(2iω_d), and a single degree of freedom's is 1/(2imω_d), so
//! the modal mass is m = 1/|b₀ + b₁p|, its stiffness mωₙ² and its damping 2ζmωₙ. The b₁ term
//! takes up the residual of modes outside the band.

use super::estimate::{Complex, FrfLine};
use std::f64::consts::TAU;

/// Fewest lines around the peak the fit accepts (four unknowns, and some to spare).
const MIN_LINES: usize = 6;

/// A mode's modal values (SI: kg, N/m, N·s/m when the response is m/N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalFit {
    pub natural_frequency_hz: f64,
    pub damping_ratio: f64,
    pub mass: f64,
    pub stiffness: f64,
    pub damping: f64,
    /// Lines used, and the band they span, Hz.
    pub lines: usize,
    pub band: [f64; 2],
}

/// Fits the mode at the largest magnitude (above 0 Hz) of `frf`; `Err` says why it cannot.
pub fn fit_mode(frf: &[FrfLine]) -> Result<ModalFit, String> {
    let peak = frf
        .iter()
        .enumerate()
        .filter(|(_, l)| l.frequency_hz > 0.0)
        .max_by(|a, b| a.1.response.abs().total_cmp(&b.1.response.abs()))
        .map(|(i, _)| i)
        .ok_or("no line above 0 Hz to fit")?;
    let half = frf[peak].response.abs() / 2.0;
    let mut first = peak;
    while first > 0 && frf[first - 1].response.abs() >= half && frf[first - 1].frequency_hz > 0.0 {
        first -= 1;
    }
    let mut last = peak;
    while last + 1 < frf.len() && frf[last + 1].response.abs() >= half {
        last += 1;
    }
    let lines = &frf[first..=last];
    if lines.len() < MIN_LINES {
        return Err(format!(
            "only {} lines above half the peak at {:.1} Hz (at least {MIN_LINES} needed): the \
             resolution is too coarse for this mode; use a longer segment",
            lines.len(),
            frf[peak].frequency_hz
        ));
    }
    let scale_w = TAU * frf[peak].frequency_hz;
    let scale_h = frf[peak].response.abs();
    let [a0, a1, b0, b1] = solve_levy(lines, scale_w, scale_h)?;
    // Back to SI: s = scale_w·s̃, H = scale_h·H̃.
    let (a0, a1) = (a0 * scale_w * scale_w, a1 * scale_w);
    let (b0, b1) = (b0 * scale_h * scale_w * scale_w, b1 * scale_h * scale_w);
    if !(a0 > 0.0 && a1 > 0.0) || a1 * a1 >= 4.0 * a0 {
        return Err(format!(
            "the fitted pole is not a damped oscillation (a₀ = {a0:.4e}, a₁ = {a1:.4e})"
        ));
    }
    let wn = a0.sqrt();
    let zeta = a1 / (2.0 * wn);
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let pole = Complex::new(-zeta * wn, wd);
    let mass = 1.0 / Complex::new(b0, 0.0).plus(pole.scale(b1)).abs();
    Ok(ModalFit {
        natural_frequency_hz: wn / TAU,
        damping_ratio: zeta,
        mass,
        stiffness: mass * wn * wn,
        damping: 2.0 * zeta * mass * wn,
        lines: lines.len(),
        band: [lines[0].frequency_hz, lines[lines.len() - 1].frequency_hz],
    })
}

/// Least squares of H̃·(s̃² + a₁s̃ + a₀) = b₀ + b₁s̃ in scaled units (s̃ = iω/scale_w,
/// H̃ = H/scale_h), real and imaginary parts as two equations per line; normal equations.
fn solve_levy(lines: &[FrfLine], scale_w: f64, scale_h: f64) -> Result<[f64; 4], String> {
    let mut normal = [[0.0; 5]; 4];
    for line in lines {
        let w = TAU * line.frequency_hz / scale_w;
        let h = line.response.scale(1.0 / scale_h);
        let s = Complex::new(0.0, w);
        // Unknowns a₀, a₁, b₀, b₁: columns H, H·s, −1, −s; right side −H·s².
        let cols = [h, h.times(s), Complex::new(-1.0, 0.0), s.scale(-1.0)];
        let rhs = h.scale(w * w);
        for part in [|c: Complex| c.re, |c: Complex| c.im] {
            let row = cols.map(part);
            for i in 0..4 {
                for j in 0..4 {
                    normal[i][j] += row[i] * row[j];
                }
                normal[i][4] += row[i] * part(rhs);
            }
        }
    }
    gauss(normal).ok_or_else(|| "the fit's equations are singular".to_string())
}

/// Solves a 4×4 system (augmented) by Gaussian elimination with partial pivoting.
fn gauss(mut m: [[f64; 5]; 4]) -> Option<[f64; 4]> {
    for c in 0..4 {
        let p = (c..4).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs()))?;
        if m[p][c].abs() <= 1e-300 || m[p][c].is_nan() {
            return None;
        }
        m.swap(c, p);
        let pivot = m[c];
        for row in m.iter_mut().skip(c + 1) {
            let f = row[c] / pivot[c];
            for (value, p) in row.iter_mut().zip(pivot).skip(c) {
                *value -= f * p;
            }
        }
    }
    let mut x = [0.0; 4];
    for r in (0..4).rev() {
        let tail: f64 = (r + 1..4).map(|k| m[r][k] * x[k]).sum();
        x[r] = (m[r][4] - tail) / m[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact receptance of m = 0.056 kg, k = 1.3669 MN/m, ζ = 0.02 on 2 Hz lines: the fit
    /// returns them.
    #[test]
    fn recovers_an_exact_single_mode() {
        let (m, k, zeta): (f64, f64, f64) = (0.056, 1.3669e6, 0.02);
        let c = 2.0 * zeta * (k * m).sqrt();
        let frf: Vec<FrfLine> = (0..2000)
            .map(|i| {
                let f = 2.0 * i as f64;
                let w = TAU * f;
                FrfLine {
                    frequency_hz: f,
                    response: Complex::new(1.0, 0.0).over(Complex::new(k - m * w * w, c * w)),
                    coherence: 1.0,
                }
            })
            .collect();
        let fit = fit_mode(&frf).unwrap();
        let fn_exact = (k / m).sqrt() / TAU;
        assert!((fit.natural_frequency_hz / fn_exact - 1.0).abs() < 1e-9);
        assert!((fit.damping_ratio / zeta - 1.0).abs() < 1e-6);
        assert!((fit.mass / m - 1.0).abs() < 1e-6);
        assert!((fit.stiffness / k - 1.0).abs() < 1e-6);
    }

    #[test]
    fn too_coarse_a_resolution_is_refused() {
        let frf: Vec<FrfLine> = (0..5)
            .map(|i| FrfLine {
                frequency_hz: 500.0 * i as f64,
                response: Complex::new(if i == 2 { 1.0 } else { 0.1 }, 0.0),
                coherence: 1.0,
            })
            .collect();
        let error = fit_mode(&frf).unwrap_err();
        assert!(error.contains("longer segment"), "{error}");
    }
}
