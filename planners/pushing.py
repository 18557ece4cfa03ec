"""Quasi-static planar pushing with an ellipsoidal limit surface (Howe & Cutkosky; Lynch).

Why this module exists: capture regions (`planners.capture`) need thousands of push simulations,
so every solver here works on batches of samples with numpy. Conventions: the object frame sits at
the centre of friction, a twist is ``(vx, vy, omega)`` in that frame, contact normals point from
the pusher into the object, and ``A = diag(1, 1, 1/c^2)``.

Several simultaneous contacts are solved as the contact LCP (Stewart & Trinkle) by enumerating,
for each contact, the four complementarity patterns of its ``(f_n, f_t+, f_t-, lambda)`` block
(separate, stick, slide +t, slide -t): with at most four contacts that is at most 256 linear
systems, each solved for the whole batch at once, and an exhaustive enumeration never misses a
solution the way a pivoting method with a degenerate start can. No solution means the contacts
jam.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

MAX_CONTACTS = 4
"""Contacts kept per sample and step (the nearest ones); a box on a flat face needs two."""
_TOL = 1e-9


# --------------------------------------------------------------------------------------------
# Limit surface
# --------------------------------------------------------------------------------------------
def positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


@dataclass(frozen=True)
class RimPressure:
    """All support pressure on a circle of ``radius``: the largest c of a disc (c = R)."""

    radius: float

    def __post_init__(self) -> None:
        positive("RimPressure.radius", self.radius)

    @property
    def c(self) -> float:
        return self.radius


@dataclass(frozen=True)
class DiscPressure:
    """Uniform pressure over a disc: c = 2R/3."""

    radius: float

    def __post_init__(self) -> None:
        positive("DiscPressure.radius", self.radius)

    @property
    def c(self) -> float:
        return 2.0 * self.radius / 3.0


@dataclass(frozen=True)
class RectanglePressure:
    """Uniform pressure over a rectangle of ``half_extents`` (closed form of the mean |r|)."""

    half_extents: tuple[float, float]

    def __post_init__(self) -> None:
        for k, h in enumerate(self.half_extents):
            positive(f"RectanglePressure.half_extents[{k}]", h)

    @property
    def c(self) -> float:
        a, b = self.half_extents
        d = math.hypot(a, b)
        quarter = (2 * a * b * d + a**3 * math.log((b + d) / a) + b**3 * math.log((a + d) / b)) / 6
        return quarter / (a * b)


@dataclass(frozen=True)
class SampledPressure:
    """Point masses of pressure ``weights`` at ``points`` (object frame, centroid at the origin)."""

    points: tuple[tuple[float, float], ...]
    weights: tuple[float, ...]

    def __post_init__(self) -> None:
        p, w = np.asarray(self.points, float), np.asarray(self.weights, float)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) == 0 or w.shape != (len(p),):
            raise ValueError(
                f"SampledPressure needs points (n, 2) and weights (n,), got {p.shape} and {w.shape}"
            )
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(w)) and np.all(w >= 0)):
            raise ValueError("SampledPressure.weights must be finite and >= 0, points finite")
        if w.sum() <= 0:
            raise ValueError("SampledPressure.weights must have a positive sum")
        centroid = (w[:, None] * p).sum(0) / w.sum()
        scale = float(np.abs(p).max())
        if scale == 0 or np.abs(centroid).max() > 1e-9 * scale:
            raise ValueError(
                f"SampledPressure must be centred on the object frame (its centre of friction) and "
                f"not all at one point; weighted centroid is {centroid.tolist()}"
            )

    @property
    def c(self) -> float:
        p, w = np.asarray(self.points, float), np.asarray(self.weights, float)
        return float((w * np.hypot(p[:, 0], p[:, 1])).sum() / w.sum())


PressureDistribution = RimPressure | DiscPressure | RectanglePressure | SampledPressure


def limit_surface_matrix(c: float) -> np.ndarray:
    """A = diag(1, 1, 1/c^2): maps a wrench to a twist direction (c is a length, not 1/c^2)."""
    positive("c", c)
    return np.diag([1.0, 1.0, 1.0 / c**2])


# --------------------------------------------------------------------------------------------
# One contact
# --------------------------------------------------------------------------------------------
def contact_jacobian(r: np.ndarray) -> np.ndarray:
    """J(r) = [[1, 0, -y], [0, 1, x]], batched: (..., 2) -> (..., 2, 3)."""
    r = np.asarray(r, float)
    j = np.zeros((*r.shape[:-1], 2, 3))
    j[..., 0, 0] = j[..., 1, 1] = 1.0
    j[..., 0, 2] = -r[..., 1]
    j[..., 1, 2] = r[..., 0]
    return j


def lynch_sticking_twist(r: np.ndarray, vp: np.ndarray, c: np.ndarray | float) -> np.ndarray:
    """Lynch's closed-form sticking twist (Lynch, Maekawa & Tanie 1992), batched."""
    r, vp = np.asarray(r, float), np.asarray(vp, float)
    x, y, c2 = r[..., 0], r[..., 1], np.asarray(c, float) ** 2
    d = c2 + x * x + y * y
    vx = ((c2 + x * x) * vp[..., 0] + x * y * vp[..., 1]) / d
    vy = (x * y * vp[..., 0] + (c2 + y * y) * vp[..., 1]) / d
    return np.stack([vx, vy, (x * vy - y * vx) / c2], axis=-1)


