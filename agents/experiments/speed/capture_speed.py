"""`clutter-gym bench capture`: capture-region build and query times, measured, written as JSON.

Builds go to a fresh temporary cache so they are real builds; a second call shows the cached
load. Queries time membership plus minimum push distance for 50 poses (the paper's sample
count at sigma3), as the median of many repetitions.
"""

from __future__ import annotations

import platform
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from clutter_gym.model.objects import Footprint, get_object
from planners.capture import push_grasp_region, sweep_region
from planners.hand2d import MAX_APERTURE, default_aperture

PUSH_GRASP_OBJECTS = ("soda_can", "juice_bottle", "poptart_box")
SWEEP_OBJECTS = ("large_box",)
QUERY_SAMPLES = 50
QUERY_REPEATS = 500


def _median_query_ms(query: Any, rng: np.random.Generator) -> float:
    poses = np.c_[
        rng.uniform(0.2, 0.6, QUERY_SAMPLES),
        rng.uniform(-0.1, 0.1, QUERY_SAMPLES),
        rng.uniform(-np.pi, np.pi, QUERY_SAMPLES),
    ]
    times = []
    for _ in range(QUERY_REPEATS):
        start = time.perf_counter()
        query(poses)
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def _region(action: str, footprint: Footprint, aperture: float, cache: Path) -> Any:
    if action == "sweep":
        return sweep_region(footprint, cache_dir=cache)
    return push_grasp_region(footprint, aperture, cache_dir=cache)


def bench_capture(objects: tuple[str, ...] | None = None) -> dict[str, Any]:
    rng = np.random.default_rng(0)
    result: dict[str, Any] = {
        "benchmark": "capture",
        "python": platform.python_version(),
        "query_samples": QUERY_SAMPLES,
    }
    jobs = [("push_grasp", k) for k in PUSH_GRASP_OBJECTS] + [("sweep", k) for k in SWEEP_OBJECTS]
    if objects is not None:
        jobs = [job for job in jobs if job[1] in objects]
    with tempfile.TemporaryDirectory() as cache:
        for action, kind in tqdm(jobs, desc="capture regions", unit="region"):
            footprint = get_object(kind).footprint
            aperture = default_aperture(footprint)

            start = time.perf_counter()
            region = _region(action, footprint, aperture, Path(cache))
            built = time.perf_counter() - start
            start = time.perf_counter()
            _region(action, footprint, aperture, Path(cache))
            loaded = time.perf_counter() - start
            result[f"{action}/{kind}"] = {
                "aperture_m": aperture if action == "push_grasp" else MAX_APERTURE,
                "build_s": built,
                "cached_load_s": loaded,
                "query_50_ms": _median_query_ms(region.query, rng),
            }
    return result
