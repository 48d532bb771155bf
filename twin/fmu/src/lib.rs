//! The twin as an FMI 2.0 co-simulation FMU (Modelica Association, FMI 2.0.4, §4): a
//! scenario's plant without its controller, or its closed loop with it ([`twin::Simulator`]).
//! The plant's inputs are the actuators' efforts; the closed loop's a setpoint on the
//! scenario's reference and disturbances on the joints; outputs are the measured and the true
//! signals (and the controller's efforts and internals); parameters the scenario's numbers. The
//! shared library exports the 34 `fmi2*` functions of co-simulation ([`api`]), FMU state
//! included; the rlib gives the `twin fmu` command the model description and the packing
//! ([`package()`]).

pub mod api;
mod closed_loop;
mod description;
mod error;
mod instance;
mod package;
mod parameters;
mod state;

pub use description::model_identifier;
pub use error::FmuError;
pub use package::{package, Packed, KIND_FILE, SCENARIO_FILE};
