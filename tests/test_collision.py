"""Tests of the arm collision geometry and the fcl collision layer, with pybullet as reference."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import fcl
import numpy as np
import pybullet
import pytest

from clutter_gym.model import herb as hm
from clutter_gym.model.arm_geometry import ArmGeometry
from clutter_gym.model.collision import (
    HAND_RIGID_LINKS,
    SELF_COLLISION_GROUPS,
    SURFACE_PADDING,
    CollisionChecker,
    CollisionWorld,
    RobotCollision,
    Volume,
    convex_hull,
    interpolate,
    make_checker,
    objects_overlap,
)
from clutter_gym.model.herb import HandCommand, hand_targets, hand_transition
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import OBJECTS, ObjectSpec, Pose
from clutter_gym.model.reachability import approach_rotation
from clutter_gym.model.shapes import Shape
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.world import TABLE
from tests.helpers import HerbBullet, load_herb, transform

CAN_XY = (0.90, -0.30)
#: Table + 3 objects: the can where the test grasps reach, the others nearby.
SCENE: dict[str, tuple[ObjectSpec, Pose]] = {
    "can": (OBJECTS["soda_can"], (*CAN_XY, 0.0)),
    "bottle": (OBJECTS["juice_bottle"], (0.82, -0.05, 0.0)),
    "box": (OBJECTS["poptart_box"], (0.95, -0.52, 0.3)),
}
CLOSED = HandCommand(0.0, 1.0)
#: Over the table, out of reach of the objects even with the fingers flat open.
CLEAR_XY = (0.85, 0.30)


@dataclass
class Bullet(HerbBullet):
    """HERB (left side parked, exact cylinders) and the scene's static bodies."""

    bodies: list[int]

    def set(self, q: np.ndarray, hand: HandCommand) -> None:
        names = hm.arm_joint_names("right") + hm.hand_joint_names("right")
        self.set_joints(names, [*q, *hand_targets(hand)])


@pytest.fixture(scope="module")
def bullet(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Bullet]:
    urdf = hm.write_herb_urdf(Path(tmp_path_factory.mktemp("urdf")), hm.parked_left_side())
    herb = load_herb(urdf, pybullet.URDF_USE_IMPLICIT_CYLINDER)
    c = herb.client
    bodies = [
        c.createMultiBody(
            0, c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=b.half_extents), -1, b.centre
        )
        for b in TABLE.boxes
    ]
    for spec, (x, y, theta) in SCENE.values():
        for p in spec.primitives:
            shape = (
                c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[s / 2 for s in p.dims])
                if p.kind == "box"
                else c.createCollisionShape(
                    pybullet.GEOM_CYLINDER, radius=p.dims[0], height=p.dims[1]
                )
            )
            orientation = c.getQuaternionFromEuler((0.0, 0.0, theta))
            position = (x, y, TABLE.top_z + p.xyz[2])
            bodies.append(c.createMultiBody(0, shape, -1, position, orientation))
    yield Bullet(herb.client, herb.robot, herb.joints, herb.links, bodies)
    c.disconnect()


@pytest.fixture(scope="module")
def checker() -> CollisionChecker:
    # The exact surface, to compare with pybullet; planners pad it by SURFACE_PADDING.
    return make_checker(TABLE, SCENE, padding=0.0)


def tcp_target(
    x: float, y: float, z: float, direction: tuple[float, float] = (1.0, 0.0)
) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = approach_rotation(np.array(direction))
    t[:3, 3] = (x, y, z)
    return t


def solve(kin: ArmKinematics, target: np.ndarray) -> np.ndarray:
    q = kin.solve_ik(target)
    assert q is not None
    return q


