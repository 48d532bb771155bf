"""Gymnasium environments of the twin's machines. Importing this module registers them::

    import gymnasium
    import twin.gym  # registers twin/Whitworth-v0, twin/FeedAxis-v0, …

    env = gymnasium.make("twin/Whitworth-v0")

Per step of the environment the plant runs one control period of its scenario.

* observation: the measured signals (SI, through the scenario's sensors), in the order of
  ``env.unwrapped.signals``;
* action: one value per actuator in [-1, 1], scaled by the actuator's effort limit (N or N·m,
  A on the arm, whose drives take a current);
* reward: minus the machine's headline error at the end of the step, divided by its scale (see
  ``MACHINES``: each entry says which error and why that scale); on a divergence or a crash the
  episode is ``terminated`` and the reward is ``-failure_penalty`` per step left, so that ending
  early never pays;
* ``truncated`` when the scenario's duration is reached.

``gymnasium.make("twin/Whitworth-v0", duration=1.0, set={"sensors.\\"crank.position\\".noise": 0})``
changes the scenario as :meth:`twin.Scenario.set` does.

``twin/Generic-v0`` is any scenario, your own mechanism's (the generic machine) or a built-in
one, with the error you name rewarded::

    env = gymnasium.make("twin/Generic-v0", scenario="examples/cart-pole/cart-pole.toml",
                         signal="cart.position", reference=0.3, scale=0.01)

``signal`` is the true signal whose error is rewarded, ``reference`` the signal it should follow
or a constant (default 0), ``scale`` the error that costs -1 per step (default 1, SI).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Optional, Union

import gymnasium
import numpy as np
from gymnasium import spaces

from . import DivergedError, Scenario


@dataclass(frozen=True)
class Machine:
    """What an environment of one machine runs and rewards."""

    env_id: str
    scenario: str
    #: The true signal whose error is rewarded: a plant signal, or else a model check of the
    #: machine (``Simulator.diagnostic_names``).
    signal: str
    #: The signal it should follow (None: the signal itself should be zero), or a constant target.
    reference: Union[str, float, None]
    #: The error that costs a reward of -1 per step, in the signal's SI unit.
    scale: float
    why: str


MACHINES = {
    "whitworth": Machine(
        "twin/Whitworth-v0", "whitworth-tracking", "ram_position", "reference", 1e-3,
        "ram tracking error, per mm (the scenario's tracking MSE is of this error)",
    ),
    "feed_axis": Machine(
        "twin/FeedAxis-v0", "feed-axis-micromilling", "table.position", "reference", 1e-6,
        "table position error, per µm (Table I of Rubio et al. is of this error)",
    ),
    "lathe": Machine(
        "twin/Lathe-v0", "lathe-turning", "spindle_power", 20e3, 1e3,
        "spindle power's distance from P_max = 20 kW, per kW (the power loop's set point, "
        "Sudhakara & Landers Table 1)",
    ),
    "milling": Machine(
        "twin/Milling-v0", "milling-constant-15000", "tool_y.position", None, 1e-5,
        "tool vibration (y) per 10 µm (the scenario's displacement RMS is of this signal)",
    ),
    "arm": Machine(
        "twin/Arm-v0", "arm-milling", "path_deviation", None, 1e-3,
        "tool deviation from its path, per mm",
    ),
    "platform": Machine(
        "twin/Platform-v0", "platform-path", "path_error", None, 1e-2,
        "distance from the path, per cm",
    ),
}


#: The environment of any scenario, the error rewarded given by its arguments.
GENERIC = "generic"
GENERIC_ID = "twin/Generic-v0"


class TwinEnv(gymnasium.Env):
    """One machine's plant as a Gymnasium environment (see the module's docstring)."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        machine: str,
        scenario: Optional[str] = None,
        duration: Optional[float] = None,
        set: Optional[Mapping[str, Any]] = None,
        failure_penalty: float = 1.0,
        signal: Optional[str] = None,
        reference: Union[str, float, None] = None,
        scale: float = 1.0,
    ) -> None:
        self.machine = self._machine(machine, scenario, signal, reference, scale)
        built = Scenario(scenario or self.machine.scenario)
        for key, value in (set or {}).items():
            built = built.set(key, value)
        if duration is not None:
            built = built.duration(duration)
        # A crash ends the episode as a divergence does.
        self.scenario = built.set("health.stop_on_collision", True)
        self.sim = self.scenario.simulator()
        self.signals = self.sim.signals
        self.actuators = self.sim.actuators
        self.failure_penalty = failure_penalty
        self._limits = self.sim.effort_limits
        self._error = self._error_of(self.signals, self.sim.diagnostic_names)
        self._steps = int(round(self.sim.end_time / self.sim.control_period))
        self._step = 0
        self.action_space = spaces.Box(-1.0, 1.0, (len(self.actuators),), np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (len(self.signals),), np.float64)

    @staticmethod
    def _machine(name: str, scenario: Optional[str], signal: Optional[str],
                 reference: Union[str, float, None], scale: float) -> Machine:
        """The built-in machine `name`, or for ``generic`` the one the arguments describe."""
        if name != GENERIC:
            return MACHINES[name]
        if scenario is None or signal is None:
            raise ValueError(
                "twin/Generic-v0 needs scenario= (a scenario file or name) and signal= (the "
                "true signal whose error is rewarded), with reference= (a signal or a number, "
                "default 0) and scale= (the error costing -1 per step, default 1)")
        if not (scale > 0 and np.isfinite(scale)):
            raise ValueError(f"scale must be a finite number > 0, not {scale}")
        return Machine(GENERIC_ID, scenario, signal, reference, float(scale),
                       f"{signal}'s error, per {scale} (SI)")

    def _error_of(self, signals: list[str], diagnostics: list[str]):
        """The headline error as a function of the simulator, after a step."""
        name, reference = self.machine.signal, self.machine.reference
        if name not in signals:
            index = diagnostics.index(name)
            return lambda sim: -sim.diagnostics[index]
        index = signals.index(name)
        if isinstance(reference, str):
            ref = signals.index(reference)
            return lambda sim: sim.true_signals[ref] - sim.true_signals[index]
        target = 0.0 if reference is None else float(reference)
        return lambda sim: target - sim.true_signals[index]

    def reset(
        self, *, seed: Optional[int] = None, options: Optional[dict[str, Any]] = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        # The sensors' noise follows the episode's seed.
        observation = self.sim.reset(int(self.np_random.integers(0, 2**63 - 1)))
        self._step = 0
        return observation, {"time": self.sim.time}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        efforts = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0) * self._limits
        self._step += 1
        try:
            observation = self.sim.step(efforts)
        except DivergedError as failure:
            left = self._steps - self._step + 1
            info = {"time": failure.time, "failure": str(failure), "kind": failure.kind}
            return self.sim.measured, -self.failure_penalty * left, True, False, info
        error = self._error(self.sim)
        reward = -abs(error) / self.machine.scale
        truncated = self._step >= self._steps
        return observation, float(reward), False, truncated, {"time": self.sim.time, "error": error}


def register_environments() -> None:
    """Registers one environment per machine with Gymnasium (done on import)."""
    for name, machine in MACHINES.items():
        if machine.env_id not in gymnasium.registry:
            gymnasium.register(
                id=machine.env_id,
                entry_point="twin.gym:TwinEnv",
                kwargs={"machine": name},
            )
    if GENERIC_ID not in gymnasium.registry:
        gymnasium.register(id=GENERIC_ID, entry_point="twin.gym:TwinEnv",
                           kwargs={"machine": GENERIC})


register_environments()
