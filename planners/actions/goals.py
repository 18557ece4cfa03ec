"""G: which final states of an object are acceptable (the goal argument of every action)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from clutter_gym.model.collision import Volume
from planners.actions.context import PlanningContext


class Goal(Protocol):
    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool: ...

    def clearly_accepts(self, ctx: PlanningContext, name: str, final: np.ndarray) -> bool:
        """A quick sufficient test of `accepts` for an object left standing at ``final``."""
        ...

    def describe(self) -> str: ...


@dataclass(frozen=True)
class Retrieve:
    """The goal object's G: grasped with every sample in the hand (then lifted or pulled out)."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        return held

    def clearly_accepts(self, ctx: PlanningContext, name: str, final: np.ndarray) -> bool:
        return False

    def describe(self) -> str:
        return "in the hand"


@dataclass(frozen=True)
class Anywhere:
    """Any final state: an action run with parameters chosen outside the planner
    (`planners.actions.primitives`), whose outcome physics decides."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        return True

    def clearly_accepts(self, ctx: PlanningContext, name: str, final: np.ndarray) -> bool:
        return True

    def describe(self) -> str:
        return "anywhere"


@dataclass(frozen=True)
class AwayFrom:
    """StablePoses(o) - NGR: standing on the surface, clear of the negative goal region."""

    ngr: Volume

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        with ctx.stats.timed("goal"):
            return self._accepts(ctx, name, final, held)

    def _accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        if held or not ctx.stays_stable(name, final):
            return False
        near = self._near(ctx, name, final)
        if not near.any():
            return True
        spec = ctx.beliefs[name].spec
        placed = Volume.of_object(name, spec, final[near], ctx.surface.top_z)
        # The hull of the poses near the NGR contains them all: clear hull, clear poses. One
        # convex shape is far cheaper for the broad phase than a hundred overlapping boxes.
        if not placed.hulled().intersects(self.ngr):
            return True
        return not placed.intersects(self.ngr)

    def clearly_accepts(self, ctx: PlanningContext, name: str, final: np.ndarray) -> bool:
        """A quick sufficient test: stable, and every pose's axis-aligned bounds clear the
        NGR in the top-view map (no exact geometry)."""
        with ctx.stats.timed("goal"):
            return ctx.stays_stable(name, final) and not self._near(ctx, name, final).any()

    def _near(self, ctx: PlanningContext, name: str, final: np.ndarray) -> np.ndarray:
        spec = ctx.beliefs[name].spec
        boxes = spec.footprint.aabbs(final)
        return self.ngr.lowest_over(boxes) <= ctx.surface.top_z + spec.height

    def describe(self) -> str:
        return "out of the negative goal region"
