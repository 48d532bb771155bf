//! Scenarios: a TOML file naming the machine, its URDF, the controller and its parameters, the
//! reference, process parameters, sensors, timing and recording options.

use crate::evaluate::MetricSpec;
use crate::faults::FaultSpec;
use crate::plant::PlantValues;
use crate::sensors::SensorSpec;
use controllers::registry::{describe_toml_error, from_table, shortened};
use models::reference::Reference;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// The scenarios shipped with the twin: (name, TOML).
pub const BUILTIN: &[(&str, &str)] = &[
    (
        "whitworth-crank-pi",
        include_str!("../scenarios/whitworth-crank-pi.toml"),
    ),
    (
        "whitworth-tracking",
        include_str!("../scenarios/whitworth-tracking.toml"),
    ),
    (
        "whitworth-cutting",
        include_str!("../scenarios/whitworth-cutting.toml"),
    ),
    ("arm-milling", include_str!("../scenarios/arm-milling.toml")),
    (
        "platform-path",
        include_str!("../scenarios/platform-path.toml"),
    ),
    (
        "platform-path-s",
        include_str!("../scenarios/platform-path-s.toml"),
    ),
    (
        "feed-axis-micromilling",
        include_str!("../scenarios/feed-axis-micromilling.toml"),
    ),
    (
        "lathe-turning",
        include_str!("../scenarios/lathe-turning.toml"),
    ),
    (
        "milling-constant-15000",
        include_str!("../scenarios/milling-constant-15000.toml"),
    ),
    (
        "milling-constant-16500",
        include_str!("../scenarios/milling-constant-16500.toml"),
    ),
    ("milling-z04", include_str!("../scenarios/milling-z04.toml")),
    ("milling-z05", include_str!("../scenarios/milling-z05.toml")),
    (
        "milling-optimal-linear",
        include_str!("../scenarios/milling-optimal-linear.toml"),
    ),
];

/// The URDF files shipped with the twin, by the path scenarios name them with.
const BUILTIN_URDF: &[(&str, &str)] = &[
    (
        "urdf/platform.urdf",
        include_str!("../../urdf/platform.urdf"),
    ),
    (
        "urdf/whitworth.urdf",
        include_str!("../../urdf/whitworth.urdf"),
    ),
    ("urdf/arm.urdf", include_str!("../../urdf/arm.urdf")),
    (
        "urdf/feed_axis.urdf",
        include_str!("../../urdf/feed_axis.urdf"),
    ),
    ("urdf/milling.urdf", include_str!("../../urdf/milling.urdf")),
    ("urdf/lathe.urdf", include_str!("../../urdf/lathe.urdf")),
];

#[derive(Debug, Error, Clone, PartialEq)]
pub enum ScenarioError {
    #[error("unknown scenario `{name}` (built in: {known}; or give a .toml file)")]
    Unknown { name: String, known: String },
    #[error("{file}: cannot read: {reason}")]
    Read { file: String, reason: String },
    #[error("{file}: {reason}")]
    Invalid { file: String, reason: String },
    #[error("--set {assignment}: {reason}")]
    BadSet { assignment: String, reason: String },
    #[error("scenario key `{key}`: {reason}")]
    BadKey { key: String, reason: String },
}

