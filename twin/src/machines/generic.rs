//! The generic machine: any planar mechanism the twin accepts, with nothing of its own but what
//! the scenario names. Its signals are the joints' (as every machine's) and the task-space
//! points of `[points.<name>]` ([`super::points`]), which may carry loads. Its actuators are the
//! URDF's driven joints, ideal unless the scenario says otherwise ([`super::actuators`]).

use super::actuators::ActuatorSpecs;
use super::error::MachineError;
use super::joint_drives::JointDrives;
use super::machine::effort_unit;
use super::machine::Machine;
use super::points::{PointSpecs, Points};
use crate::mechanism::Mechanism;
use crate::physics::{Load, MechanismState};
use crate::scene::{Bounds, Scene};
use framework::{Actuator, SignalSpec, Unit};

/// The machine's name in a scenario (`machine = "generic"`, or no `machine` at all).
pub const GENERIC: &str = "generic";

pub struct Generic {
    points: Points,
    /// The driven joints' actuators: through their transmission, or a DC servo.
    drives: JointDrives,
    /// The view: wide enough for every link turned any way about the base.
    bounds: Bounds,
}

impl Generic {
    pub fn new(
        mechanism: &Mechanism,
        points: &PointSpecs,
        actuators: &ActuatorSpecs,
    ) -> Result<Self, MachineError> {
        Ok(Self {
            points: Points::new(GENERIC, mechanism, points)?,
            drives: JointDrives::new(mechanism, actuators)?,
            bounds: reach(mechanism),
        })
    }
}

/// A square about the world origin holding every link's shapes turned any way about it, with a
/// margin: a tree swinging about its base stays in view.
fn reach(mechanism: &Mechanism) -> Bounds {
    let poses = mechanism.zero_pose();
    let radius = (mechanism.links.iter().zip(&poses))
        .flat_map(|(link, pose)| {
            (link.visuals.iter()).flat_map(|shape| shape.extent().map(|[x, y]| pose.apply(x, y)))
        })
        .chain(poses.iter().map(|p| [p.x, p.y]))
        .map(|[x, y]| x.hypot(y))
        .fold(0.1_f64, f64::max);
    let r = 1.1 * radius;
    Bounds {
        x: [-r, r],
        y: [-r, r],
    }
}

impl Machine for Generic {
    fn signals(&self) -> Vec<SignalSpec> {
        let mut specs = self.points.signals();
        specs.extend(self.drives.signals());
        specs
    }

    /// A DC servo's command is a current, A; an ideal actuator's its effort.
    fn command_unit(&self, actuator: &Actuator) -> Unit {
        (self.drives.command_unit(actuator)).unwrap_or_else(|| effort_unit(actuator.kind))
    }

    /// A DC servo's current limit; an ideal actuator's effort limit less its reduction.
    fn command_limit(&self, actuator: &Actuator) -> f64 {
        self.drives.command_limit(actuator)
    }

    /// Through each transmission, or each DC servo.
    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        self.drives.drive(dt, commanded, applied);
    }

    fn scene(&self) -> Scene {
        Scene {
            title: "mechanism (m, y up)".into(),
            bounds: self.bounds,
            drawings: Vec::new(),
            markers: self.points.markers(),
        }
    }

    fn measure(
        &mut self,
        _time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        _diagnostics: &mut [f64],
    ) {
        let (points, drives) = signals.split_at_mut(self.points.signal_count());
        self.points.measure(state, points);
        self.drives.measure(state, drives);
    }

    fn loads(&mut self, time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        self.points.loads(time, state, loads);
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        Vec::new()
    }
}
