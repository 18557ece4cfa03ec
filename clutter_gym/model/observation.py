"""The observations of the env's variants, encoded by the env and decoded by every policy here,
so their layout is written once.

`ClutterRetrieve-v0` observes a Dict of fixed-shape arrays (M = `MAX_OBJECTS` slots):
- arm_joints (7,), arm_velocities (7,): right arm state [rad, rad/s]
- hand (4,): spread and F1, F2, F3 proximal angles [rad]
- tcp_pose (7,): position [m] and quaternion (x, y, z, w) of the hand's TCP
- object_poses (M, 3): DETECTED planar poses (x, y, theta): truth + Gaussian noise, redrawn
  every step
- object_sizes (M, 3): footprint extents along the object's x and y, and height [m]
- object_kinds (M,): 1 + index into `OBJECT_KINDS` (the library's order); 0 for an empty slot
- object_mask (M,): 1 where a slot holds an object
- goal_object (): slot of the goal object
- goal_region (4,): x_min, x_max, y_min, y_max [m]
- noise (2,): sigma_xy [m], sigma_theta [rad] of the detections
- surface (): index into `SURFACES` (0 table, 1 shelf)

The end-effector variants (`ClutterRetrieveEE-v0`, `ClutterRetrieveEEDense-v0`) are
goal-conditioned (Gymnasium-Robotics' GoalEnv, what stable-baselines3's `HerReplayBuffer`
needs), a Dict of
- observation (9M + 29 = 101,) float32: `flatten` of the Dict above, in this order: arm_joints (7),
  arm_velocities (7), hand (4), tcp_pose (7); per slot the DETECTED (x, y, cos 2 theta,
  sin 2 theta) (4M: every object of the library looks the same after a half turn, so 2 theta
  loses nothing and never jumps; zeros in empty slots), object_sizes (3M), object_mask (M), the
  goal slot one-hot (M), the goal's detected (x, y) minus the TCP's (2), noise (2). Kinds are
  left out (the sizes tell them apart), and so are goal_region and surface (these variants are
  table tasks: lift the goal object);
- achieved_goal (3,) float64: the goal object's detected x, y (this step's detection) and the
  height z of its base (detections are planar; the height is what lifting changes);
- desired_goal (3,) float64: the goal's first detected x, y of the episode and the height its
  base must reach, `LIFT_HEIGHT` (0.10 m) above where it stood.
With the grasp objective (`ClutterRetrieveEEGrasp-v0`, the first stage of learning) the goals
are (4,): achieved_goal the TCP's offset from the goal's grasp point (its detected x, y at grasp
height above its base) and 1.0 while two fingers grip the goal object (0.0 otherwise);
desired_goal (0, 0, 0, 1).
float64 goals, as Gymnasium-Robotics has them: the env's reward is `compute_reward` of exactly
these numbers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces

from clutter_gym.model import herb as hm
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.objects import OBJECTS, Footprint, ObjectSpec, get_object
from clutter_gym.model.scene import MAX_OBJECTS, Scene
from clutter_gym.model.world import SURFACES, Region, Surface

Observation = dict[str, Any]
"""ndarrays, and np.int64 for the Discrete entries."""
OBJECT_KINDS = tuple(OBJECTS)
GOAL_SIZES = {"retrieve": 3, "grasp": 4}
"""Length of the end-effector variants' goals per objective (module docstring)."""
WORLD_REACH = 5.0
"""m: bounds every position in the world, so that the observation space is finite."""
MAX_JOINT_SPEED = 10.0
"""rad/s: the observed arm velocities are clipped to this (a collision can spike them)."""


