//! Reading a data file, the part every kind shares: its kind by extension, its bytes (bounded
//! in size), and the checks of its parsed columns (no duplicate, a `time` column in a time unit,
//! its values finite and strictly increasing; another column with a value that is not a finite
//! number kept apart, unread).

use super::error::DataError;
use super::measured::header;
use super::measured::{DataColumn, RunData, UnreadColumn};
use super::units;
use std::path::Path;

/// Largest data file read, bytes (1 GiB): far above an hour of a machine's signals at 1 kHz in
/// Parquet, and it keeps a mistaken device or huge path from eating the memory.
pub const MAX_DATA_BYTES: u64 = 1 << 30;

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
    /// Per column: its name and its unit as written, empty when none is given (after the
    /// renames).
    pub(super) columns: Vec<(String, String)>,
    /// Per column, its values (each column as long as the others; NaN where a cell is not a
    /// number).
    pub(super) values: Vec<Vec<f64>>,
    /// Per column, its first cell that is not a number, if any: its row (`None`: the whole
    /// column) and what is wrong with it.
    pub(super) unread: Vec<Option<(Option<usize>, String)>>,
    /// Per value, its row as a spreadsheet shows the file (its first line is row 1).
    pub(super) rows: Vec<usize>,
}

impl RawTable {
    /// A table of these columns (name, unit), without rows yet.
    pub(super) fn new(columns: Vec<(String, String)>) -> Self {
        let width = columns.len();
        Self {
            columns,
            values: vec![Vec::new(); width],
            unread: vec![None; width],
            rows: Vec::new(),
        }
    }

    pub(super) fn rename(&mut self, renames: &[(String, String)]) {
        for (name, _) in &mut self.columns {
            if let Some((_, new)) = renames.iter().find(|(old, _)| old == name) {
                name.clone_from(new);
            }
        }
    }

    /// The table with its `time` column (in s or ms, converted to s) apart and the columns
    /// with a cell that is not a finite number kept unread; refuses a duplicate column, a
    /// missing `time`, one without a time unit or with a cell that is not a finite number, and
    /// times not strictly increasing.
    pub(super) fn into_run_data(mut self, file: &str) -> Result<RunData, DataError> {
        for (i, (name, unit)) in self.columns.iter().enumerate() {
            if self.columns[..i].iter().any(|(other, _)| other == name) {
                return Err(DataError::Column {
                    file: file.to_owned(),
                    column: header(name, unit),
                    reason: format!("a second column named {name}"),
                });
            }
        }
        self.mark_non_finite();
        let Some(t) = self.columns.iter().position(|(name, _)| name == "time") else {
            return Err(DataError::Format {
                file: file.to_owned(),
                reason: "no `time [s]` column (give one, or rename yours with --rename old=time)"
                    .into(),
            });
        };
        let (_, time_unit) = self.columns.remove(t);
        let time = self.values.remove(t);
        if let Some(unread) = self.unread.remove(t) {
            return Err(unread_error(file, "time", &time_unit, unread));
        }
        let column_error = |reason: String| DataError::Column {
            file: file.to_owned(),
            column: header("time", &time_unit),
            reason,
        };
        let factor = match time_unit.as_str() {
            "" => Err(units::missing("time", "s")),
            unit => units::factor(unit, "time", "s"),
        };
        let time = units::to_si(&time, factor.map_err(column_error)?);
        check_increasing(file, &time, &self.rows)?;
        let mut data = RunData {
            source: file.to_owned(),
            time,
            ..RunData::default()
        };
        let columns = self.columns.into_iter().zip(self.values).zip(self.unread);
        for (((name, unit), values), unread) in columns {
            match unread {
                None => data.columns.push(DataColumn { name, unit, values }),
                Some((row, reason)) => data.unread.push(UnreadColumn {
                    name,
                    unit,
                    row,
                    reason,
                }),
            }
        }
        Ok(data)
    }

    /// Marks each column's first value that is not finite (a NaN or an infinity written in a
    /// cell), unless a cell of it is already marked (its values there are NaN).
    fn mark_non_finite(&mut self) {
        for (values, unread) in self.values.iter().zip(&mut self.unread) {
            let Some(k) = values.iter().position(|v| !v.is_finite()) else {
                continue;
            };
            let row = self.rows.get(k).copied().unwrap_or(k + 2);
            unread.get_or_insert((Some(row), format!("{} is not a finite number", values[k])));
        }
    }
}

/// The refusal of a column with a cell that is not a number (or of values that are not
/// numbers).
pub(super) fn unread_error(
    file: &str,
    name: &str,
    unit: &str,
    (row, reason): (Option<usize>, String),
) -> DataError {
    let (file, column) = (file.to_owned(), header(name, unit));
    match row {
        Some(row) => DataError::Cell {
            file,
            row,
            column,
            reason,
        },
        None => DataError::Column {
            file,
            column,
            reason,
        },
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
    // Only a regular file is opened: a FIFO or a device would block the open or never end.
    let metadata = std::fs::metadata(path).map_err(|e| error(e.to_string()))?;
    if metadata.is_dir() {
        return Err(error("it is a directory".into()));
    }
    if !metadata.is_file() {
        return Err(error(
            "it is not a regular file (a FIFO, a socket or a device); give a file".into(),
        ));
    }
    let handle = std::fs::File::open(path).map_err(|e| error(e.to_string()))?;
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
