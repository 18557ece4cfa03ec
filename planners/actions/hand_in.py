"""The hand moving straight in at grasp height, and what a grasp does after it: PickUp (close,
then lift, or on the shelf lift slightly and pull into the goal strip) or release (open flat and
back away, leaving a pushed obstacle where the capture region put it). Push-grasps and static
grasps share these; pick-and-place (`planners.actions.pick_and_place`) has its own finish."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.objects import Footprint
from clutter_gym.model.reachability import PUSH_HEIGHT, hand_pose
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.transforms import Frame2D, rotation_2d
from planners.actions.arm import Arm, Free
from planners.actions.clearance import line_overlap
from planners.actions.context import PlanningContext
from planners.actions.goals import Goal
from planners.actions.grasp_geometry import (
    GRASP_CLOSURE,
    LIFT,
    OPEN_FLAT,
    rise_height,
)
from planners.actions.results import ActionResult, Failure
from planners.goto import upright_hand
from planners.hand2d import (
    PALM_FRONT,
    TURN_SEAT,
    PushGraspProfile,
    box_band,
    closure_for_aperture,
)

NU_SPACING = 0.02  # m of push between stored stages of nu_o
OUT_OF_REACH = "the reachability map rules out the hand on its way in"
NU_INTO_AVOID = "the object's uncertainty sweeps into avoidVol"
CLOSING_STAGES = 10
"""Orientations at which `closing` puts a box while the fingers close on it."""
TURN_REST = (math.radians(-5.0), math.radians(10.0), math.radians(30.0))
"""Where the box comes to rest relative to the approach axis, with a margin: from the first
angle to the second when it stands at the palm, to the third at the far end of `TURN_SEAT`
(the BH-280 closes two fingers against one, and the further ahead, the more they turn it past
the axis)."""
CLOSING_SHOVE = (
    np.radians([0.0, 10.0, 20.0, 30.0, 40.0, 50.0]),
    np.array([0.020, 0.020, 0.024, 0.034, 0.042, 0.049]),
)
"""(off-axis angle rad, m): how far a box within `TURN_BAND` of the approach axis may be pushed
away from the palm while the fingers close on it, the measured envelope plus 5 mm. Measured in
pybullet (static closes of the poptart box 3, 23, 43 and 63 mm ahead of the palm, every 10 deg,
on the axis and 2 cm either side, at 0.151-0.275 m, then the lift; 458 held): at most 1.5,
1.4, 1.9, 2.9, 3.7 and 4.4 cm at 0-50 deg off the axis, and no more than 1 cm from 43 mm
ahead."""
CLOSING_SHOVE_ELSEWHERE = 0.096
"""m: the same for a box further off the axis: up to 9.1 cm at 70 deg, plus 5 mm. Table 1
medium_05 sigma3: a box pushed in 55 deg off the axis, shoved 7.7 cm over the table's near
edge before it was held."""
CLOSING_CENTRE = -0.027
"""m: where a closing hand centres a box across the approach axis (the BH-280 closes two
fingers against one): the same closes ended 4.4 cm right to 1.4 cm left of the axis, most
within a few millimetres of this, wherever the box stood within 2 cm of the axis."""
CYLINDER_SEAT_ASIDE = (-0.010, 0.003)
"""m: where closing fingers hold a cylinder that stood short of `PINCH_ONSET` across the
approach axis: drawn against the palm (its centre a radius ahead of `PALM_FRONT`) and into
this band, wherever it stood across the hand. Measured in pybullet (static closes and a 15
cm lift at every push-grasp preshape, the centre up to 6 cm either side of the axis and from
the palm to 1 cm beyond the fingertip line, 0.5-1 cm apart): 291 soda cans and 202 juice
bottles, all held, 2.6 mm behind to 1.2 mm beyond that seat along the axis and 9.6 mm right
to 2.4 mm left of it across."""
PINCH_ONSET = ((0.156, 0.192, 0.235, 0.275), (-0.020, -0.010, -0.005, 0.005))
"""(preshape apertures m, m along the axis from the fingertip line): a cylinder standing
beyond this (interpolated between apertures) may be pinched by the fingertips instead of
drawn to the palm. Measured as above: the first pinched can or bottle stood 15 mm behind the
line in the narrow preshapes (0.086-0.156 m), 5 mm behind it in the straight one (0.192 m),
at it in the 0.235 m V and 10 mm beyond it in the 0.275 m V; the onset is the grid row before
(5 mm short), where every one was drawn in."""
CYLINDER_TIP_HOLD = (0.058, (-0.044, 0.005))
"""(m along the axis, m across it): where a cylinder standing beyond `PINCH_ONSET` is held,
from its seat to this far beyond where it stood, across this band. Measured as above: of 172
cans and 144 bottles held, 86 and 65 were drawn to the seat, the others pinched, up to 5.0 and
5.8 cm further out than they stood, and all ended 4.4 cm right to 0.5 cm left of the axis. The
81 dropped stood where the planner never closes (within `GRASP_DEPTH` of the line in the
narrow preshapes, beyond it in the others)."""
CLOSED_HAND = HandCommand(0.0, GRASP_CLOSURE)
FLAT_HAND = HandCommand(0.0, OPEN_FLAT)
RETREAT = 0.06  # m the open hand backs away from a pushed obstacle
SHELF_LIFT = 0.02  # m: on the shelf the goal is lifted clear of the board, then pulled out
STRIP_MARGIN = 0.02  # m inside the goal strip's sides the pulled object's samples must end
PULL_TURNS = tuple(math.radians(d) for d in (0, 15, -15, 30, -30, 45, -45, 60, -60))
"""Turns of the hand about the grasped object while it is pulled out of the shelf, fewest
first: a level hand pointing straight ahead cannot reach the front strip (its wrist would
need |j6| > 1.56; docs/world.md), so an object grasped from straight in front leaves turned."""
FAILED_CARRIES = 3
"""Upright carries (GoTo on the constraint manifold, up to `goto_evaluations` each, about a
second) that may fail in one plan before PickUp stops trying them: where straight pulls fail
for one candidate they tend to fail for the next, and the carries then eat the budget (Fig. 16:
17 of 30 s)."""


@dataclass(frozen=True)
class HandIn:
    """A feasible straight motion of the hand and the object's evolution nu_o during it."""

    push: Segment
    q_end: np.ndarray
    end_xy: np.ndarray
    heading: float
    z: float  # TCP height
    nu: np.ndarray  # (stages, M, 3)
    profile: PushGraspProfile  # the preshape


