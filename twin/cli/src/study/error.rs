//! Why a study could not be planned, run, merged or written.

use std::path::PathBuf;
use thiserror::Error;
use twin::ScenarioError;

/// Why a study failed.
#[derive(Debug, Error)]
pub enum StudyError {
    /// An axis, spec, shard or option that cannot work; found before any run starts.
    #[error("{0}")]
    Input(String),
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// A run's scenario cannot be built (a bad key or parameter, from the base or an axis): the
    /// study is refused before any run, naming the first such run and how many more there are.
    #[error("run {index}{}: {reason}", if *more > 0 { format!(" (and {more} more)") } else { String::new() })]
    Refused {
        index: usize,
        more: usize,
        reason: String,
    },
    #[error("{}: {reason}", path.display())]
    Io { path: PathBuf, reason: String },
    /// The output folder holds another study's results.
    #[error("{}: holds a different study ({reason}); give another --out or remove it", folder.display())]
    Mismatch { folder: PathBuf, reason: String },
}
