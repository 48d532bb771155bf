//! `pid`: the reference method of Kalinski et al. 2013, §4 — two PID loops, one on the linear
//! velocity error, one on the angular velocity error of the platform, with the same correcting
//! velocities of H (eq 19) and inverse kinematics as `energy-optimal`.
//!
//! `F = PID_v(v* − v)` (N) and `T = PID_ω(ω* − ω)` (N·m) are shared out to the wheels as
//! `τ_L = r/2·F − r/(2b)·T`, `τ_R = r/2·F + r/(2b)·T`; the derivative is filtered
//! (`derivative_time_constant`) and the integrators freeze while a torque is clipped.
//!
//! The default gains are the best of the grid search in `tests/tests/platform.rs`
//! (`pid_grid_search`, run with `--ignored`) on the `platform-path` scenario, smallest RMS path
//! error of H: kp_v ∈ {60, 120, 240} N·s/m × kp_w ∈ {1, 2, 4} N·m·s × integral time
//! T_i ∈ {∞, 0.5, 0.1} s (ki = kp/T_i), no derivative. Best: kp_v = 60, kp_w = 4, T_i = 0.1 s
//! (0.4163 mm); all 27 lie within 0.416–0.456 mm, those with integral action within 0.4163–0.4169
//! mm: the path error of the true H is set by the odometry's drift, which no gain removes.

use crate::filters::FirstOrderFilter;
use crate::platform_guidance::{wheel_actuators, Guide};
use crate::platform_model::PlatformModel;
use crate::registry::{parse_params, Entry};
use crate::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

/// Parameters of `pid` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PlatformPidParams {
    pub model: PlatformModel,
    /// k of eq (19).
    pub k: f64,
    /// Δt of eq (19), s.
    pub sampling_interval: f64,
    /// Linear-velocity loop: N per m/s, N per m, N per m/s².
    pub kp_v: f64,
    pub ki_v: f64,
    pub kd_v: f64,
    /// Angular-velocity loop: N·m per rad/s, N·m per rad, N·m per rad/s².
    pub kp_w: f64,
    pub ki_w: f64,
    pub kd_w: f64,
    /// Time constant of the derivatives' low-pass, s.
    pub derivative_time_constant: f64,
    /// Largest wheel torque, N·m (the drive's effort limit applies too).
    pub torque_limit: f64,
}

impl Default for PlatformPidParams {
    fn default() -> Self {
        Self {
            model: PlatformModel::default(),
            k: 60.0,
            sampling_interval: 0.005,
            kp_v: 60.0,
            ki_v: 600.0,
            kd_v: 0.0,
            kp_w: 4.0,
            ki_w: 40.0,
            kd_w: 0.0,
            derivative_time_constant: 0.02,
            torque_limit: 1.0,
        }
    }
}

/// One loop's gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
}

/// Checks the parameters and returns the (linear, angular) loop gains.
pub fn design(params: &PlatformPidParams) -> Result<[PidGains; 2], ControllerError> {
    let bad = |reason: String| ControllerError::BadParameters {
        controller: "pid".into(),
        reason,
    };
    params.model.validate().map_err(bad)?;
    for (name, value) in [
        ("k", params.k),
        ("sampling_interval", params.sampling_interval),
        ("derivative_time_constant", params.derivative_time_constant),
        ("torque_limit", params.torque_limit),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(bad(format!("{name} must be > 0, got {value}")));
        }
    }
    for (name, value) in [
        ("kp_v", params.kp_v),
        ("ki_v", params.ki_v),
        ("kd_v", params.kd_v),
        ("kp_w", params.kp_w),
        ("ki_w", params.ki_w),
        ("kd_w", params.kd_w),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(bad(format!("{name} must be ≥ 0, got {value}")));
        }
    }
    Ok([
        PidGains {
            kp: params.kp_v,
            ki: params.ki_v,
            kd: params.kd_v,
        },
        PidGains {
            kp: params.kp_w,
            ki: params.ki_w,
            kd: params.kd_w,
        },
    ])
}

/// The running law.
pub struct PlatformPid {
    params: PlatformPidParams,
    gains: [PidGains; 2],
    guide: Guide,
    derivatives: [FirstOrderFilter; 2],
    actuators: [usize; 2],
    limit: f64,
    /// (v, ω) errors and their integrals.
    error: [f64; 2],
    integral: [f64; 2],
    torque: [f64; 2],
}

