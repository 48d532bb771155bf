//! A run's table bound to a plant: every column the plant knows as its command, measured or
//! true signal, in a unit that fits it (converted to SI), and resampled onto the control
//! period's grid: rows already on it are taken exactly; otherwise measured and true signals are
//! interpolated linearly and commands held (zero-order hold), as the controller held them,
//! except across a gap of rows (dropped, or a logger slower than the control), where they follow
//! a cubic through the rows around the gap. The columns the plant does not know are left out
//! and named, or refused when reading is strict.

use super::error::DataError;
use super::measured::RunData;
use super::plant_columns::PlantColumns;
use super::reading::unread_error;
use super::trace::{DataRate, Trace};
use super::units::{factor, missing, to_si};
use crate::recording::ColumnRole;

/// Most grid points a resampling makes (about 400 MB per column): a period far below the data's
/// own would otherwise ask for more memory than there is.
const MAX_SAMPLES: usize = 50_000_000;
/// Rows closer than this many periods to a grid point are on it.
const ON_GRID: f64 = 1e-9;
/// Rows further apart than this many control periods leave the commands between them to an
/// interpolation.
const COMMAND_GAP: f64 = 1.5;
/// Names listed in a refusal of an unknown column before "… and N more".
const KNOWN_LISTED: usize = 12;

/// Where grid point `k` falls among the rows: row `row`, and `weight` of the way to the next
/// (0 when on the row).
#[derive(Debug, Clone, Copy)]
struct Place {
    row: usize,
    weight: f64,
}

impl RunData {
    /// Binds every column the plant knows (a command `effort.<actuator>`, measured signal
    /// `<signal>` or true signal `true.<signal>`): checks its unit and numbers and converts it
    /// to the plant's SI unit; leaves out the others, named in the trace's `left_out` (refused
    /// when [`RunData::strict`]). Resamples the rows onto `t_k = t_0 + k·period` from the first
    /// time to the last. Refuses fewer than two rows, a non-positive period, and fewer than
    /// `min_samples` grid points.
    pub fn bind(
        &self,
        plant: &PlantColumns,
        period: f64,
        min_samples: usize,
    ) -> Result<Trace, DataError> {
        let format = |reason: String| DataError::Format {
            file: self.source.clone(),
            reason,
        };
        if !(period.is_finite() && period > 0.0) {
            return Err(format(format!(
                "cannot resample onto a control period of {period} s; it must be positive"
            )));
        }
        let left_out = self.unknown_columns(plant)?;
        let rows = self.time.len();
        if rows < 2 || self.columns.iter().any(|c| c.values.len() != rows) {
            return Err(format(format!(
                "{rows} rows of data; at least two are needed, every column as long as `time`"
            )));
        }
        let bound = self.bind_columns(plant)?;
        let (places, resampled) = self.grid(period)?;
        if places.len() < min_samples {
            return Err(format(format!(
                "{} samples at the control period {period} s ({} s of data); {min_samples} are \
                 needed",
                places.len(),
                self.time[rows - 1] - self.time[0]
            )));
        }
        let mut trace = Trace {
            source: self.source.clone(),
            digest: self.digest.clone(),
            period,
            start_time: self.time[0],
            samples: places.len(),
            commands: vec![None; plant.actuators.len()],
            measured: vec![None; plant.signals.len()],
            truth: vec![None; plant.signals.len()],
            rate: self.rate(resampled),
            rows: None,
            logged: vec![None; plant.signals.len()],
            left_out,
        };
        if resampled {
            let first = self.time[0];
            trace.rows = Some(self.time.iter().map(|t| (t - first) / period).collect());
        }
        for (role, index, values) in bound {
            if resampled && role == ColumnRole::Measured {
                trace.logged[index] = Some(values.clone());
            }
            let slot = match role {
                ColumnRole::Command => &mut trace.commands[index],
                ColumnRole::Measured => &mut trace.measured[index],
                ColumnRole::True => &mut trace.truth[index],
            };
            *slot = Some(match (resampled, role) {
                (false, _) => values,
                (true, ColumnRole::Command) => (places.iter())
                    .map(|p| self.command_at(&values, *p, period))
                    .collect(),
                (true, _) => places.iter().map(|p| interpolate(&values, *p)).collect(),
            });
        }
        Ok(trace)
    }

    /// The headers of the columns `plant` does not know, in the file's order but the unread
    /// ones last. Refuses a column it knows whose cells are not all finite numbers, and under
    /// [`RunData::strict`] the first column it does not know.
    pub fn unknown_columns(&self, plant: &PlantColumns) -> Result<Vec<String>, DataError> {
        let mut left_out = Vec::new();
        let readable = (self.columns.iter()).map(|c| (&c.name, &c.unit, None));
        let unread = (self.unread.iter()).map(|c| (&c.name, &c.unit, Some(c)));
        for (name, unit, unread) in readable.chain(unread) {
            let header = super::measured::header(name, unit);
            match (plant.role_of(name), unread) {
                (Some(_), None) => {}
                (Some(_), Some(c)) => {
                    let cell = (c.row, c.reason.clone());
                    return Err(unread_error(&self.source, name, unit, cell));
                }
                (None, _) if self.strict => {
                    return Err(DataError::Column {
                        file: self.source.clone(),
                        column: header,
                        reason: unknown(name, plant),
                    })
                }
                (None, _) => left_out.push(header),
            }
        }
        Ok(left_out)
    }

    /// Leaves out the columns `plant` does not know (refused under [`RunData::strict`]) and
    /// returns their headers, for [`left_out_note`](super::left_out_note); refuses a column it
    /// knows whose cells are not all finite numbers.
    pub fn leave_out_unknown(&mut self, plant: &PlantColumns) -> Result<Vec<String>, DataError> {
        let left_out = self.unknown_columns(plant)?;
        self.columns.retain(|c| plant.role_of(&c.name).is_some());
        self.unread.clear();
        Ok(left_out)
    }

