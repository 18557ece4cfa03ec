"""Planar frames for the pushing actions: world poses to and from a hand's 2D frame.

Capture regions live in the hand's frame (`planners.hand2d`): x along the push, y to the left.
A left-hand sweep uses the mirror image of the right-hand sweep's region, so a frame may be
left-handed; orientations then change sign.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from clutter_gym.perception import wrap_angle


@dataclass(frozen=True)
class Frame2D:
    """A planar frame at ``origin`` whose x axis points at ``angle`` (world yaw); its y axis is
    at ``angle + 90 deg`` when ``handedness`` is +1 and at ``angle - 90 deg`` when -1."""

    origin: tuple[float, float]
    angle: float
    handedness: int = 1

    @property
    def x_axis(self) -> np.ndarray:
        return np.array([math.cos(self.angle), math.sin(self.angle)])

    @property
    def y_axis(self) -> np.ndarray:
        a = self.angle + self.handedness * math.pi / 2
        return np.array([math.cos(a), math.sin(a)])

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
