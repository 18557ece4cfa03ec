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

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
from tqdm import tqdm

from clutter_gym.model.objects import Footprint
from planners.capture_build import (
    SHIPPED_DIR,
    CaptureSettings,
    build_push_grasp,
    build_sweep,
    cache_name,
    cached_arrays,
    parameter_sets,
)
from planners.hand2d import (
    MAX_APERTURE,
    STRAIGHT_APERTURE,
    check_fits,
    check_footprint,
    default_aperture,
    push_grasp_profile,
    sweep_profile,
)
from planners.push_simulation import Pusher, simulate_push

PUSH_MARGIN = 0.01
"""m a push-grasp pushes a cylinder beyond its capture region's need (a true pose just outside
the samples; the quasi-static model's last millimetres)."""
BOX_PUSH_MARGIN = 0.02
"""m a push-grasp pushes a box beyond its need: a poptart box standing 78-82 deg to the push
(nearly across the hand) in the 0.151 and 0.192 m preshapes is still turning into the palm at
its need plus `PUSH_MARGIN`, and closing there toppled it in 7 of 30 pybullet pushes; 1 cm
further held all 30, and validation at 5 deg found no failure inside with this margin
(docs/results.md, "the 80 deg band")."""


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

    def cell(self, poses: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """The flat index (N,) of each pose's cell in an `over_cells` array of node values of
        ``shape``, and whether the cell exists."""
        ny, nt = shape
        fy = (poses[:, 1] - self.y0) / self.dy
        i0 = np.floor(fy).astype(int)
        ok = (i0 >= 0) & (i0 + 1 <= ny - 1)
        i0 = np.clip(i0, 0, ny - 2)
        if self.theta_period:
            ft = np.mod(poses[:, 2], self.theta_period) / (self.theta_period / nt)
            j0 = np.floor(ft).astype(int) % nt
        else:
            j0 = np.zeros(len(poses), dtype=int)
        return i0 * nt + j0, ok

    def over_cells(self, values: np.ndarray, reduce: np.ufunc) -> np.ndarray:
        """``reduce`` (np.maximum or np.minimum) of node ``values`` (ny, nt) over the four
        nodes around each cell, (ny - 1, nt): computed once per region, so that a lookup
        (the conservative worst of the nodes) reads one value per pose."""
        low, high = values[:-1], values[1:]
        if not self.theta_period:  # a cylinder's poses all read theta's first column
            return reduce(low, high)
        return reduce(reduce(low, high), reduce(np.roll(low, -1, 1), np.roll(high, -1, 1)))


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

    @property
    def push_margin(self) -> float:
        """m the planner pushes beyond a pose's need (`BOX_PUSH_MARGIN` for boxes, else
        `PUSH_MARGIN`): the push-grasp it plans for a pose the region asks d of is d + margin,
        capped at ``d_max``."""
        return BOX_PUSH_MARGIN if self.footprint.shape == "box" else PUSH_MARGIN

    @cached_property
    def lateral_reach(self) -> float:
        """How far either side of the hand's axis (m) a pose can be and still be captured by
        some push (at some orientation): the extreme lateral offsets of the search."""
        ys = self.grid.y0 + self.grid.dy * np.arange(self.s_req.shape[0])
        captured = np.isfinite(self.s_req).any(axis=1)
        return float(np.abs(ys[captured]).max()) if captured.any() else 0.0

    def query(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(inside, push_distance) for object poses (N, 3) in the hand frame.

        A pose is inside only if all grid nodes around it succeed and it lies on their
        trajectories (not inside or behind the hand); its distance is the worst of the nodes,
        0 when the object is already in the hand. Outside poses get distance inf.
        """
        p = _check_poses(poses)
        index, ok = self.grid.cell(p, self.s_req.shape)
        s_req = self._cell_req[index]
        x_contact = self.grid.x_start - self._cell_contact[index]
        d = np.maximum(s_req - (self.grid.x_start - p[:, 0]), 0.0)
        inside = ok & np.isfinite(s_req) & (p[:, 0] >= x_contact) & (d <= self.d_max)
        return inside, np.where(inside, d, np.inf)

    @cached_property
    def _cell_req(self) -> np.ndarray:
        return self.grid.over_cells(self.s_req, np.maximum).ravel()

    @cached_property
    def _cell_contact(self) -> np.ndarray:
        return self.grid.over_cells(self.s_contact, np.minimum).ravel()

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
        index, ok = self.grid.cell(p, self.s_contact.shape)
        shift = p[:, 0] - self.grid.x_start
        contact = self._cell_contact[index] + shift
        escape = self._cell_escape[index] + shift
        inside = ok & (contact >= 0) & (contact <= distance) & (escape > distance)
        return inside, np.where(inside, contact, np.inf)

    def holds_until(self, poses: np.ndarray) -> float:
        """The longest sweep that keeps every pose (the region's escape distances: a sample
        lost at one distance is lost at every longer one); 0 if some pose is never held."""
        p = _check_poses(poses)
        index, ok = self.grid.cell(p, self.s_contact.shape)
        if not ok.all():
            return 0.0
        shift = p[:, 0] - self.grid.x_start
        escape = float((self._cell_escape[index] + shift).min())
        return max(0.0, min(self.d_max, escape))

    @cached_property
    def _cell_contact(self) -> np.ndarray:
        return self.grid.over_cells(self.s_contact, np.maximum).ravel()

    @cached_property
    def _cell_escape(self) -> np.ndarray:
        return self.grid.over_cells(self.s_escape, np.minimum).ravel()

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


BOX_PUSH_GRASP_SETTINGS = CaptureSettings(box_thetas=36, box_y_resolution=0.005)
"""The grid of boxes' push-grasp regions: every 5 deg and 5 mm. A pose counts as inside only
where all four grid nodes around it do, so with 15 deg between nodes a box standing a few
degrees either side of end-on in a narrow preshape had to fit the bands at -15, 0 and +15 deg
at once: at the poptart box's 0.111 m preshape they overlap over 1 cm, where the band at 0 deg
is 5 cm wide, and no sigma2 detection's samples ever fitted. At 5 deg the overlap of the bands
at -5, 0 and +5 deg is 4.4 cm. Sweeps and cylinders keep the default grid."""


def push_grasp_settings(footprint: Footprint) -> CaptureSettings:
    """The settings a push-grasp region of this outline is built and shipped with."""
    return BOX_PUSH_GRASP_SETTINGS if footprint.shape == "box" else CaptureSettings()


def push_grasp_region(
    footprint: Footprint,
    aperture: float,
    settings: CaptureSettings | None = None,
    cache_dir: Path | None = None,
) -> CaptureRegion:
    """The push-grasp capture region of an object outline at a hand aperture (m), cached."""
    settings = settings or push_grasp_settings(footprint)
    check_fits(footprint, aperture)
    hand = push_grasp_profile(aperture)
    arrays = cached_arrays(
        "push_grasp",
        footprint,
        aperture,
        settings,
        cache_dir,
        lambda: build_push_grasp(footprint, hand, settings),
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
    aperture: float = STRAIGHT_APERTURE,
    settings: CaptureSettings | None = None,
    cache_dir: Path | None = None,
) -> SweepRegion:
    """The sweep capture region of an object outline (any size), fingers at ``aperture``."""
    settings = settings or CaptureSettings()
    check_footprint(footprint)
    hand = sweep_profile(aperture)
    arrays = cached_arrays(
        "sweep",
        footprint,
        aperture,
        settings,
        cache_dir,
        lambda: build_sweep(footprint, hand, settings),
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


APERTURE_MARGIN = 0.02
"""m between the narrowest preshape and the object's narrowest width (a fingertip's width)."""
V_APERTURES = (0.235, MAX_APERTURE)
"""The V preshapes searched beyond the straight one (`planners.hand2d`): proximal angles of
about 0.45 and 0.2 rad."""
APERTURE_SPACING = 0.015
"""m: apertures closer than this to a wider one in the list are dropped (one region each)."""
APERTURE_GAP = 0.06
"""m: the widest step between searched apertures; a wider one is split evenly."""


def push_grasp_apertures(footprint: Footprint, liftable: bool = True) -> tuple[float, ...]:
    """The apertures the planner searches (§2.2.6: "between the maximum hand aperture and the
    minimum hand aperture for the object"), narrowest first: the object's narrowest width plus
    a fingertip, one that fits it at any orientation (`default_aperture`), the fingertips
    straight ahead, and the V preshapes, with no step wider than `APERTURE_GAP`. Narrow hands
    fit between neighbours in clutter; wide ones capture the spread of large uncertainty.

    An object the arm cannot lift gets no V preshape: a V captures a box once it is seated at
    the palm because closing holds it there, which `validate-capture` checks by lifting it, so
    for such an object the claim would ship untested."""
    wanted = sorted(
        {
            footprint.min_width + APERTURE_MARGIN,
            default_aperture(footprint),
            STRAIGHT_APERTURE,
            *(V_APERTURES if liftable else ()),
        }
    )
    kept: list[float] = []
    for aperture in reversed(wanted):  # widest first, so the hand's own apertures stay exact
        if kept:
            parts = math.ceil((kept[-1] - aperture) / APERTURE_GAP - 1e-9)
            kept += [round(float(x), 3) for x in np.linspace(kept[-1], aperture, parts + 1)[1:-1]]
        if not kept or kept[-1] - aperture >= APERTURE_SPACING:
            kept.append(aperture)
    return tuple(reversed(kept))


def precompute(directory: Path) -> list[Path]:
    """Build the shipped regions into ``directory``: the push-grasp of every graspable object
    at every aperture the planner searches and at `default_aperture` (the primitive env's and
    validate-capture's default), the sweep of every object, and remove any other region file
    there."""
    from clutter_gym.model.objects import OBJECTS

    settings = CaptureSettings()
    wanted = set()
    for spec in tqdm(OBJECTS.values(), desc="capture regions", unit="object"):
        if spec.graspable:
            apertures = {
                *push_grasp_apertures(spec.footprint, spec.liftable),
                default_aperture(spec.footprint),
            }
            grid = push_grasp_settings(spec.footprint)
            for aperture in sorted(apertures):
                push_grasp_region(spec.footprint, aperture, cache_dir=directory)
                wanted.add(cache_name("push_grasp", spec.footprint, aperture, grid))
        sweep_region(spec.footprint, cache_dir=directory)
        wanted.add(cache_name("sweep", spec.footprint, STRAIGHT_APERTURE, settings))
    for stale in directory.glob("*.npz"):
        if stale.name not in wanted:
            stale.unlink()
    return sorted(directory.glob("*.npz"))


if __name__ == "__main__":
    for written in precompute(SHIPPED_DIR):
        print(written)
