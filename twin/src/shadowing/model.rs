//! The shadow's model of its machine: the twin's equations of motion on the mechanism's
//! independent coordinates ([`ReducedDynamics`], what `twin linearize` differentiates), driven
//! by the machine's commands through the twin's own drives and process, with the tracked
//! parameters applied, and the measured signals as the twin's sensors give them.
//!
//! One propagation over a span is recorded on a [`Tape`] (the drives' efforts and the process
//! loads of each substep), so that the filter's perturbed propagations replay the same inputs:
//! the machine's own states (a drive's current, a cut's history) follow the estimate only.

use super::error::ShadowError;
use crate::machines::Machine;
use crate::mechanism::{Inertial, Mechanism, Pose2};
use crate::physics::{Load, MechanismState, ReducedDynamics, ReducedError};
use crate::run::{ModelParts, SignalLayout};

/// A parameter the filter holds as a state.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Knob {
    /// A link's mass (its izz scaled with it).
    LinkMass { link: usize, nominal: Inertial },
    /// A tree joint's viscous damping.
    JointDamping { joint: usize },
    /// A tree joint's dry friction.
    JointFriction { joint: usize },
    /// An offset on a watched signal's reading (index into the watched signals).
    SensorBias { watched: usize },
}

impl Knob {
    /// Whether the knob is a physical quantity that cannot be negative (a mass, a damping, a
    /// friction), as a sensor's bias can.
    pub fn is_physical(&self) -> bool {
        !matches!(self, Knob::SensorBias { .. })
    }
}

/// One substep of a propagation: its length and the efforts and loads it was given.
#[derive(Debug, Clone, Default)]
struct Substep {
    span: f64,
    efforts: Vec<f64>,
    loads: Vec<Load>,
}

/// The inputs of one propagation, replayed by the perturbed ones.
#[derive(Debug, Clone, Default)]
pub(super) struct Tape {
    substeps: Vec<Substep>,
}

/// The model: dynamics, machine, layout and the watched signals.
pub(super) struct Model {
    reduced: ReducedDynamics,
    machine: Box<dyn Machine>,
    pub mechanism: Mechanism,
    pub layout: SignalLayout,
    actuated: Vec<usize>,
    command_limits: Vec<f64>,
    /// Physics step, s: no substep is longer.
    dt: f64,
    /// Per tree joint, the dry friction in use.
    friction: Vec<f64>,
    /// Per watched signal: its index among the plant's signals, its sensor's gain and bias.
    pub watched: Vec<usize>,
    gain: Vec<f64>,
    bias: Vec<f64>,
    /// The independent coordinates' tree joints.
    pub coordinates: Vec<usize>,
    pub x0: Vec<f64>,
    state: MechanismState,
    signals: Vec<f64>,
    diagnostics: Vec<f64>,
    joint_efforts: Vec<f64>,
    applied: Vec<f64>,
    loads: Vec<Load>,
}

impl Model {
    /// The model of `parts` watching the plant signals `watched`.
    pub fn new(parts: ModelParts, watched: Vec<usize>) -> Self {
        let scenario = &parts.scenario;
        let mut loads = Vec::new();
        let mut machine = parts.machine;
        machine.loads(0.0, &parts.state, &mut loads);
        let reduced = ReducedDynamics::new(
            &parts.mechanism,
            scenario.gravity,
            &parts.state,
            &loads,
            &parts.actuated,
        );
        let sensor = |i: &usize| scenario.sensors.get(&parts.layout.signals[*i]);
        let gain = watched.iter().map(|i| sensor(i).map_or(1.0, |s| s.gain));
        let bias = watched.iter().map(|i| sensor(i).map_or(0.0, |s| s.bias));
        Self {
            coordinates: reduced.coordinates(),
            x0: reduced.operating_state(),
            friction: parts.mechanism.joints.iter().map(|j| j.friction).collect(),
            joint_efforts: vec![0.0; parts.mechanism.joints.len()],
            signals: vec![0.0; parts.layout.signals.len()],
            diagnostics: vec![0.0; parts.layout.specs.diagnostics.len()],
            applied: vec![0.0; parts.actuated.len()],
            gain: gain.collect(),
            bias: bias.collect(),
            reduced,
            machine,
            dt: scenario.dt,
            actuated: parts.actuated,
            command_limits: parts.command_limits,
            watched,
            state: parts.state,
            mechanism: parts.mechanism,
            layout: parts.layout,
            loads,
        }
    }

