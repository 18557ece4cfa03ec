"""Where HERB's right hand can be, horizontal, at object height: the reachability map.

Every action of the planner puts the hand horizontal (approach axis level, finger plane
horizontal) at grasp height, somewhere over a support, approaching along some heading. Whether
the arm can be there without touching the support or itself is a property of the robot and the
world alone, so it is computed once, with the project's own IK and collision layer, on a grid of
hand_base positions x headings x heights, and shipped as data (`clutter-gym reachability`
rebuilds it; a test checks the shipped map matches the current robot and world).

The map answers two questions: the planner's O(1) pre-check before any IK (`may_reach`: False
only where no neighbouring grid pose was reachable), and how dexterous a place is (the number
of headings that reach it), which decides where scenes put objects (`Surface.workspace`).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.collision import SURFACE_PADDING, make_checker
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import CHECK_SPACING, J3_SAMPLES, MAX_CHECKS, ArmKinematics
from clutter_gym.model.world import SURFACES, Surface

MAP_VERSION = 3
"""Bump when how a cell is decided changes: it is part of the map's digest (3: the analytic IK,
deterministic, in place of random-restart descent: 6% more reachable cells on the table, 16%
more on the shelf)."""
SHIPPED_DIR = Path(__file__).resolve().parents[1] / "data" / "reachability"
IK_EFFORT = f"analytic j3 sweep {J3_SAMPLES}, checks {MAX_CHECKS}, spacing {CHECK_SPACING}"
"""The IK a cell is decided with, the planner's own (`ArmKinematics.solve_ik`): a cell is
reachable when the planner's solve finds it."""
GRASP_STANDOFF = 0.12
"""m from the hand_base to the centre of an object the hand grasps or pushes (about the
push-grasp's stop, `planners.hand2d`): how `dexterity` places the hand around an object."""
PROBE_HAND = HandCommand(0.0, 0.3)
"""A preshaped hand: the fingers curled forward as in a push-grasp."""


# --------------------------------------------------------------------------------------------
# The horizontal hand
# --------------------------------------------------------------------------------------------
def approach_rotation(direction: np.ndarray) -> np.ndarray:
    """Hand orientation with the approach axis (hand z) horizontal along `direction` and the
    finger plane horizontal, F3 on the robot's left of the object, as in HERB's home pose."""
    norm = math.hypot(direction[0], direction[1])
    zx, zy = direction[0] / norm, direction[1] / norm
    # x = y cross z with y = (zy, -zx, 0) (-(world z x approach): the home pose's roll), z =
    # (zx, zy, 0), written out term by term as np.cross computes it (so every entry, signed
    # zeros too, is the same): a planner asks for thousands of hand poses.
    return np.array(
        [
            [(-zx) * 0.0 - 0.0 * zy, zy, zx],
            [0.0 * zx - zy * 0.0, -zx, zy],
            [zy * zy - (-zx) * zx, 0.0, 0.0],
        ]
    )


