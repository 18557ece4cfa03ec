"""A planar pusher (the hand's cross-section) moving through objects: contact detection and the
quasi-static simulation of many pushes at once (`simulate_push`), on the contact mechanics of
`planners.pushing`.

Each sample keeps its own clock, so samples far from the pusher jump ahead while only those in
contact pay for small steps; every step of every sample in contact is solved in one compiled
call (`planners.push_kernels`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from clutter_gym.model.objects import Footprint
from clutter_gym.model.transforms import rotation_2d
from planners import push_kernels, pushing
from planners.pushing import PATTERNS, positive


# --------------------------------------------------------------------------------------------
# Pusher geometry and contact detection
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Circle:
    """A disc of the pusher (a cylindrical fingertip seen from above)."""

    center: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        positive("Circle.radius", self.radius)


@dataclass(frozen=True)
class ConvexPolygon:
    """A convex polygon of the pusher, vertices counter-clockwise (a link or a palm face)."""

    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, float)
        if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3:
            raise ValueError(f"ConvexPolygon needs >= 3 vertices (k, 2), got shape {v.shape}")
        # Plain floats: a pusher of a few polygons is built for every new push length.
        k = len(self.vertices)
        for i in range(k):
            (ax, ay), (bx, by) = self.vertices[i - 1], self.vertices[i]
            cx, cy = self.vertices[(i + 1) % k]
            if (bx - ax) * (cy - by) - (by - ay) * (cx - bx) <= 0.0:
                raise ValueError(
                    "ConvexPolygon vertices must be strictly convex and counter-clockwise"
                )


def swept(pusher: Pusher, length: float) -> Pusher:
    """The region a pusher covers moving ``length`` (> 0) along +x, as a pusher: each convex
    polygon becomes the convex hull of it and its translate, each disc a capsule (a rectangle
    and the two end discs). One overlap test against it replaces tests along the motion."""
    shift = np.array([length, 0.0])
    polygons = []
    for p in pusher.polygons:
        polygons.append(
            ConvexPolygon(_hull([*p.vertices, *((x + length, y) for x, y in p.vertices)]))
        )
    circles = []
    for c in pusher.circles:
        start = np.asarray(c.center, float)
        polygons.append(rectangle(start, start + shift, c.radius))
        circles += [c, Circle((float(start[0] + length), float(start[1])), c.radius)]
    return Pusher(tuple(polygons), tuple(circles))


def _hull(points: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """The convex hull of a few points, counter-clockwise, without collinear vertices
    (Andrew's monotone chain: for the handful of vertices of a link and its translate it is
    about ten times faster than qhull, and `swept` runs for every new push length)."""
    ordered = sorted(set(points))

    def chain(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for x, y in seq:
            while len(out) >= 2:
                (ax, ay), (bx, by) = out[-2], out[-1]
                if (bx - ax) * (y - ay) - (by - ay) * (x - ax) > 0.0:
                    break
                out.pop()
            out.append((x, y))
        return out

    lower, upper = chain(ordered), chain(ordered[::-1])
    return tuple(lower[:-1] + upper[:-1])


def rectangle(p0: np.ndarray, p1: np.ndarray, half_width: float) -> ConvexPolygon:
    """The rectangle around segment p0-p1 with the given half-width (a finger link or a plate)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    side = half_width * np.array([-d[1], d[0]])
    corners = (p0 - side, p1 - side, p1 + side, p0 + side)
    return ConvexPolygon(tuple((float(x), float(y)) for x, y in corners))


@dataclass(frozen=True)
class Pusher:
    """A rigid 2D pusher made of convex shapes; it translates along +x of its own frame."""

    polygons: tuple[ConvexPolygon, ...]
    circles: tuple[Circle, ...] = ()

    @cached_property
    def _groups(self) -> list[np.ndarray]:
        """Polygon vertex arrays stacked by vertex count: one batched distance call per group."""
        by_k: dict[int, list[np.ndarray]] = {}
        for p in self.polygons:
            by_k.setdefault(len(p.vertices), []).append(np.asarray(p.vertices, float))
        return [np.stack(v) for v in by_k.values()]

    @cached_property
    def _circle_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.array([c.center for c in self.circles], float).reshape(-1, 2),
            np.array([c.radius for c in self.circles], float),
        )

    @cached_property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the pusher."""
        centers, radii = self._circle_arrays
        pts = [np.asarray(p.vertices, float) for p in self.polygons]
        lo = np.vstack(pts + [centers - radii[:, None]]).min(0)
        hi = np.vstack(pts + [centers + radii[:, None]]).max(0)
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])

    @cached_property
    def packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What the compiled kernels take: every polygon in `_groups` order, padded to one
        array (P, K, 2), its vertex count (P,), and the discs' centres (C, 2) and radii (C,)."""
        flat = [v for group in self._groups for v in group]
        polygons = np.zeros((len(flat), max((len(v) for v in flat), default=3), 2))
        for i, v in enumerate(flat):
            polygons[i, : len(v)] = v
        counts = np.array([len(v) for v in flat], dtype=np.int64)
        centres, radii = self._circle_arrays
        return polygons, counts, np.ascontiguousarray(centres), np.ascontiguousarray(radii)

    def clearance(self, centers: np.ndarray) -> np.ndarray:
        """Distance from points (N, 2) to the pusher (negative inside): a free-motion bound."""
        return push_kernels.clearance(np.ascontiguousarray(centers, dtype=float), *self.packed)


