//! What a scenario holds: the machine and its URDF, the controller and its parameters, the
//! reference, process parameters, sensors, timing and recording options, as its TOML says them.

use super::metrics::MetricSpec;
use crate::faults::FaultSpec;
use crate::machines::ActuatorSpecs;
use crate::physics::{AllowedContact, BodySpec, ContactOptions, SolverOptions};
use crate::plant::PlantValues;
use crate::sensors::SensorSpec;
use models::reference::Reference;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Default cap on physics steps per run (`max_steps`): about a minute of the fastest machine,
/// and a recording of a few GB at `recording.every = 1`.
pub const DEFAULT_MAX_STEPS: usize = 10_000_000;

/// A scenario as its TOML gives it (see the module doc);
/// [`LoadedScenario`](super::loaded::LoadedScenario) is one checked.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// The scenario's name, as the run's summary gives it.
    pub name: String,
    /// What the scenario shows, for the reader.
    #[serde(default)]
    pub description: String,
    /// Machine kind: `whitworth`, …, or `generic` (the default: any planar mechanism, its
    /// signals the joints' and the `[points]`).
    #[serde(default = "default_machine")]
    pub machine: String,
    /// URDF path, relative to the scenario file (built-in files are found by this path too).
    pub urdf: String,
    /// Simulated time, s.
    pub duration: f64,
    /// Physics step, s.
    pub dt: f64,
    /// Controller period, s; a whole multiple of dt (zero-order hold). Defaults to dt.
    pub control_period: Option<f64>,
    /// Gravitational acceleration in the plane [x, y], m/s² (default [0, −9.81]): the TOML's
    /// `gravity` as two numbers, or its three in the URDF's own frame laid onto the plane with
    /// the URDF ([`Scenario::gravity_given`]) once the twin is bound.
    #[serde(skip)]
    pub gravity: [f64; 2],
    /// The TOML's `gravity` as given: [x, y] in the plane, or [x, y, z] in the URDF's frame
    /// (`[0, 0, -9.81]` for a z-up model).
    #[serde(rename = "gravity", default = "default_gravity")]
    pub gravity_given: Gravity,
    /// RK4 substeps per physics step (efforts and process loads are held over the step).
    #[serde(default = "default_substeps")]
    pub substeps: usize,
    /// Refuse runs of more physics steps than this (duration / dt); raise it for a long run.
    #[serde(default = "default_max_steps")]
    pub max_steps: usize,
    /// Seed of the sensor noise.
    #[serde(default)]
    pub seed: u64,
    /// The controller and its parameters (`[controller]`).
    pub controller: ControllerSpec,
    /// Reference given to the controller as `reference`, `reference_rate`,
    /// `reference_acceleration`.
    pub reference: Option<Reference>,
    /// Machine-specific process parameters (contact forces, geometry checks).
    #[serde(default)]
    pub process: toml::Table,
    /// The generic machine's task-space points (`[points.<name>]`): their positions and rates
    /// as signals, and the loads they carry.
    #[serde(default)]
    pub points: crate::machines::PointSpecs,
    /// How each actuator turns its command into the joint's effort (`[actuators.<joint>]`, or
    /// `[actuators."*"]` for every one): `kind = "drive"` (the default) through the machine's own
    /// drive, `kind = "effort"` directly, the command the joint's torque or force. Checked
    /// against the machine's actuators when the twin is built.
    #[serde(default)]
    pub actuators: ActuatorSpecs,
    /// Sensor models by measured signal name.
    #[serde(default)]
    pub sensors: BTreeMap<String, SensorSpec>,
    /// What the recording samples (`[recording]`).
    #[serde(default)]
    pub recording: RecordingOptions,
    /// The bounds beyond which the run is declared diverged (`[health]`).
    #[serde(default)]
    pub health: HealthLimits,
    /// The figures the run is judged by (`[[metrics]]`), computed by evaluators.
    #[serde(default)]
    pub metrics: Vec<MetricSpec>,
    /// Values replacing the URDF's (`[plant.link.<name>]`, `[plant.joint.<name>]`); `set` and
    /// `--set` also take them as `urdf.link.<name>.mass=…`.
    #[serde(default)]
    pub plant: PlantValues,
    /// The state a joint starts in (`[initial.<joint>] position, velocity`; default: at rest at
    /// the URDF's zero), such as a spindle already at speed when the cut begins.
    #[serde(default)]
    pub initial: BTreeMap<String, InitialJoint>,
    /// Injected faults (`[[faults]]`), see the `faults` module.
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// The engine that steps the mechanism and its settings (`[solver]`).
    #[serde(default)]
    pub solver: SolverOptions,
    /// How the rapier engine resolves contacts (`[contact]`).
    #[serde(default)]
    pub contact: ContactOptions,
    /// Rigid bodies beside the machine (`[[bodies]]`): a clamp, a wall, a free box.
    #[serde(default)]
    pub bodies: Vec<BodySpec>,
    /// Pairs of links or bodies that touch by design (`[[allowed_contacts]]`); adjacent links
    /// are allowed without an entry.
    #[serde(default)]
    pub allowed_contacts: Vec<AllowedContact>,
    /// How `twin calibrate` fits this scenario to measured runs (`[calibration]`); the command
    /// line adds to it. Runs ignore it.
    pub calibration: Option<CalibrationSpec>,
}

