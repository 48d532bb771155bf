//! The twin against measured runs from Python: `Scenario.compare` and `twin.calibrate`, the
//! command line's `twin compare` and `twin calibrate` with their options as keyword arguments.
//! Each returns the command's JSON report as a dict (`report`) beside the series it compared, as
//! NumPy arrays on the control-period grid.

use crate::errors::from_calibration;
use crate::errors::ScenarioError;
use crate::measured::{entries, from_json, grid, kind, paths, plant_columns, read_options};
use crate::measured::{read_run, refuse, strings};
use crate::scenario::Scenario;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};
use std::path::{Path, PathBuf};
use twin::calibration::{
    self, Calibration, CalibrationError, CalibrationOptions, FitParameter, Iteration, RunFit,
    StartStates,
};
use twin::data::{ReadOptions, RunData};
use twin::{CalibrationSpec, ScenarioBuilder};

/// Fits scenario values to measured runs, as `twin calibrate` does (the scenario's
/// `[calibration]` table, if any, gives what the call leaves out). Returns a dict: `report` (as
/// calibration.json: `parameters` with each `key`, `start`, `estimate`, `standard_error`,
/// `interval`, `at_bound`; `correlation`; `runs` and `validation` with their fits `before`
/// and `after`; `warnings`; …), `calibrated_toml`, `scenario` (the calibrated `Scenario`), per
/// run and validation run its series (`runs`, `validation`) and `notes` (the columns left out,
/// one line per file). `progress(iteration, cost, step)` is called at each accepted step of the
/// solve. `rename`, `delimiter` and `strict` read the runs as `Scenario.compare` does.
#[pyfunction]
#[pyo3(signature = (
    scenario, data=None, *, fit=None, bounds=None, per_run=None, validate=None, signals=None,
    noise=None, segment=None, states=None, closed_loop=false, starts=None, max_iterations=50,
    threads=0, rename=None, delimiter=None, strict=false, progress=None
))]
// One keyword per option of `twin calibrate`.
#[allow(clippy::too_many_arguments)]
pub fn calibrate<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    data: Option<&Bound<'py, PyAny>>,
    fit: Option<&Bound<'py, PyAny>>,
    bounds: Option<&Bound<'py, PyAny>>,
    per_run: Option<&Bound<'py, PyAny>>,
    validate: Option<&Bound<'py, PyAny>>,
    signals: Option<&Bound<'py, PyAny>>,
    noise: Option<&Bound<'py, PyAny>>,
    segment: Option<f64>,
    states: Option<&Bound<'py, PyAny>>,
    closed_loop: bool,
    starts: Option<usize>,
    max_iterations: usize,
    threads: usize,
    rename: Option<&Bound<'py, PyAny>>,
    delimiter: Option<&str>,
    strict: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let scenario = scenario_of(scenario)?;
    let spec = scenario.load()?.scenario.calibration.unwrap_or_default();
    let request = Request {
        data: paths("data", data)?,
        validate: paths("validate", validate)?,
        fit: fit_parameters(fit)?,
        bounds: fit_bounds(bounds)?,
        per_run: strings("per_run", per_run)?,
        signals: strings("signals", signals)?,
        noise: noise_levels(noise)?,
        segment,
        states: states.map(start_states).transpose()?,
        closed_loop,
        starts,
        max_iterations,
        threads,
        reading: read_options(rename, &spec.rename, delimiter, strict)?,
    };
    let plan = request.plan(&spec, scenario.folder())?;
    let mut progress = Progress::new(py, progress)?;
    let outcome = py.detach(|| plan.run(scenario.builder(), &mut progress));
    if let Some(error) = progress.error.take() {
        return Err(error);
    }
    let (outcome, notes) = outcome.map_err(from_calibration)?;
    let dict = calibration_dict(py, &scenario, &outcome)?;
    dict.set_item("notes", notes)?;
    Ok(dict)
}

/// The scenario argument: a `Scenario`, or a built-in name or file path as `Scenario()` takes.
pub fn scenario_of(value: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    if let Ok(scenario) = value.cast::<Scenario>() {
        return Ok(scenario.get().clone());
    }
    match value.extract::<PathBuf>() {
        Ok(path) => Scenario::new(path),
        Err(_) => Err(ScenarioError::new_err(format!(
            "scenario: a {} is neither a twin.Scenario nor a scenario's name or path",
            kind(value)
        ))),
    }
}

/// `twin.calibrate`'s arguments, before the scenario's `[calibration]` table fills the gaps.
struct Request {
    data: Vec<PathBuf>,
    validate: Vec<PathBuf>,
    fit: Vec<FitParameter>,
    bounds: Vec<(String, [f64; 2])>,
    per_run: Vec<String>,
    signals: Vec<String>,
    noise: Vec<(String, f64)>,
    segment: Option<f64>,
    states: Option<StartStates>,
    closed_loop: bool,
    starts: Option<usize>,
    max_iterations: usize,
    threads: usize,
    /// How the runs are read.
    reading: ReadOptions,
}

