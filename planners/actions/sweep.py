"""Sweep (§2.1.6, Fig. 7): the outer side of the hand pushes an obstacle sideways, far enough
that every sample of nu_o[1] leaves the negative goal region, guarded by the sweep capture
region (the object stays against the hand's side for the whole sweep)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.reachability import PUSH_HEIGHT, hand_pose
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.transforms import Frame2D
from planners.actions.arm import Arm, Free
from planners.actions.clearance import overlapped
from planners.actions.context import PlanningContext
from planners.actions.goals import AwayFrom, Goal
from planners.actions.grasp_geometry import (
    START_CLEARANCE,
    near_edge,
    rise_height,
    translated,
)
from planners.actions.hand_in import NU_INTO_AVOID, NU_SPACING, OUT_OF_REACH
from planners.actions.heuristics import sweep_directions
from planners.actions.results import ActionResult, Failure, Outcome
from planners.actions.sweep_evolution import (
    PILOT_STEP,
    evolved,
    first_guess,
    not_far_enough,
    simulate,
    sweep_until,
)
from planners.capture import SweepRegion
from planners.hand2d import closure_for_aperture, sweep_profile

ACTION = "sweep"
SWEEP_RETREAT = 0.02  # m the hand backs away along the sweep before rising

DIRECTION_REFINE = 2
"""In an enclosed surface the sweep directions are searched again at this fraction of the
settings' step (`_directions`)."""
SWEEP_PLACEMENTS = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.1, 0.9, 0.55, 0.65, 0.45, 0.75)
"""Where the object's centre meets the hand's side, as fractions from the wrist end to the
fingertip, most central first, then the half-steps between the central ones: how far the sweep
region holds an object changes steeply with the placement (a large box swept square to its face
in a Figs. 3-5 variant: every sample 0.27 m at 0.5, 0.72 m at 0.6, where the arm has no IK at the
sweep's start)."""
FIRST_STROKE_MIN = 0.06
"""m: the shortest first stroke of a sweep in two strokes (`_two_strokes_at`); a shorter one
barely moves the object before the hand is placed against it again."""
STRAIGHT_INTO_AVOID = "the detected pose's straight way out sweeps into avoidVol"
STROKE_BACK = 0.03
"""m the hand backs away from the object between the two strokes, before it moves along the
object to where the second stroke starts."""


def sweep(
    ctx: PlanningContext, arm: Arm, name: str, goal: Goal, avoid: Volume
) -> Iterator[Outcome]:
    """Sweeps of ``name`` out of the NGR with the outer side of the hand, best first: in one
    stroke in every direction, then, only if the search goes on, in two strokes where the
    sweep region lets go of the object before it is out (`_two_strokes_at`)."""
    if not isinstance(goal, AwayFrom):
        return
    if not ctx.beliefs[name].spec.pushable:
        yield Failure(name, ACTION, "tips over when pushed")
        return
    guesses: dict[tuple[float, int], float | None] = {}  # rigid shifts into G, by direction
    for angle, handedness in _directions(ctx, arm, name):
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        yield from _sweep_at(ctx, arm, name, goal, avoid, angle, handedness, guesses)
    for (angle, handedness), guess in guesses.items():
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        yield from _two_strokes_at(ctx, arm, name, goal, avoid, angle, handedness, guess)


def _directions(ctx: PlanningContext, arm: Arm, name: str) -> Iterator[tuple[float, int]]:
    """`sweep_directions` at the settings' step; in an enclosed surface, then, only if the
    search goes on, the ones between them at a `DIRECTION_REFINE`-th of the step. In the
    shelf an object in front of the goal has few ways out, between the NGR of the goal's
    pick-up, the walls, the front edge and the hole in front of the shoulder (shelf high
    scene 45: a bottle swept at 255 deg, where 240 and 270 deg give no sweep); on the table
    an object has room all around and the finer grid only costs (the Figs. 3-5 plan, which
    it leaves as it is, took 32% longer with it)."""
    coarse = sweep_directions(ctx, arm.heading_origin, name)
    yield from coarse
    if ctx.surface.interior is None:
        return
    step = ctx.settings.sweep_step_deg / DIRECTION_REFINE
    for angle, handedness in sweep_directions(ctx, arm.heading_origin, name, step):
        if all(
            h != handedness or abs(math.remainder(angle - a, 2 * math.pi)) > 1e-6 for a, h in coarse
        ):
            yield angle, handedness


