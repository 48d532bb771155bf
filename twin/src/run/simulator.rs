//! `Simulator`: the plant without its controller, stepped from outside one control period at a
//! time (an FMU, a control engineer's own loop), or the twin's closed loop with its controller,
//! stepped likewise with a host's disturbances and setpoint ([`Simulator::with_controller`]). It
//! runs the run loop's own stages ([`Session::hold`], [`Session::close`]); whole runs keep their
//! one door, [`Twin::run_with`].

use super::plant_model::effort_kind;
use super::session::Session;
use super::summary::Divergence;
use super::twin::{Twin, TwinError};
use crate::scenario::{LoadedScenario, Scenario};
use framework::{
    Actuator, Controller, ControllerError, EffortKind, Measurement, PlantInterface, Registry,
    SignalSpec,
};
use thiserror::Error;

/// Why a step was refused or failed.
#[derive(Debug, Error)]
pub enum StepError {
    /// [`Simulator::step`] was given a number of efforts other than one per actuator.
    #[error("efforts: {given} values given for {expected} actuators ({names}); give one per actuator in that order")]
    Length {
        /// Efforts given.
        given: usize,
        /// Actuators the plant has.
        expected: usize,
        /// The actuators, comma-separated, in the order the efforts go.
        names: String,
    },
    /// An effort given to [`Simulator::step`] is NaN or infinite.
    #[error("effort of actuator `{actuator}` is {value}: must be a finite number")]
    NotFinite {
        /// The actuator's joint.
        actuator: String,
        /// The value given.
        value: f64,
    },
    /// The plant diverged or crashed, in this period or an earlier one: every step is refused
    /// until a reset.
    #[error("the plant diverged at step {} (t = {} s): {} = {}; reset it", .0.step, .0.time, .0.signal, .0.value)]
    Diverged(Divergence),
    /// [`Simulator::step_closed_loop`] was given a number of disturbances other than one per
    /// movable joint.
    #[error("disturbances: {given} values given for {expected} joints ({names}); give one per joint in that order")]
    Disturbances {
        /// Disturbances given.
        given: usize,
        /// Movable joints the plant has.
        expected: usize,
        /// The movable joints, comma-separated, in the order the disturbances go.
        names: String,
    },
    /// A disturbance or reference offset given to [`Simulator::step_closed_loop`] is NaN or
    /// infinite.
    #[error("{input} is {value}: must be a finite number")]
    NotFiniteInput {
        /// Which input: the disturbance's joint or the reference offset's component.
        input: String,
        /// The value given.
        value: f64,
    },
    /// [`Simulator::step`] was called on a simulator whose controller commands the efforts;
    /// holds the controller's name.
    #[error("the simulator runs its controller `{0}`, which commands the efforts; step it with step_closed_loop")]
    ControllerInLoop(String),
    /// [`Simulator::step_closed_loop`] was called on a simulator made without its controller.
    #[error("the simulator has no controller (Simulator::new); step it with step(efforts), or make it with Simulator::with_controller")]
    NoController,
    /// A non-zero reference offset was given where the reference cannot take one; holds why
    /// (see [`Simulator::reference_inputs`]).
    #[error("reference offset: {0}; leave it at zero")]
    NoReference(&'static str),
}

/// The twin's scenario stepped from outside: its plant alone ([`Simulator::new`]) or its closed
/// loop with its controller ([`Simulator::with_controller`]).
///
/// # Example
///
/// The feed axis's plant, its controller left out, pushed by a constant motor force:
///
/// ```
/// use twin::{Scenario, Simulator};
///
/// let loaded = Scenario::builtin("feed-axis-micromilling")?.build(&controllers::builtin())?;
/// let mut plant = Simulator::new(loaded)?;
/// let force = vec![0.5; plant.actuators().len()]; // N, held over one control period
/// let measured = plant.step(&force)?.to_vec();
/// assert_eq!(measured.len(), plant.signal_specs().len());
/// assert!(plant.time() > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Simulator {
    /// The scenario as loaded, without its controller, to build the plant again on a reset.
    recipe: LoadedScenario,
    session: Session<Box<Twin>>,
    /// The physics step reached (a control update).
    step: usize,
    failure: Option<Divergence>,
    /// The registry the scenario's controller is built from on every (re)start, when the
    /// controller is in the loop.
    registry: Option<Registry>,
}

