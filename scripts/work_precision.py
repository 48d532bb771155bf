"""The work-precision diagram of `scripts/bench-mujoco --work-precision`: on the Whitworth
coasting for one second from one turn a second (no drive, gravity on), each engine and
integrator at several time steps, the ram's largest position error over that second against
the simulated seconds each computes per wall second.

- The twin: the exact engine (RK4, loops closed to 1e-12 m) at each step, its speed from
  `twin bench` with recording off and on, its error from `twin run --csv` (`true.ram.position`).
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
DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


def scenario(folder: str, repo: str, dt: float, duration: float) -> str:
    """The coasting Whitworth at `dt` as a scenario file in `folder`."""
    path = os.path.join(folder, f"coast-{dt:g}.toml")
    urdf = os.path.join(repo, "urdf", "whitworth.urdf")
    with open(path, "w", encoding="utf-8") as f:
        f.write(f'name = "whitworth-coast"\ndescription = "Whitworth coasting, no drive"\n'
                f'machine = "whitworth"\nurdf = "{urdf}"\nduration = {duration!r}\n'
                f'dt = {dt!r}\n\n[controller]\nname = "passive"\n\n'
                f'[initial.crank]\nposition = 0.0\nvelocity = {CRANK_SPEED!r}\n\n'
                f'[recording]\nevery = 1\n')
    return path


def twin_ram(command, twin: str, folder: str, repo: str, dt: float):
    """The twin's ram position over the horizon at `dt`: (time, position)."""
    path = scenario(folder, repo, dt, HORIZON)
    csv = os.path.join(folder, f"coast-{dt:g}.csv")
    command([twin, "run", path, "--csv", csv, "--out", csv[:-4] + ".rrd"], folder)
    names, table = mm.read_csv(csv)
    return table[:, 0], table[:, names.index("true.ram.position")]


def error_against(reference, t: np.ndarray, ram: np.ndarray) -> float:
    """Largest |ram − reference| at the times `t` (the reference's grid holds every one)."""
    rt, rram = reference
    at = np.searchsorted(rt, t - 1e-12)
    if np.any(np.abs(rt[at] - t) > 1e-9):
        raise ValueError("the reference's grid misses a time of the run compared")
    return float(np.max(np.abs(ram - rram[at])))


def mujoco_machine(repo: str, dt: float, integrator: str, stiff: bool) -> mm.Machine:
    machine = mm.Machine(os.path.join(repo, "urdf", "whitworth.urdf"), [], dt=dt, sensors=[])
    m = machine.model
    m.opt.integrator = INTEGRATORS[integrator]
    if not stiff:
        m.opt.jacobian = mujoco.mjtJacobian.mjJAC_AUTO
        for i in range(m.neq):
            m.eq_solref[i] = DEFAULT_SOLREF
            m.eq_solimp[i] = DEFAULT_SOLIMP
    return machine


def mujoco_point(machine: mm.Machine, duration: float, repeats: int):
    """MuJoCo's speed (simulated s per wall s, best of `repeats`) and its ram over the horizon."""
    m = machine.model
    data = mujoco.MjData(m)
    machine.set_state(data, {"crank": 0.0}, {"crank": CRANK_SPEED})
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
    ram = np.empty(rows + 1)
    i = [j.name for j in machine.twin_joints].index("ram")
    previous = None
    for k in range(rows + 1):
        mujoco.mj_setState(m, data, start if k == 0 else state[0, k - 1], spec)
        mujoco.mj_forward(m, data)
        q, _ = machine.twin_state(data, previous)
        previous = q
        ram[k] = q[i]
    t = np.arange(rows + 1) * m.opt.timestep
    finite = bool(np.all(np.isfinite(state)))
    return best, (t, ram), finite


def measure(command, bench, twin: str, repo: str, folder: str, duration: float,
            repeats: int) -> dict:
    """Every point of the diagram, and the reference's agreement with MuJoCo's finest run."""
    os.makedirs(folder, exist_ok=True)
    reference = twin_ram(command, twin, folder, repo, REFERENCE_DT)
    points = []
    for dt in STEPS:
        t, ram = twin_ram(command, twin, folder, repo, dt)
        path = scenario(folder, repo, dt, duration)
        speeds = [bench(twin, path, duration, folder) for _ in range(repeats)]
        steps_bare = max(s[0] for s in speeds)
        steps_rec = max(s[1] for s in speeds)
        error = error_against(reference, t, ram)
        for label, steps_per_s in (("twin RK4", steps_bare), ("twin RK4, recorded", steps_rec)):
            points.append({"family": label, "dt": dt, "error_m": error,
                           "realtime": steps_per_s * dt, "steps_per_s": steps_per_s})
    for stiff in (False, True):
        for integrator in INTEGRATORS:
            for dt in STEPS:
                machine = mujoco_machine(repo, dt, integrator, stiff)
                speed, (t, ram), finite = mujoco_point(machine, duration, repeats)
                error = error_against(reference, t, ram) if finite else float("inf")
                family = f"MuJoCo {integrator}, {'stiff' if stiff else 'default'} constraints"
                points.append({"family": family, "dt": dt, "error_m": error,
                               "realtime": speed, "steps_per_s": speed / dt})
    finest = mujoco_machine(repo, REFERENCE_DT, "RK4", True)
    _, (t, ram), _ = mujoco_point(finest, HORIZON, 1)
    floor = error_against(reference, t, ram)
    return {"points": points, "reference_dt": REFERENCE_DT, "horizon_s": HORIZON,
            "mujoco_rk4_stiff_vs_reference_m": floor}


def plot(results: dict, path: str) -> None:
    """The diagram as a PNG: error (x, log) against simulated seconds per wall second (y, log);
    one line per engine and integrator, its points the time steps (labelled on the twin's)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 6), dpi=110)
    families = dict.fromkeys(p["family"] for p in results["points"])
    styles = {"twin": ("-", "o", 2.5), "default": ("--", "s", 1.2), "stiff": (":", "^", 1.2)}
    for family in families:
        pts = [p for p in results["points"] if p["family"] == family and np.isfinite(p["error_m"])]
        if not pts:
            continue
        kind = "twin" if family.startswith("twin") else (
            "default" if "default" in family else "stiff")
        line, marker, width = styles[kind]
        x = [max(p["error_m"], 1e-16) for p in pts]
        y = [p["realtime"] for p in pts]
        ax.plot(x, y, line, marker=marker, linewidth=width, label=family)
        if family == "twin RK4":
            for p, xi, yi in zip(pts, x, y):
                ax.annotate(f"{p['dt'] * 1e3:g} ms", (xi, yi), textcoords="offset points",
                            xytext=(6, 4), fontsize=8)
    floor = results["mujoco_rk4_stiff_vs_reference_m"]
    ax.axvline(floor, color="grey", linewidth=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ram position error over 1 s, largest (m)")
    ax.set_ylabel("simulated seconds per wall-clock second")
    ax.set_title("Whitworth coasting from 1 rev/s: work against precision\n"
                 f"(reference: the twin at {results['reference_dt'] * 1e3:g} ms; MuJoCo RK4 "
                 f"there, stiff, differs by {floor:.1e} m: grey line)", fontsize=10)
    ax.grid(True, which="both", linewidth=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
