//! Scenarios: a TOML file naming the machine, its URDF, the controller and its parameters, the
//! reference, process parameters, sensors, timing and recording options.
//!
//! `spec` is what a scenario holds, `checks` what a valid one is; `builder` puts one together
//! from TOML and typed changes and builds its controller into a `loaded` scenario, `builtin`
//! holds the shipped scenarios and URDFs, `metrics` the figures a run is judged by.

mod builder;
mod builtin;
mod checks;
mod error;
mod loaded;
mod metrics;
mod opening;
mod spec;
#[cfg(test)]
mod tests;

pub use builder::{load, Overrides, ScenarioBuilder, ScenarioValue};
pub use builtin::BUILTIN;
pub use error::ScenarioError;
pub use loaded::LoadedScenario;
pub use metrics::{MetricKind, MetricSpec};
pub use spec::{CalibrationSpec, FitSpec, Gravity, Scenario};
