//! `Shadow`: the twin beside a running machine, for those who bring their own transport (MQTT,
//! ROS 2, a historian): fed the machine's commands and measurements sample by sample with their
//! source timestamps (late, out of order, repeated), it estimates the machine's state and the
//! parameters it tracks, tests the innovations and reports anomalies with the parameter that
//! explains them, as `twin shadow` does (`twin::shadowing::Shadow` behind a lock, so the object
//! may cross Python threads).

use crate::calibration::scenario_of;
use crate::errors::{from_shadow, CalibrationError, ShadowError as PyShadowError};
use crate::measured::{entries, kind, strings};
use crate::scenario::Scenario;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};
use std::sync::{Mutex, MutexGuard};
use twin::shadowing::{self, Anomaly, AnomalyChange, ShadowOptions, ShadowStep, TrackedParameter};

/// The twin beside a running machine. Give it the machine's samples as they arrive,
/// `command(actuator, t, value)` and `measure(signal, t, value)` (SI, `t` the source's timestamp
/// in seconds, any origin: the first sample sets it), and call `advance()` now and then: it
/// processes the samples `latency` seconds behind the slowest stream, in time order, and returns what
/// each measurement time gave. `flush()` processes the rest (at the end). Samples older than
/// those processed are dropped as late, a repeated one (same signal, same time) as a duplicate
/// (`counts`). Times in what it returns are seconds since the first sample (`origin`).
#[pyclass(module = "twin._twin", frozen)]
pub struct Shadow {
    inner: Mutex<shadowing::Shadow>,
    /// The actuators' joint names, in the engine's order.
    actuators: Vec<String>,
    /// Every plant signal, to tell a signal not watched from one the plant lacks.
    signals: Vec<String>,
}

/// The options as given, before the engine checks them against the scenario.
struct Given<'a, 'py> {
    signals: &'a Bound<'py, PyAny>,
    track: Option<&'a Bound<'py, PyAny>>,
    noise: Option<&'a Bound<'py, PyAny>>,
    false_alarms_per_hour: f64,
    learn: f64,
    latency: f64,
    process_noise: Option<f64>,
}

impl Shadow {
    fn lock(&self) -> MutexGuard<'_, shadowing::Shadow> {
        // A panic inside the engine (turned into a Python exception) leaves the shadow as it was.
        self.inner
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// A shadow of `scenario` with the options `given`.
    fn start(scenario: &Scenario, given: &Given) -> PyResult<Self> {
        let signals = shadow_refusal(strings("signals", Some(given.signals)))?;
        let options = ShadowOptions {
            parameters: tracked(given.track)?,
            noise: noise_levels(given.noise, &signals)?,
            signals: checked_signals(signals)?,
            false_alarms_per_hour: positive("false_alarms_per_hour", given.false_alarms_per_hour)?,
            learn: positive("learn", given.learn)?,
            latency: match given.latency {
                l if l.is_finite() && l >= 0.0 => l,
                l => return Err(refuse("latency", format!("{l}: must be ≥ 0 s"))),
            },
            process_noise: match given.process_noise {
                Some(share) => positive("process_noise", share)?,
                None => shadowing::DEFAULT_PROCESS_NOISE,
            },
        };
        let shadow = shadowing::Shadow::new(scenario.load()?, &options).map_err(from_shadow)?;
        let columns = shadow.columns();
        let actuators = columns.actuators.iter().map(|(a, _)| a.clone()).collect();
        let signals = columns.signals.iter().map(|(s, _)| s.clone()).collect();
        Ok(Self {
            inner: Mutex::new(shadow),
            actuators,
            signals,
        })
    }

    /// Processes samples (`flush`: all of them) with the GIL released; the steps as dicts.
    fn process<'py>(&self, py: Python<'py>, flush: bool) -> PyResult<Bound<'py, PyList>> {
        let steps = py.detach(|| {
            let mut shadow = self.lock();
            match flush {
                true => shadow.flush(),
                false => shadow.advance(),
            }
            .map_err(from_shadow)
        })?;
        let shadow = self.lock();
        let dicts: PyResult<Vec<_>> = (steps.iter())
            .map(|step| step_dict(py, &shadow, step))
            .collect();
        PyList::new(py, dicts?)
    }
}

