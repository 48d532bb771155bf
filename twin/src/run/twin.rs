//! The twin: a loaded scenario built into its mechanism, machine, sensors and controller, and
//! what stops a run before it starts (`TwinError`). `Twin::run`, the one door in, is
//! [`super::whole_run`].

use super::evaluate::Evaluator;
use super::layout::LayoutParts;
use super::layout::SignalLayout;
use super::observer::ObserverError;
use super::plant_model::{effort_kind, MechanismDynamics, ScenarioFolder};
use super::record::{RecordingObserver, RecordingParts};
use super::spectra::SpectraPlan;
use super::summary::{Divergence, FailureKind};
use crate::data::PlantColumns;
use crate::faults::FaultSet;
use crate::machines::{self, Machine, MachineError};
use crate::mechanism::{JointMotion, Mechanism};
use crate::physics::{BodyKind, BodySpec, Engine};
use crate::physics::{BodyShapes, ContactDetector, MechanismState};
use crate::recording::{LiveViewer, RecordingError};
use crate::scenario::{LoadedScenario, Scenario, ScenarioError};
use crate::scene::{Bounds, Scene};
use crate::sensors::Sensor;
use crate::urdf::{self, UrdfError};
use framework::{Actuator, Controller, ControllerError, PlantInterface};
use std::path::Path;
use std::sync::Arc;
use thiserror::Error;

/// Everything that stops a run before it starts, or ends it without a summary (a failed
/// recording or observer).
#[derive(Debug, Error)]
pub enum TwinError {
    /// The scenario cannot be found, read or checked, or an override does not apply.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The scenario's URDF cannot be read or makes no planar mechanism.
    #[error(transparent)]
    Urdf(#[from] UrdfError),
    /// A machine's checks cover the scenario's `[process]` and `[actuators]` tables and the
    /// URDF's geometry: both files are named.
    #[error("{scenario} (URDF {urdf}): {source}")]
    Machine {
        /// Where the scenario came from.
        scenario: String,
        /// The URDF's path or built-in name.
        urdf: String,
        /// What the machine found wrong.
        source: MachineError,
    },
    /// A controller's parameters are the scenario's; its plant check also concerns the URDF.
    #[error("{context}: {source}")]
    Controller {
        /// The scenario and its URDF, e.g. `<scenario> (URDF <urdf>)`.
        context: String,
        /// What the controller found wrong.
        source: ControllerError,
    },
    /// The plant's signals come from the URDF (its joints) and the machine: both files are named.
    #[error(
        "{source_name} (URDF {urdf}): sensors.\"{signal}\": no such measured signal (known: {known})"
    )]
    UnknownSensor {
        /// Where the scenario came from.
        source_name: String,
        /// The URDF's path or built-in name.
        urdf: String,
        /// The `[sensors]` key that names no plant signal.
        signal: String,
        /// The plant's signals, comma-separated.
        known: String,
    },
    /// A `[[metrics]]`, `[[faults]]` or `[plant]` entry names a signal, actuator, link or joint
    /// the run lacks, or asks what this run cannot do (the scenario's or the URDF's mistake: both
    /// are named; `reason` names the entry).
    #[error("{source_name} (URDF {urdf}): {reason}")]
    Binding {
        /// Where the scenario came from.
        source_name: String,
        /// The URDF's path or built-in name.
        urdf: String,
        /// What is wrong, naming the entry.
        reason: String,
    },
    /// The run's recording could not be created or written.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A caller's observer failed; the run stopped.
    #[error("observer: {0}")]
    Observer(ObserverError),
}

/// A flag a run polls once per step: 0 goes on, any other value (a signal number) stops it.
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicUsize>;

/// A setpoint from outside a whole run (an OPC UA client's, a host's): the offset added to the
/// scenario's `[reference]` triple, polled at each control update before the controller reads
/// the reference. See [`Twin::with_setpoints`].
pub trait SetpointSource: Send + Sync {
    /// The offset now: position, rate, acceleration, in the reference's SI units. An offset with
    /// a component that is not finite is ignored (the last one holds).
    fn offset(&self) -> [f64; 3];
}

