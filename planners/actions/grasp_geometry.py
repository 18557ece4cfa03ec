"""Where HERB's hand goes to grasp or push an upright object from the side, shared by every
action, the direct-grasp baseline and the capture-region validation.

The hand is horizontal: its approach axis (hand z) is level along a heading, its finger plane
horizontal with F3 on the robot's left, as in HERB's home pose; the TCP sits `HAND_TCP_OFFSET`
in front of ``hand_base`` on the approach axis.
"""

from __future__ import annotations

import math

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.objects import Footprint

LIFT = 0.15
"""m a retrieved object is lifted, more than the task's 0.10 m."""
GRASP_CLOSURE = 1.0
"""Hand closure that grasps: the fingers close until they meet the object."""
OPEN_FLAT = 0.0
"""Closure 0: fingers flat in the palm plane, nothing in front to drag a released object."""
HAND_BELOW_TCP = hm.HAND_PALM_RADIUS
"""m: a horizontal hand's lowest point under its TCP."""
RISE = 0.10
"""m the hand rises after releasing an obstacle."""
RISE_CLEARANCE = 0.03
"""m between the risen hand and the top of the object it released."""
START_CLEARANCE = 0.01
"""m between the hand's front and the nearest sample's outline where a push or sweep starts."""


def grasp_height(height: float) -> float:
    """TCP height above the surface for an object of ``height``: mid-object, but high enough
    that the wrist housing (4.5 cm radius, level with the TCP in a horizontal approach) clears
    the surface."""
    return min(max(0.5 * height, 0.075), 0.09)


def approach_rotation(direction: np.ndarray) -> np.ndarray:
    """Hand orientation with the approach axis (hand z) horizontal along `direction` and the
    finger plane horizontal, F3 on the robot's left of the object, as in HERB's home pose."""
    z = np.array([direction[0], direction[1], 0.0]) / np.hypot(direction[0], direction[1])
    y = np.array([z[1], -z[0], 0.0])  # -(world z x approach): the home pose's roll
    return np.column_stack([np.cross(y, z), y, z])


def tcp_pose(tcp: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """TCP pose (4x4) of a horizontal hand with its TCP at ``tcp`` (3,), approaching along
    ``direction`` (3,)."""
    pose = np.eye(4)
    pose[:3, :3] = approach_rotation(direction)
    pose[:3, 3] = tcp
    return pose


def hand_pose(hand_base_xy: np.ndarray, heading: float, z: float) -> np.ndarray:
    """TCP pose (4x4) of a horizontal hand whose hand_base is at (x, y, z), approaching along
    ``heading`` (world yaw)."""
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    return tcp_pose(np.r_[hand_base_xy, z] + hm.HAND_TCP_OFFSET * direction, direction)


def rise_height(surface_z: float, height: float, z: float) -> float:
    """TCP height after releasing an object of ``height``: RISE up, and high enough that the hand
    clears the object's top, so the transit that follows starts above everything it leaves."""
    return max(z + RISE, surface_z + height + HAND_BELOW_TCP + RISE_CLEARANCE)


def near_edge(footprint: Footprint, poses: np.ndarray) -> float:
    """Smallest x reached by the object's outline over poses (N, 3) in a frame: where a hand
    moving along +x would first meet it."""
    if footprint.shape == "circle":
        return float((poses[:, 0] - footprint.radius).min())
    hx, hy = footprint.half_extents
    reach = np.abs(hx * np.cos(poses[:, 2])) + np.abs(hy * np.sin(poses[:, 2]))
    return float((poses[:, 0] - reach).min())


def translated(poses: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Planar poses (N, 3) moved by ``shift`` (2,)."""
    moved = np.array(poses, dtype=float)
    moved[:, :2] += shift
    return moved
