"""Task space regions for grasping under pose uncertainty (Berenson, Srinivasa & Kuffner 2009).

A TSR is a frame ``T0_w`` (here the detected object pose), an offset ``Tw_e`` and bounds ``B_w`` on
the end effector's six coordinates in that frame. HERB grasps an upright object from the side with
the finger plane horizontal at grasp height, so z, roll and pitch are fixed and three coordinates
are free: the approach heading around the object, the object's lateral offset between the fingers
and its depth in the hand.

The *uncertainty* TSR planner (Table 1's baseline) keeps a sampled hand pose only if it grasps
every hypothesis of the object pose as it stands: the hand moves in and closes, it does not push.
That is the push-grasp capture region at zero push (every sample inside with d = 0, §2.2.3), so the
baseline and the push-grasp planner are judged by the same hand model and mechanics; the one
difference is the push.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from clutter_gym.model.transforms import Frame2D, to_frames
from planners.capture import CaptureRegion
from planners.hand2d import GRASP_DEPTH, turned_to_axis


@dataclass(frozen=True)
class GraspTSR:
    """Bounds on a horizontal side grasp of an object at ``centre``: the approach heading (world
    yaw), the object centre's lateral offset (hand y) and its depth (hand x, from hand_base)."""

    centre: tuple[float, float]
    heading: tuple[float, float]
    lateral: tuple[float, float]
    depth: tuple[float, float]

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` hand poses drawn uniformly from the bounds: rows (heading, lateral, depth)."""
        low = [self.heading[0], self.lateral[0], self.depth[0]]
        high = [self.heading[1], self.lateral[1], self.depth[1]]
        return rng.uniform(low, high, size=(count, 3))

    def in_hands(self, draws: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """World poses (N, 3) in the frames of the hands ``draws`` (K, 3) (`hand_frame` of
        every row at once): (K, N, 3)."""
        heading, lateral, depth = np.asarray(draws, dtype=float).reshape(-1, 3).T
        v = np.stack([np.cos(heading), np.sin(heading)], -1)
        n = np.stack([-v[:, 1], v[:, 0]], -1)
        origins = np.asarray(self.centre) - depth[:, None] * v - lateral[:, None] * n
        return to_frames(origins, heading, poses)

    def hand_frame(self, heading: float, lateral: float, depth: float) -> Frame2D:
        """The hand's frame (origin hand_base, x along the approach) that holds the object centre
        at (depth, lateral)."""
        v = np.array([math.cos(heading), math.sin(heading)])
        n = np.array([-v[1], v[0]])
        origin = np.asarray(self.centre) - depth * v - lateral * n
        return Frame2D((float(origin[0]), float(origin[1])), heading)


def grasped_still(region: CaptureRegion, in_hand: np.ndarray) -> np.ndarray:
    """Which object poses (N, 3) in the hand frame the fingers grasp by closing where the hand
    stands, with no push: in the region, needing no push, and `GRASP_DEPTH` behind the
    fingertip line at every preshape. Where closing itself needs that depth
    (`planners.hand2d.grasp_depth`) the region asks for it too; at the straight and V preshapes
    a cylinder's is the static grasp's margin against a true pose beyond the samples, which a
    push-grasp gets from pushing `planners.capture.PUSH_MARGIN` further (without it,
    pick-and-place closed 8 mm behind the line at 0.192 m in Table 1 high_06 sigma2, and a
    true bottle beyond the samples left the table in 2 of 10 trials).

    A box is also grasped where the closing fingers turn it to the approach axis and hold it
    (`planners.hand2d.turned_to_axis`), which the region, counting a box captured only
    once pushed to the palm, leaves to a push. Measured in pybullet: the 427 closes that band
    was measured from all held; static closes of the poptart box on a grid 5 mm apart from 15
    mm beyond the fingertip line to the palm, 0-2 cm either side of the axis, turned 0-50 deg,
    at 0.111, 0.151 and 0.192 m and the scene turned 0 and 45 deg, held in all 1072 that the
    open hand did not overlap, the 788 of them in the band included (turned 60 deg, 109 of 116
    held; across the hand, 6 of 60 within 5 mm of the line). Without it a static grasp of a
    box had a window of under 2 cm between the palm and the depth margin, which 30 samples at
    sigma2 overrun."""
    in_hand = np.asarray(in_hand, dtype=float).reshape(-1, 3)
    inside, push = region.query(in_hand)
    deep = in_hand[:, 0] <= region.grasp_line - GRASP_DEPTH
    still = inside & (push <= 0.0) & deep
    if region.footprint.shape == "box":
        still |= inside & turned_to_axis(region.footprint, in_hand)
    return np.asarray(still)


def grasps_every_sample(
    region: CaptureRegion, tsr: GraspTSR, draws: np.ndarray, samples: np.ndarray
) -> np.ndarray:
    """For hand poses ``draws`` (K, 3) from `GraspTSR.sample`: does closing the hand there grasp
    every object pose in ``samples`` (N, 3) without pushing? Returns a (K,) mask."""
    samples = np.asarray(samples, dtype=float).reshape(-1, 3)
    draws = np.asarray(draws, dtype=float).reshape(-1, 3)
    in_hand = tsr.in_hands(draws, samples)
    static = grasped_still(region, in_hand.reshape(-1, 3)).reshape(len(draws), len(samples))
    return np.asarray(static.all(axis=1))