#[pymethods]
impl Shadow {
    /// A shadow of `scenario` (a `Scenario`, or a built-in name or file path; `set`: a dict of
    /// dotted keys to values applied as `Scenario.set` does) at its initial state. `signals`:
    /// the measured signals the filter corrects the model with (among `Shadow.watchable`; two
    /// that say the same thing, both without sensor noise, leave the filter singular); `track`: scenario values estimated as they go
    /// (`urdf.link.<link>.mass`, `urdf.joint.<joint>.damping` or `.friction`,
    /// `sensors.<signal>.bias`), each a key or `(key, drift)` with drift the random walk's σ per
    /// √s, SI; `false_alarms_per_hour` of healthy operation, all tests together; `learn`: the
    /// first seconds, taken as healthy, that set the tests' thresholds; `latency`: seconds a
    /// sample may come behind the newest and still be taken in order; `noise`: a signal's
    /// measurement σ, SI (default: its sensor's noise and resolution); `process_noise`: the
    /// model's acceleration noise as a share of the largest acceleration an actuator gives, per
    /// √s. Raises `ScenarioError` for a scenario that cannot be built and `ShadowError` for an
    /// option it cannot use.
    #[new]
    #[pyo3(signature = (
        scenario, *, signals, track=None, false_alarms_per_hour=0.1, learn=5.0,
        latency=0.25, noise=None, process_noise=None, set=None
    ))]
    // One keyword per option of `twin shadow`.
    #[allow(clippy::too_many_arguments)]
    fn new(
        scenario: &Bound<'_, PyAny>,
        signals: &Bound<'_, PyAny>,
        track: Option<&Bound<'_, PyAny>>,
        false_alarms_per_hour: f64,
        learn: f64,
        latency: f64,
        noise: Option<&Bound<'_, PyAny>>,
        process_noise: Option<f64>,
        set: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let scenario = with_changes(scenario_of(scenario)?, scenario.py(), set)?;
        let given = Given {
            signals,
            track,
            noise,
            false_alarms_per_hour,
            learn,
            latency,
            process_noise,
        };
        Self::start(&scenario, &given)
    }

    /// The plant signals of `scenario` a shadow can watch: those its model predicts from the
    /// mechanism's state (not those that need a controller's reference or the history).
    #[staticmethod]
    fn watchable(scenario: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
        let loaded = scenario_of(scenario)?.load()?;
        shadowing::Shadow::watchable(loaded).map_err(from_shadow)
    }

    /// Takes actuator `actuator`'s command (its joint's name, as in `actuators`) of `value` in
    /// its command unit (`command_units`, SI) at source time `t`, s. A value that is not finite
    /// (a dropout) is dropped, as the engine drops it; an unknown actuator or a time that is not
    /// finite raises `ShadowError`.
    fn command(&self, actuator: &str, t: f64, value: f64) -> PyResult<()> {
        let index = self.actuators.iter().position(|a| a == actuator);
        let index = index.ok_or_else(|| {
            refuse(
                "command",
                format!(
                    "`{actuator}` is not an actuator of this plant (actuators: {})",
                    self.actuators.join(", ")
                ),
            )
        })?;
        finite_time("command", actuator, t)?;
        self.lock().command(index, t, value);
        Ok(())
    }

    /// Takes signal `signal`'s measurement `value` (SI, `units`) at source time `t`, s. A plant
    /// signal that is not watched, or a value that is not finite (a dropout), is dropped, as the
    /// engine drops them; a signal the plant lacks or a time that is not finite raises
    /// `ShadowError`.
    fn measure(&self, signal: &str, t: f64, value: f64) -> PyResult<()> {
        if !self.signals.iter().any(|s| s == signal) {
            let watched = self.lock().watched().join(", ");
            let reason = format!("`{signal}` is not a signal of this plant (watched: {watched})");
            return Err(refuse("measure", reason));
        }
        finite_time("measure", signal, t)?;
        self.lock().measurement(signal, t, value);
        Ok(())
    }

    /// Processes the samples `latency` behind the newest; per measurement time processed, a
    /// dict: `time` (s since the first sample) and `source_time` (s, the source's clock);
    /// per signal measured then, `measured`, `predicted` (before the update), `residual` and
    /// `normalised` (residual / its predicted σ); `estimate` of every watched signal after the
    /// update; `parameters`, key → (estimate, σ); `tests`: `cusum` per signal, `nis` and `drift`
    /// per parameter, each in units of its threshold (alarm above 1; 0 while learning); `alarm`
    /// (an anomaly is open); `learning`; `change`: None, or the anomaly (as in `anomalies`)
    /// with `kind` `"opened"` or `"closed"`. Raises `ShadowError` if the model fails.
    fn advance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        self.process(py, false)
    }

    /// Processes every sample taken, as `advance` does, and ends the feed: a sample taken after
    /// it is late, and dropped.
    fn flush<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        self.process(py, true)
    }

    /// The anomalies found so far, the one still open last: each a dict of `signals` (the tests
    /// that alarmed, and the parameters that drifted), `start` (the change point), `detected`,
    /// `end` (None while open), all s since the first sample, `size` (the largest standardised
    /// shift, σ) and `attribution`: None, or the parameter that explains it, a dict of
    /// `parameter`, `before`, `estimate`, `interval` (95 %) and `shift_sigmas`.
    #[getter]
    fn anomalies<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let anomalies = self.lock().anomalies();
        let dicts: PyResult<Vec<_>> = (anomalies.iter())
            .map(|anomaly| anomaly_dict(py, anomaly))
            .collect();
        PyList::new(py, dicts?)
    }

    /// Each tracked parameter's estimate and standard deviation now, SI: key → (estimate, σ).
    #[getter]
    fn estimates<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let shadow = self.lock();
        let dict = PyDict::new(py);
        for (key, estimate) in shadow.parameters().iter().zip(shadow.estimates()) {
            dict.set_item(key, estimate)?;
        }
        Ok(dict)
    }

    /// What the intake did with the samples: `processed`, `late` (older than those processed:
    /// dropped), `duplicate` (a signal's time repeated: dropped), `reordered` (taken out of
    /// their arrival order).
    #[getter]
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let counts = self.lock().counts();
        let dict = PyDict::new(py);
        dict.set_item("processed", counts.processed)?;
        dict.set_item("late", counts.late)?;
        dict.set_item("duplicate", counts.duplicate)?;
        dict.set_item("reordered", counts.reordered)?;
        Ok(dict)
    }

    /// The tests' thresholds once learnt (`cusum`: h in σ of a block mean, `nis`: the NIS
    /// window's, `drift`: a parameter's, in σ), or None while learning.
    #[getter]
    fn thresholds<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some([cusum, nis, drift]) = self.lock().thresholds() else {
            return Ok(None);
        };
        let dict = PyDict::new(py);
        dict.set_item("cusum", cusum)?;
        dict.set_item("nis", nis)?;
        dict.set_item("drift", drift)?;
        Ok(Some(dict))
    }

    /// The watched signals.
    #[getter]
    fn watched(&self) -> Vec<String> {
        self.lock().watched().to_vec()
    }

    /// The tracked parameters' keys.
    #[getter]
    fn parameters(&self) -> Vec<String> {
        self.lock().parameters().to_vec()
    }

    /// The actuators' joint names (what `command` takes).
    #[getter]
    fn actuators(&self) -> Vec<String> {
        self.actuators.clone()
    }

    /// The SI unit of each plant signal, by name.
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        pairs(py, &self.lock().columns().signals)
    }

    /// The SI unit of each actuator's command (`N`, `N·m`, or `A` where a drive takes a
    /// current), by actuator.
    #[getter]
    fn command_units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        pairs(py, &self.lock().columns().actuators)
    }

    /// The first sample's source time, s (None before one came): the origin of the times
    /// reported.
    #[getter]
    fn origin(&self) -> Option<f64> {
        self.lock().origin()
    }

    /// The newest sample's time, s since the first (None before one came).
    #[getter]
    fn newest(&self) -> Option<f64> {
        self.lock().newest()
    }

    fn __repr__(&self) -> String {
        let shadow = self.lock();
        let listed = |names: &[String]| {
            let quoted: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
            format!("[{}]", quoted.join(", "))
        };
        format!(
            "Shadow('{}', watched={}, tracked={}, processed={}, anomalies={})",
            shadow.scenario_name(),
            listed(shadow.watched()),
            listed(shadow.parameters()),
            shadow.counts().processed,
            shadow.anomalies().len()
        )
    }
}

