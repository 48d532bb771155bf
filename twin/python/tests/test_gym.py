"""The Gymnasium environments: Gymnasium's own checker on every machine, the reward against the
signals it is defined by, and the episode's ends."""

import pathlib

import gymnasium
import numpy as np
import pytest
from gymnasium.utils import seeding
from gymnasium.utils.env_checker import check_env

import twin.gym
from twin.gym import MACHINES

IDS = [machine.env_id for machine in MACHINES.values()]


def test_one_environment_per_machine():
    assert sorted(MACHINES) == ["arm", "feed_axis", "lathe", "milling", "platform", "whitworth"]
    assert all(env_id in gymnasium.registry for env_id in IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasiums_checker_passes(env_id):
    env = gymnasium.make(env_id, duration=0.05)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_spaces_follow_the_plant(env_id):
    env = gymnasium.make(env_id, duration=0.05).unwrapped
    assert env.action_space.shape == (len(env.actuators),)
    assert env.observation_space.shape == (len(env.signals),)
    observation, info = env.reset(seed=1)
    assert observation.shape == (len(env.signals),) and info["time"] == 0.0


def test_the_reward_is_the_tracking_error_per_mm_and_actions_scale_to_the_limits():
    env = gymnasium.make("twin/Whitworth-v0", duration=0.2).unwrapped
    env.reset(seed=3)
    sim, signals = env.sim, env.signals
    # The same efforts, action × limit, straight into a simulator with the episode's noise seed.
    rng, _ = seeding.np_random(3)
    plain = env.scenario.simulator()
    plain.reset(int(rng.integers(0, 2**63 - 1)))
    for _ in range(20):
        observation, reward, terminated, truncated, info = env.step(np.array([0.3], np.float32))
        truth = sim.true_signals
        error = truth[signals.index("reference")] - truth[signals.index("ram_position")]
        assert reward == pytest.approx(-abs(error) / 1e-3, rel=1e-12)
        assert info["error"] == error and not terminated and not truncated
        effort = np.float64(np.float32(0.3)) * plain.effort_limits
        np.testing.assert_array_equal(observation, plain.step(effort))


def test_an_episode_is_truncated_at_the_duration():
    env = gymnasium.make("twin/FeedAxis-v0", duration=0.01).unwrapped
    env.reset(seed=0)
    ends = [env.step(np.zeros(1, np.float32))[3] for _ in range(100)]
    assert ends == [False] * 99 + [True]


def test_a_divergence_terminates_with_the_steps_left_as_penalty():
    env = gymnasium.make(
        "twin/Whitworth-v0", duration=1.0, set={"health.max_joint_speed": 0.5}
    ).unwrapped
    env.reset(seed=0)
    for k in range(1, 1001):
        observation, reward, terminated, truncated, info = env.step(np.ones(1, np.float32))
        if terminated:
            break
    assert terminated and not truncated and info["kind"] == "diverged"
    assert reward == -(1000 - k + 1)
    assert np.all(np.isfinite(observation))


def test_the_same_seed_gives_the_same_episode():
    env = gymnasium.make("twin/Platform-v0", duration=0.1).unwrapped
    def episode(seed):
        first, _ = env.reset(seed=seed)
        rest = [env.step(np.full(len(env.actuators), 0.2, np.float32))[0] for _ in range(10)]
        return np.vstack([first] + rest)
    np.testing.assert_array_equal(episode(5), episode(5))


CART_POLE = str(pathlib.Path(__file__).resolve().parents[3] / "examples" / "cart-pole" / "cart-pole.toml")


def test_any_scenario_is_an_environment_with_the_error_it_names():
    """twin/Generic-v0 on the cart-pole example (the generic machine): the signals observed, the
    cart's force the action, the cart's distance from 0.3 m per cm the reward."""
    env = gymnasium.make("twin/Generic-v0", scenario=CART_POLE, signal="cart.position",
                         reference=0.3, scale=0.01, duration=0.05).unwrapped
    check_env(env, skip_render_check=True)
    assert env.actuators == ["cart"] and "bob.x" in env.signals
    env.reset(seed=1)
    _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
    cart = env.signals.index("cart.position")
    assert not terminated
    assert reward == pytest.approx(-abs(0.3 - env.sim.true_signals[cart]) / 0.01)
    with pytest.raises(ValueError, match="signal="):
        gymnasium.make("twin/Generic-v0", scenario=CART_POLE)
