"""The registered variants against the Gymnasium contract, determinism, bad input and the task
rules (the learning-specific parts of the end-effector variants: tests/test_rl_env.py)."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import clutter_gym
from agents.policies.scripted import DirectGraspPolicy
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.model import herb as hm
from clutter_gym.model.reachability import approach_rotation
from clutter_gym.model.scene import scene_to_dict
from clutter_gym.model.world import TABLE
from tests.helpers import (
    EE_IDS,
    TRAJECTORY_ID,
    hold_action,
    registered_env,
    rollout_digest,
    still_action,
)

CAN_SCENE = {
    "format": "clutter-gym-scene/1",
    "surface": "table",
    "objects": [
        {"name": "can", "kind": "soda_can", "pose": [0.95, -0.25, 0.0]},
        {"name": "box", "kind": "poptart_box", "pose": [1.05, 0.0, 0.5]},
    ],
    "goal": {"object": "can"},
    "noise": "sigma1",
}


def make(**kwargs: object) -> ClutterRetrieveEnv:
    return gym.make("ClutterRetrieve-v0", **kwargs).unwrapped  # type: ignore[return-value]


@pytest.mark.parametrize("env_id", clutter_gym.ENV_IDS)
def test_gymnasium_checker(env_id: str) -> None:
    env = gym.make(env_id, level="none")
    with warnings.catch_warnings():  # the primitive variant is a wrapper by design
        warnings.filterwarnings("ignore", "(?s).*different from the unwrapped version")
        check_env(registered_env(env), skip_render_check=True)
    env.close()


@pytest.mark.parametrize(
    "env_id",
    [
        pytest.param(i, marks=pytest.mark.slow) if i == TRAJECTORY_ID else i
        for i in clutter_gym.ENV_IDS
    ],
)
def test_stable_baselines3_checker(env_id: str) -> None:
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(env_id, level="none")
    sb3_check_env(registered_env(env), warn=False)
    env.close()


@pytest.mark.parametrize(("env_id", "steps"), [*((i, 40) for i in EE_IDS), (TRAJECTORY_ID, 2)])
def test_same_seed_same_rollout_in_process(env_id: str, steps: int) -> None:
    assert rollout_digest(3, env_id, steps) == rollout_digest(3, env_id, steps)
    assert rollout_digest(3, env_id, steps) != rollout_digest(4, env_id, steps)


def test_same_seed_same_rollout_across_processes() -> None:
    code = (
        "from tests.helpers import rollout_digest; "
        "print(rollout_digest(7, 'ClutterRetrieveEE-v0', 40))"
    )
    root = Path(__file__).resolve().parents[1]
    other = (
        subprocess.run(
            [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True
        )
        .stdout.strip()
        .splitlines()[-1]
    )
    assert other == rollout_digest(7, "ClutterRetrieveEE-v0", 40)


def test_async_vector_env() -> None:
    envs = gym.make_vec(
        "ClutterRetrieveEE-v0", num_envs=2, vectorization_mode="async", level="medium"
    )
    obs, _ = envs.reset(seed=0)
    assert obs["observation"].shape == (2, 101) and obs["desired_goal"].shape == (2, 3)
    obs, rewards, terminated, _, _ = envs.step(envs.action_space.sample())
    assert rewards.shape == (2,) and terminated.dtype == np.bool_
    envs.close()


def test_render_headless_and_close_twice() -> None:
    env = gym.make("ClutterRetrieve-v0", render_mode="rgb_array", level="medium")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (360, 480, 3) and frame.dtype == np.uint8
    assert frame.std() > 10  # a scene, not a blank image
    env.close()
    env.close()


def test_render_mode_none_returns_none() -> None:
    env = make(level="none")
    env.reset(seed=0)
    assert env.render() is None
    env.close()


def test_making_an_env_prints_nothing_on_stdout(capfd: pytest.CaptureFixture[str]) -> None:
    """pybullet's native "argv[0]=" must not reach stdout, where CLIs write JSON lines."""
    capfd.readouterr()
    env = make(level="none")
    env.reset(seed=0)
    env.close()
    assert capfd.readouterr().out == ""


