"""`clutter-gym reachability`: build the reachability map of a support with the project's own
IK and collision layer (`clutter_gym.model.reachability`) and ship it
(`agents.figures.reachability_figure` plots it).

One job per (height, row of x): the runner (`agents.runner.jobs`) runs them in a process pool and
logs each row, so an interrupted build resumes. The map is written where the planner and the scene
checks look for it (``clutter_gym/data/reachability``), named by the digest of everything it depends
on; the figure shows, for each height, how many headings reach each hand_base position.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.runner.jobs import config_digest, run_jobs
from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.reachability import (
    SHIPPED_DIR,
    ReachabilityMap,
    default_grid,
    map_digest,
    reachable_row,
)
from clutter_gym.model.world import SURFACES


@dataclass(frozen=True)
class RowJob:
    """One row of x of the map at one height of one support."""

    surface: str
    height: int  # index into the grid's heights
    row: int  # index into the grid's xs

    @property
    def key(self) -> str:
        return f"{self.surface}/h{self.height}/x{self.row}"

    def identity(self) -> dict[str, Any]:
        return {"surface": self.surface, "height": self.height, "row": self.row}

    def crashed(self, error: str) -> dict[str, Any]:
        return {"error": error}


def _row(job: RowJob) -> dict[str, Any]:
    surface = SURFACES[job.surface]
    return {"reach": reachable_row(surface, default_grid(surface), job.height, job.row).tolist()}


def build_map(name: str, workers: int, log_dir: Path) -> tuple[ReachabilityMap, Path]:
    """Compute (or resume) the map of a support and write it to the shipped directory."""
    surface = SURFACES[name]
    grid = default_grid(surface)
    digest = map_digest(surface, grid)
    jobs = [RowJob(name, h, i) for h in range(len(grid.heights)) for i in range(len(grid.xs))]
    run = run_jobs(
        jobs,
        _row,
        log_dir / f"{name}.jobs.jsonl",
        config_digest(digest),
        workers=workers,
        desc=f"reachability {name}",
    )
    failed = [j.key for j, r in zip(jobs, run.records, strict=True) if "error" in r]
    if failed:
        raise RuntimeError(f"reachability rows crashed: {', '.join(failed[:5])}")
    reach = np.zeros((len(grid.heights), len(grid.headings), len(grid.xs), len(grid.ys)), bool)
    for job, record in zip(jobs, run.records, strict=True):
        reach[job.height, :, job.row, :] = np.asarray(record["reach"], dtype=bool)
    built = ReachabilityMap(name, grid, reach)
    path = SHIPPED_DIR / f"{name}_{digest}.npz"
    for stale in SHIPPED_DIR.glob(f"{name}_*.npz"):
        if stale != path:
            stale.unlink()
    atomic_write_bytes(path, built.to_bytes(digest))
    return built, path
