"""HERB's right arm as the actions use it: collision checks against obstacle volumes (counted),
IK, straight TCP lines and GoTo, all within the plan's budget.

This is the one object through which the actions reach the collision checker, the IK and the
GoTo planner; it is passed to them beside the `PlanningContext`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.arm_geometry import ArmGeometry
from clutter_gym.model.collision import (
    CollisionChecker,
    CollisionWorld,
    RobotCollision,
    Volume,
    interpolate,
)
from clutter_gym.model.herb import HandCommand, hand_transition
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.reachability import HEIGHTS, shipped_map
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.transforms import rotation_log
from clutter_gym.model.world import Surface
from planners.actions.settings import Budget, PlannerSettings, PlanStats
from planners.goto import NO_PATH, JointConstraint, plan_goto

ARM_CHECK_STEP = 0.02
"""rad between collision-checked configurations along a motion."""
WAYPOINT_SPACING = 0.025
"""m between waypoints of straight hand motions."""
POSE_KEY_DECIMALS = 9
"""Target poses equal to this many decimals share their analytic IK solutions (`Arm.solve`)."""
CHECKS_KEPT = 256
"""Collision checks `Arm.free_check` keeps (the most recently used), each with its IK answers."""
ELBOW_RADIUS = 0.055
"""m: the radius of the WAM's elbow (the wam4 joint cylinder); an elbow centre this near a
surface's interior stands in its opening (`Arm._select`)."""
GOTO_CLEARANCE = 0.01
"""m a GoTo path keeps from every object, but near an end that stands closer (`Arm.goto`): a
path simplified onto the objects' surfaces grazes them once the real arm lags its command by a
few mrad or a placed object stands a few mm off its planned pose (a finger grazing a placed
can's rim toppled it)."""
END_ZONE = 0.1
"""rad (every joint) around a GoTo end nearer than `GOTO_CLEARANCE` to an object within which
the path may stay that near: the arm leaves such an end (a hand beside what it released or is
about to push) before the clearance holds."""
BACK_OUT = (0.25, 0.15)
"""m the hand backs straight out of a narrow pocket before GoTo plans again (`Arm.goto`),
longest first."""
SWING_DEVIATION = 0.01
"""m the TCP may leave the straight line while a swung waypoint turns the elbow
(`Arm.straight`: the joints move linearly between waypoints, and the hand with them)."""
SWING_TILT = 0.1
"""rad the hand may turn away from the line's orientation meanwhile."""

Free = Callable[[np.ndarray], bool]
"""Whether the arm is collision-free at a configuration (the ``accept`` of IK)."""
IKSolver = Callable[[np.ndarray, Free], np.ndarray | None]
"""An IK solver: a configuration putting the TCP at a pose (4x4) that ``accept`` takes, or None."""


class ArmCheck:
    """The counted ``accept`` of the arm's IK and motions (`Arm.free_check`): the arm at q with
    a hand command clear of the surface, itself and the obstacles. `hand_clear` checks only the
    links rigid with the TCP at a TCP pose, where every IK solution of the pose puts them."""

    def __init__(
        self,
        checker: CollisionChecker,
        hand: HandCommand,
        stats: PlanStats,
        grown: RobotCollision,
    ) -> None:
        self._free = checker.checker(hand)
        self._hand = checker.hand_checker(hand)
        self._clear = checker.clearance_checker(grown, hand)
        self._unloaded = checker.checker(hand, objects=False)
        self._unloaded_grown = CollisionChecker(checker.world, grown).checker(hand, objects=False)
        self._stats = stats
        #: `Arm.solve`'s answers under this check, by target pose.
        self.solved: dict[bytes, np.ndarray | None] = {}

    def __call__(self, q: np.ndarray) -> bool:
        self._stats.collision_checks += 1
        return self._free(q)

    def hand_clear(self, tcp_pose: np.ndarray) -> bool:
        self._stats.collision_checks += 1
        return self._hand(tcp_pose)

    def clear(self, q: np.ndarray) -> bool:
        """Whether the arm at q keeps `GOTO_CLEARANCE` from the obstacles."""
        self._stats.collision_checks += 1
        return self._clear(q)

    def free_of_surface_and_self(self, q: np.ndarray) -> bool:
        """The check without the obstacles (for a q already `clear` of them). The grown arm,
        which `clear` has just placed at q, answers first: it holds the arm, so where it misses
        the surface and itself the arm does, without placing the arm's own shapes (placing
        them is most of a check's cost)."""
        self._stats.collision_checks += 1
        return self._unloaded_grown(q) or self._unloaded(q)


