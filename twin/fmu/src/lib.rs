//! The twin as an FMI 2.0 co-simulation FMU (Modelica Association, FMI 2.0.4, §4): a
//! scenario's plant without its controller, or its closed loop with it ([`twin::Simulator`]).
//! The plant's inputs are the actuators' efforts; the closed loop's a setpoint on the
//! scenario's reference and disturbances on the joints; outputs are the measured and the true
//! signals (and the controller's efforts and internals); parameters the scenario's numbers. The
//! shared library exports the 34 `fmi2*` functions of co-simulation ([`api`]), FMU state
//! included; the rlib gives the `twin fmu` command the model description and the packing
//! ([`package()`]).

pub mod api;
mod description;
mod instance;
mod package;
mod parameters;
mod state;

use controllers::Registry;
pub use description::model_identifier;
pub use package::{package, Packed, KIND_FILE, SCENARIO_FILE};
use thiserror::Error;
use twin::{LoadedScenario, Simulator, TwinError};

/// Why an FMU could not be made.
#[derive(Debug, Error)]
pub enum FmuError {
    #[error("{0}")]
    Scenario(String),
    #[error("FMU library {path}: {reason}; build it with `cargo build --release -p twin-fmu`")]
    Library { path: String, reason: String },
}

/// The FMU's simulator: the plant alone, or with `controlled` the closed loop with the
/// scenario's controller built from `registry`.
fn simulator(
    loaded: LoadedScenario,
    controlled: bool,
    registry: &Registry,
) -> Result<Simulator, TwinError> {
    if controlled {
        Simulator::with_controller(loaded, registry)
    } else {
        Simulator::new(loaded)
    }
}
