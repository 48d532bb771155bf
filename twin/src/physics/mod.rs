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
//! the same way ([`state::loop_gaps`]).
//!
//! This file only declares the modules and re-exports what the library shows.

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
mod state;
mod stepping;
mod tree;

pub use contacts::{length, BodyShapes, Collision, ContactDetector};
pub use linearize::{ReducedDynamics, ReducedError};
pub use options::{
    AllowedContact, BodyKind, BodyShape, BodySpec, ContactOptions, Engine, Integrator,
    SolverOptions, SolverSettings, MAX_SUBSTEPS,
};
pub use state::{Load, MechanismState, NO_DAMPING, NO_STIFFNESS};
pub use stepping::Physics;

#[cfg(test)]
mod tests;
