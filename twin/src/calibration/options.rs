//! What a calibration fits and how it runs: the parameters, the start states fitted per segment,
//! the segments' length, the starts and iterations of the solve.

use crate::scenario::CalibrationSpec;

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
