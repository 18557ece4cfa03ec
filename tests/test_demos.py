"""The planner as a teacher: its plans as end-effector actions (`agents.learning.demos`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents.learning.demos import (
    WAYPOINT_SPACING,
    Demo,
    load_demos,
    plan_waypoints,
    record_demos,
    replay,
    save_demos,
)
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.trajectory import Segment, Trajectory

LONE_CAN = {"level": "none", "goal_kind": "soda_can", "noise": "sigma1"}


@pytest.fixture(scope="module")
def demos() -> list[Demo]:
    return record_demos("ClutterRetrieveEE-v0", LONE_CAN, "pushing", 10, 0, 20.0)


def test_the_pushing_planner_retrieves_lone_cans_as_end_effector_actions(
    demos: list[Demo],
) -> None:
    assert sum(d.success for d in demos) >= 9
    for demo in demos:
        assert demo.actions.shape[1:] == (5,) and demo.actions.dtype == np.float32
        assert np.all(np.abs(demo.actions) <= 1.0)
        assert demo.success == (demo.reason == "")


def test_replaying_the_demos_retrieves_the_can_again(demos: list[Demo]) -> None:
    env = gym.make("ClutterRetrieveEE-v0", **LONE_CAN)
    outcomes = [replay(env, demo) for demo in demos]
    env.close()
    assert sum(ok for ok, _ in outcomes) >= 0.9 * len(demos)
    for demo, (ok, transitions) in zip(demos, outcomes, strict=True):
        assert ok == demo.success and len(transitions) == len(demo.actions)
        _, _, reward, _, terminated, _, _ = transitions[-1]
        # A success ends the episode with the reward; a failure may end it too (a strike).
        assert (terminated and reward == 1.0) if ok else reward < 1.0


def test_save_and_load_keep_every_demo(demos: list[Demo], tmp_path: Path) -> None:
    failed = Demo(99, np.zeros((0, 5), np.float32), False, "no plan: x")
    save_demos(tmp_path, [*demos, failed], {"env": "ClutterRetrieveEE-v0"})
    loaded, meta = load_demos(tmp_path)
    assert meta["env"] == "ClutterRetrieveEE-v0" and meta["episodes"] == len(demos) + 1
    failures = {str(d.seed): d.reason for d in demos if not d.success}
    assert meta["failures"] == {**failures, "99": "no plan: x"}
    for a, b in zip([*demos, failed], loaded, strict=True):
        assert (a.seed, a.success, a.reason) == (b.seed, b.success, b.reason)
        assert np.array_equal(a.actions, b.actions)


def test_in_the_lift_env_a_grasped_start_is_taught_the_planners_lift() -> None:
    """A grasped start (the env's planned grasp at reset) gets PickUp's straight lift with the
    hand closed; its replay lifts again, also in a lift env that would not draw that start."""
    demos = record_demos(
        "ClutterRetrieveEELift-v0", {**LONE_CAN, "grasped_start": 1.0}, "pushing", 3, 0, 20.0
    )
    assert [d.start for d in demos] == ["grasped"] * 3 and all(d.success for d in demos)
    assert all(np.all(d.actions[:, 4] == 1.0) and d.actions[:, 2].mean() > 0.5 for d in demos)
    env = gym.make("ClutterRetrieveEELift-v0", **LONE_CAN, grasped_start=0.0)
    assert all(replay(env, demo)[0] for demo in demos)
    env.close()
    env = gym.make("ClutterRetrieveEE-v0", **LONE_CAN)
    with pytest.raises(ValueError, match=r"^demo 0: starts 'grasped', which only Clutter"):
        replay(env, demos[0])
    env.close()


def test_save_and_load_keep_each_demos_start(tmp_path: Path) -> None:
    made = [
        Demo(k, np.zeros((2, 5), np.float32), True, "", s)
        for k, s in enumerate(("ready", "grasped"))
    ]
    save_demos(tmp_path, made, {})
    loaded, meta = load_demos(tmp_path)
    assert [d.start for d in loaded] == ["ready", "grasped"]
    assert meta["starts"] == {"ready": 1, "grasped": 1, "grasp failed": 0}


def test_demos_recorded_before_starts_were_kept_all_began_ready(tmp_path: Path) -> None:
    made = [Demo(k, np.zeros((2, 5), np.float32), True, "", "ready") for k in range(2)]
    save_demos(tmp_path, made, {})
    with np.load(tmp_path / "demos.npz") as data:
        older = {key: data[key] for key in data.files if key != "starts"}
    np.savez_compressed(tmp_path / "demos.npz", **older)
    assert [d.start for d in load_demos(tmp_path)[0]] == ["ready", "ready"]
    del older["actions"]
    np.savez_compressed(tmp_path / "demos.npz", **older)
    with pytest.raises(ValueError, match=r"^demos: .*demos\.npz has no actions; record"):
        load_demos(tmp_path)


def test_grasped_start_is_refused_for_an_env_without_it(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "agents.cli", "demos", "--env", "ClutterRetrieveEE-v0"]
        + ["--episodes", "1", "--grasped-start", "0.5", "--out", str(tmp_path / "d")],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "--grasped-start" in result.stderr and "ClutterRetrieveEELift-v0" in result.stderr
    assert not (tmp_path / "d").exists()


def test_loading_demos_from_an_empty_directory_names_the_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"^demos: .*no demos\.npz"):
        load_demos(tmp_path)


def test_waypoints_are_a_centimetre_apart_and_the_closing_hand_waits() -> None:
    kinematics = ArmKinematics("right")
    q0 = np.array([4.5, -1.6, -0.8, 2.5, -1.6, -0.7, 1.2])
    q1 = q0 + np.array([0.2, 0.2, 0.0, -0.2, 0.1, 0.0, 0.1])
    open_hand, closed = HandCommand(0.0, 0.2), HandCommand(0.0, 1.0)
    plan = Trajectory(
        (Segment("push", np.stack([q0, q1]), open_hand), Segment("close", q1[None], closed))
    )
    points = plan_waypoints(plan, kinematics, q0, lambda q: True)
    tcp = np.array([p.tcp for p in points])
    start = kinematics.fk_tcp(q0)[:3, 3]
    steps = np.linalg.norm(np.diff(np.vstack([start, tcp]), axis=0), axis=1)
    assert steps.max() <= WAYPOINT_SPACING + 1e-9
    assert points[-1].hold > 0 and points[-1].closure == 1.0 and not points[-1].passing
    assert all(p.closure == 0.2 for p in points[:-1])


def test_demos_command_writes_the_demos_and_one_json_line(tmp_path: Path) -> None:
    out = tmp_path / "demos"
    result = subprocess.run(
        [sys.executable, "-m", "agents.cli", "demos", "--env", "ClutterRetrieveEEGrasp-v0"]
        + ["--episodes", "2", "--out", str(out)],
        capture_output=True,
        text=True,
        check=True,
    )
    line = json.loads(result.stdout)
    assert line["episodes"] == 2 and line["env"] == "ClutterRetrieveEEGrasp-v0"
    loaded, _ = load_demos(out)
    assert len(loaded) == 2 and sum(d.success for d in loaded) == line["successes"]
