//! Helpers shared by the end-to-end tests.

use controllers::Registry;
use std::path::PathBuf;
use twin::{LoadedScenario, Overrides, RunSummary, Twin};

/// Loads a built-in scenario with `key=value` overrides.
pub fn scenario(name: &str, set: &[&str]) -> LoadedScenario {
    twin::load_scenario(
        name,
        &Overrides {
            set: set.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Runs a loaded scenario with the built-in controllers, optionally recording.
pub fn run(loaded: LoadedScenario, recording: Option<&std::path::Path>) -> RunSummary {
    Twin::new(loaded, &Registry::builtin())
        .and_then(|t| t.run(recording))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A fresh, empty folder under the target's temp dir for one test.
pub fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-tests-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
