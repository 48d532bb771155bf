//! The physics of a [`Mechanism`]: the only module that knows Rapier. Two engines step it, chosen
//! by the scenario's `[solver] engine`, behind one interface ([`Physics`]), so controllers,
//! sensors, faults, observers, recordings and studies work on either unchanged:
//!
//! - `exact` ([`exact`]): the twin's own equations of motion on Rapier's multibody kinematics,
//!   RK4, loop closures exact to 1e-12 m; no contacts;
//! - `rapier` ([`rapier_engine`]): Rapier's own `PhysicsPipeline` — first-order, the loops closed
//!   by impulse joints to about a micrometre, and contacts between the links' collision shapes
//!   and the scenario's `[[bodies]]`.
//!
//! Both hand out the same [`MechanismState`], in the URDF's conventions, and read the loop gaps
//! the same way ([`loop_gaps`]).

mod contacts;
mod dense;
mod dynamics;
mod exact;
mod held_closure;
mod linearize;
mod options;
mod rapier_engine;
mod rapier_model;
mod shapes;
mod tree;

use crate::mechanism::{Inertial, JointMotion, Mechanism, Pose2};
use exact::{ExactEngine, ExactSettings};
use rapier_engine::RapierEngine;

pub use contacts::{length, BodyShapes, Collision, ContactDetector};
pub use linearize::{ReducedDynamics, ReducedError};
pub use options::{
    AllowedContact, BodyKind, BodyShape, BodySpec, ContactOptions, Engine, SolverOptions,
    MAX_SUBSTEPS,
};

/// Joint coordinates and link motion after a step, in the URDF's conventions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MechanismState {
    /// Per tree joint (as [`Mechanism::joints`]): rad or m, counted along the URDF axis; 0 for
    /// fixed.
    pub joint_positions: Vec<f64>,
    /// rad/s or m/s.
    pub joint_velocities: Vec<f64>,
    /// Per link (as [`Mechanism::links`]): the link frame in the world.
    pub link_poses: Vec<Pose2>,
    /// Per link: velocity of the link frame's origin, m/s.
    pub link_velocities: Vec<[f64; 2]>,
    /// Per link: angular velocity, rad/s.
    pub link_angular_velocities: Vec<f64>,
    /// Per loop joint: how far its two frames have drifted apart (m), the loop-closure error.
    pub loop_gaps: Vec<f64>,
    /// Per scenario `[[bodies]]` entry: its frame in the world. Static bodies stay where the
    /// scenario puts them; free ones move as the rapier engine's contacts push them (the exact
    /// engine has no contacts and leaves them where they are put).
    pub body_poses: Vec<Pose2>,
}

/// An external force on a link (a process force: cutting, contact), in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Load {
    pub link: usize,
    /// The force at the start of the step, N.
    pub force: [f64; 2],
    /// Where it acts, world coordinates (at the start of the step; it moves with the link).
    pub point: [f64; 2],
    /// How the force changes with the point's velocity, ∂F/∂v (N·s/m, rows x and y): over the
    /// step the force is `force + damping·(v − v_start)`, so a stiff velocity-dependent process
    /// (a cut is a damper of thousands of N·s/m) is integrated with the motion, not frozen.
    pub damping: [[f64; 2]; 2],
    /// How the force changes with the point's displacement, ∂F/∂p (N/m, rows x and y): over the
    /// step the force adds `stiffness·(p − p_start)`, so a cut whose chip follows the tool's
    /// deflection pushes back within the step, not one step late (a lag that acts as damping).
    pub stiffness: [[f64; 2]; 2],
}

/// A load that does not depend on velocity.
pub const NO_DAMPING: [[f64; 2]; 2] = [[0.0; 2]; 2];
/// A load that does not depend on where its point is.
pub const NO_STIFFNESS: [[f64; 2]; 2] = [[0.0; 2]; 2];

/// Solver settings a scenario may tune.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverSettings {
    /// Physics step, s.
    pub dt: f64,
    /// Gravitational acceleration in the world frame [x, y], m/s².
    pub gravity: [f64; 2],
    /// The exact engine's RK4 substeps per step (efforts and loads are held over the whole step).
    pub substeps: usize,
    /// The engine and the rapier engine's settings (`[solver]`).
    pub solver: SolverOptions,
    /// How the rapier engine resolves contacts (`[contact]`).
    pub contact: ContactOptions,
    /// The rigid bodies beside the mechanism (`[[bodies]]`).
    pub bodies: Vec<BodySpec>,
    /// Pairs that touch by design (`[[allowed_contacts]]`): the rapier engine does not push
    /// them apart (a tool in its stock is a cut, which the machine's process model computes).
    pub allowed_contacts: Vec<AllowedContact>,
}

