//! Measured runs in and out, one format: a table of `time [s]`, the actuators' commands
//! `effort.<actuator> [unit]`, the measured plant signals `<signal> [unit]` and the true ones
//! `true.<signal> [unit]`, one row per control update, as CSV or Parquet (one Float64 column per
//! CSV column, the same names); a twin `.rrd` recording is read as the same table.
//!
//! Reading ([`RunData::read`]) checks the file's shape (a header with a bracketed unit on every
//! column, a `time` column strictly increasing, finite numbers in every cell); binding to a plant
//! ([`RunData::bind`]) checks every column's name and unit against the plant, converts to SI and
//! resamples onto the control period's grid. Each refusal is one line naming the file and the
//! row (counted as a spreadsheet shows the table: the header is row 1) or the column.
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
    /// A column is refused: no bracketed unit, a duplicate, an unknown signal, a unit that does
    /// not fit its signal, a type that is not numbers.
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
    /// A `--map old=new` argument is malformed.
    #[error("--map `{given}`: {reason}")]
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
    /// Every column but `time`, in the file's order; each has one value per row.
    pub columns: Vec<DataColumn>,
}

/// One column of a [`RunData`].
#[derive(Debug, Clone, PartialEq)]
pub struct DataColumn {
    /// Its name: `effort.<actuator>`, `<signal>` or `true.<signal>` (or anything, until bound).
    pub name: String,
    /// Its unit, as written in its header's brackets.
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
    /// Reads a run's table from a CSV, Parquet or twin `.rrd` file, by its extension; `renames`
    /// (`--map old=new`) rename columns (names without their units) before anything else looks
    /// at them. Refuses a file of another kind, one that does not parse as its kind, a column
    /// without a bracketed unit, a duplicate column, a missing `time`, a time not strictly
    /// increasing, a row of another width than the header and an empty, non-numeric or
    /// non-finite cell.
    ///
    /// A recording gives one row per recorded sample: the series `twin run` marks as the run's
    /// commands and signals, their `f64` values converted back from the plots' display units
    /// (equal to the run's own to within a rounding or two; wrapped angles unwrapped).
    pub fn read(path: &Path, renames: &[(String, String)]) -> Result<RunData, DataError> {
        let file = path.display().to_string();
        let kind = Kind::of(path, &file)?;
        let bytes = read_bounded(path, &file)?;
        let digest = sha256_hex(&bytes);
        let mut table = match kind {
            Kind::Csv => csv_file::parse(&file, &bytes)?,
            Kind::Parquet => parquet_file::parse(&file, bytes::Bytes::from(bytes))?,
            Kind::Recording => recorded::parse(path, &file, &bytes)?,
        };
        table.rename(renames);
        let mut data = table.into_run_data(&file)?;
        data.digest = digest;
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

    /// A column's header as written: `name [unit]`.
    fn header(column: &DataColumn) -> String {
        format!("{} [{}]", column.name, column.unit)
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

/// Parses `--map old=new` arguments: each renames the column `old` (its name without the unit)
/// to `new`.
pub fn parse_renames(args: &[String]) -> Result<Vec<(String, String)>, DataError> {
    args.iter()
        .map(|given| {
            let error = |reason: &str| DataError::Rename {
                given: given.clone(),
                reason: reason.to_owned(),
            };
            let (old, new) = given
                .split_once('=')
                .ok_or_else(|| error("give old=new, e.g. --map pos=ram_position"))?;
            let (old, new) = (old.trim(), new.trim());
            if old.is_empty() || new.is_empty() {
                return Err(error("both names are needed: old=new"));
            }
            if new.contains(['[', ']', ',', '"', '\n', '\r']) {
                return Err(error(
                    "the new name may not hold brackets, commas, quotes or line breaks",
                ));
            }
            Ok((old.to_owned(), new.to_owned()))
        })
        .collect()
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
