//! What can go wrong packing an FMU: the scenario, or the shared library it carries.

use thiserror::Error;

/// Why an FMU could not be made.
#[derive(Debug, Error)]
pub enum FmuError {
    #[error("{0}")]
    Scenario(String),
    #[error("FMU library {path}: {reason}; build it with `cargo build --release -p twin-fmu`")]
    Library { path: String, reason: String },
}
