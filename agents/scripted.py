"""Scripted policies: plan from the first observation, then emit one trajectory per step."""

from __future__ import annotations

import numpy as np

from clutter_gym.robot.kinematics import ArmKinematics
from planners.direct_grasp import GraspRequest, PlanningError, plan_direct_grasp


class DirectGraspPolicy:
    """`action = policy(obs)` for control_mode="trajectory": a direct side grasp of the goal.

    Plans once, from the detected goal pose of the first observation (open loop). If planning
    fails, `self.failure` holds the reason and the policy holds the arm still.
    """

    def __init__(self, waypoints: int, surface_z: float, seed: int = 0) -> None:
        self.kinematics = ArmKinematics("right")
        self.waypoints = waypoints
        self.surface_z = surface_z
        self.rng = np.random.default_rng(seed)
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
                self.plan = plan_direct_grasp(self.kinematics, request, self.waypoints, self.rng)
                return self.plan
            except PlanningError as error:
                self.failure = str(error)
        hold = np.r_[obs["arm_joints"], 0.0, float(obs["hand"][1]) / 2.443]
        return np.tile(hold, (self.waypoints, 1)).astype(np.float32)
