"""Capture regions of push-grasps and sweeps (Dogar & Srinivasa §2.2, Figs 7, 9, 10; App. A).

Why the representation is 2D for a 3D region: in the hand frame an object ahead of the hand only
translates (along -x) until something touches it, so every pose (x, y, theta) lies on the
trajectory of the pose (x_start, y, theta) started just ahead of the hand. One simulated push per
(y, theta) node therefore gives the whole x line: the push distance ``s_req`` from x_start until
the object is captured (and stays captured) and ``s_contact`` until it is first touched. A pose at
x needs d = s_req - (x_start - x) (the paper's d = D_max - d_sub, Fig. 10; d <= 0 means already
in the hand, d = 0) and lies in the region of a push of length D iff d <= D. The region of a
shorter push is the longer one shifted toward the hand (Fig. 9c), so regions are nested.

Conservative parameters: cylinders use rim pressure (c = R) and a very high finger friction,
which Appendix A proves needs the longest push of every rotationally symmetric pressure and
every lower mu_c. Boxes have no such result: each node takes the worst case (longest push,
earliest contact) over a grid of mu_c and pressure distributions.

Aperture: §2.2.3 shifts one region sideways for other apertures, assuming fingertip contact
surfaces that do not change. On the BH-280 the aperture is set by curling the fingers, which
turns the finger links, so the pocket's walls change; regions are computed per aperture (one
per cache file, about a second each for cylinders) instead of being shifted.
"""

from __future__ import annotations

import hashlib
import io
import itertools
import json
import math
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from clutter_gym.files import atomic_write_bytes, cache_dir
from clutter_gym.objects import Footprint
from planners.hand2d import (
    MAX_APERTURE,
    PushGraspProfile,
    SweepProfile,
    check_fits,
    default_aperture,
    push_grasp_profile,
    sweep_profile,
)
from planners.pushing import (
    DiscPressure,
    Pusher,
    PushState,
    RectanglePressure,
    RimPressure,
    SampledPressure,
    simulate_push,
)

CACHE_VERSION = 1
"""Bump when the simulation changes: it is part of every cache file's hash."""


@dataclass(frozen=True)
class CaptureSettings:
    """Everything besides the object and aperture that a region depends on (all in the hash)."""

    d_max: float = 1.0  # the paper's D_max
    step: float = 1e-3  # pusher step of the simulation
    y_resolution: float = 0.0025  # lateral grid spacing of cylinders
    box_y_resolution: float = 0.01  # lateral grid spacing of boxes
    box_thetas: int = 12  # orientations of boxes over [0, pi)
    cylinder_mu: float = 100.0  # "very high mu_c" (Appendix A)
    box_mus: tuple[float, ...] = (0.1, 0.3, 1.0, 3.0)

    def __post_init__(self) -> None:
        for name in ("d_max", "step", "y_resolution", "box_y_resolution", "cylinder_mu"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"CaptureSettings.{name} must be positive and finite, got {value}")
        if self.box_thetas < 1:
            raise ValueError(f"CaptureSettings.box_thetas must be >= 1, got {self.box_thetas}")
        if not self.box_mus or not all(math.isfinite(m) and m > 0 for m in self.box_mus):
            raise ValueError(f"CaptureSettings.box_mus must be positive, got {self.box_mus}")


def parameter_sets(footprint: Footprint, settings: CaptureSettings) -> tuple[np.ndarray, ...]:
    """(mu_c, c) pairs the region must hold for: one conservative pair for a cylinder; for a box
    every mu_c with pressure spread uniformly, at the corners (largest c) and near the centre."""
    if footprint.shape == "circle":
        return np.array([settings.cylinder_mu]), np.array([RimPressure(footprint.radius).c])
    hx, hy = footprint.half_extents
    corners = ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
    cs = (
        RectanglePressure((hx, hy)).c,
        SampledPressure(corners, (1.0, 1.0, 1.0, 1.0)).c,
        DiscPressure(min(hx, hy) / 2).c,
    )
    pairs = np.array(list(itertools.product(settings.box_mus, cs)))
    return pairs[:, 0], pairs[:, 1]


def _theta_grid(footprint: Footprint, settings: CaptureSettings) -> np.ndarray:
    if footprint.shape == "circle":
        return np.zeros(1)
    return np.arange(settings.box_thetas) * (np.pi / settings.box_thetas)


