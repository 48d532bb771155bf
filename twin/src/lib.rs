//! The twin engine: planar URDF mechanisms simulated in Rapier, driven through joint efforts by
//! controllers chosen at run time, recorded to Rerun `.rrd` files.
//!
//! One door in: [`Twin::run`]. Only [`physics`] knows Rapier; only `recording` knows Rerun.

pub mod analysis;
pub mod energy;
pub mod evaluate;
pub mod faults;
pub mod machines;
pub mod mechanism;
pub mod output;
pub mod physics;
pub mod plant;
pub mod recording;
pub mod reproduce;
pub mod run;
pub mod scenario;
pub mod scene;
pub mod sensors;
pub mod spectrum;
pub mod study;
pub mod summary;
pub mod urdf;

pub use run::{
    Divergence, Findings, Interruption, Observer, ObserverError, RunSummary, SignalLayout,
    StepView, StopFlag, Twin, TwinError,
};
pub use scenario::{
    load as load_scenario, LoadedScenario, Overrides, Scenario, ScenarioBuilder, ScenarioValue,
};