def test_primitive_poses_match_pybullet(bullet: Bullet) -> None:
    geometry, kin = ArmGeometry(), ArmKinematics()
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(kin.lower, kin.upper)
        hand = HandCommand(float(rng.uniform()), float(rng.uniform()))
        bullet.set(q, hand)
        poses = geometry.primitive_placements(kin.link_frames(q), hand)[0]
        links = geometry.link_poses(kin.link_frames(q), hand)
        seen: dict[str, int] = {}
        for primitive, pose in zip(geometry.primitives, poses, strict=True):
            index = bullet.links[f"right_{primitive.link}"]
            state = bullet.client.getLinkState(bullet.robot, index, computeForwardKinematics=True)
            k = seen[primitive.link] = seen.get(primitive.link, -1) + 1
            shape = bullet.client.getCollisionShapeData(bullet.robot, index)[k]
            # pybullet gives collision shapes relative to the link's inertial frame.
            expected = transform(state[0], state[1]) @ transform(shape[5], shape[6])
            np.testing.assert_allclose(pose, expected, atol=1e-6)
            np.testing.assert_allclose(
                links[primitive.link], transform(state[4], state[5]), atol=1e-6
            )


def test_home_is_free(checker: CollisionChecker) -> None:
    for hand in (HandCommand(), CLOSED):
        assert not checker.in_collision(hm.RIGHT_ARM_HOME, hand)
        assert not checker.robot.self_collision(hm.RIGHT_ARM_HOME, hand)
        assert not checker.surface_collision(hm.RIGHT_ARM_HOME, hand)


def test_hand_below_table_top_hits_the_table_only(checker: CollisionChecker) -> None:
    q = solve(checker.robot.kinematics, tcp_target(*CLEAR_XY, 0.70))
    assert checker.surface_collision(q)
    assert checker.in_collision(q)
    assert checker.touching_objects(q) == set()


def test_can_at_the_hand_is_named_and_can_be_ignored(checker: CollisionChecker) -> None:
    q = solve(checker.robot.kinematics, tcp_target(*CAN_XY, TABLE.top_z + 0.09))
    assert not checker.surface_collision(q, CLOSED)
    assert checker.touching_objects(q, CLOSED) == {"can"}
    assert checker.in_collision(q, CLOSED)
    assert not checker.in_collision(q, CLOSED, ignore=["can"])
    assert not checker.checker(CLOSED)(q)
    assert checker.checker(CLOSED, ignore=["can"])(q)
    with pytest.raises(KeyError):
        checker.in_collision(q, CLOSED, ignore=["no_such_object"])


def test_swept_objects_names_an_object_between_free_ends(checker: CollisionChecker) -> None:
    kin = checker.robot.kinematics
    z = TABLE.top_z + 0.09
    start = solve(kin, tcp_target(CAN_XY[0], CAN_XY[1] + 0.15, z))
    path = kin.cartesian_path(start, tcp_target(CAN_XY[0], CAN_XY[1] - 0.15, z), 8)
    assert path is not None
    assert not checker.in_collision(path[0], CLOSED)
    assert not checker.in_collision(path[-1], CLOSED)
    assert checker.swept_objects(path, CLOSED) == {"can"}
    assert checker.swept_objects(path[:1], CLOSED) == set()


def test_interpolate_bounds_the_joint_step() -> None:
    path = np.array([np.zeros(7), np.full(7, 0.1), np.r_[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -0.5]])
    dense = interpolate(path, 0.02)
    assert np.max(np.abs(np.diff(dense, axis=0))) <= 0.02 + 1e-12
    for row in path:
        assert np.min(np.linalg.norm(dense - row, axis=1)) < 1e-12


def test_checker_as_ik_accept_gives_free_solutions(checker: CollisionChecker) -> None:
    kin = checker.robot.kinematics
    free = checker.checker(CLOSED, objects=False)
    rng = np.random.default_rng(1)
    assert kin.solve_ik(tcp_target(*CLEAR_XY, 0.70), accept=free) is None
    for _ in range(5):
        x, y = rng.uniform(0.75, 1.0), rng.uniform(-0.6, 0.0)
        q = kin.solve_ik(tcp_target(x, y, TABLE.top_z + 0.08), accept=free)
        assert q is not None
        assert not checker.surface_collision(q, CLOSED)
        assert not checker.robot.self_collision(q, CLOSED)