/// Largest scenario or URDF file read, bytes: far above any real one, and it keeps `/dev/zero`
/// or a mistaken multi-gigabyte path from eating the memory.
pub const MAX_INPUT_BYTES: u64 = 8 << 20;
/// Largest RK4 substep count per physics step.
pub const MAX_SUBSTEPS: usize = 64;
/// Default cap on physics steps per run (`max_steps`): about a minute of the fastest machine,
/// and a recording of a few GB at `recording.every = 1`.
pub const DEFAULT_MAX_STEPS: usize = 10_000_000;
/// Largest key set (`set`, `--set`): characters and dotted segments (no scenario key is deeper
/// than 4).
const MAX_SET_KEY_CHARS: usize = 256;
const MAX_SET_KEY_SEGMENTS: usize = 8;
/// Longest scenario name (it names the default recording file).
const MAX_NAME_CHARS: usize = 100;

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Machine kind: `whitworth`, ….
    pub machine: String,
    /// URDF path, relative to the scenario file (built-in files are found by this path too).
    pub urdf: String,
    /// Simulated time, s.
    pub duration: f64,
    /// Physics step, s.
    pub dt: f64,
    /// Controller period, s; a whole multiple of dt (zero-order hold). Defaults to dt.
    pub control_period: Option<f64>,
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 2],
    /// RK4 substeps per physics step (efforts and process loads are held over the step).
    #[serde(default = "default_substeps")]
    pub substeps: usize,
    /// Refuse runs of more physics steps than this (duration / dt); raise it for a long run.
    #[serde(default = "default_max_steps")]
    pub max_steps: usize,
    /// Seed of the sensor noise.
    #[serde(default)]
    pub seed: u64,
    pub controller: ControllerSpec,
    /// Reference given to the controller as `reference`, `reference_rate`, `reference_acceleration`.
    pub reference: Option<Reference>,
    /// Machine-specific process parameters (contact forces, geometry checks).
    #[serde(default)]
    pub process: toml::Table,
    /// Sensor models by measured signal name.
    #[serde(default)]
    pub sensors: BTreeMap<String, SensorSpec>,
    #[serde(default)]
    pub recording: RecordingOptions,
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
    /// Injected faults (`[[faults]]`), see [`crate::faults`].
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
}

/// A joint's state at t = 0, in the joint's own sense (rad or m, rad/s or m/s).
#[derive(Debug, Clone, Copy, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct InitialJoint {
    pub position: f64,
    pub velocity: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    pub name: String,
    #[serde(default)]
    pub params: toml::Table,
}

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
}

impl Default for HealthLimits {
    fn default() -> Self {
        Self {
            max_joint_speed: 1e3,
            max_loop_gap: 1e-2,
        }
    }
}

fn default_gravity() -> [f64; 2] {
    [0.0, -9.81]
}

fn default_substeps() -> usize {
    1
}

fn default_max_steps() -> usize {
    DEFAULT_MAX_STEPS
}

/// A scenario ready to run: parsed, checked, with its text (for provenance) and its URDF text.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedScenario {
    pub scenario: Scenario,
    /// The TOML as run: the text as written, or re-serialised after changes (`set`, `--set`).
    pub toml: String,
    /// Where the scenario came from, for messages.
    pub source: String,
    pub urdf_text: String,
    /// The URDF's path or built-in name, for messages.
    pub urdf_source: String,
}

impl Scenario {
    pub fn control_period(&self) -> f64 {
        self.control_period.unwrap_or(self.dt)
    }

    /// Physics steps per control period.
    pub fn control_every(&self) -> usize {
        (self.control_period() / self.dt).round() as usize
    }

    pub fn steps(&self) -> usize {
        (self.duration / self.dt).round() as usize
    }

    fn validate(&self) -> Result<(), String> {
        check_name(&self.name)?;
        self.validate_timing()?;
        if self.recording.every == 0 {
            return Err("recording.every must be ≥ 1".into());
        }
        if (self.health.max_joint_speed.is_nan() || self.health.max_joint_speed <= 0.0)
            || (self.health.max_loop_gap.is_nan() || self.health.max_loop_gap <= 0.0)
        {
            return Err("health limits must be > 0".into());
        }
        for (signal, spec) in &self.sensors {
            spec.validate()
                .map_err(|reason| format!("sensors.\"{signal}\": {reason}"))?;
            if spec.delay > self.duration {
                return Err(format!(
                    "sensors.\"{signal}\": delay ({} s) must not exceed the run's duration ({} s)",
                    spec.delay, self.duration
                ));
            }
        }
        if let Some(reference) = &self.reference {
            reference.validate()?;
        }
        self.plant.validate()?;
        for (joint, state) in &self.initial {
            if !(state.position.is_finite() && state.velocity.is_finite()) {
                return Err(format!(
                    "initial.{joint}: position and velocity must be finite, got {} and {}",
                    state.position, state.velocity
                ));
            }
        }
        for (i, fault) in self.faults.iter().enumerate() {
            fault.validate(i, self.duration)?;
        }
        for (i, metric) in self.metrics.iter().enumerate() {
            metric.validate()?;
            if self.metrics[..i].iter().any(|m| m.name == metric.name) {
                return Err(format!("metrics `{}`: named twice", metric.name));
            }
        }
        Ok(())
    }

