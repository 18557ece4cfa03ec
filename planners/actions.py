"""The action library of the framework (§2.1.6) with the interface of Eq. 1:
``a(o, G, avoidVol) -> (tau, nu_o)`` or nothing.

Each action is a generator of candidates, best first by its heuristic, so that Rearrange can
backtrack into the next parametrisation when a later check (the GoTo to the next action, a
recursive call) fails. Every candidate satisfies the paper's two conditions: nu_o[1] is inside
G for every uncertainty sample, and Volume(robot, tau) and Volume(o, nu_o) are free of avoidVol.

* Push-grasp (§2.2): a straight push of the hand, horizontal at grasp height, that the capture
  region guarantees ends with every sample between the fingers. Searched over the direction v
  (ordered by §2.2.6's heuristic: objects hit by the hand on its way), the aperture and the
  lateral offset. For the goal object it is PickUp: close and lift (table) or close and pull
  into the goal strip (shelf). For an obstacle the hand opens flat and backs away: the object
  stays where the capture region put it, inside the hand's pocket.
* Sweep (§2.1.6, Fig. 7): the outer side of the hand pushes the object sideways, far enough
  that every sample of nu_o[1] is in G, guarded by the sweep capture region.
* GoTo: `planners.goto` in the 7-DoF joint space against avoidVol (see `PlanningContext.goto`).
"""

from __future__ import annotations

import math
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache
from typing import Protocol

import fcl
import numpy as np

from clutter_gym.objects import Footprint, ObjectSpec
from clutter_gym.robot import herb_model as hm
from clutter_gym.robot.geometry import Hand
from clutter_gym.robot.kinematics import ArmKinematics
from clutter_gym.world import Surface
from planners.capture import (
    CaptureRegion,
    SweepRegion,
    extreme_parameters,
    push_grasp_apertures,
    push_grasp_region,
    sweep_region,
)
from planners.collision import (
    CollisionChecker,
    CollisionWorld,
    RobotCollision,
    Volume,
    interpolate,
)
from planners.direct_grasp import LIFT, approach_rotation, grasp_height
from planners.frames import Frame2D
from planners.goto import JointConstraint, plan_goto, upright_hand
from planners.hand2d import (
    PushGraspProfile,
    closure_for_aperture,
    push_grasp_profile,
    sweep_profile,
)
from planners.tsr import GraspTSR, grasps_every_sample
from planners.uncertainty import ObjectBelief

GRASP_CLOSURE = 1.0
OPEN_FLAT = 0.0  # closure 0: fingers flat in the palm plane, nothing in front to drag the object
PUSH_MARGIN = 0.01  # m pushed beyond the capture region's requirement
START_CLEARANCE = 0.01  # m between the hand's front and the nearest sample's bounding circle
WAYPOINT_SPACING = 0.025  # m between waypoints of straight hand motions
RETREAT = 0.06  # m the open hand backs away from a pushed obstacle
RISE = 0.10  # m the hand rises after releasing an obstacle
HAND_BELOW_TCP = hm.HAND_PALM_RADIUS  # m: a horizontal hand's lowest point under its TCP
RISE_CLEARANCE = 0.03  # m between the risen hand and the top of the object it released
CARRY_LIFT = 0.15  # m: pick-and-place carries the object this far above where it stood
PLACEMENT_SPACING = 0.05  # m between candidate placements and between carried-volume poses
PLACEMENT_TRIES = 6  # placements in G tried per grasp, nearest first
TSR_DRAWS = 300  # hand poses drawn from a TSR per aperture (seeded)
TSR_DEPTH = 0.08  # m: the TSR's depth bound, behind the grasp line
TSR_IK_TRIES = 12  # static-grasp poses tried with IK and motions per aperture
TSR_SPREAD = math.radians(4.0)  # rad between the headings of the poses tried
SHELF_LIFT = 0.02  # m: on the shelf the goal is lifted clear of the board, then pulled out
ARM_CHECK_STEP = 0.02  # rad between collision-checked configurations along a motion
NU_SPACING = 0.02  # m of push between stored stages of nu_o
NU_STEP = 0.005  # m: simulation step of nu_o (regions are built at 1 mm; nu_o is a volume)
PILOT_STEP = 0.01  # m: simulation step of the one-sample pilot of a sweep
SWEEP_CHUNK = 0.06  # m of sweep simulated before checking whether the object has reached G
STABLE_MARGIN = 0.01  # m: in the shelf, the footprint stays this far inside the walls
TABLE_EDGE_MARGIN = 0.05  # m: on the table, the centre of mass stays this far from the edge


# --------------------------------------------------------------------------------------------
# Trajectories
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Segment:
    """Part of a robot trajectory with one hand command: joint rows (N, 7) and (spread,
    closure); the env moves through the rows in order and changes the hand at the first."""

    label: str
    path: np.ndarray
    hand: Hand

    def rows(self) -> np.ndarray:
        """(N, 9) rows in the env's trajectory action format."""
        hand = np.tile(np.asarray(self.hand, dtype=float), (len(self.path), 1))
        return np.hstack([self.path, hand])


@dataclass(frozen=True)
class Motion:
    """A robot trajectory tau as segments."""

    segments: tuple[Segment, ...]

    @property
    def start(self) -> np.ndarray:
        return self.segments[0].path[0]

    @property
    def end(self) -> np.ndarray:
        return self.segments[-1].path[-1]

    @property
    def end_hand(self) -> Hand:
        return self.segments[-1].hand

    def rows(self) -> np.ndarray:
        return np.vstack([s.rows() for s in self.segments])

    def volume(self, robot: RobotCollision) -> Volume:
        """Volume(robot, tau)."""
        total = Volume()
        for s in self.segments:
            total += Volume.of_robot(robot, s.path, s.hand, ARM_CHECK_STEP)
        return total

    def __add__(self, other: Motion) -> Motion:
        return Motion(self.segments + other.segments)


@dataclass(frozen=True)
class ActionResult:
    """(tau, nu_o) of Eq. 1 with what produced it."""

    action: str  # "push-grasp", "pickup" or "sweep"
    obj: str
    motion: Motion
    nu: np.ndarray  # (stages, M, 3) world poses of the samples; nu[0] = U(o), nu[-1] the end
    held: bool  # the object ends in the closed hand
    details: dict[str, float]
    carried: Volume = field(default_factory=Volume)  # a held object on its way (pick-and-place)