/// `[calibration]`: the runs, the parameters and the options of `twin calibrate`; file paths
/// are relative to the scenario file.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CalibrationSpec {
    /// The measured runs fitted (`--data`).
    pub data: Vec<String>,
    /// Runs replayed after the fit, never fitted (`--validate`).
    pub validate: Vec<String>,
    /// The parameters by scenario key (`--fit`, `--bounds`, `--per-run`).
    pub fit: BTreeMap<String, FitSpec>,
    /// The fitted signals (`--signal`); empty: every logged one.
    pub signals: Vec<String>,
    /// Noise σ per signal, SI (`--noise`); others are estimated from the data.
    pub noise: BTreeMap<String, f64>,
    /// Segment length, s (`--segment`).
    pub segment: Option<f64>,
    /// Start states fitted per segment: `auto`, `none` or joints separated by commas
    /// (`--states`).
    pub states: Option<String>,
    /// Replay the runs with the scenario's controller on the logged reference (`--closed-loop`).
    pub closed_loop: bool,
    /// Starts of the solve (`--starts`).
    pub starts: Option<usize>,
    /// Column renames, old name = new name (`--rename`).
    pub rename: BTreeMap<String, String>,
    /// `[calibration.map]`, the old name of `[calibration.rename]`: never read, as it is refused
    /// with the new name.
    #[serde(rename = "map", deserialize_with = "refuse_old_map")]
    _map: Option<toml::Table>,
}

/// Refuses `[calibration.map]` in one line: the table is `[calibration.rename]` now.
fn refuse_old_map<'de, D: serde::Deserializer<'de>>(_: D) -> Result<Option<toml::Table>, D::Error> {
    Err(serde::de::Error::custom(
        "the table is now called [calibration.rename]; rename [calibration.map] to it",
    ))
}

/// One parameter of `[calibration.fit]`.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FitSpec {
    /// Where the fit starts (default: the scenario's or the URDF's value).
    pub start: Option<f64>,
    /// Lowest and highest value allowed.
    pub bounds: Option<[f64; 2]>,
    /// Fitted once per run rather than shared by all.
    pub per_run: bool,
}

/// A joint's state at t = 0, in the joint's own sense (rad or m, rad/s or m/s).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct InitialJoint {
    /// Joint coordinate, rad or m.
    pub position: f64,
    /// Joint rate, rad/s or m/s.
    pub velocity: f64,
}

/// `[controller]`: which controller runs the machine and with what parameters.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// The controller's registry name, e.g. `crank-pi`.
    pub name: String,
    /// Its parameters (`[controller.params]`), typed and checked by the controller when built.
    #[serde(default)]
    pub params: toml::Table,
}

/// `[recording]`: how densely the run is recorded.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RecordingOptions {
    /// Record every n-th physics step.
    pub every: usize,
}

impl Default for RecordingOptions {
    fn default() -> Self {
        Self { every: 1 }
    }
}

/// Beyond these the run is declared diverged and stopped.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct HealthLimits {
    /// Largest |joint velocity|, rad/s or m/s.
    pub max_joint_speed: f64,
    /// Largest loop-closure gap, m.
    pub max_loop_gap: f64,
    /// Stop the run (exit 3) at the first contact of a pair not allowed, naming both.
    pub stop_on_collision: bool,
}

impl Default for HealthLimits {
    fn default() -> Self {
        Self {
            max_joint_speed: 1e3,
            max_loop_gap: 1e-2,
            stop_on_collision: false,
        }
    }
}

fn default_machine() -> String {
    crate::machines::GENERIC.into()
}

fn default_gravity() -> Gravity {
    Gravity::InPlane([0.0, -9.81])
}

/// Gravity as a scenario gives it.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(try_from = "Vec<f64>")]
pub enum Gravity {
    /// [x, y] in the plane the mechanism moves in, m/s².
    InPlane([f64; 2]),
    /// [x, y, z] in the URDF's frame, m/s²; its part along the plane's normal is borne by the
    /// joints and moves nothing.
    InUrdf([f64; 3]),
}

impl TryFrom<Vec<f64>> for Gravity {
    type Error = String;

    fn try_from(values: Vec<f64>) -> Result<Self, String> {
        match values.as_slice() {
            &[x, y] => Ok(Gravity::InPlane([x, y])),
            &[x, y, z] => Ok(Gravity::InUrdf([x, y, z])),
            other => Err(format!(
                "{} elements: give 2 (in the plane, m/s²) or 3 (in the URDF's frame)",
                other.len()
            )),
        }
    }
}

impl Gravity {
    /// The gravity in the plane `plane` lays the URDF onto.
    pub(crate) fn in_plane(&self, plane: &crate::mechanism::Plane) -> [f64; 2] {
        match *self {
            Gravity::InPlane(g) => g,
            Gravity::InUrdf(g) => {
                let [x, y, _] = plane.vector(g);
                [x, y]
            }
        }
    }
}

fn default_substeps() -> usize {
    1
}

fn default_max_steps() -> usize {
    DEFAULT_MAX_STEPS
}

impl Scenario {
    /// Controller period, s: `control_period`, or dt when not given.
    pub fn control_period(&self) -> f64 {
        self.control_period.unwrap_or(self.dt)
    }

    /// Physics steps per control period.
    pub fn control_every(&self) -> usize {
        (self.control_period() / self.dt).round() as usize
    }

    /// Physics steps in the run: duration / dt, rounded.
    pub fn steps(&self) -> usize {
        (self.duration / self.dt).round() as usize
    }
}
