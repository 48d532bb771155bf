//! The scenario's tunable values as FMU parameters: every number of its `[controller.params]`
//! (with the controller in the loop), `[reference]`, `[process]`, `[initial]`, `[plant]` and
//! `[sensors]` tables, named by their dotted key (array entries by index), applied as `--set`
//! assignments ([`twin::Overrides`]).

use framework::EffortKind;
use twin::Simulator;

/// The tables whose numbers are parameters, as key paths into the scenario.
const TABLES: [&[&str]; 6] = [
    &["controller", "params"],
    &["reference"],
    &["process"],
    &["initial"],
    &["plant"],
    &["sensors"],
];

/// A parameter's value: TOML's float or integer (an fmi2 Real or Integer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Number {
    Real(f64),
    Integer(i32),
}

impl Number {
    /// Bit for bit the same (so a NaN equals itself and -0 differs from +0).
    pub fn same(&self, other: &Number) -> bool {
        match (self, other) {
            (Number::Real(a), Number::Real(b)) => a.to_bits() == b.to_bits(),
            (Number::Integer(a), Number::Integer(b)) => a == b,
            _ => false,
        }
    }

    /// As TOML writes it: a float always as a float (`30.0`, `1e-6`), non-finite ones as TOML
    /// spells them (`nan`, `inf`), so that `--set` refuses them by key as it would from a file.
    fn toml(&self) -> String {
        match *self {
            Number::Integer(i) => i.to_string(),
            Number::Real(x) if x.is_nan() => "nan".into(),
            Number::Real(x) if x.is_infinite() => (if x > 0.0 { "inf" } else { "-inf" }).into(),
            Number::Real(x) => format!("{x:?}"),
        }
    }
}

/// One number of the scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The FMU variable's name: the dotted key, an array entry as `[k]`
    /// (`controller.params.time_constants[0]`).
    pub name: String,
    /// The `--set` key of the value, or of its whole array for an entry of an array of numbers.
    pub key: String,
    /// The entry's index within the array of numbers at `key`.
    pub element: Option<usize>,
    /// The scenario's value.
    pub default: Number,
    /// The SI unit, where the twin knows it (ASCII, as in modelDescription.xml).
    pub unit: Option<String>,
}

/// The parameters of the scenario (its TOML as loaded), sorted by name; the controller's only
/// when it is in the loop (`controlled`). `simulator` gives the units of the reference, joint and
/// signal values.
pub fn parameters(toml_text: &str, simulator: &Simulator, controlled: bool) -> Vec<Parameter> {
    let Ok(table) = toml_text.parse::<toml::Table>() else {
        return Vec::new();
    };
    let mut found = Vec::new();
    let tables = (TABLES.iter().copied()).filter(|path| controlled || path[0] != "controller");
    for path in tables {
        let mut value = Some(&table);
        for part in path {
            value = value
                .and_then(|t| t.get(*part))
                .and_then(toml::Value::as_table);
        }
        if let Some(table) = value {
            let path: Vec<String> = path.iter().map(|p| p.to_string()).collect();
            walk_table(table, &path, &mut found);
        }
    }
    for parameter in &mut found {
        parameter.unit = unit(&parameter.name, simulator);
    }
    found.sort_by(|a, b| a.name.cmp(&b.name));
    found
}

/// The numbers under `table` (at `path`), into `found`.
fn walk_table(table: &toml::Table, path: &[String], found: &mut Vec<Parameter>) {
    for (key, value) in table {
        // A key with a quote cannot be written as a `--set` key.
        if key.contains('"') {
            continue;
        }
        let mut path = path.to_vec();
        path.push(key.clone());
        match value {
            toml::Value::Table(inner) => walk_table(inner, &path, found),
            toml::Value::Array(items) => walk_array(items, &path, found),
            other => found.extend(number(other).map(|default| Parameter {
                name: dotted(&path),
                key: dotted(&path),
                element: None,
                default,
                unit: None,
            })),
        }
    }
}

