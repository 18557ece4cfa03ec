"""`clutter-gym train`: stable-baselines3 (PPO, SAC) and sb3-contrib (TQC) agents on any
registered variant, in the conventions of rl-baselines3-zoo.

One run is one (algorithm, env id, seed) in its own directory (`agents.learning.runs` names the
files):

* ``run.json``: the settings and hyperparameters actually used, versions, seed, status;
* ``eval.csv`` (timesteps, success_rate, mean_reward, mean_length) and ``tb/`` (TensorBoard):
  every ``eval_freq`` env steps, and at the end, ``eval_episodes`` deterministic episodes, the
  k-th reset with seed ``EVAL_SEED + k``: every evaluation of every run sees the same scenes,
  so curves of different seeds and algorithms compare;
* ``best_model.zip`` (with ``best.json``), ``final_model.zip``, VecNormalize statistics beside
  each when the entry normalises;
* ``checkpoints/``: the latest checkpoint (model, VecNormalize, replay buffer of off-policy
  algorithms), every ``save_freq`` env steps and when interrupted; ``latest.json`` is written
  last, so a crash while saving leaves the previous checkpoint in force.

Running the same command again resumes an unfinished run from its checkpoint (the eval rows
after it are dropped: they are measured again); a finished run says so and does nothing; other
settings in the same directory are refused. The first Ctrl-C stops the run at the next env step
and saves a checkpoint (a second one stops at once); env worker processes ignore it. In a local
grid every running run does so; Ray's tasks are not in the terminal's process group, so a Ray
grid stopped by Ctrl-C keeps each run's last periodic checkpoint.

A grid (several seeds or algorithms) is one job per run for the project's job runner
(`agents.runner.jobs`: a local process pool or Ray tasks). The runs' directories, not the runner's
log, say what is done, so the log beside them is a history of invocations. Every run uses one torch
thread, so results do not depend on where it ran: the same seeds give the same eval.csv locally and
on Ray.
"""

from __future__ import annotations

import csv
import functools
import json
import multiprocessing
import os
import platform
import signal
import sys
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import gymnasium as gym
from gymnasium import spaces
from tqdm import tqdm

from agents.learning import runs as files
from agents.learning.episodes import Act, run_episode
from agents.learning.rl_config import (
    Hyperparams,
    algorithm_class,
    algorithm_kwargs,
    allowed_keys,
    load_hyperparams,
    require_rl,
    vec_env_tools,
)
from agents.learning.runs import one_torch_thread
from agents.runner.jobs import FirstInterrupt, Record, config_digest, run_jobs
from clutter_gym.model.files import atomic_write_text

EVAL_SEED = 1_000_000
EVAL_COLUMNS = ("timesteps", "success_rate", "mean_reward", "mean_length")
RUN_FORMAT = "clutter-gym-train/1"
JOBS_LOG = "train_jobs.jsonl"
DRY_BUFFER = 1000
"""Replay buffer size when a config is checked by building its model (not the run's own)."""
VERSIONS = ("clutter-gym", "stable-baselines3", "sb3-contrib", "torch", "gymnasium", "numpy")


@dataclass(frozen=True)
class TrainJob:
    """One run: everything it needs, picklable (it may run in another process or on Ray)."""

    algo: str
    env_id: str
    seed: int
    steps: int
    n_envs: int
    eval_freq: int
    eval_episodes: int
    save_freq: int
    out: str
    hyperparams: Hyperparams

    @property
    def key(self) -> str:
        return f"{self.algo}_seed{self.seed}"

    def identity(self) -> Record:
        return {"algo": self.algo, "env": self.env_id, "seed": self.seed, "dir": self.out}

    def crashed(self, error: str) -> Record:
        return {**self.identity(), "status": "crashed", "error": error}

    def settings(self) -> dict[str, Any]:
        """What a run's directory must match to be resumed (not where the config came from)."""
        entry = {k: v for k, v in self.hyperparams.as_dict().items() if k != "source"}
        return {
            "algo": self.algo,
            "env": self.env_id,
            "seed": self.seed,
            "steps": self.steps,
            "n_envs": self.n_envs,
            "eval_freq": self.eval_freq,
            "eval_episodes": self.eval_episodes,
            "save_freq": self.save_freq,
            "hyperparams": entry,
        }


# --------------------------------------------------------------------------------------------
# Planning and checking a grid (before any work)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GridRequest:
    """The command line's request; None where the config's value (or a default) applies."""

    algos: tuple[str, ...]
    env_id: str
    config: Path | None
    steps: int | None
    n_envs: int | None
    seeds: tuple[int, ...]
    grid: bool
    out: Path
    eval_freq: int | None
    eval_episodes: int
    save_freq: int | None


