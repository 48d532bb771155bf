//! Controllers chosen by name at run time.

use crate::{Controller, ControllerError};
use serde::de::DeserializeOwned;

/// Builds a controller from the scenario's `[controller.params]` table.
pub type Constructor = fn(&toml::Table) -> Result<Box<dyn Controller>, ControllerError>;

/// One registered controller.
#[derive(Clone)]
pub struct Entry {
    pub name: &'static str,
    /// The machine it is written for (`*` for any).
    pub machine: &'static str,
    pub summary: &'static str,
    pub build: Constructor,
}

/// Name → constructor. [`Registry::builtin`] holds the project's controllers; a downstream crate
/// adds its own with [`Registry::register`].
#[derive(Clone, Default)]
pub struct Registry {
    entries: Vec<Entry>,
}

impl Registry {
    /// The controllers shipped with the twin.
    pub fn builtin() -> Self {
        let mut registry = Self::default();
        for entry in crate::builtin_entries() {
            registry.register(entry);
        }
        registry
    }

    /// Adds (or replaces, by name) a controller.
    pub fn register(&mut self, entry: Entry) {
        self.entries.retain(|e| e.name != entry.name);
        self.entries.push(entry);
    }

    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Builds the controller called `name` from its parameter table.
    pub fn build(
        &self,
        name: &str,
        params: &toml::Table,
    ) -> Result<Box<dyn Controller>, ControllerError> {
        let entry = self
            .entries
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| ControllerError::Unknown {
                name: name.to_string(),
                known: self
                    .entries
                    .iter()
                    .map(|e| e.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        (entry.build)(params)
    }
}

/// Reads a controller's parameter struct from its table; unknown keys and wrong types are errors
/// that name the controller and the offending entry.
pub fn parse_params<P: DeserializeOwned>(
    controller: &str,
    params: &toml::Table,
) -> Result<P, ControllerError> {
    from_table(params).map_err(|reason| ControllerError::BadParameters {
        controller: controller.to_string(),
        reason,
    })
}

/// Deserialises a table, with a one-line message that names the offending key path. Stricter than
/// TOML itself: every number must be finite (TOML allows `inf` and `nan`, no physical parameter
/// does), and an array must have exactly the length its field takes (the TOML deserialiser would
/// silently drop extra elements of a fixed-size array).
pub fn from_table<P: DeserializeOwned>(table: &toml::Table) -> Result<P, String> {
    check_finite(table, &mut Vec::new())?;
    // Through the value: it checks array lengths, and the error carries the key path. (Line
    // numbers would be those of a re-serialised table, not of the user's file.)
    serde_path_to_error::deserialize(toml::Value::Table(table.clone()))
        .map_err(|error| describe_path_error(&error))
}

/// `key.path: message`, with serde's wording for a too-long array made plain.
fn describe_path_error(error: &serde_path_to_error::Error<toml::de::Error>) -> String {
    let message = error.inner().message().trim().replace('\n', " ");
    let message = match message.strip_prefix("invalid length ") {
        Some(rest) if rest.contains("fewer elements in array") => {
            let found = rest.split(',').next().unwrap_or(rest);
            format!("has {found} elements, more than it takes")
        }
        _ => message,
    };
    match error.path().to_string().as_str() {
        // The table itself (a missing field): the message names the key.
        "." => message,
        path => format!("`{path}`: {message}"),
    }
}

/// Rejects NaN and infinities anywhere in the table, naming the key.
fn check_finite(table: &toml::Table, path: &mut Vec<String>) -> Result<(), String> {
    for (key, value) in table {
        path.push(key.clone());
        check_finite_value(value, path)?;
        path.pop();
    }
    Ok(())
}

fn check_finite_value(value: &toml::Value, path: &mut Vec<String>) -> Result<(), String> {
    match value {
        toml::Value::Float(x) if !x.is_finite() => Err(format!(
            "`{}` = {x}: must be a finite number",
            path.join(".")
        )),
        toml::Value::Table(table) => check_finite(table, path),
        toml::Value::Array(items) => {
            for (index, item) in items.iter().enumerate() {
                path.push(index.to_string());
                check_finite_value(item, path)?;
                path.pop();
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// The first `chars` characters of `text`, with `…` when it was longer: long inputs quoted in a
/// one-line message.
pub fn shortened(text: &str, chars: usize) -> String {
    match text.char_indices().nth(chars) {
        Some((end, _)) => format!("{}…", &text[..end]),
        None => text.to_string(),
    }
}

/// A TOML error on one line: where it is (`line N: <that line>`) and what is wrong.
pub fn describe_toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) if span.start < text.len() => {
            let line_number = text[..span.start].matches('\n').count() + 1;
            let line = text.lines().nth(line_number - 1).unwrap_or("").trim();
            // A long line (a generated file, a hostile input) is quoted by its start only.
            let line = shortened(line, 80);
            format!("line {line_number} (`{line}`): {message}")
        }
        _ => message,
    }
}
