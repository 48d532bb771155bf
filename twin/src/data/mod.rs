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
//! Writing ([`RunData::write_csv`], [`RunData::write_parquet`], and a run's own table, `twin::RunTable`) is atomic: a
//! temporary file beside the target, renamed onto it once whole.

mod bind;
pub(crate) mod csv_file;
mod error;
mod file;
mod measured;
mod options;
pub(crate) mod parquet_file;
mod plant_columns;
mod reading;
mod recorded;
mod trace;
pub(crate) mod units;

pub use crate::recording::ColumnRole;
pub use error::DataError;
pub(crate) use file::sha256_hex;
pub use measured::{DataColumn, RunData, UnreadColumn};
pub use options::{parse_renames, Delimiter, ReadOptions};
pub use plant_columns::PlantColumns;
pub use reading::MAX_DATA_BYTES;
pub use trace::{left_out_note, DataRate, Trace};
