"""`clutter-gym evaluate`: a trained agent and a planner on the same episodes, JSON records and
a Markdown table; bad agents and flags are one line before any work; the trajectory-mode env the
planners act in meets the same scene and detection as the end-effector variant; objects moved
are counted from true poses."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

from agents.cli import main
from agents.learning.agent_specs import AgentSpec
from agents.learning.episodes import MOVED_M, objects_moved
from agents.learning.evaluate import plan_episodes
from tests.helpers import TINY_SAC, TRAIN_ENV, TRAIN_SCENES, train_argv, write_config
from tests.helpers import run_cli as run

EVAL_SCENES = {k: v for k, v in TRAIN_SCENES.items() if k != "max_episode_steps"}


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny PPO run (numbers meaningless) to evaluate."""
    root = tmp_path_factory.mktemp("trained")
    out = root / "ppo"
    argv = train_argv(write_config(root / "tiny.yml"), out, steps="128", eval_freq="128")
    assert main(argv) == 0
    return out


def evaluate_argv(tmp_path: Path, *agents: str, **flags: str) -> list[str]:
    argv = ["evaluate", "--env", TRAIN_ENV, "--episodes", "2", "--seed", "3"]
    argv += ["--json", str(tmp_path / "eval.json"), "--md", str(tmp_path / "eval.md")]
    for agent in agents:
        argv += ["--agent", agent]
    for flag, value in flags.items():
        argv += [f"--{flag.replace('_', '-')}", value]
    return argv


