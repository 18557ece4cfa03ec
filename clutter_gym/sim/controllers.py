"""The two ways an agent drives HERB's right arm: whole trajectories, or small end-effector steps.

`TrajectoryController` (`ClutterRetrieve-v0`): one env step executes a whole
joint-space trajectory of K waypoints. Each row is the 7 arm joint angles plus a hand command
(spread, closure), both fractions in [0, 1]. Segments are timed so that no joint exceeds
`JOINT_SPEED_SCALE` x its velocity limit, the hand's TCP moves no faster than `max_hand_speed`
(quasi-static pushing: at 0.05 m/s a pushed object drifts < 1 mm after the hand stops), and the
fingers close no faster than the BH-280 does. The position targets are interpolated at every
physics step. To use fewer than K waypoints, repeat the last one: a zero-length segment costs
nothing.

`EndEffectorDeltaController` (the `ClutterRetrieveEE*` variants, for low-level RL): one env
step moves the TCP target by (dx, dy, dz) x `EE_STEP` metres and turns it by dyaw x `YAW_STEP`
about the vertical, sets the hand closure to (a[4] + 1) / 2, and simulates `EE_SUBSTEPS` physics
steps of `EE_TIMESTEP` (1/25 s). The arm starts from `ready_configuration`: the hand horizontal
at grasp height before the workspace's near edge, facing its centre. Turning only about the
vertical keeps it horizontal, so the 5-D action reaches every side grasp of an upright object
(the planners' grasps are all horizontal) and random exploration cannot pitch the fingers into
the table; a pitch component would add a dimension the task never needs.

Actions outside the Box bounds are clipped (reported as info["action_clipped"]); actions that are
not real numbers (strings, dicts, None, complex or object arrays), of the wrong shape, or with NaN
or inf raise ValueError before anything touches the world.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from gymnasium import spaces

from clutter_gym.model import herb as hm
from clutter_gym.model.collision import make_checker
from clutter_gym.model.fields import invalid
from clutter_gym.model.herb import OPEN_HAND, HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.reachability import HEIGHTS, tcp_pose
from clutter_gym.model.transforms import rotation_log, rotation_z
from clutter_gym.model.world import Surface
from clutter_gym.sim.robot import Herb

JOINT_SPEED_SCALE = 0.5
HAND_CLOSE_TIME = 1.0  # seconds for closure 0 -> 1 (the BH-280 closes in about a second)
SETTLE_TIME = 0.5  # seconds of holding the last waypoint: the arm catches up, fingers squeeze
EE_STEP = 0.01
YAW_STEP = 0.05
EE_TIMESTEP = 1.0 / 100.0
"""s: the end-effector variants' physics step (trajectory mode keeps `simulator.TIMESTEP`,
1/240 s); scripted side grasps and lifts of cans and bottles went alike (the same 10 of 12) at
1/120, 1/100 and 1/80 s."""
EE_SUBSTEPS = 4
"""Physics steps per end-effector action: 1/25 s, panda-gym's control period (10 steps of
1/240 s would cost 2.5 times the physics for about the same period)."""
EE_LEAD = 0.02
"""m the TCP target may run ahead of the measured TCP along each axis."""
EE_DAMPING = 0.05
"""Damping of the least-squares IK step (m, rad): negligible unless the arm is singular."""
EE_LIMIT_MARGIN = 0.3
"""rad from a joint limit where the IK step's null-space motion starts pushing the joint back."""
EE_LIMIT_GAIN = 0.5
"""Fraction of a joint's way into `EE_LIMIT_MARGIN` undone per step, in the null space."""
READY_HEIGHT = HEIGHTS[-1]
"""m: the ready TCP's height above the surface, the highest side-grasp height."""
READY_STANDOFF = 0.08
"""m between the ready TCP and the support's near edge: objects stand on the support (their
footprints at least `scene.SUPPORT_MARGIN`, 2 cm, inside it) and the open hand's flat fingers
reach less than 10 cm toward them, so the hand starts clear of every object."""
READY_CANDIDATES = 7
TRAJECTORY_COLUMNS = 9  # 7 joints + spread + closure


class SegmentSpeed(NamedTuple):
    """Speed limits of one trajectory segment: the TCP's (m/s) and the joints' as a fraction of
    their velocity limits (`hm.ARM_VELOCITY_LIMITS`)."""

    hand: float
    joints: float = JOINT_SPEED_SCALE


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
        if not self.run(clipped, substep, SegmentSpeed(self.max_hand_speed)):
            self.settle(substep)
        return bool(np.any(clipped != array))

    def run(self, rows: np.ndarray, substep: Substep, speed: SegmentSpeed) -> bool:
        """Moves through joint rows (N, 9) from where the arm is within the ``speed`` limits;
        returns True if the episode ended on the way (execution stops)."""
        q_prev, _ = self.herb.arm_state()
        hand_prev = self._hand
        for row in rows:
            q_next = row[:7]
            hand_next = HandCommand(spread=float(row[7]), closure=float(row[8]))
            steps = self.segment_steps(q_prev, q_next, hand_prev, hand_next, speed)
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
                    return True
            q_prev, hand_prev = q_next, hand_next
        self._hand = hand_prev
        return False

    def settle(self, substep: Substep) -> None:
        """Holds the last target for `SETTLE_TIME`: the arm catches up, the fingers squeeze."""
        for _ in range(round(SETTLE_TIME / self.timestep)):
            if substep():
                break

    def segment_steps(
        self,
        q0: np.ndarray,
        q1: np.ndarray,
        h0: HandCommand,
        h1: HandCommand,
        speed: SegmentSpeed | None = None,
    ) -> int:
        """Physics steps for one segment: the slowest of the joint, TCP and finger limits."""
        speed = speed or SegmentSpeed(self.max_hand_speed)
        joint_time = float(np.max(np.abs(q1 - q0) / (hm.ARM_VELOCITY_LIMITS * speed.joints)))
        samples = np.linspace(0.0, 1.0, 9)[:, None]
        tcp = self.kinematics.fk_tcp_batch(q0 + samples * (q1 - q0))[:, :3, 3]
        tcp_time = float(np.sum(np.linalg.norm(np.diff(tcp, axis=0), axis=1))) / speed.hand
        hand_time = HAND_CLOSE_TIME * max(abs(h1.closure - h0.closure), abs(h1.spread - h0.spread))
        duration = max(joint_time, tcp_time, hand_time)
        return max(1, math.ceil(duration / self.timestep))


