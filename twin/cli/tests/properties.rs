//! Property tests of the `twin` binary against mutated URDFs, scenario files and command lines.
//! Whatever the input: no panic or abort (exit 0, 1, 2 or 3 only), an end within a bound, an
//! error of one line (`error: …`, plus one `hint:` line for usage errors) that names the file or
//! key at fault, and nothing left on disk but a finished recording and summary.
//!
//! `TWIN_PROPTEST_CASES` sets the cases per property (default 24: about a minute in CI).

mod common;

use common::twin;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use std::path::Path;
use std::process::Output;

/// (scenario, its TOML, its URDF): each shipped URDF with a scenario that uses it.
const MACHINES: [(&str, &str, &str); 5] = [
    (
        "whitworth-crank-pi",
        include_str!("../../scenarios/whitworth-crank-pi.toml"),
        include_str!("../../../urdf/whitworth.urdf"),
    ),
    (
        "arm-milling",
        include_str!("../../scenarios/arm-milling.toml"),
        include_str!("../../../urdf/arm.urdf"),
    ),
    (
        "platform-path",
        include_str!("../../scenarios/platform-path.toml"),
        include_str!("../../../urdf/platform.urdf"),
    ),
    (
        "feed-axis-micromilling",
        include_str!("../../scenarios/feed-axis-micromilling.toml"),
        include_str!("../../../urdf/feed_axis.urdf"),
    ),
    (
        "lathe-turning",
        include_str!("../../scenarios/lathe-turning.toml"),
        include_str!("../../../urdf/lathe.urdf"),
    ),
];

/// Values a mutation puts in place of a number or attribute.
const HOSTILE: [&str; 12] = [
    "nan", "NaN", "inf", "-inf", "-1", "0", "1e308", "-1e308", "1e-320", "abc", "", "1 2 3 4",
];

fn config() -> Config {
    let cases = std::env::var("TWIN_PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24);
    Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    }
}

/// A fresh folder per case (cases of one property share a process).
fn scratch() -> common::Scratch {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    common::scratch("prop", &NEXT.fetch_add(1, Ordering::Relaxed).to_string())
}

/// The checks every outcome must pass; `names` are strings one of which an error must contain.
fn check(
    output: &Output,
    dir: &Path,
    inputs: &[&str],
    names: &[String],
) -> Result<(), TestCaseError> {
    let text = String::from_utf8_lossy(&output.stderr).into_owned();
    let code = output.status.code();
    prop_assert!(
        matches!(code, Some(0..=3)),
        "exit {code:?} (a panic is 101, an abort a signal): {text}"
    );
    let lines: Vec<&str> = text.trim().lines().collect();
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|f| !inputs.contains(&f.as_str()))
        .collect();
    left.sort();
    match code {
        Some(1) => {
            prop_assert_eq!(lines.len(), 1, "one line: {}", text);
            prop_assert!(lines[0].starts_with("error: "), "{}", text);
            prop_assert!(
                names.is_empty() || names.iter().any(|n| text.contains(n.as_str())),
                "the error names none of {:?}: {}",
                names,
                text
            );
            prop_assert!(left.is_empty(), "left behind: {:?}", left);
        }
        // `twin` alone lists the commands; any other usage error is one line and a hint.
        Some(2) if text.contains("\nCommands:\n") => {
            prop_assert!(left.is_empty(), "left behind: {:?}", left);
        }
        Some(2) => {
            prop_assert_eq!(lines.len(), 2, "error and hint: {}", text);
            prop_assert!(left.is_empty(), "left behind: {:?}", left);
        }
        _ => prop_assert!(
            left.iter().all(|f| !f.ends_with(".part")),
            "no temporary file may remain: {:?}",
            left
        ),
    }
    Ok(())
}

/// A scenario file using `urdf_text` as m.urdf, shortened to a few steps.
fn write_inputs(dir: &Path, toml: &str, urdf_text: &str) {
    let mut table: toml::Table = toml.parse().unwrap();
    table.insert("urdf".into(), "m.urdf".into());
    table.insert("duration".into(), toml::Value::Float(0.005));
    std::fs::write(dir.join("m.toml"), toml::to_string(&table).unwrap()).unwrap();
    std::fs::write(dir.join("m.urdf"), urdf_text).unwrap();
}

