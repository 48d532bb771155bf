//! Joint servos and path following of the machining arm, shared by the path-speed controllers
//! ([`crate::path_speed_adaptive`]): the robot program of `models::arm_path` (control points → inverse
//! kinematics → cubics in the path length, Ilyukhin et al. eqs 2–4) walked at the path speed the
//! controller chooses, and one PID position servo per joint whose output is the joint drive's
//! **current command, in A** (the arm's drives take currents; see the `arm` machine).
//!
//! Design: each joint is taken as an inertia `J` driven through `G·k_t` N·m per ampere; the PID
//! `i* = K_p·e + K_i·∫e + K_d·ė` places the three closed-loop poles at `−ω` (bandwidth ω):
//! `K_d = 3ωJ/(G·k_t)`, `K_p = 3ω²J/(G·k_t)`, `K_i = ω³J/(G·k_t)`. Gravity and the cutting
//! force's reaction are disturbances the integral takes up. The command is clipped to the drive's
//! current limit, `effort_limit/(G·k_t)` (the URDF effort limit is the drive's peak torque), and
//! the integral stops while it is clipped.
//!
//! Cycle: from wherever the arm is at the first update, a quintic in joint space brings it in
//! `approach_time` to a clearance point `clearance` off the contour's first point on the side
//! away from the stock (a joint-space move may sweep anywhere, so it must end in the air); a
//! second quintic lowers it onto the first point in `settle_time`; then the path length
//! `l` advances by the path speed each period and the joints follow `q(l)` with the velocity
//! reference `dq/dl·V_K` and the acceleration reference `d²q/dl²·V_K²`. At the end of the contour
//! the arm holds the last point.

use crate::event::Event;
use crate::{ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use models::arm_path::{ArmGeometry, Contour, ContourPath, Elbow, JointPath, PathCursor};
use serde::Deserialize;

/// The arm's joints, in the order of every per-joint array.
pub const JOINTS: [&str; 3] = ["shoulder", "elbow", "wrist"];

/// The servo's recorded internals, in the order of [`ArmServo::errors`] then
/// [`ArmServo::commands`]: joint errors, and the current commands before the twin's clip.
pub fn internals() -> Vec<SignalSpec> {
    let errors = JOINTS
        .iter()
        .map(|j| SignalSpec::new(format!("{j}_error"), Unit::Degree, "joint errors"));
    let commands = JOINTS.iter().map(|j| {
        SignalSpec::new(
            format!("{j}_current_command"),
            Unit::Ampere,
            "current commands",
        )
    });
    errors.chain(commands).collect()
}

/// `[controller.params.servo]`: the robot program and the joint servos (SI units).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ServoParams {
    /// The arm's kinematic model (must describe the URDF).
    pub arm: ArmGeometry,
    pub elbow: Elbow,
    /// The part contour: the program's control points are taken along it.
    pub contour: Contour,
    /// Per joint: the inertia the design assumes, kg·m².
    pub inertia: [f64; 3],
    /// Per joint: joint torque per ampere of its drive, `G·k_t`, N·m/A.
    pub torque_per_ampere: [f64; 3],
    /// Closed-loop bandwidth ω of every joint servo, rad/s.
    pub bandwidth: f64,
    /// Duration of the move to the contour's start, s.
    pub approach_time: f64,
    /// Time to come down from the clearance point onto the contour's start, s.
    pub settle_time: f64,
    /// Distance of the clearance point from the contour's start, to the left of the direction of
    /// travel (the stock lies on the right), m.
    pub clearance: f64,
}

impl Default for ServoParams {
    /// The arm of `urdf/arm.urdf` with its drives (notes in `twin/src/machines/arm.rs`); inertias about each joint
    /// on the default contour, to the nearest round figure.
    fn default() -> Self {
        Self {
            arm: ArmGeometry::default(),
            elbow: Elbow::Up,
            contour: Contour::default(),
            inertia: [2.5, 0.8, 0.05],
            torque_per_ampere: [4.2, 3.0, 1.0],
            bandwidth: 80.0,
            approach_time: 2.0,
            settle_time: 0.5,
            clearance: 0.02,
        }
    }
}

/// PID gains of one joint, in A per rad, A per rad·s and A per rad/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGains {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
}