/// An argument refused, named as the keyword (or method) that gave it.
fn refuse(argument: &str, reason: impl std::fmt::Display) -> PyErr {
    PyShadowError::new_err(format!("{argument}: {reason}"))
}

/// The shared argument readers' refusals (`CalibrationError`s) as `ShadowError`s.
fn shadow_refusal<T>(result: PyResult<T>) -> PyResult<T> {
    result.map_err(|error| {
        Python::attach(|py| match error.is_instance_of::<CalibrationError>(py) {
            true => PyShadowError::new_err(error.value(py).to_string()),
            false => error,
        })
    })
}

/// `value` if it is a positive number, else the refusal naming `argument`.
fn positive(argument: &str, value: f64) -> PyResult<f64> {
    match value.is_finite() && value > 0.0 {
        true => Ok(value),
        false => Err(refuse(
            argument,
            format!("{value}: must be a positive number"),
        )),
    }
}

/// Refuses a sample's time that is not a number of seconds.
fn finite_time(method: &str, name: &str, t: f64) -> PyResult<()> {
    match t.is_finite() {
        true => Ok(()),
        false => Err(refuse(
            method,
            format!("{name} at t = {t}: the time must be a finite number of seconds"),
        )),
    }
}

/// `scenario` with the `set` dict's changes, each as `Scenario.set` makes it.
fn with_changes(
    scenario: Scenario,
    py: Python<'_>,
    set: Option<&Bound<'_, PyAny>>,
) -> PyResult<Scenario> {
    let changes = shadow_refusal(entries("set", set))?;
    let mut changed = Bound::new(py, scenario)?;
    for (key, value) in changes {
        changed = changed.call_method1("set", (key, value))?.cast_into()?;
    }
    Ok(changed.get().clone())
}