    /// dt, duration, control period, substeps and the step cap.
    fn validate_timing(&self) -> Result<(), String> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(format!("dt must be > 0, got {}", self.dt));
        }
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(format!("duration must be > 0, got {}", self.duration));
        }
        let period = self.control_period();
        let ratio = period / self.dt;
        if !(period.is_finite() && period > 0.0)
            || (ratio - ratio.round()).abs() > 1e-9
            || ratio.round() < 1.0
        {
            return Err(format!(
                "control_period ({period} s) must be a whole multiple of dt ({} s)",
                self.dt
            ));
        }
        if period > self.duration {
            return Err(format!(
                "control_period ({period} s) must not exceed the duration ({} s)",
                self.duration
            ));
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(format!(
                "substeps must be between 1 and {MAX_SUBSTEPS}, got {}",
                self.substeps
            ));
        }
        let steps = self.duration / self.dt;
        if steps > self.max_steps as f64 {
            return Err(format!(
                "duration / dt = {steps:.3e} steps exceeds max_steps = {}; shorten the run, \
                 enlarge dt, or raise the cap (max_steps = … in the scenario, --set max_steps=…)",
                self.max_steps
            ));
        }
        Ok(())
    }
}

/// A scenario name names files (`<name>.rrd`): letters, digits, `_`, `-`, `.`, not leading `.`.
fn check_name(name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.');
    if name.is_empty()
        || name.len() > MAX_NAME_CHARS
        || name.starts_with('.')
        || !name.chars().all(allowed)
    {
        return Err(format!(
            "name {name:?}: use 1 to {MAX_NAME_CHARS} letters, digits, `_`, `-` or `.`, \
             not starting with `.` (it names the recording file)"
        ));
    }
    Ok(())
}

/// Changes the command line makes to a scenario before it is checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Another controller: the scenario's controller parameters are dropped (defaults apply).
    pub controller: Option<String>,
    pub duration: Option<f64>,
    /// `key=value` with a dotted key into the TOML, e.g. `controller.params.crank_speed=-3`;
    /// applied last.
    pub set: Vec<String>,
}

/// Loads a scenario by built-in name or file path, applies the overrides and checks it.
pub fn load(name_or_path: &str, overrides: &Overrides) -> Result<LoadedScenario, ScenarioError> {
    Scenario::open(name_or_path)?.overrides(overrides)?.build()
}

/// A scenario being put together: a built-in or file scenario's TOML plus typed changes; checked
/// as a whole (the same checks as a TOML file) by `build`.
#[derive(Debug, Clone)]
pub struct ScenarioBuilder {
    table: toml::Table,
    /// Where the scenario came from, for messages.
    source: String,
    /// Where a relative URDF path is looked for first (a scenario file's folder).
    folder: Option<PathBuf>,
    /// The text as given: the run's provenance while nothing is changed (comments and all).
    text: String,
    changed: bool,
    /// A change that a method which cannot fail could not make; `build` reports it.
    pending: Option<ScenarioError>,
}

/// A typed scenario value. A number TOML cannot hold (beyond i64) is kept as the reason, so
/// `set` reports it with the key instead of a `From` panicking.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioValue(Result<toml::Value, String>);

macro_rules! scenario_value_from {
    ($($from:ty => $variant:ident),* $(,)?) => {$(
        impl From<$from> for ScenarioValue {
            fn from(value: $from) -> Self {
                Self(Ok(toml::Value::$variant(value.into())))
            }
        }
    )*};
}

scenario_value_from!(
    f64 => Float, f32 => Float, i64 => Integer, i32 => Integer, u32 => Integer,
    bool => Boolean, &str => String, String => String, toml::Table => Table,
);

impl From<toml::Value> for ScenarioValue {
    fn from(value: toml::Value) -> Self {
        Self(Ok(value))
    }
}

impl From<usize> for ScenarioValue {
    fn from(value: usize) -> Self {
        Self::integer(value)
    }
}