    /// The value a knob has in the model now.
    pub fn knob(&self, knob: &Knob) -> f64 {
        match knob {
            Knob::LinkMass { link, .. } => self.mechanism.links[*link]
                .inertial
                .map_or(0.0, |inertial| inertial.mass),
            Knob::JointDamping { joint } => self.mechanism.joints[*joint].damping,
            Knob::JointFriction { joint } => self.friction[*joint],
            Knob::SensorBias { watched } => self.bias[*watched],
        }
    }

    /// Sets a knob for later propagations and measurements.
    pub fn set_knob(&mut self, knob: &Knob, value: f64) {
        match knob {
            Knob::LinkMass { link, nominal } => {
                // A mass through zero makes no body: the filter's step is held at a floor.
                let mass = value.max(1e-6 * nominal.mass);
                let inertial = nominal.with_mass(mass);
                self.mechanism.links[*link].inertial = Some(inertial);
                self.reduced.set_link_inertial(*link, inertial);
            }
            Knob::JointDamping { joint } => {
                self.mechanism.joints[*joint].damping = value;
                self.reduced.set_joint_damping(*joint, value);
            }
            Knob::JointFriction { joint } => self.friction[*joint] = value,
            Knob::SensorBias { watched } => self.bias[*watched] = value,
        }
    }

    /// Propagates x from `time` over `span` under `commands` (per actuator, held), through the
    /// machine's drives and process, onto `tape`.
    pub fn propagate(
        &mut self,
        x: &mut [f64],
        commands: &[f64],
        time: f64,
        span: f64,
        tape: &mut Tape,
    ) -> Result<(), ReducedError> {
        tape.substeps.clear();
        let count = (span / self.dt - 1e-9).ceil().max(1.0) as usize;
        let h = span / count as f64;
        let limited: Vec<f64> = commands
            .iter()
            .zip(&self.command_limits)
            .map(|(c, limit)| c.clamp(-limit, *limit))
            .collect();
        for k in 0..count {
            self.machine.drive(h, &limited, &mut self.applied);
            self.reduced.read_state(x, &mut self.state)?;
            self.loads.clear();
            let now = time + k as f64 * h;
            self.machine.loads(now, &self.state, &mut self.loads);
            let substep = Substep {
                span: h,
                efforts: self.applied.clone(),
                loads: self.loads.clone(),
            };
            self.substep(x, &substep)?;
            tape.substeps.push(substep);
        }
        Ok(())
    }

    /// Propagates x again through the inputs on `tape` (a perturbed copy of the propagation).
    pub fn replay(&mut self, x: &mut [f64], tape: &Tape) -> Result<(), ReducedError> {
        for substep in &tape.substeps {
            self.reduced.read_state(x, &mut self.state)?;
            self.substep(x, substep)?;
        }
        Ok(())
    }

    /// One RK4 substep from x (whose full state is in `self.state`).
    fn substep(&mut self, x: &mut [f64], substep: &Substep) -> Result<(), ReducedError> {
        self.joint_efforts.fill(0.0);
        for (&joint, effort) in self.actuated.iter().zip(&substep.efforts) {
            self.joint_efforts[joint] = *effort;
        }
        self.reduced.hold_loads(x, &substep.loads)?;
        let h = substep.span;
        self.dry_friction(x, h)?;
        let n = x.len();
        let mut k = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut probe = x.to_vec();
        for stage in 0..4 {
            if stage > 0 {
                let weight = if stage == 3 { h } else { 0.5 * h };
                for i in 0..n {
                    probe[i] = x[i] + weight * k[stage - 1][i];
                }
            }
            self.reduced
                .rates(&probe, &self.joint_efforts, &mut k[stage])?;
        }
        for i in 0..n {
            x[i] += h / 6.0 * (k[0][i] + 2.0 * k[1][i] + 2.0 * k[2][i] + k[3][i]);
        }
        Ok(())
    }

    /// Adds each joint's dry friction over a substep of `h` to the efforts, as the exact engine
    /// applies it: the effort that would stop the joint within the substep, at most the
    /// friction, so that a joint the drive cannot break loose sticks. A joint the loops
    /// determine (not a coordinate) gets the friction against its motion.
    fn dry_friction(&mut self, x: &[f64], h: f64) -> Result<(), ReducedError> {
        let c = self.coordinates.len();
        for j in 0..self.friction.len() {
            let friction = self.friction[j];
            if friction == 0.0 {
                continue;
            }
            let v = self.state.joint_velocities[j];
            let coordinate = self.coordinates.iter().position(|&k| k == j);
            // An estimate below zero acts against the motion's sign alone, so that the filter
            // still sees which way friction moves the state and can come back.
            let (Some(i), true) = (coordinate, friction > 0.0) else {
                if v != 0.0 {
                    self.joint_efforts[j] -= friction * v.signum();
                }
                continue;
            };
            let mut free = vec![0.0; x.len()];
            self.reduced.rates(x, &self.joint_efforts, &mut free)?;
            self.joint_efforts[j] += 1.0;
            let mut pushed = vec![0.0; x.len()];
            let result = self.reduced.rates(x, &self.joint_efforts, &mut pushed);
            self.joint_efforts[j] -= 1.0;
            result?;
            // Acceleration per unit effort on this coordinate: the inverse mass it sees.
            let mobility = pushed[c + i] - free[c + i];
            let stopping = -(x[c + i] / h + free[c + i]) / mobility;
            if stopping.is_finite() {
                self.joint_efforts[j] += stopping.clamp(-friction, friction);
            }
        }
        Ok(())
    }