def hand_in(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    action: str,
    avoid: Volume,
    line: tuple[np.ndarray, np.ndarray],
    heading: float,
    profile: PushGraspProfile,
    evolve: Callable[[], np.ndarray],
    pilots: Callable[[], Iterator[np.ndarray]] | None = None,
    planar_clear: bool = False,
) -> HandIn | Failure:
    """The hand moves straight in, as low as the arm can hold it (`Arm.line_heights`), from
    ``line[0]`` to ``line[1]`` (hand_base positions) while the object's samples go through
    ``evolve()`` (nu_o, computed only once the arm's motion is known to be feasible).
    ``pilots()``, where given, yields some of nu_o's own poses, cheapest first (nothing once
    nu_o itself is at hand): each is tested against avoidVol before the next is computed, and
    refuses the motion before nu_o is simulated. ``planar_clear``: the caller's planar test
    found the hand clear of avoidVol along the whole line (`clearance.lines_overlapping`)."""
    start_xy, end_xy = line
    if not planar_clear:
        plane = ctx.surface.top_z + PUSH_HEIGHT
        why, blocker = line_overlap(ctx, profile.pusher, line, heading, avoid, plane)
        if blocker:  # first: what blocks the hand decides which objects a plan moves
            return Failure(name, action, why, blocker)
    heights = arm.line_heights(start_xy, end_xy, heading)
    if not heights:
        return Failure(name, action, OUT_OF_REACH)
    hand = HandCommand(0.0, profile.closure)
    free = arm.free_check(avoid, hand)
    why = "no collision-free IK solution where the hand stops"
    for height in heights:
        z = ctx.surface.top_z + height
        end = hand_pose(end_xy, heading, z)
        q_end = arm.solve(end, free)
        if q_end is None:
            continue
        path = arm.line(q_end, hand_pose(start_xy, heading, z), end, free)
        if path is None:
            why = "the straight push is out of reach or hits avoidVol"
            continue
        q_end = path[-1]
        push = Segment("push", path, hand)
        if arm.motion_free((push,), avoid):
            break
        why = "the arm hits avoidVol during the push"
    else:
        return Failure(name, action, why)
    nu = _clear_evolution(ctx, name, avoid, evolve, pilots)
    if nu is None:
        return Failure(name, action, NU_INTO_AVOID)
    return HandIn(push, q_end, end_xy, heading, z, nu, profile)


