//! Joint servos and path following of the machining arm, shared by the path-speed controllers
//! ([`super::path_speed_adaptive`], [`super::path_speed_constant`]): the robot program of
//! `models::arm::path` (control points → inverse kinematics → cubics in the path length,
//! Ilyukhin eqs (2)–(4)) walked at the path speed the controller chooses, and one PID position
//! servo per joint whose output is the joint drive's **current command, in A** (the arm's drives
//! take currents; see the `arm` machine).
//!
//! Design (computed torque, the inverse-dynamics law of robot control): the joints are coupled
//! through the arm's mass matrix `M(q)`, so no fixed per-joint inertia describes them — stretched
//! out, the inertia the elbow feels, `1/(M⁻¹)₂₂` = 0.085 kg·m², is a twelfth of `M₂₂` and a ninth
//! of its `M₂₂` on the contour — and a per-joint PID designed for one pose chatters rail to rail
//! at another. The servo therefore works per unit inertia: each joint's PID asks for the
//! acceleration `a = q̈_r + K_d·ė + K_p·e + K_i·∫e` (S1), whose three closed-loop poles
//! `s³ + K_d s² + K_p s + K_i = (s + ω)³` sit at `−ω` (bandwidth ω) with `K_d = 3ω`, `K_p = 3ω²`,
//! `K_i = ω³` (S2); the drives are asked for the joint torques that give it,
//! `i* = (G·k_t)⁻¹·M̂(q)·a` (S3), `M̂` the rigid-body model of the arm from the servo's own link
//! parameters ([`models::serial_chain`]). With `M̂ = M` each joint error obeys
//! `ë = −(K_d·ė + K_p·e + K_i·∫e)` at every pose. Gravity, the Coriolis terms and the cutting
//! force's reaction are disturbances the integral takes up. The commands are kept within the
//! drives' current limits, `effort_limit/(G·k_t)` (the URDF effort limit is the drive's peak
//! torque), by clipping the joints that pass theirs and giving the others the accelerations they
//! ask for (`limited_torques`); a clipped joint's integral stops.
//!
//! Cycle: from wherever the arm is at the first update, a quintic in joint space brings it in
//! `approach_time` to a clearance point `clearance` off the contour's first point on the side
//! away from the stock (a joint-space move may sweep anywhere, so it must end in the air); a
//! second quintic lowers it onto the first point in `settle_time`; then the path length
//! `l` advances by the path speed each period and the joints follow `q(l)` with the velocity
//! reference `dq/dl·V_K` and the acceleration reference `d²q/dl²·V_K²`. At the end of the contour
//! the arm holds the last point.

use crate::check::{finite, non_negative, positive};
use framework::Event;
use framework::{ControllerError, Measurement, PlantInterface, SignalSpec, Unit};
use models::arm::path::{
    ArmGeometry, Contour, ContourPath, Elbow, JointPath, PathCursor, PathError,
};
use models::serial_chain::{solve_in_place, ChainLink, SerialChain};
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
    /// Which side of the shoulder–wrist line the elbow takes in the inverse kinematics.
    pub elbow: Elbow,
    /// The part contour: the program's control points are taken along it.
    pub contour: Contour,
    /// Per link (upper arm, forearm, hand with the spindle housing): mass, kg.
    pub link_masses: [f64; 3],
    /// Per link: distance of its centre of mass from its joint, along the link, m.
    pub link_centres: [f64; 3],
    /// Per link: moment of inertia about z through its centre of mass, kg·m².
    pub link_inertias: [f64; 3],
    /// The cutter (spindle rotor, holder, end mill) on the spindle axis, `arm.hand` from the
    /// wrist: mass, kg.
    pub tool_mass: f64,
    /// The cutter's moment of inertia about the spindle axis, kg·m².
    pub tool_inertia: f64,
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
    /// The arm of `urdf/arm.urdf` with its drives (notes in `twin/src/machines/arm.rs`): links
    /// and cutter as the URDF's inertials.
    fn default() -> Self {
        Self {
            arm: ArmGeometry::default(),
            elbow: Elbow::Up,
            contour: Contour::default(),
            link_masses: [9.0, 5.0, 3.5],
            link_centres: [0.18, 0.16, 0.09],
            link_inertias: [0.15, 0.06, 0.01],
            tool_mass: 0.4,
            tool_inertia: 2e-4,
            torque_per_ampere: [4.2, 3.0, 1.0],
            bandwidth: 80.0,
            approach_time: 2.0,
            settle_time: 0.5,
            clearance: 0.02,
        }
    }
}