#[derive(Debug, Clone)]
enum UrdfMutation {
    /// Remove the n-th attribute.
    DeleteAttribute(usize),
    /// Replace the n-th attribute's value.
    ReplaceAttribute(usize, &'static str),
    /// Repeat the n-th line.
    DuplicateLine(usize),
    /// Wrap the n-th line in this many elements.
    Nest(usize, usize),
}

fn urdf_mutation() -> impl Strategy<Value = UrdfMutation> {
    prop_oneof![
        any::<usize>().prop_map(UrdfMutation::DeleteAttribute),
        (any::<usize>(), proptest::sample::select(&HOSTILE[..]))
            .prop_map(|(n, v)| UrdfMutation::ReplaceAttribute(n, v)),
        any::<usize>().prop_map(UrdfMutation::DuplicateLine),
        (any::<usize>(), 30usize..3000).prop_map(|(n, d)| UrdfMutation::Nest(n, d)),
    ]
}

/// Byte ranges of every `name="value"` attribute: (whole attribute, value).
fn attributes(text: &str) -> Vec<(std::ops::Range<usize>, std::ops::Range<usize>)> {
    let mut found = Vec::new();
    let bytes = text.as_bytes();
    for (i, window) in bytes.windows(2).enumerate() {
        if window == b"=\"" {
            let name_start = text[..i]
                .rfind(|c: char| c.is_whitespace())
                .map_or(0, |p| p + 1);
            let value_start = i + 2;
            if let Some(len) = text[value_start..].find('"') {
                found.push((
                    name_start..value_start + len + 1,
                    value_start..value_start + len,
                ));
            }
        }
    }
    found
}

fn mutate_urdf(text: &str, mutation: &UrdfMutation) -> String {
    let attrs = attributes(text);
    let lines: Vec<&str> = text.lines().collect();
    match *mutation {
        UrdfMutation::DeleteAttribute(n) => {
            let (whole, _) = attrs[n % attrs.len()].clone();
            format!("{}{}", &text[..whole.start], &text[whole.end..])
        }
        UrdfMutation::ReplaceAttribute(n, value) => {
            let (_, range) = attrs[n % attrs.len()].clone();
            format!("{}{value}{}", &text[..range.start], &text[range.end..])
        }
        UrdfMutation::DuplicateLine(n) => {
            let k = n % lines.len();
            let mut out: Vec<&str> = lines.clone();
            out.insert(k, lines[k]);
            out.join("\n")
        }
        UrdfMutation::Nest(n, depth) => {
            let k = 1 + n % (lines.len() - 2);
            let wrapped = format!(
                "{}{}{}",
                "<x>".repeat(depth),
                lines[k],
                "</x>".repeat(depth)
            );
            let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
            out[k] = wrapped;
            out.join("\n")
        }
    }
}

#[test]
fn mutated_urdfs_fail_cleanly() {
    let strategy = (0..MACHINES.len(), urdf_mutation());
    TestRunner::new(config())
        .run(&strategy, |(machine, mutation)| {
            let (_, toml, urdf) = MACHINES[machine];
            let dir = scratch();
            write_inputs(&dir, toml, &mutate_urdf(urdf, &mutation));
            let output = twin(&["run", "m.toml"], &dir);
            let result = check(&output, &dir, &["m.toml", "m.urdf"], &["m.urdf".into()]);
            std::fs::remove_dir_all(&dir).ok();
            result
        })
        .unwrap();
}

/// Every key path of a table down to its leaves (array elements included).
fn leaf_paths(value: &toml::Value, path: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match value {
        toml::Value::Table(table) => {
            for (key, item) in table {
                path.push(key.clone());
                leaf_paths(item, path, out);
                path.pop();
            }
        }
        _ => out.push(path.clone()),
    }
}

#[derive(Debug, Clone)]
enum TomlMutation {
    Replace(usize, &'static str),
    Delete(usize),
    /// An unknown key beside the n-th leaf.
    Unknown(usize),
}

/// TOML values of every type and range trouble.
const TOML_VALUES: [&str; 12] = [
    "nan",
    "inf",
    "-inf",
    "-1.0",
    "0",
    "1e300",
    "-1e300",
    "\"text\"",
    "true",
    "[1.0, 2.0, 3.0]",
    "{ a = 1 }",
    "9223372036854775807",
];

fn toml_mutation() -> impl Strategy<Value = TomlMutation> {
    prop_oneof![
        (any::<usize>(), proptest::sample::select(&TOML_VALUES[..]))
            .prop_map(|(n, v)| TomlMutation::Replace(n, v)),
        any::<usize>().prop_map(TomlMutation::Delete),
        any::<usize>().prop_map(TomlMutation::Unknown),
    ]
}

/// Applies the mutation; returns the text and the key names an error must mention (any one).
fn mutate_toml(text: &str, mutation: &TomlMutation) -> (String, Vec<String>) {
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration".into(), toml::Value::Float(0.005));
    let mut paths = Vec::new();
    leaf_paths(
        &toml::Value::Table(table.clone()),
        &mut Vec::new(),
        &mut paths,
    );
    let (TomlMutation::Replace(n, _) | TomlMutation::Delete(n) | TomlMutation::Unknown(n)) =
        *mutation;
    let path = paths[n % paths.len()].clone();
    let (last, parents) = path.split_last().unwrap();
    let mut current = &mut table;
    for part in parents {
        current = current.get_mut(part).unwrap().as_table_mut().unwrap();
    }
    let mut names = vec![last.clone()];
    match mutation {
        TomlMutation::Replace(_, value) => {
            let parsed: toml::Table = format!("v = {value}").parse().unwrap();
            current.insert(last.clone(), parsed["v"].clone());
        }
        TomlMutation::Delete(_) => {
            current.remove(last);
        }
        TomlMutation::Unknown(_) => {
            current.insert("bogus_key".into(), toml::Value::Integer(1));
            names = vec!["bogus_key".into()];
        }
    }
    // Errors found downstream, or inside a tagged table such as `[reference]`, name the table.
    names.extend(parents.iter().cloned());
    (toml::to_string(&table).unwrap(), names)
}

#[test]
fn mutated_scenarios_fail_naming_the_key() {
    let strategy = (0..MACHINES.len(), toml_mutation());
    TestRunner::new(config())
        .run(&strategy, |(machine, mutation)| {
            let (_, toml, _) = MACHINES[machine];
            let dir = scratch();
            let (text, names) = mutate_toml(toml, &mutation);
            std::fs::write(dir.join("m.toml"), text).unwrap();
            let output = twin(&["run", "m.toml"], &dir);
            let result = check(&output, &dir, &["m.toml"], &names);
            std::fs::remove_dir_all(&dir).ok();
            result
        })
        .unwrap();
}

/// Command-line words: subcommands, flags and hostile values.
const WORDS: [&str; 30] = [
    "run",
    "analyze",
    "bench",
    "reproduce",
    "list",
    "lathe",
    "whitworth-crank-pi",
    "--duration",
    "--set",
    "--out",
    "--summary",
    "--controller",
    "--grid",
    "--connect",
    "--max-force",
    "--m1",
    "nan",
    "-inf",
    "1e308",
    "-1",
    "0",
    "",
    "dt=0",
    "x.y.z=[",
    "controller.params.natural_frequency=-1",
    "/",
    "/proc/x",
    "..",
    "passive",
    "0.001",
];

#[test]
fn mutated_command_lines_fail_cleanly() {
    let strategy = proptest::collection::vec(proptest::sample::select(&WORDS[..]), 0..7);
    TestRunner::new(config())
        .run(&strategy, |words| {
            let dir = scratch();
            let mut args: Vec<String> = words.iter().map(|w| w.to_string()).collect();
            // Keep runs that happen to be valid short.
            if args.first().is_some_and(|w| w == "run") {
                args.extend(["--duration".into(), "0.005".into()]);
            }
            if args
                .first()
                .is_some_and(|w| w == "bench" || w == "reproduce")
            {
                args.truncate(1);
                args.push("--help".into());
            }
            let output = twin(&args, &dir);
            let result = check(&output, &dir, &[], &[]);
            std::fs::remove_dir_all(&dir).ok();
            result
        })
        .unwrap();
}
