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
from planners.capture import SweepRegion, extreme_parameters
from planners.hand2d import closure_for_aperture, sweep_profile

ACTION = "sweep"
NU_STEP = 0.005  # m: simulation step of nu_o (regions are built at 1 mm; nu_o is a volume)
PILOT_STEP = 0.01  # m: simulation step of the one-sample pilot of a sweep
SWEEP_CHUNK = 0.06  # m of sweep simulated before checking whether the object has reached G
SWEEP_RETREAT = 0.02  # m the hand backs away along the sweep before rising
_NOT_FAR_ENOUGH = "no sweep up to {} m ends {}"
PILOT_INTO_AVOID = "the detected pose sweeps into avoidVol"
EXACT_STRIDE = 4
"""Steps of nu_o between the first exact goal tests of a sweep's first guess."""

DIRECTION_REFINE = 2
"""In an enclosed surface the sweep directions are searched again at this fraction of the
settings' step (`_directions`)."""
SWEEP_PLACEMENTS = (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8, 0.1, 0.9, 0.55, 0.65, 0.45, 0.75)
"""Where the object's centre meets the hand's side, as fractions from the wrist end to the
fingertip, most central first, then the half-steps between the central ones: how far the sweep
region holds an object changes steeply with the placement (a large box swept square to its face
in a Figs. 3-5 variant: every sample 0.27 m at 0.5, 0.72 m at 0.6, where the arm has no IK at the
sweep's start)."""


def sweep(
    ctx: PlanningContext, arm: Arm, name: str, goal: Goal, avoid: Volume
) -> Iterator[Outcome]:
    """Sweeps of ``name`` out of the NGR with the outer side of the hand, best first."""
    if not isinstance(goal, AwayFrom):
        return
    if not ctx.beliefs[name].spec.pushable:
        yield Failure(name, ACTION, "tips over when pushed")
        return
    for angle, handedness in _directions(ctx, arm, name):
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        yield from _sweep_at(ctx, arm, name, goal, avoid, angle, handedness)


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
) -> Iterator[Outcome]:
    """At most one sweep in this direction (and the failures on the way)."""
    with ctx.stats.timed("capture"):  # the samples in the sweep's frame
        plan = _plan_sweep(ctx, name, angle, handedness)
    guess = _first_guess(ctx, name, goal, plan)
    if guess is None:
        guess = _pilot_guess(ctx, name, goal, plan)
    if guess is None:
        yield Failure(name, ACTION, _NOT_FAR_ENOUGH.format(ctx.settings.sweep_max, goal.describe()))
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
        frame, in_frame, placed = placement  # the plan at the placement's height
        with ctx.stats.timed("nu"):
            swept = _simulate(ctx, name, goal, placed.region, frame, in_frame, avoid)
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


def _clearances(
    ctx: PlanningContext, arm: Arm, name: str, avoid: Volume, hand: HandCommand
) -> tuple[Free, Free]:
    """The sweep's collision checks: clear of avoidVol, and, where it starts, of the object's
    own samples too (the approach or transit brings the arm there with the object standing
    where it was detected; beside a large box the first IK solution often has the elbow in
    it)."""
    return arm.free_check(avoid, hand), arm.free_check(ctx.with_own_samples(avoid, name), hand)


def _plan_sweep(ctx: PlanningContext, name: str, angle: float, handedness: int) -> _Sweep:
    belief = ctx.beliefs[name]
    spec = belief.spec
    region = ctx.sweep_region(spec.footprint)
    profile = sweep_profile(region.aperture)
    centre = (float(belief.samples[0, 0]), float(belief.samples[0, 1]))
    local = Frame2D(centre, angle, handedness).to_frame(belief.samples)
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
    )