# --------------------------------------------------------------------------------------------
# Goals
# --------------------------------------------------------------------------------------------
class Goal(Protocol):
    """G: which final states of the object are acceptable."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool: ...

    def describe(self) -> str: ...


@dataclass(frozen=True)
class Retrieve:
    """The goal object's G: grasped with every sample in the hand (then lifted or pulled out)."""

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        return held

    def describe(self) -> str:
        return "in the hand"


@dataclass(frozen=True)
class AwayFrom:
    """StablePoses(o) - NGR: standing on the surface, clear of the negative goal region."""

    ngr: Volume

    def accepts(self, ctx: PlanningContext, name: str, final: np.ndarray, held: bool) -> bool:
        if held or not ctx.stable(name, final):
            return False
        near = self._near(ctx, name, final)
        if not near.any():
            return True
        spec = ctx.beliefs[name].spec
        placed = Volume.of_object(name, spec, final[near], ctx.surface.top_z)
        # The hull of the poses near the NGR contains them all: clear hull, clear poses. One
        # convex shape is far cheaper for the broad phase than a hundred overlapping boxes.
        if not placed.hulled().intersects(self.ngr):
            return True
        return not placed.intersects(self.ngr)

    def clearly_accepts(self, ctx: PlanningContext, name: str, final: np.ndarray) -> bool:
        """A quick sufficient test: stable, and every pose's bounding square clears the NGR
        in the top-view map (no exact geometry)."""
        return ctx.stable(name, final) and not self._near(ctx, name, final).any()

    def _near(self, ctx: PlanningContext, name: str, final: np.ndarray) -> np.ndarray:
        spec = ctx.beliefs[name].spec
        r = spec.footprint.bounding_radius
        boxes = np.column_stack(
            [final[:, 0] - r, final[:, 0] + r, final[:, 1] - r, final[:, 1] + r]
        )
        return self.ngr.lowest_over(boxes) <= ctx.surface.top_z + spec.height

    def describe(self) -> str:
        return "out of the negative goal region"


# --------------------------------------------------------------------------------------------
# Context
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlannerSettings:
    """Search resolution and budgets (the paper's "user defined step sizes", §2.2.6)."""

    time_budget: float = 20.0  # s for the whole plan
    # Evaluations per GoTo request (collision checks; with a constraint, also its Jacobians):
    # about 1 s here, and a count, not seconds, so that plans do not depend on the machine's load.
    goto_evaluations: int = 5000
    heading_step_deg: float = 15.0
    max_heading_deg: float = 75.0  # push directions within this of the shoulder-object line
    offsets: tuple[float, ...] = (0.0, 0.01, -0.01, 0.02, -0.02)
    sweep_max: float = 0.55  # m
    sweep_step_deg: float = 30.0
    candidates_per_action: int = 3
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("goto_evaluations", "heading_step_deg", "sweep_max", "sweep_step_deg"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"PlannerSettings.{name}: {value!r}; must be > 0")
        if not (math.isfinite(self.time_budget) and self.time_budget >= 0):
            raise ValueError(f"PlannerSettings.time_budget: {self.time_budget!r}; must be >= 0")
        if self.candidates_per_action < 1:
            raise ValueError(
                f"PlannerSettings.candidates_per_action: {self.candidates_per_action}; must be >= 1"
            )


@dataclass
class PlanStats:
    """What planning cost: steps (recursive calls), candidates tried, checks, time by part."""

    planning_steps: int = 0
    actions_tried: int = 0
    collision_checks: int = 0
    seconds: dict[str, float] = field(default_factory=lambda: defaultdict(float))

    def as_dict(self) -> dict[str, object]:
        return {
            "planning_steps": self.planning_steps,
            "actions_tried": self.actions_tried,
            "collision_checks": self.collision_checks,
            "seconds": {k: round(v, 4) for k, v in sorted(self.seconds.items())},
        }


class BudgetExceeded(Exception):
    """The plan's time budget ran out."""


@cache
def _push_region(footprint: Footprint, aperture: float) -> CaptureRegion:
    return push_grasp_region(footprint, aperture)


@cache
def _sweep_region(footprint: Footprint) -> SweepRegion:
    return sweep_region(footprint)


