"""`clutter-gym benchmark`: the paper's experiments as one command each, run in parallel.

A suite is a list of (scene, noise level) cases; every case is planned by every requested
planner from the same detection (the seed of a case depends on the scene, the noise level and
``--seed`` only, never on the planner or the worker), and a returned plan is executed open loop
on true worlds drawn from N(detection, Q) (`agents.experiments.plan`). One job is one
(case, planner): jobs run in a local process pool or as Ray tasks, and every finished job is
appended to ``<json>.jobs.jsonl`` at once, so an interrupted run resumes where it stopped.

Suites:
* ``table1``: Table 1, the 10 scenes of each clutter level (`scenes/paper`) at sigma1-sigma4.
* ``fig15``: pushing vs pick-and-place (§3.2.1, Figs. 15-16) on the figure scenes (Figs. 2, 3-5,
  16 and a can behind a graspable poptart box) at their own noise: plan length, objects moved,
  planning and execution time.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.experiments.plan import (
    WAYPOINTS,
    detect_scene,
    execute_trial,
    plan_from_detection,
    true_worlds,
)
from agents.experiments.suites import (
    CLUTTER_LEVELS,
    PAPER_TABLE1,
    TABLE1_NOISES,
    Case,
    check_planners,
    get_suite,
    select_cases,
)
from agents.runner.jobs import config_digest, run_jobs
from agents.runner.markdown import markdown_table
from agents.runner.records import BenchmarkRecord, ExecutionSummary, PlanFacts
from clutter_gym.model.files import atomic_write_text
from clutter_gym.model.noise import resolve_noise
from planners.actions.settings import PlannerSettings


@dataclass(frozen=True)
class Job:
    """One case planned by one planner, then executed on ``trials`` true worlds."""

    case: Case
    planner: str
    seed: int
    trials: int
    time_budget: float

    @property
    def key(self) -> str:
        return f"{self.case.label}/{self.case.noise}/{self.planner}/seed{self.seed}"

    def identity(self) -> dict[str, Any]:
        return {
            "key": self.key,
            "scene": self.case.label,
            "group": self.case.group,
            "noise": self.case.noise,
            "planner": self.planner,
            "seed": self.seed,
        }

    def crashed(self, error: str) -> dict[str, Any]:
        """The record of a job that raised or killed its worker: a failed plan with the error."""
        crashed = BenchmarkRecord(
            **self.identity(),
            success=False,
            reason=f"crashed: {error}",
            planning_time_s=None,
            error=error,
        )
        return crashed.as_dict()

    @property
    def case_seed(self) -> int:
        """The detection's, the samples', the worlds' and the planner's seed: the same for
        every planner and every backend."""
        text = f"{self.case.label}/{self.case.noise}/{self.seed}"
        return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


# --------------------------------------------------------------------------------------------
# One job
# --------------------------------------------------------------------------------------------
def run_job(job: Job) -> dict[str, Any]:
    """Plan and execute one job: its record as JSON. Never raises: an error becomes a failed
    record with it."""
    try:
        return _plan_and_execute(job).as_dict()
    except Exception as error:
        return job.crashed(f"{type(error).__name__}: {error}")


def _plan_and_execute(job: Job) -> BenchmarkRecord:
    scene = replace(job.case.scene, noise=job.case.noise)
    rng = np.random.default_rng(job.case_seed)
    detection = detect_scene(scene, rng)
    settings = PlannerSettings(time_budget=job.time_budget, seed=job.case_seed)
    plan, _ = plan_from_detection(scene, detection, job.planner, settings, None, rng)
    record = BenchmarkRecord(
        **job.identity(),
        success=plan.success,
        reason=plan.reason,
        planning_time_s=round(plan.planning_time, 4),
        plan=PlanFacts(len(plan.steps), plan.objects_moved, plan.blocked_by[:3]),
    )
    if not plan.success:
        return record
    digest = hashlib.sha256(plan.trajectory.rows().tobytes()).hexdigest()[:12]
    record = replace(record, plan_digest=digest)
    # Without noise every true world is the detection: one execution says it all.
    trials = 1 if resolve_noise(scene.noise) == (0.0, 0.0) else job.trials
    if trials == 0:
        return record
    actions = plan.actions(WAYPOINTS)
    worlds = true_worlds(scene, detection, trials, rng)
    outcomes = [execute_trial(w, actions, i) for i, w in enumerate(worlds)]
    return replace(record, execution=ExecutionSummary.of(outcomes))


# --------------------------------------------------------------------------------------------
# The run: resumable log, report, table
# --------------------------------------------------------------------------------------------
def run_benchmark(
    suite_name: str,
    planners: Sequence[str] | None = None,
    out: Path = Path("out/benchmark.json"),
    markdown: Path | None = None,
    trials: int = 10,
    seed: int = 0,
    time_budget: float = 20.0,
    workers: int = 2,
    backend: str = "local",
    scenes_per_group: int | None = None,
    noises: tuple[str, ...] | None = None,
    work: Callable[[Job], dict[str, Any]] = run_job,
) -> dict[str, Any]:
    """Run (or resume) a suite; write the JSON report and the Markdown table (the command line
    draws the plots from the report with `agents.figures.benchmark_plots`)."""
    suite = get_suite(suite_name)
    names = check_planners(planners, suite)
    if trials < 0:
        raise ValueError(f"trials: {trials}; must be >= 0")
    if not (np.isfinite(time_budget) and time_budget > 0):
        raise ValueError(f"time_budget: {time_budget!r}; must be > 0")
    cases = select_cases(suite, noises, scenes_per_group)
    jobs = [Job(c, p, seed, trials, time_budget) for c in cases for p in names]
    run = run_jobs(
        jobs,
        work,
        out.with_name(f"{out.name}.jobs.jsonl"),
        config_digest({"trials": trials, "time_budget": time_budget}),
        workers=workers,
        backend=backend,
        desc=suite.name,
        describe=lambda r: "plan" if r["success"] else "no plan",
    )
    records = [BenchmarkRecord.from_dict(r) for r in run.records]
    report = {
        "suite": suite.name,
        "description": suite.description,
        "planners": list(names),
        "trials": trials,
        "time_budget_s": time_budget,
        "seed": seed,
        "workers": workers,
        "backend": backend,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count()},
        "resumed_jobs": run.resumed,
        "summary": summarize(records, suite.name),
        "records": [r.as_dict() for r in records],
    }
    atomic_write_text(out, json.dumps(report, indent=1) + "\n")
    if markdown is not None:
        atomic_write_text(markdown, to_markdown(report))
    return report


def summarize(records: list[BenchmarkRecord], suite: str) -> dict[str, Any]:
    """Per planner, group and noise: scenes solved, mean planning time, execution success."""
    cells: dict[tuple[str, str, str], list[BenchmarkRecord]] = {}
    for r in records:
        cells.setdefault((r.planner, r.group, r.noise), []).append(r)
    summary: dict[str, Any] = {}
    for (planner, group, noise), rows in cells.items():
        times = [r.planning_time_s for r in rows if r.planning_time_s is not None]
        solved = [r for r in rows if r.success]
        executions = sum(r.trials for r in rows)
        successes = sum(r.execution_successes for r in rows)
        cell: dict[str, Any] = {
            "scenes": len(rows),
            "solved": len(solved),
            "crashed": sum(bool(r.error) for r in rows),
            "mean_planning_time_s": _mean(times),
            "mean_planning_time_solved_s": _mean(
                [r.planning_time_s for r in solved if r.planning_time_s is not None]
            ),
            "executions": executions,
            "execution_successes": successes,
            "execution_success_rate": round(successes / executions, 4) if executions else None,
        }
        if suite == "fig15":
            cell.update(_figure_row(solved))
        paper = PAPER_TABLE1.get((planner, group))
        if suite == "table1" and paper is not None and noise in TABLE1_NOISES:
            paper_cell = paper[TABLE1_NOISES.index(noise)]
            cell["paper_solved"], cell["paper_mean_planning_time_s"] = paper_cell
        summary.setdefault(planner, {}).setdefault(group, {})[noise] = cell
    return summary


def _figure_row(solved: list[BenchmarkRecord]) -> dict[str, Any]:
    first = solved[0] if solved else None
    return {
        "actions": first.plan.actions if first and first.plan else None,
        "objects_moved": first.plan.objects_moved if first and first.plan else None,
        "mean_execution_simulated_s": (
            first.execution.mean_execution_simulated_s if first and first.execution else None
        ),
    }


def _mean(values: list[float]) -> float | None:
    return round(statistics.fmean(values), 4) if values else None


# --------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------
def to_markdown(report: dict[str, Any]) -> str:
    if report["suite"] == "table1":
        return _table1_markdown(report)
    return _figures_markdown(report)


def _rows(
    summary: dict[str, Any],
    noises: list[str],
    groups: list[str],
    planners: list[str],
    text: Callable[[dict[str, Any] | None], str],
) -> list[list[str]]:
    """One row per noise level, one cell per (group, planner)."""
    return [
        [noise, *(text(summary.get(p, {}).get(g, {}).get(noise)) for g in groups for p in planners)]
        for noise in noises
    ]


def _planning_text(cell: dict[str, Any] | None) -> str:
    """Scenes solved / mean planning time, and the paper's cell in brackets if it has one."""
    if cell is None:
        return "-"
    t = cell["mean_planning_time_s"]
    text = f"{cell['solved']} / {t:.2f}" if t is not None else f"{cell['solved']} / -"
    if "paper_solved" in cell:
        text += f" ({cell['paper_solved']} / {cell['paper_mean_planning_time_s']:.2f})"
    return text


