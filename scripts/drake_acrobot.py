#!/usr/bin/env python3
"""Drake plays a published URDF: its own `Acrobot.urdf`, from the `drake` wheel on PyPI, simulated
by pydrake's MultibodyPlant, as the reference the twin's generic machine is held to
(twin/cli/tests/published_urdf.rs).

    eval "$(scripts/test-tools)"
    "$TWIN_TOOLS_PYTHON" scripts/drake_acrobot.py --where            # prints the URDF's path
    "$TWIN_TOOLS_PYTHON" scripts/drake_acrobot.py --initial shoulder=0.8,0 --initial elbow=-0.5,0 \\
        --pd elbow=20,2,0.4 --duration 2 --period 0.001 --out drake.csv

The plant is continuous (time_step 0), integrated by Drake's error-controlled Runge–Kutta 5 at
a target accuracy of 1e-12, with its default gravity (−9.81 m/s² along z) and the URDF's joint
damping. `--pd joint=kp,kd,target` drives that joint's actuator (the URDF's <transmission>) by
u = kp·(target − q) − kd·q̇, computed from the state at the start of each `--period` and held
over it (zero-order hold), as the twin's `joint-pid` with ki = 0 drives it; without it the
actuators are given no effort. Row k of the CSV holds t_k, the effort applied from t_k on, and
every joint's position and velocity at t_k: `time [s]`, `effort.<joint> [N·m]`,
`<joint>.position [rad]`, `<joint>.velocity [rad/s]`.
"""

import argparse
import csv
import sys

import numpy as np
from pydrake.common import FindResourceOrThrow
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder

URDF = "drake/examples/acrobot/Acrobot.urdf"
JOINTS = ["shoulder", "elbow"]


def parse(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--where", action="store_true", help="print the URDF's path and stop")
    parser.add_argument("--initial", action="append", default=[], help="joint=position,velocity")
    parser.add_argument("--pd", action="append", default=[], help="joint=kp,kd,target")
    parser.add_argument("--duration", type=float, default=2.0)
    parser.add_argument("--period", type=float, default=1e-3)
    parser.add_argument("--out", default="drake.csv")
    return parser.parse_args(argv)


def pairs(items, count):
    """`name=a,b,…` entries as {name: [floats]} with `count` numbers each."""
    out = {}
    for item in items:
        name, _, values = item.partition("=")
        numbers = [float(v) for v in values.split(",")]
        if name not in JOINTS or len(numbers) != count:
            sys.exit(f"`{item}`: expected one of {JOINTS} = {count} numbers")
        out[name] = numbers
    return out


def build():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModels(FindResourceOrThrow(URDF))
    plant.Finalize()
    return plant, builder.Build()


def run(args):
    plant, diagram = build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    for name, (position, velocity) in pairs(args.initial, 2).items():
        joint = plant.GetJointByName(name)
        joint.set_angle(plant_context, position)
        joint.set_angular_rate(plant_context, velocity)
    laws = pairs(args.pd, 3)
    actuated = [
        plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices()
    ]
    for name in laws:
        if name not in actuated:
            sys.exit(f"--pd {name}: the URDF does not actuate it (actuated: {actuated})")
    port = plant.get_actuation_input_port()
    simulator = Simulator(diagram, context)
    integrator = ResetIntegratorFromFlags(simulator, "runge_kutta5", args.period)
    integrator.set_target_accuracy(1e-12)
    simulator.Initialize()
    steps = int(round(args.duration / args.period))
    rows = []
    for k in range(steps + 1):
        time = k * args.period
        state = {
            name: (
                plant.GetJointByName(name).get_angle(plant_context),
                plant.GetJointByName(name).get_angular_rate(plant_context),
            )
            for name in JOINTS
        }
        efforts = []
        for name in actuated:
            if name in laws:
                kp, kd, target = laws[name]
                q, v = state[name]
                efforts.append(kp * (target - q) - kd * v)
            else:
                efforts.append(0.0)
        port.FixValue(plant_context, np.array(efforts))
        rows.append([time, *efforts, *[x for name in JOINTS for x in state[name]]])
        if k < steps:
            simulator.AdvanceTo((k + 1) * args.period)
    header = ["time [s]"] + [f"effort.{name} [N·m]" for name in actuated]
    for name in JOINTS:
        header += [f"{name}.position [rad]", f"{name}.velocity [rad/s]"]
    with open(args.out, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([[repr(float(v)) for v in row] for row in rows])


def main(argv):
    args = parse(argv)
    if args.where:
        print(FindResourceOrThrow(URDF))
        return
    run(args)


if __name__ == "__main__":
    main(sys.argv[1:])
