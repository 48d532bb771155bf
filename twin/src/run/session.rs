//! One run's loop: sense → control → actuate → observe → step, over buffers sized once.

use super::observer::{Observer, StepView};
use super::stats::Digest;
use super::summary::{Divergence, FailureKind, Interruption};
use super::twin::{observer_error, Twin, TwinError};
use crate::energy::mechanical_energy;
use crate::faults::PlantChange;
use crate::mechanism::Pose2;
use crate::physics::{Load, MechanismState, Physics, SolverSettings};
use crate::sensors::Noise;
use framework::{Event, EventKind, Measurement};
use std::ops::DerefMut;

/// How a run ended.
pub(super) struct Ending {
    /// The last step simulated.
    pub steps: usize,
    pub failure: Option<Divergence>,
    pub interrupted: Option<Interruption>,
    pub digest: u64,
}

/// The values of one step, in the layout's orders.
#[derive(Default)]
struct Buffers {
    state: MechanismState,
    signals: Vec<f64>,
    measured: Vec<f64>,
    commanded: Vec<f64>,
    /// Commanded efforts clipped to the actuator limits (what the drives are given).
    limited: Vec<f64>,
    applied: Vec<f64>,
    saturated: Vec<bool>,
    internals: Vec<f64>,
    diagnostics: Vec<f64>,
    events: Vec<Event>,
    joint_efforts: Vec<f64>,
    loads: Vec<Load>,
    plant_changes: Vec<PlantChange>,
}

impl Buffers {
    /// Where the `[[bodies]]` are now, in the scenario's order: static ones where the scenario
    /// places them, free ones where the rapier engine's contacts have moved them.
    fn bodies(&self) -> &[Pose2] {
        &self.state.body_poses
    }
}

/// A twin being run: borrowed for a whole run, or owned by a [`super::Simulator`] stepped from
/// outside.
pub(super) struct Session<T: DerefMut<Target = Twin>> {
    twin: T,
    physics: Physics,
    values: Buffers,
    noise: Noise,
    digest: Digest,
    dt: f64,
    control_every: usize,
    control_period: f64,
    record_every: usize,
    /// Efforts from outside on the tree joints (a host's disturbances on a closed loop stepped
    /// from outside); empty in a run.
    disturbances: Vec<f64>,
    /// Added to the scenario's reference triple (a host's setpoint on a closed loop); zero in a
    /// run.
    reference_offset: [f64; 3],
}

impl<T: DerefMut<Target = Twin>> Session<T> {
    pub fn new(twin: T) -> Self {
        let scenario = &twin.loaded.scenario;
        let mut physics = Physics::new(
            &twin.mechanism,
            SolverSettings {
                dt: scenario.dt,
                gravity: scenario.gravity,
                substeps: scenario.substeps,
                solver: scenario.solver.clone(),
                contact: scenario.contact.clone(),
                bodies: scenario.bodies.clone(),
                allowed_contacts: scenario.allowed_contacts.clone(),
            },
        );
        physics.set_joint_states(&twin.initial);
        let layout = &twin.layout;
        let actuators = layout.actuators.len();
        let values = Buffers {
            signals: vec![0.0; layout.signals.len()],
            measured: vec![0.0; layout.signals.len()],
            commanded: vec![0.0; actuators],
            limited: vec![0.0; actuators],
            applied: vec![0.0; actuators],
            saturated: vec![false; actuators],
            internals: vec![0.0; layout.internals.len()],
            diagnostics: vec![0.0; layout.diagnostics.len()],
            joint_efforts: vec![0.0; twin.mechanism.joints.len()],
            ..Buffers::default()
        };
        Self {
            noise: Noise::new(scenario.seed),
            digest: Digest::default(),
            dt: scenario.dt,
            control_every: scenario.control_every(),
            control_period: scenario.control_period(),
            record_every: scenario.recording.every,
            disturbances: Vec::new(),
            reference_offset: [0.0; 3],
            physics,
            values,
            twin,
        }
    }

