"""The two ways an agent drives HERB's right arm: whole trajectories, or small end-effector steps.

`TrajectoryController` (control_mode="trajectory", the default): one env step executes a whole
joint-space trajectory of K waypoints. Each row is the 7 arm joint angles plus a hand command
(spread, closure), both fractions in [0, 1]. Segments are timed so that no joint exceeds
`JOINT_SPEED_SCALE` x its velocity limit, the hand's TCP moves no faster than `max_hand_speed`
(quasi-static pushing: at 0.05 m/s a pushed object drifts < 1 mm after the hand stops), and the
fingers close no faster than the BH-280 does. The position targets are interpolated at every
physics step. To use fewer than K waypoints, repeat the last one: a zero-length segment costs
nothing.

`EndEffectorDeltaController` (control_mode="ee_delta", for low-level RL): one env step moves the
TCP target by (dx, dy, dz) x `EE_STEP` metres and its yaw by dyaw x `YAW_STEP`, sets the hand
closure to (a[4] + 1) / 2, and simulates `EE_SUBSTEPS` physics steps.

Actions outside the Box bounds are clipped (reported as info["action_clipped"]); actions that are
not real numbers (strings, dicts, None, complex or object arrays), of the wrong shape, or with NaN
or inf raise ValueError before anything touches the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from gymnasium import spaces

from clutter_gym.model import herb as hm
from clutter_gym.model.fields import invalid
from clutter_gym.model.herb import OPEN_HAND, HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.sim.robot import Herb

JOINT_SPEED_SCALE = 0.5
HAND_CLOSE_TIME = 1.0  # seconds for closure 0 -> 1 (the BH-280 closes in about a second)
SETTLE_TIME = 0.5  # seconds of holding the last waypoint: the arm catches up, fingers squeeze
EE_STEP = 0.01
YAW_STEP = 0.05
EE_SUBSTEPS = 10
EE_IK_ITERATIONS = 15  # a 1 cm step converges in a few; more only burns time on unreachable ones
EE_IK_TOLERANCE = (1e-3, 1e-2)  # m, rad: the next target starts from the measured TCP anyway
TRAJECTORY_COLUMNS = 9  # 7 joints + spread + closure

Substep = Callable[[], bool]
"""Advances physics one step; returns True when the episode has ended (stop executing)."""


def real_array(value: object) -> np.ndarray | None:
    """`value` as a float64 array, or None unless it holds only integers and floats: numpy would
    parse strings, drop imaginary parts, or raise a bare TypeError on a dict."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        return None
    return array.astype(np.float64) if array.dtype.kind in "iuf" else None