@dataclass(frozen=True)
class _Sweep:
    """One sweep direction and side of the hand, and the object's samples in its frame."""

    region: SweepRegion
    angle: float  # world yaw of the sweep
    handedness: int
    approach: float  # world yaw of the hand's approach axis
    z: float  # TCP height
    centre: tuple[float, float]  # the detected pose
    local: np.ndarray  # the samples in the frame at the centre
    x0: float  # where the hand's side starts, in that frame
    span: tuple[float, float]  # the hand's side, from the wrist end to the fingertip
    samples: np.ndarray  # world poses (M, 3): U(o), or where a first stroke left them

    @property
    def frame(self) -> Frame2D:
        return Frame2D(self.centre, self.angle, self.handedness)


def _sweep_at(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: AwayFrom,
    avoid: Volume,
    angle: float,
    handedness: int,
    guesses: dict[tuple[float, int], float | None],
) -> Iterator[Outcome]:
    """At most one sweep in this direction (and the failures on the way); the rigid shift's
    guess of how far joins ``guesses``: the same for either side of the hand (a translation
    of U(o) along the direction), so the other side's is taken where it was made (Figs. 3-5:
    105 of its 220 guesses were repeats)."""
    with ctx.stats.timed("capture"):  # the samples in the sweep's frame
        plan = _plan_sweep(ctx, name, angle, handedness)
    other_side = (angle, -handedness)
    guess = guesses[(angle, handedness)] = (
        guesses[other_side]
        if other_side in guesses
        else first_guess(ctx, name, goal, plan.samples, plan.frame.x_axis)
    )
    if guess is None:
        guess = _pilot_guess(ctx, name, goal, plan)
    if guess is None:
        yield Failure(name, ACTION, not_far_enough(ctx, goal))
        return
    hand = HandCommand(0.0, closure_for_aperture(plan.region.aperture))
    free = _clearances(ctx, arm, name, avoid, hand)
    # Placements in order until one gives a sweep: where the object meets the hand decides how
    # long the region holds it and which way it turns, so one placement's failure (a short
    # hold, a corner swinging into avoidVol) says nothing about the next one's.
    for fraction in SWEEP_PLACEMENTS:
        placement = _placement(ctx, arm, name, plan, fraction, guess, avoid, free)
        if isinstance(placement, Failure):
            yield placement
            continue
        frame, in_frame, placed, _ = placement  # the plan at the placement's height
        with ctx.stats.timed("nu"):
            swept = simulate(ctx, name, goal, placed.region, frame, in_frame, avoid)
        if isinstance(swept, str):
            yield Failure(name, ACTION, swept)
            continue
        distance, nu = swept
        start_xy = np.asarray(frame.origin)
        end_xy = start_xy + distance * frame.x_axis
        # At the placement's height, or higher where the straight line is out of reach there.
        heights = [z for z in _heights(ctx, arm, placed, start_xy, end_xy) if z >= placed.z]
        for z in heights or [placed.z]:
            result = _sweep_motion(
                ctx, arm, name, avoid, replace(placed, z=z), frame, hand, free, distance, nu
            )
            if not isinstance(result, Failure):
                break
        yield result
        if not isinstance(result, Failure):
            return


@dataclass(frozen=True)
class FirstStroke:
    """A sweep's first stroke: the arm's path and nu_o (stages, P*N, 3), ending with the
    hand_base at ``end_xy`` at the plan's height; avoidVol with the object where it may have
    been left (``with_object``), and the hand backed away from it (`STROKE_BACK`) or None."""

    plan: _Sweep
    path: np.ndarray
    length: float
    end_xy: np.ndarray
    nu: np.ndarray
    with_object: Volume
    back: np.ndarray | None


