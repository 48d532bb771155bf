//! The Python exceptions: `TwinError` and, beneath it, what went wrong where.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _twin,
    TwinError,
    PyException,
    "Anything the twin refuses or fails at."
);
create_exception!(
    _twin,
    ScenarioError,
    TwinError,
    "A scenario that cannot be built: an unknown name or key, a bad value, a URDF it cannot use. \
     The message names the file, key or element and what to change."
);
create_exception!(
    _twin,
    StepError,
    TwinError,
    "A step refused: efforts of the wrong length or not finite (the message names the actuator)."
);
create_exception!(
    _twin,
    DivergedError,
    StepError,
    "The plant diverged or crashed; attributes `step`, `time` (s), `signal`, `value`, `kind` \
     (`diverged` or `collision`). Reset the simulator to go on."
);
create_exception!(
    _twin,
    ControllerError,
    TwinError,
    "A Python controller broke its protocol (`update(t, measurements) -> efforts`) or raised; \
     the original exception is its `__cause__`."
);
create_exception!(
    _twin,
    DataError,
    TwinError,
    "A data file that cannot be read or written, or whose columns do not fit the scenario: the \
     message names the file and the row or column."
);
create_exception!(
    _twin,
    CalibrationError,
    TwinError,
    "A comparison or calibration refused or failed: options that contradict each other or name \
     what the scenario lacks, parameters the data cannot determine (the check before the solve), \
     a replay that diverged."
);

create_exception!(
    _twin,
    ShadowError,
    TwinError,
    "A shadow refused or failed: an option naming what the scenario lacks (a signal, a tracked \
     key, an actuator) or out of range, a sample's time that is not a number, or the model \
     failing on the samples (the estimate is lost: start a new shadow)."
);

/// A twin error (building, binding or running a scenario) as a Python exception: the
/// scenario's and model files' mistakes are `ScenarioError`s.
pub fn from_twin(error: twin::TwinError) -> PyErr {
    match error {
        twin::TwinError::Recording(_) | twin::TwinError::Observer(_) => {
            TwinError::new_err(error.to_string())
        }
        _ => ScenarioError::new_err(error.to_string()),
    }
}

pub fn from_scenario(error: twin::ScenarioError) -> PyErr {
    ScenarioError::new_err(error.to_string())
}

/// A data file's refusal as a `DataError`.
pub fn from_data(error: twin::data::DataError) -> PyErr {
    DataError::new_err(error.to_string())
}

/// A comparison's or calibration's refusal: the scenario's, the twin's and the data's as their
/// own exceptions, the rest as `CalibrationError`s.
pub fn from_calibration(error: twin::calibration::CalibrationError) -> PyErr {
    use twin::calibration::CalibrationError as Refused;
    match error {
        Refused::Scenario(error) => from_scenario(error),
        Refused::Twin(error) => from_twin(error),
        Refused::Data(error) => from_data(error),
        other => CalibrationError::new_err(other.to_string()),
    }
}

/// A shadow's refusal or failure: the scenario's as a `ScenarioError`, the rest as
/// `ShadowError`s, the engine's option names (`--track KEY`) put as the keywords that give them.
pub fn from_shadow(error: twin::shadowing::ShadowError) -> PyErr {
    use twin::shadowing::ShadowError as Refused;
    match error {
        Refused::Twin(error) => from_twin(error),
        other => ShadowError::new_err(as_keywords(&other.to_string())),
    }
}

/// The engine's messages name the command line's options; Python's callers give keywords.
fn as_keywords(message: &str) -> String {
    const OPTIONS: [(&str, &str); 7] = [
        ("--track ", "track: "),
        ("--noise ", "noise: "),
        ("--false-alarms ", "false_alarms_per_hour: "),
        ("--learn ", "learn: "),
        ("--latency ", "latency: "),
        ("--process-noise ", "process_noise: "),
        ("signal `", "signals: `"),
    ];
    for (option, keyword) in OPTIONS {
        if let Some(rest) = message.strip_prefix(option) {
            return format!("{keyword}{rest}");
        }
    }
    message.to_string()
}

/// A divergence as a `DivergedError` carrying its figures.
pub fn diverged(py: Python<'_>, failure: &twin::Divergence) -> PyErr {
    let error = DivergedError::new_err(format!("{failure}; reset the simulator to go on"));
    let value = error.value(py);
    let kind = match failure.kind {
        twin::FailureKind::Diverged => "diverged",
        twin::FailureKind::Collision => "collision",
    };
    let described = (|| -> PyResult<()> {
        value.setattr("step", failure.step)?;
        value.setattr("time", failure.time)?;
        value.setattr("signal", failure.signal.as_str())?;
        value.setattr("value", failure.value)?;
        value.setattr("kind", kind)
    })();
    match described {
        Ok(()) => error,
        Err(e) => e,
    }
}

pub fn add_to(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("TwinError", py.get_type::<TwinError>())?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("StepError", py.get_type::<StepError>())?;
    m.add("DivergedError", py.get_type::<DivergedError>())?;
    m.add("ControllerError", py.get_type::<ControllerError>())?;
    m.add("DataError", py.get_type::<DataError>())?;
    m.add("CalibrationError", py.get_type::<CalibrationError>())?;
    m.add("ShadowError", py.get_type::<ShadowError>())
}
