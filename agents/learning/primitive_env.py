"""`ClutterRetrievePrimitive-v0`: one env step is one of the paper's parameterised primitives.

The agent picks what the planner searches: a primitive (PickUp, push-grasp then release, or
sweep), the object it acts on, and the primitive's direction, lateral offset (where along the
hand, for a sweep), distance and aperture (which side of the hand, for a sweep). The env, a
`gymnasium.Wrapper` of the trajectory env, builds it with the planner's own action code
(`planners.actions.primitives`) from the latest detection, moves the arm there with GoTo, and
runs it in `ClutterRetrieve-v0`'s physics:
free-space motions fast, contact quasi-static (`SEGMENT_SPEEDS`). Whether the object ends in the
hand, stays upright or is knocked over is physics' answer, not the capture region's.

Action: ``MultiDiscrete([3, MAX_OBJECTS, 12, 5, 4, 2])`` =
(primitive, slot, direction, offset, distance, aperture-or-side):

- primitive: `PRIMITIVE_KINDS` (0 pickup, 1 push-grasp, 2 sweep);
- slot: 0 is the goal object, then the others by distance from the goal's detection;
- direction: `DIRECTIONS_DEG` from the line from the right shoulder to the object (0 pushes
  straight away from the robot; +-180 pulls toward it);
- offset: `OFFSETS` m of lateral hand shift (push-grasp), or `SWEEP_FRACTIONS` along the hand;
- distance: `PUSH_DISTANCES` m past a static grasp, or `SWEEP_DISTANCES` m swept;
- the last: push-grasp aperture (0 one that fits the object at any orientation,
  `planners.hand2d.default_aperture`; 1 the fingertips straight ahead, `STRAIGHT_APERTURE`), or
  for a sweep the side of the hand (0 its right, 1 its left).

Observation: ``Box((MAX_OBJECTS * 8 + 4,))``, per slot in the action's order: occupied, x, y
(the goal's absolute, the others' relative to the goal), cos 2 theta, sin 2 theta, footprint
extents and height; then the detection noise (sigma_xy, sigma_theta) and the goal region's
centre relative to the goal. Detections are redrawn after every step, as in the other variants.

Reward: +1 when the goal is retrieved, -1 when a step fails the task (an object toppled or
fell, the arm hit the support), `INFEASIBLE_COST` when the chosen parameters have no motion
(no IK solution, no collision-free straight push, no GoTo): the step then ends without moving,
never with an exception. Truncation is the registered TimeLimit.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.model.collision import Volume
from clutter_gym.model.observation import MAX_OBJECTS, Observation, ObservedScene, decode
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.sim.controllers import SegmentSpeed
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.heuristics import base_heading
from planners.actions.primitives import PRIMITIVE_KINDS, Primitive, execute_primitive
from planners.actions.results import Failure
from planners.actions.settings import PlannerSettings
from planners.hand2d import STRAIGHT_APERTURE, default_aperture
from planners.uncertainty import ObjectBelief

DIRECTIONS_DEG = tuple(range(-150, 181, 30))
OFFSETS = (-0.02, -0.01, 0.0, 0.01, 0.02)
SWEEP_FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
PUSH_DISTANCES = (0.0, 0.05, 0.10, 0.20)
SWEEP_DISTANCES = (0.05, 0.10, 0.20, 0.30)
INFEASIBLE_COST = -0.1
SLOT_FEATURES = 8
SEGMENT_SPEEDS = {
    "transit": SegmentSpeed(hand=1.0, joints=1.0),
    "rise": SegmentSpeed(hand=0.3),
    "retreat": SegmentSpeed(hand=0.1),
    "lift": SegmentSpeed(hand=0.1),
}
"""Speed limits by segment label: a transit through free space at the arm's full joint
velocity limits; pushes, sweeps and pulls (in contact) keep the env's quasi-static
`max_hand_speed` (0.05 m/s), at which the capture regions were validated."""
GOTO_EVALUATIONS = 1500
"""Collision checks a GoTo to a primitive's start may spend (about 0.3 s here)."""


class PrimitivePhysicsEnv(ClutterRetrieveEnv):
    """`ClutterRetrieve-v0` with HERB's fixed links merged (`sim.robot`): a primitive is
    thousands of physics steps and this makes each about 40% cheaper. The same planned
    retrievals end alike, to the physics step (37 of 37 PG plans, seeds 0-19 of no and medium
    clutter at sigma2); a 1/100 s or 1/120 s step, tried too, changed 2 and 1 of the 17 lone
    objects (a bottle toppled, a can not lifted)."""

    merge_fixed_links = True


