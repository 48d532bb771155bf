//! A joint's own reference in the generic controllers' parameters
//! (`[controller.params.joints.<joint>] reference = { kind = "waypoints", … }`, any
//! [`Reference`]): checked when the controller is designed, its table (if it is one) read through
//! the engine when it is bound to the plant.

use framework::{ControllerError, EffortKind, PlantInterface};
use models::reference::Reference;

/// Checks `reference`, the entry `key` of `controller`'s table.
pub(crate) fn check(
    controller: &str,
    key: &str,
    reference: &Reference,
) -> Result<(), ControllerError> {
    (reference.validate())
        .map_err(|reason| ControllerError::parameter_table(controller, key, reason))
}

/// Reads a table reference's rows from the scenario's files, its positions in the unit of a
/// joint of `kind` (rad or m); any other reference is left as it is.
pub(crate) fn read_table(
    controller: &str,
    key: &str,
    reference: &mut Reference,
    plant: &PlantInterface,
    kind: EffortKind,
) -> Result<(), ControllerError> {
    let Some(file) = reference.table_file().map(str::to_owned) else {
        return Ok(());
    };
    let unit = match kind {
        EffortKind::Torque => "rad",
        EffortKind::Force => "m",
    };
    let table =
        |reason| ControllerError::parameter(controller, format!("{key}.file"), &file, reason);
    let rows = plant
        .files(controller)?
        .positions(&file, unit)
        .map_err(table)?;
    reference.set_rows(rows).map_err(table)
}
