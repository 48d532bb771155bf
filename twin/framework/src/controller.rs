//! The controller interface: measurement in, joint efforts out.

use crate::event::Event;
use crate::plant_model::{Dynamics, EffortKind, ScenarioFiles};
use crate::signal::SignalSpec;
use std::fmt;
use std::sync::Arc;
use thiserror::Error;

/// One actuated joint as a controller sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    /// The joint's name in the URDF.
    pub joint: String,
    /// Whether the joint takes a torque (N·m) or a force (N).
    pub kind: EffortKind,
    /// Largest |effort| the twin applies (from the URDF `<limit effort>`); the command is clipped
    /// to it.
    pub effort_limit: f64,
}

/// The plant as a controller may know it before the run: which signals it measures and which
/// joints it can drive, and what the engine lends it (its equations of motion, the scenario's
/// data files). Indices into [`Measurement::signals`] and into the effort slice follow the order
/// of `signals` and `actuators`.
#[derive(Clone, Default)]
pub struct PlantInterface {
    /// The machine's name, e.g. `whitworth`.
    pub machine: String,
    /// Measured signal names: `<joint>.position`, `<joint>.velocity`, the machine's task-space and
    /// process signals (e.g. `ram_position`, `cutting_force`) and the scenario's references.
    pub signals: Vec<String>,
    /// The actuated joints, in the order of the effort slice [`Controller::update`] fills.
    pub actuators: Vec<Actuator>,
    /// The mechanism's equations of motion, where the engine lends them (the twin does).
    pub dynamics: Option<Arc<dyn Dynamics>>,
    /// The data files beside the scenario, where the engine reads them (the twin does).
    pub files: Option<Arc<dyn ScenarioFiles>>,
}

impl fmt::Debug for PlantInterface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PlantInterface")
            .field("machine", &self.machine)
            .field("signals", &self.signals)
            .field("actuators", &self.actuators)
            .field("dynamics", &self.dynamics.as_ref().map(|d| d.coordinates()))
            .field("files", &self.files.is_some())
            .finish()
    }
}

/// Two plants are equal when they measure and drive the same and lend the same model and files
/// (the same objects).
impl PartialEq for PlantInterface {
    fn eq(&self, other: &Self) -> bool {
        fn same<T: ?Sized>(a: &Option<Arc<T>>, b: &Option<Arc<T>>) -> bool {
            match (a, b) {
                (Some(a), Some(b)) => Arc::ptr_eq(a, b),
                (None, None) => true,
                _ => false,
            }
        }
        self.machine == other.machine
            && self.signals == other.signals
            && self.actuators == other.actuators
            && same(&self.dynamics, &other.dynamics)
            && same(&self.files, &other.files)
    }
}

impl PlantInterface {
    /// The equations of motion, or an error saying the controller `controller` needs them.
    pub fn dynamics(&self, controller: &str) -> Result<&Arc<dyn Dynamics>, ControllerError> {
        self.dynamics
            .as_ref()
            .ok_or_else(|| ControllerError::NoModel {
                controller: controller.to_string(),
                machine: self.machine.clone(),
                what: "equations of motion",
            })
    }

    /// The scenario's files, or an error saying the controller `controller` needs them.
    pub fn files(&self, controller: &str) -> Result<&Arc<dyn ScenarioFiles>, ControllerError> {
        self.files.as_ref().ok_or_else(|| ControllerError::NoModel {
            controller: controller.to_string(),
            machine: self.machine.clone(),
            what: "data files",
        })
    }
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

    /// Index of the actuator on `joint`, which must take efforts of `kind`, or an error naming
    /// what is missing or different.
    pub fn actuator_of_kind(
        &self,
        joint: &str,
        kind: EffortKind,
    ) -> Result<usize, ControllerError> {
        let index = self.actuator(joint)?;
        let found = self.actuators[index].kind;
        if found != kind {
            return Err(ControllerError::WrongEffort {
                machine: self.machine.clone(),
                joint: joint.to_string(),
                expected: kind,
                found,
            });
        }
        Ok(index)
    }
}

