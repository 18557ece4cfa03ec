"""A direct side grasp: the simplest plan that retrieves an object (the scripted baseline).

The hand comes in horizontally along the line from the right shoulder to the detected object,
fingers preshaped open in a horizontal plane, closes and lifts. It trusts the single detected
pose (no uncertainty reasoning) and checks the arm only against the support surface height: it is
the baseline the push-grasp planner improves on, not a substitute for it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.reachability import PUSH_HEIGHT, tcp_pose
from clutter_gym.model.trajectory import Segment, Trajectory
from planners.actions.grasp_geometry import GRASP_CLOSURE, LIFT

PREGRASP_DISTANCE = 0.12  # m behind the object centre along the approach
HOVER_HEIGHT = 0.20  # m above the pregrasp for the transit from home
PRESHAPE_CLOSURE = 0.45  # fingers angled forward and open wider than a juice bottle
SURFACE_CLEARANCE = 0.05  # m: the hand_base frame stays this far above the surface
HEADING_OFFSETS = np.deg2rad([0, 10, -10, 20, -20, 30, -30, 40, -40, 50, -50, 60, -60])


class PlanningError(RuntimeError):
    """No plan: the message names the stage that failed."""


@dataclass(frozen=True)
class GraspRequest:
    pose: tuple[float, float, float]  # detected (x, y, theta) of the object
    height: float  # object height [m]
    surface_z: float


def plan_direct_grasp(
    kinematics: ArmKinematics,
    request: GraspRequest,
    waypoints: int,
    accept: Callable[[np.ndarray], bool] | None = None,
) -> Trajectory:
    """Hover, pregrasp, straight approach, close, lift: a trajectory that fits one env action
    of ``waypoints`` rows.

    Tries approach headings around the line from the shoulder to the object, nearest first:
    the arm's joint limits rule out some headings at some places on the table.
    """
    x, y, _ = request.pose
    centre = np.array([x, y, request.surface_z + PUSH_HEIGHT])
    to_object = centre[:2] - kinematics.shoulder[:2]
    base_heading = float(np.arctan2(to_object[1], to_object[0]))
    failures: list[str] = []
    for offset in HEADING_OFFSETS:
        heading = base_heading + offset
        direction = np.array([np.cos(heading), np.sin(heading), 0.0])
        try:
            grasp = _grasp_along(kinematics, centre, direction, request.surface_z, accept)
        except PlanningError as error:
            failures.append(str(error))
            continue
        rows = len(grasp.rows())
        if rows > waypoints:
            raise PlanningError(f"the grasp needs {rows} waypoints; the env allows {waypoints}")
        return grasp
    most_common = max(set(failures), key=failures.count)
    raise PlanningError(f"no approach heading works; most common reason: {most_common}")


def _grasp_along(
    kinematics: ArmKinematics,
    centre: np.ndarray,
    direction: np.ndarray,
    surface_z: float,
    accept: Callable[[np.ndarray], bool] | None,
) -> Trajectory:
    def pose(position: np.ndarray) -> np.ndarray:
        return tcp_pose(position, direction)

    def clear(q: np.ndarray) -> bool:
        hand_z = kinematics.fk(q)[2, 3]
        return bool(hand_z > surface_z + SURFACE_CLEARANCE) and (accept is None or accept(q))

    # Plan backwards from the grasp so every segment stays on one IK branch (the 7-DoF arm has
    # many; independent IK calls for hover and grasp can land on disconnected ones).
    q_grasp = kinematics.solve_ik(pose(centre), accept=clear)
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

    preshape, closed = HandCommand(0.0, PRESHAPE_CLOSURE), HandCommand(0.0, GRASP_CLOSURE)
    return Trajectory(
        (
            Segment("approach", np.vstack([descend, approach[1:]]), preshape),
            Segment("close", approach[-1:], closed),
            Segment("lift", lift[1:], closed),
        )
    )
