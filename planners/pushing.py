"""Quasi-static planar pushing with an ellipsoidal limit surface (Howe & Cutkosky; Lynch).

Why this module exists: capture regions (`planners.capture`) need thousands of push simulations,
so every solver here takes batches of samples; the per-sample arithmetic is compiled
(`planners.push_kernels`). Conventions: the object frame sits at the centre of friction, a twist
is ``(vx, vy, omega)`` in that frame, contact normals point from the pusher into the object, and
``A = diag(1, 1, 1/c^2)``.

Several simultaneous contacts are solved as the contact LCP (Stewart & Trinkle) by enumerating,
for each contact, the four complementarity patterns of its ``(f_n, f_t+, f_t-, lambda)`` block
(separate, stick, slide +t, slide -t): with at most four contacts that is at most 256 small
linear systems, tried simplest first until one is feasible, and an exhaustive enumeration never
misses a solution the way a pivoting method with a degenerate start can. No solution means the
contacts jam.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from planners import push_kernels
from planners.push_kernels import MAX_CONTACTS


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


def single_contact_twist(
    r: np.ndarray,
    n: np.ndarray,
    vp: np.ndarray,
    mu: np.ndarray | float,
    c: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray]:
    """Object twist and contact mode (`push_kernels.SEPARATE`, STICK or SLIDE) of one point
    contact, batched.

    The three cases of a point contact: the sticking force f* = B^-1 v_p decides between
    sticking and sliding on the friction-cone edge that f* lies beyond.
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, float) for a in (r, n, vp)))
    shape = arrays[0].shape[:-1]
    r, n, vp = (np.ascontiguousarray(a.reshape(-1, 2)) for a in arrays)
    mu, c = (
        np.ascontiguousarray(np.broadcast_to(np.asarray(a, float), shape).ravel()) for a in (mu, c)
    )
    twist, mode = push_kernels.one_contact_batch(r, n, vp, mu, c)
    return twist.reshape(*shape, 3), mode.reshape(shape)


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


PATTERNS = tuple(_mode_patterns(m) for m in range(MAX_CONTACTS + 1))
"""`_mode_patterns` of 0 to MAX_CONTACTS contacts, made once."""


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
    Each sample takes the first feasible complementarity pattern, fewest active contacts first.
    """
    r, n, vp = (np.ascontiguousarray(a, dtype=float) for a in (r, n, vp))
    big_n, m = r.shape[:2]
    if not 1 <= m <= MAX_CONTACTS:
        raise ValueError(f"solve_contacts takes 1 to {MAX_CONTACTS} contacts, got m = {m}")
    mu = np.ascontiguousarray(np.broadcast_to(np.asarray(mu, float), (big_n,)))
    c = np.ascontiguousarray(np.broadcast_to(np.asarray(c, float), (big_n,)))
    twist, forces, jammed = push_kernels.lcp_batch(r, n, vp, mu, c, PATTERNS[m])
    return ContactSolution(twist, forces.reshape(big_n, m, 2), jammed)


def warm_up() -> None:
    """Compile the batched solvers' kernels (or load them from numba's cache): one contact and
    two, each for a single sample (`push_simulation.warm_up` calls this)."""
    r = np.array([[[0.0, -0.01], [0.0, 0.01]]])
    n = np.array([[[1.0, 0.0], [1.0, 0.0]]])
    single_contact_twist(r[:, 0], n[:, 0], n[:, 0], 0.5, 0.02)
    solve_contacts(r, n, n, 0.5, 0.02)
