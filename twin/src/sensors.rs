//! Sensor models between the true signals and the controller: gain and bias, noise,
//! quantisation and delay.
//!
//! Noise comes from a seeded generator (SplitMix64 + Box–Muller), so a run is reproducible bit for
//! bit. A delay of whole control periods holds readings (a sensor sampled by the drive's clock);
//! a fraction of a period in between interpolates the two neighbouring readings, so that a
//! calibration can fit a delay as a continuous value.

use serde::Deserialize;
use std::collections::VecDeque;

/// How one measured signal is sensed; every field defaults to an ideal sensor.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// Scale factor on the true value (a miscalibrated encoder or load cell); 1 = none.
    pub gain: f64,
    /// Offset added to the scaled value, in the signal's unit; 0 = none.
    pub bias: f64,
    /// Quantisation step in the signal's unit (e.g. 2π/40000 rad for a 10,000-line encoder read
    /// in quadrature); 0 = none.
    pub resolution: f64,
    /// Standard deviation of white Gaussian noise added before quantisation; 0 = none.
    pub noise: f64,
    /// Transport delay, s: whole control periods hold readings, a fraction of a period
    /// interpolates between two.
    pub delay: f64,
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            gain: 1.0,
            bias: 0.0,
            resolution: 0.0,
            noise: 0.0,
            delay: 0.0,
        }
    }
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
        for (name, value) in [("gain", self.gain), ("bias", self.bias)] {
            if !value.is_finite() {
                return Err(format!("{name} must be finite, got {value}"));
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
    /// Whole control periods of delay.
    delay_periods: usize,
    /// The delay's fraction of a period beyond them: the weight of the reading one period older.
    delay_fraction: f64,
}

impl Sensor {
    pub fn new(spec: SensorSpec, control_period: f64) -> Self {
        let periods = spec.delay / control_period;
        // A delay within a billionth of a whole period is that whole period (no interpolation).
        let whole = periods.round();
        let (delay_periods, delay_fraction) = if (periods - whole).abs() < 1e-9 {
            (whole as usize, 0.0)
        } else {
            (periods.floor() as usize, periods - periods.floor())
        };
        Self {
            spec,
            // Grown as readings arrive: a long delay costs memory only once the run reaches it.
            history: VecDeque::with_capacity(delay_periods.min(4096) + 2),
            delay_periods,
            delay_fraction,
        }
    }

    /// The reading for a true value sampled now.
    pub fn read(&mut self, true_value: f64, noise: &mut Noise) -> f64 {
        let mut value = self.spec.gain * true_value + self.spec.bias;
        if self.spec.noise > 0.0 {
            value += self.spec.noise * noise.gaussian();
        }
        if self.spec.resolution > 0.0 {
            value = (value / self.spec.resolution).round() * self.spec.resolution;
        }
        if self.delay_fraction > 0.0 {
            return self.interpolated(value);
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

    /// A reading delayed by `delay_periods + delay_fraction` periods: the readings `n` and
    /// `n + 1` periods old, weighted; the first reading stands in for those before it.
    fn interpolated(&mut self, value: f64) -> f64 {
        self.history.push_back(value);
        let n = self.delay_periods;
        while self.history.len() > n + 2 {
            self.history.pop_front();
        }
        let len = self.history.len();
        let aged = |periods: usize| self.history[len.saturating_sub(periods + 1)];
        (1.0 - self.delay_fraction) * aged(n) + self.delay_fraction * aged(n + 1)
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
    fn gain_and_bias_scale_and_offset_the_reading() {
        let spec = SensorSpec {
            gain: 1.5,
            bias: -0.25,
            ..Default::default()
        };
        let mut sensor = Sensor::new(spec, 1e-3);
        assert_eq!(sensor.read(2.0, &mut Noise::new(1)), 2.75);
    }

    #[test]
    fn a_fractional_delay_interpolates_between_periods() {
        let spec = SensorSpec {
            delay: 1.25e-3,
            ..Default::default()
        };
        let mut sensor = Sensor::new(spec, 1e-3);
        let mut noise = Noise::new(1);
        let readings: Vec<f64> = (1..=5).map(|v| sensor.read(v as f64, &mut noise)).collect();
        // 1.25 periods late: 0.75 of the reading one period old plus 0.25 of the one two old.
        assert_eq!(readings, [1.0, 1.0, 1.75, 2.75, 3.75]);
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
