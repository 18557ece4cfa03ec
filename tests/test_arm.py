"""The actions' arm (planners/actions/arm.py): which IK solution it takes, straight lines traced
from either end, and a GoTo that backs the hand out of a narrow pocket."""

from __future__ import annotations

import fcl
import numpy as np
import pytest

from clutter_gym.model.arm_geometry import ArmGeometry
from clutter_gym.model.collision import RobotCollision, Volume, interpolate
from clutter_gym.model.herb import HAND_TCP_OFFSET, RIGHT_ARM_START, HandCommand
from clutter_gym.model.objects import get_object
from clutter_gym.model.reachability import hand_pose
from clutter_gym.model.world import SHELF, TABLE, Surface
from planners.actions.arm import (
    ARM_CHECK_STEP,
    ELBOW_RADIUS,
    END_ZONE,
    GOTO_CLEARANCE,
    SWING_DEVIATION,
    Arm,
)
from planners.actions.settings import Budget, PlannerSettings, PlanStats

#: Hands in the shelf, each (hand_base x, y, heading): poses whose IK solution nearest the home
#: pose has the elbow in the shelf's opening, where a solution with it in front exists.
IN_SHELF = [(0.55, -0.1, -1.0), (0.55, -0.3, 0.5), (0.6, 0.0, -0.5)]
HAND = HandCommand(0.0, 0.4)


def make_arm(surface: Surface, **settings: float) -> Arm:
    return Arm(surface, PlannerSettings(seed=0, **settings), PlanStats(), Budget(60.0))  # type: ignore[arg-type]


def elbow_in_shelf(arm: Arm, q: np.ndarray) -> bool:
    assert SHELF.interior is not None
    low, high = np.array(SHELF.interior).T
    elbow = arm.kinematics.elbow_points(q[None])[0]
    return bool(np.all((elbow > low - ELBOW_RADIUS) & (elbow < high + ELBOW_RADIUS)))


@pytest.mark.parametrize("x, y, heading", IN_SHELF)
def test_in_the_shelf_a_solution_with_the_elbow_in_front_of_it_comes_first(
    x: float, y: float, heading: float
) -> None:
    arm = make_arm(SHELF)
    target = hand_pose(np.array([x, y]), heading, SHELF.top_z + 0.08)
    nearest_home = arm.kinematics.ik_solutions(target)[0]
    assert elbow_in_shelf(arm, nearest_home)
    q = arm.solve(target, lambda q: True)
    assert q is not None
    np.testing.assert_allclose(arm.kinematics.fk_tcp(q), target, atol=1e-6)
    assert not elbow_in_shelf(arm, q)


def test_on_the_table_the_solution_nearest_home_comes_first() -> None:
    arm = make_arm(TABLE)
    target = hand_pose(np.array([0.6, -0.2]), 0.0, TABLE.top_z + 0.08)
    q = arm.solve(target, lambda q: True)
    assert q is not None
    np.testing.assert_array_equal(q, arm.kinematics.ik_solutions(target)[0])


def test_goto_backs_the_hand_out_of_a_pocket_the_planner_alone_cannot_leave() -> None:
    """A synthetic pocket: the goal's hand is in the shelf and the arm is free only along the
    straight line that backs it out toward the shoulder (a 0.03 rad tube) and wherever the hand
    is out of the shelf. RRTConnect alone does not find the tube; GoTo backs out first."""
    arm = make_arm(SHELF, goto_evaluations=5000)
    goal = arm.solve(hand_pose(np.array([0.54, -0.45]), 0.4, SHELF.top_z + 0.08), lambda q: True)
    assert goal is not None
    line = arm._backed_out(goal, lambda q: True)
    assert line is not None
    tube = interpolate(line, ARM_CHECK_STEP / 2)
    front = SHELF.bounds[0]

    def free(q: np.ndarray) -> bool:
        out = arm.kinematics.fk_tcp(q)[0, 3] < front - 0.03
        return bool(out or np.min(np.max(np.abs(tube - q), axis=1)) < 0.03)

    class Pocket:
        """The check GoTo asks: free above, and clear of objects (there are none)."""

        __call__ = free_of_surface_and_self = staticmethod(free)

        def clear(self, q: np.ndarray) -> bool:
            return True

    arm.free_check = lambda obstacles, hand, exact=False: Pocket()  # type: ignore[method-assign]
    start = RIGHT_ARM_START
    plain, reason = arm.plan_path(start, goal, free)
    assert plain is None and reason.startswith("no path found"), reason
    path, reason = arm.goto(start, goal, Volume(), HAND)
    assert path is not None, reason
    np.testing.assert_allclose(path[0], start)
    np.testing.assert_allclose(path[-1], goal)
    assert all(free(q) for q in interpolate(path, ARM_CHECK_STEP))
    # The last stretch is the hand coming straight back in: its TCP on one line.
    tcp = np.array([arm.kinematics.fk_tcp(q)[:3, 3] for q in path[-len(line) :]])
    direction = tcp[-1] - tcp[0]
    off_line = np.cross(tcp - tcp[0], direction / np.linalg.norm(direction))
    assert np.max(np.linalg.norm(off_line, axis=1)) < 1e-3