/// A scenario bound to its mechanism, machine and controller, ready to run.
///
/// # Example
///
/// A built-in scenario, shortened, run under its own controller without a recording:
///
/// ```
/// use twin::{Scenario, Twin};
///
/// let scenario = Scenario::builtin("whitworth-crank-pi")?
///     .duration(0.2)
///     .build(&controllers::builtin())?;
/// let summary = Twin::new(scenario)?.run(None)?;
/// assert!(summary.failure.is_none());
/// assert_eq!(summary.steps, 200); // 0.2 s at the scenario's 1 ms step
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Twin {
    pub(super) loaded: LoadedScenario,
    pub(super) mechanism: Mechanism,
    pub(super) machine: Box<dyn Machine>,
    pub(super) plant: PlantInterface,
    /// Per actuator, the largest command (in its command unit): commands are clipped to it.
    pub(super) command_limits: Vec<f64>,
    pub(super) layout: SignalLayout,
    /// Per plant signal: its sensor, if the scenario gives one.
    pub(super) sensors: Vec<Option<Sensor>>,
    /// Tree joint index of each actuator on a joint; the machine's own actuators follow them.
    pub(super) actuated: Vec<usize>,
    /// The scenario's `[[metrics]]`, bound to the layout.
    pub(super) evaluators: Vec<Evaluator>,
    /// The scenario's `[[faults]]`, bound to the run.
    pub(super) faults: FaultSet,
    /// The scenario's `[initial]` joint states: tree joint, position, velocity.
    pub(super) initial: Vec<(usize, f64, f64)>,
    /// Crash detection between the links' collision shapes and the scenario's bodies.
    pub(super) contacts: ContactDetector,
    /// A viewer to stream the run to, besides the recording file.
    pub(super) live: Option<LiveViewer>,
    /// Polled every step; see [`Twin::with_stop_flag`].
    pub(super) stop: Option<StopFlag>,
    /// An effort from outside the machine; see [`Twin::with_joint_effort`].
    pub(super) excitation: Option<Excitation>,
    /// The reference offset from outside; see [`Twin::with_setpoints`].
    pub(super) setpoints: Option<Arc<dyn SetpointSource>>,
}

/// An effort from outside the machine on one joint (a shaker, an impact hammer): tree joint and
/// the effort over each physics step.
pub(super) struct Excitation {
    pub(super) joint: usize,
    pub(super) efforts: Vec<f64>,
}

impl Twin {
    /// Builds the twin around a controller the caller made (a user's own, for example), in place
    /// of the scenario's.
    pub fn with_controller(
        mut loaded: LoadedScenario,
        controller: Box<dyn Controller>,
    ) -> Result<Self, TwinError> {
        loaded.controller = controller;
        Self::new(loaded)
    }

    /// Builds the twin around the scenario's controller (built with the scenario): the URDF's
    /// mechanism, the machine, the signal layout, sensors, metrics and faults, and the controller
    /// bound to the plant.
    pub fn new(mut loaded: LoadedScenario) -> Result<Self, TwinError> {
        let mut mechanism = urdf::load_str(&loaded.urdf_text, &loaded.urdf_source)?;
        loaded.scenario.gravity = (loaded.scenario.gravity_given).in_plane(&mechanism.plane);
        let scenario = &loaded.scenario;
        // A scenario entry naming what the URDF or the run lacks.
        let binding = |reason: String| TwinError::Binding {
            source_name: loaded.source.clone(),
            urdf: loaded.urdf_source.clone(),
            reason,
        };
        scenario.plant.apply(&mut mechanism).map_err(binding)?;
        let initial = initial_states(scenario, &mut mechanism).map_err(binding)?;
        let contacts = contact_detector(scenario, &mechanism).map_err(binding)?;
        let mut machine =
            build_machine(scenario, &mechanism).map_err(|source| TwinError::Machine {
                scenario: loaded.source.clone(),
                urdf: loaded.urdf_source.clone(),
                source,
            })?;
        let actuated = mechanism.actuated_joints();
        let mut actuators = joint_actuators(&mechanism, &actuated);
        actuators.extend(machine.extra_actuators());
        let mut layout =
            signal_layout(&mechanism, machine.as_ref(), scenario, &actuators).map_err(binding)?;
        let command_limits = actuators.iter().map(|a| machine.command_limit(a)).collect();
        let plant = PlantInterface {
            machine: scenario.machine.clone(),
            signals: layout.signals.clone(),
            actuators,
            dynamics: Some(Arc::new(
                MechanismDynamics::new(&mechanism, scenario.gravity, &initial, &actuated)
                    .with_points(point_places(scenario, &mechanism)),
            )),
            files: Some(Arc::new(ScenarioFolder::new(
                loaded.folder.clone(),
                PlantColumns::of_layout(&layout),
                scenario.control_period(),
            ))),
        };
        let sensors = bind_sensors(&loaded, &plant)?;
        let context = format!("{} (URDF {})", loaded.source, loaded.urdf_source);
        loaded
            .controller
            .reset(&plant)
            .map_err(|source| TwinError::Controller { context, source })?;
        layout.set_internals(loaded.controller.internals());
        let evaluators = scenario
            .metrics
            .iter()
            .map(|spec| Evaluator::bind(spec, &layout))
            .collect::<Result<_, _>>()
            .map_err(binding)?;
        let has_process = machine.set_process_factor(1.0);
        let faults = FaultSet::bind(
            &scenario.faults,
            &plant.signals,
            &plant.actuators,
            &mechanism,
            has_process,
            scenario.seed,
        )
        .map_err(binding)?;
        Ok(Self {
            loaded,
            mechanism,
            machine,
            plant,
            command_limits,
            layout,
            sensors,
            actuated,
            evaluators,
            faults,
            initial,
            contacts,
            live: None,
            stop: None,
            excitation: None,
            setpoints: None,
        })
    }

