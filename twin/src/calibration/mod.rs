//! The twin against its machine's measured runs: [`compare`] replays a run and says per signal
//! how far apart they are; [`calibrate`] fits scenario values to runs by weighted output-error
//! least squares, checked first, with standard errors, 95 % intervals and the calibrated
//! scenario.
//!
//! `replay` simulates a stretch of a run (open loop on the logged commands, or closed loop on the
//! logged reference); `problem` lays the unknowns and residuals out and differentiates them,
//! rolled out on `threads`; `check` refuses what the data cannot determine before any solve;
//! `solve` is the bounded Levenberg–Marquardt; `report` the estimates, intervals and the
//! calibrated scenario; `metrics` fit %, whiteness and noise; `options` what a calibration fits
//! and how, `error` why it is refused. This file only declares the modules and re-exports what
//! the library shows.

mod check;
mod compare;
mod error;
mod local_fit;
mod metrics;
mod options;
mod problem;
mod replay;
mod report;
mod segments;
mod solve;
mod start;
mod threads;
mod verdict;

pub use compare::{compare, Comparison, Overlay, SegmentFit};
pub use error::CalibrationError;
pub use metrics::{SignalFit, Whiteness};
pub use options::{CalibrationOptions, FitParameter, StartStates, DEFAULT_SEGMENT};
pub use report::{calibrate, Calibration, Estimate, RunFit};
pub use solve::Iteration;
pub use verdict::{SignalVerdict, Verdict, VARIANCE_FITS};