def _clear_evolution(
    ctx: PlanningContext,
    name: str,
    avoid: Volume,
    evolve: Callable[[], np.ndarray],
    pilots: Callable[[], Iterator[np.ndarray]] | None,
) -> np.ndarray | None:
    """nu_o, or None where it sweeps into avoidVol (the pilots' poses tested first)."""
    if not avoid.parts:  # an empty avoidVol (nothing to avoid) needs no swept volume
        return evolve()
    for poses in () if pilots is None else pilots():
        with ctx.stats.timed("volumes"):
            if ctx.sweeps_into(name, poses, avoid):
                return None
    nu = evolve()
    with ctx.stats.timed("volumes"):
        return None if ctx.sweeps_into(name, nu, avoid) else nu


def pick_up_or_release(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    moved: HandIn,
    details: dict[str, float],
) -> ActionResult | Failure:
    """PickUp (``action == "pickup"``: close, lift or pull) or release after a hand-in."""
    held = action == "pickup"
    nu = moved.nu
    if not goal.accepts(ctx, name, nu[-1], held):
        return Failure(name, action, f"the object does not end {goal.describe()}")
    if held:
        turning, in_hand = closing(ctx, name, moved)
        if turned_into(ctx, name, turning, avoid):
            return Failure(name, action, TURNS_INTO_AVOID)
        if not ctx.stays_stable(name, turning):
            return Failure(name, action, CLOSES_OFF_SURFACE)
        if not fingers_close_free(ctx, arm, name, moved, avoid):
            return Failure(name, action, FINGERS_INTO_AVOID)
        lifted = ctx.surface.success == "lift"
        targets = [] if lifted else pull_targets(ctx, moved.end_xy, moved.heading, moved.z, in_hand)
        if not (lifted or targets):
            return Failure(name, action, HELD_BEYOND_STRIP)
        finish, carried_poses = _retrieve(ctx, arm, moved, in_hand, targets, avoid)
        if finish is None:
            return Failure(name, action, "no collision-free lift or pull out after the grasp")
        nu = np.concatenate([*through_close(nu, turning, in_hand), carried_poses])
    else:
        finish = release(
            ctx,
            arm,
            name,
            moved.push.hand,
            FLAT_HAND,
            moved.q_end,
            moved.end_xy,
            moved.heading,
            moved.z,
            nu[-1],
            avoid,
        )
        if finish is None:
            return Failure(name, action, "no collision-free retreat after the push")
    return ActionResult(action, name, Trajectory((moved.push, *finish)), nu, held, details)


TURNS_INTO_AVOID = "the object turning in the closing hand sweeps into avoidVol"
CLOSES_OFF_SURFACE = "the closing hand may push the object off the surface"
FINGERS_INTO_AVOID = "the closing fingers sweep into avoidVol"
HELD_BEYOND_STRIP = "the object may be held where no pull fits it in the goal strip"


def fingers_close_free(
    ctx: PlanningContext, arm: Arm, name: str, moved: HandIn, avoid: Volume
) -> bool:
    """Whether the fingers, closing from the push's preshape until their tips are as far apart
    as the object is wide (where they meet it), stay clear of avoidVol: a neighbour standing
    between the open fingers of a wide preshape, clear of the hand itself, would be swept along
    with the object. The fingers stop on the object, so closing further sweeps nothing."""
    width = ctx.beliefs[name].spec.footprint.min_width
    meets = HandCommand(0.0, max(closure_for_aperture(width), moved.push.hand.closure))
    return arm.hand_change_free(moved.q_end, moved.push.hand, meets, avoid)


def closing(ctx: PlanningContext, name: str, moved: HandIn) -> tuple[np.ndarray, np.ndarray]:
    """Where the object may stand while the fingers close on it, stages (S, M, 3) around its
    poses (M, 3) where the hand stopped (``moved.nu[-1]``; `closing_poses`), and where it may
    rest once they have closed, (K, 3) (`held_poses`)."""
    hand = Frame2D((float(moved.end_xy[0]), float(moved.end_xy[1])), moved.heading)
    footprint = ctx.beliefs[name].spec.footprint
    stages = closing_poses(footprint, hand.to_frame(moved.nu[-1]), moved.profile)
    return hand.to_world(stages), hand.to_world(held_poses(footprint, stages, moved.profile))


