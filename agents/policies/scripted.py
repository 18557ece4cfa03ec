"""Scripted policies: plan from the first observation, then emit one trajectory per step."""

from __future__ import annotations

import numpy as np

from clutter_gym.model.collision import make_checker
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.observation import Observation, decode
from clutter_gym.model.trajectory import hold_action
from clutter_gym.model.world import Surface
from planners.direct_grasp import (
    PRESHAPE_CLOSURE,
    GraspRequest,
    PlanningError,
    plan_direct_grasp,
)


class DirectGraspPolicy:
    """`action = policy(obs)` in `ClutterRetrieve-v0` (one trajectory per step): a direct side
    grasp of the goal.

    Plans once, from the detected goal pose of the first observation (open loop). If planning
    fails, `self.failure` holds the reason and the policy holds the arm still.
    """

    def __init__(self, waypoints: int, surface: Surface) -> None:
        self.kinematics = ArmKinematics("right")
        self.waypoints = waypoints
        self.surface_z = surface.top_z
        # Every IK solution is checked with fcl against the table or shelf and the arm itself.
        self.collision_free = make_checker(surface, {}).checker(
            hand=HandCommand(0.0, PRESHAPE_CLOSURE), objects=False
        )
        self.plan: np.ndarray | None = None
        self.failure = ""

    def __call__(self, obs: Observation) -> np.ndarray:
        seen = decode(obs)
        if self.plan is None and not self.failure:
            goal = int(obs["goal_object"])
            request = GraspRequest(
                pose=seen.objects[goal].detected,
                height=seen.objects[goal].spec.height,
                surface_z=self.surface_z,
            )
            try:
                grasp = plan_direct_grasp(
                    self.kinematics, request, self.waypoints, self.collision_free
                )
            except PlanningError as error:
                self.failure = str(error)
            else:
                (self.plan,) = grasp.actions(self.waypoints)
                return self.plan
        lower, upper = self.kinematics.lower, self.kinematics.upper
        return hold_action(seen.arm, seen.hand, self.waypoints, lower, upper)
