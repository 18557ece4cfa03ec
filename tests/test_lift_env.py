"""`ClutterRetrieveEELift-v0`: episodes that start with the goal object in the hand."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from clutter_gym.model.world import TABLE
from clutter_gym.sim.controllers import ready_configuration
from tests.test_rl_env import lone_goal

LIFT_ACTION = np.array([0.0, 0.0, 1.0, 0.0, 1.0], dtype=np.float32)  # up, hand closed


def make(**kwargs: Any) -> gym.Env:
    return gym.make("ClutterRetrieveEELift-v0", scenes=lone_goal(), **kwargs)


def test_a_grasped_start_holds_the_can_by_friction_and_lifting_it_succeeds() -> None:
    env = make()
    obs, info = env.reset(seed=0, options={"grasped": True})
    assert info["start"] == "grasped" and info["goal_gripped"] and not info["is_success"]
    assert not info["goal_held"]  # gripped, still standing on the table: nothing lifted yet
    assert obs["achieved_goal"][2] < obs["desired_goal"][2]
    compute = env.unwrapped.compute_reward  # type: ignore[attr-defined]
    steps, terminated = 0, False
    while not terminated and steps < 30:
        obs, reward, terminated, _, info = env.step(LIFT_ACTION)
        assert compute(obs["achieved_goal"], obs["desired_goal"], info) == reward
        steps += 1
    assert info["is_success"] and reward == 1.0 and steps < 20
    env.close()


def test_opening_the_hand_after_a_grasped_start_drops_the_can() -> None:
    """The grasp is the fingers' friction, not an attach constraint: open them and lift, and
    the can stays on the table."""
    env = make()
    env.reset(seed=0, options={"grasped": True})
    for _ in range(20):
        _, _, terminated, _, info = env.step(np.array([0.0, 0.0, 1.0, 0.0, -1.0], np.float32))
        assert not terminated
    assert not info["goal_gripped"] and abs(info["goal_lift"]) < 0.01
    env.close()


def test_an_ordinary_start_is_the_ready_pose() -> None:
    env = make()
    _, info = env.reset(seed=0, options={"grasped": False})
    q, _ = env.unwrapped.herb.arm_state()  # type: ignore[attr-defined]
    assert info["start"] == "ready" and not info["goal_gripped"]
    assert np.allclose(q, ready_configuration(TABLE), atol=0.02)
    env.close()


@pytest.mark.parametrize(("fraction", "expected"), [(0.0, {"ready"}), (1.0, {"grasped"})])
def test_grasped_start_is_the_fraction_of_grasped_episodes(
    fraction: float, expected: set[str]
) -> None:
    env = make(grasped_start=fraction)
    starts = {env.reset(seed=seed)[1]["start"] for seed in range(3)}
    assert starts == expected
    env.close()


def test_half_of_the_episodes_start_grasped_by_default() -> None:
    env = make()
    starts = [env.reset(seed=seed)[1]["start"] for seed in range(16)]
    assert 3 <= starts.count("grasped") <= 13 and set(starts) == {"ready", "grasped"}
    env.close()


@pytest.mark.parametrize("fraction", [-0.1, 1.5, "half", float("nan")])
def test_a_bad_grasped_start_names_the_keyword(fraction: object) -> None:
    with pytest.raises(ValueError, match=r"^grasped_start: "):
        make(grasped_start=fraction)


def test_a_bad_grasped_option_names_it() -> None:
    env = make()
    with pytest.raises(ValueError, match=r"^options\['grasped'\]: "):
        env.reset(seed=0, options={"grasped": "yes"})
    env.close()