def closing_poses(
    footprint: Footprint, in_hand: np.ndarray, profile: PushGraspProfile
) -> np.ndarray:
    """Where an object standing at ``in_hand`` (M, 3; hand_base's frame) may stand while the
    fingers close on it, stages (S, M, 3). A cylinder is drawn to its seat against the palm
    (`CYLINDER_SEAT_ASIDE`; the last stage spans the measured band). A box near the palm
    (`TURN_SEAT`) and within `TURN_BAND` of the approach axis turns toward the axis, through every
    orientation between its own and `TURN_REST`. Measured in pybullet (static grasps, the
    box's nearest point 3, 23, 43, 63 and 83 mm ahead of the palm): at the five preshapes
    0.111-0.275 m, turned 0-50 deg either way, 427 closes with the centre up to 2 cm either
    side of the axis and 3-43 mm ahead, and 106 with it 4 cm aside and 3-23 mm ahead, all held
    and each turned one way, to 0.8 deg below the axis and up to 8, 19 and 22 deg above it (3,
    23, 43 mm); 43 mm ahead and 4 cm aside 4 of 74 failed, 63 and 83 mm ahead 33 of 93 and 99
    of 99. Elsewhere it may turn either way, by up to a quarter turn (across the hand a poptart
    box turned 80 deg and shoved a can 12 cm), so it may stand at any orientation. While it
    turns, the fingers push it away from the palm (`CLOSING_SHOVE`, `CLOSING_SHOVE_ELSEWHERE`)
    and towards `CLOSING_CENTRE`."""
    in_hand = np.asarray(in_hand, dtype=float)
    fractions = np.linspace(0.0, 1.0, CLOSING_STAGES)[:, None]
    if footprint.shape != "box":
        return _cylinder_closing(footprint, in_hand, profile, fractions)
    off_axis, ahead, near_axis, seated = box_band(footprint, in_hand)
    banded = near_axis & seated
    rest_low, seated_high, far_high = TURN_REST
    rest_high = np.interp(ahead, (0.0, TURN_SEAT[-1][0]), (seated_high, far_high))
    low = np.where(banded, np.minimum(off_axis, rest_low), off_axis)
    anywhere = off_axis + np.pi * (1 - 1 / CLOSING_STAGES)  # the half turn, evenly
    high = np.where(banded, np.maximum(off_axis, rest_high), anywhere)
    turned = np.repeat(in_hand[None], CLOSING_STAGES, axis=0)
    shove = np.where(
        near_axis, np.interp(np.abs(off_axis), *CLOSING_SHOVE), CLOSING_SHOVE_ELSEWHERE
    )
    turned[..., 0] += fractions * shove
    turned[..., 1] += fractions * (CLOSING_CENTRE - in_hand[:, 1])
    turned[..., 2] = low + fractions * (high - low)
    return turned


def _cylinder_closing(
    footprint: Footprint, in_hand: np.ndarray, profile: PushGraspProfile, fractions: np.ndarray
) -> np.ndarray:
    """`closing_poses` of a cylinder: one short of `PINCH_ONSET` goes straight to
    its seat (the last stage spans `CYLINDER_SEAT_ASIDE`); one further ahead, drawn in or
    pinched by the fingertips, passes through every part of `CYLINDER_TIP_HOLD` (along the axis
    in even steps, alternating between the band's sides, which lie closer than the cylinder is
    wide)."""
    seat_x = PALM_FRONT + footprint.radius
    seated = drawn_to_seat(in_hand, profile)
    seat = np.column_stack(
        [np.full(len(in_hand), seat_x), np.linspace(*CYLINDER_SEAT_ASIDE, len(in_hand))]
    )
    stages = (1.0 - fractions[..., None]) * in_hand + fractions[..., None] * np.column_stack(
        [seat, in_hand[:, 2]]
    )
    out, sides = CYLINDER_TIP_HOLD
    spread = np.linspace(0.0, 1.0, CLOSING_STAGES - 1)[:, None]  # stages 1.. over the hold
    along = seat_x + spread * (in_hand[:, 0] + out - seat_x)
    across = np.resize(sides, CLOSING_STAGES - 1)[:, None]
    stages[1:, ~seated, 0] = along[:, ~seated]
    stages[1:, ~seated, 1] = across
    return stages


