"""Retrieval task: when an episode succeeds or fails, and what it pays.

Success is physical: the goal object must be held by finger contact (at least two different
fingers touching it, nothing but the robot touching it) and lifted at least `LIFT_HEIGHT` above
where it started, or, for `success="region"` scenes (the shelf), its centre must lie inside the
goal region while it stands upright. No attach constraint is ever created. The grasp objective
(`Objective`, the first stage of end-effector learning) stops before the lift: the goal object
gripped by two fingers (it may still stand on the surface) with the hand around it, the TCP
within `GRASP_TOLERANCE` of its grasp point (its axis at grasp height, where it stands now: a
push-grasp moves it before the fingers close).

Failure terminates the episode: an object topples (its axis tilts more than `TOPPLE_ANGLE`), an
object leaves the surface, or the robot touches the table or shelf.

Reward, `reward_type="sparse"` (the default): +1 on success, -1 on failure, 0 otherwise.

`reward_type="dense"`: a success bonus, a failure cost and potential-based shaping (Ng, Harada
& Russell 1999, "Policy invariance under reward transformations"):

    r = DENSE_SUCCESS_BONUS * success - DENSE_FAILURE_COST * failure + gamma * Phi(s') - Phi(s)

with Phi(s') = 0 when s' ends the episode (success or failure), and

    Phi(s) = -(REACH_WEIGHT * (1 - reach) + GRASP_WEIGHT * (1 - grasp) + GOAL_WEIGHT * (1 - goal))

from three progress terms, each in [0, 1] (the weights sum to 1, so -1 <= Phi <= 0):
- reach = exp(-d / REACH_SCALE), d the distance from the hand's TCP to the goal object's grasp
  point: its axis at `PUSH_HEIGHT` (the TCP is where a held object's axis sits,
  `herb.HAND_TCP_OFFSET`, so the palm is then beside the object);
- grasp = min(fingers touching the goal, 2) / 4 + held / 2;
- goal: lift tasks, held * min(lift / LIFT_HEIGHT, 1) (only a held object's lift counts: tilting
  an object also raises its base); the grasp objective, whether it is grasped; region tasks,
  1 - min(distance from the goal object's centre to the goal region / REGION_SCALE, 1).

Why: with the agent's own discount as `gamma` (the env keyword, default 0.99) the shaping leaves
the optimal policies unchanged, and with Phi = 0 at the end of an episode this holds in
episodic tasks too (Grzes 2017). With Phi <= 0 a step that changes nothing pays
(1 - gamma) * |Phi| >= 0, and N steps that do not end the episode return
gamma * Phi(s_N) - Phi(s_0) + (1 - gamma) * sum_{0<t<N} |Phi(s_t)| >= -1 + |Phi(s_0)|, while
failing at the first step returns -DENSE_FAILURE_COST + |Phi(s_0)|, lower by at least
DENSE_FAILURE_COST - 1 = 1 whatever the horizon: crashing at once is worse than any amount of
waiting (a cost of 0.1 x the distance per step would pay a crash better than
waiting, and PPO learns to crash under it). A success ends with
DENSE_SUCCESS_BONUS + |Phi(s)| > 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from clutter_gym.model.objects import ObjectSpec
from clutter_gym.model.reachability import PUSH_HEIGHT
from clutter_gym.model.scene import Scene
from clutter_gym.model.transforms import tilt_of_quaternion, yaw_of_quaternion
from clutter_gym.model.world import Surface
from clutter_gym.sim.robot import Herb
from clutter_gym.sim.simulator import Simulator

LIFT_HEIGHT = 0.10
TOPPLE_ANGLE = np.deg2rad(45.0)
FELL_DEPTH = 0.05
SUCCESS_REWARD = 1.0
FAILURE_REWARD = -1.0
DENSE_SUCCESS_BONUS = 1.0
DENSE_FAILURE_COST = 2.0
"""More than the largest |Phi| (1): a failure never pays back the potential it forfeits."""
REACH_WEIGHT = GRASP_WEIGHT = GOAL_WEIGHT = 1.0 / 3.0
REACH_SCALE = 0.15
"""m: the reach term halves every 10 cm; the ready hand starts 0.1-0.5 m from the goal."""
REGION_SCALE = 0.30
"""m: a shelf's goal object starts at most ~0.3 m behind the front strip."""
RewardType = Literal["sparse", "dense"]
REWARD_TYPES: tuple[RewardType, ...] = ("sparse", "dense")
Objective = Literal["retrieve", "grasp"]
OBJECTIVES: tuple[Objective, ...] = ("retrieve", "grasp")
GRASP_TOLERANCE = 0.04
"""m between the TCP and the grasp point for a gripped object to count as grasped: the hand is
around it. Measured with a soda can: the hand closing with the TCP 0-3 cm short of its axis
wraps it; 5 cm short grips it between the fingertips only; 7 cm short flicks it away."""


