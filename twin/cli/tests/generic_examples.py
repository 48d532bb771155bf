#!/usr/bin/env python3
"""MuJoCo 4.0 as the machine and as the reference for twin/cli/tests/generic_examples.rs, on the
shipped examples' URDFs (scripts/mujoco_machine.py builds the model: contacts and limits off,
RK4, loops closed by `connect` equalities).

    run        the machine under its own controller (mujoco_machine's pid or speed-pi, designed
               on the URDF's nominal values), its hidden values (`--set`) from the start and, with
               `--fault-at T --fault KEY=VALUE`, others from T on (the model swapped mid-run, the
               state carried over); logged as a machine logs: the efforts and the encoders, with
               seeded Gaussian noise, then quantised to the encoder's count (`--resolution`).
    place      every twin joint's position and velocity (JSON) with the independent joints given,
               the loops closed on the URDF's assembly branch.
    linearize  A and B of ẋ = f(x, u) at the operating point of a twin `linear.json`, in its
               states (independent joints' positions, then velocities) and inputs, by central
               differences of MuJoCo's constrained accelerations: q̈ from the KKT system of
               MuJoCo's mass matrix (mj_fullM), its smooth forces (qfrc_smooth: gravity, Coriolis,
               damping, the efforts and the applied loads) and the loops' point Jacobians (mj_jac) and
               their rates (mj_jacDot), the hard constraint the twin's engine solves (MuJoCo's own
               soft solver would make the loop compliant); the dependent joints placed by Newton
               on MuJoCo's own closure gaps. JSON out.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import mujoco
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../../scripts"))
import mujoco_machine as mm  # noqa: E402


def pairs(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        key, _, value = item.partition("=")
        out[key.strip()] = value.strip()
    return out


# --------------------------------------------------------------------------------------------
# run


def simulate(machine, after, fault_at, controller, rows, period, initial):
    """mujoco_machine's controlled run, stepping `after`'s model from `fault_at` on."""
    m = machine.model
    substeps = int(round(period / m.opt.timestep))
    data = mujoco.MjData(m)
    machine.set_state(data, {k: v[0] for k, v in initial.items()},
                      {k: v[1] for k, v in initial.items()})
    n = len(machine.twin_joints)
    q, v = np.empty((rows, n)), np.empty((rows, n))
    applied = np.empty((rows, len(machine.driven)))
    q[0], v[0] = machine.twin_state(data)
    controller.reset()
    for k in range(rows - 1):
        model = after.model if after is not None and k * period >= fault_at - 1e-12 else m
        applied[k] = controller.command(k, q[k], v[k])
        data.ctrl[:] = applied[k]
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        q[k + 1], v[k + 1] = machine.twin_state(data, q[k])
    applied[rows - 1] = controller.command(rows - 1, q[rows - 1], v[rows - 1])
    return applied, q, v


def run(args) -> None:
    values = [mm.parse_value(s) for s in args.set]
    machine = mm.Machine(args.urdf, values, mm.DEFAULT_GRAVITY, args.dt)
    nominal = mm.Machine(args.urdf, [], mm.DEFAULT_GRAVITY, args.dt)
    after = None
    if args.fault:
        faulty = values + [mm.parse_value(s) for s in args.fault]
        after = mm.Machine(args.urdf, faulty, mm.DEFAULT_GRAVITY, args.dt)
    period = args.control_period
    steps = int(round(args.duration / period))
    t = np.arange(steps + 1) * period
    references = {k: mm.excitation(v, t, args.duration) for k, v in pairs(args.reference).items()}
    initial = {}
    for name, r in references.items():
        if args.controller == "pid":
            initial[name] = (float(r[0]), float((r[1] - r[0]) / period))
        else:
            initial[name] = (0.0, float(r[0]))
    gains = {k: float(v) for k, v in pairs(args.gain).items()}
    controller = mm.Controller(args.controller, machine, nominal, references, period, gains,
                               {k: v[0] for k, v in initial.items()})
    applied, q, v = simulate(machine, after, args.fault_at, controller, steps + 1, period, initial)
    columns = {"time": t}
    units = {"time": "s"}
    for i, j in enumerate(machine.driven):
        columns[f"effort.{j.name}"] = applied[:, i]
        units[f"effort.{j.name}"] = "N" if j.prismatic else "N·m"
    for i, j in enumerate(machine.twin_joints):
        columns[f"{j.name}.position"] = q[:, i]
        units[f"{j.name}.position"] = "m" if j.prismatic else "rad"
    names = ["time"] + [c.strip() for c in args.log.split(",")]
    rng = np.random.default_rng(args.seed)
    noise = {k: float(v) for k, v in pairs(args.noise).items()}
    resolution = {k: float(v) for k, v in pairs(args.resolution).items()}
    table = []
    for name in names:
        column = np.array(columns[name], dtype=float)
        if name in noise:
            column = column + rng.normal(0.0, noise[name], column.shape)
        if name in resolution:
            column = np.round(column / resolution[name]) * resolution[name]
        table.append(column)
    with open(args.out, "w", encoding="utf-8") as out:
        out.write(",".join(f"{n} [{units[n]}]" for n in names) + "\n")
        for row in np.column_stack(table):
            out.write(",".join(f"{x:.17g}" for x in row) + "\n")
    for line in controller.describe():
        print(f"generic_examples: {line}", file=sys.stderr)


# --------------------------------------------------------------------------------------------
# The mechanism's constrained dynamics in MuJoCo's coordinates


class Loads:
    """The scenario's point loads, as MuJoCo's qfrc_applied: a constant force, or a
    spring-damper to an anchor (−K·(p − anchor) − C·v per axis, the twin's `[points]` spring)."""

    def __init__(self, machine, forces: list[str], springs: list[str]):
        self.items = []
        for text in forces:
            link, x, y, fx, fy = text.split(",")
            self.items.append((machine.body_id[link], float(x), float(y), float(fx), float(fy),
                               None))
        for text in springs:
            link, x, y, ax, ay, k, c = text.split(",")
            self.items.append((machine.body_id[link], float(x), float(y), float(ax), float(ay),
                               (float(k), float(c))))

    def apply(self, m, d) -> None:
        d.qfrc_applied[:] = 0.0
        jacp = np.zeros((3, m.nv))
        for body, x, y, a, b, spring in self.items:
            point = d.xpos[body] + d.xmat[body].reshape(3, 3) @ np.array([x, y, 0.0])
            mujoco.mj_jac(m, d, jacp, None, point, body)
            if spring is None:
                force = np.array([a, b, 0.0])
            else:
                k, c = spring
                velocity = jacp @ d.qvel
                force = np.array([-k * (point[0] - a) - c * velocity[0],
                                  -k * (point[1] - b) - c * velocity[1], 0.0])
            d.qfrc_applied[:] += jacp.T @ force


class Dynamics:
    """q̈ of the nominal model with its loops held exactly."""

    def __init__(self, machine, loads: Loads):
        self.machine, self.loads = machine, loads
        self.m = machine.model
        self.d = mujoco.MjData(self.m)

    def anchors(self, k: int):
        m, d = self.m, self.d
        b1, b2 = m.eq_obj1id[k], m.eq_obj2id[k]
        p1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ m.eq_data[k, 0:3]
        p2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ m.eq_data[k, 3:6]
        return b1, p1, b2, p2

    def closure(self):
        """The loops' gaps (x, y per connect), their Jacobian and J̇·q̇, at the data's state."""
        m, d = self.m, self.d
        rows, jac, drift = [], [], []
        a1, a2 = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for k in range(m.neq):
            b1, p1, b2, p2 = self.anchors(k)
            mujoco.mj_jac(m, d, a1, None, p1, b1)
            mujoco.mj_jac(m, d, a2, None, p2, b2)
            j = a1 - a2
            mujoco.mj_jacDot(m, d, a1, None, p1, b1)
            mujoco.mj_jacDot(m, d, a2, None, p2, b2)
            jdot = a1 - a2
            rows.extend((p1 - p2)[:2])
            jac.extend(j[:2])
            drift.extend((jdot @ d.qvel)[:2])
        return np.array(rows), np.array(jac).reshape(-1, m.nv), np.array(drift)

    def place(self, qpos: np.ndarray, independent: list[int]) -> None:
        """Newton on the gaps over the dependent coordinates, from `qpos`."""
        m, d = self.m, self.d
        d.qpos[:] = qpos
        dependent = [i for i in range(m.nv) if i not in independent]
        for _ in range(60):
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            gap, jac, _ = self.closure()
            if not m.neq or np.max(np.abs(gap)) < 1e-15:
                break
            d.qpos[dependent] -= np.linalg.lstsq(jac[:, dependent], gap, rcond=None)[0]
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        gap, _, _ = self.closure()
        if m.neq and np.max(np.abs(gap)) > 1e-13:
            raise SystemExit(f"generic_examples: the loops do not close (gap {np.max(np.abs(gap)):.3g})")

    def acceleration(self, qpos, qvel, efforts, independent: list[int]) -> np.ndarray:
        m, d = self.m, self.d
        self.place(qpos, independent)
        if m.neq:
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            _, jac, _ = self.closure()
            dependent = [i for i in range(m.nv) if i not in independent]
            v = np.array(qvel, dtype=float)
            v[dependent] = -np.linalg.lstsq(jac[:, dependent], jac[:, independent] @ v[independent],
                                            rcond=None)[0]
            d.qvel[:] = v
        else:
            d.qvel[:] = qvel
        # The efforts at their joints (gear 1) as applied forces: MuJoCo's ctrl is clamped to
        # the effort limit, and the twin's B is the unclipped plant's.
        d.ctrl[:] = 0.0
        mujoco.mj_forward(m, d)
        self.loads.apply(m, d)
        d.qfrc_applied[:] += efforts
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        force = d.qfrc_smooth.copy()
        if not m.neq:
            return np.linalg.solve(full, force)
        _, jac, drift = self.closure()
        c = jac.shape[0]
        kkt = np.block([[full, jac.T], [jac, np.zeros((c, c))]])
        solution = np.linalg.lstsq(kkt, np.concatenate([force, -drift]), rcond=None)[0]
        return solution[: m.nv]


def dynamics_of(args):
    machine = mm.Machine(args.urdf, [], mm.DEFAULT_GRAVITY, 1e-3)
    # The equality constraints are the KKT's, not MuJoCo's soft solver's.
    machine.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EQUALITY
    return machine, Dynamics(machine, Loads(machine, args.force, args.spring))


def placed(machine, positions: dict[str, float], velocities: dict[str, float]):
    data = mujoco.MjData(machine.model)
    machine.model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_EQUALITY)
    machine.set_state(data, positions, velocities)
    machine.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EQUALITY
    return data


