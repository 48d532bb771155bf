//! The H1 estimate of a frequency response with Welch averaging (Bendat & Piersol): per segment
//! the windowed input and output are transformed, the auto- and cross-spectra summed over the
//! segments, and H1 = G_xy / G_xx with the coherence γ² = |G_xy|² / (G_xx·G_yy).

use std::f64::consts::{PI, TAU};
use twin::signal::fft;

/// A complex number, just what the estimate needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Complex {
    pub re: f64,
    pub im: f64,
}

impl Complex {
    pub fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    pub fn norm_sqr(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    pub fn conj(self) -> Self {
        Self::new(self.re, -self.im)
    }
    pub fn times(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    pub fn scale(self, k: f64) -> Self {
        Self::new(self.re * k, self.im * k)
    }
    pub fn over(self, o: Self) -> Self {
        self.times(o.conj()).scale(1.0 / o.norm_sqr())
    }
    pub fn plus(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    pub fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
}

/// The window applied to each segment before its transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// None: a transient that starts and dies within its segment (an impulse per average).
    Rectangular,
    /// Hann, periodic form (the segment's ends at zero weight): stationary excitation.
    Hann,
}

impl Window {
    /// The levels a segment's input and output are taken about: for a transient, none and the
    /// output's before the tap (its first sample; the input is zero between taps); for a
    /// stationary excitation, their means.
    fn operating_point(self, x: &[f64], y: &[f64]) -> (f64, f64) {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        match self {
            Window::Rectangular => (0.0, y.first().copied().unwrap_or(0.0)),
            Window::Hann => (mean(x), mean(y)),
        }
    }

    fn weight(self, k: usize, n: usize) -> f64 {
        match self {
            Window::Rectangular => 1.0,
            Window::Hann => 0.5 - 0.5 * (TAU * k as f64 / n as f64).cos(),
        }
    }
}

/// How the record is cut: `segment` samples (a power of two), starting every `hop` samples
/// from `first`, `count` of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segments {
    pub first: usize,
    pub segment: usize,
    pub hop: usize,
    pub count: usize,
    pub window: Window,
}

/// One frequency line of the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrfLine {
    pub frequency_hz: f64,
    /// H1, output unit per input unit.
    pub response: Complex,
    pub coherence: f64,
}

/// H1 and coherence at the bins of `[low, high]` Hz from input `x` and output `y` sampled every
/// `period` s, each segment's output taken about its operating point (the window's). The input is an effort held over each sample period (a zero-order hold): its
/// spectrum is the samples' times `sinc(f·T)·e^(−iπfT)`, which is divided out so that H1 is the
/// continuous plant's response, not the hold's. Bins where the input has no power are left out.
pub fn h1_estimate(
    x: &[f64],
    y: &[f64],
    period: f64,
    segments: Segments,
    [low, high]: [f64; 2],
) -> Vec<FrfLine> {
    let n = segments.segment;
    let bins = n / 2 + 1;
    let mut gxx = vec![0.0; bins];
    let mut gyy = vec![0.0; bins];
    let mut gxy = vec![Complex::default(); bins];
    let (mut xr, mut xi, mut yr, mut yi) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for s in 0..segments.count {
        let start = segments.first + s * segments.hop;
        let (x0, y0) =
            (segments.window).operating_point(&x[start..start + n], &y[start..start + n]);
        for k in 0..n {
            let w = segments.window.weight(k, n);
            (xr[k], xi[k]) = (w * (x[start + k] - x0), 0.0);
            (yr[k], yi[k]) = (w * (y[start + k] - y0), 0.0);
        }
        fft(&mut xr, &mut xi);
        fft(&mut yr, &mut yi);
        for b in 0..bins {
            let (xb, yb) = (Complex::new(xr[b], xi[b]), Complex::new(yr[b], yi[b]));
            gxx[b] += xb.norm_sqr();
            gyy[b] += yb.norm_sqr();
            gxy[b] = gxy[b].plus(xb.conj().times(yb));
        }
    }
    let bin_width = 1.0 / (n as f64 * period);
    (0..bins)
        .filter_map(|b| {
            let f = b as f64 * bin_width;
            let powered = gxx[b] > 1e-12 * gxx.iter().cloned().fold(0.0, f64::max);
            (f >= low && f <= high && powered).then(|| {
                let hold = zero_order_hold(f, period);
                FrfLine {
                    frequency_hz: f,
                    response: gxy[b].scale(1.0 / gxx[b]).over(hold),
                    coherence: if gyy[b] > 0.0 {
                        (gxy[b].norm_sqr() / (gxx[b] * gyy[b])).min(1.0)
                    } else {
                        0.0
                    },
                }
            })
        })
        .collect()
}

/// The hold's response at `f` Hz for samples `period` s apart: `sinc(fT)·e^(−iπfT)`.
fn zero_order_hold(f: f64, period: f64) -> Complex {
    let a = PI * f * period;
    let sinc = if a == 0.0 { 1.0 } else { a.sin() / a };
    Complex::new(a.cos(), -a.sin()).scale(sinc)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A known discrete filter y[k] = x[k] + 0.5·x[k−1] seen through H1: its response
    /// 1 + 0.5·e^(−iωT), the hold divided out, coherence 1.
    #[test]
    fn h1_recovers_a_known_filter_with_unit_coherence() {
        let mut noise = twin::Noise::new(3);
        let x: Vec<f64> = (0..4096).map(|_| noise.uniform() - 0.5).collect();
        let y: Vec<f64> = (0..4096)
            .map(|k| x[k] + if k > 0 { 0.5 * x[k - 1] } else { 0.0 })
            .collect();
        let segments = Segments {
            first: 1024,
            segment: 1024,
            hop: 512,
            count: 5,
            window: Window::Hann,
        };
        let period = 1e-3;
        for line in h1_estimate(&x, &y, period, segments, [0.0, 500.0]) {
            let w = TAU * line.frequency_hz * period;
            let exact = Complex::new(1.0 + 0.5 * w.cos(), -0.5 * w.sin())
                .over(zero_order_hold(line.frequency_hz, period));
            let error = line.response.plus(exact.scale(-1.0)).abs() / exact.abs();
            assert!(error < 0.02, "{} Hz: {error}", line.frequency_hz);
            assert!(
                line.coherence > 0.99,
                "{} Hz: γ² {}",
                line.frequency_hz,
                line.coherence
            );
        }
    }
}
