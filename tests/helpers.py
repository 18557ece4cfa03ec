"""Helpers shared by the tests: scene dicts and HERB in a bare pybullet client."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from clutter_gym.model import herb as hm

NEAR = (0.70, -0.25, 0.0)
"""In easy reach of the right arm (18 of 24 headings reach it, docs/reachability_table.png)."""
OUT_OF_REACH = (1.15, 0.68, 0.0)
"""The table's far left corner: no heading reaches it."""


def two_objects() -> dict[str, Any]:
    """A valid table scene: the goal can and a large box beside it."""
    return {
        "format": "clutter-gym-scene/1",
        "surface": "table",
        "objects": [
            {"name": "can", "kind": "soda_can", "pose": [0.72, -0.2, 0.0]},
            {"name": "box", "kind": "large_box", "pose": [0.76, -0.45, 0.0]},
        ],
        "goal": {"object": "can"},
        "noise": "sigma2",
    }


def lone_can(noise: str, pose: tuple[float, float, float] = NEAR) -> dict[str, Any]:
    """A scene with the goal can ``red_can`` alone at ``pose``, detected with ``noise``."""
    return {
        "format": "clutter-gym-scene/1",
        "surface": "table",
        "objects": [{"name": "red_can", "kind": "soda_can", "pose": list(pose)}],
        "goal": {"object": "red_can"},
        "noise": noise,
    }


def transform(position: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    """4x4 pose from a pybullet position and (x, y, z, w) quaternion."""
    t = np.eye(4)
    t[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(quaternion), (3, 3))
    t[:3, 3] = position
    return t


@dataclass
class HerbBullet:
    client: BulletClient
    robot: int
    joints: dict[str, int]
    links: dict[str, int]

    def set_joints(self, names: Sequence[str], values: Sequence[float]) -> None:
        for name, value in zip(names, values, strict=True):
            self.client.resetJointState(self.robot, self.joints[name], float(value))

    def set_arm(self, side: str, q: np.ndarray) -> None:
        self.set_joints(hm.arm_joint_names(side), q)

    def link_pose(self, name: str) -> np.ndarray:
        state = self.client.getLinkState(
            self.robot, self.links[name], computeForwardKinematics=True
        )
        return transform(state[4], state[5])


def load_herb(urdf: Path, flags: int = 0) -> HerbBullet:
    client = BulletClient(connection_mode=pybullet.DIRECT)
    robot = client.loadURDF(str(urdf), useFixedBase=True, flags=flags)
    joints, links = {}, {"herb_base": -1}
    for j in range(client.getNumJoints(robot)):
        info = client.getJointInfo(robot, j)
        joints[info[1].decode()] = j
        links[info[12].decode()] = j
    return HerbBullet(client, robot, joints, links)