@dataclass(frozen=True)
class Outcome:
    success: bool
    failure: str  # "" when nothing failed; otherwise a short reason naming the object
    goal_held: bool
    goal_gripped: bool  # two fingers on it, nothing but the robot and the surface touching it
    goal_lift: float  # metres above the goal object's initial height
    fingers: int  # fingers touching the goal object
    poses: np.ndarray  # true planar poses (N, 3) of the scene's objects, as judged
    goal_position: np.ndarray  # (3,) the goal object's base frame (centre of its base)

    @property
    def done(self) -> bool:
        return self.success or bool(self.failure)


def lifted(height: ArrayLike, goal_height: ArrayLike) -> np.ndarray:
    """Whether a goal object's base height reaches the goal height: the one comparison behind
    the env's success and the GoalEnv's compute_reward, so both decide alike."""
    return np.asarray(height) >= np.asarray(goal_height)


def grasped(offset: ArrayLike, target: ArrayLike, gripped: ArrayLike) -> np.ndarray:
    """Whether the goal object is grasped: gripped by two fingers (`RetrievalTask.grasp`),
    with the TCP's offset from the grasp point within `GRASP_TOLERANCE` of ``target`` (zero
    for the episode's own goal; vectorized over leading axes): the one test behind the grasp
    objective's success and the GoalEnv's compute_reward."""
    near = np.linalg.norm(np.asarray(offset) - np.asarray(target), axis=-1) <= GRASP_TOLERANCE
    return np.asarray(gripped, dtype=bool) & near


def shaping(before: float, after: float, done: bool, gamma: float) -> float:
    """gamma * Phi(s') - Phi(s), with Phi = 0 once the episode is over."""
    return gamma * (0.0 if done else after) - before


def reward(
    success: ArrayLike, failed: ArrayLike, shaped: ArrayLike, reward_type: RewardType
) -> np.ndarray:
    """The reward of transitions (vectorized): `shaped` is their `shaping` (dense only)."""
    success, failed = np.asarray(success, dtype=bool), np.asarray(failed, dtype=bool)
    if reward_type == "sparse":
        return np.where(success, SUCCESS_REWARD, np.where(failed, FAILURE_REWARD, 0.0))
    return (
        DENSE_SUCCESS_BONUS * success
        - DENSE_FAILURE_COST * failed
        + np.asarray(shaped, dtype=np.float64)
    )


