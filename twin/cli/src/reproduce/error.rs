//! Why `twin reproduce` could not reproduce a paper.

use twin::TwinError;

/// Why a paper could not be reproduced.
#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    #[error("unknown paper `{name}` (known: {known})")]
    Unknown { name: String, known: String },
    #[error(transparent)]
    Twin(#[from] TwinError),
    #[error("cannot write {path}: {reason}")]
    Output { path: String, reason: String },
    /// A search over runs (the arm's safe path speed) found no answer.
    #[error("{0}")]
    Search(String),
    /// `--engine` on a paper whose runs go through an analysis that builds its own scenarios.
    #[error("twin reproduce {paper} runs the exact engine only (through `twin analyze {paper}`); leave out --engine")]
    EngineFixed { paper: String },
}