def _first_guess(ctx: PlanningContext, name: str, goal: AwayFrom, plan: _Sweep) -> float | None:
    """A rigid translation along the sweep is a cheap first guess of how far to sweep (the
    simulated evolution decides); it does not depend on where along the hand. The top-view
    test of the axis-aligned bounds is tried first, for every distance at once; when no
    distance passes it (a turned box's
    bounds are pessimistic next to the NGR), the exact test decides, every `EXACT_STRIDE`
    steps first and then at the steps just short of the first distance that passes: a failing
    exact test costs milliseconds (a large NGR), and most distances fail."""
    samples = ctx.beliefs[name].samples
    direction = plan.frame.x_axis
    gap = START_CLEARANCE
    shifts = np.arange(NU_SPACING, ctx.settings.sweep_max - gap + 1e-9, NU_SPACING)

    def accepts(d: float) -> bool:
        return goal.accepts(ctx, name, translated(samples, d * direction), False)

    moved = np.repeat(samples[None], len(shifts), axis=0)
    moved[:, :, :2] += (shifts[:, None] * direction)[:, None, :]
    clear = np.flatnonzero(goal.clearly_accepts_each(ctx, name, moved))
    if len(clear):
        return float(gap + shifts[clear[0]])
    coarse = list(range(EXACT_STRIDE - 1, len(shifts), EXACT_STRIDE))
    if coarse[-1] != len(shifts) - 1:
        coarse.append(len(shifts) - 1)
    previous = -1
    for k in coarse:
        if accepts(shifts[k]):
            shorter = (j for j in range(previous + 1, k) if accepts(shifts[j]))
            return float(gap + shifts[next(shorter, k)])
        previous = k
    return None


def _pilot_guess(ctx: PlanningContext, name: str, goal: AwayFrom, plan: _Sweep) -> float | None:
    """How far a sweep of the detected pose alone, at the most central placement, goes before
    it is in G: the guess when no rigid translation reaches G, because the object must turn
    on the way (a long object pushed at its end swings round against the hand, and only then
    fits between the NGR and the table's edge). The pilot is kept for the full simulation."""
    with ctx.stats.timed("capture"):
        frame, in_frame = _frame_at(ctx, name, plan, SWEEP_PLACEMENTS[0])
        limit = min(ctx.settings.sweep_max, plan.region.holds_until(in_frame[:1]))
    with ctx.stats.timed("nu"):
        pilot = _sweep_until(ctx, name, goal, plan.region, frame, in_frame[:1], limit, PILOT_STEP)
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
) -> tuple[Frame2D, np.ndarray, _Sweep] | Failure:
    """The sweep frame with the object's centre at ``fraction`` along the hand's side, if the
    capture region holds every sample and the arm reaches the start (clear of the object too:
    `_clearances`) and the guessed end; the sweep at the lowest height the arm holds the hand
    there (`Arm.push_height`)."""
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
            return frame, in_frame, at_z
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
    return frame, frame.to_frame(ctx.beliefs[name].samples)


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


def _simulate(
    ctx: PlanningContext,
    name: str,
    goal: AwayFrom,
    region: SweepRegion,
    frame: Frame2D,
    in_frame: np.ndarray,
    avoid: Volume,
) -> tuple[float, np.ndarray] | str:
    """How far to sweep and nu_o, or why not: a pilot with the detected pose alone (a
    thirtieth of the work) says whether and roughly where the sweep reaches G, and whether the
    detected pose already sweeps into avoidVol (nu_o holds its path, so the sweep would fail
    there after simulating every sample); only then are all samples simulated, tested for G
    from a chunk before there on, as far as the sweep may go (the samples spread as they turn,
    and the last of them may need several chunks more)."""
    # No sweep longer than the region holds every sample can pass: simulate no further.
    limit = min(ctx.settings.sweep_max, region.holds_until(in_frame))
    not_far_enough = _NOT_FAR_ENOUGH.format(ctx.settings.sweep_max, goal.describe())
    pilot = _sweep_until(ctx, name, goal, region, frame, in_frame[:1], limit, PILOT_STEP)
    if pilot is None:
        return not_far_enough
    if ctx.sweeps_into(name, pilot[1], avoid):
        return PILOT_INTO_AVOID
    swept = _sweep_until(
        ctx,
        name,
        goal,
        region,
        frame,
        in_frame,
        limit,
        check_from=pilot[0] - SWEEP_CHUNK,
    )
    return not_far_enough if swept is None else swept


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
    spec = ctx.beliefs[name].spec
    start_xy = np.asarray(frame.origin)
    end_xy = start_xy + distance * frame.x_axis
    path = _straight_sweep(arm, plan, start_xy, end_xy, free)
    if isinstance(path, str):
        return Failure(name, ACTION, path)
    q_end = path[-1]
    motion = Segment("sweep", path, hand)
    if not arm.motion_free((motion,), avoid):
        return Failure(name, ACTION, "the arm hits avoidVol during the sweep")
    with ctx.stats.timed("volumes"):
        if ctx.sweeps_into(name, nu, avoid):
            return Failure(name, ACTION, NU_INTO_AVOID)
    placed = avoid + Volume.of_object(name, spec, nu[-1], ctx.surface.top_z)
    clear = arm.free_check(placed, hand, exact=True)
    back_xy = end_xy - SWEEP_RETREAT * frame.x_axis
    retreat = arm.straight(q_end, hand_pose(back_xy, plan.approach, plan.z), clear)
    rise = (
        None
        if retreat is None
        else arm.straight(
            retreat[-1],
            hand_pose(back_xy, plan.approach, rise_height(ctx.surface.top_z, spec.height, plan.z)),
            arm.free_check(placed, hand, exact=True),
        )
    )
    if retreat is None or rise is None:
        return Failure(name, ACTION, "no collision-free retreat after the sweep")
    details = {
        "direction_deg": math.degrees(plan.angle),
        "side": float(plan.handedness),
        "sweep_m": distance,
    }
    segments = (motion, Segment("retreat", retreat, hand), Segment("rise", rise, hand))
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


