//! The machines the twin knows by name, each built from a scenario's tables.

use super::actuators::ActuatorSpecs;
use super::error::MachineError;
use super::generic::GENERIC;
use super::machine::Machine;
use super::points::{PointSpecs, Points};
use super::with_points::WithPoints;
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

/// Builds the machine `name` on `mechanism` with the scenario's `[process]` table, its
/// `[actuators]` (the drives it makes ideal; an entry naming no actuator is refused) and its
/// `[points]` (the generic machine's task space; beside a built-in machine's own signals). The
/// whitworth, lathe and milling machines have no drives of their own: their actuators are ideal
/// whatever the kind.
pub fn build(
    name: &str,
    mechanism: &Mechanism,
    process: &toml::Table,
    actuators: &ActuatorSpecs,
    points: &PointSpecs,
) -> Result<Box<dyn Machine>, MachineError> {
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
    if name == GENERIC || points.is_empty() {
        return Ok(machine);
    }
    let points = Points::new(name, mechanism, points)?;
    let own: Vec<String> = (machine.signals().into_iter())
        .chain(machine.diagnostics())
        .map(|s| s.name)
        .collect();
    if let Some(clash) = points.signals().into_iter().find(|s| own.contains(&s.name)) {
        return Err(MachineError::Point {
            key: format!(
                "points.{}",
                clash.name.split('.').next().unwrap_or_default()
            ),
            reason: format!(
                "`{}` is a signal of the {name} machine already: name the point otherwise",
                clash.name
            ),
        });
    }
    Ok(Box::new(WithPoints::new(machine, points)))
}
