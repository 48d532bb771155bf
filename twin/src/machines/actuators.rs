//! `[actuators.<joint>]`: how the scenario has each actuator turn its command into the joint's
//! effort — through the machine's own drive (`kind = "drive"`, the default), or directly, as an
//! ideal drive (`kind = "effort"`: the command is the joint's torque, N·m, or force, N, clipped
//! to the URDF `<limit effort>`), or on the generic machine through a DC servo drive from its data
//! sheet (`kind = "dc-servo"` with `[actuators.<joint>.drive]`: the command is a current, A; the
//! drive the arm's joints have, [`models::drive`]). `[actuators."*"]` speaks for every actuator
//! of the machine; a joint's own entry overrides it.

use super::error::MachineError;
use crate::mechanism::Mechanism;
use framework::Actuator;
use models::drive::DriveParams;
use serde::Deserialize;
use std::collections::BTreeMap;

/// The `[actuators]` key that stands for every actuator of the machine.
pub const EVERY_ACTUATOR: &str = "*";

/// What an actuator's command is.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ActuatorKind {
    /// The machine's own drive: the command is what that drive takes (the arm's motor current,
    /// A). On a machine without drives of its own the same as `Effort`.
    #[default]
    Drive,
    /// An ideal drive: the command is the joint's torque (N·m) or force (N), clipped to the URDF
    /// effort limit and applied as it is, with no drive state (no current) of its own.
    Effort,
    /// A DC servo drive from the entry's `drive` data sheet (the generic machine's): the command
    /// is the current, A, clipped to the drive's current limit; the joint gets `G·k_t·i`.
    DcServo,
}

/// One entry of `[actuators]`.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorSpec {
    /// `drive` (the default), `effort` or `dc-servo`.
    pub kind: ActuatorKind,
    /// A `dc-servo`'s data sheet (`[actuators.<joint>.drive]`, SI units).
    pub drive: Option<DriveParams>,
}

/// The scenario's `[actuators]` table: entries by joint name, or [`EVERY_ACTUATOR`].
pub type ActuatorSpecs = BTreeMap<String, ActuatorSpec>;

/// The kind `specs` gives the actuator on `joint`: its own entry's, else `"*"`'s, else `drive`.
pub fn kind_of(specs: &ActuatorSpecs, joint: &str) -> ActuatorKind {
    spec_of(specs, joint).map_or(ActuatorKind::Drive, |spec| spec.kind)
}

/// The entry that speaks for the actuator on `joint`: its own, else `"*"`'s.
pub fn spec_of<'a>(specs: &'a ActuatorSpecs, joint: &str) -> Option<&'a ActuatorSpec> {
    specs.get(joint).or_else(|| specs.get(EVERY_ACTUATOR))
}

/// The entry that gives `joint` its kind, as the scenario spells it: `actuators.<joint>` or
/// `actuators."*"`.
pub fn key_of(specs: &ActuatorSpecs, joint: &str) -> String {
    if specs.contains_key(joint) {
        format!("actuators.{joint}")
    } else {
        format!("actuators.\"{EVERY_ACTUATOR}\"")
    }
}

/// Refuses a `dc-servo` on a machine with drives of its own (it is the generic machine's), and a
/// data sheet on an entry of another kind.
pub(super) fn check_kinds(specs: &ActuatorSpecs, generic: bool) -> Result<(), MachineError> {
    for (name, spec) in specs {
        let bad = |reason: &str| MachineError::Actuator {
            key: format!("actuators.{}", quoted(name)),
            reason: reason.into(),
        };
        match (spec.kind, spec.drive.is_some()) {
            (ActuatorKind::DcServo, _) if !generic => {
                return Err(bad("kind = \"dc-servo\" is the generic machine's: a built-in machine's drives are its own (\"drive\") or ideal (\"effort\")"));
            }
            (ActuatorKind::DcServo, false) => {
                return Err(bad("kind = \"dc-servo\" needs its data sheet: [actuators.<joint>.drive] torque_constant, back_emf_constant, resistance, inductance, gear_ratio, supply_voltage, current_limit, current_bandwidth, current_loop_period"));
            }
            (ActuatorKind::Drive | ActuatorKind::Effort, true) => {
                return Err(bad("a `drive` data sheet is for kind = \"dc-servo\""));
            }
            _ => {}
        }
    }
    Ok(())
}

fn quoted(name: &str) -> String {
    if name == EVERY_ACTUATOR {
        format!("\"{name}\"")
    } else {
        name.to_string()
    }
}

/// Refuses an entry that names no actuator of the machine (the URDF's actuated joints and the
/// machine's `own` actuators), saying which ones there are.
pub(super) fn check_entries(
    specs: &ActuatorSpecs,
    mechanism: &Mechanism,
    own: &[Actuator],
) -> Result<(), MachineError> {
    let mut known: Vec<&str> = (mechanism.actuated_joints().into_iter())
        .map(|j| mechanism.joints[j].name.as_str())
        .collect();
    known.extend(own.iter().map(|a| a.joint.as_str()));
    for name in specs.keys() {
        if name == EVERY_ACTUATOR || known.contains(&name.as_str()) {
            continue;
        }
        let part_of_mechanism = mechanism.joint_index(name).is_some()
            || mechanism.wheels.iter().any(|w| &w.name == name);
        let what = if part_of_mechanism {
            format!("`{name}` is not an actuator (the URDF gives it no <limit effort>)")
        } else {
            format!("the URDF has no joint `{name}`")
        };
        return Err(MachineError::Actuator {
            key: key_of(specs, name),
            reason: format!(
                "{what}; name one of the machine's actuators ({}) or \"{EVERY_ACTUATOR}\"",
                known.join(", ")
            ),
        });
    }
    Ok(())
}
