"""Learning on the env: registered time limits, curriculum keywords, the dense reward's order of
returns, the end-effector variants' GoalEnv (compute_reward, HER) and their ready pose.

Scenes are generated or placed from the table's workspace, never at hard-coded poses."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import clutter_gym
from agents.policies.scripted import DirectGraspPolicy
from clutter_gym.env import ClutterRetrieveEEEnv, ClutterRetrieveEnv
from clutter_gym.model.reachability import PUSH_HEIGHT, tcp_pose
from clutter_gym.model.scene import (
    SCENE_FORMAT,
    Scene,
    generate_scene,
    load_scene,
    scene_to_dict,
)
from clutter_gym.model.world import TABLE
from clutter_gym.sim.controllers import EE_STEP, READY_HEIGHT, YAW_STEP
from clutter_gym.sim.task import GRASP_TOLERANCE, GRASP_WEIGHT, LIFT_HEIGHT
from tests.helpers import EE_IDS, OPEN_AND_HOLD, still_action

REGISTERED_STEPS = {
    "ClutterRetrieve-v0": 10,
    "ClutterRetrieveEE-v0": 100,
    "ClutterRetrieveEEGrasp-v0": 100,
    "ClutterRetrieveEELift-v0": 100,
}


def workspace_centre() -> tuple[float, float]:
    (x_lo, x_hi), (y_lo, y_hi) = TABLE.workspace
    return (x_lo + x_hi) / 2.0, (y_lo + y_hi) / 2.0


def lone_goal(kind: str = "soda_can") -> dict[str, Any]:
    """The goal object alone at the table workspace's centre, detected without noise."""
    x, y = workspace_centre()
    return {
        "format": SCENE_FORMAT,
        "surface": "table",
        "objects": [{"name": "goal", "kind": kind, "pose": [x, y, 0.0]}],
        "goal": {"object": "goal"},
        "noise": "sigma1",
    }


def rollout(
    env: gym.Env, policy: Callable[[dict[str, np.ndarray]], np.ndarray], **reset: Any
) -> tuple[float, int, dict[str, Any], bool]:
    """(return, steps, last info, truncated) of one episode."""
    obs, info = env.reset(**reset)
    total, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        total, steps = total + float(reward), steps + 1
        if terminated or truncated:
            return total, steps, info, truncated


class ScriptedSideGrasp:
    """An end-effector policy that grasps the goal from the side along the line from the ready
    TCP to its first detection, closes the hand and lifts: a P-controller on the TCP (read from
    the robot, as proprioception) and on the hand's heading."""

    PREGRASP = 0.14  # m behind the goal's axis on the approach line
    PRESHAPE, CLOSE = -0.1, 1.0  # closure 0.45 (open wider than a bottle), then closed

    def __init__(self, env: gym.Env, obs: dict[str, np.ndarray], kind: str) -> None:
        self.herb = env.unwrapped.herb  # type: ignore[attr-defined]
        start = self.herb.tcp_pose()[0]
        if len(obs["desired_goal"]) == 4:  # the grasp objective: the TCP's offset from it
            self.goal = (start - obs["achieved_goal"][:3])[:2]
        else:
            self.goal = np.asarray(obs["desired_goal"][:2], dtype=float)
        self.direction = (self.goal - start[:2]) / np.linalg.norm(self.goal - start[:2])
        self.z = TABLE.top_z + PUSH_HEIGHT
        self.phase, self.count, self.hold = 0, 0, np.zeros(3)

    def target(self) -> tuple[np.ndarray, float]:
        """Pregrasp, grasp, close (30 steps), lift: where the TCP goes and the closure action."""
        if self.phase == 0:
            return np.r_[self.goal - self.PREGRASP * self.direction, self.z], self.PRESHAPE
        if self.phase == 1:
            return np.r_[self.goal, self.z], self.PRESHAPE
        if self.phase == 2:
            return self.hold, self.CLOSE
        return self.hold + [0.0, 0.0, 1.5 * LIFT_HEIGHT], self.CLOSE

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        tcp, quaternion = self.herb.tcp_pose()
        target, closure = self.target()
        x, y, z, w = quaternion
        approach = (2 * (x * z + w * y), 2 * (y * z - w * x))
        heading_error = math.remainder(
            math.atan2(self.direction[1], self.direction[0]) - math.atan2(*approach[::-1]), math.tau
        )
        self.count += 1
        reached = np.linalg.norm(target - tcp) < 0.003 and abs(heading_error) < 0.02
        if (self.phase < 2 and reached) or (self.phase == 2 and self.count > 30):
            self.phase, self.count, self.hold = self.phase + 1, 0, tcp.copy()
        move = np.clip((target - tcp) / EE_STEP, -1.0, 1.0)
        turn = np.clip(heading_error / YAW_STEP, -1.0, 1.0)
        return np.r_[move, turn, closure].astype(np.float32)


