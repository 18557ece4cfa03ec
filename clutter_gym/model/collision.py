"""The one collision layer (python-fcl): HERB's right arm and hand against the support surface,
the objects and itself; objects against objects (scene validation); the planners' Volumes.
Nothing else in the project calls fcl.

fcl reports contacts by geometry, not by object, so every geometry is mapped back to what it
belongs to (an object's name, or "robot") by ``id(geometry)``. Planners consume the checks as
callables: `CollisionChecker.checker` is the ``accept`` predicate of `ArmKinematics.solve_ik`,
which is how IK avoids the table and the shelf.

`Volume` is the paper's Volume operator (§2.1.2): the union of an object placed at every pose of
an uncertainty region or of its evolution, or of the robot at densely sampled configurations of a
trajectory. Avoid volumes, negative goal regions and FindPenetrated are all Volume queries.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Collection, Iterable, Mapping
from functools import cache, cached_property
from typing import NamedTuple

import fcl
import numpy as np
from scipy.spatial import ConvexHull

from clutter_gym.model.arm_geometry import ArmGeometry
from clutter_gym.model.arm_kernels import placements
from clutter_gym.model.herb import OPEN_HAND, HandCommand, hand_transition
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.kinematics import warm_up as kinematics_warm_up
from clutter_gym.model.objects import ObjectSpec, Pose
from clutter_gym.model.shapes import Shape
from clutter_gym.model.trajectory import Trajectory
from clutter_gym.model.transforms import rotation_z
from clutter_gym.model.volume_kernels import BOX, CYLINDER, lowest_per_cell, prisms_overlap
from clutter_gym.model.world import Surface

_HAND_LINKS = ("hand_base", "f1_knuckle", "f2_knuckle") + tuple(
    f"f{i}_{part}" for i in (1, 2, 3) for part in ("prox", "dist")
)
HAND_RIGID_LINKS = ("wam7", *_HAND_LINKS)
"""Links rigid with the TCP (the last wrist link and the hand): every IK solution of one TCP
pose puts them in the same place, so one check of them speaks for all (`hand_checker`)."""
#: Self-collision is checked between these groups of links only. Every other pair is disabled:
#: chain neighbours always touch at their joints; the shoulder links (wam_base..wam3) cannot reach
#: each other within the joint limits, nor can the wrist links and hand (wam5..hand), and the
#: elbow (wam4) cannot reach the wrist or hand since j6 bends at most 90 degrees.
SELF_COLLISION_GROUPS: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = (
    (("wam_base", "wam1", "wam2", "wam3"), ("wam5", "wam6", "wam7", *_HAND_LINKS)),
    (("wam_base", "wam1", "wam2"), ("wam4",)),
)

_REQUEST = fcl.CollisionRequest()

SURFACE_PADDING = 0.015
"""m added to every table or shelf box: the position-controlled arm lags its trajectory by up to
about a centimetre, and the task fails the moment the robot touches the surface."""


def _fcl_geometry(shape: Shape, margin: float = 0.0) -> fcl.CollisionGeometry:
    """The shape in fcl, grown by ``margin`` on every face (it then holds every point within
    ``margin`` of the shape)."""
    if shape.kind == "box":
        return fcl.Box(*(d + 2.0 * margin for d in shape.dims))
    if shape.kind == "cylinder":
        return fcl.Cylinder(shape.dims[0] + margin, shape.dims[1] + 2.0 * margin)
    return fcl.Sphere(shape.dims[0] + margin)


def _object_transforms(spec: ObjectSpec, pose: Pose, surface_z: float) -> list[fcl.Transform]:
    """World transforms of an object's shapes at a planar pose on a surface of top ``surface_z``
    (its shapes are upright: no roll or pitch)."""
    rotation = rotation_z(pose[2])
    origin = np.array([pose[0], pose[1], surface_z])
    return [fcl.Transform(rotation, origin + rotation @ np.array(p.xyz)) for p in spec.primitives]


def penetration_depth(
    a: ObjectSpec, pose_a: Pose, b: ObjectSpec, pose_b: Pose, surface_z: float
) -> float:
    """Deepest penetration between two objects standing on a surface; 0 when they are apart."""
    depth = 0.0
    placed_a = [
        fcl.CollisionObject(_fcl_geometry(s), t)
        for s, t in zip(a.primitives, _object_transforms(a, pose_a, surface_z), strict=True)
    ]
    placed_b = [
        fcl.CollisionObject(_fcl_geometry(s), t)
        for s, t in zip(b.primitives, _object_transforms(b, pose_b, surface_z), strict=True)
    ]
    for pa in placed_a:
        for pb in placed_b:
            request = fcl.CollisionRequest(enable_contact=True, num_max_contacts=1)
            result = fcl.CollisionResult()
            if fcl.collide(pa, pb, request, result):
                depth = max(depth, *(c.penetration_depth for c in result.contacts))
    return depth


def _manager(objects: Iterable[fcl.CollisionObject]) -> fcl.DynamicAABBTreeCollisionManager:
    manager = fcl.DynamicAABBTreeCollisionManager()
    manager.registerObjects(list(objects))
    manager.setup()
    return manager


class _Query:
    """Broad-phase callback state: geometry-id pairs in contact, stopping at the first if asked."""

    def __init__(self, skip: Collection[int] = (), first_only: bool = True) -> None:
        self.skip = skip
        self.first_only = first_only
        self.hits: list[tuple[int, int]] = []

    def __call__(self, o1: fcl.CollisionObject, o2: fcl.CollisionObject, _: object) -> bool:
        result = fcl.CollisionResult()
        if fcl.collide(o1, o2, _REQUEST, result):
            contact = result.contacts[0]
            pair = (id(contact.o1), id(contact.o2))
            if pair[0] not in self.skip and pair[1] not in self.skip:
                self.hits.append(pair)
        return self.first_only and bool(self.hits)


def _collide(a: fcl.DynamicAABBTreeCollisionManager, b: object, query: _Query) -> _Query:
    a.collide(b, None, query)
    return query


GROUP_SIZE = 16
"""Copies of one shape (consecutive parts sharing a geometry) per bounding box in
`Volume.intersects`: arm links 0.02 rad apart along a path, or an object's samples at one
stage of its evolution, lie close together, so their bound is tight."""
DIRECT_PAIRS = 256
"""Volumes whose part counts multiply to at most this are compared part by part directly."""
GROUP_AFTER = 2
"""`Volume.intersects` calls before a large volume is tested as bounded groups."""


class _Groups:
    """Bounding boxes of groups of a volume's parts, each with the volume of its parts."""

    def __init__(
        self,
        objects: list[fcl.CollisionObject],
        members: dict[int, Volume],
        manager: fcl.DynamicAABBTreeCollisionManager | None = None,
    ) -> None:
        self.objects = objects
        #: The parts inside each bound, by ``id`` of the bound's geometry.
        self.members = members
        self._manager = manager

    @property
    def manager(self) -> fcl.DynamicAABBTreeCollisionManager:
        if self._manager is None:
            self._manager = _manager(self.objects)
        return self._manager

    @classmethod
    def of_parts(cls, parts: tuple[Part, ...], poses: np.ndarray) -> _Groups:
        """Copies of one shape in order, `GROUP_SIZE` at a time, each group bounded by a box
        turned like its first copy (the copies turn little within a group): tight, and built
        with a few array operations where a convex hull costs a millisecond. ``poses``: the
        parts' (`Volume.part_poses`)."""
        by_shape: dict[int, list[int]] = {}
        for i, part in enumerate(parts):
            by_shape.setdefault(id(part[1]), []).append(i)
        objects, members = [], {}
        for indices in by_shape.values():
            same = [parts[i] for i in indices]
            geometry = same[0][1]
            if isinstance(geometry, fcl.Convex):  # already a hull (`hulled`): as it is
                objects += [obj for obj, _, _ in same]
                members[id(geometry)] = Volume(same)
                continue
            rotations, origins = poses[indices, :, :3], poses[indices, :, 3]
            corners = _BOX_SIGNS * _half_extents(geometry)
            world = np.einsum("nij,kj->nki", rotations, corners) + origins[:, None]
            for k in range(0, len(same), GROUP_SIZE):
                turn = rotations[k]
                local = (world[k : k + GROUP_SIZE].reshape(-1, 3) - origins[k]) @ turn
                low, high = local.min(0), local.max(0)
                box = fcl.Box(*(high - low))
                centre = origins[k] + turn @ ((low + high) / 2)
                objects.append(fcl.CollisionObject(box, fcl.Transform(turn, centre)))
                members[id(box)] = Volume(same[k : k + GROUP_SIZE])
        return cls(objects, members)


