"""`clutter-gym train` and `clutter-gym plot-training`.

Bad input is one line, exit status 2, before any training; the configs of the results are the
algorithm's defaults with overrides; a tiny PPO run leaves its evaluation CSV (rows measured as
`clutter-gym evaluate` measures), TensorBoard log, checkpoint, best and final models and run.json;
Ctrl-C saves a checkpoint and the same command resumes from it (an off-policy run with its replay
buffer), and so does a run killed by SIGKILL from its last periodic checkpoint; a finished run
does nothing; a grid on Ray gives the local grid's numbers; the training plot is a PNG.

Runs are tiny (a few hundred env steps of 20-step episodes) and their numbers mean nothing
about learning: the dense variant is used because its returns are real numbers, so that equal
CSVs say that two runs really computed the same thing."""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import yaml

from agents.figures.training_curves import Curve, band
from agents.learning.episodes import run_episode
from agents.learning.rl_config import ALGOS, HYPERPARAMS, load_hyperparams
from agents.learning.runs import EVAL_COLUMNS, TrainedRun, make_env, read_eval_csv, read_run
from agents.learning.train import EVAL_SEED
from clutter_gym import ENV_IDS
from tests.helpers import (
    TAB_BLUE,
    TINY_PPO,
    TINY_SAC,
    TRAIN_ENV,
    TRAIN_SCENES,
    WHITE,
    assert_picture,
    train_argv,
    write_config,
)
from tests.helpers import run_cli as run

ROOT = Path(__file__).resolve().parents[1]


def train_tiny(out: Path, config: Path, capsys: pytest.CaptureFixture[str], **flags: str) -> str:
    """Train the tiny PPO entry into ``out``; stdout (one JSON line per run)."""
    code, stdout, err = run(train_argv(config, out, **flags), capsys)
    assert code == 0, err
    return stdout


# --- bad input ---------------------------------------------------------------------------------

BAD_FLAGS: list[tuple[str, dict[str, str | None], tuple[str, ...]]] = [
    ("unknown algo", {"algo": "dqn"}, ("--algo", "'dqn'", "ppo, sac, tqc")),
    ("one algo unknown", {"algo": "ppo,a2c"}, ("--algo", "'a2c'", "ppo, sac, tqc")),
    ("unknown env", {"env": "Nope-v0"}, ("--env", "Nope-v0", "ClutterRetrieveEE-v0")),
    ("seed and seeds", {"seed": "1", "seeds": "0,1"}, ("--seeds", "not allowed with")),
    ("bad seeds", {"seeds": "0,x"}, ("--seeds", "'x'", "integer >= 0")),
    ("steps 0", {"steps": "0"}, ("--steps", "integer >= 1")),
    ("n-envs 0", {"n_envs": "0"}, ("--n-envs", "integer >= 1")),
    ("backend", {"backend": "dask"}, ("--backend", "dask", "local", "ray")),
    ("config missing", {"config": "/nonexistent/ppo.yml"}, ("--config", "no such file")),
    ("out under a file", {"out": "{file}/run"}, ("--out", "is a file")),
    ("no steps anywhere", {"steps": None}, ("--steps", "not given", "n_timesteps")),
]

BAD_ENTRIES: list[tuple[str, dict[str, Any], tuple[str, ...]]] = [
    (
        "unknown key",
        {**TINY_PPO, "learning_rat": 0.1},
        ("unknown key 'learning_rat'", "learning_rate"),
    ),
    ("unknown zoo-style key", {**TINY_PPO, "frame_stack": 4}, ("'frame_stack'", "n_timesteps")),
    ("normalize key", {**TINY_PPO, "normalize": {"norm_obz": True}}, ("norm_obz", "norm_obs")),
    ("schedule", {**TINY_PPO, "learning_rate": "exp_0.1"}, ("learning_rate", "lin_<number > 0>")),
    ("activation", {**TINY_PPO, "policy_kwargs": {"activation_fn": "swish"}}, ("swish", "tanh")),
    ("bad value", {**TINY_PPO, "batch_size": "big"}, ("ppo cannot use this entry",)),
    ("env keyword", {**TINY_PPO, "env_kwargs": {"level": "extreme"}}, ("env_kwargs", "extreme")),
    ("budget", {**TINY_PPO, "n_timesteps": -5}, ("n_timesteps", "must be >= 1")),
    ("cloning", {**TINY_PPO, "clone_steps": 0}, ("clone_steps", "must be >= 1")),
    ("base missing", {**TINY_PPO, "base": "nope.yml"}, ("base ", "nope.yml", "cannot be read")),
    ("base is itself", {**TINY_PPO, "base": "tiny.yml"}, ("base: tiny.yml is this entry",)),
    ("base's key", {**TINY_PPO, "base": "bad.yml"}, ("bad.yml", "unknown key 'n_step'")),
]


