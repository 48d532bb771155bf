//! A run bound to a plant and resampled onto the control period's grid, how its data were
//! sampled, and the note of the columns the binding left out.

/// A run bound to a plant and resampled onto the control period's grid
/// `t_k = start_time + k·period`, `k = 0 … samples − 1`. Each list follows the
/// [`PlantColumns`](super::PlantColumns)' order, `None` where the data have no such column.
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

/// The one-line note of the columns of `source` a binding left out (a [`Trace`]'s
/// `left_out`, or what [`RunData::leave_out_unknown`](super::RunData::leave_out_unknown) returns); `None` when there are none.
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