def _two_strokes_at(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: AwayFrom,
    avoid: Volume,
    angle: float,
    handedness: int,
    guess: float | None,
) -> Iterator[Outcome]:
    """At most one sweep in two strokes in this direction, for the placements along the hand
    where the sweep region lets go of a sample before a rigid shift would reach G (``guess``;
    a large box turning against the hand slides along it: 0.26 m at the middle of the hand,
    where 0.5 m is needed, Fig. 15): the first stroke goes as far as the region holds every
    sample, the hand backs away and is placed against the object again where that stroke may
    have left it (`_second_stroke`). Each stroke is a sweep the region was validated for: the
    object at rest in it, the hand starting clear of it; the evolution goes on under each
    sample's own pushing parameters (the world's friction does not change between strokes)."""
    if guess is None:
        yield Failure(name, ACTION, not_far_enough(ctx, goal))
        return
    with ctx.stats.timed("capture"):
        plan = _plan_sweep(ctx, name, angle, handedness)
    # The detected pose shifted straight out: where it meets avoidVol, the sweep would carry
    # it there too (a cheap stand-in for the evolution, not a proof: the object may turn).
    straight = np.repeat(plan.samples[:1], math.ceil(guess / NU_SPACING) + 1, axis=0)
    straight[:, :2] += np.arange(len(straight))[:, None] * NU_SPACING * plan.frame.x_axis
    with ctx.stats.timed("volumes"):
        if ctx.sweeps_into(name, straight, avoid):
            yield Failure(name, ACTION, STRAIGHT_INTO_AVOID)
            return
    hand = HandCommand(0.0, closure_for_aperture(plan.region.aperture))
    free = _clearances(ctx, arm, name, avoid, hand)
    for fraction in SWEEP_PLACEMENTS:
        with ctx.stats.timed("capture"):
            _, in_frame = _frame_at(ctx, name, plan, fraction)
            hold = plan.region.holds_until(in_frame)
        if hold >= guess:
            continue  # one stroke holds it that far: the sweeps in one stroke tried this
        length = math.floor(hold / NU_SPACING + 1e-9) * NU_SPACING
        if length < FIRST_STROKE_MIN:
            yield Failure(name, ACTION, "the sweep capture region holds no first stroke")
            continue
        # The first stroke never depends on G: one per placement, avoidVol and plan.
        key = (name, angle, handedness, fraction, id(avoid))
        if key not in ctx.first_strokes:  # avoidVol is kept with it: its id stays its own
            stroke = _first_stroke(ctx, arm, name, plan, fraction, length, avoid, hand, free)
            ctx.first_strokes[key] = (avoid, stroke)
        first = ctx.first_strokes[key][1]
        result = (
            first
            if isinstance(first, Failure)
            else _second_stroke(ctx, arm, name, goal, avoid, hand, first)
        )
        yield result
        if not isinstance(result, Failure):
            return


def _first_stroke(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    plan: _Sweep,
    fraction: float,
    length: float,
    avoid: Volume,
    hand: HandCommand,
    free: tuple[Free, Free],
) -> FirstStroke | Failure:
    """The first stroke of ``length`` at this placement (`_placement`'s checks), clear of
    avoidVol, with its nu_o (the detected pose's own evolution tested against avoidVol first,
    as `simulate` does)."""
    placement = _placement(ctx, arm, name, plan, fraction, length, avoid, free)
    if isinstance(placement, Failure):
        return placement
    frame, in_frame, placed, path = placement
    end_xy = np.asarray(frame.origin) + length * frame.x_axis
    if not arm.motion_free((Segment("sweep", path, hand),), avoid):
        return Failure(name, ACTION, "the arm hits avoidVol during the sweep")
    for rows in (in_frame[:1], in_frame):
        with ctx.stats.timed("nu"):
            nu = evolved(ctx, name, placed.region, frame, rows, length)
        with ctx.stats.timed("volumes"):
            if ctx.sweeps_into(name, nu, avoid):
                return Failure(name, ACTION, NU_INTO_AVOID)
    spec = ctx.beliefs[name].spec
    left = avoid + Volume.of_object(name, spec, nu[-1], ctx.surface.top_z)
    back_xy = end_xy - STROKE_BACK * frame.x_axis
    back = arm.straight(
        path[-1], hand_pose(back_xy, plan.approach, placed.z), arm.free_check(left, hand, True)
    )
    return FirstStroke(placed, path, length, end_xy, nu, left, back)


