//! `[actuators.<joint>]`: how the scenario has each actuator turn its command into the joint's
//! effort — through the machine's own drive (`kind = "drive"`, the default), or directly, as an
//! ideal drive (`kind = "effort"`: the command is the joint's torque, N·m, or force, N, clipped
//! to the URDF `<limit effort>`), or, on the generic machine, through one of the built-in
//! machines' drives from its data sheet:
//! - `kind = "dc-servo"` with `[actuators.<joint>.drive]`: the arm's DC servo drive
//!   ([`models::drive`]); the command is a current, A;
//! - `kind = "gear-motor"` with `[actuators.<joint>.motor]`: the platform's wheel motor
//!   ([`models::gear_motor`]); the command is a torque;
//! - `kind = "current-amplifier"` with `[actuators.<joint>.amplifier]`: the feed axis's amplifier
//!   and linear motor ([`models::current_amplifier`]); the command is a force (or torque).
//!
//! `[actuators."*"]` speaks for every actuator of the machine; a joint's own entry overrides it.

use super::error::MachineError;
use crate::mechanism::Mechanism;
use framework::Actuator;
use models::current_amplifier::AmplifierParams;
use models::drive::DriveParams;
use models::gear_motor::GearMotorParams;
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
    /// A DC gear motor from the entry's `motor` data (the generic machine's): the command is
    /// the joint's torque, turned into a current demand; the joint gets `N·k_t·i`.
    GearMotor,
    /// A static current amplifier and motor from the entry's `amplifier` data (the generic
    /// machine's): the command is the joint's force (or torque), its current clipped.
    CurrentAmplifier,
}

impl ActuatorKind {
    /// The kind as a scenario spells it.
    fn spelled(self) -> &'static str {
        match self {
            ActuatorKind::Drive => "drive",
            ActuatorKind::Effort => "effort",
            ActuatorKind::DcServo => "dc-servo",
            ActuatorKind::GearMotor => "gear-motor",
            ActuatorKind::CurrentAmplifier => "current-amplifier",
        }
    }

    /// The data sheet the kind needs, its key and fields; `None` for a kind that needs none.
    fn sheet(self) -> Option<(&'static str, &'static str)> {
        match self {
            ActuatorKind::Drive | ActuatorKind::Effort => None,
            ActuatorKind::DcServo => Some(("drive", "torque_constant, back_emf_constant, resistance, inductance, gear_ratio, supply_voltage, current_limit, current_bandwidth, current_loop_period")),
            ActuatorKind::GearMotor => Some(("motor", "gear_ratio, torque_constant, resistance, inductance, supply_voltage, current_limit")),
            ActuatorKind::CurrentAmplifier => Some(("amplifier", "amplifier_gain, force_constant, current_limit")),
        }
    }
}

/// One entry of `[actuators]`.
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorSpec {
    /// `drive` (the default), `effort`, `dc-servo`, `gear-motor` or `current-amplifier`.
    pub kind: ActuatorKind,
    /// A `dc-servo`'s data sheet (`[actuators.<joint>.drive]`, SI units).
    pub drive: Option<DriveParams>,
    /// A `gear-motor`'s data (`[actuators.<joint>.motor]`, SI units).
    pub motor: Option<GearMotorParams>,
    /// A `current-amplifier`'s data (`[actuators.<joint>.amplifier]`, SI units).
    pub amplifier: Option<AmplifierParams>,
}

impl ActuatorSpec {
    /// The data sheets the entry gives, by key.
    fn sheets(&self) -> impl Iterator<Item = &'static str> {
        [
            ("drive", self.drive.is_some()),
            ("motor", self.motor.is_some()),
            ("amplifier", self.amplifier.is_some()),
        ]
        .into_iter()
        .filter_map(|(key, given)| given.then_some(key))
    }
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

/// Refuses a drive from a data sheet on a machine with drives of its own (those are the generic
/// machine's), a kind without its data sheet, and a data sheet on an entry of another kind.
pub(super) fn check_kinds(specs: &ActuatorSpecs, generic: bool) -> Result<(), MachineError> {
    for (name, spec) in specs {
        let bad = |reason: String| MachineError::Actuator {
            key: format!("actuators.{}", quoted(name)),
            reason,
        };
        let kind = spec.kind.spelled();
        let needed = spec.kind.sheet();
        if needed.is_some() && !generic {
            return Err(bad(format!("kind = \"{kind}\" is the generic machine's: a built-in machine's drives are its own (\"drive\") or ideal (\"effort\")")));
        }
        if let Some((key, fields)) = needed.filter(|(key, _)| !spec.sheets().any(|k| k == *key)) {
            return Err(bad(format!(
                "kind = \"{kind}\" needs its data sheet: [actuators.<joint>.{key}] {fields}"
            )));
        }
        if let Some(extra) = spec
            .sheets()
            .find(|k| needed.is_none_or(|(key, _)| key != *k))
        {
            let owner = [
                ActuatorKind::DcServo,
                ActuatorKind::GearMotor,
                ActuatorKind::CurrentAmplifier,
            ]
            .into_iter()
            .find(|k| k.sheet().is_some_and(|(key, _)| key == extra))
            .map_or("", ActuatorKind::spelled);
            return Err(bad(format!(
                "a `{extra}` data sheet is for kind = \"{owner}\""
            )));
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
