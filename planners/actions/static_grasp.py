"""Static grasps: hand poses drawn from the object's task space region (TSR) that grasp every
uncertainty sample as it stands, without pushing. PickUp for the goal object (the uncertainty
TSR baseline, and the d = 0 push-grasps of the pushing planner); an obstacle is picked up,
carried out of the NGR and put down (pick-and-place, §3.2.1)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import Footprint
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import Goal, Retrieve
from planners.actions.grasp_geometry import START_CLEARANCE, near_edge
from planners.actions.hand_in import OUT_OF_REACH, HandIn, hand_in, pick_up_or_release
from planners.actions.heuristics import base_heading, push_headings
from planners.actions.pick_and_place import place
from planners.actions.results import ActionResult, Failure, Outcome, unfit
from planners.capture import CaptureRegion, push_grasp_apertures
from planners.hand2d import (
    GRASP_DEPTH,
    PALM_FRONT,
    TURN_SEAT,
    PushGraspProfile,
    push_grasp_profile,
)
from planners.tsr import GraspTSR, grasps_every_sample

TSR_DRAWS = 300  # hand poses drawn from a TSR per aperture (seeded)
TSR_DEPTH = 0.08  # m: the TSR's depth bound, behind the grasp line
TSR_IK_TRIES = 12
"""Static-grasp poses tried with IK and motions per aperture. A pose the reachability map rules
out on the hand's way in, or whose hand overlaps an object of avoidVol (the planar
test before any IK), costs microseconds and is not one of them: the directions §2.2.6 ranks
first hit the fewest objects, which behind the object are often out of reach and beside a
fixed neighbour often blocked by it, and counting them left reachable directions that need
only movable objects moved untried."""
NO_TSR_POSE = "no hand pose in the TSR grasps every uncertainty sample"
TSR_SPREAD = math.radians(4.0)  # rad between the headings of the poses tried


def static_grasp(
    ctx: PlanningContext, arm: Arm, name: str, goal: Goal, avoid: Volume
) -> Iterator[Outcome]:
    """Static grasps of ``name``, most centred first, from the §2.2.6 order of directions."""
    spec = ctx.beliefs[name].spec
    action = "pickup" if isinstance(goal, Retrieve) else "pick-and-place"
    why = unfit(spec, pushed=False, lifted=True)
    if why:
        yield Failure(name, action, why)
        return
    found: list[float] = []  # headings that gave a grasp
    for aperture in sorted(push_grasp_apertures(spec.footprint), reverse=True):
        ctx.check_budget()
        yield from _at_aperture(ctx, arm, name, goal, avoid, action, aperture, found)


def _at_aperture(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    action: str,
    aperture: float,
    found: list[float],
) -> Iterator[Outcome]:
    """Static grasps at one aperture, each at a heading away from those in ``found``
    (extended here), until `TSR_IK_TRIES` poses have paid for IK."""
    belief = ctx.beliefs[name]
    centre = belief.samples[0, :2]
    base = base_heading(arm.heading_origin, centre)
    limit = math.radians(ctx.settings.max_heading_deg)
    region = ctx.push_region(belief.spec.footprint, aperture)
    profile = push_grasp_profile(aperture)
    tsr = GraspTSR(
        (float(centre[0]), float(centre[1])),
        (base - limit, base + limit),
        (-profile.half_gap, profile.half_gap),
        (profile.grasp_line - TSR_DEPTH, _deepest(belief.spec.footprint, profile)),
    )
    draws = _grasping_draws(ctx, arm, name, tsr, region, profile, avoid)
    if not len(draws):
        yield Failure(name, action, NO_TSR_POSE)
        return

    def still() -> np.ndarray:
        """nu_o of a static grasp: the samples stay where they are until the fingers close."""
        return np.stack([belief.samples, belief.samples])

    ik_tries = 0
    for heading, lateral, depth in _distinct(draws, found, ctx.settings.heading_step_deg):
        if ik_tries >= TSR_IK_TRIES:
            return
        ctx.check_budget()
        ctx.stats.actions_tried += 1
        start_xy, end_xy = _hand_line(ctx, name, tsr, profile, (heading, lateral, depth))
        if not arm.line_heights(start_xy, end_xy, heading):
            yield Failure(name, action, OUT_OF_REACH)
            continue
        line = (start_xy, end_xy)
        moved = hand_in(ctx, arm, name, action, avoid, line, heading, profile, still)
        if not (isinstance(moved, Failure) and moved.blocker):
            ik_tries += 1
        if isinstance(moved, Failure):
            yield moved
            continue
        details = {
            "heading_deg": math.degrees(heading),
            "aperture_m": aperture,
            "lateral_m": lateral,
            "depth_m": depth,
        }
        finish = place if action == "pick-and-place" else _pick_up
        result = finish(ctx, arm, name, goal, avoid, moved, details)
        yield result
        if isinstance(result, ActionResult):
            found.append(float(heading))


def _deepest(footprint: Footprint, profile: PushGraspProfile) -> float:
    """The TSR's bound on the object centre's depth (hand x): `GRASP_DEPTH` behind the
    fingertip line, or, for a box, as far ahead as the closing fingers still turn it to the
    axis and hold it (`planners.tsr.grasped_still`), past the line for a box end-on."""
    deepest = profile.grasp_line - GRASP_DEPTH
    if footprint.shape == "box":
        deepest = max(deepest, PALM_FRONT + TURN_SEAT[-1][0] + footprint.bounding_radius)
    return deepest


def _pick_up(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    moved: HandIn,
    details: dict[str, float],
) -> Outcome:
    """PickUp after the hand is in: close, then lift or pull out."""
    return pick_up_or_release(ctx, arm, name, goal, avoid, "pickup", moved, details)


def _hand_line(
    ctx: PlanningContext,
    name: str,
    tsr: GraspTSR,
    profile: PushGraspProfile,
    pose: tuple[float, float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """hand_base where the straight motion to a TSR pose (heading, lateral, depth) starts, a
    clearance short of the nearest sample, and where it stops."""
    frame = tsr.hand_frame(*pose)
    end_xy = np.asarray(frame.origin)
    samples = frame.to_frame(ctx.beliefs[name].samples)
    back = (
        profile.pusher.bounds[1]
        + START_CLEARANCE
        - near_edge(ctx.beliefs[name].spec.footprint, samples)
    )
    return end_xy - max(back, START_CLEARANCE) * frame.x_axis, end_xy


def _grasping_draws(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    tsr: GraspTSR,
    region: CaptureRegion,
    profile: PushGraspProfile,
    avoid: Volume,
) -> np.ndarray:
    """Hand poses (K, 3) drawn from the TSR that grasp every sample as it stands, in §2.2.6's
    order of the push directions (objects hit on the way in first), then most centred."""
    samples = ctx.beliefs[name].samples
    with ctx.stats.timed("capture"):
        draws = tsr.sample(ctx.rng, TSR_DRAWS)
        draws = draws[grasps_every_sample(region, tsr, draws, samples)]
    if not len(draws):
        return draws
    reach = profile.pusher.bounds[3]
    ranked = np.array(push_headings(ctx, arm.heading_origin, name, reach, avoid))
    rank = np.abs(np.remainder(draws[:, :1] - ranked + np.pi, 2 * np.pi) - np.pi).argmin(1)
    return draws[np.lexsort((np.abs(draws[:, 1]), rank))]


def _distinct(
    draws: np.ndarray, found: list[float], step_deg: float
) -> Iterator[tuple[float, float, float]]:
    """Draws in order, skipping headings near one already tried (a pose from nearly the same
    direction fails the same way) or near one that gave a grasp (``found``, which the caller
    extends as grasps are found)."""
    tried: list[float] = []
    for heading, lateral, depth in draws:
        near_found = any(abs(heading - h) < math.radians(step_deg) for h in found)
        near_tried = any(abs(heading - h) < TSR_SPREAD for h in tried)
        if near_found or near_tried:
            continue
        tried.append(float(heading))
        yield float(heading), float(lateral), float(depth)
