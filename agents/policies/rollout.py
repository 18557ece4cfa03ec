"""The one rollout loop: a policy, or a fixed list of actions, stepped on an env until the
episode ends. The demo, `clutter-gym plan`'s executions, validate-capture's trials and every
measured episode (`agents.learning.episodes`) step through it."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym


@dataclass(frozen=True)
class Rollout:
    """What the steps did: how many, their summed reward, the last info and observation."""

    steps: int
    ret: float
    info: dict[str, Any]
    obs: Any


def roll_out(
    env: gym.Env,
    obs: Any,
    act: Callable[[Any], Any] | Iterable[Any],
    info: dict[str, Any],
    stop: Callable[[], bool] | None = None,
) -> Rollout:
    """Step from ``obs`` (with ``info``, returned if no step is taken) until the episode is
    terminated or truncated, ``act`` (a policy of the observation, or the actions to replay in
    order) has no more actions, or ``stop()`` says so after a step."""
    replayed = None if callable(act) else iter(act)
    steps, total = 0, 0.0
    while True:
        if replayed is None:
            action = act(obs)  # type: ignore[operator]
        else:
            action = next(replayed, None)
            if action is None:
                break
        obs, reward, terminated, truncated, info = env.step(action)
        steps, total = steps + 1, total + float(reward)
        if terminated or truncated or (stop is not None and stop()):
            break
    return Rollout(steps, total, info, obs)
