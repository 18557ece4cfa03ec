"""The compiled inner loops of the arm's kinematics (numba): the DH chain, the TCP Jacobian, the
rotation log and the Levenberg-Marquardt descent of `clutter_gym.model.kinematics`.

Why compiled: a plan calls the chain hundreds of thousands of times on 4x4 matrices (collision
checks place the arm's links, straight TCP lines descend waypoint by waypoint), where numpy's
call overhead is most of the cost: 20 us a chain and 0.5 ms a descent as numpy, about 1 us and
20 us here. `ArmKinematics` wraps these kernels; `clutter_gym.model.transforms` re-exports the
rotation log, the rotation maths' home.

Self-contained on purpose: numba's on-disk cache (``cache=True``) is invalidated by a change of
this file only, never by a change of a module it would import.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

STEP_LIMIT = 0.4
"""rad: the largest joint change of one descent step (a longer step is scaled down)."""


@njit(cache=True)
def rotation_log(r: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle) of a rotation matrix, robust near 0 and pi."""
    vee = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    cos_t = min(max((r[0, 0] + r[1, 1] + r[2, 2] - 1.0) / 2.0, -1.0), 1.0)
    theta = math.acos(cos_t)
    if theta < 1e-7:
        return 0.5 * vee
    if math.pi - theta > 1e-4:
        return theta / (2.0 * math.sin(theta)) * vee
    # Near pi: axis from the symmetric part, sign from the small antisymmetric part.
    b = (r + np.eye(3)) / 2.0
    k = np.argmax(np.diag(b))
    axis = b[:, k] / math.sqrt(b[k, k])
    if axis @ vee < 0:
        axis = -axis
    return theta * axis / np.linalg.norm(axis)


@njit(cache=True)
def dh_frames(
    q: np.ndarray, frame0: np.ndarray, a: np.ndarray, d: np.ndarray, ca: np.ndarray, sa: np.ndarray
) -> np.ndarray:
    """World poses of DH frames 0..7 (8, 4, 4): frame i+1 = frame i Rz(q_i) Tz(d_i) Tx(a_i)
    Rx(alpha_i), written out on the columns (x, y, z, origin) of frame i."""
    out = np.zeros((8, 4, 4))
    out[0] = frame0
    for i in range(7):
        c, s = math.cos(q[i]), math.sin(q[i])
        for row in range(3):
            x, y, z, p = out[i, row, 0], out[i, row, 1], out[i, row, 2], out[i, row, 3]
            x1 = c * x + s * y
            y1 = c * y - s * x
            out[i + 1, row, 0] = x1
            out[i + 1, row, 1] = ca[i] * y1 + sa[i] * z
            out[i + 1, row, 2] = ca[i] * z - sa[i] * y1
            out[i + 1, row, 3] = p + d[i] * z + a[i] * x1
        out[i + 1, 3, 3] = 1.0
    return out


@njit(cache=True)
def link_frames(
    q: np.ndarray,
    base: np.ndarray,
    chain: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    to_hand: np.ndarray,
) -> np.ndarray:
    """World poses of wam_base, the URDF links wam1..wam7 and hand_base (9, 4, 4): the URDF
    frame of link i+1 is DH frame i turned by q_i about its z axis. ``chain`` as `descend`'s."""
    dh = dh_frames(q, *chain)
    out = np.empty((9, 4, 4))
    out[0] = base
    for i in range(7):
        c, s = math.cos(q[i]), math.sin(q[i])
        out[i + 1] = dh[i]
        for row in range(3):
            x, y = dh[i, row, 0], dh[i, row, 1]
            out[i + 1, row, 0] = c * x + s * y
            out[i + 1, row, 1] = -s * x + c * y
    out[8] = dh[7] @ to_hand
    return out


