//! The spindle-speed loop shared by the milling controllers (`spindle-constant`,
//! `spindle-programme`, `spindle-optimal-linear`): they differ only in the speed they ask for.
//!
//! Design: the spindle is taken as an inertia `J` driven by the torque, `J·ω̇ = τ − τ_cut`. The
//! law `τ = J·ω̇_ref + kp·e + ki·∫e` feeds the reference's acceleration forward (a programme's
//! ramps are followed without lag) and places both poles of the error at
//! `s² + 2ζω_n s + ω_n² = 0`: `kp = 2ζω_n·J`, `ki = ω_n²·J`. The cutting torque is a disturbance
//! the integrator removes; its tooth-frequency ripple lies far above the loop's bandwidth.

use crate::check::{finite, positive};
use framework::{ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use serde::Deserialize;

/// Parameters of the spindle-speed loop (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SpeedLoopParams {
    /// The driven spindle joint.
    pub joint: String,
    /// Rotor inertia the design assumes, kg·m².
    pub inertia: f64,
    /// Closed-loop natural frequency, rad/s.
    pub natural_frequency: f64,
    /// Closed-loop damping ratio.
    pub damping_ratio: f64,
}

impl Default for SpeedLoopParams {
    fn default() -> Self {
        Self {
            joint: "spindle".into(),
            inertia: 1.6e-3,
            natural_frequency: 100.0,
            damping_ratio: 1.0,
        }
    }
}

/// Gains produced by [`design`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedGains {
    /// Feed-forward inertia, kg·m².
    pub inertia: f64,
    /// N·m per rad/s.
    pub kp: f64,
    /// N·m per rad.
    pub ki: f64,
}

/// Pole placement for `J·ω̇ = τ` under PI control with acceleration feed-forward; `params` is
/// the `speed_loop` table of `controller`'s parameters.
pub fn design(controller: &str, params: &SpeedLoopParams) -> Result<SpeedGains, ControllerError> {
    let inertia = positive(controller, "speed_loop.inertia", params.inertia)?;
    let wn = positive(
        controller,
        "speed_loop.natural_frequency",
        params.natural_frequency,
    )?;
    let zeta = positive(controller, "speed_loop.damping_ratio", params.damping_ratio)?;
    let gains = SpeedGains {
        inertia,
        kp: 2.0 * zeta * wn * inertia,
        ki: wn * wn * inertia,
    };
    if !(gains.kp.is_finite() && gains.ki.is_finite()) {
        return Err(ControllerError::parameter(
            controller,
            "speed_loop.natural_frequency",
            wn,
            "must be small enough that the gains ω_n²·inertia and 2·damping_ratio·ω_n·inertia \
             do not overflow",
        ));
    }
    Ok(gains)
}

/// Checks n0 (`nominal_speed`, > 0) and n_max (`maximum_speed`, > n0) of `controller`: the
/// speeds of a programme between n0 and n_max.
pub(crate) fn check_speeds(
    controller: &str,
    nominal: f64,
    maximum: f64,
) -> Result<(), ControllerError> {
    positive(controller, "nominal_speed", nominal)?;
    if finite(controller, "maximum_speed", maximum)? <= nominal {
        return Err(ControllerError::parameter(
            controller,
            "maximum_speed",
            maximum,
            format!("must be > nominal_speed = {nominal}"),
        ));
    }
    Ok(())
}

/// The internals a spindle-speed controller records: the speed it commands (on the spindle
/// speed's plot), the loop's error and its torque.
pub fn internals() -> Vec<SignalSpec> {
    vec![
        SignalSpec::new("speed_command", Unit::Rpm, "spindle speed"),
        SignalSpec::new("speed_error", Unit::Rpm, "spindle speed error"),
        SignalSpec::new("torque", Unit::NewtonMetre, "spindle torque"),
    ]
}

/// The running loop: integrator frozen while the torque is clipped (anti-windup).
#[derive(Debug, Clone)]
pub struct SpeedLoop {
    gains: SpeedGains,
    joint: String,
    speed_signal: usize,
    angle_signal: usize,
    actuator: usize,
    effort_limit: f64,
    integral: f64,
    /// Last speed error, rad/s (an internal).
    pub speed_error: f64,
    /// Last torque command, within the actuator's limit, N·m (an internal).
    pub torque: f64,
}

impl SpeedLoop {
    /// Designs the loop from `params`, the `speed_loop` table of `controller`'s parameters.
    pub fn new(controller: &str, params: &SpeedLoopParams) -> Result<Self, ControllerError> {
        Ok(Self {
            gains: design(controller, params)?,
            joint: params.joint.clone(),
            speed_signal: 0,
            angle_signal: 0,
            actuator: 0,
            effort_limit: f64::INFINITY,
            integral: 0.0,
            speed_error: 0.0,
            torque: 0.0,
        })
    }

    /// Binds to the plant (the joint's speed and angle, its actuator and effort limit) and clears
    /// the integral.
    pub fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.speed_signal = plant.signal(&format!("{}.velocity", self.joint))?;
        self.angle_signal = plant.signal(&format!("{}.position", self.joint))?;
        self.actuator = plant.actuator(&self.joint)?;
        self.effort_limit = plant.actuators[self.actuator].effort_limit;
        (self.integral, self.speed_error, self.torque) = (0.0, 0.0, 0.0);
        Ok(())
    }

    /// Measured spindle speed, rad/s.
    pub fn speed(&self, measurement: &Measurement) -> f64 {
        measurement.get(self.speed_signal)
    }

    /// Measured spindle angle, rad.
    pub fn angle(&self, measurement: &Measurement) -> f64 {
        measurement.get(self.angle_signal)
    }

    /// Drives the spindle towards `speed` (rad/s) changing at `acceleration` (rad/s²).
    pub fn update(
        &mut self,
        measurement: &Measurement,
        (speed, acceleration): (f64, f64),
        period: f64,
        efforts: &mut [f64],
    ) {
        let g = self.gains;
        self.speed_error = speed - self.speed(measurement);
        let candidate = self.integral + self.speed_error * period;
        let law =
            |integral: f64| g.inertia * acceleration + g.kp * self.speed_error + g.ki * integral;
        if law(candidate).abs() <= self.effort_limit {
            self.integral = candidate;
        }
        self.torque = law(self.integral).clamp(-self.effort_limit, self.effort_limit);
        efforts[self.actuator] = self.torque;
    }
}
