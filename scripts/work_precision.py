"""The work-precision diagrams of `scripts/bench-mujoco --work-precision`, one per machine:
each engine and integrator at several time steps, the largest error over one second against
the simulated seconds each computes per wall second.

- The Whitworth coasting from one turn a second (no drive, gravity on): the ram's position.
- The arm falling from a bent pose (shoulder 0, elbow −0.9, wrist 0.4 rad; the drives' power
  off, no stock, as bench-mujoco's arm-fall case): the joints' angles. A tree: MuJoCo has no
  constraint to soften, and only its default settings are shown.

- The twin: the exact engine (loops closed to 1e-12 m) with each of its integrators (`[solver]
  integrator`: RK4, the explicit midpoint rule, semi-implicit Euler) at each step, its speed
  from `twin bench` with recording off and on, its error from `twin run --csv`
  (`true.ram.position`).
- MuJoCo: Euler, implicitfast and RK4 at each step, with its default constraint settings
  (solref [0.02, 1], solimp [0.9, 0.95, 0.001, 0.5, 2]) and with stiff ones (solref 2·dt,
  solimp 0.9999, as scripts/mujoco_machine.py's Machine sets), timed by `mujoco.rollout` over
  `--duration` s (one thread, the state of every step written), its error from the same
  rollout's first second.
- The reference: the twin at dt = 1/16 ms. MuJoCo's RK4 at the same step with stiff
  constraints is compared with it too, and the figure's title says by how much they differ: the
  floor under which no error on the plot means anything.
"""

import os
import re
import time

import numpy as np
import mujoco
from mujoco import rollout

import mujoco_machine as mm

STEPS = (4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4)
REFERENCE_DT = 6.25e-5
HORIZON = 1.0
CRANK_SPEED = -2.0 * np.pi
INTEGRATORS = {"Euler": mujoco.mjtIntegrator.mjINT_EULER,
               "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
               "RK4": mujoco.mjtIntegrator.mjINT_RK4}
TWIN_INTEGRATORS = {"RK4": "rk4", "midpoint": "midpoint",
                    "semi-implicit Euler": "semi_implicit_euler"}
DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


ARM_POSE = {"shoulder": 0.0, "elbow": -0.9, "wrist": 0.4}


def coast_scenario(folder: str, repo: str, dt: float, duration: float) -> str:
    """The coasting Whitworth at `dt` as a scenario file in `folder`."""
    path = os.path.join(folder, f"coast-{dt:g}-{duration:g}.toml")
    urdf = os.path.join(repo, "urdf", "whitworth.urdf")
    with open(path, "w", encoding="utf-8") as f:
        f.write(f'name = "whitworth-coast"\ndescription = "Whitworth coasting, no drive"\n'
                f'machine = "whitworth"\nurdf = "{urdf}"\nduration = {duration!r}\n'
                f'dt = {dt!r}\n\n[controller]\nname = "passive"\n\n'
                f'[initial.crank]\nposition = 0.0\nvelocity = {CRANK_SPEED!r}\n\n'
                f'[recording]\nevery = 1\n')
    return path