    /// The watched signals at x and `time`, as the sensors read them (gain, bias), into `out`.
    pub fn measure(&mut self, x: &[f64], time: f64, out: &mut [f64]) -> Result<(), ReducedError> {
        self.reduced.read_state(x, &mut self.state)?;
        self.signals.fill(f64::NAN);
        self.layout
            .fill_joint_signals(&self.state, &mut self.signals);
        let (machine_signals, _) = self.layout.machine_and_reference(&mut self.signals);
        let (machine_diagnostics, _, _) = self.layout.split_diagnostics(&mut self.diagnostics);
        self.machine
            .measure(time, &self.state, machine_signals, machine_diagnostics);
        for (k, &i) in self.watched.iter().enumerate() {
            out[k] = self.gain[k] * self.signals[i] + self.bias[k];
        }
        Ok(())
    }

    /// The machine's mechanism view: its frame, what is machined, its markers.
    pub fn scene(&self) -> crate::scene::Scene {
        self.machine.scene()
    }

    /// The links' poses at the state [`Model::measure`] last read.
    pub fn link_poses(&self) -> &[Pose2] {
        &self.state.link_poses
    }

    /// The links' poses where the measured joint positions put the mechanism: x with each
    /// independent coordinate's position replaced by its reading in `measured` (watched signal,
    /// SI value; the sensor's gain and bias undone). `None` unless every independent
    /// coordinate's position is among them.
    pub fn measured_poses(
        &mut self,
        x: &[f64],
        measured: &[(usize, f64)],
    ) -> Result<Option<Vec<Pose2>>, ReducedError> {
        let mut placed = x.to_vec();
        let mut found = 0;
        for &(k, value) in measured {
            let signal = self.watched[k];
            let Some(joint) = self.layout.position_joint(signal) else {
                continue;
            };
            if let Some(c) = self.coordinates.iter().position(|&j| j == joint) {
                placed[c] = (value - self.bias[k]) / self.gain[k];
                found += 1;
            }
        }
        if found < self.coordinates.len() {
            return Ok(None);
        }
        self.reduced.read_state(&placed, &mut self.state)?;
        Ok(Some(self.state.link_poses.clone()))
    }

    /// Per independent coordinate, the largest acceleration one actuator at its effort limit
    /// (1 N or N·m without one) gives it from the initial state.
    pub fn acceleration_scales(&mut self) -> Result<Vec<f64>, ReducedError> {
        let x0 = self.x0.clone();
        let n = x0.len();
        let coordinates = n / 2;
        let mut rest = vec![0.0; n];
        let efforts = vec![0.0; self.mechanism.joints.len()];
        self.reduced.rates(&x0, &efforts, &mut rest)?;
        let mut scales = vec![0.0_f64; coordinates];
        let mut pushed = vec![0.0; n];
        for &joint in &self.actuated {
            let mut efforts = efforts.clone();
            let limit = self.mechanism.joints[joint].effort_limit;
            efforts[joint] = limit.filter(|l| l.is_finite()).unwrap_or(1.0);
            self.reduced.rates(&x0, &efforts, &mut pushed)?;
            for (c, scale) in scales.iter_mut().enumerate() {
                let i = coordinates + c;
                *scale = scale.max((pushed[i] - rest[i]).abs());
            }
        }
        Ok(scales)
    }

    /// Starts later loop-closure solves from x.
    pub fn recenter(&mut self, x: &[f64]) -> Result<(), ReducedError> {
        self.reduced.recenter(x)
    }

    /// Starts later loop-closure solves from `to`, reached from `from` on the loops' branch.
    pub fn recenter_along(&mut self, from: &[f64], to: &[f64]) -> Result<(), ReducedError> {
        self.reduced.recenter_along(from, to)
    }
}

/// A model error at a time, as the shadow reports it.
pub(super) fn diverged(time: f64, error: ReducedError) -> ShadowError {
    ShadowError::Diverged {
        time,
        reason: error.to_string(),
    }
}
