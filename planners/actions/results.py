"""What an action yields: candidates (tau, nu_o) of Eq. 1, or typed failures with a reason.

Every action is a generator of `ActionResult | Failure`, best candidate first: Rearrange tries
each result and records each failure (the account of what blocked a plan, `FailureLog`).
"""

from __future__ import annotations

from collections import Counter, defaultdict
from dataclasses import dataclass, field

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import ObjectSpec
from clutter_gym.model.trajectory import Trajectory


@dataclass(frozen=True)
class ActionResult:
    """(tau, nu_o) of Eq. 1 with what produced it."""

    action: str  # "push-grasp", "pickup", "sweep" or "pick-and-place"
    obj: str
    trajectory: Trajectory
    nu: np.ndarray  # (stages, M, 3) world poses of the samples; nu[0] = U(o), nu[-1] the end
    held: bool  # the object ends in the closed hand
    details: dict[str, float]
    carried: Volume = field(default_factory=Volume)  # a held object on its way (pick-and-place)


@dataclass(frozen=True)
class Failure:
    """A candidate (or a whole action) that failed for ``reason``, e.g. "no collision-free IK
    solution where the hand stops"."""

    obj: str
    action: str
    reason: str
    blocker: str = ""  # the object of avoidVol that the hand would hit, when one is named


Outcome = ActionResult | Failure


class FailureLog:
    """Why candidates failed, per (object, action): the planner's account of what blocked it."""

    def __init__(self) -> None:
        self._counts: dict[tuple[str, str], Counter[str]] = defaultdict(Counter)
        self._blockers: dict[str, Counter[str]] = defaultdict(Counter)

    def record(self, failure: Failure) -> None:
        self._counts[(failure.obj, failure.action)][failure.reason] += 1
        if failure.blocker:
            self._blockers[failure.obj][failure.blocker] += 1

    def blocking(self, name: str) -> list[str]:
        """The objects that blocked the hand in actions on ``name``, most often first."""
        return [b for b, _ in self._blockers[name].most_common()]

    def blockers(self) -> list[str]:
        """One line per reason, ``"<action> <object>: <reason> (<n>x)"``, most frequent first."""
        counted = [
            (count, f"{action} {name}: {reason} ({count}x)")
            for (name, action), reasons in self._counts.items()
            for reason, count in reasons.items()
        ]
        return [line for _, line in sorted(counted, key=lambda item: -item[0])]


def unfit(spec: ObjectSpec, pushed: bool, lifted: bool) -> str:
    """Why the hand cannot grasp the object (and push it, and lift it), or "" if it can."""
    if not spec.graspable:
        return "wider than the hand can hold"
    if pushed and not spec.pushable:
        return "tips over when pushed"
    if lifted and not spec.liftable:
        return "too heavy to lift"
    return ""
