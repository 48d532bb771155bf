"""Type hints of the compiled module (twin/python/src)."""

import os
import pathlib
from typing import Any, Callable, Mapping, Protocol, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

Value = Union[bool, int, float, str, Sequence["Value"], dict[str, "Value"]]
Efforts = Union[npt.NDArray[np.float64], Sequence[float], float]
Path = Union[str, os.PathLike[str]]
Array = npt.NDArray[np.float64]

class TwinError(Exception): ...
class ScenarioError(TwinError): ...
class StepError(TwinError): ...

class DivergedError(StepError):
    step: int
    time: float
    signal: str
    value: float
    kind: str

class ControllerError(TwinError): ...
class DataError(TwinError): ...
class CalibrationError(TwinError): ...

class Controller(Protocol):
    def update(self, t: float, measurements: npt.NDArray[np.float64]) -> Efforts: ...

def scenarios() -> list[str]: ...
def controllers() -> list[tuple[str, str, str]]: ...
def engine_step_seconds(scenario: Scenario, steps: int) -> float: ...

class Comparison(TypedDict):
    """`Scenario.compare`'s result."""

    #: As `twin compare` writes comparison.json: `data`, `sha256`, `closed_loop`, `samples`,
    #: `control_period_s`, `data_rate`, and `signals`, per signal `signal`, `unit`,
    #: `fit_percent`, `rms_error`, `max_error`, `whiteness`.
    report: dict[str, Any]
    #: The control-period grid the run was compared on, s.
    time: Array
    measured: dict[str, Array]
    simulated: dict[str, Array]
    units: dict[str, str]

class RunSeries(TypedDict):
    """One run of a calibration: its file and, per fitted signal, the series."""

    data: str
    time: Array
    units: dict[str, str]
    measured: dict[str, Array]
    #: The twin with the start values.
    before: dict[str, Array]
    #: The twin with the fitted values.
    after: dict[str, Array]

class Calibration(TypedDict):
    """`calibrate`'s result."""

    #: As `twin calibrate` writes calibration.json: `parameters` (per estimate `key`, `run`,
    #: `start`, `estimate`, `standard_error`, `interval`, `bounds`, `at_bound`), `correlation`,
    #: `runs` and `validation` (per run `data`, `sha256`, `data_rate`, and the fits `before` and
    #: `after`), `iterations`, `best_start`, `converged`, `warnings`, `noise`,
    #: `residual_variance`, `degrees_of_freedom`, `segments`, `start_states`, `rollouts`.
    report: dict[str, Any]
    #: The scenario with the shared estimates set, headed by comments giving their intervals.
    calibrated_toml: str
    #: The same, as a scenario to run.
    scenario: Scenario
    runs: list[RunSeries]
    validation: list[RunSeries]

def calibrate(
    scenario: Union[Scenario, Path],
    data: Union[Path, Sequence[Path], None] = None,
    *,
    fit: Union[str, Sequence[str], Mapping[str, Union[float, None]], None] = None,
    bounds: Union[Mapping[str, tuple[float, float]], None] = None,
    per_run: Union[str, Sequence[str], None] = None,
    validate: Union[Path, Sequence[Path], None] = None,
    signals: Union[str, Sequence[str], None] = None,
    noise: Union[Mapping[str, float], None] = None,
    segment: Union[float, None] = None,
    states: Union[str, Sequence[str], None] = None,
    closed_loop: bool = False,
    starts: Union[int, None] = None,
    max_iterations: int = 50,
    threads: int = 0,
    map: Union[Mapping[str, str], None] = None,
    progress: Union[Callable[[int, float, float], object], None] = None,
) -> Calibration: ...

class Scenario:
    def __init__(self, name_or_path: Union[str, os.PathLike[str]]) -> None: ...
    def set(self, key: str, value: Value) -> Scenario: ...
    def controller(self, name: str) -> Scenario: ...
    def duration(self, seconds: float) -> Scenario: ...
    def seed(self, seed: int) -> Scenario: ...
    def engine(self, engine: str) -> Scenario: ...
    @property
    def name(self) -> str: ...
    @property
    def machine(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def controller_name(self) -> str: ...
    @property
    def end_time(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def control_period(self) -> float: ...
    @property
    def signals(self) -> list[str]: ...
    @property
    def actuators(self) -> list[str]: ...
    @property
    def toml(self) -> str: ...
    def simulator(self) -> Simulator: ...
    def run(
        self,
        record: Union[str, os.PathLike[str], None] = None,
        controller: Union[Controller, None] = None,
    ) -> RunResult: ...
    def compare(
        self,
        data: Path,
        *,
        closed_loop: bool = False,
        map: Union[Mapping[str, str], None] = None,
    ) -> Comparison: ...

class Simulator:
    def reset(self, seed: Union[int, None] = None) -> npt.NDArray[np.float64]: ...
    def step(self, efforts: Efforts) -> npt.NDArray[np.float64]: ...
    @property
    def time(self) -> float: ...
    @property
    def control_period(self) -> float: ...
    @property
    def end_time(self) -> float: ...
    @property
    def signals(self) -> list[str]: ...
    @property
    def units(self) -> list[str]: ...
    @property
    def actuators(self) -> list[str]: ...
    @property
    def effort_limits(self) -> npt.NDArray[np.float64]: ...
    @property
    def effort_units(self) -> list[str]: ...
    @property
    def diagnostic_names(self) -> list[str]: ...
    @property
    def diagnostic_units(self) -> list[str]: ...
    @property
    def diagnostics(self) -> npt.NDArray[np.float64]: ...
    @property
    def measured(self) -> npt.NDArray[np.float64]: ...
    @property
    def true_signals(self) -> npt.NDArray[np.float64]: ...

class RunResult:
    summary: dict[str, Any]
    metrics: dict[str, float]
    failure: Union[str, None]
    time: npt.NDArray[np.float64]
    signals: dict[str, npt.NDArray[np.float64]]
    measured: dict[str, npt.NDArray[np.float64]]
    commanded: dict[str, npt.NDArray[np.float64]]
    efforts: dict[str, npt.NDArray[np.float64]]
    internals: dict[str, npt.NDArray[np.float64]]
    diagnostics: dict[str, npt.NDArray[np.float64]]
    units: dict[str, str]
    command_units: dict[str, str]
    effort_units: dict[str, str]
    internal_units: dict[str, str]
    diagnostic_units: dict[str, str]
    recording: Union[pathlib.Path, None]
    @property
    def ok(self) -> bool: ...
    def to_csv(self, path: Path) -> None: ...
    def to_parquet(self, path: Path) -> None: ...