def drawn_to_seat(in_hand: np.ndarray, profile: PushGraspProfile) -> np.ndarray:
    """Which cylinder poses (M, 3; hand_base's frame) the closing fingers draw to the palm:
    those short of `PINCH_ONSET` (the same for the can and the bottle)."""
    onset = profile.grasp_line + float(np.interp(profile.aperture, *PINCH_ONSET))
    return in_hand[:, 0] <= onset


def held_poses(footprint: Footprint, stages: np.ndarray, profile: PushGraspProfile) -> np.ndarray:
    """Where the object may rest in the closed hand, (K, 3; hand_base's frame), from its
    `closing_poses` stages there: cylinders all drawn to the seat at the last stage; else
    anywhere along the stages (a box in its turn, a cylinder in `CYLINDER_TIP_HOLD`)."""
    if footprint.shape != "box" and drawn_to_seat(stages[0], profile).all():
        return stages[-1]
    return stages.reshape(-1, 3)


def through_close(nu: np.ndarray, turning: np.ndarray, in_hand: np.ndarray) -> list[np.ndarray]:
    """nu_o up to the hand closing: the push's stages and the `closing` stages, each with as
    many poses as the held ones (``in_hand``, `held_poses`: M, or S x M when they span every
    closing stage), so that the stages after the close stack with them."""
    copies = len(in_hand) // nu.shape[1]
    return [np.tile(nu, (1, copies, 1)), np.tile(turning, (1, copies, 1))]


def turned_into(ctx: PlanningContext, name: str, turning: np.ndarray, avoid: Volume) -> bool:
    """Whether the object at the `closing` stages overlaps avoidVol."""
    with ctx.stats.timed("volumes"):
        return ctx.sweeps_into(name, turning, avoid)


def _retrieve(
    ctx: PlanningContext,
    arm: Arm,
    moved: HandIn,
    in_hand: np.ndarray,
    targets: list[np.ndarray],
    avoid: Volume,
) -> tuple[tuple[Segment, ...] | None, np.ndarray]:
    """Close the fingers, then lift (table) or lift slightly and pull the object, held at
    ``in_hand`` (`held_poses`), to one of the `pull_targets` in the goal strip (shelf).
    Returns the segments and the carried object's poses."""
    q_end, end_xy, heading, z = moved.q_end, moved.end_xy, moved.heading, moved.z
    closed = CLOSED_HAND
    close = Segment("close", q_end[None].copy(), closed)
    free = arm.free_check(avoid, closed)
    nothing = np.empty((0, len(in_hand), 3))
    if ctx.surface.success == "lift":
        lift = arm.straight(q_end, hand_pose(end_xy, heading, z + LIFT), free)
        if lift is None:
            return None, nothing
        return (close, Segment("lift", lift, closed)), nothing
    raise_ = arm.straight(q_end, hand_pose(end_xy, heading, z + SHELF_LIFT), free)
    if raise_ is None:
        return None, nothing
    pull = _pull(ctx, arm, raise_[-1], targets, free)
    if pull is None:
        return None, nothing
    carried = carried_poses(arm, pull, in_hand)
    return (close, Segment("lift", raise_, closed), Segment("pull", pull, closed)), carried


def _pull(
    ctx: PlanningContext, arm: Arm, q_start: np.ndarray, targets: list[np.ndarray], free: Free
) -> np.ndarray | None:
    """Straight pulls first (a Cartesian line, milliseconds), then the upright carry to the
    first target that has an IK solution."""
    for target in targets:
        pull = arm.straight(q_start, target, free)
        if pull is not None:
            return pull
    if ctx.failed_carries < FAILED_CARRIES:
        for target in targets:
            if arm.solve(target, free) is not None:
                pull = carry_upright(arm, q_start, target, free)
                ctx.failed_carries += pull is None
                return pull
    return None


