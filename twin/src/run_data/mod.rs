//! Measured runs in and out, one format: a table of `time [s]`, the actuators' commands
//! `effort.<actuator> [unit]`, the measured plant signals `<signal> [unit]` and the true ones
//! `true.<signal> [unit]`, one row per control update, as CSV or Parquet (one Float64 column per
//! CSV column, the same names); a twin `.rrd` recording is read as the same table.
//!
//! A machine's logger writes the same table in its own way, and reading takes it as it comes:
//! `#` comment lines, a units row under the header or units in brackets or parentheses
//! (`name [unit]`, `name (unit)`), `,`, `;` or tab separators (a decimal comma with the last two)
//! and quoted cells ([`ReadOptions`]).
//!
//! Reading ([`RunData::read_with`]) checks the file's shape (a `time` column in a time unit,
//! strictly increasing; as many cells in every row as in the header); binding to a plant
//! ([`RunData::bind`]) checks every column the plant knows (its unit, finite numbers in every
//! cell), converts to SI and resamples onto the control period's grid. The columns the plant does
//! not know are left out, with a note ([`left_out_note`]), or refused when reading is strict.
//! Each refusal is one line naming the file and the row (counted as a spreadsheet shows the
//! file: its first line is row 1) or the column, and what to change.
//! Writing ([`RunData::write_csv`], [`RunData::write_parquet`], [`RunTable`]) is atomic: a
//! temporary file beside the target, renamed onto it once whole.

mod bind;
mod csv_file;
mod parquet_file;
mod reading;
mod recorded;
mod table;
mod units;

pub use crate::recording::ColumnRole;
pub use table::RunTable;

use crate::output::OutputFile;
use crate::run::{SignalLayout, Simulator};
use reading::{read_bounded, Kind, RawTable};
use std::path::Path;
use thiserror::Error;

/// Largest data file read, bytes (1 GiB): far above an hour of a machine's signals at 1 kHz in
/// Parquet, and it keeps a mistaken device or huge path from eating the memory.
pub const MAX_DATA_BYTES: u64 = 1 << 30;

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

/// How a data file is read: its columns renamed, the CSV separator, and whether the columns the
/// plant does not know are refused.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Column renames, old → new (names without their units), applied before anything else
    /// looks at the columns (`--rename old=new`, [`parse_renames`]).
    pub renames: Vec<(String, String)>,
    /// The CSV separator; `None`: the one the header holds most of (`,` when it holds none).
    pub delimiter: Option<Delimiter>,
    /// Refuse the columns the plant does not know instead of leaving them out with a note.
    pub strict: bool,
}

/// The separator of a CSV file's cells (`--delimiter`). With `;` or tab, a number may have a
/// decimal comma (`0,25`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delimiter {
    /// `,`
    Comma,
    /// `;`
    Semicolon,
    /// A tab.
    Tab,
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

/// What one scenario's twin reads and writes: its actuators and plant signals with their SI
/// units, from a [`Simulator`] or a run's [`SignalLayout`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlantColumns {
    /// Per actuator: its joint and its command's SI unit (`N`, `N·m`, or `A` for a drive that
    /// takes a current).
    pub actuators: Vec<(String, String)>,
    /// Per plant signal: its name and SI unit.
    pub signals: Vec<(String, String)>,
}

/// A run bound to a plant and resampled onto the control period's grid
/// `t_k = start_time + k·period`, `k = 0 … samples − 1`. Each list follows the
/// [`PlantColumns`]' order, `None` where the data have no such column.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// The data file, as given.
    pub source: String,
    /// SHA-256 of the data file's bytes, lower-case hex.
    pub digest: String,
    /// The control period, s.
    pub period: f64,
    /// The data's first time, s.
    pub start_time: f64,
    /// Grid points.
    pub samples: usize,
    /// Per actuator: the commands, SI, held from each sample to the next (zero-order hold).
    pub commands: Vec<Option<Vec<f64>>>,
    /// Per plant signal: the measured values, SI (linear interpolation between the data's rows).
    pub measured: Vec<Option<Vec<f64>>>,
    /// Per plant signal: the true values (`true.<signal>` columns), SI, interpolated alike.
    pub truth: Vec<Option<Vec<f64>>>,
    /// How the data were sampled.
    pub rate: DataRate,
    /// The headers of the data's columns the plant does not know, left out (see
    /// [`left_out_note`]).
    pub left_out: Vec<String>,
    /// Where the data's own rows fall on the grid, in samples from the first (row r is at
    /// `start_time + rows[r]·period`); `None` when the rows are the grid's samples. A fit
    /// compares the twin with the data at these instants only, not at interpolated ones.
    pub rows: Option<Vec<f64>>,
    /// Per plant signal, the measured values at the data's own rows, SI, when they are not the
    /// grid's samples (`rows` is `Some`).
    pub logged: Vec<Option<Vec<f64>>>,
}

