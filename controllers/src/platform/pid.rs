//! `pid`: the reference method of Kalinski et al. 2013, §4 — two PID loops, one on the linear
//! velocity error, one on the angular velocity error of the platform, with the same correcting
//! velocities of H (Kaliński eq (19)) and inverse kinematics as `energy-optimal`.
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

use super::guidance::{wheel_actuators, Guide};
use super::model::PlatformModel;
use crate::check::{non_negative, positive};
use crate::filters::{FilterParameter, FirstOrderFilter};
use framework::{parse_params, Entry};
use framework::{Controller, ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

const NAME: &str = "pid";

/// Parameters of `pid` (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct PlatformPidParams {
    /// The controller's model of the platform: wheels, track, point H, mass and inertias.
    pub model: PlatformModel,
    /// k of Kaliński eq (19).
    pub k: f64,
    /// Δt of Kaliński eq (19), s.
    pub sampling_interval: f64,
    /// Linear-velocity loop, proportional gain on v* − v: N per m/s.
    pub kp_v: f64,
    /// Linear-velocity loop, integral gain: N per m.
    pub ki_v: f64,
    /// Linear-velocity loop, derivative gain: N per m/s².
    pub kd_v: f64,
    /// Angular-velocity loop, proportional gain on ω* − ω: N·m per rad/s.
    pub kp_w: f64,
    /// Angular-velocity loop, integral gain: N·m per rad.
    pub ki_w: f64,
    /// Angular-velocity loop, derivative gain: N·m per rad/s².
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
    /// Proportional gain: N per m/s on the linear loop, N·m per rad/s on the angular one.
    pub kp: f64,
    /// Integral gain: N per m, or N·m per rad.
    pub ki: f64,
    /// Derivative gain: N per m/s², or N·m per rad/s².
    pub kd: f64,
}

/// Checks the parameters and returns the (linear, angular) loop gains.
pub fn design(params: &PlatformPidParams) -> Result<[PidGains; 2], ControllerError> {
    params.model.validate(NAME)?;
    for (key, value) in [
        ("k", params.k),
        ("sampling_interval", params.sampling_interval),
        ("derivative_time_constant", params.derivative_time_constant),
        ("torque_limit", params.torque_limit),
    ] {
        positive(NAME, key, value)?;
    }
    let gain = |key: &str, value: f64| non_negative(NAME, key, value);
    Ok([
        PidGains {
            kp: gain("kp_v", params.kp_v)?,
            ki: gain("ki_v", params.ki_v)?,
            kd: gain("kd_v", params.kd_v)?,
        },
        PidGains {
            kp: gain("kp_w", params.kp_w)?,
            ki: gain("ki_w", params.ki_w)?,
            kd: gain("kd_w", params.kd_w)?,
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
    /// Checks the gains and builds the derivative filters and the guide; errors name the
    /// parameter at fault.
    pub fn new(params: PlatformPidParams) -> Result<Self, ControllerError> {
        let gains = design(&params)?;
        let derivative = FirstOrderFilter::derivative(params.derivative_time_constant)
            .map_err(|e| e.for_parameter(NAME, "derivative_time_constant"))?;
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
        name: NAME,
        machine: "platform",
        summary: "two PID loops on linear and angular velocity errors (the platform's reference)",
        build: |table| Ok(Box::new(PlatformPid::new(parse_params(NAME, table)?)?)),
    }
}

impl Controller for PlatformPid {
    fn name(&self) -> &str {
        NAME
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
        let build = |text: &str| {
            framework::Registry::with([super::entry()])
                .build(NAME, "platform", &text.parse::<toml::Table>().unwrap())
                .err()
                .unwrap()
        };
        for (text, key, value, reason) in [
            ("kp_v = -1.0", "kp_v", "-1", "must be ≥ 0"),
            ("kd_w = -0.5", "kd_w", "-0.5", "must be ≥ 0"),
            ("k = 0.0", "k", "0", "must be > 0"),
            (
                "derivative_time_constant = 0.0",
                "derivative_time_constant",
                "0",
                "must be > 0",
            ),
            (
                "model = { wheel_inertia = -1e-3 }",
                "model.wheel_inertia",
                "-0.001",
                "must be ≥ 0",
            ),
        ] {
            assert_eq!(
                build(text),
                ControllerError::BadParameter {
                    controller: NAME.into(),
                    key: key.into(),
                    value: Some(value.into()),
                    reason: reason.into(),
                },
                "{text}"
            );
        }
        assert_eq!(
            build("kp_v = -1").to_string(),
            "controller `pid`: params.kp_v = -1: must be ≥ 0"
        );
        assert_eq!(
            build("model = { point_h = 0 }").to_string(),
            "controller `pid`: params.model.point_h = 0: must be > 0"
        );
    }

    #[test]
    fn defaults_design() {
        let gains = design(&PlatformPidParams::default()).unwrap();
        assert_eq!(gains[0].kp, 60.0);
    }
}
