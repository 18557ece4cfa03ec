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
from clutter_gym.model.transforms import Frame2D
from planners.actions.context import PlanningContext
from planners.push_simulation import PoseSets, Pusher, first_overlapped, swept
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


Facing = tuple[tuple[str, ...], PoseSets]
"""The objects the hand may meet at one heading, by name, and their samples (`_facing`)."""


def _blockers(pusher: Pusher, objects: Facing, shifts: np.ndarray) -> list[str]:
    """For each of the hand's poses, ``shifts`` (M, 2) from the origin of the objects' frame
    (the hand turned as that frame), the first object by name one of whose sample poses its
    cross-section overlaps, or "" (one compiled pass, `push_simulation.first_overlapped`: a
    pose's test ends at its first overlapping sample)."""
    names, poses = objects
    return [names[o] if o >= 0 else "" for o in first_overlapped(poses, pusher, shifts, OVERLAP)]


def _facing(ctx: PlanningContext, angle: float, handedness: int, avoid: Volume, z: float) -> Facing:
    """The samples of each relevant object in the frame at the world's origin turned to
    ``angle`` (as the planner keeps them for that heading), mirrored across its x for
    ``handedness`` -1 (a sweep with the hand's other side); packed once per plan."""
    key = (angle, handedness, avoid.labels, z)
    if key not in ctx.planar_objects:
        mirror = np.array([1.0, float(handedness), float(handedness)])
        relevant = _relevant(ctx, avoid, z)
        sets = [(b.spec.footprint, ctx.samples_facing(n, angle) * mirror) for n, b in relevant]
        ctx.planar_objects[key] = (tuple(n for n, _ in relevant), PoseSets.of(sets))
    return ctx.planar_objects[key]


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


def lines_overlapping(
    ctx: PlanningContext,
    pusher: Pusher,
    starts: np.ndarray,
    ends: np.ndarray,
    heading: float,
    avoid: Volume,
    z: float,
) -> list[tuple[str, str]]:
    """Why the hand moving straight from each of ``starts`` to ``ends`` (M, 2; hand_base
    positions) at ``heading`` cannot be collision-free, and the object it overlaps where it
    stops or on its way; ("", "") where it can. A longer push passes through every pose of a
    shorter one, so this also rules out pushing further. One compiled pass over every stop,
    then one per swept length over the ways in of the motions whose stop is clear: the
    push-grasp search asks this for every lateral offset of a direction and aperture."""
    with ctx.stats.timed("clearance"):
        starts, ends = (np.asarray(a, dtype=float).reshape(-1, 2) for a in (starts, ends))
        found = [("", "")] * len(ends)
        objects = _facing(ctx, heading, 1, avoid, z)
        if not objects[0]:  # no object the hand can meet at this height
            return found
        ways_in: dict[int, list[int]] = {}  # swept steps -> motions whose stop is clear
        lengths = (ends - starts) @ np.array([math.cos(heading), math.sin(heading)])
        for k, blocker in enumerate(_blockers(pusher, objects, _shifts(ends, heading))):
            if blocker:
                found[k] = (f"the hand overlaps {blocker} where it stops", blocker)
            elif lengths[k] > 0.0:
                ways_in.setdefault(_swept_steps(float(lengths[k])), []).append(k)
        for steps, ks in ways_in.items():
            on_way = _blockers(_swept(pusher, steps), objects, _shifts(starts[ks], heading))
            for k, blocker in zip(ks, on_way, strict=True):
                if blocker:
                    found[k] = (f"the hand sweeps through {blocker} on its way in", blocker)
        return found


def line_overlap(
    ctx: PlanningContext,
    pusher: Pusher,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    avoid: Volume,
    z: float,
) -> tuple[str, str]:
    """`lines_overlapping` of one motion."""
    return lines_overlapping(ctx, pusher, line[0], line[1], heading, avoid, z)[0]


SWEPT_RESOLUTION = 0.002
"""m: a push's length rounded up to this for its swept hand (cached: building one costs more
than testing against it); the same as `OVERLAP`, so the test stays sound."""


def _swept_steps(length: float) -> int:
    return math.ceil(length / SWEPT_RESOLUTION - 1e-9)


@functools.lru_cache(maxsize=4096)
def _swept(pusher: Pusher, steps: int) -> Pusher:
    return swept(pusher, steps * SWEPT_RESOLUTION)
