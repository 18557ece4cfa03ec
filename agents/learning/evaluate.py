"""`clutter-gym evaluate`: trained agents, the planners and the scripted grasp on the same
episodes, measured the same way (`agents.learning.episodes`).

Episode k of every agent resets with seed ``seed + k``; every env is made with the same scene
keywords (`SCENE_KEYWORDS`: a scene list, level, goal kind, noise, surface), so every agent
meets the same scene with the same detection noise. A trained agent acts, deterministically, in
its own variant (the env id in its run.json; its training keywords other than the scene ones are
kept); the planners and the scripted grasp plan whole trajectories, so they act in
`ClutterRetrieve-v0`.

Each (agent, episode) is one job for the project's job runner: records stream to
``<json>.jobs.jsonl`` and a rerun resumes them (a retrained model is a new agent: its file's
digest is in the log's config). Wall time per episode includes planning and, with more than one
worker, the other workers' load.
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.learning.agent_specs import AgentSpec
from agents.learning.episodes import Act, env_scene, run_episode
from agents.learning.lift_env import LIFT_ENV_ID
from agents.learning.runs import TrainedRun, make_env, one_torch_thread
from agents.policies.rearrange import RearrangePolicy
from agents.policies.scripted import DirectGraspPolicy
from agents.runner.jobs import Record, config_digest, run_jobs
from agents.runner.markdown import markdown_table
from clutter_gym.media import write_json
from clutter_gym.model.files import atomic_write_text
from clutter_gym.model.scene import scene_to_dict
from planners.actions.settings import PlannerSettings

SCENE_KEYWORDS = ("scenes", "level", "goal_kind", "noise", "surface")
TRAJECTORY_ID = "ClutterRetrieve-v0"


def scene_keywords(agents: list[AgentSpec], given: dict[str, Any]) -> dict[str, Any]:
    """The evaluation's scene keywords: those given; else the trained agents' (if they agree)."""
    if given:
        return given
    trained = [
        {k: v for k, v in a.run.env_kwargs.items() if k in SCENE_KEYWORDS}
        for a in agents
        if a.run is not None
    ]
    if any(t != trained[0] for t in trained[1:]):
        raise ValueError(
            "the trained agents were trained on different scenes "
            f"({'; '.join(map(json.dumps, trained))}): give --level, --goal-kind, --noise, "
            "--surface or --scenes for the evaluation"
        )
    return trained[0] if trained else {}


@dataclass(frozen=True)
class EvalJob:
    """One episode of one agent (picklable, for the job runner)."""

    agent: AgentSpec
    episode: int
    seed: int
    env_id: str
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    budget: float = 20.0

    @property
    def key(self) -> str:
        return f"{self.agent.label}#{self.episode}"

    def identity(self) -> Record:
        return {
            "agent": self.agent.label,
            "episode": self.episode,
            "seed": self.seed,
            "env": self.env_id,
        }

    def crashed(self, error: str) -> Record:
        return {**self.identity(), "success": False, "crashed": error}


def plan_episodes(
    agents: list[AgentSpec],
    episodes: int,
    seed: int,
    scenes: dict[str, Any],
    budget: float,
    grasped_start: float | None = None,
) -> list[EvalJob]:
    """Every agent's episodes; a trained agent acts in its own variant with its own keywords,
    but ``scenes``, and ``grasped_start`` (if given) for the agents of the lift variant."""
    jobs = []
    lifting = [a for a in agents if a.run is not None and a.run.env_id == LIFT_ENV_ID]
    if grasped_start is not None and not lifting:
        raise ValueError(
            f"--grasped-start: {grasped_start} is for agents trained on {LIFT_ENV_ID}; "
            "none of the agents is"
        )
    for agent in agents:
        env_id, kwargs = TRAJECTORY_ID, dict(scenes)
        if agent.run is not None:
            own = {k: v for k, v in agent.run.env_kwargs.items() if k not in SCENE_KEYWORDS}
            if agent in lifting and grasped_start is not None:
                own["grasped_start"] = grasped_start
            env_id, kwargs = agent.run.env_id, {**own, **scenes}
        jobs += [EvalJob(agent, k, seed + k, env_id, kwargs, budget) for k in range(episodes)]
    return jobs


def check_envs(jobs: list[EvalJob]) -> None:
    """Make each distinct env once, so that a bad keyword or an unknown id is one line now."""
    seen = set()
    for job in jobs:
        key = json.dumps([job.env_id, job.env_kwargs], sort_keys=True, default=str)
        if key in seen:
            continue
        seen.add(key)
        try:
            make_env(job.env_id, **job.env_kwargs).close()
        except (TypeError, ValueError, gym.error.Error) as error:
            raise ValueError(f"{job.agent.label}: {job.env_id}: {error}") from None


def check_agents(jobs: list[EvalJob]) -> None:
    """Load each trained agent once, in its own env, so that a corrupt model or statistics
    file is one line now rather than every episode recorded as crashed and scored 0%."""
    seen = set()
    for job in jobs:
        run = job.agent.run
        if run is None or job.agent.label in seen:
            continue
        seen.add(job.agent.label)
        env = make_env(job.env_id, **job.env_kwargs)
        try:
            with one_torch_thread():
                run.make_act(env)
        except Exception as error:  # whatever the zip or pickle raised: the file is unusable
            raise ValueError(
                f"{job.agent.label}: cannot load {run.model.name} or its statistics "
                f"({type(error).__name__}: {error})"
            ) from None
        finally:
            env.close()


# --------------------------------------------------------------------------------------------
# One episode (in a worker)
# --------------------------------------------------------------------------------------------
@functools.cache
def _env(env_id: str, kwargs_json: str) -> gym.Env:
    """One env per (id, keywords) per process, kept for its next episodes."""
    return make_env(env_id, **json.loads(kwargs_json))


_LOADED: dict[tuple[str, str], Act] = {}


def _trained_act(run: TrainedRun, digest: str, env: gym.Env) -> Act:
    """A trained agent loaded once per process (it keeps no state between episodes)."""
    key = (str(run.model), digest)
    if key not in _LOADED:
        _LOADED[key] = run.make_act(env)
    return _LOADED[key]


def _make_act(job: EvalJob, env: gym.Env) -> Any:
    """(env, reset info) -> act: a fresh planner or grasp per episode (they plan once)."""
    agent, seed = job.agent, job.seed
    if agent.run is not None:
        act = _trained_act(agent.run, agent.digest, env)
        return lambda env, info: act
    if agent.kind == "scripted":
        return lambda env, info: DirectGraspPolicy(
            env.get_wrapper_attr("waypoints"), env.get_wrapper_attr("surface")
        )
    settings = PlannerSettings(seed=seed, time_budget=job.budget)
    return lambda env, info: RearrangePolicy(
        env.get_wrapper_attr("waypoints"),
        agent.planner,
        settings=settings,
        names=tuple(info["object_names"]),
        seed=seed,
    )


def episode_record(job: EvalJob) -> Record:
    env = _env(job.env_id, json.dumps(job.env_kwargs, sort_keys=True))
    with one_torch_thread():
        episode = run_episode(env, _make_act(job, env), job.seed)
    return {
        **job.identity(),
        **episode.as_dict(),
        "planning_failure": str(getattr(episode.act, "failure", "")),
        "scene": _scene_digest(env),
    }


def _scene_digest(env: gym.Env) -> str | None:
    """A digest of the episode's scene: equal digests, same scene (objects, poses, noise)."""
    scene = env_scene(env)
    if scene is None:
        return None
    text = json.dumps(scene_to_dict(scene), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


# --------------------------------------------------------------------------------------------
# The report
# --------------------------------------------------------------------------------------------
def run_evaluation(
    agents: list[AgentSpec],
    env_id: str,
    jobs: list[EvalJob],
    out: Path,
    markdown: Path | None = None,
    workers: int = 1,
    backend: str = "local",
) -> dict[str, Any]:
    """Run (or resume) every episode; write the JSON report (and the Markdown table)."""
    settings = {
        "env": env_id,
        "jobs": [(j.key, j.seed, j.env_id, j.env_kwargs, j.budget, j.agent.digest) for j in jobs],
    }
    run = run_jobs(
        jobs,
        episode_record,
        out.with_name(f"{out.name}.jobs.jsonl"),
        config_digest(settings),
        workers=workers,
        backend=backend,
        desc="episodes",
        describe=lambda r: "success" if r.get("success") else str(r.get("failure") or "no"),
    )
    first = jobs[0] if jobs else None
    report = {
        "env": env_id,
        "episodes": len({j.episode for j in jobs}),
        "seed": first.seed if first else None,
        "scene_keywords": _scene_part(first.env_kwargs) if first else {},
        "agents": [a.label for a in agents],
        # Each agent's own keywords of the variant it acts in (a lift agent's grasped_start).
        "agent_keywords": {
            j.agent.label: {k: v for k, v in j.env_kwargs.items() if k not in SCENE_KEYWORDS}
            for j in jobs
        },
        "records": run.records,
        "summary": summarize(agents, run.records),
    }
    write_json(out, report)
    if markdown is not None:
        atomic_write_text(markdown, report_markdown(report))
    crashed = [r for r in run.records if "crashed" in r]
    if crashed:
        print(
            f"{len(crashed)} episodes crashed, e.g. {crashed[0]['agent']} episode "
            f"{crashed[0]['episode']}: {crashed[0]['crashed']}",
            file=sys.stderr,
        )
    return report


def _scene_part(kwargs: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in kwargs.items() if k in SCENE_KEYWORDS}


def summarize(agents: list[AgentSpec], records: list[Record]) -> dict[str, dict[str, Any]]:
    """Per agent: success rate, mean length, objects moved and wall time per episode."""
    summary = {}
    for agent in agents:
        mine = [r for r in records if r["agent"] == agent.label]
        ran = [r for r in mine if "crashed" not in r]
        moved = [r["n_objects_moved"] for r in ran if r.get("n_objects_moved") is not None]
        summary[agent.label] = {
            "acts_in": mine[0]["env"] if mine else None,
            "episodes": len(mine),
            "successes": sum(bool(r["success"]) for r in mine),
            "success_rate": _mean([float(bool(r["success"])) for r in mine]),
            "mean_length": _mean([r["length"] for r in ran]),
            "mean_objects_moved": _mean(moved),
            "mean_wall_time_s": _mean([r["wall_time_s"] for r in ran]),
            "crashed": len(mine) - len(ran),
        }
    return summary


def _mean(values: list[float]) -> float | None:
    return round(float(np.mean(values)), 4) if values else None


def report_markdown(report: dict[str, Any]) -> str:
    """The report's table: one row per agent."""
    header = (
        "agent",
        "acts in",
        "episodes",
        "success rate",
        "mean length [steps]",
        "mean objects moved",
        "mean wall time [s]",
        "crashed",
    )
    own = report["agent_keywords"]
    rows = [
        (
            label,
            " ".join(
                [cell["acts_in"], *(f"{k}={v}" for k, v in sorted(own.get(label, {}).items()))]
            ),
            cell["episodes"],
            cell["success_rate"],
            cell["mean_length"],
            cell["mean_objects_moved"],
            cell["mean_wall_time_s"],
            cell["crashed"],
        )
        for label, cell in report["summary"].items()
    ]
    lines = [
        f"Evaluation on {report['env']}: {report['episodes']} episodes, reset seeds "
        f"{report['seed']}..{(report['seed'] or 0) + report['episodes'] - 1}, scene keywords "
        f"{json.dumps(report['scene_keywords'], sort_keys=True)}",
        "",
        *markdown_table(header, rows),
    ]
    return "\n".join(lines) + "\n"