def random_scene_configurations(kin: ArmKinematics, n: int) -> list[tuple[np.ndarray, HandCommand]]:
    """Half uniform in the limits, half reaching into the objects (where contacts happen)."""
    rng = np.random.default_rng(3)
    out: list[tuple[np.ndarray, HandCommand]] = []
    while len(out) < n:
        hand = HandCommand(float(rng.uniform()), float(rng.uniform()))
        if len(out) % 2:
            out.append((rng.uniform(kin.lower, kin.upper), hand))
            continue
        _, (x, y, _) = SCENE[str(rng.choice(list(SCENE)))]
        heading = rng.uniform(-1.0, 1.0)
        target = tcp_target(
            x + rng.uniform(-0.15, 0.15),
            y + rng.uniform(-0.15, 0.15),
            TABLE.top_z + rng.uniform(0.0, 0.25),
            (np.cos(heading), np.sin(heading)),
        )
        q = kin.solve_ik(target)
        if q is not None:
            out.append((q, hand))
    return out


def test_in_collision_agrees_with_pybullet(checker: CollisionChecker, bullet: Bullet) -> None:
    arm = {bullet.links[f"right_{name}"] for name in checker.robot.geometry.links}
    agree = disagree = in_band = colliding = 0
    for q, hand in random_scene_configurations(checker.robot.kinematics, 200):
        bullet.set(q, hand)
        distance = min(
            (
                point[8]
                for body in bullet.bodies
                for point in bullet.client.getClosestPoints(bullet.robot, body, 0.01)
                if point[3] in arm
            ),
            default=np.inf,
        )
        colliding += distance < 0
        if abs(distance) <= 0.002:
            in_band += 1
        elif checker.in_collision(q, hand, self_collision=False) == (distance < 0):
            agree += 1
        else:
            disagree += 1
    print(f"pybullet agreement {agree}/{agree + disagree}, {in_band} within 2 mm, {colliding} hits")
    assert colliding > 40
    assert disagree <= 0.01 * (agree + disagree)


def test_self_collision_agrees_with_pybullet(checker: CollisionChecker, bullet: Bullet) -> None:
    pairs = [
        (bullet.links[f"right_{a}"], bullet.links[f"right_{b}"])
        for first, second in SELF_COLLISION_GROUPS
        for a, b in itertools.product(first, second)
    ]
    kin = checker.robot.kinematics
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(200):
        q = rng.uniform(kin.lower, kin.upper)
        hand = HandCommand(float(rng.uniform()), float(rng.uniform()))
        bullet.set(q, hand)
        distance = min(
            (
                point[8]
                for a, b in pairs
                for point in bullet.client.getClosestPoints(
                    bullet.robot, bullet.robot, 0.01, linkIndexA=a, linkIndexB=b
                )
            ),
            default=np.inf,
        )
        hits += distance < 0
        if abs(distance) > 0.002:
            assert checker.robot.self_collision(q, hand) == (distance < 0)
    assert hits > 0


def test_planning_pads_the_surface() -> None:
    """A hand 1 cm above the table is free for the exact surface, not for planning."""
    kinematics = ArmKinematics("right")
    target = tcp_target(0.9, -0.3, TABLE.top_z + hm.HAND_PALM_RADIUS + 0.01)
    q = kinematics.solve_ik(target)
    assert q is not None
    assert not make_checker(TABLE, {}, padding=0.0).surface_collision(q)
    assert SURFACE_PADDING > 0.01
    assert make_checker(TABLE, {}).surface_collision(q)


