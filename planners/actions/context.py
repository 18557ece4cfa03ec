"""What one planning request shares: the beliefs and the world, the budget, statistics, the
failure log and caches. The arm (IK, collision checks, GoTo) is `planners.actions.arm.Arm`,
passed to the actions beside this."""

from __future__ import annotations

from collections.abc import Hashable, Iterable
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from clutter_gym.model.collision import Volume, objects_overlap
from clutter_gym.model.objects import Footprint
from clutter_gym.model.transforms import Frame2D
from clutter_gym.model.world import Region, Surface
from planners.actions.results import Failure, FailureLog
from planners.actions.settings import Budget, PlannerSettings, PlanStats
from planners.capture import CaptureRegion, SweepRegion, push_grasp_region, sweep_region
from planners.uncertainty import ObjectBelief

if TYPE_CHECKING:
    from planners.actions.clearance import Facing
    from planners.actions.pick_and_place import GraspToPlace
    from planners.actions.push_grasp import BlockedHand, HandInSearch, PlannedPush
    from planners.actions.sweep import FirstStroke
    from planners.actions.sweep_evolution import SweepEvolution


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
        self._sums: dict[frozenset[str], Volume] = {}
        self._with_own: dict[tuple[int, str], tuple[Volume, Volume]] = {}
        #: Sweep evolutions simulated so far, by object and sweep frame (`SweepEvolution`).
        self.sweeps: dict[tuple[Hashable, ...], SweepEvolution] = {}
        #: First strokes of sweeps in two strokes by object, direction, placement and
        #: avoidVol (kept with it), or why there is none (`sweep._two_strokes_at`).
        self.first_strokes: dict[tuple[Hashable, ...], tuple[Volume, FirstStroke | Failure]] = {}
        #: Push-grasp evolutions nu_o (world poses) by object, heading, aperture and offset:
        #: a push is the same under every parent candidate that asks to move the object.
        self.pushes: dict[tuple[str, float, float, float], np.ndarray] = {}
        #: Rows of such an nu_o simulated before it, in the hand's frame: the detected pose's,
        #: then the extreme samples' (`push_grasp._push_at`), until nu_o takes them.
        self.push_pilots: dict[tuple[str, float, float, float], list[np.ndarray]] = {}
        #: Push-grasp hand motions by object, action, heading, aperture and avoidVol, with
        #: the failures met on the way (`push_grasp.HandInSearch`).
        self.hand_ins: dict[tuple[Hashable, ...], HandInSearch] = {}
        #: Push-grasps by object, heading and aperture, one per lateral offset (None where
        #: the capture region misses a sample): `push_grasp._plan_pushes`.
        self.push_plans: dict[tuple[str, float, float], list[PlannedPush | None]] = {}
        #: The belief mass each such push captures (`push_grasp._belief_masses`), by object,
        #: heading, aperture and offset.
        self.push_masses: dict[tuple[str, float, float, float], float] = {}
        #: Push-grasp hand motions (object, heading, aperture, offset) that an object of
        #: avoidVol blocked, with why: they fail again under every avoidVol that holds that
        #: object (`push_grasp._blocked_before`), whatever else it holds.
        self.blocked_hands: dict[tuple[str, float, float, float], BlockedHand] = {}
        #: Pick-and-place's close, lift and carries after a grasp, by the ids of the hand-in
        #: and avoidVol (`pick_and_place.GraspToPlace`): they never depend on G.
        self.grasps_to_place: dict[tuple[int, int], GraspToPlace] = {}
        self._facing: dict[tuple[str, float], np.ndarray] = {}
        #: The samples the planar hand test meets at a heading, by heading, handedness,
        #: avoidVol's labels and height (`clearance._facing`).
        self.planar_objects: dict[tuple[float, int, frozenset[str], float], Facing] = {}
        self._stable: dict[str, np.ndarray] = {}
        #: Upright carries out of the shelf that found no path (`hand_in.FAILED_CARRIES`).
        self.failed_carries = 0

    def check_budget(self) -> None:
        self.budget.check()

    # -- geometry -----------------------------------------------------------------------------
    def uncertainty_volume(self, name: str) -> Volume:
        """Volume(i, U(i)), cached."""
        if name not in self._volumes:
            b = self.beliefs[name]
            self._volumes[name] = Volume.of_object(name, b.spec, b.samples, self.surface.top_z)
        return self._volumes[name]

    def meets_samples(self, name: str, poses: np.ndarray, others: Iterable[str]) -> bool:
        """Whether object ``name`` standing at any of ``poses`` (N, 3) penetrates a sample of
        one of ``others``: in the plane and in height (`collision.objects_overlap`), fcl's
        answer without placing an fcl shape per pose (nu_o and the placement search hold
        hundreds to thousands of poses)."""
        spec = self.beliefs[name].spec
        return any(
            objects_overlap(spec, poses, self.beliefs[o].spec, self.beliefs[o].samples)
            for o in others
        )

    def sweeps_into(self, name: str, poses: np.ndarray, avoid: Volume) -> bool:
        """Whether object ``name`` standing at any of ``poses`` (N, 3) penetrates ``avoid``:
        `meets_samples` where ``avoid`` is the samples of named objects (`objects_volume`:
        avoidVol in Rearrange), fcl for any other volume."""
        labels = avoid.labels
        if self._sums.get(labels) is avoid:  # `objects_volume(labels)` itself
            return self.meets_samples(name, poses, sorted(labels))
        spec = self.beliefs[name].spec
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        return Volume.of_object(name, spec, poses, self.surface.top_z).intersects(avoid)

    def samples_facing(self, name: str, heading: float) -> np.ndarray:
        """U(name) in the frame at the world's origin whose x axis points along ``heading``
        (cached): a hand moving along that heading tests its poses against these, shifted by
        its own position, and the planner tries each heading with many offsets and apertures."""
        key = (name, heading)
        if key not in self._facing:
            self._facing[key] = Frame2D((0.0, 0.0), heading).to_frame(self.beliefs[name].samples)
        return self._facing[key]

    def objects_volume(self, names: Iterable[str]) -> Volume:
        """Sum of Volume(i, U(i)) over the named objects (the avoid volume), cached per set of
        names, so that its convex hulls (`Volume.hulled`, for the arm's checks) are built once."""
        key = frozenset(names)
        if key not in self._sums:
            total = Volume()
            for name in sorted(key):
                total += self.uncertainty_volume(name)
            self._sums[key] = total
        return self._sums[key]

    def with_own_samples(self, avoid: Volume, name: str) -> Volume:
        """avoidVol plus U(name) (cached per avoidVol and object): what the arm must clear
        where an action on ``name`` starts, before the hand touches it. The approach or
        transit that brings the arm there sees the object standing where it was detected."""
        key = (id(avoid), name)
        if key not in self._with_own:
            # avoidVol is kept with the sum: its id stays its own while the entry lives.
            self._with_own[key] = (avoid, avoid + self.uncertainty_volume(name))
        return self._with_own[key][1]

    def stable_mask(self, name: str, poses: np.ndarray) -> np.ndarray:
        """StablePoses, per pose: upright on the surface. On the open table the centre of mass
        must be over the top (an overhanging box stands); in the shelf the outline must be
        inside the walls."""
        footprint = self.beliefs[name].spec.footprint
        x0, x1, y0, y1 = self.surface.bounds
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        if self.surface.name == "table":
            m = TABLE_EDGE_MARGIN
            return np.asarray(
                (p[:, 0] > x0 + m) & (p[:, 0] < x1 - m) & (p[:, 1] > y0 + m) & (p[:, 1] < y1 - m)
            )
        m = STABLE_MARGIN
        boxes = footprint.aabbs(p)
        return np.asarray(
            (boxes[:, 0] >= x0 + m)
            & (boxes[:, 1] <= x1 - m)
            & (boxes[:, 2] >= y0 + m)
            & (boxes[:, 3] <= y1 - m)
        )

    def stays_stable(self, name: str, final: np.ndarray) -> bool:
        """StablePoses for an action's outcome: every sample of U(o) that stood stable before
        the action stands stable after it (``final`` holds one row per sample, or several such
        blocks, one per pushing parameter set). A sample that was already off (a sigma2 sample
        of a box overhanging the shelf front) is not the action's doing and does not veto it."""
        return bool(self.stays_stable_each(name, np.asarray(final).reshape(1, -1, 3))[0])

    def stays_stable_each(self, name: str, finals: np.ndarray) -> np.ndarray:
        """`stays_stable` for each of K outcomes (K, M, 3) at once."""
        before = self._stable_before(name)
        after = self.stable_mask(name, finals).reshape(len(finals), -1)
        if after.shape[1] % len(before):
            return np.asarray(after.all(1))
        return np.asarray(np.all(after | ~np.tile(before, after.shape[1] // len(before)), 1))

    def _stable_before(self, name: str) -> np.ndarray:
        """`stable_mask` of U(o) as detected, once per object (every outcome is tested
        against it)."""
        if name not in self._stable:
            self._stable[name] = self.stable_mask(name, self.beliefs[name].samples)
        return self._stable[name]

    # -- capture regions ----------------------------------------------------------------------
    def push_region(self, footprint: Footprint, aperture: float) -> CaptureRegion:
        with self.stats.timed("capture"):
            return _push_region(footprint, aperture)

    def sweep_region(self, footprint: Footprint) -> SweepRegion:
        with self.stats.timed("capture"):
            return _sweep_region(footprint)
