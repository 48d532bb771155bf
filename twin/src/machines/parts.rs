//! What every machine reads from its scenario and mechanism alike: its `[process]` table, and
//! its joints and links by name, each failing with the entry or the part it could not find.

use super::error::MachineError;
use crate::mechanism::Mechanism;

/// Reads a machine's `[process]` table into its parameter struct; the error quotes the bad entry.
pub(crate) fn process_params<P: serde::de::DeserializeOwned>(
    machine: &str,
    process: &toml::Table,
) -> Result<P, MachineError> {
    framework::from_table(process).map_err(|reason| MachineError::BadParameters {
        machine: machine.into(),
        reason,
    })
}

/// Index of a tree joint by name, or the error naming it.
pub(crate) fn joint(
    machine: &str,
    mechanism: &Mechanism,
    name: &str,
) -> Result<usize, MachineError> {
    mechanism
        .joint_index(name)
        .ok_or_else(|| MachineError::MissingPart {
            machine: machine.into(),
            what: "joint",
            name: name.into(),
        })
}

/// Index of a link by name, or the error naming it.
pub(crate) fn link(
    machine: &str,
    mechanism: &Mechanism,
    name: &str,
) -> Result<usize, MachineError> {
    mechanism
        .link_index(name)
        .ok_or_else(|| MachineError::MissingPart {
            machine: machine.into(),
            what: "link",
            name: name.into(),
        })
}
