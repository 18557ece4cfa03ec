"""The stable-baselines3 callbacks of a `clutter-gym train` run: SB3's `EvalCallback` and
`CheckpointCallback`, subclassed where the run directory needs more than they write.

Both keep the run's schedule in env steps: they act when the step count crosses a multiple of
``eval_freq`` or ``save_freq`` (`crossed`). SB3 counts calls of a callback instead, and a call is
``n_envs`` steps whose count starts again at 0 when a run resumes; so their own frequency is 1
(every call) and `crossed` decides which calls do the work.

Imported only when a run trains (it imports stable-baselines3, an optional extra).
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, SupportsFloat

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import VecEnv
from tqdm import tqdm

from agents.learning import runs as files
from agents.runner.jobs import FirstInterrupt
from clutter_gym.model.files import atomic_write_text

if TYPE_CHECKING:
    from agents.learning.demos import Transition


def crossed(steps: int, n_envs: int, every: int) -> bool:
    """Whether the call that brought the step count to ``steps`` (``n_envs`` steps, one per
    env) crossed a multiple of ``every``."""
    return steps // every > (steps - n_envs) // every


class EvalEpisodes(Monitor):
    """The evaluation env under SB3's Monitor, which keeps each episode's return (unrounded)
    and length. The k-th reset after `restart` uses seed ``first_seed + k``, so that every
    evaluation of every run sees the same scenes (a vector env seeds only its first reset);
    each episode's success (``is_success`` of its last info, False without one) is kept too."""

    def __init__(self, env: gym.Env, first_seed: int) -> None:
        super().__init__(env)
        self.first_seed = first_seed
        self.resets = 0
        self.successes: list[bool] = []

    def restart(self) -> None:
        self.resets = 0

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        kwargs["seed"] = self.first_seed + self.resets
        self.resets += 1
        return super().reset(**kwargs)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = super().step(action)
        if terminated or truncated:
            self.successes.append(bool(info.get("is_success", False)))
        return obs, reward, terminated, truncated, info

    def row(self, n: int, steps: int) -> dict[str, float]:
        """The row of eval.csv for the last ``n`` episodes (the mean return to 6 digits)."""
        returns, lengths = self.get_episode_rewards()[-n:], self.get_episode_lengths()[-n:]
        return {
            "timesteps": float(steps),
            "success_rate": sum(self.successes[-n:]) / n,
            "mean_reward": round(sum(returns) / n, 6),
            "mean_length": sum(lengths) / n,
        }


class RunEvaluation(EvalCallback):
    """SB3's evaluation (deterministic episodes on `EvalEpisodes`, VecNormalize statistics
    synced from training, ``eval/`` scalars to TensorBoard), then a row of the run's eval.csv
    and its best model. The best is by success rate, then mean reward (SB3 saves by mean reward
    alone, so its own best model is off), saved with its VecNormalize statistics and best.json.
    """

    def __init__(
        self,
        eval_env: VecEnv,
        episodes: EvalEpisodes,
        directory: Path,
        n_episodes: int,
        every: int,
        bar: tqdm,
    ) -> None:
        super().__init__(eval_env, n_eval_episodes=n_episodes, eval_freq=1, verbose=0)
        self.episodes = episodes
        self.directory = directory
        self.every = every
        self.bar = bar
        self.rows = files.read_eval_csv(directory / files.EVAL_CSV)
        self.best = files.read_json_object(directory / files.BEST_JSON)

    def _init_callback(self) -> None:
        with warnings.catch_warnings():
            # The evaluation env is one env in this process, whatever vector env trains.
            warnings.filterwarnings("ignore", "Training and eval env are not of the same type")
            super()._init_callback()

    def _on_step(self) -> bool:
        if not crossed(self.num_timesteps, self.model.n_envs, self.every):
            return True
        return self.evaluate()

    def evaluate(self) -> bool:
        """Evaluate now (also called once training has stopped); False stops training."""
        self.episodes.restart()
        go_on = super()._on_step()
        row = self.episodes.row(self.n_eval_episodes, self.num_timesteps)
        self.rows.append(row)
        files.write_eval_csv(self.directory / files.EVAL_CSV, self.rows)
        self.bar.set_postfix(success=f"{row['success_rate']:.2f}")
        if _better(row, self.best):
            save_model(self.model, self.directory, files.BEST_MODEL, files.BEST_VECNORMALIZE)
            self.best = {k: row[k] for k in files.EVAL_COLUMNS}
            atomic_write_text(self.directory / files.BEST_JSON, json.dumps(self.best) + "\n")
        return go_on


def _better(row: dict[str, float], best: dict[str, Any]) -> bool:
    """Higher success rate; at equal success, higher mean reward."""
    if not best:
        return True
    return (row["success_rate"], row["mean_reward"]) > (best["success_rate"], best["mean_reward"])