def _execution_text(cell: dict[str, Any] | None) -> str:
    if not cell or not cell["executions"]:
        return "-"
    return f"{cell['execution_successes']}/{cell['executions']}"


def _table1_markdown(report: dict[str, Any]) -> str:
    summary, planners = report["summary"], report["planners"]
    noises = sorted({n for p in summary.values() for g in p.values() for n in g})
    groups = [g for g in CLUTTER_LEVELS if any(g in summary[p] for p in planners)]
    header = ["noise", *(f"{g}: {p}" for g in groups for p in planners)]
    scenes = max(c["scenes"] for p in summary.values() for g in p.values() for c in g.values())
    lines = [
        f"# {report['description']}",
        "",
        f"Scenes solved (of {scenes} per cell) / mean planning time [s] over all scenes of the "
        "cell; in brackets the "
        f"paper's Table 1 where it has the planner. Planning budget {report['time_budget_s']:g} "
        f"s, {report['workers']} workers ({report['backend']}), Python "
        f"{report['machine']['python']}.",
        "",
        *markdown_table(header, _rows(summary, noises, groups, planners, _planning_text)),
        "",
        f"Execution success of the returned plans ({report['trials']} true worlds per plan "
        "drawn from N(detection, Q); one world without noise):",
        "",
        *markdown_table(header, _rows(summary, noises, groups, planners, _execution_text)),
    ]
    return "\n".join(lines) + "\n"


def _figures_markdown(report: dict[str, Any]) -> str:
    header = (
        "scene",
        "noise",
        "planner",
        "plan",
        "actions",
        "objects moved",
        "planning time [s]",
        "execution [simulated s]",
        "execution success",
    )
    rows = []
    for r in (BenchmarkRecord.from_dict(d) for d in report["records"]):
        plan, execution = r.plan, r.execution
        rows.append(
            (
                r.scene,
                r.noise,
                r.planner,
                "yes" if r.success else "no: " + _short(r),
                plan.actions if plan else None,
                ", ".join(plan.objects_moved if plan else []) or "-",
                r.planning_time_s,
                execution.mean_execution_simulated_s if execution else None,
                f"{r.execution_successes}/{r.trials}" if r.trials else "-",
            )
        )
    lines = [f"# {report['description']}", "", *markdown_table(header, rows)]
    return "\n".join(lines) + "\n"


def _short(record: BenchmarkRecord) -> str:
    blocked = (record.plan.blocked_by if record.plan else []) or [record.reason]
    return str(blocked[0]).replace("|", "/")