# --- registration and truncation -------------------------------------------------------------


def test_every_variant_is_registered_with_a_time_limit() -> None:
    assert {"ClutterRetrieve-v0", *EE_IDS} <= set(clutter_gym.ENV_IDS)
    for env_id in clutter_gym.ENV_IDS:
        assert gym.spec(env_id).max_episode_steps is not None
    assert gym.spec("ClutterRetrieve-v0").max_episode_steps == 10
    assert gym.spec("ClutterRetrieveEEDense-v0").max_episode_steps == 100
    assert gym.spec("ClutterRetrieveEEDense-v0").kwargs["reward_type"] == "dense"


@pytest.mark.parametrize(("env_id", "steps"), REGISTERED_STEPS.items())
def test_truncation_at_the_registered_max_episode_steps(env_id: str, steps: int) -> None:
    env = gym.make(env_id, scenes=lone_goal())
    _, taken, info, truncated = rollout(env, lambda obs: still_action(env, obs), seed=0)
    assert (taken, truncated) == (steps, True) and not info["failure"]
    env.close()


@pytest.mark.parametrize(
    ("env_id", "steps"), [("ClutterRetrieve-v0", 13), *((i, 150) for i in EE_IDS)]
)
def test_a_larger_max_episode_steps_really_runs_that_many_steps(env_id: str, steps: int) -> None:
    """Truncation is Gymnasium's TimeLimit alone: the env itself never truncates."""
    env = gym.make(env_id, scenes=lone_goal(), max_episode_steps=steps)
    _, taken, _, truncated = rollout(env, lambda obs: still_action(env, obs), seed=0)
    assert (taken, truncated) == (steps, True)
    env.close()


# --- curriculum keywords ---------------------------------------------------------------------


def test_scenes_keyword_draws_from_the_list_with_the_seed(tmp_path: Path) -> None:
    path = tmp_path / "generated.json"
    path.write_text(json.dumps(scene_to_dict(generate_scene("medium", seed=5))))
    bottle = scene_to_dict(generate_scene("none", seed=1, goal_kind="juice_bottle"))
    sources = [bottle, lone_goal(), str(path), generate_scene("high", seed=2)]
    loaded = [load_scene(s) if not isinstance(s, Scene) else s for s in sources]
    env = gym.make("ClutterRetrieveEE-v0", scenes=sources).unwrapped
    drawn = []
    for seed in range(12):
        env.reset(seed=seed)
        drawn.append(loaded.index(env.scene))
        env.reset(seed=seed)
        assert loaded.index(env.scene) == drawn[-1]
    assert set(drawn) == {0, 1, 2, 3}
    _, info = env.reset(seed=0, options={"level": "none"})  # a reset option overrides the list
    assert len(info["object_names"]) == 1 and env.scene not in loaded
    env.close()


def test_one_scene_given_is_every_episode() -> None:
    env = gym.make("ClutterRetrieve-v0", scenes=lone_goal("juice_bottle")).unwrapped
    for seed in range(3):
        _, info = env.reset(seed=seed)
        assert info["object_names"] == ("goal",)
    env.close()


