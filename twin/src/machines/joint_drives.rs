//! Actuators, one per driven joint: the command passes through the joint's transmission (its
//! `<mechanicalReduction>`), ideal, or through a DC servo drive, whose command is a current. The
//! generic machine's servos come from the scenario's data sheet (`[actuators.<joint>] kind =
//! "dc-servo"`); the arm's are its own (`[process.drives]`), written once here for both.

use super::actuators::{key_of, spec_of, ActuatorKind, ActuatorSpecs};
use super::error::MachineError;
use crate::mechanism::Mechanism;
use crate::physics::MechanismState;
use framework::{Actuator, SignalSpec, Unit};
use models::drive::Drive;

/// One driven joint's actuator.
struct JointDrive {
    /// The joint's name and index.
    name: String,
    joint: usize,
    /// The transmission's reduction: the joint's effort is this times an ideal command.
    reduction: f64,
    /// The DC servo, when the scenario gives one.
    servo: Option<Drive>,
    /// The joint's speed at the last measurement, rad/s (m/s): the servo's back-EMF.
    speed: f64,
}

/// The driven joints' actuators, in actuator order.
pub(super) struct JointDrives(Vec<JointDrive>);

impl JointDrives {
    /// Each driven joint's actuator, its DC servo checked.
    pub(super) fn new(mechanism: &Mechanism, specs: &ActuatorSpecs) -> Result<Self, MachineError> {
        let mut drives = Vec::new();
        for j in mechanism.actuated_joints() {
            let joint = &mechanism.joints[j];
            let spec = spec_of(specs, &joint.name);
            let servo = match spec.filter(|s| s.kind == ActuatorKind::DcServo) {
                Some(spec) => Some(servo(
                    spec.drive,
                    joint.reduction,
                    &key_of(specs, &joint.name),
                )?),
                None => None,
            };
            drives.push(JointDrive {
                name: joint.name.clone(),
                joint: j,
                reduction: joint.reduction,
                servo,
                speed: 0.0,
            });
        }
        Ok(Self(drives))
    }

    /// The actuators of `joints` (in actuator order) with the DC servos a machine brings,
    /// `None` where a joint's drive is ideal; each takes its joint's transmission reduction.
    pub(super) fn with_servos(mechanism: &Mechanism, servos: Vec<(usize, Option<Drive>)>) -> Self {
        let drives = (servos.into_iter())
            .map(|(j, servo)| JointDrive {
                name: mechanism.joints[j].name.clone(),
                joint: j,
                reduction: mechanism.joints[j].reduction,
                servo,
                speed: 0.0,
            })
            .collect();
        Self(drives)
    }

    /// Each actuator's winding current, A (0 for an ideal one), and whether its current loop
    /// is at its limit, in actuator order.
    pub(super) fn currents(&self) -> impl Iterator<Item = (f64, bool)> + '_ {
        (self.0.iter()).map(|d| {
            d.servo
                .as_ref()
                .map_or((0.0, false), |s| (s.current(), s.at_limit()))
        })
    }

    /// Keeps each joint's speed for the drives' back-EMF.
    pub(super) fn observe_speeds(&mut self, state: &MechanismState) {
        for drive in &mut self.0 {
            drive.speed = state.joint_velocities[drive.joint];
        }
    }

    /// Sets the joints' speeds the drives see, in actuator order (a test's state).
    #[cfg(test)]
    pub(super) fn set_speeds(&mut self, speeds: &[f64]) {
        for (drive, &speed) in self.0.iter_mut().zip(speeds) {
            drive.speed = speed;
        }
    }

    fn of(&self, actuator: &Actuator) -> Option<&JointDrive> {
        self.0.iter().find(|d| d.name == actuator.joint)
    }

    /// A servo's winding current, one signal each, `<joint>.current` (A).
    pub(super) fn signals(&self) -> Vec<SignalSpec> {
        (self.0.iter().filter(|d| d.servo.is_some()))
            .map(|d| {
                SignalSpec::new(
                    format!("{}.current", d.name),
                    Unit::Ampere,
                    "drive currents",
                )
            })
            .collect()
    }

    /// Fills [`JointDrives::signals`] and keeps each joint's speed for the drives' back-EMF.
    pub(super) fn measure(&mut self, state: &MechanismState, signals: &mut [f64]) {
        self.observe_speeds(state);
        let servos = self.0.iter().filter_map(|d| d.servo.as_ref());
        for (signal, servo) in signals.iter_mut().zip(servos) {
            *signal = servo.current();
        }
    }

    /// A servo's command is a current (A); an ideal actuator's the effort it is given.
    pub(super) fn command_unit(&self, actuator: &Actuator) -> Option<Unit> {
        (self.of(actuator)?.servo.as_ref()).map(|_| Unit::Ampere)
    }

    /// A servo's current limit; an ideal actuator's effort limit less its reduction.
    pub(super) fn command_limit(&self, actuator: &Actuator) -> f64 {
        match self.of(actuator) {
            Some(JointDrive {
                servo: Some(servo), ..
            }) => servo.params().current_limit,
            Some(drive) => actuator.effort_limit / drive.reduction.abs(),
            None => actuator.effort_limit,
        }
    }

    /// Each joint's effort over the coming step from its command.
    pub(super) fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        for (drive, (out, &command)) in self.0.iter_mut().zip(applied.iter_mut().zip(commanded)) {
            *out = match &mut drive.servo {
                Some(servo) => servo.step(dt, command, drive.speed),
                None => drive.reduction * command,
            };
        }
    }
}

/// A DC servo from the entry `key`'s data sheet; its gear ratio stands for the transmission's.
fn servo(
    params: Option<models::drive::DriveParams>,
    reduction: f64,
    key: &str,
) -> Result<Drive, MachineError> {
    let bad = |reason: String| MachineError::Actuator {
        key: key.to_string(),
        reason,
    };
    let params =
        params.ok_or_else(|| bad("kind = \"dc-servo\" needs its [drive] data sheet".into()))?;
    if reduction != 1.0 {
        return Err(bad(format!(
            "the joint's <transmission> has a reduction of {reduction}: a dc-servo's gear_ratio is the \
             transmission's (leave mechanicalReduction out, or at 1)"
        )));
    }
    Drive::new(params).map_err(|e| bad(format!("drive: {e}")))
}