def observation_space(max_objects: int = MAX_OBJECTS) -> spaces.Dict:
    reach = WORLD_REACH
    m = max_objects
    return spaces.Dict(
        {
            "arm_joints": spaces.Box(-2 * np.pi, 2 * np.pi, (7,), np.float32),
            "arm_velocities": spaces.Box(-MAX_JOINT_SPEED, MAX_JOINT_SPEED, (7,), np.float32),
            "hand": spaces.Box(-0.5, 3.5, (4,), np.float32),
            "tcp_pose": spaces.Box(-reach, reach, (7,), np.float32),
            "object_poses": spaces.Box(-reach, reach, (m, 3), np.float32),
            "object_sizes": spaces.Box(0.0, reach, (m, 3), np.float32),
            "object_kinds": spaces.MultiDiscrete([len(OBJECT_KINDS) + 1] * m),
            "object_mask": spaces.MultiBinary(m),
            "goal_object": spaces.Discrete(m),
            "goal_region": spaces.Box(-reach, reach, (4,), np.float32),
            "noise": spaces.Box(0.0, reach, (2,), np.float32),
            "surface": spaces.Discrete(len(SURFACES)),
        }
    )


def goal_observation_space(max_objects: int = MAX_OBJECTS, goal_size: int = 3) -> spaces.Dict:
    """The end-effector variants' observation space (module docstring)."""
    low, high = _flat_bounds(observation_space(max_objects), max_objects)
    goal = spaces.Box(-WORLD_REACH, WORLD_REACH, (goal_size,), np.float64)
    return spaces.Dict(
        {
            "observation": spaces.Box(low, high, dtype=np.float32),
            "achieved_goal": goal,
            "desired_goal": goal,
        }
    )


