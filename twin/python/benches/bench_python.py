"""The Python package's speed (issue 26's targets): the step API's overhead per step beyond the
engine's own step, and a 10 s Whitworth run from Python against `twin run` of the same scenario.

    python twin/python/benches/bench_python.py [--twin target/release/twin]

Run it on a quiet machine; each figure is the best of five repetitions.
"""

import argparse
import os
import subprocess
import tempfile
import time

import numpy as np

import twin
from twin._twin import engine_step_seconds


def best(repeat, f):
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        f()
        times.append(time.perf_counter() - started)
    return min(times)


def step_overhead(name, steps):
    scenario = twin.Scenario(name)
    sim = scenario.simulator()
    efforts = np.zeros(len(sim.actuators))

    def python_loop():
        sim.reset()
        step = sim.step
        for _ in range(steps):
            step(efforts)

    engine = min(engine_step_seconds(scenario, steps) for _ in range(5))
    python = best(5, python_loop)
    return engine / steps, python / steps


def run_against_cli(name, twin_cli):
    folder = tempfile.mkdtemp()
    scenario = twin.Scenario(name)
    python = best(5, lambda: scenario.run(record=os.path.join(folder, "py.rrd")))
    cli = best(5, lambda: subprocess.run(
        [twin_cli, "run", name, "--out", os.path.join(folder, "cli.rrd")],
        check=True, capture_output=True))
    return python, cli


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--twin", default="target/release/twin", help="the twin command line")
    parser.add_argument("--steps", type=int, default=20_000)
    args = parser.parse_args()
    for name in ["whitworth-crank-pi", "feed-axis-micromilling"]:
        engine, python = step_overhead(name, args.steps)
        print(f"{name}: step from Rust {engine * 1e6:.2f} µs, from Python {python * 1e6:.2f} µs, "
              f"overhead {(python - engine) * 1e6:.2f} µs per step (target ≤ 2 µs)")
    python, cli = run_against_cli("whitworth-crank-pi", args.twin)
    print(f"whitworth-crank-pi, 10 s with recording: Scenario.run {python:.3f} s, twin run "
          f"{cli:.3f} s (whole process), ratio {python / cli:.3f} (target ≤ 1.10)")


if __name__ == "__main__":
    main()
