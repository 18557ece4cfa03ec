"""Where HERB's hand goes to grasp or push an upright object from the side, shared by every
action, the direct-grasp baseline and the capture-region validation.

The hand is horizontal (`clutter_gym.model.reachability.hand_pose`: approach axis level along a
heading, finger plane horizontal, the TCP `HAND_TCP_OFFSET` in front of ``hand_base``); this
module says at which height, how far it lifts and rises, and where a push starts.
"""

from __future__ import annotations

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.objects import Footprint
from planners.hand2d import outline_reach

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


def rise_height(surface_z: float, height: float, z: float) -> float:
    """TCP height after releasing an object of ``height``: RISE up, and high enough that the hand
    clears the object's top, so the transit that follows starts above everything it leaves."""
    return max(z + RISE, surface_z + height + HAND_BELOW_TCP + RISE_CLEARANCE)


def near_edge(footprint: Footprint, poses: np.ndarray) -> float:
    """Smallest x reached by the object's outline over poses (N, 3) in a frame: where a hand
    moving along +x would first meet it."""
    return float((poses[:, 0] - outline_reach(footprint, poses[:, 2])).min())


def translated(poses: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """Planar poses (N, 3) moved by ``shift`` (2,)."""
    moved = np.array(poses, dtype=float)
    moved[:, :2] += shift
    return moved