SEPARATE, STICK, SLIDE = 0, 1, 2


def single_contact_twist(
    r: np.ndarray,
    n: np.ndarray,
    vp: np.ndarray,
    mu: np.ndarray | float,
    c: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray]:
    """Object twist and contact mode (SEPARATE/STICK/SLIDE) for one point contact, batched.

    The three cases of a point contact: the sticking force f* = B^-1 v_p decides between
    sticking and sliding on the friction-cone edge that f* lies beyond.
    """
    r, n, vp = np.broadcast_arrays(*(np.asarray(a, float) for a in (r, n, vp)))
    mu, c = np.asarray(mu, float), np.asarray(c, float)
    t = np.stack([-n[..., 1], n[..., 0]], axis=-1)
    jac = contact_jacobian(r)
    a_diag = np.stack(np.broadcast_arrays(np.ones_like(c), np.ones_like(c), 1.0 / c**2), -1)
    ajt = a_diag[..., :, None] * np.swapaxes(jac, -1, -2)  # A J^T, (..., 3, 2)
    b = jac @ ajt
    f_star = np.linalg.solve(b, vp[..., None])[..., 0]
    fn, ft = (f_star * n).sum(-1), (f_star * t).sum(-1)
    v_stick = (ajt @ f_star[..., None])[..., 0]
    s = np.sign(ft)
    edge = n + (s * mu)[..., None] * t
    v_b = (ajt @ edge[..., None])[..., 0]
    vpn = (vp * n).sum(-1)
    n_jvb = (n * (jac @ v_b[..., None])[..., 0]).sum(-1)
    v_slide = (vpn / n_jvb)[..., None] * v_b
    sticking = np.abs(ft) <= mu * fn
    separating = vpn <= 0
    twist = np.where(sticking[..., None], v_stick, v_slide)
    twist = np.where(separating[..., None], 0.0, twist)
    mode = np.where(separating, SEPARATE, np.where(sticking, STICK, SLIDE))
    return twist, mode


# --------------------------------------------------------------------------------------------
# Several contacts
# --------------------------------------------------------------------------------------------
def contact_lcp(
    r: np.ndarray, n: np.ndarray, vp: np.ndarray, mu: float, c: float
) -> tuple[np.ndarray, np.ndarray]:
    """(M, q) of the contact LCP for m contacts (r, n, vp: (m, 2)); z = (f_n, f_t, lambda)."""
    r, n, vp = (np.asarray(a, float) for a in (r, n, vp))
    m = len(r)
    a = limit_surface_matrix(c)
    t = np.stack([-n[:, 1], n[:, 0]], axis=1)
    jac = contact_jacobian(r)
    big_n = np.einsum("ik,ikj->ij", n, jac)  # (m, 3)
    d = np.zeros((m, 2 * m, 2))  # D_i = [t_i, -t_i] per contact
    for i in range(m):
        d[i, 2 * i] = t[i]
        d[i, 2 * i + 1] = -t[i]
    big_l = np.einsum("ipk,ikj->pj", d, jac)  # (2m, 3)
    e = np.kron(np.eye(m), np.ones((2, 1)))  # (2m, m)
    top = np.hstack([big_n @ a @ big_n.T, big_n @ a @ big_l.T, np.zeros((m, m))])
    mid = np.hstack([big_l @ a @ big_n.T, big_l @ a @ big_l.T, e])
    bot = np.hstack([mu * np.eye(m), -e.T, np.zeros((m, m))])
    q = np.concatenate([-(n * vp).sum(1), -np.einsum("ipk,ik->p", d, vp), np.zeros(m)])
    return np.vstack([top, mid, bot]), q


@dataclass(frozen=True)
class ContactSolution:
    """Batched solution: twist (N, 3); forces (N, m, 2) as (f_n, f_t) on t = (-n_y, n_x);
    ``jammed`` where no complementarity pattern is feasible (the contacts cage the object)."""

    twist: np.ndarray
    forces: np.ndarray
    jammed: np.ndarray


def _mode_patterns(m: int) -> np.ndarray:
    """All 4^m per-contact modes (0 separate, 1 stick, 2 slide +t, 3 slide -t), fewest active
    contacts first, then fewest sliding: with friction the LCP can also admit a solution in which
    a receding pusher drags the object, and this order picks separation, the physical answer."""
    combos = np.array(list(itertools.product(range(4), repeat=m)), dtype=int)
    key = (combos != 0).sum(1) * 10 + (combos >= 2).sum(1)
    return combos[np.argsort(key, kind="stable")]


