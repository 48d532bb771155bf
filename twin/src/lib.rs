//! The twin engine: planar URDF mechanisms simulated in Rapier, driven through joint efforts by
//! controllers chosen at run time, recorded to Rerun `.rrd` files.
//!
//! One door in: a [`Scenario`] is put together ([`ScenarioBuilder`]), built with the controller
//! registry into a [`LoadedScenario`] (its controller's parameters checked there), bound into a
//! [`Twin`] and run ([`Twin::run`], [`Twin::run_with`] and [`Observer`]s), giving a
//! [`RunSummary`]. The modules are private; this file is the surface. Only the `physics` module
//! knows Rapier; only `recording` knows Rerun. The applications built on the library (the `twin`
//! command line, studies, reproductions, analyses) live in the `twin-cli` crate.

#![warn(missing_docs)]

mod energy;
mod faults;
mod files;
mod fitting;
mod linear;
mod machines;
mod mechanism;
mod output;
mod physics;
mod plant;
mod recording;
mod run;
mod run_data;
mod scenario;
mod scene;
mod sensors;
mod shadow;
mod spectrum;
mod urdf;

pub use linear::{Channel, LinearModel, ModelError, OperatingPoint};
pub use machines::{ActuatorKind, ActuatorSpec, PointSpec, SpringSpec};
pub use output::{same_file, OutputError, OutputFile};
pub use physics::{
    AllowedContact, BodyKind, BodyShape, BodySpec, Collision, ContactOptions, Engine, SolverOptions,
};
pub use recording::{LiveViewer, RecordingError};
pub use run::{
    Divergence, FailureKind, Findings, Interruption, LinearizeError, Observer, ObserverError,
    RunSummary, SetpointSource, SignalLayout, Simulator, StepError, StepView, StopFlag, Twin,
    TwinError,
};
pub use scenario::{
    load as load_scenario, CalibrationSpec, FitSpec, LoadedScenario, MetricKind, MetricSpec,
    Overrides, Scenario, ScenarioBuilder, ScenarioError, ScenarioValue,
    BUILTIN as BUILTIN_SCENARIOS,
};
pub use sensors::Noise;

/// Signal processing the twin's own spectra use, for applications that analyse signals alike.
pub mod signal {
    pub use crate::spectrum::{fft, Spectrum};
}

/// Measured runs in and out: a run's table of commands, measured and true signals as CSV,
/// Parquet or a twin `.rrd` ([`RunData`](data::RunData)), bound to a plant's
/// [`PlantColumns`](data::PlantColumns) and resampled onto its control period
/// ([`Trace`](data::Trace)), and written from a run by the [`RunTable`](data::RunTable)
/// observer.
pub mod data {
    pub use crate::run_data::{
        left_out_note, parse_renames, ColumnRole, DataColumn, DataError, DataRate, Delimiter,
        PlantColumns, ReadOptions, RunData, RunTable, Trace, UnreadColumn, MAX_DATA_BYTES,
    };
}

/// The twin against its machine's measured runs: [`compare`](calibration::compare) replays a
/// run and says per signal how far apart they are; [`calibrate`](calibration::calibrate) fits
/// scenario values to runs, checked first, with standard errors, 95 % intervals and the
/// calibrated scenario.
pub mod calibration {
    pub use crate::fitting::{
        calibrate, compare, Calibration, CalibrationError, CalibrationOptions, Comparison,
        Estimate, FitParameter, Iteration, Overlay, RunFit, SegmentFit, SignalFit, SignalVerdict,
        StartStates, Verdict, Whiteness, DEFAULT_SEGMENT, VARIANCE_FITS,
    };
}

/// The twin beside a running machine: a [`Shadow`](shadowing::Shadow) fed the machine's
/// commands and measurements as they arrive estimates its state and tracked parameters with an
/// extended Kalman filter on the twin's own model, tests the innovations and raises
/// [`Anomaly`](shadowing::Anomaly) events, named after the parameter that explains them.
pub mod shadowing {
    pub use crate::shadow::{
        describe, Anomaly, AnomalyChange, Attribution, DetectorView, Innovation, IntakeCounts,
        Shadow, ShadowError, ShadowOptions, ShadowRecording, ShadowStep, TrackedParameter,
        DEFAULT_PROCESS_NOISE, MAX_GAP,
    };
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
