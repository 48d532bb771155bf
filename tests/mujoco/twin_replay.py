#!/usr/bin/env python3
"""Replays a run's efforts on the twin, open loop, and writes the twin's response in the same
CSV format (scripts/mujoco_machine.py): the twin's side of the MuJoCo agreement check.

    python tests/mujoco/twin_replay.py SCENARIO run.csv --out twin.csv \
        [--set urdf.link.ram.mass=5.5 ...] [--arm-currents]

Needs a Python with the twin's package (`pip install ./twin/python`); the rest is numpy. The
scenario's controller is left out (`Scenario.simulator()`): each row's efforts are held over one
control period, and the twin starts from the run's first row (`initial.<joint>.position` and
`.velocity` for every joint the run gives, except those the scenario's loops determine). The
written states are the plant's true signals (before the scenario's sensors).

`--arm-currents`: the arm's drives take current commands (A), not torques; the efforts are
divided by each drive's G·k_t (shoulder 4.2, elbow 3.0, wrist 1.0 N·m/A, twin/src/machines/arm.rs)
and the drives' current loops (2000 rad/s) and back-EMF stand between them and the joint, and the
spindle's own drive holds the cutter at 6,000 rpm: the comparison is then only as close as those
drives are ideal (they are far from it). `--ideal-arm` makes them so through the scenario's
`[process]` table: every joint drive's back-EMF constant 1e-9 V·s/rad and its current loop at
3e6 rad/s sampled every 0.1 µs (the winding current follows the command within microseconds), and
the spindle's drive the same, limited to 1e-12 A, with a 1e-9 rad/s speed loop (the cutter turns free, as
on MuJoCo, where no drive holds it). Implies --arm-currents.
"""

import argparse
import json
import sys

import numpy as np
import twin

ARM_TORQUE_PER_AMP = {"shoulder": 4.2, "elbow": 3.0, "wrist": 1.0}
ARM_DRIVES = {"shoulder": (0.035, 120.0), "elbow": (0.025, 120.0), "wrist": (0.02, 50.0)}


def ideal_arm(s):
    """The arm's drives as near ideal torque sources, its spindle free (see the docstring)."""
    def drive(kt, gear, emf, limit, bandwidth, period):
        return {"torque_constant": kt, "back_emf_constant": emf, "resistance": 0.3,
                "inductance": 0.5e-3, "gear_ratio": gear, "supply_voltage": 48.0,
                "current_limit": limit, "current_bandwidth": bandwidth,
                "current_loop_period": period}
    s = s.set("process.drives", {joint: drive(kt, gear, 1e-9, 20.0, 3e6, 1e-7)
                                 for joint, (kt, gear) in ARM_DRIVES.items()})
    return s.set("process.spindle", {"speed": 0.0, "speed_bandwidth": 1e-9,
                                     "drive": drive(0.06, 1.0, 1e-9, 1e-12, 3e6, 1e-7)})


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenario")
    p.add_argument("run")
    p.add_argument("--out", required=True)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--arm-currents", action="store_true")
    p.add_argument("--ideal-arm", action="store_true")
    p.add_argument("--no-initial", default="", help="comma-separated joints not to set initially")
    args = p.parse_args()

    with open(args.run, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    table = np.loadtxt(args.run, delimiter=",", skiprows=1, ndmin=2)
    names = [h.rsplit(" [", 1)[0] for h in header]

    s = twin.Scenario(args.scenario)
    for item in args.set:
        key, value = item.split("=", 1)
        try:
            s = s.set(key, json.loads(value))  # numbers, [x, y], {…}
        except ValueError:
            s = s.set(key, value)
    if args.ideal_arm:
        s = ideal_arm(s)
        args.arm_currents = True
    skip = set(filter(None, args.no_initial.split(",")))
    for c, name in enumerate(names):
        if name.endswith(".position") or name.endswith(".velocity"):
            joint, field = name.rsplit(".", 1)
            if joint not in skip and table[0, c] != 0.0:
                s = s.set(f"initial.{joint}.{field}", float(table[0, c]))
    sim = s.simulator()
    if abs(sim.control_period - (table[1, 0] - table[0, 0])) > 1e-12:
        raise SystemExit(f"twin_replay: the scenario's control period is {sim.control_period} s, "
                         f"the run's {table[1, 0] - table[0, 0]} s")
    sim.reset()
    effort_cols = [names.index(f"effort.{a}") for a in sim.actuators]
    scale = np.ones(len(effort_cols))
    if args.arm_currents:
        scale = np.array([1.0 / ARM_TORQUE_PER_AMP[a] for a in sim.actuators])
    state_names = [n for n in names[1:] if not n.startswith("effort.")]
    index = [sim.signals.index(n) for n in state_names]
    out = np.empty((table.shape[0], 1 + len(effort_cols) + len(state_names)))
    out[:, 0] = table[:, 0]
    out[:, 1:1 + len(effort_cols)] = table[:, effort_cols]
    out[0, 1 + len(effort_cols):] = np.asarray(sim.true_signals)[index]
    for k in range(table.shape[0] - 1):
        sim.step(table[k, effort_cols] * scale)
        out[k + 1, 1 + len(effort_cols):] = np.asarray(sim.true_signals)[index]
    cols = [header[0]] + [header[c] for c in effort_cols] + [
        header[names.index(n)] for n in state_names]
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(",".join(cols) + "\n")
        for row in out:
            f.write(",".join(f"{x:.17g}" for x in row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