class RunCheckpoint(CheckpointCallback):
    """SB3's checkpoint (the model, VecNormalize statistics and an off-policy algorithm's
    replay buffer, under names of the step), then `files.LATEST_JSON` naming them, written
    atomically and last: a run killed while saving resumes from the checkpoint before. The
    files of older checkpoints go."""

    def __init__(self, directory: Path, every: int) -> None:
        super().__init__(
            save_freq=1, save_path=str(directory), save_replay_buffer=True, save_vecnormalize=True
        )
        self.directory = directory
        self.every = every

    def _on_step(self) -> bool:
        if crossed(self.num_timesteps, self.model.n_envs, self.every):
            self.save()
        return True

    def save(self) -> None:
        """A checkpoint now (also called once training has stopped)."""
        super()._on_step()
        has_buffer = getattr(self.model, "replay_buffer", None) is not None
        has_stats = self.model.get_vec_normalize_env() is not None
        latest = {
            "steps": self.num_timesteps,
            "model": self._name("", "zip"),
            "vecnormalize": self._name("vecnormalize_", "pkl") if has_stats else None,
            "replay_buffer": self._name("replay_buffer_", "pkl") if has_buffer else None,
        }
        atomic_write_text(self.directory / files.LATEST_JSON, json.dumps(latest) + "\n")
        keep = {latest["model"], latest["vecnormalize"], latest["replay_buffer"]}
        for path in self.directory.iterdir():
            if path.name not in keep | {files.LATEST_JSON}:
                path.unlink(missing_ok=True)

    def _name(self, kind: str, extension: str) -> str:
        return Path(self._checkpoint_path(kind, extension)).name


class Progress(BaseCallback):
    """The run's env steps on a bar that starts where the run resumed (SB3's progress bar
    counts this session's steps only)."""

    def __init__(self, bar: tqdm) -> None:
        super().__init__()
        self.bar = bar

    def _on_step(self) -> bool:
        self.bar.update(self.num_timesteps - self.bar.n)
        return True


class DemoCloning:
    """Behaviour cloning of the demos' actions by the actor's deterministic action (mean
    squared error, batches of the run's batch size drawn from the demos), called for a number
    of gradient steps: before the run learns (`train.BC_STEPS`), then `train.CLONE_STEPS` after
    every env step of it (`KeepCloning`). The cloned actor grasped the can in 10 of 10 episodes
    of the grasp stage's first evaluation; left to SAC's updates alone, with a critic that
    starts random or one first trained on the demos, it grasped in none of the evaluations
    after (to 8k steps); with one cloning step per env step, in none to 3k; with five, it fell
    to 0-1 of 10 and came back to 8 of 10 at 5k steps."""

    def __init__(self, model: Any, steps: list[Transition], seed: int) -> None:
        self.model = model
        first = steps[0][0]
        if isinstance(first, dict):
            stacked: Any = {key: np.stack([s[0][key] for s in steps]) for key in first}
        else:
            stacked = np.stack([s[0] for s in steps])
        self.observations, _ = model.policy.obs_to_tensor(stacked)
        actions = np.stack([np.asarray(s[1]) for s in steps])
        self.actions = torch.as_tensor(model.policy.scale_action(actions))
        self.rng = np.random.default_rng(seed)

    def __call__(self, gradient_steps: int) -> float:
        """Root mean squared action error of the last batch (actions in [-1, 1])."""
        model, loss = self.model, torch.zeros(())
        model.policy.set_training_mode(True)
        for _ in range(gradient_steps):
            rows = self.rng.integers(len(self.actions), size=int(model.batch_size))
            index = torch.as_tensor(rows)
            obs = self.observations
            batch = {k: v[index] for k, v in obs.items()} if isinstance(obs, dict) else obs[index]
            loss = torch.nn.functional.mse_loss(
                model.actor(batch, deterministic=True), self.actions[index]
            )
            model.actor.optimizer.zero_grad()
            loss.backward()
            model.actor.optimizer.step()
        model.policy.set_training_mode(False)
        return float(loss.detach()) ** 0.5


class KeepCloning(BaseCallback):
    """``steps`` gradient steps of behaviour cloning of the demos (`DemoCloning`) after
    every env step once the algorithm learns (from ``learning_starts`` on): the actor keeps what the
    teacher showed while SAC improves on it."""

    def __init__(self, clone: Callable[[int], float], steps: int) -> None:
        super().__init__()
        self.clone = clone
        self.steps = steps

    def _on_step(self) -> bool:
        if self.num_timesteps >= getattr(self.model, "learning_starts", 0):
            self.clone(self.steps)
        return True


class StopOnInterrupt(BaseCallback):
    """Stops training at the step after the first Ctrl-C; the run then saves a checkpoint."""

    def __init__(self, interrupt: FirstInterrupt) -> None:
        super().__init__()
        self.interrupt = interrupt

    def _on_step(self) -> bool:
        return not self.interrupt.seen


def save_model(model: BaseAlgorithm, directory: Path, name: str, stats_name: str) -> None:
    """The model (and its VecNormalize statistics) under a name, each replaced atomically."""
    temporary = directory / f".{name}.tmp.zip"
    model.save(temporary)
    os.replace(temporary, directory / name)
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        normalizer.save(str(directory / f".{stats_name}.tmp"))
        os.replace(directory / f".{stats_name}.tmp", directory / stats_name)