@pytest.mark.parametrize("level", ["none", None])
def test_goal_kind_fixes_the_goal_of_sampled_scenes(level: str | None) -> None:
    env = gym.make("ClutterRetrieveEE-v0", level=level, goal_kind="juice_bottle").unwrapped
    kinds, sizes = set(), set()
    for seed in range(8):
        env.reset(seed=seed)
        goal = next(o for o in env.scene.objects if o.name == env.scene.goal.object)
        kinds.add(goal.kind)
        sizes.add(len(env.scene.objects))
    assert kinds == {"juice_bottle"}
    assert (sizes == {1}) == (level == "none")
    env.close()


def test_end_effector_variants_refuse_a_shelf_scene_at_reset() -> None:
    env = gym.make("ClutterRetrieveEE-v0").unwrapped
    shelf = generate_scene("medium", seed=0, surface="shelf")
    with pytest.raises(ValueError, match=r"^options\['scene'\]: a shelf scene"):
        env.reset(seed=0, options={"scene": shelf})
    env.close()


# --- the dense reward ------------------------------------------------------------------------


def test_dense_returns_order_crash_below_waiting_below_success_end_effector() -> None:
    """On one scene: driving the open hand straight into the table, holding still for the whole
    episode, and a scripted side grasp that the env itself reports as a physical success."""
    env = gym.make("ClutterRetrieveEEDense-v0", scenes=lone_goal())
    down = np.array([0.0, 0.0, -1.0, 0.0, -1.0], dtype=np.float32)
    crash, _, crash_info, _ = rollout(env, lambda obs: down, seed=0)
    assert crash_info["failure"] == "robot struck the table"
    wait, waited, _, truncated = rollout(env, lambda obs: OPEN_AND_HOLD, seed=0)
    assert truncated and waited == 100
    obs, _ = env.reset(seed=0)
    policy = ScriptedSideGrasp(env, obs, "soda_can")
    success, _, info, _ = rollout(env, policy, seed=0)
    assert info["is_success"] and info["goal_held"] and info["goal_lift"] >= LIFT_HEIGHT
    assert env.unwrapped.sim.client.getNumConstraints() == 0  # held by friction alone
    assert crash < wait < success
    env.close()


def test_dense_returns_order_crash_below_waiting_below_success_trajectory() -> None:
    env = gym.make("ClutterRetrieve-v0", reward_type="dense", scenes=lone_goal())
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEnv)
    x, _ = workspace_centre()
    under_table = tcp_pose(
        np.array([x, TABLE.workspace[1][1], TABLE.top_z - 0.035]), np.array([1.0, 0.0, 0.0])
    )
    q = base.kinematics.solve_ik(under_table)
    assert q is not None
    into_table = np.tile(np.r_[q, 0.0, 0.0], (base.waypoints, 1)).astype(np.float32)
    crash, _, crash_info, _ = rollout(env, lambda obs: into_table, seed=0)
    assert crash_info["failure"] == "robot struck the table"
    wait, _, _, truncated = rollout(env, lambda obs: still_action(env, obs), seed=0)
    assert truncated
    success, _, info, _ = rollout(env, DirectGraspPolicy(base.waypoints, TABLE), seed=0)
    assert info["is_success"]
    assert crash < wait < success
    env.close()


def test_dense_reward_is_potential_shaping_with_the_bonus_and_cost() -> None:
    env = gym.make("ClutterRetrieveEEDense-v0", scenes=lone_goal(), gamma=0.9)
    _, info = env.reset(seed=0)
    previous = info["potential"]
    assert -1.0 <= previous <= 0.0 and info["shaping"] == 0.0
    toward = np.array([1.0, 0.5, 0.0, 0.0, -1.0], dtype=np.float32)
    for _ in range(5):
        _, reward, terminated, _, info = env.step(toward)
        assert not terminated and -1.0 <= info["potential"] <= 0.0
        assert reward == pytest.approx(0.9 * info["potential"] - previous)
        previous = info["potential"]
    down = np.array([0.0, 0.0, -1.0, 0.0, -1.0], dtype=np.float32)
    while True:
        _, reward, terminated, _, info = env.step(down)
        if terminated:
            break
        previous = info["potential"]
    assert reward == pytest.approx(-2.0 - previous)  # the failure cost; Phi(end) = 0
    env.close()


