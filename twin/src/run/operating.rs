//! `Twin::linearize`: the scenario run with its controller to an operating time, the efforts
//! held there, and the plant linearised about that state ([`crate::linear`]).

use super::layout::SignalLayout;
use super::observer::{Observer, ObserverError, StepView};
use super::session::Session;
use super::summary::Divergence;
use super::twin::TwinError;
use super::twin::{build_machine, Twin};
use crate::linear::{self, Channel, Description, LinearModel, ModelError, Plant};
use crate::machines::Machine;
use crate::mechanism::{JointMotion, Mechanism};
use crate::physics::{Load, MechanismState, ReducedDynamics};
use framework::EffortKind;
use thiserror::Error;

/// A machine signal counts as the same value to this share (of max(|value|, 1)).
const SAME_VALUE: f64 = 1e-9;

/// Why a scenario could not be linearised.
#[derive(Debug, Error)]
pub enum LinearizeError {
    /// The operating time is not in the run.
    #[error("{at} s: {reason}")]
    At {
        /// The operating time asked for, s.
        at: f64,
        /// What is wrong with it: not finite, negative or past the scenario's duration.
        reason: String,
    },
    /// The scenario could not be bound or the run up to the operating time failed.
    #[error(transparent)]
    Twin(#[from] TwinError),
    /// The run diverged or crashed before reaching the operating time.
    #[error("the run diverged before the operating time {at} s: {failure}")]
    Diverged {
        /// The operating time asked for, s.
        at: f64,
        /// Where and why the run failed.
        failure: Divergence,
    },
    /// A machine whose actuators are not joints (driven wheels with their own spin states).
    #[error("{scenario}: machine `{machine}` drives {actuators} through states of its own (not joints), which a linear model of the mechanism lacks")]
    OwnActuators {
        /// Where the scenario came from.
        scenario: String,
        /// The machine kind, e.g. `platform`.
        machine: String,
        /// The machine's own actuators, comma-separated.
        actuators: String,
    },
    /// The Jacobians at the operating point make no model.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// A model's parts, from [`Twin::model_parts`].
pub(crate) struct ModelParts {
    /// The mechanism, with the scenario's plant values.
    pub mechanism: Mechanism,
    /// A fresh machine (drives, process, signals).
    pub machine: Box<dyn Machine>,
    /// The run's names and units.
    pub layout: SignalLayout,
    /// Tree joint of each actuator.
    pub actuated: Vec<usize>,
    /// Per actuator, the largest command.
    pub command_limits: Vec<f64>,
    /// The mechanism's initial state.
    pub state: MechanismState,
    /// The scenario.
    pub scenario: crate::scenario::Scenario,
}

/// The last step a run showed: the operating point.
#[derive(Default)]
struct Capture {
    time: f64,
    state: MechanismState,
    signals: Vec<f64>,
    applied: Vec<f64>,
}

impl Observer for Capture {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.last {
            self.time = view.time;
            self.state.clone_from(view.state);
            self.signals = view.signals.to_vec();
            self.applied = view.applied.to_vec();
        }
        Ok(())
    }
}

impl Twin {
    /// Runs the scenario with its controller to `at` (s, rounded to the physics step; 0: its
    /// initial state), holds the efforts the drives apply there and linearises the plant about
    /// that state with the exact engine's equations of motion (whatever engine ran to it).
    pub fn linearize(mut self, at: f64) -> Result<LinearModel, LinearizeError> {
        let scenario = &self.loaded.scenario;
        let reason = if !at.is_finite() {
            Some("must be a finite time".to_string())
        } else if at < 0.0 {
            Some("must be ≥ 0".to_string())
        } else if at > scenario.duration + 0.5 * scenario.dt {
            Some(format!(
                "is beyond the scenario's duration, {} s; give a time within it or raise duration",
                scenario.duration
            ))
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(LinearizeError::At { at, reason });
        }
        self.own_actuators()?;
        let capture = self.capture(at)?;
        self.linearize_at(&capture)
    }

