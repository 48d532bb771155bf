//! The twin from Python (`twin._twin`, wrapped by the `twin` package in `python/twin`):
//! scenarios run to NumPy arrays (`scenario`), the plant stepped from a Python loop
//! (`simulator`), Python controllers (`controller`), the twin compared with and calibrated
//! to measured runs (`calibration`), the twin beside a running machine fed sample by
//! sample (`shadow`). Every Rust error becomes a Python
//! exception of the hierarchy below; pyo3 turns a Rust panic into `pyo3_runtime.PanicException`,
//! never a crashed interpreter.

mod calibration;
mod controller;
mod errors;
mod measured;
mod result;
mod scenario;
mod shadow;
mod simulator;

use pyo3::prelude::*;

pub use errors::{
    CalibrationError, ControllerError, DataError, DivergedError, ScenarioError, ShadowError,
    StepError, TwinError,
};

/// The built-in scenarios' names, e.g. `whitworth-crank-pi`.
#[pyfunction]
fn scenarios() -> Vec<&'static str> {
    twin::BUILTIN_SCENARIOS
        .iter()
        .map(|(name, _)| *name)
        .collect()
}

/// The registry's controllers as `(name, machine, summary)`; machine `*` fits any machine.
#[pyfunction(name = "controllers")]
fn registry_controllers() -> Vec<(&'static str, &'static str, &'static str)> {
    ::controllers::builtin()
        .entries()
        .iter()
        .map(|entry| (entry.name, entry.machine, entry.summary))
        .collect()
}

/// Seconds the engine alone takes for `steps` control periods of `scenario`'s plant with zero
/// efforts, stepped from Rust: the baseline of the Python step API's overhead (benchmarks).
#[pyfunction]
fn engine_step_seconds(scenario: &scenario::Scenario, steps: usize) -> PyResult<f64> {
    simulator::engine_step_seconds(scenario.load()?, steps)
}

#[pymodule]
fn _twin(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(scenarios, m)?)?;
    m.add_function(wrap_pyfunction!(registry_controllers, m)?)?;
    m.add_function(wrap_pyfunction!(engine_step_seconds, m)?)?;
    m.add_function(wrap_pyfunction!(calibration::calibrate, m)?)?;
    m.add_class::<scenario::Scenario>()?;
    m.add_class::<simulator::Simulator>()?;
    m.add_class::<result::RunResult>()?;
    m.add_class::<shadow::Shadow>()?;
    errors::add_to(m)
}
