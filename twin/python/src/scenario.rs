//! `Scenario`: a built-in or file scenario with changes, checked at each change, run whole,
//! handed out as a simulator or compared with a measured run.

use crate::controller::PythonController;
use crate::errors::{from_scenario, from_twin, ScenarioError, TwinError};
use crate::measured;
use crate::result::{RunResult, Series};
use crate::simulator::Simulator;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use twin::RunTable;
use twin::{LoadedScenario, Observer, ObserverError, ScenarioBuilder, StepView};

/// A scenario: a built-in name (see `twin.scenarios()`) or a scenario TOML file, with changes.
///
/// Each change returns a new `Scenario` (the old one is kept) and is checked at once, with the
/// same checks and messages as `twin run --set`: a bad key or value raises `ScenarioError`
/// naming it.
#[pyclass(module = "twin._twin", frozen)]
#[derive(Clone)]
pub struct Scenario {
    builder: ScenarioBuilder,
    /// The scenario as the changes so far make it (checked).
    scenario: twin::Scenario,
    /// The folder of the scenario's file (its `[calibration]` paths are relative to it), or
    /// None for a built-in scenario.
    folder: Option<PathBuf>,
}

impl Scenario {
    /// The builder's scenario checked whole, as `twin run` checks it before a run: the
    /// scenario, the controller's parameters, then the machine's `[process]`, the sensors, the
    /// metrics and the faults against the plant (a twin is bound and dropped, about 1 ms).
    pub fn checked(builder: ScenarioBuilder, folder: Option<PathBuf>) -> PyResult<Self> {
        let loaded = builder.clone().build(&controllers::builtin());
        let loaded = loaded.map_err(from_scenario)?;
        let scenario = loaded.scenario.clone();
        twin::Twin::new(loaded).map_err(from_twin)?;
        Ok(Self {
            builder,
            scenario,
            folder,
        })
    }

    /// This scenario's builder changed by `change`, checked, in the same folder.
    fn changed(
        &self,
        change: impl FnOnce(ScenarioBuilder) -> Result<ScenarioBuilder, twin::ScenarioError>,
    ) -> PyResult<Self> {
        let builder = change(self.builder.clone()).map_err(from_scenario)?;
        Self::checked(builder, self.folder.clone())
    }

    /// The scenario as the engine library puts it together.
    pub fn builder(&self) -> &ScenarioBuilder {
        &self.builder
    }

    /// The folder of the scenario's file, if it came from one.
    pub fn folder(&self) -> Option<&Path> {
        self.folder.as_deref()
    }

    /// The scenario with its controller, ready to be bound into a twin.
    pub fn load(&self) -> PyResult<LoadedScenario> {
        let built = self.builder.clone().build(&controllers::builtin());
        built.map_err(from_scenario)
    }
}

#[pymethods]
impl Scenario {
    /// Opens a built-in scenario by name or a scenario TOML file by path.
    #[new]
    pub fn new(name_or_path: PathBuf) -> PyResult<Self> {
        let name = name_or_path.to_string_lossy();
        let builder = twin::Scenario::open(&name).map_err(from_scenario)?;
        // As `twin calibrate` finds a scenario file's `[calibration]` runs.
        let folder = match name_or_path.parent() {
            Some(parent) if name_or_path.is_file() => Some(parent.to_path_buf()),
            _ => None,
        };
        Self::checked(builder, folder)
    }

