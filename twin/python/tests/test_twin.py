"""The Python package against the twin's own runs: the command line's summary, the built-in
controllers' recorded efforts replayed through a Python controller and through the step API, and
every bad input against its exception. Run by scripts/test after `pip install ./twin/python`."""

import json
import math
import os
import runpy
import signal
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

import twin


def test_lists_the_scenarios_and_controllers():
    assert "whitworth-crank-pi" in twin.scenarios()
    assert len(twin.scenarios()) >= 15
    names = {name for name, _, _ in twin.controllers()}
    assert {"crank-pi", "p-pi", "stsmc"} <= names


def test_a_scenario_describes_itself():
    s = twin.Scenario("feed-axis-micromilling").duration(0.5)
    assert (s.name, s.machine, s.controller_name) == ("feed-axis-micromilling", "feed_axis", "p-pi")
    assert s.end_time == 0.5 and s.dt == 1e-4 and s.control_period == 1e-4
    assert s.actuators == ["table"]
    assert "table.position" in s.signals and "reference" in s.signals
    assert "duration = 0.5" in s.toml


def test_the_generic_machine_runs_a_shipped_example_from_its_path():
    """A scenario with no `machine` (the double pendulum of examples/): its joints, its point
    and its efforts, and joint-pid holding the targets."""
    path = Path(__file__).resolve().parents[3] / "examples" / "double-pendulum" / "double-pendulum.toml"
    s = twin.Scenario(str(path)).duration(2.0)
    assert (s.machine, s.controller_name) == ("generic", "joint-pid")
    assert s.actuators == ["shoulder", "elbow"]
    assert {"shoulder.position", "elbow.velocity", "tip.x", "tip.vy"} <= set(s.signals)
    result = s.run()
    assert abs(result.summary["metrics"]["controller_final/shoulder.error"]) < 0.01


EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
# Every shipped example's scenarios but replay.toml, which reads a run the guide makes first.
EXAMPLE_SCENARIOS = sorted(p for p in EXAMPLES.glob("*/*.toml") if p.stem != "replay")