def _flat_bounds(space: spaces.Dict, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of `flatten`'s vector, part by part in its order."""

    def box(key: str) -> tuple[np.ndarray, np.ndarray]:
        part = space[key]
        assert isinstance(part, spaces.Box)
        return part.low.ravel(), part.high.ravel()

    reach = WORLD_REACH
    zeros, ones = np.zeros(m), np.ones(m)
    parts = [
        box("arm_joints"),
        box("arm_velocities"),
        box("hand"),
        box("tcp_pose"),
        (np.tile([-reach, -reach, -1.0, -1.0], m), np.tile([reach, reach, 1.0, 1.0], m)),
        box("object_sizes"),
        (zeros, ones),
        (zeros, ones),
        (np.full(2, -2.0 * reach), np.full(2, 2.0 * reach)),
        box("noise"),
    ]
    return (
        np.concatenate([low for low, _ in parts]).astype(np.float32),
        np.concatenate([high for _, high in parts]).astype(np.float32),
    )


# --------------------------------------------------------------------------------------------
# Encoding (the env)
# --------------------------------------------------------------------------------------------
def encode_scene(scene: Scene, sigma: tuple[float, float]) -> Observation:
    """The entries fixed for an episode (computed once per reset; copy them per step)."""
    m = MAX_OBJECTS
    sizes = np.zeros((m, 3), dtype=np.float32)
    kinds = np.zeros(m, dtype=np.int64)
    mask = np.zeros(m, dtype=np.int8)
    names = [o.name for o in scene.objects]
    for i, placement in enumerate(scene.objects):
        spec = placement.spec
        sizes[i] = (*_extents(spec.footprint), spec.height)
        kinds[i] = 1 + OBJECT_KINDS.index(placement.kind)
        mask[i] = 1
    (x_lo, x_hi), (y_lo, y_hi) = scene.goal.region
    return {
        "object_sizes": sizes,
        "object_kinds": kinds,
        "object_mask": mask,
        "goal_object": np.int64(names.index(scene.goal.object)),
        "goal_region": np.array([x_lo, x_hi, y_lo, y_hi], dtype=np.float32),
        "noise": np.array(sigma, dtype=np.float32),
        "surface": np.int64(list(SURFACES).index(scene.surface)),
    }


def encode_state(
    arm: np.ndarray,
    arm_velocities: np.ndarray,
    hand_angles: np.ndarray,
    tcp_position: np.ndarray,
    tcp_quaternion: np.ndarray,
    detected: np.ndarray,
) -> Observation:
    """The entries that change every step: the robot's state and the detected poses (N, 3)."""
    poses = np.zeros((MAX_OBJECTS, 3), dtype=np.float32)
    # Clipped only so that absurd custom noise levels stay inside the observation space.
    poses[: len(detected)] = np.clip(detected, -WORLD_REACH, WORLD_REACH)
    return {
        "arm_joints": arm.astype(np.float32),
        "arm_velocities": np.clip(arm_velocities, -MAX_JOINT_SPEED, MAX_JOINT_SPEED).astype(
            np.float32
        ),
        "hand": hand_angles.astype(np.float32),
        "tcp_pose": np.concatenate([tcp_position, tcp_quaternion]).astype(np.float32),
        "object_poses": poses,
    }


def flatten(obs: Observation) -> np.ndarray:
    """The end-effector variants' `observation` vector (module docstring) of a Dict observation."""
    poses, mask = obs["object_poses"], obs["object_mask"]
    goal = int(obs["goal_object"])
    one_hot = np.zeros(len(mask), dtype=np.float32)
    one_hot[goal] = 1.0
    double = 2.0 * poses[:, 2]
    orientation = np.column_stack([np.cos(double), np.sin(double)]) * mask[:, None]
    return np.concatenate(
        [
            obs["arm_joints"],
            obs["arm_velocities"],
            obs["hand"],
            obs["tcp_pose"],
            np.column_stack([poses[:, :2], orientation]).ravel(),
            obs["object_sizes"].ravel(),
            mask,
            one_hot,
            poses[goal, :2] - obs["tcp_pose"][:2],
            obs["noise"],
        ]
    ).astype(np.float32)


def encode_goal_observation(
    obs: Observation, achieved: np.ndarray, desired: np.ndarray
) -> Observation:
    """The end-effector variants' observation: `flatten` of the Dict observation and the goals."""
    return {
        "observation": flatten(obs),
        "achieved_goal": np.array(achieved, dtype=np.float64),
        "desired_goal": np.array(desired, dtype=np.float64),
    }


def _extents(footprint: Footprint) -> tuple[float, float]:
    """Footprint size along the object's own x and y axes."""
    if footprint.shape == "circle":
        return 2.0 * footprint.radius, 2.0 * footprint.radius
    return 2.0 * footprint.half_extents[0], 2.0 * footprint.half_extents[1]


# --------------------------------------------------------------------------------------------
# Decoding (the policies)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ObservedObject:
    """One occupied slot: a name (the env's, or made up from the kind and slot), the kind's
    spec and the detected pose."""

    name: str
    spec: ObjectSpec
    detected: tuple[float, float, float]


@dataclass(frozen=True)
class ObservedScene:
    """What an observation says about the task, decoded for a planner."""

    objects: tuple[ObservedObject, ...]
    goal: str
    surface: Surface
    goal_region: Region
    sigma: tuple[float, float]
    arm: np.ndarray
    hand: HandCommand


def decode(obs: Observation, names: tuple[str, ...] | None = None) -> ObservedScene:
    """The task as an observation shows it; object names from ``names`` (the env's
    ``info["object_names"]``) or made up as ``<kind>_<slot>``."""
    objects = []
    for slot in np.flatnonzero(obs["object_mask"]):
        kind = OBJECT_KINDS[int(obs["object_kinds"][slot]) - 1]
        name = names[slot] if names is not None else f"{kind}_{slot}"
        x, y, theta = (float(v) for v in obs["object_poses"][slot])
        objects.append(ObservedObject(name, get_object(kind), (x, y, theta)))
    x0, x1, y0, y1 = (float(v) for v in obs["goal_region"])
    return ObservedScene(
        objects=tuple(objects),
        goal=objects[int(obs["goal_object"])].name,
        surface=list(SURFACES.values())[int(obs["surface"])],
        goal_region=((x0, x1), (y0, y1)),
        sigma=(float(obs["noise"][0]), float(obs["noise"][1])),
        arm=np.asarray(obs["arm_joints"], dtype=float),
        hand=hand_command(obs),
    )


def hand_command(obs: Observation) -> HandCommand:
    """The hand command that holds the observed hand as it is."""
    spread = float(np.clip(obs["hand"][0] / hm.HAND_SPREAD_RANGE[1], 0.0, 1.0))
    closure = float(np.clip(obs["hand"][1] / hm.HAND_PROXIMAL_RANGE[1], 0.0, 1.0))
    return HandCommand(spread, closure)