/// An array of numbers gives one parameter per entry; an array of tables is walked by index
/// (`process.path.segments.1.radius`, named `process.path.segments[1].radius`).
fn walk_array(items: &[toml::Value], path: &[String], found: &mut Vec<Parameter>) {
    for (k, item) in items.iter().enumerate() {
        match item {
            toml::Value::Table(inner) => {
                let mut indexed = path.to_vec();
                indexed.push(k.to_string());
                let before = found.len();
                walk_table(inner, &indexed, found);
                let entry = format!("{}.{k}", dotted(path));
                let named = format!("{}[{k}]", dotted(path));
                for parameter in &mut found[before..] {
                    parameter.name = parameter.name.replacen(&entry, &named, 1);
                }
            }
            other => found.extend(number(other).map(|default| Parameter {
                name: format!("{}[{k}]", dotted(path)),
                key: dotted(path),
                element: Some(k),
                default,
                unit: None,
            })),
        }
    }
}

/// A float, or an integer an fmi2Integer holds.
fn number(value: &toml::Value) -> Option<Number> {
    match value {
        toml::Value::Float(x) => Some(Number::Real(*x)),
        toml::Value::Integer(i) => i32::try_from(*i).ok().map(Number::Integer),
        _ => None,
    }
}

/// A key path as `--set` reads it: a segment with a dot, a space or nothing in it quoted.
fn dotted(path: &[String]) -> String {
    let quoted = |part: &String| {
        let plain = !part.is_empty()
            && (part.chars()).all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if plain {
            part.clone()
        } else {
            format!("\"{part}\"")
        }
    };
    path.iter().map(quoted).collect::<Vec<_>>().join(".")
}

/// The `--set` assignments that give `values` (one per parameter, in `parameters`' order):
/// one per value that differs from the scenario's, an array of numbers whole.
pub fn assignments(parameters: &[Parameter], values: &[Number]) -> Vec<String> {
    let mut set = Vec::new();
    for (p, parameter) in parameters.iter().enumerate() {
        if values[p].same(&parameter.default) {
            continue;
        }
        let assignment = match parameter.element {
            None => format!("{}={}", parameter.key, values[p].toml()),
            Some(_) => {
                let mut entries: Vec<(usize, String)> = (parameters.iter().zip(values))
                    .filter(|(q, _)| q.key == parameter.key)
                    .filter_map(|(q, v)| q.element.map(|k| (k, v.toml())))
                    .collect();
                entries.sort();
                let entries: Vec<String> = entries.into_iter().map(|(_, v)| v).collect();
                format!("{}=[{}]", parameter.key, entries.join(", "))
            }
        };
        if !set.contains(&assignment) {
            set.push(assignment);
        }
    }
    set
}

/// The SI unit of a parameter where the twin's own types say it: the reference (in the
/// reference's unit; ω in rad/s, φ in rad), a joint's initial state, a sensor (in its signal's
/// unit; delay in s), a link's mass properties and a joint's dynamics.
fn unit(name: &str, simulator: &Simulator) -> Option<String> {
    let parts: Vec<&str> = name.split('.').map(|p| p.trim_matches('"')).collect();
    let signal_unit = |signal: &str| {
        let index = simulator
            .signal_specs()
            .iter()
            .position(|s| s.name == signal)?;
        Some(simulator.signal_units()[index].to_string())
    };
    let joint = |joint: &str| {
        let kinds = simulator.joints();
        kinds.iter().find(|(n, _)| *n == joint).map(|(_, k)| *k)
    };
    let per_kind = |joint_name: &str, force: &str, torque: &str| {
        joint(joint_name).map(|kind| match kind {
            EffortKind::Force => force.to_string(),
            EffortKind::Torque => torque.to_string(),
        })
    };
    let unit = match parts.as_slice() {
        ["reference", "offset" | "amplitude" | "value"] => signal_unit("reference"),
        ["reference", "angular_frequency"] => Some("rad/s".into()),
        ["reference", "phase"] => Some("rad".into()),
        ["initial", j, "position"] => per_kind(j, "m", "rad"),
        ["initial", j, "velocity"] => per_kind(j, "m/s", "rad/s"),
        ["sensors", .., "delay"] => Some("s".into()),
        // A sensor's key may be a quoted signal name with dots in it.
        ["sensors", signal @ .., "resolution" | "noise"] => signal_unit(&signal.join(".")),
        ["plant", "link", _, "mass"] => Some("kg".into()),
        ["plant", "link", _, "izz"] => Some("kg·m²".into()),
        ["plant", "link", _, com] if com.starts_with("com[") => Some("m".into()),
        ["plant", "joint", j, "damping"] => per_kind(j, "N·s/m", "N·m·s/rad"),
        ["plant", "joint", j, "friction" | "effort_limit"] => per_kind(j, "N", "N·m"),
        ["plant", "joint", j, "stiffness"] => per_kind(j, "N/m", "N·m/rad"),
        _ => None,
    };
    unit.map(|u| unit_name(&u))
}

