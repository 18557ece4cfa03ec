"""ClutterRetrievePrimitive-v0: one step is one parameterised primitive, run in physics.

The checkers run on it with every other id (test_env.py); here: its action decoding, bad
actions, infeasible parameters (a cost, never an exception) and real primitives whose outcome
physics decides."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import clutter_gym  # noqa: F401  (registers the ids)
from agents.learning.episodes import env_scene, goal_name
from agents.learning.primitive_env import (
    DIRECTIONS_DEG,
    INFEASIBLE_COST,
    PUSH_DISTANCES,
    SLOT_FEATURES,
    ClutterRetrievePrimitiveEnv,
)
from clutter_gym.env import ClutterRetrieveEnv
from tests.helpers import lone_can, registered_env

CAN = (0.70, -0.25, 0.0)


def make() -> ClutterRetrievePrimitiveEnv:
    env = registered_env(gym.make("ClutterRetrievePrimitive-v0"))
    assert isinstance(env, ClutterRetrievePrimitiveEnv)
    return env


def can_and_bottle() -> dict[str, Any]:
    scene = lone_can("sigma1", CAN)
    scene["objects"].append({"name": "bottle", "kind": "juice_bottle", "pose": [0.62, 0.0, 0.0]})
    return scene


def action(kind: int, slot: int, direction_deg: int, distance: float, last: int = 1) -> np.ndarray:
    return np.array(
        [kind, slot, DIRECTIONS_DEG.index(direction_deg), 2, PUSH_DISTANCES.index(distance), last]
    )


def test_the_registered_spec_and_spaces() -> None:
    assert gym.spec("ClutterRetrievePrimitive-v0").max_episode_steps == 6
    env = make()
    assert env.action_space.nvec.tolist() == [3, 8, 12, 5, 4, 2]
    obs, _ = env.reset(seed=0, options={"scene": can_and_bottle()})
    assert env.observation_space.contains(obs)
    # Slot 0 is the goal, absolute; slot 1 the bottle relative to it.
    assert obs[0] == 1.0 and np.allclose(obs[1:3], CAN[:2], atol=1e-3)
    assert np.allclose(obs[SLOT_FEATURES + 1 : SLOT_FEATURES + 3], (-0.08, 0.25), atol=1e-3)
    assert obs[2 * SLOT_FEATURES] == 0.0  # no third object
    env.close()


@pytest.mark.parametrize(
    "bad",
    [
        np.array([0, 0, 0, 0, 0]),  # too short
        np.array([3, 0, 0, 0, 0, 0]),  # no fourth primitive
        np.array([0, 8, 0, 0, 0, 0]),  # slot out of range
        np.array([0, 0, -1, 0, 0, 0]),
        np.array([0.0, 0, 0, 0, 0, 0.5]),  # not integers
        np.array(["a"] * 6),
    ],
)
def test_bad_actions_raise_before_anything_moves(bad: np.ndarray) -> None:
    env = make()
    _, info = env.reset(seed=0, options={"scene": lone_can("sigma1", CAN)})
    with pytest.raises(ValueError, match=r"^action: .*shape \(6,\)"):
        env.step(bad)
    assert env.env.sim_steps == info["sim_steps"]
    env.close()


def test_infeasible_parameters_cost_and_leave_the_world_still() -> None:
    env = make()
    obs, info = env.reset(seed=0, options={"scene": lone_can("sigma1", CAN)})
    after, reward, terminated, truncated, step_info = env.step(action(0, 3, 0, 0.0))
    assert reward == INFEASIBLE_COST and not terminated and not truncated
    assert step_info["infeasible"] == "slot 3 is empty"
    assert env.env.sim_steps == info["sim_steps"]
    assert np.array_equal(after, obs)
    env.close()


def test_a_pickup_retrieves_the_can_in_physics() -> None:
    env = make()
    env.reset(seed=0, options={"scene": lone_can("sigma1", CAN)})
    outcomes = []
    for direction in (-30, 30, -60, 60):
        _, reward, terminated, _, info = env.step(action(0, 0, direction, 0.05))
        outcomes.append((direction, reward, info["infeasible"], info["failure"]))
        if terminated:
            break
    assert terminated and reward == 1.0 and info["is_success"], outcomes
    assert info["goal_held"] and info["goal_lift"] >= 0.10
    env.close()


def test_a_push_grasp_moves_an_obstacle_and_lets_go() -> None:
    env = make()
    _, start = env.reset(seed=0, options={"scene": can_and_bottle()})
    moved = None
    for direction in (30, -30, 60, 0):
        _, reward, terminated, _, info = env.step(action(1, 1, direction, 0.10))
        if not info["infeasible"]:
            moved = info
            break
    assert moved is not None and not terminated and reward == 0.0
    shift = np.linalg.norm(moved["true_object_poses"][1, :2] - start["true_object_poses"][1, :2])
    assert shift > 0.05  # pushed past the static grasp, then released where it stood
    assert not moved["goal_held"] and moved["failure"] == ""
    env.close()


def test_it_is_a_wrapper_of_the_trajectory_env() -> None:
    env = gym.make("ClutterRetrievePrimitive-v0")
    assert isinstance(registered_env(env), gym.Wrapper)
    assert isinstance(env.unwrapped, ClutterRetrieveEnv)
    env.reset(seed=0, options={"scene": lone_can("sigma1", CAN)})
    assert env_scene(env) is env.unwrapped.scene and goal_name(env) == "red_can"
    env.close()