/// The controller slot of a twin stepped from outside: its efforts come with each step.
struct Outside;

impl Controller for Outside {
    fn name(&self) -> &str {
        "outside"
    }

    fn reset(&mut self, _plant: &PlantInterface) -> Result<(), ControllerError> {
        Ok(())
    }

    fn update(&mut self, _measurement: &Measurement, _period: f64, _efforts: &mut [f64]) {}
}

impl Simulator {
    /// The scenario's plant at its start (t = 0, the scenario's seed), its controller left out.
    pub fn new(loaded: LoadedScenario) -> Result<Self, TwinError> {
        Self::start(loaded, None)
    }

    /// The scenario's closed loop at its start: its controller (`[controller]`, built from
    /// `registry` afresh on every reset, as a run builds it) in the loop, stepped with
    /// [`Simulator::step_closed_loop`].
    pub fn with_controller(loaded: LoadedScenario, registry: &Registry) -> Result<Self, TwinError> {
        Self::start(loaded, Some(registry.clone()))
    }

    fn start(loaded: LoadedScenario, registry: Option<Registry>) -> Result<Self, TwinError> {
        let recipe = LoadedScenario {
            controller: Box::new(Outside),
            ..loaded
        };
        let seed = recipe.scenario.seed;
        let (session, failure) = Self::build(&recipe, seed, registry.as_ref())?;
        Ok(Self {
            recipe,
            session,
            step: 0,
            failure,
            registry,
        })
    }

    fn build(
        recipe: &LoadedScenario,
        seed: u64,
        registry: Option<&Registry>,
    ) -> Result<(Session<Box<Twin>>, Option<Divergence>), TwinError> {
        let mut scenario = recipe.scenario.clone();
        scenario.seed = seed;
        let controller: Box<dyn Controller> = match registry {
            None => Box::new(Outside),
            Some(registry) => {
                let spec = &scenario.controller;
                (registry.build(&spec.name, &scenario.machine, &spec.params)).map_err(|source| {
                    TwinError::Controller {
                        context: recipe.source.clone(),
                        source,
                    }
                })?
            }
        };
        let loaded = LoadedScenario {
            scenario,
            toml: recipe.toml.clone(),
            source: recipe.source.clone(),
            urdf_text: recipe.urdf_text.clone(),
            urdf_source: recipe.urdf_source.clone(),
            controller,
            folder: recipe.folder.clone(),
        };
        let mut session = Session::new(Box::new(Twin::new(loaded)?));
        let failure = session.begin()?;
        Ok((session, failure))
    }

    /// Back to t = 0 with the sensor noise and fault draws of `seed`.
    pub fn reset(&mut self, seed: u64) -> Result<(), TwinError> {
        let (session, failure) = Self::build(&self.recipe, seed, self.registry.as_ref())?;
        (self.session, self.step, self.failure) = (session, 0, failure);
        Ok(())
    }

    /// One control period with `efforts` (one per actuator, in [`Simulator::actuators`]' order,
    /// SI, in [`Simulator::command_units`]: N, N·m, or A where a drive takes a current) held,
    /// clipped to [`Simulator::command_limits`] as in a run; the measured signals at its end. After
    /// a divergence every step is refused until a reset.
    pub fn step(&mut self, efforts: &[f64]) -> Result<&[f64], StepError> {
        if self.registry.is_some() {
            return Err(StepError::ControllerInLoop(self.controller().into()));
        }
        let actuators = self.actuators();
        if efforts.len() != actuators.len() {
            return Err(StepError::Length {
                given: efforts.len(),
                expected: actuators.len(),
                names: names(actuators),
            });
        }
        if let Some((actuator, &value)) = actuators
            .iter()
            .zip(efforts)
            .find(|(_, value)| !value.is_finite())
        {
            return Err(StepError::NotFinite {
                actuator: actuator.joint.clone(),
                value,
            });
        }
        if let Some(failure) = &self.failure {
            return Err(StepError::Diverged(failure.clone()));
        }
        let reached = self.session.hold(self.step, efforts);
        self.reached(reached)
    }