@njit(cache=True)
def placements(
    frames: np.ndarray, anchors: np.ndarray, offsets: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The poses frames[anchors[i]] @ offsets[i] (P, 4, 4) and their rotations as (w, x, y, z)
    quaternions (P, 4): fcl objects are placed with those (a quaternion sets in a third of the
    time a rotation matrix does, and the placement is most of a collision check's cost)."""
    count = anchors.shape[0]
    quaternions = np.empty((count, 4))
    poses = np.zeros((count, 4, 4))
    for i in range(count):
        f, o, r = frames[anchors[i]], offsets[i], poses[i]
        for row in range(4):
            for col in range(4):
                r[row, col] = (
                    f[row, 0] * o[0, col]
                    + f[row, 1] * o[1, col]
                    + f[row, 2] * o[2, col]
                    + f[row, 3] * o[3, col]
                )
        # Shepperd's method: divide by the largest of the four candidates' roots.
        trace = r[0, 0] + r[1, 1] + r[2, 2]
        if trace > r[0, 0] and trace > r[1, 1] and trace > r[2, 2]:
            s = 2.0 * math.sqrt(1.0 + trace)
            w, x, y, z = (
                0.25 * s,
                (r[2, 1] - r[1, 2]) / s,
                (r[0, 2] - r[2, 0]) / s,
                (r[1, 0] - r[0, 1]) / s,
            )
        elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
            s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
            w, x, y, z = (
                (r[2, 1] - r[1, 2]) / s,
                0.25 * s,
                (r[0, 1] + r[1, 0]) / s,
                (r[0, 2] + r[2, 0]) / s,
            )
        elif r[1, 1] > r[2, 2]:
            s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
            w, x, y, z = (
                (r[0, 2] - r[2, 0]) / s,
                (r[0, 1] + r[1, 0]) / s,
                0.25 * s,
                (r[1, 2] + r[2, 1]) / s,
            )
        else:
            s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
            w, x, y, z = (
                (r[1, 0] - r[0, 1]) / s,
                (r[0, 2] + r[2, 0]) / s,
                (r[1, 2] + r[2, 1]) / s,
                0.25 * s,
            )
        quaternions[i, 0], quaternions[i, 1], quaternions[i, 2], quaternions[i, 3] = w, x, y, z
    return poses, quaternions


@njit(cache=True)
def tcp_jacobian(frames: np.ndarray, to_tcp: np.ndarray) -> np.ndarray:
    """Geometric Jacobian (6, 7) of the TCP from the DH frames: z_i x (p - o_i) over z_i."""
    p = (frames[7] @ to_tcp)[:3, 3]
    j = np.empty((6, 7))
    for i in range(7):
        z, r = frames[i, :3, 2], p - frames[i, :3, 3]
        j[0, i] = z[1] * r[2] - z[2] * r[1]
        j[1, i] = z[2] * r[0] - z[0] * r[2]
        j[2, i] = z[0] * r[1] - z[1] * r[0]
        j[3:, i] = z
    return j


@njit(cache=True)
def pose_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """6-vector (position error, rotation-vector error), both in the world frame."""
    e = np.empty(6)
    e[:3] = target[:3, 3] - current[:3, 3]
    relative = np.empty((3, 3))  # target rotation @ current rotation^T
    for i in range(3):
        for j in range(3):
            relative[i, j] = (
                target[i, 0] * current[j, 0]
                + target[i, 1] * current[j, 1]
                + target[i, 2] * current[j, 2]
            )
    e[3:] = rotation_log(relative)
    return e


@njit(cache=True)
def descend(
    target: np.ndarray,
    q0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    chain: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    to_tcp: np.ndarray,
    pos_tol: float,
    rot_tol: float,
    max_iter: int,
) -> tuple[np.ndarray, bool]:
    """Levenberg-Marquardt from q0 towards the TCP pose ``target``, every iterate clamped into
    the joint limits; joints pinned at a limit and pushed outwards are frozen for the step.
    ``chain`` is (frame0, a, d, cos alpha, sin alpha). Returns (q, converged)."""
    q = np.minimum(np.maximum(q0, lower), upper)
    frames = dh_frames(q, *chain)
    e = pose_error(target, frames[7] @ to_tcp)
    cost = e @ e
    lam = 1e-3
    for _ in range(max_iter):
        if np.linalg.norm(e[:3]) < pos_tol and np.linalg.norm(e[3:]) < rot_tol:
            return q, True
        j = tcp_jacobian(frames, to_tcp)
        g = j.T @ e
        free = np.flatnonzero(~(((q <= lower) & (g < 0)) | ((q >= upper) & (g > 0))))
        jf = j[:, free]
        jtj = jf.T @ jf
        damped = jtj + lam * (np.diag(np.diag(jtj)) + np.eye(len(free)))
        dq = np.zeros(7)
        dq[free] = np.linalg.solve(damped, jf.T @ e)
        step = np.abs(dq).max()
        if step > STEP_LIMIT:
            dq *= STEP_LIMIT / step
        qn = np.minimum(np.maximum(q + dq, lower), upper)
        fn = dh_frames(qn, *chain)
        en = pose_error(target, fn[7] @ to_tcp)
        cn = en @ en
        if cn < cost:
            q, frames, e, cost = qn, fn, en, cn
            lam = max(lam / 3.0, 1e-7)
        else:
            lam *= 5.0
            if lam > 1e4:
                return q, False
    return q, False
