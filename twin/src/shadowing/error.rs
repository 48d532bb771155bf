//! Why a shadow cannot start or go on: its scenario, its model, an option, the model failing
//! mid-watch, or its recording.

use crate::run::{LinearizeError, TwinError};
use thiserror::Error;

/// Why a shadow cannot start or go on.
#[derive(Debug, Error)]
pub enum ShadowError {
    /// The scenario cannot be built into a model.
    #[error(transparent)]
    Twin(#[from] TwinError),
    /// The scenario's machine has no model a filter can use.
    #[error(transparent)]
    Model(#[from] LinearizeError),
    /// An option names what the scenario lacks, or has a value out of range.
    #[error("{0}")]
    Option(String),
    /// The model failed at a time (its loops would not close): the estimate is lost.
    #[error("the shadow's model failed at t = {time:.6} s: {reason}")]
    Diverged {
        /// Time since the first sample, s.
        time: f64,
        /// What failed.
        reason: String,
    },
    /// The recording could not be written.
    #[error(transparent)]
    Recording(#[from] crate::recording::RecordingError),
}