/// PID gains per unit inertia, (S2): acceleration demand in rad/s² per rad, per rad·s and per
/// rad/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGains {
    /// K_p = 3ω², 1/s².
    pub kp: f64,
    /// K_i = ω³, 1/s³.
    pub ki: f64,
    /// K_d = 3ω, 1/s.
    pub kd: f64,
}

/// The servo design and the program built from the parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoDesign {
    /// The gains of every joint's PID, (S1).
    pub gains: JointGains,
    /// The arm's rigid-body model `M̂(q)` of (S3) comes from: the three joints and the cutter
    /// welded on the spindle axis (its joint held at 0).
    pub model: SerialChain,
    /// The robot program: the joint angles as cubics in the path length along the contour.
    pub program: JointPath,
    /// Joint angles at the clearance point above the contour's start.
    pub clearance_point: [f64; 3],
    /// Open-loop crossover of every (decoupled) joint servo, rad/s (`|L(jω_c)| = 1`).
    pub crossover: f64,
}

/// Gains by pole placement (S2), the arm's model and the program through the inverse
/// kinematics. Errors name the entry of `[controller.params.servo]` at fault.
pub fn design(controller: &str, params: &ServoParams) -> Result<ServoDesign, ControllerError> {
    let w = positive(controller, "servo.bandwidth", params.bandwidth)?;
    positive(controller, "servo.approach_time", params.approach_time)?;
    non_negative(controller, "servo.settle_time", params.settle_time)?;
    let gains = JointGains {
        kp: 3.0 * w * w,
        ki: w.powi(3),
        kd: 3.0 * w,
    };
    if !gains.ki.is_finite() {
        return Err(ControllerError::parameter(
            controller,
            "servo.bandwidth",
            w,
            "must be small enough that the gain K_i = ω³ of (S2) does not overflow",
        ));
    }
    for (i, value) in params.torque_per_ampere.iter().enumerate() {
        positive(controller, &format!("servo.torque_per_ampere.{i}"), *value)?;
    }
    let model = model(controller, params)?;
    let program = JointPath::new(&params.arm, &params.contour, params.elbow)
        .map_err(|e| path_error(controller, e))?;
    let clearance = non_negative(controller, "servo.clearance", params.clearance)?;
    let start = program.sample(&PathCursor::default()).position;
    let contour = ContourPath::new(&params.contour).map_err(|e| path_error(controller, e))?;
    let (point, tangent) = contour.point(0.0);
    let above = [
        point[0] - clearance * tangent[1],
        point[1] + clearance * tangent[0],
    ];
    let clearance_point = params
        .arm
        .inverse(above, start[0] + start[1] + start[2], params.elbow)
        .map_err(|e| {
            ControllerError::parameter(
                controller,
                "servo.clearance",
                clearance,
                format!("must leave the clearance point within the arm's reach: {e}"),
            )
        })?;
    Ok(ServoDesign {
        gains,
        model,
        program,
        clearance_point,
        crossover: crossover(w),
    })
}

/// A robot-program error, named by the entry of `servo` at fault.
fn path_error(controller: &str, error: PathError) -> ControllerError {
    match error {
        PathError::BadArm(name) => ControllerError::parameter_table(
            controller,
            format!("servo.arm.{name}"),
            if name == "base" {
                "must be finite"
            } else {
                "must be finite and > 0"
            },
        ),
        PathError::OutOfReach { .. } => ControllerError::parameter_table(
            controller,
            "servo.contour",
            format!("must lie within the arm's reach: {error}"),
        ),
        PathError::BadContour(reason) => {
            ControllerError::parameter_table(controller, "servo.contour", reason)
        }
    }
}