    /// Streams the recorded run to a live viewer too (`twin run --connect URL | --spawn`).
    pub fn with_live_viewer(mut self, live: LiveViewer) -> Self {
        self.live = Some(live);
        self
    }

    /// Stops the run at the next step once `flag` holds a non-zero value (the CLI stores the
    /// signal number there): the recording is finished and the summary says where it stopped.
    pub fn with_stop_flag(mut self, flag: StopFlag) -> Self {
        self.stop = Some(flag);
        self
    }

    /// Lets `source` move the scenario's reference during the run: at each control update, before
    /// the controller reads the reference, its offset is added to the `[reference]` triple from
    /// that update on, as
    /// [`Simulator::step_closed_loop`](super::Simulator::step_closed_loop) adds one (the two
    /// agree bit for bit; a zero offset leaves the run as it is). Refused where an offset cannot reach the controller
    /// exactly: no `[reference]`, or a sensor or sensor fault on it.
    pub fn with_setpoints(mut self, source: Arc<dyn SetpointSource>) -> Result<Self, TwinError> {
        self.reference_inputs().map_err(|why| {
            self.binding_error(format!(
                "a setpoint from outside cannot reach the controller: {why}"
            ))
        })?;
        self.setpoints = Some(source);
        Ok(self)
    }

    /// Whether a reference offset can reach the controller exactly: the scenario has a
    /// `[reference]` and no sensor or sensor fault stands between it and the controller; else
    /// why not.
    pub(crate) fn reference_inputs(&self) -> Result<(), &'static str> {
        let range = self.layout.reference_range();
        if range.is_empty() {
            return Err("the scenario has no [reference] to offset");
        }
        if range
            .clone()
            .any(|i| self.sensors[i].is_some() || self.faults.reads_signal(i))
        {
            return Err("a sensor or sensor fault stands on the scenario's reference");
        }
        Ok(())
    }

    /// Adds an effort from outside the machine to `joint` (a shaker or an impact hammer on it):
    /// `efforts[k]` acts over step k, from `k·dt` to `(k+1)·dt` (N on a prismatic joint, N·m on a
    /// revolute one), on top of what its drive applies; none after the last. The controller does
    /// not see it. An unknown or fixed joint or a non-finite effort is refused by name.
    pub fn with_joint_effort(mut self, joint: &str, efforts: Vec<f64>) -> Result<Self, TwinError> {
        let index = self
            .mechanism
            .joint_index(joint)
            .filter(|&j| self.mechanism.joints[j].motion.is_movable())
            .ok_or_else(|| {
                let known: Vec<&str> = (self.mechanism.joints.iter())
                    .filter(|j| j.motion.is_movable())
                    .map(|j| j.name.as_str())
                    .collect();
                self.binding_error(format!(
                    "joint effort: the URDF has no moving joint `{joint}` (known: {})",
                    known.join(", ")
                ))
            })?;
        if let Some(k) = efforts.iter().position(|e| !e.is_finite()) {
            return Err(self.binding_error(format!(
                "joint effort on `{joint}`: step {k}'s effort is {}; give finite efforts",
                efforts[k]
            )));
        }
        self.excitation = Some(Excitation {
            joint: index,
            efforts,
        });
        Ok(self)
    }

    /// What a recording of this run shows: its plots (each one unit; references and commands
    /// on the plots of what they command) and the mechanism view's scene with its fixed frame.
    pub fn recording_plan(&self) -> (Vec<crate::recording::PlotSpec>, Scene) {
        let sensed: Vec<bool> = self.sensors.iter().map(Option::is_some).collect();
        (
            super::record::plan(&self.layout, &sensed, &self.plain_measurements()),
            framed(
                self.machine.scene(),
                &self.mechanism,
                &self.loaded.scenario.bodies,
            ),
        )
    }

    /// Per plant signal: whether its measurement is its true value at each control update (no
    /// sensor and no sensor fault stand between them).
    pub(super) fn plain_measurements(&self) -> Vec<bool> {
        (0..self.sensors.len())
            .map(|i| self.sensors[i].is_none() && !self.faults.reads_signal(i))
            .collect()
    }

    /// A scenario entry that does not fit the run, found once it runs (a body overlapping a link
    /// at t = 0): both files are named.
    pub(super) fn binding_error(&self, reason: String) -> TwinError {
        TwinError::Binding {
            source_name: self.loaded.source.clone(),
            urdf: self.loaded.urdf_source.clone(),
            reason,
        }
    }

    /// The plant as the controller sees it: its measured signals and actuators (with limits).
    pub fn plant(&self) -> &PlantInterface {
        &self.plant
    }

    /// What the URDF holds that the twin left out or read in its own way (a `<frame>`, a weld
    /// to `world`, an offset along the joints' axis), one line each, naming the element; and an
    /// `[initial]` state the loops could not close as given.
    pub fn urdf_notes(&self) -> &[String] {
        &self.mechanism.notes
    }

    pub(super) fn recording_observer(&self, path: &Path) -> RecordingObserver {
        let scenario = &self.loaded.scenario;
        let mut digest = super::stats::Digest::default();
        digest.add_bytes(self.loaded.toml.as_bytes());
        let scenario_digest = digest.0;
        let start_text = format!(
            "run started: scenario {}, machine {}, controller {}, scenario digest \
             {scenario_digest:016x} (FNV-1a of its TOML), dt {} s, {} s",
            scenario.name,
            scenario.machine,
            self.loaded.controller.name(),
            scenario.dt,
            scenario.duration,
        );
        // The same inputs make the same recording, id included; other inputs another id.
        digest.add_bytes(self.loaded.urdf_text.as_bytes());
        digest.add_bytes(self.loaded.controller.name().as_bytes());
        RecordingObserver::new(RecordingParts {
            path: path.to_path_buf(),
            app: scenario.name.clone(),
            recording_id: format!("{}-{:016x}", scenario.name, digest.0),
            scenario_toml: self.loaded.toml.clone(),
            links: self
                .mechanism
                .links
                .iter()
                .map(|l| (l.name.clone(), l.visuals.clone()))
                .collect(),
            bodies: scenario
                .bodies
                .iter()
                .map(|b| (b.name.clone(), b.outlines()))
                .collect(),
            scene: framed(self.machine.scene(), &self.mechanism, &scenario.bodies),
            sensed: self.sensors.iter().map(Option::is_some).collect(),
            plain: self.plain_measurements(),
            start_text,
            live: self.live.clone(),
            spectra: self.spectra_plan(),
        })
    }

    /// What the recording's spectra and lobe diagram are made of.
    pub(super) fn spectra_plan(&self) -> SpectraPlan {
        let scenario = &self.loaded.scenario;
        let excitation = self.machine.excitation();
        let initial_speed = excitation
            .as_ref()
            .and_then(|e| e.speed_signal.split_once('.'))
            .and_then(|(joint, _)| scenario.initial.get(joint))
            .map_or(0.0, |state| state.velocity);
        SpectraPlan {
            metrics: scenario.metrics.clone(),
            excitation,
            stability: self.machine.stability(),
            dt: scenario.dt,
            control_period: scenario.control_period(),
            initial_speed,
        }
    }

    pub(super) fn stop_requested(&self) -> Option<usize> {
        let signal = self
            .stop
            .as_ref()?
            .load(std::sync::atomic::Ordering::Relaxed);
        (signal != 0).then_some(signal)
    }

    pub(super) fn check_health(
        &self,
        step: usize,
        time: f64,
        state: &MechanismState,
        signals: &[f64],
    ) -> Option<Divergence> {
        let limits = &self.loaded.scenario.health;
        let diverged = |signal: String, value: f64| {
            Some(Divergence {
                step,
                time,
                signal,
                value,
                kind: FailureKind::Diverged,
            })
        };
        for (j, joint) in self.mechanism.joints.iter().enumerate() {
            let (q, v) = (state.joint_positions[j], state.joint_velocities[j]);
            if !q.is_finite() {
                return diverged(format!("{}.position", joint.name), q);
            }
            if !v.is_finite() || v.abs() > limits.max_joint_speed {
                return diverged(format!("{}.velocity", joint.name), v);
            }
        }
        for (l, gap) in state.loop_gaps.iter().enumerate() {
            if !gap.is_finite() || *gap > limits.max_loop_gap {
                return diverged(format!("loop_gap/{}", self.mechanism.loops[l].name), *gap);
            }
        }
        for (name, value) in self.plant.signals.iter().zip(signals) {
            if !value.is_finite() {
                return diverged(name.clone(), *value);
            }
        }
        None
    }
}