/// One sample of every measured signal, in the order of [`PlantInterface::signals`].
#[derive(Debug, Clone, Copy)]
pub struct Measurement<'a> {
    /// Simulated time at the sample, s.
    pub time: f64,
    /// The sampled values, SI, in the order of [`PlantInterface::signals`].
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
    /// No controller of the registry has the requested name.
    #[error("unknown controller `{name}` (known: {known})")]
    Unknown {
        /// The name asked for.
        name: String,
        /// The registered names, comma-separated, for the message.
        known: String,
    },
    /// An entry of the controller's `[controller.params]` table that cannot be used.
    #[error("controller `{controller}`: {}", parameter_message(key, value.as_deref(), reason))]
    BadParameter {
        /// The controller's name.
        controller: String,
        /// Dotted path of the entry inside the table (`natural_frequency`, `lathe.max_feed`,
        /// `time_constants.0`); empty when the error concerns the whole table.
        key: String,
        /// The offending value as written, when one value is at fault.
        value: Option<String>,
        /// What the value must be (`must be > 0`), without repeating the key.
        reason: String,
    },
    /// The plant does not measure a signal the controller reads.
    #[error("controller needs signal `{signal}`, which machine `{machine}` does not measure")]
    MissingSignal {
        /// The machine's name.
        machine: String,
        /// The signal's name, e.g. `ram_position`.
        signal: String,
    },
    /// The plant has no actuator on a joint the controller drives.
    #[error(
        "controller needs an actuator on joint `{joint}`, which machine `{machine}` does not have (a URDF joint is actuated when its <limit effort> is > 0)"
    )]
    MissingActuator {
        /// The machine's name.
        machine: String,
        /// The URDF joint the controller would drive.
        joint: String,
    },
    /// An actuated joint takes the other kind of effort than the controller commands.
    #[error(
        "controller needs joint `{joint}` of machine `{machine}` to take a {expected}, not a {found}"
    )]
    WrongEffort {
        /// The machine's name.
        machine: String,
        /// The URDF joint.
        joint: String,
        /// The effort the controller commands.
        expected: EffortKind,
        /// The effort the joint takes.
        found: EffortKind,
    },
    /// The controller needs what the engine lends (its equations of motion, the scenario's data
    /// files) and the plant it is bound to lends none.
    #[error("controller `{controller}` needs the {what} of machine `{machine}`, which this plant does not lend (run it in the twin)")]
    NoModel {
        /// The controller's name.
        controller: String,
        /// The machine's name.
        machine: String,
        /// What it needs: `equations of motion` or `data files`.
        what: &'static str,
    },
    /// The controller is registered for another machine than the one it was asked for.
    #[error("controller `{controller}` is written for machine `{written_for}`, not `{machine}`")]
    WrongMachine {
        /// The controller's name.
        controller: String,
        /// The machine it was asked for.
        machine: String,
        /// The machine it is registered for ([`Entry::machine`](crate::Entry::machine)).
        written_for: String,
    },
}

impl ControllerError {
    /// A [`BadParameter`](Self::BadParameter) error of `controller`: the entry `key` holds
    /// `value`, which it must not (`reason`, e.g. `must be > 0`).
    pub fn parameter(
        controller: &str,
        key: impl Into<String>,
        value: impl fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Self::BadParameter {
            controller: controller.to_string(),
            key: key.into(),
            value: Some(shown(value.to_string())),
            reason: reason.into(),
        }
    }

    /// A [`BadParameter`](Self::BadParameter) error about a whole table (`key` empty) or
    /// sub-table (e.g. `lathe`) rather than one value, such as a model that rejects its data.
    pub fn parameter_table(
        controller: &str,
        key: impl Into<String>,
        reason: impl Into<String>,
    ) -> Self {
        Self::BadParameter {
            controller: controller.to_string(),
            key: key.into(),
            value: None,
            reason: reason.into(),
        }
    }
}

/// A value as a one-line message shows it: a number whose digits run long (`1e300` written out
/// has 301) in exponent form.
fn shown(value: String) -> String {
    match value.parse::<f64>() {
        Ok(number) if value.len() > 20 => format!("{number:e}"),
        _ => value,
    }
}

/// A parameter error as the controller's table sees it: `params.KEY = VALUE: reason`, without
/// ` = VALUE` when no single value is at fault and `params: reason` for the whole table. The
/// scenario layer prefixes `controller.` to name the entry in the scenario file.
pub fn parameter_message(key: &str, value: Option<&str>, reason: &str) -> String {
    let path = if key.is_empty() {
        "params".to_string()
    } else {
        format!("params.{key}")
    };
    match value {
        Some(value) => format!("{path} = {value}: {reason}"),
        None => format!("{path}: {reason}"),
    }
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