def pull_targets(
    ctx: PlanningContext, end_xy: np.ndarray, heading: float, z: float, in_hand: np.ndarray
) -> list[np.ndarray]:
    """The TCP poses that bring the grasped object, held at ``in_hand`` (`held_poses`), into
    the goal strip, one per turn of the hand about the object's centre (`PULL_TURNS`) that
    fits every held pose in it: to the strip's middle along x, and along y only as far as
    needed to bring every pose STRIP_MARGIN inside it (an object grasped near a wall lies
    beside the strip; pulled straight out it would stay there). A cylinder the fingertips may
    pinch is held anywhere over 6-10 cm along the hand (`CYLINDER_TIP_HOLD`), as deep as the
    strip: the grasp that leaves it there cannot promise the strip."""
    centre = in_hand[:, :2].mean(axis=0)
    (x0, x1), (y0, y1) = ctx.goal_region
    targets = []
    for turn in PULL_TURNS:
        rotation = rotation_2d(turn)
        turned = centre + (in_hand[:, :2] - centre) @ rotation.T
        xs, ys = turned[:, 0], turned[:, 1]
        if np.ptp(xs) >= x1 - x0 or np.ptp(ys) >= y1 - y0 - 2 * STRIP_MARGIN:
            continue
        into = max(y0 + STRIP_MARGIN - float(ys.min()), 0.0)
        dy = into - max(float(ys.max()) - (y1 - STRIP_MARGIN), 0.0)
        shift = np.array([(x0 + x1 - float(xs.min()) - float(xs.max())) / 2, dy])
        hand_xy = centre + shift + rotation @ (np.asarray(end_xy) - centre)
        targets.append(hand_pose(hand_xy, heading + turn, z + SHELF_LIFT))
    return targets


def carry_upright(
    arm: Arm, q_start: np.ndarray, target: np.ndarray, free: Free
) -> np.ndarray | None:
    """GoTo with a grasped object kept upright (the hand's finger plane horizontal), to the
    target's IK solution nearest ``q_start``: one on another branch (the planner's usual
    choice is nearest the home pose) is rarely connected to it with the hand kept level."""
    with arm.stats.timed("ik"):
        q_goal = arm.kinematics.solve_ik(target, q_start, free)
    if q_goal is None:
        return None
    path, _ = arm.plan_path(q_start, q_goal, free, upright_hand(arm.kinematics))
    return path


def carried_poses(arm: Arm, path: np.ndarray, in_hand: np.ndarray) -> np.ndarray:
    """Object sample poses (S, N, 3) along a carrying path: rigidly attached to the TCP in the
    plane (the hand stays level), every NU_SPACING of TCP travel."""
    tcps = arm.kinematics.fk_tcp_batch(path)
    xy, yaw = tcps[:, :2, 3], np.arctan2(tcps[:, 1, 2], tcps[:, 0, 2])
    travel = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
    marks = np.arange(NU_SPACING, travel[-1] + NU_SPACING, NU_SPACING).clip(max=travel[-1])
    rows = np.unique(np.searchsorted(travel, marks).clip(max=len(path) - 1))
    stages = []
    for k in rows:
        turn = yaw[k] - yaw[0]
        rel = in_hand[:, :2] - xy[0]
        moved = xy[k] + rel @ rotation_2d(turn).T
        stages.append(np.column_stack([moved, in_hand[:, 2] + turn]))
    return np.stack(stages) if stages else np.empty((0, len(in_hand), 3))


def release(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    holding: HandCommand,
    opened: HandCommand,
    q_end: np.ndarray,
    end_xy: np.ndarray,
    heading: float,
    z: float,
    final: np.ndarray,
    avoid: Volume,
) -> tuple[Segment, ...] | None:
    """Open the hand from ``holding`` to ``opened`` and back away, leaving a pushed (or
    placed) object where it is; the opening fingers must clear avoidVol too."""
    if not arm.hand_change_free(q_end, holding, opened, avoid):
        return None
    release_ = Segment("release", q_end[None].copy(), opened)
    v = np.array([math.cos(heading), math.sin(heading)])
    back_xy = end_xy - RETREAT * v
    retreat = arm.straight(q_end, hand_pose(back_xy, heading, z), arm.free_check(avoid, opened))
    if retreat is None:
        return None
    spec = ctx.beliefs[name].spec
    placed = avoid + Volume.of_object(name, spec, final, ctx.surface.top_z)
    rise = arm.straight(
        retreat[-1],
        hand_pose(back_xy, heading, rise_height(ctx.surface.top_z, spec.height, z)),
        arm.free_check(placed, opened, exact=True),
    )
    if rise is None:
        return None
    return (release_, Segment("retreat", retreat, opened), Segment("rise", rise, opened))