/// The scene with its frame widened to hold the links at their URDF pose, the bodies where the
/// scenario places them and the drawings, with a margin, so that nothing drawn touches the
/// view's border.
pub(crate) fn framed(mut scene: Scene, mechanism: &Mechanism, bodies: &[BodySpec]) -> Scene {
    const MARGIN: f64 = 0.04;
    let poses = mechanism.zero_pose();
    let links = mechanism.links.iter().zip(&poses).flat_map(|(link, pose)| {
        link.visuals
            .iter()
            .flat_map(|shape| shape.extent().map(|[x, y]| pose.apply(x, y)))
    });
    let bodies = bodies.iter().flat_map(|body| {
        let pose = body.placement();
        body.outlines()
            .into_iter()
            .flat_map(move |shape| shape.extent().map(|[x, y]| pose.apply(x, y)))
    });
    let drawings = scene
        .drawings
        .iter()
        .flat_map(|d| d.lines.iter().flatten().copied());
    if let Some(content) = Bounds::around(links.chain(bodies).chain(drawings), MARGIN) {
        scene.bounds = scene.bounds.union(&content);
    }
    scene
}

/// An observer's error as the run's: a recording's keeps its type.
pub(crate) fn observer_error(error: ObserverError) -> TwinError {
    match error.downcast::<RecordingError>() {
        Ok(recording) => TwinError::Recording(*recording),
        Err(other) => TwinError::Observer(other),
    }
}

