//! Why a scenario could not be found, read, changed or checked.

use thiserror::Error;

/// Why a scenario could not be found, read, changed or checked.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ScenarioError {
    /// A name that is neither a built-in scenario nor a `.toml` file.
    #[error("unknown scenario `{name}` (built in: {known}; or give a .toml file)")]
    Unknown {
        /// The name given.
        name: String,
        /// The built-in scenarios' names, comma-separated.
        known: String,
    },
    /// The scenario file or its URDF cannot be read.
    #[error("{file}: cannot read: {reason}")]
    Read {
        /// The file's path.
        file: String,
        /// What the file system said.
        reason: String,
    },
    /// The scenario is not valid TOML, fails a check, names no URDF found, or its controller
    /// refuses its parameters.
    #[error("{file}: {reason}")]
    Invalid {
        /// Where the scenario came from.
        file: String,
        /// What is wrong, naming the key.
        reason: String,
    },
    /// A command line `--set key=value` is malformed or cannot be applied.
    #[error("--set {assignment}: {reason}")]
    BadSet {
        /// The assignment as given (shortened).
        assignment: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A typed change (`set`, `seed`, `metric`) cannot be applied to the scenario's TOML.
    #[error("scenario key `{key}`: {reason}")]
    BadKey {
        /// The dotted key (shortened).
        key: String,
        /// What is wrong with it.
        reason: String,
    },
}