def _second_stroke(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: AwayFrom,
    avoid: Volume,
    hand: HandCommand,
    first: FirstStroke,
) -> Outcome:
    """The rest of a sweep in two strokes: the hand backs away `STROKE_BACK` along the sweep,
    moves straight to the start of a second sweep of the samples where the first stroke may
    have left them (`_sweep_at`'s placements, its checks with that object in place of U(o)),
    and sweeps on until G; the whole motion, retreat and rise as any sweep's (`_finished`)."""
    back = first.back
    if back is None:
        return Failure(name, ACTION, "the hand cannot back away between the strokes")
    rest = first.nu[-1]  # (P*N, 3): each sample under each parameter set
    with ctx.stats.timed("capture"):
        plan = _plan_sweep(ctx, name, first.plan.angle, first.plan.handedness, rest)
    guess = first_guess(ctx, name, goal, plan.samples, plan.frame.x_axis)
    if guess is None:
        return Failure(name, ACTION, "no second stroke ends " + goal.describe())
    free = (arm.free_check(avoid, hand), arm.free_check(first.with_object, hand))
    rows = len(rest) // len(ctx.beliefs[name].samples)
    why = "no second stroke"
    for fraction in SWEEP_PLACEMENTS:
        placement = _placement(ctx, arm, name, plan, fraction, guess, avoid, free)
        if isinstance(placement, Failure):
            why = placement.reason
            continue
        frame, in_frame, at_z, _ = placement
        start_xy = np.asarray(frame.origin)
        with ctx.stats.timed("nu"):
            swept = simulate(
                ctx, name, goal, at_z.region, frame, in_frame.reshape(rows, -1, 3), avoid
            )
        if isinstance(swept, str):
            why = swept
            continue
        distance, nu = swept
        end_xy = start_xy + distance * frame.x_axis
        shift = arm.straight(back[-1], hand_pose(start_xy, plan.approach, at_z.z), free[1])
        stroke = (
            None
            if shift is None
            else arm.straight(shift[-1], hand_pose(end_xy, plan.approach, at_z.z), free[0])
        )
        if shift is None or stroke is None:
            why = "the hand cannot move from the first stroke through the second"
            continue
        motion = (
            Segment("sweep", first.path, hand),
            Segment("retreat", back, hand),
            Segment("shift", shift, hand),
            Segment("sweep", stroke, hand),
        )
        details = {
            "direction_deg": math.degrees(plan.angle),
            "side": float(plan.handedness),
            "sweep_m": first.length + distance,
            "first_stroke_m": first.length,
        }
        total = np.concatenate([first.nu, nu[1:]])
        return _finished(ctx, arm, name, avoid, at_z, end_xy, hand, motion, total, details)
    return Failure(name, ACTION, why)


def _clearances(
    ctx: PlanningContext, arm: Arm, name: str, avoid: Volume, hand: HandCommand
) -> tuple[Free, Free]:
    """The sweep's collision checks: clear of avoidVol, and, where it starts, of the object's
    own samples too (the approach or transit brings the arm there with the object standing
    where it was detected; beside a large box the first IK solution often has the elbow in
    it)."""
    return arm.free_check(avoid, hand), arm.free_check(ctx.with_own_samples(avoid, name), hand)


def _plan_sweep(
    ctx: PlanningContext,
    name: str,
    angle: float,
    handedness: int,
    samples: np.ndarray | None = None,
) -> _Sweep:
    """A sweep of the object's ``samples`` (default U(o)) in this direction."""
    spec = ctx.beliefs[name].spec
    samples = ctx.beliefs[name].samples if samples is None else samples
    region = ctx.sweep_region(spec.footprint)
    profile = sweep_profile(region.aperture)
    centre = (float(samples[0, 0]), float(samples[0, 1]))
    local = Frame2D(centre, angle, handedness).to_frame(samples)
    x_front = profile.pusher.bounds[1]
    return _Sweep(
        region=region,
        angle=angle,
        handedness=handedness,
        approach=angle + handedness * math.pi / 2,
        z=ctx.surface.top_z + PUSH_HEIGHT,
        centre=centre,
        local=local,
        x0=near_edge(spec.footprint, local) - x_front - START_CLEARANCE,
        span=profile.span,
        samples=samples,
    )


