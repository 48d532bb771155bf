//! Where each value of a run lives: the names behind every slice a step carries, and the index
//! arithmetic between the mechanism's joints, the plant's signals and the diagnostics.

use crate::mechanism::Mechanism;
use crate::physics::MechanismState;
use framework::{SignalSpec, Unit};
use std::ops::Range;

/// The names of everything a run carries per step, fixed before the first step. Every slice in
/// a [`StepView`](super::StepView) follows the order of the matching list here.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalLayout {
    /// Movable joints (all recorded), in tree order.
    pub joints: Vec<String>,
    /// The plant's signals, as the controller measures them: `<joint>.position` and
    /// `<joint>.velocity` of each sensed joint, the machine's task-space and process signals,
    /// then `reference`, `reference_rate`, `reference_acceleration` when the scenario has one.
    pub signals: Vec<String>,
    /// Actuated joints (and the machine's own actuators, e.g. driven wheels).
    pub actuators: Vec<String>,
    /// The controller's internal signals.
    pub internals: Vec<String>,
    /// Model checks recorded beside the signals: the machine's, one `loop_gap/<loop>` per loop
    /// closure, and `mechanical_energy` last.
    pub diagnostics: Vec<String>,
    /// How each of these is shown (unit and plot), list by list.
    pub specs: LayoutSpecs,
    /// Tree joint index of each movable joint.
    movable: Vec<usize>,
    /// Tree joint index of each sensed joint (its position and velocity lead `signals`).
    sensed: Vec<usize>,
    machine_signals: Range<usize>,
    /// Start of the reference triple in `signals`.
    reference: Option<usize>,
    machine_diagnostics: usize,
    loops: usize,
}

/// The units and plots of a [`SignalLayout`]'s values, parallel to its name lists.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LayoutSpecs {
    /// Per movable joint: its position and velocity.
    pub joints: Vec<[SignalSpec; 2]>,
    pub signals: Vec<SignalSpec>,
    /// Per actuator: the unit of the effort commanded and of the effort applied.
    pub efforts: Vec<[Unit; 2]>,
    pub internals: Vec<SignalSpec>,
    pub diagnostics: Vec<SignalSpec>,
}

/// The parts of the layout the twin knows before it binds a controller.
pub(super) struct LayoutParts {
    pub movable: Vec<usize>,
    pub sensed: Vec<usize>,
    /// Per movable joint, its position and velocity specs.
    pub joint_specs: Vec<[SignalSpec; 2]>,
    pub machine_signals: Vec<SignalSpec>,
    /// The units and plots of the reference triple, when the scenario has one.
    pub reference: Option<[SignalSpec; 3]>,
    pub actuators: Vec<String>,
    /// Per actuator: commanded and applied effort units.
    pub effort_units: Vec<[Unit; 2]>,
    pub machine_diagnostics: Vec<SignalSpec>,
}

impl SignalLayout {
    pub(super) fn new(mechanism: &Mechanism, parts: LayoutParts) -> Self {
        let joint_spec = |j: usize| {
            let k = parts.movable.iter().position(|&m| m == j);
            k.map(|k| parts.joint_specs[k].clone())
        };
        let mut signal_specs: Vec<SignalSpec> = parts
            .sensed
            .iter()
            .filter_map(|&j| joint_spec(j))
            .flatten()
            .collect();
        let machine_start = signal_specs.len();
        signal_specs.extend(parts.machine_signals);
        let machine_signals = machine_start..signal_specs.len();
        let reference = parts.reference.is_some().then_some(signal_specs.len());
        signal_specs.extend(parts.reference.into_iter().flatten());
        let machine_diagnostics = parts.machine_diagnostics.len();
        let mut diagnostic_specs = parts.machine_diagnostics;
        diagnostic_specs.extend(mechanism.loops.iter().map(|l| {
            SignalSpec::new(
                format!("loop_gap/{}", l.name),
                Unit::Micrometre,
                "loop gaps",
            )
        }));
        diagnostic_specs.push(SignalSpec::new(
            "mechanical_energy",
            Unit::Joule,
            "mechanical energy",
        ));
        Self {
            joints: parts
                .movable
                .iter()
                .map(|&j| mechanism.joints[j].name.clone())
                .collect(),
            signals: framework::signal_names(&signal_specs),
            actuators: parts.actuators,
            internals: Vec::new(),
            diagnostics: framework::signal_names(&diagnostic_specs),
            specs: LayoutSpecs {
                joints: parts.joint_specs,
                signals: signal_specs,
                efforts: parts.effort_units,
                internals: Vec::new(),
                diagnostics: diagnostic_specs,
            },
            movable: parts.movable,
            sensed: parts.sensed,
            machine_signals,
            reference,
            machine_diagnostics,
            loops: mechanism.loops.len(),
        }
    }