def test_a_hull_hit_is_confirmed_against_the_samples() -> None:
    """avoidVol is the union of the uncertainty samples (Algorithm 1, line 3): the hand may
    stand between two samples of an object, where their convex hull alone would refuse it."""
    kin = ArmKinematics("right")
    samples = np.array([[0.72, -0.45, 0.0], [0.72, 0.05, 0.0]])
    obstacles = Volume.of_object("can", OBJECTS["soda_can"], samples, TABLE.top_z)
    robot = RobotCollision(kin, ArmGeometry())

    def world(**how: bool) -> CollisionChecker:
        return CollisionChecker(CollisionWorld.around(TABLE, obstacles, **how), robot)

    hull_only = CollisionChecker(CollisionWorld.around(TABLE, obstacles.hulled()), robot)
    exact, hulled = world(), world(hulled=True)
    between = solve(kin, tcp_target(0.84, -0.20, TABLE.top_z + 0.08))
    assert hull_only.in_collision(between)
    assert not exact.in_collision(between) and not hulled.in_collision(between)
    at_sample = solve(kin, tcp_target(0.84, -0.45, TABLE.top_z + 0.08))
    assert exact.in_collision(at_sample) and hulled.in_collision(at_sample)
    assert hulled.touching_objects(at_sample) == {"can"}


