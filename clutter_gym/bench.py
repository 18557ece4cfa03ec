"""Speed and memory benchmarks: numbers are measured here and written as JSON, never asserted.

`clutter-gym bench env` reports
- low-level steps/s (control_mode="ee_delta", random actions),
- trajectory steps/s and physics steps/s (control_mode="trajectory", free-space trajectories
  around the home configuration),
- mean reset time, and RSS growth over `resets` resets,
- panda-gym's PandaPush-v3 steps/s in the same run, and our ratio to it, when panda-gym is
  installed (`pip install -e ".[bench]"`).
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

import clutter_gym  # noqa: F401  (registers the env)
from clutter_gym.model import herb as hm
from clutter_gym.sim.simulator import native_stdout_muted


def rss_mb() -> float:
    """Resident set size of this process in MB (Linux /proc; the benchmark machine)."""
    with open("/proc/self/statm") as handle:
        pages = int(handle.read().split()[1])
    return pages * resource.getpagesize() / 1e6


def _steps_per_second(env: gym.Env, steps: int, desc: str, seed: int = 0) -> float:
    env.reset(seed=seed)
    env.action_space.seed(seed)
    elapsed = 0.0
    for _ in tqdm(range(steps), desc=desc, unit="step", leave=False):
        action = env.action_space.sample()
        start = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(action)
        elapsed += time.perf_counter() - start
        if terminated or truncated:
            env.reset()
    return steps / elapsed


def bench_low_level(steps: int) -> float:
    env = gym.make("ClutterRetrieve-v0", control_mode="ee_delta", level="medium")
    try:
        return _steps_per_second(env, steps, "ee_delta steps")
    finally:
        env.close()


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


def bench_panda(steps: int) -> float | None:
    """PandaPush-v3 steps/s in this process, or None without panda-gym (the bench extra)."""
    try:
        import panda_gym  # noqa: F401
    except ImportError:
        print("PandaPush-v3 not measured: pip install -e '.[bench]'", file=sys.stderr)
        return None
    with native_stdout_muted():
        env = gym.make("PandaPush-v3")
    try:
        return _steps_per_second(env, steps, "PandaPush-v3 steps")
    finally:
        env.close()


def bench_env(steps: int = 2000, trajectory_steps: int = 20, resets: int = 1000) -> dict[str, Any]:
    result: dict[str, Any] = {
        "benchmark": "env",
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    result["low_level_steps_per_s"] = bench_low_level(steps)
    result.update(bench_trajectory(trajectory_steps))
    result.update(bench_resets(resets))
    panda = bench_panda(steps)
    result["panda_push_v3_steps_per_s"] = panda
    result["low_level_vs_panda_ratio"] = (
        None if panda is None else result["low_level_steps_per_s"] / panda
    )
    return result
