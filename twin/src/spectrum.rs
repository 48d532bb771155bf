//! One-sided amplitude spectra of sampled signals (the milling chatter figures and plots).
//!
//! The window's samples less their mean are weighted by a Hann window, zero-padded to a power of
//! two and transformed (radix-2 FFT). Amplitudes are corrected for the window's coherent gain, so a
//! sine of amplitude A that falls on a bin reads A: `|X_k|·2/Σw`. The bins are `fs/N_fft` apart;
//! the resolution (Hann main lobe) is about `2·fs/N_samples`, twice the inverse window length.

use std::f64::consts::TAU;

/// An amplitude spectrum: bin k at `k·bin_width` Hz.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// The bins' spacing, Hz.
    pub bin_width: f64,
    /// The amplitude in each bin, in the signal's unit, from 0 Hz to the Nyquist frequency.
    pub amplitudes: Vec<f64>,
}

impl Spectrum {
    /// The spectrum of `samples` taken every `sample_period` s (empty for fewer than 2 samples).
    pub fn of(samples: &[f64], sample_period: f64) -> Self {
        let n = samples.len();
        if n < 2 || sample_period.is_nan() || sample_period <= 0.0 {
            return Self {
                bin_width: 0.0,
                amplitudes: Vec::new(),
            };
        }
        let mean = samples.iter().sum::<f64>() / n as f64;
        let size = n.next_power_of_two();
        let mut re = vec![0.0; size];
        let mut im = vec![0.0; size];
        let mut weight_sum = 0.0;
        for (k, (slot, &x)) in re.iter_mut().zip(samples).enumerate() {
            let w = 0.5 - 0.5 * (TAU * k as f64 / (n - 1) as f64).cos();
            weight_sum += w;
            *slot = w * (x - mean);
        }
        fft(&mut re, &mut im);
        let amplitudes = (0..size / 2 + 1)
            .map(|k| 2.0 * re[k].hypot(im[k]) / weight_sum)
            .collect();
        Self {
            bin_width: 1.0 / (size as f64 * sample_period),
            amplitudes,
        }
    }

    /// The largest amplitude with its frequency (Hz) within `[low, high]` Hz.
    pub fn peak(&self, [low, high]: [f64; 2]) -> Option<(f64, f64)> {
        self.amplitudes
            .iter()
            .enumerate()
            .map(|(k, &a)| (k as f64 * self.bin_width, a))
            .filter(|&(f, _)| f >= low && f <= high)
            .fold(None, |best: Option<(f64, f64)>, (f, a)| match best {
                Some((_, b)) if b >= a => best,
                _ => Some((f, a)),
            })
    }
}

/// In-place iterative radix-2 FFT (X_k = Σ x_n e^(−2πikn/N)); `re.len()` must be a power of
/// two.
pub fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let (ws, wc) = (-TAU / len as f64).sin_cos();
        for start in (0..n).step_by(len) {
            let (mut wr, mut wi) = (1.0, 0.0);
            for k in 0..len / 2 {
                let (a, b) = (start + k, start + k + len / 2);
                let tr = re[b] * wr - im[b] * wi;
                let ti = re[b] * wi + im[b] * wr;
                (re[b], im[b]) = (re[a] - tr, im[a] - ti);
                re[a] += tr;
                im[a] += ti;
                (wr, wi) = (wr * wc - wi * ws, wr * ws + wi * wc);
            }
        }
        len <<= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sine_on_a_bin_reads_its_amplitude_and_frequency() {
        let (fs, n) = (10_000.0, 8192);
        let f0 = 100.0 * fs / n as f64; // on bin 100
        let samples: Vec<f64> = (0..n)
            .map(|k| 3.0 + 2.5e-5 * (TAU * f0 * k as f64 / fs).sin())
            .collect();
        let spectrum = Spectrum::of(&samples, 1.0 / fs);
        let (f, a) = spectrum.peak([10.0, 5000.0]).unwrap();
        assert!((f - f0).abs() < 1e-9, "{f} vs {f0}");
        assert!((a - 2.5e-5).abs() < 1e-3 * 2.5e-5, "{a}");
    }

    #[test]
    fn the_fft_matches_a_direct_dft() {
        let x: Vec<f64> = (0..64).map(|k| ((k * k) % 7) as f64 - 3.0).collect();
        let (mut re, mut im) = (x.clone(), vec![0.0; 64]);
        fft(&mut re, &mut im);
        for k in 0..64 {
            let (mut dr, mut di) = (0.0, 0.0);
            for (t, v) in x.iter().enumerate() {
                let angle = -TAU * (k * t) as f64 / 64.0;
                dr += v * angle.cos();
                di += v * angle.sin();
            }
            assert!((re[k] - dr).abs() < 1e-9 && (im[k] - di).abs() < 1e-9);
        }
    }
}