    /// Steps until the scenario's end, a divergence or a stop request.
    pub fn run(mut self, observers: &mut [&mut dyn Observer]) -> Result<Ending, TwinError> {
        let steps = self.twin.loaded.scenario.steps();
        self.start()?;
        let mut step = 0;
        loop {
            let time = step as f64 * self.dt;
            self.apply_faults(time);
            self.sense(time);
            let mut failure = self
                .twin
                .check_health(step, time, &self.values.state, &self.values.signals)
                .or_else(|| self.collide(step, time));
            let interrupted =
                self.twin
                    .stop_requested()
                    .map(|signal| Interruption { signal, step, time });
            let control_update = step.is_multiple_of(self.control_every) && failure.is_none();
            if control_update {
                self.poll_setpoints(time);
                self.control(time);
                failure = failure.or_else(|| self.limit(step, time));
                self.twin.faults.actuators(&mut self.values.limited);
            }
            self.twin
                .machine
                .drive(self.dt, &self.values.limited, &mut self.values.applied);
            // A crash has its own event already.
            if let Some(failure) = failure.as_ref().filter(|f| f.kind == FailureKind::Diverged) {
                let event = Event::error(EventKind::Divergence, failure.to_string());
                self.values.events.push(event);
            }
            if let Some(interrupted) = &interrupted {
                let event = Event::warning(EventKind::Interruption, interrupted.to_string());
                self.values.events.push(event);
            }
            let last = failure.is_some() || interrupted.is_some() || step == steps;
            self.observe(step, time, control_update, last, observers)?;
            if last {
                return Ok(Ending {
                    steps: step,
                    failure,
                    interrupted,
                    digest: self.digest.0,
                });
            }
            self.advance(step, time);
            step += 1;
        }
    }

    /// Reads the starting state; a body overlapping a link it may not touch is refused.
    fn start(&mut self) -> Result<(), TwinError> {
        self.physics.read_state(&mut self.values.state);
        let values = &self.values;
        let start = (self.twin.contacts).check_start(&values.state.link_poses, values.bodies());
        start.map_err(|error| self.twin.binding_error(error.to_string()))
    }

    /// Prepares stepping from outside ([`super::Simulator`]): the starting state sensed and
    /// measured as a run's first control update sees it, or why it fails its health check.
    pub fn begin(&mut self) -> Result<Option<Divergence>, TwinError> {
        self.start()?;
        Ok(self.sense_step(0))
    }

    /// From the control update at `step`, one control period with the finite efforts
    /// `commanded` held: clipped to the limits, through the actuator faults and the drives, the
    /// physics stepped and each new state sensed as in [`Session::run`]. The step reached, or the
    /// first failure.
    pub fn hold(&mut self, step: usize, commanded: &[f64]) -> Result<usize, Divergence> {
        self.values.commanded.copy_from_slice(commanded);
        self.actuate(step)
    }

    /// From the control update at `step`, one control period of the twin's own loop with a
    /// host's inputs held over it: `disturbances` (per movable joint, on top of the drives) and
    /// `reference_offset` (on the reference triple, from `step` on, the controller's reading at
    /// `step` included). The controller decides on what the sensors read at `step`, as in
    /// [`Session::run`]. The step reached, or the first failure.
    pub fn close(
        &mut self,
        step: usize,
        disturbances: &[f64],
        reference_offset: [f64; 3],
    ) -> Result<usize, Divergence> {
        let twin = &*self.twin;
        self.disturbances.resize(twin.mechanism.joints.len(), 0.0);
        for (&j, &effort) in twin.layout.movable_joints().iter().zip(disturbances) {
            self.disturbances[j] = effort;
        }
        let time = step as f64 * self.dt;
        if reference_offset != self.reference_offset {
            self.reference_offset = reference_offset;
            self.resense_reference(time);
        }
        self.decide(time);
        self.actuate(step)
    }

    /// A run's setpoint source read at the control update at `time`: a new finite offset moves
    /// the reference from now on, as [`Session::close`] moves it.
    fn poll_setpoints(&mut self, time: f64) {
        let Some(source) = &self.twin.setpoints else {
            return;
        };
        let offset = source.offset();
        if offset != self.reference_offset && offset.iter().all(|v| v.is_finite()) {
            self.reference_offset = offset;
            self.resense_reference(time);
        }
    }

    /// The reference triple at `time` sensed again with a new offset, its reading with it: exact
    /// when no sensor or sensor fault stands between the reference and the controller (the
    /// caller's check).
    fn resense_reference(&mut self, time: f64) {
        let range = self.twin.layout.reference_range();
        let Some(reference) = self.reference_at(time) else {
            return;
        };
        self.values.signals[range.clone()].copy_from_slice(&reference);
        self.values.measured[range].copy_from_slice(&reference);
    }

    /// The commanded efforts clipped, through the actuator faults and the drives, over one
    /// control period from `step`, each new state sensed.
    fn actuate(&mut self, step: usize) -> Result<usize, Divergence> {
        if let Some(failure) = self.limit(step, step as f64 * self.dt) {
            return Err(failure);
        }
        self.twin.faults.actuators(&mut self.values.limited);
        for k in step..step + self.control_every {
            let values = &mut self.values;
            (self.twin.machine).drive(self.dt, &values.limited, &mut values.applied);
            self.advance(k, k as f64 * self.dt);
            if let Some(failure) = self.sense_step(k + 1) {
                return Err(failure);
            }
        }
        Ok(step + self.control_every)
    }

