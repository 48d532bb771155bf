"""The machining digital twin from Python.

The ways in, all in SI units:

* ``Scenario(name).set(key, value).run()`` runs a scenario whole (its own controller, or a
  Python one: ``run(controller=obj)`` with ``obj.update(t, measurements) -> efforts``) and
  returns a :class:`RunResult` with the summary as a dict and every signal as NumPy arrays;
* ``Scenario(name).simulator()`` gives the plant without its controller, stepped one control
  period at a time (``sim.step(efforts) -> measurements``), so a Python loop is the controller;
* ``twin.gym`` registers a Gymnasium environment per machine (``twin/Whitworth-v0``, …);
* ``Scenario(name).linearize(at)`` gives the plant's linear model as ``twin linearize`` does.

Against a machine's measured runs (CSV, Parquet or a twin ``.rrd``, as ``RunResult.to_csv`` and
``to_parquet`` write them): ``Scenario(name).compare(path)`` replays a run and reports how far the
twin is from it, per signal; ``twin.calibrate(scenario, paths, fit=[key, …])`` fits scenario
values to runs and returns the estimates with their intervals and the calibrated scenario.

Beside a running machine, with your own transport (MQTT, ROS 2, a historian):
``shadow = Shadow(scenario, signals=[…], track=[key, …])`` takes the machine's samples with their
timestamps (``shadow.command(actuator, t, value)``, ``shadow.measure(signal, t, value)``, late,
out of order or repeated), and ``shadow.advance()`` returns its estimates, residuals and tests;
``shadow.anomalies`` lists the anomalies found, each with the tracked parameter that explains it.

Errors are exceptions beneath :class:`TwinError` that name the key, actuator or file at fault.
"""

from ._twin import (
    CalibrationError,
    ControllerError,
    DataError,
    DivergedError,
    RunResult,
    Scenario,
    ScenarioError,
    Shadow,
    ShadowError,
    Simulator,
    StepError,
    TwinError,
    calibrate,
    controllers,
    scenarios,
)

__all__ = [
    "CalibrationError",
    "ControllerError",
    "DataError",
    "DivergedError",
    "RunResult",
    "Scenario",
    "ScenarioError",
    "Shadow",
    "ShadowError",
    "Simulator",
    "StepError",
    "TwinError",
    "calibrate",
    "controllers",
    "scenarios",
]