impl From<u64> for ScenarioValue {
    fn from(value: u64) -> Self {
        Self::integer(value)
    }
}

impl<T: Into<ScenarioValue>> From<Vec<T>> for ScenarioValue {
    fn from(items: Vec<T>) -> Self {
        let items: Result<Vec<_>, _> = items.into_iter().map(|item| item.into().0).collect();
        Self(items.map(toml::Value::Array))
    }
}

impl<T: Into<ScenarioValue>, const N: usize> From<[T; N]> for ScenarioValue {
    fn from(items: [T; N]) -> Self {
        Vec::from(items).into()
    }
}

impl ScenarioValue {
    /// An unsigned number as a TOML integer, or the reason it is none.
    fn integer<T: TryInto<i64> + Copy + std::fmt::Display>(value: T) -> Self {
        Self(
            value
                .try_into()
                .map(toml::Value::Integer)
                .map_err(|_| format!("{value} is beyond the largest TOML integer, {}", i64::MAX)),
        )
    }
}

impl Scenario {
    /// A built-in scenario by name (`whitworth-tracking`, …); unknown names list the known ones.
    pub fn builtin(name: &str) -> Result<ScenarioBuilder, ScenarioError> {
        let (name, text) = BUILTIN
            .iter()
            .find(|(known, _)| *known == name)
            .ok_or_else(|| unknown(name))?;
        Self::from_toml(text, &format!("built-in scenario {name}"), None)
    }

    /// A scenario file; its URDF path is resolved beside it.
    pub fn from_file(path: impl AsRef<Path>) -> Result<ScenarioBuilder, ScenarioError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let text = read_text(path).map_err(|reason| ScenarioError::Read {
            file: file.clone(),
            reason,
        })?;
        Self::from_toml(&text, &file, path.parent())
    }

    /// A scenario given as TOML text; `source` names it in messages; a relative URDF path is
    /// found in `folder` if given, else among the built-in URDFs, else from the working folder.
    pub fn from_toml(
        text: &str,
        source: &str,
        folder: Option<&Path>,
    ) -> Result<ScenarioBuilder, ScenarioError> {
        let table = toml::from_str(text).map_err(|e: toml::de::Error| ScenarioError::Invalid {
            file: source.into(),
            reason: describe_toml_error(text, &e),
        })?;
        Ok(ScenarioBuilder {
            table,
            source: source.into(),
            folder: folder.map(Path::to_path_buf),
            text: text.into(),
            changed: false,
            pending: None,
        })
    }

    /// A built-in name, else a file path (what the CLI's SCENARIO argument accepts).
    pub fn open(name_or_path: &str) -> Result<ScenarioBuilder, ScenarioError> {
        if BUILTIN.iter().any(|(name, _)| *name == name_or_path) {
            Self::builtin(name_or_path)
        } else if name_or_path.ends_with(".toml") || Path::new(name_or_path).exists() {
            Self::from_file(name_or_path)
        } else {
            Err(unknown(name_or_path))
        }
    }
}

