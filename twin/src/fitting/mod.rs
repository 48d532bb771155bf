//! Calibration, the twin against its machine's data: how far a scenario is from a measured run
//! ([`compare`]), and its parameters fitted to runs by weighted output-error least squares
//! ([`calibrate`]).
//!
//! `replay` simulates a stretch of a run (open loop on the logged commands, or closed loop on the
//! logged reference); `problem` lays the unknowns and residuals out and differentiates them;
//! `check` refuses what the data cannot determine before any solve; `solve` is the bounded
//! Levenberg–Marquardt; `report` the estimates, intervals and the calibrated scenario;
//! `metrics` fit %, whiteness and noise.

mod check;
mod compare;
mod local_fit;
mod metrics;
mod problem;
mod replay;
mod report;
mod segments;
mod solve;
mod start;
mod verdict;

pub use compare::{compare, Comparison, Overlay, SegmentFit};
pub use metrics::{SignalFit, Whiteness};
pub use report::{calibrate, Calibration, Estimate, RunFit};
pub use solve::Iteration;
pub use verdict::{SignalVerdict, Verdict, VARIANCE_FITS};

use crate::run::TwinError;
use crate::run_data::DataError;
use crate::scenario::{CalibrationSpec, ScenarioError};
use thiserror::Error;

/// Why a comparison or a calibration was refused or failed; one line, naming the file, key or
/// parameter and what to change.
#[derive(Debug, Error)]
pub enum CalibrationError {
    /// The scenario, or a value tried in it, is refused.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The twin cannot be built from the scenario.
    #[error(transparent)]
    Twin(#[from] TwinError),
    /// A data file cannot be read or does not fit the scenario.
    #[error(transparent)]
    Data(#[from] DataError),
    /// The twin diverged while replaying a run.
    #[error("{run}: the twin diverged replaying the run at t = {time} s: {reason}")]
    Diverged {
        /// The run's data file.
        run: String,
        /// The data's time where it diverged, s.
        time: f64,
        /// What diverged.
        reason: String,
    },
    /// The check before the solve refused the problem (a parameter without effect, parameters
    /// the data cannot separate, bounds that exclude the start, too little data).
    #[error("calibration check: {0}")]
    Check(String),
    /// The options contradict each other or name what the scenario lacks.
    #[error("{0}")]
    Options(String),
}

/// A scenario value to fit: any numeric key (`urdf.link.ram.mass`, `urdf.joint.crank.damping`,
/// `sensors."crank.position".bias`, `process.…`, `controller.params.…`).
#[derive(Debug, Clone, PartialEq)]
pub struct FitParameter {
    /// The dotted key, as `--set` takes it.
    pub key: String,
    /// Where the fit starts; `None`: the scenario's (or the URDF's) value.
    pub start: Option<f64>,
    /// Lowest and highest value allowed; `None`: ≥ 0 for physical magnitudes (> 0 for a mass
    /// or an inertia), else unbounded.
    pub bounds: Option<[f64; 2]>,
    /// Fitted once per run (a workpiece mass that changes between runs) rather than shared.
    pub per_run: bool,
}

/// Segment length where the data place the mechanism, s: long enough to excite inertia and
/// damping, short enough that a replay with parameters tens of percent off stays near its run
/// (a Whitworth replayed open loop over 3 s from nominal values stalls in a local minimum; in
/// 0.5–1 s segments it converges).
pub const DEFAULT_SEGMENT: f64 = 1.0;

impl FitParameter {
    /// The parameters of a scenario's `[calibration.fit]` table, in key order.
    pub fn from_table(spec: &CalibrationSpec) -> Vec<FitParameter> {
        (spec.fit.iter())
            .map(|(key, fit)| FitParameter {
                key: key.clone(),
                start: fit.start,
                bounds: fit.bounds,
                per_run: fit.per_run,
            })
            .collect()
    }
}

/// Which joints' start states a calibration fits per segment, beside the parameters.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum StartStates {
    /// Every independent coordinate the logged positions place (a linkage's crank, every joint
    /// of a tree).
    #[default]
    Automatic,
    /// None: each segment starts where its first samples say.
    Fixed,
    /// These joints' positions and velocities.
    Joints(Vec<String>),
}

impl StartStates {
    /// As `--states` and `[calibration] states` spell it: `auto`, `none`, or joints separated
    /// by commas.
    pub fn parse(text: &str) -> Self {
        match text {
            "auto" => Self::Automatic,
            "none" => Self::Fixed,
            joints => Self::Joints(joints.split(',').map(|j| j.trim().to_string()).collect()),
        }
    }
}

/// How a calibration runs.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationOptions {
    /// The values to fit.
    pub parameters: Vec<FitParameter>,
    /// The measured signals fitted; empty: every plant signal the data hold (not the reference).
    pub signals: Vec<String>,
    /// A signal's noise σ, SI, in place of the estimate from its data.
    pub noise: Vec<(String, f64)>,
    /// Segments of this many seconds, each simulated from its own start state (multiple
    /// shooting), so that an open-loop replay never drifts far from its run; 0: each run
    /// whole. `None`: [`DEFAULT_SEGMENT`] where the logged positions place the mechanism (a
    /// segment can then start where its run is), else whole runs, said in a note.
    pub segment: Option<f64>,
    /// The start states fitted per segment.
    pub states: StartStates,
    /// Drive the twin with its own controller following the logged reference, not with the
    /// logged commands.
    pub closed_loop: bool,
    /// Solves from this many starts (the given one, then draws within the bounds); the best
    /// wins.
    pub starts: usize,
    /// Most Levenberg–Marquardt iterations per start.
    pub max_iterations: usize,
    /// Threads for the rollouts; 0: the machine's cores.
    pub threads: usize,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            parameters: Vec::new(),
            signals: Vec::new(),
            noise: Vec::new(),
            segment: None,
            states: StartStates::Automatic,
            closed_loop: false,
            starts: 1,
            max_iterations: 50,
            threads: 0,
        }
    }
}

/// Runs `job(i)` for `i` in `0..jobs` on up to `threads` threads; the results in job order, so
/// that the outcome never depends on the threads' timing.
fn parallel<T: Send>(jobs: usize, threads: usize, job: impl Fn(usize) -> T + Sync) -> Vec<T> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;
    let threads = threads.clamp(1, jobs.max(1));
    if threads == 1 {
        return (0..jobs).map(job).collect();
    }
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<T>>> = Mutex::new((0..jobs).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= jobs {
                    break;
                }
                let result = job(i);
                if let Ok(mut slots) = slots.lock() {
                    slots[i] = Some(result);
                }
            });
        }
    });
    let slots = slots
        .into_inner()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    slots.into_iter().flatten().collect()
}

/// The machine's cores, or `threads` when given.
fn thread_count(threads: usize) -> usize {
    if threads > 0 {
        return threads;
    }
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