def test_hulls_confirmed_by_the_links_that_hit_them_answer_as_the_samples_do() -> None:
    """A hull hit is confirmed only against the hit object's samples and only by the links
    that hit its hull: among three neighbours whose few samples spread wide (so that each
    hull covers gaps between them), the hulled world answers every query as the world of the
    samples themselves does, for the arm, the hand alone and the arm grown by a margin."""
    kin, geometry = ArmKinematics("right"), ArmGeometry()
    rng = np.random.default_rng(11)
    obstacles = Volume()
    for name, kind, xy in (
        ("can", "soda_can", (0.78, -0.32)),
        ("bottle", "juice_bottle", (0.80, -0.10)),
        ("box", "poptart_box", (0.92, -0.22)),
    ):
        samples = np.c_[rng.normal(xy, 0.1, (5, 2)), rng.normal(0.0, 0.175, 5)]
        obstacles += Volume.of_object(name, OBJECTS[kind], samples, TABLE.top_z)
    robot, grown = RobotCollision(kin, geometry), RobotCollision(kin, geometry, 0.02)

    def checker(volume: Volume, hulled: bool = False) -> CollisionChecker:
        return CollisionChecker(CollisionWorld.around(TABLE, volume, hulled=hulled), robot)

    exact, hulled = checker(obstacles), checker(obstacles, hulled=True)
    hull_only = checker(obstacles.hulled())
    answers = {True: 0, False: 0}
    # Queries a hull alone refuses and the samples leave free, per checker: where the
    # confirmation changes the answer.
    gaps = {"arm": 0, "hand": 0, "grown": 0}
    for _ in range(150):
        heading = rng.uniform(-0.9, 0.9)
        target = tcp_target(
            rng.uniform(0.62, 0.95),
            rng.uniform(-0.55, 0.08),
            TABLE.top_z + rng.uniform(0.03, 0.25),
            (np.cos(heading), np.sin(heading)),
        )
        solutions = kin.ik_solutions(target)
        if not len(solutions):
            continue
        hand_clear = exact.hand_checker(CLOSED)(target)
        assert hulled.hand_checker(CLOSED)(target) == hand_clear
        gaps["hand"] += hand_clear and not hull_only.hand_checker(CLOSED)(target)
        for q in solutions[:: max(1, len(solutions) // 4)]:
            hit = exact.in_collision(q, CLOSED, self_collision=False)
            assert hulled.in_collision(q, CLOSED, self_collision=False) == hit
            answers[hit] += 1
            gaps["arm"] += not hit and hull_only.in_collision(q, CLOSED, self_collision=False)
            clear = exact.clearance_checker(grown, CLOSED)(q)
            assert hulled.clearance_checker(grown, CLOSED)(q) == clear
            gaps["grown"] += clear and not hull_only.clearance_checker(grown, CLOSED)(q)
    assert answers[True] >= 50 and answers[False] >= 50, answers
    assert min(gaps.values()) >= 5, gaps


def test_a_hand_hit_is_a_hit_of_every_ik_solution_of_the_pose() -> None:
    """`hand_checker` tests the links rigid with the TCP, placed from the TCP pose alone: they
    stand where every IK solution of the pose puts them, and where they hit the surface or an
    object (hulls confirmed by the samples), the full check finds a hit at every solution."""
    kin = ArmKinematics("right")
    geometry = ArmGeometry()
    assert {p.link for p in geometry.primitives} >= set(HAND_RIGID_LINKS)
    samples = np.array([[0.80, -0.30, 0.0], [0.80, -0.20, 0.3]])
    obstacles = Volume.of_object("box", OBJECTS["poptart_box"], samples, TABLE.top_z)
    robot = RobotCollision(kin, geometry)
    checker = CollisionChecker(CollisionWorld.around(TABLE, obstacles, hulled=True), robot)
    hand_clear = checker.hand_checker(CLOSED)
    primitives = zip(robot._objects, geometry.primitives, strict=True)
    rigid = [o for o, p in primitives if p.link in HAND_RIGID_LINKS]

    def rigid_poses() -> np.ndarray:
        return np.array([np.r_[o.getTranslation(), o.getRotation().ravel()] for o in rigid])

    rng = np.random.default_rng(7)
    hand_hits = poses = 0
    while poses < 40:
        heading = rng.uniform(-0.8, 0.8)
        target = tcp_target(
            rng.uniform(0.62, 0.95),
            rng.uniform(-0.45, -0.05),
            TABLE.top_z + rng.uniform(0.0, 0.2),
            (np.cos(heading), np.sin(heading)),
        )
        solutions = kin.ik_solutions(target)
        if not len(solutions):
            continue
        poses += 1
        clear = hand_clear(target)
        from_pose = rigid_poses()
        for q in solutions[:: max(1, len(solutions) // 6)]:
            robot.place(q, CLOSED)
            np.testing.assert_allclose(rigid_poses(), from_pose, atol=1e-9)
        if not clear:
            hand_hits += 1
            assert all(checker.in_collision(q, CLOSED) for q in solutions[::5])
    assert 5 <= hand_hits <= 35, hand_hits


def test_convex_hull_contains_its_points_and_nothing_far() -> None:
    """The qhull-built fcl hull: a small ball at every input point touches it (the hull holds
    them all) and one beyond the points' bounds in each direction does not."""
    rng = np.random.default_rng(3)
    request = fcl.CollisionRequest()
    for _ in range(20):
        points = rng.normal(size=(int(rng.integers(8, 200)), 3)) * rng.uniform(0.05, 0.3, 3)
        hull = fcl.CollisionObject(convex_hull(points), fcl.Transform())
        for p in points[:: max(1, len(points) // 10)]:
            ball = fcl.CollisionObject(fcl.Sphere(1e-3), fcl.Transform(p))
            assert fcl.collide(hull, ball, request, fcl.CollisionResult())
        far = np.abs(points).max(0) + 0.01
        for axis, sign in itertools.product(range(3), (-1, 1)):
            beyond = np.zeros(3)
            beyond[axis] = sign * far[axis]
            ball = fcl.CollisionObject(fcl.Sphere(1e-3), fcl.Transform(beyond))
            assert not fcl.collide(hull, ball, request, fcl.CollisionResult())


def test_a_change_of_hand_command_sweeps_the_fingers_between(checker: CollisionChecker) -> None:
    """Volume(robot, tau) holds the fingers on their way from one command to the next: every
    can the open or the closed hand touches is touched by the trajectory's volume, and some cans
    standing between the open fingers of a wide preshape are touched only on the way."""
    robot = checker.robot
    q = robot.kinematics.solve_ik(tcp_target(0.75, -0.2, TABLE.top_z + 0.075))
    assert q is not None
    wide, closed = HandCommand(0.0, 0.12), HandCommand(0.0, 1.0)
    assert len(hand_transition(wide, closed)) >= 3 and hand_transition(closed, closed) == []
    path = q[None].copy()
    closing = Volume.of_trajectory(
        robot, Trajectory((Segment("push", path, wide), Segment("close", path, closed)))
    )
    ends = Volume.of_robot(robot, path, wide) + Volume.of_robot(robot, path, closed)
    can = OBJECTS["soda_can"]
    only_on_the_way = 0
    for x, y in itertools.product(np.arange(0.70, 1.0, 0.01), np.arange(-0.35, -0.05, 0.01)):
        placed = Volume.of_object("can", can, np.array([x, y, 0.0]), TABLE.top_z)
        hit_ends, hit_closing = placed.intersects(ends), placed.intersects(closing)
        assert hit_closing or not hit_ends
        only_on_the_way += hit_closing and not hit_ends
    assert only_on_the_way > 0


def _touch_part_by_part(a: Volume, b: Volume) -> bool:
    """The reference: every pair of parts through fcl's narrow phase, no broad phase."""
    request = fcl.CollisionRequest()
    return any(
        fcl.collide(pa, pb, request, fcl.CollisionResult())
        for pa, _, _ in a.parts
        for pb, _, _ in b.parts
    )


def _random_volume(rng: np.random.Generator, tag: str) -> Volume:
    """One to three objects, each at up to 80 poses strung along a line with noise: an
    evolution's or an uncertainty region's copies, some near the other volumes."""
    volume = Volume()
    kinds = sorted(OBJECTS)
    for i in range(int(rng.integers(1, 4))):
        count = int(rng.integers(1, 80))
        start = rng.uniform(-0.6, 0.6, 2)
        along = np.linspace(0.0, rng.uniform(0.0, 0.2), count)
        poses = np.column_stack(
            [
                start[0] + along + rng.normal(0.0, 0.02, count),
                start[1] + rng.normal(0.0, 0.02, count),
                rng.uniform(-np.pi, np.pi, count),
            ]
        )
        spec = OBJECTS[kinds[int(rng.integers(len(kinds)))]]
        volume += Volume.of_object(f"{tag}{i}", spec, poses, TABLE.top_z)
    return volume


def test_volume_queries_agree_with_every_pair_of_parts() -> None:
    """`Volume.intersects` tests large volumes asked more than once as bounded groups of
    copies: the answers must stay those of the parts themselves, for sums of volumes, for
    FindPenetrated and whichever side is grouped."""
    rng = np.random.default_rng(7)
    answers = []
    for trial in range(40):
        a, b, c = (_random_volume(rng, f"{side}{trial}_") for side in "abc")
        for x, y in [(a, b), (a, c), (a, b), (b, a), (c, a + b), (a + b, c), (c, a + b)]:
            expected = _touch_part_by_part(x, y)
            assert x.intersects(y) == expected
            answers.append(expected)
        labels = {
            label
            for label in sorted((b + c).labels)
            if _touch_part_by_part(a, Volume(p for p in (b + c).parts if p[2] == label))
        }
        assert a.penetrated(b + c) == labels
    assert 0.2 < np.mean(answers) < 0.8  # both answers are exercised


def _world_pose(obj: fcl.CollisionObject) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = obj.getRotation(), obj.getTranslation()
    return pose


def _fcl_bounds(obj: fcl.CollisionObject, shape: fcl.CollisionGeometry) -> np.ndarray:
    """A placed box's, cylinder's or sphere's world bounds from fcl's pose of it."""
    if isinstance(shape, fcl.Box):
        half = np.asarray(shape.side, dtype=float) / 2
    elif isinstance(shape, fcl.Cylinder):
        half = np.array([shape.radius, shape.radius, shape.lz / 2])
    else:
        half = np.full(3, float(shape.radius))
    extent = np.abs(np.asarray(obj.getRotation())) @ half
    centre = np.asarray(obj.getTranslation(), dtype=float)
    return np.stack([centre - extent, centre + extent])


def test_placed_shapes_stand_at_their_poses_with_their_bounds() -> None:
    """The arm is placed by quaternion (`arm_kernels.placements`) and volumes are built with
    their parts' poses and bounds: the fcl objects of a placed arm, a placed hand and robot and
    object volumes must stand at the primitives' poses, and a volume's poses and bounds (a
    sum's too) be fcl's own."""
    kin, geometry = ArmKinematics("right"), ArmGeometry()
    robot = RobotCollision(kin, geometry)
    rng = np.random.default_rng(11)
    for _ in range(10):
        q = rng.uniform(kin.lower, kin.upper)
        hand = HandCommand(float(rng.uniform()), float(rng.uniform()))
        expected = geometry.primitive_placements(kin.link_frames(q), hand)[0]
        robot.place(q, hand)
        placed = np.array([_world_pose(o) for o in robot._objects])
        np.testing.assert_allclose(placed, expected, atol=1e-12)
        robot.place_hand(kin.fk_tcp(q), hand)
        for i, primitive in enumerate(geometry.primitives):
            if primitive.link in HAND_RIGID_LINKS:
                np.testing.assert_allclose(_world_pose(robot._objects[i]), expected[i], atol=1e-9)
        path = np.stack([q, np.clip(q + rng.normal(0.0, 0.1, 7), kin.lower, kin.upper)])
        arm = Volume.of_robot(robot, path, hand)
        first = np.array([_world_pose(o) for o, _, _ in arm.parts[: len(expected)]])
        np.testing.assert_allclose(first, expected, atol=1e-12)
        objects = _random_volume(rng, "o")
        for volume in (arm, objects, arm + objects, objects + arm):
            from_fcl = np.array([_fcl_bounds(obj, shape) for obj, shape, _ in volume.parts])
            np.testing.assert_allclose(volume.part_bounds(), from_fcl, atol=1e-12)
            poses = np.array([_world_pose(obj)[:3] for obj, _, _ in volume.parts])
            np.testing.assert_allclose(volume.part_poses(), poses, atol=1e-12)


def test_the_floor_map_is_the_lowest_part_bound_over_each_cell() -> None:
    """The compiled floor map against the plain loop over every part's cells."""
    rng = np.random.default_rng(5)
    for trial in range(10):
        volume = _random_volume(rng, f"f{trial}_")
        bounds = volume.part_bounds()
        origin = bounds[:, 0, :2].min(0)
        low = np.floor((bounds[:, 0, :2] - origin) / 0.01).astype(int)
        high = np.floor((bounds[:, 1, :2] - origin) / 0.01).astype(int)
        expected = np.full(high.max(0) + 1, np.inf)
        for (i0, j0), (i1, j1), z in zip(low, high, bounds[:, 0, 2], strict=True):
            cells = expected[i0 : i1 + 1, j0 : j1 + 1]
            np.minimum(cells, z, out=cells)
        np.testing.assert_array_equal(volume._floor_map().lowest, expected)


def test_clear_above_is_the_lowest_over_each_box_above_the_height() -> None:
    """The goal's quick test asks, for many candidate outcomes at once, whether every pose of
    each certainly misses the NGR: row by row it must be the per-box answer's minimum against
    the height, boxes off the map, partly on it and empty rows of the map included."""
    rng = np.random.default_rng(3)
    answers = []
    for trial in range(30):
        volume = _random_volume(rng, f"v{trial}_")
        for count in (1, 5, 40):
            centres = rng.uniform(-0.9, 0.9, (6, count, 2))
            half = rng.uniform(0.01, 0.12, (6, count, 2))
            boxes = np.stack(
                [centres[..., 0] - half[..., 0], centres[..., 0] + half[..., 0]]
                + [centres[..., 1] - half[..., 1], centres[..., 1] + half[..., 1]],
                axis=-1,
            )
            for height in TABLE.top_z + rng.uniform(-0.02, 0.25, 3):
                expected = [volume.lowest_over(row).min() > height for row in boxes]
                assert volume.clear_above(boxes, height).tolist() == expected
                answers += expected
    assert 0.2 < np.mean(answers) < 0.8  # both answers are exercised


def test_a_grown_arm_is_clear_only_of_objects_at_least_its_margin_away() -> None:
    """`clearance_checker` against fcl's own distances between the real primitives and the
    objects: clear means at least the margin away; every box or cylinder at least margin * sqrt(3)
    away (a grown box's corner) is clear; nearer objects are found."""
    kin = ArmKinematics("right")
    geometry = ArmGeometry()
    margin = 0.01
    real, grown = RobotCollision(kin, geometry), RobotCollision(kin, geometry, margin)
    rng = np.random.default_rng(3)
    outcomes = {"near": 0, "far": 0}
    for _ in range(120):
        heading = rng.uniform(-0.6, 0.6)
        target = tcp_target(0.80, -0.25, TABLE.top_z + 0.10, (np.cos(heading), np.sin(heading)))
        q = solve(kin, target)
        hand = HandCommand(0.0, float(rng.uniform(0.0, 0.6)))
        xy = target[:2, 3] + rng.uniform(-0.14, 0.14, 2)
        name = str(rng.choice(["soda_can", "poptart_box"]))
        obstacles = Volume.of_object(name, OBJECTS[name], np.array([[*xy, 0.3]]), TABLE.top_z)
        checker = CollisionChecker(CollisionWorld.around(TABLE, obstacles), real)
        clear = checker.clearance_checker(grown, hand)(q)
        real.place(q, hand)
        distance = min(
            fcl.distance(arm, part, fcl.DistanceRequest(), fcl.DistanceResult())
            for arm in real._objects
            for part, _, _ in obstacles.parts
        )
        if clear:
            assert distance >= margin - 1e-6
        if distance >= margin * np.sqrt(3.0) + 1e-6:
            assert clear
        outcomes["near" if distance < margin else "far"] += 1
    assert min(outcomes.values()) >= 10  # both sides of the margin were tried


@pytest.mark.parametrize("kinds", list(itertools.combinations_with_replacement(sorted(OBJECTS), 2)))
def test_objects_overlap_answers_as_fcl_does(kinds: tuple[str, str]) -> None:
    """The planar test of two objects standing on one surface says what fcl says of their
    volumes, on pose sets near enough that about half of them penetrate (single poses a few
    centimetres apart across the boundary, and sets of a few poses, spread by the objects'
    sizes)."""
    a, b = (OBJECTS[k] for k in kinds)
    rng = np.random.default_rng(sum(map(ord, "".join(kinds))))
    spread = 0.75 * (a.footprint.bounding_radius + b.footprint.bounding_radius)
    hits = 0
    for trial in range(300):
        sizes = (1, 1) if trial % 2 else (4, 3)
        poses = [
            np.column_stack([rng.uniform(-spread, spread, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
            for n in sizes
        ]
        fcl_says = Volume.of_object("a", a, poses[0], 0.7).intersects(
            Volume.of_object("b", b, poses[1], 0.7)
        )
        assert objects_overlap(a, poses[0], b, poses[1]) == fcl_says, (kinds, poses)
        hits += fcl_says
    assert 30 <= hits <= 270  # both answers, many times


def test_objects_overlap_sees_heights() -> None:
    """A flat mat under the dumbbell's handle, between its heads, overlaps it from above but
    not in height: apart, as fcl says; raised into the handle, they meet."""
    dumbbell = OBJECTS["dumbbell"]
    flat = Shape("box", (0.1, 0.02, 0.02), (0.0, 0.0, 0.01))
    mat = replace(OBJECTS["poptart_box"], kind="mat", primitives=(flat,))
    under = np.zeros((1, 3))
    assert not Volume.of_object("m", mat, under, 0.0).intersects(
        Volume.of_object("d", dumbbell, under, 0.0)
    )
    assert not objects_overlap(mat, under, dumbbell, under)
    raised = replace(mat, primitives=(Shape("box", (0.1, 0.02, 0.02), (0.0, 0.0, 0.05)),))
    assert objects_overlap(raised, under, dumbbell, under)