/// The servo design and the program built from the parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoDesign {
    pub gains: [JointGains; 3],
    pub program: JointPath,
    /// Joint angles at the clearance point above the contour's start.
    pub clearance_point: [f64; 3],
    /// Open-loop crossover of the slowest joint servo, rad/s (`|L(jω_c)| = 1`).
    pub crossover: f64,
}

/// Gains by pole placement and the program through the inverse kinematics.
pub fn design(controller: &str, params: &ServoParams) -> Result<ServoDesign, ControllerError> {
    let bad = |reason: String| ControllerError::BadParameters {
        controller: controller.into(),
        reason,
    };
    let positive = |name: String, value: f64| {
        if value > 0.0 && value.is_finite() {
            Ok(value)
        } else {
            Err(bad(format!("{name} must be finite and > 0 (got {value})")))
        }
    };
    let w = positive("servo.bandwidth".into(), params.bandwidth)?;
    positive("servo.approach_time".into(), params.approach_time)?;
    if !(params.settle_time >= 0.0 && params.settle_time.is_finite()) {
        return Err(bad("servo.settle_time must be finite and ≥ 0".into()));
    }
    let mut gains = [JointGains {
        kp: 0.0,
        ki: 0.0,
        kd: 0.0,
    }; 3];
    for (i, joint) in JOINTS.iter().enumerate() {
        let j = positive(format!("servo.inertia of {joint}"), params.inertia[i])?;
        let k = positive(
            format!("servo.torque_per_ampere of {joint}"),
            params.torque_per_ampere[i],
        )?;
        gains[i] = JointGains {
            kp: 3.0 * w * w * j / k,
            ki: w.powi(3) * j / k,
            kd: 3.0 * w * j / k,
        };
        if ![gains[i].kp, gains[i].ki, gains[i].kd]
            .iter()
            .all(|g| g.is_finite())
        {
            return Err(bad(format!(
                "servo.bandwidth, inertia and torque_per_ampere of {joint} give gains that overflow"
            )));
        }
    }
    let program = JointPath::new(&params.arm, &params.contour, params.elbow)
        .map_err(|e| bad(e.to_string()))?;
    if !(params.clearance >= 0.0 && params.clearance.is_finite()) {
        return Err(bad("servo.clearance must be finite and ≥ 0".into()));
    }
    let start = program.sample(&PathCursor::default()).position;
    let contour = ContourPath::new(&params.contour).map_err(|e| bad(e.to_string()))?;
    let (point, tangent) = contour.point(0.0);
    let above = [
        point[0] - params.clearance * tangent[1],
        point[1] + params.clearance * tangent[0],
    ];
    let clearance_point = params
        .arm
        .inverse(above, start[0] + start[1] + start[2], params.elbow)
        .map_err(|e| bad(format!("servo.clearance: {e}")))?;
    Ok(ServoDesign {
        gains,
        program,
        clearance_point,
        crossover: crossover(w),
    })
}

/// Crossover of `L(s) = ω(3s² + 3ωs + ω²)/s³` (the PID over the inertia, per unit design
/// inertia): `|L(jx)| = 1` solved by bisection.
fn crossover(w: f64) -> f64 {
    let magnitude =
        |x: f64| w * ((w * w - 3.0 * x * x).powi(2) + (3.0 * w * x).powi(2)).sqrt() / x.powi(3);
    let (mut low, mut high) = (0.1 * w, 100.0 * w);
    for _ in 0..100 {
        let mid = (low * high).sqrt();
        if magnitude(mid) > 1.0 {
            low = mid;
        } else {
            high = mid;
        }
    }
    (low * high).sqrt()
}

/// Where the arm is in its cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stage {
    /// Waiting for the first measurement.
    Idle,
    /// Moving from `from` over the clearance point to the first control point since `since`.
    Approach { from: [f64; 3], since: f64 },
    /// Following the contour.
    Machining,
    /// At the end of the contour.
    Finished,
}

