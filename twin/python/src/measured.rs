//! Reading Python arguments for the measured-run entry points (their names in messages), reading
//! a run as they ask (`rename`, `delimiter`, `strict`), and `Scenario.compare`: the run read,
//! replayed on the scenario and returned as its JSON report beside the compared series as NumPy
//! arrays.

use crate::errors::{from_calibration, from_data, CalibrationError as PyCalibrationError};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use twin::calibration::{self, CalibrationError};
use twin::data::{left_out_note, parse_renames, PlantColumns, ReadOptions, RunData};
use twin::{ScenarioBuilder, Simulator};

/// An argument refused, named as the keyword that gave it.
pub fn refuse(argument: &str, reason: impl std::fmt::Display) -> PyErr {
    PyCalibrationError::new_err(format!("{argument}: {reason}"))
}

/// A Python value's type name, for messages.
pub fn kind(value: &Bound<'_, PyAny>) -> String {
    let name = value.get_type().name();
    name.map(|n| n.to_string()).unwrap_or_default()
}

/// `Scenario.compare`: the run in `data` read as `reading` asks and replayed on the scenario of
/// `builder`, with the GIL released while the twin works.
pub fn compare<'py>(
    py: Python<'py>,
    builder: &ScenarioBuilder,
    data: &Path,
    closed_loop: bool,
    reading: &ReadOptions,
) -> PyResult<Bound<'py, PyDict>> {
    let comparison = py.detach(|| {
        let registry = controllers::builtin();
        let plant = plant_columns(builder, &registry)?;
        let (run, notes) = read_run(data, reading, &plant)?;
        let options = calibration::CalibrationOptions {
            closed_loop,
            ..Default::default()
        };
        let comparison = calibration::compare(builder, &registry, &run, &options)?;
        Ok::<_, CalibrationError>((comparison, notes))
    });
    let (comparison, notes) = comparison.map_err(from_calibration)?;
    let dict = PyDict::new(py);
    dict.set_item("notes", notes)?;
    dict.set_item("report", from_json(py, &comparison.to_json().to_string())?)?;
    let samples = comparison.overlays.first().map_or(0, |o| o.measured.len());
    let time = grid(py, comparison.start_time, comparison.period, samples);
    dict.set_item("time", time)?;
    let [units, measured, simulated] = [(); 3].map(|_| PyDict::new(py));
    for overlay in &comparison.overlays {
        let signal = &overlay.signal;
        units.set_item(signal, &overlay.unit)?;
        measured.set_item(signal, PyArray1::from_slice(py, &overlay.measured))?;
        simulated.set_item(signal, PyArray1::from_slice(py, &overlay.simulated))?;
    }
    dict.set_item("measured", measured)?;
    dict.set_item("simulated", simulated)?;
    dict.set_item("units", units)?;
    Ok(dict)
}

/// The control-period grid `start + k·period`, s.
pub fn grid(py: Python<'_>, start: f64, period: f64, samples: usize) -> Bound<'_, PyArray1<f64>> {
    let time = (0..samples).map(|k| start + k as f64 * period).collect();
    PyArray1::from_vec(py, time)
}

/// A JSON report as Python reads JSON.
pub fn from_json<'py>(py: Python<'py>, json: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (json,))
}

/// A dict argument's entries, in its order; None gives none.
pub fn entries<'py>(
    argument: &str,
    value: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    let dict = (value.cast::<PyDict>()).map_err(|_| {
        refuse(
            argument,
            format!("a {} is not a dict; give one", kind(value)),
        )
    })?;
    let entry = |(key, item): (Bound<'py, PyAny>, Bound<'py, PyAny>)| {
        let key = key.extract::<String>();
        let key = key.map_err(|_| refuse(argument, "its keys must be str"))?;
        Ok((key, item))
    };
    dict.iter().map(entry).collect()
}

/// One str, or a sequence of them; None gives none.
pub fn strings(argument: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    if let Ok(text) = value.cast::<PyString>() {
        return Ok(vec![text.to_string()]);
    }
    let wrong = || {
        refuse(
            argument,
            format!("a {} is not a str or a list of str", kind(value)),
        )
    };
    let items = value.try_iter().map_err(|_| wrong())?;
    items
        .map(|item| {
            item.and_then(|i| i.extract::<String>())
                .map_err(|_| wrong())
        })
        .collect()
}

/// One path (str or os.PathLike), or a sequence of them; None gives none.
pub fn paths(argument: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<PathBuf>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    if let Ok(path) = value.extract::<PathBuf>() {
        return Ok(vec![path]);
    }
    let wrong = || {
        refuse(
            argument,
            format!("a {} is not a path or a list of paths", kind(value)),
        )
    };
    let items = value.try_iter().map_err(|_| wrong())?;
    items
        .map(|item| {
            item.and_then(|i| i.extract::<PathBuf>())
                .map_err(|_| wrong())
        })
        .collect()
}

/// The reading asked by `rename` (a dict of old → new column names, before `table`'s renames),
/// `delimiter` (`","`, `";"` or `"tab"`) and `strict`.
pub fn read_options(
    rename: Option<&Bound<'_, PyAny>>,
    table: &BTreeMap<String, String>,
    delimiter: Option<&str>,
    strict: bool,
) -> PyResult<ReadOptions> {
    let entry = |(old, new): (String, Bound<'_, PyAny>)| {
        let new: String = (new.extract())
            .map_err(|_| refuse("rename", format!("{old}: the new name must be a str")))?;
        Ok(format!("{old}={new}"))
    };
    let mut renames: Vec<String> = (entries("rename", rename)?.into_iter())
        .map(entry)
        .collect::<PyResult<_>>()?;
    renames.extend(table.iter().map(|(old, new)| format!("{old}={new}")));
    let delimiter = delimiter.map(str::parse).transpose();
    Ok(ReadOptions {
        renames: parse_renames(&renames).map_err(from_data)?,
        delimiter: delimiter.map_err(|reason: String| refuse("delimiter", reason))?,
        strict,
    })
}

/// The columns the scenario of `builder` reads and writes.
pub fn plant_columns(
    builder: &ScenarioBuilder,
    registry: &framework::Registry,
) -> Result<PlantColumns, CalibrationError> {
    let simulator = Simulator::new(builder.clone().build(registry)?)?;
    Ok(PlantColumns::of_simulator(&simulator))
}

/// The run at `path` read as `reading` asks, the columns `plant` does not know left out (refused
/// when strict), and the note saying which, if any.
pub fn read_run(
    path: &Path,
    reading: &ReadOptions,
    plant: &PlantColumns,
) -> Result<(RunData, Vec<String>), CalibrationError> {
    let mut run = RunData::read_with(path, reading)?;
    let left_out = run.leave_out_unknown(plant)?;
    let notes = left_out_note(&run.source, &left_out).into_iter().collect();
    Ok((run, notes))
}