@dataclass
class SweepEvolution:
    """A sweep's simulated nu_o so far, chunk by chunk. The evolution depends on the object's
    samples, the sweep's frame and the pushing parameters, not on the goal G (only where it
    stops does), so every parent candidate of a plan that asks for the same sweep reuses it
    (`PlanningContext.sweeps`) and only runs its own stop test."""

    chunks: list[tuple[np.ndarray, np.ndarray]]  # (distances (k + 1,), world (k + 1, P, N, 3))
    current: np.ndarray  # hand-frame poses where the last chunk ends
    advanced: float  # m simulated

    def chunk(
        self,
        i: int,
        region: SweepRegion,
        frame: Frame2D,
        step: float,
        limit: float,
        chosen: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Chunk ``i`` of the sweep, simulated only the first time anyone asks for it."""
        while len(self.chunks) <= i:
            d = min(SWEEP_CHUNK, limit - self.advanced)
            k = max(1, math.ceil(d / NU_SPACING))
            nu_hand = region.evolve(self.current, d, k, step, chosen)
            distances = self.advanced + np.linspace(0.0, d, k + 1)
            self.chunks.append((distances, frame.moving_to_world(nu_hand, distances)))
            self.current = nu_hand[-1]
            self.advanced += d
        return self.chunks[i]


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
    box under every (mu_c, c) is the planner's most expensive computation, so the chunks are
    kept (`SweepEvolution`) for the next goal that asks for the same sweep. G is tested from
    ``check_from`` on (a pilot run tells roughly where it is reached)."""
    chosen = extreme_parameters(region.mus, region.cs)
    key = (name, frame.origin, frame.angle, frame.handedness, step, len(in_frame))
    evolution = ctx.sweeps.get(key)
    if evolution is None:
        evolution = ctx.sweeps[key] = SweepEvolution([], in_frame, 0.0)
    stages = [frame.moving_to_world(np.tile(in_frame, (len(chosen), 1, 1))[None], np.zeros(1))]
    hold = region.holds_until(in_frame)
    i = 0
    while i < len(evolution.chunks) or evolution.advanced < limit - 1e-9:
        ctx.check_budget()
        distances, world = evolution.chunk(i, region, frame, step, limit, chosen)
        i += 1
        # A chunk kept from a longer sweep may run past this one's limit.
        k = int(np.searchsorted(distances, limit + 1e-9)) - 1
        if k < 1:
            break
        if distances[k] >= check_from:

            def reached(j: int, d: np.ndarray = distances, w: np.ndarray = world) -> bool:
                return _reached(ctx, name, goal, region, in_frame, float(d[j]), w[j])

            held = bool(distances[k] < hold)
            if not held or reached(k):
                # G is reached by the chunk's end, or the region lets go of a sample by then and
                # holds none longer: the sweep is the chunk's first stage that reaches G (the
                # last stage only while it is held, and then it is known to).
                last = k if held else k - 1
                j = next((j for j in range(1, last + 1) if j == k or reached(j)), None)
                if j is None:
                    return None
                return float(distances[j]), np.concatenate([*stages, world[1 : j + 1]])
        if k < len(distances) - 1:
            break
        stages.append(world[1:])
    return None
