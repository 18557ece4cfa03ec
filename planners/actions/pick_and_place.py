"""Pick-and-place of an obstacle (the baseline's way of moving things, §3.2.1): after a static
grasp, close, lift `CARRY_LIFT`, carry level to the nearest placement out of the NGR that stands
clear of every other object, lower, open and back away. The carried object's volume is part of
the action's volume."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.reachability import hand_pose
from clutter_gym.model.trajectory import Segment, Trajectory
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import Goal
from planners.actions.grasp_geometry import GRASP_CLOSURE, translated
from planners.actions.hand_in import (
    CLOSES_OFF_SURFACE,
    FINGERS_INTO_AVOID,
    TURNS_INTO_AVOID,
    HandIn,
    closing,
    fingers_close_free,
    release,
    through_close,
    turned_into,
)
from planners.actions.results import ActionResult, Failure, unfit

ACTION = "pick-and-place"
CARRY_LIFT = 0.15  # m: the object is carried this far above where it stood
PLACEMENT_SPACING = 0.05  # m between candidate placements and between carried-volume poses
PLACEMENT_TRIES = 6  # placements in G tried per grasp, nearest first
PLACEMENT_CHUNK = 32
"""Placements whose G test runs at once, nearest first: a grasp's first placements in G are
mostly among its nearest few dozen, and one test of many poses costs little more than one."""
PLACE_ABOVE = 0.01
"""m above where it was grasped that a carried object is let go: lowered all the way, an object
that slipped a few mm in the fingers is pressed into the table and springs away when released."""


Carry = tuple[tuple[Segment, ...], Volume]
"""A carry's segments (carry, lower, release) and the carried object's volume."""


@dataclass
class GraspToPlace:
    """What a grasp with one avoidVol gives pick-and-place before any placement: the close and
    the lift (or why they fail), and the carries to the placements asked so far. None of it
    depends on G, so every parent candidate that asks to move the object with this hand-in
    (`push_grasp.HandInSearch` keeps them) reads it and only tests its own placements. The
    hand-in and avoidVol are kept: their ids key the entry (`PlanningContext.grasps_to_place`)."""

    moved: HandIn
    avoid: Volume
    held: tuple[np.ndarray, np.ndarray, np.ndarray] | Failure  # (turning, in hand, lift)
    carries: dict[tuple[float, float], Carry | None] = field(default_factory=dict)


def place(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    goal: Goal,
    avoid: Volume,
    moved: HandIn,
    details: dict[str, float],
) -> ActionResult | Failure:
    """Carry the grasped obstacle to a placement in G; nu_o is the push, the object turning
    while the fingers close (`closing`) and where it is put down, every stage with one pose per
    sample, parameter set and turn. The details add where it is put down (``place_x_m``,
    ``place_y_m``: the middle of its put-down poses), which a plan's summary otherwise omits."""
    why = unfit(ctx.beliefs[name].spec, pushed=True, lifted=True)
    if why:  # the carry lifts it: the 5 kg dumbbell is pushed only
        return Failure(name, ACTION, why)
    grasp = _grasp_to_place(ctx, arm, name, avoid, moved)
    if isinstance(grasp.held, Failure):
        return grasp.held
    turning, in_hand, lifted = grasp.held
    closed = HandCommand(0.0, GRASP_CLOSURE)
    for shift, placed in _free_placements(ctx, name, goal, in_hand):
        ctx.check_budget()
        key = (float(shift[0]), float(shift[1]))
        if key not in grasp.carries:
            grasp.carries[key] = _carry(ctx, arm, name, avoid, moved, lifted, in_hand, shift)
        carried = grasp.carries[key]
        if carried is None:
            continue
        segments, volume = carried
        close = Segment("close", moved.q_end[None].copy(), closed)
        nu = np.concatenate([*through_close(moved.nu, turning, in_hand), placed[None]])
        trajectory = Trajectory((moved.push, close, Segment("lift", lifted, closed), *segments))
        middle = placed[:, :2].mean(axis=0)
        where = {"place_x_m": float(middle[0]), "place_y_m": float(middle[1])}
        return ActionResult(ACTION, name, trajectory, nu, False, {**details, **where}, volume)
    return Failure(name, ACTION, "no reachable placement out of the NGR")


def _grasp_to_place(
    ctx: PlanningContext, arm: Arm, name: str, avoid: Volume, moved: HandIn
) -> GraspToPlace:
    """The plan's `GraspToPlace` for this hand-in and avoidVol: close, then lift."""
    key = (id(moved), id(avoid))
    grasp = ctx.grasps_to_place.get(key)
    if grasp is not None:
        return grasp
    turning, in_hand = closing(ctx, name, moved)
    held: tuple[np.ndarray, np.ndarray, np.ndarray] | Failure
    if turned_into(ctx, name, turning, avoid):
        held = Failure(name, ACTION, TURNS_INTO_AVOID)
    elif not ctx.stays_stable(name, turning):
        held = Failure(name, ACTION, CLOSES_OFF_SURFACE)
    elif not fingers_close_free(ctx, arm, name, moved, avoid):
        held = Failure(name, ACTION, FINGERS_INTO_AVOID)
    else:
        free = arm.free_check(avoid, HandCommand(0.0, GRASP_CLOSURE))
        lift_to = hand_pose(moved.end_xy, moved.heading, moved.z + CARRY_LIFT)
        lifted = arm.straight(moved.q_end, lift_to, free)
        if lifted is None:
            held = Failure(name, ACTION, "no collision-free lift after the grasp")
        else:
            held = (turning, in_hand, lifted)
    grasp = GraspToPlace(moved, avoid, held)
    ctx.grasps_to_place[key] = grasp
    return grasp


