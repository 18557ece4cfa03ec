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
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.push_simulation import Pusher, contacts

OVERLAP = 2e-3
"""m of planar overlap that counts: the 3D check pads nothing for objects, so 2 mm is real."""
SWEEP_STEP = 0.02
"""m between the hand poses tested along a straight push (finger and palm are wider)."""


def overlapped(
    ctx: PlanningContext, pusher: Pusher, frame: Frame2D, avoid: Volume, z: float
) -> str:
    """The first object of ``avoid`` (by name) one of whose uncertainty samples the hand's
    cross-section, placed in ``frame`` with the TCP at height ``z``, overlaps; or ""."""
    x0, x1, y0, y1 = pusher.bounds
    for name in sorted(avoid.labels):
        belief = ctx.beliefs.get(name)
        if belief is None or len(belief.spec.primitives) != 1:
            continue  # a stack of primitives (the dumbbell) is not one prism at every height
        if ctx.surface.top_z + belief.spec.height < z:
            continue
        local = frame.to_frame(belief.samples)
        r = belief.spec.footprint.bounding_radius
        near = (
            (local[:, 0] + r > x0) & (local[:, 0] - r < x1) & (local[:, 1] + r > y0)
            & (local[:, 1] - r < y1)
        )  # fmt: skip
        if not near.any():
            continue  # every sample's bounding circle is clear of the hand's bounding box
        gaps, _, _ = contacts(belief.spec.footprint, pusher, local[near])
        if float(np.min(gaps)) < -OVERLAP:
            return name
    return ""


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
    push passes through every pose of a shorter one, so this also rules out pushing further."""
    start, end = line
    blocker = overlapped(ctx, pusher, Frame2D((float(end[0]), float(end[1])), heading), avoid, z)
    if blocker:
        return f"the hand overlaps {blocker} where it stops"
    steps = max(1, math.ceil(float(np.linalg.norm(end - start)) / SWEEP_STEP))
    for t in np.linspace(0.0, 1.0, steps, endpoint=False):
        xy = start + t * (end - start)
        blocker = overlapped(ctx, pusher, Frame2D((float(xy[0]), float(xy[1])), heading), avoid, z)
        if blocker:
            return f"the hand sweeps through {blocker} on its way in"
    return ""
