//! Actuators, one per driven joint: the command passes through the joint's transmission (its
//! `<mechanicalReduction>`), ideal, or through a motor: a DC servo drive (its command a current),
//! a DC gear motor, or a static current amplifier (their command an effort). The generic
//! machine's motors come from the scenario's data sheets (`[actuators.<joint>] kind =
//! "dc-servo"`, `"gear-motor"`, `"current-amplifier"`); the arm's servos and the feed axis's
//! amplifier are their own (`[process]`), written once here for all.

use super::actuators::{key_of, spec_of, ActuatorKind, ActuatorSpec, ActuatorSpecs};
use super::error::MachineError;
use crate::mechanism::Mechanism;
use crate::physics::MechanismState;
use framework::{Actuator, SignalSpec, Unit};
use models::current_amplifier::CurrentAmplifier;
use models::drive::Drive;
use models::gear_motor::GearMotor;

/// The motor between a joint's command and its effort.
pub(super) enum JointMotor {
    /// A DC servo drive: the command is a current, A.
    DcServo(Drive),
    /// A DC gear motor: the command is the joint's torque.
    GearMotor(GearMotor),
    /// A static current amplifier and motor: the command is the joint's effort.
    CurrentAmplifier(CurrentAmplifier),
}

impl JointMotor {
    /// The joint's effort over a step of `dt` from `command`, the joint moving at `speed`.
    fn step(&mut self, dt: f64, command: f64, speed: f64) -> f64 {
        match self {
            JointMotor::DcServo(servo) => servo.step(dt, command, speed),
            JointMotor::GearMotor(motor) => motor.step(dt, command, speed),
            JointMotor::CurrentAmplifier(amplifier) => amplifier.effort(command),
        }
    }

    /// The winding's (or amplifier's) current, A, and whether it was held at its limit.
    fn current(&self) -> (f64, bool) {
        match self {
            JointMotor::DcServo(servo) => (servo.current(), servo.at_limit()),
            JointMotor::GearMotor(motor) => (motor.current(), motor.at_limit()),
            JointMotor::CurrentAmplifier(amplifier) => (amplifier.current(), amplifier.at_limit()),
        }
    }

    /// The current limit of a motor whose command is a current.
    fn command_current_limit(&self) -> Option<f64> {
        match self {
            JointMotor::DcServo(servo) => Some(servo.params().current_limit),
            JointMotor::GearMotor(_) | JointMotor::CurrentAmplifier(_) => None,
        }
    }
}

/// One driven joint's actuator.
struct JointDrive {
    /// The joint's name and index.
    name: String,
    joint: usize,
    /// The transmission's reduction: the joint's effort is this times an ideal command.
    reduction: f64,
    /// The motor, when the joint has one.
    motor: Option<JointMotor>,
    /// The joint's speed at the last measurement, rad/s (m/s): the motor's back-EMF.
    speed: f64,
}

/// The driven joints' actuators, in actuator order.
pub(super) struct JointDrives(Vec<JointDrive>);

impl JointDrives {
    /// Each driven joint's actuator, its motor's data sheet checked.
    pub(super) fn new(mechanism: &Mechanism, specs: &ActuatorSpecs) -> Result<Self, MachineError> {
        let mut motors = Vec::new();
        for j in mechanism.actuated_joints() {
            let joint = &mechanism.joints[j];
            let motor = match spec_of(specs, &joint.name) {
                Some(spec) => motor(spec, joint.reduction, &key_of(specs, &joint.name))?,
                None => None,
            };
            motors.push((j, motor));
        }
        Ok(Self::with_motors(mechanism, motors))
    }

    /// The actuators of `joints` (in actuator order) with the motors a machine brings, `None`
    /// where a joint's drive is ideal; each takes its joint's transmission reduction.
    pub(super) fn with_motors(
        mechanism: &Mechanism,
        motors: Vec<(usize, Option<JointMotor>)>,
    ) -> Self {
        let drives = (motors.into_iter())
            .map(|(j, motor)| JointDrive {
                name: mechanism.joints[j].name.clone(),
                joint: j,
                reduction: mechanism.joints[j].reduction,
                motor,
                speed: 0.0,
            })
            .collect();
        Self(drives)
    }

    /// Each actuator's motor current, A (0 for an ideal one), and whether it is held at its
    /// limit, in actuator order.
    pub(super) fn currents(&self) -> impl Iterator<Item = (f64, bool)> + '_ {
        (self.0.iter()).map(|d| d.motor.as_ref().map_or((0.0, false), JointMotor::current))
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

    /// A motor's current, one signal each, `<joint>.current` (A).
    pub(super) fn signals(&self) -> Vec<SignalSpec> {
        (self.0.iter().filter(|d| d.motor.is_some()))
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
        let motors = self.0.iter().filter_map(|d| d.motor.as_ref());
        for (signal, motor) in signals.iter_mut().zip(motors) {
            *signal = motor.current().0;
        }
    }