    /// Sets the controller's internals (known once it is bound).
    pub(super) fn set_internals(&mut self, specs: Vec<SignalSpec>) {
        self.internals = framework::signal_names(&specs);
        self.specs.internals = specs;
    }

    /// Index of a plant signal by name.
    pub fn signal(&self, name: &str) -> Option<usize> {
        self.signals.iter().position(|s| s == name)
    }

    /// Index among [`SignalLayout::actuators`] of the actuator at `joint` (or so named).
    pub fn actuator(&self, joint: &str) -> Option<usize> {
        self.actuators.iter().position(|s| s == joint)
    }

    /// Index of a controller internal by name.
    pub fn internal(&self, name: &str) -> Option<usize> {
        self.internals.iter().position(|s| s == name)
    }

    /// Index of a diagnostic by name.
    pub fn diagnostic(&self, name: &str) -> Option<usize> {
        self.diagnostics.iter().position(|s| s == name)
    }

    /// Where the machine's own signals are among the plant's signals.
    pub(crate) fn machine_signal_range(&self) -> Range<usize> {
        self.machine_signals.clone()
    }

    /// Where the reference triple is among the plant's signals (empty without one).
    pub(crate) fn reference_range(&self) -> Range<usize> {
        self.reference.map_or(0..0, |start| start..start + 3)
    }

    /// Tree joint index of each movable joint, in the order of `joints`.
    pub fn movable_joints(&self) -> &[usize] {
        &self.movable
    }

    /// Loop closures of the mechanism (one `loop_gap/<loop>` diagnostic each).
    pub fn loop_count(&self) -> usize {
        self.loops
    }

    /// The mechanical energy within the diagnostics, J.
    pub fn mechanical_energy(&self, diagnostics: &[f64]) -> f64 {
        diagnostics[diagnostics.len() - 1]
    }

    /// The tree joint whose position is plant signal `signal`, if it is one.
    pub(crate) fn position_joint(&self, signal: usize) -> Option<usize> {
        signal
            .is_multiple_of(2)
            .then(|| self.sensed.get(signal / 2).copied())
            .flatten()
    }

    /// Copies the sensed joints' positions and velocities into the head of `signals`.
    pub(crate) fn fill_joint_signals(&self, state: &MechanismState, signals: &mut [f64]) {
        for (k, &j) in self.sensed.iter().enumerate() {
            signals[2 * k] = state.joint_positions[j];
            signals[2 * k + 1] = state.joint_velocities[j];
        }
    }

    /// The machine's signal slice (to fill) and the reference triple, if any.
    pub(crate) fn machine_and_reference<'a>(
        &self,
        signals: &'a mut [f64],
    ) -> (&'a mut [f64], Option<&'a mut [f64]>) {
        let (head, tail) = signals.split_at_mut(self.machine_signals.end);
        let machine = &mut head[self.machine_signals.start..];
        (machine, self.reference.map(|_| &mut tail[..3]))
    }

    /// The machine's diagnostics, the loop gaps and the mechanical energy, to fill.
    pub(crate) fn split_diagnostics<'a>(
        &self,
        diagnostics: &'a mut [f64],
    ) -> (&'a mut [f64], &'a mut [f64], &'a mut f64) {
        let (machine, rest) = diagnostics.split_at_mut(self.machine_diagnostics);
        let (gaps, energy) = rest.split_at_mut(self.loops);
        (machine, gaps, &mut energy[0])
    }
}
