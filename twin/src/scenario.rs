//! Scenarios: a TOML file naming the machine, its URDF, the controller and its parameters, the
//! reference, process parameters, sensors, timing and recording options.

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
}

/// Largest scenario or URDF file read, bytes: far above any real one, and it keeps `/dev/zero`
/// or a mistaken multi-gigabyte path from eating the memory.
pub const MAX_INPUT_BYTES: u64 = 8 << 20;
/// Largest RK4 substep count per physics step.
pub const MAX_SUBSTEPS: usize = 64;
/// Default cap on physics steps per run (`max_steps`): about a minute of the fastest machine,
/// and a recording of a few GB at `recording.every = 1`.
pub const DEFAULT_MAX_STEPS: usize = 10_000_000;
/// Largest `--set` key: characters and dotted segments (no scenario key is deeper than 4).
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
    /// The TOML as run, after `--set` overrides.
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
    let (text, source, folder) = match BUILTIN.iter().find(|(name, _)| *name == name_or_path) {
        Some((name, text)) => (text.to_string(), format!("built-in scenario {name}"), None),
        None if name_or_path.ends_with(".toml") || Path::new(name_or_path).exists() => {
            let path = Path::new(name_or_path);
            let text = read_text(path).map_err(|reason| ScenarioError::Read {
                file: name_or_path.into(),
                reason,
            })?;
            (
                text,
                name_or_path.to_string(),
                path.parent().map(Path::to_path_buf),
            )
        }
        None => {
            return Err(ScenarioError::Unknown {
                name: name_or_path.into(),
                known: BUILTIN
                    .iter()
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
        }
    };
    let invalid = |reason: String| ScenarioError::Invalid {
        file: source.clone(),
        reason,
    };
    let mut table: toml::Table = toml::from_str(&text)
        .map_err(|e: toml::de::Error| invalid(describe_toml_error(&text, &e)))?;
    let changed = overrides != &Overrides::default();
    if let Some(name) = &overrides.controller {
        let mut controller = toml::Table::new();
        controller.insert("name".into(), toml::Value::String(name.clone()));
        table.insert("controller".into(), toml::Value::Table(controller));
    }
    if let Some(duration) = overrides.duration {
        table.insert("duration".into(), toml::Value::Float(duration));
    }
    for assignment in &overrides.set {
        apply_override(&mut table, assignment)?;
    }
    let toml = if !changed {
        text
    } else {
        toml::to_string(&table).map_err(|e| invalid(e.to_string()))?
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
fn key_path(key: &str) -> Option<Vec<String>> {
    let mut parts = vec![String::new()];
    let mut quoted = false;
    for c in key.chars() {
        match c {
            '"' => quoted = !quoted,
            '.' if !quoted => parts.push(String::new()),
            _ => parts.last_mut()?.push(c),
        }
    }
    (!quoted).then_some(parts)
}

/// Sets a dotted key to a TOML value (a number, bool, string, array; bare words are strings).
fn apply_override(table: &mut toml::Table, assignment: &str) -> Result<(), ScenarioError> {
    let bad = |reason: &str| ScenarioError::BadSet {
        assignment: shortened(assignment, 60),
        reason: reason.into(),
    };
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| bad("expected key=value"))?;
    if key.len() > MAX_SET_KEY_CHARS {
        return Err(bad(&format!(
            "key longer than {MAX_SET_KEY_CHARS} characters"
        )));
    }
    let path = key_path(key.trim()).ok_or_else(|| bad("unbalanced quotes in the key"))?;
    if path.iter().any(|p| p.is_empty()) {
        return Err(bad("empty key"));
    }
    if path.len() > MAX_SET_KEY_SEGMENTS {
        return Err(bad(&format!(
            "key deeper than {MAX_SET_KEY_SEGMENTS} levels; no scenario key is"
        )));
    }
    let value = match format!("v = {raw}").parse::<toml::Table>() {
        Ok(mut parsed) => parsed.remove("v").ok_or_else(|| bad("no value"))?,
        Err(_) => toml::Value::String(raw.trim().to_string()),
    };
    let (last, parents) = path.split_last().ok_or_else(|| bad("empty key"))?;
    let mut current = table;
    for part in parents {
        let part = part.as_str();
        current = current
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()))
            .as_table_mut()
            .ok_or_else(|| bad(&format!("`{part}` is not a table")))?;
    }
    current.insert(last.to_string(), value);
    Ok(())
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
}