class Arm:
    """The right arm's kinematics and collision model, with the plan's budget and counters."""

    def __init__(
        self,
        surface: Surface,
        settings: PlannerSettings,
        stats: PlanStats,
        budget: Budget,
        ik: IKSolver | None = None,
    ) -> None:
        """``ik`` replaces the analytic IK (`bench plan` compares a random-restart reference)."""
        self.surface = surface
        self.settings = settings
        self.stats = stats
        self.budget = budget
        self.kinematics = ArmKinematics("right")
        self.robot = RobotCollision(self.kinematics, ArmGeometry())
        self.grown = RobotCollision(self.kinematics, ArmGeometry(), GOTO_CLEARANCE)
        self.reach = shipped_map(surface.name)
        # The planner asks for the same poses again and again with other obstacles: each
        # pose's analytic IK solutions (seeded by the home pose) are computed once.
        self._solutions: dict[bytes, np.ndarray] = {}
        # ... and each (pose, obstacles, hand)'s answer once: the actions ask for the same
        # start of a sweep or push under every parent candidate (`free_check`).
        self._checks: dict[tuple[int, HandCommand, bool], tuple[Volume, ArmCheck]] = {}
        self._ik = ik

    @property
    def heading_origin(self) -> np.ndarray:
        """Where push, grasp and sweep directions are measured from (`PlannerSettings`)."""
        origin = self.settings.heading_origin
        return self.kinematics.shoulder if origin is None else np.asarray(origin, dtype=float)

    # -- collision ------------------------------------------------------------------------------
    def free_check(self, obstacles: Volume, hand: HandCommand, exact: bool = False) -> ArmCheck:
        """Counted predicate: the arm at q with ``hand`` is clear of surface, itself and
        ``obstacles``, the union of every object's uncertainty samples (each object's convex
        hull first, the samples themselves only where a hull is hit; with ``exact`` the samples
        alone: for the hand moving away from an object it has just placed). The same volume
        and hand get the same check (`CHECKS_KEPT` of them), with the IK answers found under
        it."""
        key = (id(obstacles), hand, exact)
        kept = self._checks.pop(key, None)  # re-inserted last: the least recently used go
        if kept is None:
            with self.stats.timed("collision"):
                world = CollisionWorld.around(self.surface, obstacles, hulled=not exact)
                check = ArmCheck(CollisionChecker(world, self.robot), hand, self.stats, self.grown)
            kept = (obstacles, check)
            if len(self._checks) >= CHECKS_KEPT:
                del self._checks[next(iter(self._checks))]
        # The volume is kept with its check: its id stays its own while the entry lives.
        self._checks[key] = kept
        return kept[1]

    def motion_free(self, segments: Iterable[Segment], obstacles: Volume) -> bool:
        """Whether every segment is clear of ``obstacles``, checked every `ARM_CHECK_STEP`."""
        with self.stats.timed("collision"):
            for s in segments:
                free = self.free_check(obstacles, s.hand)
                if not all(free(q) for q in interpolate(s.path, ARM_CHECK_STEP)):
                    return False
            return True

    def hand_change_free(
        self, q: np.ndarray, start: HandCommand, end: HandCommand, obstacles: Volume
    ) -> bool:
        """Whether the fingers stay clear of ``obstacles`` while the hand command changes from
        ``start`` to ``end`` at configuration ``q`` (`hand_transition`)."""
        with self.stats.timed("collision"):
            return all(self.free_check(obstacles, hand)(q) for hand in hand_transition(start, end))

    def volume(self, trajectory: Trajectory) -> Volume:
        """Volume(robot, tau), sampled every `ARM_CHECK_STEP`."""
        return Volume.of_trajectory(self.robot, trajectory, ARM_CHECK_STEP)

    # -- inverse kinematics ---------------------------------------------------------------------
    def solve(self, target: np.ndarray, accept: Free) -> np.ndarray | None:
        """The first collision-free configuration in `_ordered` order putting the TCP at
        ``target`` (4x4), or None. A horizontal hand the reachability map says no arm
        configuration reaches is refused at once, without IK (about half the IK solves of a
        cluttered scene fail)."""
        with self.stats.timed("reach"):
            unreachable = self._unreachable(target)
        if unreachable:
            self.stats.ik_skipped += 1
            return None
        with self.stats.timed("ik"):
            if self._ik is not None:
                return self._ik(target, accept)
            key = (np.round(target, POSE_KEY_DECIMALS) + 0.0).tobytes()  # + 0.0: no -0.0
            if not isinstance(accept, ArmCheck):
                return self._select(key, target, accept)
            if key not in accept.solved:
                clear = accept.hand_clear(target)  # else the hand stands there in every solution
                accept.solved[key] = self._select(key, target, accept) if clear else None
            q = accept.solved[key]
            return None if q is None else q.copy()

    def _select(self, key: bytes, target: np.ndarray, accept: Free) -> np.ndarray | None:
        """The first of the pose's analytic solutions (computed once per pose, `_ordered`)
        ``accept`` takes."""
        solutions = self._solutions.get(key)
        if solutions is None:
            solutions = self._solutions[key] = self._ordered(self.kinematics.ik_solutions(target))
        return self.kinematics.select(solutions, accept)

    def _ordered(self, solutions: np.ndarray) -> np.ndarray:
        """The solutions nearest the home pose first; in an enclosed surface (the shelf) those
        with the elbow in its interior or opening after all others: the arm gets there only
        through the opening: all seven approaches one shelf scene lost (no path in 50000
        evaluations either) went to postures with the elbow in the opening, and for three of
        those poses GoTo reached other solutions, with the elbow in front."""
        if not len(solutions):
            return solutions
        return solutions[np.argsort(self._elbow_inside(solutions), kind="stable")]

    def elbow_inside(self, q: np.ndarray) -> bool:
        """Whether the arm at q stands with the elbow within its radius of the surface's
        interior (`_elbow_inside`): in the shelf, the postures GoTo rarely finds a way into."""
        return bool(self._elbow_inside(np.asarray(q, dtype=float)[None])[0])

    def _elbow_inside(self, qs: np.ndarray) -> np.ndarray:
        """Which configurations (N, 7) stand with the elbow within its radius of the surface's
        interior (none on an open surface)."""
        interior = self.surface.interior
        if interior is None:
            return np.zeros(len(qs), dtype=bool)
        low, high = np.array(interior).T
        elbows = self.kinematics.elbow_points(qs)
        return np.all((elbows > low - ELBOW_RADIUS) & (elbows < high + ELBOW_RADIUS), axis=1)

    def line_heights(self, start_xy: np.ndarray, end_xy: np.ndarray, heading: float) -> list[float]:
        """TCP heights above the support to try, lowest first (`PUSH_HEIGHT`; §2.2.1: objects
        are pushed "as low as possible"), for a horizontal hand moving straight from hand_base
        ``start_xy`` to ``end_xy`` at ``heading``: the map's heights at which it rules out no
        point of the line, asked at the map's own resolution (a line whose ends it allows may
        skirt the hole in front of the shoulder). Far out the forearm slopes down to the
        support and the lowest may be out of reach."""
        if self.reach is None:
            return list(HEIGHTS)
        with self.stats.timed("reach"):
            start, end = np.asarray(start_xy, dtype=float), np.asarray(end_xy, dtype=float)
            length = float(np.linalg.norm(end - start))
            steps = max(1, math.ceil(length / self.reach.grid.resolution))
            points = start + np.linspace(0.0, 1.0, steps + 1)[:, None] * (end - start)
            return [h for h in HEIGHTS if not self.reach.rules_out_any(points, heading, h)]

    def _unreachable(self, target: np.ndarray) -> bool:
        """Whether the map rules the target out (only for a horizontal hand on its grid)."""
        if self.reach is None or abs(target[2, 0] - 1.0) > 1e-6 or abs(target[2, 2]) > 1e-6:
            return False
        approach = target[:3, 2]
        hand_base = target[:2, 3] - hm.HAND_TCP_OFFSET * approach[:2]
        heading = math.atan2(approach[1], approach[0])
        height = float(target[2, 3]) - self.surface.top_z
        return self.reach.may_reach(hand_base, heading, height) is False

    def straight(self, q_start: np.ndarray, target: np.ndarray, accept: Free) -> np.ndarray | None:
        """Straight TCP line from q_start to target (4x4), waypoints every WAYPOINT_SPACING.
        In an enclosed surface (the shelf) a waypoint that would end the line may swing the
        elbow to another solution of its pose (`ArmKinematics.swung_waypoint`) where the
        motion there is clear at every `ARM_CHECK_STEP` and keeps the hand on the line
        (`_swing_keeps_line`): under the cubby's ceiling the elbow of a push's end often
        stands within millimetres of it, and the goal's 2 cm lift, the pull out or the next
        line would run it in. On shelf high scenes 0-49 (pushing, sigma2, planning alone)
        this planned 18 scenes where lines without it planned 15, and lost none.

        A line whose end has the hand (`ArmCheck.hand_clear`) in collision is refused before
        any waypoint: its last waypoint stands there in every solution (shelf high scene 4:
        the goal's pulls into the front strip that failed took 0.17 s instead of 2.0 s, each
        walked to its end with swung waypoints before)."""
        if isinstance(accept, ArmCheck) and not accept.hand_clear(target):
            return None
        distance = float(np.linalg.norm(target[:3, 3] - self.kinematics.fk_tcp(q_start)[:3, 3]))
        n = max(2, math.ceil(distance / WAYPOINT_SPACING) + 1)
        connect = None
        if self.surface.interior is not None:

            def connect(q_from: np.ndarray, q_to: np.ndarray) -> bool:
                return self._swing_keeps_line(q_from, q_to, accept)

        with self.stats.timed("ik"):
            return self.kinematics.cartesian_path(
                q_start, target, n, accept=accept, connect=connect
            )

    def _swing_keeps_line(self, q_from: np.ndarray, q_to: np.ndarray, accept: Free) -> bool:
        """Whether the joints moving linearly from ``q_from`` to ``q_to`` (two waypoints of a
        straight line) keep the arm clear (``accept`` every `ARM_CHECK_STEP`), the TCP within
        `SWING_DEVIATION` of the line and the hand within `SWING_TILT` more than the
        waypoints' own turn of the first waypoint's orientation."""
        between = interpolate(np.stack([q_from, q_to]), ARM_CHECK_STEP)[1:-1]
        if not len(between):
            return True
        first, last = (self.kinematics.fk_tcp(q) for q in (q_from, q_to))
        p0 = first[:3, 3]
        axis = (last[:3, 3] - p0) / max(float(np.linalg.norm(last[:3, 3] - p0)), 1e-12)
        turn = _angle(last[:3, :3] @ first[:3, :3].T) + SWING_TILT
        for q in between:
            tcp = self.kinematics.fk_tcp(q)
            offset = tcp[:3, 3] - p0
            if np.linalg.norm(offset - (offset @ axis) * axis) > SWING_DEVIATION:
                return False
            if _angle(tcp[:3, :3] @ first[:3, :3].T) > turn:
                return False
        return all(accept(q) for q in between)

    def line(
        self,
        q_end: np.ndarray,
        start: np.ndarray,
        end: np.ndarray,
        free: Free,
        free_at_start: Free | None = None,
    ) -> np.ndarray | None:
        """A straight TCP line from ``start`` to ``end`` (4x4), rows from start to end, or None:
        traced back from ``q_end`` (an IK solution at ``end``), else forward from the start's
        IK solution. The end's solution nearest the home pose can leave its branch partway (a
        wrist or j3 limit) where the start's stays on one: of the 71 lines a lone pop-tart box's
        push-grasps traced back in vain, 48 were straight from the start. In an enclosed
        surface a start with the elbow in the interior is not taken: there the end's line
        had failed, and GoTo found no way in to any of the 24 such starts one shelf scene
        offered (`_ordered`). ``free_at_start`` (default ``free``) must also take the first
        configuration."""
        first = free if free_at_start is None else free_at_start
        back = self.straight(q_end, start, free)
        if back is not None and first(back[-1]):
            return back[::-1].copy()
        q_start = self.solve(start, first)
        if q_start is None or self.elbow_inside(q_start):
            return None
        return self.straight(q_start, end, free)

    # -- GoTo ------------------------------------------------------------------------------------
    def goto(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        obstacles: Volume,
        hand: HandCommand,
        evaluations: int | None = None,
    ) -> tuple[np.ndarray | None, str]:
        """GoTo: a joint path from start to goal clear of ``obstacles`` (and surface, itself),
        each search within ``evaluations`` (default the settings' `goto_evaluations`).

        The path keeps `GOTO_CLEARANCE` from the obstacles but within `END_ZONE` of an end
        nearer than that (`_cleared`). Where the straight joint line is blocked, the line to
        the goal's backed-out configuration (below) and the hand's straight way in from there
        come before any search: most approaches are blocked only near the goal, where the hand
        comes in (Table 1 none_00 sigma2: RRTConnect spent 3559 collision checks on one).
        Where RRTConnect finds no such path, an end usually
        stands in a narrow pocket (a hand beside what it released or among the shelf's walls:
        seven approaches one shelf scene lost found no path with 50000 evaluations either,
        and from none could the hand move 5 cm toward the robot). A real hand leaves such a
        place the way it came: straight. Each end backs its hand out (`_backed_out`) and GoTo
        plans between the backed-out configurations, with the clearance, then without it (a
        passage narrower than the hand and twice the clearance). Only where neither end can
        back out is the plain path between the ends sought: measured on the shelf, the figure
        variants and Table 1, every GoTo a plain search rescued there after the cleared one
        failed had a cleared path between backed-out ends (found in 600-5000 evaluations,
        where each failing search spends 5000)."""
        free = self.free_check(obstacles, hand)
        cleared = self._cleared(free, (start, goal))
        if self._line_free(start, goal, cleared):
            return np.stack([start, goal]), ""
        enter = self._backed_out(goal, free)
        if enter is not None and self._line_free(
            start, enter[-1], self._cleared(free, (start, enter[-1]))
        ):
            return np.concatenate([start[None], enter[::-1]]), ""
        path, reason = self.plan_path(start, goal, cleared, evaluations=evaluations, direct=False)
        # An end the cleared check refuses is one the plain check refuses (`_cleared`).
        if path is not None or not reason.startswith(NO_PATH):
            return path, reason
        leave = self._backed_out(start, free)
        if leave is None and enter is None:
            return self.plan_path(start, goal, free, evaluations=evaluations)
        first = start if leave is None else leave[-1]
        last = goal if enter is None else enter[-1]
        for check in (self._cleared(free, (first, last)), free):
            middle, _ = self.plan_path(first, last, check, evaluations=evaluations)
            if middle is None:
                continue
            parts = [middle] if leave is None else [leave[:-1], middle]
            path = np.concatenate(parts if enter is None else [*parts, enter[-2::-1]])
            return path, ""
        return None, reason

    def _line_free(self, start: np.ndarray, goal: np.ndarray, free: Free) -> bool:
        """Whether the straight joint segment from start to goal is ``free`` at both ends
        and every `ARM_CHECK_STEP` between them."""
        self.budget.check()
        with self.stats.timed("goto"):
            return all(free(q) for q in interpolate(np.stack([start, goal]), ARM_CHECK_STEP))

    @staticmethod
    def _cleared(check: ArmCheck, ends: tuple[np.ndarray, ...]) -> Free:
        """``check``, and `GOTO_CLEARANCE` from the obstacles except within `END_ZONE` of an
        end that stands nearer."""
        near = [np.asarray(e, dtype=float) for e in ends if not check.clear(e)]

        def free(q: np.ndarray) -> bool:
            if check.clear(q):  # the grown arm misses the obstacles, so the arm does
                return check.free_of_surface_and_self(q)
            return any(np.max(np.abs(q - e)) <= END_ZONE for e in near) and check(q)

        return free

    def _backed_out(self, q: np.ndarray, free: Free) -> np.ndarray | None:
        """A straight hand motion from q out of where it stands, or None: toward the shoulder
        (out of the shelf's opening), back along the hand's approach axis, or up, by each of
        `BACK_OUT` in turn; free at its waypoints and every `ARM_CHECK_STEP` between them (a
        line whose joints swing between waypoints may clip an object there: stop 47's first
        order of GoTo's searches lost a shelf scene's approach to one)."""
        tcp = self.kinematics.fk_tcp(q)
        toward = self.kinematics.shoulder - tcp[:3, 3]
        toward[2] = 0.0
        toward /= max(float(np.linalg.norm(toward)), 1e-9)
        for direction in (toward, -tcp[:3, 2], np.array([0.0, 0.0, 1.0])):
            for distance in BACK_OUT:
                target = tcp.copy()
                target[:3, 3] += distance * direction
                path = self.straight(q, target, free)
                if path is not None and all(free(q) for q in interpolate(path, ARM_CHECK_STEP)):
                    return path
        return None

    def plan_path(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        free: Free,
        constraint: JointConstraint | None = None,
        evaluations: int | None = None,
        direct: bool = True,
    ) -> tuple[np.ndarray | None, str]:
        """`plan_goto` within this plan's budget and seed and ``evaluations`` (default the
        settings' `goto_evaluations`; ``direct`` as there): (path or None, reason)."""
        self.budget.check()
        with self.stats.timed("goto"):
            result = plan_goto(
                start,
                goal,
                free,
                self.kinematics.lower,
                self.kinematics.upper,
                time_budget=max(self.budget.remaining(), 1e-3),
                seed=self.settings.seed,
                resolution=ARM_CHECK_STEP,
                constraint=constraint,
                max_evaluations=evaluations or self.settings.goto_evaluations,
                direct=direct,
            )
        return result.path, result.reason


def _angle(rotation: np.ndarray) -> float:
    """The angle (rad) of a rotation matrix."""
    return float(np.linalg.norm(rotation_log(rotation)))
