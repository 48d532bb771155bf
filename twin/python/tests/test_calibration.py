"""The twin against measured runs from Python: a run's table written as `twin run --csv` and
`--parquet` write it, replayed by `Scenario.compare`, and a hidden mass found again by
`twin.calibrate`; every bad input against its exception and message."""

import subprocess
from pathlib import Path

import numpy as np
import pytest

import twin

RAM_MASS = "urdf.link.ram.mass"


def whitworth(seconds):
    """The crank-speed loop with an ideal crank encoder: its 10,000 counts per turn would be noise
    that the noise-free recoveries below do not want."""
    s = twin.Scenario("whitworth-crank-pi").duration(seconds)
    return s.set('sensors."crank.position".resolution', 0.0)


def one_line(error):
    message = str(error.value)
    assert message and "\n" not in message, message
    return message


def test_a_run_written_to_csv_is_replayed_at_a_100_percent_fit(tmp_path):
    s = whitworth(2.0)
    r = s.run()
    r.to_csv(tmp_path / "run.csv")
    c = s.compare(tmp_path / "run.csv")
    assert set(c) == {"report", "time", "measured", "simulated", "units", "notes"}
    assert c["notes"] == []
    report = c["report"]
    assert report["data"] == str(tmp_path / "run.csv") and not report["closed_loop"]
    assert report["samples"] == len(c["time"]) == 2001 and report["control_period_s"] == 1e-3
    np.testing.assert_allclose(c["time"], np.arange(2001) * 1e-3, rtol=0, atol=1e-12)
    fits = {fit["signal"]: fit for fit in report["signals"]}
    assert {"crank.velocity", "ram_position"} <= set(fits) == set(c["measured"])
    for name, fit in fits.items():
        assert fit["fit_percent"] > 99.999, (name, fit)
        assert fit["unit"] == c["units"][name] == r.units[name]
        assert set(fit) >= {"rms_error", "max_error", "whiteness"}
    # The table holds what the controller measured, at each control update (here every step).
    for name in c["measured"]:
        np.testing.assert_array_equal(c["measured"][name], r.measured[name])
    assert np.ptp(c["simulated"]["ram_position"]) > 0.1