class _Side(NamedTuple):
    """One volume in a `_GroupQuery`: its parts, or its group bounds and the parts in each."""

    manager: fcl.DynamicAABBTreeCollisionManager
    keys: Mapping[int, object]  # by the ids of the geometries its tree reports: bounds or parts
    members: Mapping[int, Volume] | None  # the parts in each bound; None: the tree holds parts


class _GroupQuery:
    """Broad-phase callback over two volumes, one or both as group bounds: a bound that touches
    the other side is confirmed with the parts it holds, and the first confirmed contact ends
    the search."""

    def __init__(self, mine: _Side, theirs: _Side) -> None:
        self.mine = mine
        self.theirs = theirs
        self.hit = False
        self.error: Exception | None = None

    def __call__(self, o1: fcl.CollisionObject, o2: fcl.CollisionObject, _: object) -> bool:
        try:
            result = fcl.CollisionResult()
            if fcl.collide(o1, o2, _REQUEST, result):
                contact = result.contacts[0]
                (a, obj_a), (b, obj_b) = (id(contact.o1), o1), (id(contact.o2), o2)
                if a not in self.mine.keys:
                    (a, obj_a), (b, obj_b) = (b, obj_b), (a, obj_a)
                parts_a = None if self.mine.members is None else self.mine.members[a]
                parts_b = None if self.theirs.members is None else self.theirs.members[b]
                self.hit = _confirmed(parts_a, obj_a, parts_b, obj_b)
        except Exception as error:  # fcl prints and drops a callback's exception
            self.error = error
            return True
        return self.hit

    def run(self) -> bool:
        """Whether the two volumes touch."""
        self.mine.manager.collide(self.theirs.manager, None, self)
        if self.error is not None:
            raise self.error
        return self.hit


