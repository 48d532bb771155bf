//! The machine a run is built on: what its mechanism measures in its own words, the process
//! loads it suffers, its drives, its view, and the figures it is judged by.

use crate::mechanism::{Joint, JointMotion};
use crate::physics::{Load, MechanismState};
use crate::scene::Scene;
use framework::{Actuator, EffortKind, SignalSpec, Unit};

/// A machine built on a loaded mechanism.
pub trait Machine: Send {
    /// Task-space and process signals, measured (through the sensors) by the controller,
    /// recorded, each with its display unit and plot.
    fn signals(&self) -> Vec<SignalSpec>;

    /// Signals recorded for the engineer but not given to the controller (model checks).
    fn diagnostics(&self) -> Vec<SignalSpec> {
        Vec::new()
    }

    /// What the scenario's `[reference]` is a reference for: the units and plots of `reference`,
    /// `reference_rate` and `reference_acceleration`, or `None` when the machine has no output
    /// to track (a `[reference]` is then an error).
    fn reference(&self) -> Option<[SignalSpec; 3]> {
        None
    }

    /// How a movable joint's position and velocity are shown. The default: mm and mm/s for a
    /// slide, degrees (wrapped when the joint turns without limits) and rpm for a turning joint.
    fn joint_signals(&self, joint: &Joint) -> [SignalSpec; 2] {
        default_joint_signals(joint)
    }

    /// The unit of the effort the controller commands on `actuator`: N·m or N, unless the
    /// machine's drive takes another quantity (a current).
    fn command_unit(&self, actuator: &Actuator) -> Unit {
        effort_unit(actuator.kind)
    }

    /// The largest command on `actuator`, in its [`Machine::command_unit`]: larger ones are
    /// clipped to it. The actuator's effort limit, unless the drive takes another quantity.
    fn command_limit(&self, actuator: &Actuator) -> f64 {
        actuator.effort_limit
    }

    /// What the mechanism view shows besides the links: its fixed frame, what is machined, and
    /// the points traced as the run goes.
    fn scene(&self) -> Scene;

    /// Fills the true signal and diagnostic values for the state at `time`; called every step.
    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    );

    /// Joints the controller does not measure (they are still recorded): a planar base that only
    /// stands for the floor, say. Names as in the URDF.
    fn unmeasured_joints(&self) -> Vec<String> {
        Vec::new()
    }

    /// Actuators the machine provides besides the URDF's actuated joints (driven wheels). Their
    /// efforts follow the joints' in the controller's effort slice and in `drive`; the machine
    /// applies them itself (through `loads`).
    fn extra_actuators(&self) -> Vec<Actuator> {
        Vec::new()
    }

    /// The drives between controller and joints, stepped every physics step: turn each commanded
    /// effort (already clipped to the URDF limit, held between control periods) into the effort
    /// the joint receives — through an amplifier's current limit or a motor model — and keep
    /// their state (currents) for `measure`. The default is an ideal drive. A machine with drives
    /// of its own passes the command of an actuator the scenario makes ideal
    /// (`[actuators.<joint>] kind = "effort"`, given to its constructor) through as it is.
    fn drive(&mut self, _dt: f64, commanded: &[f64], applied: &mut [f64]) {
        applied.copy_from_slice(commanded);
    }

    /// Process loads (cutting, contact) acting during the coming step.
    fn loads(&mut self, _time: f64, _state: &MechanismState, _loads: &mut Vec<Load>) {}

    /// Scales the process forces from now on (a process fault: 0 a broken tool, k > 1 a hard
    /// spot); `false` when the machine has no cutting process to scale.
    fn set_process_factor(&mut self, _factor: f64) -> bool {
        false
    }

    /// Figures of the machine's process that need its own state (cuts made, contour finished),
    /// by name. Figures judged from signals are the scenario's `[[metrics]]`, computed by
    /// evaluators outside the machine.
    fn metrics(&self) -> Vec<(String, f64)>;

    /// What excites the machine's vibration at a multiple of a joint's speed (a mill's flutes),
    /// for the recording's spectra: their tooth-passing harmonics are marked and a peak between
    /// them is chatter. `None`: nothing periodic.
    fn excitation(&self) -> Option<Excitation> {
        None
    }

    /// The process's stability lobes, for the recording's lobe diagram. `None`: no regenerative
    /// process.
    fn stability(&self) -> Option<Stability> {
        None
    }
}

/// A vibration source turning with a joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Excitation {
    /// The signal of the joint's speed, rad/s (e.g. `spindle.velocity`).
    pub speed_signal: String,
    /// Impulses per revolution (a mill's flutes): the tooth-passing frequency is
    /// `per_revolution·|speed|/2π`.
    pub per_revolution: usize,
    /// The signal whose spectrum the recording shows when the scenario declares no spectral
    /// metric (the tool's displacement).
    pub vibration_signal: String,
}

/// The regenerative cut's stability problem ([`models::milling::stability`]) and where the
/// machine cuts in it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stability {
    pub tool: models::milling::stability::ToolModes,
    pub cut: models::milling::stability::CutGeometry,
    /// The run's axial depth of cut, m.
    pub axial_depth: f64,
    /// Speeds drawn when the scenario gives the spindle no initial speed, rad/s.
    pub speeds: [f64; 2],
}

/// The unit of an effort: N·m for a torque, N for a force.
pub fn effort_unit(kind: EffortKind) -> Unit {
    match kind {
        EffortKind::Torque => Unit::NewtonMetre,
        EffortKind::Force => Unit::Newton,
    }
}

/// A joint's position and velocity signals as [`Machine::joint_signals`] shows them by default.
/// A driven joint that turns without limits (a crank, a spindle) has its speed on a plot of its
/// own, `<joint> speed`, where the speed a controller commands joins it.
pub fn default_joint_signals(joint: &Joint) -> [SignalSpec; 2] {
    let own_speed = format!("{} speed", joint.name);
    let (position_unit, velocity_unit, positions, velocities) = match joint.motion {
        JointMotion::Prismatic { .. } => (
            Unit::Millimetre,
            Unit::MillimetrePerSecond,
            "joint positions",
            "joint velocities",
        ),
        _ if joint.limits.is_none() && joint.effort_limit.is_some() => (
            Unit::DegreeWrapped,
            Unit::Rpm,
            "joint angles, wrapped",
            own_speed.as_str(),
        ),
        _ if joint.limits.is_none() => (
            Unit::DegreeWrapped,
            Unit::Rpm,
            "joint angles, wrapped",
            "joint speeds",
        ),
        _ => (Unit::Degree, Unit::Rpm, "joint angles", "joint speeds"),
    };
    [
        SignalSpec::new(format!("{}.position", joint.name), position_unit, positions),
        SignalSpec::new(
            format!("{}.velocity", joint.name),
            velocity_unit,
            velocities,
        ),
    ]
}
