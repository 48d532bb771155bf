//! The machines the twin knows by name, each built from a scenario's tables.

use super::actuators::ActuatorSpecs;
use super::error::MachineError;
use super::generic::{PointSpecs, GENERIC};
use super::machine::Machine;
use super::{actuators, arm, feed_axis, generic, lathe, milling, platform, whitworth};
use crate::mechanism::Mechanism;

/// Names of the machines the twin knows.
pub const MACHINES: &[&str] = &[
    GENERIC,
    "arm",
    "whitworth",
    "feed_axis",
    "platform",
    "lathe",
    "milling",
];

/// Builds the machine `name` on `mechanism` with the scenario's `[process]` table and its
/// `[actuators]` (the drives it makes ideal; an entry naming no actuator is refused). The
/// whitworth, lathe and milling machines have no drives of their own: their actuators are ideal
/// whatever the kind.
pub fn build(
    name: &str,
    mechanism: &Mechanism,
    process: &toml::Table,
    actuators: &ActuatorSpecs,
    points: &PointSpecs,
) -> Result<Box<dyn Machine>, MachineError> {
    if let Some(point) = points.keys().next().filter(|_| name != GENERIC) {
        return Err(MachineError::Point {
            key: format!("points.{point}"),
            reason: format!(
                "the {name} machine has task-space signals of its own; `[points]` are the \
                 generic machine's (leave `machine` out)"
            ),
        });
    }
    if name == GENERIC && !process.is_empty() {
        return Err(MachineError::BadParameters {
            machine: GENERIC.into(),
            reason: "it has no process: leave [process] out (loads on points: `[points]`)".into(),
        });
    }
    actuators::check_kinds(actuators, name == GENERIC)?;
    let machine: Box<dyn Machine> = match name {
        GENERIC => Box::new(generic::Generic::new(mechanism, points, actuators)?),
        "arm" => Box::new(arm::Arm::new(mechanism, process, actuators)?),
        "whitworth" => Box::new(whitworth::Whitworth::new(mechanism, process)?),
        "platform" => Box::new(platform::Platform::new(mechanism, process, actuators)?),
        "feed_axis" => Box::new(feed_axis::FeedAxis::new(mechanism, process, actuators)?),
        "lathe" => Box::new(lathe::ParallelLathe::new(mechanism, process)?),
        "milling" => Box::new(milling::Milling::new(mechanism, process)?),
        _ => {
            return Err(MachineError::Unknown {
                name: name.to_string(),
                known: MACHINES.join(", "),
            })
        }
    };
    actuators::check_entries(actuators, mechanism, &machine.extra_actuators())?;
    Ok(machine)
}
