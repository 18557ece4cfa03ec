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

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.push_simulation import Pusher, overlaps, swept
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
    cross-section overlaps, or "". The poses of one object are tested in two batches: one
    sample at every pose of the hand first (in clutter most hand poses overlap every sample
    of a neighbour, and one decides it), then all samples where the hand is still free."""
    blockers = [""] * len(shifts)
    for name, footprint, local in objects:
        free = np.array([not b for b in blockers])
        for batch in (local[:1], local[1:]):
            open_ = np.flatnonzero(free)
            if not len(open_) or not len(batch):
                break
            hit = _overlapped(pusher, footprint, batch, shifts[open_])
            for k in open_[hit]:
                blockers[k] = name
            free[open_[hit]] = False
    return blockers


def _overlapped(
    pusher: Pusher, footprint: Footprint, local: np.ndarray, shifts: np.ndarray
) -> np.ndarray:
    """Whether the hand at each of ``shifts`` (M, 2) overlaps the object at any of ``local``
    (N, 3): (M,). All pairs near the hand's bounding box are tested in one batch."""
    x0, x1, y0, y1 = pusher.bounds
    r = footprint.bounding_radius
    x = local[None, :, 0] - shifts[:, None, 0]
    y = local[None, :, 1] - shifts[:, None, 1]
    near = (x + r > x0) & (x - r < x1) & (y + r > y0) & (y - r < y1)
    near_shift, near_sample = np.nonzero(near)
    hit = np.zeros(len(shifts), dtype=bool)
    if len(near_shift):  # else every sample's bounding circle is clear of the hand's box
        poses = local[near_sample].copy()
        poses[:, :2] -= shifts[near_shift]
        hit[near_shift[overlaps(footprint, pusher, poses, OVERLAP)]] = True
    return hit


def _near_band(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float, length: float
) -> list[tuple[str, Footprint, np.ndarray]]:
    """The samples of each relevant object, in ``frame``, whose bounding circle meets the band
    the hand's bounding box sweeps moving ``length`` along the frame's x."""
    x0, x1, y0, y1 = pusher.bounds
    # The samples as the planner keeps them for this heading, moved to the frame's origin (and
    # mirrored for a left-handed frame: a sweep with the hand's other side).
    right_handed = Frame2D(frame.origin, frame.angle)
    origin = np.array([*right_handed.to_frame(np.zeros((1, 3)))[0, :2], 0.0])
    mirror = np.array([1.0, float(frame.handedness), float(frame.handedness)])
    objects = []
    for name, belief in _relevant(ctx, avoid, z):
        footprint = belief.spec.footprint
        r = footprint.bounding_radius
        local = (ctx.samples_facing(name, frame.angle) + origin) * mirror
        near = (
            (local[:, 1] + r > y0)
            & (local[:, 1] - r < y1)
            & (local[:, 0] + r > x0)
            & (local[:, 0] - r < x1 + length)
        )
        if near.any():
            objects.append((name, footprint, local[near]))
    return objects


def overlapped(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float
) -> str:
    """The first object of ``avoid`` (by name) one of whose uncertainty samples the hand's
    cross-section, placed in ``frame`` with the TCP at height ``z``, overlaps; or ""."""
    with ctx.stats.timed("clearance"):
        objects = _near_band(ctx, pusher, frame, avoid, z, 0.0)
        return _blockers(pusher, objects, np.zeros((1, 2)))[0]


def stops_overlapping(
    ctx: PlanningContext, pusher: Pusher, ends: np.ndarray, heading: float, avoid: Volume, z: float
) -> list[str]:
    """`overlapped` for many hand_base positions ``ends`` (M, 2) at one ``heading``: the
    object each hand overlaps there, or "" (one batch per object: the push-grasp search asks
    this for every lateral offset of a direction and aperture at once)."""
    with ctx.stats.timed("clearance"):
        objects = [
            (name, belief.spec.footprint, ctx.samples_facing(name, heading))
            for name, belief in _relevant(ctx, avoid, z)
        ]
        frame = Frame2D((0.0, 0.0), heading)
        shifts = frame.to_frame(np.column_stack([ends, np.zeros(len(ends))]))[:, :2]
        return _blockers(pusher, objects, shifts)


def line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
) -> tuple[str, str]:
    """Why the hand moving straight along ``line`` (hand_base positions) at ``heading`` cannot
    be collision-free, and the object it overlaps where it stops or on its way; ("", "") if
    it can. A longer
    push passes through every pose of a shorter one, so this also rules out pushing further.
    The samples are placed in the motion's frame once, and only those near its band tested."""
    with ctx.stats.timed("clearance"):
        return _line_overlap(ctx, pusher, line, heading, avoid, z)


SWEPT_RESOLUTION = 0.002
"""m: a push's length rounded up to this for its swept hand (cached: building one costs more
than testing against it); the same as `OVERLAP`, so the test stays sound."""


def _swept(pusher: Pusher, length: float) -> Pusher:
    return _swept_steps(pusher, math.ceil(length / SWEPT_RESOLUTION - 1e-9))


@functools.lru_cache(maxsize=4096)
def _swept_steps(pusher: Pusher, steps: int) -> Pusher:
    return swept(pusher, steps * SWEPT_RESOLUTION)


def _line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
) -> tuple[str, str]:
    start, end = line
    frame = Frame2D((float(start[0]), float(start[1])), heading)
    length = float((end - start) @ np.array([math.cos(heading), math.sin(heading)]))
    objects = _near_band(ctx, pusher, frame, avoid, z, max(length, 0.0))
    if not objects:
        return "", ""
    # Where the hand stops first: most blocked candidates fail there, in one pose's test.
    (blocker,) = _blockers(pusher, objects, np.array([[length, 0.0]]))
    if blocker:
        return f"the hand overlaps {blocker} where it stops", blocker
    if length <= 0.0:
        return "", ""
    (blocker,) = _blockers(_swept(pusher, length), objects, np.zeros((1, 2)))
    if blocker:
        return f"the hand sweeps through {blocker} on its way in", blocker
    return "", ""