def test_region_potential_rises_as_the_goal_nears_the_shelf_front() -> None:
    """The shelf's goal term alone: the TCP is put at the goal's grasp point each time, so the
    reach term is 1 in both states and no finger touches the goal."""
    env = gym.make("ClutterRetrieve-v0", surface="shelf", level="none", reward_type="dense")
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEnv)
    base.reset(seed=1)
    goal = base.scene.goal.object
    (x_lo, x_hi), (y_lo, y_hi) = base.scene.goal.region
    above = np.array([0.0, 0.0, PUSH_HEIGHT])

    def potential() -> float:
        outcome = base.task.evaluate()
        return base.task.potential(outcome, outcome.goal_position + above)

    behind = potential()
    front = [(x_lo + x_hi) / 2, (y_lo + y_hi) / 2, base.surface.top_z]
    base.sim.set_base_pose(goal, front, [0.0, 0.0, 0.0, 1.0])
    assert behind < potential() == pytest.approx(-GRASP_WEIGHT)  # only the grasp is missing
    env.close()


# --- the GoalEnv -----------------------------------------------------------------------------


@pytest.mark.parametrize("env_id", EE_IDS)
def test_reward_is_compute_reward_single_and_batched(env_id: str) -> None:
    env = gym.make(env_id, level="medium")
    compute = env.unwrapped.compute_reward  # type: ignore[attr-defined]
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    goals, rewards, infos, desired = [], [], [], []
    for _ in range(60):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert compute(obs["achieved_goal"], obs["desired_goal"], info) == reward
        if env_id == "ClutterRetrieveEE-v0":
            assert reward == (1.0 if info["is_success"] else -1.0 if info["failure"] else 0.0)
        goals.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(reward)
        infos.append(info)
        if terminated or truncated:
            obs, _ = env.reset()
    batch = compute(np.array(goals), np.array(desired), np.array(infos, dtype=object))
    assert batch.shape == (60,) and np.array_equal(batch, np.array(rewards))
    env.close()


def test_goals_are_the_detected_position_and_the_lift_height() -> None:
    env = gym.make("ClutterRetrieveEE-v0", level="medium", noise="sigma3")
    obs, info = env.reset(seed=4)
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEEEnv)
    goal = info["object_names"].index(base.scene.goal.object)
    true = info["true_object_poses"][goal]
    assert 0 < np.linalg.norm(obs["achieved_goal"][:2] - true[:2]) < 0.2  # detected, not true
    assert obs["achieved_goal"][2] == pytest.approx(TABLE.top_z, abs=2e-3)
    assert np.array_equal(obs["desired_goal"][:2], obs["achieved_goal"][:2])
    assert obs["desired_goal"][2] == pytest.approx(obs["achieved_goal"][2] + LIFT_HEIGHT)
    first = obs["desired_goal"].copy()
    obs, *_ = env.step(OPEN_AND_HOLD)
    assert np.array_equal(obs["desired_goal"], first)
    assert not np.array_equal(obs["achieved_goal"][:2], first[:2])  # a new detection
    # The same detection in the observation: the goal's slot (model.observation's layout:
    # 25 robot entries, then (x, y, cos 2 theta, sin 2 theta) per slot).
    slot = obs["observation"][25 + 4 * goal : 27 + 4 * goal]
    assert slot == pytest.approx(obs["achieved_goal"][:2], abs=1e-6)
    env.close()


