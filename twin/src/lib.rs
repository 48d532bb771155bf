//! The twin engine: planar URDF mechanisms simulated in Rapier, driven through joint efforts by
//! controllers chosen at run time, recorded to Rerun `.rrd` files.
//!
//! One door in: a [`Scenario`] is put together ([`ScenarioBuilder`]), built with the controller
//! registry into a [`LoadedScenario`] (its controller's parameters checked there), bound into a
//! [`Twin`] and run ([`Twin::run`], [`Twin::run_with`] and [`Observer`]s), giving a
//! [`RunSummary`]. This file is the surface: the engine's modules are private, but for
//! [`data`], [`calibration`] and [`shadowing`], public under their folders' names, whose own
//! `mod.rs` says what they show. Only the `physics` module knows Rapier; only `recording` knows
//! Rerun. The applications built on the library (the `twin` command line, studies,
//! reproductions, analyses) live in the `twin-cli` crate.

#![warn(missing_docs)]

pub mod calibration;
pub mod data;
mod energy;
mod faults;
mod files;
mod linear;
mod machines;
mod mechanism;
mod output;
mod physics;
mod plant;
mod recording;
mod run;
mod scenario;
mod scene;
mod sensors;
pub mod shadowing;
mod spectrum;
mod urdf;

pub use linear::{Channel, LinearModel, ModelError, OperatingPoint};
pub use machines::{ActuatorKind, ActuatorSpec, PointAt, PointSpec, SpringSpec};
pub use output::{same_file, OutputError, OutputFile};
pub use physics::{
    AllowedContact, BodyKind, BodyShape, BodySpec, Collision, ContactOptions, Engine, Integrator,
    SolverOptions,
};
pub use recording::{LiveViewer, RecordingError};
pub use run::{
    Divergence, FailureKind, Findings, Interruption, LinearizeError, Observer, ObserverError,
    RunSummary, RunTable, SetpointSource, SignalLayout, Simulator, StepError, StepView, StopFlag,
    Twin, TwinError,
};
pub use scenario::{
    load as load_scenario, CalibrationSpec, FitSpec, Gravity, LoadedScenario, MetricKind,
    MetricSpec, Overrides, Scenario, ScenarioBuilder, ScenarioError, ScenarioValue,
    BUILTIN as BUILTIN_SCENARIOS,
};
pub use sensors::Noise;

/// Signal processing the twin's own spectra use, for applications that analyse signals alike.
pub mod signal {
    pub use crate::spectrum::{fft, Spectrum};
}

/// A run's summary as a table for people and JSON for scripts.
pub mod summary {
    pub use crate::run::{to_json, to_table, write_json};
}

/// The engine beneath a run, for those who check its physics or build on it: a URDF read into a
/// [`Mechanism`](engine::Mechanism), the [`Physics`](engine::Physics) that steps it, and its
/// mechanical energy.
pub mod engine {
    pub use crate::energy::mechanical_energy;
    pub use crate::mechanism::{JointMotion, Mechanism, Outline, Pose2, Shape};
    pub use crate::physics::{MechanismState, Physics, SolverSettings};
    pub use crate::urdf::{load_file as load_urdf_file, load_str as load_urdf, UrdfError};
}

/// Rerun files beside a run's own recording: what a run will record
/// ([`Twin::recording_plan`]), 2D plots and study plots written by the applications, and reading
/// back or salvaging a recording.
pub mod recordings {
    pub use crate::recording::{
        inspect, salvage, write_figures, write_plot, write_study_plots, FigureLayer, Histogram,
        Plot2D, PlotAxis, PlotGeometry, PlotLayer, PlotSpec, PlotTab, RecordingContents,
        SalvageReport, Scatter, SeriesRole, SeriesSpec, StudyPlots,
    };
    pub use crate::scene::Scene;
}
