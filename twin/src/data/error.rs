//! Why a data file cannot be read, written or bound to a plant.

use thiserror::Error;

/// Why a data file cannot be read, written or bound to a plant: one line naming the file and
/// the row or column, and what to change.
#[derive(Debug, Error)]
pub enum DataError {
    /// The file cannot be read (missing, a directory, unreadable, too large).
    #[error("cannot read {file}: {reason}")]
    Read {
        /// The file, as given.
        file: String,
        /// What the file system said.
        reason: String,
    },
    /// The file as a whole is refused: not of a known kind, not parsing as its kind, no `time`
    /// column, too few samples, a control period that cannot be used.
    #[error("{file}: {reason}")]
    Format {
        /// The file, as given.
        file: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A column is refused: no unit, a duplicate, an unknown signal (when strict), a unit that
    /// does not fit its signal, a type that is not numbers.
    #[error("{file}: column \"{column}\": {reason}")]
    Column {
        /// The file, as given.
        file: String,
        /// The column's header, as written.
        column: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A row is refused: a number of cells other than the header's, a time not after the row
    /// before's.
    #[error("{file}: row {row}: {reason}")]
    Row {
        /// The file, as given.
        file: String,
        /// The row, counted from the header's 1.
        row: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A cell is refused: empty, not a number, not finite.
    #[error("{file}: row {row}, column \"{column}\": {reason}")]
    Cell {
        /// The file, as given.
        file: String,
        /// The row, counted from the header's 1.
        row: usize,
        /// The column's header, as written.
        column: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A `--rename old=new` argument is malformed.
    #[error("--rename `{given}`: {reason}")]
    Rename {
        /// The argument, as given.
        given: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The file cannot be written (its folder is missing or not writable, the table is
    /// inconsistent); nothing is left at its path.
    #[error("cannot write {file}: {reason}")]
    Write {
        /// The file, as given.
        file: String,
        /// What failed.
        reason: String,
    },
}