def fall_scenario(make_fall, folder: str, dt: float, duration: float) -> str:
    """bench-mujoco's passive arm fall (`make_fall`) at `dt`, its control period the same."""
    sub = os.path.join(folder, f"fall-{dt:g}-{duration:g}")
    os.makedirs(sub, exist_ok=True)
    path = make_fall(sub, ARM_POSE, duration, False)
    with open(path, encoding="utf-8") as f:
        text = f.read()
    text = re.sub(r"(?m)^dt = .*$", f"dt = {dt!r}", text)
    text = re.sub(r"(?m)^control_period = .*$", f"control_period = {dt!r}", text)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def cases(repo: str, make_fall) -> dict:
    """Each machine: its twin scenario at (folder, dt, duration), the joints compared, its URDF
    and start for MuJoCo, the constraint settings shown, the quantity's label."""
    return {
        "whitworth": {
            "scenario": lambda folder, dt, duration: coast_scenario(folder, repo, dt, duration),
            "joints": ["ram"], "urdf": os.path.join(repo, "urdf", "whitworth.urdf"),
            "initial": {"crank": (0.0, CRANK_SPEED)}, "stiffness": (False, True),
            "quantity": "ram position error over 1 s, largest (m)",
            "title": "Whitworth coasting from 1 rev/s"},
        "arm": {
            "scenario": lambda folder, dt, duration: fall_scenario(make_fall, folder, dt,
                                                                   duration),
            "joints": list(ARM_POSE), "urdf": os.path.join(repo, "urdf", "arm.urdf"),
            "initial": {j: (q, 0.0) for j, q in ARM_POSE.items()}, "stiffness": (False,),
            "quantity": "joint angle error over 1 s, largest (rad)",
            "title": "The arm falling from a bent pose, drives off"},
    }


def twin_positions(command, twin: str, case: dict, folder: str, dt: float, sets=()):
    """The twin's positions of the case's joints over the horizon at `dt` (with the scenario
    values `sets`): (time, rows)."""
    path = case["scenario"](folder, dt, HORIZON)
    csv = os.path.splitext(path)[0] + ".csv"
    flags = [word for value in sets for word in ("--set", value)]
    command([twin, "run", path, "--csv", csv, "--out", csv[:-4] + ".rrd", *flags], folder)
    names, table = mm.read_csv(csv)
    columns = [names.index(f"true.{j}.position") for j in case["joints"]]
    return table[:, 0], table[:, columns]


def error_against(reference, t: np.ndarray, q: np.ndarray) -> float:
    """Largest |q − reference| at the times `t` (the reference's grid holds every one)."""
    rt, rq = reference
    at = np.searchsorted(rt, t - 1e-12)
    if np.any(np.abs(rt[at] - t) > 1e-9):
        raise ValueError("the reference's grid misses a time of the run compared")
    return float(np.max(np.abs(q - rq[at])))


def mujoco_machine(urdf: str, dt: float, integrator: str, stiff: bool) -> mm.Machine:
    machine = mm.Machine(urdf, [], dt=dt, sensors=[])
    m = machine.model
    m.opt.integrator = INTEGRATORS[integrator]
    if not stiff:
        m.opt.jacobian = mujoco.mjtJacobian.mjJAC_AUTO
        for i in range(m.neq):
            m.eq_solref[i] = DEFAULT_SOLREF
            m.eq_solimp[i] = DEFAULT_SOLIMP
    return machine


def mujoco_point(machine: mm.Machine, case: dict, duration: float, repeats: int):
    """MuJoCo's speed (simulated s per wall s, best of `repeats`) and the case's joints over the
    horizon."""
    m = machine.model
    data = mujoco.MjData(m)
    initial = case["initial"]
    machine.set_state(data, {k: v[0] for k, v in initial.items()},
                      {k: v[1] for k, v in initial.items()})
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    start = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, data, start, spec)
    steps = int(round(duration / m.opt.timestep))
    control = np.zeros((1, steps, m.nu))
    state = np.empty((1, steps, start.shape[0]))
    sensordata = np.empty((1, steps, m.nsensordata))
    best = 0.0
    for _ in range(repeats):
        began = time.perf_counter()
        rollout.rollout(m, data, start[None], control, nstep=steps, state=state,
                        sensordata=sensordata)
        best = max(best, duration / (time.perf_counter() - began))
    rows = int(round(HORIZON / m.opt.timestep))
    out = np.empty((rows + 1, len(case["joints"])))
    names = [j.name for j in machine.twin_joints]
    columns = [names.index(j) for j in case["joints"]]
    previous = None
    for k in range(rows + 1):
        mujoco.mj_setState(m, data, start if k == 0 else state[0, k - 1], spec)
        mujoco.mj_forward(m, data)
        q, _ = machine.twin_state(data, previous)
        previous = q
        out[k] = q[columns]
    t = np.arange(rows + 1) * m.opt.timestep
    finite = bool(np.all(np.isfinite(state)))
    return best, (t, out), finite


