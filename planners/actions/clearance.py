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

import math

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.push_simulation import Pusher, contacts
from planners.uncertainty import ObjectBelief

OVERLAP = 2e-3
"""m of planar overlap that counts: the 3D check pads nothing for objects, so 2 mm is real."""
SWEEP_STEP = 0.02
"""m between the hand poses tested along a straight push (finger and palm are wider)."""


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


def _first_overlap(
    pusher: Pusher, objects: list[tuple[str, Footprint, np.ndarray]], shift: float
) -> str:
    """The first object one of whose sample poses (in a frame along the hand's motion) the
    hand's cross-section, ``shift`` along that frame's x, overlaps; or ""."""
    x0, x1 = pusher.bounds[:2]  # the band already keeps to the hand's y range
    for name, footprint, local in objects:
        r = footprint.bounding_radius
        x = local[:, 0] - shift
        near = (x + r > x0) & (x - r < x1)
        if not near.any():
            continue  # every sample's bounding circle is clear of the hand's bounding box
        poses = local[near].copy()
        poses[:, 0] -= shift
        gaps, _, _ = contacts(footprint, pusher, poses)
        if float(np.min(gaps)) < -OVERLAP:
            return name
    return ""


def _near_band(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float, length: float
) -> list[tuple[str, Footprint, np.ndarray]]:
    """The samples of each relevant object, in ``frame``, whose bounding circle meets the band
    the hand's bounding box sweeps moving ``length`` along the frame's x."""
    x0, x1, y0, y1 = pusher.bounds
    objects = []
    for name, belief in _relevant(ctx, avoid, z):
        footprint = belief.spec.footprint
        r = footprint.bounding_radius
        local = frame.to_frame(belief.samples)
        near = (
            (local[:, 1] + r > y0) & (local[:, 1] - r < y1) & (local[:, 0] + r > x0)
            & (local[:, 0] - r < x1 + length)
        )  # fmt: skip
        if near.any():
            objects.append((name, footprint, local[near]))
    return objects


def overlapped(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float
) -> str:
    """The first object of ``avoid`` (by name) one of whose uncertainty samples the hand's
    cross-section, placed in ``frame`` with the TCP at height ``z``, overlaps; or ""."""
    with ctx.stats.timed("clearance"):
        return _first_overlap(pusher, _near_band(ctx, pusher, frame, avoid, z, 0.0), 0.0)


def line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
) -> str:
    """Why the hand moving straight along ``line`` (hand_base positions) at ``heading`` cannot
    be collision-free: an object it overlaps where it stops, or on its way; or "". A longer
    push passes through every pose of a shorter one, so this also rules out pushing further.
    The samples are placed in the motion's frame once, and only those near its band tested."""
    with ctx.stats.timed("clearance"):
        return _line_overlap(ctx, pusher, line, heading, avoid, z)


def _line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
) -> str:
    start, end = line
    frame = Frame2D((float(start[0]), float(start[1])), heading)
    length = float((end - start) @ np.array([math.cos(heading), math.sin(heading)]))
    objects = _near_band(ctx, pusher, frame, avoid, z, max(length, 0.0))
    if not objects:
        return ""
    blocker = _first_overlap(pusher, objects, length)
    if blocker:
        return f"the hand overlaps {blocker} where it stops"
    steps = max(1, math.ceil(abs(length) / SWEEP_STEP))
    for t in np.linspace(0.0, 1.0, steps, endpoint=False):
        blocker = _first_overlap(pusher, objects, float(t * length))
        if blocker:
            return f"the hand sweeps through {blocker} on its way in"
    return ""