def test_relabelled_goals_reward_holding_the_object_that_high() -> None:
    """What HER relies on: a desired goal at an achieved height pays when the object is held."""
    env = gym.make("ClutterRetrieveEE-v0", scenes=lone_goal())
    compute = env.unwrapped.compute_reward  # type: ignore[attr-defined]
    obs, _ = env.reset(seed=0)
    policy = ScriptedSideGrasp(env, obs, "soda_can")
    info: dict[str, Any] = {}
    while not info.get("goal_held"):
        obs, reward, terminated, _, info = env.step(policy(obs))
        assert reward == 0.0 and not terminated
    held_here = obs["achieved_goal"].copy()
    assert compute(obs["achieved_goal"], held_here, info) == 1.0
    assert compute(obs["achieved_goal"], obs["desired_goal"], info) == 0.0  # not lifted yet
    assert compute(obs["achieved_goal"], held_here, {**info, "goal_held": False}) == 0.0
    assert compute(held_here, held_here, {**info, "failure": "x toppled"}) == -1.0
    env.close()


class ShortGrasp(ScriptedSideGrasp):
    """The side grasp closing with the TCP ``short`` metres before the goal's axis."""

    def __init__(self, env: gym.Env, obs: dict[str, np.ndarray], short: float) -> None:
        super().__init__(env, obs, "soda_can")
        self.goal = self.goal - short * self.direction


def grasp_episode(
    policy_of: Callable[[gym.Env, dict[str, np.ndarray]], ScriptedSideGrasp], steps: int = 100
) -> tuple[list[float], dict[str, Any], dict[str, np.ndarray]]:
    """Rewards, last info and observation of a grasp-objective episode on a lone can; every
    reward is checked against compute_reward and the env's success."""
    env = gym.make("ClutterRetrieveEEGrasp-v0", scenes=lone_goal(), max_episode_steps=steps)
    compute = env.unwrapped.compute_reward  # type: ignore[attr-defined]
    obs, info = env.reset(seed=0)
    policy, rewards = policy_of(env, obs), []
    while True:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        assert compute(obs["achieved_goal"], obs["desired_goal"], info) == reward
        assert (reward == 1.0) == info["is_success"]
        rewards.append(float(reward))
        if terminated or truncated:
            env.close()
            return rewards, info, obs


def test_grasp_objective_succeeds_when_two_fingers_grip_the_goal_around_its_axis() -> None:
    rewards, info, obs = grasp_episode(lambda env, obs: ScriptedSideGrasp(env, obs, "soda_can"))
    assert info["is_success"] and rewards[-1] == 1.0 and sum(rewards) == 1.0
    # The can still stands: the fingers, which hold where they stall (worm gears), may squeeze
    # it off the table's contact (held) but lift it no more than a millimetre.
    assert info["goal_gripped"] and info["goal_lift"] < 0.001
    assert obs["achieved_goal"][3] == obs["desired_goal"][3] == 1.0
    assert np.linalg.norm(obs["achieved_goal"][:3] - obs["desired_goal"][:3]) <= GRASP_TOLERANCE


def test_grasp_objective_fails_when_the_hand_closes_short_of_the_goal() -> None:
    """Closed 7 cm short of the can's axis, the fingers flick it away: no grasp, no reward."""
    rewards, info, obs = grasp_episode(lambda env, obs: ShortGrasp(env, obs, 0.07), steps=80)
    assert not info["is_success"] and not info["goal_gripped"] and set(rewards) == {0.0}
    assert obs["achieved_goal"][3] == 0.0


