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
