"""Retrieval task: when an episode succeeds or fails, and what it pays.

Success is physical: the goal object must be held by finger contact (at least two different
fingers touching it, nothing but the robot touching it) and lifted at least `LIFT_HEIGHT` above
where it started, or, for `success="region"` scenes (the shelf), its centre must lie inside the
goal region while it stands upright. No attach constraint is ever created.

Failure terminates the episode: an object topples (its axis tilts more than `TOPPLE_ANGLE`), an
object leaves the surface, or the robot touches the table or shelf.

Reward (`reward_type="sparse"`, the default): +1 on success, -1 on failure, 0 otherwise.
`reward_type="dense"` adds -`DENSE_DISTANCE_WEIGHT` x the distance (m) from the hand's TCP to the
goal object's true centre, every step: a shaping signal for low-level RL.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from clutter_gym.model.objects import ObjectSpec
from clutter_gym.model.scene import Scene
from clutter_gym.model.transforms import tilt_of_quaternion
from clutter_gym.model.world import Surface
from clutter_gym.sim.robot import Herb
from clutter_gym.sim.simulator import Simulator

LIFT_HEIGHT = 0.10
TOPPLE_ANGLE = np.deg2rad(45.0)
FELL_DEPTH = 0.05
DENSE_DISTANCE_WEIGHT = 0.1
SUCCESS_REWARD = 1.0
FAILURE_REWARD = -1.0

RewardType = Literal["sparse", "dense"]
REWARD_TYPES: tuple[RewardType, ...] = ("sparse", "dense")


@dataclass(frozen=True)
class Outcome:
    success: bool
    failure: str  # "" when nothing failed; otherwise a short reason naming the object
    goal_held: bool
    goal_lift: float  # metres above the goal object's initial height

    @property
    def done(self) -> bool:
        return self.success or bool(self.failure)


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
    ) -> None:
        self.sim = sim
        self.herb = herb
        self.scene = scene
        self.surface = surface
        self.specs = specs
        self.surface_body = surface_body
        self.goal = scene.goal.object
        self.goal_start_z = float(sim.base_pose(self.goal)[0][2])

    def robot_strikes_surface(self) -> bool:
        return bool(self.sim.contacts(self.herb.name, self.surface_body))

    def goal_held(self) -> bool:
        """Two or more fingers touch the goal, and only the robot touches it."""
        c = self.sim.client
        goal_id = self.sim.body(self.goal)
        touching = {
            pt[1] if pt[2] == goal_id else pt[2] for pt in c.getContactPoints(bodyA=goal_id)
        }
        if touching != {self.herb.body_id}:
            return False
        links = {pt[4] for pt in c.getContactPoints(goal_id, self.herb.body_id)}
        fingers = sum(1 for f_links in self.herb.finger_links.values() if links & set(f_links))
        return fingers >= 2

    def evaluate(self) -> Outcome:
        held = self.goal_held()
        failure = self._failure(held)
        lift = float(self.sim.base_pose(self.goal)[0][2]) - self.goal_start_z
        if self.scene.goal.success == "lift":
            success = held and lift >= LIFT_HEIGHT
        else:
            success = self._goal_in_region()
        return Outcome(
            success=success and not failure, failure=failure, goal_held=held, goal_lift=lift
        )

    def reward(self, outcome: Outcome, reward_type: RewardType) -> float:
        reward = SUCCESS_REWARD if outcome.success else FAILURE_REWARD if outcome.failure else 0.0
        if reward_type == "dense":
            tcp, _ = self.herb.tcp_pose()
            goal_pos, _ = self.sim.base_pose(self.goal)
            centre = goal_pos + np.array([0.0, 0.0, self.specs[self.goal].height / 2.0])
            reward -= DENSE_DISTANCE_WEIGHT * float(np.linalg.norm(tcp - centre))
        return reward

    # --- helpers ----------------------------------------------------------------------------
    def _failure(self, goal_held: bool) -> str:
        if self.robot_strikes_surface():
            return f"robot struck the {self.surface.name}"
        x_min, x_max, y_min, y_max = self.surface.bounds
        for placement in self.scene.objects:
            name = placement.name
            if name == self.goal and goal_held:
                continue  # a held object may be anywhere, at any tilt
            pos, quat = self.sim.base_pose(name)
            on_top = x_min <= pos[0] <= x_max and y_min <= pos[1] <= y_max
            if not on_top or pos[2] < self.surface.top_z - FELL_DEPTH:
                return f"{name} left the {self.surface.name}"
            if tilt_of_quaternion(quat) > TOPPLE_ANGLE:
                return f"{name} toppled"
        return ""

    def _goal_in_region(self) -> bool:
        pos, quat = self.sim.base_pose(self.goal)
        (x_lo, x_hi), (y_lo, y_hi) = self.scene.goal.region
        inside = x_lo <= pos[0] <= x_hi and y_lo <= pos[1] <= y_hi
        return bool(inside and tilt_of_quaternion(quat) < TOPPLE_ANGLE)
