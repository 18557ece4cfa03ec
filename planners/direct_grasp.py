"""A direct side grasp: the simplest plan that retrieves an object, used by `clutter-gym demo`.

The hand comes in horizontally along the line from the right shoulder to the detected object,
fingers preshaped open in a horizontal plane, closes and lifts. It trusts the single detected
pose (no uncertainty reasoning) and checks the arm only against the support surface height: it is
the baseline the push-grasp planner improves on, not a substitute for it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from clutter_gym.robot import herb_model as hm
from clutter_gym.robot.kinematics import ArmKinematics

PREGRASP_DISTANCE = 0.12  # m behind the object centre along the approach
HOVER_HEIGHT = 0.20  # m above the pregrasp for the transit from home
LIFT = 0.15  # m, more than the task's 0.10 m
PRESHAPE_CLOSURE = 0.45  # fingers angled forward and open wider than a juice bottle
GRASP_CLOSURE = 1.0
SURFACE_CLEARANCE = 0.05  # m: the hand_base frame stays this far above the surface
HEADING_OFFSETS = np.deg2rad([0, 10, -10, 20, -20, 30, -30, 40, -40, 50, -50, 60, -60])


class PlanningError(RuntimeError):
    """No plan: the message names the stage that failed."""


@dataclass(frozen=True)
class GraspRequest:
    pose: tuple[float, float, float]  # detected (x, y, theta) of the object
    height: float  # object height [m]
    surface_z: float


def grasp_height(height: float) -> float:
    """TCP height above the surface: mid-object, but high enough that the wrist housing
    (4.5 cm radius, level with the TCP in a horizontal approach) clears the surface."""
    return min(max(0.5 * height, 0.075), 0.09)


def approach_rotation(direction: np.ndarray) -> np.ndarray:
    """Hand orientation with the approach axis (hand z) horizontal along `direction` and the
    finger plane horizontal, F3 on the robot's left of the object, as in HERB's home pose."""
    z = np.array([direction[0], direction[1], 0.0]) / np.hypot(direction[0], direction[1])
    y = np.array([z[1], -z[0], 0.0])  # -(world z x approach): the home pose's roll
    return np.column_stack([np.cross(y, z), y, z])


def plan_direct_grasp(
    kinematics: ArmKinematics,
    request: GraspRequest,
    waypoints: int,
    rng: np.random.Generator,
    accept: Callable[[np.ndarray], bool] | None = None,
) -> np.ndarray:
    """A (waypoints, 9) trajectory action: hover, pregrasp, straight approach, close, lift.

    Tries approach headings around the line from the shoulder to the object, nearest first:
    the arm's joint limits rule out some headings at some places on the table.
    """
    x, y, _ = request.pose
    centre = np.array([x, y, request.surface_z + grasp_height(request.height)])
    to_object = centre[:2] - kinematics.shoulder[:2]
    base_heading = float(np.arctan2(to_object[1], to_object[0]))
    failures: list[str] = []
    for offset in HEADING_OFFSETS:
        heading = base_heading + offset
        direction = np.array([np.cos(heading), np.sin(heading), 0.0])
        try:
            rows = _grasp_along(kinematics, centre, direction, request.surface_z, rng, accept)
        except PlanningError as error:
            failures.append(str(error))
            continue
        if len(rows) > waypoints:
            raise PlanningError(
                f"the grasp needs {len(rows)} waypoints; the env allows {waypoints}"
            )
        rows.extend([rows[-1]] * (waypoints - len(rows)))
        return np.asarray(rows, dtype=np.float32)
    most_common = max(set(failures), key=failures.count)
    raise PlanningError(f"no approach heading works; most common reason: {most_common}")


def _grasp_along(
    kinematics: ArmKinematics,
    centre: np.ndarray,
    direction: np.ndarray,
    surface_z: float,
    rng: np.random.Generator,
    accept: Callable[[np.ndarray], bool] | None,
) -> list[np.ndarray]:
    rotation = approach_rotation(direction)

    def pose(position: np.ndarray) -> np.ndarray:
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = rotation, position
        return t

    def clear(q: np.ndarray) -> bool:
        hand_z = kinematics.fk(q)[2, 3]
        return bool(hand_z > surface_z + SURFACE_CLEARANCE) and (accept is None or accept(q))

    # Plan backwards from the grasp so every segment stays on one IK branch (the 7-DoF arm has
    # many; independent IK calls for hover and grasp can land on disconnected ones).
    q_grasp = kinematics.solve_ik(pose(centre), hm.RIGHT_ARM_HOME, rng, accept=clear)
    if q_grasp is None:
        raise PlanningError(f"no IK solution grasping the object at {np.round(centre, 3).tolist()}")
    pregrasp = centre - PREGRASP_DISTANCE * direction
    retreat = kinematics.cartesian_path(q_grasp, pose(pregrasp), 6, accept=clear)
    if retreat is None:
        raise PlanningError(
            f"no straight approach from the pregrasp {np.round(pregrasp, 3).tolist()}"
        )
    rise = kinematics.cartesian_path(
        retreat[-1], pose(pregrasp + [0.0, 0.0, HOVER_HEIGHT]), 4, accept=clear
    )
    if rise is None:
        raise PlanningError("no straight descent from above the pregrasp")
    lift = kinematics.cartesian_path(q_grasp, pose(centre + [0.0, 0.0, LIFT]), 5, accept=clear)
    if lift is None:
        raise PlanningError("no straight lift from the grasp")
    descend, approach = rise[::-1], retreat[::-1]

    rows = [np.r_[q, 0.0, PRESHAPE_CLOSURE] for q in (*descend, *approach[1:])]
    rows.append(np.r_[approach[-1], 0.0, GRASP_CLOSURE])
    rows.extend(np.r_[q, 0.0, GRASP_CLOSURE] for q in lift[1:])
    return rows
