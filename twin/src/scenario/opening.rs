//! Opening a scenario by a built-in name or a file path, as the command line's SCENARIO
//! argument does.

use super::builder::ScenarioBuilder;
use super::builtin::{unknown, BUILTIN};
use super::error::ScenarioError;
use super::spec::Scenario;
use std::path::Path;

impl Scenario {
    /// A built-in scenario by name (`whitworth-tracking`, …); unknown names list the known ones.
    pub fn builtin(name: &str) -> Result<ScenarioBuilder, ScenarioError> {
        let (name, text) = BUILTIN
            .iter()
            .find(|(known, _)| *known == name)
            .ok_or_else(|| unknown(name))?;
        Self::from_toml(text, &format!("built-in scenario {name}"), None)
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
