"""HERB inside a `Simulator`: joint lookup by name, arm and hand position control.

The right arm and hand are commanded. The left arm and hand are parked: the URDF freezes them at
`LEFT_ARM_PARK` as fixed joints, which removes 15 DoF and their motors from every physics step
(measured: 455 -> 167 us per step). pybullet ignores URDF `<mimic>`, so the BH-280's distal
joints are driven here from the proximal ones with the hand's fixed coupling ratio, and F1/F2
spread mirror each other.

With `merge_fixed_links` (the end-effector variants) the parked left side and the fixed frames
(wam bases, hand base, TCP) fold into their moving parents: 36 links become 15 and a physics
step costs ~40% less (measured: 120 -> 70 us with the arm and hand under position control).
The rigid bodies are the same; the palm is then part of the `right_wam7` link and the TCP is
read through its fixed offset from it. The trajectory mode keeps the unmerged body, on which
the capture regions were validated.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.herb import OPEN_HAND, HandCommand, hand_targets
from clutter_gym.sim.bullet import pybullet
from clutter_gym.sim.simulator import Simulator

FINGERS = ("f1", "f2", "f3")
FINGER_FRICTION = 1.0  # rubber-padded fingertips and palm
ARM_POSITION_GAIN = 0.3  # pybullet's position-control gain: stiff enough to push a 1 kg box
WORM_GEAR_EFFORT = 50.0
"""N m a finger joint resists being turned back open with: the BH-280 drives its fingers through
worm gears, which cannot be back-driven. A position servo limited to the drive's effort can:
closing on a poptart box across the hand, F1 and F2 (6 N m together) pushed it against F3 (3
N m) and turned F3 from 0.87 rad back to fully open (Table 1 high_09)."""
WORM_GEAR_SLACK = 0.01  # rad a finger may be turned back before its gear holds it
WRIST_TO_TCP = (
    (0.0, 0.0, hm.HAND_MOUNT_XYZ[2] + hm.HAND_TCP_OFFSET),
    (0.0, 0.0, math.sin(hm.HAND_MOUNT_YAW / 2.0), math.cos(hm.HAND_MOUNT_YAW / 2.0)),
)
"""The TCP in the `right_wam7` link frame: the hand mount, then `HAND_TCP_OFFSET` forward."""


def parked_herb_urdf() -> Path:
    """The URDF with the left side parked, generated once per process (4 ms saved per reset)."""
    path = _cached_urdf()
    if not path.is_file():  # the cache directory was cleaned while we ran
        _cached_urdf.cache_clear()
        path = _cached_urdf()
    return path


@functools.cache
def _cached_urdf() -> Path:
    return hm.write_herb_urdf(parked=hm.parked_left_side())


class Herb:
    """The loaded HERB body and its controllers."""

    def __init__(self, sim: Simulator, name: str = "herb", merge_fixed_links: bool = False) -> None:
        self.sim = sim
        self.name = name
        self.body_id = sim.load_urdf(name, parked_herb_urdf(), True, merge_fixed_links)
        c = sim.client
        self.joint_index: dict[str, int] = {}
        self.link_index: dict[str, int] = {}
        for j in range(c.getNumJoints(self.body_id)):
            info = c.getJointInfo(self.body_id, j)
            self.joint_index[info[1].decode()] = j
            self.link_index[info[12].decode()] = j
        self.arm = [self.joint_index[n] for n in hm.arm_joint_names("right")]
        self.hand = [self.joint_index[n] for n in hm.hand_joint_names("right")]
        merged = "right_hand_tcp" not in self.link_index
        wrist = self.link_index["right_wam7"]
        self._tcp_link = wrist if merged else self.link_index["right_hand_tcp"]
        self._to_tcp = WRIST_TO_TCP if merged else None
        self.finger_links: dict[str, tuple[int, ...]] = {
            f: tuple(i for n, i in self.link_index.items() if n.startswith(f"right_{f}_"))
            for f in FINGERS
        }
        self.palm_link = wrist if merged else self.link_index["right_hand_base"]
        self._hand_forces = np.array(
            [hm.HAND_SPREAD_EFFORT] * 2
            + [hm.HAND_PROXIMAL_EFFORT] * 3
            + [hm.HAND_DISTAL_EFFORT] * 3
        )
        for link in (*self.finger_links["f1"], *self.finger_links["f2"], *self.finger_links["f3"]):
            c.changeDynamics(self.body_id, link, lateralFriction=FINGER_FRICTION)
        c.changeDynamics(self.body_id, self.palm_link, lateralFriction=FINGER_FRICTION)
        self._closure = 0.0  # the last closure commanded
        # The most-closed angle of each finger joint (proximal, distal) since the hand last
        # opened: where its worm gear holds it (`hold_fingers`).
        self._gear = np.zeros(6)
        self._finger_targets = np.zeros(6)
        self._holding = False  # a gear holds some finger joint (`hold_fingers`)

    # --- state ------------------------------------------------------------------------------
    def reset(self, arm_q: np.ndarray, hand: HandCommand = OPEN_HAND) -> None:
        """Teleport to a configuration (only between episodes) and hold it."""
        c = self.sim.client
        for j, q in zip(self.arm, arm_q, strict=True):
            c.resetJointState(self.body_id, j, float(q))
        for j, q in zip(self.hand, hand_targets(hand), strict=True):
            c.resetJointState(self.body_id, j, float(q))
        self._closure = hand.closure
        self._gear = hand_targets(hand)[2:]
        self.command(np.asarray(arm_q, dtype=np.float64), hand)

    def arm_state(self) -> tuple[np.ndarray, np.ndarray]:
        states = self.sim.client.getJointStates(self.body_id, self.arm)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def hand_state(self) -> np.ndarray:
        """(spread, f1, f2, f3 proximal) joint angles."""
        states = self.sim.client.getJointStates(self.body_id, self.hand[1:5])
        return np.array([s[0] for s in states])

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        c = self.sim.client
        state = c.getLinkState(self.body_id, self._tcp_link, computeForwardKinematics=True)
        pose = (
            state[4:6] if self._to_tcp is None else c.multiplyTransforms(*state[4:6], *self._to_tcp)
        )
        return np.array(pose[0]), np.array(pose[1])

    # --- control ----------------------------------------------------------------------------
    def command(self, arm_q: np.ndarray, hand: HandCommand) -> None:
        """Position targets for the right arm and hand, held until the next command."""
        c = self.sim.client
        c.setJointMotorControlArray(
            self.body_id,
            self.arm,
            pybullet.POSITION_CONTROL,
            targetPositions=arm_q.tolist(),
            forces=list(hm.ARM_EFFORT_LIMITS),
            positionGains=[ARM_POSITION_GAIN] * 7,
        )
        targets = hand_targets(hand)
        if hand.closure < self._closure:
            # Opening: the BH-280's worm gears reverse from where each link stands; a finger
            # stalled on an object does not first keep squeezing toward its old target.
            fingers = [s[0] for s in c.getJointStates(self.body_id, self.hand[2:])]
            targets[2:] = np.minimum(targets[2:], fingers)
            self._gear = np.minimum(self._gear, targets[2:])
        self._closure = hand.closure
        self._finger_targets = targets[2:].copy()
        c.setJointMotorControlArray(
            self.body_id,
            self.hand,
            pybullet.POSITION_CONTROL,
            targetPositions=targets.tolist(),
            forces=self._hand_forces.tolist(),
        )

    def hold_fingers(self) -> None:
        """Before each physics step: a finger joint turned back open by more than
        `WORM_GEAR_SLACK` from the most-closed angle it reached is held there with
        `WORM_GEAR_EFFORT` (the worm gear), any other is driven to its target with the drive's
        effort. Opening (`command` with a smaller closure) releases the gears."""
        if self._closure <= 0.0 and not self._holding:
            return  # an open hand: nothing to hold (its fingers sit at their open limits)
        c = self.sim.client
        joints = self.hand[2:]
        angles = np.array([s[0] for s in c.getJointStates(self.body_id, joints)])
        reached = np.minimum(angles, self._finger_targets)
        self._gear = np.maximum(self._gear, reached)
        back = angles < self._gear - WORM_GEAR_SLACK
        if not back.any() and not self._holding:
            return  # every finger is driven by `command`'s targets already
        self._holding = bool(back.any())
        targets = np.where(back, self._gear, self._finger_targets)
        forces = np.where(back, WORM_GEAR_EFFORT, self._hand_forces[2:])
        c.setJointMotorControlArray(
            self.body_id,
            joints,
            pybullet.POSITION_CONTROL,
            targetPositions=targets.tolist(),
            forces=forces.tolist(),
        )
