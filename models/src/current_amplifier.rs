//! A static current amplifier and a motor of constant force (or torque) per ampere: the drive of
//! the linear-motor feed axis (Rubio, Ibeas & Luo, Fig. 1), and of a generic machine's joint with
//! `kind = "current-amplifier"`.
//!
//! The effort command F* becomes the amplifier's input voltage `u_c = F*/(k_t·K_a)`; the amplifier
//! gives the current `i = k_t·u_c`, clipped to ±`current_limit`, and the motor gives `F = K_a·i`.
//! The amplifier is static: its own current loop is taken as far faster than the loops it
//! serves.

use crate::data_sheet::{all_positive, NotPositive};
use serde::Deserialize;

/// The amplifier's and motor's data (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmplifierParams {
    /// k_t, the amplifier's transconductance, A/V.
    pub amplifier_gain: f64,
    /// K_a, the motor's force per ampere, N/A (N·m/A on a turning joint).
    pub force_constant: f64,
    /// The amplifier's peak current, A.
    pub current_limit: f64,
}

impl AmplifierParams {
    /// Checks every field is finite and positive.
    pub fn validate(&self) -> Result<(), NotPositive> {
        all_positive(&[
            ("amplifier_gain", self.amplifier_gain),
            ("force_constant", self.force_constant),
            ("current_limit", self.current_limit),
        ])
    }
}

/// A running amplifier: the current it gave last.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurrentAmplifier {
    params: AmplifierParams,
    current: f64,
    limited: bool,
}

impl CurrentAmplifier {
    /// Checks the data; no current flows yet.
    pub fn new(params: AmplifierParams) -> Result<Self, NotPositive> {
        params.validate()?;
        Ok(Self {
            params,
            current: 0.0,
            limited: false,
        })
    }

    /// The data the amplifier was built from.
    pub fn params(&self) -> &AmplifierParams {
        &self.params
    }

    /// The current it gave last, A.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// Whether the last command was clipped at the current limit.
    pub fn at_limit(&self) -> bool {
        self.limited
    }

    /// The effort the motor gives for `command` (N or N·m), keeping the current.
    pub fn effort(&mut self, command: f64) -> f64 {
        let p = &self.params;
        let voltage = command / (p.amplifier_gain * p.force_constant);
        let current = p.amplifier_gain * voltage;
        self.current = current.clamp(-p.current_limit, p.current_limit);
        self.limited = self.current != current;
        p.force_constant * self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's amplifier and linear motor, with a 10 A peak.
    fn params() -> AmplifierParams {
        AmplifierParams {
            amplifier_gain: 2.0,
            force_constant: 50.0,
            current_limit: 10.0,
        }
    }

    #[test]
    fn passes_an_effort_within_its_current_and_clips_beyond() {
        let mut amplifier = CurrentAmplifier::new(params()).unwrap();
        assert!((amplifier.effort(100.0) - 100.0).abs() < 1e-12);
        assert!((amplifier.current() - 2.0).abs() < 1e-12);
        assert!(!amplifier.at_limit());
        assert_eq!(amplifier.effort(-800.0), -500.0);
        assert_eq!(amplifier.current(), -10.0);
        assert!(amplifier.at_limit());
    }

    #[test]
    fn refuses_data_that_are_not_positive() {
        let bad = AmplifierParams {
            current_limit: -1.0,
            ..params()
        };
        let error = CurrentAmplifier::new(bad).unwrap_err();
        assert_eq!(
            error.to_string(),
            "current_limit must be finite and > 0, got -1"
        );
    }
}
