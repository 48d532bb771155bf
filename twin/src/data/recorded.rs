//! A twin `.rrd` recording read as a run's table: the series the recording marks as the run's
//! commands, measurements and true signals ([`crate::recording::read_signals`]), named as a
//! data file names them, in SI units, one row per recorded sample.
//!
//! A signal without a sensor or sensor fault is recorded once, for its true value, and read as
//! both its `true.<signal>` and its `<signal>` column: at each control update the controller
//! reads the true value. A signal whose sensor fault stands alone (no `[sensors]` entry) has no
//! measured series in the recording, so only its `true.<signal>` column.

use std::path::Path;

use super::error::DataError;
use super::plant_columns::PlantColumns;
use super::reading::RawTable;
use crate::recording::ColumnRole;
use crate::recording::{read_signals, RecordingError};

/// The run's columns in the recording `path` (named `file` in errors), from its `bytes`:
/// commands first, then the measured signals, then the true ones.
pub(super) fn parse(path: &Path, file: &str, bytes: &[u8]) -> Result<RawTable, DataError> {
    let signals = read_signals(path, bytes).map_err(|error| DataError::Format {
        file: file.to_owned(),
        reason: match error {
            RecordingError::Read { reason, .. } => {
                let reason = reason.split_whitespace().collect::<Vec<_>>().join(" ");
                format!("not a twin run's recording: {reason}")
            }
            other => other.to_string(),
        },
    })?;
    let mut columns = vec![("time".to_owned(), "s".to_owned())];
    let mut values = vec![signals.time.clone()];
    for role in [ColumnRole::Command, ColumnRole::Measured, ColumnRole::True] {
        for series in signals.series.iter().filter(|s| s.roles.contains(&role)) {
            columns.push((
                PlantColumns::column_name(role, &series.name),
                series.unit.clone(),
            ));
            values.push(series.values.clone());
        }
    }
    let rows = (0..signals.time.len()).map(|k| k + 2).collect();
    Ok(RawTable {
        unread: vec![None; columns.len()],
        columns,
        values,
        rows,
    })
}
