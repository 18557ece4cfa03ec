"""The Rearrange planner as a Gymnasium policy, executed in the pybullet env."""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import clutter_gym  # noqa: F401  (registers the env)
from agents.policies.rearrange import RearrangePolicy
from clutter_gym.model.scene import load_scene, scene_from_dict
from planners.actions.settings import PlannerSettings
from tests.helpers import OUT_OF_REACH, lone_can

LONE_CAN = lone_can("sigma3")


def rollout(
    scene: Any, policy_kwargs: dict[str, Any], seed: int = 0
) -> tuple[dict, RearrangePolicy]:
    env = gym.make("ClutterRetrieve-v0", max_episode_steps=40)
    try:
        obs, info = env.reset(seed=seed, options={"scene": scene})
        # A budget far above these plans' few seconds: a loaded machine must not cut them.
        policy_kwargs.setdefault("settings", PlannerSettings(time_budget=120.0))
        policy = RearrangePolicy(16, names=info["object_names"], **policy_kwargs)
        terminated = truncated = False
        while not (terminated or truncated):
            action = policy(obs)
            assert env.action_space.contains(action)
            obs, _, terminated, truncated, info = env.step(action)
            if policy.failure:
                break
    finally:
        env.close()
    return info, policy


def test_open_loop_policy_retrieves_a_can_under_sigma3() -> None:
    info, policy = rollout(scene_from_dict(LONE_CAN), {})
    assert policy.plan is not None and policy.plan.success
    assert len(policy.plans) == 1  # planned once, from the first detection
    assert info["is_success"] and info["goal_held"] and not info["failure"]


@pytest.mark.xfail(
    strict=True,
    reason="the replan after the dumbbell's sweep finds no sweep of the box: the dumbbell was "
    "swept only just out of the first plan's NGR, and the new detection's box sweep swings "
    "its corner into it (open-loop execution of the first plan succeeds)",
)
def test_closed_loop_policy_replans_after_each_action() -> None:
    text = (
        resources.files("clutter_gym")
        .joinpath("scenes/figures/fig3_can_box_dumbbell.json")
        .read_text()
    )
    info, policy = rollout(load_scene(json.loads(text)), {"closed_loop": True})
    assert policy.plans[0].objects_moved == ["dumbbell", "big_box"]
    assert len(policy.plans) == 3  # one plan per action, each from a new detection
    assert policy.plans[1].objects_moved == ["big_box"]
    assert policy.plans[2].objects_moved == []
    assert info["is_success"], policy.failure


def test_policy_without_a_plan_holds_still_and_says_why() -> None:
    far = lone_can("sigma3", OUT_OF_REACH)
    env = gym.make("ClutterRetrieve-v0")
    try:
        obs, _ = env.reset(seed=0, options={"scene": scene_from_dict(far)})
        policy = RearrangePolicy(16, settings=PlannerSettings(time_budget=3.0))
        action = policy(obs)
        assert policy.failure and policy.plan is not None and policy.plan.blocked_by
        assert np.allclose(action[:, :7], obs["arm_joints"], atol=1e-6)
    finally:
        env.close()


def test_unknown_planner_lists_the_choices() -> None:
    with pytest.raises(ValueError, match="allowed: pushing, pick-and-place, pg, tsr"):
        RearrangePolicy(16, planner="teleport")