/// The arm as a planar serial chain (joint frames from `params.arm`, links from the servo's link
/// parameters, the cutter a fourth link on the spindle axis), checked so that `M̂(q)` is positive
/// definite at every pose: link masses and inertias > 0, the cutter's ≥ 0.
fn model(controller: &str, params: &ServoParams) -> Result<SerialChain, ControllerError> {
    let arm = &params.arm;
    let lengths = [arm.upper, arm.fore, arm.hand];
    let mut links = Vec::with_capacity(4);
    for i in 0..3 {
        let mass = positive(
            controller,
            &format!("servo.link_masses.{i}"),
            params.link_masses[i],
        )?;
        let izz = positive(
            controller,
            &format!("servo.link_inertias.{i}"),
            params.link_inertias[i],
        )?;
        let centre = finite(
            controller,
            &format!("servo.link_centres.{i}"),
            params.link_centres[i],
        )?;
        let origin = if i == 0 {
            [arm.base[0], arm.base[1], 0.0]
        } else {
            [lengths[i - 1], 0.0, 0.0]
        };
        links.push(ChainLink {
            origin,
            mass,
            centre_of_mass: [centre, 0.0],
            izz,
            damping: 0.0,
        });
    }
    links.push(ChainLink {
        origin: [arm.hand, 0.0, 0.0],
        mass: non_negative(controller, "servo.tool_mass", params.tool_mass)?,
        centre_of_mass: [0.0, 0.0],
        izz: non_negative(controller, "servo.tool_inertia", params.tool_inertia)?,
        damping: 0.0,
    });
    // Only M̂(q) is used: gravity is a disturbance the integral takes up.
    Ok(SerialChain {
        links,
        gravity: [0.0, 0.0],
    })
}

/// Crossover of `L(s) = ω(3s² + 3ωs + ω²)/s³` (the PID of (S2) over the unit inertia):
/// `|L(jx)| = 1` solved by bisection.
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
    Approach {
        /// Joint angles where the approach began, rad.
        from: [f64; 3],
        /// Time the approach began, s.
        since: f64,
    },
    /// Following the contour.
    Machining,
    /// At the end of the contour.
    Finished,
}

/// The running servo: program cursor and per-joint PID state.
pub struct ArmServo {
    params: ServoParams,
    design: ServoDesign,
    positions: [usize; 3],
    velocities: [usize; 3],
    actuators: [usize; 3],
    current_limits: [f64; 3],
    integrals: [f64; 3],
    /// Where the arm is in its cycle.
    pub stage: Stage,
    /// How far the program has come along the contour.
    pub cursor: PathCursor,
    /// Joint angle references of the last update, rad.
    pub reference: [f64; 3],
    /// Joint errors `q_r − q` of the last update, rad.
    pub errors: [f64; 3],
    /// Current commands of the last update, before the twin's clip, A.
    pub commands: [f64; 3],
}

