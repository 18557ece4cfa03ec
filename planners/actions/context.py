"""What one planning request shares: the beliefs and the world, the budget, statistics, the
failure log and caches. The arm (IK, collision checks, GoTo) is `planners.actions.arm.Arm`,
passed to the actions beside this."""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from clutter_gym.model.world import Region, Surface
from planners.actions.results import FailureLog
from planners.actions.settings import Budget, PlannerSettings, PlanStats
from planners.capture import CaptureRegion, SweepRegion, push_grasp_region, sweep_region
from planners.uncertainty import ObjectBelief

STABLE_MARGIN = 0.01  # m: in the shelf, the footprint stays this far inside the walls
TABLE_EDGE_MARGIN = 0.05  # m: on the table, the centre of mass stays this far from the edge


@cache
def _push_region(footprint: Footprint, aperture: float) -> CaptureRegion:
    return push_grasp_region(footprint, aperture)


@cache
def _sweep_region(footprint: Footprint) -> SweepRegion:
    return sweep_region(footprint)


class PlanningContext:
    """The beliefs U(o) of every object, the surface and goal region, and the request's
    settings, budget, statistics, failure log and caches."""

    def __init__(
        self,
        surface: Surface,
        beliefs: dict[str, ObjectBelief],
        settings: PlannerSettings,
        goal_region: Region,
        rng: np.random.Generator,
    ) -> None:
        self.surface = surface
        self.goal_region = goal_region
        self.beliefs = beliefs
        self.settings = settings
        self.rng = rng
        self.stats = PlanStats()
        self.budget = Budget(settings.time_budget)
        self.failures = FailureLog()
        self._volumes: dict[str, Volume] = {}

    def check_budget(self) -> None:
        self.budget.check()

    # -- geometry -----------------------------------------------------------------------------
    def uncertainty_volume(self, name: str) -> Volume:
        """Volume(i, U(i)), cached."""
        if name not in self._volumes:
            b = self.beliefs[name]
            self._volumes[name] = Volume.of_object(name, b.spec, b.samples, self.surface.top_z)
        return self._volumes[name]

    def objects_volume(self, names: Iterable[str]) -> Volume:
        """Sum of Volume(i, U(i)) over the named objects (the avoid volume)."""
        total = Volume()
        for name in sorted(names):
            total += self.uncertainty_volume(name)
        return total

    def stable(self, name: str, poses: np.ndarray) -> bool:
        """StablePoses: upright on the surface. On the open table the centre of mass must be
        over the top (an overhanging box stands); in the shelf the outline must be inside the
        walls."""
        footprint = self.beliefs[name].spec.footprint
        x0, x1, y0, y1 = self.surface.bounds
        p = np.asarray(poses).reshape(-1, 3)
        if self.surface.name == "table":
            m = TABLE_EDGE_MARGIN
            return bool(
                np.all((p[:, 0] > x0 + m) & (p[:, 0] < x1 - m))
                and np.all((p[:, 1] > y0 + m) & (p[:, 1] < y1 - m))
            )
        m = STABLE_MARGIN
        for pose in p:
            lo_x, hi_x, lo_y, hi_y = footprint.aabb(tuple(pose))
            if lo_x < x0 + m or hi_x > x1 - m or lo_y < y0 + m or hi_y > y1 - m:
                return False
        return True

    # -- capture regions ----------------------------------------------------------------------
    def push_region(self, footprint: Footprint, aperture: float) -> CaptureRegion:
        with self.stats.timed("capture"):
            return _push_region(footprint, aperture)

    def sweep_region(self, footprint: Footprint) -> SweepRegion:
        with self.stats.timed("capture"):
            return _sweep_region(footprint)