def check_finite(action: object, expected_shape: tuple[int, ...]) -> np.ndarray:
    """The action as a float64 array, or a ValueError naming `action`: raised before execution,
    so that a bad action never half-moves the arm."""
    array = real_array(action)
    if array is None or array.shape != expected_shape:
        raise invalid("action", action, f"a real-valued array of shape {expected_shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0].tolist()
        raise ValueError(
            f"action: non-finite value {array[tuple(bad)]} at index {bad}; expected finite values"
        )
    return array


class TrajectoryController:
    def __init__(
        self,
        herb: Herb,
        kinematics: ArmKinematics,
        waypoints: int,
        max_hand_speed: float,
        timestep: float,
    ) -> None:
        """`waypoints` (>= 1) and `max_hand_speed` (finite, > 0) come checked from the env."""
        self.herb = herb
        self.kinematics = kinematics
        self.waypoints = waypoints
        self.max_hand_speed = max_hand_speed
        self.timestep = timestep
        low = np.tile(np.r_[kinematics.lower, 0.0, 0.0], (waypoints, 1))
        high = np.tile(np.r_[kinematics.upper, 1.0, 1.0], (waypoints, 1))
        self.action_space = spaces.Box(
            low.astype(np.float32), high.astype(np.float32), dtype=np.float32
        )
        self._hand = OPEN_HAND

    def reset(self, hand: HandCommand) -> None:
        self._hand = hand

    def execute(self, action: np.ndarray, substep: Substep) -> bool:
        """Runs the trajectory; returns whether it was clipped to the action bounds."""
        array = check_finite(action, self.action_space.shape)
        clipped = np.clip(array, self.action_space.low, self.action_space.high)
        q_prev, _ = self.herb.arm_state()
        hand_prev = self._hand
        for row in clipped:
            q_next = row[:7]
            hand_next = HandCommand(spread=float(row[7]), closure=float(row[8]))
            steps = self.segment_steps(q_prev, q_next, hand_prev, hand_next)
            for k in range(1, steps + 1):
                s = k / steps
                self.herb.command(
                    q_prev + s * (q_next - q_prev),
                    HandCommand(
                        spread=hand_prev.spread + s * (hand_next.spread - hand_prev.spread),
                        closure=hand_prev.closure + s * (hand_next.closure - hand_prev.closure),
                    ),
                )
                if substep():
                    self._hand = hand_next
                    return bool(np.any(clipped != array))
            q_prev, hand_prev = q_next, hand_next
        self._hand = hand_prev
        for _ in range(round(SETTLE_TIME / self.timestep)):
            if substep():
                break
        return bool(np.any(clipped != array))

    def segment_steps(
        self, q0: np.ndarray, q1: np.ndarray, h0: HandCommand, h1: HandCommand
    ) -> int:
        """Physics steps for one segment: the slowest of the joint, TCP and finger limits."""
        joint_time = float(np.max(np.abs(q1 - q0) / (hm.ARM_VELOCITY_LIMITS * JOINT_SPEED_SCALE)))
        samples = np.linspace(0.0, 1.0, 9)[:, None]
        tcp = self.kinematics.fk_tcp_batch(q0 + samples * (q1 - q0))[:, :3, 3]
        tcp_time = float(np.sum(np.linalg.norm(np.diff(tcp, axis=0), axis=1))) / self.max_hand_speed
        hand_time = HAND_CLOSE_TIME * max(abs(h1.closure - h0.closure), abs(h1.spread - h0.spread))
        duration = max(joint_time, tcp_time, hand_time)
        return max(1, math.ceil(duration / self.timestep))


class EndEffectorDeltaController:
    def __init__(self, herb: Herb, kinematics: ArmKinematics) -> None:
        self.herb = herb
        self.kinematics = kinematics
        self.action_space = spaces.Box(-1.0, 1.0, shape=(5,), dtype=np.float32)
        self._target_rotation = np.eye(3)
        self._q_target = np.zeros(7)

    def reset(self, q: np.ndarray) -> None:
        self._q_target = q.copy()
        self._target_rotation = self.kinematics.fk_tcp(q)[:3, :3]

    def execute(self, action: np.ndarray, substep: Substep) -> bool:
        array = check_finite(action, self.action_space.shape)
        clipped = np.clip(array, -1.0, 1.0)
        q, _ = self.herb.arm_state()
        target = np.eye(4)
        target[:3, 3] = self.kinematics.fk_tcp(q)[:3, 3] + EE_STEP * clipped[:3]
        c, s = math.cos(YAW_STEP * clipped[3]), math.sin(YAW_STEP * clipped[3])
        yaw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        target[:3, :3] = yaw @ self._target_rotation
        solution = self.kinematics.solve_ik_local(
            target, q, EE_IK_ITERATIONS, pos_tol=EE_IK_TOLERANCE[0], rot_tol=EE_IK_TOLERANCE[1]
        )
        if solution is not None:  # unreachable: hold the last reachable target
            self._q_target = solution
            self._target_rotation = target[:3, :3]
        self.herb.command(self._q_target, HandCommand(spread=0.0, closure=(clipped[4] + 1.0) / 2.0))
        for _ in range(EE_SUBSTEPS):
            if substep():
                break
        return bool(np.any(clipped != array))