class PlanningContext:
    """Everything one planning request shares: the beliefs, the robot, budgets and statistics."""

    def __init__(
        self,
        surface: Surface,
        beliefs: dict[str, ObjectBelief],
        settings: PlannerSettings,
        kinematics: ArmKinematics,
        robot: RobotCollision,
        goal_region: tuple[tuple[float, float], tuple[float, float]],
    ) -> None:
        self.surface = surface
        self.goal_region = goal_region
        self.beliefs = beliefs
        self.settings = settings
        self.kinematics = kinematics
        self.robot = robot
        self.rng = np.random.default_rng(settings.seed)
        self.stats = PlanStats()
        self.deadline = time.perf_counter() + settings.time_budget
        #: Why candidates failed, per (object, action): the planner's account of what blocked it.
        self.failures: dict[tuple[str, str], Counter[str]] = defaultdict(Counter)
        self._volumes: dict[str, Volume] = {}

    # -- budget and bookkeeping -------------------------------------------------------------
    def remaining(self) -> float:
        return self.deadline - time.perf_counter()

    def check_budget(self) -> None:
        if self.remaining() <= 0:
            raise BudgetExceeded

    def fail(self, name: str, action: str, reason: str) -> None:
        self.failures[(name, action)][reason] += 1

    def timed(self, part: str) -> _Timer:
        return _Timer(self.stats, part)

    # -- geometry -----------------------------------------------------------------------------
    def uncertainty_volume(self, name: str) -> Volume:
        """Volume(i, U(i)), cached."""
        if name not in self._volumes:
            b = self.beliefs[name]
            self._volumes[name] = Volume.of_object(name, b.spec, b.samples, self.surface.top_z)
        return self._volumes[name]

    def objects_volume(self, names: Iterable[str]) -> Volume:
        """Sum of Volume(i, U(i)) over the named objects (the avoid volume)."""
        total = Volume()
        for name in sorted(names):
            total += self.uncertainty_volume(name)
        return total

    def free_check(
        self, obstacles: Volume, hand: Hand, exact: bool = False
    ) -> Callable[[np.ndarray], bool]:
        """Counted predicate: the arm at q with ``hand`` is clear of surface, itself and
        ``obstacles`` (each object's uncertainty samples as one convex hull, or with ``exact``
        every sample: for the hand moving away from an object it has just placed)."""
        world = CollisionWorld.around(self.surface, obstacles if exact else obstacles.hulled())
        checker = CollisionChecker(world, self.robot)
        free = checker.checker(hand)

        def counted(q: np.ndarray) -> bool:
            self.stats.collision_checks += 1
            return free(q)

        return counted

    def motion_free(self, segments: tuple[Segment, ...], obstacles: Volume) -> bool:
        for s in segments:
            free = self.free_check(obstacles, s.hand)
            if not all(free(q) for q in interpolate(s.path, ARM_CHECK_STEP)):
                return False
        return True

    def stable(self, name: str, poses: np.ndarray) -> bool:
        """StablePoses: upright on the surface. On the open table the centre of mass must be
        over the top (an overhanging box stands); in the shelf the outline must be inside the
        walls."""
        footprint = self.beliefs[name].spec.footprint
        x0, x1, y0, y1 = self.surface.bounds
        p = np.asarray(poses).reshape(-1, 3)
        if self.surface.name == "table":
            m = TABLE_EDGE_MARGIN
            return bool(
                np.all((p[:, 0] > x0 + m) & (p[:, 0] < x1 - m))
                and np.all((p[:, 1] > y0 + m) & (p[:, 1] < y1 - m))
            )
        m = STABLE_MARGIN
        for pose in p:
            lo_x, hi_x, lo_y, hi_y = footprint.aabb(tuple(pose))
            if lo_x < x0 + m or hi_x > x1 - m or lo_y < y0 + m or hi_y > y1 - m:
                return False
        return True

    # -- motions ------------------------------------------------------------------------------
    def tcp_pose(self, hand_base_xy: np.ndarray, heading: float, z: float) -> np.ndarray:
        """TCP pose of a horizontal hand whose hand_base is at (x, y, z), approach at heading."""
        direction = np.array([math.cos(heading), math.sin(heading), 0.0])
        pose = np.eye(4)
        pose[:3, :3] = approach_rotation(direction)
        pose[:3, 3] = np.r_[hand_base_xy, z] + hm.HAND_TCP_OFFSET * direction
        return pose

    def straight(
        self,
        q_start: np.ndarray,
        target: np.ndarray,
        accept: Callable[[np.ndarray], bool],
    ) -> np.ndarray | None:
        """Straight TCP line from q_start to target (4x4), waypoints every WAYPOINT_SPACING."""
        distance = float(np.linalg.norm(target[:3, 3] - self.kinematics.fk_tcp(q_start)[:3, 3]))
        n = max(2, math.ceil(distance / WAYPOINT_SPACING) + 1)
        with self.timed("ik"):
            return self.kinematics.cartesian_path(q_start, target, n, accept=accept)

    def solve(self, target: np.ndarray, accept: Callable[[np.ndarray], bool]) -> np.ndarray | None:
        with self.timed("ik"):
            return self.kinematics.solve_ik(
                target, hm.RIGHT_ARM_HOME, self.rng, accept=accept, max_restarts=8
            )

    def goto(
        self, start: np.ndarray, goal: np.ndarray, obstacles: Volume, hand: Hand
    ) -> tuple[np.ndarray | None, str]:
        """GoTo: a joint path from start to goal clear of ``obstacles`` (and surface, itself)."""
        return self.plan_path(start, goal, self.free_check(obstacles, hand))

    def plan_path(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        free: Callable[[np.ndarray], bool],
        constraint: JointConstraint | None = None,
    ) -> tuple[np.ndarray | None, str]:
        """`plan_goto` within this plan's budget and seed: (path or None, reason)."""
        self.check_budget()
        with self.timed("goto"):
            result = plan_goto(
                start,
                goal,
                free,
                self.kinematics.lower,
                self.kinematics.upper,
                time_budget=max(self.remaining(), 1e-3),
                seed=self.settings.seed,
                resolution=ARM_CHECK_STEP,
                constraint=constraint,
                max_evaluations=self.settings.goto_evaluations,
            )
        return result.path, result.reason

    # -- capture regions ----------------------------------------------------------------------
    def push_region(self, footprint: Footprint, aperture: float) -> CaptureRegion:
        with self.timed("capture"):
            return _push_region(footprint, aperture)

    def sweep_region(self, footprint: Footprint) -> SweepRegion:
        with self.timed("capture"):
            return _sweep_region(footprint)


class _Timer:
    def __init__(self, stats: PlanStats, part: str) -> None:
        self.stats, self.part = stats, part

    def __enter__(self) -> None:
        self.began = time.perf_counter()

    def __exit__(self, *_: object) -> None:
        self.stats.seconds[self.part] += time.perf_counter() - self.began


# --------------------------------------------------------------------------------------------
# Heuristic (§2.2.6)
# --------------------------------------------------------------------------------------------
def _corridor_hits(
    ctx: PlanningContext, name: str, start: np.ndarray, end: np.ndarray, width: float
) -> int:
    """Objects other than ``name`` whose U overlaps a box swept from start to end (2D) at the
    hand's height: the paper's count of objects hit when the hand turns around the object."""
    delta = end - start
    length = float(np.linalg.norm(delta))
    if length < 1e-9:
        return 0
    yaw = math.atan2(delta[1], delta[0])
    c, s = math.cos(yaw), math.sin(yaw)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre = np.r_[(start + end) / 2, ctx.surface.top_z + 0.10]
    geometry = fcl.Box(length, width, 0.12)
    corridor = Volume(
        [(fcl.CollisionObject(geometry, fcl.Transform(rotation, centre)), geometry, "corridor")]
    )
    hits = 0
    for other in ctx.beliefs:
        if other != name and corridor.intersects(ctx.uncertainty_volume(other)):
            hits += 1
    return hits


def _base_heading(ctx: PlanningContext, xy: np.ndarray) -> float:
    """Yaw of the line from the right shoulder to a point: the arm's most comfortable push."""
    d = xy - ctx.kinematics.shoulder[:2]
    return math.atan2(d[1], d[0])


