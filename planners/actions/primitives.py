"""The paper's actions with their parameters chosen by the caller instead of searched for: one
push-grasp (then PickUp, or release), or one sweep, built by the planner's own motion code.

Rearrange searches the parameters (direction, aperture, lateral offset, distance) and keeps
only candidates the capture region guarantees. A learning agent (the primitive-level env,
``ClutterRetrievePrimitive-v0``) or a script picks them itself; here the arm's feasibility (IK,
straight motions, the support) is checked as the planner checks it, and whether the object ends
in the hand is left to physics. ``avoid`` says which detected objects the arm must not touch
(none, for an agent that may push through anything).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from clutter_gym.model.collision import Volume
from clutter_gym.model.transforms import Frame2D
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import Anywhere, Retrieve
from planners.actions.grasp_geometry import START_CLEARANCE, near_edge, translated
from planners.actions.hand_in import hand_in, pick_up_or_release
from planners.actions.results import Failure, Outcome, unfit
from planners.actions.sweep import sweep_with
from planners.hand2d import push_grasp_profile

PrimitiveKind = Literal["pickup", "push-grasp", "sweep"]
PRIMITIVE_KINDS: tuple[PrimitiveKind, ...] = ("pickup", "push-grasp", "sweep")
GRASP_DEPTH = 0.03
"""m the object's centre sits behind the fingertips' line when a push of distance 0 ends: a
static grasp of the detected pose."""


@dataclass(frozen=True)
class Primitive:
    """One parameterised action on one object.

    - ``kind``: "pickup" (push-grasp, close, lift or pull out), "push-grasp" (push-grasp, then
      open flat and back away) or "sweep" (the outer side of the hand pushes it sideways);
    - ``heading``: world yaw of the push (of the hand's approach for a push-grasp, of the
      object's motion for a sweep);
    - ``offset``: push-grasp: m the hand is shifted to its left of the object's centre; sweep:
      where the object meets the hand's side, 0 at the wrist end to 1 at the fingertip;
    - ``distance``: m pushed past a static grasp of the detected pose, or swept;
    - ``aperture``: m between the fingertips (push-grasp); ``handedness`` which side of the
      hand sweeps (+1 its right, -1 its left).
    """

    kind: PrimitiveKind
    obj: str
    heading: float
    offset: float
    distance: float
    aperture: float = 0.0
    handedness: int = 1


def execute_primitive(
    ctx: PlanningContext, arm: Arm, primitive: Primitive, avoid: Volume
) -> Outcome:
    """The primitive's trajectory (from its start pose on) and nu_o, or why the arm cannot."""
    if primitive.kind == "sweep":
        return sweep_with(
            ctx,
            arm,
            primitive.obj,
            (primitive.heading, primitive.handedness),
            primitive.offset,
            primitive.distance,
            avoid,
        )
    return _push_grasp_with(ctx, arm, primitive, avoid)


def _push_grasp_with(
    ctx: PlanningContext, arm: Arm, primitive: Primitive, avoid: Volume
) -> Outcome:
    name, heading = primitive.obj, primitive.heading
    action = primitive.kind
    belief = ctx.beliefs[name]
    why = unfit(belief.spec, pushed=primitive.distance > 0, lifted=action == "pickup")
    if why:
        return Failure(name, action, why)
    profile = push_grasp_profile(primitive.aperture)
    v = np.array([math.cos(heading), math.sin(heading)])
    centre = belief.samples[0, :2] + primitive.offset * np.array([-v[1], v[0]])
    local = Frame2D((float(centre[0]), float(centre[1])), heading).to_frame(belief.samples)
    back_off = near_edge(belief.spec.footprint, local) - profile.pusher.bounds[1]
    start_xy = centre + (back_off - START_CLEARANCE) * v
    end_xy = centre + (primitive.distance - profile.grasp_line + GRASP_DEPTH) * v
    if float((end_xy - start_xy) @ v) < 0.0:
        return Failure(name, action, "the hand would end behind where it starts")

    def evolve() -> np.ndarray:
        """The samples carried rigidly by the push (physics decides what really happens)."""
        return np.stack([belief.samples, translated(belief.samples, primitive.distance * v)])

    moved = hand_in(ctx, arm, name, action, avoid, (start_xy, end_xy), heading, profile, evolve)
    if isinstance(moved, Failure):
        return moved
    details = {
        "heading_deg": math.degrees(heading),
        "aperture_m": primitive.aperture,
        "offset_m": primitive.offset,
        "push_m": primitive.distance,
    }
    goal = Retrieve() if action == "pickup" else Anywhere()
    return pick_up_or_release(ctx, arm, name, goal, avoid, action, moved, details)