def _check_poses(poses: np.ndarray) -> np.ndarray:
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"poses must have shape (N, 3) as (x, y, theta), got {p.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(p), axis=1))
    if bad.size:
        raise ValueError(f"poses contain NaN or inf at rows {bad[:10].tolist()}")
    return p


@dataclass(frozen=True, eq=False)
class _Grid:
    """Per-node push distances over a (y, theta) grid, with conservative cell lookup."""

    y0: float
    dy: float
    theta_period: float  # pi for boxes, 0 for cylinders (theta ignored)
    x_start: float

    @classmethod
    def of(cls, footprint: Footprint, arrays: dict[str, np.ndarray]) -> _Grid:
        """The grid of built region arrays (boxes repeat every pi in theta)."""
        ys = arrays["ys"]
        period = np.pi if footprint.shape == "box" else 0.0
        return cls(float(ys[0]), float(ys[1] - ys[0]), period, float(arrays["x_start"]))

    def cells(self, poses: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
        """Flat indices (N, 4) of the nodes around each pose, and whether the cell exists."""
        ny, nt = shape
        fy = (poses[:, 1] - self.y0) / self.dy
        i0 = np.floor(fy).astype(int)
        ok = (i0 >= 0) & (i0 + 1 <= ny - 1)
        i0 = np.clip(i0, 0, ny - 2)
        if self.theta_period:
            ft = np.mod(poses[:, 2], self.theta_period) / (self.theta_period / nt)
            j0 = np.floor(ft).astype(int) % nt
            j1 = (j0 + 1) % nt
        else:
            j0 = j1 = np.zeros(len(poses), dtype=int)
        flat = np.stack([i0 * nt + j0, (i0 + 1) * nt + j0, i0 * nt + j1, (i0 + 1) * nt + j1], 1)
        return flat, ok


@dataclass(frozen=True, eq=False)
class CaptureRegion:
    """Push-grasp capture region of one object and aperture, hand-centric (§2.2.3).

    Frame: `planners.hand2d` push-grasp frame (x along the push, hand_base at the origin).
    ``s_req`` / ``s_contact``: (ny, ntheta) push distances from x_start, inf where the push
    fails within the simulated length.
    """

    footprint: Footprint
    aperture: float
    d_max: float
    grid: _Grid
    s_req: np.ndarray
    s_contact: np.ndarray
    grasp_line: float
    half_gap: float
    mus: np.ndarray
    cs: np.ndarray
    step: float

    def query(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(inside, push_distance) for object poses (N, 3) in the hand frame.

        A pose is inside only if all grid nodes around it succeed and it lies on their
        trajectories (not inside or behind the hand); its distance is the worst of the nodes,
        0 when the object is already in the hand. Outside poses get distance inf.
        """
        p = _check_poses(poses)
        flat, ok = self.grid.cells(p, self.s_req.shape)
        s_req = self.s_req.ravel()[flat].max(1)
        x_contact = self.grid.x_start - self.s_contact.ravel()[flat].min(1)
        d = np.maximum(s_req - (self.grid.x_start - p[:, 0]), 0.0)
        inside = ok & np.isfinite(s_req) & (p[:, 0] >= x_contact) & (d <= self.d_max)
        return inside, np.where(inside, d, np.inf)

    def contains(self, poses: np.ndarray, push_distance: float) -> np.ndarray:
        """Membership in the region of a push of ``push_distance`` (<= D_max): nested in it."""
        if not 0.0 <= push_distance <= self.d_max:
            raise ValueError(f"push_distance {push_distance!r} must be in [0, {self.d_max}]")
        inside, d = self.query(poses)
        return inside & (d <= push_distance)

    def evolve(
        self,
        poses: np.ndarray,
        push_distance: float,
        stages: int,
        step: float | None = None,
        parameters: np.ndarray | None = None,
    ) -> np.ndarray:
        """ν_o (§2.2.7) for sample poses (N, 3): their poses in the moving hand's frame after
        each of ``stages`` equal parts of the push, under every (mu_c, c) the region was built
        for, shape (stages + 1, P, N, 3). Stage k's hand has advanced k * push_distance / stages
        along its x; the union of the footprints over stages and P bounds the volume the object
        sweeps. Poses of shape (P, N, 3), one row per (mu_c, c), continue an evolution.
        ``step`` overrides the simulation step the region was built with; ``parameters``
        selects (mu_c, c) sets by index (default all; see `extreme_parameters`)."""
        chosen = slice(None) if parameters is None else parameters
        return _evolve(
            self.footprint,
            push_grasp_profile(self.aperture).pusher,
            poses,
            push_distance,
            stages,
            self.mus[chosen],
            self.cs[chosen],
            step or self.step,
        )


def extreme_parameters(mus: np.ndarray, cs: np.ndarray) -> np.ndarray:
    """Indices of the (mu_c, c) sets at the corners of the grid (lowest and highest finger
    friction with the most and least concentrated pressure): a quarter of a box's sets, which
    bound the spread of the pushed motion in practice, for estimating nu_o quickly."""
    wanted = {(mu, c) for mu in (mus.min(), mus.max()) for c in (cs.min(), cs.max())}
    return np.array([i for i, pair in enumerate(zip(mus, cs, strict=True)) if pair in wanted])


def _evolve(
    footprint: Footprint,
    pusher: Pusher,
    poses: np.ndarray,
    distance: float,
    stages: int,
    mus: np.ndarray,
    cs: np.ndarray,
    step: float,
) -> np.ndarray:
    n_par = len(mus)
    raw = np.asarray(poses, dtype=float)
    if raw.ndim == 3:  # (P, N, 3): continuing an evolution, one row of poses per (mu_c, c)
        if raw.shape[0] != n_par:
            raise ValueError(f"poses have {raw.shape[0]} parameter rows; the region has {n_par}")
        tiled = _check_poses(raw.reshape(-1, 3))
    else:
        tiled = np.tile(_check_poses(raw), (n_par, 1))
    n = len(tiled) // n_par
    if not (math.isfinite(distance) and distance >= 0) or stages < 1:
        raise ValueError(f"distance must be >= 0 (got {distance}) and stages >= 1 (got {stages})")
    checkpoints = np.linspace(0.0, distance, stages + 1)[1:]
    result = simulate_push(
        footprint,
        pusher,
        tiled,
        np.repeat(mus, n),
        np.repeat(cs, n),
        distance,
        step,
        record=checkpoints,
    )
    out = np.concatenate([tiled[None], result.recorded], axis=0)
    return out.reshape(stages + 1, n_par, n, 3)


@dataclass(frozen=True, eq=False)
class SweepRegion:
    """Sweep capture region (Fig. 7b) in the `planners.hand2d` sweep frame: the object must be
    touched by the sweep and keep its centre within ``span`` along y while being pushed."""

    footprint: Footprint
    aperture: float
    d_max: float
    grid: _Grid
    s_contact: np.ndarray
    s_escape: np.ndarray
    span: tuple[float, float]
    mus: np.ndarray
    cs: np.ndarray
    step: float

    def query(
        self, poses: np.ndarray, distance: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """(inside, contact_distance) for a sweep of ``distance`` (default D_max): inside if
        the sweep reaches the object and does not lose it before the end; contact_distance is
        how far the hand travels before touching it (0 if already touching)."""
        p = _check_poses(poses)
        distance = self.d_max if distance is None else distance
        if not 0.0 <= distance <= self.d_max:
            raise ValueError(f"sweep distance {distance!r} must be in [0, {self.d_max}]")
        flat, ok = self.grid.cells(p, self.s_contact.shape)
        shift = p[:, 0] - self.grid.x_start
        contact = self.s_contact.ravel()[flat].max(1) + shift
        escape = self.s_escape.ravel()[flat].min(1) + shift
        inside = ok & (contact >= 0) & (contact <= distance) & (escape > distance)
        return inside, np.where(inside, contact, np.inf)

    def evolve(
        self,
        poses: np.ndarray,
        distance: float,
        stages: int,
        step: float | None = None,
        parameters: np.ndarray | None = None,
    ) -> np.ndarray:
        """ν_o of a sweep: sweep-frame poses after each of ``stages`` equal parts of a sweep
        of ``distance``, under every (mu_c, c), shape (stages + 1, P, N, 3) (see
        `CaptureRegion.evolve`)."""
        chosen = slice(None) if parameters is None else parameters
        return _evolve(
            self.footprint,
            sweep_profile(self.aperture).pusher,
            poses,
            distance,
            stages,
            self.mus[chosen],
            self.cs[chosen],
            step or self.step,
        )


# --------------------------------------------------------------------------------------------
# Building
# --------------------------------------------------------------------------------------------
def _y_grid(lo: float, hi: float, resolution: float) -> np.ndarray:
    n = max(math.ceil((hi - lo) / resolution) + 1, 2)
    return np.linspace(lo, hi, n)


def _start_poses(x_start: float, ys: np.ndarray, thetas: np.ndarray, n_par: int) -> np.ndarray:
    yy, tt = np.meshgrid(ys, thetas, indexing="ij")
    nodes = np.column_stack([np.full(yy.size, x_start), yy.ravel(), tt.ravel()])
    return np.tile(nodes, (n_par, 1))


@dataclass(frozen=True)
class _StartGrid:
    """Push starts: every (y, theta) node just ahead of the hand, once per parameter set."""

    x_start: float
    ys: np.ndarray
    thetas: np.ndarray
    mus: np.ndarray
    cs: np.ndarray

    @property
    def poses(self) -> np.ndarray:
        return _start_poses(self.x_start, self.ys, self.thetas, len(self.mus))

    def parameters(self) -> tuple[np.ndarray, np.ndarray]:
        """(mu_c, c) of every start pose, in `poses` order."""
        nodes = len(self.ys) * len(self.thetas)
        return np.repeat(self.mus, nodes), np.repeat(self.cs, nodes)

    def per_node(self, values: np.ndarray) -> np.ndarray:
        """Per-pose values as (parameter set, y, theta)."""
        return values.reshape(len(self.mus), len(self.ys), len(self.thetas))


def _start_grid(
    footprint: Footprint, x_front: float, y_range: tuple[float, float], settings: CaptureSettings
) -> _StartGrid:
    res = settings.y_resolution if footprint.shape == "circle" else settings.box_y_resolution
    mus, cs = parameter_sets(footprint, settings)
    return _StartGrid(
        x_start=x_front + footprint.bounding_radius + 2 * settings.step,
        ys=_y_grid(*y_range, res),
        thetas=_theta_grid(footprint, settings),
        mus=mus,
        cs=cs,
    )


def _build_push_grasp(
    footprint: Footprint, hand: PushGraspProfile, settings: CaptureSettings
) -> dict[str, np.ndarray]:
    _, x_front, _, y_max = hand.pusher.bounds
    reach = y_max + footprint.bounding_radius
    grid = _start_grid(footprint, x_front, (-reach, reach), settings)
    poses = grid.poses
    total = len(poses)
    tip_r = hand.pusher.circles[0].radius
    captured = np.zeros(total, dtype=bool)
    s_cap = np.zeros(total)
    s_req = np.full(total, np.inf)
    s_contact = np.full(total, np.inf)

    def watch(state: PushState) -> np.ndarray:
        ids, s = state.ids, state.pushed
        first = state.touching & np.isinf(s_contact[ids])
        s_contact[ids[first]] = np.maximum(s[first] - settings.step, 0.0)
        x = state.poses[:, 0]
        now = (x <= hand.grasp_line) & (np.abs(state.poses[:, 1]) <= hand.half_gap)
        new = now & ~captured[ids]
        # A free jump is a pure translation along -x: it crossed the grasp line exactly
        # grasp_line - x ago. In contact, keep the step's end (at most one step late).
        late = np.where(state.touching, 0.0, hand.grasp_line - x)
        s_cap[ids[new]] = (s - late)[new]
        captured[ids] = now
        settled = state.stationary
        s_req[ids[settled & now]] = s_cap[ids[settled & now]]
        # Behind the grasp line and outside the fingertips: the fingers keep it out for good.
        beside = (x < hand.grasp_line) & (np.abs(state.poses[:, 1]) > hand.half_gap + 2 * tip_r)
        return settled | beside

    length = settings.d_max + grid.x_start
    mu_all, c_all = grid.parameters()
    result = simulate_push(
        footprint, hand.pusher, poses, mu_all, c_all, length, settings.step, watch=watch
    )
    open_end = np.isinf(s_req) & captured & (result.pushed >= length - 1e-9)
    s_req[open_end] = s_cap[open_end]
    return {
        "ys": grid.ys,
        "thetas": grid.thetas,
        "x_start": np.array(grid.x_start),
        "s_req": grid.per_node(s_req).max(0),
        "s_contact": grid.per_node(s_contact).min(0),
    }


def _build_sweep(
    footprint: Footprint, hand: SweepProfile, settings: CaptureSettings
) -> dict[str, np.ndarray]:
    _, x_front, _, _ = hand.pusher.bounds
    lo, hi = hand.span
    grid = _start_grid(footprint, x_front, (lo, hi), settings)
    poses = grid.poses
    total = len(poses)
    s_contact = np.full(total, np.inf)
    s_escape = np.full(total, np.inf)

    def watch(state: PushState) -> np.ndarray:
        ids, s, y = state.ids, state.pushed, state.poses[:, 1]
        first = state.touching & np.isinf(s_contact[ids])
        s_contact[ids[first]] = np.maximum(s[first] - settings.step, 0.0)
        lost = (y < lo) | (y > hi)
        s_escape[ids[lost]] = s[lost]
        return lost | state.stationary

    length = settings.d_max + grid.x_start
    mu_all, c_all = grid.parameters()
    simulate_push(footprint, hand.pusher, poses, mu_all, c_all, length, settings.step, watch=watch)
    return {
        "ys": grid.ys,
        "thetas": grid.thetas,
        "x_start": np.array(grid.x_start),
        "s_contact": grid.per_node(s_contact).min(0),
        "s_escape": grid.per_node(s_escape).min(0),
    }


# --------------------------------------------------------------------------------------------
# Cache
# --------------------------------------------------------------------------------------------
def default_cache_dir() -> Path:
    return cache_dir() / "capture"


SHIPPED_DIR = Path(__file__).parent / "data" / "capture"
"""Regions precomputed offline (the paper does the same, once per object) and shipped with the
package: the default push-grasp of every graspable object and the sweep of every object. They
are looked up by the same key as the user cache, so a change to the simulation or settings
misses them and rebuilds; ``python -m planners.capture`` regenerates them."""


def _cache_key(kind: str, footprint: Footprint, aperture: float, settings: CaptureSettings) -> str:
    spec = {
        "version": CACHE_VERSION,
        "kind": kind,
        "footprint": [footprint.shape, footprint.radius, list(footprint.half_extents)],
        "aperture": aperture,
        "settings": asdict(settings),
    }
    return json.dumps(spec, sort_keys=True)


def cache_name(kind: str, footprint: Footprint, aperture: float, settings: CaptureSettings) -> str:
    """File name of a region in a cache (or in `SHIPPED_DIR`): a hash of every parameter."""
    digest = hashlib.sha256(_cache_key(kind, footprint, aperture, settings).encode()).hexdigest()
    return f"{kind}_{footprint.shape}_{digest[:16]}.npz"


_FINITE = ("ys", "thetas", "x_start")
"""Arrays of a region that must be finite; the push distances may be inf (never NaN)."""


def _cached(
    kind: str,
    footprint: Footprint,
    aperture: float,
    settings: CaptureSettings,
    cache_dir: Path | None,
    build: Callable[[], dict[str, np.ndarray]],
) -> dict[str, np.ndarray]:
    """The arrays for this exact key: the shipped copy, else the cache's, else built and cached.

    The hash of every parameter is in the file name and the full key inside it. A copy that
    cannot be read, holds another key or bad values is passed over with a warning, never
    trusted and never fatal; a cache that cannot be written only costs a rebuild next time.
    """
    key = _cache_key(kind, footprint, aperture, settings)
    directory = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    name = cache_name(kind, footprint, aperture, settings)
    places = ([SHIPPED_DIR / name] if cache_dir is None else []) + [directory / name]
    for place in places:
        arrays = _load(place, key)
        if arrays is not None:
            return arrays
    arrays = build()
    buffer = io.BytesIO()
    np.savez(buffer, key=np.array(key), **arrays)  # type: ignore[arg-type]  # numpy's hints reject **arrays
    try:
        atomic_write_bytes(directory / name, buffer.getvalue())
    except OSError as error:
        warnings.warn(
            f"capture region cache {directory / name} could not be written ({error}); the "
            "region was built and is used, but will be built again next time",
            stacklevel=3,
        )
    return arrays


def _load(path: Path, key: str) -> dict[str, np.ndarray] | None:
    """The arrays of a cache file with this key, or None (missing, unreadable or bad)."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["key"]) != key:
                return None
            arrays = {k: data[k] for k in data.files if k != "key"}
        problem = _bad_arrays(arrays)
    except Exception as error:  # any broken copy: truncated, a flipped byte, a directory
        problem = f"{type(error).__name__}: {error}"
    if not problem:
        return arrays
    warnings.warn(
        f"capture region cache {path} is unusable ({problem}); not using it",
        stacklevel=4,
    )
    return None


def _bad_arrays(arrays: dict[str, np.ndarray]) -> str:
    """Why a loaded region is not one `_build_*` could have written, or ""."""
    for name, values in arrays.items():
        if not np.issubdtype(values.dtype, np.floating):
            return f"{name} is not a float array"
        if np.isnan(values).any() or (name in _FINITE and not np.isfinite(values).all()):
            return f"{name} holds NaN or inf"
    if "ys" not in arrays or arrays["ys"].ndim != 1 or len(arrays["ys"]) < 2:
        return "the lateral grid is missing"
    return ""


def push_grasp_region(
    footprint: Footprint,
    aperture: float,
    settings: CaptureSettings | None = None,
    cache_dir: Path | None = None,
) -> CaptureRegion:
    """The push-grasp capture region of an object outline at a hand aperture (m), cached."""
    settings = settings or CaptureSettings()
    check_fits(footprint, aperture)
    hand = push_grasp_profile(aperture)
    arrays = _cached(
        "push_grasp",
        footprint,
        aperture,
        settings,
        cache_dir,
        lambda: _build_push_grasp(footprint, hand, settings),
    )
    mus, cs = parameter_sets(footprint, settings)
    return CaptureRegion(
        footprint,
        aperture,
        settings.d_max,
        _Grid.of(footprint, arrays),
        arrays["s_req"],
        arrays["s_contact"],
        hand.grasp_line,
        hand.half_gap,
        mus,
        cs,
        settings.step,
    )


def sweep_region(
    footprint: Footprint,
    aperture: float = MAX_APERTURE,
    settings: CaptureSettings | None = None,
    cache_dir: Path | None = None,
) -> SweepRegion:
    """The sweep capture region of an object outline (any size), fingers at ``aperture``."""
    settings = settings or CaptureSettings()
    sizes = (footprint.radius,) if footprint.shape == "circle" else footprint.half_extents
    if footprint.shape not in ("circle", "box") or not all(
        math.isfinite(s) and s > 0 for s in sizes
    ):
        raise ValueError(f"footprint sizes must be positive and finite, got {footprint!r}")
    hand = sweep_profile(aperture)
    arrays = _cached(
        "sweep",
        footprint,
        aperture,
        settings,
        cache_dir,
        lambda: _build_sweep(footprint, hand, settings),
    )
    mus, cs = parameter_sets(footprint, settings)
    return SweepRegion(
        footprint,
        aperture,
        settings.d_max,
        _Grid.of(footprint, arrays),
        arrays["s_contact"],
        arrays["s_escape"],
        hand.span,
        mus,
        cs,
        settings.step,
    )


def push_grasp_apertures(footprint: Footprint) -> tuple[float, ...]:
    """The apertures the planner searches (§2.2.6): the object's width plus a margin, and for
    cylinders also the widest (a region per aperture; box regions take a minute each, so boxes
    use one)."""
    default = default_aperture(footprint)
    if footprint.shape == "circle" and MAX_APERTURE - default > 0.02:
        return (default, MAX_APERTURE)
    return (default,)


def precompute(directory: Path) -> list[Path]:
    """Build the shipped regions into ``directory``: the default push-grasp of every graspable
    object and the sweep of every object (the planner's action library uses exactly these)."""
    from clutter_gym.objects import OBJECTS

    for spec in tqdm(OBJECTS.values(), desc="capture regions", unit="object"):
        if spec.graspable:
            for aperture in push_grasp_apertures(spec.footprint):
                push_grasp_region(spec.footprint, aperture, cache_dir=directory)
        sweep_region(spec.footprint, cache_dir=directory)
    return sorted(directory.glob("*.npz"))


if __name__ == "__main__":
    for written in precompute(SHIPPED_DIR):
        print(written)