    /// This scenario with the dotted `key` set to `value` (bool, int, float, str, or a list or
    /// dict of them), e.g. `set("controller.params.crank_speed", -6.0)`.
    fn set(&self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<Self> {
        let value = toml_value(key, value)?;
        self.changed(|builder| builder.set(key, value))
    }

    /// This scenario with another controller of the registry (see `twin.controllers()`); the
    /// old controller's parameters are dropped.
    fn controller(&self, name: &str) -> PyResult<Self> {
        self.changed(|builder| Ok(builder.controller(name)))
    }

    /// This scenario run for `seconds` of simulated time.
    fn duration(&self, seconds: f64) -> PyResult<Self> {
        self.changed(|builder| Ok(builder.duration(seconds)))
    }

    /// This scenario with the sensor noise and fault draws of `seed`.
    fn seed(&self, seed: u64) -> PyResult<Self> {
        self.changed(|builder| Ok(builder.seed(seed)))
    }

    /// This scenario stepped by `engine`: `"exact"` or `"rapier"`.
    fn engine(&self, engine: &str) -> PyResult<Self> {
        self.changed(|builder| builder.set("solver.engine", engine))
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> &str {
        &self.scenario.name
    }

    /// The machine it runs: `whitworth`, `arm`, `platform`, `feed_axis`, `lathe` or `milling`.
    #[getter]
    fn machine(&self) -> &str {
        &self.scenario.machine
    }

    #[getter]
    fn description(&self) -> &str {
        &self.scenario.description
    }

    /// The registry name of the scenario's controller.
    #[getter]
    fn controller_name(&self) -> &str {
        &self.scenario.controller.name
    }

    /// Simulated time of a run, s.
    #[getter]
    fn end_time(&self) -> f64 {
        self.scenario.duration
    }

    /// The physics step, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.scenario.dt
    }

    /// The control period, s: how often a controller (and a simulator's step) acts.
    #[getter]
    fn control_period(&self) -> f64 {
        self.scenario.control_period()
    }

    /// The plant's measured signals' names, in the order of a controller's `measurements`.
    #[getter]
    fn signals(&self) -> PyResult<Vec<String>> {
        Ok(Simulator::from_loaded(self.load()?)?.signal_names())
    }

    /// The actuated joints' names, in the order of the efforts.
    #[getter]
    fn actuators(&self) -> PyResult<Vec<String>> {
        Ok(Simulator::from_loaded(self.load()?)?.actuator_names())
    }

    /// The scenario's TOML after the changes.
    #[getter]
    fn toml(&self) -> PyResult<String> {
        Ok(self.load()?.toml)
    }

    /// The plant without its controller, to step from Python (`Simulator`).
    fn simulator(&self) -> PyResult<Simulator> {
        Simulator::from_loaded(self.load()?)
    }

    /// Runs the scenario to its end and returns a `RunResult` (summary, signals as NumPy
    /// arrays, and the run's table for `to_csv` and `to_parquet`). `record`: write the Rerun
    /// recording there. `controller`: any object with `update(t, measurements) -> efforts`,
    /// called every control period in place of the scenario's controller (and `reset()` first,
    /// if it has one).
    #[pyo3(signature = (record=None, controller=None))]
    fn run(
        &self,
        py: Python<'_>,
        record: Option<PathBuf>,
        controller: Option<Py<PyAny>>,
    ) -> PyResult<RunResult> {
        let loaded = self.load()?;
        let python_controller = controller.map(PythonController::new);
        let twin = match &python_controller {
            Some(controller) => twin::Twin::with_controller(loaded, Box::new(controller.clone())),
            None => twin::Twin::new(loaded),
        };
        let controller_error = |py| python_controller.as_ref().and_then(|c| c.take_error(py));
        let stop = Arc::new(AtomicUsize::new(0));
        let twin = match twin {
            Ok(twin) => twin.with_stop_flag(stop.clone()),
            Err(error) => return Err(controller_error(py).unwrap_or_else(|| from_twin(error))),
        };
        let mut series = Series::default();
        let mut table = RunTable::new(None, None);
        let mut interrupts = Interrupts { stop, error: None };
        let summary = py.detach(|| {
            let observers: &mut [&mut dyn Observer] =
                &mut [&mut series, &mut table, &mut interrupts];
            twin.run_with(record.as_deref(), observers)
        });
        let summary = summary.map_err(from_twin)?;
        if let Some(error) = interrupts.error {
            return Err(error);
        }
        if let Some(error) = controller_error(py) {
            return Err(error);
        }
        RunResult::new(py, &summary, series, table.data().clone(), record)
    }

    /// This scenario replaying the measured run in `data` (a `.csv`, `.parquet` or twin `.rrd`
    /// file) as `twin compare` does, in 1 s segments from the start states the data give: open
    /// loop on its logged commands, or with `closed_loop` the scenario's controller on its
    /// logged reference.
    /// `rename` renames the data's columns first (`{old: new}`, as `--rename old=new`),
    /// `delimiter` gives a CSV file's separator (`","`, `";"` or `"tab"`; default: the
    /// header's), and `strict` refuses the columns the scenario does not know instead of
    /// leaving them out. Returns a dict: `report` (as `twin compare` writes comparison.json:
    /// per signal `fit_percent`, `rms_error`, `max_error`, `whiteness`), `time` (the
    /// control-period grid, s), per compared signal `measured` and `simulated` (NumPy arrays,
    /// SI) and `units`, and `notes` (the columns left out, one line per file).
    #[pyo3(signature = (data, *, closed_loop=false, rename=None, delimiter=None, strict=false))]
    fn compare<'py>(
        &self,
        py: Python<'py>,
        data: PathBuf,
        closed_loop: bool,
        rename: Option<&Bound<'py, PyAny>>,
        delimiter: Option<&str>,
        strict: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let reading = measured::read_options(rename, &Default::default(), delimiter, strict)?;
        measured::compare(py, &self.builder, &data, closed_loop, &reading)
    }