    /// Runs the scenario with its controller to `at` (s, rounded to the physics step) and
    /// captures the last step.
    fn capture(&mut self, at: f64) -> Result<Capture, LinearizeError> {
        let scenario = &self.loaded.scenario;
        self.loaded.scenario.duration = (at / scenario.dt).round() * scenario.dt;
        let mut capture = Capture::default();
        let ending = Session::new(&mut *self).run(&mut [&mut capture])?;
        if let Some(failure) = ending.failure {
            return Err(LinearizeError::Diverged { at, failure });
        }
        Ok(capture)
    }

    /// The parts of a model of the plant beside a machine (a shadow's filter): the mechanism at
    /// the scenario's initial state, a fresh machine, the layout and the actuators. Refuses, as
    /// [`Twin::linearize`] does, a machine whose actuators are not all joints.
    pub(crate) fn model_parts(self) -> Result<ModelParts, LinearizeError> {
        self.own_actuators()?;
        self.start_parts()
    }

    /// The parts of a model at the scenario's initial state, whatever drives the machine's
    /// actuators: what a calibration needs to place the mechanism where its data say (its
    /// joints and loops), not to integrate it.
    pub(crate) fn start_parts(mut self) -> Result<ModelParts, LinearizeError> {
        let capture = self.capture(0.0)?;
        let scenario = &self.loaded.scenario;
        let machine =
            build_machine(scenario, &self.mechanism).map_err(|source| TwinError::Machine {
                scenario: self.loaded.source.clone(),
                urdf: self.loaded.urdf_source.clone(),
                source,
            })?;
        Ok(ModelParts {
            machine,
            state: capture.state,
            mechanism: self.mechanism,
            layout: self.layout,
            actuated: self.actuated,
            command_limits: self.command_limits,
            scenario: self.loaded.scenario,
        })
    }

