"""`clutter-gym plan`: plan once from one noisy detection, then execute the open-loop plan on
many true worlds consistent with the noise model (the paper's robustness claim, tested).

The scene file holds the true poses. One detection is drawn from them with the scene's noise;
the planner sees only that detection and its noise level. Each trial then draws a true world
from N(detection, Q) for every object (redrawn until objects neither interpenetrate nor leave
the surface), resets the env to it and replays the plan's env actions unchanged. A trial
succeeds when the env reports success (goal held by the fingers and lifted, or in the shelf's
goal strip), with nothing toppled or pushed off the surface.

Trial outcomes stream to ``<json>.trials.jsonl`` (`agents.runner.jobs`), keyed by the plan,
the worlds and the code, so an interrupted run resumes where it stopped and says so.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.policies.rollout import roll_out
from agents.runner.jobs import NumberedTrial, config_digest, run_jobs
from agents.runner.records import ExecutionSummary, TrialOutcome
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.media import gif_writer, write_json
from clutter_gym.model import herb as hm
from clutter_gym.model.noise import detect, resolve_noise
from clutter_gym.model.scene import Scene, load_scene, scene_to_dict
from clutter_gym.model.trajectory import DEFAULT_WAYPOINTS
from clutter_gym.model.world import Surface, get_surface
from planners.actions.arm import IKSolver
from planners.actions.settings import PlannerSettings
from planners.kinds import planner_kind
from planners.rearrange import Plan, plan_retrieval
from planners.uncertainty import ObjectBelief, beliefs, sample_count

WAYPOINTS = DEFAULT_WAYPOINTS
WORLD_ATTEMPTS = 200
FRAME_EVERY = 24
PlanHook = Callable[[Plan, list[ObjectBelief], Surface], dict[str, Any]]
"""Called with a found plan, its beliefs and the support; what it returns joins the report (the
command line writes the timeline figure with it, so that no figure code is imported here)."""


def detect_scene(scene: Scene, rng: np.random.Generator) -> np.ndarray:
    """One detection of every object: true poses plus the scene's noise, (N, 3)."""
    truth = np.array([o.pose for o in scene.objects], dtype=float)
    return detect(truth, resolve_noise(scene.noise), rng)


def true_worlds(
    scene: Scene, detection: np.ndarray, count: int, rng: np.random.Generator
) -> list[Scene]:
    """``count`` scenes whose poses are drawn from N(detection, Q), physically valid."""
    sigma = resolve_noise(scene.noise)
    worlds = []
    for _ in range(count):
        for _attempt in range(WORLD_ATTEMPTS):
            poses = detect(detection, sigma, rng)
            objects = tuple(
                replace(o, pose=(float(p[0]), float(p[1]), float(p[2])))
                for o, p in zip(scene.objects, poses, strict=True)
            )
            try:
                worlds.append(load_scene(scene_to_dict(replace(scene, objects=objects))))
                break
            except ValueError:
                continue
        else:
            raise ValueError(
                f"no valid true world in {WORLD_ATTEMPTS} draws around the detection: the "
                "noise makes objects interpenetrate or leave the surface"
            )
    return worlds


def plan_from_detection(
    scene: Scene,
    detection: np.ndarray,
    planner: str,
    settings: PlannerSettings,
    samples: int | None,
    rng: np.random.Generator,
    ik: IKSolver | None = None,
) -> tuple[Plan, list[ObjectBelief]]:
    sigma = resolve_noise(scene.noise)
    n = samples or sample_count(sigma)
    detections = [
        (o.name, o.spec, (float(d[0]), float(d[1]), float(d[2])))
        for o, d in zip(scene.objects, detection, strict=True)
    ]
    believed = beliefs(detections, sigma, n, rng)
    plan = plan_retrieval(
        get_surface(scene.surface),
        believed,
        scene.goal.object,
        np.asarray(hm.RIGHT_ARM_START),
        settings,
        scene.goal.region,
        planner,
        ik,
    )
    return plan, believed


