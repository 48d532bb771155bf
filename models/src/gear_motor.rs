//! A DC gear motor behind a torque-commanded current amplifier: the drive of the platform's
//! wheels, and of a generic machine's joint with `kind = "gear-motor"`.
//!
//! The controller asks for a joint torque τ*. The amplifier turns it into a current demand
//! `i* = τ*/(N·k_t)`, clipped to its current limit and to what the supply can push against the
//! back-EMF, `(±U − k_e·N·ω)/R`; the winding follows with its electrical time constant `L/R`
//! (first order, solved exactly over a step). The joint receives `N·k_t·i`, the current reached
//! at the step's end (the gearbox is taken as lossless, `k_e = k_t` in SI units). The rotor's
//! inertia and the gearbox's friction are not part of the drive: they belong to what it turns.

use crate::data_sheet::{all_positive, NotPositive};
use serde::Deserialize;

/// The motor's, gearbox's and amplifier's data (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearMotorParams {
    /// N: motor turns per joint turn.
    pub gear_ratio: f64,
    /// k_t, N·m/A (= k_e, V·s/rad).
    pub torque_constant: f64,
    /// R, Ω.
    pub resistance: f64,
    /// L, H.
    pub inductance: f64,
    /// U, V.
    pub supply_voltage: f64,
    /// The amplifier's current limit, A.
    pub current_limit: f64,
}

impl GearMotorParams {
    /// Checks every field is finite and positive.
    pub fn validate(&self) -> Result<(), NotPositive> {
        all_positive(&[
            ("gear_ratio", self.gear_ratio),
            ("torque_constant", self.torque_constant),
            ("resistance", self.resistance),
            ("inductance", self.inductance),
            ("supply_voltage", self.supply_voltage),
            ("current_limit", self.current_limit),
        ])
    }
}

/// A running gear motor: its winding current.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearMotor {
    params: GearMotorParams,
    current: f64,
    /// Whether the last demand was clipped.
    limited: bool,
}

impl GearMotor {
    /// Checks the data; the motor starts with no current.
    pub fn new(params: GearMotorParams) -> Result<Self, NotPositive> {
        params.validate()?;
        Ok(Self {
            params,
            current: 0.0,
            limited: false,
        })
    }

    /// The data the motor was built from.
    pub fn params(&self) -> &GearMotorParams {
        &self.params
    }

    /// Winding current, A.
    pub fn current(&self) -> f64 {
        self.current
    }

    /// Whether the last demand was clipped (current limit or supply).
    pub fn at_limit(&self) -> bool {
        self.limited
    }

    /// Advances the current by `dt` (s) towards the demand for the joint torque `torque` (N·m)
    /// with the joint turning at `speed` (rad/s); returns the joint torque at the step's end,
    /// N·m.
    pub fn step(&mut self, dt: f64, torque: f64, speed: f64) -> f64 {
        let p = &self.params;
        let back_emf = p.torque_constant * p.gear_ratio * speed;
        let upper = ((p.supply_voltage - back_emf) / p.resistance).min(p.current_limit);
        let lower = ((-p.supply_voltage - back_emf) / p.resistance).max(-p.current_limit);
        let wanted = torque / (p.gear_ratio * p.torque_constant);
        let demand = wanted.clamp(lower, upper.max(lower));
        self.limited = demand != wanted;
        let decay = (-dt * p.resistance / p.inductance).exp();
        self.current = demand + (self.current - demand) * decay;
        p.gear_ratio * p.torque_constant * self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 12 V gear motor of a small lab robot.
    fn params() -> GearMotorParams {
        GearMotorParams {
            gear_ratio: 30.0,
            torque_constant: 0.02,
            resistance: 2.0,
            inductance: 1e-3,
            supply_voltage: 12.0,
            current_limit: 2.0,
        }
    }

    #[test]
    fn follows_the_demand_with_the_electrical_lag_and_limits() {
        let params = params();
        let mut motor = GearMotor::new(params).unwrap();
        let tau = params.inductance / params.resistance;
        let torque = motor.step(tau, 0.3, 0.0);
        assert!((torque - 0.3 * (1.0 - (-1.0f64).exp())).abs() < 1e-12);
        assert!(!motor.at_limit());
        for _ in 0..100 {
            motor.step(tau, 5.0, 0.0);
        }
        assert!((motor.current() - params.current_limit).abs() < 1e-9);
        assert!(motor.at_limit());
        // Near the no-load speed the supply cannot push the current.
        let no_load = params.supply_voltage / (params.torque_constant * params.gear_ratio);
        for _ in 0..100 {
            motor.step(tau, 5.0, no_load);
        }
        assert!(motor.current().abs() < 1e-9);
    }

    #[test]
    fn refuses_data_that_are_not_positive() {
        let bad = GearMotorParams {
            inductance: 0.0,
            ..params()
        };
        let error = GearMotor::new(bad).unwrap_err();
        assert_eq!(
            error.to_string(),
            "inductance must be finite and > 0, got 0"
        );
    }
}