/// The running servo: program cursor and per-joint PID state.
pub struct ArmServo {
    controller: &'static str,
    params: ServoParams,
    design: ServoDesign,
    positions: [usize; 3],
    velocities: [usize; 3],
    actuators: [usize; 3],
    current_limits: [f64; 3],
    integrals: [f64; 3],
    pub stage: Stage,
    pub cursor: PathCursor,
    pub reference: [f64; 3],
    pub errors: [f64; 3],
    pub commands: [f64; 3],
}

impl ArmServo {
    pub fn new(controller: &'static str, params: ServoParams) -> Result<Self, ControllerError> {
        let design = design(controller, &params)?;
        Ok(Self {
            controller,
            params,
            design,
            positions: [0; 3],
            velocities: [0; 3],
            actuators: [0; 3],
            current_limits: [f64::INFINITY; 3],
            integrals: [0.0; 3],
            stage: Stage::Idle,
            cursor: PathCursor::default(),
            reference: [0.0; 3],
            errors: [0.0; 3],
            commands: [0.0; 3],
        })
    }

    pub fn design(&self) -> &ServoDesign {
        &self.design
    }

    /// Binds to the plant: joint signals and actuators; the current limits from the effort limits.
    pub fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        if plant.machine != "arm" {
            return Err(ControllerError::WrongMachine {
                controller: self.controller.into(),
                machine: plant.machine.clone(),
            });
        }
        for (i, joint) in JOINTS.iter().enumerate() {
            self.positions[i] = plant.signal(&format!("{joint}.position"))?;
            self.velocities[i] = plant.signal(&format!("{joint}.velocity"))?;
            self.actuators[i] = plant.actuator(joint)?;
            self.current_limits[i] =
                plant.actuators[self.actuators[i]].effort_limit / self.params.torque_per_ampere[i];
        }
        self.integrals = [0.0; 3];
        self.stage = Stage::Idle;
        self.cursor = PathCursor::default();
        self.reference = [0.0; 3];
        self.errors = [0.0; 3];
        self.commands = [0.0; 3];
        Ok(())
    }

    /// Whether the arm is on the contour, so that the path speed matters.
    pub fn machining(&self) -> bool {
        self.stage == Stage::Machining
    }

    /// Path length covered, m.
    pub fn covered(&self) -> f64 {
        self.design.program.covered(&self.cursor)
    }

    /// One period: advances the program by `path_speed·period` while machining, runs the servos
    /// and writes the current commands. Returns a stage change worth an event, if any.
    pub fn update(
        &mut self,
        measurement: &Measurement,
        period: f64,
        path_speed: f64,
        efforts: &mut [f64],
    ) -> Option<Event> {
        let q: [f64; 3] = std::array::from_fn(|i| measurement.get(self.positions[i]));
        let mut event = None;
        let program = &self.design.program;
        let start = program.sample(&PathCursor::default()).position;
        let (reference, rate, acceleration) = match self.stage {
            Stage::Idle => {
                self.stage = Stage::Approach {
                    from: q,
                    since: measurement.time,
                };
                approach(q, start, 0.0)
            }
            Stage::Approach { from, since } => {
                let elapsed = measurement.time - since;
                if elapsed >= self.params.approach_time + self.params.settle_time {
                    self.stage = Stage::Machining;
                    event = Some(Event::mode(
                        "machining",
                        format!(
                            "at the contour's start: machining {:.1} mm",
                            program.length() * 1e3
                        ),
                    ));
                }
                let (approach_time, settle_time) =
                    (self.params.approach_time, self.params.settle_time);
                let above = self.design.clearance_point;
                if elapsed < approach_time || settle_time == 0.0 {
                    approach(from, above, elapsed / approach_time).scaled(approach_time)
                } else {
                    approach(above, start, (elapsed - approach_time) / settle_time)
                        .scaled(settle_time)
                }
            }
            Stage::Machining | Stage::Finished => {
                if self.stage == Stage::Machining {
                    program.advance(&mut self.cursor, path_speed * period);
                    if program.finished(&self.cursor) {
                        self.stage = Stage::Finished;
                        event = Some(Event::mode(
                            "finished",
                            format!("contour finished at t = {:.3} s", measurement.time),
                        ));
                    }
                }
                let sample = program.sample(&self.cursor);
                let speed = if self.stage == Stage::Machining {
                    path_speed
                } else {
                    0.0
                };
                (
                    sample.position,
                    sample.slope.map(|s| s * speed),
                    sample.curvature.map(|c| c * speed * speed),
                )
            }
        };
        for i in 0..3 {
            let g = self.design.gains[i];
            let error = reference[i] - q[i];
            let rate_error = rate[i] - measurement.get(self.velocities[i]);
            let feedforward =
                acceleration[i] * self.params.inertia[i] / self.params.torque_per_ampere[i];
            let limit = self.current_limits[i];
            let candidate = self.integrals[i] + error * period;
            let unclipped = g.kp * error + g.ki * candidate + g.kd * rate_error + feedforward;
            if unclipped.abs() <= limit {
                self.integrals[i] = candidate;
            }
            let command = g.kp * error + g.ki * self.integrals[i] + g.kd * rate_error + feedforward;
            self.commands[i] = command.clamp(-limit, limit);
            self.errors[i] = error;
            efforts[self.actuators[i]] = self.commands[i];
        }
        self.reference = reference;
        event
    }
}

