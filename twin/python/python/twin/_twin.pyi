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
class ShadowError(TwinError): ...

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
    #: The columns the scenario does not know, left out: one line per file that had some.
    notes: list[str]

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
    #: The columns the scenario does not know, left out: one line per file that had some.
    notes: list[str]

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
    rename: Union[Mapping[str, str], None] = None,
    delimiter: Union[str, None] = None,
    strict: bool = False,
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
    def linearize(self, at: float = 0.0) -> dict[str, Any]: ...
    def fmu(
        self,
        path: Union[str, os.PathLike[str]],
        *,
        plant_alone: bool = False,
        library: Union[str, os.PathLike[str], None] = None,
    ) -> dict[str, Any]: ...
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
        rename: Union[Mapping[str, str], None] = None,
        delimiter: Union[str, None] = None,
        strict: bool = False,
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

class Attribution(TypedDict):
    """The tracked parameter named as an anomaly's cause."""

    parameter: str
    #: Its estimate at the anomaly's start, SI.
    before: float
    #: Its estimate now (or at the anomaly's end), SI.
    estimate: float
    #: The estimate's 95 % interval, SI.
    interval: tuple[float, float]
    #: How far it moved, in its standard deviations.
    shift_sigmas: float

class Anomaly(TypedDict):
    """A stretch of time in which the machine stopped behaving like its model (times in s since
    the shadow's first sample)."""

    #: The signals whose tests alarmed, and the parameters that drifted.
    signals: list[str]
    #: The change point the tests place its start at.
    start: float
    detected: float
    #: None while it lasts.
    end: Union[float, None]
    #: The largest standardised shift of an innovation, σ of a healthy block mean.
    size: float
    attribution: Union[Attribution, None]

class AnomalyChange(Anomaly):
    """An anomaly that opened or closed at a step."""

    #: `"opened"` or `"closed"`.
    kind: str

class ShadowTests(TypedDict):
    """The detector's statistics, each in units of its threshold (alarm above 1)."""

    cusum: dict[str, float]
    nis: float
    drift: dict[str, float]

class ShadowStep(TypedDict):
    """What one processed measurement time gave (`Shadow.advance`, `Shadow.flush`)."""

    #: s since the first sample.
    time: float
    #: s on the source's clock.
    source_time: float
    #: The signals measured at this time, SI.
    measured: dict[str, float]
    #: What the model predicted for them before the update.
    predicted: dict[str, float]
    #: Measured less predicted.
    residual: dict[str, float]
    #: The residual over its predicted standard deviation.
    normalised: dict[str, float]
    #: Every watched signal as the corrected estimate gives it.
    estimate: dict[str, float]
    #: Each tracked parameter's (estimate, σ), SI.
    parameters: dict[str, tuple[float, float]]
    tests: ShadowTests
    #: Whether an anomaly is open.
    alarm: bool
    #: Whether the detector is still learning the healthy statistics.
    learning: bool
    change: Union[AnomalyChange, None]

class ShadowCounts(TypedDict):
    processed: int
    late: int
    duplicate: int
    reordered: int

class ShadowThresholds(TypedDict):
    cusum: float
    nis: float
    drift: float

class Shadow:
    def __init__(
        self,
        scenario: Union[Scenario, Path],
        *,
        signals: Union[str, Sequence[str]],
        track: Union[
            str,
            Sequence[Union[str, tuple[str, Union[float, None]]]],
            Mapping[str, Union[float, None]],
            None,
        ] = None,
        false_alarms_per_hour: float = 0.1,
        learn: float = 5.0,
        latency: float = 0.25,
        noise: Union[Mapping[str, float], None] = None,
        process_noise: Union[float, None] = None,
        set: Union[Mapping[str, Value], None] = None,
    ) -> None: ...
    @staticmethod
    def watchable(scenario: Union[Scenario, Path]) -> list[str]: ...
    def command(self, actuator: str, t: float, value: float) -> None: ...
    def measure(self, signal: str, t: float, value: float) -> None: ...
    def advance(self) -> list[ShadowStep]: ...
    def flush(self) -> list[ShadowStep]: ...
    @property
    def anomalies(self) -> list[Anomaly]: ...
    @property
    def estimates(self) -> dict[str, tuple[float, float]]: ...
    @property
    def counts(self) -> ShadowCounts: ...
    @property
    def thresholds(self) -> Union[ShadowThresholds, None]: ...
    @property
    def watched(self) -> list[str]: ...
    @property
    def parameters(self) -> list[str]: ...
    @property
    def actuators(self) -> list[str]: ...
    @property
    def units(self) -> dict[str, str]: ...
    @property
    def command_units(self) -> dict[str, str]: ...
    @property
    def origin(self) -> Union[float, None]: ...
    @property
    def newest(self) -> Union[float, None]: ...