def test_a_trained_agent_and_a_planner_on_the_same_episodes(
    trained: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(evaluate_argv(tmp_path, "planner:pg", str(trained)), capsys)
    assert code == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    assert [line["agent"] for line in lines] == ["planner:pg", str(trained)]

    report = json.loads((tmp_path / "eval.json").read_text())
    assert report["env"] == TRAIN_ENV and report["episodes"] == 2 and report["seed"] == 3
    assert report["scene_keywords"] == EVAL_SCENES  # taken from the trained run
    assert report["agent_keywords"] == {"planner:pg": {}, str(trained): {"max_episode_steps": 20}}
    records = report["records"]
    assert [(r["agent"], r["episode"], r["seed"]) for r in records] == [
        ("planner:pg", 0, 3),
        ("planner:pg", 1, 4),
        (str(trained), 0, 3),
        (str(trained), 1, 4),
    ]
    planner, agent = records[:2], records[2:]
    assert {r["env"] for r in planner} == {"ClutterRetrieve-v0"}
    assert {r["env"] for r in agent} == {TRAIN_ENV}
    for mine, theirs in zip(planner, agent, strict=True):
        assert mine["scene"] == theirs["scene"] is not None  # the same scene, episode by episode
    assert planner[0]["scene"] != planner[1]["scene"]
    for record in records:
        assert record["objects_moved"] == [] and record["n_objects_moved"] == 0  # lone goal
        assert record["wall_time_s"] > 0 and record["length"] >= 1
    assert all(r["length"] == 20 and not r["success"] for r in agent)  # its own time limit
    assert all(r["success"] for r in planner), planner  # a lone can: PG retrieves it

    summary = report["summary"]
    assert summary["planner:pg"]["success_rate"] == 1.0
    assert summary[str(trained)]["mean_length"] == 20.0
    assert summary[str(trained)]["acts_in"] == TRAIN_ENV
    table = (tmp_path / "eval.md").read_text()
    assert "| agent | acts in | episodes | success rate |" in table
    assert "| planner:pg | ClutterRetrieve-v0 | 2 | 1.0 |" in table
    # The agent's own keywords of its variant stand beside it.
    assert f"| {trained} | {TRAIN_ENV} max_episode_steps=20 | 2 | 0.0 | 20.0 |" in table

    # Again: every episode comes from the log, the report is the same.
    code, _, err = run(evaluate_argv(tmp_path, "planner:pg", str(trained)), capsys)
    assert code == 0 and "resumed 4 of 4" in err
    assert json.loads((tmp_path / "eval.json").read_text())["records"] == records


def test_an_off_policy_agent_with_her_is_evaluated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """SAC with a HER replay buffer: loading it needs an env (and builds no large buffer)."""
    out = tmp_path / "sac"
    config = write_config(tmp_path / "sac.yml", TINY_SAC)
    argv = train_argv(config, out, algo="sac", steps="80", eval_freq="80", eval_episodes="1")
    assert main(argv) == 0
    capsys.readouterr()
    code, _, err = run([*evaluate_argv(tmp_path, str(out)), "--episodes", "1"], capsys)
    assert code == 0, err
    (record,) = json.loads((tmp_path / "eval.json").read_text())["records"]
    assert "crashed" not in record and record["length"] == 20, record


def test_scripted_and_scene_flags(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    flags = {"level": "none", "goal_kind": "soda_can", "noise": "sigma1"}
    code, _, err = run(evaluate_argv(tmp_path, "scripted", **flags), capsys)
    assert code == 0, err
    report = json.loads((tmp_path / "eval.json").read_text())
    assert report["scene_keywords"] == {"level": "none", "goal_kind": "soda_can", "noise": "sigma1"}
    assert report["summary"]["scripted"]["episodes"] == 2


BAD: list[tuple[str, list[str], tuple[str, ...]]] = [
    ("unknown planner", ["--agent", "planner:rrt"], ("--agent", "rrt", "planner:pushing")),
    ("not an agent", ["--agent", "{tmp}/nowhere"], ("--agent", "nowhere", "scripted")),
    ("not a run", ["--agent", "{tmp}"], ("--agent", "no run.json")),
    ("no agent", [], ("--agent", "required")),
    ("episodes 0", ["--agent", "scripted", "--episodes", "0"], ("--episodes", ">= 1")),
    ("level", ["--agent", "scripted", "--level", "extreme"], ("--level", "extreme", "none")),
    ("noise", ["--agent", "scripted", "--noise", "sigma9"], ("--noise", "sigma9", "sigma1")),
    ("env", ["--agent", "scripted", "--env", "Nope-v0"], ("--env", "Nope-v0")),
    (
        "grasped start",
        ["--agent", "scripted", "--grasped-start", "2"],
        ("--grasped-start", "[0, 1]"),
    ),
    (
        "grasped start, no lift agent",
        ["--agent", "scripted", "--grasped-start", "0"],
        ("--grasped-start", "ClutterRetrieveEELift-v0", "none of the agents"),
    ),
    ("scene file", ["--agent", "scripted", "--scenes", "{tmp}/x.json"], ("--scenes", "no such")),
]


@pytest.mark.parametrize(("extra", "texts"), [c[1:] for c in BAD], ids=[c[0] for c in BAD])
def test_bad_input_is_one_line_before_any_work(
    extra: list[str], texts: tuple[str, ...], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--env", TRAIN_ENV, "--json", str(tmp_path / "out" / "e.json")]
    argv += [a.replace("{tmp}", str(tmp_path)) for a in extra]
    code, out, err = run(argv, capsys)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for text in texts:
        assert text in err, err
    assert not (tmp_path / "out").exists()


def test_grasped_start_changes_only_the_lift_agents_episodes() -> None:
    """`--grasped-start 0`: the lift agent's success from ordinary starts, the planners'
    episodes unchanged."""
    lift = AgentSpec(
        "lift",
        "trained",
        run=SimpleNamespace(  # type: ignore[arg-type]
            env_id="ClutterRetrieveEELift-v0", env_kwargs={"level": "none", "grasped_start": 0.5}
        ),
    )
    planner = AgentSpec("planner:pg", "planner", planner="pg")
    jobs = plan_episodes([lift, planner], 1, 7, {"level": "none"}, 20.0, grasped_start=0.0)
    assert [(j.env_id, j.env_kwargs) for j in jobs] == [
        ("ClutterRetrieveEELift-v0", {"grasped_start": 0.0, "level": "none"}),
        ("ClutterRetrieve-v0", {"level": "none"}),
    ]
    kept = plan_episodes([lift], 1, 7, {"level": "none"}, 20.0)
    assert kept[0].env_kwargs["grasped_start"] == 0.5


def test_agents_trained_on_other_scenes_need_the_evaluations_scenes(
    trained: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    other = tmp_path / "other"
    other.mkdir()
    for name in ("final_model.zip", "vecnormalize.pkl"):
        (other / name).write_bytes((trained / name).read_bytes())
    run_json = json.loads((trained / "run.json").read_text())
    run_json["settings"]["hyperparams"]["env_kwargs"] = {"level": "medium"}
    (other / "run.json").write_text(json.dumps(run_json))
    code, _, err = run(evaluate_argv(tmp_path, str(trained), str(other)), capsys)
    assert code == 2 and "trained on different scenes" in err and "--level" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("corrupt", ["final_model.zip", "vecnormalize.pkl"])
def test_an_agent_that_cannot_be_loaded_is_one_line_before_any_episode(
    corrupt: str, trained: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("run.json", "final_model.zip", "vecnormalize.pkl"):
        (broken / name).write_bytes((trained / name).read_bytes())
    (broken / corrupt).write_bytes(b"not a model")
    code, _, err = run(evaluate_argv(tmp_path, "planner:pg", str(broken)), capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert str(broken) in err and "cannot load" in err
    assert not (tmp_path / "eval.json").exists()
    assert not (tmp_path / "eval.json.jobs.jsonl").exists()


def test_a_crashed_episode_is_a_failure_the_summary_counts() -> None:
    from agents.learning.agent_specs import parse_agent
    from agents.learning.evaluate import summarize

    agent = parse_agent("planner:pg")
    ran = {
        "agent": "planner:pg",
        "env": "ClutterRetrieve-v0",
        "success": True,
        "length": 1,
        "n_objects_moved": 0,
        "wall_time_s": 2.0,
    }
    crashed = {
        "agent": "planner:pg",
        "env": "ClutterRetrieve-v0",
        "success": False,
        "crashed": "RuntimeError: boom",
    }
    cell = summarize([agent], [ran, crashed])["planner:pg"]
    assert cell["episodes"] == 2 and cell["successes"] == 1 and cell["success_rate"] == 0.5
    assert cell["crashed"] == 1 and cell["mean_length"] == 1.0


def test_scenes_an_agents_env_refuses_are_one_line_before_any_work(
    trained: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Shelf scenes: the planners' env takes them, the end-effector variant does not."""
    shelf = {"surface": "shelf", "level": "none"}
    code, _, err = run(evaluate_argv(tmp_path, "planner:pg", str(trained), **shelf), capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert str(trained) in err and "surface" in err and "shelf" in err
    assert not (tmp_path / "eval.json").exists()


@pytest.mark.parametrize("ee_id", ["ClutterRetrieveEE-v0", "ClutterRetrieveEEDense-v0"])
def test_trajectory_and_end_effector_envs_meet_the_same_scene_and_detection(ee_id: str) -> None:
    """What makes planners and trained agents comparable: for one reset seed and keywords,
    the same scene and the same first detection (the goal alone, untouched by either start)."""
    planner_env = gym.make("ClutterRetrieve-v0", **EVAL_SCENES)
    agent_env = gym.make(ee_id, **EVAL_SCENES)
    for seed in range(3):
        obs, info = planner_env.reset(seed=seed)
        goal_obs, goal_info = agent_env.reset(seed=seed)
        assert planner_env.unwrapped.scene == agent_env.unwrapped.scene  # type: ignore[attr-defined]
        np.testing.assert_allclose(
            goal_info["true_object_poses"], info["true_object_poses"], atol=1e-4
        )
        detected = obs["object_poses"][int(obs["goal_object"]), :2]
        np.testing.assert_allclose(goal_obs["desired_goal"][:2], detected, atol=1e-4)
    planner_env.close()
    agent_env.close()


def test_objects_moved_are_others_displaced_more_than_two_centimetres() -> None:
    names = ("goal", "box", "bottle", "can")
    before = np.zeros((8, 3))
    after = before.copy()
    after[0, :2] = [0.3, 0.0]  # the goal: lifted and carried, not counted
    after[1, :2] = [0.0, MOVED_M + 0.001]
    after[2, :2] = [MOVED_M - 0.001, 0.0]
    after[3, 2] = 1.0  # turned in place
    start = {"object_names": names, "true_object_poses": before}
    end = {"object_names": names, "true_object_poses": after}
    assert objects_moved(start, end, "goal") == ("box",)
    assert objects_moved(start, end, None) == ("goal", "box")
    assert objects_moved({}, end, "goal") is None
