"""Pure-numpy kinematics of one HERB WAM arm: FK, Jacobian, limit-respecting IK.

The chain is the Spong-DH product of ``herb_model.WAM_DH`` between the fixed mount of the arm and
the hand mount. The URDF link frame ``{side}_wam{i}`` equals DH frame i-1 rotated by q_i, so the
poses here match pybullet's forward kinematics of ``herb_model.herb_urdf()`` to machine precision.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.transforms import rotation_exp, rotation_log, transform

Accept = Callable[[np.ndarray], bool]

#: Largest shoulder-to-wrist-centre distance of the WAM (upper arm + forearm with offsets).
_MAX_WRIST_REACH = float(np.hypot(0.55, 0.045) + np.hypot(0.3, 0.045))


def pose_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """6-vector (position error, rotation-vector error), both in the world frame."""
    e = np.empty(6)
    e[:3] = target[:3, 3] - current[:3, 3]
    e[3:] = rotation_log(target[:3, :3] @ current[:3, :3].T)
    return e


class ArmKinematics:
    """Kinematics of one WAM arm of HERB in the world (= ``herb_base``) frame."""

    def __init__(self, side: str = "right", base: np.ndarray | None = None) -> None:
        """``base`` overrides the world pose of ``{side}_wam_base`` (default: HERB mounting)."""
        if side not in hm.SIDES:
            raise ValueError(f"side must be one of {hm.SIDES}, got {side!r}")
        self.side = side
        self.base = transform(*hm.ARM_MOUNT[side]) if base is None else np.asarray(base, float)
        self._frame0 = self.base @ transform(hm.WAM_BASE_TO_J1, (0.0, 0.0, 0.0))
        a, alpha, d = hm.WAM_DH.T
        self._a, self._d = a, d
        self._ca, self._sa = np.cos(alpha), np.sin(alpha)
        self._to_hand = transform((0.0, 0.0, hm.FT_SENSOR_LENGTH), (0.0, 0.0, hm.HAND_MOUNT_YAW))
        self._to_tcp = self._to_hand @ transform((0.0, 0.0, hm.HAND_TCP_OFFSET), (0.0, 0.0, 0.0))
        lower, upper = hm.arm_joint_limits(side)
        self.lower, self.upper = lower.copy(), upper.copy()
        #: Elbow-up ready pose used as the second IK start (the mirrored one for the left arm).
        self.home = (
            hm.RIGHT_ARM_HOME.copy()
            if side == "right"
            else hm.mirror_arm_configuration(hm.RIGHT_ARM_HOME)
        )
        self.shoulder = self._frame0[:3, 3].copy()

    # ---------------------------------------------------------------- forward kinematics
    def _dh(self, q: np.ndarray) -> np.ndarray:
        """Stack of DH matrices, shape q.shape + (4, 4)."""
        cq, sq = np.cos(q), np.sin(q)
        m = np.zeros((*q.shape, 4, 4))
        m[..., 0, 0], m[..., 0, 1], m[..., 0, 2] = cq, -sq * self._ca, sq * self._sa
        m[..., 1, 0], m[..., 1, 1], m[..., 1, 2] = sq, cq * self._ca, -cq * self._sa
        m[..., 2, 1], m[..., 2, 2] = self._sa, self._ca
        m[..., 0, 3], m[..., 1, 3], m[..., 2, 3] = self._a * cq, self._a * sq, self._d
        m[..., 3, 3] = 1.0
        return m

    def _dh_frames(self, q: np.ndarray) -> np.ndarray:
        """World poses of DH frames 0..7, shape (8, 4, 4)."""
        dh = self._dh(np.asarray(q, dtype=float))
        frames = np.empty((8, 4, 4))
        frames[0] = self._frame0
        for i in range(7):
            frames[i + 1] = frames[i] @ dh[i]
        return frames

    def fk(self, q: np.ndarray) -> np.ndarray:
        """World pose of ``{side}_hand_base``."""
        return self._dh_frames(q)[7] @ self._to_hand

    def fk_tcp(self, q: np.ndarray) -> np.ndarray:
        """World pose of ``{side}_hand_tcp``."""
        return self._dh_frames(q)[7] @ self._to_tcp

    def link_frames(self, q: np.ndarray) -> np.ndarray:
        """World poses of wam_base, the URDF link frames wam1..wam7 and hand_base: (9, 4, 4).

        These are the frames the URDF collision primitives are attached to.
        """
        q = np.asarray(q, dtype=float)
        dh = self._dh_frames(q)
        out = np.empty((9, 4, 4))
        out[0] = self.base
        c, s = np.cos(q), np.sin(q)
        for i in range(7):
            # URDF frame of link i+1 = DH frame i rotated by q_{i+1} about its z axis.
            f = dh[i]
            out[i + 1] = f
            out[i + 1, :3, 0] = c[i] * f[:3, 0] + s[i] * f[:3, 1]
            out[i + 1, :3, 1] = -s[i] * f[:3, 0] + c[i] * f[:3, 1]
        out[8] = dh[7] @ self._to_hand
        return out

    def fk_batch(self, qs: np.ndarray) -> np.ndarray:
        """Vectorized fk of an (N, 7) array: (N, 4, 4) hand_base poses."""
        return self._flange_batch(qs) @ self._to_hand

    def fk_tcp_batch(self, qs: np.ndarray) -> np.ndarray:
        """Vectorized fk_tcp of an (N, 7) array: (N, 4, 4) hand_tcp poses."""
        return self._flange_batch(qs) @ self._to_tcp

    def _flange_batch(self, qs: np.ndarray) -> np.ndarray:
        """World poses of DH frame 7 (the WAM flange) for an (N, 7) array."""
        qs = np.asarray(qs, dtype=float)
        n = qs.shape[0]
        # Propagate the rotation columns (x, y, z) and origin p of the DH frame column-wise:
        # frame @ Rz(q) Tz(d) Tx(a) Rx(alpha) is a handful of (N, 3) axpy operations.
        x, y, z, p = (np.broadcast_to(self._frame0[:3, k], (n, 3)) for k in range(4))
        c, s = np.cos(qs), np.sin(qs)
        for i in range(7):
            ci, si = c[:, i : i + 1], s[:, i : i + 1]
            x, y = ci * x + si * y, ci * y - si * x
            p = p + self._d[i] * z + self._a[i] * x
            y, z = self._ca[i] * y + self._sa[i] * z, self._ca[i] * z - self._sa[i] * y
        out = np.zeros((n, 4, 4))
        out[:, :3, 0], out[:, :3, 1], out[:, :3, 2], out[:, :3, 3] = x, y, z, p
        out[:, 3, 3] = 1.0
        return out

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Geometric Jacobian (6, 7) of the hand_tcp: linear rows then angular, world frame."""
        return self._jacobian(self._dh_frames(q))

    def tcp_pose_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``fk_tcp(q)`` and ``jacobian(q)`` from one pass of the kinematic chain."""
        frames = self._dh_frames(q)
        return frames[7] @ self._to_tcp, self._jacobian(frames)

    def _jacobian(self, frames: np.ndarray) -> np.ndarray:
        p = (frames[7] @ self._to_tcp)[:3, 3]
        z = frames[:7, :3, 2].T
        r = p[:, None] - frames[:7, :3, 3].T
        j = np.empty((6, 7))
        # z x r written out: np.cross costs more than the rest of an IK iteration.
        j[0] = z[1] * r[2] - z[2] * r[1]
        j[1] = z[2] * r[0] - z[0] * r[2]
        j[2] = z[0] * r[1] - z[1] * r[0]
        j[3:] = z
        return j

    # ---------------------------------------------------------------- inverse kinematics
    def solve_ik_local(
        self,
        target: np.ndarray,
        seed: np.ndarray,
        max_iter: int = 15,
        pos_tol: float = 1e-4,
        rot_tol: float = 1e-3,
    ) -> np.ndarray | None:
        """IK by descent from `seed` only, never a restart: for small moves that must stay
        continuous with the current configuration (end-effector-delta control)."""
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
        """Levenberg-Marquardt from q0; every iterate is clamped into the joint limits."""
        q = np.clip(q0, self.lower, self.upper)
        frames = self._dh_frames(q)
        e = pose_error(target, frames[7] @ self._to_tcp)
        cost = float(e @ e)
        lam = 1e-3
        eye = np.eye(7)
        for _ in range(max_iter):
            if np.linalg.norm(e[:3]) < pos_tol and np.linalg.norm(e[3:]) < rot_tol:
                return q
            j = self._jacobian(frames)
            # Joints pinned at a limit and pushed outwards are frozen for this step.
            g = j.T @ e
            free = ~(((q <= self.lower) & (g < 0)) | ((q >= self.upper) & (g > 0)))
            jf = j[:, free]
            jtj = jf.T @ jf
            dq = np.zeros(7)
            dq[free] = np.linalg.solve(
                jtj + lam * (np.diag(np.diag(jtj)) + eye[free][:, free]), jf.T @ e
            )
            step = float(np.max(np.abs(dq)))
            if step > 0.4:
                dq *= 0.4 / step
            qn = np.clip(q + dq, self.lower, self.upper)
            fn = self._dh_frames(qn)
            en = pose_error(target, fn[7] @ self._to_tcp)
            cn = float(en @ en)
            if cn < cost:
                q, frames, e, cost = qn, fn, en, cn
                lam = max(lam / 3.0, 1e-7)
            else:
                lam *= 5.0
                if lam > 1e4:
                    return None
        return None

    def random_configuration(self, rng: np.random.Generator, elbow_up: bool = True) -> np.ndarray:
        """Uniform in-limit configuration; with ``elbow_up`` the elbow is above the line from
        the shoulder to the wrist (such seeds keep IK away from elbow-down table collisions)."""
        qs = rng.uniform(self.lower, self.upper, size=(16, 7))
        if not elbow_up:
            return qs[0]
        score = np.array([self.elbow_height(q) for q in qs])
        good = np.flatnonzero(score > 0.0)
        return qs[rng.choice(good)] if good.size else qs[int(np.argmax(score))]

    def elbow_height(self, q: np.ndarray) -> float:
        """Height of the elbow above the shoulder-wrist midpoint: > 0 means elbow up."""
        frames = self._dh_frames(q)
        # DH frame 3 sits on the elbow (j4) axis, frame 5 on the wrist centre.
        return float(frames[3][2, 3] - 0.5 * (frames[0][2, 3] + frames[5][2, 3]))

    def solve_ik(
        self,
        target: np.ndarray,
        seed: np.ndarray | None,
        rng: np.random.Generator,
        accept: Accept | None = None,
        max_restarts: int = 20,
        pos_tol: float = 1e-4,
        rot_tol: float = 1e-3,
        n_solutions: int = 3,
        max_iter: int = 100,
    ) -> np.ndarray | None:
        """In-limit configuration putting ``{side}_hand_tcp`` at ``target`` (4x4), or None.

        Descends from the seed (or the home pose if there is none), then restarts up to
        ``max_restarts`` times: from the home pose first, then from random elbow-up
        configurations (``max_restarts=0`` makes a purely local solve). A solution reached from
        the seed is returned at once (it is continuous with the seed); otherwise the one closest
        to the seed (home if no seed) among the first ``n_solutions`` accepted solutions is
        returned. Only configurations with ``accept(q)`` True are returned.
        """
        target = np.asarray(target, dtype=float)
        wrist = target[:3, 3] - (hm.HAND_MOUNT_XYZ[2] + hm.HAND_TCP_OFFSET) * target[:3, 2]
        if np.linalg.norm(wrist - self.shoulder) > _MAX_WRIST_REACH:
            return None
        reference = self.home if seed is None else np.asarray(seed, dtype=float)
        starts = (
            [reference]
            if seed is None or np.allclose(reference, self.home)
            else [reference, self.home]
        )
        found: list[np.ndarray] = []
        for attempt in range(1 + max_restarts):
            q0 = starts[attempt] if attempt < len(starts) else self.random_configuration(rng)
            q = self._descend(target, q0, pos_tol, rot_tol, max_iter)
            if q is None or (accept is not None and not accept(q)):
                continue
            if seed is not None and attempt == 0:
                return q
            found.append(q)
            if len(found) >= n_solutions:
                break
        if not found:
            return None
        return min(found, key=lambda s: float(np.linalg.norm(s - reference)))

    def cartesian_path(
        self,
        q_start: np.ndarray,
        target_tcp_pose: np.ndarray,
        n_waypoints: int,
        accept: Accept | None = None,
        max_jump: float = 0.3,
        pos_tol: float = 1e-4,
        rot_tol: float = 1e-3,
    ) -> np.ndarray | None:
        """Joint path (n_waypoints, 7) moving the tcp on a straight line (slerp in rotation).

        Row 0 is ``q_start``, the last row reaches the target. Each waypoint is solved locally
        from the previous one; the path is rejected (None) if a waypoint fails IK or ``accept``,
        or if any joint jumps more than ``max_jump`` rad between consecutive waypoints.
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
            if q is None or np.max(np.abs(q - q_prev)) > max_jump:
                return None
            if accept is not None and not accept(q):
                return None
            path[k] = q_prev = q
        return path