def _feasible_forces(
    g: np.ndarray, b: np.ndarray, mu: np.ndarray, patterns: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """For each sample, whether one of ``patterns`` (P, m) satisfies the LCP conditions, and
    the contact forces (N, 2m) of the first that does."""
    big_n, m = len(g), patterns.shape[1]
    n_pat = len(patterns)
    k = np.zeros((big_n, n_pat, 2 * m, 2 * m))
    h = np.zeros((big_n, n_pat, 2 * m))
    eye = np.eye(2 * m)
    for i in range(m):
        rn, rt = 2 * i, 2 * i + 1
        mode = patterns[:, i][None, :, None]  # (1, P, 1)
        sigma = np.where(mode == 2, 1.0, -1.0)
        k[:, :, rn] = np.where(mode == 0, eye[rn], g[:, None, rn])
        slide_row = eye[rt] + sigma * mu[:, None, None] * eye[rn]
        k[:, :, rt] = np.where(mode == 0, eye[rt], np.where(mode == 1, g[:, None, rt], slide_row))
        h[:, :, rn] = np.where(mode[..., 0] == 0, 0.0, b[:, None, rn])
        h[:, :, rt] = np.where(mode[..., 0] == 1, b[:, None, rt], 0.0)
    f = _solve_patterns(k + 1e-10 * eye, h)  # (N, P, 2m)
    u = (g[:, None] @ f[..., None])[..., 0] - b[:, None]  # relative (normal, tangent) velocity
    tol = 1e-7 * (1.0 + np.abs(f).max(-1) + np.abs(b).max(-1)[:, None])  # (N, P)
    fn, ft, un, ut = f[..., 0::2], f[..., 1::2], u[..., 0::2], u[..., 1::2]
    modes = patterns[None]
    sigma = np.where(modes == 2, 1.0, -1.0)
    t3 = tol[..., None]
    feasible = np.where(
        modes == 0,
        un >= -t3,
        (fn >= -t3)
        & np.where(modes == 1, np.abs(ft) <= mu[:, None, None] * fn + t3, sigma * ut >= -t3),
    ).all(-1)
    first = np.argmax(feasible, axis=1)
    return feasible.any(1), f[np.arange(big_n), first]


def _solve_patterns(k: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Batched k f = h; the singular systems (degenerate patterns, e.g. two slides on one
    point) get the pseudo-inverse, the rest an LU solve, so one degenerate pattern does not
    send the whole batch through an SVD."""
    singular = ~(np.abs(np.linalg.det(k)) > 0.0)
    f = np.empty_like(h)
    regular = ~singular
    if regular.any():
        f[regular] = np.linalg.solve(k[regular], h[regular][..., None])[..., 0]
    if singular.any():
        f[singular] = (np.linalg.pinv(k[singular]) @ h[singular][..., None])[..., 0]
    return f


def solve_contacts(
    r: np.ndarray,
    n: np.ndarray,
    vp: np.ndarray,
    mu: np.ndarray | float,
    c: np.ndarray | float,
) -> ContactSolution:
    """Twist of an object under m simultaneous point contacts, batched over N samples.

    r, n, vp: (N, m, 2) in the object frame; mu, c: scalars or (N,). Forces are not unique when
    contacts are redundant (a face on a face); a 1e-10 ridge picks one, the twist is unique.
    """
    r, n, vp = (np.asarray(a, float) for a in (r, n, vp))
    big_n, m = r.shape[:2]
    mu = np.broadcast_to(np.asarray(mu, float), (big_n,))
    c = np.broadcast_to(np.asarray(c, float), (big_n,))
    t = np.stack([-n[..., 1], n[..., 0]], axis=-1)
    jac = contact_jacobian(r)  # (N, m, 2, 3)
    dirs = np.stack([n, t], axis=-1)  # (N, m, 2, 2): columns n, t
    w = np.einsum("nmkj,nmkd->njmd", jac, dirs).reshape(big_n, 3, 2 * m)  # W = [J^T n, J^T t]
    a_diag = np.stack([np.ones(big_n), np.ones(big_n), 1.0 / c**2], axis=1)
    aw = a_diag[:, :, None] * w
    g = np.swapaxes(w, 1, 2) @ aw  # (N, 2m, 2m)
    b = np.einsum("nmk,nmkd->nmd", vp, dirs).reshape(big_n, 2 * m)  # (n.vp, t.vp)
    patterns = _mode_patterns(m)  # (P, m), simplest first
    # Patterns are tried in blocks of equal simplicity, each only for the samples still without
    # a feasible one: the first feasible pattern in order is the same as trying all at once,
    # and most samples settle in the first blocks (4^m patterns for m contacts otherwise).
    active = (patterns != 0).sum(1)
    forces = np.zeros((big_n, 2 * m))
    pending = np.ones(big_n, dtype=bool)
    for level in range(m + 1):
        rows = np.flatnonzero(pending)
        if not rows.size:
            break
        block = patterns[active == level]
        found, f = _feasible_forces(g[rows], b[rows], mu[rows], block)
        forces[rows[found]] = f[found]
        pending[rows[found]] = False
    twist = (aw @ forces[..., None])[..., 0]
    return ContactSolution(twist, forces.reshape(big_n, m, 2), pending)
