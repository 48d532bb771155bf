"""The twin's FMUs checked by a real FMI client, FMPy 0.3.32 (scripts/test-tools installs it):
the plant alone (`twin fmu --no-controller`) and the closed loop with the scenario's controller
(`twin fmu`, the default), against the twin's own runs (`Twin::run_with` through the examples
closed_run, and `twin run --summary`), never against the FMU itself.

TWIN names the `twin` executable (default: target/release/twin beside libtwin_fmu.so);
`cargo build --release -p twin-cli -p twin-fmu` builds both. Run:
    TWIN=... python -m pytest twin/fmu/tests
"""

import ctypes
import json
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
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")).resolve()
TWIN = pathlib.Path(os.environ.get("TWIN", TARGET / "release" / "twin")).resolve()

# The shipped examples of the generic machine (no `machine`: any planar URDF), by their paths,
# each with a joint its controller moves.
def example(name):
    return str(ROOT / "examples" / name / f"{name}.toml")


DOUBLE_PENDULUM = example("double-pendulum")
EXAMPLES = {
    DOUBLE_PENDULUM: "shoulder.position",
    example("cart-pole"): "cart.position",
    example("slider-crank"): "crank.position",
    example("five-bar"): "left.position",
    example("gantry"): "x.position",
}

MACHINES = [
    "whitworth-crank-pi",
    "arm-milling",
    "platform-path",
    "feed-axis-micromilling",
    "lathe-turning",
    "milling-constant-15000",
    *EXAMPLES,
]


def make_fmu(scenario, folder, *extra):
    kind = "plant" if "--no-controller" in extra else "loop"
    out = folder / f"{pathlib.Path(scenario).stem}-{kind}.fmu"
    subprocess.run([str(TWIN), "fmu", scenario, "--out", str(out), *extra], check=True)
    return out


def plant_fmu(scenario, folder):
    return make_fmu(scenario, folder, "--no-controller")


@pytest.mark.parametrize("scenario", MACHINES)
@pytest.mark.parametrize("kind", [(), ("--no-controller",)], ids=["closed-loop", "plant"])
def test_every_machine_validates(scenario, kind, tmp_path):
    fmu = make_fmu(scenario, tmp_path, *kind)
    assert validate_fmu(str(fmu)) == []
    variables = read_model_description(str(fmu)).modelVariables
    names = [v.name for v in variables]
    inputs = [v.name for v in variables if v.causality == "input"]
    if kind:
        assert all(name.startswith("effort.") for name in inputs) and inputs
    else:
        assert any(name.startswith("disturbance.") for name in inputs)
        assert any(name.startswith("controller.") for name in names)
        assert any(name.startswith("controller.params.") for name in names)


def twin_run(scenario, duration, step_at, effort, folder):
    """The twin's own run of the step (examples/closed_run.rs --step-input, Twin::run_with)."""
    return closed_run(scenario, duration, folder, "--step-input", str(step_at), str(effort))


@pytest.mark.parametrize(
    "scenario, input_name, duration, effort",
    [
        ("feed-axis-micromilling", "effort.table", 0.05, 1.0),
        ("whitworth-crank-pi", "effort.crank", 0.5, 2.0),
    ],
)
def test_a_step_input_matches_the_twins_own_run(scenario, input_name, duration, effort, tmp_path):
    fmu = plant_fmu(scenario, tmp_path)
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
    host = Host(plant_fmu("whitworth-crank-pi", tmp_path), tmp_path, guid="{not-this-one}")
    with pytest.raises(Exception, match="Failed to instantiate"):
        host.slave.instantiate(callbacks=host.callbacks)
    assert host.messages and host.messages[0][0] == 3
    assert "fmuGUID {not-this-one} is not this FMU's" in host.messages[0][1]


def test_a_nan_input_and_a_wrong_step_are_errors_and_the_fmu_goes_on(tmp_path):
    host = Host(plant_fmu("whitworth-crank-pi", tmp_path), tmp_path)
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
    host.slave.terminate()
    host.slave.freeInstance()