    /// Refuses a machine that drives some of its actuators through states of its own.
    fn own_actuators(&self) -> Result<(), LinearizeError> {
        if self.plant.actuators.len() > self.actuated.len() {
            let own = &self.plant.actuators[self.actuated.len()..];
            return Err(LinearizeError::OwnActuators {
                scenario: self.loaded.source.clone(),
                machine: self.loaded.scenario.machine.clone(),
                actuators: own
                    .iter()
                    .map(|a| a.joint.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        Ok(())
    }

    /// The linear model about the captured step.
    fn linearize_at(&mut self, point: &Capture) -> Result<LinearModel, LinearizeError> {
        let scenario = &self.loaded.scenario;
        let mut loads: Vec<Load> = Vec::new();
        self.machine.loads(point.time, &point.state, &mut loads);
        let mut dynamics = ReducedDynamics::new(
            &self.mechanism,
            scenario.gravity,
            &point.state,
            &loads,
            &self.actuated,
        );
        let x0 = dynamics.operating_state();
        let coordinates = dynamics.coordinates();
        let (kept, outputs_left_out) = self.state_signals(point);
        let layout = &self.layout;
        let build = || build_machine(scenario, &self.mechanism).ok();
        let mut all = vec![0.0; layout.signals.len()];
        let mut diagnostics = vec![0.0; layout.specs.diagnostics.len()];
        let mut outputs = |state: &MechanismState, values: &mut Vec<f64>| {
            all.fill(f64::NAN);
            layout.fill_joint_signals(state, &mut all);
            if let Some(mut machine) = build() {
                let (signals, _) = layout.machine_and_reference(&mut all);
                let (machine_diagnostics, _, _) = layout.split_diagnostics(&mut diagnostics);
                machine.measure(point.time, state, signals, machine_diagnostics);
            }
            values.clear();
            values.extend(kept.iter().map(|&i| all[i]));
        };
        let mut plant = Plant {
            dynamics: &mut dynamics,
            input_joints: &self.actuated,
            joints: self.mechanism.joints.len(),
            outputs: &mut outputs,
        };
        let jacobians =
            linear::differentiate(&mut plant, &x0, &point.applied).map_err(ModelError::from)?;
        let (states, inputs, outputs) = self.channels(&coordinates, &kept);
        let description = Description {
            scenario: scenario.name.clone(),
            states,
            inputs,
            outputs,
            outputs_left_out,
            control_period: scenario.control_period(),
            time: point.time,
            x0,
            u0: point.applied.clone(),
        };
        Ok(LinearModel::assemble(description, jacobians)?)
    }

    /// The names and SI units of the states (positions, then velocities of the independent
    /// `coordinates`), the inputs (the actuators) and the `kept` outputs.
    fn channels(
        &self,
        coordinates: &[usize],
        kept: &[usize],
    ) -> (Vec<Channel>, Vec<Channel>, Vec<Channel>) {
        let joint_channel = |j: usize, rate: bool| {
            let joint = &self.mechanism.joints[j];
            let slide = matches!(joint.motion, JointMotion::Prismatic { .. });
            let (quantity, unit) = match (rate, slide) {
                (false, true) => ("position", "m"),
                (false, false) => ("position", "rad"),
                (true, true) => ("velocity", "m/s"),
                (true, false) => ("velocity", "rad/s"),
            };
            Channel {
                name: format!("{}.{quantity}", joint.name),
                unit,
            }
        };
        let states = [false, true]
            .into_iter()
            .flat_map(|rate| coordinates.iter().map(move |&j| joint_channel(j, rate)))
            .collect();
        let inputs = self.plant.actuators.iter().map(|a| Channel {
            name: a.joint.clone(),
            unit: match a.kind {
                EffortKind::Torque => "N·m",
                EffortKind::Force => "N",
            },
        });
        let layout = &self.layout;
        let outputs = kept.iter().map(|&i| Channel {
            name: layout.signals[i].clone(),
            unit: layout.specs.signals[i].unit.si_label(),
        });
        (states, inputs.collect(), outputs.collect())
    }

    /// The plant signals that are functions of the mechanism's state (indices into the layout's
    /// signals), and the machine's others with why they are left out: a fresh machine at the
    /// captured state must give the run's value, whatever its drives were given.
    fn state_signals(&self, point: &Capture) -> (Vec<usize>, Vec<(String, String)>) {
        let layout = &self.layout;
        let machine_range = layout.machine_signal_range();
        let mut kept: Vec<usize> = (0..machine_range.start).collect();
        let mut left_out = Vec::new();
        let scenario = &self.loaded.scenario;
        let fresh = |push: f64| -> Option<Vec<f64>> {
            let mut machine = build_machine(scenario, &self.mechanism).ok()?;
            let commands: Vec<f64> = point.applied.iter().map(|e| e + push).collect();
            let mut applied = commands.clone();
            machine.drive(scenario.dt, &commands, &mut applied);
            Some(measure(
                machine.as_mut(),
                point,
                layout,
                machine_range.len(),
            ))
        };
        let (Some(held), Some(pushed)) = (fresh(0.0), fresh(1.0)) else {
            return (kept, left_out);
        };
        for (k, i) in machine_range.enumerate() {
            let run = point.signals[i];
            let same = |a: f64, b: f64| (a - b).abs() <= SAME_VALUE * a.abs().max(1.0);
            let name = layout.signals[i].clone();
            if !same(run, held[k]) {
                left_out.push((
                    name,
                    "depends on the machine's history, not only on the mechanism's state".into(),
                ));
            } else if !same(held[k], pushed[k]) {
                left_out.push((name, "depends on the drives' state (their currents)".into()));
            } else {
                kept.push(i);
            }
        }
        (kept, left_out)
    }
}

/// A machine's own signals at the captured state.
fn measure(
    machine: &mut dyn Machine,
    point: &Capture,
    layout: &SignalLayout,
    signals: usize,
) -> Vec<f64> {
    let mut values = vec![0.0; signals];
    let mut diagnostics = vec![0.0; layout.specs.diagnostics.len()];
    let (machine_diagnostics, _, _) = layout.split_diagnostics(&mut diagnostics);
    machine.measure(point.time, &point.state, &mut values, machine_diagnostics);
    values
}
