"""`clutter-gym reachability`: build the reachability map of a support with the project's own
IK and collision layer (`clutter_gym.model.reachability`), ship it, and plot it.

One job per (height, row of x): the runner (`agents.jobs`) runs them in a process pool and logs
each row, so an interrupted build resumes. The map is written where the planner and the scene
checks look for it (``clutter_gym/data/reachability``), named by the digest of everything it
depends on; the figure shows, for each height, how many headings reach each hand_base position.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from agents.jobs import JobSpec, config_digest, run_jobs
from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.reachability import (
    SHIPPED_DIR,
    ReachabilityMap,
    default_grid,
    map_digest,
    reachable_row,
)
from clutter_gym.model.world import SURFACES, Surface

RowJob = tuple[str, int, int]
"""(surface, height index, row index)."""


def _row(job: RowJob) -> dict[str, Any]:
    name, height, row = job
    surface = SURFACES[name]
    return {"reach": reachable_row(surface, default_grid(surface), height, row).tolist()}


def _key(job: RowJob) -> str:
    return f"{job[0]}/h{job[1]}/x{job[2]}"


def _crashed(job: RowJob, error: str) -> dict[str, Any]:
    return {"error": error}


ROWS = JobSpec(work=_row, key=_key, crashed=_crashed)


def build_map(name: str, workers: int, log_dir: Path) -> tuple[ReachabilityMap, Path]:
    """Compute (or resume) the map of a support and write it to the shipped directory."""
    surface = SURFACES[name]
    grid = default_grid(surface)
    digest = map_digest(surface, grid)
    jobs = [(name, h, i) for h in range(len(grid.heights)) for i in range(len(grid.xs))]
    run = run_jobs(
        jobs, ROWS, log_dir / f"{name}.jobs.jsonl", config_digest(digest), workers=workers,
        desc=f"reachability {name}",
    )  # fmt: skip
    failed = [_key(j) for j, r in zip(jobs, run.records, strict=True) if "error" in r]
    if failed:
        raise RuntimeError(f"reachability rows crashed: {', '.join(failed[:5])}")
    reach = np.zeros((len(grid.heights), len(grid.headings), len(grid.xs), len(grid.ys)), bool)
    for (_, h, i), record in zip(jobs, run.records, strict=True):
        reach[h, :, i, :] = np.asarray(record["reach"], dtype=bool)
    built = ReachabilityMap(name, grid, reach)
    path = SHIPPED_DIR / f"{name}_{digest}.npz"
    for stale in SHIPPED_DIR.glob(f"{name}_*.npz"):
        if stale != path:
            stale.unlink()
    atomic_write_bytes(path, built.to_bytes(digest))
    return built, path


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
        ax.plot([wy0, wy1, wy1, wy0, wy0], [wx0, wx0, wx1, wx1, wx0], "r--", lw=1.2,
                label="scene workspace")  # fmt: skip
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