def test_detections_are_noisy_truth_only_in_info() -> None:
    env = make(noise="sigma3")
    obs, info = env.reset(seed=1, options={"scene": CAN_SCENE})
    error = obs["object_poses"][:2, :2] - info["true_object_poses"][:2, :2]
    assert np.all(np.abs(error) > 0) and np.all(np.abs(error) < 0.2)
    assert obs["noise"].tolist() == pytest.approx([0.02, 0.175])
    exact = make()
    obs, info = exact.reset(seed=1, options={"scene": CAN_SCENE})  # the scene says sigma1
    assert np.allclose(obs["object_poses"][:2], info["true_object_poses"][:2], atol=1e-5)
    assert obs["object_mask"].tolist() == [1, 1, 0, 0, 0, 0, 0, 0]
    assert obs["object_sizes"][0].tolist() == pytest.approx([0.066, 0.066, 0.122])
    env.close()
    exact.close()


def test_reset_accepts_dict_path_and_rejects_bad_scenes(tmp_path: Path) -> None:
    env = make()
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(CAN_SCENE))
    _, from_dict = env.reset(seed=0, options={"scene": CAN_SCENE})
    _, from_path = env.reset(seed=0, options={"scene": str(path)})
    assert from_dict["object_names"] == from_path["object_names"] == ("can", "box")
    bad = json.loads(json.dumps(CAN_SCENE))
    bad["objects"][1]["kind"] = "teapot"
    with pytest.raises(ValueError, match=r"objects\[1\]\.kind"):
        env.reset(options={"scene": bad})
    with pytest.raises(ValueError, match="allowed"):
        env.reset(options={"scene": CAN_SCENE, "colour": "red"})
    env.close()


def test_sampled_scenes_follow_the_seed() -> None:
    env = make(level="high")
    _, a = env.reset(seed=5)
    names_a = a["object_names"]
    _, b = env.reset(seed=5)
    assert names_a == b["object_names"]
    assert np.array_equal(a["true_object_poses"], b["true_object_poses"])
    assert 3 <= len(names_a) <= 4
    assert scene_to_dict(env.scene)["surface"] == "table"
    env.close()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"level": "extreme"}, "level"),
        ({"goal_kind": "dumbbell"}, "goal_kind"),
        ({"scenes": []}, "scenes"),
        ({"gamma": 1.5}, "gamma"),
        ({"surface": "floor"}, "surface"),
        ({"noise": "sigma9"}, "noise"),
        ({"noise": (-0.1, 0.0)}, "noise"),
        ({"reward_type": "shaped"}, "reward_type"),
        ({"render_mode": "rgb"}, "render_mode"),
        ({"waypoints": 0}, "waypoints"),
    ],
)
def test_bad_constructor_arguments_name_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValueError, match=field):
        gym.make("ClutterRetrieve-v0", **kwargs)