    /// A DC servo's command is a current (A); any other actuator's the effort it is given.
    pub(super) fn command_unit(&self, actuator: &Actuator) -> Option<Unit> {
        let motor = self.of(actuator)?.motor.as_ref()?;
        motor.command_current_limit().map(|_| Unit::Ampere)
    }

    /// A DC servo's current limit; a motor's the effort limit; an ideal actuator's effort limit
    /// less its reduction.
    pub(super) fn command_limit(&self, actuator: &Actuator) -> f64 {
        match self.of(actuator) {
            Some(JointDrive {
                motor: Some(motor), ..
            }) => (motor.command_current_limit()).unwrap_or(actuator.effort_limit),
            Some(drive) => actuator.effort_limit / drive.reduction.abs(),
            None => actuator.effort_limit,
        }
    }

    /// Each joint's effort over the coming step from its command.
    pub(super) fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        for (drive, (out, &command)) in self.0.iter_mut().zip(applied.iter_mut().zip(commanded)) {
            *out = match &mut drive.motor {
                Some(motor) => motor.step(dt, command, drive.speed),
                None => drive.reduction * command,
            };
        }
    }
}

/// The motor of the entry `key` (`spec`), from its data sheet; `None` for an ideal drive. A motor's
/// gear ratio stands for the transmission's.
fn motor(
    spec: &ActuatorSpec,
    reduction: f64,
    key: &str,
) -> Result<Option<JointMotor>, MachineError> {
    let bad = |reason: String| MachineError::Actuator {
        key: key.to_string(),
        reason,
    };
    let missing = |sheet: &str| bad(format!("this kind needs its [{key}.{sheet}] data sheet"));
    let motor = match spec.kind {
        ActuatorKind::Drive | ActuatorKind::Effort => return Ok(None),
        ActuatorKind::DcServo => {
            let params = spec.drive.ok_or_else(|| missing("drive"))?;
            JointMotor::DcServo(Drive::new(params).map_err(|e| bad(format!("drive: {e}")))?)
        }
        ActuatorKind::GearMotor => {
            let params = spec.motor.ok_or_else(|| missing("motor"))?;
            let motor = GearMotor::new(params).map_err(|e| bad(format!("motor.{e}")))?;
            JointMotor::GearMotor(motor)
        }
        ActuatorKind::CurrentAmplifier => {
            let params = spec.amplifier.ok_or_else(|| missing("amplifier"))?;
            let amplifier =
                (CurrentAmplifier::new(params)).map_err(|e| bad(format!("amplifier.{e}")))?;
            JointMotor::CurrentAmplifier(amplifier)
        }
    };
    if reduction != 1.0 {
        return Err(bad(format!(
            "the joint's <transmission> has a reduction of {reduction}: the motor's own data give \
             its effort per ampere (leave mechanicalReduction out, or at 1)"
        )));
    }
    Ok(Some(motor))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pendulum on `shoulder` whose transmission has the reduction `reduction`.
    fn pendulum(reduction: f64) -> Mechanism {
        let urdf = format!(
            r#"<robot name="p">
  <link name="base"/>
  <link name="bar"><inertial><origin xyz="0 -0.2 0"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="bar"/>
    <axis xyz="0 0 1"/></joint>
  <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface></joint>
    <actuator name="m"><mechanicalReduction>{reduction}</mechanicalReduction></actuator>
  </transmission>
</robot>"#
        );
        crate::urdf::load_str(&urdf, "p.urdf").expect("urdf")
    }

    /// A motor's data give its effort per ampere: a transmission's reduction besides is refused,
    /// naming the entry; an ideal drive takes the reduction.
    #[test]
    fn a_motor_behind_a_reduction_is_refused_and_an_ideal_drive_takes_it() {
        let amplifier = "[shoulder]\nkind = \"current-amplifier\"\n[shoulder.amplifier]\n\
                         amplifier_gain = 2.0\nforce_constant = 5.0\ncurrent_limit = 10.0\n";
        let specs: ActuatorSpecs = toml::from_str(amplifier).expect("toml");
        let Err(error) = JointDrives::new(&pendulum(50.0), &specs) else {
            panic!("a reduction of 50 behind a motor was taken");
        };
        let message = error.to_string();
        assert!(
            message.contains("actuators.shoulder") && message.contains("reduction of 50"),
            "{message}"
        );
        let mut drives = JointDrives::new(&pendulum(1.0), &specs).expect("drives");
        let mut applied = [0.0];
        drives.drive(1e-3, &[60.0], &mut applied);
        assert_eq!(applied, [50.0]);
        assert_eq!(drives.currents().next(), Some((10.0, true)));
        let mut ideal = JointDrives::new(&pendulum(50.0), &ActuatorSpecs::new()).expect("drives");
        ideal.drive(1e-3, &[0.5], &mut applied);
        assert_eq!(applied, [25.0]);
    }
}