def prepare_grid(request: GridRequest) -> list[TrainJob]:
    """The runs of a request, every one checked: config entries and keys, the directories, and
    one build of each algorithm's model on the env (skipped when every run is finished)."""
    require_rl()
    hyperparams = {
        algo: load_hyperparams(algo, request.env_id, request.config) for algo in request.algos
    }
    jobs = plan_runs(request, hyperparams)
    for job in jobs:
        check_run_dir(job)
    built = set()
    for job in jobs:
        if job.algo not in built and not _finished(Path(job.out)):
            check_build(job)
            built.add(job.algo)
    return jobs


def plan_runs(request: GridRequest, hyperparams: dict[str, Hyperparams]) -> list[TrainJob]:
    """One job per (algorithm, seed); a grid puts each in ``out/<algo>_seed<seed>``."""
    jobs = []
    for algo in request.algos:
        hp = hyperparams[algo]
        steps = request.steps or hp.n_timesteps
        if steps is None:
            raise ValueError(f"--steps: not given, and {hp.where} has no n_timesteps for {algo}")
        eval_freq = request.eval_freq or max(steps // 10, 1)
        for seed in request.seeds:
            out = request.out / f"{algo}_seed{seed}" if request.grid else request.out
            jobs.append(
                TrainJob(
                    algo=algo,
                    env_id=request.env_id,
                    seed=seed,
                    steps=steps,
                    n_envs=request.n_envs or hp.n_envs or 1,
                    eval_freq=eval_freq,
                    eval_episodes=request.eval_episodes,
                    save_freq=request.save_freq or eval_freq,
                    out=str(out.resolve()),
                    hyperparams=hp,
                )
            )
    return jobs


def check_run_dir(job: TrainJob) -> None:
    """A directory holding another run (other settings, or files but no run.json) is refused."""
    directory = Path(job.out)
    path = directory / files.RUN_JSON
    if not path.exists():
        clutter = [files.EVAL_CSV, files.CHECKPOINTS, files.FINAL_MODEL, files.BEST_MODEL]
        if any((directory / name).exists() for name in clutter):
            raise ValueError(f"--out {directory}: holds training files but no {files.RUN_JSON}")
        return
    try:
        recorded = json.loads(path.read_text()).get("settings")
    except (OSError, ValueError, AttributeError) as error:
        raise ValueError(f"--out {path}: cannot be read as a run ({error})") from None
    now = json.loads(json.dumps(job.settings()))  # tuples as lists, as the file has them
    if recorded != now:
        recorded = recorded if isinstance(recorded, dict) else {}
        differ = [k for k in now if recorded.get(k) != now[k]]
        raise ValueError(
            f"--out {directory}: holds a run with other settings (differs in "
            f"{', '.join(differ) or 'format'}); give another --out or delete it"
        )


def check_build(job: TrainJob) -> None:
    """Build the job's env and model once (a small replay buffer), so that a bad keyword, an
    action space the algorithm cannot handle or a bad env keyword is one line now."""
    require_rl()
    hp = job.hyperparams
    where = f"{hp.where}: {job.env_id}"
    kwargs = algorithm_kwargs(hp)
    try:
        venv = _dummy(job.env_id, hp.env_kwargs)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: env_kwargs: {_line(error)}") from None
    try:
        venv = _normalized(venv, hp.normalize)
        if "buffer_size" in allowed_keys(job.algo):
            kwargs["buffer_size"] = min(int(kwargs.get("buffer_size", DRY_BUFFER)), DRY_BUFFER)
        with one_torch_thread():
            policy = policy_for(hp, venv.observation_space)
            algorithm_class(job.algo)(policy, venv, device="cpu", verbose=0, **kwargs)
    except (TypeError, ValueError, AssertionError, KeyError) as error:
        raise ValueError(f"{where}: {job.algo} cannot use this entry: {_line(error)}") from None
    finally:
        venv.close()


def policy_for(hp: Hyperparams, space: spaces.Space[Any]) -> str:
    """The entry's policy, else the one stable-baselines3 needs for the observation space."""
    if hp.policy is not None:
        return hp.policy
    return "MultiInputPolicy" if isinstance(space, spaces.Dict) else "MlpPolicy"


def _line(error: BaseException) -> str:
    return " ".join(str(error).split()) or type(error).__name__


# --------------------------------------------------------------------------------------------
# Running a grid
# --------------------------------------------------------------------------------------------
def run_grid(
    jobs: list[TrainJob], log_dir: Path, backend: str = "local", workers: int = 1
) -> list[Record]:
    """Every job with the job runner; records in the order of the jobs. A lone local run
    trains here, without the runner's progress bar over its own."""
    if len(jobs) == 1 and backend == "local":
        return [train_run(jobs[0])]
    invocation = {"runs": [j.settings() for j in jobs], "started": time.time_ns()}
    run = run_jobs(
        jobs,
        train_run,
        log_dir / JOBS_LOG,
        config_digest(invocation),
        workers=workers,
        backend=backend,
        desc="runs",
        describe=lambda record: str(record.get("status")),
    )
    return run.records


# --------------------------------------------------------------------------------------------
# One run
# --------------------------------------------------------------------------------------------
def train_run(job: TrainJob) -> Record:
    """Train (or resume, or find finished) the run of ``job``; its summary record."""
    require_rl()
    check_run_dir(job)
    directory = Path(job.out)
    if _finished(directory):
        print(f"{directory}: already finished; nothing to do", file=sys.stderr)
        return _summary(job, "finished")
    with one_torch_thread(), FirstInterrupt("saving a checkpoint at the next step") as interrupt:
        training = _Training(job, interrupt)
        try:
            training.learn()
        finally:
            training.close()
    if interrupt.seen:
        steps = training.model.num_timesteps
        print(f"{directory}: interrupted at {steps} steps; checkpoint saved", file=sys.stderr)
        if multiprocessing.parent_process() is None:
            raise KeyboardInterrupt
        return _summary(job, "interrupted")
    return _summary(job, "finished")


def _finished(directory: Path) -> bool:
    try:
        run = json.loads((directory / files.RUN_JSON).read_text())
    except (OSError, ValueError):
        return False
    return run.get("status") == "finished" and (directory / files.FINAL_MODEL).is_file()


def _summary(job: TrainJob, status: str) -> Record:
    """The run's record: status, steps done, last and best success rates (from its files)."""
    directory = Path(job.out)
    rows = read_eval_csv(directory / files.EVAL_CSV)
    checkpoint = _latest(directory)
    best = _read_json(directory / files.BEST_JSON)
    return {
        **job.identity(),
        "status": status,
        "timesteps": checkpoint["steps"] if checkpoint else 0,
        "final_success_rate": rows[-1]["success_rate"] if rows else None,
        "best_success_rate": best.get("success_rate"),
    }


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


def _read_json(path: Path) -> dict[str, Any]:
    try:
        value = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


def _latest(directory: Path) -> dict[str, Any] | None:
    """The checkpoint in force, if its files are all there."""
    latest = _read_json(directory / files.CHECKPOINTS / "latest.json")
    names = [latest.get(k) for k in ("model", "vecnormalize", "replay_buffer")]
    checkpoints = directory / files.CHECKPOINTS
    if "steps" not in latest or not all(n is None or (checkpoints / n).is_file() for n in names):
        return None
    return latest


def worker_env(env_id: str, in_worker: bool, **kwargs: Any) -> gym.Env:
    """An env of the run's vector env. In a SubprocVecEnv worker it ignores SIGINT: a Ctrl-C is
    the trainer's to handle (it saves a checkpoint), and a worker killed by it would break the
    vector env first. (A DummyVecEnv makes its env in the trainer, whose handler stays.)"""
    if in_worker:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    return files.make_env(env_id, **kwargs)


def _dummy(env_id: str, env_kwargs: dict[str, Any]) -> Any:
    return vec_env_tools().DummyVecEnv([functools.partial(files.make_env, env_id, **env_kwargs)])


def _normalized(venv: Any, options: dict[str, Any] | None) -> Any:
    """``venv`` under VecNormalize when the entry normalises; a Dict observation normalises its
    Box entries only (VecNormalize cannot scale discrete ones)."""
    if options is None:
        return venv
    options = dict(options)
    space = venv.observation_space
    if isinstance(space, spaces.Dict) and "norm_obs_keys" not in options:
        options["norm_obs_keys"] = [k for k, s in space.spaces.items() if isinstance(s, spaces.Box)]
    return vec_env_tools().VecNormalize(venv, **options)


class _Training:
    """The state of one run while it trains: envs, model, evaluation env, progress."""

    def __init__(self, job: TrainJob, interrupt: FirstInterrupt) -> None:
        self.job = job
        self.interrupt = interrupt
        self.dir = Path(job.out)
        self.checkpoints = self.dir / files.CHECKPOINTS
        self.cls = algorithm_class(job.algo)
        checkpoint = _latest(self.dir)
        self.start = int(checkpoint["steps"]) if checkpoint else 0
        self.venv = self._vec_env(job.seed + self.start)
        self.model: Any = None
        try:
            if checkpoint is None:
                self._fresh()
            else:
                self._resume(checkpoint)
            self.eval_env = files.make_env(job.env_id, **job.hyperparams.env_kwargs)
        except BaseException:
            self.venv.close()  # no worker processes left behind
            raise
        self.rows = read_eval_csv(self.dir / files.EVAL_CSV)
        self.best = _read_json(self.dir / files.BEST_JSON)
        self.bar = tqdm(
            total=job.steps, initial=self.start, unit="step", desc=f"{job.algo} seed {job.seed}"
        )
        self.next_eval = _next_multiple(self.start, job.eval_freq)
        self.next_save = _next_multiple(self.start, job.save_freq)

    # --- building -----------------------------------------------------------------------------
    def _vec_env(self, seed: int) -> Any:
        tools = vec_env_tools()
        many = self.job.n_envs > 1
        return tools.make_vec_env(
            functools.partial(worker_env, self.job.env_id, many),
            n_envs=self.job.n_envs,
            seed=seed,
            env_kwargs=self.job.hyperparams.env_kwargs,
            vec_env_cls=tools.SubprocVecEnv if many else tools.DummyVecEnv,
            vec_env_kwargs={"start_method": "spawn"} if many else None,
        )

    def _fresh(self) -> None:
        hp = self.job.hyperparams
        self.dir.mkdir(parents=True, exist_ok=True)
        self.venv = _normalized(self.venv, hp.normalize)
        self.model = self.cls(
            policy_for(hp, self.venv.observation_space),
            self.venv,
            seed=self.job.seed,
            device="cpu",
            verbose=0,
            tensorboard_log=str(self.dir / files.TENSORBOARD),
            **algorithm_kwargs(hp),
        )
        for stale in (files.EVAL_CSV, files.BEST_JSON, files.BEST_MODEL, files.BEST_VECNORMALIZE):
            (self.dir / stale).unlink(missing_ok=True)
        self._write_run("running")
        print(f"{self.dir}: training {self.job.key} on {self.job.env_id}", file=sys.stderr)

    def _resume(self, checkpoint: dict[str, Any]) -> None:
        if checkpoint.get("vecnormalize"):
            stats = self.checkpoints / checkpoint["vecnormalize"]
            self.venv = vec_env_tools().VecNormalize.load(str(stats), self.venv)
        self.model = self.cls.load(
            self.checkpoints / checkpoint["model"],
            env=self.venv,
            device="cpu",
            tensorboard_log=str(self.dir / files.TENSORBOARD),
        )
        self.model.set_random_seed(self.job.seed + self.start)
        if checkpoint.get("replay_buffer"):
            self.model.load_replay_buffer(self.checkpoints / checkpoint["replay_buffer"])
        kept = [r for r in read_eval_csv(self.dir / files.EVAL_CSV) if r["timesteps"] <= self.start]
        self._write_csv(kept)
        print(f"{self.dir}: resuming {self.job.key} from step {self.start}", file=sys.stderr)

    # --- training -----------------------------------------------------------------------------
    def learn(self) -> None:
        remaining = self.job.steps - self.start
        self.model.learn(
            total_timesteps=remaining,
            callback=self._on_step,
            reset_num_timesteps=self.start == 0,
            tb_log_name=self.job.algo.upper(),
        )
        if self.interrupt.seen:
            self.checkpoint()
            self._write_run("interrupted")
            return
        if not self.rows or self.rows[-1]["timesteps"] != self.model.num_timesteps:
            self.evaluate()
        self.checkpoint()
        self._save(files.FINAL_MODEL, files.FINAL_VECNORMALIZE)
        self._write_run("finished")

    def _on_step(self, _locals: dict[str, Any], _globals: dict[str, Any]) -> bool:
        """stable-baselines3 calls this after every vector env step; False stops learning."""
        steps = self.model.num_timesteps
        self.bar.update(steps - self.bar.n)
        if steps >= self.next_eval:
            self.evaluate()
            self.next_eval = _next_multiple(steps, self.job.eval_freq)
        if steps >= self.next_save:
            self.checkpoint()
            self.next_save = _next_multiple(steps, self.job.save_freq)
        return not self.interrupt.seen

    def evaluate(self) -> None:
        """``eval_episodes`` deterministic episodes on the evaluation scenes: a row of
        eval.csv, TensorBoard scalars, and the best model if it is the best so far."""
        act = _policy_act(self.model)
        episodes = [
            run_episode(self.eval_env, lambda env, info: act, EVAL_SEED + k)
            for k in range(self.job.eval_episodes)
        ]
        n = len(episodes)
        row = {
            "timesteps": float(self.model.num_timesteps),
            "success_rate": sum(e.success for e in episodes) / n,
            "mean_reward": round(sum(e.ret for e in episodes) / n, 6),
            "mean_length": sum(e.length for e in episodes) / n,
        }
        self.rows.append(row)
        self._write_csv(self.rows)
        for key in EVAL_COLUMNS[1:]:
            self.model.logger.record(f"eval/{key}", row[key])
        self.model.logger.dump(self.model.num_timesteps)
        self.bar.set_postfix(success=f"{row['success_rate']:.2f}")
        if _better(row, self.best):
            self._save(files.BEST_MODEL, files.BEST_VECNORMALIZE)
            self.best = {k: row[k] for k in EVAL_COLUMNS}
            atomic_write_text(self.dir / files.BEST_JSON, json.dumps(self.best) + "\n")

    # --- files --------------------------------------------------------------------------------
    def checkpoint(self) -> None:
        """Model, VecNormalize and replay buffer under names of this step, then latest.json;
        the files of the previous checkpoint go once latest.json names the new ones."""
        steps = self.model.num_timesteps
        self.checkpoints.mkdir(parents=True, exist_ok=True)
        latest: dict[str, Any] = {"steps": steps, "model": f"model_{steps}_steps.zip"}
        self.model.save(self.checkpoints / latest["model"])
        latest["vecnormalize"] = latest["replay_buffer"] = None
        normalizer = self.model.get_vec_normalize_env()
        if normalizer is not None:
            latest["vecnormalize"] = f"vecnormalize_{steps}_steps.pkl"
            normalizer.save(str(self.checkpoints / latest["vecnormalize"]))
        if getattr(self.model, "replay_buffer", None) is not None:
            latest["replay_buffer"] = f"replay_buffer_{steps}_steps.pkl"
            self.model.save_replay_buffer(self.checkpoints / latest["replay_buffer"])
        atomic_write_text(self.checkpoints / "latest.json", json.dumps(latest) + "\n")
        keep = {latest["model"], latest["vecnormalize"], latest["replay_buffer"], "latest.json"}
        for path in self.checkpoints.iterdir():
            if path.name not in keep:
                path.unlink(missing_ok=True)

    def _save(self, model_name: str, stats_name: str) -> None:
        """The model (and its VecNormalize statistics) under a name, replaced atomically."""
        temporary = self.dir / f".{model_name}.tmp.zip"
        self.model.save(temporary)
        os.replace(temporary, self.dir / model_name)
        normalizer = self.model.get_vec_normalize_env()
        if normalizer is not None:
            normalizer.save(str(self.dir / f".{stats_name}.tmp"))
            os.replace(self.dir / f".{stats_name}.tmp", self.dir / stats_name)

    def _write_csv(self, rows: list[dict[str, float]]) -> None:
        lines = [",".join(EVAL_COLUMNS)]
        lines += [",".join(_number(row[k]) for k in EVAL_COLUMNS) for row in rows]
        atomic_write_text(self.dir / files.EVAL_CSV, "\n".join(lines) + "\n")
        self.rows = list(rows)

    def _write_run(self, status: str) -> None:
        job = self.job
        run = {
            "format": RUN_FORMAT,
            "algo": job.algo,
            "env": job.env_id,
            "seed": job.seed,
            "status": status,
            "settings": job.settings(),
            "config": job.hyperparams.source,
            "eval_seed": EVAL_SEED,
            "timesteps": self.start if status == "running" else self.model.num_timesteps,
            "versions": _versions(),
            "command": sys.argv,
        }
        atomic_write_text(self.dir / files.RUN_JSON, json.dumps(run, indent=2) + "\n")

    def close(self) -> None:
        self.bar.close()
        self.eval_env.close()
        self.venv.close()


def _policy_act(model: Any) -> Act:
    """The model's deterministic policy on raw observations (normalised as in training)."""
    normalizer = model.get_vec_normalize_env()

    def act(obs: Any) -> Any:
        seen = normalizer.normalize_obs(obs) if normalizer is not None else obs
        action, _ = model.predict(seen, deterministic=True)
        return action

    return act


def _better(row: dict[str, float], best: dict[str, Any]) -> bool:
    """Higher success rate; at equal success, higher mean reward."""
    if not best:
        return True
    return (row["success_rate"], row["mean_reward"]) > (
        best["success_rate"],
        best["mean_reward"],
    )


def _next_multiple(steps: int, every: int) -> int:
    return (steps // every + 1) * every


def _number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def _versions() -> dict[str, str]:
    found = {"python": platform.python_version()}
    for name in VERSIONS:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found