def closed_run(scenario, duration, folder, *options):
    """The twin's own closed-loop run (examples/closed_run.rs, through Twin::run_with)."""
    out = folder / "closed.csv"
    subprocess.run(
        ["cargo", "run", "--quiet", "--release", "-p", "twin-fmu", "--example", "closed_run",
         "--", scenario, str(duration), str(out), *options],
        check=True, cwd=ROOT,
    )
    return np.genfromtxt(out, delimiter=",", names=True, deletechars="")


def simulate(fmu, duration, **options):
    """simulate_fmu over every output at the control period."""
    description = read_model_description(str(fmu))
    period = float(description.defaultExperiment.stepSize)
    outputs = [v.name for v in description.modelVariables if v.causality == "output"]
    result = simulate_fmu(str(fmu), stop_time=duration, step_size=period,
                          output_interval=period, output=outputs, **options)
    return result, outputs


def assert_matches(result, outputs, run, first_row=0):
    """The FMU's outputs against the run's to 1e-9 relative: the signals at the same time, the
    controller's efforts and internals after the step that its update began."""
    assert len(result) == len(run)
    np.testing.assert_allclose(result["time"], run["time"], rtol=1e-12, atol=1e-15)
    compared = 0
    for name in outputs:
        if name.startswith(("measured.", "true.")):
            fmu, own = result[name][first_row:], run[name][first_row:]
        else:
            fmu, own = result[name][1:], run[name][:-1]
        np.testing.assert_allclose(fmu, own, rtol=1e-9, atol=0, err_msg=name)
        compared += 1
    assert compared == len(run.dtype.names) - 1, "every column of the run compared"


@pytest.mark.parametrize(
    "scenario, duration",
    [("feed-axis-micromilling", 0.2), ("whitworth-crank-pi", 0.5),
     *[(path, 0.5) for path in EXAMPLES]],
)
def test_the_closed_loop_matches_the_twins_own_run(scenario, duration, tmp_path):
    fmu = make_fmu(scenario, tmp_path)
    result, outputs = simulate(fmu, duration)
    run = closed_run(scenario, duration, tmp_path)
    assert_matches(result, outputs, run)
    moved = {"feed-axis-micromilling": "table.position", "whitworth-crank-pi": "crank.velocity",
             **EXAMPLES}[scenario]
    assert np.ptp(run["measured." + moved]) > 0, "the loop moved nothing"


def test_a_disturbance_matches_a_load_on_the_twins_own_run(tmp_path):
    fmu = make_fmu("feed-axis-micromilling", tmp_path)
    period, load = 1e-4, 5.0
    at = 10 * period  # on a communication point: FMPy applies the value after the step
    signal = np.array([(0.0, 0.0), (at, 0.0), (at, load), (0.05, load)],
                      dtype=[("time", np.float64), ("disturbance.table", np.float64)])
    result, outputs = simulate(fmu, 0.05, input=signal)
    run = closed_run("feed-axis-micromilling", 0.05, tmp_path, "--load", "table", str(at),
                     str(load))
    assert_matches(result, outputs, run)
    plain = closed_run("feed-axis-micromilling", 0.05, tmp_path)
    assert np.max(np.abs(run["true.table.position"] - plain["true.table.position"])) > 1e-9


def test_a_setpoint_matches_the_scenarios_own_reference_offset(tmp_path):
    fmu = make_fmu("feed-axis-micromilling", tmp_path)
    offset = 2.5e-6
    signal = np.array([(0.0, offset), (0.05, offset)],
                      dtype=[("time", np.float64), ("setpoint.reference", np.float64)])
    result, outputs = simulate(fmu, 0.05, input=signal)
    run = closed_run("feed-axis-micromilling", 0.05, tmp_path,
                     "--set", f"reference.offset={offset!r}")
    # The setpoint arrives with the first step: the reference at t = 0 is still the scenario's.
    assert_matches(result, outputs, run, first_row=1)
    assert result["true.reference"][0] == 0.0 and run["true.reference"][0] == offset


def summary(scenario, duration, folder, *options):
    """`twin run --summary`: the figures of the twin's own run."""
    subprocess.run([str(TWIN), "run", scenario, "--duration", str(duration), "--out",
                    str(folder / "run.rrd"), "--summary", str(folder / "run.json"), *options],
                   check=True, capture_output=True)
    return json.loads((folder / "run.json").read_text())["metrics"]


