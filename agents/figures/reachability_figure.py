"""The reachability map of a support as a PNG (`clutter-gym reachability` writes it to docs/)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.reachability import ReachabilityMap
from clutter_gym.model.world import Surface


def plot_map(reach: ReachabilityMap, surface: Surface, out: Path) -> None:
    """From how many headings the hand reaches an object at each position (`dexterity`), one
    panel per grasp height, over the support's outline and the workspace where scenes put
    objects."""
    grid = reach.grid
    fig, axes = plt.subplots(1, len(grid.heights), figsize=(5.0 * len(grid.heights), 4.6))
    for h, ax in enumerate(np.atleast_1d(axes)):
        counts = reach.dexterity(h)
        image = ax.imshow(
            counts,
            origin="lower",
            extent=(grid.y[0], grid.y[1], grid.x[0], grid.x[1]),
            vmin=0,
            vmax=len(grid.headings),
            cmap="viridis",
            aspect="equal",
        )
        x0, x1, y0, y1 = surface.bounds
        ax.plot([y0, y1, y1, y0, y0], [x0, x0, x1, x1, x0], "w-", lw=1.2, label="support")
        (wx0, wx1), (wy0, wy1) = surface.workspace
        ax.plot(
            [wy0, wy1, wy1, wy0, wy0],
            [wx0, wx0, wx1, wx1, wx0],
            "r--",
            lw=1.2,
            label="scene workspace",
        )
        ax.invert_xaxis()  # the robot's left on the left
        ax.set_xlabel("y [m] (robot's left)")
        ax.set_ylabel("object x [m] (away from the robot)")
        ax.set_title(f"{surface.name}: TCP {grid.heights[h]:.3f} m above the top")
        ax.legend(loc="upper right", fontsize=7)
        fig.colorbar(image, ax=ax, label=f"headings reaching it (of {len(grid.headings)})")
    fig.suptitle(
        "HERB's right hand, horizontal, around an object: collision-free IK, headings all around"
    )
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out, buffer.getvalue())
