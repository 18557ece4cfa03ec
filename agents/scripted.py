"""Scripted policies: plan from the first observation, then emit one trajectory per step."""

from __future__ import annotations

import numpy as np

from clutter_gym.robot import herb_model as hm
from clutter_gym.robot.kinematics import ArmKinematics
from clutter_gym.world import Surface
from planners.collision import make_checker
from planners.direct_grasp import (
    PRESHAPE_CLOSURE,
    GraspRequest,
    PlanningError,
    plan_direct_grasp,
)


class DirectGraspPolicy:
    """`action = policy(obs)` for control_mode="trajectory": a direct side grasp of the goal.

    Plans once, from the detected goal pose of the first observation (open loop). If planning
    fails, `self.failure` holds the reason and the policy holds the arm still.
    """

    def __init__(self, waypoints: int, surface: Surface, seed: int = 0) -> None:
        self.kinematics = ArmKinematics("right")
        self.waypoints = waypoints
        self.surface_z = surface.top_z
        # Every IK solution is checked with fcl against the table or shelf and the arm itself.
        self.collision_free = make_checker(surface, {}).checker(
            hand=(0.0, PRESHAPE_CLOSURE), objects=False
        )
        self.rng = np.random.default_rng(seed)
        self._bounds = (
            np.r_[self.kinematics.lower, 0.0, 0.0],
            np.r_[self.kinematics.upper, 1.0, 1.0],
        )
        self.plan: np.ndarray | None = None
        self.failure = ""

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if self.plan is None and not self.failure:
            goal = int(obs["goal_object"])
            request = GraspRequest(
                pose=tuple(float(v) for v in obs["object_poses"][goal]),  # type: ignore[arg-type]
                height=float(obs["object_sizes"][goal][2]),
                surface_z=self.surface_z,
            )
            try:
                self.plan = plan_direct_grasp(
                    self.kinematics, request, self.waypoints, self.rng, self.collision_free
                )
                return self.plan
            except PlanningError as error:
                self.failure = str(error)
        spread = float(obs["hand"][0]) / hm.HAND_SPREAD_RANGE[1]
        closure = float(obs["hand"][1]) / hm.HAND_PROXIMAL_RANGE[1]
        hold = np.clip(np.r_[obs["arm_joints"], spread, closure], *self._bounds)
        return np.tile(hold, (self.waypoints, 1)).astype(np.float32)
