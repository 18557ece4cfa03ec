"""`clutter-gym bench plan`: Rearrange's planning time, and where it goes, as JSON.

Each scene is planned at each noise level from ``seeds`` different detections (the seed draws the
detection, the uncertainty samples and OMPL's random numbers), once with the analytic IK and once
with a reference solver (random-restart Levenberg-Marquardt,
`agents.experiments.speed.ik_speed`), the two taking turns on the same detection so that the
machine's load hits both alike. The report gives, per solver, the plans found, every planning time
and its median, the share of planning time in IK, how much of the planning time the planner's
own statistics account for (`PlanStats`: every costly step has a part) and each part's share.
Execution is measured by ``clutter-gym plan --execute``, not here.
"""

from __future__ import annotations

import platform
import statistics
from dataclasses import replace
from typing import Any

import numpy as np
from tqdm import tqdm

from agents.experiments.plan import detect_scene, plan_from_detection
from agents.experiments.speed.ik_speed import ANALYTIC, PREVIOUS, lm_restarts
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.scene import load_scene, shipped_scene
from clutter_gym.sim.bullet import native_stdout_muted
from planners.actions.arm import Free, IKSolver
from planners.actions.settings import PlannerSettings

SCENES = (
    "figures/fig3_can_box_dumbbell",
    "figures/fig2_high_uncertainty",
    "figures/fig16_shelf_can_behind_box",
    "can_behind_poptarts",
    "paper/high_00",
    "paper/high_03",
    "paper/high_07",
)
NOISES = ("sigma2", "sigma3")
PLANNER = "pushing"


def _previous_solver(seed: int) -> IKSolver:
    kinematics = ArmKinematics("right")
    rng = np.random.default_rng(seed)

    def solve(target: np.ndarray, accept: Free) -> np.ndarray | None:
        return lm_restarts(kinematics, target, accept, rng)

    return solve


def _run(scene_name: str, noise: str, seed: int, ik: IKSolver | None) -> dict[str, Any]:
    scene = replace(load_scene(shipped_scene(scene_name)), noise=noise)
    rng = np.random.default_rng(seed)
    detection = detect_scene(scene, rng)
    settings = PlannerSettings(seed=seed)
    plan, _ = plan_from_detection(scene, detection, PLANNER, settings, None, rng, ik)
    seconds = plan.stats.seconds
    return {
        "success": plan.success,
        "planning_time_s": round(plan.planning_time, 4),
        "seconds": {part: round(t, 4) for part, t in seconds.items()},
        "objects_moved": plan.objects_moved,
    }


def _summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    times = [r["planning_time_s"] for r in runs]
    total = sum(times)
    parts = _part_seconds(runs)
    return {
        "planned": sum(r["success"] for r in runs),
        "planning_time_s": times,
        "median_planning_time_s": round(statistics.median(times), 3),
        "ik_share": round(parts.get("ik", 0.0) / total, 3) if total else None,
        "accounted_share": round(sum(parts.values()) / total, 3) if total else None,
        # Each part's share, largest first: where a regression or a speed-up went.
        "shares": {part: round(t / total, 3) for part, t in parts.items()} if total else {},
        "objects_moved": [r["objects_moved"] for r in runs if r["success"]],
    }


def _part_seconds(runs: list[dict[str, Any]]) -> dict[str, float]:
    """The seconds of each part of the planner's statistics (`PlanStats.seconds`) over the
    runs, largest first."""
    parts: dict[str, float] = {}
    for r in runs:
        for part, seconds in r["seconds"].items():
            parts[part] = parts.get(part, 0.0) + seconds
    return dict(sorted(parts.items(), key=lambda item: -item[1]))


def bench_plan(
    seeds: int = 3, noises: tuple[str, ...] = NOISES, scenes: tuple[str, ...] = SCENES
) -> dict[str, Any]:
    if seeds < 1:
        raise ValueError(f"seeds: {seeds}; must be >= 1")
    result: dict[str, Any] = {
        "benchmark": "plan",
        "planner": PLANNER,
        "python": platform.python_version(),
    }
    runs: dict[str, list[dict[str, Any]]] = {ANALYTIC: [], PREVIOUS: []}
    jobs = [(scene, noise) for scene in scenes for noise in noises]
    with native_stdout_muted():
        for scene, noise in tqdm(jobs, desc="bench plan", unit="scene"):
            per_scene: dict[str, list[dict[str, Any]]] = {ANALYTIC: [], PREVIOUS: []}
            for seed in range(seeds):
                solvers = {ANALYTIC: None, PREVIOUS: _previous_solver(seed)}
                for name in list(solvers)[:: 1 if seed % 2 == 0 else -1]:
                    per_scene[name].append(_run(scene, noise, seed, solvers[name]))
            result[f"{scene.split('/')[-1]}/{noise}"] = {
                name: _summary(r) for name, r in per_scene.items()
            }
            for name, r in per_scene.items():
                runs[name] += r
    result["all"] = {name: _summary(r) for name, r in runs.items()}
    for summary in result["all"].values():
        del summary["planning_time_s"], summary["objects_moved"]
    return result