    /// Every known column's role, index and SI values; a column without a unit or with a unit
    /// that does not fit is refused.
    fn bind_columns(
        &self,
        plant: &PlantColumns,
    ) -> Result<Vec<(ColumnRole, usize, Vec<f64>)>, DataError> {
        let mut bound = Vec::with_capacity(self.columns.len());
        for column in &self.columns {
            let Some((role, index)) = plant.role_of(&column.name) else {
                continue;
            };
            let error = |reason: String| DataError::Column {
                file: self.source.clone(),
                column: RunData::header(column),
                reason,
            };
            let si = match role {
                ColumnRole::Command => &plant.actuators[index].1,
                _ => &plant.signals[index].1,
            };
            let factor = match column.unit.as_str() {
                "" => Err(missing(&column.name, si)),
                unit => factor(unit, &column.name, si),
            };
            bound.push((role, index, to_si(&column.values, factor.map_err(error)?)));
        }
        Ok(bound)
    }

    /// The grid's places among the rows, and whether they are off it (resampled). Rows all
    /// within [`ON_GRID`] periods of `t_0 + k·period` are the grid.
    fn grid(&self, period: f64) -> Result<(Vec<Place>, bool), DataError> {
        let time = &self.time;
        let (first, last) = (time[0], time[time.len() - 1]);
        let tolerance = ON_GRID * period;
        let on_grid = (time.iter().enumerate())
            .all(|(k, &t)| (t - (first + k as f64 * period)).abs() <= tolerance);
        if on_grid {
            let places = (0..time.len()).map(|row| Place { row, weight: 0.0 });
            return Ok((places.collect(), false));
        }
        let span = ((last - first) / period + ON_GRID).floor();
        if span >= MAX_SAMPLES as f64 {
            return Err(DataError::Format {
                file: self.source.clone(),
                reason: format!(
                    "{} s of data at the control period {period} s make more than \
                     {MAX_SAMPLES} samples; split the run",
                    last - first
                ),
            });
        }
        let mut places = Vec::with_capacity(span as usize + 1);
        let mut row = 0;
        for k in 0..=span as usize {
            let t = first + k as f64 * period;
            while row + 1 < time.len() && time[row + 1] <= t + tolerance {
                row += 1;
            }
            let weight = match time.get(row + 1) {
                Some(&next) if (t - time[row]).abs() > tolerance => {
                    ((t - time[row]) / (next - time[row])).clamp(0.0, 1.0)
                }
                _ => 0.0,
            };
            places.push(Place { row, weight });
        }
        Ok((places, true))
    }

    /// A command at a grid point: the row's at or before it, held (the controller held it over
    /// its period); across a gap of more than [`COMMAND_GAP`] periods (rows dropped, a logger
    /// slower than the control), on a cubic through the rows around it: the controller updated
    /// it in between by amounts the data do not hold, and a smooth command is followed closely.
    fn command_at(&self, values: &[f64], place: Place, period: f64) -> f64 {
        let gap = match self.time.get(place.row + 1) {
            Some(next) => (next - self.time[place.row]) / period,
            None => 0.0,
        };
        match gap > COMMAND_GAP {
            true => self.cubic(values, place),
            false => values[place.row],
        }
    }

    /// The value at `place` on the cubic through the two rows around it and their neighbours
    /// (Lagrange, at the rows' own times), linear where the data end on either side.
    fn cubic(&self, values: &[f64], place: Place) -> f64 {
        let r = place.row;
        if r == 0 || r + 2 >= values.len() {
            return interpolate(values, place);
        }
        let t = self.time[r] + place.weight * (self.time[r + 1] - self.time[r]);
        let rows = [r - 1, r, r + 1, r + 2];
        let mut sum = 0.0;
        for &i in &rows {
            let mut weight = 1.0;
            for &j in rows.iter().filter(|&&j| j != i) {
                weight *= (t - self.time[j]) / (self.time[i] - self.time[j]);
            }
            sum += weight * values[i];
        }
        sum
    }

    /// The data's own time steps.
    fn rate(&self, resampled: bool) -> DataRate {
        let steps = self.time.windows(2).map(|pair| pair[1] - pair[0]);
        let rows = self.time.len();
        DataRate {
            mean_period: (self.time[rows - 1] - self.time[0]) / (rows - 1) as f64,
            min_period: steps.clone().fold(f64::INFINITY, f64::min),
            max_period: steps.fold(0.0, f64::max),
            resampled,
        }
    }
}

/// The value at `place`, linear between its row and the next.
fn interpolate(values: &[f64], place: Place) -> f64 {
    let here = values[place.row];
    if place.weight == 0.0 {
        return here;
    }
    here + place.weight * (values[place.row + 1] - here)
}

/// The refusal of an unknown column: the names the plant knows, shortened.
fn unknown(name: &str, plant: &PlantColumns) -> String {
    let commands =
        (plant.actuators.iter()).map(|(a, _)| PlantColumns::column_name(ColumnRole::Command, a));
    let signals = plant.signals.iter().map(|(s, _)| s.clone());
    let known: Vec<String> = commands.chain(signals).collect();
    let listed = known.len().min(KNOWN_LISTED);
    let more = match known.len() - listed {
        0 => String::new(),
        n => format!(" and {n} more"),
    };
    format!(
        "unknown signal {name} (known: {}{more}; each signal also as true.<signal>); rename it \
         with --rename {name}=<known>, or read without --strict to leave it out",
        known[..listed].join(", ")
    )
}
