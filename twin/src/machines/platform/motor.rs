//! The platform's `[process.motor]`: the DC gear motor driving each wheel
//! ([`models::gear_motor`], the drive a generic machine's joint takes with `kind =
//! "gear-motor"`), with what it adds to the wheel it turns: the rotor's inertia, seen at the wheel
//! as `N²·J`, and the gearbox's viscous friction on the wheel's spin.

use models::gear_motor::GearMotorParams;
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
    /// The drive's own data: the motor, gearbox and amplifier.
    pub fn gear_motor(&self) -> GearMotorParams {
        GearMotorParams {
            gear_ratio: self.gear_ratio,
            torque_constant: self.torque_constant,
            resistance: self.resistance,
            inductance: self.inductance,
            supply_voltage: self.supply_voltage,
            current_limit: self.current_limit,
        }
    }

    pub fn validate(&self) -> Result<(), String> {
        (self.gear_motor().validate()).map_err(|e| format!("motor.{e}"))?;
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
