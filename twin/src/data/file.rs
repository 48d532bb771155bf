//! A measured run's table read from a file by its kind (CSV, Parquet or a twin `.rrd`) and
//! written whole as CSV or Parquet, atomically.

use super::csv_file;
use super::error::DataError;
use super::measured::RunData;
use super::options::ReadOptions;
use super::parquet_file;
use super::reading::{read_bounded, Kind};
use super::recorded;
use crate::output::OutputFile;
use std::path::Path;

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
}

/// SHA-256 of `bytes`, lower-case hex.
pub(crate) fn sha256_hex(bytes: &[u8]) -> String {
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
