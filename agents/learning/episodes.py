"""One episode of any agent on any registered variant, measured the same way for all: the
training runs' periodic evaluations and `clutter-gym evaluate` both count with `run_episode`.

An agent is a function from an observation to an action, made after the reset (a planner plans
from the first observation; the scripted grasp needs the scene's surface).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from agents.policies.rollout import roll_out

Act = Callable[[Any], Any]
MakeAct = Callable[[gym.Env, dict[str, Any]], Act]
"""(env after its reset, the reset's info) -> the agent's act function."""
MOVED_M = 0.02
"""An object other than the goal counts as moved when its planar position changed more."""


@dataclass(frozen=True)
class Episode:
    """What one episode did; ``objects_moved`` is None when the env does not report poses."""

    success: bool
    length: int
    ret: float
    failure: str
    objects_moved: tuple[str, ...] | None
    wall_time_s: float
    act: Act

    def as_dict(self) -> dict[str, Any]:
        moved = None if self.objects_moved is None else list(self.objects_moved)
        return {
            "success": self.success,
            "length": self.length,
            "return": round(self.ret, 6),
            "failure": self.failure,
            "objects_moved": moved,
            "n_objects_moved": None if moved is None else len(moved),
            "wall_time_s": round(self.wall_time_s, 4),
        }


def run_episode(env: gym.Env, make_act: MakeAct, seed: int) -> Episode:
    """Reset with ``seed`` and act until the episode ends (terminated or truncated)."""
    start = time.perf_counter()
    obs, first = env.reset(seed=seed)
    act = make_act(env, first)
    rollout = roll_out(env, obs, act, first)
    info = rollout.info
    return Episode(
        success=bool(info.get("is_success", False)),
        length=rollout.steps,
        ret=rollout.ret,
        failure=str(info.get("failure", "")),
        objects_moved=objects_moved(first, info, goal_name(env)),
        wall_time_s=time.perf_counter() - start,
        act=act,
    )


def env_scene(env: gym.Env) -> Any:
    """The episode's scene: an attribute of the env under any wrappers (the primitive variant
    is one), None if there is none."""
    try:
        return env.get_wrapper_attr("scene")
    except AttributeError:
        return None


def goal_name(env: gym.Env) -> str | None:
    """The goal object's name, from the env's scene (None if it shows none)."""
    goal = getattr(env_scene(env), "goal", None)
    return getattr(goal, "object", None)


def objects_moved(
    start: Mapping[str, Any], end: Mapping[str, Any], goal: str | None
) -> tuple[str, ...] | None:
    """Objects other than the goal whose true planar position moved more than `MOVED_M`
    between two infos (`true_object_poses`, `object_names`); None if they lack them."""
    try:
        names = tuple(start["object_names"])
        before = np.asarray(start["true_object_poses"], dtype=float)[: len(names), :2]
        after = np.asarray(end["true_object_poses"], dtype=float)[: len(names), :2]
    except (KeyError, TypeError, ValueError):
        return None
    distance = np.linalg.norm(after - before, axis=1)
    return tuple(n for n, d in zip(names, distance, strict=True) if n != goal and d > MOVED_M)
