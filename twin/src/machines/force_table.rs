//! A force on a point given as a table in time (`[points.<name>] force_table = "push.csv"`): a
//! run-data file (CSV or Parquet, as `twin calibrate` reads measured runs) with the columns
//! `time [s]`, `fx [N]` and `fy [N]` (any force unit the twin knows, converted to N once, here),
//! world frame. Between rows the force is interpolated linearly; before the first row it is the
//! first row's, after the last the last row's. The file is read when the scenario is loaded,
//! named relative to the scenario's folder.

use crate::data::units::factor;
use crate::data::RunData;
use std::path::Path;

/// A force in time: rows of (t, fx, fy), t rising, SI units.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ForceTable(Vec<[f64; 3]>);

impl ForceTable {
    /// Reads `file` (relative to `folder`, if any); the error names the file and the column.
    pub fn read(file: &str, folder: Option<&Path>) -> Result<Self, String> {
        let path = folder.map_or_else(|| Path::new(file).to_path_buf(), |f| f.join(file));
        let data = RunData::read(&path, &[]).map_err(|e| e.to_string())?;
        let source = &data.source;
        let mut axes = Vec::with_capacity(2);
        for name in ["fx", "fy"] {
            if let Some(bad) = data.unread.iter().find(|c| c.name == name) {
                let row = bad.row.map_or(String::new(), |row| format!("row {row}, "));
                return Err(format!("{source}: {row}column \"{name}\": {}", bad.reason));
            }
            let column = (data.column(name).filter(|c| !c.unit.is_empty())).ok_or_else(|| {
                format!("{source}: no column \"{name} [N]\" (with its unit); a force table has `time`, `fx` and `fy`")
            })?;
            let factor = factor(&column.unit, name, "N")
                .map_err(|reason| format!("{source}: column \"{name}\": {reason}"))?;
            axes.push(
                column
                    .values
                    .iter()
                    .map(|v| v * factor)
                    .collect::<Vec<f64>>(),
            );
        }
        if data.time.is_empty() {
            return Err(format!(
                "{source}: no rows; a force table needs at least one"
            ));
        }
        let rows = (data.time.iter().enumerate())
            .map(|(k, &t)| [t, axes[0][k], axes[1][k]])
            .collect();
        Ok(Self(rows))
    }

    /// The force at `time`, N.
    pub fn at(&self, time: f64) -> [f64; 2] {
        let rows = &self.0;
        let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
            return [0.0; 2];
        };
        if time <= first[0] {
            return [first[1], first[2]];
        }
        if time >= last[0] {
            return [last[1], last[2]];
        }
        let next = rows.partition_point(|row| row[0] <= time);
        let (a, b) = (rows[next - 1], rows[next]);
        let span = b[0] - a[0];
        let w = if span > 0.0 {
            (time - a[0]) / span
        } else {
            1.0
        };
        [a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_force_is_interpolated_between_rows_and_held_beyond_them() {
        let table = ForceTable(vec![[0.0, 0.0, 10.0], [1.0, 2.0, 0.0], [3.0, 4.0, 0.0]]);
        assert_eq!(table.at(-1.0), [0.0, 10.0]);
        assert_eq!(table.at(0.5), [1.0, 5.0]);
        assert_eq!(table.at(2.0), [3.0, 0.0]);
        assert_eq!(table.at(9.0), [4.0, 0.0]);
    }
}