/// The run's layout: the movable joints, those the controller measures (the machine may hide
/// some, e.g. a planar base), the machine's signals and diagnostics, the actuators. A
/// `[reference]` for a machine with nothing to track is an error.
fn signal_layout(
    mechanism: &Mechanism,
    machine: &dyn Machine,
    scenario: &crate::scenario::Scenario,
    actuators: &[Actuator],
) -> Result<SignalLayout, String> {
    let movable: Vec<usize> = (0..mechanism.joints.len())
        .filter(|&j| mechanism.joints[j].motion.is_movable())
        .collect();
    let hidden = machine.unmeasured_joints();
    let sensed = movable
        .iter()
        .copied()
        .filter(|&j| !hidden.contains(&mechanism.joints[j].name))
        .collect();
    let reference = match (&scenario.reference, machine.reference()) {
        (None, _) => None,
        (Some(_), Some(specs)) => Some(specs),
        (Some(_), None) => {
            return Err(format!(
                "[reference]: machine `{}` has no output to track; remove the table",
                scenario.machine
            ))
        }
    };
    Ok(SignalLayout::new(
        mechanism,
        LayoutParts {
            joint_specs: movable
                .iter()
                .map(|&j| machine.joint_signals(&mechanism.joints[j]))
                .collect(),
            movable,
            sensed,
            machine_signals: machine.signals(),
            reference,
            actuators: actuators.iter().map(|a| a.joint.clone()).collect(),
            effort_units: actuators
                .iter()
                .map(|a| [machine.command_unit(a), machines::effort_unit(a.kind)])
                .collect(),
            machine_diagnostics: machine.diagnostics(),
        },
    ))
}

/// Per plant signal, its sensor if the scenario gives one; an unknown signal is an error.
fn bind_sensors(
    loaded: &LoadedScenario,
    plant: &PlantInterface,
) -> Result<Vec<Option<Sensor>>, TwinError> {
    let scenario = &loaded.scenario;
    let mut sensors: Vec<Option<Sensor>> = vec![None; plant.signals.len()];
    for (name, spec) in &scenario.sensors {
        let index = plant
            .signals
            .iter()
            .position(|s| s == name)
            .ok_or_else(|| TwinError::UnknownSensor {
                source_name: loaded.source.clone(),
                urdf: loaded.urdf_source.clone(),
                signal: name.clone(),
                known: plant.signals.join(", "),
            })?;
        sensors[index] = Some(Sensor::new(*spec, scenario.control_period()));
    }
    Ok(sensors)
}