    /// One control period of the twin's own loop (a simulator made with
    /// [`Simulator::with_controller`]): the controller updates on what the sensors read now, its
    /// efforts go through the limits and drives; `disturbances` (one per movable joint, in
    /// [`Simulator::joints`]' order, N or N·m) act on the joints on top of them, unseen by the
    /// controller (a load), and `reference_offset` (position, rate, acceleration, the reference's
    /// SI units) is added to the scenario's `[reference]` from now on, the controller's reading
    /// now included. Both are held over the period. The measured signals at its end.
    pub fn step_closed_loop(
        &mut self,
        disturbances: &[f64],
        reference_offset: [f64; 3],
    ) -> Result<&[f64], StepError> {
        if self.registry.is_none() {
            return Err(StepError::NoController);
        }
        self.check_inputs(disturbances, &reference_offset)?;
        if reference_offset != [0.0; 3] {
            self.reference_inputs().map_err(StepError::NoReference)?;
        }
        if let Some(failure) = &self.failure {
            return Err(StepError::Diverged(failure.clone()));
        }
        let reached = self
            .session
            .close(self.step, disturbances, reference_offset);
        self.reached(reached)
    }

    /// One disturbance per movable joint and every input finite, or the error naming the input
    /// (the names are made only then: this runs every period).
    fn check_inputs(&self, disturbances: &[f64], offset: &[f64; 3]) -> Result<(), StepError> {
        let joints = self.session.twin().layout.movable_joints().len();
        if disturbances.len() != joints {
            let names: Vec<&str> = self.joints().iter().map(|(name, _)| *name).collect();
            return Err(StepError::Disturbances {
                given: disturbances.len(),
                expected: joints,
                names: names.join(", "),
            });
        }
        let inputs = disturbances.iter().chain(offset);
        let Some(k) = inputs.clone().position(|v| !v.is_finite()) else {
            return Ok(());
        };
        let input = match k.checked_sub(joints) {
            None => format!("disturbance on joint `{}`", self.joints()[k].0),
            Some(r) => {
                let names = ["reference", "reference_rate", "reference_acceleration"];
                format!("reference offset `{}`", names[r])
            }
        };
        let value = inputs.copied().nth(k).unwrap_or(f64::NAN);
        Err(StepError::NotFiniteInput { input, value })
    }

    /// Where a period ended: the step reached, or the failure (remembered: every later step is
    /// refused until a reset).
    fn reached(&mut self, reached: Result<usize, Divergence>) -> Result<&[f64], StepError> {
        match reached {
            Ok(step) => self.step = step,
            Err(failure) => {
                self.step = failure.step;
                self.failure = Some(failure.clone());
                return Err(StepError::Diverged(failure));
            }
        }
        Ok(self.session.measured())
    }

