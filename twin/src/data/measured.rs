//! A measured run's table as read from a file (CSV, Parquet or a twin `.rrd`), its columns, and
//! writing it whole as CSV or Parquet.

use super::csv_file;
use super::error::DataError;
use super::options::ReadOptions;
use super::parquet_file;
use super::reading::{read_bounded, Kind};
use super::recorded;
use crate::output::OutputFile;
use std::path::Path;

/// A run's table as read from a file (CSV, Parquet or a twin `.rrd`): units as written, but
/// times in seconds (a `time [ms]` column is converted on reading).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunData {
    /// The file's path, as given.
    pub source: String,
    /// SHA-256 of the file's bytes, lower-case hex.
    pub digest: String,
    /// Time of each row, s, strictly increasing.
    pub time: Vec<f64>,
    /// Every column but `time` whose cells are all finite numbers, in the file's order; each has
    /// one value per row.
    pub columns: Vec<DataColumn>,
    /// The columns with a cell that is not a finite number: refused by [`RunData::bind`] if the
    /// plant knows them, else left out like any column it does not know.
    pub unread: Vec<UnreadColumn>,
    /// Whether [`RunData::bind`] refuses the columns the plant does not know (`--strict`)
    /// instead of leaving them out.
    pub strict: bool,
}

/// A column with a cell that is not a finite number (or, in Parquet, values that are not
/// numbers), kept apart from the numbers.
#[derive(Debug, Clone, PartialEq)]
pub struct UnreadColumn {
    /// Its name (after the renames).
    pub name: String,
    /// Its unit as written, empty when none is given.
    pub unit: String,
    /// The first row of a cell that is not a number (counted as [`DataError::Row`] counts);
    /// `None` for a whole column of another type.
    pub row: Option<usize>,
    /// What is wrong with that cell or column.
    pub reason: String,
}

/// One column of a [`RunData`].
#[derive(Debug, Clone, PartialEq)]
pub struct DataColumn {
    /// Its name: `effort.<actuator>`, `<signal>` or `true.<signal>` (or anything, until bound).
    pub name: String,
    /// Its unit, as written in its header's brackets or parentheses or in the units row; empty
    /// when none is given (refused by [`RunData::bind`] if the plant knows the column).
    pub unit: String,
    /// One value per row, in `unit`, finite.
    pub values: Vec<f64>,
}

impl RunData {
    /// Reads a run's table from a CSV, Parquet or twin `.rrd` file, by its extension, as
    /// [`RunData::read_with`] does with these `renames` and nothing else asked.
    pub fn read(path: &Path, renames: &[(String, String)]) -> Result<RunData, DataError> {
        let options = ReadOptions {
            renames: renames.to_vec(),
            ..ReadOptions::default()
        };
        Self::read_with(path, &options)
    }

    /// Reads a run's table from a CSV, Parquet or twin `.rrd` file, by its extension; the
    /// `options`' renames apply before anything else looks at the columns. A CSV file may hold
    /// `#` comment lines anywhere, give its units in the header (`name [unit]`, `name (unit)`)
    /// or in a row under it, separate its cells by `,`, `;` or tab (from the header, unless
    /// given) and quote them. Refuses a file of another kind, one that does not parse as its
    /// kind, a duplicate column, a missing `time` or one without a time unit, a time not
    /// strictly increasing or not a finite number, and a row of another width than the header.
    /// A column with another cell that is not a number is kept apart ([`RunData::unread`]).
    ///
    /// A recording gives one row per recorded sample: the series `twin run` marks as the run's
    /// commands and signals, their `f64` values converted back from the plots' display units
    /// (equal to the run's own to within a rounding or two; wrapped angles unwrapped).
    pub fn read_with(path: &Path, options: &ReadOptions) -> Result<RunData, DataError> {
        let file = path.display().to_string();
        let kind = Kind::of(path, &file)?;
        let bytes = read_bounded(path, &file)?;
        let digest = sha256_hex(&bytes);
        let mut table = match kind {
            Kind::Csv => csv_file::parse(&file, &bytes, options.delimiter)?,
            Kind::Parquet => parquet_file::parse(&file, bytes::Bytes::from(bytes))?,
            Kind::Recording => recorded::parse(path, &file, &bytes)?,
        };
        table.rename(&options.renames);
        let mut data = table.into_run_data(&file)?;
        data.digest = digest;
        data.strict = options.strict;
        Ok(data)
    }

    /// Writes the table as CSV: a header row (`time [s]`, then each column's `name [unit]`) and
    /// one row per time, values written with Rust's shortest round-trip form (read back
    /// bit-identical). Atomic: nothing is left at `path` on failure.
    pub fn write_csv(&self, path: &Path) -> Result<(), DataError> {
        let bytes = csv_file::to_bytes(self).map_err(|reason| write_error(path, reason))?;
        commit(path, &bytes)
    }

    /// Writes the table as Parquet: one non-null Float64 column per CSV column, with the same
    /// names. Atomic: nothing is left at `path` on failure.
    pub fn write_parquet(&self, path: &Path) -> Result<(), DataError> {
        let bytes = parquet_file::to_bytes(self).map_err(|reason| write_error(path, reason))?;
        commit(path, &bytes)
    }

    /// The column named `name` (without its unit), if any.
    pub fn column(&self, name: &str) -> Option<&DataColumn> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// A column's header as written: `name [unit]`, or `name` without a unit.
    pub(super) fn header(column: &DataColumn) -> String {
        header(&column.name, &column.unit)
    }
}

/// A column's header as written: `name [unit]`, or `name` without a unit.
pub(super) fn header(name: &str, unit: &str) -> String {
    match unit {
        "" => name.to_owned(),
        unit => format!("{name} [{unit}]"),
    }
}

/// SHA-256 of `bytes`, lower-case hex.
pub(super) fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    format!("{:x}", sha2::Sha256::digest(bytes))
}

fn write_error(path: &Path, reason: String) -> DataError {
    DataError::Write {
        file: path.display().to_string(),
        reason,
    }
}

/// Writes `bytes` as the whole file at `path`, atomically.
fn commit(path: &Path, bytes: &[u8]) -> Result<(), DataError> {
    let output = |e: crate::output::OutputError| write_error(path, e.reason);
    OutputFile::create(path)
        .and_then(|file| file.commit(bytes))
        .map_err(output)
}
