//! The controller interface: measurement in, joint efforts out.

use crate::event::Event;
use crate::signal::SignalSpec;
use thiserror::Error;

/// What an actuated joint takes as effort.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EffortKind {
    /// N·m on a revolute or continuous joint.
    Torque,
    /// N on a prismatic joint.
    Force,
}

/// One actuated joint as a controller sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    /// The joint's name in the URDF.
    pub joint: String,
    pub kind: EffortKind,
    /// Largest |effort| the twin applies (from the URDF `<limit effort>`); the command is clipped to it.
    pub effort_limit: f64,
}

/// The plant as a controller may know it before the run: which signals it measures and which
/// joints it can drive. Indices into [`Measurement::signals`] and into the effort slice follow
/// the order of `signals` and `actuators`.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantInterface {
    /// The machine's name, e.g. `whitworth`.
    pub machine: String,
    /// Measured signal names: `<joint>.position`, `<joint>.velocity`, the machine's task-space and
    /// process signals (e.g. `ram_position`, `cutting_force`) and the scenario's references.
    pub signals: Vec<String>,
    pub actuators: Vec<Actuator>,
}

impl PlantInterface {
    /// Index of a measured signal, or an error naming what is missing.
    pub fn signal(&self, name: &str) -> Result<usize, ControllerError> {
        self.signals
            .iter()
            .position(|s| s == name)
            .ok_or_else(|| ControllerError::MissingSignal {
                machine: self.machine.clone(),
                signal: name.to_string(),
            })
    }

    /// Index of the actuator on `joint`, or an error naming it.
    pub fn actuator(&self, joint: &str) -> Result<usize, ControllerError> {
        self.actuators
            .iter()
            .position(|a| a.joint == joint)
            .ok_or_else(|| ControllerError::MissingActuator {
                machine: self.machine.clone(),
                joint: joint.to_string(),
            })
    }
}

/// One sample of every measured signal, in the order of [`PlantInterface::signals`].
#[derive(Debug, Clone, Copy)]
pub struct Measurement<'a> {
    /// Simulated time at the sample, s.
    pub time: f64,
    pub signals: &'a [f64],
}

impl Measurement<'_> {
    /// The value of the signal at `index` (from [`PlantInterface::signal`]).
    pub fn get(&self, index: usize) -> f64 {
        self.signals[index]
    }
}

/// Errors a controller reports when built or bound to a plant; all are raised before a run starts.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ControllerError {
    #[error("unknown controller `{name}` (known: {known})")]
    Unknown { name: String, known: String },
    #[error("controller `{controller}`: bad parameters: {reason}")]
    BadParameters { controller: String, reason: String },
    #[error("controller needs signal `{signal}`, which machine `{machine}` does not measure")]
    MissingSignal { machine: String, signal: String },
    #[error(
        "controller needs an actuator on joint `{joint}`, which machine `{machine}` does not have (a URDF joint is actuated when its <limit effort> is > 0)"
    )]
    MissingActuator { machine: String, joint: String },
    #[error("controller `{controller}` does not fit machine `{machine}`")]
    WrongMachine { controller: String, machine: String },
}

/// A controller: object safe, so the twin holds any of them as `Box<dyn Controller>`.
///
/// The twin calls [`reset`](Controller::reset) once, then [`update`](Controller::update) once per
/// control period; the efforts it writes are held (zero-order hold) until the next period.
pub trait Controller: Send {
    /// The registry name, e.g. `crank-pi`.
    fn name(&self) -> &str;

    /// Binds the controller to a plant (resolving signal and actuator indices) and clears its
    /// state. Fails when the plant lacks what the controller needs.
    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError>;

    /// One control period: reads `measurement`, writes one effort per actuator (N·m or N) into
    /// `efforts`, which arrives zeroed.
    fn update(&mut self, measurement: &Measurement, period: f64, efforts: &mut [f64]);

    /// The internal signals recorded with the run, with their units and plots (fixed after
    /// `reset`). A signal on the plot of a plant signal is drawn with it (a command with what it
    /// commands).
    fn internals(&self) -> Vec<SignalSpec> {
        Vec::new()
    }

    /// The internal signals after the last update, in the order of `internals`.
    fn internal_values(&self, _values: &mut [f64]) {}

    /// Moves the events raised since the last call (mode switches, saturation) into `events`.
    fn drain_events(&mut self, _events: &mut Vec<Event>) {}
}