def measure(command, bench, twin: str, case: dict, folder: str, duration: float,
            repeats: int) -> dict:
    """Every point of a case's diagram, and the reference's agreement with MuJoCo's finest
    run."""
    os.makedirs(folder, exist_ok=True)
    reference = twin_positions(command, twin, case, folder, REFERENCE_DT)
    points = []
    for integrator, name in TWIN_INTEGRATORS.items():
        sets = [f"solver.integrator={name}"]
        for dt in STEPS:
            t, q = twin_positions(command, twin, case, folder, dt, sets)
            path = case["scenario"](folder, dt, duration)
            speeds = [bench(twin, path, duration, folder, sets) for _ in range(repeats)]
            error = error_against(reference, t, q)
            for label, steps_per_s in ((f"twin {integrator}", max(s[0] for s in speeds)),
                                       (f"twin {integrator}, recorded",
                                        max(s[1] for s in speeds))):
                points.append({"family": label, "dt": dt, "error": error,
                               "realtime": steps_per_s * dt, "steps_per_s": steps_per_s})
    for stiff in case["stiffness"]:
        for integrator in INTEGRATORS:
            for dt in STEPS:
                machine = mujoco_machine(case["urdf"], dt, integrator, stiff)
                speed, (t, q), finite = mujoco_point(machine, case, duration, repeats)
                error = error_against(reference, t, q) if finite else float("inf")
                family = f"MuJoCo {integrator}"
                if len(case["stiffness"]) > 1:
                    family += f", {'stiff' if stiff else 'default'} constraints"
                points.append({"family": family, "dt": dt, "error": error,
                               "realtime": speed, "steps_per_s": speed / dt})
    finest = mujoco_machine(case["urdf"], REFERENCE_DT, "RK4", True)
    _, (t, q), _ = mujoco_point(finest, case, HORIZON, 1)
    return {"points": points, "reference_dt": REFERENCE_DT, "horizon_s": HORIZON,
            "mujoco_rk4_vs_reference": error_against(reference, t, q),
            "quantity": case["quantity"], "title": case["title"]}


def plot(results: dict, path: str) -> None:
    """The diagram as a PNG: error (x, log) against simulated seconds per wall second (y, log);
    one line per engine and integrator, its points the time steps (labelled on the twin's)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 7), dpi=110)
    families = dict.fromkeys(p["family"] for p in results["points"])
    ax.set_prop_cycle(color=[plt.get_cmap("tab20")(i % 20) for i in range(len(families))])
    styles = {"twin": ("-", "o", 2.5), "default": ("--", "s", 1.2), "stiff": (":", "^", 1.2)}
    for family in families:
        pts = [p for p in results["points"] if p["family"] == family and np.isfinite(p["error"])]
        if not pts:
            continue
        kind = "twin" if family.startswith("twin") else (
            "stiff" if "stiff" in family else "default")
        line, marker, width = styles[kind]
        x = [max(p["error"], 1e-16) for p in pts]
        y = [p["realtime"] for p in pts]
        ax.plot(x, y, line, marker=marker, linewidth=width, label=family)
        if family == "twin RK4":
            for p, xi, yi in zip(pts, x, y):
                ax.annotate(f"{p['dt'] * 1e3:g} ms", (xi, yi), textcoords="offset points",
                            xytext=(6, 4), fontsize=8)
    floor = results["mujoco_rk4_vs_reference"]
    ax.axvline(floor, color="grey", linewidth=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(results["quantity"])
    ax.set_ylabel("simulated seconds per wall-clock second")
    ax.set_title(f"{results['title']}: work against precision\n"
                 f"(reference: the twin at {results['reference_dt'] * 1e3:g} ms; MuJoCo RK4 "
                 f"there differs by {floor:.1e}: grey line)", fontsize=10)
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
