//! Why an analysis could not be made or written.

use controllers::lathe::output_feedback_design::DesignError;
use models::lathe::LatheError;
use std::path::PathBuf;
use thiserror::Error;
use twin::RecordingError;

/// Why `twin analyze` failed.
#[derive(Debug, Error)]
pub enum AnalysisError {
    #[error("unknown analysis `{name}` (known: {known})")]
    Unknown { name: String, known: String },
    #[error(transparent)]
    Lathe(#[from] LatheError),
    #[error(transparent)]
    Design(#[from] DesignError),
    #[error("{flag}: {reason}")]
    Argument { flag: &'static str, reason: String },
    #[error("cannot write {path}: {reason}")]
    Output { path: PathBuf, reason: String },
    #[error(transparent)]
    Recording(#[from] RecordingError),
}
