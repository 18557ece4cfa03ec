"""G: which final states of an object are acceptable (the goal argument of every action)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from clutter_gym.model.collision import Volume
from planners.actions.context import PlanningContext


class Goal(Protocol):
    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool: ...

    def clearly_accepts_each(
        self, ctx: PlanningContext, name: str, finals: np.ndarray
    ) -> np.ndarray:
        """A quick sufficient test of `accepts` for an object left standing at each of K final
        states (K, M, 3), all at once."""
        ...

    def describe(self) -> str: ...


@dataclass(frozen=True)
class Retrieve:
    """The goal object's G: grasped with every sample in the hand (then lifted or pulled out)."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        return held

    def clearly_accepts_each(
        self, ctx: PlanningContext, name: str, finals: np.ndarray
    ) -> np.ndarray:
        return np.zeros(len(finals), dtype=bool)

    def describe(self) -> str:
        return "in the hand"


@dataclass(frozen=True)
class Anywhere:
    """Any final state: an action run with parameters chosen outside the planner
    (`planners.actions.primitives`), whose outcome physics decides."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        return True

    def clearly_accepts_each(
        self, ctx: PlanningContext, name: str, finals: np.ndarray
    ) -> np.ndarray:
        return np.ones(len(finals), dtype=bool)

    def describe(self) -> str:
        return "anywhere"


SINGLE_POSE_TESTS = 4
"""Poses an exact NGR test tries one at a time, lowest NGR over them first, before all at once."""


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
        spec = ctx.beliefs[name].spec
        top_z = ctx.surface.top_z
        lowest = self._lowest_over(ctx, name, final)
        near = lowest <= top_z + spec.height
        if not near.any():
            return True
        # Most final states tested this near the NGR meet it, and one pose under its lowest
        # parts finds the hit about seven times faster than all poses at once (whose broad
        # phase first visits many pairs of overlapping bounds that do not touch).
        order = np.flatnonzero(near)[np.argsort(lowest[near], kind="stable")]
        for k in order[:SINGLE_POSE_TESTS]:
            if Volume.of_object(name, spec, final[k], top_z).intersects(self.ngr):
                return False
        placed = Volume.of_object(name, spec, final[near], top_z)
        # The hull of the poses near the NGR contains them all: clear hull, clear poses. One
        # convex shape is far cheaper for the broad phase than a hundred overlapping boxes.
        if not placed.hulled().intersects(self.ngr):
            return True
        return not placed.intersects(self.ngr)

    def clearly_accepts_each(
        self, ctx: PlanningContext, name: str, finals: np.ndarray
    ) -> np.ndarray:
        """A quick sufficient test for each of K final states (K, M, 3): stable, and every
        pose's axis-aligned bounds clear the NGR in the top-view map (no exact geometry)."""
        with ctx.stats.timed("goal"):
            spec = ctx.beliefs[name].spec
            boxes = spec.footprint.aabbs(finals.reshape(-1, 3)).reshape(len(finals), -1, 4)
            clear = self.ngr.clear_above(boxes, ctx.surface.top_z + spec.height)
            return np.asarray(clear & ctx.stays_stable_each(name, finals))

    def _lowest_over(self, ctx: PlanningContext, name: str, final: np.ndarray) -> np.ndarray:
        """The NGR's lowest point over each pose's axis-aligned bounds (inf: nothing over)."""
        return self.ngr.lowest_over(ctx.beliefs[name].spec.footprint.aabbs(final))

    def describe(self) -> str:
        return "out of the negative goal region"