impl PlatformPid {
    pub fn new(params: PlatformPidParams) -> Result<Self, ControllerError> {
        let gains = design(&params)?;
        let derivative =
            FirstOrderFilter::derivative(params.derivative_time_constant).map_err(|e| {
                ControllerError::BadParameters {
                    controller: "pid".into(),
                    reason: e.to_string(),
                }
            })?;
        let guide = Guide::new(params.model, params.k * params.sampling_interval);
        Ok(Self {
            params,
            gains,
            guide,
            derivatives: [derivative.clone(), derivative],
            actuators: [0, 1],
            limit: f64::INFINITY,
            error: [0.0; 2],
            integral: [0.0; 2],
            torque: [0.0; 2],
        })
    }
}

pub(crate) fn entry() -> Entry {
    Entry {
        name: "pid",
        machine: "platform",
        summary: "two PID loops on linear and angular velocity errors (the platform's reference)",
        build: |table| Ok(Box::new(PlatformPid::new(parse_params("pid", table)?)?)),
    }
}

impl Controller for PlatformPid {
    fn name(&self) -> &str {
        "pid"
    }

    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.guide.reset(plant)?;
        (self.actuators, self.limit) = wheel_actuators(plant, self.params.torque_limit)?;
        self.derivatives
            .iter_mut()
            .for_each(FirstOrderFilter::reset);
        self.error = [0.0; 2];
        self.integral = [0.0; 2];
        self.torque = [0.0; 2];
        Ok(())
    }

    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]) {
        let guidance = self.guide.update(measurement, period);
        let model = *self.guide.model();
        let wanted = model.body_rates(guidance.wheel_rates_wanted);
        let actual = model.body_rates(guidance.wheel_rates);
        let mut candidate = self.integral;
        let mut output = [0.0; 2];
        for i in 0..2 {
            self.error[i] = wanted[i] - actual[i];
            candidate[i] += self.error[i] * period;
            let rate = self.derivatives[i].update(self.error[i], period);
            let g = self.gains[i];
            output[i] = g.kp * self.error[i] + g.ki * candidate[i] + g.kd * rate;
        }
        let (r, b) = (model.wheel_radius, model.half_track);
        let share = |[force, torque]: [f64; 2]| {
            [
                r / 2.0 * force - r / (2.0 * b) * torque,
                r / 2.0 * force + r / (2.0 * b) * torque,
            ]
        };
        let torque = share(output);
        if torque.iter().all(|t| t.abs() <= self.limit) {
            self.integral = candidate;
        }
        self.torque = torque.map(|t| t.clamp(-self.limit, self.limit));
        efforts[self.actuators[0]] = self.torque[0];
        efforts[self.actuators[1]] = self.torque[1];
    }

    fn internals(&self) -> Vec<SignalSpec> {
        let mut specs = Guide::internals();
        specs.extend([
            SignalSpec::new("speed_error", Unit::MillimetrePerSecond, "speed error"),
            SignalSpec::new("yaw_rate_error", Unit::Rpm, "yaw rate error"),
            SignalSpec::new("torque.left", Unit::NewtonMetre, "wheel torque commands"),
            SignalSpec::new("torque.right", Unit::NewtonMetre, "wheel torque commands"),
        ]);
        specs
    }

    fn internal_values(&self, values: &mut [f64]) {
        values[..6].copy_from_slice(&self.guide.values());
        values[6..].copy_from_slice(&[
            self.error[0],
            self.error[1],
            self.torque[0],
            self.torque[1],
        ]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_parameters() {
        for (key, value) in [
            ("kp_v", -1.0),
            ("k", 0.0),
            ("derivative_time_constant", 0.0),
        ] {
            let mut table = toml::Table::new();
            table.insert(key.into(), toml::Value::Float(value));
            let err = crate::Registry::builtin()
                .build("pid", &table)
                .err()
                .unwrap();
            assert!(err.to_string().contains(key), "{err}");
        }
    }

    #[test]
    fn defaults_design() {
        let gains = design(&PlatformPidParams::default()).unwrap();
        assert_eq!(gains[0].kp, 60.0);
    }
}
