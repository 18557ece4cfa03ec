"""The reachability map: shipped for the current robot and world, its pre-check never refuses
what IK reaches nearby, and the scene workspaces lie where the hand is dexterous."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clutter_gym.model.collision import make_checker
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.reachability import (
    HEIGHTS,
    PROBE_HAND,
    Grid,
    ReachabilityMap,
    default_grid,
    hand_pose,
    shipped_map,
)
from clutter_gym.model.world import SURFACES

MIN_HEADINGS = 7
"""Every object centre of a scene workspace is graspable from at least this many of the 24
headings (the hand_base 12 cm behind it): the dexterous part of the reach."""


@pytest.mark.parametrize("surface", sorted(SURFACES))
def test_a_map_is_shipped_for_the_current_robot_and_world(surface: str) -> None:
    built = shipped_map(surface)
    assert built is not None, f"run: clutter-gym reachability --surface {surface}"
    grid = default_grid(SURFACES[surface])
    assert built.reach.shape == (len(grid.heights), len(grid.headings), len(grid.xs), len(grid.ys))
    assert 0.1 < built.reach.mean() < 0.9


def test_the_precheck_refuses_only_where_no_neighbour_is_reachable() -> None:
    grid = Grid((0.0, 0.1), (0.0, 0.1), 0.05, (-180.0, -90.0, 0.0, 90.0), (0.08,))
    reach = np.zeros((1, 4, 3, 3), dtype=bool)
    reach[0, 2, 0, 0] = True  # heading 0 deg at (0, 0)
    reach[0, 0, 2, 2] = True  # heading -180 deg at (0.1, 0.1)
    built = ReachabilityMap("table", grid, reach)
    assert built.may_reach(np.array([0.02, 0.02]), 0.0, 0.08) is True
    assert built.may_reach(np.array([0.02, 0.02]), math.radians(10.0), 0.08) is True
    assert built.may_reach(np.array([0.02, 0.02]), math.radians(-40.0), 0.08) is True
    assert built.may_reach(np.array([0.08, 0.08]), 0.0, 0.08) is False
    assert built.may_reach(np.array([0.02, 0.02]), math.radians(120.0), 0.08) is False
    # Headings wrap around: 170 deg lies between 90 and -180.
    assert built.may_reach(np.array([0.08, 0.08]), math.radians(170.0), 0.08) is True
    assert built.may_reach(np.array([0.08, 0.08]), math.radians(-60.0), 0.08) is False
    assert built.may_reach(np.array([0.02, 0.02]), 0.0, 0.20) is None  # another height
    assert built.may_reach(np.array([0.5, 0.02]), 0.0, 0.08) is None  # off the grid


def test_a_line_is_ruled_out_where_one_of_its_points_is() -> None:
    """`rules_out_any` (a straight hand line in one lookup) says what `may_reach` says point by
    point: ruled out where one point is False; off-map points and other heights rule nothing
    out."""
    built = shipped_map("table")
    assert built is not None
    rng = np.random.default_rng(0)
    verdicts = set()
    for _ in range(400):
        start = rng.uniform((0.2, -1.2), (1.3, 0.8))
        points = start + np.linspace(0.0, 1.0, 12)[:, None] * rng.uniform(-0.4, 0.4, 2)
        heading, height = rng.uniform(-math.pi, math.pi), float(rng.choice(HEIGHTS))
        each = [built.may_reach(p, heading, height) for p in points]
        verdict = built.rules_out_any(points, heading, height)
        assert verdict == (False in each)
        verdicts.add(verdict)
        assert not built.rules_out_any(points, heading, 0.5)  # no such height on the map
    assert verdicts == {True, False}


@pytest.mark.parametrize("surface", sorted(SURFACES))
def test_reachable_cells_are_reached_by_ik(surface: str) -> None:
    built = shipped_map(surface)
    assert built is not None
    world = SURFACES[surface]
    kinematics = ArmKinematics("right")
    free = make_checker(world, {}).checker(PROBE_HAND, objects=False)
    h, k, i, j = (a[::97][:6] for a in np.nonzero(built.reach))
    for hh, kk, ii, jj in zip(h, k, i, j, strict=True):
        xy = np.array([built.grid.xs[ii], built.grid.ys[jj]])
        target = hand_pose(xy, float(built.grid.headings[kk]), world.top_z + built.grid.heights[hh])
        q = kinematics.solve_ik(target, accept=free)
        assert q is not None, (surface, xy, built.grid.headings_deg[kk])


@pytest.mark.parametrize("surface", sorted(SURFACES))
def test_scene_workspaces_are_dexterous(surface: str) -> None:
    built = shipped_map(surface)
    assert built is not None
    (x0, x1), (y0, y1) = SURFACES[surface].workspace
    xs, ys = built.grid.xs, built.grid.ys
    inside = np.ix_((xs >= x0 - 1e-9) & (xs <= x1 + 1e-9), (ys >= y0 - 1e-9) & (ys <= y1 + 1e-9))
    for h in range(len(built.grid.heights)):
        counts = built.dexterity(h)[inside]
        assert counts.min() >= MIN_HEADINGS, (surface, built.grid.heights[h], counts.min())
