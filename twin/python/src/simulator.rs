//! `Simulator`: the plant without its controller, stepped from a Python loop one control period
//! at a time (`twin::Simulator` behind a lock, so the object may cross Python threads).

use crate::controller::efforts_from;
use crate::errors::StepError as PyStepError;
use crate::errors::{diverged, from_twin};
use numpy::PyArray1;
use pyo3::prelude::*;
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;
use twin::{LoadedScenario, StepError};

/// The scenario's plant without its controller: `step(efforts)` holds the efforts (one per
/// actuator in its command unit, `effort_units`: N, N·m, or A where a drive takes a current;
/// clipped to `effort_limits`) over one control period and returns the measured signals at
/// its end (SI, in the order of `signals`).
#[pyclass(module = "twin._twin", frozen)]
pub struct Simulator {
    inner: Mutex<twin::Simulator>,
}

impl Simulator {
    /// The plant of a loaded scenario, its controller left out.
    pub fn from_loaded(loaded: LoadedScenario) -> PyResult<Self> {
        let simulator = twin::Simulator::new(loaded).map_err(from_twin)?;
        Ok(Self {
            inner: Mutex::new(simulator),
        })
    }

    fn lock(&self) -> MutexGuard<'_, twin::Simulator> {
        // A panic inside a step (turned into a Python exception) leaves the twin as it was.
        self.inner
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    pub fn signal_names(&self) -> Vec<String> {
        let sim = self.lock();
        sim.signal_specs().iter().map(|s| s.name.clone()).collect()
    }

    pub fn actuator_names(&self) -> Vec<String> {
        let sim = self.lock();
        sim.actuators().iter().map(|a| a.joint.clone()).collect()
    }
}

#[pymethods]
impl Simulator {
    /// Back to t = 0 with the sensor noise and fault draws of `seed` (the scenario's seed when
    /// None); returns the measured signals at t = 0.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<u64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let mut sim = self.lock();
        let seed = seed.unwrap_or(sim.scenario().seed);
        sim.reset(seed).map_err(from_twin)?;
        Ok(PyArray1::from_slice(py, sim.measured()))
    }

    /// One control period with `efforts` held; the measured signals at its end. Raises
    /// `StepError` for efforts of the wrong length or not finite (naming the actuator) and
    /// `DivergedError` when the plant diverges or crashes (then every step until a `reset`).
    fn step<'py>(
        &self,
        py: Python<'py>,
        efforts: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let efforts =
            efforts_from(efforts).map_err(|e| PyStepError::new_err(e.value(py).to_string()))?;
        let mut sim = self.lock();
        match sim.step(&efforts) {
            Ok(measured) => Ok(PyArray1::from_slice(py, measured)),
            Err(StepError::Diverged(failure)) => Err(diverged(py, &failure)),
            Err(error) => Err(PyStepError::new_err(error.to_string())),
        }
    }

    /// The simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.lock().time()
    }

    /// The control period (one `step`), s.
    #[getter]
    fn control_period(&self) -> f64 {
        self.lock().scenario().control_period()
    }

    /// The scenario's simulated duration, s.
    #[getter]
    fn end_time(&self) -> f64 {
        self.lock().scenario().duration
    }

    /// The measured signals' names, in the order of a step's measurements.
    #[getter]
    fn signals(&self) -> Vec<String> {
        self.signal_names()
    }

    /// The SI unit of each signal, in the order of `signals`.
    #[getter]
    fn units(&self) -> Vec<&'static str> {
        self.lock().signal_units()
    }

    /// The actuated joints' names, in the order of a step's efforts.
    #[getter]
    fn actuators(&self) -> Vec<String> {
        self.actuator_names()
    }

    /// Each actuator's effort limit (in its `effort_units`; the drive's current limit on the
    /// arm): larger efforts are clipped to it.
    #[getter]
    fn effort_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.lock().command_limits())
    }

    /// Each actuator's command unit: `N` (a slide), `N·m` (a turning joint), or `A` where the
    /// drive takes a current (the arm's).
    #[getter]
    fn effort_units(&self) -> Vec<&'static str> {
        self.lock().command_units()
    }

    /// The measured signals at the last step (or reset).
    #[getter]
    fn measured<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.lock().measured())
    }

    /// The plant's true signals now (before the sensors), in the order of `signals`.
    #[getter]
    fn true_signals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.lock().true_signals())
    }

    /// The model checks' names: the machine's own figures (e.g. the arm's `path_deviation`, the
    /// platform's `path_error`), one `loop_gap/<loop>` per loop closure, `mechanical_energy`.
    #[getter]
    fn diagnostic_names(&self) -> Vec<String> {
        let sim = self.lock();
        sim.diagnostic_specs()
            .iter()
            .map(|s| s.name.clone())
            .collect()
    }

    /// The SI unit of each model check, in the order of `diagnostic_names`.
    #[getter]
    fn diagnostic_units(&self) -> Vec<&'static str> {
        let sim = self.lock();
        sim.diagnostic_specs()
            .iter()
            .map(|s| s.unit.si_label())
            .collect()
    }

    /// The model checks now, in the order of `diagnostic_names`.
    #[getter]
    fn diagnostics<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.lock().diagnostics())
    }

    fn __repr__(&self) -> String {
        let sim = self.lock();
        format!(
            "Simulator('{}', t={} s, {} actuators, {} signals)",
            sim.scenario().name,
            sim.time(),
            sim.actuators().len(),
            sim.signal_specs().len()
        )
    }
}

/// Seconds for `steps` zero-effort steps of the scenario's plant, from Rust.
pub fn engine_step_seconds(loaded: LoadedScenario, steps: usize) -> PyResult<f64> {
    let mut sim = twin::Simulator::new(loaded).map_err(from_twin)?;
    let efforts = vec![0.0; sim.actuators().len()];
    let started = Instant::now();
    for _ in 0..steps {
        if sim.step(&efforts).is_err() {
            sim.reset(0).map_err(from_twin)?;
        }
    }
    Ok(started.elapsed().as_secs_f64())
}
