"""The machining digital twin from Python.

Three ways in, all in SI units:

* ``Scenario(name).set(key, value).run()`` runs a scenario whole (its own controller, or a
  Python one: ``run(controller=obj)`` with ``obj.update(t, measurements) -> efforts``) and
  returns a :class:`RunResult` with the summary as a dict and every signal as NumPy arrays;
* ``Scenario(name).simulator()`` gives the plant without its controller, stepped one control
  period at a time (``sim.step(efforts) -> measurements``), so a Python loop is the controller;
* ``twin.gym`` registers a Gymnasium environment per machine (``twin/Whitworth-v0``, …).

Errors are exceptions beneath :class:`TwinError` that name the key, actuator or file at fault.
"""

from ._twin import (
    ControllerError,
    DivergedError,
    RunResult,
    Scenario,
    ScenarioError,
    Simulator,
    StepError,
    TwinError,
    controllers,
    scenarios,
)

__all__ = [
    "ControllerError",
    "DivergedError",
    "RunResult",
    "Scenario",
    "ScenarioError",
    "Simulator",
    "StepError",
    "TwinError",
    "controllers",
    "scenarios",
]