@pytest.mark.parametrize("path", EXAMPLE_SCENARIOS, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_every_shipped_example_runs_through_python_as_through_the_command_line(
        path, tmp_path, twin_cli):
    """Each example of the generic machine (trees, loops, a contact, springs, lqr's design and
    computed-torque's equations) by its path: the same figures and recorded series as
    `twin run`."""
    result = twin.Scenario(str(path)).duration(1.0).run(record=tmp_path / "py.rrd")
    subprocess.run(
        [twin_cli, "run", str(path), "--duration", "1.0", "--out", str(tmp_path / "cli.rrd"),
         "--summary", str(tmp_path / "cli.json")],
        check=True, capture_output=True,
    )
    cli = json.loads((tmp_path / "cli.json").read_text())
    assert result.ok and result.summary["status"] == cli["status"] == "ok"
    assert result.summary["series_digest"] == cli["series_digest"]
    assert result.summary["metrics"] == cli["metrics"]


@pytest.mark.parametrize("name", ["double-pendulum", "cart-pole", "slider-crank", "five-bar",
                                  "gantry"])
def test_each_example_linearises_through_python_as_through_the_command_line(
        name, tmp_path, twin_cli):
    """`Scenario.linearize()` is `twin linearize`'s linear.json, its matrices as NumPy arrays:
    the same numbers, bit for bit, on every shipped example (trees, loops, a contact)."""
    path = EXAMPLES / name / f"{name}.toml"
    model = twin.Scenario(str(path)).linearize(at=0.5)
    subprocess.run([twin_cli, "linearize", str(path), "--at", "0.5", "--out-dir",
                    str(tmp_path / "lin")], check=True, capture_output=True)
    cli = json.loads((tmp_path / "lin" / "linear.json").read_text())
    for key in ("A", "B", "C", "D", "Ad", "Bd", "poles"):
        assert isinstance(model[key], np.ndarray)
        assert np.array_equal(model[key], np.array(cli[key])), key
    assert [s["name"] for s in model["states"]] == [s["name"] for s in cli["states"]]
    assert model["operating_point"] == cli["operating_point"]
    with pytest.raises(twin.ScenarioError, match="at: "):
        twin.Scenario(str(path)).linearize(at=-1.0)


@pytest.mark.parametrize("name", ["double-pendulum", "cart-pole", "slider-crank", "five-bar",
                                  "gantry"])
def test_each_example_exports_through_python_the_command_lines_fmu(name, tmp_path, twin_cli):
    """`Scenario.fmu()` is `twin fmu`: the same .fmu, byte for byte, for the closed loop and for
    the plant alone, on every shipped example."""
    path = EXAMPLES / name / f"{name}.toml"
    library = Path(twin_cli).with_name("libtwin_fmu.so")
    for flags, plant_alone in (([], False), (["--no-controller"], True)):
        packed = twin.Scenario(str(path)).fmu(tmp_path / "py.fmu", plant_alone=plant_alone,
                                              library=library)
        subprocess.run([twin_cli, "fmu", str(path), "--out", str(tmp_path / "cli.fmu"), *flags],
                       check=True, capture_output=True)
        assert (tmp_path / "py.fmu").read_bytes() == (tmp_path / "cli.fmu").read_bytes()
        assert packed["bytes"] == (tmp_path / "py.fmu").stat().st_size
        assert (packed["controller"] is None) == plant_alone
        assert packed["model_identifier"] and packed["guid"]


def test_an_fmu_without_its_library_is_refused_naming_it(tmp_path, monkeypatch):
    monkeypatch.delenv("TWIN_FMU_LIBRARY", raising=False)
    s = twin.Scenario(str(EXAMPLES / "cart-pole" / "cart-pole.toml"))
    with pytest.raises(twin.ScenarioError, match="library: give the built twin-fmu"):
        s.fmu(tmp_path / "a.fmu")
    with pytest.raises(twin.ScenarioError, match="library: FMU library .*missing.so"):
        s.fmu(tmp_path / "a.fmu", library=tmp_path / "missing.so")
    assert list(tmp_path.iterdir()) == []


def test_a_run_matches_the_command_line(tmp_path, twin_cli):
    """The same scenario and --set through Python and through `twin run`: same figures, same
    recorded series (digest), the recording written where asked."""
    s = twin.Scenario("whitworth-crank-pi").set("controller.params.crank_speed", -6.0).duration(1.0)
    result = s.run(record=tmp_path / "py.rrd")
    subprocess.run(
        [twin_cli, "run", "whitworth-crank-pi", "--set", "controller.params.crank_speed=-6.0",
         "--duration", "1.0", "--out", str(tmp_path / "cli.rrd"),
         "--summary", str(tmp_path / "cli.json")],
        check=True, capture_output=True,
    )
    cli = json.loads((tmp_path / "cli.json").read_text())
    assert result.ok and result.failure is None
    assert result.summary["series_digest"] == cli["series_digest"]
    assert result.summary["metrics"] == cli["metrics"]
    assert (tmp_path / "py.rrd").stat().st_size > 10_000
    assert str(result.recording) == str(tmp_path / "py.rrd")


def test_a_result_carries_every_series_in_si():
    s = twin.Scenario("whitworth-crank-pi").duration(0.5).set("recording.every", 1)
    r = s.run()
    assert len(r.time) == 501 and r.time[-1] == pytest.approx(0.5)
    assert r.units["ram_position"] == "m" and r.units["crank.velocity"] == "rad/s"
    assert r.effort_units == r.command_units == {"crank": "N·m"}
    assert set(r.signals) == set(r.measured) == set(s.signals)
    assert all(len(v) == 501 for v in r.signals.values())
    # The ram stays on its stroke (a metre-scale number, not millimetres).
    assert 0.0 < np.ptp(r.signals["ram_position"]) < 1.0
    # The crank PI holds the crank turning at a steady speed (rad/s).
    speed = r.signals["crank.velocity"][-100:]
    assert abs(np.mean(speed)) > 1.0 and np.std(speed) < 0.2 * abs(np.mean(speed))
    assert r.metrics == {k: v for k, v in r.summary["metrics"].items()}


class Replay:
    """A Python controller that repeats a run's commanded efforts, one per control update."""

    def __init__(self, efforts):
        self.efforts = efforts
        self.k = 0
        self.reset_calls = 0

    def reset(self):
        self.reset_calls += 1
        self.k = 0

    def update(self, t, measurements):
        assert isinstance(measurements, np.ndarray) and measurements.dtype == np.float64
        effort = self.efforts[:, self.k]
        self.k += 1
        return effort


def built_in_run(name, duration):
    s = twin.Scenario(name).duration(duration).set("recording.every", 1)
    return s, s.run()


@pytest.mark.parametrize("name", ["feed-axis-micromilling", "whitworth-tracking"])
def test_a_python_controller_replaying_the_built_in_one_runs_the_same_plant(name):
    """The built-in controller's commanded efforts, handed back by a Python controller, give the
    plant bit for bit the same run (sensor noise included)."""
    s, reference = built_in_run(name, 0.3)
    efforts = np.array([reference.commanded[a] for a in s.actuators])
    replay = Replay(efforts)
    mine = s.run(controller=replay)
    assert replay.reset_calls == 1
    assert mine.summary["controller"] == "python:Replay"
    for signal in s.signals:
        np.testing.assert_array_equal(mine.signals[signal], reference.signals[signal])
        np.testing.assert_array_equal(mine.measured[signal], reference.measured[signal])


@pytest.mark.parametrize("name", ["feed-axis-micromilling", "whitworth-tracking", "lathe-turning"])
def test_the_step_api_replaying_a_run_measures_what_the_run_measured(name):
    s, reference = built_in_run(name, 0.2)
    sim = s.simulator()
    first = sim.reset()
    every = int(round(s.control_period / s.dt))
    np.testing.assert_array_equal(first, [reference.measured[n][0] for n in sim.signals])
    updates = len(reference.time[::every]) - 1
    for k in range(updates):
        efforts = [reference.commanded[a][k * every] for a in sim.actuators]
        measured = sim.step(np.array(efforts))
        expected = [reference.measured[n][(k + 1) * every] for n in sim.signals]
        np.testing.assert_array_equal(measured, expected)
    assert sim.time == pytest.approx(updates * s.control_period)


def test_the_simulator_describes_its_plant():
    sim = twin.Scenario("arm-milling").simulator()
    assert sim.actuators == ["shoulder", "elbow", "wrist"]
    # The arm's drives take a current, clipped at their 20 A protection (not at the joints'
    # 84, 60 and 20 N·m); the feed axis's table a force.
    assert sim.effort_units == ["A", "A", "A"]
    np.testing.assert_array_equal(sim.effort_limits, [20.0, 20.0, 20.0])
    table = twin.Scenario("feed-axis-micromilling").simulator()
    assert table.effort_units == ["N"]
    np.testing.assert_array_equal(table.effort_limits, [500.0])
    assert len(sim.units) == len(sim.signals)
    assert sim.time == 0.0 and sim.control_period == 1e-3


def test_reset_with_a_seed_repeats_the_sensor_noise():
    s = twin.Scenario("whitworth-tracking").set('sensors."ram_position".noise', 1e-5)
    sim = s.simulator()
    def episode(seed):
        sim.reset(seed=seed)
        return np.array([sim.step([0.5]) for _ in range(50)])
    a, b, c = episode(7), episode(7), episode(8)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


# Bad input, each against its exception and message.

def test_an_unknown_scenario_is_named():
    with pytest.raises(twin.ScenarioError, match="no-such-scenario"):
        twin.Scenario("no-such-scenario")


def test_a_bad_value_names_its_key():
    s = twin.Scenario("whitworth-crank-pi")
    with pytest.raises(twin.ScenarioError, match="crank_speed"):
        s.set("controller.params.crank_speed", "fast")
    with pytest.raises(twin.ScenarioError, match="duration"):
        s.duration(-1.0)
    with pytest.raises(twin.ScenarioError, match="controller.params.gain.*object"):
        s.set("controller.params.gain", object())
    with pytest.raises(twin.ScenarioError, match="no-such-controller"):
        s.controller("no-such-controller")
    with pytest.raises(twin.ScenarioError, match="engine"):
        s.engine("mujoco")
    with pytest.raises(twin.ScenarioError, match="no_such_gain"):
        s.set("controller.params.no_such_gain", 1.0)
    # The machine's own tables are checked at the change too, not first at the run.
    with pytest.raises(twin.ScenarioError, match="process.*`nothing`"):
        s.set("process.nothing", 1.0)
    # The scenario a failed change started from is unchanged.
    assert s.end_time == 10.0


def test_efforts_of_the_wrong_length_or_not_finite_name_the_actuator():
    sim = twin.Scenario("feed-axis-micromilling").simulator()
    with pytest.raises(twin.StepError, match="2 values given for 1 actuators \\(table\\)"):
        sim.step([1.0, 2.0])
    with pytest.raises(twin.StepError, match="`table` is NaN"):
        sim.step([math.nan])
    with pytest.raises(twin.StepError, match="str"):
        sim.step("ten")
    assert sim.time == 0.0
    sim.step([1.0])
    assert sim.time == pytest.approx(1e-4)


def test_a_divergence_raises_with_its_figures_until_a_reset():
    s = twin.Scenario("whitworth-crank-pi").set("health.max_joint_speed", 0.5)
    sim = s.simulator()
    sim.reset()
    with pytest.raises(twin.DivergedError) as failure:
        for _ in range(1000):
            sim.step([sim.effort_limits[0]])
    assert failure.value.kind == "diverged" and failure.value.time > 0
    assert "velocity" in failure.value.signal and abs(failure.value.value) > 0.5
    with pytest.raises(twin.DivergedError):
        sim.step([0.0])
    sim.reset()
    sim.step([0.0])


class Broken:
    def __init__(self, reply=None, fail_at=None):
        self.reply, self.fail_at = reply, fail_at

    def update(self, t, measurements):
        if self.fail_at is not None and t >= self.fail_at:
            raise RuntimeError("my controller broke")
        return self.reply


def test_a_python_controller_that_raises_stops_the_run_and_keeps_its_recording(tmp_path):
    s = twin.Scenario("feed-axis-micromilling").duration(0.2)
    with pytest.raises(twin.ControllerError, match="python:Broken.*my controller broke") as failure:
        s.run(record=tmp_path / "broken.rrd", controller=Broken([0.0], fail_at=0.05))
    assert isinstance(failure.value.__cause__, RuntimeError)
    assert (tmp_path / "broken.rrd").stat().st_size > 1000


def test_a_python_controller_with_a_bad_reply_is_named():
    s = twin.Scenario("feed-axis-micromilling").duration(0.05)
    with pytest.raises(twin.ControllerError, match="2 efforts .* 1 actuators \\(table\\)"):
        s.run(controller=Broken([1.0, 2.0]))
    with pytest.raises(twin.ControllerError, match="inf for actuator `table`"):
        s.run(controller=Broken([math.inf]))
    with pytest.raises(twin.ControllerError, match="not a sequence"):
        s.run(controller=Broken({"table": 1.0}))
    with pytest.raises(twin.ControllerError, match="update"):
        s.run(controller=object())


def test_ctrl_c_stops_a_run_and_keeps_its_recording(tmp_path):
    # Python's own Ctrl-C handler, even where the test runner was started with SIGINT ignored (a
    # shell's background job): the test is about the run's answer to it.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    # 300 s of simulated time: seconds of work, stopped after 0.3 s.
    s = twin.Scenario("feed-axis-micromilling").duration(300.0)
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            s.run(record=tmp_path / "stopped.rrd")
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert (tmp_path / "stopped.rrd").stat().st_size > 1000


def test_the_guides_example_pd_in_python_against_the_built_in_p_pi():
    """The guide's worked example (twin/python/examples/feed_axis_pd.py) over the paper's 25 s."""
    example = runpy.run_path(str(Path(__file__).parents[1] / "examples" / "feed_axis_pd.py"))
    figures = example["compare"](25.0)
    p_pi, pd = figures["P-PI (built in)"], figures["PD (Python)"]
    # The built-in P-PI keeps its Table I σ (the feed axis's chapter: 0.0325 µm).
    assert p_pi[1] == pytest.approx(0.0325e-6, rel=0.01)
    # Poles at 2π·50 Hz with the reference fed forward: a far smaller error for more force.
    assert pd[0] < p_pi[0] / 10 and pd[1] < p_pi[1] / 10 and pd[2] > p_pi[2]


def test_the_guides_python_example_runs(tmp_path, monkeypatch):
    """The guide's block of the three ways in (docs/src/python.md) runs as written."""
    chapter = (Path(__file__).parents[3] / "docs" / "src" / "python.md").read_text()
    section = chapter.split("## Three ways in", 1)[1].split("\n## ", 1)[0]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()  # as the guide's Getting started makes it
    scope = {}
    exec(compile(code, "docs/src/python.md", "exec"), scope)
    assert scope["r"].ok and scope["r"].summary["controller"] == "python:Hold"
    assert (tmp_path / "out" / "crank.rrd").stat().st_size > 10_000
    assert scope["sim"].time == pytest.approx(1.0)