    /// Whether a reference offset can reach the controller exactly: the scenario has a
    /// `[reference]` and no sensor or sensor fault stands between it and the controller; else
    /// why not.
    pub fn reference_inputs(&self) -> Result<(), &'static str> {
        self.session.twin().reference_inputs()
    }

    /// The reference signals' indices among the plant's signals (empty without a
    /// `[reference]`).
    pub(crate) fn reference_signals(&self) -> std::ops::Range<usize> {
        self.session.twin().layout.reference_range()
    }

    /// The controller in the loop (`outside` for the plant alone).
    pub fn controller(&self) -> &str {
        self.session.twin().loaded.controller.name()
    }

    /// The movable joints, in the order of [`Simulator::step_closed_loop`]'s disturbances, each
    /// with the effort it takes (a force on a prismatic joint, else a torque).
    pub fn joints(&self) -> Vec<(&str, EffortKind)> {
        let twin = self.session.twin();
        let joints = twin.layout.movable_joints().iter();
        joints
            .map(|&j| {
                let joint = &twin.mechanism.joints[j];
                (joint.name.as_str(), effort_kind(joint))
            })
            .collect()
    }

    /// The SI unit of each actuator's command, in [`Simulator::actuators`]' order: N·m or N,
    /// or what the machine's drive takes instead (the arm's current, A).
    pub fn command_units(&self) -> Vec<&'static str> {
        let efforts = &self.session.twin().layout.specs.efforts;
        efforts
            .iter()
            .map(|[commanded, _]| commanded.si_label())
            .collect()
    }

    /// The controller's internal signals (names, display units, plots); none without one.
    pub fn internal_specs(&self) -> &[SignalSpec] {
        &self.session.twin().layout.specs.internals
    }

    /// The SI unit of each internal signal's values.
    pub fn internal_units(&self) -> Vec<&'static str> {
        self.internal_specs()
            .iter()
            .map(|s| s.unit.si_label())
            .collect()
    }

    /// The controller's internal signals after its last update (SI).
    pub fn internals(&self) -> &[f64] {
        self.session.internals()
    }

    /// The efforts the controller commanded at its last update, before the limits (SI; with
    /// the plant alone, those last given to [`Simulator::step`]).
    pub fn commanded(&self) -> &[f64] {
        self.session.commanded()
    }

    /// The simulated time, s.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.scenario().dt
    }

    /// The scenario stepped (its `dt`, `control_period`, `duration`, `seed`).
    pub fn scenario(&self) -> &Scenario {
        &self.session.twin().loaded.scenario
    }

    /// The actuators, in the order of a step's efforts, with the joints' effort limits.
    pub fn actuators(&self) -> &[Actuator] {
        &self.session.twin().plant.actuators
    }

    /// Each actuator's largest command, in [`Simulator::command_units`]: a step clips to it
    /// (the joint's effort limit, or the drive's current limit where a drive takes a current).
    pub fn command_limits(&self) -> &[f64] {
        &self.session.twin().command_limits
    }

    /// The plant's signals (names, display units, plots), in the order of the measured and the
    /// true values.
    pub fn signal_specs(&self) -> &[SignalSpec] {
        &self.session.twin().layout.specs.signals
    }

    /// The SI unit of each signal's values (`m`, `rad/s`, `N·m`, …).
    pub fn signal_units(&self) -> Vec<&'static str> {
        self.signal_specs()
            .iter()
            .map(|s| s.unit.si_label())
            .collect()
    }

    /// Per signal: whether a sensor (quantisation, noise, delay) stands between it and its
    /// measurement.
    pub fn sensed(&self) -> Vec<bool> {
        self.session
            .twin()
            .sensors
            .iter()
            .map(Option::is_some)
            .collect()
    }

    /// What the sensors read at the last control update (SI).
    pub fn measured(&self) -> &[f64] {
        self.session.measured()
    }

    /// The plant's true signals now (SI).
    pub fn true_signals(&self) -> &[f64] {
        self.session.signals()
    }

    /// The model checks' names and units: the machine's own figures (a tool's distance from
    /// its path, a pose), one `loop_gap/<loop>` per loop closure, and `mechanical_energy`.
    pub fn diagnostic_specs(&self) -> &[SignalSpec] {
        &self.session.twin().layout.specs.diagnostics
    }

    /// The model checks now (SI), in the order of [`Simulator::diagnostic_specs`].
    pub fn diagnostics(&self) -> &[f64] {
        self.session.diagnostics()
    }
}

fn names(actuators: &[Actuator]) -> String {
    let names: Vec<&str> = actuators.iter().map(|a| a.joint.as_str()).collect();
    names.join(", ")
}
