//! A scenario put together from a built-in or file scenario's TOML plus typed changes (`set`,
//! `--set`, another controller, metrics), checked as a whole and built with the registry.

use super::builtin::find_urdf;
use super::error::ScenarioError;
use super::loaded::LoadedScenario;
use super::metrics::MetricSpec;
use super::spec::Scenario;
use crate::files::read_text;
use crate::machines::ForceTable;
use crate::mechanism::Plane;
use framework::{describe_toml_error, from_table, shortened};
use framework::{parameter_message, ControllerError, Registry};
use std::path::{Path, PathBuf};

/// Largest key set (`set`, `--set`): characters and dotted segments (no scenario key is deeper
/// than 4).
const MAX_SET_KEY_CHARS: usize = 256;
const MAX_SET_KEY_SEGMENTS: usize = 8;

/// Changes the command line makes to a scenario before it is checked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// Another controller: the scenario's controller parameters are dropped (defaults apply).
    pub controller: Option<String>,
    /// Another simulated time, s, in place of the scenario's `duration`.
    pub duration: Option<f64>,
    /// `key=value` with a dotted key into the TOML, e.g. `controller.params.crank_speed=-3`;
    /// applied last.
    pub set: Vec<String>,
}

/// Loads a scenario by built-in name or file path, applies the overrides, checks it and builds
/// its controller from `registry`.
pub fn load(
    name_or_path: &str,
    overrides: &Overrides,
    registry: &Registry,
) -> Result<LoadedScenario, ScenarioError> {
    Scenario::open(name_or_path)?
        .overrides(overrides)?
        .build(registry)
}

