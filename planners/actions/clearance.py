"""A planar test of the hand against the objects it must not touch, before any IK.

At a given stop or start pose the hand's shape is fixed, whatever arm configuration IK would
find, so if its cross-section at grasp height (`planners.hand2d`) overlaps a possible pose of an
object in avoidVol, no configuration is collision-free there. In cluttered scenes most failed
hand poses fail this way (the hand around the goal overlaps a neighbour); the 2D test answers it
in microseconds, where IK with its collision checks takes tens of milliseconds to say no.

The test is sound but not complete: it never refuses a pose that is free (a corner of a box
inside the hand, a vertex of the hand inside a box or a disc within reach are real overlaps),
and leaves the rest to IK's 3D checks.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.push_simulation import Pusher, overlapped_at, swept
from planners.uncertainty import ObjectBelief

OVERLAP = 2e-3
"""m of planar overlap that counts: the 3D check pads nothing for objects, so 2 mm is real."""


def _relevant(ctx: PlanningContext, avoid: Volume, z: float) -> list[tuple[str, ObjectBelief]]:
    """The objects of ``avoid`` (by name) the hand's cross-section at TCP height ``z`` can meet:
    one prism (a stack of primitives, the dumbbell, is not the same at every height) whose top
    is above ``z``."""
    found = []
    for name in sorted(avoid.labels):
        belief = ctx.beliefs.get(name)
        if belief is None or len(belief.spec.primitives) != 1:
            continue
        if ctx.surface.top_z + belief.spec.height >= z:
            found.append((name, belief))
    return found


def _blockers(
    pusher: Pusher, objects: list[tuple[str, Footprint, np.ndarray]], shifts: np.ndarray
) -> list[str]:
    """For each of the hand's poses, ``shifts`` (M, 2) from the origin of the objects' frame
    (the hand turned as that frame), the first object by name one of whose sample poses its
    cross-section overlaps, or "" (one compiled pass per object over the hand poses still
    free, `push_simulation.overlapped_at`: a pose's test ends at its first overlapping sample)."""
    blockers = [""] * len(shifts)
    free = np.ones(len(shifts), dtype=bool)
    for name, footprint, local in objects:
        if not free.any():
            break
        hit = overlapped_at(footprint, pusher, local, shifts, OVERLAP, free)
        for k in np.flatnonzero(hit):
            blockers[k] = name
        free &= ~hit
    return blockers


def _facing(
    ctx: PlanningContext, angle: float, handedness: int, avoid: Volume, z: float
) -> list[tuple[str, Footprint, np.ndarray]]:
    """The samples of each relevant object in the frame at the world's origin turned to
    ``angle`` (as the planner keeps them for that heading), mirrored across its x for
    ``handedness`` -1 (a sweep with the hand's other side)."""
    facing = [
        (name, belief.spec.footprint, ctx.samples_facing(name, angle))
        for name, belief in _relevant(ctx, avoid, z)
    ]
    if handedness > 0:
        return facing
    mirror = np.array([1.0, -1.0, -1.0])
    return [(name, footprint, local * mirror) for name, footprint, local in facing]


def _shifts(points: ArrayLike, angle: float, handedness: int = 1) -> np.ndarray:
    """Hand positions (M, 2) in `_facing`'s frame."""
    across = angle + math.pi / 2  # the axes of `Frame2D` at ``angle``, then mirrored
    axes = np.array([[math.cos(angle), math.cos(across)], [math.sin(angle), math.sin(across)]])
    return (np.asarray(points, dtype=float).reshape(-1, 2) @ axes) * [1.0, float(handedness)]


def overlapped(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float
) -> str:
    """The first object of ``avoid`` (by name) one of whose uncertainty samples the hand's
    cross-section, placed in ``frame`` with the TCP at height ``z``, overlaps; or ""."""
    with ctx.stats.timed("clearance"):
        objects = _facing(ctx, frame.angle, frame.handedness, avoid, z)
        return _blockers(pusher, objects, _shifts(frame.origin, frame.angle, frame.handedness))[0]


def stops_overlapping(
    ctx: PlanningContext, pusher: Pusher, ends: np.ndarray, heading: float, avoid: Volume, z: float
) -> list[str]:
    """`overlapped` for many hand_base positions ``ends`` (M, 2) at one ``heading``: the
    object each hand overlaps there, or "" (one pass per object: the push-grasp search asks
    this for every lateral offset of a direction and aperture at once)."""
    with ctx.stats.timed("clearance"):
        return _blockers(pusher, _facing(ctx, heading, 1, avoid, z), _shifts(ends, heading))


def line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
    stop_clear: bool = False,
) -> tuple[str, str]:
    """Why the hand moving straight along ``line`` (hand_base positions) at ``heading`` cannot
    be collision-free, and the object it overlaps where it stops or on its way; ("", "") if
    it can. A longer push passes through every pose of a shorter one, so this also rules out
    pushing further. ``stop_clear``: the caller has found the stop free
    (`stops_overlapping`), only the way in is tested."""
    with ctx.stats.timed("clearance"):
        start, end = line
        objects = _facing(ctx, heading, 1, avoid, z)
        if not objects:
            return "", ""
        if not stop_clear:  # most blocked candidates fail where the hand stops: one pose's test
            (blocker,) = _blockers(pusher, objects, _shifts(end, heading))
            if blocker:
                return f"the hand overlaps {blocker} where it stops", blocker
        length = float((end - start) @ np.array([math.cos(heading), math.sin(heading)]))
        if length <= 0.0:
            return "", ""
        (blocker,) = _blockers(_swept(pusher, length), objects, _shifts(start, heading))
        if blocker:
            return f"the hand sweeps through {blocker} on its way in", blocker
        return "", ""


SWEPT_RESOLUTION = 0.002
"""m: a push's length rounded up to this for its swept hand (cached: building one costs more
than testing against it); the same as `OVERLAP`, so the test stays sound."""


def _swept(pusher: Pusher, length: float) -> Pusher:
    return _swept_steps(pusher, math.ceil(length / SWEPT_RESOLUTION - 1e-9))


@functools.lru_cache(maxsize=4096)
def _swept_steps(pusher: Pusher, steps: int) -> Pusher:
    return swept(pusher, steps * SWEPT_RESOLUTION)
