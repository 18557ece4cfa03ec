"""`ClutterRetrieveEELift-v0`: the end-effector retrieval in which some episodes start with the
goal object already in the hand (the second stage of end-effector learning, docs/learning.md).

The lift task alone is hard to explore: the sparse reward pays only once the object is held and
raised, and random motions almost never close the hand around it. The original HER work started
some pick-and-place episodes with the object in the gripper; here a fraction ``grasped_start``
of the resets (or ``reset(options={"grasped": True})``) runs the project's side-grasp planner
(`planners.direct_grasp`) on the first detection of the goal and executes its approach and
closing in physics, under joint position control, before the first observation. The object is
then held by the fingers' friction alone, as in any other episode (never an attach
constraint): the policy must keep the hand closed and lift. Everything else, the observation,
goals, reward and success, is `ClutterRetrieveEE-v0`'s.

``info["start"]`` says how the episode began: "ready" (the ordinary start), "grasped" (two
fingers grip the goal object after the planned grasp) or "grasp failed" (no plan, or the
executed grasp does not grip it: the episode goes on from wherever physics left the arm).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from clutter_gym.env import ClutterRetrieveEEEnv
from clutter_gym.model.collision import make_checker
from clutter_gym.model.fields import invalid
from clutter_gym.model.herb import OPEN_HAND, HandCommand
from clutter_gym.model.objects import get_object
from clutter_gym.model.observation import Observation
from clutter_gym.sim.controllers import SegmentSpeed, TrajectoryController
from planners.actions.grasp_geometry import GRASP_CLOSURE
from planners.direct_grasp import PRESHAPE_CLOSURE, GraspRequest, PlanningError, plan_direct_grasp

GRASP_WAYPOINTS = 64
"""Rows allowed for the planned grasp (it needs about a dozen)."""
GRASP_SPEED = SegmentSpeed(0.05)
"""The approach at the trajectory env's quasi-static hand speed (m/s)."""
START_KINDS = ("ready", "grasped", "grasp failed")
LIFT_ENV_ID = "ClutterRetrieveEELift-v0"


class ClutterRetrieveLiftEnv(ClutterRetrieveEEEnv):
    """`ClutterRetrieveEE-v0` with a fraction ``grasped_start`` (in [0, 1]) of the episodes
    starting with the goal object gripped by a planned, physically executed side grasp."""

    def __init__(self, *args: Any, grasped_start: float = 0.5, **kwargs: Any) -> None:
        if not isinstance(grasped_start, int | float) or not 0.0 <= grasped_start <= 1.0:
            raise invalid("grasped_start", grasped_start, "a fraction of the episodes in [0, 1]")
        self.grasped_start = float(grasped_start)
        super().__init__(*args, **kwargs)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        rest = dict(options or {})
        grasped = rest.pop("grasped", None)
        if grasped is not None and not isinstance(grasped, bool | np.bool_):
            raise invalid("options['grasped']", grasped, "True, False or None (drawn)")
        obs, info = super().reset(seed=seed, options=rest)
        if grasped is None:
            grasped = bool(self.np_random.random() < self.grasped_start)
        if not grasped:
            return obs, {**info, "start": "ready"}
        start = self._grasp_goal(obs)
        # The episode starts here: a new first detection fixes the goals, a new potential.
        outcome, tcp = self._task.evaluate(), self.herb.tcp_pose()
        obs = self._observe(outcome, tcp)
        self._potential = self._task.potential(outcome, tcp[0])
        return obs, {**self._info(outcome, clipped=False, shaped=0.0), "start": start}

    def _grasp_goal(self, obs: Observation) -> str:
        """Plan a side grasp of the goal's detection and run its approach and closing."""
        x, y = (float(v) for v in obs["desired_goal"][:2])  # the first detection
        kinds = {o.name: o.kind for o in self.scene.objects}
        height = get_object(kinds[self.scene.goal.object]).height
        request = GraspRequest((x, y, 0.0), height, self.surface.top_z)
        free = make_checker(self.surface, {}).checker(
            hand=HandCommand(0.0, PRESHAPE_CLOSURE), objects=False
        )
        try:
            grasp = plan_direct_grasp(self.kinematics, request, GRASP_WAYPOINTS, free)
        except PlanningError:
            return "grasp failed"
        runner = TrajectoryController(
            self.herb, self.kinematics, GRASP_WAYPOINTS, GRASP_SPEED.hand, self.sim.timestep
        )
        runner.reset(OPEN_HAND)
        for segment in grasp.segments:
            if segment.label == "lift":
                break  # lifting is the policy's
            runner.run(segment.rows(), self._substep, GRASP_SPEED)
        runner.settle(self._substep)
        self._sim_steps = 0
        q, _ = self.herb.arm_state()
        self._controller = self._make_controller(q, HandCommand(0.0, GRASP_CLOSURE))
        _, gripped, _ = self._task.grasp()
        return "grasped" if gripped else "grasp failed"
