"""`clutter-gym train`: stable-baselines3 (PPO, SAC) and sb3-contrib (TQC) agents on any
registered variant, in the conventions of rl-baselines3-zoo.

One run is one (algorithm, env id, seed) in its own directory (`agents.learning.runs` names the
files). The model learns with SB3's own `learn` under SB3's callbacks, subclassed in
`agents.learning.callbacks` for what the directory holds beyond theirs:

* ``run.json``: the settings and hyperparameters actually used, versions, seed, status;
* ``eval.csv`` (timesteps, success_rate, mean_reward, mean_length) and ``tb/`` (TensorBoard),
  from `EvalCallback`: every ``eval_freq`` env steps, and at the end, ``eval_episodes``
  deterministic episodes, the k-th reset with seed ``EVAL_SEED + k``: every evaluation of every
  run sees the same scenes, so curves of different seeds and algorithms compare;
* ``best_model.zip`` (with ``best.json``: best by success rate, then mean reward),
  ``final_model.zip``, VecNormalize statistics beside each when the entry normalises;
* ``checkpoints/``, from `CheckpointCallback`: the latest checkpoint (model, VecNormalize,
  replay buffer of off-policy algorithms), every ``save_freq`` env steps and when interrupted;
  ``latest.json`` is written last, so a crash while saving leaves the previous checkpoint in
  force.

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

import functools
import json
import multiprocessing
import platform
import signal
import sys
import time
from contextlib import ExitStack
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from tqdm import tqdm

from agents.learning import runs as files
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

if TYPE_CHECKING:
    from agents.learning.callbacks import EvalEpisodes
    from agents.learning.demos import Transition

EVAL_SEED = 1_000_000
RUN_FORMAT = "clutter-gym-train/1"
JOBS_LOG = "train_jobs.jsonl"
DRY_BUFFER = 1000
"""Replay buffer size when a config is checked by building its model (not the run's own)."""
BC_STEPS = 1000
"""Gradient steps of behaviour cloning (batches drawn from the demos) before a --demos run
learns."""
CLONE_STEPS = 5
"""Gradient steps of behaviour cloning after each env step of a --demos run's learning, unless
the config's entry sets ``clone_steps``."""
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
    demos: str | None = None  # a `clutter-gym demos` directory pre-filling the replay buffer

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
            "demos": self.demos,
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
    demos: Path | None = None


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
        check_demos(job)
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
                    demos=None if request.demos is None else str(request.demos.resolve()),
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


def check_demos(job: TrainJob) -> None:
    """Demonstrations need an off-policy algorithm (a replay buffer), observations as the env
    gives them (no VecNormalize) and a readable directory recorded in the same scenes."""
    if job.demos is None:
        return
    if "buffer_size" not in allowed_keys(job.algo):
        raise ValueError(f"--demos: {job.algo} has no replay buffer to pre-fill; use sac or tqc")
    if job.hyperparams.normalize:
        raise ValueError("--demos: the entry normalises observations; demos need them raw")
    from agents.learning.demos import load_demos
    from agents.learning.lift_env import LIFT_ENV_ID

    demos, meta = load_demos(Path(job.demos))
    recorded = {k: v for k, v in meta.get("env_kwargs", {}).items() if k != "grasped_start"}
    scenes = {k: v for k, v in job.hyperparams.env_kwargs.items() if k in recorded}
    if scenes != {k: recorded[k] for k in scenes} or set(recorded) - set(scenes):
        raise ValueError(
            f"--demos {job.demos}: recorded in scenes {recorded}; the run's env_kwargs are "
            f"{job.hyperparams.env_kwargs}"
        )
    grasped = sum(d.start != "ready" for d in demos)
    if grasped and job.env_id != LIFT_ENV_ID:
        raise ValueError(
            f"--demos {job.demos}: {grasped} demos start with the goal in the hand, which only "
            f"{LIFT_ENV_ID} does; {job.env_id} replays demos recorded from the ready pose"
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
        steps = _train(job, interrupt)
    if interrupt.seen:
        print(f"{directory}: interrupted at {steps} steps; checkpoint saved", file=sys.stderr)
        if multiprocessing.parent_process() is None:
            raise KeyboardInterrupt
        return _summary(job, "interrupted")
    return _summary(job, "finished")


def _finished(directory: Path) -> bool:
    run = files.read_json_object(directory / files.RUN_JSON)
    return run.get("status") == "finished" and (directory / files.FINAL_MODEL).is_file()


def _summary(job: TrainJob, status: str) -> Record:
    """The run's record: status, steps done, last and best success rates (from its files)."""
    directory = Path(job.out)
    rows = files.read_eval_csv(directory / files.EVAL_CSV)
    checkpoint = files.latest_checkpoint(directory)
    best = files.read_json_object(directory / files.BEST_JSON)
    return {
        **job.identity(),
        "status": status,
        "timesteps": checkpoint["steps"] if checkpoint else 0,
        "final_success_rate": rows[-1]["success_rate"] if rows else None,
        "best_success_rate": best.get("success_rate"),
    }


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


def _train(job: TrainJob, interrupt: FirstInterrupt) -> int:
    """Train from the run's checkpoint in force (or from scratch) to ``job.steps`` under SB3's
    callbacks (`agents.learning.callbacks`); then, unless interrupted, a last evaluation if the
    last step has none, and the final model. A checkpoint either way; the steps trained."""
    from agents.learning import callbacks  # stable-baselines3, which train_run has required

    directory = Path(job.out)
    checkpoint = files.latest_checkpoint(directory)
    start = int(checkpoint["steps"]) if checkpoint else 0
    with ExitStack() as stack:
        venv = _vec_env(job, job.seed + start)
        stack.callback(venv.close)  # no worker processes left behind, whatever happens
        model = _fresh(job, venv) if checkpoint is None else _resumed(job, venv, checkpoint)
        extra = []
        if job.demos is not None:
            demos = _demo_steps(job)
            cloning = callbacks.DemoCloning(model, demos, job.seed + start)
            if checkpoint is None:
                _prefill(model, demos)
                error = cloning(BC_STEPS)
                print(
                    f"{directory}: {len(demos)} demonstration steps in the replay buffer; the "
                    f"actor cloned them (action error {error:.3f})",
                    file=sys.stderr,
                )
            keep = job.hyperparams.clone_steps or CLONE_STEPS
            extra.append(callbacks.KeepCloning(cloning, keep))
        eval_env, episodes = _eval_env(job)  # after the model: its seeding comes first
        stack.callback(eval_env.close)
        bar = stack.enter_context(
            tqdm(total=job.steps, initial=start, unit="step", desc=f"{job.algo} seed {job.seed}")
        )
        evaluation = callbacks.RunEvaluation(
            eval_env, episodes, directory, job.eval_episodes, job.eval_freq, bar
        )
        saving = callbacks.RunCheckpoint(directory / files.CHECKPOINTS, job.save_freq)
        model.learn(
            total_timesteps=job.steps - start,
            callback=[
                callbacks.Progress(bar),
                evaluation,
                saving,
                callbacks.StopOnInterrupt(interrupt),
                *extra,
            ],
            reset_num_timesteps=start == 0,
            tb_log_name=job.algo.upper(),
        )
        steps = int(model.num_timesteps)
        if interrupt.seen:
            saving.save()
            _write_run(job, "interrupted", steps)
            return steps
        if not evaluation.rows or evaluation.rows[-1]["timesteps"] != steps:
            evaluation.evaluate()
        saving.save()
        callbacks.save_model(model, directory, files.FINAL_MODEL, files.FINAL_VECNORMALIZE)
        _write_run(job, "finished", steps)
        return steps


def _vec_env(job: TrainJob, seed: int) -> Any:
    """The training envs: in spawned worker processes when there are several."""
    tools = vec_env_tools()
    many = job.n_envs > 1
    return tools.make_vec_env(
        functools.partial(worker_env, job.env_id, many),
        n_envs=job.n_envs,
        seed=seed,
        env_kwargs=job.hyperparams.env_kwargs,
        vec_env_cls=tools.SubprocVecEnv if many else tools.DummyVecEnv,
        vec_env_kwargs={"start_method": "spawn"} if many else None,
    )


def _fresh(job: TrainJob, venv: Any) -> Any:
    """A new model on ``venv`` (normalised if the entry says so); files of an earlier start
    in the directory that never reached a checkpoint are removed."""
    hp = job.hyperparams
    directory = Path(job.out)
    directory.mkdir(parents=True, exist_ok=True)
    venv = _normalized(venv, hp.normalize)
    model = algorithm_class(job.algo)(
        policy_for(hp, venv.observation_space),
        venv,
        seed=job.seed,
        device="cpu",
        verbose=0,
        tensorboard_log=str(directory / files.TENSORBOARD),
        **algorithm_kwargs(hp),
    )
    for stale in (files.EVAL_CSV, files.BEST_JSON, files.BEST_MODEL, files.BEST_VECNORMALIZE):
        (directory / stale).unlink(missing_ok=True)

    _write_run(job, "running", 0)
    print(f"{directory}: training {job.key} on {job.env_id}", file=sys.stderr)
    return model


def _demo_steps(job: TrainJob) -> list[Transition]:
    """The successful demos replayed in the run's env (reset with their seeds and starts),
    every step."""
    from agents.learning.demos import load_demos, replay

    demos, _ = load_demos(Path(job.demos or ""))
    env = gym.make(job.env_id, **job.hyperparams.env_kwargs)
    try:
        return [step for d in demos if d.success for step in replay(env, d)[1]]
    finally:
        env.close()


def _prefill(model: Any, steps: list[Transition]) -> None:
    """Add demo steps to the model's replay buffer as SB3's own rollouts add them (a batch of
    one env; for HER, each demo is one whole episode)."""

    def batch(obs: Any) -> Any:
        if isinstance(obs, dict):
            return {key: np.asarray(value)[None] for key, value in obs.items()}
        return np.asarray(obs)[None]

    for obs, action, reward, next_obs, terminated, truncated, info in steps:
        model.replay_buffer.add(
            batch(obs),
            batch(next_obs),
            model.policy.scale_action(np.asarray(action))[None],
            np.array([reward], dtype=np.float32),
            np.array([terminated or truncated]),
            [{**info, "TimeLimit.truncated": truncated and not terminated}],
        )


def _resumed(job: TrainJob, venv: Any, checkpoint: dict[str, Any]) -> Any:
    """The checkpoint's model (with its VecNormalize statistics and replay buffer) on
    ``venv``, reseeded for the steps done; the eval rows after the checkpoint are dropped (they
    are measured again)."""
    directory = Path(job.out)
    checkpoints = directory / files.CHECKPOINTS
    start = int(checkpoint["steps"])
    if checkpoint.get("vecnormalize"):
        stats = checkpoints / checkpoint["vecnormalize"]
        venv = vec_env_tools().VecNormalize.load(str(stats), venv)
    model = algorithm_class(job.algo).load(
        checkpoints / checkpoint["model"],
        env=venv,
        device="cpu",
        tensorboard_log=str(directory / files.TENSORBOARD),
    )
    model.set_random_seed(job.seed + start)
    if checkpoint.get("replay_buffer"):
        model.load_replay_buffer(checkpoints / checkpoint["replay_buffer"])
    rows = files.read_eval_csv(directory / files.EVAL_CSV)
    files.write_eval_csv(directory / files.EVAL_CSV, [r for r in rows if r["timesteps"] <= start])
    print(f"{directory}: resuming {job.key} from step {start}", file=sys.stderr)
    return model


def _eval_env(job: TrainJob) -> tuple[Any, EvalEpisodes]:
    """The evaluation env (one, in this process) as SB3's EvalCallback takes it: a vector env,
    under VecNormalize when training normalises (its statistics are synced from training
    before each evaluation; rewards stay raw), and the `EvalEpisodes` inside it."""
    from agents.learning.callbacks import EvalEpisodes

    hp = job.hyperparams
    episodes = EvalEpisodes(files.make_env(job.env_id, **hp.env_kwargs), EVAL_SEED)
    venv = vec_env_tools().DummyVecEnv([lambda: episodes])
    if hp.normalize is not None:
        venv = _normalized(venv, {**hp.normalize, "training": False, "norm_reward": False})
    return venv, episodes


def _write_run(job: TrainJob, status: str, timesteps: int) -> None:
    run = {
        "format": RUN_FORMAT,
        "algo": job.algo,
        "env": job.env_id,
        "seed": job.seed,
        "status": status,
        "settings": job.settings(),
        "config": job.hyperparams.source,
        "eval_seed": EVAL_SEED,
        "timesteps": timesteps,
        "versions": _versions(),
        "command": sys.argv,
    }
    atomic_write_text(Path(job.out) / files.RUN_JSON, json.dumps(run, indent=2) + "\n")


def _versions() -> dict[str, str]:
    found = {"python": platform.python_version()}
    for name in VERSIONS:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found
