"""`clutter-gym benchmark`: the paper's experiments as one command each, run in parallel.

A suite is a list of (scene, noise level) cases; every case is planned by every requested
planner from the same detection (the seed of a case depends on the scene, the noise level and
``--seed`` only, never on the planner or the worker), and a returned plan is executed open loop
on true worlds drawn from N(detection, Q) (`agents.execute`). One job is one (case, planner):
jobs run in a local process pool or as Ray tasks, and every finished job is appended to
``<json>.jobs.jsonl`` at once, so an interrupted run resumes where it stopped.

Suites:
* ``table1``: Table 1, the 10 scenes of each clutter level (`scenes/paper`) at sigma1-sigma4.
* ``fig15``: pushing vs pick-and-place (§3.2.1, Figs. 15-16) on the figure scenes (Figs. 2, 3-5,
  16 and a can behind a graspable poptart box) at their own noise: plan length, objects moved,
  planning and execution time.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import statistics
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from agents.execute import WAYPOINTS, detect_scene, execute_trial, plan_from_detection, true_worlds
from agents.jobs import JobSpec, config_digest, run_jobs
from agents.records import BenchmarkRecord, ExecutionSummary, PlanFacts
from clutter_gym.model.files import atomic_write_text
from clutter_gym.model.noise import resolve_noise
from clutter_gym.model.scene import (
    PERTURB_SHIFT,
    PERTURB_TURN,
    Scene,
    load_scene,
    perturbed,
    shipped_scene,
)
from planners.actions.settings import PlannerSettings
from planners.rearrange import planner_kind

TABLE1_NOISES = ("sigma1", "sigma2", "sigma3", "sigma4")
CLUTTER_LEVELS = ("none", "medium", "high")
PERTURBED_VARIANTS = 10
"""Variants of each figure layout in the perturbed suite (issue: at least 10)."""
FIGURE_SCENES = (
    "figures/fig3_can_box_dumbbell",
    "figures/fig16_shelf_can_behind_box",
    "figures/fig2_high_uncertainty",
    "can_behind_poptarts",
)

PAPER_TABLE1: dict[tuple[str, str], tuple[tuple[int, float], ...]] = {
    ("tsr", "none"): ((10, 0.01), (9, 0.52), (0, 0.86), (0, 0.86)),
    ("tsr", "medium"): ((10, 0.01), (9, 1.02), (0, 1.61), (0, 1.63)),
    ("tsr", "high"): ((5, 0.54), (0, 1.97), (0, 3.22), (0, 3.08)),
    ("pg", "none"): ((10, 0.02), (10, 0.58), (10, 1.00), (5, 1.44)),
    ("pg", "medium"): ((10, 0.04), (10, 1.17), (10, 5.17), (0, 3.91)),
    ("pg", "high"): ((8, 1.98), (5, 12.93), (3, 28.16), (0, 7.46)),
}
"""Table 1 of the paper (Dogar & Srinivasa): (scenes solved of 10, mean planning
time [s]) per (planner, clutter level), at sigma1-sigma4. Reference data for the report."""


@dataclass(frozen=True)
class Case:
    """One scene at one noise level; ``group`` is the clutter level or the figure."""

    scene: Scene
    label: str  # e.g. "high_03"
    group: str
    noise: str


@dataclass(frozen=True)
class Suite:
    name: str
    description: str
    cases: tuple[Case, ...]
    planners: tuple[str, ...]  # the default planners


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

    @property
    def case_seed(self) -> int:
        """The detection's, the samples', the worlds' and the planner's seed: the same for
        every planner and every backend."""
        text = f"{self.case.label}/{self.case.noise}/{self.seed}"
        return int.from_bytes(hashlib.sha256(text.encode()).digest()[:4], "little")


def table1_suite() -> Suite:
    cases = tuple(
        Case(load_scene(shipped_scene(f"paper/{level}_{k:02d}")), f"{level}_{k:02d}", level, noise)
        for level in CLUTTER_LEVELS
        for k in range(10)
        for noise in TABLE1_NOISES
    )
    return Suite(
        "table1",
        "Table 1: 10 scenes x 3 clutter levels x 4 noise levels",
        cases,
        ("tsr", "pg"),
    )


def _figure_cases(variants: int) -> tuple[Case, ...]:
    """The figure scenes at their own noise: as drawn (``variants`` 0), or that many seeded
    perturbed variants of each (`clutter_gym.model.scene.perturbed`)."""
    cases = []
    for name in FIGURE_SCENES:
        path = shipped_scene(name)
        scene = load_scene(path)
        if not isinstance(scene.noise, str):
            raise ValueError(f"{path}: noise must be a level name for the suite")
        figure = name.split("/")[-1]
        if not variants:
            cases.append(Case(scene, figure, figure, scene.noise))
        for k in range(variants):
            cases.append(Case(perturbed(scene, k), f"{figure}~{k:02d}", figure, scene.noise))
    return tuple(cases)


def fig15_suite() -> Suite:
    return Suite(
        "fig15",
        "Pushing vs pick-and-place (§3.2.1) on the figure scenes: "
        + ", ".join(n.split("/")[-1] for n in FIGURE_SCENES),
        _figure_cases(0),
        ("pushing", "pick-and-place"),
    )


def perturbed_suite() -> Suite:
    return Suite(
        "perturbed",
        f"The figure layouts moved by up to {PERTURB_SHIFT:g} m and turned by up to "
        f"{math.degrees(PERTURB_TURN):g} deg, {PERTURBED_VARIANTS} seeded variants each",
        _figure_cases(PERTURBED_VARIANTS),
        ("pushing", "pick-and-place"),
    )


SUITES: dict[str, Callable[[], Suite]] = {
    "table1": table1_suite,
    "fig15": fig15_suite,
    "perturbed": perturbed_suite,
}


def get_suite(name: str) -> Suite:
    try:
        return SUITES[name]()
    except KeyError:
        raise ValueError(f"suite: {name!r} is unknown; allowed: {', '.join(SUITES)}") from None


def check_planners(names: Sequence[str] | None, suite: Suite) -> tuple[str, ...]:
    """The planners to run (default: the suite's); an unknown name lists the valid ones."""
    if names is None:
        return suite.planners
    if not names:
        raise ValueError("planners: none given; name at least one")
    for name in names:
        planner_kind(name)
    return tuple(dict.fromkeys(names))


# --------------------------------------------------------------------------------------------
# One job
# --------------------------------------------------------------------------------------------
def run_job(job: Job) -> dict[str, Any]:
    """Plan and execute one job: its record as JSON. Never raises: an error becomes a failed
    record with it."""
    try:
        return _plan_and_execute(job).as_dict()
    except Exception as error:
        return _crashed(job, f"{type(error).__name__}: {error}")


def _record(job: Job, **fields: Any) -> BenchmarkRecord:
    return BenchmarkRecord(key=job.key, scene=job.case.label, group=job.case.group,
                           noise=job.case.noise, planner=job.planner, seed=job.seed,
                           **fields)  # fmt: skip


def _crashed(job: Job, error: str) -> dict[str, Any]:
    """The record of a job that raised or killed its worker."""
    crashed = _record(
        job, success=False, reason=f"crashed: {error}", planning_time_s=None, error=error
    )
    return crashed.as_dict()


def _plan_and_execute(job: Job) -> BenchmarkRecord:
    scene = replace(job.case.scene, noise=job.case.noise)
    rng = np.random.default_rng(job.case_seed)
    detection = detect_scene(scene, rng)
    settings = PlannerSettings(time_budget=job.time_budget, seed=job.case_seed)
    plan, _ = plan_from_detection(scene, detection, job.planner, settings, None, rng)
    record = _record(
        job,
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
def _job_key(job: Job) -> str:
    return job.key


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
    plots: Path | None = None,
    work: Callable[[Job], dict[str, Any]] = run_job,
) -> dict[str, Any]:
    """Run (or resume) a suite; write the JSON report, the Markdown table and the plots."""
    suite = get_suite(suite_name)
    names = check_planners(planners, suite)
    if trials < 0:
        raise ValueError(f"trials: {trials}; must be >= 0")
    if not (np.isfinite(time_budget) and time_budget > 0):
        raise ValueError(f"time_budget: {time_budget!r}; must be > 0")
    cases = _first_scenes(suite.cases, scenes_per_group)
    if noises is not None:
        known = sorted({c.noise for c in suite.cases})
        unknown = [n for n in noises if n not in known]
        if unknown or not noises:
            raise ValueError(f"noises: {list(noises)!r}; the suite has {', '.join(known)}")
        cases = [c for c in cases if c.noise in noises]
    jobs = [Job(c, p, seed, trials, time_budget) for c in cases for p in names]
    run = run_jobs(
        jobs,
        JobSpec(work=work, key=_job_key, crashed=_crashed),
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
    if plots is not None:
        from agents.benchmark_plots import write_plots

        report["plots"] = [str(p) for p in write_plots(report, plots)]
    return report


def _first_scenes(cases: Iterable[Case], per_group: int | None) -> list[Case]:
    if per_group is None:
        return list(cases)
    if per_group < 1:
        raise ValueError(f"scenes_per_group: {per_group}; must be >= 1")
    labels: dict[str, list[str]] = {}
    for c in cases:
        group = labels.setdefault(c.group, [])
        if c.label not in group:
            group.append(c.label)
    keep = {label for group in labels.values() for label in group[:per_group]}
    return [c for c in cases if c.label in keep]


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
) -> list[str]:
    """One Markdown row per noise level, one cell per (group, planner)."""
    return [
        f"| {noise} | "
        + " | ".join(
            text(summary.get(p, {}).get(g, {}).get(noise)) for g in groups for p in planners
        )
        + " |"
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
    head = "| noise | " + " | ".join(f"{g}: {p}" for g in groups for p in planners) + " |"
    scenes = max(c["scenes"] for p in summary.values() for g in p.values() for c in g.values())
    rule = "|---" * (1 + len(groups) * len(planners)) + "|"
    lines = [
        f"# {report['description']}",
        "",
        f"Scenes solved (of {scenes} per cell) / mean planning time [s] over all scenes of the "
        "cell; in brackets the "
        f"paper's Table 1 where it has the planner. Planning budget {report['time_budget_s']:g} "
        f"s, {report['workers']} workers ({report['backend']}), Python "
        f"{report['machine']['python']}.",
        "",
        head,
        rule,
    ]
    lines += _rows(summary, noises, groups, planners, _planning_text)
    lines += [
        "",
        f"Execution success of the returned plans ({report['trials']} true worlds per plan "
        "drawn from N(detection, Q); one world without noise):",
        "",
        head,
        rule,
    ]
    lines += _rows(summary, noises, groups, planners, _execution_text)
    return "\n".join(lines) + "\n"


def _figures_markdown(report: dict[str, Any]) -> str:
    lines = [
        f"# {report['description']}",
        "",
        "| scene | noise | planner | plan | actions | objects moved | planning time [s] "
        "| execution [simulated s] | execution success |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in (BenchmarkRecord.from_dict(d) for d in report["records"]):
        plan, execution = r.plan, r.execution
        moved = ", ".join(plan.objects_moved if plan else []) or "-"
        executed = f"{r.execution_successes}/{r.trials}" if r.trials else "-"
        simulated = execution.mean_execution_simulated_s if execution else None
        lines.append(
            f"| {r.scene} | {r.noise} | {r.planner} | "
            f"{'yes' if r.success else 'no: ' + _short(r)} | {plan.actions if plan else '-'} | "
            f"{moved} | {_or_dash(r.planning_time_s)} | {_or_dash(simulated)} | {executed} |"
        )
    return "\n".join(lines) + "\n"


def _or_dash(value: object) -> str:
    return "-" if value is None else str(value)


def _short(record: BenchmarkRecord) -> str:
    blocked = (record.plan.blocked_by if record.plan else []) or [record.reason]
    return str(blocked[0]).replace("|", "/")