/// A calibration ready to run: its options and the runs to read.
struct Plan {
    options: CalibrationOptions,
    reading: ReadOptions,
    data: Vec<PathBuf>,
    validate: Vec<PathBuf>,
}

impl Request {
    /// The options as `twin calibrate` makes them: the table's, with the call's on top; the
    /// table's runs (relative to the scenario file's `folder`) where the call gives none.
    fn plan(self, spec: &CalibrationSpec, folder: Option<&Path>) -> PyResult<Plan> {
        let parameters = self.parameters(spec)?;
        let mut noise: Vec<(String, f64)> = spec.noise.clone().into_iter().collect();
        for (name, sigma) in self.noise {
            noise.retain(|(n, _)| *n != name);
            noise.push((name, sigma));
        }
        let table_states = || StartStates::parse(spec.states.as_deref().unwrap_or("auto"));
        let folder = folder.unwrap_or(Path::new(""));
        let runs = |given: Vec<PathBuf>, table: &[String]| match given.is_empty() {
            true => table.iter().map(|p| folder.join(p)).collect(),
            false => given,
        };
        let data: Vec<PathBuf> = runs(self.data, &spec.data);
        if data.is_empty() {
            let reason = "give a measured run (.csv, .parquet or .rrd), or [calibration] data";
            return Err(refuse("data", reason));
        }
        let options = CalibrationOptions {
            parameters,
            signals: match self.signals.is_empty() {
                true => spec.signals.clone(),
                false => self.signals,
            },
            noise,
            segment: self.segment.or(spec.segment),
            states: self.states.unwrap_or_else(table_states),
            closed_loop: self.closed_loop || spec.closed_loop,
            starts: self.starts.or(spec.starts).unwrap_or(1),
            max_iterations: self.max_iterations,
            threads: self.threads,
        };
        Ok(Plan {
            options,
            reading: self.reading,
            data,
            validate: runs(self.validate, &spec.validate),
        })
    }

    /// The table's parameters, then the call's `fit` (replacing the table's of the same key),
    /// with the call's `bounds` and `per_run` on them.
    fn parameters(&self, spec: &CalibrationSpec) -> PyResult<Vec<FitParameter>> {
        let mut parameters: Vec<FitParameter> = FitParameter::from_table(spec);
        for parameter in &self.fit {
            parameters.retain(|p| p.key != parameter.key);
            parameters.push(parameter.clone());
        }
        for (key, bounds) in &self.bounds {
            fitted(&mut parameters, "bounds", key)?.bounds = Some(*bounds);
        }
        for key in &self.per_run {
            fitted(&mut parameters, "per_run", key)?.per_run = true;
        }
        if parameters.is_empty() {
            let reason = "give a scenario key to fit, e.g. fit=[\"urdf.link.ram.mass\"], or \
                          [calibration.fit] in the scenario";
            return Err(refuse("fit", reason));
        }
        Ok(parameters)
    }
}

/// The parameter of `key` among those fitted, or the refusal of the `argument` naming it.
fn fitted<'a>(
    parameters: &'a mut [FitParameter],
    argument: &str,
    key: &str,
) -> PyResult<&'a mut FitParameter> {
    let found = parameters.iter_mut().find(|p| p.key == key);
    found.ok_or_else(|| refuse(argument, format!("`{key}` is not fitted; add it to fit")))
}

impl Plan {
    /// Reads the runs (the columns the scenario does not know left out, with the notes saying
    /// which) and calibrates, each accepted step reported to `progress`.
    fn run(
        &self,
        builder: &ScenarioBuilder,
        progress: &mut Progress,
    ) -> Result<(Calibration, Vec<String>), CalibrationError> {
        let registry = controllers::builtin();
        let plant = plant_columns(builder, &registry)?;
        let mut notes = Vec::new();
        let mut read = |paths: &[PathBuf]| -> Result<Vec<RunData>, CalibrationError> {
            let mut runs = Vec::with_capacity(paths.len());
            for path in paths {
                let (run, note) = read_run(path, &self.reading, &plant)?;
                runs.push(run);
                notes.extend(note);
            }
            Ok(runs)
        };
        let (data, validate) = (read(&self.data)?, read(&self.validate)?);
        let mut report = |step: &Iteration| progress.report(step);
        let calibration = calibration::calibrate(
            builder,
            &registry,
            &data,
            &validate,
            &self.options,
            &mut report,
        )?;
        Ok((calibration, notes))
    }
}

/// The solve's accepted steps handed to a Python callable, the GIL taken for each call. The
/// first exception it raises, or a Ctrl-C, is kept (no later step is reported) and raised once
/// the solve has ended: the library's solve cannot be stopped from outside.
struct Progress {
    callback: Option<Py<PyAny>>,
    error: Option<PyErr>,
}

impl Progress {
    /// Refuses a `callback` that cannot be called before any work.
    fn new(py: Python<'_>, callback: Option<Py<PyAny>>) -> PyResult<Self> {
        if let Some(callback) = callback.as_ref().map(|c| c.bind(py)) {
            if !callback.is_callable() {
                let reason = format!(
                    "a {} is not callable; give f(iteration, cost, step)",
                    kind(callback)
                );
                return Err(refuse("progress", reason));
            }
        }
        Ok(Self {
            callback,
            error: None,
        })
    }

