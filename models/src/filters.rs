//! Discrete first-order filters: low-pass, lead-lag and filtered derivative, for controllers and
//! for the machines' own figures.
//!
//! Each is a continuous section `H(s) = (b₁ s + b₀)/(a₁ s + 1)` with `a₁ > 0`, discretised by the
//! bilinear (Tustin) transform `s ← (2/T)·(1 − z⁻¹)/(1 + z⁻¹)` at the period `T` passed to each
//! [`update`](FirstOrderFilter::update), so a controller whose period changes keeps the same
//! continuous filter. Tustin maps a product of sections to the product of their discretisations,
//! so cascading these filters discretises the cascaded transfer function.
//!
//! A filter primes itself on the first sample after construction or
//! [`reset`](FirstOrderFilter::reset): its state is set to the steady state for that input (output
//! `b₀·input`), so a signal that starts far from zero causes no start-up transient.

use thiserror::Error;

/// A filter time constant that cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum FilterError {
    /// A time constant (or bandwidth) that must be > 0 is zero, negative or not finite.
    #[error("filter {name} must be finite and > 0 (got {value})")]
    NotPositive {
        /// Which one, e.g. `time constant`, `bandwidth`.
        name: &'static str,
        /// The value given, s (rad/s for a bandwidth).
        value: f64,
    },
    /// A time constant that may be zero (a lead-lag's `T_a`) is negative or not finite.
    #[error("filter {name} must be finite and ≥ 0 (got {value})")]
    Negative {
        /// Which one, e.g. `lead time constant`.
        name: &'static str,
        /// The value given, s.
        value: f64,
    },
}

fn positive(name: &'static str, value: f64) -> Result<f64, FilterError> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(FilterError::NotPositive { name, value })
    }
}

/// `H(s) = (b₁ s + b₀)/(a₁ s + 1)` in Tustin form.
#[derive(Debug, Clone, PartialEq)]
pub struct FirstOrderFilter {
    /// b₁, s.
    lead: f64,
    /// b₀ (the DC gain).
    dc_gain: f64,
    /// a₁, s.
    lag: f64,
    last_input: f64,
    output: f64,
    primed: bool,
}

impl FirstOrderFilter {
    fn section(lead: f64, dc_gain: f64, lag: f64) -> Self {
        Self {
            lead,
            dc_gain,
            lag,
            last_input: 0.0,
            output: 0.0,
            primed: false,
        }
    }

    /// Low-pass `1/(τ s + 1)`, τ in s.
    pub fn low_pass(time_constant: f64) -> Result<Self, FilterError> {
        Ok(Self::section(
            0.0,
            1.0,
            positive("time constant", time_constant)?,
        ))
    }

    /// Lead-lag `(T_a s + 1)/(T_b s + 1)`: a lead for `T_a > T_b`, a lag for `T_a < T_b`; T_a ≥ 0,
    /// T_b > 0, in s.
    pub fn lead_lag(lead: f64, lag: f64) -> Result<Self, FilterError> {
        if !(lead >= 0.0 && lead.is_finite()) {
            return Err(FilterError::Negative {
                name: "lead time constant",
                value: lead,
            });
        }
        Ok(Self::section(
            lead,
            1.0,
            positive("lag time constant", lag)?,
        ))
    }

    /// Filtered derivative `s/(τ s + 1)`: the rate of the input, low-passed at 1/τ rad/s.
    pub fn derivative(time_constant: f64) -> Result<Self, FilterError> {
        Ok(Self::section(
            1.0,
            0.0,
            positive("time constant", time_constant)?,
        ))
    }

    /// Forgets the past: the next sample primes the filter again.
    pub fn reset(&mut self) {
        self.primed = false;
        self.last_input = 0.0;
        self.output = 0.0;
    }

    /// Feeds one sample taken `period` (s) after the previous one and returns the new output. A
    /// period that is not positive and finite leaves the state alone and returns the last output.
    pub fn update(&mut self, input: f64, period: f64) -> f64 {
        if !self.primed {
            self.primed = true;
            self.last_input = input;
            self.output = self.dc_gain * input;
            return self.output;
        }
        if !(period > 0.0 && period.is_finite()) {
            return self.output;
        }
        let t = period;
        let (b1, b0, a1) = (self.lead, self.dc_gain, self.lag);
        self.output = ((2.0 * b1 + b0 * t) * input + (b0 * t - 2.0 * b1) * self.last_input
            - (t - 2.0 * a1) * self.output)
            / (2.0 * a1 + t);
        self.last_input = input;
        self.output
    }