def place(args) -> None:
    machine, _ = dynamics_of(args)
    given = {k: [float(x) for x in v.split(",")] for k, v in pairs(args.joint).items()}
    data = placed(machine, {k: v[0] for k, v in given.items()},
                  {k: v[1] for k, v in given.items()})
    q, v = machine.twin_state(data)
    print(json.dumps({j.name: [q[i], v[i]] for i, j in enumerate(machine.twin_joints)}))


def linearize(args) -> None:
    machine, dynamics = dynamics_of(args)
    with open(args.linear, encoding="utf-8") as f:
        linear = json.load(f)
    names = [s["name"] for s in linear["states"]]
    n = len(names) // 2
    joints = [name.rsplit(".", 1)[0] for name in names[:n]]
    x0 = np.array(linear["operating_point"]["state"], dtype=float)
    u0 = np.array(linear["operating_point"]["efforts"], dtype=float)
    inputs = [s["name"] for s in linear["inputs"]]
    actuated = [machine.vadr[name] for name in inputs]
    dofs = [machine.vadr[j] for j in joints]
    qadr = [machine.qadr[j] for j in joints]
    start = placed(machine, dict(zip(joints, x0[:n])), dict(zip(joints, x0[n:])))
    q_start = start.qpos.copy()

    def rates(x, u):
        qpos = q_start.copy()
        qpos[qadr] = x[:n]
        qvel = np.zeros(machine.model.nv)
        qvel[dofs] = x[n:]
        efforts = np.zeros(machine.model.nv)
        efforts[actuated] = u
        qacc = dynamics.acceleration(qpos, qvel, efforts, dofs)
        return np.concatenate([x[n:], qacc[dofs]])

    def step(value):
        h = np.finfo(float).eps ** (1.0 / 3.0) * max(abs(value), 1.0)
        return (value + h) - value

    a = np.zeros((2 * n, 2 * n))
    for j in range(2 * n):
        h = step(x0[j])
        plus, minus = x0.copy(), x0.copy()
        plus[j] += h
        minus[j] -= h
        a[:, j] = (rates(plus, u0) - rates(minus, u0)) / (2 * h)
    b = np.zeros((2 * n, len(u0)))
    for k in range(len(u0)):
        h = step(u0[k])
        plus, minus = u0.copy(), u0.copy()
        plus[k] += h
        minus[k] -= h
        b[:, k] = (rates(x0, plus) - rates(x0, minus)) / (2 * h)
    print(json.dumps({"states": names, "inputs": inputs, "A": a.tolist(), "B": b.tolist(),
                      "rates": rates(x0, u0).tolist()}))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("--urdf", required=True)
    r.add_argument("--set", action="append", default=[])
    r.add_argument("--fault", action="append", default=[])
    r.add_argument("--fault-at", type=float, default=math.inf)
    r.add_argument("--controller", default="pid")
    r.add_argument("--reference", action="append", default=[])
    r.add_argument("--gain", action="append", default=[])
    r.add_argument("--duration", type=float, required=True)
    r.add_argument("--dt", type=float, required=True)
    r.add_argument("--control-period", type=float, default=1e-3)
    r.add_argument("--log", required=True)
    r.add_argument("--noise", action="append", default=[])
    r.add_argument("--resolution", action="append", default=[])
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--out", required=True)
    for name in ("place", "linearize"):
        p = sub.add_parser(name)
        p.add_argument("--urdf", required=True)
        p.add_argument("--force", action="append", default=[], help="LINK,X,Y,FX,FY")
        p.add_argument("--spring", action="append", default=[], help="LINK,X,Y,AX,AY,K,C")
        if name == "place":
            p.add_argument("--joint", action="append", default=[], help="JOINT=POSITION,VELOCITY")
        else:
            p.add_argument("--linear", required=True, help="the twin's linear.json")
    args = parser.parse_args()
    {"run": run, "place": place, "linearize": linearize}[args.command](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