class ClutterRetrievePrimitiveEnv(gym.Wrapper[np.ndarray, np.ndarray, Any, Any]):
    """`ClutterRetrieve-v0` with one parameterised primitive per step (module docstring): a
    Gymnasium wrapper of the trajectory env, whose attributes (``scene``, ``surface``,
    ``waypoints``) it shows through `get_wrapper_attr`; ``unwrapped`` is that env."""

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        self._physics = PrimitivePhysicsEnv(render_mode=render_mode, **kwargs)
        super().__init__(self._physics)  # type: ignore[arg-type]  # mypy binds the inner env to the outer spaces
        self._actions = spaces.MultiDiscrete(
            [
                len(PRIMITIVE_KINDS),
                MAX_OBJECTS,
                len(DIRECTIONS_DEG),
                len(OFFSETS),
                len(PUSH_DISTANCES),
                2,
            ]
        )
        self.action_space = self._actions
        size = MAX_OBJECTS * SLOT_FEATURES + 4
        self.observation_space = spaces.Box(-10.0, 10.0, (size,), np.float32)
        self._obs: Observation = {}
        self._names: tuple[str, ...] = ()
        self._last_info: dict[str, Any] = {}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = self._physics.reset(seed=seed, options=options)
        return self._observe(obs, info), self._info(info, "")

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        a = np.asarray(action)
        nvec = self._actions.nvec
        if a.shape != nvec.shape or a.dtype.kind not in "iu" or np.any((a < 0) | (a >= nvec)):
            raise ValueError(
                f"action: {action!r}; expected shape {nvec.shape} integers, each in [0, n) "
                f"for n in {nvec.tolist()}"
            )
        seen = decode(self._obs, self._names)
        order = _slot_order(seen)
        slot = int(a[1])
        if slot >= len(order):
            return self._infeasible(f"slot {slot} is empty")
        trajectory = self._plan(seen, order[slot], a)
        if isinstance(trajectory, Failure):
            return self._infeasible(f"{trajectory.action} {trajectory.obj}: {trajectory.reason}")
        obs, reward, terminated, truncated, info = self._physics.execute_trajectory(
            trajectory, SEGMENT_SPEEDS
        )
        return self._observe(obs, info), float(reward), terminated, truncated, self._info(info, "")

    # -- internals -------------------------------------------------------------------------------
    def _plan(self, seen: ObservedScene, name: str, a: np.ndarray) -> Trajectory | Failure:
        """The primitive's motion from the arm's current configuration, or why there is none."""
        beliefs = {
            o.name: ObjectBelief(o.name, o.spec, o.detected, np.array([o.detected]))
            for o in seen.objects
        }
        settings = PlannerSettings(goto_evaluations=GOTO_EVALUATIONS)
        ctx = PlanningContext(
            seen.surface, beliefs, settings, seen.goal_region, np.random.default_rng(0)
        )
        arm = Arm(seen.surface, settings, ctx.stats, ctx.budget)
        primitive = _primitive(beliefs[name], a, arm)
        outcome = execute_primitive(ctx, arm, primitive, Volume())
        if isinstance(outcome, Failure):
            return outcome
        start = outcome.trajectory
        hand = start.segments[0].hand
        everything = ctx.objects_volume(beliefs)
        path, reason = arm.goto(seen.arm, start.start, everything, hand)
        if path is None:  # touching an object on the way is the agent's risk, not an error
            path, reason = arm.goto(seen.arm, start.start, Volume(), hand)
        if path is None:
            return Failure(name, "goto", f"to the primitive's start: {reason}")
        return Trajectory((Segment("transit", path, hand),)) + start

    def _infeasible(self, why: str) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        info = self._info(self._last_info, why)
        return self._flat(self._obs), INFEASIBLE_COST, False, False, info

    def _observe(self, obs: Observation, info: dict[str, Any]) -> np.ndarray:
        self._obs = obs
        self._names = tuple(info["object_names"])
        self._last_info = info
        return self._flat(obs)

    def _flat(self, obs: Observation) -> np.ndarray:
        seen = decode(obs, self._names)
        by_name = {o.name: o for o in seen.objects}
        goal = by_name[seen.goal].detected
        out = np.zeros((MAX_OBJECTS, SLOT_FEATURES), dtype=np.float32)
        for slot, name in enumerate(_slot_order(seen)):
            x, y, theta = by_name[name].detected
            if slot:
                x, y = x - goal[0], y - goal[1]
            index = self._names.index(name)
            sizes = obs["object_sizes"][index]
            out[slot] = (1.0, x, y, math.cos(2 * theta), math.sin(2 * theta), *sizes)
        (x0, x1), (y0, y1) = seen.goal_region
        tail = np.array(
            [*seen.sigma, (x0 + x1) / 2 - goal[0], (y0 + y1) / 2 - goal[1]], dtype=np.float32
        )
        return np.clip(np.concatenate([out.ravel(), tail]), -10.0, 10.0).astype(np.float32)

    @staticmethod
    def _info(info: dict[str, Any], infeasible: str) -> dict[str, Any]:
        out = dict(info)
        out["true_object_poses"] = np.array(info["true_object_poses"])
        out["infeasible"] = infeasible
        return out


def _slot_order(seen: ObservedScene) -> list[str]:
    """The goal first, then the other objects by distance from the goal's detection."""
    goal = next(o for o in seen.objects if o.name == seen.goal)
    others = sorted(
        (o for o in seen.objects if o.name != seen.goal),
        key=lambda o: math.dist(o.detected[:2], goal.detected[:2]),
    )
    return [goal.name, *(o.name for o in others)]


def _primitive(belief: ObjectBelief, a: np.ndarray, arm: Arm) -> Primitive:
    """The action's integers as a `Primitive` on the detected object."""
    kind = PRIMITIVE_KINDS[int(a[0])]
    xy = np.array(belief.detected[:2])
    heading = base_heading(arm.kinematics.shoulder, xy) + math.radians(DIRECTIONS_DEG[int(a[2])])
    if kind == "sweep":
        return Primitive(
            kind,
            belief.name,
            heading,
            SWEEP_FRACTIONS[int(a[3])],
            SWEEP_DISTANCES[int(a[4])],
            handedness=1 if int(a[5]) == 0 else -1,
        )
    aperture = (default_aperture(belief.spec.footprint), STRAIGHT_APERTURE)[int(a[5])]
    return Primitive(
        kind, belief.name, heading, OFFSETS[int(a[3])], PUSH_DISTANCES[int(a[4])], aperture
    )
