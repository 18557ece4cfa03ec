"""The order in which actions try their candidates (§2.2.6): directions that hit the fewest
other objects first, then the most natural for the arm."""

from __future__ import annotations

import math

import numpy as np

from clutter_gym.model.collision import Volume
from planners.actions.context import PlanningContext


def corridor_hits(
    ctx: PlanningContext, name: str, start: np.ndarray, end: np.ndarray, width: float
) -> set[str]:
    """Objects other than ``name`` whose U overlaps a box swept from start to end (2D) at the
    hand's height: the paper's count of objects hit when the hand turns around the object."""
    with ctx.stats.timed("heuristics"):
        delta = end - start
        length = float(np.linalg.norm(delta))
        if length < 1e-9:
            return set()
        yaw = math.atan2(delta[1], delta[0])
        centre = np.r_[(start + end) / 2, ctx.surface.top_z + 0.10]
        corridor = Volume.of_box("corridor", centre, (length, width, 0.12), yaw)
        return {
            other
            for other in ctx.beliefs
            if other != name and corridor.intersects(ctx.uncertainty_volume(other))
        }


def base_heading(shoulder: np.ndarray, xy: np.ndarray) -> float:
    """Yaw of the line from the right shoulder to a point: the arm's most comfortable push."""
    d = xy - shoulder[:2]
    return math.atan2(d[1], d[0])


def headings(ctx: PlanningContext, base: float, step_deg: float) -> list[float]:
    """Headings every ``step_deg`` within ``max_heading_deg`` of ``base``, each direction once
    (at 180 degrees the two ends of the range are the same direction)."""
    step = math.radians(step_deg)
    limit = math.radians(ctx.settings.max_heading_deg) + 1e-9
    count = int(limit // step)
    ks = range(-count, count + 1)
    if 2 * count * step >= 2 * math.pi - 1e-9:
        ks = range(-count + 1, count + 1)
    return [base + k * step for k in ks]


def push_headings(
    ctx: PlanningContext,
    shoulder: np.ndarray,
    name: str,
    reach: float,
    avoid: Volume,
    step_deg: float | None = None,
) -> list[float]:
    """Push directions ordered by §2.2.6: fewest objects hit by the hand on its way in and by
    the object and fingers on their way on, then closest to the shoulder-object line. Hitting
    an object of avoidVol (which no candidate may penetrate) counts before any other hit.
    ``step_deg`` (default `PlannerSettings.heading_step_deg`) spaces them."""
    belief = ctx.beliefs[name]
    centre = belief.samples[0, :2]
    base = base_heading(shoulder, centre)
    footprint = belief.spec.footprint
    radius = footprint.bounding_radius
    fixed = avoid.labels
    candidates = headings(ctx, base, step_deg or ctx.settings.heading_step_deg)
    if footprint.shape == "box":
        # Square to the detected box's faces too: a narrow hand fits a box only along them.
        limit = math.radians(ctx.settings.max_heading_deg) + 1e-9
        for k in range(4):
            off = math.remainder(belief.detected[2] + k * math.pi / 2 - base, 2 * math.pi)
            if abs(off) <= limit and all(
                abs(math.remainder(base + off - h, 2 * math.pi)) > 1e-6 for h in candidates
            ):
                candidates.append(base + off)
    scored = []
    for h in candidates:
        v = np.array([math.cos(h), math.sin(h)])
        hits = corridor_hits(ctx, name, centre - (radius + 0.30) * v, centre, 2 * reach)
        # Where the object and the fingers go: pushing it into others is as bad.
        hits |= corridor_hits(ctx, name, centre, centre + (radius + 0.15) * v, 2 * reach)
        scored.append((len(hits & fixed), len(hits), abs(h - base), h))
    return [h for *_, h in sorted(scored)]


def sweep_directions(
    ctx: PlanningContext, shoulder: np.ndarray, name: str, step_deg: float | None = None
) -> list[tuple[float, int]]:
    """(sweep direction, handedness) pairs whose hand approach is within reach, ordered by the
    objects the swept object would run into, then by how natural the approach is. A box is
    also swept square to its detected faces: the hand's side then meets a face flat, where the
    sweep capture region holds the box longest, and a box turned off the direction grid would
    otherwise meet the hand at a corner. ``step_deg`` (default
    `PlannerSettings.sweep_step_deg`) spaces the directions."""
    belief = ctx.beliefs[name]
    centre = belief.samples[0, :2]
    base = base_heading(shoulder, centre)
    radius = belief.spec.footprint.bounding_radius
    limit = math.radians(ctx.settings.sweep_max_heading_deg) + 1e-9
    scored = []
    step = math.radians(step_deg or ctx.settings.sweep_step_deg)
    angles = [k * step for k in range(round(2 * math.pi / step))]
    if belief.spec.footprint.shape == "box":
        for k in range(4):
            square = (belief.detected[2] + k * math.pi / 2) % (2 * math.pi)
            if all(abs(math.remainder(square - a, 2 * math.pi)) > 1e-6 for a in angles):
                angles.append(square)
    for angle in angles:
        for handedness in (1, -1):
            approach = angle + handedness * math.pi / 2
            off = abs(math.remainder(approach - base, 2 * math.pi))
            if off > limit:
                continue
            v = np.array([math.cos(angle), math.sin(angle)])
            hits = corridor_hits(ctx, name, centre + radius * v, centre + 0.30 * v, 2 * radius)
            scored.append((len(hits), off, angle, handedness))
    return [(a, h) for _, _, a, h in sorted(scored)]