def replay(
    world: Scene,
    actions: list[np.ndarray],
    seed: int,
    on_frame: Callable[[np.ndarray], object] | None = None,
) -> TrialOutcome:
    """Replay env actions on one true world; the outcome. With ``on_frame``, every rendered
    frame is handed to it as it comes (a `clutter_gym.media.GifStream`)."""
    env = ClutterRetrieveEnv(render_mode="rgb_array" if on_frame else None, waypoints=WAYPOINTS)
    try:
        obs, _ = env.reset(seed=seed, options={"scene": world})
        if on_frame is not None:
            env.start_recording(on_frame, FRAME_EVERY)
        info = roll_out(env, obs, actions, {}).info
        return TrialOutcome(
            success=bool(info["is_success"]),
            failure=info["failure"],
            goal_lift_m=round(float(info["goal_lift"]), 4),
            simulated_s=round(info["sim_steps"] * env.sim.timestep, 2),
        )
    finally:
        env.close()


def execute_trial(world: Scene, actions: list[np.ndarray], seed: int) -> TrialOutcome:
    """One trial's outcome; a trial that crashes is a failed trial, with the error."""
    try:
        return replay(world, actions, seed=seed)
    except Exception as error:
        return TrialOutcome.crashed(repr(error))


@dataclass(frozen=True)
class TrialJob(NumberedTrial):
    """One execution: its index (also the env seed), the true world and the plan's env actions."""

    index: int
    world: Scene
    actions: list[np.ndarray]

    def crashed(self, error: str) -> dict[str, Any]:
        return TrialOutcome.crashed(error).as_dict()


def _run_trial(job: TrialJob) -> dict[str, Any]:
    return execute_trial(job.world, job.actions, seed=job.index).as_dict()


def run_plan(
    scene_path: str | Path,
    planner: str = "pushing",
    trials: int = 0,
    out: Path | None = None,
    gif: Path | None = None,
    on_plan: PlanHook | None = None,
    seed: int = 0,
    time_budget: float = 20.0,
    samples: int | None = None,
    workers: int = 2,
    noise: str | tuple[float, float] | None = None,
) -> dict[str, Any]:
    """Plan for a scene from one detection; execute the plan on ``trials`` true worlds.
    ``noise`` (a level name or (sigma_xy, sigma_theta)) replaces the scene's noise."""
    planner_kind(planner)
    if trials < 0:
        raise ValueError(f"trials: {trials}; must be >= 0")
    if samples is not None and samples < 1:
        raise ValueError(f"samples: {samples}; must be >= 1")
    scene = load_scene(scene_path)
    if noise is not None:
        scene = replace(scene, noise=noise)
    rng = np.random.default_rng(seed)
    detection = detect_scene(scene, rng)
    settings = PlannerSettings(time_budget=time_budget, seed=seed)
    plan, beliefs = plan_from_detection(scene, detection, planner, settings, samples, rng)
    report: dict[str, Any] = {
        "scene": str(scene_path),
        "planner": planner,
        "noise": list(resolve_noise(scene.noise)),
        "samples": len(beliefs[0].samples),
        "detection": np.round(detection, 4).tolist(),
        **plan.summary().as_dict(),
    }
    if on_plan is not None and plan.success:
        report.update(on_plan(plan, beliefs, get_surface(scene.surface)))
    if plan.success and (trials or gif):
        actions = plan.actions(WAYPOINTS)
        worlds = true_worlds(scene, detection, max(trials, 1), rng)
        if gif is not None:
            with gif_writer(gif, fps=10) as frames:
                outcome = replay(worlds[0], actions, seed=0, on_frame=frames.add)
            report["gif"] = str(gif)
            report["gif_trial"] = outcome.as_dict()
        if trials:
            report.update(_trials(worlds[:trials], actions, out, workers))
    if out is not None:
        write_json(out, report)
    return report


def _trials(
    worlds: list[Scene], actions: list[np.ndarray], out: Path | None, workers: int
) -> dict[str, Any]:
    """Execute on every world through the job runner: the log beside ``out`` (or
    out/plan.json) is keyed by the worlds, the actions and the code, so a rerun of the same
    plan resumes and any other plan or code starts afresh."""
    plan = hashlib.sha256(
        repr(([scene_to_dict(w) for w in worlds], [a.tobytes() for a in actions])).encode()
    ).hexdigest()
    base = out or Path("out/plan.json")
    log = base.with_name(f"{base.name}.trials.jsonl")
    jobs = [TrialJob(i, w, actions) for i, w in enumerate(worlds)]
    run = run_jobs(jobs, _run_trial, log, config_digest(plan), workers=workers, desc="execute")
    outcomes = [TrialOutcome.from_dict(r) for r in run.records]
    return {
        **ExecutionSummary.of(outcomes).as_dict(),
        "resumed_trials": run.resumed,
        "trial_outcomes": [o.as_dict() for o in outcomes],
    }