/// The watched signals, each once.
fn checked_signals(signals: Vec<String>) -> PyResult<Vec<String>> {
    if signals.is_empty() {
        return Err(refuse(
            "signals",
            "give at least one of the machine's signals",
        ));
    }
    for (i, signal) in signals.iter().enumerate() {
        if signals[..i].contains(signal) {
            return Err(refuse("signals", format!("`{signal}` is given twice")));
        }
    }
    Ok(signals)
}

/// `track`: a key, a list of keys or `(key, drift)` pairs, or a dict of key → drift (None:
/// the default drift).
fn tracked(value: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<TrackedParameter>> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    if value.is_instance_of::<PyString>() {
        return Ok(vec![parameter(value.extract()?, None)?]);
    }
    if value.is_instance_of::<PyDict>() {
        let pairs = shadow_refusal(entries("track", Some(value)))?;
        return (pairs.into_iter())
            .map(|(key, drift)| {
                let drift = drift_of(&key, &drift)?;
                parameter(key, drift)
            })
            .collect();
    }
    let wrong = || {
        let reason = format!(
            "a {} is not a key, a list of keys or (key, drift) pairs, or a dict",
            kind(value)
        );
        refuse("track", reason)
    };
    let mut parameters = Vec::new();
    for item in value.try_iter().map_err(|_| wrong())? {
        let item = item?;
        let (key, drift) = match item.extract::<String>() {
            Ok(key) => (key, None),
            Err(_) => {
                let (key, drift): (String, Bound<'_, PyAny>) =
                    item.extract().map_err(|_| wrong())?;
                let drift = drift_of(&key, &drift)?;
                (key, drift)
            }
        };
        parameters.push(parameter(key, drift)?);
    }
    Ok(parameters)
}

/// A tracked parameter, its drift (if given) checked.
fn parameter(key: String, drift: Option<f64>) -> PyResult<TrackedParameter> {
    if let Some(d) = drift.filter(|d| !(d.is_finite() && *d > 0.0)) {
        let reason = format!("{key}: the drift {d} must be a positive number (σ per √s, SI)");
        return Err(refuse("track", reason));
    }
    Ok(TrackedParameter { key, drift })
}

/// A drift as given: a number, or None for the default.
fn drift_of(key: &str, drift: &Bound<'_, PyAny>) -> PyResult<Option<f64>> {
    drift.extract::<Option<f64>>().map_err(|_| {
        let reason = format!(
            "{key}: the drift must be a number (σ per √s, SI) or None, not a {}",
            kind(drift)
        );
        refuse("track", reason)
    })
}

/// `noise`: a dict of watched signal → σ, SI, each > 0 (read as calibration reads it).
fn noise_levels(
    value: Option<&Bound<'_, PyAny>>,
    signals: &[String],
) -> PyResult<Vec<(String, f64)>> {
    let given = shadow_refusal(crate::calibration::noise_levels(value))?;
    match given.iter().find(|(name, _)| !signals.contains(name)) {
        Some((name, _)) => Err(refuse(
            "noise",
            format!(
                "`{name}` is not a watched signal (watched: {})",
                signals.join(", ")
            ),
        )),
        None => Ok(given),
    }
}

/// Name → unit pairs as a dict.
fn pairs<'py>(py: Python<'py>, pairs: &[(String, String)]) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (name, unit) in pairs {
        dict.set_item(name, unit)?;
    }
    Ok(dict)
}

