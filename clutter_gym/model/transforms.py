"""All rotation maths of the project, planar and 3D, in one place.

Conventions: the world frame is HERB's ``herb_base`` (x forward, y left, z up, metres); planar
poses are ``(x, y, theta)`` with theta the yaw about world z; quaternions are pybullet's
``(x, y, z, w)``; URDF origins are ``xyz`` plus fixed-axis roll, pitch, yaw (R = Rz Ry Rx).

Planar frames (`Frame2D`) carry the pushing actions: capture regions live in the hand's frame
(`planners.hand2d`: x along the push, y to the left), and a left-hand sweep uses the mirror
image of the right-hand sweep's region, so a frame may be left-handed (orientations then change
sign).

The rotation log is compiled with the arm's kinematics kernels, which call it
(`clutter_gym.model.arm_kernels`: numba's cache sees one file), and re-exported here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from clutter_gym.model.arm_kernels import rotation_log as rotation_log  # re-exported

Vec3 = tuple[float, float, float]


# --------------------------------------------------------------------------------------------
# Planar
# --------------------------------------------------------------------------------------------
def wrap_angle(theta: np.ndarray) -> np.ndarray:
    """Angles mapped to [-pi, pi)."""
    return (np.asarray(theta) + np.pi) % (2.0 * np.pi) - np.pi


def rotation_2d(theta: np.ndarray | float) -> np.ndarray:
    """Planar rotation matrices (..., 2, 2) of angles (...)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def rotation_z(theta: float) -> np.ndarray:
    """The 3x3 rotation by ``theta`` about z (a yaw)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_of_quaternion(quat: np.ndarray) -> float:
    """The yaw of an (x, y, z, w) quaternion (the planar orientation of an upright body)."""
    x, y, z, w = quat
    return float(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def tilt_of_quaternion(quat: np.ndarray) -> float:
    """Angle (rad) between a body's z axis and the world's vertical."""
    x, y, _, _ = quat
    cos_tilt = 1.0 - 2.0 * (x * x + y * y)
    return float(np.arccos(np.clip(cos_tilt, -1.0, 1.0)))


# --------------------------------------------------------------------------------------------
# 3D
# --------------------------------------------------------------------------------------------
def rotation_rpy(rpy: Vec3) -> np.ndarray:
    """3x3 rotation of a URDF origin's fixed-axis roll, pitch, yaw: Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = np.cos(rpy[0]), np.sin(rpy[0])
    cp, sp = np.cos(rpy[1]), np.sin(rpy[1])
    cy, sy = np.cos(rpy[2]), np.sin(rpy[2])
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rpy_of(r: np.ndarray) -> Vec3:
    """Inverse of `rotation_rpy` (pitch kept in [-pi/2, pi/2])."""
    pitch = float(np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)))
    if abs(r[2, 0]) < 1.0 - 1e-12:
        return float(np.arctan2(r[2, 1], r[2, 2])), pitch, float(np.arctan2(r[1, 0], r[0, 0]))
    return 0.0, pitch, float(np.arctan2(-r[0, 1], r[1, 1]))  # gimbal lock: fold roll into yaw


def transform(xyz: Vec3, rpy: Vec3) -> np.ndarray:
    """4x4 homogeneous transform of a URDF origin."""
    t = np.eye(4)
    t[:3, :3] = rotation_rpy(rpy)
    t[:3, 3] = xyz
    return t


def rotation_about(axis: Vec3, angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` about ``axis`` (any length)."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * skew + (1.0 - np.cos(angle)) * skew @ skew


def rotation_exp(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues)."""
    theta = float(np.linalg.norm(w))
    if theta < 1e-12:
        return np.eye(3)
    k = w / theta
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * kx + (1.0 - np.cos(theta)) * (kx @ kx)


# --------------------------------------------------------------------------------------------
# Planar frames of the pushing actions
# --------------------------------------------------------------------------------------------
def to_frames(origins: np.ndarray, angles: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """World poses (N, 3) in K right-handed `Frame2D` frames at once (``origins`` (K, 2),
    ``angles`` (K,)), as each frame's `Frame2D.to_frame` gives them: (K, N, 3)."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    angles = np.asarray(angles, dtype=float)
    x_axis = np.stack([np.cos(angles), np.sin(angles)], -1)[:, None]  # (K, 1, 2)
    y_axis = np.stack([np.cos(angles + math.pi / 2), np.sin(angles + math.pi / 2)], -1)[:, None]
    d = p[None, :, :2] - np.asarray(origins, dtype=float)[:, None]  # (K, N, 2)
    theta = wrap_angle(p[None, :, 2] - angles[:, None])
    return np.stack([(d * x_axis).sum(-1), (d * y_axis).sum(-1), theta], axis=-1)


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class Frame2D:
    """A planar frame at ``origin`` whose x axis points at ``angle`` (world yaw); its y axis is
    at ``angle + 90 deg`` when ``handedness`` is +1 and at ``angle - 90 deg`` when -1."""

    origin: tuple[float, float]
    angle: float
    handedness: int = 1

    @cached_property
    def x_axis(self) -> np.ndarray:
        """The unit x axis (read-only: computed once per frame, which the sweep asks often)."""
        return _read_only(np.array([math.cos(self.angle), math.sin(self.angle)]))

    @cached_property
    def y_axis(self) -> np.ndarray:
        """The unit y axis (read-only, as `x_axis`)."""
        a = self.angle + self.handedness * math.pi / 2
        return _read_only(np.array([math.cos(a), math.sin(a)]))

    def to_frame(self, poses: np.ndarray) -> np.ndarray:
        """World poses (N, 3) in this frame."""
        p = np.asarray(poses, dtype=float).reshape(-1, 3)
        d = p[:, :2] - np.asarray(self.origin)
        theta = self.handedness * (p[:, 2] - self.angle)
        return np.column_stack([d @ self.x_axis, d @ self.y_axis, wrap_angle(theta)])

    def to_world(self, poses: np.ndarray) -> np.ndarray:
        """Frame poses (..., 3) in the world."""
        p = np.asarray(poses, dtype=float)
        xy = np.asarray(self.origin) + p[..., :1] * self.x_axis + p[..., 1:2] * self.y_axis
        theta = wrap_angle(self.angle + self.handedness * p[..., 2])
        return np.concatenate([xy, theta[..., None]], axis=-1)

    def moving_to_world(self, poses: np.ndarray, advances: np.ndarray) -> np.ndarray:
        """Poses (S, P, N, 3) in this frame after it moved ``advances`` (S,) along its own x
        (a hand pushing), in the world, flattened to (S, P*N, 3)."""
        shifted = np.array(poses, dtype=float)
        shifted[..., 0] += advances[:, None, None]
        return self.to_world(shifted).reshape(len(advances), -1, 3)