def _pilot_guess(ctx: PlanningContext, name: str, goal: AwayFrom, plan: _Sweep) -> float | None:
    """How far a sweep of the detected pose alone, at the most central placement, goes before
    it is in G: the guess when no rigid translation reaches G, because the object must turn
    on the way (a long object pushed at its end swings round against the hand, and only then
    fits between the NGR and the table's edge). The pilot is kept for the full simulation."""
    with ctx.stats.timed("capture"):
        frame, in_frame = _frame_at(ctx, name, plan, SWEEP_PLACEMENTS[0])
        limit = min(ctx.settings.sweep_max, plan.region.holds_until(in_frame[:1]))
    with ctx.stats.timed("nu"):
        pilot = sweep_until(ctx, name, goal, plan.region, frame, in_frame[:1], limit, PILOT_STEP)
    return None if pilot is None else pilot[0]


def _placement(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    plan: _Sweep,
    fraction: float,
    guess: float,
    avoid: Volume,
    free: tuple[Free, Free],
) -> tuple[Frame2D, np.ndarray, _Sweep, np.ndarray] | Failure:
    """The sweep frame with the object's centre at ``fraction`` along the hand's side, if the
    capture region holds every sample and the arm reaches the start (clear of the object too:
    `_clearances`) and the guessed end; the sweep at the lowest height the arm holds the hand
    there (`Arm.push_height`), and its straight line to the guessed end."""
    with ctx.stats.timed("capture"):
        frame, in_frame = _frame_at(ctx, name, plan, fraction)
        captured = bool(plan.region.query(in_frame, float(guess))[0].all())
    if not captured:
        return Failure(name, ACTION, "the sweep capture region misses some uncertainty samples")
    start_xy = np.asarray(frame.origin)
    blocker = overlapped(ctx, sweep_profile(plan.region.aperture).pusher, frame, avoid, plan.z)
    if blocker:
        return Failure(name, ACTION, f"the hand overlaps {blocker} where the sweep starts", blocker)
    # Reachable and clear where it starts and where the guess ends, and along the straight
    # line between, before paying for the simulated evolution (the sweep's most expensive
    # step); another placement along the hand may clear what this hits.
    end_xy = start_xy + guess * frame.x_axis
    heights = _heights(ctx, arm, plan, start_xy, end_xy)
    if not heights:
        return Failure(name, ACTION, OUT_OF_REACH)
    why = "no collision-free IK solution at the start of the sweep"
    for z in heights:
        if arm.solve(hand_pose(start_xy, plan.approach, z), free[1]) is None:
            continue
        at_z = replace(plan, z=z)
        line = _straight_sweep(arm, at_z, start_xy, end_xy, free)
        if not isinstance(line, str):
            return frame, in_frame, at_z, line
        why = line
    return Failure(name, ACTION, why)


def _heights(
    ctx: PlanningContext, arm: Arm, plan: _Sweep, start_xy: np.ndarray, end_xy: np.ndarray
) -> list[float]:
    """TCP heights (world z) for a sweep from ``start_xy`` to ``end_xy``, lowest first, at
    which the map rules no point of the line out (`Arm.line_heights`)."""
    return [ctx.surface.top_z + h for h in arm.line_heights(start_xy, end_xy, plan.approach)]


def _frame_at(
    ctx: PlanningContext, name: str, plan: _Sweep, fraction: float
) -> tuple[Frame2D, np.ndarray]:
    """The sweep frame (origin where the hand starts) with the object's centre ``fraction``
    along the hand's side, and the samples in it."""
    lo, hi = plan.span
    y0 = plan.local[:, 1].mean() - (lo + fraction * (hi - lo))
    origin = plan.frame.to_world(np.array([plan.x0, y0, 0.0]))
    frame = Frame2D((float(origin[0]), float(origin[1])), plan.angle, plan.handedness)
    return frame, frame.to_frame(plan.samples)


