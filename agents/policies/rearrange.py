"""The Rearrange planner as a Gymnasium policy: ``action = policy(obs)`` in trajectory mode.

At the first call it plans from the detected poses (open loop, as in the paper); then it returns
the plan's trajectories one env step at a time, each step up to ``waypoints`` rows of the env's
(K, 9) action. With ``closed_loop=True`` it replans from the new detection after every planned
action (the paper's future work). When there is no plan, ``failure`` says why and the policy
holds the arm still.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.observation import Observation, decode
from clutter_gym.model.trajectory import hold_action
from planners.actions.settings import PlannerSettings
from planners.kinds import planner_kind
from planners.rearrange import Plan, plan_retrieval
from planners.uncertainty import beliefs, sample_count


class RearrangePolicy:
    """Plans with Rearrange at the first observation and replays the plan, one env step at a
    time; `plan` holds the last plan (statistics, steps) and `failure` why planning failed."""

    def __init__(
        self,
        waypoints: int,
        planner: str = "pushing",
        settings: PlannerSettings | None = None,
        samples: int | None = None,
        closed_loop: bool = False,
        names: tuple[str, ...] | None = None,
        seed: int = 0,
    ) -> None:
        self.waypoints = waypoints
        planner_kind(planner)  # fail now on an unknown name, not at the first observation
        self.planner = planner
        self.settings = settings or PlannerSettings(seed=seed)
        self.samples = samples
        self.closed_loop = closed_loop
        self.names = names
        self.rng = np.random.default_rng(seed)
        self.plans: list[Plan] = []
        self.failure = ""
        self._queue: deque[np.ndarray] = deque()
        self._steps_left: deque[int] = deque()  # env steps per planned action, in order
        self._limits = ArmKinematics("right")

    @property
    def plan(self) -> Plan | None:
        return self.plans[-1] if self.plans else None

    def __call__(self, obs: Observation) -> np.ndarray:
        if not self._queue and not self.failure and (not self.plans or self.closed_loop):
            if not self.plans or not self.plans[-1].success or self._replan_due():
                self._plan(obs)
        if self._queue:
            self._steps_left[0] -= 1
            if self._steps_left[0] == 0:
                self._steps_left.popleft()
            return self._queue.popleft()
        seen = decode(obs)
        return hold_action(
            seen.arm, seen.hand, self.waypoints, self._limits.lower, self._limits.upper
        )

    def _replan_due(self) -> bool:
        # In closed loop every planned action is followed by a new plan, until the last one
        # (the goal's PickUp) has been sent.
        last = self.plans[-1]
        return len(last.steps) > 1

    def _plan(self, obs: Observation) -> None:
        seen = decode(obs, self.names)
        n = self.samples or sample_count(seen.sigma)
        detections = [(o.name, o.spec, o.detected) for o in seen.objects]
        plan = plan_retrieval(
            seen.surface,
            beliefs(detections, seen.sigma, n, self.rng),
            seen.goal,
            seen.arm,
            self.settings,
            seen.goal_region,
            self.planner,
        )
        self.plans.append(plan)
        if not plan.success:
            self.failure = plan.reason
            return
        self._enqueue(plan, first_only=self.closed_loop)

    def _enqueue(self, plan: Plan, first_only: bool = False) -> None:
        for step in plan.steps[:1] if first_only else plan.steps:
            actions = step.trajectory.actions(self.waypoints)
            self._queue.extend(actions)
            self._steps_left.append(len(actions))
