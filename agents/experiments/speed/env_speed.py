"""Speed and memory benchmarks: numbers are measured here and written as JSON, never asserted.

`clutter-gym bench env` reports
- low-level steps/s (`ClutterRetrieveEE-v0`, random actions; resets are not timed),
- trajectory steps/s and physics steps/s (`ClutterRetrieve-v0`, free-space trajectories around
  the home configuration),
- mean reset time, and RSS growth over `resets` resets,
- panda-gym's PandaPush-v3 steps/s in the same run, and our ratio to it, when panda-gym is
  installed (`pip install -e ".[bench]"`). The two low-level envs take turns, `CHUNKS` times
  each, so that on a shared machine a change of load slows both alike instead of biasing the
  ratio (measured one after the other, repeated runs' ratios swung between 1.3 and 2.5 here).
"""

from __future__ import annotations

import platform
import resource
import sys
import time
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import clutter_gym  # noqa: F401  (registers the variants)
from clutter_gym.model import herb as hm
from clutter_gym.sim.bullet import native_stdout_muted


def rss_mb() -> float:
    """Resident set size of this process in MB (Linux /proc; the benchmark machine)."""
    with open("/proc/self/statm") as handle:
        pages = int(handle.read().split()[1])
    return pages * resource.getpagesize() / 1e6


CHUNKS = 10


class _Timed:
    """An env stepped with seeded random actions and reset when an episode ends; only `step`
    is timed."""

    def __init__(self, env: gym.Env, seed: int = 0) -> None:
        self.env = env
        env.reset(seed=seed)
        env.action_space.seed(seed)
        self.steps, self.elapsed = 0, 0.0

    def run(self, steps: int) -> None:
        for _ in range(steps):
            action = self.env.action_space.sample()
            start = time.perf_counter()
            _, _, terminated, truncated, _ = self.env.step(action)
            self.elapsed += time.perf_counter() - start
            if terminated or truncated:
                self.env.reset()
        self.steps += steps

    @property
    def per_second(self) -> float:
        return self.steps / self.elapsed


def bench_low_level(steps: int) -> dict[str, float | None]:
    """Our end-effector steps/s and PandaPush-v3's (None without panda-gym), taking turns."""
    envs = [gym.make("ClutterRetrieveEE-v0", level="medium")]
    panda = _make_panda()
    if panda is not None:
        envs.append(panda)
    try:
        timed = [_Timed(env) for env in envs]
        for chunk in tqdm(range(CHUNKS), desc="low-level steps", unit="chunk", leave=False):
            for each in timed:
                each.run(steps // CHUNKS + (chunk < steps % CHUNKS))
    finally:
        for env in envs:
            env.close()
    ours = timed[0].per_second
    theirs = timed[1].per_second if panda is not None else None
    return {
        "low_level_steps_per_s": ours,
        "panda_push_v3_steps_per_s": theirs,
        "low_level_vs_panda_ratio": None if theirs is None else ours / theirs,
    }


def bench_trajectory(steps: int, seed: int = 0) -> dict[str, float]:
    env = gym.make("ClutterRetrieve-v0", level="medium")
    rng = np.random.default_rng(seed)
    home = np.asarray(hm.RIGHT_ARM_HOME)
    shape = env.action_space.shape
    assert shape is not None
    env.reset(seed=seed)
    elapsed, physics = 0.0, 0
    try:
        for _ in tqdm(range(steps), desc="trajectory steps", unit="step", leave=False):
            action = np.zeros(shape, dtype=np.float32)
            action[:, :7] = home + rng.uniform(-0.3, 0.3, size=(shape[0], 7))
            action[:, 7:] = rng.uniform(0.0, 0.5, size=(shape[0], 2))
            start = time.perf_counter()
            *_, info = env.step(action)
            elapsed += time.perf_counter() - start
            physics += info["sim_steps"]
            env.reset()
    finally:
        env.close()
    return {"trajectory_steps_per_s": steps / elapsed, "physics_steps_per_s": physics / elapsed}


def bench_resets(resets: int) -> dict[str, float]:
    env = gym.make("ClutterRetrieve-v0")
    env.reset(seed=0)
    for _ in range(20):  # warm-up: caches, allocator pools
        env.reset()
    before = rss_mb()
    start = time.perf_counter()
    for i in tqdm(range(resets), desc="resets", unit="reset", leave=False):
        env.reset(seed=i)
    elapsed = time.perf_counter() - start
    growth = rss_mb() - before
    env.close()
    return {"reset_ms": 1e3 * elapsed / resets, "rss_growth_mb": growth, "resets": resets}


def _make_panda() -> gym.Env | None:
    """panda-gym's PandaPush-v3, or None without panda-gym (the bench extra)."""
    try:
        import panda_gym  # noqa: F401
    except ImportError:
        print("PandaPush-v3 not measured: pip install -e '.[bench]'", file=sys.stderr)
        return None
    with native_stdout_muted():
        return gym.make("PandaPush-v3")


def bench_primitive(steps: int) -> dict[str, float | None]:
    """Wall time of a ClutterRetrievePrimitive-v0 step under seeded random actions: over every
    step, and over the steps whose primitive was executed in physics (the rest end at once
    with the infeasible cost). Made by id: the env is a wrapper above ``planners``."""
    env = gym.make("ClutterRetrievePrimitive-v0")
    env.action_space.seed(0)
    env.reset(seed=0)
    executed: list[float] = []
    total = 0.0
    try:
        for _ in tqdm(range(steps), desc="primitive steps", unit="step", leave=False):
            action = env.action_space.sample()
            start = time.perf_counter()
            _, _, terminated, truncated, info = env.step(action)
            elapsed = time.perf_counter() - start
            total += elapsed
            if not info["infeasible"]:
                executed.append(elapsed)
            if terminated or truncated:
                env.reset()
    finally:
        env.close()
    return {
        "primitive_step_s": total / steps,
        "primitive_executed_step_s": float(np.mean(executed)) if executed else None,
        "primitive_executed_steps": len(executed),
        "primitive_steps": steps,
    }


def bench_env(
    steps: int = 2000, trajectory_steps: int = 20, resets: int = 1000, primitive_steps: int = 100
) -> dict[str, Any]:
    result: dict[str, Any] = {
        "benchmark": "env",
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    result.update(bench_low_level(steps))
    result.update(bench_trajectory(trajectory_steps))
    result.update(bench_resets(resets))
    result.update(bench_primitive(primitive_steps))
    return result