class RetrievalTask:
    """Evaluates a scene in a simulator: holds the names and specs it needs, nothing else."""

    def __init__(
        self,
        sim: Simulator,
        herb: Herb,
        scene: Scene,
        surface: Surface,
        specs: dict[str, ObjectSpec],
        surface_body: str = "surface",
        objective: Objective = "retrieve",
    ) -> None:
        self.sim = sim
        self.herb = herb
        self.scene = scene
        self.surface = surface
        self.specs = specs
        self.surface_body = surface_body
        self.goal = scene.goal.object
        self.names = tuple(o.name for o in scene.objects)
        self._goal_index = self.names.index(self.goal)
        self.goal_start_z = float(sim.base_pose(self.goal)[0][2])
        self.goal_height = self.goal_start_z + LIFT_HEIGHT
        """z the goal object's base must reach (lift tasks)."""
        self._grasp_offset = np.array([0.0, 0.0, PUSH_HEIGHT])
        self.objective = objective

    def grasp_offset(self, goal_position: ArrayLike) -> np.ndarray:
        """The TCP's offset (3,) from the grasp point of the goal object standing with its base
        at ``goal_position``: its axis at grasp height (the TCP is where a held object's axis
        sits, `herb.HAND_TCP_OFFSET`)."""
        return self.herb.tcp_pose()[0] - (np.asarray(goal_position) + self._grasp_offset)

    def robot_strikes_surface(self) -> bool:
        return bool(self.sim.contacts(self.herb.name, self.surface_body))

    def grasp(self) -> tuple[int, bool, bool]:
        """Fingers touching the goal; whether it is gripped: two or more fingers touch it and
        nothing but the robot and the surface does; and whether it is held: gripped, and only
        the robot touches it."""
        goal_id, robot_id = self.sim.body(self.goal), self.herb.body_id
        touching, links = set(), set()
        for pt in self.sim.client.getContactPoints(bodyA=goal_id):
            other, link = (pt[2], pt[4]) if pt[1] == goal_id else (pt[1], pt[3])
            touching.add(other)
            if other == robot_id:
                links.add(link)
        fingers = sum(1 for f_links in self.herb.finger_links.values() if links & set(f_links))
        gripped = fingers >= 2 and touching <= {robot_id, self.sim.body(self.surface_body)}
        return fingers, gripped, gripped and touching == {robot_id}

    def evaluate(self) -> Outcome:
        positions, quaternions = self.sim.base_poses(self.names)
        fingers, gripped, held = self.grasp()
        failure = self._failure(held, positions, quaternions)
        goal_z = float(positions[self._goal_index, 2])
        if self.objective == "grasp":
            offset = self.grasp_offset(positions[self._goal_index])
            success = bool(grasped(offset, np.zeros(3), gripped))
        elif self.scene.goal.success == "lift":
            success = held and bool(lifted(goal_z, self.goal_height))
        else:
            success = self._in_region(positions[self._goal_index], quaternions[self._goal_index])
        yaws = [yaw_of_quaternion(q) for q in quaternions]
        return Outcome(
            success=success and not failure,
            failure=failure,
            goal_held=held,
            goal_gripped=gripped,
            goal_lift=goal_z - self.goal_start_z,
            fingers=fingers,
            poses=np.column_stack([positions[:, :2], yaws]),
            goal_position=positions[self._goal_index],
        )

    def potential(self, outcome: Outcome, tcp: np.ndarray) -> float:
        """Phi of the state `outcome` was judged on, with the TCP at `tcp` (module docstring)."""
        d = float(np.linalg.norm(tcp - (outcome.goal_position + self._grasp_offset)))
        reach = math.exp(-d / REACH_SCALE)
        grasp = min(outcome.fingers, 2) / 4.0 + 0.5 * outcome.goal_held
        if self.objective == "grasp":
            goal = float(outcome.success)
        elif self.scene.goal.success == "lift":
            goal = outcome.goal_held * min(max(outcome.goal_lift / LIFT_HEIGHT, 0.0), 1.0)
        else:
            goal = 1.0 - min(self._region_distance(outcome.goal_position) / REGION_SCALE, 1.0)
        return -(
            REACH_WEIGHT * (1.0 - reach) + GRASP_WEIGHT * (1.0 - grasp) + GOAL_WEIGHT * (1.0 - goal)
        )

    # --- helpers ----------------------------------------------------------------------------
    def _failure(self, goal_held: bool, positions: np.ndarray, quaternions: np.ndarray) -> str:
        if self.robot_strikes_surface():
            return f"robot struck the {self.surface.name}"
        x_min, x_max, y_min, y_max = self.surface.bounds
        for name, pos, quat in zip(self.names, positions, quaternions, strict=True):
            if name == self.goal and goal_held:
                continue  # a held object may be anywhere, at any tilt
            on_top = x_min <= pos[0] <= x_max and y_min <= pos[1] <= y_max
            if not on_top or pos[2] < self.surface.top_z - FELL_DEPTH:
                return f"{name} left the {self.surface.name}"
            if tilt_of_quaternion(quat) > TOPPLE_ANGLE:
                return f"{name} toppled"
        return ""

    def _region_distance(self, position: np.ndarray) -> float:
        """m from a point to the goal region (0 inside)."""
        (x_lo, x_hi), (y_lo, y_hi) = self.scene.goal.region
        dx = max(x_lo - position[0], 0.0, position[0] - x_hi)
        dy = max(y_lo - position[1], 0.0, position[1] - y_hi)
        return math.hypot(dx, dy)

    def _in_region(self, position: np.ndarray, quaternion: np.ndarray) -> bool:
        upright = tilt_of_quaternion(quaternion) < TOPPLE_ANGLE
        return bool(self._region_distance(position) == 0.0 and upright)
