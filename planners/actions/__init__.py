"""The action library of the framework (§2.1.6), each with the interface of Eq. 1:
``a(o, G, avoidVol) -> (tau, nu_o)`` or nothing.

Every action is a generator of candidates, best first by its heuristic, interleaved with typed
failures (`results`), so that Rearrange can backtrack into the next parametrisation when a later
check (the GoTo to the next action, a recursive call) fails, and can say what blocked a plan.
Every candidate satisfies the paper's two conditions: nu_o[1] is inside G for every uncertainty
sample, and Volume(robot, tau) and Volume(o, nu_o) are free of avoidVol.

* `push_grasp`: push-grasp, and PickUp of the goal (§2.2)
* `sweep`: the outer side of the hand pushes an obstacle out of the NGR (Fig. 7)
* `static_grasp`: a static grasp from the TSR; PickUp, or pick-and-place of an obstacle
* GoTo: `planners.goto` through `arm.Arm`
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import ObjectSpec
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import Goal
from planners.actions.push_grasp import push_grasp
from planners.actions.results import Outcome, unfit
from planners.actions.static_grasp import static_grasp
from planners.actions.sweep import sweep

Action = Callable[[PlanningContext, Arm, str, Goal, Volume], Iterator[Outcome]]

ACTIONS: dict[str, Action] = {
    "push-grasp": push_grasp,
    "sweep": sweep,
    "static-grasp": static_grasp,
}
"""The manipulation actions Rearrange searches, in the order it tries them."""

CAN_MOVE: dict[str, Callable[[ObjectSpec], bool]] = {
    "push-grasp": lambda spec: not unfit(spec, pushed=True, lifted=False),
    "sweep": lambda spec: spec.pushable,
    "static-grasp": lambda spec: not unfit(spec, pushed=False, lifted=True),
}
"""Which objects an action can move at all: the others are obstacles every motion avoids."""