def _confirmed(
    parts_a: Volume | None,
    obj_a: fcl.CollisionObject,
    parts_b: Volume | None,
    obj_b: fcl.CollisionObject,
) -> bool:
    """Whether two touching objects, each a part or the bound of the given parts, have parts
    that touch."""
    if parts_a is None and parts_b is None:
        return True
    if parts_a is None or parts_b is None:
        # The broad phase hands over stand-ins of the registered objects, which a tree will
        # not take: the part meets each of the bound's few parts in turn.
        parts, obj = (parts_b, obj_a) if parts_a is None else (parts_a, obj_b)
        assert parts is not None
        return any(fcl.collide(obj, p, _REQUEST, fcl.CollisionResult()) for p, _, _ in parts.parts)
    return bool(_collide(parts_a.manager, parts_b.manager, _Query()).hits)


ROBOT = "robot"
"""Label of the robot's shapes in a `Volume`."""

Part = tuple[fcl.CollisionObject, fcl.CollisionGeometry, str]
"""A placed shape, its geometry (fcl reports contacts by geometry) and its owner's label."""


class Volume:
    """A union of placed fcl shapes, each labelled with its owner (an object name or `ROBOT`).

    Shapes of one owner share their fcl geometries, so ``id(geometry)`` names the owner.
    Managers are built lazily, once, because volumes are queried far more often than built.
    """

    def __init__(
        self,
        parts: Iterable[Part] = (),
        leaves: tuple[Volume, ...] = (),
        poses: np.ndarray | None = None,
    ) -> None:
        """``poses``: the parts' world poses (N, 3, 4: rotation and translation) where the
        builder knows them; else `part_poses` asks fcl for each (two calls a part)."""
        self.parts: tuple[Part, ...] = tuple(parts)
        self._poses = poses
        self._bounds: np.ndarray | None = None
        #: The volumes summed into this one (`__add__`), whose groups it reuses; a volume
        #: built from parts is its own single leaf.
        self._leaves = leaves or (self,)
        self._manager: fcl.DynamicAABBTreeCollisionManager | None = None
        self._by_label: dict[str, Volume] = {}
        self._floor: _FloorMap | None = None
        self._hulled: Volume | None = None
        self._groups: _Groups | None = None
        self._queries = 0  # `intersects` calls so far

    @classmethod
    def of_object(cls, name: str, spec: ObjectSpec, poses: np.ndarray, surface_z: float) -> Volume:
        """Volume(o, R): object ``name`` placed at every planar pose (N, 3) of a region."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        geometries = [_fcl_geometry(p) for p in spec.primitives]
        # `_object_transforms` for every pose at once: a volume may hold thousands of poses.
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        zero, one = np.zeros(len(poses)), np.ones(len(poses))
        rotations = np.stack(
            [
                np.stack([c, -s, zero], -1),
                np.stack([s, c, zero], -1),
                np.stack([zero, zero, one], -1),
            ],
            axis=1,
        )  # (N, 3, 3)
        origins = np.column_stack([poses[:, :2], np.full(len(poses), surface_z)])
        offsets = np.stack([rotations @ np.array(p.xyz) for p in spec.primitives], 1)  # (N, P, 3)
        centres = origins[:, None] + offsets
        # The yaw's quaternions (w, x, y, z) as lists: fcl sets one in a sixth of a matrix's time.
        quaternions = np.column_stack(
            [np.cos(poses[:, 2] / 2), zero, zero, np.sin(poses[:, 2] / 2)]
        ).tolist()
        parts = []
        for i in range(len(poses)):
            for geometry, centre in zip(geometries, centres[i], strict=True):
                placed = fcl.CollisionObject(geometry)
                placed.setQuatRotation(quaternions[i])
                placed.setTranslation(centre)
                parts.append((placed, geometry, name))
        frames = np.empty((len(poses), len(geometries), 3, 4))
        frames[..., :3], frames[..., 3] = rotations[:, None], centres
        return cls(parts, poses=frames.reshape(-1, 3, 4))

    @classmethod
    def of_robot(
        cls, robot: RobotCollision, path: np.ndarray, hand: HandCommand, step_rad: float = 0.02
    ) -> Volume:
        """Volume(robot, tau): the arm and hand at configurations along a joint path (N, 7),
        sampled so that no joint moves more than ``step_rad`` between samples."""
        parts = []
        geometries = robot.geometries
        samples = []
        for q in interpolate(np.asarray(path, dtype=float), step_rad):
            poses, quaternions = robot.geometry.primitive_placements(
                robot.kinematics.link_frames(q), hand
            )
            samples.append(poses)
            for geometry, pose, quaternion in zip(
                geometries, poses, quaternions.tolist(), strict=True
            ):
                placed = fcl.CollisionObject(geometry)
                placed.setQuatRotation(quaternion)
                placed.setTranslation(pose[:3, 3])
                parts.append((placed, geometry, ROBOT))
        return cls(parts, poses=np.stack(samples)[:, :, :3].reshape(-1, 3, 4))

    @classmethod
    def of_trajectory(
        cls, robot: RobotCollision, trajectory: Trajectory, step_rad: float = 0.02
    ) -> Volume:
        """Volume(robot, tau) of every segment of a trajectory (see `of_robot`), and where the
        hand command changes between segments, the fingers on their way (`hand_transition`)."""
        total = cls()
        previous = None
        for s in trajectory.segments:
            if previous is not None:
                for hand in hand_transition(previous, s.hand):
                    total += cls.of_robot(robot, s.path[:1], hand, step_rad)
            total += cls.of_robot(robot, s.path, s.hand, step_rad)
            previous = s.hand
        return total

    @classmethod
    def of_box(
        cls, label: str, centre: np.ndarray, sizes: tuple[float, float, float], yaw: float
    ) -> Volume:
        """A box of full ``sizes`` at ``centre`` (3,), turned by ``yaw`` about z (a corridor)."""
        geometry = fcl.Box(*sizes)
        placed = fcl.CollisionObject(geometry, fcl.Transform(rotation_z(yaw), centre))
        return cls([(placed, geometry, label)])

    def __add__(self, other: Volume) -> Volume:
        leaves = tuple(v for v in self._leaves + other._leaves if v.parts)
        return Volume(self.parts + other.parts, leaves)

    def part_poses(self) -> np.ndarray:
        """World poses (N, 3, 4: rotation and translation) of the parts, in order: a sum's are
        its leaves'."""
        if self._poses is None:
            if self._leaves != (self,):
                self._poses = np.concatenate([leaf.part_poses() for leaf in self._leaves])
            else:
                self._poses = np.array(
                    [np.c_[o.getRotation(), o.getTranslation()] for o, _, _ in self.parts]
                ).reshape(-1, 3, 4)
        return self._poses

    def part_bounds(self) -> np.ndarray:
        """World axis-aligned bounds (N, 2, 3) of the parts (boxes, cylinders and spheres),
        from `part_poses` and each shape's half sizes."""
        if self._bounds is None:
            halves: dict[int, np.ndarray] = {}
            half = np.array(
                [halves.setdefault(id(g), _half_extents(g)) for _, g, _ in self.parts]
            ).reshape(-1, 3)
            poses = self.part_poses()
            extent = (np.abs(poses[:, :, :3]) @ half[:, :, None])[..., 0]
            centre = poses[:, :, 3]
            self._bounds = np.stack([centre - extent, centre + extent], axis=1)
        return self._bounds

    def __len__(self) -> int:
        return len(self.parts)

    @cached_property
    def owner(self) -> dict[int, str]:
        """The label of every part's geometry, by ``id(geometry)`` (built when first asked:
        most sums of volumes never are)."""
        return {id(geometry): label for _, geometry, label in self.parts}

    @cached_property
    def labels(self) -> frozenset[str]:
        return frozenset(label for _, _, label in self.parts)

    @property
    def manager(self) -> fcl.DynamicAABBTreeCollisionManager:
        if self._manager is None:
            self._manager = _manager(obj for obj, _, _ in self.parts)
        return self._manager

    def of_label(self, label: str) -> Volume:
        """The parts of one owner, as the sum of the leaves that hold only it where they do
        (so that their groups are reused)."""
        if label not in self._by_label:
            leaves = [v for v in self._leaves if label in v.labels]
            if all(v.labels == {label} for v in leaves):
                self._by_label[label] = sum(leaves[1:], leaves[0])
            else:
                self._by_label[label] = Volume(p for p in self.parts if p[2] == label)
        return self._by_label[label]

    def intersects(self, other: Volume) -> bool:
        """Whether any shape of this volume penetrates any shape of ``other``.

        A large volume (hundreds of overlapping copies of an arm link along a path, or of an
        object along its evolution) that is asked again meets the other first as one bounding
        box per `GROUP_SIZE` copies, and only a box that touches compares its copies: the
        broad phase of the copies themselves reports hundreds of pairs of overlapping bounds
        per query, each a Python callback. The answer is the exact one (a box contains its
        copies)."""
        if not self.parts or not other.parts:
            return False
        self._queries += 1
        other._queries += 1
        if len(self.parts) * len(other.parts) <= DIRECT_PAIRS:
            return bool(_collide(self.manager, other.manager, _Query()).hits)
        mine, theirs = self._side(), other._side()
        if mine.members is None and theirs.members is None:
            return bool(_collide(self.manager, other.manager, _Query()).hits)
        return _GroupQuery(mine, theirs).run()

    def _side(self) -> _Side:
        """This volume in a query: as bounded groups once it is large and asked again (a
        volume asked once is cheaper to test part by part than to group)."""
        grouped = self._groups is not None or self._queries >= GROUP_AFTER
        if len(self.parts) > GROUP_SIZE and grouped:
            groups = self._grouped()
            return _Side(groups.manager, groups.members, groups.members)
        return _Side(self.manager, self.owner, None)

    def hulled(self) -> Volume:
        """One convex hull per label around all its parts: a conservative stand-in for a union
        of uncertainty samples when the arm must avoid it. Tens of overlapping copies of an
        object make the broad phase report hundreds of pairs per arm configuration; one hull
        per object makes GoTo's collision checks about as cheap as without uncertainty."""
        if self._hulled is None:
            parts: list[Part] = []
            for label in sorted(self.labels):
                points = np.vstack(
                    [part_points(obj, g) for obj, g, owner in self.parts if owner == label]
                )
                geometry = convex_hull(points)
                parts.append((fcl.CollisionObject(geometry, fcl.Transform()), geometry, label))
            self._hulled = Volume(parts)
        return self._hulled

    def lowest_over(self, boxes: np.ndarray) -> np.ndarray:
        """For planar boxes (N, 4) as (x_min, x_max, y_min, y_max): the lowest point of this
        volume above each (inf where nothing is), from a 1 cm top-view map of the parts'
        bounding boxes. An object whose top is below that height certainly misses the volume:
        a quick test before the exact one, since most goal poses are far from the NGR."""
        return self._floor_map().lowest_over(np.asarray(boxes, dtype=float).reshape(-1, 4))

    def clear_above(self, boxes: np.ndarray, height: float) -> np.ndarray:
        """For rows of planar boxes (K, N, 4): whether the volume's lowest point over every
        box of the row (`lowest_over`'s map) is above ``height``, for all rows at once: K
        quick sufficient tests that objects no taller than that miss the volume."""
        boxes = np.asarray(boxes, dtype=float)
        return self._floor_map().clear_above(boxes.reshape(len(boxes), -1, 4), float(height))

    def _floor_map(self) -> _FloorMap:
        if self._floor is None:
            self._floor = _FloorMap(self.part_bounds())
        return self._floor

    def penetrated(self, other: Volume) -> set[str]:
        """FindPenetrated: the labels of ``other`` whose shapes this volume penetrates."""
        if not self.parts:
            return set()
        return {label for label in sorted(other.labels) if self.intersects(other.of_label(label))}

    def _grouped(self) -> _Groups:
        """The bounded groups of its parts: a sum's are its leaves' (built once per leaf)."""
        if self._groups is None:
            if self._leaves == (self,):
                self._groups = _Groups.of_parts(self.parts, self.part_poses())
            elif len(self._leaves) == 1:
                self._groups = self._leaves[0]._grouped()
            else:
                groups = [leaf._grouped() for leaf in self._leaves]
                members = {k: v for g in groups for k, v in g.members.items()}
                self._groups = _Groups([o for g in groups for o in g.objects], members)
        return self._groups


