"""`clutter-gym bench train`: what one training step of an off-policy agent costs here, the env
and the gradient update timed apart in one run, and what a run of the config's length takes.

The model is built from a hyperparameter entry as `clutter-gym train` builds it (one torch
thread, CPU). Its first `learning_starts` steps fill the replay buffer with no update; then
`steps` steps learn, one update per step as the entries ask. A wrapper times every `env.step`;
the rest of the learning phase is the update (sampling from the replay buffer, with hindsight
relabelling for HER, and the gradient step) plus stable-baselines3's own bookkeeping.
"""

from __future__ import annotations

import platform
import time
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym

from agents.learning.rl_config import algorithm_class, algorithm_kwargs, load_hyperparams
from agents.learning.runs import make_env, one_torch_thread
from agents.learning.train import policy_for

DEFAULT_CONFIG = Path(__file__).resolve().parents[2] / "hyperparams" / "sac_lone_can.yml"


class _StepTimer(gym.Wrapper):
    """Adds up the wall time spent inside the wrapped env's `step`."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.seconds = 0.0

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        start = time.perf_counter()
        try:
            return self.env.step(action)
        finally:
            self.seconds += time.perf_counter() - start


def bench_train(
    algo: str = "sac",
    env_id: str = "ClutterRetrieveEE-v0",
    config: Path | None = None,
    steps: int = 2000,
    seed: int = 0,
) -> dict[str, Any]:
    """Milliseconds per env step, per update and per training step, and the hours of a run of
    the entry's ``n_timesteps`` at that pace."""
    hp = load_hyperparams(algo, env_id, config or DEFAULT_CONFIG)
    warmup = int(hp.algo_kwargs.get("learning_starts", 100))
    env = _StepTimer(make_env(env_id, **hp.env_kwargs))
    with one_torch_thread():
        model = algorithm_class(algo)(
            policy_for(hp, env.observation_space),
            env,
            seed=seed,
            device="cpu",
            verbose=0,
            **algorithm_kwargs(hp),
        )
        model.learn(total_timesteps=warmup)  # random actions into the buffer, no update
        env.seconds = 0.0
        start = time.perf_counter()
        model.learn(total_timesteps=steps, reset_num_timesteps=False)
        total = time.perf_counter() - start
    env.close()
    per_step = 1000.0 * total / steps
    env_ms = 1000.0 * env.seconds / steps
    run_steps = hp.n_timesteps or steps
    return {
        "algo": algo,
        "env": env_id,
        "config": str(config) if config else "agents/hyperparams/sac_lone_can.yml",
        "env_kwargs": hp.env_kwargs,
        "batch_size": hp.algo_kwargs.get("batch_size"),
        "net_arch": (hp.algo_kwargs.get("policy_kwargs") or {}).get("net_arch"),
        "replay_buffer": hp.algo_kwargs.get("replay_buffer_class", "ReplayBuffer"),
        "timed_steps": steps,
        "warmup_steps": warmup,
        "torch_threads": 1,
        "ms_per_env_step": round(env_ms, 2),
        "ms_per_update": round(per_step - env_ms, 2),
        "ms_per_training_step": round(per_step, 2),
        "run_steps": run_steps,
        "run_hours": round(run_steps * per_step / 3.6e6, 2),
        "python": platform.python_version(),
    }
