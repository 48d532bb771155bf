//! A DC gear motor behind a current-controlled amplifier, as the drive of one wheel.
//!
//! The controller asks for a wheel torque τ*. The amplifier turns it into a current demand
//! `i* = τ*/(N·k_t)`, clipped to its current limit and to what the supply can push against the
//! back-EMF, `(±U − k_e·N·ω)/R`; the winding follows with its electrical time constant `L/R`
//! (first-order, integrated exactly over a step). The wheel receives `N·k_t·i` (the gearbox is
//! taken as lossless; its viscous friction `gear_damping` acts on the wheel spin). `k_e = k_t` in
//! SI units.

use serde::Deserialize;

/// Motor, gearbox and amplifier data (SI). Defaults: a 12 V gear motor of a small lab robot.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotorParams {
    /// N: motor turns per wheel turn.
    pub gear_ratio: f64,
    /// k_t, N·m/A (= k_e, V·s/rad).
    pub torque_constant: f64,
    /// R, Ω.
    pub resistance: f64,
    /// L, H.
    pub inductance: f64,
    /// U, V.
    pub supply_voltage: f64,
    /// Amplifier current limit, A.
    pub current_limit: f64,
    /// Rotor inertia, kg·m² (seen at the wheel as N²·J).
    pub rotor_inertia: f64,
    /// Viscous friction of the gearbox at the wheel, N·m·s/rad.
    pub gear_damping: f64,
}

impl Default for MotorParams {
    fn default() -> Self {
        Self {
            gear_ratio: 30.0,
            torque_constant: 0.02,
            resistance: 2.0,
            inductance: 1e-3,
            supply_voltage: 12.0,
            current_limit: 2.0,
            rotor_inertia: 1.2e-6,
            gear_damping: 2e-3,
        }
    }
}

impl MotorParams {
    pub fn validate(&self) -> Result<(), String> {
        for (name, value) in [
            ("gear_ratio", self.gear_ratio),
            ("torque_constant", self.torque_constant),
            ("resistance", self.resistance),
            ("inductance", self.inductance),
            ("supply_voltage", self.supply_voltage),
            ("current_limit", self.current_limit),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(format!("motor.{name} must be > 0, got {value}"));
            }
        }
        for (name, value) in [
            ("rotor_inertia", self.rotor_inertia),
            ("gear_damping", self.gear_damping),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!("motor.{name} must be ≥ 0, got {value}"));
            }
        }
        Ok(())
    }

    /// Rotor inertia reflected to the wheel, kg·m².
    pub fn reflected_inertia(&self) -> f64 {
        self.gear_ratio * self.gear_ratio * self.rotor_inertia
    }
}

/// One motor's state: its winding current.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Motor {
    pub current: f64,
}

impl Motor {
    /// Advances the current by `dt` towards the demand for wheel torque `torque` at wheel spin
    /// `spin` (rad/s); returns the torque at the wheel, N·m.
    pub fn step(&mut self, params: &MotorParams, dt: f64, torque: f64, spin: f64) -> f64 {
        let p = params;
        let back_emf = p.torque_constant * p.gear_ratio * spin;
        let upper = ((p.supply_voltage - back_emf) / p.resistance).min(p.current_limit);
        let lower = ((-p.supply_voltage - back_emf) / p.resistance).max(-p.current_limit);
        let demand = (torque / (p.gear_ratio * p.torque_constant)).clamp(lower, upper.max(lower));
        let decay = (-dt * p.resistance / p.inductance).exp();
        self.current = demand + (self.current - demand) * decay;
        p.gear_ratio * p.torque_constant * self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follows_the_demand_with_the_electrical_lag_and_limits() {
        let params = MotorParams::default();
        let mut motor = Motor::default();
        let tau = params.inductance / params.resistance;
        let torque = motor.step(&params, tau, 0.3, 0.0);
        let full = 0.3;
        assert!((torque - full * (1.0 - (-1.0f64).exp())).abs() < 1e-12);
        for _ in 0..100 {
            motor.step(&params, tau, 5.0, 0.0);
        }
        assert!((motor.current - params.current_limit).abs() < 1e-9);
        // Near the no-load speed the supply cannot push the current.
        let no_load = params.supply_voltage / (params.torque_constant * params.gear_ratio);
        for _ in 0..100 {
            motor.step(&params, tau, 5.0, no_load);
        }
        assert!(motor.current.abs() < 1e-9);
    }
}
