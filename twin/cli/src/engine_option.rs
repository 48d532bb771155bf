//! The `--engine` option that run, bench, linearize, sweep and reproduce share.

use twin::Engine;

/// Parses `--engine`: a name a scenario's `solver.engine` takes.
pub fn parse_engine(name: &str) -> Result<Engine, String> {
    [Engine::Exact, Engine::Rapier]
        .into_iter()
        .find(|engine| engine.name() == name)
        .ok_or_else(|| format!("unknown engine `{name}`; choose exact or rapier"))
}
