//! A Python object as the twin's controller: `update(t, measurements) -> efforts` every control
//! period. A Python exception or a broken reply cannot fail the trait's `update`, so the
//! controller answers NaN efforts, which stops the run there as a divergence (its recording kept),
//! and `Scenario.run` then raises the reason.

use crate::errors::ControllerError as PyControllerError;
use framework::{Controller, ControllerError, Measurement, PlantInterface};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// Shared by the twin's controller slot and `Scenario.run`, which reads the error afterwards.
#[derive(Clone)]
pub struct PythonController {
    object: Arc<Py<PyAny>>,
    name: String,
    actuators: Vec<String>,
    error: Arc<Mutex<Option<PyErr>>>,
}

impl PythonController {
    pub fn new(object: Py<PyAny>) -> Self {
        let name = Python::attach(|py| {
            let kind = object.bind(py).get_type();
            format!(
                "python:{}",
                kind.name().map(|n| n.to_string()).unwrap_or_default()
            )
        });
        Self {
            object: Arc::new(object),
            name,
            actuators: Vec::new(),
            error: Arc::new(Mutex::new(None)),
        }
    }

    /// What stopped the run, if the controller did.
    pub fn take_error(&self, py: Python<'_>) -> Option<PyErr> {
        let taken = self.error.lock().ok()?.take()?;
        // Ctrl-C while Python code of the controller ran is the user's stop, not its fault.
        if taken.is_instance_of::<PyKeyboardInterrupt>(py) {
            return Some(taken);
        }
        let error = PyControllerError::new_err(format!("{}: {}", self.name, taken.value(py)));
        error.set_cause(py, Some(taken));
        Some(error)
    }

    fn fail(&self, error: PyErr) {
        if let Ok(mut slot) = self.error.lock() {
            slot.get_or_insert(error);
        }
    }

    fn failed(&self) -> bool {
        self.error.lock().map_or(true, |slot| slot.is_some())
    }

    /// One `update` call: the efforts it returns, checked (one finite value per actuator).
    fn call(&self, py: Python<'_>, measurement: &Measurement, efforts: &mut [f64]) -> PyResult<()> {
        let measurements = PyArray1::from_slice(py, measurement.signals);
        let reply = self
            .object
            .bind(py)
            .call_method1("update", (measurement.time, measurements))?;
        let values = efforts_from(&reply)?;
        if values.len() != efforts.len() {
            return Err(PyControllerError::new_err(format!(
                "update returned {} efforts at t = {} s for {} actuators ({}); return one per \
                 actuator in that order",
                values.len(),
                measurement.time,
                efforts.len(),
                self.actuators.join(", ")
            )));
        }
        if let Some((actuator, value)) =
            (self.actuators.iter().zip(&values)).find(|(_, v)| !v.is_finite())
        {
            return Err(PyControllerError::new_err(format!(
                "update returned {value} for actuator `{actuator}` at t = {} s: efforts must be \
                 finite",
                measurement.time
            )));
        }
        efforts.copy_from_slice(&values);
        Ok(())
    }
}

/// Efforts as Python gives them: a float64 array, any sequence of numbers, or one number.
pub fn efforts_from(value: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    if let Ok(array) = value.extract::<PyReadonlyArray1<f64>>() {
        return Ok(array
            .as_slice()
            .map_or_else(|_| array.as_array().to_vec(), <[f64]>::to_vec));
    }
    if let Ok(number) = value.extract::<f64>() {
        return Ok(vec![number]);
    }
    value.extract::<Vec<f64>>().map_err(|_| {
        let kind = value
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default();
        PyControllerError::new_err(format!(
            "efforts: a {kind} is not a sequence of numbers; give one float per actuator"
        ))
    })
}

impl Controller for PythonController {
    fn name(&self) -> &str {
        &self.name
    }

    /// Calls the object's `reset()`, if it has one.
    fn reset(&mut self, plant: &PlantInterface) -> Result<(), ControllerError> {
        self.actuators = plant.actuators.iter().map(|a| a.joint.clone()).collect();
        let reset = Python::attach(|py| {
            let object = self.object.bind(py);
            match object.hasattr("reset")? {
                true => object.call_method0("reset").map(drop),
                false => Ok(()),
            }
        });
        reset.map_err(|error| {
            let reason = Python::attach(|py| format!("its reset() raised {}", error.value(py)));
            self.fail(error);
            ControllerError::BadParameter {
                controller: self.name.clone(),
                key: String::new(),
                value: None,
                reason,
            }
        })
    }

    fn update(&mut self, measurement: &Measurement, _period: f64, efforts: &mut [f64]) {
        if self.failed() {
            efforts.fill(f64::NAN);
            return;
        }
        if let Err(error) = Python::attach(|py| self.call(py, measurement, efforts)) {
            self.fail(error);
            efforts.fill(f64::NAN);
        }
    }
}
