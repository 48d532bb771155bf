//! A run's result for Python: its summary as a dict and every series as NumPy arrays, sampled as
//! the recording samples (`recording.every`), and its table (one row per control update) written
//! as `twin run --csv` and `--parquet` write it.

use crate::errors::from_data;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use twin::data::RunData;
use twin::{Observer, ObserverError, SignalLayout, StepView};

/// The series an observer collects, row by row, at the recording's samples.
#[derive(Default)]
pub struct Series {
    layout: Option<SignalLayout>,
    time: Vec<f64>,
    signals: Vec<f64>,
    measured: Vec<f64>,
    commanded: Vec<f64>,
    applied: Vec<f64>,
    internals: Vec<f64>,
    diagnostics: Vec<f64>,
}

impl Observer for Series {
    fn start(&mut self, layout: &SignalLayout) -> Result<(), ObserverError> {
        self.layout = Some(layout.clone());
        Ok(())
    }

    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.sampled {
            self.time.push(view.time);
            self.signals.extend_from_slice(view.signals);
            self.measured.extend_from_slice(view.measured);
            self.commanded.extend_from_slice(view.commanded);
            self.applied.extend_from_slice(view.applied);
            self.internals.extend_from_slice(view.internals);
            self.diagnostics.extend_from_slice(view.diagnostics);
        }
        Ok(())
    }
}

/// One column of a row-major table per name, as a dict of arrays.
fn columns<'py>(py: Python<'py>, names: &[String], rows: &[f64]) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    let width = names.len();
    for (i, name) in names.iter().enumerate() {
        let column: Vec<f64> = rows.iter().skip(i).step_by(width.max(1)).copied().collect();
        dict.set_item(name, PyArray1::from_vec(py, column))?;
    }
    Ok(dict)
}

fn units<'py>(
    py: Python<'py>,
    names: &[String],
    units: impl Iterator<Item = &'static str>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (name, unit) in names.iter().zip(units) {
        dict.set_item(name, unit)?;
    }
    Ok(dict)
}

/// A finished run: its summary and its series (SI units, sampled every `recording.every` steps
/// and at the last step), and its table of commands, measured and true signals per control
/// update (`to_csv`, `to_parquet`).
#[pyclass(module = "twin._twin", frozen)]
pub struct RunResult {
    /// The summary as `twin run --summary` writes it: `scenario`, `controller`, `status`
    /// (`ok`, `failed`, `interrupted`), `failure`, `metrics`, `steps`, `time_reached`, …
    #[pyo3(get)]
    summary: Py<PyDict>,
    /// The summary's metrics by name (SI unless the name says otherwise).
    #[pyo3(get)]
    metrics: Py<PyDict>,
    /// Why the run stopped early (a divergence or a crash), or None.
    #[pyo3(get)]
    failure: Option<String>,
    /// Simulated time of each sample, s.
    #[pyo3(get)]
    time: Py<PyArray1<f64>>,
    /// The plant's true signals by name.
    #[pyo3(get)]
    signals: Py<PyDict>,
    /// The signals as the controller measured them (through the sensors) by name.
    #[pyo3(get)]
    measured: Py<PyDict>,
    /// The efforts the controller commanded, by actuator (in `command_units`).
    #[pyo3(get)]
    commanded: Py<PyDict>,
    /// The efforts the joints received (clipped to the limits, through the drives), by actuator.
    #[pyo3(get)]
    efforts: Py<PyDict>,
    /// The controller's internal signals by name.
    #[pyo3(get)]
    internals: Py<PyDict>,
    /// The model checks by name: the machine's own figures (the arm's `path_deviation`, the
    /// platform's `path_error`), `loop_gap/<loop>`, `mechanical_energy`.
    #[pyo3(get)]
    diagnostics: Py<PyDict>,
    /// The SI unit of each signal (`m`, `rad/s`, …), by name.
    #[pyo3(get)]
    units: Py<PyDict>,
    /// The SI unit of each actuator's commanded effort (`N`, `N·m`, or `A` where the drive
    /// takes a current).
    #[pyo3(get)]
    command_units: Py<PyDict>,
    /// The SI unit of each actuator's applied effort (`N` or `N·m`).
    #[pyo3(get)]
    effort_units: Py<PyDict>,
    /// The SI unit of each internal signal.
    #[pyo3(get)]
    internal_units: Py<PyDict>,
    /// The SI unit of each model check.
    #[pyo3(get)]
    diagnostic_units: Py<PyDict>,
    /// The recording written, or None.
    #[pyo3(get)]
    recording: Option<PathBuf>,
    /// One row per control update, as `twin run --csv` writes it (not exposed: `to_csv`,
    /// `to_parquet`).
    table: RunData,
}