@pytest.mark.parametrize(
    ("flags", "texts"), [c[1:] for c in BAD_FLAGS], ids=[c[0] for c in BAD_FLAGS]
)
def test_bad_flags_are_one_line_before_any_work(
    flags: dict[str, str | None],
    texts: tuple[str, ...],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    (tmp_path / "file").write_text("a regular file")
    config = write_config(tmp_path / "tiny.yml")
    flags = {k: v.replace("{file}", str(tmp_path / "file")) if v else v for k, v in flags.items()}
    code, out, err = run(train_argv(config, tmp_path / "run", **flags), capsys)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for text in texts:
        assert text in err, err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("entry", "texts"), [c[1:] for c in BAD_ENTRIES], ids=[c[0] for c in BAD_ENTRIES]
)
def test_bad_config_entries_are_one_line_before_any_work(
    entry: dict[str, Any],
    texts: tuple[str, ...],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    write_config(tmp_path / "bad.yml", {"n_step": 64})
    config = write_config(tmp_path / "tiny.yml", entry)
    code, _, err = run(train_argv(config, tmp_path / "run"), capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"--config {config}" in err and TRAIN_ENV in err
    for text in texts:
        assert text in err, err
    assert not (tmp_path / "run").exists()


def test_an_env_without_an_entry_names_the_ones_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = write_config(tmp_path / "tiny.yml", env="ClutterRetrieve-v0")
    code, _, err = run(train_argv(config, tmp_path / "run"), capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"has no entry for {TRAIN_ENV}; it has: ClutterRetrieve-v0" in err
    (tmp_path / "bad.yml").write_text("a: [1, 2\n")
    code, _, err = run(train_argv(tmp_path / "bad.yml", tmp_path / "run"), capsys)
    assert code == 2 and "not valid YAML" in err and len(err.strip().splitlines()) == 1


def test_shipped_hyperparameters_name_registered_ids_and_known_keys() -> None:
    for algo in ALGOS:
        entries = yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text())
        assert set(entries) <= set(ENV_IDS), algo
        for env_id in entries:
            hp = load_hyperparams(algo, env_id)  # raises on an unknown key
            assert hp.n_timesteps and hp.policy in ("MultiInputPolicy", "MlpPolicy")
            her = hp.algo_kwargs.get("replay_buffer_class") == "HerReplayBuffer"
            if her:
                assert hp.algo_kwargs["replay_buffer_kwargs"]["copy_info_dict"] is True
            assert her == (algo != "ppo" and env_id.startswith("ClutterRetrieveEE")), env_id
            if "gamma" in hp.env_kwargs:  # the dense reward shapes with the agent's discount
                assert hp.env_kwargs["gamma"] == hp.algo_kwargs["gamma"]


# The result configs written out in full: each override must load as its full entry.
RESULT_COPIES = {
    "ppo_primitive_medium.yml": """
ClutterRetrievePrimitive-v0:
  policy: MlpPolicy
  n_timesteps: 10000
  n_envs: 2
  env_kwargs: {level: medium, noise: sigma2}
  n_steps: 128
  batch_size: 64
  n_epochs: 10
  learning_rate: 0.0003
  gamma: 0.95
  gae_lambda: 0.95
  ent_coef: 0.01
  policy_kwargs: {net_arch: [128, 128]}
""",
    "ppo_primitive_none.yml": """
ClutterRetrievePrimitive-v0:
  policy: MlpPolicy
  n_timesteps: 10000
  n_envs: 2
  env_kwargs: {level: none, noise: sigma2}
  n_steps: 128
  batch_size: 64
  n_epochs: 10
  learning_rate: 0.0003
  gamma: 0.95
  gae_lambda: 0.95
  ent_coef: 0.01
  policy_kwargs: {net_arch: [128, 128]}
""",
    "sac_lone_can.yml": """
ClutterRetrieveEE-v0:
  policy: MultiInputPolicy
  n_timesteps: 300000
  n_envs: 1
  env_kwargs: {level: none, goal_kind: soda_can, noise: sigma1}
  buffer_size: 300000
  learning_starts: 1000
  batch_size: 256
  learning_rate: 0.001
  gamma: 0.95
  tau: 0.05
  replay_buffer_class: HerReplayBuffer
  replay_buffer_kwargs: {goal_selection_strategy: future, n_sampled_goal: 4, copy_info_dict: true}
  policy_kwargs: {net_arch: [256, 256], n_critics: 2}
""",
    "sac_grasp_clone10.yml": """
ClutterRetrieveEEGrasp-v0:
  policy: MultiInputPolicy
  n_timesteps: 50000
  n_envs: 1
  env_kwargs: {level: none, goal_kind: soda_can, noise: sigma1}
  clone_steps: 10
  buffer_size: 50000
  learning_starts: 1000
  batch_size: 256
  learning_rate: 0.001
  gamma: 0.95
  tau: 0.05
  replay_buffer_class: HerReplayBuffer
  replay_buffer_kwargs: {goal_selection_strategy: future, n_sampled_goal: 4, copy_info_dict: true}
  policy_kwargs: {net_arch: [256, 256]}
""",
}


@pytest.mark.parametrize("name", sorted(RESULT_COPIES))
def test_result_configs_override_only_what_differs_and_load_as_their_full_copies(
    name: str, tmp_path: Path
) -> None:
    algo = name.split("_")[0]
    path = HYPERPARAMS / name
    ((env_id, entry),) = yaml.safe_load(path.read_text()).items()
    base = yaml.safe_load((HYPERPARAMS / entry["base"]).read_text())[env_id]
    for key, value in entry.items():
        if key != "base":
            assert value != base.get(key), f"{name}: {key} repeats its base"
    copy = tmp_path / name
    copy.write_text(RESULT_COPIES[name])
    loaded, expected = load_hyperparams(algo, env_id, path), load_hyperparams(algo, env_id, copy)
    assert {**loaded.as_dict(), "source": None} == {**expected.as_dict(), "source": None}


def test_an_override_merges_mappings_and_replaces_other_values(tmp_path: Path) -> None:
    """A config anywhere may build on a shipped file (a path relative to itself, or absolute)."""
    entry = {"base": str(HYPERPARAMS / "ppo.yml"), "env_kwargs": {"level": "none"}, "n_steps": 32}
    config = write_config(tmp_path / "mine.yml", entry)
    shipped = load_hyperparams("ppo", TRAIN_ENV)
    hp = load_hyperparams("ppo", TRAIN_ENV, config)
    assert hp.env_kwargs == {**shipped.env_kwargs, "level": "none"}
    assert hp.algo_kwargs == {**shipped.algo_kwargs, "n_steps": 32}
    assert (hp.policy, hp.normalize, hp.n_timesteps) == (
        shipped.policy,
        shipped.normalize,
        shipped.n_timesteps,
    )


@pytest.mark.parametrize("algo", ALGOS)
def test_shipped_goal_env_entries_build_their_model(algo: str) -> None:
    """Each algorithm's entry for the sparse end-effector variant (HER for SAC and TQC) builds
    its model on the env (what train checks before it starts)."""
    from agents.learning.train import GridRequest, TrainJob, check_build, plan_runs

    hp = load_hyperparams(algo, "ClutterRetrieveEE-v0")
    request = GridRequest((algo,), hp.env_id, None, 1000, 1, (0,), False, Path("x"), None, 1, None)
    (job,) = plan_runs(request, {algo: hp})
    assert isinstance(job, TrainJob)
    check_build(job)


def test_an_algorithm_that_cannot_act_in_the_action_space_is_one_line(tmp_path: Path) -> None:
    """SAC needs a Box action space (CartPole's is Discrete, as the primitive variant's is
    MultiDiscrete): refused by the check that builds the model, before any run."""
    from agents.learning.train import GridRequest, check_build, plan_runs

    config = write_config(tmp_path / "c.yml", {"learning_starts": 1}, env="CartPole-v1")
    hp = load_hyperparams("sac", "CartPole-v1", config)
    request = GridRequest(("sac",), "CartPole-v1", config, 10, 1, (0,), False, tmp_path, 5, 1, 5)
    (job,) = plan_runs(request, {"sac": hp})
    with pytest.raises(ValueError, match=r"CartPole-v1: sac cannot use this entry: .*Discrete"):
        check_build(job)


# --- one run -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "env_id",
    [pytest.param("ClutterRetrieve-v0", marks=pytest.mark.slow), "ClutterRetrievePrimitive-v0"],
)
def test_any_registered_variant_trains_whatever_its_spaces(
    env_id: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Dict observation and (K, 9) Box actions; Box observation and MultiDiscrete actions (the
    policy follows the observation when the entry names none)."""
    entry = {
        "n_steps": 8,
        "batch_size": 8,
        "n_epochs": 1,
        "policy_kwargs": {"net_arch": [16]},
        "env_kwargs": {"level": "none", "goal_kind": "soda_can"},
    }
    config = write_config(tmp_path / "c.yml", entry, env=env_id)
    flags = {"env": env_id, "steps": "8", "eval_freq": "8", "eval_episodes": "1"}
    (record,) = map(json.loads, train_tiny(tmp_path / "run", config, capsys, **flags).splitlines())
    assert record["status"] == "finished" and record["timesteps"] == 8
    assert [r["timesteps"] for r in read_eval_csv(tmp_path / "run" / "eval.csv")] == [8]


def test_a_tiny_ppo_run_leaves_its_logs_models_and_run_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    config = write_config(tmp_path / "tiny.yml")
    (record,) = map(json.loads, train_tiny(out, config, capsys).splitlines())
    assert record["status"] == "finished" and record["timesteps"] == 256 and record["seed"] == 0
    rows = read_eval_csv(out / "eval.csv")
    assert (out / "eval.csv").read_text().splitlines()[0] == ",".join(EVAL_COLUMNS)
    assert [r["timesteps"] for r in rows] == [128, 256]
    assert all(r["mean_length"] == 20 and 0 <= r["success_rate"] <= 1 for r in rows)
    for name in ("best_model.zip", "best_vecnormalize.pkl", "final_model.zip", "vecnormalize.pkl"):
        assert (out / name).is_file(), name
    latest = json.loads((out / "checkpoints" / "latest.json").read_text())
    assert latest["steps"] == 256 and latest["replay_buffer"] is None
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == sorted(
        ["latest.json", latest["model"], latest["vecnormalize"]]
    )  # only the checkpoint in force is kept
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    meta = json.loads((out / "run.json").read_text())
    assert meta["status"] == "finished" and meta["seed"] == 0 and meta["timesteps"] == 256
    assert meta["settings"]["hyperparams"]["n_steps"] == 64 and meta["config"] == str(config)
    assert meta["versions"]["stable-baselines3"] != "not installed"
    best = json.loads((out / "best.json").read_text())
    assert best["success_rate"] == max(r["success_rate"] for r in rows)
    best_run = read_run(out)
    assert best_run == TrainedRun(
        out, "ppo", TRAIN_ENV, TRAIN_SCENES, out / "best_model.zip", out / "best_vecnormalize.pkl"
    )
    # The best row is what `run_episode` (the measure of `clutter-gym evaluate`) gives of the best
    # model on the evaluation scenes: episode k reset with seed EVAL_SEED + k.
    env = make_env(TRAIN_ENV, **TRAIN_SCENES)
    act = best_run.make_act(env)
    episodes = [run_episode(env, lambda _env, _info: act, EVAL_SEED + k) for k in range(2)]
    env.close()
    assert {k: best[k] for k in EVAL_COLUMNS[1:]} == {
        "success_rate": sum(e.success for e in episodes) / 2,
        "mean_reward": round(sum(e.ret for e in episodes) / 2, 6),
        "mean_length": sum(e.length for e in episodes) / 2,
    }

    # The same command again: finished, nothing done. Other settings: refused, in one line.
    stamp = (out / "final_model.zip").stat().st_mtime_ns
    code, again, err = run(train_argv(config, out), capsys)
    assert code == 0 and "already finished; nothing to do" in err
    assert json.loads(again)["status"] == "finished"
    assert (out / "final_model.zip").stat().st_mtime_ns == stamp
    code, _, err = run(train_argv(config, out, steps="512"), capsys)
    assert code == 2 and "holds a run with other settings (differs in steps)" in err
    assert len(err.strip().splitlines()) == 1


def _clutter_gym(argv: list[str]) -> subprocess.Popen[str]:
    """The command in its own process group, as a terminal runs it (Ctrl-C reaches the group)."""
    script = Path(sys.executable).with_name("clutter-gym")
    return subprocess.Popen(
        [str(script), *argv],
        text=True,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )


def _interrupt_after_first_checkpoint(argv: list[str], *runs: Path) -> tuple[int, str]:
    """Ctrl-C once every run has a checkpoint; (exit status, stderr)."""
    process = _clutter_gym(argv)
    latest = [run / "checkpoints" / "latest.json" for run in runs]
    deadline = time.monotonic() + 180
    while not all(p.exists() for p in latest) and process.poll() is None:
        assert time.monotonic() < deadline, "no checkpoint in time"
        time.sleep(0.05)
    assert process.poll() is None, "the run ended before it could be interrupted"
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: to the trainer and its env workers
    _, err = process.communicate(timeout=120)
    return process.returncode, err


def _resume_and_check(argv: list[str], out: Path, steps: int) -> dict[str, Any]:
    """Interrupt after the first checkpoint, then the same command: it resumes from the
    interrupt's checkpoint, keeps the rows before it and finishes; the final latest.json."""
    code, err = _interrupt_after_first_checkpoint(argv, out)
    assert code == 130 and "checkpoint saved" in err, err[-2000:]
    stopped = json.loads((out / "checkpoints" / "latest.json").read_text())["steps"]
    assert 0 < stopped < steps
    interrupted = json.loads((out / "run.json").read_text())
    assert interrupted["status"] == "interrupted" and interrupted["timesteps"] == stopped
    before = read_eval_csv(out / "eval.csv")
    assert before and all(r["timesteps"] <= stopped for r in before)

    process = _clutter_gym(argv)
    stdout, err = process.communicate(timeout=300)
    assert process.returncode == 0, err[-2000:]
    assert f"resuming {json.loads(stdout)['algo']}_seed0 from step {stopped}" in err
    latest = json.loads((out / "checkpoints" / "latest.json").read_text())
    assert latest["steps"] >= steps
    after = read_eval_csv(out / "eval.csv")
    assert after[: len(before)] == before
    assert [r["timesteps"] for r in after] == sorted({r["timesteps"] for r in after})
    assert after[-1]["timesteps"] == latest["steps"]
    return latest


def test_ctrl_c_saves_a_checkpoint_and_the_same_command_resumes(tmp_path: Path) -> None:
    out = tmp_path / "run"
    config = write_config(tmp_path / "tiny.yml")
    argv = train_argv(config, out, steps="1024", eval_freq="256", eval_episodes="1")
    _resume_and_check(argv, out, 1024)
    assert json.loads((out / "run.json").read_text())["status"] == "finished"


def test_a_killed_run_resumes_from_its_last_checkpoint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """SIGKILL after the first periodic checkpoint, then the same command: it resumes from that
    checkpoint and finishes. Its rows up to the checkpoint are an uninterrupted run's; the rows
    after it are not (the resumed session starts new episodes, reseeded with seed + steps), but
    two resumes of the same checkpoint give the same rows."""
    out = tmp_path / "run"
    config = write_config(tmp_path / "tiny.yml")
    flags = {"steps": "1024", "eval_freq": "256", "eval_episodes": "1"}
    argv = train_argv(config, out, **flags)
    process = _clutter_gym(argv)
    latest = out / "checkpoints" / "latest.json"
    deadline = time.monotonic() + 180
    while not latest.exists() and process.poll() is None:
        assert time.monotonic() < deadline, "no checkpoint in time"
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGKILL)
    process.communicate(timeout=60)
    stopped = json.loads(latest.read_text())["steps"]
    assert json.loads((out / "run.json").read_text())["status"] == "running" and stopped < 1024
    shutil.copytree(out, tmp_path / "again")

    resumed = []
    for directory in (out, tmp_path / "again"):
        process = _clutter_gym(train_argv(config, directory, **flags))
        _, err = process.communicate(timeout=300)
        assert process.returncode == 0 and f"resuming ppo_seed0 from step {stopped}" in err, err
        resumed.append(read_eval_csv(directory / "eval.csv"))
    assert resumed[0] == resumed[1]
    assert [r["timesteps"] for r in resumed[0]] == [256, 512, 768, 1024]

    train_tiny(tmp_path / "whole", config, capsys, **flags)
    whole = read_eval_csv(tmp_path / "whole" / "eval.csv")
    kept = [r for r in whole if r["timesteps"] <= stopped]
    assert kept and resumed[0][: len(kept)] == kept


@pytest.mark.slow
def test_ctrl_c_stops_every_run_of_a_parallel_grid_and_the_same_command_resumes_them(
    tmp_path: Path,
) -> None:
    """Two runs in the job runner's worker processes: each saves a checkpoint and stops. Each
    run is 16 checkpoints long, so that one run cannot finish while the other, its worker
    started late on a loaded machine, has yet to write its first (768 steps once did)."""
    out = tmp_path / "grid"
    config = write_config(tmp_path / "tiny.yml")
    argv = train_argv(
        config, out, seeds="0,1", workers="2", steps="4096", eval_freq="256", eval_episodes="1"
    )
    runs = [out / f"ppo_seed{seed}" for seed in (0, 1)]
    code, err = _interrupt_after_first_checkpoint(argv, *runs)
    assert code == 130, err[-2000:]
    stopped = [json.loads((r / "checkpoints" / "latest.json").read_text())["steps"] for r in runs]
    assert all(0 < steps < 4096 for steps in stopped), stopped
    process = _clutter_gym(argv)
    stdout, err = process.communicate(timeout=300)
    assert process.returncode == 0, err[-2000:]
    assert [json.loads(line)["status"] for line in stdout.splitlines()] == ["finished"] * 2
    for seed, steps in enumerate(stopped):
        assert f"resuming ppo_seed{seed} from step {steps}" in err


@pytest.mark.slow
def test_off_policy_resume_keeps_the_replay_buffer(tmp_path: Path) -> None:
    """SAC with HER: the resumed run goes on with the interrupted run's transitions."""
    out = tmp_path / "run"
    config = write_config(tmp_path / "sac.yml", TINY_SAC)
    argv = train_argv(config, out, algo="sac", steps="600", eval_freq="200", eval_episodes="1")
    latest = _resume_and_check(argv, out, 600)
    with (out / "checkpoints" / latest["replay_buffer"]).open("rb") as handle:
        buffer = pickle.load(handle)
    assert buffer.size() >= 590  # the run's transitions, before and after the interrupt


@pytest.mark.slow
def test_ctrl_c_with_worker_processes(tmp_path: Path) -> None:
    """Two envs in spawned workers: they ignore the Ctrl-C, the trainer saves and resumes."""
    out = tmp_path / "run"
    config = write_config(tmp_path / "tiny.yml")
    argv = train_argv(config, out, steps="768", eval_freq="256", eval_episodes="1", n_envs="2")
    _resume_and_check(argv, out, 768)


@pytest.mark.parametrize(
    ("n_envs", "every", "start"), [(1, 128, 0), (2, 128, 0), (2, 129, 0), (3, 100, 171), (4, 3, 8)]
)
def test_evaluations_and_checkpoints_follow_env_steps_across_resumes(
    n_envs: int, every: int, start: int
) -> None:
    """Each falls on the first call at or after each multiple of its frequency in env steps,
    whatever the number of envs and wherever the run resumed (SB3 counts calls from 0)."""
    from agents.learning.callbacks import crossed

    calls = range(start + n_envs, 1000, n_envs)  # the step count after each call
    due = [steps for steps in calls if crossed(steps, n_envs, every)]
    multiples = range((start // every + 1) * every, calls[-1] + 1, every)
    assert due == sorted({next(s for s in calls if s >= m) for m in multiples})


# --- grids ---------------------------------------------------------------------------------------


def _final_parameters(run: Path) -> dict[str, np.ndarray]:
    from stable_baselines3 import PPO

    model = PPO.load(run / "final_model.zip", device="cpu")
    return {k: v.numpy() for k, v in model.policy.state_dict().items()}


@pytest.mark.slow
def test_a_ray_grid_gives_the_local_grids_numbers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = write_config(tmp_path / "tiny.yml", {**TINY_PPO, "normalize": False})
    local, ray = tmp_path / "local", tmp_path / "ray"
    train_tiny(local, config, capsys, seeds="0,1")
    train_tiny(ray, config, capsys, seeds="0,1", backend="ray", workers="2")
    for seed in (0, 1):
        a, b = local / f"ppo_seed{seed}", ray / f"ppo_seed{seed}"
        assert (a / "eval.csv").read_text() == (b / "eval.csv").read_text()
        first, second = _final_parameters(a), _final_parameters(b)
        assert all(np.array_equal(first[k], second[k]) for k in first)
    # Not equal by accident: the seeds' runs differ.
    assert read_eval_csv(local / "ppo_seed0" / "eval.csv") != read_eval_csv(
        local / "ppo_seed1" / "eval.csv"
    )


def test_a_local_grid_puts_each_algorithm_and_seed_in_its_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "both.yml"
    config.write_text(yaml.safe_dump({TRAIN_ENV: {**TINY_PPO, "normalize": False}}))
    out = tmp_path / "grid"
    stdout = train_tiny(out, config, capsys, seeds="0,1", steps="128", eval_freq="128")
    records = [json.loads(line) for line in stdout.splitlines()]
    assert [(r["algo"], r["seed"], r["status"]) for r in records] == [
        ("ppo", 0, "finished"),
        ("ppo", 1, "finished"),
    ]
    for seed in (0, 1):
        run_json = json.loads((out / f"ppo_seed{seed}" / "run.json").read_text())
        assert run_json["seed"] == seed and run_json["algo"] == "ppo"
    assert (out / "train_jobs.jsonl").is_file()


# --- plot-training -------------------------------------------------------------------------------


def _fake_run(directory: Path, algo: str, seed: int, rows: list[tuple[int, float]]) -> Path:
    """A run's eval.csv and run.json, as plot-training reads them."""
    directory.mkdir(parents=True)
    lines = [",".join(EVAL_COLUMNS), *(f"{t},{s},0,20" for t, s in rows)]
    (directory / "eval.csv").write_text("\n".join(lines) + "\n")
    (directory / "run.json").write_text(json.dumps({"algo": algo, "env": TRAIN_ENV, "seed": seed}))
    return directory


def test_band_is_mean_min_and_max_over_seeds_on_common_steps() -> None:
    def curve(steps: list[int], success: list[float]) -> Curve:
        return Curve(Path("x"), "ppo", TRAIN_ENV, 0, np.array(steps), np.array(success))

    steps, mean, low, high = band([curve([0, 100, 200], [0, 0.5, 1]), curve([0, 200], [0, 0.5])])
    assert steps.tolist() == [0, 100, 200]
    assert mean.tolist() == [0, 0.375, 0.75]
    assert low.tolist() == [0, 0.25, 0.5] and high.tolist() == [0, 0.5, 1]


def test_plot_training_writes_a_png_grouped_by_algorithm_and_env(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grid = tmp_path / "grid"
    for seed in (0, 1, 2):
        _fake_run(grid / f"ppo_seed{seed}", "ppo", seed, [(0, 0), (100, 0.1 * seed), (200, 0.5)])
    other = _fake_run(tmp_path / "sac", "sac", 0, [(100, 0.2), (200, 0.9)])
    png = tmp_path / "fig" / "curves.png"
    code, out, err = run(["plot-training", str(grid), str(other), "--out", str(png)], capsys)
    assert code == 0, err
    assert out.strip() == f"wrote {png} (4 runs)"
    assert_picture(png, min_width=400, colours=(WHITE, TAB_BLUE))


@pytest.mark.parametrize(
    ("setup", "texts"),
    [
        ("empty", ("no eval.csv",)),
        ("bad csv", ("not an eval.csv",)),
        ("missing", ("no such directory",)),
    ],
)
def test_plot_training_bad_input_is_one_line(
    setup: str, texts: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "run"
    if setup != "missing":
        run_dir.mkdir()
    if setup == "bad csv":
        (run_dir / "eval.csv").write_text("step,reward\n1,2\n")
    code, _, err = run(["plot-training", str(run_dir), "--out", str(tmp_path / "f.png")], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    for text in texts:
        assert text in err
    assert not (tmp_path / "f.png").exists()


# --- demonstrations ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def lone_can_demos(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    """Two demos of the pushing planner in the training variant; the steps a run replays
    of them (its time limit cuts them at 20)."""
    from agents.learning.demos import record_demos, save_demos

    kwargs = {"level": "none", "goal_kind": "soda_can"}
    demos = record_demos(TRAIN_ENV, kwargs, "pushing", 2, 0, 20.0)
    directory = tmp_path_factory.mktemp("demos")
    save_demos(directory, demos, {"env": TRAIN_ENV, "env_kwargs": kwargs})
    return directory, sum(min(len(d.actions), 20) for d in demos if d.success)


def test_demos_pre_fill_the_replay_buffer_of_an_off_policy_run(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    lone_can_demos: tuple[Path, int],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The demos fill the replay buffer, and the actor keeps cloning them by the entry's
    ``clone_steps`` gradient steps per env step."""
    from agents.learning import callbacks

    kept: list[int] = []
    keep = callbacks.KeepCloning.__init__

    def recorded(self: Any, clone: Any, steps: int) -> None:
        kept.append(steps)
        keep(self, clone, steps)

    monkeypatch.setattr(callbacks.KeepCloning, "__init__", recorded)
    directory, replayed = lone_can_demos
    assert replayed > 0
    config = write_config(tmp_path / "sac.yml", {**TINY_SAC, "clone_steps": 3})
    out = tmp_path / "run"
    argv = train_argv(
        config, out, algo="sac", steps="64", eval_freq="64", eval_episodes="1", demos=str(directory)
    )
    code, _, err = run(argv, capsys)
    assert code == 0, err
    assert f"{replayed} demonstration steps in the replay buffer" in err
    latest = json.loads((out / "checkpoints" / "latest.json").read_text())
    with (out / "checkpoints" / latest["replay_buffer"]).open("rb") as handle:
        assert pickle.load(handle).size() == replayed + 64
    settings = json.loads((out / "run.json").read_text())["settings"]
    assert settings["demos"] == str(directory.resolve())
    assert kept == [3] and settings["hyperparams"]["clone_steps"] == 3


def test_an_entry_without_clone_steps_records_none_so_older_runs_still_resume(
    tmp_path: Path,
) -> None:
    config = write_config(tmp_path / "sac.yml", TINY_SAC)
    hp = load_hyperparams("sac", TRAIN_ENV, config)
    assert hp.clone_steps is None and "clone_steps" not in hp.as_dict()


@pytest.mark.parametrize(
    ("entry", "algo", "message"),
    [
        (TINY_PPO, "ppo", r"--demos: ppo has no replay buffer to pre-fill"),
        (
            {**TINY_SAC, "env_kwargs": {**TRAIN_SCENES, "level": "medium"}},
            "sac",
            r"--demos .*: recorded in scenes \{'level': 'none'",
        ),
    ],
)
def test_demos_the_run_cannot_use_are_one_line(
    entry: dict[str, Any],
    algo: str,
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    lone_can_demos: tuple[Path, int],
) -> None:
    config = write_config(tmp_path / "c.yml", entry)
    argv = train_argv(config, tmp_path / "run", algo=algo, demos=str(lone_can_demos[0]))
    code, _, err = run(argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert re.search(message, err), err


def test_demos_with_grasped_starts_are_refused_outside_the_lift_env(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from agents.learning.demos import Demo, save_demos

    directory = tmp_path / "demos"
    grasped = Demo(0, np.zeros((3, 5), np.float32), True, "", "grasped")
    kwargs = {"level": "none", "goal_kind": "soda_can"}
    save_demos(directory, [grasped], {"env": "ClutterRetrieveEELift-v0", "env_kwargs": kwargs})
    config = write_config(tmp_path / "c.yml", TINY_SAC)
    code, _, err = run(
        train_argv(config, tmp_path / "run", algo="sac", demos=str(directory)), capsys
    )
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "1 demos start with the goal in the hand" in err and TRAIN_ENV in err
    assert not (tmp_path / "run").exists()


def test_behaviour_cloning_fits_the_actor_to_the_demos(lone_can_demos: tuple[Path, int]) -> None:
    from stable_baselines3 import SAC

    from agents.learning.callbacks import DemoCloning
    from agents.learning.demos import load_demos, replay

    env = gym.make(TRAIN_ENV, level="none", goal_kind="soda_can")
    demos, _ = load_demos(lone_can_demos[0])
    steps = replay(env, demos[0])[1]
    model = SAC("MultiInputPolicy", env, policy_kwargs={"net_arch": [64, 64]}, seed=0)

    def error() -> float:
        acted = np.array([model.predict(s[0], deterministic=True)[0] for s in steps])
        return float(np.sqrt(np.mean((acted - np.array([s[1] for s in steps])) ** 2)))

    before = error()
    reported = DemoCloning(model, steps, seed=0)(1000)
    assert error() < before / 2 and reported < before / 2
    env.close()