fn unknown(name: &str) -> ScenarioError {
    ScenarioError::Unknown {
        name: name.into(),
        known: BUILTIN
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

impl ScenarioBuilder {
    /// Another controller; the old controller's parameters are dropped (defaults apply).
    pub fn controller(mut self, name: &str) -> Self {
        let mut controller = toml::Table::new();
        controller.insert("name".into(), toml::Value::String(name.into()));
        self.table
            .insert("controller".into(), toml::Value::Table(controller));
        self.changed = true;
        self
    }

    /// Simulated time, s.
    pub fn duration(mut self, seconds: f64) -> Self {
        self.table
            .insert("duration".into(), toml::Value::Float(seconds));
        self.changed = true;
        self
    }

    /// The sensor noise's seed; one beyond TOML's integers (above i64::MAX) fails at `build`.
    pub fn seed(mut self, seed: u64) -> Self {
        if let Err(reason) = self.put("seed", seed.into()) {
            let error = ScenarioError::BadKey {
                key: "seed".into(),
                reason,
            };
            self.pending.get_or_insert(error);
        }
        self
    }

    /// Declares a figure the run is judged by, replacing the scenario's `[[metrics]]` entry of
    /// the same name if there is one.
    pub fn metric(mut self, spec: &MetricSpec) -> Self {
        let entry = match toml::Value::try_from(spec) {
            Ok(entry) => entry,
            Err(e) => {
                let error = ScenarioError::BadKey {
                    key: format!("metrics.{}", spec.name),
                    reason: e.to_string(),
                };
                self.pending.get_or_insert(error);
                return self;
            }
        };
        let list = self
            .table
            .entry("metrics")
            .or_insert_with(|| toml::Value::Array(Vec::new()));
        let Some(list) = list.as_array_mut() else {
            let error = ScenarioError::BadKey {
                key: "metrics".into(),
                reason: "is not an array of tables".into(),
            };
            self.pending.get_or_insert(error);
            return self;
        };
        let same =
            |v: &toml::Value| v.get("name").and_then(toml::Value::as_str) == Some(&spec.name);
        match list.iter_mut().find(|v| same(v)) {
            Some(existing) => *existing = entry,
            None => list.push(entry),
        }
        self.changed = true;
        self
    }

    /// Sets a dotted key (quoted segments may hold dots: `sensors."table.position".noise`) to a
    /// typed value. Errors (bad key syntax, a parent that is not a table, too deep/long, a number
    /// TOML cannot hold) name the key; the value's type is checked by `build`.
    pub fn set(
        mut self,
        key: &str,
        value: impl Into<ScenarioValue>,
    ) -> Result<Self, ScenarioError> {
        self.put(key, value.into())
            .map_err(|reason| ScenarioError::BadKey {
                key: shortened(key, 60),
                reason,
            })?;
        Ok(self)
    }

    /// The command line's `key=value` (`--set`): parses the value as TOML (bare words are
    /// strings) and sets it as `set` does.
    pub fn assign(mut self, assignment: &str) -> Result<Self, ScenarioError> {
        let bad = |reason: String| ScenarioError::BadSet {
            assignment: shortened(assignment, 60),
            reason,
        };
        let (key, raw) = assignment
            .split_once('=')
            .ok_or_else(|| bad("expected key=value".into()))?;
        let value = match format!("v = {raw}").parse::<toml::Table>() {
            Ok(mut parsed) => parsed.remove("v").ok_or_else(|| bad("no value".into()))?,
            Err(_) => toml::Value::String(raw.trim().to_string()),
        };
        self.put(key, value.into()).map_err(bad)?;
        Ok(self)
    }

    /// Applies the CLI's `Overrides` (controller, duration, then each `set` assignment).
    pub fn overrides(mut self, overrides: &Overrides) -> Result<Self, ScenarioError> {
        if let Some(name) = &overrides.controller {
            self = self.controller(name);
        }
        if let Some(seconds) = overrides.duration {
            self = self.duration(seconds);
        }
        overrides
            .set
            .iter()
            .try_fold(self, |builder, assignment| builder.assign(assignment))
    }

    /// Parses, checks (names, timing, sensors, reference, limits) and finds the URDF.
    pub fn build(self) -> Result<LoadedScenario, ScenarioError> {
        let Self {
            table,
            source,
            folder,
            text,
            changed,
            pending,
        } = self;
        if let Some(error) = pending {
            return Err(error);
        }
        let invalid = |reason: String| ScenarioError::Invalid {
            file: source.clone(),
            reason,
        };
        let toml = if changed {
            toml::to_string(&table).map_err(|e| invalid(e.to_string()))?
        } else {
            text
        };
        let scenario: Scenario = from_table(&table).map_err(invalid)?;
        scenario.validate().map_err(invalid)?;
        let (urdf_text, urdf_source) = find_urdf(&scenario.urdf, folder.as_deref())
            .ok_or_else(|| invalid(format!("urdf `{}` not found", scenario.urdf)))?;
        Ok(LoadedScenario {
            scenario,
            toml,
            source,
            urdf_text: urdf_text.map_err(|reason| ScenarioError::Read {
                file: urdf_source.clone(),
                reason,
            })?,
            urdf_source,
        })
    }

    /// Sets a dotted key to a value: the one path of `set` and `assign`. A numeric segment
    /// indexes an array of tables (`metrics.0.from`, `faults.1.start`); a leading `urdf.` is the
    /// `[plant]` table (the URDF's values: `urdf.link.ram.mass`).
    fn put(&mut self, key: &str, value: ScenarioValue) -> Result<(), String> {
        let mut path = key_path(key)?;
        let value = value.0?;
        if path.len() > 1 && path[0] == "urdf" {
            path[0] = "plant".into();
        }
        let (last, parents) = path.split_last().ok_or("empty key")?;
        let mut current = &mut self.table;
        let mut parts = parents.iter();
        while let Some(part) = parts.next() {
            let entry = current
                .entry(part.as_str())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            let entry = match entry {
                toml::Value::Array(items) => array_entry(items, part, parts.next())?,
                other => other,
            };
            current = entry
                .as_table_mut()
                .ok_or_else(|| format!("`{part}` is not a table"))?;
        }
        current.insert(last.clone(), value);
        self.changed = true;
        Ok(())
    }
}

/// The entry of the array `name` that the key's next segment, an index, picks.
fn array_entry<'a>(
    items: &'a mut [toml::Value],
    name: &str,
    index: Option<&String>,
) -> Result<&'a mut toml::Value, String> {
    let count = items.len();
    let index = index
        .and_then(|i| i.parse::<usize>().ok())
        .ok_or_else(|| format!("`{name}` is an array: give an entry's index (`{name}.0.…`)"))?;
    items
        .get_mut(index)
        .ok_or_else(|| format!("`{name}` has {count} entries; there is no `{name}.{index}`"))
}