@pytest.mark.parametrize("env_id", [TRAJECTORY_ID, *EE_IDS])
def test_bad_actions_raise_and_leave_the_world_intact(env_id: str) -> None:
    env = gym.make(env_id).unwrapped
    obs, info = env.reset(seed=0, options={"scene": CAN_SCENE})
    good = still_action(env, obs)
    with pytest.raises(ValueError, match="shape"):
        env.step(good[:-1])
    nan = good.copy()
    nan.flat[3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        env.step(nan)
    inf = good.copy()
    inf.flat[0] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        env.step(inf)
    assert env.sim_steps == info["sim_steps"]  # rejected before any physics ran
    _, _, terminated, _, after = env.step(good)
    assert not terminated and after["sim_steps"] > info["sim_steps"]
    assert np.allclose(after["true_object_poses"], info["true_object_poses"], atol=1e-3)
    env.close()


def test_out_of_limit_waypoints_are_clipped_and_reported() -> None:
    env = make()
    obs, _ = env.reset(seed=0, options={"scene": CAN_SCENE})
    action = hold_action(env, obs)
    action[:, 7:] = 1.7  # hand command above 1
    _, _, _, _, info = env.step(action)
    assert info["action_clipped"]
    assert env.herb.hand_state()[1] == pytest.approx(hm.HAND_PROXIMAL_RANGE[1], abs=0.1)
    env.close()


def test_direct_grasp_lifts_the_can_by_finger_contact() -> None:
    env = make()
    obs, _ = env.reset(seed=0, options={"scene": CAN_SCENE})
    policy = DirectGraspPolicy(env.waypoints, TABLE)
    obs, reward, terminated, truncated, info = env.step(policy(obs))
    assert policy.failure == ""
    assert info["is_success"] and terminated and not truncated and reward == 1.0
    assert info["goal_held"] and info["goal_lift"] >= 0.10
    assert env.sim.client.getNumConstraints() == 0  # held by friction, never attached


def test_arm_striking_the_table_terminates_with_failure() -> None:
    env = make()
    env.reset(seed=0, options={"scene": CAN_SCENE})
    below_top = np.eye(4)
    below_top[:3, :3] = approach_rotation(np.array([1.0, 0.0, 0.0]))
    below_top[:3, 3] = (0.95, 0.15, 0.70)  # 3.5 cm under the table top, clear of the objects
    q = env.kinematics.solve_ik(below_top)
    assert q is not None
    action = np.tile(np.r_[q, 0.0, 0.0], (env.action_space.shape[0], 1)).astype(np.float32)
    _, reward, terminated, _, info = env.step(action)
    assert terminated and reward == -1.0
    assert info["failure"] == "robot struck the table"
    with pytest.raises(RuntimeError, match="reset"):
        env.step(action)
    env.close()


def test_toppled_object_is_a_failure() -> None:
    env = make()
    env.reset(seed=0, options={"scene": CAN_SCENE})
    lying = env.sim.client.getQuaternionFromEuler([np.pi / 2, 0.0, 0.0])
    env.sim.set_base_pose("box", [1.05, 0.0, 0.8], lying)
    env.sim.step(60)
    outcome = env.task.evaluate()
    assert outcome.failure == "box toppled" and not outcome.success
    env.close()


def test_hand_distal_joints_follow_proximal() -> None:
    env = make()
    obs, _ = env.reset(seed=0, options={"scene": CAN_SCENE})
    action = hold_action(env, obs)
    action[:, 8] = 0.6
    env.step(action)
    states = env.sim.client.getJointStates(env.herb.body_id, env.herb.hand)
    prox, dist = np.array([s[0] for s in states[2:5]]), np.array([s[0] for s in states[5:8]])
    assert prox == pytest.approx(0.6 * hm.HAND_PROXIMAL_RANGE[1], abs=0.05)
    assert dist == pytest.approx(prox * hm.HAND_DISTAL_COUPLING, abs=0.05)
    env.close()


def test_shelf_goal_brought_into_the_region_is_a_success() -> None:
    env = make(surface="shelf", level="medium")
    _, info = env.reset(seed=4)
    goal = env.scene.goal.object
    (x_lo, x_hi), (y_lo, y_hi) = env.scene.goal.region
    assert not info["is_success"]
    others = [p.pose for p in env.scene.objects if p.name != goal]
    # A free spot in the front strip (the generator keeps clutter out of it at this seed).
    spot = min(
        (
            (x, y)
            for x in np.linspace(x_lo + 0.05, x_hi - 0.05, 3)
            for y in np.linspace(y_lo + 0.05, y_hi - 0.05, 9)
        ),
        key=lambda s: -min(np.hypot(s[0] - p[0], s[1] - p[1]) for p in others),
    )
    env.sim.set_base_pose(goal, [spot[0], spot[1], env.surface.top_z], [0.0, 0.0, 0.0, 1.0])
    env.sim.step(24)
    outcome = env.task.evaluate()
    assert outcome.success and not outcome.failure
    env.close()


def test_reset_can_start_from_a_given_arm_and_hand() -> None:
    env = make()
    q = np.array(hm.RIGHT_ARM_HOME) + 0.1
    obs, info = env.reset(seed=0, options={"scene": CAN_SCENE, "arm": q, "hand": (0.0, 0.4)})
    assert obs["arm_joints"] == pytest.approx(q, abs=2e-3)
    assert obs["hand"][1] == pytest.approx(0.4 * hm.HAND_PROXIMAL_RANGE[1], abs=0.02)
    assert info["failure"] == ""
    bad = q.copy()
    bad[1] = 3.0
    with pytest.raises(ValueError, match=r"options\['arm'\]\[1\]: 3.0000 rad is outside"):
        env.reset(options={"scene": CAN_SCENE, "arm": bad})
    with pytest.raises(ValueError, match=r"options\['hand'\]"):
        env.reset(options={"scene": CAN_SCENE, "hand": (0.0, 1.5)})
    env.close()
