//! The `--engine` option that run, bench, linearize, sweep and reproduce share.

use twin::Engine;

/// `--engine` as the `--set` it equals (none when not given).
pub fn engine_override(engine: Option<Engine>) -> Vec<String> {
    engine
        .map(|e| format!("solver.engine={}", e.name()))
        .into_iter()
        .collect()
}

/// Parses `--engine`: a name a scenario's `solver.engine` takes.
pub fn parse_engine(name: &str) -> Result<Engine, String> {
    [Engine::Exact, Engine::Rapier]
        .into_iter()
        .find(|engine| engine.name() == name)
        .ok_or_else(|| format!("unknown engine `{name}`; choose exact or rapier"))
}