def test_to_csv_and_to_parquet_write_what_twin_run_writes(tmp_path, twin_cli):
    s = whitworth(0.5)
    r = s.run()
    r.to_csv(tmp_path / "py.csv")
    r.to_parquet(str(tmp_path / "py.parquet"))
    subprocess.run(
        [twin_cli, "run", "whitworth-crank-pi", "--duration", "0.5",
         "--set", 'sensors."crank.position".resolution=0',
         "--out", str(tmp_path / "cli.rrd"),
         "--csv", str(tmp_path / "cli.csv"), "--parquet", str(tmp_path / "cli.parquet")],
        check=True, capture_output=True,
    )
    for kind in ["csv", "parquet"]:
        assert (tmp_path / f"py.{kind}").read_bytes() == (tmp_path / f"cli.{kind}").read_bytes()
    header = (tmp_path / "py.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["time [s]", "effort.crank [N·m]", "crank.position [rad]"]
    assert "true.ram_position [m]" in header
    # Read back by the twin, the Parquet file holds the CSV file's values, bit for bit.
    from_csv = s.compare(tmp_path / "py.csv")
    from_parquet = s.compare(tmp_path / "py.parquet")
    np.testing.assert_array_equal(from_csv["time"], from_parquet["time"])
    for part in ["measured", "simulated"]:
        assert from_csv[part].keys() == from_parquet[part].keys()
        for name, values in from_csv[part].items():
            np.testing.assert_array_equal(values, from_parquet[part][name])
    assert from_csv["report"]["signals"] == from_parquet["report"]["signals"]


def test_calibrate_finds_a_hidden_ram_mass(tmp_path):
    """The ram's mass hidden in a run (6.2 kg, the scenario says 5 kg), fitted back to 1e-6
    relative from the nominal scenario; a second run with a slower crank validates it."""
    hidden = 6.2
    whitworth(1.5).set(RAM_MASS, hidden).run().to_csv(tmp_path / "fit.csv")
    slower = whitworth(1.0).set(RAM_MASS, hidden).set("controller.params.crank_speed", -3.0)
    slower.run().to_parquet(tmp_path / "validate.parquet")
    steps = []
    result = twin.calibrate(
        whitworth(1.5), tmp_path / "fit.csv", fit={RAM_MASS: None},
        validate=[tmp_path / "validate.parquet"], progress=lambda *step: steps.append(step),
    )
    report = result["report"]
    [estimate] = report["parameters"]
    assert estimate["key"] == RAM_MASS and estimate["start"] == 5.0
    assert abs(estimate["estimate"] - hidden) <= 1e-6 * hidden, estimate
    assert not estimate["at_bound"] and estimate["run"] is None
    lo, hi = estimate["interval"]
    assert lo <= estimate["estimate"] <= hi and estimate["standard_error"] >= 0
    assert report["correlation"] == [[pytest.approx(1.0)]]
    assert report["converged"] and report["warnings"] == []
    [run] = report["runs"]
    assert run["data"] == str(tmp_path / "fit.csv")
    for before, after in zip(run["before"], run["after"]):
        assert after["fit_percent"] > 99.999 and after["fit_percent"] > before["fit_percent"]
    [validation] = report["validation"]
    assert all(fit["fit_percent"] > 99.9 for fit in validation["after"])
    # The progress saw every accepted step, the cost falling.
    assert [i for i, _, _ in steps] == list(range(len(steps))) and len(steps) >= 2
    assert steps[-1][1] < steps[0][1]
    assert [(i["iteration"], i["cost"]) for i in report["iterations"]] == [s[:2] for s in steps]
    # The series beside the report, and the calibrated scenario as TOML and to run.
    [series] = result["runs"]
    assert series["measured"].keys() == series["after"].keys() == series["units"].keys()
    assert len(series["time"]) == len(series["after"]["ram_position"]) == 1501
    assert f"{RAM_MASS} = {estimate['estimate']!r}" in result["calibrated_toml"]
    assert len(result["validation"]) == 1
    rerun = result["scenario"].run()
    truth = whitworth(1.5).set(RAM_MASS, hidden).run()
    np.testing.assert_allclose(rerun.signals["ram_position"], truth.signals["ram_position"],
                               rtol=0, atol=1e-9)


def test_calibrate_takes_a_scenario_by_name_and_a_start(tmp_path):
    whitworth(1.0).set(RAM_MASS, 4.0).run().to_csv(tmp_path / "run.csv")
    result = twin.calibrate("whitworth-crank-pi", str(tmp_path / "run.csv"), fit={RAM_MASS: 4.5},
                            bounds={RAM_MASS: (1.0, 10.0)}, states="auto", threads=1)
    [estimate] = result["report"]["parameters"]
    assert estimate["start"] == 4.5 and estimate["bounds"] == [1.0, 10.0]
    # The named scenario's crank encoder quantises: close, not exact.
    assert estimate["estimate"] == pytest.approx(4.0, rel=0.02)


# Bad input, each against its exception and a one-line message naming it.

def test_a_missing_or_unreadable_data_file_is_named(tmp_path):
    s = whitworth(0.5)
    with pytest.raises(twin.DataError) as error:
        s.compare(tmp_path / "no-such-run.csv")
    assert "no-such-run.csv" in one_line(error)
    (tmp_path / "run.txt").write_text("time [s]\n0\n")
    with pytest.raises(twin.DataError, match=r"run\.txt.*\.csv, \.parquet or \.rrd") as error:
        s.compare(tmp_path / "run.txt")
    one_line(error)
    with pytest.raises(twin.DataError) as error:
        twin.calibrate(s, [tmp_path / "no-such-run.parquet"], fit=RAM_MASS)
    assert "no-such-run.parquet" in one_line(error)
    with pytest.raises(twin.DataError) as error:
        s.run().to_csv(tmp_path / "no-such-folder" / "run.csv")
    assert "no-such-folder" in one_line(error)
    assert not (tmp_path / "no-such-folder").exists()


def test_a_column_the_scenario_lacks_is_left_out_with_a_note_or_refused_when_strict(tmp_path):
    s = whitworth(0.5)
    s.run().to_csv(tmp_path / "run.csv")
    c = s.compare(tmp_path / "run.csv", rename={"crank.velocity": "speed"})
    assert c["notes"] == [
        f"{tmp_path / 'run.csv'}: left out 1 column the scenario does not know: speed [rad/s] "
        "(--strict refuses it)"
    ]
    assert "crank.velocity" not in c["measured"]
    with pytest.raises(twin.DataError, match='column "speed \\[rad/s\\]"') as error:
        s.compare(tmp_path / "run.csv", rename={"crank.velocity": "speed"}, strict=True)
    one_line(error)
    with pytest.raises(twin.CalibrationError, match="rename: a list is not a dict"):
        s.compare(tmp_path / "run.csv", rename=["crank.velocity"])
    with pytest.raises(twin.CalibrationError, match="delimiter: `[|]` is not a separator"):
        s.compare(tmp_path / "run.csv", delimiter="|")


def test_a_loggers_file_is_read_as_it_comes(tmp_path):
    """Semicolons, decimal commas, comments, a units row and a column the scenario lacks."""
    s = whitworth(0.5)
    s.run().to_csv(tmp_path / "run.csv")
    lines = (tmp_path / "run.csv").read_text().splitlines()
    names = [cell.split(" [")[0] for cell in lines[0].split(",")]
    units = [cell.split(" [")[1].rstrip("]") for cell in lines[0].split(",")]
    rows = [row.replace(",", ";").replace(".", ",") + ";21,5" for row in lines[1:]]
    text = ["# logged on the shop floor", ";".join(names) + ";temperature",
            ";".join(units) + ";°C", *rows]
    (tmp_path / "logger.csv").write_text("\n".join(text) + "\n")
    logged = s.compare(tmp_path / "logger.csv")
    written = s.compare(tmp_path / "run.csv")
    assert logged["notes"] == [
        f"{tmp_path / 'logger.csv'}: left out 1 column the scenario does not know: "
        "temperature [°C] (--strict refuses it)"
    ]
    for name, values in written["measured"].items():
        np.testing.assert_array_equal(logged["measured"][name], values)
    with pytest.raises(twin.DataError, match="temperature"):
        s.compare(tmp_path / "logger.csv", delimiter=";", strict=True)


def test_an_unknown_key_or_a_bad_option_is_named(tmp_path):
    s = whitworth(0.5)
    s.run().to_csv(tmp_path / "run.csv")
    data = tmp_path / "run.csv"
    refusals = [
        (twin.CalibrationError, "urdf.link.no_such_link.mass", {"fit": ["urdf.link.no_such_link.mass"]}),
        (twin.ScenarioError, "no_such_link", {"fit": {"urdf.link.no_such_link.mass": 1.0}}),
        (twin.CalibrationError, "fit: give a scenario key", {}),
        (twin.CalibrationError, "fit: .*mass: the start must be a number",
         {"fit": {RAM_MASS: "heavy"}}),
        (twin.CalibrationError, "bounds: `urdf.joint.crank.damping` is not fitted",
         {"fit": RAM_MASS, "bounds": {"urdf.joint.crank.damping": (0.0, 1.0)}}),
        (twin.CalibrationError, "mass: the start 5 lies outside the bounds \\[7, 8\\]",
         {"fit": RAM_MASS, "bounds": {RAM_MASS: (7.0, 8.0)}}),
        (twin.CalibrationError, "per_run: `ram` is not fitted", {"fit": RAM_MASS, "per_run": "ram"}),
        (twin.CalibrationError, "noise: crank.position: σ must be > 0",
         {"fit": RAM_MASS, "noise": {"crank.position": -1.0}}),
        (twin.CalibrationError, "no_such_signal", {"fit": RAM_MASS, "signals": ["no_such_signal"]}),
        (twin.CalibrationError, "no_such_joint", {"fit": RAM_MASS, "states": ["no_such_joint"]}),
        (twin.CalibrationError, "progress: a int is not callable", {"fit": RAM_MASS, "progress": 5}),
    ]
    for exception, message, options in refusals:
        with pytest.raises(exception, match=message) as error:
            twin.calibrate(s, data, **options)
        one_line(error)
    with pytest.raises(twin.CalibrationError, match="data: give a measured run"):
        twin.calibrate(s, fit=RAM_MASS)
    with pytest.raises(twin.ScenarioError, match="no-such-scenario"):
        twin.calibrate("no-such-scenario", data, fit=RAM_MASS)
    with pytest.raises(twin.ScenarioError, match="scenario: a float is neither"):
        twin.calibrate(1.5, data, fit=RAM_MASS)


def test_an_exception_in_the_progress_callback_is_raised(tmp_path):
    s = whitworth(0.5)
    s.set(RAM_MASS, 6.0).run().to_csv(tmp_path / "run.csv")
    calls = []

    def progress(iteration, cost, step):
        calls.append(iteration)
        raise RuntimeError("my progress bar broke")

    with pytest.raises(RuntimeError, match="my progress bar broke"):
        twin.calibrate(s, tmp_path / "run.csv", fit=RAM_MASS, progress=progress)
    # Not called again once it raised.
    assert calls == [0]


def test_the_guides_block_on_measured_runs_runs(tmp_path, monkeypatch, capsys):
    """The guide's block on measured runs (docs/src/python.md) runs as written."""
    chapter = (Path(__file__).parents[3] / "docs" / "src" / "python.md").read_text()
    section = chapter.split("## Against measured runs", 1)[1].split("\n## ", 1)[0]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()  # as the guide's Getting started makes it
    scope = {}
    exec(compile(code, "docs/src/python.md", "exec"), scope)
    assert scope["est"]["estimate"] == pytest.approx(6.2, rel=1e-6)
    assert scope["r"].ok and "0 " in capsys.readouterr().out