def tcp_pose(tcp: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """TCP pose (4x4) of a horizontal hand with its TCP at ``tcp`` (3,), approaching along
    ``direction`` (3,)."""
    pose = np.eye(4)
    pose[:3, :3] = approach_rotation(direction)
    pose[:3, 3] = tcp
    return pose


def hand_pose(hand_base_xy: np.ndarray, heading: float, z: float) -> np.ndarray:
    """TCP pose (4x4) of a horizontal hand whose hand_base is at (x, y, z), approaching along
    ``heading`` (world yaw)."""
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    return tcp_pose(np.r_[hand_base_xy, z] + hm.HAND_TCP_OFFSET * direction, direction)


# --------------------------------------------------------------------------------------------
# The grid
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Grid:
    """Hand_base positions (x, y) over a support, headings (world yaw, evenly spaced around the
    full circle) and TCP heights above the support's top."""

    x: tuple[float, float]
    y: tuple[float, float]
    resolution: float
    headings_deg: tuple[float, ...]
    heights: tuple[float, ...]

    @property
    def xs(self) -> np.ndarray:
        return _axis(*self.x, self.resolution)

    @property
    def ys(self) -> np.ndarray:
        return _axis(*self.y, self.resolution)

    @property
    def headings(self) -> np.ndarray:
        return np.radians(np.asarray(self.headings_deg, dtype=float))


def _axis(low: float, high: float, step: float) -> np.ndarray:
    return low + step * np.arange(round((high - low) / step) + 1)


HEADINGS_DEG = tuple(float(h) for h in range(-180, 180, 15))
"""Approach yaws all around (the paper searches push directions over [0, 2 pi), §2.2.6): the
right arm reaches around a near object to push it toward the robot or to the right."""
HEIGHTS = (0.075, 0.09)
"""TCP heights above the support on the map: `PUSH_HEIGHT` and the end-effector variants'
ready height (`clutter_gym.sim.controllers.READY_HEIGHT`)."""
PUSH_HEIGHT = HEIGHTS[0]
"""TCP height above the support of pushes, sweeps and side grasps: as low as the hand allows,
because the paper pushes objects "as low as possible" so that they do not topple (§2.2.1). The
wrist housing (4.5 cm in radius, level with the TCP in a horizontal approach) then clears the
support by 3 cm, twice the planner's padding; every object is taller than the hand there.
Where the arm cannot hold the hand that low (far out, the forearm slopes down to the support),
the planner takes the map's next height (`planners.actions.arm.Arm.push_height`)."""


def default_grid(surface: Surface) -> Grid:
    """Positions from just in front of HERB to the support's far edge, over its width."""
    _, x_max, y_min, y_max = surface.bounds
    return Grid(
        (0.30, round(x_max, 2)), (round(y_min, 2), round(y_max, 2)), 0.02, HEADINGS_DEG, HEIGHTS
    )


def map_digest(surface: Surface, grid: Grid) -> str:
    """Everything a map depends on: the robot (its URDF text), the support's geometry (not
    where scenes put objects), the padding, the grid and the IK effort."""
    key = json.dumps(
        {
            "version": MAP_VERSION,
            "robot": hashlib.sha256(hm.herb_urdf().encode()).hexdigest(),
            "home": hm.RIGHT_ARM_HOME.tolist(),
            "surface": repr((surface.top_z, surface.bounds, surface.boxes)),
            "padding": SURFACE_PADDING,
            "grid": repr(grid),
            "ik": IK_EFFORT,
            "hand": repr(PROBE_HAND),
        },
        sort_keys=True,
    )
    return hashlib.sha256(key.encode()).hexdigest()[:16]


def reachable_row(surface: Surface, grid: Grid, height: int, row: int) -> np.ndarray:
    """(headings, ys) booleans: whether a collision-free IK solution exists for the hand at
    ``grid.xs[row]``, each y and heading, TCP ``grid.heights[height]`` above the support."""
    kinematics = ArmKinematics("right")
    free = make_checker(surface, {}).checker(PROBE_HAND, objects=False)
    z = surface.top_z + grid.heights[height]
    out = np.zeros((len(grid.headings), len(grid.ys)), dtype=bool)
    for k, heading in enumerate(grid.headings):
        for j, y in enumerate(grid.ys):
            target = hand_pose(np.array([grid.xs[row], y]), float(heading), z)
            out[k, j] = kinematics.solve_ik(target, accept=free) is not None
    return out


# --------------------------------------------------------------------------------------------
# The map
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ReachabilityMap:
    """``reach[h, k, i, j]``: the hand is reachable at height h, heading k, xs[i], ys[j]."""

    surface: str
    grid: Grid
    reach: np.ndarray

    def may_reach(self, hand_base_xy: np.ndarray, heading: float, height: float) -> bool | None:
        """False when no grid pose around this one (the 4 positions and 2 headings that
        bracket it) is reachable, so IK would fail: skip it; True when one is; None when the
        pose is not on the map (another height, or off the grid): decide with IK."""
        slab = self._slab(heading, height)
        if slab is None:
            return None
        g = self.grid
        fx = (hand_base_xy[0] - g.x[0]) / g.resolution
        fy = (hand_base_xy[1] - g.y[0]) / g.resolution
        nx, ny = slab.shape[1:]
        if not (0 <= fx <= nx - 1 and 0 <= fy <= ny - 1):
            return None
        i0, j0 = min(int(fx), nx - 2), min(int(fy), ny - 2)
        return bool(slab[:, i0 : i0 + 2, j0 : j0 + 2].any())

    def rules_out_any(self, hand_base_xys: np.ndarray, heading: float, height: float) -> bool:
        """Whether `may_reach` is False at any of the hand_base positions (N, 2), all at one
        heading and height: a straight hand line in one lookup."""
        slab = self._slab(heading, height)
        if slab is None:
            return False
        g = self.grid
        xys = np.asarray(hand_base_xys, dtype=float).reshape(-1, 2)
        fx = (xys[:, 0] - g.x[0]) / g.resolution
        fy = (xys[:, 1] - g.y[0]) / g.resolution
        nx, ny = slab.shape[1:]
        on = (fx >= 0) & (fx <= nx - 1) & (fy >= 0) & (fy <= ny - 1)
        i0 = np.minimum(fx[on].astype(np.int64), nx - 2)
        j0 = np.minimum(fy[on].astype(np.int64), ny - 2)
        near = slab[:, i0, j0] | slab[:, i0 + 1, j0] | slab[:, i0, j0 + 1] | slab[:, i0 + 1, j0 + 1]
        return bool(not near.any(axis=0).all())

    def _slab(self, heading: float, height: float) -> np.ndarray | None:
        """The map at the two grid headings that bracket ``heading`` (2, xs, ys), at the grid
        height ``height`` is; None when it is none of the map's heights."""
        g = self.grid
        h = int(np.argmin(np.abs(np.asarray(g.heights) - height)))
        if abs(g.heights[h] - height) > 1e-3:
            return None
        step = g.headings_deg[1] - g.headings_deg[0]
        count = len(g.headings_deg)
        fk = math.remainder(math.degrees(heading) - g.headings_deg[0], 360.0) % 360.0 / step
        k0 = math.floor(fk) % count
        return self.reach[h][[k0, (k0 + 1) % count]]

    def dexterity(self, height: int = 0, standoff: float = GRASP_STANDOFF) -> np.ndarray:
        """(xs, ys): from how many headings the hand, at grasp height ``height`` (an index of
        the grid's heights), reaches an object centred at each grid position, its hand_base
        ``standoff`` behind the centre along the heading (`may_reach`)."""
        g = self.grid
        counts = np.zeros((len(g.xs), len(g.ys)), dtype=np.int64)
        for i, x in enumerate(g.xs):
            for j, y in enumerate(g.ys):
                for heading in g.headings:
                    back = standoff * np.array([math.cos(heading), math.sin(heading)])
                    counts[i, j] += bool(
                        self.may_reach(np.array([x, y]) - back, float(heading), g.heights[height])
                    )
        return counts

    def to_bytes(self, digest: str) -> bytes:
        buffer = io.BytesIO()
        np.savez_compressed(
            buffer, reach=self.reach, digest=np.array(digest), grid=np.array(repr(self.grid))
        )
        return buffer.getvalue()


def map_path(surface: Surface, grid: Grid | None = None) -> Path:
    """Where the shipped map of a support lives (its name holds the digest)."""
    grid = grid or default_grid(surface)
    return SHIPPED_DIR / f"{surface.name}_{map_digest(surface, grid)}.npz"


@cache
def shipped_map(surface_name: str) -> ReachabilityMap | None:
    """The shipped map of a support, or None if none matches the current robot and world
    (`clutter-gym reachability` builds it)."""
    surface = SURFACES[surface_name]
    grid = default_grid(surface)
    path = map_path(surface, grid)
    if not path.is_file():
        return None
    with np.load(path, allow_pickle=False) as data:
        if str(data["digest"]) != map_digest(surface, grid):
            return None
        return ReachabilityMap(surface_name, grid, data["reach"].astype(bool))
