"""The twin beside a running machine from Python: `twin.Shadow` fed a run of the twin's own, made
with the package's run API, sample by sample with source timestamps, some samples out of order
and some repeated as a transport delivers them; a heavier ram found and named; a healthy run
left alone; every bad input against its exception and message."""

import csv
import math

import numpy as np
import pytest

import twin

RAM_MASS = "urdf.link.ram.mass"
SIGNALS = ["crank.position", "crank.velocity"]
#: The ram's mass (5 kg in the URDF) becomes this from FAULT_START on.
FAULT_MASS = 6.0
FAULT_START = 20.0
#: The source's clock at the run's t = 0: the shadow's times count from its first sample.
ORIGIN = 1.7e9


def changes(faulty):
    """A 30 s crank-speed run at a 10 ms control period with noisy crank sensors (on top of the
    encoder's 10,000 counts per turn), and with the ram's mass fault if `faulty`."""
    values = {
        "control_period": 0.01,
        'sensors."crank.velocity".noise': 0.02,
        'sensors."crank.position".noise': 2e-4,
    }
    if faulty:
        fault = {"kind": "link_mass", "link": "ram", "value": FAULT_MASS, "start": FAULT_START}
        values["faults"] = [fault]
    return values


def scenario(faulty):
    s = twin.Scenario("whitworth-crank-pi").duration(30.0)
    for key, value in changes(faulty).items():
        s = s.set(key, value)
    return s


def run_table(tmp_path, faulty):
    """The run's table (one row per control update, SI) as the twin writes it: column → array."""
    path = tmp_path / "run.csv"
    result = scenario(faulty).run()
    assert result.ok
    result.to_csv(path)
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    names = [header.split(" [")[0] for header in rows[0]]
    values = np.array(rows[1:], dtype=float)
    return {name: values[:, i] for i, name in enumerate(names)}


def samples(table, seed=7):
    """The run's command and crank measurements as a transport delivers them, `(kind, name,
    source time, value)`: about one row in eight held back by 10–50 ms (taken after newer ones,
    well within the shadow's 0.25 s latency), and one sample in twenty sent twice, up to 30 ms
    later. Also what the intake should count: `duplicate`, `reordered`."""
    rng = np.random.default_rng(seed)
    rows = []
    for k, t in enumerate(table["time"]):
        row = [("command", "crank", ORIGIN + t, table["effort.crank"][k])]
        row += [("measure", name, ORIGIN + t, table[name][k]) for name in SIGNALS]
        rows.append(row)
    # Arrival order: each row at its index, some pushed later; the first stays first (it sets
    # the origin).
    arrival = np.arange(len(rows), dtype=float)
    held = rng.random(len(rows)) < 0.125
    held[0] = False
    arrival[held] += rng.integers(1, 6, held.sum()) + 0.5
    sent = []
    for k in np.argsort(arrival, kind="stable"):
        for sample in rows[k]:
            sent.append((arrival[k], sample))
            if rng.random() < 0.05:
                sent.append((arrival[k] + rng.integers(1, 4) + 0.25, sample))
    sent.sort(key=lambda pair: pair[0])
    feed = [sample for _, sample in sent]
    seen, newest, duplicate, reordered = set(), -math.inf, 0, 0
    for kind, name, t, _ in feed:
        duplicate += int((kind, name, t) in seen)
        reordered += int(t < newest)
        seen.add((kind, name, t))
        newest = max(newest, t)
    return feed, {"duplicate": duplicate, "reordered": reordered}


def feed(shadow, table):
    """Every sample into `shadow`, `advance` after each row's worth, and one late sample half way;
    the steps and the counts the intake should show."""
    sent, expected = samples(table)
    steps = []
    for i, (kind, name, t, value) in enumerate(sent):
        getattr(shadow, kind)(name, t, value)
        if i % 3 == 2:
            steps += shadow.advance()
        if i == len(sent) // 2:
            # Older than what has been processed: late, dropped.
            shadow.measure("crank.velocity", ORIGIN + 1.0, 0.0)
    steps += shadow.flush()
    return steps, expected


def one_line(error):
    message = str(error.value)
    assert message and "\n" not in message, message
    return message


