//! [`RunTable`]: a run collected as a data file, one row per control update, written when the
//! run ends (also after a divergence or an interruption).

use std::path::PathBuf;

use super::layout::SignalLayout;
use super::observer::{Findings, Observer, ObserverError, StepView};
use super::simulator::Simulator;
use crate::data::csv_file;
use crate::data::parquet_file;
use crate::data::sha256_hex;
use crate::data::{ColumnRole, DataColumn, DataError, PlantColumns, RunData};
use crate::output::OutputFile;

/// A table's bytes in one of the file formats.
type ToBytes = fn(&RunData) -> Result<Vec<u8>, String>;

/// Collects a run into a [`RunData`] and writes it as CSV and/or Parquet when the run finishes
/// (also after a divergence or an interruption: the rows up to there). Row k is the k-th control
/// update: its time `t_k`; the efforts the controller commanded then (SI, before the limits),
/// held over `[t_k, t_k + period)`; what the controller read then (`<signal>`); and the plant's
/// true signals at `t_k` (`true.<signal>`).
///
/// The files are created (as temporaries beside their paths) when the run starts, so that an
/// unwritable path stops it before its first step, and are renamed into place whole at its end;
/// a run that fails otherwise leaves nothing.
#[derive(Debug)]
pub struct RunTable {
    csv: Option<PathBuf>,
    parquet: Option<PathBuf>,
    /// The files being written, created at the run's start: CSV, Parquet.
    files: [Option<OutputFile>; 2],
    data: RunData,
    actuators: usize,
    signals: usize,
}

impl RunTable {
    /// A table written to `csv` and/or `parquet` at the run's end (to neither: kept in memory
    /// only, see [`RunTable::data`]).
    pub fn new(csv: Option<PathBuf>, parquet: Option<PathBuf>) -> Self {
        let source = csv.as_ref().or(parquet.as_ref());
        Self {
            data: RunData {
                source: source.map_or_else(|| "run".to_owned(), |p| p.display().to_string()),
                ..RunData::default()
            },
            csv,
            parquet,
            files: [None, None],
            actuators: 0,
            signals: 0,
        }
    }

    /// The rows collected so far; once the run has finished, `digest` is that of the first file
    /// written (CSV, else Parquet).
    pub fn data(&self) -> &RunData {
        &self.data
    }

    /// Writes the files created at the start, each whole or not at all.
    fn write(&mut self) -> Result<(), DataError> {
        let [csv, parquet] = std::mem::take(&mut self.files);
        let mut digest = None;
        let outputs: [(Option<OutputFile>, ToBytes); 2] =
            [(csv, csv_file::to_bytes), (parquet, parquet_file::to_bytes)];
        for (file, to_bytes) in outputs {
            let Some(file) = file else { continue };
            let path = file.path().display().to_string();
            let error = |reason: String| DataError::Write {
                file: path.clone(),
                reason,
            };
            let bytes = to_bytes(&self.data).map_err(error)?;
            digest.get_or_insert_with(|| sha256_hex(&bytes));
            file.commit(&bytes).map_err(|e| error(e.reason))?;
        }
        if let Some(digest) = digest {
            self.data.digest = digest;
        }
        Ok(())
    }
}

impl Observer for RunTable {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        let plant = PlantColumns::of_layout(layout);
        let column = |role: ColumnRole, (name, unit): &(String, String)| DataColumn {
            name: PlantColumns::column_name(role, name),
            unit: unit.clone(),
            values: Vec::new(),
        };
        let commands = (plant.actuators.iter()).map(|a| column(ColumnRole::Command, a));
        let measured = (plant.signals.iter()).map(|s| column(ColumnRole::Measured, s));
        let truth = (plant.signals.iter()).map(|s| column(ColumnRole::True, s));
        self.data.columns = commands.chain(measured).chain(truth).collect();
        self.data.time.clear();
        (self.actuators, self.signals) = (plant.actuators.len(), plant.signals.len());
        let create = |path: &Option<PathBuf>| {
            path.as_deref()
                .map(OutputFile::create)
                .transpose()
                .map_err(|e| DataError::Write {
                    file: e.path.display().to_string(),
                    reason: e.reason,
                })
        };
        self.files = [create(&self.csv)?, create(&self.parquet)?];
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if !view.control_update {
            return Ok(());
        }
        self.data.time.push(view.time);
        let (commands, rest) = self.data.columns.split_at_mut(self.actuators);
        let (measured, truth) = rest.split_at_mut(self.signals);
        let rows = [
            (commands, view.commanded),
            (measured, view.measured),
            (truth, view.signals),
        ];
        for (columns, values) in rows {
            for (k, column) in columns.iter_mut().enumerate() {
                column
                    .values
                    .push(values.get(k).copied().unwrap_or(f64::NAN));
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<Findings, ObserverError> {
        self.write()?;
        Ok(Findings::default())
    }
}

/// The columns a run reads and writes, from the run's side.
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
}
