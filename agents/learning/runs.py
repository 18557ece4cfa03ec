"""A training run's directory as `clutter-gym train` leaves it, and its agent acting again.

The file names and formats (eval.csv, the checkpoint in force) live here, shared by the trainer
and its callbacks that write them and the evaluation and figures that read them. The agent acts
deterministically on raw observations of its env: the VecNormalize statistics saved beside a
model (if the run normalised) are applied here, as in training.
"""

from __future__ import annotations

import csv
import json
import pickle
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

import clutter_gym  # noqa: F401  (registers the ids, also in a freshly spawned process)
from agents.learning.episodes import Act
from agents.learning.rl_config import ALGOS, algorithm_class
from clutter_gym.model.files import atomic_write_text

RUN_JSON = "run.json"
EVAL_CSV = "eval.csv"
BEST_MODEL = "best_model.zip"
BEST_VECNORMALIZE = "best_vecnormalize.pkl"
BEST_JSON = "best.json"
FINAL_MODEL = "final_model.zip"
FINAL_VECNORMALIZE = "vecnormalize.pkl"
CHECKPOINTS = "checkpoints"
LATEST_JSON = "latest.json"
"""In `CHECKPOINTS`: the checkpoint in force (steps, and the names of its model, VecNormalize
statistics and replay buffer files; None for those the run has not)."""
TENSORBOARD = "tb"
EVAL_COLUMNS = ("timesteps", "success_rate", "mean_reward", "mean_length")


@dataclass(frozen=True)
class TrainedRun:
    """What evaluating a run needs: its algorithm, env, keywords and the model to load (the
    best one, else the final one)."""

    directory: Path
    algo: str
    env_id: str
    env_kwargs: dict[str, Any]
    model: Path
    vecnormalize: Path | None

    def make_act(self, env: gym.Env) -> Act:
        """The trained policy as ``action = act(obs)``, deterministic. ``env`` (one of the
        run's variant) is what an off-policy model with HER needs to be loaded at all; the
        replay buffer it then builds is cut to one transition, since acting needs none."""
        model = algorithm_class(self.algo).load(
            self.model, env=env, device="cpu", custom_objects={"buffer_size": 1}
        )
        normalizer = None
        if self.vecnormalize is not None:
            with self.vecnormalize.open("rb") as handle:
                normalizer = pickle.load(handle)  # our own file: VecNormalize without its env

        def act(obs: Any) -> Any:
            seen = normalizer.normalize_obs(obs) if normalizer is not None else obs
            action, _ = model.predict(seen, deterministic=True)
            return action

        return act


def read_run(directory: Path) -> TrainedRun:
    """The run in ``directory``; ValueError saying what is missing otherwise."""
    try:
        run = json.loads((directory / RUN_JSON).read_text())
    except OSError:
        raise ValueError(f"{directory}: no {RUN_JSON}; not a clutter-gym train directory") from None
    except ValueError as error:
        raise ValueError(f"{directory / RUN_JSON}: not valid JSON ({error})") from None
    algo, env_id = run.get("algo"), run.get("env")
    if algo not in ALGOS or not isinstance(env_id, str):
        raise ValueError(f"{directory / RUN_JSON}: no algo ({', '.join(ALGOS)}) and env id")
    for model, stats in ((BEST_MODEL, BEST_VECNORMALIZE), (FINAL_MODEL, FINAL_VECNORMALIZE)):
        if (directory / model).is_file():
            normalizer = directory / stats
            return TrainedRun(
                directory=directory,
                algo=algo,
                env_id=env_id,
                env_kwargs=_env_kwargs(run),
                model=directory / model,
                vecnormalize=normalizer if normalizer.is_file() else None,
            )
    raise ValueError(f"{directory}: neither {BEST_MODEL} nor {FINAL_MODEL}; has it trained?")


def _env_kwargs(run: dict[str, Any]) -> dict[str, Any]:
    """The keywords the run made its env with (run.json: settings.hyperparams.env_kwargs)."""
    settings = run.get("settings")
    hyperparams = settings.get("hyperparams") if isinstance(settings, dict) else None
    kwargs = hyperparams.get("env_kwargs") if isinstance(hyperparams, dict) else None
    return dict(kwargs) if isinstance(kwargs, dict) else {}


def read_eval_csv(path: Path) -> list[dict[str, float]]:
    """The rows of an eval.csv as numbers; ValueError naming the file if it is not one."""
    if not path.exists():
        return []
    try:
        with path.open(newline="") as handle:
            reader = csv.DictReader(handle)
            if tuple(reader.fieldnames or ()) != EVAL_COLUMNS:
                raise ValueError(f"columns {reader.fieldnames}, expected {list(EVAL_COLUMNS)}")
            return [{k: float(row[k]) for k in EVAL_COLUMNS} for row in reader]
    except (OSError, ValueError, TypeError, csv.Error) as error:
        raise ValueError(f"{path}: not an eval.csv of clutter-gym train ({error})") from None


def write_eval_csv(path: Path, rows: list[dict[str, float]]) -> None:
    """All the rows, replacing the file atomically (whole numbers without a decimal point)."""
    lines = [",".join(EVAL_COLUMNS)]
    lines += [",".join(_number(row[k]) for k in EVAL_COLUMNS) for row in rows]
    atomic_write_text(path, "\n".join(lines) + "\n")


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def read_json_object(path: Path) -> dict[str, Any]:
    """A JSON object from a file; {} if it is missing, unreadable or not an object."""
    try:
        value = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


def latest_checkpoint(directory: Path) -> dict[str, Any] | None:
    """The run's checkpoint in force (its `LATEST_JSON`), if all its files are there."""
    checkpoints = directory / CHECKPOINTS
    latest = read_json_object(checkpoints / LATEST_JSON)
    names = [latest.get(k) for k in ("model", "vecnormalize", "replay_buffer")]
    if "steps" not in latest or not all(n is None or (checkpoints / n).is_file() for n in names):
        return None
    return latest


def make_env(env_id: str, **kwargs: Any) -> gym.Env:
    """A registered variant by id."""
    return gym.make(env_id, **kwargs)


@contextmanager
def one_torch_thread() -> Iterator[None]:
    """One torch thread inside the block (the previous count after it): runs and evaluations
    share the cores, and a run's numbers do not depend on how many threads its machine gave."""
    try:
        import torch
    except ImportError:
        yield
        return
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)
