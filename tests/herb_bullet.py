"""HERB loaded in a bare pybullet client with name -> index maps: the reference the URDF,
kinematics and collision tests compare against."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet
from pybullet_utils.bullet_client import BulletClient

from clutter_gym.model import herb as hm


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
