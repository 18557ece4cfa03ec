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

import gc
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from clutter_gym.model import collision
from clutter_gym.model.collision import Volume
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.world import Region, Surface
from planners import push_simulation
from planners.actions import ACTIONS, CAN_MOVE
from planners.actions.arm import Arm, IKSolver
from planners.actions.context import PlanningContext
from planners.actions.goals import AwayFrom, Goal, Retrieve
from planners.actions.results import ActionResult, Failure
from planners.actions.settings import BudgetExceeded, PlannerSettings, StatsRecord
from planners.goto import NO_PATH
from planners.kinds import planner_kind
from planners.uncertainty import ObjectBelief


@dataclass(frozen=True)
class PlanStep:
    """One manipulation in execution order: the approach from the robot's start (first step
    only), the action (tau_1, nu_o) and the transit to the next action's start (tau_2)."""

    result: ActionResult
    approach: Trajectory | None
    transit: Trajectory | None
    ngr: Volume  # the NGR this planning step had to keep out of (for figures)
    depth: int  # planning step: 0 for the goal's PickUp

    @property
    def trajectory(self) -> Trajectory:
        parts = [t for t in (self.approach, self.result.trajectory, self.transit) if t is not None]
        total = parts[0]
        for t in parts[1:]:
            total = total + t
        return total

    def summary(self) -> StepSummary:
        return StepSummary(
            self.result.action,
            self.result.obj,
            self.depth + 1,
            {k: round(v, 4) for k, v in self.result.details.items()},
        )


@dataclass(frozen=True)
class StepSummary:
    """A plan step as reported: the action's parameters flattened into the JSON object."""

    action: str
    obj: str
    planning_step: int
    details: dict[str, float]

    def as_dict(self) -> dict[str, Any]:
        return {
            "action": self.action,
            "object": self.obj,
            "planning_step": self.planning_step,
            **self.details,
        }


@dataclass(frozen=True)
class PlanSummary:
    """A plan as reported (`as_dict` gives its JSON object)."""

    success: bool
    reason: str
    planning_time_s: float
    actions: int
    objects_moved: list[str]
    steps: list[StepSummary]
    stats: StatsRecord
    blocked_by: list[str]

    def as_dict(self) -> dict[str, Any]:
        record = asdict(self)
        record["steps"] = [s.as_dict() for s in self.steps]
        return record


@dataclass
class Plan:
    """Rearrange's answer: the steps in execution order, or why there is none."""

    steps: list[PlanStep]
    success: bool
    reason: str
    planning_time: float
    stats: StatsRecord
    blocked_by: list[str] = field(default_factory=list)

    @property
    def objects_moved(self) -> list[str]:
        return [s.result.obj for s in self.steps if s.result.action != "pickup"]

    @property
    def trajectory(self) -> Trajectory:
        """The whole plan, from the robot's start to the goal lifted (or pulled out)."""
        if not self.steps:
            raise ValueError(f"the plan has no steps: {self.reason}")
        total = self.steps[0].trajectory
        for step in self.steps[1:]:
            total = total + step.trajectory
        return total

    def actions(self, waypoints: int) -> list[np.ndarray]:
        """The plan as env trajectory actions, each step cut into its own actions."""
        return [a for step in self.steps for a in step.trajectory.actions(waypoints)]

    def summary(self) -> PlanSummary:
        return PlanSummary(
            success=self.success,
            reason=self.reason,
            planning_time_s=round(self.planning_time, 4),
            actions=len(self.steps),
            objects_moved=self.objects_moved,
            steps=[s.summary() for s in self.steps],
            stats=self.stats,
            blocked_by=self.blocked_by,
        )


def plan_retrieval(
    surface: Surface,
    beliefs: list[ObjectBelief],
    goal: str,
    start_arm: np.ndarray,
    settings: PlannerSettings | None = None,
    goal_region: Region | None = None,
    planner: str = "pushing",
    ik: IKSolver | None = None,
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
    q0 = np.asarray(start_arm, dtype=float)
    if q0.shape != (7,) or not np.all(np.isfinite(q0)):
        raise ValueError(f"start_arm: {start_arm!r}; expected 7 finite joint angles")
    rng = np.random.default_rng(settings.seed)  # the TSR's draws
    collision.warm_up()  # the compiled kernels, before the budget starts
    push_simulation.warm_up()
    ctx = PlanningContext(
        surface,
        {b.name: b for b in beliefs},
        settings,
        goal_region or surface.default_goal_region,
        rng,
    )
    arm = Arm(surface, settings, ctx.stats, ctx.budget, ik)
    lower, upper = arm.kinematics.lower, arm.kinematics.upper
    if np.any(q0 < lower - 1e-6) or np.any(q0 > upper + 1e-6):
        raise ValueError("start_arm: outside the joint limits")
    began = time.perf_counter()
    search = _Search(ctx, arm, np.clip(q0, lower, upper), kind.actions)
    reason = ""
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
    with _scanning_only_the_plan():
        try:
            steps = search.retrieve(goal, others, fixed)
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
        stats=ctx.stats.record(),
        blocked_by=[] if steps is not None else ctx.failures.blockers(),
    )


