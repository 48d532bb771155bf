//! The milling spindle unit: a direct-drive motor with its own speed loop (as on machining robots,
//! where the spindle has its own converter and the robot controller only reads its current).
//!
//! Speed PI on the spindle's inertia `J` (the cutter link's, from the URDF), both poles at
//! `−ω_s`: `K_p = 2ω_s·J`, `K_i = ω_s²·J` (torque per rad/s and per rad), the torque command
//! divided by `k_t` as the current command of its [`Drive`]; the integrator stops while the
//! command exceeds the drive's current limit.

use models::drive::{Drive, DriveParams};
use serde::Deserialize;

/// `[process.spindle]`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpindleParams {
    /// Spindle speed to hold, rad/s, counter-clockwise positive.
    pub speed: f64,
    /// Bandwidth ω_s of the speed loop, rad/s.
    pub speed_bandwidth: f64,
    pub drive: DriveParams,
}

impl Default for SpindleParams {
    /// 6,000 rpm counter-clockwise (up milling with the stock on the right of travel); a 1 kW
    /// direct-drive spindle motor on a 48 V converter, 0.06 N·m/A,
    /// 1.2 N·m peak (a full-width slot at 20 mm/s takes 1.1 N·m).
    fn default() -> Self {
        Self {
            speed: 200.0 * std::f64::consts::PI,
            speed_bandwidth: 60.0,
            drive: DriveParams {
                torque_constant: 0.06,
                back_emf_constant: 0.06,
                resistance: 0.15,
                inductance: 0.2e-3,
                gear_ratio: 1.0,
                supply_voltage: 48.0,
                current_limit: 20.0,
                current_bandwidth: 2000.0,
                current_loop_period: 1e-4,
            },
        }
    }
}

pub struct Spindle {
    speed: f64,
    kp: f64,
    ki: f64,
    integral: f64,
    pub drive: Drive,
}

impl Spindle {
    /// The unit for a rotor of inertia `inertia` (kg·m²).
    pub fn new(params: SpindleParams, inertia: f64) -> Result<Self, String> {
        if !params.speed.is_finite() {
            return Err("spindle.speed must be finite".into());
        }
        if !(params.speed_bandwidth > 0.0 && params.speed_bandwidth.is_finite()) {
            return Err("spindle.speed_bandwidth must be finite and > 0".into());
        }
        let drive = Drive::new(params.drive).map_err(|e| format!("spindle.{e}"))?;
        let w = params.speed_bandwidth;
        Ok(Self {
            speed: params.speed,
            kp: 2.0 * w * inertia,
            ki: w * w * inertia,
            integral: 0.0,
            drive,
        })
    }

    /// The speed it holds, rad/s.
    pub fn set_speed(&self) -> f64 {
        self.speed
    }

    /// One physics step at spindle speed `speed` (rad/s); returns the motor torque, N·m.
    pub fn step(&mut self, dt: f64, speed: f64) -> f64 {
        let error = self.speed - speed;
        let candidate = self.integral + error * dt;
        let torque_per_ampere = self.drive.params().torque_per_ampere();
        let limit = self.drive.params().current_limit;
        if ((self.kp * error + self.ki * candidate) / torque_per_ampere).abs() <= limit {
            self.integral = candidate;
        }
        let command = (self.kp * error + self.ki * self.integral) / torque_per_ampere;
        self.drive.step(dt, command, speed)
    }
}