/// Reference triple: position, rate, acceleration per joint.
type Reference = ([f64; 3], [f64; 3], [f64; 3]);

trait Scaled {
    /// Rates and accelerations of a reference in normalised time, brought to seconds.
    fn scaled(self, duration: f64) -> Reference;
}

impl Scaled for Reference {
    fn scaled(self, duration: f64) -> Reference {
        (
            self.0,
            self.1.map(|v| v / duration),
            self.2.map(|a| a / (duration * duration)),
        )
    }
}

/// The quintic rest-to-rest move from `from` to `to` at normalised time `s` (clamped to [0, 1]).
fn approach(from: [f64; 3], to: [f64; 3], s: f64) -> Reference {
    let s = s.clamp(0.0, 1.0);
    let shape = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
    let slope = 30.0 * s.powi(2) - 60.0 * s.powi(3) + 30.0 * s.powi(4);
    let bend = 60.0 * s - 180.0 * s.powi(2) + 120.0 * s.powi(3);
    (
        std::array::from_fn(|i| from[i] + (to[i] - from[i]) * shape),
        std::array::from_fn(|i| (to[i] - from[i]) * slope),
        std::array::from_fn(|i| (to[i] - from[i]) * bend),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gains_place_a_triple_pole() {
        let d = design("test", &ServoParams::default()).unwrap();
        let p = ServoParams::default();
        let (w, j, k) = (p.bandwidth, p.inertia[0], p.torque_per_ampere[0]);
        // J s³ + k(K_d s² + K_p s + K_i) = J (s + ω)³.
        let g = d.gains[0];
        assert!((k * g.kd / j - 3.0 * w).abs() < 1e-9);
        assert!((k * g.kp / j - 3.0 * w * w).abs() < 1e-6);
        assert!((k * g.ki / j - w.powi(3)).abs() < 1e-3);
        // The crossover of the triple-pole PID loop lies near 3.4 ω.
        assert!(
            d.crossover > 3.0 * w && d.crossover < 4.0 * w,
            "{}",
            d.crossover
        );
    }

    #[test]
    fn bad_servo_parameters_are_named() {
        let err = |p: ServoParams| design("test", &p).unwrap_err().to_string();
        assert!(err(ServoParams {
            bandwidth: 0.0,
            ..Default::default()
        })
        .contains("bandwidth"));
        assert!(err(ServoParams {
            inertia: [1.0, -1.0, 1.0],
            ..Default::default()
        })
        .contains("inertia of elbow"));
        let far = ServoParams {
            contour: Contour {
                start: [0.9, -0.2],
                ..Default::default()
            },
            ..Default::default()
        };
        assert!(err(far).contains("out of the arm's reach"));
    }

    #[test]
    fn quintic_is_rest_to_rest() {
        let (a, b) = ([0.0, 1.0, -1.0], [1.0, -1.0, 0.5]);
        let (p0, v0, _) = approach(a, b, 0.0);
        let (p1, v1, _) = approach(a, b, 1.0);
        assert_eq!(p0, a);
        assert_eq!(p1, b);
        assert_eq!(v0, [0.0; 3]);
        assert!(v1.iter().all(|v| v.abs() < 1e-12));
    }
}