def test_relabelled_grasp_goals_reward_reaching_where_the_tcp_went() -> None:
    """What HER relies on: a goal relabelled from a step without a grip pays for reaching that
    TCP position; one with the grip flag set pays only while the object is gripped there."""
    env = gym.make("ClutterRetrieveEEGrasp-v0", scenes=lone_goal())
    compute = env.unwrapped.compute_reward  # type: ignore[attr-defined]
    obs, _ = env.reset(seed=0)
    obs, reward, _, _, info = env.step(OPEN_AND_HOLD)
    reached = obs["achieved_goal"].copy()
    assert reward == 0.0 and reached[3] == 0.0
    assert compute(reached, reached, info) == 1.0
    assert compute(reached, reached + [GRASP_TOLERANCE + 0.01, 0, 0, 0], info) == 0.0
    assert compute(reached, np.r_[reached[:3], 1.0], info) == 0.0
    assert compute(reached, reached, {**info, "failure": "x toppled"}) == -1.0
    env.close()


def test_compute_reward_without_the_step_info_says_how_to_keep_it() -> None:
    env = gym.make("ClutterRetrieveEE-v0", level="none")
    obs, _ = env.reset(seed=0)
    goals = np.array([obs["achieved_goal"]] * 2)
    with pytest.raises(ValueError, match=r"^info: has no 'goal_held'.*copy_info_dict"):
        env.unwrapped.compute_reward(goals, goals, np.array([{}, {}]))  # type: ignore[attr-defined]
    env.close()


def test_her_learns_on_the_end_effector_variant() -> None:
    """stable-baselines3's SAC with hindsight experience replay runs end to end (no claim on
    what it learns in 300 steps)."""
    from stable_baselines3 import SAC, HerReplayBuffer

    env = gym.make("ClutterRetrieveEE-v0", level="none", max_episode_steps=40)
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        # compute_reward reads the step's info (held, failure, shaping): HER must keep it.
        replay_buffer_kwargs={"copy_info_dict": True, "goal_selection_strategy": "future"},
        learning_starts=100,
        batch_size=32,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
    )
    model.learn(total_timesteps=300)
    assert model.replay_buffer is not None and model.replay_buffer.size() > 0
    action, _ = model.predict(env.reset(seed=1)[0], deterministic=True)
    assert env.action_space.contains(action)
    env.close()


# --- the ready pose --------------------------------------------------------------------------


def test_ready_pose_holds_the_hand_horizontal_at_grasp_height_and_still() -> None:
    env = gym.make("ClutterRetrieveEE-v0", level="high")
    _, info = env.reset(seed=3)
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEEEnv)
    assert not info["failure"] and not base.sim.contacts("herb", "surface")
    position, quaternion = base.herb.tcp_pose()
    rotation = np.reshape(base.sim.client.getMatrixFromQuaternion(quaternion), (3, 3))
    assert abs(rotation[2, 2]) < 0.02  # approach axis (hand z) level
    assert abs(rotation[2, 1]) < 0.02  # finger plane horizontal (its normal, hand y, level)
    assert position[2] == pytest.approx(TABLE.top_z + READY_HEIGHT, abs=0.005)
    assert position[0] < TABLE.workspace[0][0]  # before every object
    for _ in range(50):
        *_, info = env.step(OPEN_AND_HOLD)
    assert np.allclose(base.herb.tcp_pose()[0], position, atol=0.002)  # no sag
    env.close()


def test_driving_the_wrist_to_its_limit_slows_the_hand_instead_of_throwing_it() -> None:
    """Forward while turning toward straight ahead in front of the shoulder, where a level
    hand runs the wrist's j6 into its limit: the arm's redundancy holds the joints off their
    limits, so the TCP never moves much more than the 1 cm commanded (with the joint clipped at
    its limit, the least-squares step threw it 6.8 cm in one step here)."""
    env = gym.make("ClutterRetrieveEE-v0", level="none", goal_kind="soda_can", noise="sigma1")
    env.reset(seed=1)
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEEEnv)
    before, moves = base.herb.tcp_pose()[0], []
    for _ in range(40):
        _, _, terminated, _, _ = env.step(np.array([0.9, 0.3, 0.0, -0.5, -1.0], np.float32))
        after = base.herb.tcp_pose()[0]
        moves.append(float(np.linalg.norm(after - before)))
        before = after
        assert not terminated
    assert max(moves) < 0.025
    env.close()