impl SolverSettings {
    /// The exact engine with `substeps` RK4 substeps and nothing beside the mechanism.
    pub fn exact(dt: f64, gravity: [f64; 2], substeps: usize) -> Self {
        Self {
            dt,
            gravity,
            substeps,
            solver: SolverOptions::default(),
            contact: ContactOptions::default(),
            bodies: Vec::new(),
            allowed_contacts: Vec::new(),
        }
    }
}

/// Steps a mechanism with the engine its settings name.
pub struct Physics {
    stepper: Stepper,
}

/// Both boxed: each engine is kilobytes of buffers and sets.
enum Stepper {
    /// With where the scenario's bodies stay: the exact engine has no contacts to move them.
    Exact(Box<ExactEngine>, Vec<Pose2>),
    Rapier(Box<RapierEngine>),
}

impl Physics {
    /// The engine `settings` name, holding `mechanism` at rest in its URDF pose (zero coordinates).
    pub fn new(mechanism: &Mechanism, settings: SolverSettings) -> Self {
        let stepper = match settings.solver.engine {
            Engine::Exact => Stepper::Exact(
                Box::new(ExactEngine::new(
                    mechanism,
                    ExactSettings {
                        dt: settings.dt,
                        gravity: settings.gravity,
                        substeps: settings.substeps,
                    },
                )),
                settings.bodies.iter().map(BodySpec::placement).collect(),
            ),
            Engine::Rapier => Stepper::Rapier(Box::new(RapierEngine::new(mechanism, &settings))),
        };
        Self { stepper }
    }

    /// Changes a link's mass properties from the next step on (a plant fault).
    pub fn set_link_inertial(&mut self, link: usize, inertial: Inertial) {
        match &mut self.stepper {
            Stepper::Exact(engine, _) => engine.set_link_inertial(link, inertial),
            Stepper::Rapier(engine) => engine.set_link_inertial(link, inertial),
        }
    }

    /// Changes a tree joint's viscous damping and dry friction from the next step on.
    pub fn set_joint_dynamics(&mut self, joint: usize, damping: f64, friction: f64) {
        match &mut self.stepper {
            Stepper::Exact(engine, _) => engine.set_joint_dynamics(joint, damping, friction),
            Stepper::Rapier(engine) => engine.set_joint_dynamics(joint, damping, friction),
        }
    }

    /// Puts tree joints (index, position, velocity; URDF sense) in a starting state, then closes
    /// the loops and makes the velocities consistent with them.
    pub fn set_joint_states(&mut self, states: &[(usize, f64, f64)]) {
        match &mut self.stepper {
            Stepper::Exact(engine, _) => engine.set_joint_states(states),
            Stepper::Rapier(engine) => engine.set_joint_states(states),
        }
    }

    /// Applies one step's joint efforts (per tree joint, URDF sign; N·m or N) and loads, then
    /// advances by dt. Efforts and loads act for this step only.
    pub fn step(&mut self, joint_efforts: &[f64], loads: &[Load]) {
        match &mut self.stepper {
            Stepper::Exact(engine, _) => engine.step(joint_efforts, loads),
            Stepper::Rapier(engine) => engine.step(joint_efforts, loads),
        }
    }

    /// Reads the state into `state`, reusing its buffers.
    pub fn read_state(&self, state: &mut MechanismState) {
        match &self.stepper {
            Stepper::Exact(engine, bodies) => {
                engine.read_state(state);
                state.body_poses.clone_from(bodies);
            }
            Stepper::Rapier(engine) => engine.read_state(state),
        }
    }
}

/// Per loop joint, how far its two frames have drifted apart at the link poses (m), into
/// `gaps`: across the slide for a prismatic loop joint, the distance for a revolute one.
fn loop_gaps(mechanism: &Mechanism, link_poses: &[Pose2], gaps: &mut Vec<f64>) {
    gaps.clear();
    for closure in &mechanism.loops {
        let frame1 = link_poses[closure.link1].compose(&closure.frame1);
        let frame2 = link_poses[closure.link2].compose(&closure.frame2);
        let gap = [frame2.x - frame1.x, frame2.y - frame1.y];
        gaps.push(match closure.motion {
            JointMotion::Prismatic { axis } => {
                let [ax, ay] = frame1.rotate(axis[0], axis[1]);
                (gap[1] * ax - gap[0] * ay).abs()
            }
            _ => gap[0].hypot(gap[1]),
        });
    }
}

#[cfg(test)]
mod tests;