type UrdfLookup = (Result<String, String>, String);

/// The URDF beside a scenario file, else a built-in one of that path; for a built-in scenario,
/// a built-in URDF, else a file of that path (absolute or from the working folder).
fn find_urdf(path: &str, folder: Option<&Path>) -> Option<UrdfLookup> {
    let file = |candidate: PathBuf| {
        candidate.exists().then(|| {
            let text = read_text(&candidate);
            (text, candidate.display().to_string())
        })
    };
    let builtin = || {
        BUILTIN_URDF
            .iter()
            .find(|(name, _)| *name == path)
            .map(|(name, text)| (Ok(text.to_string()), format!("built-in {name}")))
    };
    match folder {
        Some(folder) => file(folder.join(path)).or_else(builtin),
        None => builtin().or_else(|| file(PathBuf::from(path))),
    }
}

/// Reads a text file of at most [`MAX_INPUT_BYTES`] (a device or huge file is refused, not read
/// to the end).
pub fn read_text(path: &Path) -> Result<String, String> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        return Err("is a directory".into());
    }
    let mut bytes = Vec::new();
    file.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(format!(
            "larger than {} MiB; not a scenario or URDF file",
            MAX_INPUT_BYTES >> 20
        ));
    }
    String::from_utf8(bytes).map_err(|_| "not UTF-8 text".into())
}