    /// This scenario's plant linearised at `at` s as `twin linearize` does (the scenario run with
    /// its controller to `at`, the efforts held there, the exact engine's equations of motion
    /// differenced about that state). Returns linear.json's content as a dict: `states`,
    /// `inputs`, `outputs` (each `{name, unit}`), `A`, `B`, `C`, `D`, `Ad`, `Bd` (NumPy arrays),
    /// `poles`, `operating_point`, `control_period` and the rest, SI.
    #[pyo3(signature = (at=0.0))]
    fn linearize<'py>(&self, py: Python<'py>, at: f64) -> PyResult<Bound<'py, PyAny>> {
        let loaded = self.load()?;
        let model = py.detach(|| {
            twin::Twin::new(loaded)
                .map_err(twin::LinearizeError::from)?
                .linearize(at)
        });
        let model = model.map_err(|error| match error {
            twin::LinearizeError::Twin(error) => from_twin(error),
            twin::LinearizeError::At { .. } => ScenarioError::new_err(format!("at: {error}")),
            other => TwinError::new_err(other.to_string()),
        })?;
        let dict = measured::from_json(py, &model.to_json().to_string())?;
        let numpy = py.import("numpy")?;
        for key in ["A", "B", "C", "D", "Ad", "Bd", "poles"] {
            let matrix = dict.get_item(key)?;
            dict.set_item(key, numpy.call_method1("array", (matrix,))?)?;
        }
        Ok(dict)
    }

    /// This scenario packed as `twin fmu` packs it: an FMI 2.0 co-simulation FMU of its closed
    /// loop, or with `plant_alone` of its plant (the host the controller), written to `path`
    /// whole or not at all. `library` is the built twin-fmu shared library (libtwin_fmu.so);
    /// by default the one the `TWIN_FMU_LIBRARY` environment variable names. Returns what was
    /// packed: `path`, `model_identifier`, `guid`, `controller` (None for the plant alone) and
    /// `bytes`.
    #[pyo3(signature = (path, *, plant_alone=false, library=None))]
    fn fmu<'py>(
        &self,
        py: Python<'py>,
        path: PathBuf,
        plant_alone: bool,
        library: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let library =
            match library.or_else(|| std::env::var_os("TWIN_FMU_LIBRARY").map(PathBuf::from)) {
                Some(library) => library,
                None => return Err(ScenarioError::new_err(
                    "library: give the built twin-fmu shared library (`cargo build --release -p \
                     twin-fmu` makes target/release/libtwin_fmu.so), or set TWIN_FMU_LIBRARY to it",
                )),
            };
        let loaded = self.load()?;
        let file = twin::OutputFile::create(&path)
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("path: {e}")))?;
        let registry = controllers::builtin();
        let packed = py.detach(|| twin_fmu::package(loaded, !plant_alone, &registry, &library));
        let (bytes, packed) = packed.map_err(|error| match error {
            twin_fmu::FmuError::Library { .. } => {
                ScenarioError::new_err(format!("library: {error}"))
            }
            other => ScenarioError::new_err(other.to_string()),
        })?;
        file.commit(&bytes)
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("path: {e}")))?;
        let dict = PyDict::new(py);
        dict.set_item("path", path)?;
        dict.set_item("model_identifier", packed.model_identifier)?;
        dict.set_item("guid", packed.guid)?;
        dict.set_item("controller", packed.controller)?;
        dict.set_item("bytes", packed.bytes)?;
        Ok(dict)
    }

    fn __repr__(&self) -> String {
        let s = &self.scenario;
        format!(
            "Scenario('{}', machine='{}', controller='{}', duration={} s)",
            s.name, s.machine, s.controller.name, s.duration
        )
    }
}

/// A Python value as a scenario (TOML) value; anything else is refused naming the key.
fn toml_value(key: &str, value: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    let refuse = || {
        let kind = value
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default();
        ScenarioError::new_err(format!(
            "{key}: a {kind} cannot be a scenario value; give a bool, int, float, str, or a list \
             or dict of them"
        ))
    };
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(value.extract()?));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = (value.try_iter()?)
            .map(|item| toml_value(key, &item?))
            .collect();
        return Ok(toml::Value::Array(items?));
    }
    if let Ok(table) = value.cast::<PyDict>() {
        let mut entries = toml::Table::new();
        for (name, entry) in table.iter() {
            let name: String = name.extract().map_err(|_| refuse())?;
            let entry = toml_value(&format!("{key}.{name}"), &entry)?;
            entries.insert(name, entry);
        }
        return Ok(toml::Value::Table(entries));
    }
    // Integers last: NumPy's integers are no `int` but index like one.
    value
        .extract::<i64>()
        .map(toml::Value::Integer)
        .map_err(|_| refuse())
}

/// Stops a run at Python's Ctrl-C (checked every 4096 steps): the run ends as interrupted, its
/// recording complete up to there, and `run` raises `KeyboardInterrupt`.
struct Interrupts {
    stop: Arc<AtomicUsize>,
    error: Option<PyErr>,
}

impl Observer for Interrupts {
    fn observe(&mut self, view: &StepView) -> Result<(), ObserverError> {
        if view.step % 4096 == 4095 && self.error.is_none() {
            if let Err(error) = Python::attach(|py| py.check_signals()) {
                let interrupt =
                    Python::attach(|py| error.is_instance_of::<PyKeyboardInterrupt>(py));
                // SIGINT's number, as the command line reports it.
                self.stop
                    .store(if interrupt { 2 } else { 15 }, Ordering::Relaxed);
                self.error = Some(error);
            }
        }
        Ok(())
    }
}
