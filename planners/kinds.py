"""The planners of the paper's experiments by name: data only, so that the command line checks a
planner's name without importing the planners."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlannerKind:
    """A planner of the paper's experiments: Rearrange with an action library, and whether it
    may move other objects (Table 1's grasp planners may not)."""

    actions: tuple[str, ...]
    moves_obstacles: bool
    description: str


PLANNERS: dict[str, PlannerKind] = {
    "pushing": PlannerKind(
        ("push-grasp", "sweep", "static-grasp"),
        True,
        "Rearrange with the paper's action library: push-grasp, sweep, PickUp (of the goal "
        "and of obstacles) and GoTo",
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