def test_a_parameter_changes_the_result_as_the_same_set_does_in_twin_run(tmp_path):
    fmu = make_fmu("feed-axis-micromilling", tmp_path)
    gain, duration = 60.0, 0.2
    result, outputs = simulate(fmu, duration,
                                  start_values={"controller.params.position_gain": gain})
    error = np.max(np.abs(result["true.table.position"] - result["true.reference"]))
    rate = np.max(np.abs(result["true.table.velocity"] - result["true.reference_rate"]))
    metrics = summary("feed-axis-micromilling", duration, tmp_path,
                      "--set", f"controller.params.position_gain={gain!r}")
    np.testing.assert_allclose(error, metrics["position_error_max"], rtol=1e-9, atol=0)
    np.testing.assert_allclose(rate, metrics["velocity_error_max"], rtol=1e-9, atol=0)
    default = summary("feed-axis-micromilling", duration, tmp_path)
    assert abs(default["position_error_max"] - metrics["position_error_max"]) > 1e-9, \
        "the gain changed nothing"
    run = closed_run("feed-axis-micromilling", duration, tmp_path,
                     "--set", f"controller.params.position_gain={gain!r}")
    assert_matches(result, outputs, run)


def test_a_bad_parameter_is_an_error_with_the_reason_twin_run_gives(tmp_path):
    host = Host(make_fmu("feed-axis-micromilling", tmp_path), tmp_path)
    host.slave.instantiate(callbacks=host.callbacks)
    mass = host.reference("controller.params.mass_estimate")
    with pytest.raises(FMICallException):
        host.slave.setReal([mass], [-1.0])
    status, message = host.messages[-1]
    cli = subprocess.run([str(TWIN), "run", "feed-axis-micromilling", "--set",
                          "controller.params.mass_estimate=-1.0"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert cli.returncode == 1
    reason = cli.stderr.strip().split(": ", 2)[-1]
    assert status == 3 and message.endswith(reason), (message, reason)
    assert reason == "controller.params.mass_estimate = -1: must be > 0"
    assert host.slave.getReal([mass]) == [11.0], "the refused value is not kept"
    host.slave.setupExperiment(startTime=0.0)
    host.slave.enterInitializationMode()
    host.slave.exitInitializationMode()
    with pytest.raises(FMICallException):
        host.slave.setReal([mass], [12.0])
    assert host.messages[-1] == (
        3, "controller.params.mass_estimate is fixed: set it before fmi2ExitInitializationMode")
    host.slave.freeInstance()


def outputs_of(host, steps, loads):
    """Every Real after each of `steps` steps with the load `loads(k)` on the table, as bits."""
    slave, period = host.slave, 1e-4
    table = host.reference("disturbance.table")
    references = [v.valueReference for v in host.description.modelVariables
                  if v.type == "Real" and v.causality == "output"]
    rows = []
    for k in range(steps):
        slave.setReal([table], [loads(k)])
        slave.doStep(host.time, period)
        host.time += period
        rows.append(np.array(slave.getReal(references)).view(np.uint64))
    return np.array(rows)


def test_fmu_state_rollback_is_bit_identical(tmp_path):
    host = Host(make_fmu("feed-axis-micromilling", tmp_path), tmp_path)
    host.start()
    host.time = 0.0
    outputs_of(host, 50, lambda k: 2.0)
    state = host.slave.getFMUstate()
    at = host.time
    first = outputs_of(host, 300, lambda k: -3.0 + 0.01 * k)
    host.slave.setFMUstate(state)
    host.time = at
    again = outputs_of(host, 300, lambda k: -3.0 + 0.01 * k)
    assert np.array_equal(first, again), "bit for bit"
    # The same through a serialized state, and a state freed.
    serialized = host.slave.serializeFMUstate(state)
    host.slave.freeFMUstate(state)
    restored = host.slave.deSerializeFMUstate(serialized)
    host.slave.setFMUstate(restored)
    host.time = at
    assert np.array_equal(first, outputs_of(host, 300, lambda k: -3.0 + 0.01 * k))
    with pytest.raises(FMICallException):
        host.slave.deSerializeFMUstate(serialized[:-1])
    assert "cut short" in host.messages[-1][1]
    host.slave.freeFMUstate(restored)
    host.slave.terminate()
    host.slave.freeInstance()