class EndEffectorDeltaController:
    """The TCP follows a target pose that integrates the actions; the joint targets follow it by
    one damped least-squares step per action (a 1 cm step is well inside its linear range, and
    the residual is part of the next step's error). The target is integrated, not re-read from
    the measured TCP, so that holding still does not let the arm sag; it stays within `EE_LEAD`
    of the measured TCP, so a blocked hand pushes with a bounded error instead of winding up."""

    def __init__(self, herb: Herb, kinematics: ArmKinematics) -> None:
        self.herb = herb
        self.kinematics = kinematics
        self.action_space = spaces.Box(-1.0, 1.0, shape=(5,), dtype=np.float32)
        self._target = np.eye(4)
        self._q_target = np.zeros(7)

    def reset(self, q: np.ndarray) -> None:
        self._q_target = q.copy()
        self._target = self.kinematics.fk_tcp(q)

    def execute(self, action: np.ndarray, substep: Substep) -> bool:
        array = check_finite(action, self.action_space.shape)
        clipped = np.clip(array, -1.0, 1.0)
        measured, _ = self.herb.tcp_pose()
        lead = self._target[:3, 3] + EE_STEP * clipped[:3] - measured
        self._target[:3, 3] = measured + np.clip(lead, -EE_LEAD, EE_LEAD)
        self._target[:3, :3] = rotation_z(YAW_STEP * float(clipped[3])) @ self._target[:3, :3]
        self._q_target = self._ik_step(self._q_target)
        self.herb.command(self._q_target, HandCommand(spread=0.0, closure=(clipped[4] + 1.0) / 2.0))
        for _ in range(EE_SUBSTEPS):
            if substep():
                break
        return bool(np.any(clipped != array))

    def _ik_step(self, q: np.ndarray) -> np.ndarray:
        pose, jacobian = self.kinematics.tcp_pose_and_jacobian(q)
        error = np.concatenate(
            [self._target[:3, 3] - pose[:3, 3], rotation_log(self._target[:3, :3] @ pose[:3, :3].T)]
        )
        damped = jacobian @ jacobian.T + EE_DAMPING**2 * np.eye(6)
        inverse = jacobian.T @ np.linalg.inv(damped)  # (7, 6) damped pseudo-inverse
        lower, upper = self.kinematics.lower, self.kinematics.upper
        # The arm's seventh degree of freedom moves joints away from their limits, unseen at
        # the TCP: a joint clipped at a limit would leave the TCP error to the other joints,
        # and the arm lurches (a level hand turned toward straight ahead drives the wrist's
        # j6 to its limit).
        inward = np.maximum(lower + EE_LIMIT_MARGIN - q, 0.0) - np.maximum(
            q - (upper - EE_LIMIT_MARGIN), 0.0
        )
        dq = inverse @ error + (np.eye(7) - inverse @ jacobian) @ (EE_LIMIT_GAIN * inward)
        return np.clip(q + dq, lower, upper)


@functools.cache
def _ready(surface: Surface) -> tuple[float, ...]:
    kinematics = ArmKinematics("right")
    collision_free = make_checker(surface, {}).checker(objects=False)

    def accept(q: np.ndarray) -> bool:
        return kinematics.elbow_height(q) > 0.0 and collision_free(q)

    (x_lo, x_hi), (y_lo, y_hi) = surface.workspace  # y along the workspace, facing its centre
    centre = np.array([(x_lo + x_hi) / 2.0, (y_lo + y_hi) / 2.0])
    best, best_margin = None, -math.inf
    for y in np.linspace(y_lo, y_hi, READY_CANDIDATES):
        tcp = np.array([surface.bounds[0] - READY_STANDOFF, y, surface.top_z + READY_HEIGHT])
        target = tcp_pose(tcp, np.r_[centre - tcp[:2], 0.0])
        # The accepted solution nearest HERB's home pose: the elbow-up branch the planners use.
        q = kinematics.solve_ik(target, accept=accept)
        if q is None:
            continue
        margin = float(np.min(np.minimum(q - kinematics.lower, kinematics.upper - q)))
        if margin > best_margin:
            best, best_margin = q, margin
    if best is None:
        raise RuntimeError(f"no ready configuration of a horizontal hand before the {surface.name}")
    return tuple(float(v) for v in best)


def ready_configuration(surface: Surface) -> np.ndarray:
    """Where the end-effector variants start: the TCP `READY_HEIGHT` above the surface and
    `READY_STANDOFF` before the support's near edge, the hand horizontal (approach axis level,
    finger plane horizontal) facing the workspace's centre, elbow up and clear of the surface.
    Of the places along the near edge, the one whose joints are farthest from their limits, so
    the arm can move every way from it. Solved with the project's IK once per surface."""
    return np.array(_ready(surface))
