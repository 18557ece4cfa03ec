"""`clutter-gym bench plan`: Rearrange's planning time on the paper's figure scenes (and a can
behind a poptart box), as JSON.

Each scene is planned at each noise level from ``seeds`` different detections (the seed draws
the detection, the uncertainty samples and OMPL's random numbers); the report gives every
planning time, the median, the plans found and what they move. Execution is measured by
``clutter-gym plan --execute``, not here.
"""

from __future__ import annotations

import platform
import statistics
from typing import Any

from tqdm import tqdm

from agents.execute import run_plan
from clutter_gym.model.scene import shipped_scene

SCENES = (
    "figures/fig3_can_box_dumbbell",
    "figures/fig2_high_uncertainty",
    "figures/fig16_shelf_can_behind_box",
    "can_behind_poptarts",
)
NOISES = ("sigma2", "sigma3")


def bench_plan(seeds: int = 3, noises: tuple[str, ...] = NOISES) -> dict[str, Any]:
    if seeds < 1:
        raise ValueError(f"seeds: {seeds}; must be >= 1")
    result: dict[str, Any] = {"benchmark": "plan", "python": platform.python_version()}
    jobs = [(scene, noise) for scene in SCENES for noise in noises]
    for scene, noise in tqdm(jobs, desc="bench plan", unit="scene"):
        runs = [run_plan(shipped_scene(scene), noise=noise, seed=seed) for seed in range(seeds)]
        times = [r["planning_time_s"] for r in runs]
        result[f"{scene.split('/')[-1]}/{noise}"] = {
            "planned": sum(r["success"] for r in runs),
            "seeds": seeds,
            "planning_time_s": times,
            "median_planning_time_s": round(statistics.median(times), 3),
            "objects_moved": [r["objects_moved"] for r in runs if r["success"]],
        }
    return result