/// An SI unit written in ASCII, as FMI unit names are compared as strings.
pub fn unit_name(unit: &str) -> String {
    unit.replace('·', ".").replace('²', "2")
}

#[cfg(test)]
mod tests {
    use super::*;
    use twin::Scenario;

    /// The scenario's numbers with its controller in the loop.
    fn found(name: &str) -> Vec<Parameter> {
        let loaded = Scenario::builtin(name)
            .and_then(|s| s.build(&controllers::builtin()))
            .unwrap();
        let toml = loaded.toml.clone();
        let simulator = Simulator::with_controller(loaded, &controllers::builtin()).unwrap();
        parameters(&toml, &simulator, true)
    }

    #[test]
    fn the_feed_axis_numbers_are_parameters_with_their_units_where_known() {
        let found = found("feed-axis-micromilling");
        let named = |name: &str| found.iter().find(|p| p.name == name).cloned();
        let gain = named("controller.params.position_gain").unwrap();
        assert_eq!((gain.default, gain.unit), (Number::Real(30.0), None));
        let amplitude = named("reference.amplitude").unwrap();
        assert_eq!(amplitude.default, Number::Real(1.0e-6));
        assert_eq!(amplitude.unit.as_deref(), Some("m"));
        let omega = named("reference.angular_frequency").unwrap();
        assert_eq!(omega.unit.as_deref(), Some("rad/s"));
        let teeth = named("process.cut.teeth").unwrap();
        assert_eq!(teeth.default, Number::Integer(2));
        let resolution = named("sensors.\"table.position\".resolution").unwrap();
        assert_eq!(resolution.key, "sensors.\"table.position\".resolution");
        assert_eq!(resolution.unit.as_deref(), Some("m"));
        // Strings and booleans are not numbers.
        assert!(named("controller.params.joint").is_none());
        assert!(named("process.cutting").is_none());
        let mut names: Vec<&str> = found.iter().map(|p| p.name.as_str()).collect();
        names.sort();
        assert_eq!(
            names,
            found.iter().map(|p| p.name.as_str()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn array_entries_are_parameters_set_as_their_whole_array() {
        let found = found("lathe-turning");
        let first = found
            .iter()
            .position(|p| p.name == "controller.params.time_constants[0]")
            .unwrap();
        assert_eq!(found[first].key, "controller.params.time_constants");
        assert_eq!(found[first + 1].name, "controller.params.time_constants[1]");
        let mut values: Vec<Number> = found.iter().map(|p| p.default).collect();
        assert!(assignments(&found, &values).is_empty(), "nothing changed");
        values[first + 1] = Number::Real(0.6);
        assert_eq!(
            assignments(&found, &values),
            ["controller.params.time_constants=[0.5, 0.6]"]
        );
        values[first + 1] = Number::Real(f64::NAN);
        assert_eq!(
            assignments(&found, &values),
            ["controller.params.time_constants=[0.5, nan]"]
        );
    }

    #[test]
    fn tables_in_arrays_are_walked_by_index() {
        let found = found("platform-path");
        let radius = found
            .iter()
            .find(|p| p.name == "process.path.segments[1].radius")
            .unwrap();
        assert_eq!(radius.key, "process.path.segments.1.radius");
        assert_eq!(radius.element, None);
        let q1 = found
            .iter()
            .find(|p| p.name == "controller.params.q1[1]")
            .unwrap();
        assert_eq!(
            (q1.key.as_str(), q1.element),
            ("controller.params.q1", Some(1))
        );
    }
}