@pytest.mark.parametrize("evaluations", [None, 77])
@pytest.mark.parametrize("backs_out", [True, False])
def test_goto_backs_out_before_it_gives_up_the_clearance(
    backs_out: bool, evaluations: int | None
) -> None:
    """Where no cleared path joins the ends, GoTo backs the hands out and seeks the cleared path
    between the backed-out configurations, then the plain one there; the plain path between
    the ends themselves only where neither end backs out. Each search is recorded (fakes for
    the searches and the back-out lines), and each gets the request's evaluations (None: the
    settings' own)."""
    arm = make_arm(TABLE)
    start, goal = np.zeros(7), np.full(7, 0.5)
    out_of = {0.0: np.full(7, 0.1), 0.5: np.full(7, 0.4)}
    searches: list[tuple[float, float, str]] = []
    budgets: list[int | None] = []

    def plan_path(
        a: np.ndarray,
        b: np.ndarray,
        check: object,
        constraint: object = None,
        evaluations: int | None = None,
        direct: bool = True,
    ):
        kind = (
            "cleared" if getattr(check, "__qualname__", "").startswith("Arm._cleared") else "plain"
        )
        searches.append((float(a[0]), float(b[0]), kind))
        budgets.append(evaluations)
        found = len(searches) == 3 if backs_out else len(searches) == 2
        return (np.stack([a, b]) if found else None), ("" if found else "no path found within 9")

    def backed_out(q: np.ndarray, free: object) -> np.ndarray | None:
        return np.stack([q, out_of[float(q[0])]]) if backs_out else None

    arm.plan_path = plan_path  # type: ignore[method-assign]
    arm._backed_out = backed_out  # type: ignore[method-assign]
    arm.free_check = lambda obstacles, hand, exact=False: Pocket()  # type: ignore[method-assign]
    arm._line_free = lambda a, b, free: False  # type: ignore[method-assign]

    class Pocket:
        def __call__(self, q: np.ndarray) -> bool:
            return True

        clear = free_of_surface_and_self = __call__

    path, reason = arm.goto(start, goal, Volume(), HAND, evaluations)
    assert path is not None, reason
    if backs_out:
        assert searches == [(0.0, 0.5, "cleared"), (0.1, 0.4, "cleared"), (0.1, 0.4, "plain")]
        np.testing.assert_allclose(path[[0, -1]], [start, goal])
    else:
        assert searches == [(0.0, 0.5, "cleared"), (0.0, 0.5, "plain")]
    assert budgets == [evaluations] * len(searches)


@pytest.mark.parametrize("via_free", [True, False])
def test_goto_comes_straight_in_from_the_goals_backed_out_configuration_before_searching(
    via_free: bool,
) -> None:
    """Where the straight joint line to the goal is blocked but the one to the goal's
    backed-out configuration is free, GoTo takes that and comes straight back in, without a
    search (Table 1 none_00 sigma2's approach cost RRTConnect 3559 collision checks); where
    that line is blocked too, it searches (fakes for the lines, the back-out and the
    search)."""
    arm = make_arm(TABLE)
    start, goal, out = np.zeros(7), np.full(7, 0.5), np.full(7, 0.3)
    lines: list[tuple[float, float]] = []
    searched: list[float] = []

    class Pocket:
        def __call__(self, q: np.ndarray) -> bool:
            return True

        clear = free_of_surface_and_self = __call__

    def line_free(a: np.ndarray, b: np.ndarray, free: object) -> bool:
        lines.append((float(a[0]), float(b[0])))
        return bool(b[0] == 0.3 and via_free)

    def backed_out(q: np.ndarray, free: object) -> np.ndarray | None:
        return np.stack([q, out]) if q[0] == 0.5 else None

    def plan_path(a: np.ndarray, b: np.ndarray, *_: object, **__: object):
        searched.append(float(b[0]))
        return np.stack([a, b]), ""

    arm.free_check = lambda obstacles, hand, exact=False: Pocket()  # type: ignore[method-assign]
    arm._line_free = line_free  # type: ignore[method-assign]
    arm._backed_out = backed_out  # type: ignore[method-assign]
    arm.plan_path = plan_path  # type: ignore[method-assign]
    path, reason = arm.goto(start, goal, Volume(), HAND)
    assert path is not None, reason
    assert lines == [(0.0, 0.5), (0.0, 0.3)]
    if via_free:
        np.testing.assert_allclose(path, [start, out, goal])
        assert not searched
    else:
        assert searched == [0.5]


