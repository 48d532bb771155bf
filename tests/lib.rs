//! Helpers shared by the end-to-end tests.

use std::path::PathBuf;
use twin::{LoadedScenario, RunSummary, Scenario, ScenarioBuilder, ScenarioValue, Twin};

/// A built-in scenario to change with typed values; panics with the error (a test's typo).
pub fn builtin(name: &str) -> ScenarioBuilder {
    Scenario::builtin(name).unwrap_or_else(|e| panic!("{e}"))
}

/// The builder's fallible steps for tests that configure a run: a failure is the test's own
/// mistake, so it panics with the message instead of being handled.
pub trait Configure: Sized {
    /// `set`, panicking with the error.
    fn with(self, key: &str, value: impl Into<ScenarioValue>) -> Self;
    /// `build`, panicking with the error.
    fn loaded(self) -> LoadedScenario;
}

impl Configure for ScenarioBuilder {
    fn with(self, key: &str, value: impl Into<ScenarioValue>) -> Self {
        self.set(key, value).unwrap_or_else(|e| panic!("{e}"))
    }

    fn loaded(self) -> LoadedScenario {
        self.build(&controllers::builtin())
            .unwrap_or_else(|e| panic!("{e}"))
    }
}

/// Runs a loaded scenario with the built-in controllers, optionally recording.
pub fn run(loaded: LoadedScenario, recording: Option<&std::path::Path>) -> RunSummary {
    Twin::new(loaded)
        .and_then(|t| t.run(recording))
        .unwrap_or_else(|e| panic!("{e}"))
}

/// What refuses `builder` as `twin run` would: building the scenario (a bad key, a bad
/// controller parameter) or binding its twin (a mismatch with the plant); `None` when neither does.
pub fn refusal(builder: ScenarioBuilder) -> Option<String> {
    match builder.build(&controllers::builtin()).map(Twin::new) {
        Ok(Ok(_)) => None,
        Ok(Err(error)) => Some(error.to_string()),
        Err(error) => Some(error.to_string()),
    }
}

/// A fresh, empty folder under the target's temp dir for one test.
pub fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("twin-tests-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}