    /// The controller's internal signals after its last update.
    pub fn internals(&self) -> &[f64] {
        &self.values.internals
    }

    /// The efforts commanded at the last control update, before the limits.
    pub fn commanded(&self) -> &[f64] {
        &self.values.commanded
    }

    /// What the sensors read at the last control update.
    pub fn measured(&self) -> &[f64] {
        &self.values.measured
    }

    /// The plant's true signals now.
    pub fn signals(&self) -> &[f64] {
        &self.values.signals
    }

    /// The model checks now: the machine's, the loop gaps, the mechanical energy.
    pub fn diagnostics(&self) -> &[f64] {
        &self.values.diagnostics
    }

    /// The twin being stepped.
    pub fn twin(&self) -> &Twin {
        &self.twin
    }

    /// Faults, true signals, health and crashes at `step`, then the sensors on a control
    /// update: a run's step up to its controller. Its events are dropped (no observer).
    fn sense_step(&mut self, step: usize) -> Option<Divergence> {
        let time = step as f64 * self.dt;
        self.apply_faults(time);
        self.sense(time);
        let values = &self.values;
        let failure = (self.twin)
            .check_health(step, time, &values.state, &values.signals)
            .or_else(|| self.collide(step, time));
        if failure.is_none() && step.is_multiple_of(self.control_every) {
            self.read_sensors(time);
        }
        self.values.events.clear();
        failure
    }

    /// Starts and ends faults; a plant or process fault changes the physics or the machine.
    fn apply_faults(&mut self, time: f64) {
        let twin = &mut *self.twin;
        twin.faults.update(time, &mut self.values.events);
        if let Some(factor) = twin.faults.process_factor() {
            twin.machine.set_process_factor(factor);
        }
        twin.faults.plant(time, &mut self.values.plant_changes);
        for change in &self.values.plant_changes {
            match *change {
                PlantChange::Link { link, inertial } => {
                    self.physics.set_link_inertial(link, inertial);
                    twin.mechanism.links[link].inertial = Some(inertial);
                }
                PlantChange::Joint {
                    joint,
                    damping,
                    friction,
                } => {
                    self.physics.set_joint_dynamics(joint, damping, friction);
                    let joint = &mut twin.mechanism.joints[joint];
                    (joint.damping, joint.friction) = (damping, friction);
                }
            }
        }
    }

    /// The plant's true signals and the diagnostics for the state at `time`.
    fn sense(&mut self, time: f64) {
        let reference_now = self.reference_at(time);
        let twin = &mut *self.twin;
        let values = &mut self.values;
        let layout = &twin.layout;
        layout.fill_joint_signals(&values.state, &mut values.signals);
        let (machine_signals, reference) = layout.machine_and_reference(&mut values.signals);
        let (machine_diagnostics, gaps, energy) = layout.split_diagnostics(&mut values.diagnostics);
        twin.machine
            .measure(time, &values.state, machine_signals, machine_diagnostics);
        gaps.copy_from_slice(&values.state.loop_gaps);
        let scenario = &twin.loaded.scenario;
        *energy = mechanical_energy(&twin.mechanism, &values.state, scenario.gravity);
        if let (Some(now), Some(reference)) = (reference_now, reference) {
            reference.copy_from_slice(&now);
        }
    }

    /// The scenario's reference triple at `time` with the host's offset, if it has one.
    fn reference_at(&self, time: f64) -> Option<[f64; 3]> {
        let sample = self.twin.loaded.scenario.reference.as_ref()?.sample(time);
        let mut reference = [sample.position, sample.rate, sample.acceleration];
        offset(&mut reference, self.reference_offset);
        Some(reference)
    }

    /// Crash detection on the state at `time`: an event for each pair that starts to touch;
    /// with `health.stop_on_collision` the first one stops the run.
    fn collide(&mut self, step: usize, time: f64) -> Option<Divergence> {
        let values = &mut self.values;
        let twin = &mut *self.twin;
        let onsets = twin
            .contacts
            .update(time, &values.state.link_poses, values.bodies());
        let stop = twin.loaded.scenario.health.stop_on_collision;
        for onset in onsets {
            let kind = EventKind::Collision {
                a: onset.a.clone(),
                b: onset.b.clone(),
            };
            values.events.push(if stop {
                Event::error(kind, onset.describe())
            } else {
                Event::warning(kind, onset.describe())
            });
        }
        let first = onsets.first().filter(|_| stop)?;
        Some(Divergence {
            step,
            time,
            signal: format!("collision {}/{}", first.a, first.b),
            value: first.depth,
            kind: FailureKind::Collision,
        })
    }

    /// Through the sensors to the controller: new commanded efforts, internals and events.
    fn control(&mut self, time: f64) {
        self.read_sensors(time);
        self.decide(time);
    }

