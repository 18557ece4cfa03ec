"""Kinematics of one HERB WAM arm: FK, Jacobian, complete analytic IK (numpy; the chain and the
descent per configuration compiled in `clutter_gym.model.arm_kernels`).

The chain is the Spong-DH product of ``herb_model.WAM_DH`` between the fixed mount of the arm and
the hand mount. The URDF link frame ``{side}_wam{i}`` equals DH frame i-1 rotated by q_i, so the
poses here match pybullet's forward kinematics of ``herb_model.herb_urdf()`` to machine precision.

IK is closed-form with j3 as the free joint (the WAM's shoulder axes j1-j3 meet in one point
and its wrist axes j5-j7 in another, Singh & Claassens 2010): for each of `J3_SAMPLES` values of
j3 there are up to 8 solutions (2 elbows x 2 shoulders x 2 wrists), all computed in one
vectorised pass, so a pose no in-limit configuration reaches is known to be out of reach
instead of being a local-descent failure. A Levenberg-Marquardt descent remains for straight
TCP lines, whose waypoints must stay continuous with the previous one.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from clutter_gym.model import arm_kernels
from clutter_gym.model import herb as hm
from clutter_gym.model.transforms import rotation_exp, rotation_log, transform

Accept = Callable[[np.ndarray], bool]

J3_SAMPLES = 256
"""Values of the free joint j3 swept over its range (0.021 rad apart); the seed's own j3 is
added, so a seed that already reaches the pose is among the solutions."""
MAX_CHECKS = 64
"""Most ``accept`` calls of one `ArmKinematics.solve_ik`, so that a pose no free configuration
reaches is refused in a few ms rather than after checking its hundreds of solutions."""
CHECK_SPACING = 0.2
"""rad (largest joint difference) around a refused solution within which `select` checks no
other solution: neighbouring j3 samples of a branch collide or not together, so the checks go
to other branches and other parts of the j3 range. Measured against checking every solution,
on 2016 horizontal-hand poses around the objects of cluttered table and shelf scenes (objects
in the check): with these two settings 286 of the 288 poses that have a free solution get one
(the two misses had 1 and 2 free solutions among 205 and 79, narrower than the j3 step), and a
refused pose costs 14 checks on average (64 at most); spacing 0 (the 64 nearest solutions)
misses 78 of the 288, spacing 0.4 misses 5."""
MAX_JUMP = 0.3
"""rad any joint may move between consecutive waypoints of a `ArmKinematics.cartesian_path`
(its default): a larger step is a jump to another branch, not a continuous line."""
POSE_TOLERANCE = 1e-6
"""m and rad: an analytic solution whose FK misses the target by more is dropped (rounding at a
double root, e.g. the elbow stretched straight, where the closed forms lose half their
digits)."""


def _cos_sin_roots(a: np.ndarray | float, b: np.ndarray | float, c: float) -> np.ndarray:
    """Both x with a cos x + b sin x = c, stacked on a new first axis (NaN where none)."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    radius = np.hypot(a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = c / radius
    # A tangent solution (|ratio| = 1) may come out a rounding error above 1.
    ratio = np.where(np.abs(ratio) <= 1.0 + 1e-12, np.clip(ratio, -1.0, 1.0), np.nan)
    phase, half = np.arctan2(b, a), np.arccos(ratio)
    return np.stack([phase + half, phase - half])


@functools.cache
def warm_up() -> None:
    """Compile the kernels (`arm_kernels`) or load them from numba's disk cache before anything
    is timed: about 12 s the first time after an install, milliseconds after; once per process.
    Every kernel called from Python is called here (tests/test_architecture.py checks it)."""
    arm = ArmKinematics()
    frames = arm._dh_frames(arm.home)
    arm.link_frames(arm.home)
    arm._jacobian(frames)
    arm._descend(frames[7] @ arm._to_tcp, arm.home, 1e-4, 1e-3, 1)
    rotation_log(np.eye(3))
    arm_kernels.placements(arm.link_frames(arm.home), np.zeros(1, dtype=np.int64), np.eye(4)[None])