def sweep_with(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    direction: tuple[float, int],
    fraction: float,
    distance: float,
    avoid: Volume,
) -> Outcome:
    """One sweep with its parameters given (direction: world yaw and which side of the hand),
    no capture region and no goal test: `planners.actions.primitives`. nu_o is the samples
    carried rigidly along; physics decides what really happens."""
    if not ctx.beliefs[name].spec.pushable:
        return Failure(name, ACTION, "tips over when pushed")
    plan = _plan_sweep(ctx, name, *direction)
    frame, _ = _frame_at(ctx, name, plan, fraction)
    start_xy = np.asarray(frame.origin)
    heights = _heights(ctx, arm, plan, start_xy, start_xy + distance * frame.x_axis)
    plan = replace(plan, z=heights[0] if heights else plan.z)  # physics decides, even off the map
    samples = ctx.beliefs[name].samples
    nu = np.stack([samples, translated(samples, distance * frame.x_axis)])
    hand = HandCommand(0.0, closure_for_aperture(plan.region.aperture))
    free = _clearances(ctx, arm, name, avoid, hand)
    return _sweep_motion(ctx, arm, name, avoid, plan, frame, hand, free, distance, nu)


def _sweep_motion(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    plan: _Sweep,
    frame: Frame2D,
    hand: HandCommand,
    free: tuple[Free, Free],
    distance: float,
    nu: np.ndarray,
) -> Outcome:
    """The arm's sweep, retreat and rise, checked against avoidVol and the placed object
    (``free``: `_clearances`)."""
    start_xy = np.asarray(frame.origin)
    end_xy = start_xy + distance * frame.x_axis
    path = _straight_sweep(arm, plan, start_xy, end_xy, free)
    if isinstance(path, str):
        return Failure(name, ACTION, path)
    details = {
        "direction_deg": math.degrees(plan.angle),
        "side": float(plan.handedness),
        "sweep_m": distance,
    }
    motion = (Segment("sweep", path, hand),)
    return _finished(ctx, arm, name, avoid, plan, end_xy, hand, motion, nu, details)


def _finished(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    plan: _Sweep,
    end_xy: np.ndarray,
    hand: HandCommand,
    motion: tuple[Segment, ...],
    nu: np.ndarray,
    details: dict[str, float],
) -> Outcome:
    """The sweep's ``motion`` (ending with the hand_base at ``end_xy`` at the plan's height)
    and nu_o checked against avoidVol, then the retreat along the sweep and the rise, clear of
    the object where it was left."""
    spec = ctx.beliefs[name].spec
    if not arm.motion_free(motion, avoid):
        return Failure(name, ACTION, "the arm hits avoidVol during the sweep")
    with ctx.stats.timed("volumes"):
        if ctx.sweeps_into(name, nu, avoid):
            return Failure(name, ACTION, NU_INTO_AVOID)
    placed = avoid + Volume.of_object(name, spec, nu[-1], ctx.surface.top_z)
    clear = arm.free_check(placed, hand, exact=True)
    back_xy = end_xy - SWEEP_RETREAT * plan.frame.x_axis
    retreat = arm.straight(motion[-1].path[-1], hand_pose(back_xy, plan.approach, plan.z), clear)
    rise = (
        None
        if retreat is None
        else arm.straight(
            retreat[-1],
            hand_pose(back_xy, plan.approach, rise_height(ctx.surface.top_z, spec.height, plan.z)),
            clear,
        )
    )
    if retreat is None or rise is None:
        return Failure(name, ACTION, "no collision-free retreat after the sweep")
    segments = (*motion, Segment("retreat", retreat, hand), Segment("rise", rise, hand))
    return ActionResult(ACTION, name, Trajectory(segments), nu, False, details)


def _straight_sweep(
    arm: Arm,
    plan: _Sweep,
    start_xy: np.ndarray,
    end_xy: np.ndarray,
    free: tuple[Free, Free],
) -> np.ndarray | str:
    """The straight hand line from start to end (`Arm.line`: from either end), or why there is
    none: every configuration clear of avoidVol, the first one also of the object's samples
    (`_clearances`; a line traced back can end with the arm inside the object, so it is then
    traced from the start)."""
    clear, at_start = free
    start, end = (hand_pose(xy, plan.approach, plan.z) for xy in (start_xy, end_xy))
    q_end = arm.solve(end, clear)
    if q_end is None:
        return "no collision-free IK solution at the end of the sweep"
    path = arm.line(q_end, start, end, clear, at_start)
    return "the straight sweep is out of reach or hits avoidVol" if path is None else path
