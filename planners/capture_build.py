"""Building capture regions by simulation, and their cache.

One simulated push per (y, theta) node of a grid just ahead of the hand gives the whole line of
poses behind it (`planners.capture` explains why); the arrays of a region are cached on disk
under a hash of every parameter, shipped with the package for the regions the planner uses.
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

from clutter_gym.model.files import atomic_write_bytes, cache_dir
from clutter_gym.model.objects import Footprint
from planners.hand2d import PALM_FRONT, PushGraspProfile, SweepProfile, grasp_depth, palm_seat
from planners.push_simulation import PushState, simulate_push
from planners.pushing import DiscPressure, RectanglePressure, RimPressure, SampledPressure

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


def theta_grid(footprint: Footprint, settings: CaptureSettings) -> np.ndarray:
    if footprint.shape == "circle":
        return np.zeros(1)
    return np.arange(settings.box_thetas) * (np.pi / settings.box_thetas)


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
        thetas=theta_grid(footprint, settings),
        mus=mus,
        cs=cs,
    )


def build_push_grasp(
    footprint: Footprint, hand: PushGraspProfile, settings: CaptureSettings
) -> dict[str, np.ndarray]:
    _, x_front, _, y_max = hand.pusher.bounds
    reach = y_max + footprint.bounding_radius
    grid = _start_grid(footprint, x_front, (-reach, reach), settings)
    poses = grid.poses
    total = len(poses)
    tip_r = hand.pusher.circles[0].radius
    # Captured: the centre within the gap and behind the line at which closing fingers hold
    # an object that nothing touches (`grasp_depth` behind the fingertips), or behind the
    # fingertips while carried by the hand; settled against the hand from then on. In a V
    # preshape a box is captured once it has come to the palm (`palm_seat`), wherever the
    # fingertips stand: end-on its centre is then up to 3 cm ahead of them, and closing holds
    # it (`planners.hand2d.TURN_SEAT`).
    line = hand.grasp_line - grasp_depth(footprint, hand.aperture)
    seat = palm_seat(footprint, hand.aperture)
    hx, hy = footprint.half_extents

    def capture_lines(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The centre's x behind which an object at ``theta`` counts as captured: free (nothing
        touching it) and carried by the hand."""
        if seat is None:
            return np.full(theta.shape, line), np.full(theta.shape, hand.grasp_line)
        seated = PALM_FRONT + seat + hx * np.abs(np.cos(theta)) + hy * np.abs(np.sin(theta))
        return seated, seated

    captured = np.zeros(total, dtype=bool)
    s_cap = np.zeros(total)
    s_req = np.full(total, np.inf)
    s_contact = np.full(total, np.inf)

    def watch(state: PushState) -> np.ndarray:
        ids, s = state.ids, state.pushed
        first = state.touching & np.isinf(s_contact[ids])
        s_contact[ids[first]] = np.maximum(s[first] - settings.step, 0.0)
        x = state.poses[:, 0]
        free_line, carried_line = capture_lines(state.poses[:, 2])
        carried = state.stationary & (x <= carried_line)
        crossed = x <= free_line
        now = (crossed | carried) & (np.abs(state.poses[:, 1]) <= hand.half_gap)
        new = now & ~captured[ids]
        # A free jump is a pure translation along -x: it crossed the line exactly
        # line - x ago. In contact, keep the step's end (at most one step late).
        late = np.where(state.touching, 0.0, free_line - x)
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


def build_sweep(
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
    if kind == "push_grasp":  # each only where it applies: regions built before keep keys
        if depth := grasp_depth(footprint, aperture):
            spec["grasp_depth"] = depth
        if (seat := palm_seat(footprint, aperture)) is not None:
            spec["palm_seat"] = seat
    return json.dumps(spec, sort_keys=True)


def cache_name(kind: str, footprint: Footprint, aperture: float, settings: CaptureSettings) -> str:
    """File name of a region in a cache (or in `SHIPPED_DIR`): a hash of every parameter."""
    digest = hashlib.sha256(_cache_key(kind, footprint, aperture, settings).encode()).hexdigest()
    return f"{kind}_{footprint.shape}_{digest[:16]}.npz"


_FINITE = ("ys", "thetas", "x_start")
"""Arrays of a region that must be finite; the push distances may be inf (never NaN)."""


def cached_arrays(
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
