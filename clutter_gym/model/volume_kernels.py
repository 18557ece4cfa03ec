"""The compiled inner loop of `clutter_gym.model.collision`'s top-view floor map (numba).

Why compiled: a robot volume holds thousands of placed shapes (an arm along a path), each
covering about 150 cells of the 1 cm map; a Python loop over the shapes cost 6 us a shape
(45 ms a volume), numpy's scattered minimum more. Self-contained, like `arm_kernels`, so that
numba's on-disk cache is invalidated by a change of this file only.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def lowest_per_cell(
    low: np.ndarray, high: np.ndarray, z: np.ndarray, shape: np.ndarray
) -> np.ndarray:
    """Grid (shape) of the lowest z over each cell: box k covers the cells low[k]..high[k]
    (inclusive, 2 indices each) from height z[k]; inf where no box is."""
    lowest = np.full((shape[0], shape[1]), np.inf)
    for k in range(z.shape[0]):
        for i in range(low[k, 0], high[k, 0] + 1):
            for j in range(low[k, 1], high[k, 1] + 1):
                if z[k] < lowest[i, j]:
                    lowest[i, j] = z[k]
    return lowest


BOX = 0
CYLINDER = 1
"""`prisms_overlap`'s shape kinds (column 0 of a shape table)."""


@njit(cache=True)
def _reach(shapes: np.ndarray) -> float:
    """Radius about the object's origin of the smallest circle holding its outline."""
    reach = 0.0
    for k in range(shapes.shape[0]):
        corner = np.hypot(shapes[k, 1], shapes[k, 2])
        reach = max(reach, np.hypot(shapes[k, 3], shapes[k, 4]) + corner)
    return reach


@njit(cache=True)
def _placed(shape: np.ndarray, pose: np.ndarray) -> tuple[float, float, float, float]:
    """World (x, y) of a shape's centre at an object pose, and the cos, sin of its yaw."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return pose[0] + c * shape[3] - s * shape[4], pose[1] + s * shape[3] + c * shape[4], c, s


@njit(cache=True)
def _box_half_width(shape: np.ndarray, c: float, s: float, nx: float, ny: float) -> float:
    """Half the width of a box (yaw cos c, sin s) along the unit direction (nx, ny)."""
    return shape[1] * abs(c * nx + s * ny) + shape[2] * abs(-s * nx + c * ny)


@njit(cache=True)
def _shapes_overlap(a: np.ndarray, pose_a: np.ndarray, b: np.ndarray, pose_b: np.ndarray) -> bool:
    """Whether two upright prisms penetrate: their heights overlap and their outlines do (two
    discs by their centres' distance, a disc and a box by the box's nearest point, two boxes
    by the separating axes of their four edge directions)."""
    if a[6] <= b[5] or b[6] <= a[5]:
        return False
    if a[0] == CYLINDER and b[0] == BOX:
        a, pose_a, b, pose_b = b, pose_b, a, pose_a
    xa, ya, ca, sa = _placed(a, pose_a)
    xb, yb, cb, sb = _placed(b, pose_b)
    dx, dy = xb - xa, yb - ya
    if a[0] == CYLINDER:  # and b too
        return np.hypot(dx, dy) < a[1] + b[1]
    if b[0] == CYLINDER:  # the disc's centre in the box's frame, clamped onto the box
        u, v = ca * dx + sa * dy, -sa * dx + ca * dy
        nu, nv = min(max(u, -a[1]), a[1]), min(max(v, -a[2]), a[2])
        return np.hypot(u - nu, v - nv) < b[1]
    for nx, ny in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        gap = abs(dx * nx + dy * ny)
        if gap >= _box_half_width(a, ca, sa, nx, ny) + _box_half_width(b, cb, sb, nx, ny):
            return False
    return True


@njit(cache=True)
def prisms_overlap(
    shapes_a: np.ndarray, poses_a: np.ndarray, shapes_b: np.ndarray, poses_b: np.ndarray
) -> bool:
    """Whether object a at any of its planar poses (N, 3) penetrates object b at any of its
    (M, 3), both standing on one surface, each a table of upright shapes (K, 7: kind, half
    extents x and y, or the radius twice; centre x, y in the object's frame; bottom and top z):
    a pose of a whose bounding circle misses the disc holding b's (centroid, spread) is
    skipped, and so is a pair of poses whose bounding circles miss."""
    reach = _reach(shapes_a) + _reach(shapes_b)
    cx, cy = poses_b[:, 0].mean(), poses_b[:, 1].mean()
    spread = 0.0
    for j in range(poses_b.shape[0]):
        spread = max(spread, np.hypot(poses_b[j, 0] - cx, poses_b[j, 1] - cy))
    for i in range(poses_a.shape[0]):
        if np.hypot(poses_a[i, 0] - cx, poses_a[i, 1] - cy) >= reach + spread:
            continue
        for j in range(poses_b.shape[0]):
            if np.hypot(poses_a[i, 0] - poses_b[j, 0], poses_a[i, 1] - poses_b[j, 1]) >= reach:
                continue
            for p in range(shapes_a.shape[0]):
                for q in range(shapes_b.shape[0]):
                    if _shapes_overlap(shapes_a[p], poses_a[i], shapes_b[q], poses_b[j]):
                        return True
    return False
