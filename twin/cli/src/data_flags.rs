//! The flags of every command that reads a measured run (`twin compare`, `twin calibrate`,
//! `twin shadow --data`): `--rename`, `--delimiter` and `--strict`, and reading a run with them,
//! the columns the scenario does not know left out with a note on stderr.

use crate::failure::Failure;
use framework::Registry;
use std::collections::BTreeMap;
use std::path::Path;
use twin::data::{left_out_note, parse_renames, Delimiter, PlantColumns, ReadOptions, RunData};
use twin::{ScenarioBuilder, Simulator};

/// How a measured run is read.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DataFlags {
    /// Rename a column of the data before reading it (`OLD=NEW`, names without units, e.g.
    /// `X1=crank.position`).
    #[arg(long = "rename", value_name = "OLD=NEW")]
    pub rename: Vec<String>,
    /// The separator of a CSV file's cells: `,`, `;` or `tab` (with `;` and tab, numbers may
    /// have a decimal comma) [default: the one the header holds].
    #[arg(long, value_name = ",|;|tab")]
    pub delimiter: Option<Delimiter>,
    /// Refuse the columns the scenario does not know instead of leaving them out with a note.
    #[arg(long)]
    pub strict: bool,
}

impl DataFlags {
    /// The reading these flags ask for, with `table`'s renames (a scenario's
    /// `[calibration.rename]`) after the command line's: the first rename of a column wins.
    pub fn options(&self, table: &BTreeMap<String, String>) -> Result<ReadOptions, Failure> {
        let mut renames = self.rename.clone();
        renames.extend(table.iter().map(|(old, new)| format!("{old}={new}")));
        Ok(ReadOptions {
            renames: parse_renames(&renames)?,
            delimiter: self.delimiter,
            strict: self.strict,
        })
    }

    /// Reads the run at `path` with these flags and leaves out the columns `plant` does not
    /// know, with a note on stderr (refused with `--strict`).
    pub fn read(&self, path: &Path, plant: &PlantColumns) -> Result<RunData, Failure> {
        read_run(path, &self.options(&BTreeMap::new())?, plant)
    }
}

/// Reads the run at `path` as `options` ask and leaves out the columns `plant` does not know,
/// with a note on stderr (refused when strict).
pub fn read_run(
    path: &Path,
    options: &ReadOptions,
    plant: &PlantColumns,
) -> Result<RunData, Failure> {
    let mut data = RunData::read_with(path, options)?;
    leave_out_unknown(&mut data, plant)?;
    Ok(data)
}

/// Leaves out the columns of `data` that `plant` does not know, with a note on stderr (refused
/// when `data` was read with `--strict`).
pub fn leave_out_unknown(data: &mut RunData, plant: &PlantColumns) -> Result<(), Failure> {
    let left_out = data.leave_out_unknown(plant)?;
    if let Some(note) = left_out_note(&data.source, &left_out) {
        eprintln!("note: {note}");
    }
    Ok(())
}

/// The columns the scenario of `builder` reads and writes.
pub fn plant_columns(
    builder: &ScenarioBuilder,
    registry: &Registry,
) -> Result<PlantColumns, Failure> {
    let simulator = Simulator::new(builder.clone().build(registry)?)?;
    Ok(PlantColumns::of_simulator(&simulator))
}