def test_a_search_within_given_evaluations_stops_there() -> None:
    """`Arm.plan_path` bounds the search by the evaluations given, else the settings' own: a
    goal GoTo cannot reach ends the search at exactly that many."""
    arm = make_arm(TABLE, goto_evaluations=400)
    start = RIGHT_ARM_START
    goal = 0.5 * (arm.kinematics.lower + arm.kinematics.upper)
    assert np.max(np.abs(start - goal)) > 0.2

    def free(q: np.ndarray) -> bool:  # the goal sits in an island no path reaches
        return bool(np.max(np.abs(q - goal)) < 0.05 or np.max(np.abs(q - goal)) > 0.2)

    for evaluations, expected in ((None, 400), (150, 150)):
        path, reason = arm.plan_path(start, goal, free, evaluations=evaluations)
        assert path is None and reason == f"no path found within {expected} evaluations"


def test_a_backed_out_line_is_free_between_its_waypoints() -> None:
    """A line whose waypoints are free but whose joints pass through an obstacle between two of
    them (here: a configuration halfway between its first two waypoints) is not a way out."""
    arm = make_arm(SHELF)
    goal = arm.solve(hand_pose(np.array([0.54, -0.45]), 0.4, SHELF.top_z + 0.08), lambda q: True)
    assert goal is not None
    line = arm._backed_out(goal, lambda q: True)
    assert line is not None and len(line) > 2
    dense = interpolate(line[:2], ARM_CHECK_STEP)
    assert len(dense) > 2  # the first two waypoints are more than one check apart
    clip = dense[len(dense) // 2]

    def free(q: np.ndarray) -> bool:
        return bool(np.max(np.abs(q - clip)) > 1e-9)

    assert all(free(q) for q in line)
    other = arm._backed_out(goal, free)
    assert other is None or not np.array_equal(other, line)
    assert other is None or all(free(q) for q in interpolate(other, ARM_CHECK_STEP))


#: A level hand pushed 0.3 m at -45 deg over the table, (hand_base x, y) where it stops: the
#: solution nearest the home pose there leaves its branch on the way back, the start's does not.
FORWARD_ONLY = (0.7, -0.5, -45.0)


def push_line(
    surface: Surface, x: float, y: float, heading_deg: float, length: float = 0.3
) -> tuple[np.ndarray, ...]:
    heading = np.radians(heading_deg)
    end_xy = np.array([x, y])
    start_xy = end_xy - length * np.array([np.cos(heading), np.sin(heading)])
    z = surface.top_z + 0.075
    return hand_pose(start_xy, heading, z), hand_pose(end_xy, heading, z)


def test_a_line_the_ends_solution_cannot_trace_back_is_traced_from_the_start() -> None:
    arm = make_arm(TABLE)
    free = arm.free_check(Volume(), HAND)
    start, end = push_line(TABLE, *FORWARD_ONLY)
    q_end = arm.solve(end, free)
    assert q_end is not None
    assert arm.straight(q_end, start, free) is None  # the case the forward trace is for
    path = arm.line(q_end, start, end, free)
    assert path is not None
    poses = np.array([arm.kinematics.fk_tcp(q) for q in path])
    np.testing.assert_allclose(poses[0], start, atol=1e-6)
    np.testing.assert_allclose(poses[-1], end, atol=1e-3)
    direction = (end[:3, 3] - start[:3, 3]) / np.linalg.norm(end[:3, 3] - start[:3, 3])
    offsets = poses[:, :3, 3] - start[:3, 3]
    off_line = offsets - np.outer(offsets @ direction, direction)
    assert np.abs(off_line).max() < 1e-3  # straight, and the hand level throughout
    np.testing.assert_allclose(
        poses[:, :3, :3], np.broadcast_to(end[:3, :3], (len(path), 3, 3)), atol=1e-3
    )
    assert np.abs(np.diff(path, axis=0)).max() <= 0.3
    assert all(free(q) for q in path)
    assert arm.line(q_end, start, end, free, lambda q: False) is None  # the start must be free


def test_in_the_shelf_a_line_is_not_traced_from_a_start_with_the_elbow_inside() -> None:
    """A hand pushed 0.2 m toward the right wall, deep in the shelf: the line exists from the
    start's solution, whose elbow stands in the shelf, where GoTo does not bring the arm."""
    arm = make_arm(SHELF)
    free = arm.free_check(Volume(), HAND)
    start, end = push_line(SHELF, 0.65, -0.2, -90.0, length=0.2)
    q_end, q_start = arm.solve(end, free), arm.solve(start, free)
    assert q_end is not None and q_start is not None
    assert arm.straight(q_end, start, free) is None
    assert elbow_in_shelf(arm, q_start) and arm.straight(q_start, end, free) is not None
    assert arm.line(q_end, start, end, free) is None


def test_in_the_shelf_a_lift_swings_the_elbow_from_under_the_ceiling() -> None:
    """A level hand in the shelf whose solution holds the elbow just under the cubby's ceiling:
    lifted 2 cm on its own branch the elbow meets the ceiling; `Arm.straight` swings it to
    another solution of the waypoint, the joints' motion between waypoints clear of the shelf
    and the hand within `SWING_DEVIATION` of the line. On the table no line swings."""
    arm = make_arm(SHELF)
    closed = HandCommand(0.0, 1.0)
    free = arm.free_check(Volume(), closed)
    start = hand_pose(np.array([0.66, -0.30]), np.radians(40.0), SHELF.top_z + 0.075)
    q0 = arm.solve(start, free)
    assert q0 is not None
    lifted = start.copy()
    lifted[2, 3] += 0.02
    assert arm.kinematics.cartesian_path(q0, lifted, 2, accept=free) is None
    path = arm.straight(q0, lifted, free)
    assert path is not None
    dense = interpolate(path, ARM_CHECK_STEP)
    assert len(dense) > len(path)  # the elbow swung: more than one check between waypoints
    assert all(free(q) for q in dense)
    tcp = np.array([arm.kinematics.fk_tcp(q)[:3, 3] for q in dense])
    off_line = tcp[:, :2] - start[:2, 3]
    assert np.abs(off_line).max() <= SWING_DEVIATION
    np.testing.assert_allclose(arm.kinematics.fk_tcp(path[-1]), lifted, atol=1e-3)
    ceiling = arm.kinematics.elbow_points(q0[None])[0, 2] + 1e-4

    def under(q: np.ndarray) -> bool:
        return bool(arm.kinematics.elbow_points(q[None])[0, 2] <= ceiling)

    assert arm.straight(q0, lifted, under) is not None
    assert make_arm(TABLE).straight(q0, lifted, under) is None


def test_a_line_traced_back_from_the_end_is_kept() -> None:
    arm = make_arm(TABLE)
    free = arm.free_check(Volume(), HAND)
    start, end = push_line(TABLE, 0.8, -0.4, -45.0)
    q_end = arm.solve(end, free)
    assert q_end is not None
    back = arm.straight(q_end, start, free)
    assert back is not None
    np.testing.assert_array_equal(arm.line(q_end, start, end, free), back[::-1])


def distance_to(arm: Arm, obstacles: Volume, q: np.ndarray) -> float:
    """fcl's distance from the real arm and hand at q to the nearest part of ``obstacles``."""
    arm.robot.place(q, HAND)
    return min(
        fcl.distance(link, part, fcl.DistanceRequest(), fcl.DistanceResult())
        for link in arm.robot._objects
        for part, _, _ in obstacles.parts
    )


@pytest.fixture(scope="module")
def near_block() -> tuple[Arm, Volume, np.ndarray]:
    """A straight joint line that carries the hand 25 cm sideways over the table, and a 3 cm
    block under the hand's middle configuration, raised until it is 5 mm from the arm."""
    arm = make_arm(TABLE)
    start = arm.solve(hand_pose(np.array([0.70, -0.50]), 0.0, TABLE.top_z + 0.15), lambda q: True)
    assert start is not None
    side = hand_pose(np.array([0.70, -0.25]), 0.0, TABLE.top_z + 0.15)
    across = arm.straight(start, side, lambda q: True)
    assert across is not None
    line = interpolate(across[[0, -1]], ARM_CHECK_STEP / 2)
    below = arm.kinematics.fk_tcp(line[len(line) // 2])[:3, 3]

    def block(z: float) -> Volume:
        return Volume.of_box("block", np.array([*below[:2], z]), (0.03, 0.03, 0.03), 0.0)

    low, high = TABLE.top_z, float(below[2]) - 0.03
    for _ in range(30):  # bisect the block's height for 5 mm to the nearest configuration
        z = (low + high) / 2
        nearest = min(distance_to(arm, block(z), q) for q in line)
        low, high = (z, high) if nearest > 0.005 else (low, z)
    return arm, block(low), line


def test_goto_keeps_its_clearance_from_objects_a_straight_line_passes_nearer(
    near_block: tuple[Arm, Volume, np.ndarray],
) -> None:
    """The straight joint line is free but passes the block nearer than `GOTO_CLEARANCE` (a
    real arm lagging its command grazes it): GoTo plans around, every configuration at least
    `GOTO_CLEARANCE` from the block by fcl's distance."""
    arm, block, line = near_block
    assert all(arm.free_check(block, HAND)(q) for q in line)
    assert 0.0 < min(distance_to(arm, block, q) for q in line) < GOTO_CLEARANCE
    assert min(distance_to(arm, block, q) for q in line[[0, -1]]) > GOTO_CLEARANCE
    path, reason = arm.goto(line[0], line[-1], block, HAND)
    assert path is not None, reason
    assert min(distance_to(arm, block, q) for q in interpolate(path, ARM_CHECK_STEP)) >= (
        GOTO_CLEARANCE - 1e-6
    )


def test_goto_leaves_an_end_nearer_than_its_clearance(
    near_block: tuple[Arm, Volume, np.ndarray],
) -> None:
    """A goal nearer the block than `GOTO_CLEARANCE` (a hand about to push it) is reached;
    the path comes that near only within `END_ZONE` of it."""
    arm, block, line = near_block
    goal = line[int(np.argmin([distance_to(arm, block, q) for q in line]))]
    path, reason = arm.goto(line[0], goal, block, HAND)
    assert path is not None, reason
    np.testing.assert_allclose(path[-1], goal)
    for q in interpolate(path, ARM_CHECK_STEP):
        if np.max(np.abs(q - goal)) > END_ZONE:
            assert distance_to(arm, block, q) >= GOTO_CLEARANCE - 1e-6


def test_goto_comes_nearer_where_no_path_keeps_its_clearance(
    near_block: tuple[Arm, Volume, np.ndarray],
) -> None:
    """With a clearance nothing keeps (every primitive grown by 0.5 m), GoTo still finds the
    path the plain check allows (a passage between objects narrower than the clearance)."""
    _, block, line = near_block
    arm = make_arm(TABLE)
    arm.grown = RobotCollision(arm.kinematics, ArmGeometry(), margin=0.5)
    assert not arm.free_check(block, HAND).clear(line[len(line) // 2])
    path, reason = arm.goto(line[0], line[-1], block, HAND)
    assert path is not None, reason
    assert all(arm.free_check(block, HAND)(q) for q in interpolate(path, ARM_CHECK_STEP))


def test_a_line_whose_end_has_the_hand_in_an_object_is_refused_before_any_waypoint() -> None:
    """The hand's links are rigid with the TCP, so a line ending with them in an object fails
    at its last waypoint whatever the arm does on the way: `Arm.straight` asks that one check
    first (a carry to a placement beside a neighbour, a pull into the front strip)."""
    arm = make_arm(TABLE)
    start, end = push_line(TABLE, 0.8, -0.4, -45.0)
    clear = arm.free_check(Volume(), HAND)
    q0 = arm.solve(start, clear)
    assert q0 is not None
    can = get_object("soda_can")
    palm = end[:2, 3] - HAND_TCP_OFFSET * end[:2, 2]  # the can where the palm ends
    at_end = Volume.of_object("can", can, np.array([[*palm, 0.0]]), TABLE.top_z)
    blocked = arm.free_check(at_end, HAND)
    assert not blocked.hand_clear(end)
    before = arm.stats.collision_checks
    assert arm.straight(q0, end, blocked) is None
    assert arm.stats.collision_checks == before + 1
    # The same line walked waypoint by waypoint fails too (the check changes no answer)...
    assert arm.kinematics.cartesian_path(q0, end, 8, accept=blocked) is None
    # ...and a line whose end is clear is walked: many checks, a path to the end.
    before = arm.stats.collision_checks
    path = arm.straight(q0, end, clear)
    assert path is not None and arm.stats.collision_checks > before + 2
