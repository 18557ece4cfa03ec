"""Rearrange (Dogar & Srinivasa, Algorithm 1): backward-chaining planning of pushes, sweeps and
pick-ups that retrieve a goal object from clutter under pose uncertainty.

Planning starts from the goal: the last action (PickUp of the goal object) is planned first. The
volume its robot trajectory and the object's uncertainty sweep is searched for other objects
(FindPenetrated); those must be moved first, out of the negative goal region (NGR) that all
later actions need, without disturbing the objects already planned for (``avoid``). Each
recursive call is one planning step; the loop over ``move`` searches orderings and an empty
result backtracks. Plans are monotone: each object is moved at most once.

Beyond the paper's listing, the action that executes first also needs a GoTo from the robot's
current configuration to its start with every object where it is now (the "approach"), and
transits prefer paths that touch no object at all before falling back to ``avoid`` only, which
keeps plans short (the paper's aim in §2.2.6).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from clutter_gym.robot.geometry import ArmGeometry, Hand
from clutter_gym.robot.kinematics import ArmKinematics
from clutter_gym.world import Surface
from planners.actions import (
    ACTIONS,
    CAN_MOVE,
    ActionResult,
    AwayFrom,
    BudgetExceeded,
    Goal,
    Motion,
    PlannerSettings,
    PlanningContext,
    Retrieve,
    Segment,
)
from planners.collision import RobotCollision, Volume
from planners.uncertainty import ObjectBelief

Region = tuple[tuple[float, float], tuple[float, float]]


@dataclass(frozen=True)
class PlannerKind:
    """A planner of the paper's experiments: Rearrange with an action library, and whether it
    may move other objects (Table 1's grasp planners may not)."""

    actions: tuple[str, ...]
    moves_obstacles: bool
    description: str


PLANNERS: dict[str, PlannerKind] = {
    "pushing": PlannerKind(
        ("push-grasp", "sweep"), True, "Rearrange with push-grasp, sweep and GoTo (the paper's)"
    ),
    "pick-and-place": PlannerKind(
        ("static-grasp",), True, "Rearrange with PickUp as a direct grasp and GoTo (§3.2.1)"
    ),
    "pg": PlannerKind(
        ("push-grasp",), False, "a push-grasp of the goal among fixed obstacles (Table 1 PG)"
    ),
    "tsr": PlannerKind(
        ("static-grasp",),
        False,
        "uncertainty TSR: a static hand pose that grasps every sample (Table 1 TSR)",
    ),
}


def planner_kind(name: str) -> PlannerKind:
    """The named planner; ValueError listing the valid names otherwise."""
    try:
        return PLANNERS[name]
    except KeyError:
        raise ValueError(f"planner: {name!r} is unknown; allowed: {', '.join(PLANNERS)}") from None


@dataclass(frozen=True)
class PlanStep:
    """One manipulation in execution order: the approach from the robot's start (first step
    only), the action (tau_1, nu_o) and the transit to the next action's start (tau_2)."""

    result: ActionResult
    approach: Motion | None
    transit: Motion | None
    ngr: Volume  # the NGR this planning step had to keep out of (for figures)
    depth: int  # planning step: 0 for the goal's PickUp

    @property
    def motion(self) -> Motion:
        parts = [m for m in (self.approach, self.result.motion, self.transit) if m is not None]
        total = parts[0]
        for m in parts[1:]:
            total = total + m
        return total

    def summary(self) -> dict[str, object]:
        return {
            "action": self.result.action,
            "object": self.result.obj,
            "planning_step": self.depth + 1,
            **{k: round(v, 4) for k, v in self.result.details.items()},
        }


@dataclass
class Plan:
    """Rearrange's answer: the steps in execution order, or why there is none."""

    steps: list[PlanStep]
    success: bool
    reason: str
    planning_time: float
    stats: dict[str, object] = field(default_factory=dict)
    blocked_by: list[str] = field(default_factory=list)

    @property
    def objects_moved(self) -> list[str]:
        return [s.result.obj for s in self.steps if s.result.action != "pickup"]

    def summary(self) -> dict[str, object]:
        return {
            "success": self.success,
            "reason": self.reason,
            "planning_time_s": round(self.planning_time, 4),
            "actions": len(self.steps),
            "objects_moved": self.objects_moved,
            "steps": [s.summary() for s in self.steps],
            "stats": self.stats,
            "blocked_by": self.blocked_by,
        }


def plan_retrieval(
    surface: Surface,
    beliefs: list[ObjectBelief],
    goal: str,
    start_arm: np.ndarray,
    settings: PlannerSettings | None = None,
    goal_region: Region | None = None,
    planner: str = "pushing",
) -> Plan:
    """Plan to retrieve ``goal`` with the named planner (`PLANNERS`):
    Rearrange(goal, {in hand}, {}, {}, {}, *).

    Bad input (no objects, an unknown goal or planner, a start outside the joint limits) raises
    ValueError naming the field; a request that simply has no plan returns ``success=False``
    with the reason and what blocked it.
    """
    settings = settings or PlannerSettings()
    kind = planner_kind(planner)
    names = [b.name for b in beliefs]
    if not beliefs:
        raise ValueError("objects: the scene is empty; there is nothing to retrieve")
    if goal not in names:
        raise ValueError(f"goal: {goal!r} is not in the scene; objects: {', '.join(names)}")
    kinematics = ArmKinematics("right")
    q0 = np.asarray(start_arm, dtype=float)
    if q0.shape != (7,) or not np.all(np.isfinite(q0)):
        raise ValueError(f"start_arm: {start_arm!r}; expected 7 finite joint angles")
    if np.any(q0 < kinematics.lower - 1e-6) or np.any(q0 > kinematics.upper + 1e-6):
        raise ValueError("start_arm: outside the joint limits")
    ctx = PlanningContext(
        surface,
        {b.name: b for b in beliefs},
        settings,
        kinematics,
        RobotCollision(kinematics, ArmGeometry()),
        goal_region or surface.default_goal_region,
    )
    began = time.perf_counter()
    search = _Search(ctx, np.clip(q0, kinematics.lower, kinematics.upper), kind.actions)
    reason = ""
    try:
        # Objects the planner may not or cannot move are avoided by every motion.
        fixed = tuple(
            sorted(
                b.name
                for b in beliefs
                if b.name != goal
                and not (kind.moves_obstacles and any(CAN_MOVE[a](b.spec) for a in kind.actions))
            )
        )
        others = tuple(sorted(set(names) - {goal}))
        steps = None
        if fixed != others:
            # A plan that moves nothing first (§2.2.6: short plans): the action generators
            # stop after a few candidates, and the first few may all need objects moved.
            steps = search.rearrange(goal, Retrieve(), Volume(), (), others, None, 0)
        if steps is None:
            steps = search.rearrange(goal, Retrieve(), Volume(), (), fixed, None, 0)
        if steps is None:
            reason = "no plan: every action for the goal object failed (see blocked_by)"
    except BudgetExceeded:
        steps = None
        reason = f"time budget of {settings.time_budget:g} s exhausted before a plan was found"
    elapsed = time.perf_counter() - began
    return Plan(
        steps=steps or [],
        success=steps is not None,
        reason=reason,
        planning_time=elapsed,
        stats=ctx.stats.as_dict(),
        blocked_by=[] if steps is not None else _blockers(ctx),
    )


def _blockers(ctx: PlanningContext) -> list[str]:
    """Why candidates failed, per (object, action), most frequent first."""
    counted = [
        (count, f"{action} {name}: {reason} ({count}x)")
        for (name, action), reasons in ctx.failures.items()
        for reason, count in reasons.items()
    ]
    return [line for _, line in sorted(counted, key=lambda item: -item[0])]


class _Search:
    def __init__(
        self, ctx: PlanningContext, start_arm: np.ndarray, actions: tuple[str, ...]
    ) -> None:
        self.ctx = ctx
        self.start_arm = start_arm
        self.actions = actions

    def rearrange(
        self,
        o: str,
        goal: Goal,
        ngr: Volume,
        move: tuple[str, ...],
        avoid: tuple[str, ...],
        r_next: tuple[np.ndarray, Hand] | None,
        depth: int,
    ) -> list[PlanStep] | None:
        """Algorithm 1. ``r_next`` is the next action's start (configuration, hand), or None
        for "anywhere" (the goal's PickUp ends the plan)."""
        ctx = self.ctx
        ctx.stats.planning_steps += 1
        ctx.check_budget()
        avoid_vol = ctx.objects_volume(avoid)
        spec = ctx.beliefs[o].spec
        for action in self.actions:
            for result in ACTIONS[action](ctx, o, goal, avoid_vol):
                transit = self._transit(o, result, avoid, avoid_vol, r_next)
                if r_next is not None and transit is None:
                    continue
                tau = result.motion if transit is None else result.motion + transit
                with ctx.timed("volumes"):
                    vol = (
                        tau.volume(ctx.robot)
                        + Volume.of_object(o, spec, result.nu.reshape(-1, 3), ctx.surface.top_z)
                        + result.carried
                    )
                    others = sorted(set(ctx.beliefs) - {o} - set(avoid))
                    penetrated = vol.penetrated(ctx.objects_volume(others))
                move_next = move + tuple(sorted(penetrated - set(move)))
                if not move_next:
                    approach = self._approach(tau)
                    if approach is None:
                        continue
                    return [PlanStep(result, approach, transit, ngr, depth)]
                ngr_next = ngr + vol
                avoid_next = avoid + (o,)
                start = (tau.start, tau.segments[0].hand)
                for i in move_next:
                    rest = tuple(m for m in move_next if m != i)
                    plan = self.rearrange(
                        i, AwayFrom(ngr_next), ngr_next, rest, avoid_next, start, depth + 1
                    )
                    if plan is not None:
                        return [*plan, PlanStep(result, None, transit, ngr, depth)]
        return None

    def _transit(
        self,
        o: str,
        result: ActionResult,
        avoid: tuple[str, ...],
        avoid_vol: Volume,
        r_next: tuple[np.ndarray, Hand] | None,
    ) -> Motion | None:
        """tau_2: GoTo from the action's end to the next action's start, clear of avoidVol and
        the object where it was left; touching no other object if possible."""
        if r_next is None:
            return None
        ctx = self.ctx
        q_next, hand = r_next
        placed = avoid_vol + Volume.of_object(
            o, ctx.beliefs[o].spec, result.nu[-1], ctx.surface.top_z
        )
        others = ctx.objects_volume(set(ctx.beliefs) - {o} - set(avoid))
        path, reason = ctx.goto(result.motion.end, q_next, placed + others, hand)
        if path is None:
            path, reason = ctx.goto(result.motion.end, q_next, placed, hand)
        if path is None:
            ctx.fail(o, "goto", f"to the next action's start: {reason}")
            return None
        return Motion((Segment("transit", path, hand),))

    def _approach(self, tau: Motion) -> Motion | None:
        """GoTo from the robot's start to the first action, every object where it is now."""
        ctx = self.ctx
        hand = tau.segments[0].hand
        path, reason = ctx.goto(self.start_arm, tau.start, ctx.objects_volume(ctx.beliefs), hand)
        if path is None:
            ctx.fail("robot", "goto", f"from the start configuration: {reason}")
            return None
        return Motion((Segment("approach", path, hand),))


def plan_rows(plan: Plan) -> np.ndarray:
    """The whole plan as (N, 9) env trajectory rows."""
    if not plan.steps:
        raise ValueError(f"the plan has no steps: {plan.reason}")
    return np.vstack([s.motion.rows() for s in plan.steps])


def chunk_rows(rows: np.ndarray, waypoints: int) -> list[np.ndarray]:
    """Rows split into env actions of ``waypoints`` rows, the last padded by holding still."""
    chunks = []
    for k in range(math.ceil(len(rows) / waypoints)):
        part = rows[k * waypoints : (k + 1) * waypoints]
        pad = np.repeat(part[-1:], waypoints - len(part), axis=0)
        chunks.append(np.vstack([part, pad]).astype(np.float32))
    return chunks
