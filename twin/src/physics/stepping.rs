//! The one door to either engine: [`Physics`] steps a mechanism with the engine its
//! [`SolverSettings`](super::SolverSettings) name, exact or rapier, behind one interface.

use super::exact::{ExactEngine, ExactSettings};
use super::options::{BodySpec, Engine, SolverSettings};
use super::rapier_engine::RapierEngine;
use super::state::{Load, MechanismState};
use crate::mechanism::{Inertial, Mechanism, Pose2};

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
                        integrator: settings.solver.integrator,
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
    /// the loops and makes the velocities consistent with them: the joints given held where the
    /// others can close the loops, which it returns (otherwise every joint moves).
    pub fn set_joint_states(&mut self, states: &[(usize, f64, f64)]) -> bool {
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