    fn report(&mut self, step: &Iteration) {
        if self.error.is_some() {
            return;
        }
        let outcome = Python::attach(|py| {
            py.check_signals()?;
            match &self.callback {
                Some(callback) => callback
                    .call1(py, (step.iteration, step.cost, step.step))
                    .map(drop),
                None => Ok(()),
            }
        });
        self.error = outcome.err();
    }
}

/// The result of `twin.calibrate` as a dict.
fn calibration_dict<'py>(
    py: Python<'py>,
    scenario: &Scenario,
    outcome: &Calibration,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("report", from_json(py, &outcome.to_json().to_string())?)?;
    dict.set_item("calibrated_toml", &outcome.calibrated_toml)?;
    let text = &outcome.calibrated_toml;
    let calibrated = twin::Scenario::from_toml(text, "the calibrated scenario", scenario.folder());
    let calibrated = calibrated.map_err(crate::errors::from_scenario)?;
    let folder = scenario.folder().map(Path::to_path_buf);
    dict.set_item("scenario", Scenario::checked(calibrated, folder)?)?;
    for (name, fits) in [("runs", &outcome.runs), ("validation", &outcome.validation)] {
        let series: PyResult<Vec<_>> = fits.iter().map(|fit| run_series(py, fit)).collect();
        dict.set_item(name, PyList::new(py, series?)?)?;
    }
    Ok(dict)
}

/// One run's series: `data` (its file), `time`, and per fitted signal `units`, `measured`, the
/// twin `before` and `after` the fit.
fn run_series<'py>(py: Python<'py>, fit: &RunFit) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("data", &fit.source)?;
    let samples = fit.overlays.first().map_or(0, |(_, _, [m, ..])| m.len());
    dict.set_item("time", grid(py, fit.start_time, fit.period, samples))?;
    let [units, measured, before, after] = [(); 4].map(|_| PyDict::new(py));
    for (signal, unit, [m, b, a]) in &fit.overlays {
        units.set_item(signal, unit)?;
        measured.set_item(signal, PyArray1::from_slice(py, m))?;
        before.set_item(signal, PyArray1::from_slice(py, b))?;
        after.set_item(signal, PyArray1::from_slice(py, a))?;
    }
    dict.set_item("units", units)?;
    dict.set_item("measured", measured)?;
    dict.set_item("before", before)?;
    dict.set_item("after", after)?;
    Ok(dict)
}

/// `fit`: a key, a list of keys, or a dict of key → start (None: the scenario's value).
fn fit_parameters(value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<FitParameter>> {
    let parameter = |key: String, start: Option<f64>| FitParameter {
        key,
        start,
        bounds: None,
        per_run: false,
    };
    if !value.is_some_and(|v| v.is_instance_of::<PyDict>()) {
        let keys = strings("fit", value)?;
        return Ok(keys.into_iter().map(|key| parameter(key, None)).collect());
    }
    let mut parameters = Vec::new();
    for (key, start) in entries("fit", value)? {
        let start: Option<f64> = start.extract().map_err(|_| {
            refuse(
                "fit",
                format!(
                    "{key}: the start must be a number or None, not a {}",
                    kind(&start)
                ),
            )
        })?;
        if start.is_some_and(|s| !s.is_finite()) {
            let reason = format!("{key}: the start must be a finite number");
            return Err(refuse("fit", reason));
        }
        parameters.push(parameter(key, start));
    }
    Ok(parameters)
}

/// `bounds`: a dict of key → (lo, hi).
fn fit_bounds(value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<(String, [f64; 2])>> {
    let bound = |(key, pair): (String, Bound<'_, PyAny>)| {
        let (lo, hi): (f64, f64) = (pair.extract())
            .map_err(|_| refuse("bounds", format!("{key}: give (lo, hi), two numbers")))?;
        Ok((key, [lo, hi]))
    };
    entries("bounds", value)?.into_iter().map(bound).collect()
}

/// `noise`: a dict of signal → σ, SI, each > 0.
pub(crate) fn noise_levels(value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<(String, f64)>> {
    let level = |(name, sigma): (String, Bound<'_, PyAny>)| {
        let sigma = sigma
            .extract::<f64>()
            .ok()
            .filter(|s| *s > 0.0 && s.is_finite());
        let sigma = sigma.ok_or_else(|| refuse("noise", format!("{name}: σ must be > 0")))?;
        Ok((name, sigma))
    };
    entries("noise", value)?.into_iter().map(level).collect()
}

/// `states`: `"auto"`, `"none"`, joints separated by commas, or a list of joints.
fn start_states(value: &Bound<'_, PyAny>) -> PyResult<StartStates> {
    if let Ok(text) = value.cast::<PyString>() {
        return Ok(StartStates::parse(&text.to_string()));
    }
    Ok(StartStates::Joints(strings("states", Some(value))?))
}