def _headings(ctx: PlanningContext, base: float, step_deg: float) -> list[float]:
    step = math.radians(step_deg)
    limit = math.radians(ctx.settings.max_heading_deg) + 1e-9
    count = int(limit // step)
    return [base + k * step for k in range(-count, count + 1)]


def _push_headings(ctx: PlanningContext, name: str, reach: float) -> list[float]:
    """Push directions ordered by §2.2.6: fewest objects hit by the hand on its way in and by
    the object and fingers on their way on, then closest to the shoulder-object line."""
    centre = ctx.beliefs[name].samples[0, :2]
    base = _base_heading(ctx, centre)
    radius = ctx.beliefs[name].spec.footprint.bounding_radius
    scored = []
    for h in _headings(ctx, base, ctx.settings.heading_step_deg):
        v = np.array([math.cos(h), math.sin(h)])
        hits = _corridor_hits(ctx, name, centre - (radius + 0.30) * v, centre, 2 * reach)
        # Where the object and the fingers go: pushing it into others is as bad.
        hits += _corridor_hits(ctx, name, centre, centre + (radius + 0.15) * v, 2 * reach)
        scored.append((hits, abs(h - base), h))
    return [h for _, _, h in sorted(scored)]


def _sweep_directions(ctx: PlanningContext, name: str) -> list[tuple[float, int]]:
    """(sweep direction, handedness) pairs whose hand approach is within reach, ordered by the
    objects the swept object would run into, then by how natural the approach is."""
    belief = ctx.beliefs[name]
    centre = belief.samples[0, :2]
    base = _base_heading(ctx, centre)
    radius = belief.spec.footprint.bounding_radius
    limit = math.radians(ctx.settings.max_heading_deg) + 1e-9
    scored = []
    step = math.radians(ctx.settings.sweep_step_deg)
    for k in range(round(2 * math.pi / step)):
        angle = k * step
        for handedness in (1, -1):
            approach = angle + handedness * math.pi / 2
            off = abs(math.remainder(approach - base, 2 * math.pi))
            if off > limit:
                continue
            v = np.array([math.cos(angle), math.sin(angle)])
            hits = _corridor_hits(ctx, name, centre + radius * v, centre + 0.30 * v, 2 * radius)
            scored.append((hits, off, angle, handedness))
    return [(a, h) for _, _, a, h in sorted(scored)]


# --------------------------------------------------------------------------------------------
# Push-grasp and PickUp
# --------------------------------------------------------------------------------------------
def _unfit(spec: ObjectSpec, pushed: bool, lifted: bool) -> str:
    """Why the hand cannot grasp the object (and push it, and lift it), or "" if it can."""
    if not spec.graspable:
        return "wider than the hand can hold"
    if pushed and not spec.pushable:
        return "tips over when pushed"
    if lifted and not spec.liftable:
        return "too heavy to lift"
    return ""


def push_grasp(
    ctx: PlanningContext, name: str, goal: Goal, avoid: Volume
) -> Iterator[ActionResult]:
    """Push-grasps of ``name`` (PickUp when G is `Retrieve`), best heading first."""
    belief = ctx.beliefs[name]
    spec = belief.spec
    action = "pickup" if isinstance(goal, Retrieve) else "push-grasp"
    unfit = _unfit(spec, pushed=True, lifted=action == "pickup")
    if unfit:
        ctx.fail(name, action, unfit)
        return
    # The goal is grasped from the widest preshape first: closing from a narrow one pops a
    # tall bottle up out of the hand in simulation (the Table 1 suite at sigma1).
    apertures = sorted(push_grasp_apertures(spec.footprint), reverse=action == "pickup")
    reach = push_grasp_profile(max(apertures)).pusher.bounds[3]
    found = 0
    for heading in _push_headings(ctx, name, reach):
        for aperture in apertures:
            result = None
            for offset in ctx.settings.offsets:
                ctx.check_budget()
                ctx.stats.actions_tried += 1
                result = _push_grasp_at(ctx, name, goal, avoid, action, heading, aperture, offset)
                if not isinstance(result, _Uncaptured):
                    break  # offsets shift the hand by a centimetre: they only help the capture
            if not isinstance(result, ActionResult):
                continue
            yield result
            found += 1
            if found >= ctx.settings.candidates_per_action:
                return
            break  # the next candidate pushes from another direction
    if action == "pickup":
        # A push-grasp with no push (d = 0) is a static grasp (§3.1.2): the hand poses of the
        # goal's TSR come after the discrete directions, so PG plans wherever TSR does.
        for result in static_grasp(ctx, name, goal, avoid):
            yield result
            found += 1
            if found >= ctx.settings.candidates_per_action:
                return


class _Uncaptured:
    """A push-grasp whose capture region misses samples: another lateral offset may help."""


def _push_grasp_at(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    heading: float,
    aperture: float,
    offset: float,
) -> ActionResult | _Uncaptured | None:
    belief = ctx.beliefs[name]
    spec = belief.spec
    region = ctx.push_region(spec.footprint, aperture)
    profile = push_grasp_profile(aperture)
    v = np.array([math.cos(heading), math.sin(heading)])
    normal = np.array([-v[1], v[0]])
    centre = belief.samples[0, :2] + offset * normal
    local = Frame2D((float(centre[0]), float(centre[1])), heading).to_frame(belief.samples)
    x_front = profile.pusher.bounds[1]
    back_off = _near_edge(spec.footprint, local) - x_front - START_CLEARANCE
    start_xy = centre + back_off * v
    frame = Frame2D((float(start_xy[0]), float(start_xy[1])), heading)
    in_hand = frame.to_frame(belief.samples)
    with ctx.timed("capture"):
        inside, need = region.query(in_hand)
    if not inside.all():
        ctx.fail(name, action, "the capture region misses some uncertainty samples")
        return _Uncaptured()
    distance = float(min(need.max() + PUSH_MARGIN, region.d_max))

    def evolve() -> np.ndarray:
        stages = max(1, math.ceil(distance / NU_SPACING))
        with ctx.timed("nu"):
            advances = np.linspace(0.0, distance, stages + 1)
            chosen = extreme_parameters(region.mus, region.cs)
            nu_hand = region.evolve(in_hand, distance, stages, NU_STEP, chosen)
            return _to_world(frame, nu_hand, advances)

    details = {
        "heading_deg": math.degrees(heading),
        "aperture_m": aperture,
        "offset_m": offset,
        "push_m": distance,
    }
    end_xy = start_xy + distance * v
    line = (start_xy, end_xy)
    return _hand_in(ctx, name, goal, avoid, action, line, heading, profile, evolve, details)


def _hand_in(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    profile: PushGraspProfile,
    evolve: Callable[[], np.ndarray],
    details: dict[str, float],
) -> ActionResult | None:
    """The hand moves straight in at grasp height from ``line[0]`` to ``line[1]`` (hand_base
    positions) while the object's samples go through ``evolve()`` (nu_o, computed only once
    the arm's motion is known to be feasible); then PickUp (the goal), release
    (a pushed obstacle) or pick-and-place (a grasped obstacle)."""
    spec = ctx.beliefs[name].spec
    start_xy, end_xy = line
    z = ctx.surface.top_z + grasp_height(spec.height)
    hand: Hand = (0.0, profile.closure)
    free = ctx.free_check(avoid, hand)
    q_end = ctx.solve(ctx.tcp_pose(end_xy, heading, z), free)
    if q_end is None:
        ctx.fail(name, action, "no collision-free IK solution where the hand stops")
        return None
    back = ctx.straight(q_end, ctx.tcp_pose(start_xy, heading, z), free)
    if back is None:
        ctx.fail(name, action, "the straight push is out of reach or hits avoidVol")
        return None
    push = Segment("push", back[::-1].copy(), hand)
    if not ctx.motion_free((push,), avoid):
        ctx.fail(name, action, "the arm hits avoidVol during the push")
        return None
    nu = evolve()
    if Volume.of_object(name, spec, nu.reshape(-1, 3), ctx.surface.top_z).intersects(avoid):
        ctx.fail(name, action, "the object's uncertainty sweeps into avoidVol")
        return None
    if action == "pick-and-place":
        placed = _pick_and_place(ctx, name, goal, q_end, end_xy, heading, z, nu[-1], avoid)
        if placed is None:
            return None
        segments, final, carried = placed
        nu = np.stack([nu[0], final])
        return ActionResult(action, name, Motion((push, *segments)), nu, False, details, carried)
    held = action == "pickup"
    if not goal.accepts(ctx, name, nu[-1], held):
        ctx.fail(name, action, f"the object does not end {goal.describe()}")
        return None
    if held:
        finish, carried_poses = _retrieve(ctx, q_end, end_xy, heading, z, nu[-1], avoid)
        if finish is None:
            ctx.fail(name, action, "no collision-free lift or pull out after the grasp")
            return None
        nu = np.concatenate([nu, carried_poses])
    else:
        finish = _release(ctx, name, q_end, end_xy, heading, z, nu[-1], avoid)
        if finish is None:
            ctx.fail(name, action, "no collision-free retreat after the push")
            return None
    return ActionResult(action, name, Motion((push, *finish)), nu, held, details)


def _retrieve(
    ctx: PlanningContext,
    q_end: np.ndarray,
    end_xy: np.ndarray,
    heading: float,
    z: float,
    in_hand: np.ndarray,
    avoid: Volume,
) -> tuple[tuple[Segment, ...] | None, np.ndarray]:
    """Close the fingers, then lift (table) or lift slightly and pull the object into the
    goal strip (shelf). Returns the segments and the carried object's poses."""
    closed: Hand = (0.0, GRASP_CLOSURE)
    close = Segment("close", q_end[None].copy(), closed)
    free = ctx.free_check(avoid, closed)
    if ctx.surface.success == "lift":
        lift = ctx.straight(q_end, ctx.tcp_pose(end_xy, heading, z + LIFT), free)
        if lift is None:
            return None, np.empty((0, len(in_hand), 3))
        return (close, Segment("lift", lift, closed)), np.empty((0, len(in_hand), 3))
    raise_ = ctx.straight(q_end, ctx.tcp_pose(end_xy, heading, z + SHELF_LIFT), free)
    if raise_ is None:
        return None, np.empty((0, len(in_hand), 3))
    (x0, x1), _ = ctx.goal_region
    shift = np.array([(x0 + x1) / 2 - float(in_hand[:, 0].mean()), 0.0])
    target = ctx.tcp_pose(end_xy + shift, heading, z + SHELF_LIFT)
    pull = ctx.straight(raise_[-1], target, free)
    if pull is None:
        # Blocked or out of reach in a straight line: carry the object along any path that
        # keeps it upright (GoTo on the constraint manifold).
        pull = _carry(ctx, raise_[-1], target, free)
    if pull is None:
        return None, np.empty((0, len(in_hand), 3))
    carried = _carried_poses(ctx, pull, in_hand)
    return (close, Segment("lift", raise_, closed), Segment("pull", pull, closed)), carried


def _carry(
    ctx: PlanningContext,
    q_start: np.ndarray,
    target: np.ndarray,
    free: Callable[[np.ndarray], bool],
) -> np.ndarray | None:
    """GoTo with a grasped object kept upright (the hand's finger plane horizontal)."""
    q_goal = ctx.solve(target, free)
    if q_goal is None:
        return None
    path, _ = ctx.plan_path(q_start, q_goal, free, upright_hand(ctx.kinematics))
    return path


def _carried_poses(ctx: PlanningContext, path: np.ndarray, in_hand: np.ndarray) -> np.ndarray:
    """Object sample poses (S, N, 3) along a carrying path: rigidly attached to the TCP in the
    plane (the hand stays level), every NU_SPACING of TCP travel."""
    tcps = ctx.kinematics.fk_tcp_batch(path)
    xy, yaw = tcps[:, :2, 3], np.arctan2(tcps[:, 1, 2], tcps[:, 0, 2])
    travel = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
    marks = np.arange(NU_SPACING, travel[-1] + NU_SPACING, NU_SPACING).clip(max=travel[-1])
    rows = np.unique(np.searchsorted(travel, marks).clip(max=len(path) - 1))
    stages = []
    for k in rows:
        turn = yaw[k] - yaw[0]
        c, s = math.cos(turn), math.sin(turn)
        rel = in_hand[:, :2] - xy[0]
        moved = xy[k] + rel @ np.array([[c, s], [-s, c]])
        stages.append(np.column_stack([moved, in_hand[:, 2] + turn]))
    return np.stack(stages) if stages else np.empty((0, len(in_hand), 3))


def _release(
    ctx: PlanningContext,
    name: str,
    q_end: np.ndarray,
    end_xy: np.ndarray,
    heading: float,
    z: float,
    final: np.ndarray,
    avoid: Volume,
) -> tuple[Segment, ...] | None:
    """Open the hand flat and back away, leaving a pushed obstacle where it is."""
    opened: Hand = (0.0, OPEN_FLAT)
    release = Segment("release", q_end[None].copy(), opened)
    v = np.array([math.cos(heading), math.sin(heading)])
    back_xy = end_xy - RETREAT * v
    retreat = ctx.straight(q_end, ctx.tcp_pose(back_xy, heading, z), ctx.free_check(avoid, opened))
    if retreat is None:
        return None
    spec = ctx.beliefs[name].spec
    placed = avoid + Volume.of_object(name, spec, final, ctx.surface.top_z)
    rise = ctx.straight(
        retreat[-1],
        ctx.tcp_pose(back_xy, heading, _rise_height(ctx, spec.height, z)),
        ctx.free_check(placed, opened, exact=True),
    )
    if rise is None:
        return None
    return (release, Segment("retreat", retreat, opened), Segment("rise", rise, opened))


# --------------------------------------------------------------------------------------------
# Static grasp (the uncertainty TSR planner's PickUp) and pick-and-place
# --------------------------------------------------------------------------------------------
def static_grasp(
    ctx: PlanningContext, name: str, goal: Goal, avoid: Volume
) -> Iterator[ActionResult]:
    """Direct grasps without pushing: hand poses drawn from the object's TSR that grasp every
    uncertainty sample as it stands. PickUp for the goal object; an obstacle is picked up,
    carried out of the NGR and put down (pick-and-place, §3.2.1)."""
    belief = ctx.beliefs[name]
    spec = belief.spec
    action = "pickup" if isinstance(goal, Retrieve) else "pick-and-place"
    unfit = _unfit(spec, pushed=False, lifted=True)
    if unfit:
        ctx.fail(name, action, unfit)
        return
    centre = belief.samples[0, :2]
    base = _base_heading(ctx, centre)
    limit = math.radians(ctx.settings.max_heading_deg)

    def still() -> np.ndarray:
        """nu_o of a static grasp: the samples stay where they are until the fingers close."""
        return np.stack([belief.samples, belief.samples])

    found: list[float] = []
    for aperture in sorted(push_grasp_apertures(spec.footprint), reverse=True):
        ctx.check_budget()
        region = ctx.push_region(spec.footprint, aperture)
        profile = push_grasp_profile(aperture)
        tsr = GraspTSR(
            (float(centre[0]), float(centre[1])),
            (base - limit, base + limit),
            (-profile.half_gap, profile.half_gap),
            (profile.grasp_line - TSR_DEPTH, profile.grasp_line),
        )
        draws = tsr.sample(ctx.rng, TSR_DRAWS)
        with ctx.timed("capture"):
            draws = draws[grasps_every_sample(region, tsr, draws, belief.samples)]
        if not len(draws):
            ctx.fail(name, action, "no hand pose in the TSR grasps every uncertainty sample")
            continue
        # §2.2.6's order of the push directions (objects hit on the way in first), then the
        # most centred between the fingers.
        ranked = np.array(_push_headings(ctx, name, profile.pusher.bounds[3]))
        rank = np.abs(np.remainder(draws[:, :1] - ranked + np.pi, 2 * np.pi) - np.pi).argmin(1)
        draws = draws[np.lexsort((np.abs(draws[:, 1]), rank))]
        tried: list[float] = []
        for heading, lateral, depth in draws:
            if len(tried) >= TSR_IK_TRIES:
                break
            near_found = any(
                abs(heading - h) < math.radians(ctx.settings.heading_step_deg) for h in found
            )
            near_tried = any(abs(heading - h) < TSR_SPREAD for h in tried)
            if near_found or near_tried:
                continue  # a pose from nearly the same direction fails (or works) the same way
            ctx.check_budget()
            ctx.stats.actions_tried += 1
            tried.append(float(heading))
            frame = tsr.hand_frame(heading, lateral, depth)
            end_xy = np.asarray(frame.origin)
            back = (
                profile.pusher.bounds[1]
                + START_CLEARANCE
                - _near_edge(spec.footprint, frame.to_frame(belief.samples))
            )
            start_xy = end_xy - max(back, START_CLEARANCE) * frame.x_axis
            details = {
                "heading_deg": math.degrees(heading),
                "aperture_m": aperture,
                "lateral_m": lateral,
                "depth_m": depth,
            }

            result = _hand_in(
                ctx,
                name,
                goal,
                avoid,
                action,
                (start_xy, end_xy),
                heading,
                profile,
                still,
                details,
            )
            if result is None:
                continue
            yield result
            found.append(float(heading))
            if len(found) >= ctx.settings.candidates_per_action:
                return


def _pick_and_place(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    q_grasp: np.ndarray,
    grasp_xy: np.ndarray,
    heading: float,
    z: float,
    in_hand: np.ndarray,
    avoid: Volume,
) -> tuple[tuple[Segment, ...], np.ndarray, Volume] | None:
    """Close, lift CARRY_LIFT, carry level to a placement in G, lower, open and back away.
    Returns the segments, the placed samples and the carried object's volume on the way."""
    spec = ctx.beliefs[name].spec
    closed: Hand = (0.0, GRASP_CLOSURE)
    free = ctx.free_check(avoid, closed)
    lifted = ctx.straight(q_grasp, ctx.tcp_pose(grasp_xy, heading, z + CARRY_LIFT), free)
    if lifted is None:
        ctx.fail(name, "pick-and-place", "no collision-free lift after the grasp")
        return None
    others = ctx.objects_volume(set(ctx.beliefs) - {name})
    tried = 0
    for shift in _placements(ctx, in_hand[0, :2]):
        placed = _translated(in_hand, shift)
        if not goal.accepts(ctx, name, placed, False):
            continue
        if Volume.of_object(name, spec, placed, ctx.surface.top_z).intersects(others):
            continue
        tried += 1
        if tried > PLACEMENT_TRIES:
            break
        ctx.check_budget()
        place_xy = grasp_xy + shift
        carry = ctx.straight(lifted[-1], ctx.tcp_pose(place_xy, heading, z + CARRY_LIFT), free)
        if carry is None:
            continue
        lower = ctx.straight(carry[-1], ctx.tcp_pose(place_xy, heading, z), free)
        if lower is None:
            continue
        carried = _carried_volume(ctx, name, in_hand, shift)
        if carried.intersects(avoid):
            continue
        finish = _release(ctx, name, lower[-1], place_xy, heading, z, placed, avoid)
        if finish is None:
            continue
        segments = (
            Segment("close", q_grasp[None].copy(), closed),
            Segment("lift", lifted, closed),
            Segment("carry", carry, closed),
            Segment("lower", lower, closed),
            *finish,
        )
        return segments, placed, carried
    ctx.fail(name, "pick-and-place", "no reachable placement out of the NGR")
    return None


def _placements(ctx: PlanningContext, centre: np.ndarray) -> list[np.ndarray]:
    """Shifts from ``centre`` to points of a PLACEMENT_SPACING grid over the surface, nearest
    first (a short carry is a short, reachable motion)."""
    x0, x1, y0, y1 = ctx.surface.bounds
    xs = np.arange(x0, x1, PLACEMENT_SPACING) + PLACEMENT_SPACING / 2
    ys = np.arange(y0, y1, PLACEMENT_SPACING) + PLACEMENT_SPACING / 2
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2) - centre
    order = np.argsort(np.linalg.norm(grid, axis=1), kind="stable")
    return [grid[i] for i in order if np.linalg.norm(grid[i]) > PLACEMENT_SPACING / 2]


