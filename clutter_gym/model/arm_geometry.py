"""Collision geometry of one HERB arm and hand, as data for a collision checker.

The primitives are read from ``herb.arm_links`` / ``hand_links``, the same data the URDF is
generated from, so the checker and pybullet see the same shapes. Arm links ride on the frames
of ``ArmKinematics.link_frames``; finger links ride on hand_base through the hand joints of
``herb.finger_joints`` at a hand command (spread, closure), as `herb.hand_targets` sets them.
Link names carry no side prefix: both arms have the same geometry.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.arm_kernels import placements
from clutter_gym.model.herb import HandCommand, hand_targets
from clutter_gym.model.shapes import Shape
from clutter_gym.model.transforms import rotation_exp, transform

#: Links whose frames `ArmKinematics.link_frames` returns, in its order.
FRAME_LINKS: tuple[str, ...] = ("wam_base", *(f"wam{i}" for i in range(1, 8)), "hand_base")


class LinkShape(NamedTuple):
    """A shape of the arm or hand, with the (side-less) name of the link it belongs to."""

    link: str
    shape: Shape


class ArmGeometry:
    """The primitives of wam_base, wam1..wam7 and the BH-280 hand, and their world poses."""

    def __init__(self) -> None:
        links = {**hm.arm_links(), **hm.hand_links()}
        self.primitives: tuple[LinkShape, ...] = tuple(
            LinkShape(name, s) for name, spec in links.items() for s in spec.shapes
        )
        self.links: tuple[str, ...] = tuple(links)
        self._joints = hm.finger_joints()
        # Index into link_frames of the frame each primitive rides on (hand_base for fingers).
        hand = FRAME_LINKS.index("hand_base")
        self.anchors = np.array(
            [FRAME_LINKS.index(p.link) if p.link in FRAME_LINKS else hand for p in self.primitives]
        )
        self._offsets: dict[HandCommand, np.ndarray] = {}

    def finger_frames(self, hand: HandCommand) -> dict[str, np.ndarray]:
        """Poses of hand_base (identity) and the knuckle and finger links in hand_base."""
        angles = dict(zip(self._joints, hand_targets(hand), strict=True))
        frames = {"hand_base": np.eye(4)}
        # finger_joints lists every parent before its children.
        for name, j in self._joints.items():
            turn = np.eye(4)
            turn[:3, :3] = rotation_exp(np.asarray(j.axis) * angles[name])
            frames[j.child] = frames[j.parent] @ transform(j.xyz, j.rpy) @ turn
        return frames

    def offsets(self, hand: HandCommand) -> np.ndarray:
        """(P, 4, 4) pose of each primitive in its anchor frame; cached per hand command since
        planners use a handful of hand shapes."""
        key = HandCommand(float(hand.spread), float(hand.closure))
        cached = self._offsets.get(key)
        if cached is None:
            fingers = self.finger_frames(key)
            cached = np.stack(
                [
                    p.shape.local if p.link in FRAME_LINKS else fingers[p.link] @ p.shape.local
                    for p in self.primitives
                ]
            )
            self._offsets[key] = cached
        return cached

    def primitive_placements(
        self, link_frames: np.ndarray, hand: HandCommand
    ) -> tuple[np.ndarray, np.ndarray]:
        """World poses (P, 4, 4) of the primitives from `ArmKinematics.link_frames` (9, 4, 4),
        and their rotations as (w, x, y, z) quaternions (P, 4), which is how the collision
        checker places its fcl objects (`arm_kernels.placements`)."""
        return placements(link_frames, self.anchors, self.offsets(hand))

    def link_poses(self, link_frames: np.ndarray, hand: HandCommand) -> dict[str, np.ndarray]:
        """World pose of every link frame (finger links included) at a hand command."""
        poses = {name: link_frames[i] for i, name in enumerate(FRAME_LINKS)}
        hand_base = poses["hand_base"]
        for name, frame in self.finger_frames(hand).items():
            poses[name] = hand_base @ frame
        return poses