    /// The controller on what the sensors last read: new commanded efforts, internals and
    /// events.
    fn decide(&mut self, time: f64) {
        let twin = &mut *self.twin;
        let values = &mut self.values;
        values.commanded.fill(0.0);
        twin.loaded.controller.update(
            &Measurement {
                time,
                signals: &values.measured,
            },
            self.control_period,
            &mut values.commanded,
        );
        twin.loaded
            .controller
            .internal_values(&mut values.internals);
        twin.loaded.controller.drain_events(&mut values.events);
    }

    /// The true signals through the sensors (and their faults): what is measured at `time`.
    fn read_sensors(&mut self, time: f64) {
        let twin = &mut *self.twin;
        let values = &mut self.values;
        for (i, sensor) in twin.sensors.iter_mut().enumerate() {
            values.measured[i] = match sensor {
                Some(sensor) => sensor.read(values.signals[i], &mut self.noise),
                None => values.signals[i],
            };
        }
        twin.faults.sensors(time, &mut values.measured);
    }

    /// Clips the commands to the command limits (the actuators' own, or their drives'), with an
    /// event when one starts or stops saturating; a non-finite command is a divergence.
    fn limit(&mut self, step: usize, time: f64) -> Option<Divergence> {
        let values = &mut self.values;
        let mut failure = None;
        for (a, actuator) in self.twin.plant.actuators.iter().enumerate() {
            let commanded = values.commanded[a];
            if !commanded.is_finite() {
                failure.get_or_insert(Divergence {
                    step,
                    time,
                    signal: format!("effort/commanded/{}", actuator.joint),
                    value: commanded,
                    kind: FailureKind::Diverged,
                });
                continue;
            }
            let limit = self.twin.command_limits[a];
            let limited = commanded.clamp(-limit, limit);
            values.limited[a] = limited;
            let now_saturated = limited != commanded;
            if now_saturated != values.saturated[a] {
                let subject = actuator.joint.clone();
                values.events.push(if now_saturated {
                    let text = format!(
                        "{subject} effort saturated at {limited:+} (commanded {commanded:+.3})"
                    );
                    Event::warning(EventKind::SaturationStart { subject }, text)
                } else {
                    let text = format!("{subject} effort back within its limit");
                    Event::info(EventKind::SaturationEnd { subject }, text)
                });
                values.saturated[a] = now_saturated;
            }
        }
        failure
    }

    /// Shows the step to every observer; the step's events are then spent.
    fn observe(
        &mut self,
        step: usize,
        time: f64,
        control_update: bool,
        last: bool,
        observers: &mut [&mut dyn Observer],
    ) -> Result<(), TwinError> {
        let values = &self.values;
        let view = StepView {
            step,
            time,
            layout: &self.twin.layout,
            state: &values.state,
            signals: &values.signals,
            measured: &values.measured,
            commanded: &values.commanded,
            applied: &values.applied,
            saturated: &values.saturated,
            internals: &values.internals,
            diagnostics: &values.diagnostics,
            bodies: values.bodies(),
            collisions: self.twin.contacts.onsets(),
            events: &values.events,
            control_update,
            sampled: step.is_multiple_of(self.record_every) || last,
            last,
        };
        if view.sampled {
            self.digest.add_step(&view);
        }
        for observer in observers.iter_mut() {
            observer.observe(&view).map_err(observer_error)?;
        }
        self.values.events.clear();
        Ok(())
    }

    /// The efforts and process loads over one physics step (`step`, from `time`).
    fn advance(&mut self, step: usize, time: f64) {
        let values = &mut self.values;
        values.joint_efforts.fill(0.0);
        for (a, &j) in self.twin.actuated.iter().enumerate() {
            values.joint_efforts[j] = values.applied[a];
        }
        self.twin.faults.collisions(&mut values.joint_efforts);
        if let Some(excitation) = &self.twin.excitation {
            values.joint_efforts[excitation.joint] +=
                excitation.efforts.get(step).copied().unwrap_or(0.0);
        }
        // Zero adds nothing, not even a sign (-0 + 0 is +0): a run stays bit for bit a run.
        for (effort, &outside) in values.joint_efforts.iter_mut().zip(&self.disturbances) {
            if outside != 0.0 {
                *effort += outside;
            }
        }
        values.loads.clear();
        self.twin
            .machine
            .loads(time, &values.state, &mut values.loads);
        self.physics.step(&values.joint_efforts, &values.loads);
        self.physics.read_state(&mut values.state);
    }
}

/// Adds a host's offset to the reference triple; a zero adds nothing, not even a sign.
fn offset(reference: &mut [f64], by: [f64; 3]) {
    for (value, by) in reference.iter_mut().zip(by) {
        if by != 0.0 {
            *value += by;
        }
    }
}