def _carried_volume(
    ctx: PlanningContext, name: str, in_hand: np.ndarray, shift: np.ndarray
) -> Volume:
    """The held object's samples raised over the pick-up spot, carried level at CARRY_LIFT
    and lowered over the placement, every PLACEMENT_SPACING."""
    spec = ctx.beliefs[name].spec
    top = ctx.surface.top_z
    total = Volume()
    for z in np.arange(spec.height, CARRY_LIFT + 1e-9, spec.height):
        for poses in (in_hand, _translated(in_hand, shift)):
            total += Volume.of_object(name, spec, poses, top + float(z))
    steps = max(2, math.ceil(float(np.linalg.norm(shift)) / PLACEMENT_SPACING) + 1)
    for f in np.linspace(0.0, 1.0, steps):
        total += Volume.of_object(name, spec, _translated(in_hand, f * shift), top + CARRY_LIFT)
    return total


# --------------------------------------------------------------------------------------------
# Sweep
# --------------------------------------------------------------------------------------------
def sweep(ctx: PlanningContext, name: str, goal: Goal, avoid: Volume) -> Iterator[ActionResult]:
    """Sweeps of ``name`` out of the NGR with the outer side of the hand, best first."""
    if not isinstance(goal, AwayFrom):
        return
    if not ctx.beliefs[name].spec.pushable:
        ctx.fail(name, "sweep", "tips over when pushed")
        return
    found = 0
    for angle, handedness in _sweep_directions(ctx, name):
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        result = _sweep_at(ctx, name, goal, avoid, angle, handedness)
        if result is not None:
            yield result
            found += 1
            if found >= ctx.settings.candidates_per_action:
                return


