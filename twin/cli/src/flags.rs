//! The flags the commands share, each declared once and flattened into the commands that take
//! it: `--set`, `--engine`, `--duration`, and the outputs of a run (`--out`, `--summary`,
//! `--connect`). A command whose flag says a little more about it (when its `--set` applies, what
//! its `--out` defaults to) rewrites the help with `#[command(mut_arg(…))]`; the flag's name,
//! value, default and parsing stay these.

use crate::engine_option::{engine_override, parse_engine};
use std::path::PathBuf;
use twin::Engine;

/// `--set KEY=VALUE`, repeated: scenario values overridden by dotted key.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SetFlag {
    /// Override a scenario value: a dotted key into the TOML.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

/// `--engine exact|rapier`: the engine that steps the mechanism.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct EngineFlag {
    /// The engine that steps the mechanism: exact (RK4, loops closed to 1e-12 m) or rapier
    /// (Rapier's pipeline, with contacts); the same as --set solver.engine=…, given before the
    /// --set values.
    #[arg(long, value_name = "exact|rapier", value_parser = parse_engine)]
    pub engine: Option<Engine>,
}

impl EngineFlag {
    /// `--engine` as the `--set` it equals, before the `set` values.
    pub fn before(&self, set: &SetFlag) -> Vec<String> {
        [engine_override(self.engine), set.set.clone()].concat()
    }
}

/// `--duration SECONDS`: how long the run lasts.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DurationFlag {
    /// Simulated time, s.
    #[arg(long, allow_hyphen_values = true)]
    pub duration: Option<f64>,
}

/// Where a run's outputs go: its recording, its summary as JSON, and a live Rerun viewer.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct OutputFlags {
    /// Recording to write (default: `<scenario>.rrd` in the current folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write the summary as JSON to this file.
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// Also stream the run to a Rerun viewer listening at this URL
    /// (e.g. rerun+http://127.0.0.1:9876/proxy).
    #[arg(long)]
    pub connect: Option<String>,
}
