#!/usr/bin/env python3
"""MuJoCo plays the machine: a measured run of one of the twin's planar URDFs, made by an engine
the twin did not write, for `twin calibrate` and its benchmark (scripts/bench-calibration).

    eval "$(scripts/test-tools)"
    "$TWIN_TOOLS_PYTHON" scripts/mujoco_machine.py --urdf urdf/arm.urdf \
        --initial shoulder=-1.5707963267948966 \
        --set link.forearm.mass=5.6 --set joint.elbow.damping=0.45 \
        --torque "shoulder=multisine:amp=12,fmin=0.2,fmax=4,tones=10,seed=1" \
        --torque "elbow=4*sin(2*pi*1.3*t)" \
        --duration 5 --dt 0.001 --control-period 0.001 --out run.csv \
        --noise '*.position=1e-4' --seed 7

or, as a real machine runs and logs (its own controller, only what its sensors and drives give,
noisy, a tenth of the rows lost):

    "$TWIN_TOOLS_PYTHON" scripts/mujoco_machine.py --urdf urdf/whitworth.urdf \
        --set link.ram.mass=6 --set joint.crank.damping=0.3 \
        --controller speed-pi --gain inertia=1.5 --gain natural_frequency=30 \
        --reference 'crank=multisine:amp=2,fmin=0.2,fmax=3,tones=8,seed=2,offset=-2*pi' \
        --duration 5 --dt 1e-4 --control-period 1e-3 \
        --log effort.crank,ram.position --noise ram.position=1e-5 --drop 0.1 --seed 0 \
        --out run.csv --truth-out truth.csv

The model. MuJoCo's own URDF import (`mujoco.MjSpec.from_file`) reads the file; then, on the
spec, before compiling:
  - gravity along −y (the twin's planar URDFs lie in x–y; `--gravity`, default 0,−9.81 as the
    twin's scenarios), contacts off (`mjDSBL_CONTACT`), joint limits off (`mjDSBL_LIMIT`: the
    twin's limits are inelastic stops, MuJoCo's soft constraints; a run that reaches a limit is
    reported as not comparable instead), classical RK4 at `--dt` (the twin's exact engine is RK4
    with efforts held over the step), a dense Jacobian;
  - one `motor` actuator per driven joint (URDF `<limit effort>` > 0), gear 1: ctrl is the joint
    effort in N·m or N, clipped to the effort limit as the twin clips it;
  - the twin's `<loop_joint>` extension, which MuJoCo's import ignores, as equality constraints:
    a revolute loop joint is a `connect` at link1's point; a prismatic one (the Whitworth's
    slot) becomes a tree slide joint of link2 under link1, and link2's former revolute joint
    (the crank pin) the `connect` (MuJoCo has no slider equality). The dropped revolute joint's
    angle is still written, from the two bodies' orientations;
  - the hidden values (`--set`), with the twin's meaning (twin/src/plant.rs): `link.L.mass`
    alone scales the link's inertia with it (same shape, denser), `link.L.izz` is the moment of
    inertia about z through the centre of mass, `link.L.com=x,y`, `joint.J.damping`,
    `joint.J.friction` (MuJoCo frictionloss: a constraint, not the twin's per-step impulse).
    `urdf.` in front is accepted, as the twin spells them in `--set`.

Joint coordinates are the twin's: MuJoCo's URDF import puts every joint's zero at the URDF's
zero pose and its sign along the URDF axis, as the twin does (checked against the twin's Python
package; see tests/mujoco/README.md for the figures). `--initial` sets joints by the twin's
coordinates; on a linkage, the joints not given (and the slide MuJoCo adds) are solved from the
closures: given no more joints than the linkage's degrees of freedom (the Whitworth's crank),
they are moved there from the URDF pose in small steps, so it stays on the URDF's assembly branch
(the twin, given the crank alone, assembles elsewhere: give it every joint); given every joint
(a recorded state), the least change that closes the loops. The model's MjSensors (jointpos,
jointvel, named `<joint>.position`, `.velocity`) are read at the start of each step: in
`mujoco.rollout` they lag the returned state by one step (fit states, `<joint>_qpos`, instead).

The run. Efforts are held over each control period (zero-order hold; `--control-period` a
multiple of `--dt`). Row k of the CSV holds t_k, the effort applied over [t_k, t_k + period) and
the joint states at t_k; N = duration/period periods give N + 1 rows (the last effort is the
excitation's value at t_N, not applied). Columns: `time [s]`, `effort.<joint> [N·m]` ([N] on a
prismatic joint) for each driven joint, then `<joint>.position [rad]`, `<joint>.velocity [rad/s]`
([m], [m/s] on a prismatic joint) for every movable URDF joint, in URDF order, or the joint
states `--signals` names. `--noise` adds Gaussian noise (seeded by `--seed`) to the written
columns only; `--truth-out` writes the run again without noise and with every joint (its first
row: every joint's initial state, the twin's `[initial]`). `--effort-unit A` labels the efforts
as the arm scenario's unit-gain current drives take them (1 A = 1 N·m). `--rest` starts the run
where gravity holds the machine (`rest_state`: a passive settle; the Whitworth ram down).

The machine's own controller (`--controller`; without it the efforts are `--torque`'s, open
loop). At each control period t_k it reads MuJoCo's state there (the controlled joints'
positions and velocities in the twin's coordinates, noise-free: what its encoders and
tachometers read), and its command, clipped to the URDF's effort limits, is held over
[t_k, t_k + period); row k holds that command. It is designed on the URDF's nominal values
(a second, unmodified model), never on `--set`'s. `--reference JOINT=SPEC` is a SPEC as
`--torque`'s below, in the controller's units:
  speed-pi  per joint the twin's `crank-pi` law: τ = kp·e + ki·∫e, e = r − q̇ (rad/s or m/s),
            the integral frozen while the command is clipped; kp = 2ζω_n·J, ki = ω_n²·J with
            `--gain inertia=J` (default: the joint's nominal reduced inertia at the start, the
            loops closed), `natural_frequency=ω_n` (30 rad/s), `damping_ratio=ζ` (1), or
            `kp=…`, `ki=…` directly. A joint not given starts at its URDF position turning at
            r(0). Every driven joint needs a reference.
  pid       per joint τ = kp·e + kd·ė + ki·∫e + g(q), e = r − q (rad or m), ė = ṙ − q̇ (ṙ by
            differences on the control grid), the integral frozen while clipped; a triple pole
            at −ω: kd = 3ω·J, kp = 3ω²·J, ki = ω³·J with `bandwidth=ω` (10 rad/s) and `inertia`
            as above, or `kp`, `ki`, `kd` directly; g(q) the nominal model's gravity at the
            measured q (`gravity=1`, the default where the machine has no closed loops). A
            driven joint without a reference is held where it starts; a joint not given starts
            on its reference (r(0), ṙ(0)).
A gain names every controlled joint (`kp=…`) or one (`elbow.kp=…`). `--controller` and
`--torque` exclude each other.

The logger (`--log`, `--log-period`, `--drop`; any of them writes the CSV this way, `--signals`
then not allowed). `--log NAME,…` the columns after `time [s]`, in that order: `effort.<joint>`
(the command held at the logged instant), `<joint>.position`, `<joint>.velocity` of any movable
joint, units as the twin's run format ([N·m], [N], [rad], [m], [rad/s], [m/s]; `--effort-unit`
relabels the efforts); default every effort and every joint state. `--log-period S` writes a
row every S (a multiple of the control period; default the control period). `--noise` is drawn
on the logged rows, then `--drop F` removes round(F × rows) of them at random (seeded by
`--seed` too, a stream apart from the noise's; never the first or the last row). `--truth-out`
is unchanged: every joint's noise-free state and every command at every control period.

`--torque JOINT=SPEC`, SPEC one of:
  multisine:amp=A,fmin=F0,fmax=F1,tones=N,seed=S,offset=O
      N tones log-spaced over [F0, F1] Hz, each nudged by up to ±10 % with the seed, Schroeder
      phases, scaled to peak |A| about the offset O (defaults: fmin 0.2, fmax 4, tones 10,
      seed 1, offset 0; a value may use pi: offset=-2*pi);
  an expression in t (s): numpy's sin, cos, tan, exp, log, sqrt, abs, sign, where, clip,
      minimum, maximum, pi, e; e.g. "3*sin(2*pi*0.7*t) + 1.5*cos(2*pi*2.3*t)";
  0 or zero.
A driven joint without --torque gets the default, a multisine with amp = 10 % of its effort
limit and seed = 1 + its index among the driven joints. The excitation has to keep the machine
within its joint limits and away from chaos (an open-loop arm should hang: start it with
`--initial shoulder=-pi/2`).

Importable: `Machine` (the model and the state mapping), `excitation`, `simulate`,
`simulate_controlled` and `Controller`, `rest_state`, `write_csv`, `write_log`, `read_csv`,
`main` are used by scripts/bench-calibration; the CLI by the CI test
tests/tests/mujoco_calibration.rs.
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
import math
import os
import sys
import tempfile
import time as wallclock
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

DEFAULT_GRAVITY = (0.0, -9.81)
# MuJoCo's soft equality constraints, made as stiff as its stability allows: a time constant of
# two steps (the least MuJoCo accepts without mjDSBL_REFSAFE), critically damped, and an
# impedance close to 1 over any violation. Measured on the Whitworth: see tests/mujoco/README.md.
LOOP_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


# --------------------------------------------------------------------------------------------
# The URDF, as the twin reads it


@dataclasses.dataclass
class UrdfJoint:
    name: str
    kind: str  # revolute, continuous, prismatic, fixed, …
    parent: str
    child: str
    xyz: tuple[float, float, float]
    yaw: float
    axis: tuple[float, float, float]
    effort: float
    limits: tuple[float, float] | None

    @property
    def movable(self) -> bool:
        return self.kind in ("revolute", "continuous", "prismatic")

    @property
    def prismatic(self) -> bool:
        return self.kind == "prismatic"

    @property
    def driven(self) -> bool:
        return self.movable and self.effort > 0.0


@dataclasses.dataclass
class LoopJoint:
    name: str
    kind: str  # revolute or prismatic
    link1: str
    xyz1: tuple[float, float, float]
    yaw1: float
    link2: str
    xyz2: tuple[float, float, float]
    yaw2: float
    axis: tuple[float, float, float]


def _floats(text: str | None, default: str) -> tuple[float, ...]:
    return tuple(float(v) for v in (text or default).split())


def _planar_origin(element: ET.Element | None, what: str) -> tuple[tuple[float, float, float], float]:
    xyz = _floats(element.get("xyz") if element is not None else None, "0 0 0")
    rpy = _floats(element.get("rpy") if element is not None else None, "0 0 0")
    if abs(xyz[2]) > 1e-9 or abs(rpy[0]) > 1e-9 or abs(rpy[1]) > 1e-9:
        raise SystemExit(f"mujoco_machine: {what} is not planar (xyz {xyz}, rpy {rpy})")
    return (xyz[0], xyz[1], xyz[2]), rpy[2]


def read_urdf(path: str) -> tuple[list[UrdfJoint], list[LoopJoint]]:
    root = ET.parse(path).getroot()
    joints = []
    for j in root.findall("joint"):
        name = j.get("name")
        xyz, yaw = _planar_origin(j.find("origin"), f"joint {name} <origin>")
        axis_el = j.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, "1 0 0")
        limit = j.find("limit")
        effort = float(limit.get("effort", "0")) if limit is not None else 0.0
        limits = None
        if limit is not None and j.get("type") in ("revolute", "prismatic"):
            lo, hi = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
            if lo < hi:
                limits = (lo, hi)
        joints.append(
            UrdfJoint(
                name=name,
                kind=j.get("type"),
                parent=j.find("parent").get("link"),
                child=j.find("child").get("link"),
                xyz=xyz,
                yaw=yaw,
                axis=(axis[0], axis[1], axis[2]),
                effort=effort,
                limits=limits,
            )
        )
    loops = []
    for lj in root.findall("loop_joint"):
        name = lj.get("name")
        l1, l2 = lj.find("link1"), lj.find("link2")
        xyz1, yaw1 = _planar_origin(l1, f"loop_joint {name} link1")
        xyz2, yaw2 = _planar_origin(l2, f"loop_joint {name} link2")
        axis_el = lj.find("axis")
        axis = _floats(axis_el.get("xyz") if axis_el is not None else None, "1 0 0")
        loops.append(
            LoopJoint(
                name=name,
                kind=lj.get("type"),
                link1=l1.get("link"),
                xyz1=xyz1,
                yaw1=yaw1,
                link2=l2.get("link"),
                xyz2=xyz2,
                yaw2=yaw2,
                axis=(axis[0], axis[1], axis[2]),
            )
        )
    return joints, loops


def _rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def _yaw_quat(angle: float) -> list[float]:
    return [math.cos(angle / 2.0), 0.0, 0.0, math.sin(angle / 2.0)]


def _quat_yaw(q: np.ndarray) -> float:
    return 2.0 * math.atan2(q[3], q[0])


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


# --------------------------------------------------------------------------------------------
# The hidden values: the twin's `urdf.link.*` / `urdf.joint.*` keys on a MuJoCo spec


LINK_KEYS = ("mass", "izz", "com")
JOINT_KEYS = ("damping", "friction")


def parse_value(text: str) -> tuple[str, str, str, float | tuple[float, float]]:
    """`[urdf.]link.L.mass=1.3` → ("link", "L", "mass", 1.3)."""
    if "=" not in text:
        raise SystemExit(f"mujoco_machine: --set {text!r}: expected KEY=VALUE")
    key, value = text.split("=", 1)
    parts = key.strip().split(".")
    if parts and parts[0] in ("urdf", "plant"):
        parts = parts[1:]
    if len(parts) != 3 or parts[0] not in ("link", "joint"):
        raise SystemExit(
            f"mujoco_machine: --set {key!r}: expected link.<link>.{{{','.join(LINK_KEYS)}}} "
            f"or joint.<joint>.{{{','.join(JOINT_KEYS)}}}"
        )
    kind, name, field = parts
    allowed = LINK_KEYS if kind == "link" else JOINT_KEYS
    if field not in allowed:
        raise SystemExit(f"mujoco_machine: --set {key!r}: `{field}` is not one of {allowed}")
    if field == "com":
        x, y = (float(v) for v in value.split(","))
        return kind, name, field, (x, y)
    return kind, name, field, float(value)


def apply_value(spec: mujoco.MjSpec, kind: str, name: str, field: str, value) -> None:
    """Writes one value into `spec` with the twin's meaning (twin/src/plant.rs). A link's mass
    scales its whole inertia tensor by mass / the spec's current mass (the URDF's, on a fresh
    spec: the same body, denser); izz then replaces the tensor's zz (about the centre of mass);
    com moves the centre of mass. Apply a link's mass before its izz, as the twin does."""
    if kind == "joint":
        joint = spec.joint(name)
        if joint is None:
            raise SystemExit(f"mujoco_machine: joint.{name}: the URDF has no such joint")
        if field == "damping":
            # MuJoCo 4 holds [linear, polynomial terms]; the twin's damping is the linear one.
            damping = np.array(joint.damping, dtype=float).ravel()
            damping[0] = float(value)
            joint.damping = damping
        elif field == "friction":
            joint.frictionloss = float(value)
        else:
            raise SystemExit(f"mujoco_machine: joint.{name}.{field}: not one of {JOINT_KEYS}")
        return
    body = spec.body(name)
    if body is None or name == "world" or not body.explicitinertial:
        raise SystemExit(f"mujoco_machine: link.{name}: no such link with an <inertial>")
    full = np.array(np.ravel(body.fullinertia)[:6], dtype=float)
    if field == "mass":
        full *= float(value) / body.mass
        body.mass = float(value)
    elif field == "izz":
        full[2] = float(value)
        # Only izz acts in the plane; raise ixx, iyy if MuJoCo's triangle inequality needs it.
        if full[0] + full[1] < full[2]:
            full[0] = full[1] = max(full[0], full[1], 0.5 * full[2])
    elif field == "com":
        x, y = value
        body.ipos = [x, y, 0.0]
    else:
        raise SystemExit(f"mujoco_machine: link.{name}.{field}: not one of {LINK_KEYS}")
    body.fullinertia = full.tolist()
    body.inertia = [0.0, 0.0, 0.0]