/// One processed step as a dict (see `Shadow.advance`).
fn step_dict<'py>(
    py: Python<'py>,
    shadow: &shadowing::Shadow,
    step: &ShadowStep,
) -> PyResult<Bound<'py, PyDict>> {
    let watched = shadow.watched();
    let dict = PyDict::new(py);
    dict.set_item("time", step.time)?;
    dict.set_item("source_time", shadow.origin().unwrap_or(0.0) + step.time)?;
    let [measured, predicted, residual, normalised, estimate, cusum] =
        [(); 6].map(|_| PyDict::new(py));
    for &(s, value) in &step.measured {
        measured.set_item(&watched[s], value)?;
    }
    let innovation = &step.innovation;
    for (i, &s) in innovation.signals.iter().enumerate() {
        let name = &watched[s];
        predicted.set_item(name, innovation.predicted[i])?;
        residual.set_item(name, innovation.residual[i])?;
        normalised.set_item(name, innovation.residual[i] / innovation.variance[i].sqrt())?;
    }
    for (name, (value, test)) in watched
        .iter()
        .zip(step.estimate.iter().zip(&step.detector.cusum))
    {
        estimate.set_item(name, value)?;
        cusum.set_item(name, test)?;
    }
    let [parameters, drift] = [(); 2].map(|_| PyDict::new(py));
    for (key, (value, test)) in
        (shadow.parameters().iter()).zip(step.parameters.iter().zip(&step.detector.drift))
    {
        parameters.set_item(key, value)?;
        drift.set_item(key, test)?;
    }
    let tests = PyDict::new(py);
    tests.set_item("cusum", cusum)?;
    tests.set_item("nis", step.detector.nis)?;
    tests.set_item("drift", drift)?;
    for (key, part) in [
        ("measured", measured),
        ("predicted", predicted),
        ("residual", residual),
        ("normalised", normalised),
        ("estimate", estimate),
        ("parameters", parameters),
        ("tests", tests),
    ] {
        dict.set_item(key, part)?;
    }
    dict.set_item("alarm", step.detector.alarm)?;
    dict.set_item("learning", step.learning)?;
    let change = match &step.change {
        None => None,
        Some(AnomalyChange::Opened(anomaly)) => Some(("opened", anomaly)),
        Some(AnomalyChange::Closed(anomaly)) => Some(("closed", anomaly)),
    };
    let change = change
        .map(|(kind, anomaly)| {
            let dict = anomaly_dict(py, anomaly)?;
            dict.set_item("kind", kind)?;
            Ok::<_, PyErr>(dict)
        })
        .transpose()?;
    dict.set_item("change", change)?;
    Ok(dict)
}

/// An anomaly as a dict (see `Shadow.anomalies`).
fn anomaly_dict<'py>(py: Python<'py>, anomaly: &Anomaly) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("signals", &anomaly.signals)?;
    dict.set_item("start", anomaly.start)?;
    dict.set_item("detected", anomaly.detected)?;
    dict.set_item("end", anomaly.end)?;
    dict.set_item("size", anomaly.size)?;
    let attribution = match &anomaly.attribution {
        None => None,
        Some(a) => {
            let cause = PyDict::new(py);
            cause.set_item("parameter", &a.parameter)?;
            cause.set_item("before", a.before)?;
            cause.set_item("estimate", a.estimate)?;
            cause.set_item("interval", (a.interval[0], a.interval[1]))?;
            cause.set_item("shift_sigmas", a.shift_sigmas)?;
            Some(cause)
        }
    };
    dict.set_item("attribution", attribution)?;
    Ok(dict)
}