def test_a_heavier_ram_is_found_within_two_seconds_and_named(tmp_path):
    table = run_table(tmp_path, faulty=True)
    shadow = twin.Shadow(
        scenario(faulty=False), signals=SIGNALS, track=[RAM_MASS], latency=0.25
    )
    assert shadow.watched == SIGNALS and shadow.parameters == [RAM_MASS]
    assert shadow.actuators == ["crank"] and shadow.command_units == {"crank": "N·m"}
    steps, expected = feed(shadow, table)
    assert expected["duplicate"] > 100 and expected["reordered"] > 300
    # Every measurement time processed once, in time order, whatever order the samples came in.
    rows = len(table["time"])
    assert [s["time"] for s in steps] == pytest.approx(table["time"], abs=1e-6)
    assert shadow.origin == ORIGIN
    assert steps[-1]["source_time"] == pytest.approx(ORIGIN + table["time"][-1], abs=1e-6)
    assert shadow.counts == {"processed": 3 * rows, "late": 1, **expected}
    assert all(set(s["measured"]) == set(SIGNALS) == set(s["estimate"]) for s in steps)

    (anomaly,) = shadow.anomalies
    assert FAULT_START < anomaly["detected"] <= FAULT_START + 2.0, anomaly
    assert FAULT_START - 0.5 <= anomaly["start"] <= anomaly["detected"], anomaly
    assert anomaly["end"] is None and anomaly["size"] > 1.0
    cause = anomaly["attribution"]
    assert cause["parameter"] == RAM_MASS, anomaly
    assert cause["before"] == pytest.approx(5.0, rel=0.02)
    low, high = cause["interval"]
    assert 0.9 * FAULT_MASS <= low < FAULT_MASS < high <= 1.1 * FAULT_MASS, cause
    assert cause["shift_sigmas"] > 3.0
    # The step that opened it says so, and the alarm holds from there.
    (opened,) = [s for s in steps if s["change"]]
    assert opened["change"]["kind"] == "opened" and opened["time"] == anomaly["detected"]
    # Named once the mass has moved far enough: not yet, or already, when it opens.
    assert opened["change"]["signals"] and opened["change"]["end"] is None
    assert all(s["alarm"] == (s["time"] >= anomaly["detected"]) for s in steps)
    estimate, sigma = shadow.estimates[RAM_MASS]
    assert estimate == pytest.approx(FAULT_MASS, rel=0.05) and 0 < sigma < 0.3
    assert steps[-1]["parameters"][RAM_MASS] == (estimate, sigma)
    # After `flush` the feed is over: a later sample is late, and dropped.
    shadow.measure("crank.velocity", ORIGIN + 30.5, 0.0)
    assert shadow.flush() == [] and shadow.counts["late"] == 2


def test_a_healthy_run_raises_no_anomaly(tmp_path):
    table = run_table(tmp_path, faulty=False)
    # By name, with the changes as a dict.
    shadow = twin.Shadow(
        "whitworth-crank-pi", signals=SIGNALS, track=RAM_MASS, set=changes(faulty=False)
    )
    steps, expected = feed(shadow, table)
    assert shadow.counts["duplicate"] == expected["duplicate"] > 0
    assert shadow.anomalies == [] and not any(s["alarm"] or s["change"] for s in steps)
    learning = [s["time"] for s in steps if s["learning"]]
    # Learning starts once the machine is acquired (its innovations in band for 0.5 s), then
    # lasts `learn` (5 s).
    assert 5.4 < max(learning) < 5.6 and shadow.thresholds["cusum"] > 0
    estimate, sigma = shadow.estimates[RAM_MASS]
    assert abs(estimate - 5.0) < 3 * sigma and estimate == pytest.approx(5.0, rel=0.05)
    after = [s for s in steps if not s["learning"]]
    assert max(max(s["tests"]["cusum"].values()) for s in after) < 1.0
    assert max(s["tests"]["nis"] for s in after) < 1.0