@contextmanager
def _scanning_only_the_plan() -> Iterator[None]:
    """Keep the objects alive before the plan out of the collector's passes during it
    (`gc.freeze`, undone after): the plan's allocations set off full passes, and each would
    rescan every object the process holds (capture regions, maps, meshes, the caller's own),
    0.18 s with 178k objects in a 0.26 s PG plan. Left alone where the caller has frozen
    objects itself."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


NextStart = tuple[np.ndarray, HandCommand]
"""Where the next action starts: its first configuration and hand command."""

UNREACHABLE_START = (
    "to the next action's start: GoTo finds no path there from the robot's start with only "
    "avoidVol in the way"
)
UNREACHABLE_OWN_START = (
    "to its start (the elbow in the surface's interior): GoTo finds no path there from the "
    "robot's start with only avoidVol and the object in the way"
)


@dataclass(frozen=True)
class _Candidate:
    """An action's result with its transit (and its approach when it executes first), the
    trajectory both make, their volume and the objects it penetrates that must be moved first
    (besides those already to be moved)."""

    result: ActionResult
    transit: Trajectory | None
    approach: Trajectory | None
    tau: Trajectory
    volume: Volume
    penetrated: tuple[str, ...]


class _Search:
    def __init__(
        self, ctx: PlanningContext, arm: Arm, start_arm: np.ndarray, actions: tuple[str, ...]
    ) -> None:
        self.ctx = ctx
        self.arm = arm
        self.start_arm = start_arm
        self.actions = actions
        self.max_depth = 0  # objects a plan may move, one per planning step below the goal's
        # Next-action starts GoTo found no path to from the robot's start, each with the sets of
        # objects it avoided then (`_reachable`), and the (start, hand, avoid) already asked.
        self._unreachable: dict[tuple[bytes, HandCommand], list[frozenset[str]]] = {}
        self._probed: set[tuple[bytes, HandCommand, frozenset[str]]] = set()
        # GoTo from the robot's start to a first action's start, by (start, hand) (`_approach`).
        self._approaches: dict[tuple[bytes, HandCommand], tuple[np.ndarray | None, str]] = {}

    def retrieve(
        self, goal: str, others: tuple[str, ...], fixed: tuple[str, ...]
    ) -> list[PlanStep] | None:
        """Rearrange(goal, {in hand}, ...) in passes, shortest plans first (§2.2.6): moving
        nothing; moving one object, the one that blocked the goal's hand most often first, with
        every candidate avoiding all the others (so that an action's few candidates are ones
        such a plan can use; unrestricted, they may all need two objects moved); then iterative
        deepening on the number of objects moved, so that the budget is not spent deep under
        the first candidates (sweeps of sweeps) while a shorter plan waits under a later one.
        The caches make the repeated levels cheap."""
        movable = [n for n in others if n not in fixed]
        if movable:
            self.max_depth = 0
            steps = self.rearrange(goal, Retrieve(), Volume(), (), others, None, 0)
            if steps is not None:
                return steps
            self.max_depth = 1
            blocking = [n for n in self.ctx.failures.blocking(goal) if n in movable]
            for name in blocking + [n for n in movable if n not in blocking]:
                avoid = tuple(n for n in others if n != name)
                steps = self.rearrange(goal, Retrieve(), Volume(), (), avoid, None, 0)
                if steps is not None:
                    return steps
        # The one-move passes above hold every plan that moves one object (each candidate that
        # such a plan can use is among the first an action yields when the rest are avoided),
        # so deepening starts at two.
        for self.max_depth in range(2 if movable else 0, len(movable) + 1):
            steps = self.rearrange(goal, Retrieve(), Volume(), (), fixed, None, 0)
            if steps is not None:
                return steps
        return None

    def rearrange(
        self,
        o: str,
        goal: Goal,
        ngr: Volume,
        move: tuple[str, ...],
        avoid: tuple[str, ...],
        r_next: NextStart | None,
        depth: int,
    ) -> list[PlanStep] | None:
        """Algorithm 1. ``r_next`` is the next action's start (configuration, hand), or None
        for "anywhere" (the goal's PickUp ends the plan)."""
        ctx = self.ctx
        ctx.stats.planning_steps += 1
        ctx.check_budget()
        for action in self.actions:
            plan = self._by_action(action, o, goal, ngr, move, avoid, r_next, depth)
            if plan is not None:
                return plan
        return None

    def _by_action(
        self,
        action: str,
        o: str,
        goal: Goal,
        ngr: Volume,
        move: tuple[str, ...],
        avoid: tuple[str, ...],
        r_next: NextStart | None,
        depth: int,
    ) -> list[PlanStep] | None:
        """Rearrange's loop over one action's candidates, the first
        `PlannerSettings.candidates_per_action` of them that the arm can get to: a candidate
        whose transit or approach GoTo finds no path takes no slot, so that an action whose
        first results are out of the robot's way (on the shelf, often all three) still offers
        ones it can execute. A candidate that needs two or more objects moved first waits
        until the action has offered its others: one that needs a single object moved is a
        shorter plan to search (§2.2.6), and the wait costs only what the action would compute
        anyway if the first candidate failed."""
        ctx = self.ctx
        avoid_vol = ctx.objects_volume(avoid)
        deferred: list[_Candidate] = []
        slots = ctx.settings.candidates_per_action
        for outcome in ACTIONS[action](ctx, self.arm, o, goal, avoid_vol):
            if isinstance(outcome, Failure):
                ctx.failures.record(outcome)
                continue
            candidate = self._assess(outcome, o, move, avoid, avoid_vol, r_next)
            if candidate is None:
                continue
            slots -= 1
            if depth + len(move) + len(candidate.penetrated) > self.max_depth:
                pass  # a longer plan than this iteration allows (the empty move_next passes)
            elif len(candidate.penetrated) > 1:
                deferred.append(candidate)
            else:
                plan = self._descend(candidate, o, ngr, move, avoid, depth)
                if plan is not None:
                    return plan
            if slots == 0:
                break
        for candidate in sorted(deferred, key=lambda c: len(c.penetrated)):
            plan = self._descend(candidate, o, ngr, move, avoid, depth)
            if plan is not None:
                return plan
        return None

    def _assess(
        self,
        result: ActionResult,
        o: str,
        move: tuple[str, ...],
        avoid: tuple[str, ...],
        avoid_vol: Volume,
        r_next: NextStart | None,
    ) -> _Candidate | None:
        """One candidate's transit, FindPenetrated and, when it leaves nothing to move first
        (the plan's first action), its approach; None when the arm cannot get to its start
        at all (`_enterable`) or the transit or the approach finds no path."""
        ctx = self.ctx
        if not self._enterable(o, result.trajectory, avoid):
            return None
        transit = self._transit(o, result, avoid, avoid_vol, r_next)
        if r_next is not None and transit is None:
            return None
        tau = result.trajectory if transit is None else result.trajectory + transit
        others = sorted(set(ctx.beliefs) - {o} - set(avoid))
        vol = Volume()
        penetrated: set[str] = set()
        # Its volume is needed only to find what it penetrates and as the next NGR: never
        # when nothing else may be moved (the grasp planners avoid every other object).
        if others or move:
            with ctx.stats.timed("volumes"):
                spec = ctx.beliefs[o].spec
                vol = (
                    self.arm.volume(tau)
                    + Volume.of_object(o, spec, result.nu.reshape(-1, 3), ctx.surface.top_z)
                    + result.carried
                )
                if others:
                    penetrated = vol.penetrated(ctx.objects_volume(others))
        new = tuple(sorted(penetrated - set(move)))
        approach = None
        if not move and not new:
            approach = self._approach(tau)
            if approach is None:
                return None
        return _Candidate(result, transit, approach, tau, vol, new)

    def _enterable(self, o: str, trajectory: Trajectory, avoid: tuple[str, ...]) -> bool:
        """Whether the arm can get to where the action starts at all: when it gets there, the
        objects of avoidVol and ``o`` stand where they are now and the others stand elsewhere
        or where they are now, and every earlier configuration of the plan was reached from
        the robot's start, so a start GoTo cannot reach from there with only these objects
        in the way is one no plan can use. GoTo is asked (`_reachable`, once per start) only
        where the start has the elbow in an enclosed surface's interior (`Arm.elbow_inside`):
        on shelf high scenes 0-25 (pushing, sigma2) 82 of 84 such starts had no path there,
        and all 69 others had one. A candidate that needs other objects moved first is
        otherwise searched below (seconds: a whole sweep and push-grasp search of each) before
        the transit into its start finds no path."""
        q = trajectory.start
        if not self.arm.elbow_inside(q):
            return True
        key = (q.tobytes(), trajectory.segments[0].hand)
        if self._reachable(key, q, avoid + (o,)):
            return True
        self.ctx.failures.record(Failure(o, "goto", UNREACHABLE_OWN_START))
        return False

    def _descend(
        self,
        candidate: _Candidate,
        o: str,
        ngr: Volume,
        move: tuple[str, ...],
        avoid: tuple[str, ...],
        depth: int,
    ) -> list[PlanStep] | None:
        """The recursive calls that clear what the candidate penetrates (Algorithm 1), or the
        candidate with its approach when it penetrates nothing; None to try the next one."""
        result, transit, tau = candidate.result, candidate.transit, candidate.tau
        move_next = move + candidate.penetrated
        if not move_next:
            return [PlanStep(result, candidate.approach, transit, ngr, depth)]
        ngr_next = ngr + candidate.volume
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
        r_next: NextStart | None,
    ) -> Trajectory | None:
        """tau_2: GoTo from the action's end to the next action's start, clear of avoidVol and
        the object where it was left; touching no other object if possible."""
        if r_next is None:
            return None
        ctx = self.ctx
        q_next, hand = r_next
        key = (q_next.tobytes(), hand)
        if self._known_unreachable(key, frozenset(avoid)):
            ctx.failures.record(Failure(o, "goto", UNREACHABLE_START))
            return None
        placed = avoid_vol + Volume.of_object(
            o, ctx.beliefs[o].spec, result.nu[-1], ctx.surface.top_z
        )
        others = ctx.objects_volume(set(ctx.beliefs) - {o} - set(avoid))
        path, reason = self.arm.goto(result.trajectory.end, q_next, placed + others, hand)
        if path is None and reason.startswith(NO_PATH) and not self._reachable(key, q_next, avoid):
            ctx.failures.record(Failure(o, "goto", UNREACHABLE_START))
            return None
        if path is None:
            path, reason = self.arm.goto(result.trajectory.end, q_next, placed, hand)
        if path is None:
            ctx.failures.record(Failure(o, "goto", f"to the next action's start: {reason}"))
            return None
        return Trajectory((Segment("transit", path, hand),))

    def _reachable(
        self, key: tuple[bytes, HandCommand], q_next: np.ndarray, avoid: tuple[str, ...]
    ) -> bool:
        """After a transit found no path: whether GoTo reaches the next action's start from the
        robot's start with only avoidVol in the way, asked once per (start, hand, avoid).
        Every transit into that start has avoidVol, and more, in its way: where even this
        GoTo finds no path (measured on the shelf: the searches that fail there grow no tree
        from that start at all), no transit into it whose avoid holds these objects is
        planned (two GoTos of up to three searches of 5000 evaluations each). The probe's
        own searches stop at the settings' `probe_evaluations`: nearly all of them find
        nothing, and a start reached only by a longer search is given up."""
        avoided = frozenset(avoid)
        if (*key, avoided) not in self._probed:
            self._probed.add((*key, avoided))
            path, reason = self.arm.goto(
                self.start_arm,
                q_next,
                self.ctx.objects_volume(avoid),
                key[1],
                self.ctx.settings.probe_evaluations,
            )
            if path is None and reason.startswith(NO_PATH):
                self._unreachable.setdefault(key, []).append(avoided)
        return not self._known_unreachable(key, avoided)

    def _known_unreachable(self, key: tuple[bytes, HandCommand], avoid: frozenset[str]) -> bool:
        """Whether GoTo found no path to this start among a subset of ``avoid`` alone."""
        return any(s <= avoid for s in self._unreachable.get(key, ()))

    def _approach(self, tau: Trajectory) -> Trajectory | None:
        """GoTo from the robot's start to the first action, every object where it is now:
        the same request whatever the plan above it, so each is planned once (the deepening
        passes offer the same first actions again)."""
        ctx = self.ctx
        hand = tau.segments[0].hand
        key = (tau.start.tobytes(), hand)
        if key not in self._approaches:
            self._approaches[key] = self.arm.goto(
                self.start_arm, tau.start, ctx.objects_volume(ctx.beliefs), hand
            )
        path, reason = self._approaches[key]
        if path is None:
            ctx.failures.record(Failure("robot", "goto", f"from the start configuration: {reason}"))
            return None
        return Trajectory((Segment("approach", path, hand),))