def apply_values(spec: mujoco.MjSpec, values: list[tuple[str, str, str, object]]) -> None:
    """`apply_value` for each, links' masses first (as twin/src/plant.rs applies them)."""
    order = {"mass": 0, "izz": 1, "com": 2, "damping": 3, "friction": 3}
    for kind, name, field, value in sorted(values, key=lambda v: order[v[2]]):
        apply_value(spec, kind, name, field, value)


# --------------------------------------------------------------------------------------------
# The machine


_WARNED: set[str] = set()


def _load_urdf(path: str) -> mujoco.MjSpec:
    """MuJoCo's URDF import; its parser's warnings (written by the C library to stderr, such as
    the Whitworth ram's `equal lower and upper limits, limit ignored`: the twin too reads
    lower = upper as no limit) are passed on once per file and process."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+") as capture:
        os.dup2(capture.fileno(), 2)
        try:
            spec = mujoco.MjSpec.from_file(path)
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        capture.seek(0)
        text = " ".join(capture.read().split())
    if text and path not in _WARNED:
        print(f"mujoco_machine: MuJoCo on {os.path.basename(path)}: {text}", file=sys.stderr)
    _WARNED.add(path)
    return spec


class Machine:
    """A twin URDF as a MuJoCo model, and the map between MuJoCo's state and the twin's joint
    coordinates."""

    def __init__(
        self,
        urdf: str,
        values: list[tuple[str, str, str, object]] | None = None,
        gravity: tuple[float, float] = DEFAULT_GRAVITY,
        dt: float = 1e-3,
        loop_timeconst: float | None = None,
        sensors: list[str] | None = None,
    ):
        self.urdf = urdf
        self.dt = dt
        self.joints, self.loops = read_urdf(urdf)
        self.twin_joints = [j for j in self.joints if j.movable]
        self.driven = [j for j in self.twin_joints if j.driven]
        self.by_name = {j.name: j for j in self.joints}
        self.loop_timeconst = loop_timeconst if loop_timeconst is not None else 2.0 * dt
        self.sensors = sensors
        self.spec = self._base_spec(gravity)
        self.values = list(values or [])
        apply_values(self.spec, self.values)
        self.model = self.spec.compile()
        self._index()

    # -- building ---------------------------------------------------------------------------

    def _base_spec(self, gravity: tuple[float, float]) -> mujoco.MjSpec:
        spec = _load_urdf(os.path.abspath(self.urdf))
        opt = spec.option
        opt.gravity = [gravity[0], gravity[1], 0.0]
        opt.timestep = self.dt
        opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
        opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
        # The derived joints: tree joints MuJoCo does not hold (replaced by a `connect`).
        self.derived: dict[str, tuple[str, str, float, float]] = {}
        for loop in self.loops:
            if loop.kind == "revolute":
                self._connect(spec, loop.name, loop.link1, loop.xyz1, loop.link2)
            elif loop.kind == "prismatic":
                self._slide_loop(spec, loop)
            else:
                raise SystemExit(f"mujoco_machine: loop_joint {loop.name}: type {loop.kind} unsupported")
        for j in self.driven:
            spec.add_actuator(
                name=j.name,
                target=j.name,
                trntype=mujoco.mjtTrn.mjTRN_JOINT,
                gear=[1.0, 0, 0, 0, 0, 0],
            )
        # Sensors named as the CSV's columns: `<joint>.position`, `<joint>.velocity` (all of the
        # joints MuJoCo holds, in URDF order, unless `sensors` names some, in its order).
        names = self.sensors
        if names is None:
            names = [f"{j.name}.{f}" for j in self.twin_joints if j.name not in self.derived
                     for f in ("position", "velocity")]
        for sensor in names:
            joint, field = sensor.rsplit(".", 1)
            if joint in self.derived or joint not in self.by_name or field not in ("position", "velocity"):
                raise SystemExit(f"mujoco_machine: no sensor {sensor!r} (a joint MuJoCo holds, "
                                 ".position or .velocity)")
            kind = mujoco.mjtSensor.mjSENS_JOINTPOS if field == "position" else mujoco.mjtSensor.mjSENS_JOINTVEL
            spec.add_sensor(name=sensor, type=kind, objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=joint)
        return spec

    def _connect(self, spec, name, body1, anchor, body2):
        eq = spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_CONNECT,
                               objtype=mujoco.mjtObj.mjOBJ_BODY, name1=body1, name2=body2)
        eq.data[:3] = [anchor[0], anchor[1], 0.0]
        eq.solref = [self.loop_timeconst, 1.0]
        eq.solimp = list(LOOP_SOLIMP)

    def _slide_loop(self, spec, loop: LoopJoint):
        """link2 moves to link1 on a slide joint; its former revolute joint becomes a connect."""
        tree = [j for j in self.joints if j.child == loop.link2]
        if len(tree) != 1 or tree[0].kind not in ("revolute", "continuous"):
            raise SystemExit(f"mujoco_machine: loop_joint {loop.name}: link2 must hang on a revolute joint")
        pin = tree[0]
        if any(j.parent == loop.link2 for j in self.joints):
            raise SystemExit(f"mujoco_machine: loop_joint {loop.name}: link2 must be a leaf")
        old = spec.body(loop.link2)
        inertial = dict(mass=old.mass, ipos=list(old.ipos), iquat=list(old.iquat),
                        fullinertia=list(np.ravel(old.fullinertia)[:6]), inertia=list(old.inertia))
        spec.delete(old)
        # At zero coordinates the loop frames coincide: link2's pose in link1 is F1 ∘ F2⁻¹.
        yaw = loop.yaw1 - loop.yaw2
        p = np.array(loop.xyz1[:2]) - _rot(yaw) @ np.array(loop.xyz2[:2])
        body = spec.body(loop.link1).add_body(name=loop.link2, pos=[p[0], p[1], 0.0], quat=_yaw_quat(yaw))
        body.explicitinertial = True
        body.mass = inertial["mass"]
        body.ipos = inertial["ipos"]
        body.iquat = inertial["iquat"]
        body.fullinertia = inertial["fullinertia"]
        body.inertia = inertial["inertia"]
        axis = _rot(loop.yaw2) @ np.array(loop.axis[:2])
        body.add_joint(name=loop.name, type=mujoco.mjtJoint.mjJNT_SLIDE,
                       pos=[loop.xyz2[0], loop.xyz2[1], 0.0], axis=[axis[0], axis[1], 0.0])
        self._connect(spec, pin.name, pin.parent, pin.xyz, loop.link2)
        sign = 1.0 if pin.axis[2] >= 0 else -1.0
        self.derived[pin.name] = (pin.parent, pin.child, pin.yaw, sign)

    def _index(self):
        m = self.model
        self.qadr, self.vadr = {}, {}
        for j in self.twin_joints:
            if j.name in self.derived:
                continue
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            self.qadr[j.name] = m.jnt_qposadr[jid]
            self.vadr[j.name] = m.jnt_dofadr[jid]
        self.body_id = {m.body(i).name: i for i in range(m.nbody)}
        self.actuator_index = {j.name: i for i, j in enumerate(self.driven)}
        self.effort_limits = np.array([j.effort for j in self.driven])

    # -- state ----------------------------------------------------------------------------

    def twin_state(self, data: mujoco.MjData, previous: np.ndarray | None = None):
        """Positions and velocities of every twin joint (URDF order). A derived joint's angle is
        unwrapped against `previous` (the last positions)."""
        n = len(self.twin_joints)
        q, v = np.empty(n), np.empty(n)
        for i, j in enumerate(self.twin_joints):
            if j.name in self.derived:
                parent, child, yaw0, sign = self.derived[j.name]
                bp, bc = self.body_id[parent], self.body_id[child]
                angle = sign * (_quat_yaw(data.xquat[bc]) - _quat_yaw(data.xquat[bp]) - yaw0)
                if previous is None:
                    q[i] = _wrap(angle)
                else:
                    q[i] = previous[i] + _wrap(angle - previous[i])
                w = np.zeros(6)
                mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, bc, w, 0)
                wc = w[2]
                mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, bp, w, 0)
                v[i] = sign * (wc - w[2])
            else:
                q[i] = data.qpos[self.qadr[j.name]]
                v[i] = data.qvel[self.vadr[j.name]]
        return q, v

    def set_state(self, data: mujoco.MjData, positions: dict[str, float],
                  velocities: dict[str, float]) -> None:
        """Puts MuJoCo in the twin's joint state. Joints not given (and MuJoCo's own loop
        coordinates) are solved from the loop closures, least change. When the given joints
        leave the linkage free to move, they are moved there from the zero pose in small steps,
        the loops closed at each, so the linkage stays on the assembly branch the URDF draws."""
        m = self.model
        mujoco.mj_resetData(m, data)
        given = {name: value for name, value in positions.items() if name in self.qadr}
        fixed = sorted({self.vadr[name] for name in given})
        # Given no more joints than the linkage has degrees of freedom, they drive it there
        # along its motion; given more (every joint of a recorded state), they are set at once.
        if m.neq:
            jac, _ = self._equality_rows(data)
            freedom = m.nv - np.linalg.matrix_rank(jac, tol=1e-9)
        else:
            freedom = m.nv
        steps = 1 if len(fixed) > freedom else max(1, int(np.ceil(max(
            [abs(v) for v in given.values()], default=0.0) / 0.05)))
        for step in range(1, steps + 1):
            for name, value in given.items():
                data.qpos[self.qadr[name]] = value * step / steps
            if m.neq:
                self._close_loops(data, fixed)
        for name, value in velocities.items():
            if name in self.vadr:
                data.qvel[self.vadr[name]] = value
        if m.neq:
            self._close_velocities(data, fixed)
        mujoco.mj_forward(m, data)

    def _equality_rows(self, data):
        m = self.model
        mujoco.mj_fwdPosition(m, data)
        rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        jac = data.efc_J.reshape(data.nefc, m.nv)[rows]
        return jac, data.efc_pos[rows].copy()

    def _close_loops(self, data, fixed_dofs):
        m = self.model
        free = [i for i in range(m.nv) if i not in fixed_dofs]
        for _ in range(50):
            jac, gap = self._equality_rows(data)
            if np.max(np.abs(gap), initial=0.0) < 1e-13:
                break
            dq = np.zeros(m.nv)
            dq[free] = -np.linalg.lstsq(jac[:, free], gap, rcond=None)[0]
            mujoco.mj_integratePos(m, data.qpos, dq, 1.0)
        _, gap = self._equality_rows(data)
        if fixed_dofs and np.max(np.abs(gap), initial=0.0) > 1e-12:
            # The given joints over-determine the linkage and miss closing it by a little (a
            # state read from a run with soft closures): the least change of every joint.
            before = data.qpos.copy()
            self._close_loops(data, [])
            change = np.max(np.abs(data.qpos - before))
            if change > 1e-6:
                raise SystemExit(f"mujoco_machine: the given joints do not close the loops "
                                 f"(they are {change:.3g} off)")
            return
        if np.max(np.abs(gap), initial=0.0) > 1e-9:
            raise SystemExit(f"mujoco_machine: the loops do not close at the given state "
                             f"(gap {np.max(np.abs(gap)):.3g})")

    def _close_velocities(self, data, fixed_dofs):
        """The free velocities that keep the loops closed, least change."""
        m = self.model
        free = [i for i in range(m.nv) if i not in fixed_dofs]
        jac, _ = self._equality_rows(data)
        v = data.qvel.copy()
        v[free] -= np.linalg.lstsq(jac[:, free], jac @ v, rcond=None)[0]
        data.qvel[:] = v

    def loop_gap(self, data) -> float:
        if not self.model.neq:
            return 0.0
        _, gap = self._equality_rows(data)
        return float(np.max(np.abs(gap)))

    # -- columns ----------------------------------------------------------------------------

    def effort_unit(self, j: UrdfJoint) -> str:
        return "N" if j.prismatic else "N·m"

    def columns(self) -> list[str]:
        cols = ["time [s]"]
        cols += [f"effort.{j.name} [{self.effort_unit(j)}]" for j in self.driven]
        for j in self.twin_joints:
            pu, vu = ("m", "m/s") if j.prismatic else ("rad", "rad/s")
            cols += [f"{j.name}.position [{pu}]", f"{j.name}.velocity [{vu}]"]
        return cols


# --------------------------------------------------------------------------------------------
# Excitation


SAFE_NAMES = {
    name: getattr(np, name)
    for name in ("sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sign", "where", "clip",
                 "minimum", "maximum", "pi", "e", "tanh", "arctan", "floor", "mod")
}


def multisine(t: np.ndarray, amp=1.0, fmin=0.2, fmax=4.0, tones=10, seed=1, offset=0.0,
              duration: float | None = None) -> np.ndarray:
    tones = int(tones)
    rng = np.random.default_rng(int(seed))
    freqs = np.geomspace(float(fmin), float(fmax), tones) if tones > 1 else np.array([float(fmin)])
    freqs = freqs * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, tones))
    k = np.arange(1, tones + 1)
    phases = -np.pi * k * (k - 1) / tones + rng.uniform(0, 2 * np.pi)
    def raw(tt):
        return np.sin(2 * np.pi * np.outer(tt, freqs) + phases).sum(axis=1)
    span = duration if duration is not None else float(t[-1] - t[0]) if len(t) > 1 else 1.0
    grid = np.linspace(0.0, max(span, 1e-9), 20001)
    peak = np.max(np.abs(raw(grid))) or 1.0
    return float(offset) + float(amp) * raw(t) / peak


def excitation(spec_text: str, t: np.ndarray, duration: float | None = None) -> np.ndarray:
    text = spec_text.strip()
    if text in ("0", "zero", ""):
        return np.zeros_like(t)
    if text.startswith("multisine"):
        args = {}
        rest = text[len("multisine"):].lstrip(":").strip()
        if rest.startswith("(") and rest.endswith(")"):
            rest = rest[1:-1]
        for item in filter(None, (s.strip() for s in rest.split(","))):
            if "=" not in item:
                raise SystemExit(f"mujoco_machine: multisine: {item!r}: expected NAME=VALUE")
            key, value = item.split("=", 1)
            if key.strip() not in ("amp", "fmin", "fmax", "tones", "seed", "offset"):
                raise SystemExit(f"mujoco_machine: multisine: unknown argument {key!r}")
            args[key.strip()] = _number(value)
        return multisine(t, duration=duration, **args)
    value = eval(text, {"__builtins__": {}}, {**SAFE_NAMES, "t": t})  # noqa: S307 (numbers only)
    return np.broadcast_to(np.asarray(value, dtype=float), t.shape).copy()


def default_excitation(machine: Machine, joint: str) -> str:
    i = machine.actuator_index[joint]
    return f"multisine:amp={0.1 * machine.effort_limits[i]:g},fmin=0.2,fmax=4,tones=10,seed={i + 1}"


# --------------------------------------------------------------------------------------------
# The machine's own controller


CONTROLLERS = {
    "speed-pi": "PI on each controlled joint's speed to its reference (rad/s or m/s)",
    "pid": "PID on each controlled joint's position to its reference (rad or m), plus gravity "
           "compensation by the URDF's nominal model where the machine has no closed loops",
}
GAIN_NAMES = {
    "speed-pi": ("inertia", "natural_frequency", "damping_ratio", "kp", "ki"),
    "pid": ("inertia", "bandwidth", "kp", "ki", "kd", "gravity"),
}
GAIN_DEFAULTS = {
    "speed-pi": {"natural_frequency": 30.0, "damping_ratio": 1.0},
    "pid": {"bandwidth": 10.0},
}


def reduced_inertia(nominal: Machine, positions: dict[str, float], joint: str) -> float:
    """The inertia a joint's drive sees at a configuration (kg·m² or kg): vᵀ·M·v with v the
    velocities of a unit speed of that joint alone, the loops closed (the other driven joints
    held). Of the URDF's nominal model: what the machine's builder knows."""
    m = nominal.model
    data = mujoco.MjData(m)
    held = {j.name: 0.0 for j in nominal.driven}
    held[joint] = 1.0
    nominal.set_state(data, positions, held)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, data, full)
    return float(data.qvel @ full @ data.qvel)


class Controller:
    """The machine's own controller, run by MuJoCo's loop at each control period from MuJoCo's
    state (the controlled joints' positions and velocities, as its encoders and tachometers
    would read them, without their noise). Designed on the URDF's nominal model (`nominal`: no
    hidden values), never on the played one.

    speed-pi: per joint the twin's `crank-pi` law, τ = kp·e + ki·∫e with e = r − q̇, the integral
    frozen while the command is clipped (anti-windup); kp = 2ζω_n·J, ki = ω_n²·J (`inertia` J,
    default the joint's nominal reduced inertia at the start; `natural_frequency` ω_n, default
    30 rad/s; `damping_ratio` ζ, default 1), or `kp`, `ki` given.

    pid: per joint τ = kp·e + kd·ė + ki·∫e + g(q) with e = r − q, ė = ṙ − q̇ (ṙ the reference's
    rate, by differences on the control grid), the integral frozen while clipped; a triple pole at
    −ω: kd = 3ω·J, kp = 3ω²·J, ki = ω³·J (`bandwidth` ω, default 10 rad/s; `inertia` J, default the
    joint's nominal reduced inertia at the start), or `kp`, `ki`, `kd` given. g(q) is the nominal
    model's gravity torque at the measured q (`gravity=1`, the default on a machine without
    closed loops; `gravity=0` leaves it out).

    Gains apply to every controlled joint (`kp=…`) or to one (`elbow.kp=…`)."""

    def __init__(self, kind: str, machine: Machine, nominal: Machine,
                 references: dict[str, np.ndarray], period: float, gains: dict[str, float],
                 start: dict[str, float]):
        if kind not in CONTROLLERS:
            raise SystemExit(f"mujoco_machine: --controller {kind}: not one of "
                             f"{', '.join(CONTROLLERS)}")
        self.kind, self.machine, self.nominal, self.period = kind, machine, nominal, period
        self.joints = [j.name for j in machine.driven if j.name in references]
        if not self.joints:
            raise SystemExit(f"mujoco_machine: --controller {kind}: no joint to control (give "
                             "--reference JOINT=SPEC)")
        index = {j.name: i for i, j in enumerate(machine.twin_joints)}
        self.columns = [index[j] for j in self.joints]
        self.actuators = [machine.actuator_index[j] for j in self.joints]
        self.reference = np.column_stack([references[j] for j in self.joints])
        self.rate = np.column_stack([np.gradient(references[j], period) if len(references[j]) > 1
                                     else np.zeros(1) for j in self.joints])
        allowed = GAIN_NAMES[kind]
        for key in gains:
            joint, _, name = key.rpartition(".")
            if name not in allowed or (joint and joint not in self.joints):
                raise SystemExit(f"mujoco_machine: --gain {key}: {kind} takes "
                                 f"[JOINT.]{{{','.join(allowed)}}} on {', '.join(self.joints)}")

        def gain(joint: str, name: str):
            return gains.get(f"{joint}.{name}", gains.get(name, GAIN_DEFAULTS[kind].get(name)))

        self.gains = []  # per joint: dict of the gains in use
        for joint in self.joints:
            inertia = gain(joint, "inertia")
            if inertia is None and any(gain(joint, n) is None for n in
                                       (("kp", "ki") if kind == "speed-pi" else ("kp", "ki", "kd"))):
                inertia = reduced_inertia(nominal, start, joint)
            if kind == "speed-pi":
                wn, zeta = gain(joint, "natural_frequency"), gain(joint, "damping_ratio")
                kp = gain(joint, "kp") if gain(joint, "kp") is not None else 2 * zeta * wn * inertia
                ki = gain(joint, "ki") if gain(joint, "ki") is not None else wn * wn * inertia
                self.gains.append({"inertia": inertia, "kp": kp, "ki": ki})
            else:
                w = gain(joint, "bandwidth")
                kp = gain(joint, "kp") if gain(joint, "kp") is not None else 3 * w * w * inertia
                ki = gain(joint, "ki") if gain(joint, "ki") is not None else w ** 3 * inertia
                kd = gain(joint, "kd") if gain(joint, "kd") is not None else 3 * w * inertia
                self.gains.append({"inertia": inertia, "kp": kp, "ki": ki, "kd": kd})
        self.gravity = False
        if kind == "pid":
            flags = {bool(gain(j, "gravity")) if gain(j, "gravity") is not None
                     else not machine.loops for j in self.joints}
            if len(flags) > 1:
                raise SystemExit("mujoco_machine: --gain gravity: give it for every joint or none")
            self.gravity = flags.pop()
            if self.gravity and machine.loops:
                raise SystemExit("mujoco_machine: --gain gravity=1: only on a machine without "
                                 "closed loops")
            self._nominal_data = mujoco.MjData(nominal.model)
            self._dofs = [nominal.vadr[j] for j in self.joints]
        self.limits = machine.effort_limits[self.actuators]
        self.reset()

    def reset(self) -> None:
        self.integral = np.zeros(len(self.joints))

    def _gravity(self, q: np.ndarray) -> np.ndarray:
        d = self._nominal_data
        d.qvel[:] = 0.0
        for i, j in enumerate(self.machine.twin_joints):
            if j.name in self.nominal.qadr:
                d.qpos[self.nominal.qadr[j.name]] = q[i]
        mujoco.mj_forward(self.nominal.model, d)
        return d.qfrc_bias[self._dofs].copy()

    def command(self, k: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        out = np.zeros(len(self.machine.driven))
        k = min(k, self.reference.shape[0] - 1)
        r, rate = self.reference[k], self.rate[k]
        extra = self._gravity(q) if self.gravity else np.zeros(len(self.joints))
        for i, g in enumerate(self.gains):
            if self.kind == "speed-pi":
                e = r[i] - v[self.columns[i]]
                candidate = self.integral[i] + e * self.period
                unclipped = g["kp"] * e + g["ki"] * candidate
                if abs(unclipped) <= self.limits[i]:
                    self.integral[i] = candidate
                u = g["kp"] * e + g["ki"] * self.integral[i]
            else:
                e = r[i] - q[self.columns[i]]
                de = rate[i] - v[self.columns[i]]
                candidate = self.integral[i] + e * self.period
                unclipped = g["kp"] * e + g["kd"] * de + g["ki"] * candidate + extra[i]
                if abs(unclipped) <= self.limits[i]:
                    self.integral[i] = candidate
                u = g["kp"] * e + g["kd"] * de + g["ki"] * self.integral[i] + extra[i]
            out[self.actuators[i]] = np.clip(u, -self.limits[i], self.limits[i])
        return out

    def describe(self) -> list[str]:
        lines = []
        for j, g in zip(self.joints, self.gains):
            text = ", ".join(f"{k} {v:.6g}" for k, v in g.items() if v is not None)
            lines.append(f"{self.kind} on {j}: {text}" +
                         (", nominal gravity compensation" if self.gravity else ""))
        return lines


# --------------------------------------------------------------------------------------------
# The run


@dataclasses.dataclass
class Run:
    time: np.ndarray
    efforts: np.ndarray  # (rows, driven)
    positions: np.ndarray  # (rows, twin joints)
    velocities: np.ndarray
    loop_gap_max: float
    limits_crossed: list[str]
    wall_seconds: float


def simulate(machine: Machine, efforts: np.ndarray, period: float,
             initial: dict[str, tuple[float, float]] | None = None) -> Run:
    """Steps MuJoCo through the rows of `efforts` (one per control period, held), from the
    initial state; returns N + 1 rows of states for N + 1 effort rows (the last one unused)."""
    applied = np.clip(efforts, -machine.effort_limits, machine.effort_limits)
    return _simulate(machine, efforts.shape[0], period, initial, lambda k, q, v: applied[k])


def simulate_controlled(machine: Machine, controller: "Controller", rows: int, period: float,
                        initial: dict[str, tuple[float, float]] | None = None) -> Run:
    """The machine under its own controller: at each control period t_k the controller reads
    MuJoCo's state there (the twin's joint coordinates) and its command, clipped to the effort
    limits, is held over [t_k, t_k + period). Row k holds t_k, that command and the state at t_k
    (the last row's command is computed, not applied)."""
    controller.reset()
    return _simulate(machine, rows, period, initial, controller.command)


def _simulate(machine: Machine, rows: int, period: float,
              initial: dict[str, tuple[float, float]] | None, command) -> Run:
    m = machine.model
    substeps = int(round(period / m.opt.timestep))
    if substeps < 1 or abs(substeps * m.opt.timestep - period) > 1e-9 * period:
        raise SystemExit("mujoco_machine: the control period must be a multiple of dt")
    data = mujoco.MjData(m)
    initial = initial or {}
    machine.set_state(data, {k: v[0] for k, v in initial.items()},
                      {k: v[1] for k, v in initial.items()})
    n = len(machine.twin_joints)
    q, v = np.empty((rows, n)), np.empty((rows, n))
    applied = np.empty((rows, len(machine.driven)))
    gap = 0.0
    start = wallclock.perf_counter()
    q[0], v[0] = machine.twin_state(data)
    for k in range(rows - 1):
        applied[k] = command(k, q[k], v[k])
        data.ctrl[:] = applied[k]
        for _ in range(substeps):
            mujoco.mj_step(m, data)
        q[k + 1], v[k + 1] = machine.twin_state(data, q[k])
        if m.neq:
            gap = max(gap, machine.loop_gap(data))
    applied[rows - 1] = command(rows - 1, q[rows - 1], v[rows - 1])
    wall = wallclock.perf_counter() - start
    crossed = []
    for i, j in enumerate(machine.twin_joints):
        if j.limits and (q[:, i].min() < j.limits[0] or q[:, i].max() > j.limits[1]):
            crossed.append(f"{j.name} [{q[:, i].min():.3f}, {q[:, i].max():.3f}] outside {j.limits}")
    times = np.arange(rows) * period
    return Run(times, applied, q, v, gap, crossed, wall)


def rest_state(urdf: str, gravity: tuple[float, float] = DEFAULT_GRAVITY) -> dict[str, float]:
    """Where the machine rests under gravity, every twin joint: a passive settle (30 s at 1 ms)
    with heavy damping (30 N·m·s/rad) on every driven joint, from the URDF's pose (the
    Whitworth: ram down)."""
    probe = Machine(urdf, [], gravity)
    values = [("joint", j.name, "damping", 30.0) for j in probe.driven]
    m = Machine(urdf, values, gravity, dt=1e-3)
    # 30 s in periods of 0.1 s (efforts zero: the period only sets where states are read).
    run = simulate(m, np.zeros((301, len(m.driven))), 0.1)
    if np.max(np.abs(run.velocities[-1])) > 1e-9:
        raise SystemExit("mujoco_machine: the settle did not come to rest")
    return {j.name: float(run.positions[-1, i]) for i, j in enumerate(m.twin_joints)}


def write_csv(path: str, machine: Machine, run: Run, noise: dict[str, float] | None = None,
              seed: int | None = None, signals: list[str] | None = None,
              effort_unit: str | None = None) -> None:
    """The run as the twin's run CSV: time, efforts, then every joint's position and velocity,
    or only `signals` (`<joint>.position`, `<joint>.velocity`, in their order); `effort_unit`
    relabels the efforts' unit (the arm scenario's unit-gain current drives: `A`, 1 A = 1 N·m);
    `noise` adds seeded Gaussian noise to the named columns (globs) of what is written."""
    table = np.column_stack([run.time, run.efforts] + [
        col for i in range(len(machine.twin_joints))
        for col in (run.positions[:, i], run.velocities[:, i])
    ])
    header = machine.columns()
    names = [h.rsplit(" [", 1)[0] for h in header]
    if signals:
        missing = [s for s in signals if s not in names or s == "time" or s.startswith("effort.")]
        if missing:
            states = [n for n in names if n.endswith((".position", ".velocity"))]
            raise SystemExit(f"mujoco_machine: --signals {', '.join(missing)}: no such joint state "
                             f"({', '.join(states)})")
        keep = [c for c, n in enumerate(names) if n == "time" or n.startswith("effort.")]
        keep += [names.index(s) for s in signals]
        table, header = table[:, keep], [header[c] for c in keep]
    if effort_unit:
        header = [h.rsplit(" [", 1)[0] + f" [{effort_unit}]" if h.startswith("effort.") else h
                  for h in header]
    if noise:
        rng = np.random.default_rng(seed)
        names = [h.rsplit(" [", 1)[0] for h in header]
        for pattern, sigma in noise.items():
            hits = [c for c, name in enumerate(names) if c > 0 and fnmatch.fnmatchcase(name, pattern)]
            if not hits:
                raise SystemExit(f"mujoco_machine: --noise {pattern}: no such column ({', '.join(names[1:])})")
            for c in hits:
                table[:, c] += rng.normal(0.0, sigma, table.shape[0])
    with open(path, "w", encoding="utf-8") as out:
        out.write(",".join(header) + "\n")
        for row in table:
            out.write(",".join(f"{x:.17g}" for x in row) + "\n")


def log_columns(machine: Machine, effort_unit: str | None = None) -> dict[str, str]:
    """Every column a log can hold, by name (without unit) → its header (with unit)."""
    out = {}
    for header in machine.columns():
        name, unit = header.rsplit(" [", 1)
        if effort_unit and name.startswith("effort."):
            header = f"{name} [{effort_unit}]"
        out[name] = header
    return out


def write_log(path: str, machine: Machine, run: Run, columns: list[str] | None = None,
              log_period: float | None = None, noise: dict[str, float] | None = None,
              seed: int | None = None, drop: float = 0.0, effort_unit: str | None = None,
              period: float | None = None) -> dict:
    """The run as a machine's logger writes it: `columns` (names without unit: `effort.<joint>`,
    `<joint>.position`, `<joint>.velocity`; default every effort and every joint state) after
    `time [s]`; a row every `log_period` (a multiple of the control period `period`; the effort
    is the command held at that instant); seeded Gaussian noise on the named columns (globs;
    `numpy.random.default_rng(seed)`, drawn column after column over every logged row); then
    `drop` (a fraction in [0, 1)) of the rows removed at random (`default_rng([seed, 1])`,
    round(drop × rows) of them, never the first or the last row: the run keeps its span).
    Returns what was written (rows, dropped, log period)."""
    available = log_columns(machine, effort_unit)
    names = list(columns) if columns else list(available)[1:]
    if not names:
        raise SystemExit("mujoco_machine: --log names no column")
    unknown = [n for n in names if n not in available or n == "time"]
    if unknown:
        raise SystemExit(f"mujoco_machine: --log {', '.join(unknown)}: no such column (one of "
                         f"{', '.join(list(available)[1:])})")
    if len(set(names)) != len(names):
        raise SystemExit("mujoco_machine: --log names a column twice")
    period = period if period is not None else (run.time[1] - run.time[0] if len(run.time) > 1 else 1.0)
    every = 1
    if log_period is not None:
        every = int(round(log_period / period))
        if every < 1 or abs(every * period - log_period) > 1e-9 * log_period:
            raise SystemExit(f"mujoco_machine: --log-period {log_period:g}: not a multiple of the "
                             f"control period {period:g} s")
    if not 0.0 <= drop < 1.0:
        raise SystemExit(f"mujoco_machine: --drop {drop:g}: a fraction in [0, 1)")
    full = {"time": run.time}
    for i, j in enumerate(machine.driven):
        full[f"effort.{j.name}"] = run.efforts[:, i]
    for i, j in enumerate(machine.twin_joints):
        full[f"{j.name}.position"] = run.positions[:, i]
        full[f"{j.name}.velocity"] = run.velocities[:, i]
    rows = np.arange(0, len(run.time), every)
    table = np.column_stack([full["time"][rows]] + [full[n][rows] for n in names])
    header = ["time [s]"] + [available[n] for n in names]
    if noise:
        rng = np.random.default_rng(seed)
        for pattern, sigma in noise.items():
            hits = [c for c, n in enumerate(names, start=1) if fnmatch.fnmatchcase(n, pattern)]
            if not hits:
                raise SystemExit(f"mujoco_machine: --noise {pattern}: no such logged column "
                                 f"({', '.join(names)})")
            for c in hits:
                table[:, c] += rng.normal(0.0, sigma, table.shape[0])
    dropped = 0
    if drop > 0.0 and table.shape[0] > 2:
        dropped = int(round(drop * table.shape[0]))
        dropped = min(dropped, table.shape[0] - 2)
        rng = np.random.default_rng([seed if seed is not None else 0, 1])
        gone = rng.choice(np.arange(1, table.shape[0] - 1), size=dropped, replace=False)
        table = np.delete(table, gone, axis=0)
    with open(path, "w", encoding="utf-8") as out:
        out.write(",".join(header) + "\n")
        for row in table:
            out.write(",".join(f"{x:.17g}" for x in row) + "\n")
    return {"rows": int(table.shape[0]), "dropped": dropped, "log_period": every * period,
            "columns": header}


def read_csv(path: str) -> tuple[list[str], np.ndarray]:
    """The header's names without units, and the numbers."""
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return [h.rsplit(" [", 1)[0].strip() for h in header], table


# --------------------------------------------------------------------------------------------


def _pairs(items: list[str], what: str) -> dict[str, str]:
    out = {}
    for item in items:
        if "=" not in item:
            raise SystemExit(f"mujoco_machine: {what} {item!r}: expected NAME=VALUE")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _number(text: str) -> float:
    return float(eval(text, {"__builtins__": {}}, {"pi": math.pi}))  # noqa: S307 (numbers only)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        description="MuJoCo plays a twin URDF: a measured run (CSV in the twin's run format) "
                    "under held joint efforts or its own controller, with hidden plant values, "
                    "logged as chosen (columns, period, noise, dropped rows).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("The machine's own controller", 1)[1].split("Importable:", 1)[0].join(
            ["The machine's own controller", ""]),
    )
    p.add_argument("--urdf", required=True, help="the twin's URDF, e.g. urdf/arm.urdf")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="hidden value: link.<link>.mass|izz|com=x,y, joint.<joint>.damping|friction "
                        "(a leading `urdf.` is accepted)")
    p.add_argument("--torque", action="append", default=[], metavar="JOINT=SPEC",
                   help="effort on a driven joint (N·m or N): multisine:…, an expression in t, or 0")
    p.add_argument("--initial", action="append", default=[], metavar="JOINT=POS[,VEL]",
                   help="initial joint state (default: the URDF's zero pose at rest); `pi` may be used")
    p.add_argument("--rest", action="store_true",
                   help="start at rest where gravity holds the machine (a passive settle; the "
                        "Whitworth: ram down), instead of --initial")
    p.add_argument("--duration", type=float, default=5.0, help="s (default 5)")
    p.add_argument("--dt", type=float, default=1e-3, help="MuJoCo's RK4 step, s (default 1e-3)")
    p.add_argument("--control-period", type=float, default=None,
                   help="s, a multiple of dt (default: dt)")
    p.add_argument("--gravity", default="0,-9.81", help="gx,gy in m/s² (default 0,-9.81)")
    p.add_argument("--loop-timeconst", type=float, default=None,
                   help="solref time constant of the loop closures, s (default 2·dt)")
    p.add_argument("--out", required=True, help="CSV to write")
    p.add_argument("--signals", default=None, metavar="NAME,…",
                   help="the joint states written, in this order (default: every joint's "
                        "position and velocity), e.g. 'crank.position,crank.velocity'")
    p.add_argument("--effort-unit", default=None, metavar="UNIT",
                   help="the unit the efforts' columns are labelled with (default N·m, N); A for "
                        "the arm scenario's unit-gain current drives (1 A = 1 N·m there)")
    p.add_argument("--truth-out", default=None, metavar="CSV",
                   help="also write the run without noise, every joint, here (its first row is "
                        "the initial state of every joint, for the twin's [initial])")
    p.add_argument("--noise", action="append", default=[], metavar="COLUMN=SIGMA",
                   help="Gaussian noise on written columns, by name without unit; globs allowed "
                        "('*.position=1e-4', 'effort.crank=0.05')")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0; --drop's too)")
    p.add_argument("--controller", default=None, choices=sorted(CONTROLLERS),
                   help="the machine's own controller, run in MuJoCo's loop at each control "
                        "period (default: none, the efforts are --torque's): speed-pi, pid")
    p.add_argument("--reference", action="append", default=[], metavar="JOINT=SPEC",
                   help="a controlled joint's reference, a --torque SPEC in the controller's "
                        "units: speed-pi rad/s (m/s), pid rad (m); pid holds a driven joint "
                        "without one at its start")
    p.add_argument("--gain", action="append", default=[], metavar="[JOINT.]NAME=VALUE",
                   help="controller gain or design value (speed-pi: inertia, natural_frequency, "
                        "damping_ratio, kp, ki; pid: inertia, bandwidth, kp, ki, kd, gravity)")
    p.add_argument("--log", default=None, metavar="NAME,…",
                   help="the columns logged after time, in this order: effort.<joint>, "
                        "<joint>.position, <joint>.velocity (default: every effort and joint "
                        "state), e.g. 'effort.crank,ram.position'")
    p.add_argument("--log-period", type=float, default=None, metavar="S",
                   help="the logger's period, a multiple of the control period (default: the "
                        "control period); an effort is the command held at the logged instant")
    p.add_argument("--drop", type=float, default=0.0, metavar="FRACTION",
                   help="remove this fraction of the logged rows at random, seeded (never the "
                        "first or the last)")
    args = p.parse_args(argv)

    values = [parse_value(s) for s in args.set]
    gx, gy = (float(v) for v in args.gravity.split(","))
    period = args.control_period if args.control_period is not None else args.dt
    machine = Machine(args.urdf, values, (gx, gy), args.dt, args.loop_timeconst)
    torques = _pairs(args.torque, "--torque")
    for name in torques:
        if name not in machine.actuator_index:
            raise SystemExit(f"mujoco_machine: --torque {name}: not a driven joint "
                             f"({', '.join(machine.actuator_index)})")
    if args.rest and args.initial:
        raise SystemExit("mujoco_machine: give --rest or --initial, not both")
    initial = {k: (v, 0.0) for k, v in rest_state(args.urdf, (gx, gy)).items()} if args.rest \
        else {}
    for name, text in _pairs(args.initial, "--initial").items():
        if name not in {j.name for j in machine.twin_joints}:
            raise SystemExit(f"mujoco_machine: --initial {name}: no such movable joint")
        parts = [_number(x) for x in text.split(",")]
        initial[name] = (parts[0], parts[1] if len(parts) > 1 else 0.0)
    noise = {k: float(v) for k, v in _pairs(args.noise, "--noise").items()}

    steps = int(round(args.duration / period))
    t = np.arange(steps + 1) * period
    logging = args.log is not None or args.log_period is not None or args.drop
    if logging:
        # The logger's settings checked before the run, not after it.
        if args.signals:
            raise SystemExit("mujoco_machine: give --signals or --log, not both")
        available = log_columns(machine)
        wanted = [c.strip() for c in (args.log or "").split(",") if c.strip()]
        unknown = [c for c in wanted if c not in available or c == "time"]
        if unknown:
            raise SystemExit(f"mujoco_machine: --log {', '.join(unknown)}: no such column (one "
                             f"of {', '.join(list(available)[1:])})")
        if args.log_period is not None:
            every = int(round(args.log_period / period))
            if every < 1 or abs(every * period - args.log_period) > 1e-9 * args.log_period:
                raise SystemExit(f"mujoco_machine: --log-period {args.log_period:g}: not a "
                                 f"multiple of the control period {period:g} s")
        if not 0.0 <= args.drop < 1.0:
            raise SystemExit(f"mujoco_machine: --drop {args.drop:g}: a fraction in [0, 1)")
    controller = None
    if args.controller:
        if torques:
            raise SystemExit("mujoco_machine: give --torque (open loop) or --controller, not both")
        references = {}
        for name, text in _pairs(args.reference, "--reference").items():
            if name not in machine.actuator_index:
                raise SystemExit(f"mujoco_machine: --reference {name}: not a driven joint "
                                 f"({', '.join(machine.actuator_index)})")
            references[name] = excitation(text, t, args.duration)
        for j in machine.driven:
            if j.name in references:
                continue
            if args.controller == "speed-pi":
                raise SystemExit(f"mujoco_machine: --controller speed-pi: give --reference "
                                 f"{j.name}=SPEC (rad/s)")
            # pid holds it where it starts.
            references[j.name] = np.full(t.shape, initial.get(j.name, (0.0, 0.0))[0])
        for name, r in references.items():
            # A controlled joint not given starts on its reference: pid at r(0) moving at ṙ(0),
            # speed-pi at its URDF position turning at r(0).
            if name not in initial:
                if args.controller == "pid":
                    rate = (r[1] - r[0]) / period if len(r) > 1 else 0.0
                    initial[name] = (float(r[0]), float(rate))
                else:
                    initial[name] = (0.0, float(r[0]))
        gains = {k: _number(v) for k, v in _pairs(args.gain, "--gain").items()}
        nominal = Machine(args.urdf, [], (gx, gy), args.dt, args.loop_timeconst)
        controller = Controller(args.controller, machine, nominal, references, period, gains,
                                {k: v[0] for k, v in initial.items()})
        specs = [f"{args.controller}, reference " + dict(_pairs(args.reference, "")).get(
            j.name, "held at the start") for j in machine.driven]
        run = simulate_controlled(machine, controller, steps + 1, period, initial)
    else:
        if args.reference or args.gain:
            raise SystemExit("mujoco_machine: --reference and --gain need --controller")
        specs = [torques.get(j.name, default_excitation(machine, j.name)) for j in machine.driven]
        efforts = np.column_stack([excitation(s, t, args.duration) for s in specs]) if specs \
            else np.zeros((steps + 1, 0))
        run = simulate(machine, efforts, period, initial)
    signals = [s.strip() for s in args.signals.split(",") if s.strip()] if args.signals else None
    logged = None
    if logging:
        columns = [c.strip() for c in args.log.split(",") if c.strip()] if args.log else None
        logged = write_log(args.out, machine, run, columns, args.log_period, noise, args.seed,
                           args.drop, args.effort_unit, period)
    else:
        write_csv(args.out, machine, run, noise, args.seed, signals, args.effort_unit)
    if args.truth_out:
        write_csv(args.truth_out, machine, run, effort_unit=args.effort_unit)

    print(f"mujoco_machine: {args.urdf}, {steps} periods of {period:g} s "
          f"({int(round(period / args.dt))} RK4 step(s) of {args.dt:g} s each), "
          f"{run.wall_seconds:.3f} s wall; wrote {args.out}", file=sys.stderr)
    for j, s in zip(machine.driven, specs):
        print(f"  effort.{j.name} = {s}", file=sys.stderr)
    if controller is not None:
        for line in controller.describe():
            print(f"  {line}", file=sys.stderr)
        for i, j in enumerate(machine.driven):
            clipped = np.mean(np.abs(run.efforts[:-1, i]) >= machine.effort_limits[i] * (1 - 1e-12))
            if clipped > 0:
                print(f"  effort.{j.name} at its limit ({machine.effort_limits[i]:g}) in "
                      f"{100 * clipped:.1f} % of the periods", file=sys.stderr)
    if logged is not None:
        print(f"  logged {logged['rows']} rows every {logged['log_period']:g} s "
              f"({logged['dropped']} dropped): {', '.join(logged['columns'])}", file=sys.stderr)
    if machine.derived or machine.loops:
        print(f"  loop closures: largest gap {run.loop_gap_max:.3g} m", file=sys.stderr)
    for text in run.limits_crossed:
        print(f"  warning: joint limit crossed, {text}: the twin stops a joint there "
              "(MuJoCo's limits are off); this run is not comparable", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
