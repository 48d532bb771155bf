//! Why a command failed: the exit code `twin` ends with and the one-line message it prints.

/// Exit code of a command that could not do its work (an unreadable scenario, an unwritable
/// output, a file that is already there).
pub const EXIT_ERROR: u8 = 1;
/// Exit code of a command line that asks for something malformed or contradictory.
pub const EXIT_USAGE: u8 = 2;
/// Exit code of a run whose simulation diverged (its files are still complete up to there).
pub const EXIT_DIVERGED: u8 = 3;

/// A failed command: its exit code (one of the `EXIT_*` codes) and a message for stderr.
///
/// Any error converts into one with [`EXIT_ERROR`], so that commands can use `?` on the
/// library's errors; the usage and divergence codes are given on purpose.
#[derive(Debug)]
pub struct Failure {
    /// The process's exit code.
    pub code: u8,
    /// One line saying what went wrong, without the `error: ` prefix.
    pub message: String,
}

impl Failure {
    /// A usage error ([`EXIT_USAGE`]): the arguments, not the files or the run, are at fault.
    pub fn usage(message: impl Into<String>) -> Self {
        Self {
            code: EXIT_USAGE,
            message: message.into(),
        }
    }
}

impl<E: std::fmt::Display> From<E> for Failure {
    fn from(error: E) -> Self {
        Self {
            code: EXIT_ERROR,
            message: error.to_string(),
        }
    }
}
