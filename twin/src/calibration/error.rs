//! Why a comparison or a calibration was refused or failed.

use crate::data::DataError;
use crate::run::TwinError;
use crate::scenario::ScenarioError;
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
