"""What fmi2SetFMUstate costs: the feed axis's closed-loop FMU stepped to t (one fmi2DoStep per
control period, 0.1 ms, as a host rolling back its steps does), a state got there, stepped on by
10 ms, then set back (its periods replayed from t = 0); the median of five sets per t, with the
time the same span took to step and the serialized state's size. Inputs are constant, or change
every period (each period its own run in the state's history).

    cargo build --release -p twin-cli -p twin-fmu
    eval "$(scripts/test-tools)"
    TWIN=$CARGO_TARGET_DIR/release/twin "$TWIN_TOOLS_PYTHON" twin/fmu/examples/state_cost.py
"""

import os
import pathlib
import statistics
import subprocess
import tempfile
import time

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

ROOT = pathlib.Path(__file__).resolve().parents[3]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
TWIN = os.environ.get("TWIN", str(TARGET / "release" / "twin"))


def main():
    folder = pathlib.Path(tempfile.mkdtemp())
    fmu = folder / "feed-axis.fmu"
    subprocess.run([TWIN, "fmu", "feed-axis-micromilling", "--out", str(fmu)], check=True,
                   capture_output=True)
    description = read_model_description(str(fmu))
    period = float(description.defaultExperiment.stepSize)
    table = next(v.valueReference for v in description.modelVariables
                 if v.name == "disturbance.table")
    print("| t | inputs | stepping to t | set (median of 5) | serialized state |")
    print("| --- | --- | --- | --- | --- |")
    for at in [1.0, 10.0]:
        for varying in [False, True]:
            slave = FMU2Slave(guid=description.guid, unzipDirectory=extract(str(fmu)),
                              modelIdentifier=description.coSimulation.modelIdentifier)
            slave.instantiate()
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            periods = round(at / period)
            started = time.perf_counter()
            for k in range(periods):
                slave.setReal([table], [0.001 * (k % 7) if varying else 1.0])
                slave.doStep(k * period, period)
            stepped = time.perf_counter() - started
            state = slave.getFMUstate()
            size = len(slave.serializeFMUstate(state))
            costs = []
            for _ in range(5):
                for k in range(100):
                    slave.doStep((periods + k) * period, period)
                started = time.perf_counter()
                slave.setFMUstate(state)
                costs.append(time.perf_counter() - started)
            slave.freeFMUstate(state)
            slave.terminate()
            slave.freeInstance()
            print(f"| {at:g} s | {'each period new' if varying else 'constant'} | "
                  f"{stepped:.3f} s | {statistics.median(costs) * 1e3:.1f} ms | "
                  f"{size / 1e3:.1f} kB |")


if __name__ == "__main__":
    main()