impl Trace {
    /// A measured signal as logged: the rows' places on the grid (in samples) and the values
    /// there; on-grid data give every sample.
    pub fn observed(&self, signal: usize) -> Option<(std::borrow::Cow<'_, [f64]>, &[f64])> {
        match &self.rows {
            None => {
                let values = self.measured[signal].as_deref()?;
                let places = (0..values.len()).map(|k| k as f64).collect();
                Some((std::borrow::Cow::Owned(places), values))
            }
            Some(rows) => Some((
                std::borrow::Cow::Borrowed(rows.as_slice()),
                self.logged[signal].as_deref()?,
            )),
        }
    }
}

/// How a run's data were sampled: their own time steps, and whether they were resampled onto
/// the control period's grid.
#[derive(Debug, Clone, PartialEq)]
pub struct DataRate {
    /// Mean time between rows, s.
    pub mean_period: f64,
    /// Shortest time between rows, s.
    pub min_period: f64,
    /// Longest time between rows, s.
    pub max_period: f64,
    /// Whether the rows were off the grid and were interpolated (or held) onto it; `false`: the
    /// rows are the grid's samples, taken exactly.
    pub resampled: bool,
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
    fn header(column: &DataColumn) -> String {
        header(&column.name, &column.unit)
    }
}

impl PlantColumns {
    /// What `simulator`'s plant reads and writes.
    pub fn of_simulator(simulator: &Simulator) -> Self {
        let actuators = simulator.actuators().iter().map(|a| a.joint.clone());
        Self {
            actuators: actuators
                .zip(simulator.command_units())
                .map(|(joint, unit)| (joint, unit.to_owned()))
                .collect(),
            signals: simulator
                .signal_specs()
                .iter()
                .map(|s| (s.name.clone(), s.unit.si_label().to_owned()))
                .collect(),
        }
    }

    /// What a run of `layout` reads and writes.
    pub fn of_layout(layout: &SignalLayout) -> Self {
        let efforts = layout.specs.efforts.iter();
        Self {
            actuators: (layout.actuators.iter().zip(efforts))
                .map(|(joint, [commanded, _])| (joint.clone(), commanded.si_label().to_owned()))
                .collect(),
            signals: (layout.signals.iter().zip(&layout.specs.signals))
                .map(|(name, spec)| (name.clone(), spec.unit.si_label().to_owned()))
                .collect(),
        }
    }

    /// What the column `name` is to this plant: its role and its index among the actuators
    /// (a command) or the signals (a measured or true signal); `None` for a name it lacks.
    pub fn role_of(&self, name: &str) -> Option<(ColumnRole, usize)> {
        let signal = |name: &str| self.signals.iter().position(|(s, _)| s == name);
        if let Some(k) = signal(name) {
            return Some((ColumnRole::Measured, k));
        }
        if let Some(joint) = name.strip_prefix("effort.") {
            let actuator = self.actuators.iter().position(|(a, _)| a == joint);
            if let Some(a) = actuator {
                return Some((ColumnRole::Command, a));
            }
        }
        let k = signal(name.strip_prefix("true.")?)?;
        Some((ColumnRole::True, k))
    }