/// A scenario being put together: a built-in or file scenario's TOML plus typed changes; checked
/// as a whole (the same checks as a TOML file) by `build`.
///
/// # Example
///
/// ```
/// use twin::Scenario;
///
/// let registry = controllers::builtin();
/// // Changed through typed values; the whole is checked as a TOML file would be.
/// let loaded = Scenario::builtin("feed-axis-micromilling")?
///     .duration(0.5)
///     .set("controller.params.mass_estimate", 12.0)?
///     .build(&registry)?;
/// assert_eq!(loaded.scenario.duration, 0.5);
///
/// // A parameter the controller does not have is refused, by name.
/// let refused = Scenario::builtin("feed-axis-micromilling")?
///     .set("controller.params.no_such_gain", 1.0)
///     .and_then(|builder| builder.build(&registry));
/// assert!(refused.unwrap_err().to_string().contains("no_such_gain"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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

    /// Parses and checks the scenario (names, timing, sensors, reference, limits), finds its
    /// URDF, and builds its controller from `registry`: the controller's parameters are typed
    /// and its design checked here, so a bad gain is refused with its key path
    /// (`controller.params.natural_frequency = -1: must be > 0`) before any twin is built.
    pub fn build(self, registry: &Registry) -> Result<LoadedScenario, ScenarioError> {
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
        let mut scenario: Scenario = from_table(&table).map_err(invalid)?;
        scenario.gravity = scenario.gravity_given.in_plane(&Plane::IDENTITY);
        read_force_tables(&mut scenario, folder.as_deref()).map_err(invalid)?;
        scenario.validate().map_err(invalid)?;
        let spec = &scenario.controller;
        let controller = registry
            .build(&spec.name, &scenario.machine, &spec.params)
            .map_err(|error| invalid(controller_reason(&error)))?;
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
            controller,
            folder,
        })
    }

    /// The scenario without its top-level table or value `key` (a calibrated scenario drops its
    /// `[calibration]`, whose runs were named relative to the file it came from).
    pub fn without(mut self, key: &str) -> Self {
        if self.table.remove(key).is_some() {
            self.changed = true;
        }
        self
    }

    /// The number the scenario's TOML holds at a dotted key (as `set` takes it, `urdf.` for
    /// `plant.`), if it holds one there; values the URDF or a default gives are not in the TOML.
    pub fn number(&self, key: &str) -> Option<f64> {
        let mut path = key_path(key).ok()?;
        if path.len() > 1 && path[0] == "urdf" {
            path[0] = "plant".into();
        }
        let (last, parents) = path.split_last()?;
        let mut table = &self.table;
        for (k, part) in parents.iter().enumerate() {
            match table.get(part.as_str())? {
                toml::Value::Array(items) if k + 1 == parents.len() => {
                    return items.get(last.parse::<usize>().ok()?)?.as_float();
                }
                value => table = value.as_table()?,
            }
        }
        match table.get(last.as_str())? {
            toml::Value::Float(value) => Some(*value),
            toml::Value::Integer(value) => Some(*value as f64),
            _ => None,
        }
    }

    /// Sets a dotted key to a value: the one path of `set` and `assign`. A numeric segment
    /// indexes an array of tables (`metrics.0.from`, `faults.1.start`); the index one past the
    /// last entry adds one (`faults.0.kind` on a scenario without faults); a leading `urdf.` is
    /// the `[plant]` table (the URDF's values: `urdf.link.ram.mass`).
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
            let indexed = parts
                .as_slice()
                .first()
                .is_some_and(|n| n.parse::<usize>().is_ok());
            let entry = current
                .entry(part.as_str())
                .or_insert_with(|| match indexed {
                    true => toml::Value::Array(Vec::new()),
                    false => toml::Value::Table(toml::Table::new()),
                });
            let entry = match entry {
                // A number in an array of numbers: `plant.link.forearm.com.0`.
                toml::Value::Array(items) if parts.len() == 0 => {
                    array_element(items, part, last, value)?;
                    self.changed = true;
                    return Ok(());
                }
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

/// Sets the element `index` of the array `name` of values (not tables) to `value`.
fn array_element(
    items: &mut [toml::Value],
    name: &str,
    index: &str,
    value: toml::Value,
) -> Result<(), String> {
    let count = items.len();
    let index = (index.parse::<usize>())
        .map_err(|_| format!("`{name}` is an array: give an entry's index (`{name}.0`)"))?;
    let item = (items.get_mut(index))
        .ok_or_else(|| format!("`{name}` has {count} entries; there is no `{name}.{index}`"))?;
    if item.is_table() {
        return Err(format!("`{name}.{index}` is a table: give a key inside it"));
    }
    *item = value;
    Ok(())
}

/// The entry of the array `name` that the key's next segment, an index, picks; the index one
/// past the last entry of an array of tables (or of an empty one) adds a table.
fn array_entry<'a>(
    items: &'a mut Vec<toml::Value>,
    name: &str,
    index: Option<&String>,
) -> Result<&'a mut toml::Value, String> {
    let count = items.len();
    let index = index
        .and_then(|i| i.parse::<usize>().ok())
        .ok_or_else(|| format!("`{name}` is an array: give an entry's index (`{name}.0.…`)"))?;
    if index == count && items.iter().all(toml::Value::is_table) {
        items.push(toml::Value::Table(toml::Table::new()));
    }
    items.get_mut(index).ok_or_else(|| {
        format!("`{name}` has {count} entries; there is no `{name}.{index}` (a new one is `{name}.{count}`)")
    })
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

impl Scenario {
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
}

/// A controller's refusal in the scenario's terms: a parameter by its key path in the scenario
/// (`controller.params.natural_frequency = -1: must be > 0`), else the registry's reason.
fn controller_reason(error: &ControllerError) -> String {
    match error {
        ControllerError::BadParameter {
            key, value, reason, ..
        } => format!(
            "controller.{}",
            parameter_message(key, value.as_deref(), reason)
        ),
        other => format!("controller: {other}"),
    }
}

/// Reads each point's `force_table`, named relative to the scenario's folder.
fn read_force_tables(scenario: &mut Scenario, folder: Option<&Path>) -> Result<(), String> {
    for (name, point) in &mut scenario.points {
        if let Some(file) = &point.force_table {
            let table = ForceTable::read(file, folder)
                .map_err(|e| format!("points.{name}.force_table: {e}"))?;
            point.force_samples = Some(table);
        }
    }
    Ok(())
}
