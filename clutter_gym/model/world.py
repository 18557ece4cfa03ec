"""The static support surfaces objects stand on: HERB's table and a shelf unit.

All coordinates are in the robot's base frame: origin on the floor under HERB, x forward,
y left, z up (metres).  HERB's right shoulder is at about (0.08, -0.19, 0.915) with ~0.9 m
of reach, so both surfaces sit in front-right of the robot.

Every static part is an axis-aligned ``Box``; the simulator and the collision checker are both
built from ``Surface.boxes``, so there is one description of the world.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Range = tuple[float, float]
Region = tuple[Range, Range]
"""An axis-aligned planar rectangle as ``((x_min, x_max), (y_min, y_max))``."""

_WOOD = (0.55, 0.38, 0.22, 1.0)
_DARK_WOOD = (0.40, 0.27, 0.16, 1.0)
_BOARD = (0.85, 0.82, 0.75, 1.0)


@dataclass(frozen=True)
class Box:
    """A static axis-aligned box: centre and half extents in metres."""

    centre: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    rgba: tuple[float, float, float, float]

    @classmethod
    def from_bounds(
        cls, x: Range, y: Range, z: Range, rgba: tuple[float, float, float, float]
    ) -> Box:
        """Build a box from its extent along each axis, the way furniture is measured."""
        return cls(
            centre=((x[0] + x[1]) / 2, (y[0] + y[1]) / 2, (z[0] + z[1]) / 2),
            half_extents=((x[1] - x[0]) / 2, (y[1] - y[0]) / 2, (z[1] - z[0]) / 2),
            rgba=rgba,
        )


@dataclass(frozen=True)
class Surface:
    """A support surface: where objects may stand and what counts as success by default.

    ``bounds`` is the supporting top ``(x_min, x_max, y_min, y_max)`` that an object's
    footprint must stay inside (for the shelf: inside the walls).  ``workspace`` is the
    smaller area the right arm can reach, where scene generators place objects.
    ``interior`` is the free space walls and a roof enclose above the top, entered only through
    its open side (x, y, z ranges; None for an open table).
    """

    name: Literal["table", "shelf"]
    top_z: float
    bounds: tuple[float, float, float, float]
    boxes: tuple[Box, ...]
    workspace: Region
    default_goal_region: Region
    success: Literal["lift", "region"]
    interior: tuple[Range, Range, Range] | None = None


def _table() -> Surface:
    """HERB's table: a 0.74 x 1.85 m top, 0.03 m thick, on four 0.05 m square legs, its near
    edge 0.45 m in front of HERB's base frame (0.30 m clear of the Segway's front).

    Placed as the lab placed HERB at a table: close enough that the objects stand in the arm's
    dexterous workspace (its examples grasp objects 0.62-0.8 m ahead). The reachability map
    (`clutter_gym.model.reachability`, plotted in docs/reachability_table.png) measures it: a
    horizontal hand at object height reaches hand_base positions from the near edge to x ~ 0.9;
    ``workspace``, where scenes put object centres, is the part of the top where an object is
    graspable from at least 7 of the map's 24 headings (measured: at least 10; the map's test
    checks it)."""
    top_z, thickness, leg, inset = 0.735, 0.03, 0.05, 0.03
    x, y = (0.45, 1.19), (-1.125, 0.725)
    leg_x = ((x[0] + inset, x[0] + inset + leg), (x[1] - inset - leg, x[1] - inset))
    leg_y = ((y[0] + inset, y[0] + inset + leg), (y[1] - inset - leg, y[1] - inset))
    legs = tuple(
        Box.from_bounds(lx, ly, (0.0, top_z - thickness), _DARK_WOOD)
        for lx in leg_x
        for ly in leg_y
    )
    return Surface(
        name="table",
        top_z=top_z,
        bounds=(x[0], x[1], y[0], y[1]),
        boxes=(Box.from_bounds(x, y, (top_z - thickness, top_z), _WOOD), *legs),
        workspace=((0.55, 0.88), (-0.60, 0.20)),
        # Success is lifting the goal object; it must be held above the table top, not
        # carried off it, so the region is the whole top.
        default_goal_region=(x, y),
        success="lift",
    )


def _shelf() -> Surface:
    """A shelf cubby open towards the robot, on a cabinet; the task is to bring the goal
    object forward from the back, past the clutter, into the front strip.

    Its opening is 0.48 m in front of HERB and it is 0.40 m deep: deep enough for a can behind
    a large box (Fig. 16), shallow enough that the hand reaches behind the box (Fig. 16: HERB
    reaches into a shelf). Inside, the reachability map (docs/reachability_shelf.png) grasps an
    object from at least 7 of 24 headings up to x 0.74 (`workspace`, where scenes put object
    centres), from 0-13 at x 0.76-0.80 (fewest near the walls) and from none behind that: the
    last 8 cm before the back wall hold only the far half of an object.
    """
    top_z, wall, clearance = 0.735, 0.02, 0.45
    inner_x, inner_y = (0.48, 0.88), (-0.65, 0.25)
    outer_x = (inner_x[0], inner_x[1] + wall)
    outer_y = (inner_y[0] - wall, inner_y[1] + wall)
    ceiling = top_z + clearance
    return Surface(
        name="shelf",
        top_z=top_z,
        bounds=(inner_x[0], inner_x[1], inner_y[0], inner_y[1]),
        boxes=(
            Box.from_bounds(outer_x, outer_y, (top_z - wall, top_z), _BOARD),
            Box.from_bounds(outer_x, outer_y, (0.0, top_z - wall), _DARK_WOOD),
            Box.from_bounds(outer_x, (outer_y[0], inner_y[0]), (top_z, ceiling), _WOOD),
            Box.from_bounds(outer_x, (inner_y[1], outer_y[1]), (top_z, ceiling), _WOOD),
            Box.from_bounds((inner_x[1], outer_x[1]), inner_y, (top_z, ceiling), _WOOD),
            Box.from_bounds(outer_x, outer_y, (ceiling, ceiling + wall), _BOARD),
        ),
        workspace=((0.56, 0.74), (-0.53, 0.10)),
        default_goal_region=((0.48, 0.58), (-0.45, 0.05)),
        success="region",
        interior=(inner_x, inner_y, (top_z, ceiling)),
    )


TABLE = _table()
SHELF = _shelf()
SURFACES: dict[str, Surface] = {s.name: s for s in (TABLE, SHELF)}


def get_surface(name: str) -> Surface:
    """Look up a surface, naming the allowed surfaces when it is unknown."""
    try:
        return SURFACES[name]
    except KeyError:
        raise ValueError(
            f"unknown surface {name!r}; allowed: {', '.join(sorted(SURFACES))}"
        ) from None
