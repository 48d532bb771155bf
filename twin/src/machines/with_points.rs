//! A built-in machine with the scenario's `[points]` beside its own signals: the points'
//! signals follow the machine's, their loads join its process loads, their markers its view;
//! everything else is the machine's. With no points the machine is built as it is, so its
//! recordings do not change.

use super::machine::{Excitation, Machine, Stability};
use super::points::Points;
use crate::mechanism::Joint;
use crate::physics::{Load, MechanismState};
use crate::scene::Scene;
use framework::{Actuator, SignalSpec, Unit};

/// `machine` and `points`, measured and loaded together.
pub(super) struct WithPoints {
    machine: Box<dyn Machine>,
    points: Points,
    /// How many signals the machine gives itself (the points' follow).
    own: usize,
}

impl WithPoints {
    pub(super) fn new(machine: Box<dyn Machine>, points: Points) -> Self {
        let own = machine.signals().len();
        Self {
            machine,
            points,
            own,
        }
    }
}

impl Machine for WithPoints {
    fn signals(&self) -> Vec<SignalSpec> {
        let mut specs = self.machine.signals();
        specs.extend(self.points.signals());
        specs
    }

    fn diagnostics(&self) -> Vec<SignalSpec> {
        self.machine.diagnostics()
    }

    fn reference(&self) -> Option<[SignalSpec; 3]> {
        self.machine.reference()
    }

    fn joint_signals(&self, joint: &Joint) -> [SignalSpec; 2] {
        self.machine.joint_signals(joint)
    }

    fn command_unit(&self, actuator: &Actuator) -> Unit {
        self.machine.command_unit(actuator)
    }

    fn command_limit(&self, actuator: &Actuator) -> f64 {
        self.machine.command_limit(actuator)
    }

    fn scene(&self) -> Scene {
        let mut scene = self.machine.scene();
        scene.markers.extend(self.points.markers());
        scene
    }

    fn measure(
        &mut self,
        time: f64,
        state: &MechanismState,
        signals: &mut [f64],
        diagnostics: &mut [f64],
    ) {
        let (own, points) = signals.split_at_mut(self.own);
        self.machine.measure(time, state, own, diagnostics);
        self.points.measure(state, points);
    }

    fn unmeasured_joints(&self) -> Vec<String> {
        self.machine.unmeasured_joints()
    }

    fn extra_actuators(&self) -> Vec<Actuator> {
        self.machine.extra_actuators()
    }

    fn drive(&mut self, dt: f64, commanded: &[f64], applied: &mut [f64]) {
        self.machine.drive(dt, commanded, applied);
    }

    fn loads(&mut self, time: f64, state: &MechanismState, loads: &mut Vec<Load>) {
        self.machine.loads(time, state, loads);
        self.points.loads(time, state, loads);
    }

    fn set_process_factor(&mut self, factor: f64) -> bool {
        self.machine.set_process_factor(factor)
    }

    fn metrics(&self) -> Vec<(String, f64)> {
        self.machine.metrics()
    }

    fn excitation(&self) -> Option<Excitation> {
        self.machine.excitation()
    }

    fn stability(&self) -> Option<Stability> {
        self.machine.stability()
    }
}