SWEEP_PLACEMENTS = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.1, 0.9)
"""Where the object's centre meets the hand's side, as fractions from the wrist end to the
fingertip, most central first."""


def _sweep_at(
    ctx: PlanningContext,
    name: str,
    goal: AwayFrom,
    avoid: Volume,
    angle: float,
    handedness: int,
) -> ActionResult | None:
    belief = ctx.beliefs[name]
    spec = belief.spec
    region = ctx.sweep_region(spec.footprint)
    profile = sweep_profile(region.aperture)
    approach = angle + handedness * math.pi / 2
    z = ctx.surface.top_z + grasp_height(spec.height)
    centre = (float(belief.samples[0, 0]), float(belief.samples[0, 1]))
    local = Frame2D(centre, angle, handedness).to_frame(belief.samples)
    lo, hi = profile.span
    x_front = profile.pusher.bounds[1]
    x0 = _near_edge(spec.footprint, local) - x_front - START_CLEARANCE
    # A rigid translation along the sweep is a cheap first guess of how far to sweep (the
    # simulated evolution below decides); it does not depend on where along the hand.
    direction = Frame2D(centre, angle, handedness).x_axis
    gap = START_CLEARANCE
    guess = next(
        (
            gap + d
            for d in np.arange(NU_SPACING, ctx.settings.sweep_max - gap + 1e-9, NU_SPACING)
            if goal.clearly_accepts(ctx, name, _translated(belief.samples, d * direction))
        ),
        None,
    )
    if guess is None:
        ctx.fail(name, "sweep", f"no sweep up to {ctx.settings.sweep_max} m ends {goal.describe()}")
        return None
    hand: Hand = (0.0, closure_for_aperture(region.aperture))
    free = ctx.free_check(avoid, hand)
    placement = None
    for fraction in SWEEP_PLACEMENTS:
        y0 = local[:, 1].mean() - (lo + fraction * (hi - lo))
        origin = Frame2D(centre, angle, handedness).to_world(np.array([x0, y0, 0.0]))
        frame = Frame2D((float(origin[0]), float(origin[1])), angle, handedness)
        in_frame = frame.to_frame(belief.samples)
        with ctx.timed("capture"):
            captured = bool(region.query(in_frame, float(guess))[0].all())
        if not captured:
            ctx.fail(name, "sweep", "the sweep capture region misses some uncertainty samples")
            continue
        start_xy = np.asarray(frame.origin)
        # Reachable and clear where it starts and where the guess ends, before paying for
        # the simulated evolution; another placement along the hand may clear what this hits.
        if ctx.solve(ctx.tcp_pose(start_xy, approach, z), free) is None:
            ctx.fail(name, "sweep", "no collision-free IK solution at the start of the sweep")
            continue
        if ctx.solve(ctx.tcp_pose(start_xy + guess * frame.x_axis, approach, z), free) is None:
            ctx.fail(name, "sweep", "no collision-free IK solution at the end of the sweep")
            continue
        placement = frame, in_frame
        break
    if placement is None:
        return None
    frame, in_frame = placement
    start_xy = np.asarray(frame.origin)
    with ctx.timed("nu"):
        # A pilot with the detected pose alone (a thirtieth of the work) says whether and
        # roughly where the sweep reaches G; only then are all samples simulated.
        pilot = _sweep_until(
            ctx, name, goal, region, frame, in_frame[:1], ctx.settings.sweep_max, PILOT_STEP
        )
        swept = (
            None
            if pilot is None
            else _sweep_until(
                ctx,
                name,
                goal,
                region,
                frame,
                in_frame,
                min(ctx.settings.sweep_max, pilot[0] + SWEEP_CHUNK),
                check_from=pilot[0] - SWEEP_CHUNK,
            )
        )
    if swept is None:
        ctx.fail(name, "sweep", f"no sweep up to {ctx.settings.sweep_max} m ends {goal.describe()}")
        return None
    distance, nu = swept
    end_xy = start_xy + distance * frame.x_axis
    q_end = ctx.solve(ctx.tcp_pose(end_xy, approach, z), free)
    if q_end is None:
        ctx.fail(name, "sweep", "no collision-free IK solution at the end of the sweep")
        return None
    back = ctx.straight(q_end, ctx.tcp_pose(start_xy, approach, z), free)
    if back is None:
        ctx.fail(name, "sweep", "the straight sweep is out of reach or hits avoidVol")
        return None
    motion = Segment("sweep", back[::-1].copy(), hand)
    if not ctx.motion_free((motion,), avoid):
        ctx.fail(name, "sweep", "the arm hits avoidVol during the sweep")
        return None
    if Volume.of_object(name, spec, nu.reshape(-1, 3), ctx.surface.top_z).intersects(avoid):
        ctx.fail(name, "sweep", "the object's uncertainty sweeps into avoidVol")
        return None
    placed = avoid + Volume.of_object(name, spec, nu[-1], ctx.surface.top_z)
    back_xy = end_xy - 0.02 * frame.x_axis
    retreat = ctx.straight(
        q_end, ctx.tcp_pose(back_xy, approach, z), ctx.free_check(placed, hand, exact=True)
    )
    rise = (
        None
        if retreat is None
        else ctx.straight(
            retreat[-1],
            ctx.tcp_pose(back_xy, approach, _rise_height(ctx, spec.height, z)),
            ctx.free_check(placed, hand, exact=True),
        )
    )
    if retreat is None or rise is None:
        ctx.fail(name, "sweep", "no collision-free retreat after the sweep")
        return None
    details = {
        "direction_deg": math.degrees(angle),
        "side": float(handedness),
        "sweep_m": distance,
    }
    segments = (motion, Segment("retreat", retreat, hand), Segment("rise", rise, hand))
    return ActionResult("sweep", name, Motion(segments), nu, False, details)