_HULL_SIDES = 16
_BOX_SIGNS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def _half_extents(geometry: fcl.CollisionGeometry) -> np.ndarray:
    """Half sizes (3,) of a box, cylinder or sphere's local bounding box."""
    if isinstance(geometry, fcl.Box):
        return np.asarray(geometry.side, dtype=float) / 2
    if isinstance(geometry, fcl.Cylinder):
        return np.array([geometry.radius, geometry.radius, geometry.lz / 2])
    return np.full(3, float(geometry.radius))


def part_points(obj: fcl.CollisionObject, geometry: fcl.CollisionGeometry) -> np.ndarray:
    """World points whose convex hull contains a placed box, cylinder or sphere."""
    if isinstance(geometry, fcl.Cylinder):
        # A polygon circumscribing the circle, so the hull contains the cylinder.
        r = geometry.radius / np.cos(np.pi / _HULL_SIDES)
        a = np.linspace(0.0, 2 * np.pi, _HULL_SIDES, endpoint=False)
        ring = np.column_stack([r * np.cos(a), r * np.sin(a)])
        h = geometry.lz / 2
        local = np.vstack([np.c_[ring, np.full(len(ring), -h)], np.c_[ring, np.full(len(ring), h)]])
    else:
        local = _BOX_SIGNS * _half_extents(geometry)
    return local @ np.asarray(obj.getRotation()).T + np.asarray(obj.getTranslation())