impl RunResult {
    pub fn new(
        py: Python<'_>,
        summary: &twin::RunSummary,
        series: Series,
        table: RunData,
        recording: Option<PathBuf>,
    ) -> PyResult<Self> {
        let layout = (series.layout).ok_or_else(|| {
            crate::errors::TwinError::new_err("the run ended before its first step")
        })?;
        let specs = &layout.specs;
        // As `twin run --summary` writes it, read as Python reads JSON.
        let json = twin::summary::to_json(summary).to_string();
        let summary_dict =
            (py.import("json")?.call_method1("loads", (json,))?).cast_into::<PyDict>()?;
        let metrics = PyDict::new(py);
        for (name, value) in &summary.metrics {
            metrics.set_item(name, value)?;
        }
        let signal_units = specs.signals.iter().map(|s| s.unit.si_label());
        let command_units = specs.efforts.iter().map(|u| u[0].si_label());
        let effort_units = specs.efforts.iter().map(|u| u[1].si_label());
        let internal_units = specs.internals.iter().map(|s| s.unit.si_label());
        let diagnostic_units = specs.diagnostics.iter().map(|s| s.unit.si_label());
        Ok(Self {
            summary: summary_dict.unbind(),
            metrics: metrics.unbind(),
            failure: summary.failure.as_ref().map(ToString::to_string),
            time: PyArray1::from_vec(py, series.time).unbind(),
            signals: columns(py, &layout.signals, &series.signals)?.unbind(),
            measured: columns(py, &layout.signals, &series.measured)?.unbind(),
            commanded: columns(py, &layout.actuators, &series.commanded)?.unbind(),
            efforts: columns(py, &layout.actuators, &series.applied)?.unbind(),
            internals: columns(py, &layout.internals, &series.internals)?.unbind(),
            diagnostics: columns(py, &layout.diagnostics, &series.diagnostics)?.unbind(),
            units: units(py, &layout.signals, signal_units)?.unbind(),
            command_units: units(py, &layout.actuators, command_units)?.unbind(),
            effort_units: units(py, &layout.actuators, effort_units)?.unbind(),
            internal_units: units(py, &layout.internals, internal_units)?.unbind(),
            diagnostic_units: units(py, &layout.diagnostics, diagnostic_units)?.unbind(),
            recording,
            table,
        })
    }
}

#[pymethods]
impl RunResult {
    /// Whether the run reached its end (no divergence, crash or interruption).
    #[getter]
    fn ok(&self, py: Python<'_>) -> PyResult<bool> {
        let status = self.summary.bind(py).get_item("status")?;
        Ok(status.is_some_and(|s| s.extract::<String>().is_ok_and(|s| s == "ok")))
    }

    /// Writes the run's table to `path` as `twin run --csv` does: `time [s]`, each actuator's
    /// commanded effort `effort.<actuator> [unit]`, each signal as measured `<signal> [unit]`
    /// and as true `true.<signal> [unit]`, SI, one row per control update; the file is written
    /// whole or not at all. `Scenario.compare` and `twin.calibrate` read it back.
    fn to_csv(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.table.write_csv(&path)).map_err(from_data)
    }

    /// Writes the run's table to `path` as `twin run --parquet` does: the columns of `to_csv`,
    /// one Float64 column each, with the same names.
    fn to_parquet(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.table.write_parquet(&path))
            .map_err(from_data)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let summary = self.summary.bind(py);
        let field = |key: &str| -> PyResult<String> {
            Ok(match summary.get_item(key)? {
                Some(value) => value.str()?.to_string(),
                None => String::new(),
            })
        };
        Ok(format!(
            "RunResult(scenario='{}', controller='{}', status='{}', samples={})",
            field("scenario")?,
            field("controller")?,
            field("status")?,
            self.time.bind(py).len()?
        ))
    }
}
