//! What building a machine on a mechanism fails with: an unknown machine, a part its URDF
//! lacks, bad `[process]`, `[actuators]` or `[points]` entries.

use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum MachineError {
    #[error("unknown machine `{name}` (known: {known})")]
    Unknown { name: String, known: String },
    #[error("machine `{machine}`: the URDF has no {what} `{name}`")]
    MissingPart {
        machine: String,
        what: &'static str,
        name: String,
    },
    #[error("machine `{machine}`: bad [process] parameters: {reason}")]
    BadParameters { machine: String, reason: String },
    /// An `[actuators]` entry naming no actuator, or a kind the actuator cannot be.
    #[error("{key}: {reason}")]
    Actuator { key: String, reason: String },
    /// A `[points]` entry the machine cannot take.
    #[error("{key}: {reason}")]
    Point { key: String, reason: String },
}