    /// Binds a column given by name and unit (a live machine's mapped node): its role, its
    /// index among the actuators or signals and the factor that takes its values to SI; the
    /// refusal says which names or units fit.
    pub fn bind_column(&self, name: &str, unit: &str) -> Result<(ColumnRole, usize, f64), String> {
        let (role, index) = self.role_of(name).ok_or_else(|| {
            let signals = self.signals.iter().map(|(s, _)| s.as_str());
            let efforts = self.actuators.iter().map(|(a, _)| format!("effort.{a}"));
            let known: Vec<String> = efforts.chain(signals.map(str::to_owned)).collect();
            format!(
                "`{name}` is not a column of this plant (known: {})",
                known.join(", ")
            )
        })?;
        let si = match role {
            ColumnRole::Command => &self.actuators[index].1,
            ColumnRole::Measured | ColumnRole::True => &self.signals[index].1,
        };
        let factor = units::factor(unit, name, si)?;
        Ok((role, index, factor))
    }

    /// The column name of the actuator or signal `name` in `role`: `effort.<actuator>`,
    /// `<signal>` or `true.<signal>`.
    pub fn column_name(role: ColumnRole, name: &str) -> String {
        match role {
            ColumnRole::Command => format!("effort.{name}"),
            ColumnRole::Measured => name.to_owned(),
            ColumnRole::True => format!("true.{name}"),
        }
    }
}

/// Parses `--rename old=new` arguments: each renames the column `old` (its name without the
/// unit) to `new`.
pub fn parse_renames(args: &[String]) -> Result<Vec<(String, String)>, DataError> {
    args.iter()
        .map(|given| {
            let error = |reason: &str| DataError::Rename {
                given: given.clone(),
                reason: reason.to_owned(),
            };
            let (old, new) = given
                .split_once('=')
                .ok_or_else(|| error("give old=new, e.g. --rename pos=ram_position"))?;
            let (old, new) = (old.trim(), new.trim());
            if old.is_empty() || new.is_empty() {
                return Err(error("both names are needed: old=new"));
            }
            if new.contains(['[', ']', ',', ';', '\t', '"', '\n', '\r']) {
                return Err(error(
                    "the new name may not hold brackets, separators, quotes or line breaks",
                ));
            }
            Ok((old.to_owned(), new.to_owned()))
        })
        .collect()
}

/// The one-line note of the columns of `source` a binding left out (a [`Trace`]'s
/// `left_out`, or what [`RunData::leave_out_unknown`] returns); `None` when there are none.
pub fn left_out_note(source: &str, left_out: &[String]) -> Option<String> {
    const LISTED: usize = 12;
    let listed = left_out.len().min(LISTED);
    let more = match left_out.len() - listed {
        0 => String::new(),
        n => format!(" and {n} more"),
    };
    let (count, them) = match left_out.len() {
        0 => return None,
        1 => ("1 column".to_owned(), "it"),
        n => (format!("{n} columns"), "them"),
    };
    Some(format!(
        "{source}: left out {count} the scenario does not know: {}{more} (--strict refuses {them})",
        left_out[..listed].join(", ")
    ))
}

impl std::str::FromStr for Delimiter {
    type Err = String;

    /// `,`, `;` or `tab` (also `comma`, `semicolon` and a tab character).
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "," | "comma" => Ok(Delimiter::Comma),
            ";" | "semicolon" => Ok(Delimiter::Semicolon),
            "tab" | "\t" => Ok(Delimiter::Tab),
            other => Err(format!(
                "`{other}` is not a separator; give `,`, `;` or `tab`"
            )),
        }
    }
}

impl Delimiter {
    /// The character that separates cells.
    pub fn separator(self) -> char {
        match self {
            Delimiter::Comma => ',',
            Delimiter::Semicolon => ';',
            Delimiter::Tab => '\t',
        }
    }

    /// How a message and `--delimiter` name it: `,`, `;` or `tab`.
    pub fn name(self) -> &'static str {
        match self {
            Delimiter::Comma => ",",
            Delimiter::Semicolon => ";",
            Delimiter::Tab => "tab",
        }
    }
}

/// A column's header as written: `name [unit]`, or `name` without a unit.
fn header(name: &str, unit: &str) -> String {
    match unit {
        "" => name.to_owned(),
        unit => format!("{name} [{unit}]"),
    }
}

/// SHA-256 of `bytes`, lower-case hex.
fn sha256_hex(bytes: &[u8]) -> String {
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

#[cfg(test)]
mod refusal_tests;
#[cfg(test)]
mod tests;