def _signed_distance(p: np.ndarray, verts: np.ndarray) -> np.ndarray:
    """Signed distance of points to convex polygons (negative inside) alone, without the
    normals and nearest points of `push_kernels.point_polygon`. p: (..., 2), verts: (..., k, 2)
    broadcast."""
    e = np.roll(verts, -1, axis=-2) - verts
    e2 = (e * e).sum(-1)
    rel = p[..., None, :] - verts
    side = (rel[..., 0] * e[..., 1] - rel[..., 1] * e[..., 0]) / np.sqrt(e2)
    t = np.clip((rel * e).sum(-1) / e2, 0.0, 1.0)
    outside = np.linalg.norm(rel - t[..., None] * e, axis=-1).min(-1)
    deepest = side.max(-1)
    return np.where(deepest <= 0.0, deepest, outside)


def box_corners(half_extents: tuple[float, float], poses: np.ndarray) -> np.ndarray:
    """Corners (N, 4, 2), counter-clockwise, of boxes at poses (N, 3)."""
    hx, hy = half_extents
    local = np.array([[hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])
    return poses[:, None, :2] + np.einsum("nij,kj->nki", rotation_2d(poses[:, 2]), local)


def smallest_gap(footprint: Footprint, pusher: Pusher, poses: np.ndarray) -> np.ndarray:
    """The smallest of `contacts`' gaps per pose (N,): how far the object at each pose (N, 3)
    is from the pusher, negative by the depth it overlaps; for overlap tests, which need no
    contact points or normals."""
    cc, cr = pusher._circle_arrays
    out = np.full(len(poses), np.inf)
    if footprint.shape == "circle":
        center = poses[:, None, :2]
        for verts in pusher._groups:
            out = np.minimum(out, _signed_distance(center, verts[None]).min(1) - footprint.radius)
        if len(cr):
            d = np.linalg.norm(center - cc[None], axis=-1) - cr[None] - footprint.radius
            out = np.minimum(out, d.min(1))
        return out
    corners = box_corners(footprint.half_extents, poses)  # (N, 4, 2)
    for verts in pusher._groups:
        inside = _signed_distance(corners[:, :, None, :], verts[None, None])  # (N, 4, P)
        pv = verts.reshape(-1, 2)
        into = _signed_distance(pv[None], corners[:, None])  # (N, V)
        out = np.minimum(out, np.minimum(inside.min((1, 2)), into.min(1)))
    if len(cr):
        d = _signed_distance(np.broadcast_to(cc, (len(poses), *cc.shape)), corners[:, None])
        out = np.minimum(out, (d - cr[None]).min(1))
    return out


@dataclass(frozen=True)
class PoseSets:
    """The poses of several objects, packed as the overlap kernel takes them: the planner
    packs the objects it avoids once per heading and tests thousands of hand positions."""

    shapes: np.ndarray  # (O, 5): a box (1) or a disc (0), its radius, half extents, reach
    poses: np.ndarray  # (N, 3): the objects' poses, object after object
    ends: np.ndarray  # (O + 1,): object o's poses are poses[ends[o]:ends[o + 1]]

    @classmethod
    def of(cls, objects: Sequence[tuple[Footprint, np.ndarray]]) -> PoseSets:
        """From (outline, poses (N_o, 3)) per object."""
        shapes = [(*_shape_args(f), f.bounding_radius) for f, _ in objects]
        poses = [np.asarray(p, dtype=float).reshape(-1, 3) for _, p in objects]
        return cls(
            np.array(shapes, dtype=float).reshape(-1, 5),
            np.concatenate(poses) if poses else np.zeros((0, 3)),
            np.cumsum([0] + [len(p) for p in poses]),
        )


def first_overlapped(
    sets: PoseSets, pusher: Pusher, shifts: np.ndarray, depth: float
) -> np.ndarray:
    """For the pusher moved to each of ``shifts`` (M, 2): the first object of ``sets`` that it
    overlaps by more than ``depth`` at any of its poses, both in the pusher's frame (where
    ``smallest_gap(footprint, pusher, poses - shift) < -depth`` somewhere), or -1; (M,). At a
    fraction of the gap's cost (`push_kernels.first_overlapped`: only the half-plane tests,
    only against the pusher's shapes within reach, a position's tests ending at its first
    overlap): the planner's 2D hand test asks this for thousands of hand poses per plan."""
    return push_kernels.first_overlapped(
        sets.shapes,
        sets.poses,
        sets.ends,
        np.ascontiguousarray(shifts, dtype=float).reshape(-1, 2),
        depth,
        pusher.bounds,
        *pusher.packed,
    )


def contacts(
    footprint: Footprint, pusher: Pusher, poses: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate contacts between objects at poses (N, 3) and the pusher: gap (N, C), contact
    point on the object (N, C, 2) and normal pusher -> object (N, C, 2), all in the pusher frame.

    Exact for circles and boxes against convex shapes: a box touches with its corners or is
    touched by the pusher's corners and discs, which covers face-face contact by its two ends.
    """
    poses = np.ascontiguousarray(poses, dtype=float).reshape(-1, 3)
    packed = pusher.packed
    size = push_kernels.candidate_count(footprint.shape == "box", packed[1], len(packed[3]))
    gaps, points, normals = (
        np.empty((len(poses), size)),
        np.empty((len(poses), size, 2)),
        np.empty((len(poses), size, 2)),
    )
    for i in range(len(poses)):
        push_kernels.candidates(
            *_shape_args(footprint), poses[i], *packed, gaps[i], points[i], normals[i]
        )
    return gaps, points, normals


def _shape_args(footprint: Footprint) -> tuple[bool, float, float, float]:
    """(is a box, radius, half extents) of a footprint, as the kernels take them."""
    box = footprint.shape == "box"
    hx, hy = footprint.half_extents if box else (0.0, 0.0)
    return box, 0.0 if box else float(footprint.radius), float(hx), float(hy)


# --------------------------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PushState:
    """What a watcher sees after each iteration, for the samples still running."""

    ids: np.ndarray  # (n,) sample indices
    pushed: np.ndarray  # (n,) distance the pusher has moved for each sample
    poses: np.ndarray  # (n, 3) object poses in the pusher frame
    touching: np.ndarray  # (n,) a contact was active in this iteration
    stationary: np.ndarray  # (n,) the object moved rigidly with the pusher (a fixed point)


@dataclass(frozen=True)
class PushResult:
    poses: np.ndarray  # (N, 3) final poses in the pusher frame
    pushed: np.ndarray  # (N,) distance pushed when each sample stopped
    recorded: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))  # (K, N, 3)


def simulate_push(
    footprint: Footprint,
    pusher: Pusher,
    poses: np.ndarray,
    mu: np.ndarray | float,
    c: np.ndarray | float,
    distance: float,
    step: float = 1e-3,
    watch: Callable[[PushState], np.ndarray] | None = None,
    record: np.ndarray | None = None,
) -> PushResult:
    """Push objects (one per row of ``poses``, pusher frame) by moving the pusher ``distance``
    along +x in steps of ``step``; mu and c may differ per sample.

    Each sample keeps its own clock: while the object is clear of the pusher it jumps by its
    clearance (motion is a pure translation in the pusher frame), so only samples in contact pay
    for 1 mm steps. Samples that can never be touched again (behind or beside the pusher) stop.
    ``watch(PushState) -> bool mask`` may stop samples early (a capture decided). ``record``:
    increasing push distances at which to store every sample's pose.

    Without a watcher, a sample that moved rigidly with the pusher for a step is done: the
    pusher moves uniformly along its x and the support is the same everywhere, so in the
    pusher's frame the motion has no clock, and a pose that does not change under a step is a
    fixed point for the rest of the push (every later checkpoint records it).
    """
    poses = np.array(poses, float).reshape(-1, 3)
    big_n = len(poses)
    mu = np.broadcast_to(np.asarray(mu, float), (big_n,)).copy()
    c = np.broadcast_to(np.asarray(c, float), (big_n,)).copy()
    if np.any(~(mu > 0)) or np.any(~(c > 0)):
        raise ValueError("mu and c must be positive")
    pushed = np.zeros(big_n)
    checkpoints = np.asarray(record if record is not None else [], float)
    recorded = np.zeros((len(checkpoints), big_n, 3))
    next_cp = np.zeros(big_n, dtype=int)
    bound_r = footprint.bounding_radius
    x_min, _, y_min, y_max = pusher.bounds
    margin = 2.0 * step
    active = np.arange(big_n)
    next_stop = np.append(checkpoints, np.inf)  # by next_cp: the next checkpoint, if any
    while active.size:
        p = poses[active]
        s = pushed[active]
        cp = next_stop[next_cp[active]]
        limit = np.minimum(distance, cp) - s
        clear = pusher.clearance(p[:, :2]) - bound_r
        free = clear > margin
        move = np.where(free, np.minimum(clear - step, limit), np.minimum(step, limit))
        twist = np.zeros((len(p), 3))
        touching = np.zeros(len(p), dtype=bool)
        busy = (~free & (move > 0)).nonzero()[0]
        if busy.size:
            twist[busy], touching[busy] = _contact_twist(
                footprint,
                pusher,
                p[busy],
                mu[active[busy]],
                c[active[busy]],
                move[busy],
                margin,
                step,
            )
        # The twist's translation turned into the pusher's frame, per unit push, less the
        # pusher's own motion along x.
        cos, sin = np.cos(p[:, 2]), np.sin(p[:, 2])
        rel_x = (cos * twist[:, 0] - sin * twist[:, 1]) * move - move
        rel_y = (sin * twist[:, 0] + cos * twist[:, 1]) * move
        dtheta = twist[:, 2] * move
        stationary = touching & (np.hypot(rel_x, rel_y) + bound_r * np.abs(dtheta) < 1e-4 * step)
        p[:, 0] += rel_x
        p[:, 1] += rel_y
        p[:, 2] += dtheta
        s = s + move
        poses[active], pushed[active] = p, s
        hit = (np.abs(s - cp) <= 1e-12).nonzero()[0]
        recorded[next_cp[active[hit]], active[hit]] = p[hit]
        next_cp[active[hit]] += 1
        gone = (p[:, 0] + bound_r < x_min - margin) | (p[:, 1] - bound_r > y_max + margin)
        gone |= p[:, 1] + bound_r < y_min - margin
        done = (s >= distance - 1e-12) | (gone & (next_cp[active] >= len(checkpoints)))
        if watch is not None:
            done |= np.asarray(watch(PushState(active, s, p, touching, stationary)), bool)
        else:
            fixed = (stationary & ~done).nonzero()[0]
            for k in fixed:
                recorded[next_cp[active[k]] :, active[k]] = p[k]
            next_cp[active[fixed]] = len(checkpoints)
            pushed[active[fixed]] = distance
            done[fixed] = True
        active = active[~done]
    return PushResult(poses, pushed, recorded)


def _contact_twist(
    footprint: Footprint,
    pusher: Pusher,
    poses: np.ndarray,
    mu: np.ndarray,
    c: np.ndarray,
    move: np.ndarray,
    margin: float,
    step: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Twists (object frame, per unit push) for samples near the pusher, and whether they touch.

    The gap g of each contact enters as a pusher velocity reduced by g/move along the normal
    (time-stepping with the gap), so a contact closes exactly and a penetration is pushed out.
    """
    packed = pusher.packed
    size = push_kernels.candidate_count(footprint.shape == "box", packed[1], len(packed[3]))
    return push_kernels.contact_twists(
        *_shape_args(footprint),
        footprint.bounding_radius,
        np.ascontiguousarray(poses, dtype=float),
        np.ascontiguousarray(mu, dtype=float),
        np.ascontiguousarray(c, dtype=float),
        np.ascontiguousarray(move, dtype=float),
        margin,
        step,
        *packed,
        size,
        PATTERNS,
    )


@functools.cache
def warm_up() -> None:
    """Compile the kernels this module runs (or load them from numba's disk cache: about 15 s
    the first time after an install or a change of `push_kernels`, a fraction of a second
    after), by pushing a box and a disc a few millimetres and testing them against the
    pusher: done before a plan's clock starts, so that no planning time or budget pays for it;
    once per process. Every kernel called from Python is called here
    (tests/test_architecture.py checks it)."""
    pusher = Pusher(
        (rectangle(np.array([0.0, -0.05]), np.array([0.0, 0.05]), 0.01),),
        (Circle((0.0, 0.06), 0.01),),
    )
    pose = np.array([[0.05, 0.0, 0.1]])
    for footprint in (Footprint("box", half_extents=(0.02, 0.03)), Footprint("circle", 0.03)):
        simulate_push(footprint, pusher, pose, 0.5, 0.02, 0.03)
        first_overlapped(PoseSets.of([(footprint, pose)]), pusher, np.zeros((1, 2)), 0.002)
        contacts(footprint, pusher, pose)
    pushing.warm_up()
