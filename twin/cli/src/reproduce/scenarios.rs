//! The built-in scenarios a paper runs, on the engine `--engine` chose.

use twin::{Engine, Scenario, ScenarioBuilder, ScenarioError};

/// A built-in scenario on the engine given (its own when none).
pub(super) fn builtin(
    name: &str,
    engine: Option<Engine>,
) -> Result<ScenarioBuilder, ScenarioError> {
    let builder = Scenario::builtin(name)?;
    match engine {
        Some(engine) => builder.set("solver.engine", engine.name()),
        None => Ok(builder),
    }
}