def convex_hull(points: np.ndarray) -> fcl.Convex:
    """The convex hull of points (N, 3) as an fcl shape, its triangles wound outward. qhull
    directly: a quarter of the cost of a trimesh hull (0.2 vs 0.84 ms for 400 points), and
    the planner's goal tests build one per call, thousands per plan."""
    hull = ConvexHull(points)
    triangles = hull.simplices.copy()
    a, b, c = (points[triangles[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    triangles[inward] = triangles[inward][:, ::-1]
    used, compact = np.unique(triangles, return_inverse=True)
    faces = np.hstack([np.full((len(triangles), 1), 3), compact.reshape(-1, 3)]).ravel()
    return fcl.Convex(np.asarray(points[used], float), len(triangles), faces)


class _FloorMap:
    """Top-view grid of the lowest z of a volume's parts over each cell (bounding boxes)."""

    RESOLUTION = 0.01

    def __init__(self, bounds: np.ndarray) -> None:
        """``bounds``: the parts' world axis-aligned bounds (N, 2, 3)."""
        self._counts: dict[float, np.ndarray] = {}
        if not len(bounds):
            self.origin = np.zeros(2)
            self.lowest = np.full((1, 1), np.inf)
            return
        self.origin = bounds[:, 0, :2].min(0)
        r = self.RESOLUTION
        lo = np.floor((bounds[:, 0, :2] - self.origin) / r).astype(int)
        hi = np.floor((bounds[:, 1, :2] - self.origin) / r).astype(int)
        self.lowest = lowest_per_cell(lo, hi, np.ascontiguousarray(bounds[:, 0, 2]), hi.max(0) + 1)

    def _windows(self, boxes: np.ndarray) -> tuple[np.ndarray, ...]:
        """First and last cell rows and columns (i0, i1, j0, j1) under each box, clipped to
        the map (empty where i0 > i1 or j0 > j1)."""
        r = self.RESOLUTION
        n, m = self.lowest.shape
        i0 = np.floor((boxes[:, 0] - self.origin[0]) / r).astype(int).clip(0, n)
        i1 = np.floor((boxes[:, 1] - self.origin[0]) / r).astype(int).clip(-1, n - 1)
        j0 = np.floor((boxes[:, 2] - self.origin[1]) / r).astype(int).clip(0, m)
        j1 = np.floor((boxes[:, 3] - self.origin[1]) / r).astype(int).clip(-1, m - 1)
        return i0, i1, j0, j1

    def lowest_over(self, boxes: np.ndarray) -> np.ndarray:
        i0, i1, j0, j1 = self._windows(boxes)
        out = np.full(len(boxes), np.inf)
        for k in range(len(boxes)):
            if i0[k] <= i1[k] and j0[k] <= j1[k]:
                out[k] = self.lowest[i0[k] : i1[k] + 1, j0[k] : j1[k] + 1].min()
        return out

    def clear_above(self, boxes: np.ndarray, height: float) -> np.ndarray:
        """Per row of boxes (K, N, 4): whether no cell under any of its boxes is at or below
        ``height``, i.e. ``lowest_over(row).min() > height``, with four lookups per box in
        the cells' prefix counts (built once per height) instead of a min per window."""
        flat = boxes.reshape(-1, 4)
        i0, i1, j0, j1 = self._windows(flat)
        counts = self._low_counts(height)
        # Windows are [i0, i1] x [j0, j1] with 0 <= i0 <= n: an empty one gets i1 + 1 == i0.
        i1, j1 = np.where(i0 > i1, i0, i1 + 1), np.where(j0 > j1, j0, j1 + 1)
        low = counts[i1, j1] - counts[i0, j1] - counts[i1, j0] + counts[i0, j0]
        return np.asarray(low.reshape(boxes.shape[:-1]).sum(-1) == 0)

    def _low_counts(self, height: float) -> np.ndarray:
        """Prefix counts (n + 1, m + 1) of the cells at or below ``height``."""
        counts = self._counts.get(height)
        if counts is None:
            n, m = self.lowest.shape
            counts = np.zeros((n + 1, m + 1), dtype=np.int64)
            counts[1:, 1:] = (self.lowest <= height).cumsum(0).cumsum(1)
            self._counts[height] = counts
        return counts


@cache
def warm_up() -> None:
    """`kinematics.warm_up` and the kernels of `volume_kernels`, compiled or loaded before
    anything is timed; once per process."""
    kinematics_warm_up()
    one = np.zeros((1, 2), dtype=np.int64)
    lowest_per_cell(one, one, np.zeros(1), np.ones(2, dtype=np.int64))
    shapes = np.array(
        [[BOX, 0.1, 0.1, 0.0, 0.0, 0.0, 0.1], [CYLINDER, 0.1, 0.1, 0.0, 0.0, 0.0, 0.1]]
    )
    prisms_overlap(shapes, np.zeros((1, 3)), shapes, np.zeros((1, 3)))


@cache
def _prisms(spec: ObjectSpec) -> np.ndarray:
    """`volume_kernels.prisms_overlap`'s table of an object's shapes (kind, half extents in x
    and y, centre x and y, bottom and top z): upright boxes and cylinders (`ObjectSpec`)."""
    rows = []
    for shape in spec.primitives:
        kind = BOX if shape.kind == "box" else CYLINDER
        z = shape.xyz[2]
        rows.append(
            [kind, *shape.half_xy, *shape.xyz[:2], z - shape.height / 2, z + shape.height / 2]
        )
    return np.array(rows, dtype=float)


def objects_overlap(
    spec_a: ObjectSpec, poses_a: np.ndarray, spec_b: ObjectSpec, poses_b: np.ndarray
) -> bool:
    """Whether object a at any of its planar poses (N, 3) penetrates object b at any of its
    (M, 3), both standing on one surface: what ``Volume.of_object(a, poses_a).intersects(
    Volume.of_object(b, poses_b))`` answers, computed in the plane and in height (every shape
    of an object is an upright box or cylinder) without placing fcl shapes: the placement
    search of pick-and-place tests an object held at a thousand poses against each neighbour's
    samples, and placing its shapes took half of a shelf scene's planning time."""
    # Copies: C-ordered and writable, the one signature the warm-up compiles.
    a = np.array(poses_a, dtype=float).reshape(-1, 3)
    b = np.array(poses_b, dtype=float).reshape(-1, 3)
    return bool(prisms_overlap(_prisms(spec_a), a, _prisms(spec_b), b))


class CollisionWorld:
    """The static scene: surface boxes and object volumes, in separate managers so that
    surface-only checks (IK) never look at objects. An object may occupy several poses (its
    uncertainty samples): the arm must then avoid all of them."""

    def __init__(
        self,
        surface: Surface,
        objects: Mapping[str, tuple[ObjectSpec, Pose]],
        padding: float = SURFACE_PADDING,
    ) -> None:
        volume = Volume()
        for name, (spec, pose) in objects.items():
            volume += Volume.of_object(name, spec, np.asarray(pose), surface.top_z)
        self._init(surface, volume, padding)

    @classmethod
    def around(
        cls,
        surface: Surface,
        obstacles: Volume,
        padding: float = SURFACE_PADDING,
        hulled: bool = False,
    ) -> CollisionWorld:
        """A world whose objects are a `Volume` (e.g. an avoid volume of uncertainty samples).

        With ``hulled`` the arm is tested against one convex hull per object first (cheap:
        `Volume.hulled`), and a hit is confirmed against the exact union of the shapes, which
        is what avoidVol is (Algorithm 1, line 3): a hull also covers the gaps between samples.
        """
        world = cls.__new__(cls)
        if hulled:
            world._init(surface, obstacles.hulled(), padding, exact=obstacles)
        else:
            world._init(surface, obstacles, padding)
        return world

    def _init(
        self, surface: Surface, obstacles: Volume, padding: float, exact: Volume | None = None
    ) -> None:
        self.surface = surface
        self._surface_objects = [
            fcl.CollisionObject(
                fcl.Box(*(2.0 * (h + padding) for h in box.half_extents)),
                fcl.Transform(np.asarray(box.centre, dtype=float)),
            )
            for box in surface.boxes
        ]
        self.surface_manager = _manager(self._surface_objects)
        self.obstacles = obstacles
        #: Object name of every object geometry (hulls and exact shapes), by ``id(geometry)``.
        self.owner: dict[int, str] = {**obstacles.owner, **(exact.owner if exact else {})}
        self.object_manager = obstacles.manager
        #: Where ``obstacles`` are hulls: the exact shapes that confirm a hit on a hull.
        self.exact = exact if exact is not None and exact.parts else None

    def geometry_ids(self, names: Iterable[str]) -> frozenset[int]:
        """Geometry ids of the named objects (unknown names are an error, not a silent no-op)."""
        wanted = set(names)
        if not wanted:
            return frozenset()
        unknown = wanted - set(self.owner.values())
        if unknown:
            raise KeyError(f"unknown objects {sorted(unknown)}")
        return frozenset(g for g, name in self.owner.items() if name in wanted)


class RobotCollision:
    """The arm and hand primitives as fcl objects, placed at a configuration on demand; with a
    ``margin`` each primitive grown by that much, so that an arm clear of a volume keeps at
    least ``margin`` from it (`CollisionChecker.clearance_checker`)."""

    def __init__(
        self, kinematics: ArmKinematics, geometry: ArmGeometry, margin: float = 0.0
    ) -> None:
        self.kinematics = kinematics
        self.geometry = geometry
        self.margin = margin
        self.geometries = [_fcl_geometry(p.shape, margin) for p in geometry.primitives]
        self._objects = [fcl.CollisionObject(g, fcl.Transform()) for g in self.geometries]
        #: Each primitive's fcl object by ``id`` of its geometry (what a contact reports).
        self.by_geometry = {id(g): o for g, o in zip(self.geometries, self._objects, strict=True)}
        self.manager = _manager(self._objects)

        def group(links: tuple[str, ...]) -> fcl.DynamicAABBTreeCollisionManager:
            return _manager(
                o
                for o, p in zip(self._objects, geometry.primitives, strict=True)
                if p.link in links
            )

        self._self_pairs = [(group(a), group(b)) for a, b in SELF_COLLISION_GROUPS]
        self.hand_manager = group(HAND_RIGID_LINKS)
        self._hand_indices = np.array(
            [i for i, p in enumerate(geometry.primitives) if p.link in HAND_RIGID_LINKS]
        )
        self._hand_objects = [self._objects[i] for i in self._hand_indices]
        self._placed: tuple[bytes, HandCommand] | None = None
        self._pairs_placed: tuple[bytes, HandCommand] | None = None

    def place(self, q: np.ndarray, hand: HandCommand) -> None:
        """Move the primitives to configuration q and hand command; no-op if already there."""
        q = np.asarray(q, dtype=float)
        key = (q.tobytes(), hand)
        if key == self._placed:
            return
        poses, quaternions = self.geometry.primitive_placements(
            self.kinematics.link_frames(q), hand
        )
        # Rotation and translation set apart (half the cost of building an fcl.Transform each),
        # the rotation as a quaternion in a list (a sixth of a matrix's: fcl reads its items).
        for obj, quaternion, origin in zip(
            self._objects, quaternions.tolist(), poses[:, :3, 3], strict=True
        ):
            obj.setQuatRotation(quaternion)
            obj.setTranslation(origin)
        self.manager.update()
        self._placed = key

    def place_hand(self, tcp_pose: np.ndarray, hand: HandCommand) -> None:
        """Move only the links rigid with the TCP (`HAND_RIGID_LINKS`) to a TCP pose, for
        `hand_manager` queries (the only place that tree is updated: nothing else queries it);
        the next `place` moves every link again."""
        frames = np.empty((9, 4, 4))
        frames[7:] = self.kinematics.hand_frames(tcp_pose)
        indices = self._hand_indices
        poses, quaternions = placements(
            frames, self.geometry.anchors[indices], self.geometry.offsets(hand)[indices]
        )
        for obj, quaternion, origin in zip(
            self._hand_objects, quaternions.tolist(), poses[:, :3, 3], strict=True
        ):
            obj.setQuatRotation(quaternion)
            obj.setTranslation(origin)
        self.hand_manager.update()
        self._placed = None

    def self_collision(self, q: np.ndarray, hand: HandCommand = OPEN_HAND) -> bool:
        """Whether two links of `SELF_COLLISION_GROUPS` penetrate at q."""
        self.place(q, hand)
        # The groups' trees are refitted here, not in `place`: most placements are refused by
        # the surface or an object, or belong to a grown robot that never asks this.
        if self._pairs_placed != self._placed:
            for a, b in self._self_pairs:
                a.update()
                b.update()
            self._pairs_placed = self._placed
        return any(_collide(a, b, _Query()).hits for a, b in self._self_pairs)


class CollisionChecker:
    """The planner's collision queries of the arm against one world (and itself)."""

    def __init__(self, world: CollisionWorld, robot: RobotCollision) -> None:
        self.world = world
        self.robot = robot

    def surface_collision(self, q: np.ndarray, hand: HandCommand = OPEN_HAND) -> bool:
        """Whether the arm or hand penetrates the table or shelf."""
        self.robot.place(q, hand)
        return bool(_collide(self.robot.manager, self.world.surface_manager, _Query()).hits)

    def in_collision(
        self,
        q: np.ndarray,
        hand: HandCommand = OPEN_HAND,
        ignore: Iterable[str] = (),
        self_collision: bool = True,
    ) -> bool:
        """Whether the arm hits the surface, an object not named in `ignore`, or itself."""
        return self._in_collision(q, hand, self.world.geometry_ids(ignore), self_collision)

    def _in_collision(
        self, q: np.ndarray, hand: HandCommand, skip: frozenset[int], self_collision: bool
    ) -> bool:
        if self.surface_collision(q, hand):
            return True
        if self._objects_hit(self.robot, self.robot.manager, skip):
            return True
        return self_collision and self.robot.self_collision(q, hand)

    def _objects_hit(
        self,
        robot: RobotCollision,
        links: fcl.DynamicAABBTreeCollisionManager,
        skip: frozenset[int],
    ) -> bool:
        """Whether ``robot``'s placed ``links`` hit an object. Where the world's objects are
        hulls, a hit is confirmed against the exact shapes, but only of the objects whose
        hulls were hit and only by the links that hit them: a hull holds its object's shapes,
        so no other link can touch them. (Confirming with every link against every sample
        compared a few hundred pairs of overlapping bounds per check in clutter.)"""
        exact = self.world.exact
        hulls = _collide(links, self.world.object_manager, _Query(skip, first_only=exact is None))
        if exact is None or not hulls.hits:
            return bool(hulls.hits)
        owner = self.world.owner
        for a, b in hulls.hits:
            link, hull = (a, b) if a in robot.by_geometry else (b, a)
            confirm = _Query(skip)
            exact.of_label(owner[hull]).manager.collide(
                robot.by_geometry[link], None, confirm.__call__
            )
            if confirm.hits:
                return True
        return False

    def hand_checker(self, hand: HandCommand = OPEN_HAND) -> Callable[[np.ndarray], bool]:
        """Whether the links rigid with the TCP (`HAND_RIGID_LINKS`), with the TCP at a pose
        (4x4), are clear of the surface and the objects. They stand alike in every IK solution
        of the pose, so a hit refuses all of them before any is computed: a failing IK then
        costs one check, not the solutions and one check per solution tried
        (`ArmKinematics.select` tries up to 64)."""

        def clear(tcp_pose: np.ndarray) -> bool:
            self.robot.place_hand(tcp_pose, hand)
            links = self.robot.hand_manager
            if _collide(links, self.world.surface_manager, _Query()).hits:
                return False
            return not self._objects_hit(self.robot, links, frozenset())

        return clear

    def clearance_checker(
        self, grown: RobotCollision, hand: HandCommand = OPEN_HAND
    ) -> Callable[[np.ndarray], bool]:
        """Whether the arm at q keeps ``grown.margin`` from every object: ``grown`` (this
        checker's robot with grown primitives) misses them. Surface and self-collision are
        `checker`'s."""

        def clear(q: np.ndarray) -> bool:
            grown.place(q, hand)
            return not self._objects_hit(grown, grown.manager, frozenset())

        return clear

    def touching_objects(self, q: np.ndarray, hand: HandCommand = OPEN_HAND) -> set[str]:
        """Names of the objects the arm penetrates at q (FindPenetrated)."""
        self.robot.place(q, hand)
        query = _collide(self.robot.manager, self.world.object_manager, _Query(first_only=False))
        owner = self.world.owner
        return {owner[g] for pair in query.hits for g in pair if g in owner}

    def swept_objects(
        self, path: np.ndarray, hand: HandCommand = OPEN_HAND, step_rad: float = 0.02
    ) -> set[str]:
        """Names of the objects penetrated anywhere along a joint path (N, 7), sampled so that
        no joint moves more than step_rad between samples (Volume(robot, tau) + FindPenetrated)."""
        found: set[str] = set()
        for q in interpolate(np.asarray(path, dtype=float), step_rad):
            found |= self.touching_objects(q, hand)
        return found

    def checker(
        self, hand: HandCommand = OPEN_HAND, ignore: Iterable[str] = (), objects: bool = True
    ) -> Callable[[np.ndarray], bool]:
        """A collision-free predicate of q, e.g. for ``ArmKinematics.solve_ik(accept=...)``;
        with ``objects=False`` it checks the surface and self-collision only."""
        skip = self.world.geometry_ids(ignore)

        def free(q: np.ndarray) -> bool:
            if not objects:
                return not (self.surface_collision(q, hand) or self.robot.self_collision(q, hand))
            return not self._in_collision(q, hand, skip, self_collision=True)

        return free


def interpolate(path: np.ndarray, step_rad: float) -> np.ndarray:
    """Joint path resampled linearly so that consecutive rows differ by at most step_rad in
    every joint; the original waypoints are kept."""
    if step_rad <= 0:
        raise ValueError("step_rad must be positive")
    rows = [path[:1]]
    for a, b in itertools.pairwise(path):
        n = max(1, int(np.ceil(np.max(np.abs(b - a)) / step_rad)))
        rows.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.concatenate(rows)


def make_checker(
    surface: Surface,
    objects: Mapping[str, tuple[ObjectSpec, Pose]],
    side: str = "right",
    padding: float = SURFACE_PADDING,
) -> CollisionChecker:
    """A checker for one arm of HERB in a scene (``padding=0`` for the exact surface)."""
    return CollisionChecker(
        CollisionWorld(surface, objects, padding),
        RobotCollision(ArmKinematics(side), ArmGeometry()),
    )