    /// The last output.
    pub fn output(&self) -> f64 {
        self.output
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_pass_step_follows_the_time_constant() {
        let (tau, dt) = (0.01, 1e-4);
        let mut filter = FirstOrderFilter::low_pass(tau).unwrap();
        filter.update(0.0, dt);
        let mut output = 0.0;
        for _ in 0..100 {
            output = filter.update(1.0, dt);
        }
        // One time constant after the step: 1 − e⁻¹, to the bilinear map's accuracy.
        assert!((output - (1.0 - (-1.0f64).exp())).abs() < 5e-3, "{output}");
        for _ in 0..2000 {
            output = filter.update(1.0, dt);
        }
        assert!((output - 1.0).abs() < 1e-9);
    }

    #[test]
    fn primes_on_the_first_sample() {
        let mut low = FirstOrderFilter::low_pass(0.05).unwrap();
        let mut rate = FirstOrderFilter::derivative(0.05).unwrap();
        assert_eq!(low.update(3.5, 1e-3), 3.5);
        assert_eq!(low.update(3.5, 1e-3), 3.5);
        assert_eq!(rate.update(3.5, 1e-3), 0.0);
        assert_eq!(rate.update(3.5, 1e-3), 0.0);
        low.reset();
        assert_eq!(low.update(-1.0, 1e-3), -1.0);
    }

    #[test]
    fn derivative_of_a_ramp_and_a_slow_sine() {
        let (tau, dt) = (1e-3, 1e-4);
        let mut rate = FirstOrderFilter::derivative(tau).unwrap();
        let mut output = 0.0;
        for k in 0..500 {
            output = rate.update(2.5 * k as f64 * dt, dt);
        }
        assert!((output - 2.5).abs() < 1e-9, "{output}");
        // 3 rad/s, well below 1/τ: amplitude ω·A, lag ≈ ωτ.
        let mut rate = FirstOrderFilter::derivative(tau).unwrap();
        let (amplitude, omega) = (1e-6, 3.0);
        let mut worst: f64 = 0.0;
        for k in 0..20_000 {
            let t = k as f64 * dt;
            let estimate = rate.update(amplitude * (omega * t).sin(), dt);
            if t > 0.1 {
                let exact = amplitude * omega * (omega * t).cos();
                worst = worst.max((estimate - exact).abs());
            }
        }
        assert!(worst < 0.01 * amplitude * omega, "{worst}");
    }

    #[test]
    fn lead_lag_gains() {
        let dt = 1e-4;
        let mut filter = FirstOrderFilter::lead_lag(0.02, 0.005).unwrap();
        let mut output = 0.0;
        for _ in 0..5000 {
            output = filter.update(2.0, dt);
        }
        assert!((output - 2.0).abs() < 1e-9, "DC gain is 1: {output}");
        // At the Nyquist frequency Tustin's gain is exactly the high-frequency gain T_a/T_b.
        let mut filter = FirstOrderFilter::lead_lag(0.02, 0.005).unwrap();
        let mut sign = 1.0;
        for _ in 0..20_000 {
            output = filter.update(sign, dt);
            sign = -sign;
        }
        assert!((output.abs() - 4.0).abs() < 1e-6, "{output}");
        // T_a = 0 is a plain low-pass.
        let mut lag = FirstOrderFilter::lead_lag(0.0, 0.01).unwrap();
        let mut low = FirstOrderFilter::low_pass(0.01).unwrap();
        for k in 0..100 {
            let x = (k as f64 * 0.37).sin();
            assert_eq!(lag.update(x, dt), low.update(x, dt));
        }
    }

    #[test]
    fn cascade_is_the_product() {
        // derivative(τ) then low_pass(τ) equals derivative(τ) applied after low_pass(τ).
        let (tau, dt) = (2e-3, 1e-4);
        let (mut d1, mut l1) = (
            FirstOrderFilter::derivative(tau).unwrap(),
            FirstOrderFilter::low_pass(tau).unwrap(),
        );
        let (mut l2, mut d2) = (
            FirstOrderFilter::low_pass(tau).unwrap(),
            FirstOrderFilter::derivative(tau).unwrap(),
        );
        for k in 0..1000 {
            let x = (k as f64 * 0.01).sin() + 0.3 * (k as f64 * 0.2).cos();
            let a = l1.update(d1.update(x, dt), dt);
            let b = d2.update(l2.update(x, dt), dt);
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn bad_time_constants_and_periods() {
        assert!(FirstOrderFilter::low_pass(0.0).is_err());
        assert!(FirstOrderFilter::derivative(f64::NAN).is_err());
        assert!(FirstOrderFilter::lead_lag(-1.0, 0.1)
            .unwrap_err()
            .to_string()
            .contains("lead"));
        assert!(FirstOrderFilter::lead_lag(0.1, f64::INFINITY)
            .unwrap_err()
            .to_string()
            .contains("lag"));
        let mut filter = FirstOrderFilter::low_pass(0.01).unwrap();
        filter.update(1.0, 1e-3);
        assert_eq!(filter.update(5.0, 0.0), 1.0);
        assert_eq!(filter.update(5.0, f64::NAN), 1.0);
        assert_eq!(filter.output(), 1.0);
    }
}