class ArmKinematics:
    """Kinematics of one WAM arm of HERB in the world (= ``herb_base``) frame."""

    def __init__(self, side: str = "right", base: np.ndarray | None = None) -> None:
        """``base`` overrides the world pose of ``{side}_wam_base`` (default: HERB mounting)."""
        if side not in hm.SIDES:
            raise ValueError(f"side must be one of {hm.SIDES}, got {side!r}")
        self.side = side
        self.base = transform(*hm.ARM_MOUNT[side]) if base is None else np.asarray(base, float)
        self._frame0 = self.base @ transform(hm.WAM_BASE_TO_J1, (0.0, 0.0, 0.0))
        a, alpha, d = (np.ascontiguousarray(column) for column in hm.WAM_DH.T)
        self._a, self._d = a, d
        self._ca, self._sa = np.cos(alpha), np.sin(alpha)
        #: What `arm_kernels` takes for the chain: (frame 0, a, d, cos alpha, sin alpha).
        self._chain = (self._frame0, a, d, self._ca, self._sa)
        self._to_hand = transform((0.0, 0.0, hm.FT_SENSOR_LENGTH), (0.0, 0.0, hm.HAND_MOUNT_YAW))
        self._to_tcp = self._to_hand @ transform((0.0, 0.0, hm.HAND_TCP_OFFSET), (0.0, 0.0, 0.0))
        self._from_tcp = np.linalg.inv(self._to_tcp)
        # The flange in the wam7 link frame is joint 7's DH transform without its rotation.
        zero = self._dh_frames(np.zeros(7))
        self._from_joint7 = np.linalg.inv(np.linalg.inv(zero[6]) @ zero[7])
        lower, upper = hm.arm_joint_limits(side)
        self.lower, self.upper = lower.copy(), upper.copy()
        self._j3_grid = np.linspace(self.lower[2], self.upper[2], J3_SAMPLES)
        #: Elbow-up ready pose: the IK's default seed (the mirrored one for the left arm).
        self.home = (
            hm.RIGHT_ARM_HOME.copy()
            if side == "right"
            else hm.mirror_arm_configuration(hm.RIGHT_ARM_HOME)
        )
        self.shoulder = self._frame0[:3, 3].copy()

    # ---------------------------------------------------------------- forward kinematics
    def _dh_frames(self, q: np.ndarray) -> np.ndarray:
        """World poses of DH frames 0..7, shape (8, 4, 4)."""
        return arm_kernels.dh_frames(np.asarray(q, dtype=float), *self._chain)

    def fk(self, q: np.ndarray) -> np.ndarray:
        """World pose of ``{side}_hand_base``."""
        return self._dh_frames(q)[7] @ self._to_hand

    def fk_tcp(self, q: np.ndarray) -> np.ndarray:
        """World pose of ``{side}_hand_tcp``."""
        return self._dh_frames(q)[7] @ self._to_tcp

    def hand_frames(self, tcp_pose: np.ndarray) -> np.ndarray:
        """World poses of the wam7 link frame and hand_base (2, 4, 4) with the TCP at
        ``tcp_pose``: rigid with the TCP, the same in every IK solution of the pose."""
        flange = np.asarray(tcp_pose, dtype=float) @ self._from_tcp
        return np.stack([flange @ self._from_joint7, flange @ self._to_hand])

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """World poses of wam_base, the URDF link frames wam1..wam7 and hand_base: (9, 4, 4).

        These are the frames the URDF collision primitives are attached to.
        """
        return arm_kernels.link_frames(
            np.asarray(q, dtype=float), self.base, self._chain, self._to_hand
        )

    def fk_batch(self, qs: np.ndarray) -> np.ndarray:
        """Vectorized fk of an (N, 7) array: (N, 4, 4) hand_base poses."""
        return self._flange_batch(qs) @ self._to_hand

    def fk_tcp_batch(self, qs: np.ndarray) -> np.ndarray:
        """Vectorized fk_tcp of an (N, 7) array: (N, 4, 4) hand_tcp poses."""
        return self._flange_batch(qs) @ self._to_tcp

    def _flange_batch(self, qs: np.ndarray) -> np.ndarray:
        """World poses of DH frame 7 (the WAM flange) for an (N, 7) array."""
        qs = np.asarray(qs, dtype=float)
        flange = self._propagate(self._base_columns(qs.shape[0]), qs, 0)
        out = np.zeros((qs.shape[0], 4, 4))
        out[:, :3, :] = flange.transpose(2, 1, 0)
        out[:, 3, 3] = 1.0
        return out

    def elbow_points(self, qs: np.ndarray) -> np.ndarray:
        """World positions (N, 3) of the elbow (the wam4 link frame, on the j4 axis) of an
        (N, 7) array of configurations."""
        qs = np.asarray(qs, dtype=float)
        return self._propagate(self._base_columns(qs.shape[0]), qs[:, :3], 0)[3].T.copy()

    def _base_columns(self, n: int) -> np.ndarray:
        """DH frame 0 as `_propagate` carries frames: (4, 3, n), columns x, y, z, origin."""
        return np.repeat(self._frame0[:3, :].T[:, :, None], n, axis=2)

    def _propagate(self, frames: np.ndarray, qs: np.ndarray, first: int) -> np.ndarray:
        """DH frames (4, 3, N) carried through joints ``first``, ``first`` + 1, ... by the
        columns of ``qs`` (N, k).

        frame @ Rz(q) Tz(d) Tx(a) Rx(alpha) is a handful of axpy operations on the columns;
        as (3, N) arrays they run 3x faster than as (N, 3) rows, and far faster than (N, 3, 3)
        matmuls. This is most of the analytic IK's time.
        """
        x, y, z, p = frames
        c, s = np.cos(qs.T), np.sin(qs.T)
        for k in range(qs.shape[1]):
            i = first + k
            x, y = c[k] * x + s[k] * y, c[k] * y - s[k] * x
            p = p + self._d[i] * z + self._a[i] * x
            y, z = self._ca[i] * y + self._sa[i] * z, self._ca[i] * z - self._sa[i] * y
        return np.stack([x, y, z, p])

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian (6, 7) of the hand_tcp: linear rows then angular, world frame."""
        return self._jacobian(self._dh_frames(q))

    def tcp_pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``fk_tcp(q)`` and ``jacobian(q)`` from one pass of the kinematic chain."""
        frames = self._dh_frames(q)
        return frames[7] @ self._to_tcp, self._jacobian(frames)

    def _jacobian(self, frames: np.ndarray) -> np.ndarray:
        return arm_kernels.tcp_jacobian(frames, self._to_tcp)

    # ---------------------------------------------------------------- inverse kinematics
    def solve_ik_local(
        self,
        target: np.ndarray,
        seed: np.ndarray,
        max_iter: int = 15,
        pos_tol: float = 1e-4,
        rot_tol: float = 1e-3,
    ) -> np.ndarray | None:
        """IK by Levenberg-Marquardt descent from `seed` only: a solution continuous with the
        seed, for small moves (`cartesian_path` steps this way; the nearest analytic solution
        may lie a j3 step away). `agents.experiments.speed.ik_speed` builds the random-restart
        reference solver on it."""
        return self._descend(
            np.asarray(target, dtype=float),
            np.asarray(seed, dtype=float),
            pos_tol,
            rot_tol,
            max_iter,
        )

    def _descend(
        self, target: np.ndarray, q0: np.ndarray, pos_tol: float, rot_tol: float, max_iter: int
    ) -> np.ndarray | None:
        """Levenberg-Marquardt from q0 (`arm_kernels.descend`); None if it does not converge."""
        q, converged = arm_kernels.descend(
            np.ascontiguousarray(target, dtype=float),
            np.asarray(q0, dtype=float),
            self.lower,
            self.upper,
            self._chain,
            self._to_tcp,
            pos_tol,
            rot_tol,
            max_iter,
        )
        return q if converged else None

    def elbow_height(self, q: np.ndarray) -> float:
        """Height of the elbow above the shoulder-wrist midpoint: > 0 means elbow up."""
        frames = self._dh_frames(q)
        # DH frame 3 sits on the elbow (j4) axis, frame 5 on the wrist centre.
        return float(frames[3][2, 3] - 0.5 * (frames[0][2, 3] + frames[5][2, 3]))

    def ik_solutions(
        self,
        target: np.ndarray,
        seed: np.ndarray | None = None,
        j3_within: float | None = None,
    ) -> np.ndarray:
        """Every in-limit configuration (N, 7) putting ``{side}_hand_tcp`` at ``target`` (4x4),
        for `J3_SAMPLES` values of j3 and the seed's own, nearest to ``seed`` (default the home
        pose) first; empty (0, 7) when no configuration within the limits reaches the pose.
        With ``j3_within`` only the grid's j3 values within that many rad of the seed's j3 are
        solved for: the rows of the whole sweep with such a j3, in the same order, for a
        fraction of the cost (a caller that wants solutions near the seed).

        Each row reaches the pose to `POSE_TOLERANCE` (checked by FK), so callers need no
        descent afterwards; only j3 is sampled, the pose is exact.
        """
        target = np.asarray(target, dtype=float)
        reference = self.home if seed is None else np.asarray(seed, dtype=float)
        flange = target @ self._from_tcp
        # The wrist centre (where j5-j7 meet) is d7 behind the flange, along its z axis.
        wrist = flange[:3, 3] - self._d[6] * flange[:3, 2]
        w = self._frame0[:3, :3].T @ (wrist - self._frame0[:3, 3])  # in the j1 frame
        a3, d3, a4, d5 = self._a[2], self._d[2], self._a[3], self._d[4]
        # j4 alone sets the shoulder-wrist distance |w|: a cos j4 + b sin j4 = c (2 elbows).
        q4 = _cos_sin_roots(
            2.0 * (a3 * a4 + d3 * d5),
            2.0 * (a3 * d5 - d3 * a4),
            float(w @ w) - (a3 * a3 + d3 * d3 + a4 * a4 + d5 * d5),
        )
        q4 = self._wrapped(q4, 3)
        if not np.isfinite(q4).any():
            return np.empty((0, 7))
        # The wrist centre in DH frame 2, for every elbow and j3: (2, J).
        own = np.clip(reference[2], self.lower[2], self.upper[2])
        grid = self._j3_grid
        if j3_within is not None:
            grid = grid[np.abs(grid - reference[2]) <= j3_within]
        j3 = np.append(grid, own)
        wx, wy = a4 * np.cos(q4) + d5 * np.sin(q4), a4 * np.sin(q4) - d5 * np.cos(q4)
        vx = (a3 + wx)[:, None] * np.cos(j3)
        vy = (a3 + wx)[:, None] * np.sin(j3)
        vz = np.broadcast_to((d3 - wy)[:, None], vx.shape)
        # R0_2 = Rz(j1) Ry(j2) turns it onto w: j2 from the height along the j1 axis (2
        # shoulders), then j1 from the bearing. Shapes (2 shoulders, 2 elbows, J).
        q2 = _cos_sin_roots(vz, -vx, float(w[2]))
        ux = vx * np.cos(q2) + vz * np.sin(q2)
        q1 = np.arctan2(w[1], w[0]) - np.arctan2(np.broadcast_to(vy, ux.shape), ux)
        arm = np.stack(
            [
                self._wrapped(q1, 0),
                self._wrapped(q2, 1),
                np.broadcast_to(j3, q1.shape),
                np.broadcast_to(q4[:, None], q1.shape),
            ],
            axis=-1,
        ).reshape(-1, 4)
        arm = arm[np.all(np.isfinite(arm), axis=1)]
        # The wrist: R4_7 = R0_4^T R0_7 = Rz(j5) Ry(j6) Rz(j7), a ZYZ Euler solve (2 wrists).
        # j5 + j7 comes from the upper-left block, well conditioned as j6 -> 0, where j5 alone
        # is lost in rounding and any error in it is made good by j7; at j6 = 0 only the sum is
        # determined, and the seed's j5 is kept.
        elbow = self._propagate(self._base_columns(arm.shape[0]), arm, 0)
        r = np.tensordot(elbow[:3], flange[:3, :3], axes=([1], [0]))  # r[i, n, j] = R4_7[n, i, j]
        sin6 = np.hypot(r[0, :, 2], r[1, :, 2])
        q5 = np.where(sin6 > 1e-12, np.arctan2(r[1, :, 2], r[0, :, 2]), reference[4])
        q6 = np.arctan2(sin6, r[2, :, 2])
        q7 = np.arctan2(r[1, :, 0] - r[0, :, 1], r[0, :, 0] + r[1, :, 1]) - q5
        wrist_q = np.concatenate(
            [np.stack([q5, q6, q7], axis=1), np.stack([q5 + np.pi, -q6, q7 + np.pi], axis=1)]
        )
        for k in range(3):
            wrist_q[:, k] = self._wrapped(wrist_q[:, k], 4 + k)
        keep = np.all(np.isfinite(wrist_q), axis=1)
        qs = np.concatenate([np.concatenate([arm, arm])[keep], wrist_q[keep]], axis=1)
        # Verify by FK, carrying on from the elbow frames already computed.
        elbows = np.concatenate([elbow, elbow], axis=2)[:, :, keep]
        qs = qs[self._reaches(self._propagate(elbows, qs[:, 4:], 4), flange)]
        return qs[np.argsort(np.linalg.norm(qs - reference, axis=1), kind="stable")]

    def _wrapped(self, angles: np.ndarray, joint: int) -> np.ndarray:
        """``angles`` shifted by a multiple of 2 pi into joint ``joint``'s limits (NaN where no
        shift fits: the ranges are shorter than 2 pi, so the representative is unique)."""
        low = self.lower[joint]
        shifted = low + np.mod(angles - low, 2.0 * np.pi)
        return np.where(shifted <= self.upper[joint], shifted, np.nan)

    def _reaches(self, frames: np.ndarray, flange: np.ndarray) -> np.ndarray:
        """Which flange frames (4, 3, N) put the TCP within `POSE_TOLERANCE` of where
        ``flange`` (4x4) puts it (rotation error: the Frobenius distance / sqrt 2, the angle to
        first order)."""
        offset = self._to_tcp[:3, 3]
        tcp = frames[3] + np.tensordot(offset, frames[:3], axes=1)
        position = np.linalg.norm(tcp - (flange[:3, :3] @ offset + flange[:3, 3])[:, None], axis=0)
        rotation = np.sqrt(np.sum((frames[:3] - flange[:3, :3].T[:, :, None]) ** 2, axis=(0, 1)))
        return (position <= POSE_TOLERANCE) & (rotation <= np.sqrt(2.0) * POSE_TOLERANCE)

    def select(
        self,
        solutions: np.ndarray,
        accept: Accept | None,
        max_checks: int = MAX_CHECKS,
        spacing: float = CHECK_SPACING,
    ) -> np.ndarray | None:
        """The first row of ``solutions`` (ordered, as `ik_solutions` returns them) that
        ``accept`` takes, or None, calling ``accept`` at most ``max_checks`` times.

        A pose has up to thousands of solutions and a collision check costs 0.2-0.4 ms, so they
        are thinned: after a refusal, every solution within ``spacing`` rad (in every joint) of
        the refused one is skipped, and the next check goes to the nearest solution not yet
        covered, which moves the checks across the branches and the j3 range.
        """
        if accept is None:
            return solutions[0].copy() if len(solutions) else None
        open_ = np.ones(len(solutions), dtype=bool)
        for _ in range(max_checks):
            remaining = np.flatnonzero(open_)
            if remaining.size == 0:
                return None
            q = solutions[remaining[0]]
            if accept(q):
                return q.copy()
            open_[remaining] = np.max(np.abs(solutions[remaining] - q), axis=1) >= spacing
        return None

    def solve_ik(
        self,
        target: np.ndarray,
        seed: np.ndarray | None = None,
        accept: Accept | None = None,
        max_checks: int = MAX_CHECKS,
        spacing: float = CHECK_SPACING,
    ) -> np.ndarray | None:
        """The in-limit configuration putting ``{side}_hand_tcp`` at ``target`` (4x4) nearest
        to ``seed`` (default the home pose) among those ``accept`` takes (`select`), or None.

        Deterministic: the analytic solutions (`ik_solutions`) replace random restarts, so
        None means out of reach or no accepted solution among the thinned checks.
        """
        return self.select(self.ik_solutions(target, seed), accept, max_checks, spacing)

    def cartesian_path(
        self,
        q_start: np.ndarray,
        target_tcp_pose: np.ndarray,
        n_waypoints: int,
        accept: Accept | None = None,
        max_jump: float = MAX_JUMP,
        pos_tol: float = 1e-4,
        rot_tol: float = 1e-3,
        connect: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    ) -> np.ndarray | None:
        """Joint path (n_waypoints, 7) moving the tcp on a straight line (slerp in rotation).

        Row 0 is ``q_start``, the last row reaches the target. Each waypoint descends from the
        previous one (continuity); where the descent stalls (at a joint limit, near a
        singularity), the analytic solution nearest the previous waypoint stands in. The path
        is rejected (None) if a waypoint has no solution or fails ``accept``, or if any joint
        jumps more than ``max_jump`` rad between consecutive waypoints.

        With ``connect`` (a test of the joint motion from one waypoint to the next), a waypoint
        that would reject the path is taken instead from the pose's other analytic solutions
        within ``max_jump`` of the previous waypoint, nearest first: the first that ``accept``
        and ``connect`` both take (`swung_waypoint`).
        """
        if n_waypoints < 2:
            raise ValueError("n_waypoints must be at least 2")
        q_prev = np.clip(np.asarray(q_start, dtype=float), self.lower, self.upper)
        start = self.fk_tcp(q_prev)
        target = np.asarray(target_tcp_pose, dtype=float)
        w = rotation_log(target[:3, :3] @ start[:3, :3].T)
        path = np.empty((n_waypoints, 7))
        path[0] = q_prev
        for k, s in enumerate(np.linspace(0.0, 1.0, n_waypoints)[1:], start=1):
            pose = np.eye(4)
            pose[:3, :3] = rotation_exp(s * w) @ start[:3, :3]
            pose[:3, 3] = (1.0 - s) * start[:3, 3] + s * target[:3, 3]
            q = self._descend(pose, q_prev, pos_tol, rot_tol, max_iter=100)
            if q is None:
                q = self.solve_ik(pose, q_prev)
            if q is not None and (
                np.max(np.abs(q - q_prev)) > max_jump or (accept is not None and not accept(q))
            ):
                q = None
            if q is None and connect is not None:
                q = self.swung_waypoint(pose, q_prev, accept, connect, max_jump)
            if q is None:
                return None
            path[k] = q_prev = q
        return path

    def swung_waypoint(
        self,
        pose: np.ndarray,
        q_prev: np.ndarray,
        accept: Accept | None,
        connect: Callable[[np.ndarray, np.ndarray], bool],
        max_jump: float,
    ) -> np.ndarray | None:
        """A configuration at ``pose`` within ``max_jump`` of ``q_prev`` (in every joint) that
        ``accept`` takes and that ``connect`` takes the motion from ``q_prev`` to, nearest
        first, or None: a straight line whose continuous solution runs the elbow into
        something (under a shelf's ceiling, a 5 mm lift does) may go on with the elbow swung
        about the shoulder-wrist axis, another j3 of the same pose. At most `MAX_CHECKS`
        configurations are tried."""
        solutions = self.ik_solutions(pose, q_prev, j3_within=max_jump)
        near = solutions[np.max(np.abs(solutions - q_prev), axis=1) <= max_jump]
        for q in near[:MAX_CHECKS]:
            if (accept is None or accept(q)) and connect(q_prev, q):
                return q.copy()
        return None