def _free_placements(
    ctx: PlanningContext, name: str, goal: Goal, in_hand: np.ndarray
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """At most `PLACEMENT_TRIES` (shift, placed poses) in G, nearest first, where the object
    stands clear of every other object. Placements are plentiful and the object is held at
    many poses, so G is decided by its quick sufficient test (axis-aligned bounds clear of
    the NGR), `PLACEMENT_CHUNK` placements at a time, and the other objects by bounding
    circles before any exact geometry."""
    others = sorted(set(ctx.beliefs) - {name})
    tried = 0
    with ctx.stats.timed("placement"):
        shifts = _placements(ctx, in_hand[0, :2])
    for first in range(0, len(shifts), PLACEMENT_CHUNK):
        chunk = shifts[first : first + PLACEMENT_CHUNK]
        placed = np.repeat(in_hand[None], len(chunk), axis=0)
        placed[:, :, :2] += chunk[:, None, :]
        in_goal = goal.clearly_accepts_each(ctx, name, placed)
        for k in np.flatnonzero(in_goal):
            if _meets_others(ctx, name, placed[k], others):
                continue
            tried += 1
            if tried > PLACEMENT_TRIES:
                return
            yield chunk[k], placed[k]


def _meets_others(ctx: PlanningContext, name: str, placed: np.ndarray, others: list[str]) -> bool:
    """Whether the object at any of ``placed`` overlaps a sample of one of ``others``
    (`PlanningContext.meets_samples`)."""
    with ctx.stats.timed("placement"):
        return ctx.meets_samples(name, placed, others)


def _carry(
    ctx: PlanningContext,
    arm: Arm,
    name: str,
    avoid: Volume,
    moved: HandIn,
    lifted: np.ndarray,
    in_hand: np.ndarray,
    shift: np.ndarray,
) -> tuple[tuple[Segment, ...], Volume] | None:
    """Carry, lower, release and back away at one placement; the segments and the carried
    object's volume, or None if the arm cannot."""
    closed = HandCommand(0.0, GRASP_CLOSURE)
    free = arm.free_check(avoid, closed)
    place_xy = moved.end_xy + shift
    heading, z = moved.heading, moved.z
    put_down = hand_pose(place_xy, heading, z + PLACE_ABOVE)
    if not free.hand_clear(put_down):  # the lowering would end there: no carry is walked
        return None
    carry = arm.straight(lifted[-1], hand_pose(place_xy, heading, z + CARRY_LIFT), free)
    if carry is None:
        return None
    lower = arm.straight(carry[-1], put_down, free)
    if lower is None:
        return None
    carried = _carried_volume(ctx, name, in_hand, shift)
    if carried.intersects(avoid):
        return None
    placed = translated(in_hand, shift)
    # Opened back to the grasp's preshape, not flat: fingers swinging flat from a grasp flung
    # a placed poptart box 14 cm and toppled it (high_05); the preshape slides off as it came.
    preshape = moved.push.hand
    finish = release(
        ctx, arm, name, closed, preshape, lower[-1], place_xy, heading, z, placed, avoid
    )
    if finish is None:
        return None
    segments = (Segment("carry", carry, closed), Segment("lower", lower, closed), *finish)
    return segments, carried


def _placements(ctx: PlanningContext, centre: np.ndarray) -> np.ndarray:
    """Shifts from ``centre`` to points of a PLACEMENT_SPACING grid over the surface, nearest
    first (a short carry is a short, reachable motion)."""
    x0, x1, y0, y1 = ctx.surface.bounds
    xs = np.arange(x0, x1, PLACEMENT_SPACING) + PLACEMENT_SPACING / 2
    ys = np.arange(y0, y1, PLACEMENT_SPACING) + PLACEMENT_SPACING / 2
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2) - centre
    distances = np.linalg.norm(grid, axis=1)
    order = np.argsort(distances, kind="stable")
    return grid[order[distances[order] > PLACEMENT_SPACING / 2]]


def _carried_volume(
    ctx: PlanningContext, name: str, in_hand: np.ndarray, shift: np.ndarray
) -> Volume:
    """The held object's samples raised over the pick-up spot, carried level at CARRY_LIFT
    and lowered over the placement, every PLACEMENT_SPACING."""
    spec = ctx.beliefs[name].spec
    top = ctx.surface.top_z
    total = Volume()
    for z in np.arange(spec.height, CARRY_LIFT + 1e-9, spec.height):
        for poses in (in_hand, translated(in_hand, shift)):
            total += Volume.of_object(name, spec, poses, top + float(z))
    steps = max(2, math.ceil(float(np.linalg.norm(shift)) / PLACEMENT_SPACING) + 1)
    for f in np.linspace(0.0, 1.0, steps):
        total += Volume.of_object(name, spec, translated(in_hand, f * shift), top + CARRY_LIFT)
    return total