impl ArmServo {
    /// Designs the servo from `params`, the `servo` table of `controller`'s parameters.
    pub fn new(controller: &str, params: ServoParams) -> Result<Self, ControllerError> {
        let design = design(controller, &params)?;
        Ok(Self {
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

    /// The gains, the arm's model and the program the servo was built with.
    pub fn design(&self) -> &ServoDesign {
        &self.design
    }

    /// Binds to the plant: joint signals and actuators; the current limits from the effort limits.
    pub fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
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
        let velocity = std::array::from_fn(|i| measurement.get(self.velocities[i]));
        self.servo(q, velocity, (reference, rate, acceleration), period);
        for i in 0..3 {
            efforts[self.actuators[i]] = self.commands[i];
        }
        self.reference = reference;
        event
    }

    /// The joint servos, (S1) and (S3): the PID's acceleration demand through `M̂(q)` to
    /// current commands within the limits ([`limited_torques`]); a joint's integral stops while
    /// its command is clipped.
    fn servo(&mut self, q: [f64; 3], velocity: [f64; 3], reference: Reference, period: f64) {
        let (position, rate, acceleration) = reference;
        let g = self.design.gains;
        let mass = self.design.model.mass_block(&[q[0], q[1], q[2], 0.0]);
        let torque_per_ampere = self.params.torque_per_ampere;
        let limits = std::array::from_fn(|i| self.current_limits[i] * torque_per_ampere[i]);
        let errors: [f64; 3] = std::array::from_fn(|i| position[i] - q[i]);
        let torques = |integrals: [f64; 3]| {
            let demand = std::array::from_fn(|i| {
                acceleration[i]
                    + g.kd * (rate[i] - velocity[i])
                    + g.kp * errors[i]
                    + g.ki * integrals[i]
            });
            limited_torques(&mass, demand, limits)
        };
        let candidate = std::array::from_fn(|i| self.integrals[i] + errors[i] * period);
        let (_, clipped) = torques(candidate);
        for i in 0..3 {
            if !clipped[i] {
                self.integrals[i] = candidate[i];
            }
        }
        let (torque, _) = torques(self.integrals);
        self.commands = std::array::from_fn(|i| torque[i] / torque_per_ampere[i]);
        self.errors = errors;
    }
}

/// (S3) within the drives' torque limits: `τ = M̂·a`, except that a joint whose torque would
/// pass its limit is held at the limit and its acceleration left to follow, while the others
/// still get the accelerations they demand — `M̂·a = τ` solved for the clipped joints'
/// accelerations and the free joints' torques, clipping the joint furthest over its limit until
/// none is (at most four rounds). Clamping each torque of `M̂·a` on its own would hand the others
/// the torques of an acceleration the clipped joint cannot make: a shoulder at its limit would
/// throw the elbow and wrist about. Returns the torques and which joints are clipped.
fn limited_torques(
    mass: &[[f64; 3]; 3],
    demand: [f64; 3],
    limits: [f64; 3],
) -> ([f64; 3], [bool; 3]) {
    let (mut torques, mut clipped) = ([0.0; 3], [false; 3]);
    loop {
        // Unknowns: a_k of the clipped joints k, τ_k of the free ones.
        let mut system: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|k| match (clipped[k], i == k) {
                (true, _) => mass[i][k],
                (false, true) => -1.0,
                (false, false) => 0.0,
            })
        });
        let mut rhs: [f64; 3] = std::array::from_fn(|i| {
            let known: f64 = (0..3)
                .filter(|&k| !clipped[k])
                .map(|k| mass[i][k] * demand[k])
                .sum();
            if clipped[i] {
                torques[i] - known
            } else {
                -known
            }
        });
        let mut unknowns = [0.0; 3];
        solve_in_place(&mut system, &mut rhs, &mut unknowns);
        for i in (0..3).filter(|&i| !clipped[i]) {
            torques[i] = unknowns[i];
        }
        let excess = |i: usize| torques[i].abs() / limits[i];
        match (0..3)
            .filter(|&i| !clipped[i] && excess(i) > 1.0)
            .max_by(|&a, &b| excess(a).total_cmp(&excess(b)))
        {
            Some(i) => {
                torques[i] = torques[i].clamp(-limits[i], limits[i]);
                clipped[i] = true;
            }
            None => return (torques, clipped),
        }
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
        let w = ServoParams::default().bandwidth;
        // s³ + K_d s² + K_p s + K_i = (s + ω)³.
        let g = d.gains;
        assert_eq!([g.kd, g.kp, g.ki], [3.0 * w, 3.0 * w * w, w.powi(3)]);
        // The crossover of the triple-pole PID loop lies near 3.4 ω.
        assert!(
            d.crossover > 3.0 * w && d.crossover < 4.0 * w,
            "{}",
            d.crossover
        );
    }

    #[test]
    fn bad_servo_parameters_are_named() {
        let err = |p: ServoParams| design("test", &p).unwrap_err();
        assert_eq!(
            err(ServoParams {
                bandwidth: 0.0,
                ..Default::default()
            })
            .to_string(),
            "controller `test`: params.servo.bandwidth = 0: must be > 0"
        );
        for (params, key, value) in [
            (
                ServoParams {
                    link_masses: [1.0, -1.0, 1.0],
                    ..Default::default()
                },
                "servo.link_masses.1",
                Some("-1"),
            ),
            (
                ServoParams {
                    tool_mass: f64::NAN,
                    ..Default::default()
                },
                "servo.tool_mass",
                Some("NaN"),
            ),
            (
                ServoParams {
                    torque_per_ampere: [4.2, 3.0, 0.0],
                    ..Default::default()
                },
                "servo.torque_per_ampere.2",
                Some("0"),
            ),
            (
                ServoParams {
                    arm: ArmGeometry {
                        fore: -0.1,
                        ..Default::default()
                    },
                    ..Default::default()
                },
                "servo.arm.fore",
                None,
            ),
        ] {
            let err = err(params);
            assert!(
                matches!(
                    &err,
                    ControllerError::BadParameter { key: k, value: v, .. }
                        if k == key && v.as_deref() == value
                ),
                "{err}"
            );
        }
        let far = ServoParams {
            contour: Contour {
                start: [0.9, -0.2],
                ..Default::default()
            },
            ..Default::default()
        };
        let err = err(far);
        assert!(
            matches!(
                &err,
                ControllerError::BadParameter { key, value: None, reason, .. }
                    if key == "servo.contour" && reason.contains("out of the arm's reach")
            ),
            "{err}"
        );
    }

    /// The model's mass matrix at the stretched pose, by hand: `M₃₃` is the hand's and the
    /// cutter's inertia about the wrist.
    #[test]
    fn model_is_the_urdf_arm() {
        let m = model("test", &ServoParams::default())
            .unwrap()
            .mass_block::<3>(&[0.0; 4]);
        let wrist = 0.01 + 3.5 * 0.09f64.powi(2) + 2e-4 + 0.4 * 0.12f64.powi(2);
        assert!((m[2][2] - wrist).abs() < 1e-12, "{m:?}");
        assert!((m[0][1] - m[1][0]).abs() < 1e-12, "{m:?}");
    }

    /// The servo on a simulated arm — the URDF's links and joint damping under gravity, each
    /// drive its 2000 rad/s current loop (`twin/src/machines/arm.rs`), 1 kHz control — from the
    /// stretched pose the arm starts in, where the joints are most strongly coupled (the elbow
    /// feels a twelfth of `M₂₂`): after the first 0.1 s no command moves by more than 0.5 A from
    /// one period to the next. A per-joint PID designed for a fixed inertia chatters rail to rail
    /// here (12.6 A per period).
    #[test]
    fn no_chatter_stretched_out() {
        let link = |x: f64, mass: f64, centre: f64, izz: f64, damping: f64| ChainLink {
            origin: [x, 0.0, 0.0],
            mass,
            centre_of_mass: [centre, 0.0],
            izz,
            damping,
        };
        let arm = SerialChain {
            links: vec![
                link(0.0, 9.0, 0.18, 0.15, 0.5),
                link(0.40, 5.0, 0.16, 0.06, 0.3),
                link(0.36, 3.5, 0.09, 0.01, 0.1),
                link(0.12, 0.4, 0.0, 2e-4, 0.0),
            ],
            gravity: [0.0, -9.81],
        };
        let plant = PlantInterface {
            machine: "arm".into(),
            signals: JOINTS
                .iter()
                .flat_map(|j| [format!("{j}.position"), format!("{j}.velocity")])
                .collect(),
            actuators: JOINTS
                .iter()
                .zip([84.0, 60.0, 20.0])
                .map(|(j, limit)| framework::Actuator {
                    joint: j.to_string(),
                    kind: framework::EffortKind::Torque,
                    effort_limit: limit,
                })
                .collect(),
            ..Default::default()
        };
        let params = ServoParams::default();
        let mut servo = ArmServo::new("test", params.clone()).unwrap();
        servo.reset(&plant).unwrap();
        let (mut q, mut qd, mut current) = (vec![0.0; 4], vec![0.0; 4], [0.0; 3]);
        let (mut efforts, mut worst) = ([0.0; 3], 0.0f64);
        let lag = 1.0 - (-2000.0f64 * 1e-4).exp();
        for k in 0..500 {
            let signals: Vec<f64> = (0..3).flat_map(|i| [q[i], qd[i]]).collect();
            let previous = servo.commands;
            let m = Measurement {
                time: k as f64 * 1e-3,
                signals: &signals,
            };
            servo.update(&m, 1e-3, 0.0, &mut efforts);
            if k >= 100 {
                (0..3).for_each(|i| worst = worst.max((servo.commands[i] - previous[i]).abs()));
            }
            for _ in 0..10 {
                current = std::array::from_fn(|i| current[i] + lag * (efforts[i] - current[i]));
                let mut torque: Vec<f64> = (0..3)
                    .map(|i| params.torque_per_ampere[i] * current[i])
                    .collect();
                torque.push(0.0);
                arm.rk4_step(&mut q, &mut qd, &torque, 1e-4);
            }
        }
        assert!(worst < 0.5, "commands move by up to {worst} A per period");
    }

    /// A shoulder asked for far more than its limit (alone it would push the elbow over its own
    /// limit too) is held at the limit; the elbow and wrist still get the accelerations they ask
    /// for, given the shoulder's.
    #[test]
    fn a_clipped_joint_leaves_the_others_their_accelerations() {
        let mass = model("test", &ServoParams::default())
            .unwrap()
            .mass_block(&[0.3, -1.2, 0.4, 0.0]);
        let demand = [500.0, 20.0, -30.0];
        assert!((mass[1][0] * demand[0]).abs() > 60.0);
        let (torques, clipped) = limited_torques(&mass, demand, [84.0, 60.0, 20.0]);
        assert_eq!((torques[0], clipped), (84.0, [true, false, false]));
        let shoulder = (84.0 - mass[0][1] * demand[1] - mass[0][2] * demand[2]) / mass[0][0];
        for i in 1..3 {
            let torque = mass[i][0] * shoulder + mass[i][1] * demand[1] + mass[i][2] * demand[2];
            assert!((torque - torques[i]).abs() < 1e-9, "{torques:?}");
        }
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