/// The crash detector of the run: the links' collision shapes, the scenario's bodies and its
/// allowed pairs. A free body needs the rapier engine (the exact one moves only the mechanism).
fn contact_detector(scenario: &Scenario, mechanism: &Mechanism) -> Result<ContactDetector, String> {
    let mut bodies = Vec::with_capacity(scenario.bodies.len());
    for (i, body) in scenario.bodies.iter().enumerate() {
        let moves = body.kind == BodyKind::Free;
        if moves && scenario.solver.engine == Engine::Exact {
            return Err(format!(
                "bodies.{i} `{}`: free bodies need `[solver] engine = \"rapier\"` (the exact \
                 engine moves only the mechanism); or make it `kind = \"static\"`",
                body.name
            ));
        }
        bodies.push(BodyShapes {
            name: body.name.clone(),
            shapes: body.outlines(),
            moves,
        });
    }
    let allowed: Vec<(&str, &str)> = scenario
        .allowed_contacts
        .iter()
        .map(|pair| (pair.a.as_str(), pair.b.as_str()))
        .collect();
    ContactDetector::new(mechanism, &bodies, &allowed).map_err(|e| e.to_string())
}

/// The scenario's `[initial]` entries as (tree joint, position, velocity); a name the URDF lacks
/// or a fixed joint is an error naming the entry. A state the loops cannot close as given adds
/// a note to the mechanism's.
fn initial_states(
    scenario: &Scenario,
    mechanism: &mut Mechanism,
) -> Result<Vec<(usize, f64, f64)>, String> {
    let initial = (scenario.initial.iter())
        .map(|(name, state)| {
            let joint = mechanism
                .joint_index(name)
                .filter(|&j| !matches!(mechanism.joints[j].motion, JointMotion::Fixed))
                .ok_or_else(|| format!("initial.{name}: the URDF has no moving joint `{name}`"))?;
            Ok((joint, state.position, state.velocity))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let note = unheld_initial(scenario, mechanism, &initial);
    mechanism.notes.extend(note);
    Ok(initial)
}

/// A note when the scenario's `[initial]` joints cannot all be held while the loops close
/// (given inconsistently, or every joint of a loop): the run then starts from the nearest closed
/// configuration, every joint moved, mass-weighted.
fn unheld_initial(
    scenario: &Scenario,
    mechanism: &Mechanism,
    initial: &[(usize, f64, f64)],
) -> Option<String> {
    if mechanism.loops.is_empty() || initial.is_empty() {
        return None;
    }
    let settings = crate::physics::SolverSettings::exact(scenario.dt, scenario.gravity, 1);
    let mut physics = crate::physics::Physics::new(mechanism, settings);
    if physics.set_joint_states(initial) {
        return None;
    }
    let names: Vec<&str> = (initial.iter())
        .map(|&(j, _, _)| mechanism.joints[j].name.as_str())
        .collect();
    Some(format!(
        "[initial]: the loops cannot close with {} where the scenario puts them; the run starts from the nearest closed configuration, every joint moved (name fewer joints to hold them)",
        names.join(", ")
    ))
}

/// The scenario's `[points]` as (name, link, where on the link in the plane); a point on a link
/// the URDF lacks is left out (the machine refuses it by name).
fn point_places(scenario: &Scenario, mechanism: &Mechanism) -> Vec<(String, usize, [f64; 2])> {
    (scenario.points.iter())
        .filter_map(|(name, spec)| {
            let link = mechanism.link_index(&spec.link)?;
            Some((name.clone(), link, spec.at.on(&mechanism.plane)))
        })
        .collect()
}

/// The scenario's machine built afresh on `mechanism`, with its `[process]` and `[actuators]`.
pub(crate) fn build_machine(
    scenario: &Scenario,
    mechanism: &Mechanism,
) -> Result<Box<dyn Machine>, MachineError> {
    machines::build(
        &scenario.machine,
        mechanism,
        &scenario.process,
        &scenario.actuators,
        &scenario.points,
    )
}

/// An actuator per actuated tree joint.
fn joint_actuators(mechanism: &Mechanism, actuated: &[usize]) -> Vec<Actuator> {
    actuated
        .iter()
        .map(|&j| {
            let joint = &mechanism.joints[j];
            Actuator {
                joint: joint.name.clone(),
                kind: effort_kind(joint),
                effort_limit: joint.effort_limit.unwrap_or(f64::INFINITY),
            }
        })
        .collect()
}
