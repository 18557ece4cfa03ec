"""The planner's resolution, budgets and statistics (the paper's "user defined step sizes",
§2.2.6)."""

from __future__ import annotations

import math
import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field


@dataclass(frozen=True)
class PlannerSettings:
    """Search resolution and budgets."""

    time_budget: float = 20.0  # s for the whole plan
    # Evaluations per GoTo request (collision checks; with a constraint, also its Jacobians):
    # about 1 s here, and a count, not seconds, so that plans do not depend on the machine's load.
    goto_evaluations: int = 5000
    # Evaluations per search of a reachability probe (`rearrange._Search._reachable`: may GoTo
    # reach a start at all?), fewer than a GoTo's: on shelf high scenes 0-49 (pushing, sigma2)
    # 723 of 759 such searches found no path, each spending its 5000 (142 s of the 682 s
    # planned), and 30 of the 36 that found one needed fewer than 1500.
    probe_evaluations: int = 1500
    heading_step_deg: float = 15.0
    # Push and grasp directions within this of the shoulder-object line: 180 is the paper's
    # v in [0, 2 pi) (§2.2.6); the reachability map prunes the ones the arm cannot reach.
    max_heading_deg: float = 180.0
    sweep_max: float = 0.55  # m
    sweep_step_deg: float = 30.0
    # Sweep approaches within this of the shoulder-object line: all around, so the hand may
    # come in from the side and sweep an object toward the robot (the map prunes the rest).
    sweep_max_heading_deg: float = 180.0
    # Candidates of one action a planning step searches below, counting only those the arm
    # can get to (`rearrange._Search._by_action`); the actions themselves yield all they find.
    candidates_per_action: int = 3
    # Push-grasps whose capture region holds at least this share of the belief (the chance
    # that it captures the true pose, `ObjectBelief.mass_draws`) are all tried before any that
    # holds less; 0 keeps the paper's order, in which holding the n samples is enough.
    preferred_mass: float = 0.95
    seed: int = 0
    # The point (x, y) the directions above are measured from: None for the right shoulder.
    # The end-effector demos (`agents.learning.demos`) give the ready pose's TCP: from there
    # a level hand can only turn a little on its way to the object.
    heading_origin: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name in (
            "goto_evaluations",
            "probe_evaluations",
            "heading_step_deg",
            "sweep_max",
            "sweep_step_deg",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"PlannerSettings.{name}: {value!r}; must be > 0")
        if not (math.isfinite(self.time_budget) and self.time_budget >= 0):
            raise ValueError(f"PlannerSettings.time_budget: {self.time_budget!r}; must be >= 0")
        if not 0.0 <= self.preferred_mass <= 1.0:
            raise ValueError(
                f"PlannerSettings.preferred_mass: {self.preferred_mass!r}; must be in [0, 1]"
            )
        if self.candidates_per_action < 1:
            raise ValueError(
                f"PlannerSettings.candidates_per_action: {self.candidates_per_action}; must be >= 1"
            )


@dataclass(frozen=True)
class StatsRecord:
    """A plan's statistics as they are reported (JSON: `dataclasses.asdict`)."""

    planning_steps: int
    actions_tried: int
    collision_checks: int
    ik_skipped: int
    seconds: dict[str, float]


@dataclass
class PlanStats:
    """What planning cost: steps (recursive calls), candidates tried, checks, time by part."""

    planning_steps: int = 0
    actions_tried: int = 0
    collision_checks: int = 0
    ik_skipped: int = 0  # IK solves the reachability map ruled out
    seconds: dict[str, float] = field(default_factory=lambda: defaultdict(float))
    # Time spent in blocks nested inside each open `timed` block, innermost last.
    _nested: list[float] = field(default_factory=list, repr=False)

    @contextmanager
    def timed(self, part: str) -> Iterator[None]:
        """Add the block's wall-clock time to ``seconds[part]``, less the time of the `timed`
        blocks nested in it: every second is counted once, in the innermost part, so the parts
        add up to at most the planning time."""
        began = time.perf_counter()
        self._nested.append(0.0)
        try:
            yield
        finally:
            elapsed = time.perf_counter() - began
            self.seconds[part] += elapsed - self._nested.pop()
            if self._nested:
                self._nested[-1] += elapsed

    def record(self) -> StatsRecord:
        return StatsRecord(
            self.planning_steps,
            self.actions_tried,
            self.collision_checks,
            self.ik_skipped,
            {k: round(v, 4) for k, v in sorted(self.seconds.items())},
        )

    def as_dict(self) -> dict[str, object]:
        return asdict(self.record())


class BudgetExceeded(Exception):
    """The plan's time budget ran out."""


class Budget:
    """The plan's wall-clock budget (the only one in seconds; GoTo is bounded by counts)."""

    def __init__(self, seconds: float) -> None:
        self.deadline = time.perf_counter() + seconds

    def remaining(self) -> float:
        return self.deadline - time.perf_counter()

    def check(self) -> None:
        """Raise BudgetExceeded once the budget is spent."""
        if self.remaining() <= 0:
            raise BudgetExceeded
