//! Reading a data file, the part every kind shares: its kind by extension, its bytes (bounded
//! in size), and the checks of its parsed columns (no duplicate, a `time` column, finite values,
//! times strictly increasing).

use super::units;
use super::{DataColumn, DataError, RunData, MAX_DATA_BYTES};
use std::path::Path;

/// The kinds of data file, by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    Csv,
    Parquet,
    Recording,
}

impl Kind {
    pub(super) fn of(path: &Path, file: &str) -> Result<Self, DataError> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match extension.as_str() {
            "csv" => Ok(Kind::Csv),
            "parquet" => Ok(Kind::Parquet),
            "rrd" => Ok(Kind::Recording),
            other => Err(DataError::Format {
                file: file.to_owned(),
                reason: format!(
                    "not a data file by its extension ({}); give a .csv, .parquet or .rrd file",
                    if other.is_empty() {
                        "none".to_owned()
                    } else {
                        format!("`.{other}`")
                    }
                ),
            }),
        }
    }
}

/// A file's columns as parsed, before the checks every kind shares.
pub(super) struct RawTable {
    /// Per column: its name and its unit, as written (after the renames).
    pub(super) columns: Vec<(String, String)>,
    /// Per column, its values (each column as long as the others).
    pub(super) values: Vec<Vec<f64>>,
    /// Per value, its row as a spreadsheet shows the file (the header is row 1).
    pub(super) rows: Vec<usize>,
}

impl RawTable {
    pub(super) fn rename(&mut self, renames: &[(String, String)]) {
        for (name, _) in &mut self.columns {
            if let Some((_, new)) = renames.iter().find(|(old, _)| old == name) {
                name.clone_from(new);
            }
        }
    }

    /// The table with its `time` column (in s or ms, converted to s) apart; refuses a
    /// duplicate column, a missing `time`, a non-finite value and times not strictly increasing.
    pub(super) fn into_run_data(self, file: &str) -> Result<RunData, DataError> {
        let header = |(name, unit): &(String, String)| format!("{name} [{unit}]");
        for (i, column) in self.columns.iter().enumerate() {
            if self.columns[..i].iter().any(|(name, _)| *name == column.0) {
                return Err(DataError::Column {
                    file: file.to_owned(),
                    column: header(column),
                    reason: format!("a second column named {}", column.0),
                });
            }
        }
        for (column, values) in self.columns.iter().zip(&self.values) {
            if let Some(k) = values.iter().position(|v| !v.is_finite()) {
                return Err(DataError::Cell {
                    file: file.to_owned(),
                    row: self.rows.get(k).copied().unwrap_or(k + 2),
                    column: header(column),
                    reason: format!("{} is not a finite number", values[k]),
                });
            }
        }
        let Some(t) = self.columns.iter().position(|(name, _)| name == "time") else {
            return Err(DataError::Format {
                file: file.to_owned(),
                reason: "no `time [s]` column (give one, or rename yours with --map old=time)"
                    .into(),
            });
        };
        let mut columns = self.columns;
        let mut values = self.values;
        let (_, time_unit) = columns.remove(t);
        let time = values.remove(t);
        let factor =
            units::factor(&time_unit, "time", "s").map_err(|reason| DataError::Column {
                file: file.to_owned(),
                column: format!("time [{time_unit}]"),
                reason,
            })?;
        let time = units::to_si(&time, factor);
        check_increasing(file, &time, &self.rows)?;
        Ok(RunData {
            source: file.to_owned(),
            digest: String::new(),
            time,
            columns: (columns.into_iter().zip(values))
                .map(|((name, unit), values)| DataColumn { name, unit, values })
                .collect(),
        })
    }
}

/// Refuses a time not after the one of the row before, naming both.
fn check_increasing(file: &str, time: &[f64], rows: &[usize]) -> Result<(), DataError> {
    match time.windows(2).position(|pair| pair[1] <= pair[0]) {
        None => Ok(()),
        Some(k) => Err(DataError::Row {
            file: file.to_owned(),
            row: rows.get(k + 1).copied().unwrap_or(k + 3),
            reason: format!(
                "time {} s is not after the row before's {} s; times must increase strictly",
                time[k + 1],
                time[k]
            ),
        }),
    }
}

/// The bytes of a file of at most [`MAX_DATA_BYTES`].
pub(super) fn read_bounded(path: &Path, file: &str) -> Result<Vec<u8>, DataError> {
    use std::io::Read;
    let error = |reason: String| DataError::Read {
        file: file.to_owned(),
        reason,
    };
    let handle = std::fs::File::open(path).map_err(|e| error(e.to_string()))?;
    if handle.metadata().is_ok_and(|m| m.is_dir()) {
        return Err(error("it is a directory".into()));
    }
    let mut bytes = Vec::new();
    handle
        .take(MAX_DATA_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| error(e.to_string()))?;
    if bytes.len() as u64 > MAX_DATA_BYTES {
        return Err(error(format!(
            "larger than {} MiB; split the run",
            MAX_DATA_BYTES >> 20
        )));
    }
    Ok(bytes)
}