def _to_world(frame: Frame2D, nu_hand: np.ndarray, advances: np.ndarray) -> np.ndarray:
    """Moving-hand-frame poses (S, P, N, 3) at hand advances (S,) as world poses (S, P*N, 3)."""
    shifted = nu_hand.copy()
    shifted[..., 0] += advances[:, None, None]
    return frame.to_world(shifted).reshape(len(advances), -1, 3)


def _near_edge(footprint: Footprint, poses: np.ndarray) -> float:
    """Smallest x reached by the object's outline over poses (N, 3) in a frame: where a hand
    moving along +x would first meet it."""
    if footprint.shape == "circle":
        return float((poses[:, 0] - footprint.radius).min())
    hx, hy = footprint.half_extents
    reach = np.abs(hx * np.cos(poses[:, 2])) + np.abs(hy * np.sin(poses[:, 2]))
    return float((poses[:, 0] - reach).min())


def _rise_height(ctx: PlanningContext, height: float, z: float) -> float:
    """TCP height after releasing an object: RISE up, and high enough that the hand (its palm
    reaches HAND_BELOW_TCP under the TCP) clears the object's top, so the transit that follows
    starts above everything it leaves behind."""
    return max(z + RISE, ctx.surface.top_z + height + HAND_BELOW_TCP + RISE_CLEARANCE)


