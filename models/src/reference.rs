//! Reference signals a scenario gives the controller: position, rate and acceleration at a time.

use serde::Deserialize;

/// A reference trajectory r(t) with its first two derivatives, in the controlled coordinate's
/// SI unit (m or rad).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Reference {
    /// r = value.
    Constant {
        /// The position held, m or rad.
        value: f64,
    },
    /// r = offset + amplitude·sin(angular_frequency·t + phase).
    Sine {
        /// Centre of the oscillation, m or rad; 0 when omitted.
        #[serde(default)]
        offset: f64,
        /// Peak deviation from the offset, m or rad.
        amplitude: f64,
        /// rad/s.
        angular_frequency: f64,
        /// Phase at t = 0, rad; 0 when omitted.
        #[serde(default)]
        phase: f64,
    },
}

/// One sample of a reference.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReferenceSample {
    /// r(t), m or rad.
    pub position: f64,
    /// dr/dt, m/s or rad/s.
    pub rate: f64,
    /// d²r/dt², m/s² or rad/s².
    pub acceleration: f64,
}

impl Reference {
    /// The reference and its first two derivatives at `time`, s.
    pub fn sample(&self, time: f64) -> ReferenceSample {
        match *self {
            Reference::Constant { value } => ReferenceSample {
                position: value,
                ..Default::default()
            },
            Reference::Sine {
                offset,
                amplitude,
                angular_frequency: w,
                phase,
            } => {
                let (s, c) = (w * time + phase).sin_cos();
                ReferenceSample {
                    position: offset + amplitude * s,
                    rate: amplitude * w * c,
                    acceleration: -amplitude * w * w * s,
                }
            }
        }
    }

    /// Checks the values are usable; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let finite = |name: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(format!("reference {name} must be finite"))
            }
        };
        match *self {
            Reference::Constant { value } => finite("value", value),
            Reference::Sine {
                offset,
                amplitude,
                angular_frequency,
                phase,
            } => {
                finite("offset", offset)?;
                finite("amplitude", amplitude)?;
                finite("phase", phase)?;
                finite("angular_frequency", angular_frequency)?;
                if angular_frequency <= 0.0 {
                    return Err("reference angular_frequency must be > 0".into());
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sine_derivatives_match_finite_differences() {
        let r = Reference::Sine {
            offset: -0.2,
            amplitude: -0.2,
            angular_frequency: std::f64::consts::PI,
            phase: 0.0,
        };
        let (t, h) = (0.37, 1e-5);
        let (a, b, c) = (r.sample(t - h), r.sample(t), r.sample(t + h));
        assert!(((c.position - a.position) / (2.0 * h) - b.rate).abs() < 1e-8);
        assert!(((c.rate - a.rate) / (2.0 * h) - b.acceleration).abs() < 1e-6);
        assert_eq!(r.sample(0.0).position, -0.2);
    }

    #[test]
    fn bad_sine_is_rejected() {
        let r = Reference::Sine {
            offset: 0.0,
            amplitude: 1.0,
            angular_frequency: 0.0,
            phase: 0.0,
        };
        assert!(r.validate().unwrap_err().contains("angular_frequency"));
    }
}
