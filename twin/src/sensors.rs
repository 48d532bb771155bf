//! Sensor models between the true signals and the controller: quantisation, noise and delay.
//!
//! Noise comes from a seeded generator (SplitMix64 + Box–Muller), so a run is reproducible bit for
//! bit. Delay is a whole number of control periods (a sensor sampled by the drive's clock).

use serde::Deserialize;
use std::collections::VecDeque;

/// How one measured signal is sensed; every field defaults to an ideal sensor.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// Quantisation step in the signal's unit (e.g. 2π/40000 rad for a 10,000-line encoder read
    /// in quadrature); 0 = none.
    pub resolution: f64,
    /// Standard deviation of white Gaussian noise added before quantisation; 0 = none.
    pub noise: f64,
    /// Transport delay, s; rounded to whole control periods.
    pub delay: f64,
}

impl SensorSpec {
    pub fn validate(&self) -> Result<(), String> {
        for (name, value) in [
            ("resolution", self.resolution),
            ("noise", self.noise),
            ("delay", self.delay),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!("{name} must be ≥ 0 and finite, got {value}"));
            }
        }
        Ok(())
    }
}

/// A sensor in operation.
#[derive(Debug, Clone)]
pub struct Sensor {
    spec: SensorSpec,
    history: VecDeque<f64>,
    delay_periods: usize,
}

impl Sensor {
    pub fn new(spec: SensorSpec, control_period: f64) -> Self {
        let delay_periods = (spec.delay / control_period).round() as usize;
        Self {
            spec,
            // Grown as readings arrive: a long delay costs memory only once the run reaches it.
            history: VecDeque::with_capacity(delay_periods.min(4096) + 1),
            delay_periods,
        }
    }

    /// The reading for a true value sampled now.
    pub fn read(&mut self, true_value: f64, noise: &mut Noise) -> f64 {
        let mut value = true_value;
        if self.spec.noise > 0.0 {
            value += self.spec.noise * noise.gaussian();
        }
        if self.spec.resolution > 0.0 {
            value = (value / self.spec.resolution).round() * self.spec.resolution;
        }
        if self.delay_periods == 0 {
            return value;
        }
        self.history.push_back(value);
        if self.history.len() > self.delay_periods {
            self.history.pop_front().unwrap_or(value)
        } else {
            // Before the first delayed sample arrives the sensor holds its first reading.
            self.history[0]
        }
    }
}

/// Seeded Gaussian noise source.
#[derive(Debug, Clone)]
pub struct Noise {
    state: u64,
    spare: Option<f64>,
}

impl Noise {
    /// A source started at `seed`: the same seed gives the same sequence.
    pub fn new(seed: u64) -> Self {
        Self {
            state: seed,
            spare: None,
        }
    }

    /// The next 64 random bits (SplitMix64).
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn gaussian(&mut self) -> f64 {
        if let Some(spare) = self.spare.take() {
            return spare;
        }
        let radius = (-2.0 * self.uniform().ln()).sqrt();
        let angle = std::f64::consts::TAU * self.uniform();
        self.spare = Some(radius * angle.sin());
        radius * angle.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantises_to_the_resolution() {
        let mut sensor = Sensor::new(
            SensorSpec {
                resolution: 0.25,
                ..Default::default()
            },
            1e-3,
        );
        let mut noise = Noise::new(1);
        assert_eq!(sensor.read(0.62, &mut noise), 0.5);
        assert_eq!(sensor.read(-0.13, &mut noise), -0.25);
    }

    #[test]
    fn delays_by_whole_periods() {
        let mut sensor = Sensor::new(
            SensorSpec {
                delay: 2e-3,
                ..Default::default()
            },
            1e-3,
        );
        let mut noise = Noise::new(1);
        let readings: Vec<f64> = (1..=5).map(|v| sensor.read(v as f64, &mut noise)).collect();
        assert_eq!(readings, [1.0, 1.0, 1.0, 2.0, 3.0]);
    }

    #[test]
    fn noise_has_the_stated_spread_and_repeats_with_the_seed() {
        let mut noise = Noise::new(42);
        let samples: Vec<f64> = (0..100_000).map(|_| noise.gaussian()).collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let var = samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / samples.len() as f64;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.02,
            "{mean} {var}"
        );
        let mut again = Noise::new(42);
        assert_eq!(again.gaussian(), samples[0]);
    }

    #[test]
    fn negative_values_are_rejected() {
        let spec = SensorSpec {
            noise: -1.0,
            ..Default::default()
        };
        assert!(spec.validate().unwrap_err().contains("noise"));
    }
}
