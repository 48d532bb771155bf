"""The twin's FMUs checked by a real FMI client, FMPy 0.3.32 (scripts/test-tools installs it).

TWIN names the `twin` executable (default: target/release/twin beside libtwin_fmu.so);
`cargo build --release -p twin-cli -p twin-fmu` builds both. Run:
    TWIN=... python -m pytest twin/fmu/tests
"""

import ctypes
import os
import pathlib
import subprocess

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu, extract
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

ROOT = pathlib.Path(__file__).resolve().parents[3]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
TWIN = pathlib.Path(os.environ.get("TWIN", TARGET / "release" / "twin"))

MACHINES = [
    "whitworth-crank-pi",
    "arm-milling",
    "platform-path",
    "feed-axis-micromilling",
    "lathe-turning",
    "milling-constant-15000",
]


def make_fmu(scenario, folder, *extra):
    out = folder / f"{scenario}.fmu"
    subprocess.run([str(TWIN), "fmu", scenario, "--out", str(out), *extra], check=True)
    return out


@pytest.mark.parametrize("scenario", MACHINES)
def test_every_machine_validates(scenario, tmp_path):
    fmu = make_fmu(scenario, tmp_path)
    assert validate_fmu(str(fmu)) == []


def twin_run(scenario, duration, step_at, effort, folder):
    """The twin's own run of the step (examples/step_run.rs, through Twin::run_with)."""
    out = folder / "run.csv"
    subprocess.run(
        ["cargo", "run", "--quiet", "--release", "-p", "twin-fmu", "--example", "step_run",
         "--", scenario, str(duration), str(step_at), str(effort), str(out)],
        check=True, cwd=ROOT,
    )
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


@pytest.mark.parametrize(
    "scenario, input_name, duration, effort",
    [
        ("feed-axis-micromilling", "effort.table", 0.05, 1.0),
        ("whitworth-crank-pi", "effort.crank", 0.5, 2.0),
    ],
)
def test_a_step_input_matches_the_twins_own_run(scenario, input_name, duration, effort, tmp_path):
    fmu = make_fmu(scenario, tmp_path)
    description = read_model_description(str(fmu))
    period = float(description.defaultExperiment.stepSize)
    step_at = 10 * period  # on a communication point: FMPy applies the value after the step
    signal = np.array(
        [(0.0, 0.0), (step_at, 0.0), (step_at, effort), (duration, effort)],
        dtype=[("time", np.float64), (input_name, np.float64)],
    )
    outputs = [v.name for v in description.modelVariables if v.name.startswith("measured.")]
    result = simulate_fmu(
        str(fmu), stop_time=duration, step_size=period, output_interval=period,
        input=signal, output=outputs,
    )
    run = twin_run(scenario, duration, step_at, effort, tmp_path)
    assert len(result) == len(run)
    np.testing.assert_allclose(result["time"], run["time"], rtol=1e-12, atol=1e-15)
    moved = False
    for name in outputs:
        np.testing.assert_allclose(result[name], run[name], rtol=1e-9, atol=0, err_msg=name)
        moved |= np.ptp(run[name]) > 0
    assert moved, "the step moved nothing"


class Host:
    """An FMU2Slave with a logger that keeps the messages."""

    def __init__(self, fmu, folder, guid=None):
        description = read_model_description(str(fmu))
        self.description = description
        self.messages = []
        unzipped = extract(str(fmu), str(folder / "unzipped"))
        self.slave = FMU2Slave(
            guid=guid or description.guid, unzipDirectory=unzipped,
            modelIdentifier=description.coSimulation.modelIdentifier, instanceName="test",
        )
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        libc = ctypes.CDLL(None)
        libc.calloc.restype = ctypes.c_void_p
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(libc.calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(libc.free)
        addLoggerProxy(ctypes.byref(callbacks))
        self.callbacks = callbacks

    def _log(self, env, name, status, category, message):
        self.messages.append((status, message.decode()))

    def start(self):
        self.slave.instantiate(callbacks=self.callbacks)
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    def reference(self, name):
        return next(v.valueReference for v in self.description.modelVariables if v.name == name)


def test_a_wrong_guid_is_refused_with_a_reason(tmp_path):
    host = Host(make_fmu("whitworth-crank-pi", tmp_path), tmp_path, guid="{not-this-one}")
    with pytest.raises(Exception, match="Failed to instantiate"):
        host.slave.instantiate(callbacks=host.callbacks)
    assert host.messages and host.messages[0][0] == 3
    assert "fmuGUID {not-this-one} is not this FMU's" in host.messages[0][1]


def test_a_nan_input_and_a_wrong_step_are_errors_and_the_fmu_goes_on(tmp_path):
    host = Host(make_fmu("whitworth-crank-pi", tmp_path), tmp_path)
    host.start()
    crank = host.reference("effort.crank")
    with pytest.raises(FMICallException):
        host.slave.setReal([crank], [float("nan")])
    assert host.messages[-1] == (3, "effort of actuator `crank` is nan: must be a finite number") \
        or host.messages[-1] == (3, "effort of actuator `crank` is NaN: must be a finite number")
    with pytest.raises(FMICallException):
        host.slave.doStep(0.0, 0.0015)
    assert "not a whole multiple of the scenario's control period 0.001 s" in host.messages[-1][1]
    host.slave.setReal([crank], [1.0])
    host.slave.doStep(0.0, 0.002)
    position = host.reference("true.crank.position")
    assert host.slave.getReal([position])[0] != 0.0
    with pytest.raises(FMICallException):
        host.slave.getFMUstate()
    assert "not supported" in host.messages[-1][1]
    host.slave.terminate()
    host.slave.freeInstance()
