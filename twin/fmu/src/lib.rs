//! The twin as an FMI 2.0 co-simulation FMU (Modelica Association, FMI 2.0.4, §4): a
//! scenario's plant without its controller ([`twin::Simulator`]); inputs are the actuators'
//! efforts, outputs the measured and the true signals. The shared library exports the 34
//! `fmi2*` functions of co-simulation ([`api`]); the rlib gives the `twin fmu` command the
//! model description and the packing ([`package()`]).

pub mod api;
mod description;
mod instance;
mod package;

pub use description::{model_description, model_identifier};
pub use package::{package, Packed, SCENARIO_FILE};
use thiserror::Error;

/// Why an FMU could not be made.
#[derive(Debug, Error)]
pub enum FmuError {
    #[error("{0}")]
    Scenario(String),
    #[error("FMU library {path}: {reason}; build it with `cargo build --release -p twin-fmu`")]
    Library { path: String, reason: String },
}