/// Splits a dotted key; a quoted segment may hold dots (`sensors."table.position".noise`).
fn key_path(key: &str) -> Result<Vec<String>, String> {
    if key.len() > MAX_SET_KEY_CHARS {
        return Err(format!("key longer than {MAX_SET_KEY_CHARS} characters"));
    }
    let mut parts = vec![String::new()];
    let mut quoted = false;
    for c in key.trim().chars() {
        match c {
            '"' => quoted = !quoted,
            '.' if !quoted => parts.push(String::new()),
            _ => parts.last_mut().ok_or("empty key")?.push(c),
        }
    }
    if quoted {
        return Err("unbalanced quotes in the key".into());
    }
    if parts.iter().any(|p| p.is_empty()) {
        return Err("empty key".into());
    }
    if parts.len() > MAX_SET_KEY_SEGMENTS {
        return Err(format!(
            "key deeper than {MAX_SET_KEY_SEGMENTS} levels; no scenario key is"
        ));
    }
    Ok(parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_load() {
        for (name, _) in BUILTIN {
            let loaded = load(name, &Overrides::default()).unwrap();
            assert_eq!(&loaded.scenario.name, name);
        }
    }

    fn set(assignments: &[&str]) -> Overrides {
        Overrides {
            set: assignments.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    #[test]
    fn overrides_reach_nested_keys() {
        let loaded = load(
            "whitworth-crank-pi",
            &set(&["controller.params.crank_speed=-3.5", "duration=0.5"]),
        )
        .unwrap();
        assert_eq!(loaded.scenario.duration, 0.5);
        assert_eq!(
            loaded.scenario.controller.params["crank_speed"].as_float(),
            Some(-3.5)
        );
        assert!(loaded.toml.contains("-3.5"));
    }

    #[test]
    fn another_controller_drops_the_old_parameters() {
        let overrides = Overrides {
            controller: Some("passive".into()),
            duration: Some(2.0),
            ..Default::default()
        };
        let loaded = load("whitworth-crank-pi", &overrides).unwrap();
        assert_eq!(loaded.scenario.controller.name, "passive");
        assert!(loaded.scenario.controller.params.is_empty());
        assert_eq!(loaded.scenario.duration, 2.0);
    }

    #[test]
    fn bad_inputs_name_the_problem() {
        let err = load("no-such-scenario", &Overrides::default()).unwrap_err();
        assert!(err.to_string().contains("no-such-scenario"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["dt=0"])).unwrap_err();
        assert!(err.to_string().contains("dt must be > 0"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["duration=-1"])).unwrap_err();
        assert!(err.to_string().contains("duration must be > 0"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["bogus_key=1"])).unwrap_err();
        assert!(err.to_string().contains("bogus_key"), "{err}");
        let err = load(
            "whitworth-crank-pi",
            &set(&["sensors.\"crank.position\".noise=-1"]),
        )
        .unwrap_err();
        assert!(err.to_string().contains("noise must be"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["novalue"])).unwrap_err();
        assert!(err.to_string().contains("key=value"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["dt=\"fast\""])).unwrap_err();
        assert!(err.to_string().contains("dt"), "{err}");
        let err = load("whitworth-crank-pi", &set(&["control_period=0.0015"])).unwrap_err();
        assert!(err.to_string().contains("whole multiple"), "{err}");
    }

    fn builder() -> ScenarioBuilder {
        Scenario::builtin("whitworth-crank-pi").unwrap()
    }

    #[test]
    fn typed_values_reach_the_scenario() {
        let mut detector = toml::Table::new();
        detector.insert("resolution".into(), 1e-3.into());
        let loaded = builder()
            .set("controller.params.crank_speed", -3.5)
            .and_then(|b| b.set("substeps", 2))
            .and_then(|b| b.set("max_steps", 20_000_usize))
            .and_then(|b| b.set("process.cutting", false))
            .and_then(|b| b.set("description", "typed"))
            .and_then(|b| b.set("name", String::from("typed-run")))
            .and_then(|b| b.set("gravity", [0.0, -1.62]))
            .and_then(|b| b.set("sensors.\"crank.velocity\"", detector))
            .and_then(|b| b.set("sensors.\"crank.velocity\".noise", 0.5_f32))
            .map(|b| b.seed(7).duration(0.5))
            .and_then(ScenarioBuilder::build)
            .unwrap();
        let scenario = &loaded.scenario;
        assert_eq!(
            scenario.controller.params["crank_speed"].as_float(),
            Some(-3.5)
        );
        assert_eq!((scenario.substeps, scenario.max_steps), (2, 20_000));
        assert_eq!(scenario.process["cutting"].as_bool(), Some(false));
        assert_eq!(scenario.description, "typed");
        assert_eq!(scenario.name, "typed-run");
        assert_eq!(scenario.gravity, [0.0, -1.62]);
        let sensor = &scenario.sensors["crank.velocity"];
        assert_eq!((sensor.resolution, sensor.noise), (1e-3, 0.5));
        assert_eq!((scenario.seed, scenario.duration), (7, 0.5));
        assert!(loaded.toml.contains("typed-run"), "{}", loaded.toml);
    }

    #[test]
    fn unchanged_builders_keep_the_text_as_written() {
        let loaded = builder().build().unwrap();
        assert_eq!(
            loaded,
            load("whitworth-crank-pi", &Overrides::default()).unwrap()
        );
        assert!(loaded.toml.starts_with("# Inverted Whitworth"));
    }

    #[test]
    fn builder_controller_drops_the_old_parameters() {
        let loaded = builder().controller("passive").build().unwrap();
        assert_eq!(loaded.scenario.controller.name, "passive");
        assert!(loaded.scenario.controller.params.is_empty());
    }

    #[test]
    fn bad_keys_are_named() {
        for (key, reason) in [
            ("sensors.\"crank.position.noise", "unbalanced quotes"),
            ("controller..params", "empty key"),
            ("a.b.c.d.e.f.g.h.i", "deeper than 8"),
            ("dt.value", "`dt` is not a table"),
            ("controller.name.first", "`name` is not a table"),
        ] {
            let err = builder().set(key, 1.0).unwrap_err().to_string();
            assert!(err.contains(key) && err.contains(reason), "{err}");
        }
        let long = "a".repeat(300);
        let err = builder().set(&long, 1.0).unwrap_err().to_string();
        assert!(err.contains("longer than 256"), "{err}");
    }

    #[test]
    fn numbers_beyond_toml_integers_are_errors_not_panics() {
        let err = builder()
            .set("max_steps", usize::MAX)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("max_steps") && err.contains("largest TOML integer"),
            "{err}"
        );
        let err = builder()
            .set("gravity", vec![u64::MAX, 0])
            .unwrap_err()
            .to_string();
        assert!(err.contains("gravity"), "{err}");
        let err = builder().seed(u64::MAX).build().unwrap_err().to_string();
        assert!(
            err.contains("seed") && err.contains("largest TOML integer"),
            "{err}"
        );
    }

    #[test]
    fn builder_and_assignments_give_the_same_scenario() {
        let typed = builder()
            .controller("passive")
            .set("controller.params", toml::Table::new())
            .and_then(|b| b.set("sensors.\"crank.position\".noise", 1e-4))
            .and_then(|b| b.set("gravity", vec![0.0, -9.0]))
            .and_then(|b| b.set("substeps", 3))
            .map(|b| b.duration(0.5))
            .and_then(ScenarioBuilder::build)
            .unwrap();
        let overrides = Overrides {
            controller: Some("passive".into()),
            duration: Some(0.5),
            set: [
                "controller.params={}",
                "sensors.\"crank.position\".noise=1e-4",
                "gravity=[0.0, -9.0]",
                "substeps=3",
            ]
            .map(String::from)
            .into(),
        };
        assert_eq!(typed, load("whitworth-crank-pi", &overrides).unwrap());
    }

    #[test]
    fn wrong_types_fail_at_build_naming_the_key() {
        let fast = builder().set("dt", "fast").unwrap();
        let err = fast.build().unwrap_err().to_string();
        assert!(err.contains("`dt`"), "{err}");
        let err = builder()
            .set("sensors.\"crank.position\".noise", true)
            .and_then(ScenarioBuilder::build)
            .unwrap_err()
            .to_string();
        assert!(err.contains("noise"), "{err}");
    }

    #[test]
    fn metrics_are_replaced_by_name_or_added() {
        use crate::evaluate::{MetricKind, MetricSpec};
        let loaded = Scenario::builtin("whitworth-tracking")
            .unwrap()
            .metric(&MetricSpec {
                from: 3.0,
                ..MetricSpec::new("tracking_mse", MetricKind::Mse, "ram_position")
            })
            .metric(&MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity"))
            .build()
            .unwrap();
        let metrics = &loaded.scenario.metrics;
        assert_eq!(metrics.len(), 2);
        assert_eq!(
            (metrics[0].name.as_str(), metrics[0].from),
            ("tracking_mse", 3.0)
        );
        assert_eq!(metrics[0].reference, None);
        assert_eq!(
            metrics[1],
            MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity")
        );
        let bad = Scenario::builtin("whitworth-tracking")
            .unwrap()
            .metric(&MetricSpec {
                scale: f64::NAN,
                ..MetricSpec::new("peak", MetricKind::MaxAbs, "ram_velocity")
            })
            .build()
            .unwrap_err();
        assert!(bad.to_string().contains("`metrics.1.scale`"), "{bad}");
    }
}
