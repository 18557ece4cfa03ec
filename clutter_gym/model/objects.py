"""The object library: the everyday objects of Dogar & Srinivasa's experiments (§3).

Every object is a few upright primitives (boxes and cylinders, no roll or pitch) placed in its
frame, so the simulator (pybullet), the collision checker (python-fcl), the renderer (trimesh)
and the planar pushing model all derive their geometry from the same few numbers.

Object frame convention: an object's pose is ``(x, y, theta)``, the position of its vertical
axis at the centre of its base and its yaw about world z.  The base rests on the top of the
support surface, so the object frame's origin is at height ``surface_z`` and each primitive's
centre is its `Shape`'s ``xyz[2]`` above it.  A box's first size runs along the object's x axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import trimesh

from clutter_gym.model.shapes import Shape

Pose = tuple[float, float, float]
"""Planar pose ``(x, y, theta)`` of an object's base centre on a support surface."""

MAX_GRASP_WIDTH = 0.20
"""Widest object (m) the BarrettHand BH-280 on HERB can close around."""


@dataclass(frozen=True)
class Footprint:
    """An object's planar outline: a circle (``radius``) or a box (``half_extents``).

    Used for 2D overlap and hang-off checks and by the planar pushing model, which only
    sees an object from above.
    """

    shape: Literal["circle", "box"]
    radius: float = 0.0
    half_extents: tuple[float, float] = (0.0, 0.0)

    @property
    def min_width(self) -> float:
        """Narrowest width across the outline: what the hand must span to grasp it."""
        if self.shape == "circle":
            return 2 * self.radius
        return 2 * min(self.half_extents)

    @property
    def bounding_radius(self) -> float:
        """Radius of the smallest circle about the axis that contains the outline."""
        if self.shape == "circle":
            return self.radius
        return math.hypot(*self.half_extents)

    def corners_xy(self, pose: Pose) -> list[tuple[float, float]]:
        """World (x, y) corners of a box outline at ``pose``, counter-clockwise."""
        if self.shape != "box":
            raise ValueError("corners_xy is defined for box footprints only")
        c, s = math.cos(pose[2]), math.sin(pose[2])
        hx, hy = self.half_extents
        return [
            (pose[0] + c * lx - s * ly, pose[1] + s * lx + c * ly)
            for lx, ly in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
        ]

    def aabb(self, pose: Pose) -> tuple[float, float, float, float]:
        """Exact world axis-aligned bounds ``(x_min, x_max, y_min, y_max)`` at ``pose``."""
        x0, x1, y0, y1 = self.aabbs(np.asarray([pose], dtype=float))[0]
        return float(x0), float(x1), float(y0), float(y1)

    def aabbs(self, poses: np.ndarray) -> np.ndarray:
        """`aabb` of many poses (N, 3) at once: (N, 4)."""
        if self.shape == "circle":
            ex = ey = np.full(len(poses), self.radius)
        else:
            c, s = np.abs(np.cos(poses[:, 2])), np.abs(np.sin(poses[:, 2]))
            hx, hy = self.half_extents
            ex, ey = c * hx + s * hy, s * hx + c * hy
        x, y = poses[:, 0], poses[:, 1]
        return np.column_stack([x - ex, x + ex, y - ey, y + ey])