def test_bad_options_raise_shadow_errors_naming_them():
    s = scenario(faulty=False)
    refused = {
        "signals: `crank.pos`: the scenario's plant has no such signal (known: crank.position, ":
            dict(signals=["crank.pos"]),
        "signals: a int is not a str or a list of str": dict(signals=3),
        "signals: `crank.velocity` is given twice": dict(signals=SIGNALS + ["crank.velocity"]),
        "track: urdf.link.nope.mass: the URDF has no link `nope`; tracked: urdf.link.<link>.mass":
            dict(signals=SIGNALS, track=["urdf.link.nope.mass"]),
        "track: urdf.link.ram.inertia: not a parameter the shadow can track":
            dict(signals=SIGNALS, track="urdf.link.ram.inertia"),
        "track: sensors.ram_position.bias: `ram_position` is not a watched signal":
            dict(signals=SIGNALS, track=["sensors.ram_position.bias"]),
        "track: urdf.link.ram.mass: the drift -1 must be a positive number":
            dict(signals=SIGNALS, track=[(RAM_MASS, -1.0)]),
        "noise: `ram_position` is not a watched signal (watched: crank.position, crank.velocity)":
            dict(signals=SIGNALS, noise={"ram_position": 1e-3}),
        "noise: crank.velocity: σ must be > 0": dict(signals=SIGNALS, noise={"crank.velocity": 0}),
        "false_alarms_per_hour: 0: must be a positive number":
            dict(signals=SIGNALS, false_alarms_per_hour=0.0),
        "learn: -1: must be a positive number": dict(signals=SIGNALS, learn=-1.0),
        "latency: NaN: must be ≥ 0 s": dict(signals=SIGNALS, latency=float("nan")),
        "process_noise: inf: must be a positive number":
            dict(signals=SIGNALS, process_noise=math.inf),
    }
    for message, options in refused.items():
        with pytest.raises(twin.ShadowError) as error:
            twin.Shadow(s, **options)
        assert one_line(error).startswith(message), (options, one_line(error))
    with pytest.raises(TypeError):
        twin.Shadow(s)  # `signals` is required: which does the transport bring?
    # A sensor bias of a watched signal is tracked, with its drift given.
    tracked = twin.Shadow(s, signals=SIGNALS, track=[("sensors.crank.position.bias", 1e-3)])
    assert tracked.parameters == ["sensors.crank.position.bias"]
    with pytest.raises(twin.ScenarioError) as error:
        twin.Shadow(s, signals=SIGNALS, set={"control_perod": 0.01})
    assert "control_perod" in one_line(error)
    with pytest.raises(twin.ScenarioError) as error:
        twin.Shadow("no-such-scenario", signals=SIGNALS)
    assert "no-such-scenario" in one_line(error)


def test_bad_samples_are_refused_or_dropped_as_the_engine_drops_them():
    shadow = twin.Shadow(scenario(faulty=False), signals=SIGNALS)
    with pytest.raises(twin.ShadowError) as error:
        shadow.measure("crank.pos", 0.0, 1.0)
    assert one_line(error) == (
        "measure: `crank.pos` is not a signal of this plant "
        "(watched: crank.position, crank.velocity)"
    )
    with pytest.raises(twin.ShadowError) as error:
        shadow.command("ram", 0.0, 1.0)
    assert one_line(error) == "command: `ram` is not an actuator of this plant (actuators: crank)"
    for method, name in [(shadow.measure, "crank.velocity"), (shadow.command, "crank")]:
        with pytest.raises(twin.ShadowError) as error:
            method(name, float("nan"), 1.0)
        assert one_line(error).endswith(
            f"{name} at t = NaN: the time must be a finite number of seconds"
        )
    with pytest.raises(TypeError):
        shadow.measure("crank.velocity", 0.0, "fast")
    # Dropped without a word, as `twin shadow` drops them: a plant signal not watched, a value
    # that is not a number (a sensor's dropout). None of them sets the origin.
    shadow.measure("ram_position", 0.0, 0.1)
    shadow.measure("crank.velocity", 0.0, float("nan"))
    shadow.command("crank", 0.0, math.inf)
    assert shadow.origin is None and shadow.advance() == []
    assert shadow.counts == {"processed": 0, "late": 0, "duplicate": 0, "reordered": 0}
    shadow.measure("crank.velocity", 5.0, 0.0)
    (step,) = shadow.flush()
    assert step["time"] == 0.0 and step["source_time"] == 5.0 and step["learning"]
    assert shadow.origin == 5.0 and shadow.counts["processed"] == 1
    assert shadow.anomalies == [] and shadow.thresholds is None
    assert repr(shadow) == (
        "Shadow('whitworth-crank-pi', watched=['crank.position', 'crank.velocity'], tracked=[], "
        "processed=1, anomalies=0)"
    )
