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

from clutter_gym.env import OBJECT_KINDS
from clutter_gym.objects import get_object
from clutter_gym.robot import herb_model as hm
from clutter_gym.world import SURFACES, Surface
from planners.actions import PlannerSettings
from planners.rearrange import Plan, chunk_rows, plan_retrieval, planner_kind
from planners.uncertainty import ObjectBelief, sample_count, sample_poses


def beliefs_from_detection(
    obs: dict[str, np.ndarray],
    names: tuple[str, ...] | None,
    samples: int | None,
    rng: np.random.Generator,
) -> tuple[list[ObjectBelief], str, Surface, tuple[tuple[float, float], tuple[float, float]]]:
    """Beliefs of every object in an observation, the goal's name, the surface and goal region.
    Object names come from ``names`` (the env's ``info["object_names"]``) or are made up from
    the kind and slot."""
    sigma = (float(obs["noise"][0]), float(obs["noise"][1]))
    n = samples or sample_count(sigma)
    beliefs = []
    for slot in np.flatnonzero(obs["object_mask"]):
        kind = OBJECT_KINDS[int(obs["object_kinds"][slot]) - 1]
        name = names[slot] if names is not None else f"{kind}_{slot}"
        detected = np.asarray(obs["object_poses"][slot], dtype=float)
        beliefs.append(
            ObjectBelief(
                name,
                get_object(kind),
                (float(detected[0]), float(detected[1]), float(detected[2])),
                sample_poses(detected, sigma, n, rng),
            )
        )
    goal = beliefs[int(obs["goal_object"])].name
    surface = list(SURFACES.values())[int(obs["surface"])]
    x0, x1, y0, y1 = (float(v) for v in obs["goal_region"])
    return beliefs, goal, surface, ((x0, x1), (y0, y1))


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

    @property
    def plan(self) -> Plan | None:
        return self.plans[-1] if self.plans else None

    def use_plan(self, plan: Plan) -> None:
        """Replay a plan made elsewhere (e.g. once for many trials) instead of planning."""
        self.plans.append(plan)
        self._enqueue(plan)

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        if not self._queue and not self.failure and (not self.plans or self.closed_loop):
            if not self.plans or not self.plans[-1].success or self._replan_due():
                self._plan(obs)
        if self._queue:
            self._steps_left[0] -= 1
            if self._steps_left[0] == 0:
                self._steps_left.popleft()
            return self._queue.popleft()
        return self._hold(obs)

    def _replan_due(self) -> bool:
        # In closed loop every planned action is followed by a new plan, until the last one
        # (the goal's PickUp) has been sent.
        last = self.plans[-1]
        return len(last.steps) > 1

    def _plan(self, obs: dict[str, np.ndarray]) -> None:
        beliefs, goal, surface, region = beliefs_from_detection(
            obs, self.names, self.samples, self.rng
        )
        plan = plan_retrieval(
            surface,
            beliefs,
            goal,
            np.asarray(obs["arm_joints"], dtype=float),
            self.settings,
            region,
            self.planner,
        )
        self.plans.append(plan)
        if not plan.success:
            self.failure = plan.reason
            return
        self._enqueue(plan, first_only=self.closed_loop)

    def _enqueue(self, plan: Plan, first_only: bool = False) -> None:
        for step in plan.steps[:1] if first_only else plan.steps:
            chunks = chunk_rows(step.motion.rows(), self.waypoints)
            self._queue.extend(chunks)
            self._steps_left.append(len(chunks))

    def _hold(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        spread = float(np.clip(obs["hand"][0] / hm.HAND_SPREAD_RANGE[1], 0.0, 1.0))
        closure = float(np.clip(obs["hand"][1] / hm.HAND_PROXIMAL_RANGE[1], 0.0, 1.0))
        row = np.r_[obs["arm_joints"], spread, closure]
        return np.tile(row, (self.waypoints, 1)).astype(np.float32)
