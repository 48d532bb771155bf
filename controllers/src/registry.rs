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

/// Deserialises a table, with a one-line message that quotes the offending `key = value` line.
pub fn from_table<P: DeserializeOwned>(table: &toml::Table) -> Result<P, String> {
    // Through text, so that the error carries a span naming the entry.
    let text = toml::to_string(table).map_err(|e| e.to_string())?;
    toml::from_str(&text).map_err(|e| describe_toml_error(&text, &e))
}

/// A TOML error on one line: where it is (`line N: <that line>`) and what is wrong.
pub fn describe_toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) if span.start < text.len() => {
            let line_number = text[..span.start].matches('\n').count() + 1;
            let line = text.lines().nth(line_number - 1).unwrap_or("").trim();
            format!("line {line_number} (`{line}`): {message}")
        }
        _ => message,
    }
}