def _translated(poses: np.ndarray, shift: np.ndarray) -> np.ndarray:
    moved = np.array(poses, dtype=float)
    moved[:, :2] += shift
    return moved


def _reached(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    region: SweepRegion,
    in_frame: np.ndarray,
    distance: float,
    final: np.ndarray,
) -> bool:
    """A sweep of ``distance`` keeps every sample and leaves all of nu_o[1] in G."""
    inside = region.query(in_frame, distance)[0].all()
    return bool(inside) and goal.accepts(ctx, name, final, False)


def _sweep_until(
    ctx: PlanningContext,
    name: str,
    goal: Goal,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    limit: float,
    step: float = NU_STEP,
    check_from: float = 0.0,
) -> tuple[float, np.ndarray] | None:
    """The shortest sweep (to NU_SPACING) whose every evolved sample ends in G, with nu_o.

    The evolution is simulated a chunk at a time and stops as soon as G is reached: sweeping a
    box under every (mu_c, c) is the planner's most expensive computation. G is tested from
    ``check_from`` on (a pilot run tells roughly where it is reached)."""
    chosen = extreme_parameters(region.mus, region.cs)
    current: np.ndarray = in_frame
    stages = [_to_world(frame, np.tile(in_frame, (len(chosen), 1, 1))[None], np.zeros(1))]
    advanced = 0.0
    while advanced < limit - 1e-9:
        ctx.check_budget()
        d = min(SWEEP_CHUNK, limit - advanced)
        k = max(1, math.ceil(d / NU_SPACING))
        nu_hand = region.evolve(current, d, k, step, chosen)
        distances = advanced + np.linspace(0.0, d, k + 1)
        world = _to_world(frame, nu_hand, distances)

        if distances[k] >= check_from and _reached(
            ctx, name, goal, region, in_frame, float(distances[k]), world[k]
        ):
            j = next(
                j
                for j in range(1, k + 1)
                if j == k
                or _reached(ctx, name, goal, region, in_frame, float(distances[j]), world[j])
            )
            return float(distances[j]), np.concatenate([*stages, world[1 : j + 1]])
        stages.append(world[1:])
        current = nu_hand[-1]
        advanced += d
    return None


ACTIONS: dict[str, Callable[[PlanningContext, str, Goal, Volume], Iterator[ActionResult]]] = {
    "push-grasp": push_grasp,
    "sweep": sweep,
    "static-grasp": static_grasp,
}
"""The manipulation actions Rearrange searches, in the order it tries them."""

CAN_MOVE: dict[str, Callable[[ObjectSpec], bool]] = {
    "push-grasp": lambda spec: not _unfit(spec, pushed=True, lifted=False),
    "sweep": lambda spec: spec.pushable,
    "static-grasp": lambda spec: not _unfit(spec, pushed=False, lifted=True),
}
"""Which objects an action can move at all: the others are obstacles every motion avoids."""