def _box_signed_distance(box: Footprint, pose: Pose, point: tuple[float, float]) -> float:
    """Signed distance from a point to a box outline: negative inside (minus the depth)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = point[0] - pose[0], point[1] - pose[1]
    ex = abs(c * dx + s * dy) - box.half_extents[0]
    ey = abs(-s * dx + c * dy) - box.half_extents[1]
    if ex <= 0 and ey <= 0:
        return max(ex, ey)
    return math.hypot(max(ex, 0.0), max(ey, 0.0))


def _box_box_signed_distance(a: Footprint, pose_a: Pose, b: Footprint, pose_b: Pose) -> float:
    """Separating-axis overlap when the boxes intersect (the exact penetration depth),
    else the nearest corner-to-box distance (the closest pair always includes a corner)."""
    dx, dy = pose_b[0] - pose_a[0], pose_b[1] - pose_a[1]
    separation = -math.inf
    for box, pose, other, other_pose in ((a, pose_a, b, pose_b), (b, pose_b, a, pose_a)):
        for k, half in enumerate(box.half_extents):
            angle = pose[2] + k * math.pi / 2
            ux, uy = math.cos(angle), math.sin(angle)
            ox, oy = other.half_extents
            reach = ox * abs(math.cos(other_pose[2] - angle)) + oy * abs(
                math.sin(other_pose[2] - angle)
            )
            separation = max(separation, abs(dx * ux + dy * uy) - half - reach)
    if separation < 0:
        return separation
    return min(
        min(_box_signed_distance(a, pose_a, corner) for corner in b.corners_xy(pose_b)),
        min(_box_signed_distance(b, pose_b, corner) for corner in a.corners_xy(pose_a)),
    )


def footprint_gap(a: Footprint, pose_a: Pose, b: Footprint, pose_b: Pose) -> float:
    """Exact planar distance between two outlines; when they overlap, minus the depth.

    Computed in closed form rather than with fcl, whose GJK returns wrong distances for
    boxes with parallel faces.
    """
    if a.shape == "circle" and b.shape == "circle":
        return math.dist(pose_a[:2], pose_b[:2]) - a.radius - b.radius
    if a.shape == "circle":
        a, pose_a, b, pose_b = b, pose_b, a, pose_a
    if b.shape == "circle":
        return _box_signed_distance(a, pose_a, (pose_b[0], pose_b[1])) - b.radius
    return _box_box_signed_distance(a, pose_a, b, pose_b)


@dataclass(frozen=True)
class ObjectSpec:
    """A rigid object kind: its geometry, mass, friction and what the hand can do with it.

    Density is taken as uniform over the primitives (for ``com_height`` and the simulator's
    inertia).  ``graspable`` must agree with ``MAX_GRASP_WIDTH``: an object wider than the
    hand's opening at its narrowest cannot be declared graspable.
    """

    kind: str
    primitives: tuple[Shape, ...]
    mass: float
    lateral_friction: float
    spinning_friction: float
    rolling_friction: float
    rgba: tuple[float, float, float, float]
    graspable: bool
    liftable: bool
    pushable: bool = True
    """False when a push at the hand's height (7.5-9 cm) tips the object over: the planner
    then never moves it and keeps every motion clear of it."""

    def __post_init__(self) -> None:
        if not self.primitives:
            raise ValueError(f"object {self.kind!r} needs at least one primitive")
        if self.mass <= 0:
            raise ValueError(f"object {self.kind!r} mass must be positive, got {self.mass}")
        for p in self.primitives:
            if p.kind not in ("box", "cylinder") or p.rpy != (0.0, 0.0, 0.0):
                raise ValueError(f"object {self.kind!r}: {p} is not an upright box or cylinder")
            if p.xyz[2] - p.height / 2 < -1e-9:
                raise ValueError(f"object {self.kind!r} has a primitive below its base: {p}")
        if self.graspable and self.footprint.min_width > MAX_GRASP_WIDTH:
            raise ValueError(
                f"object {self.kind!r} is {self.footprint.min_width:.3f} m wide at its narrowest,"
                f" more than MAX_GRASP_WIDTH={MAX_GRASP_WIDTH} m, so it cannot be graspable"
            )

    @cached_property
    def height(self) -> float:
        return max(p.xyz[2] + p.height / 2 for p in self.primitives)

    @cached_property
    def footprint(self) -> Footprint:
        """Cylinders on the vertical axis have a circular outline; otherwise the box about the
        axis that covers every primitive (computed once: the planner asks for it in every
        collision and overlap test)."""
        if all(p.kind == "cylinder" and p.xyz[:2] == (0, 0) for p in self.primitives):
            return Footprint("circle", radius=max(p.dims[0] for p in self.primitives))
        hx = max(abs(p.xyz[0]) + p.half_xy[0] for p in self.primitives)
        hy = max(abs(p.xyz[1]) + p.half_xy[1] for p in self.primitives)
        return Footprint("box", half_extents=(hx, hy))

    @property
    def volume(self) -> float:
        return sum(p.volume for p in self.primitives)

    @property
    def com_height(self) -> float:
        """Height of the centre of mass above the base, for uniform density."""
        return sum(p.volume * p.xyz[2] for p in self.primitives) / self.volume

    def mesh(self) -> trimesh.Trimesh:
        """The primitives' meshes in the object frame (base centre at the origin).

        Primitives only touch, never overlap, so concatenation is their union.
        """
        mesh = trimesh.util.concatenate([p.mesh() for p in self.primitives])
        assert isinstance(mesh, trimesh.Trimesh)
        return mesh


def _dumbbell() -> ObjectSpec:
    """A 5 kg hex dumbbell lying on its heads, the handle level between them: how a dumbbell
    rests on a table (standing on one head it is 25 cm tall on a 6 cm radius, and a push at
    the hand's height tips it over). Hexagonal heads 10 cm across the flats lie on a flat face
    (boxes 5 cm thick); the handle is a 3 cm bar 4 cm above the table. Heavier than the WAM's
    3 kg payload, so it is pushed, never lifted (the paper's "too heavy to be lifted")."""
    head = (0.05, 0.11, 0.10)
    handle = (0.15, 0.03, 0.03)
    head_x = (handle[0] + head[0]) / 2
    return ObjectSpec(
        kind="dumbbell",
        primitives=(
            Shape("box", head, (-head_x, 0.0, head[2] / 2)),
            Shape("box", handle, (0.0, 0.0, 0.04 + handle[2] / 2)),
            Shape("box", head, (head_x, 0.0, head[2] / 2)),
        ),
        mass=5.0,
        lateral_friction=0.5,
        spinning_friction=0.005,
        rolling_friction=0.0001,
        rgba=(0.10, 0.15, 0.45, 1.0),
        graspable=True,  # the fingers close around a head
        liftable=False,
    )


OBJECTS: dict[str, ObjectSpec] = {
    spec.kind: spec
    for spec in (
        ObjectSpec(
            kind="soda_can",
            primitives=(Shape("cylinder", (0.033, 0.122), (0.0, 0.0, 0.061)),),
            mass=0.35,
            lateral_friction=0.5,
            spinning_friction=0.001,
            rolling_friction=0.0001,
            rgba=(0.80, 0.08, 0.08, 1.0),
            graspable=True,
            liftable=True,
        ),
        ObjectSpec(
            kind="juice_bottle",
            primitives=(Shape("cylinder", (0.04, 0.20), (0.0, 0.0, 0.10)),),
            mass=0.5,
            lateral_friction=0.5,
            spinning_friction=0.001,
            rolling_friction=0.0001,
            rgba=(0.95, 0.55, 0.10, 1.0),
            graspable=True,
            liftable=True,
        ),
        ObjectSpec(
            kind="poptart_box",
            primitives=(Shape("box", (0.14, 0.05, 0.21), (0.0, 0.0, 0.105)),),
            mass=0.25,
            lateral_friction=0.45,
            spinning_friction=0.002,
            rolling_friction=0.0001,
            rgba=(0.20, 0.45, 0.85, 1.0),
            graspable=True,
            liftable=True,
        ),
        ObjectSpec(
            kind="large_box",
            primitives=(Shape("box", (0.36, 0.26, 0.30), (0.0, 0.0, 0.15)),),
            mass=1.0,
            lateral_friction=0.45,
            spinning_friction=0.005,
            rolling_friction=0.0001,
            rgba=(0.60, 0.42, 0.25, 1.0),
            graspable=False,  # 0.26 m at its narrowest: wider than MAX_GRASP_WIDTH
            liftable=True,
        ),
        _dumbbell(),
    )
}
"""The everyday objects of the paper's experiments, with real-world sizes and masses."""


def get_object(kind: str) -> ObjectSpec:
    """Look up an object kind, naming the allowed kinds when it is unknown."""
    try:
        return OBJECTS[kind]
    except KeyError:
        raise ValueError(
            f"unknown object kind {kind!r}; allowed: {', '.join(sorted(OBJECTS))}"
        ) from None
