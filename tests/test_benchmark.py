"""`clutter-gym benchmark`: suites, backends, resuming, crash tolerance, table and plots."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from agents.cli import main
from agents.cli.experiments import SUITE_NAMES
from agents.experiments.benchmark import Job, run_benchmark
from agents.experiments.suites import SUITES, get_suite
from agents.figures.benchmark_plots import write_plots
from agents.runner.markdown import markdown_table
from tests.helpers import TAB_BLUE, WHITE, assert_picture

SMALL = {
    "scenes_per_group": 1,
    "noises": ("sigma2",),
    "trials": 1,
    "workers": 2,
    "time_budget": 120.0,
}
"""One scene per clutter level at sigma2, TSR and PG, one execution per plan: 6 jobs."""


def _comparable(record: dict[str, Any]) -> dict[str, Any]:
    """A record without wall-clock times: what the same seed must reproduce exactly."""
    return {k: v for k, v in record.items() if k != "planning_time_s"}


@pytest.fixture(scope="module")
def local_report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("local") / "table1.json"
    report = run_benchmark("table1", ("tsr", "pg"), out, markdown=out.with_suffix(".md"), **SMALL)
    report["plots"] = [str(p) for p in write_plots(report, out.parent)]
    return report


def test_small_table1_plans_executes_and_writes_table_and_plots(
    local_report: dict[str, Any], tmp_path_factory: pytest.TempPathFactory
) -> None:
    records = local_report["records"]
    assert [(r["scene"], r["planner"]) for r in records] == [
        (f"{level}_00", planner)
        for level in ("none", "medium", "high")
        for planner in ("tsr", "pg")
    ]
    assert all(not r["error"] for r in records)
    none_pg = local_report["summary"]["pg"]["none"]["sigma2"]
    assert none_pg["solved"] == 1 and none_pg["executions"] == 1
    assert none_pg["paper_solved"] == 10
    for r in records:
        assert r["trials"] == (1 if r["success"] else 0)
    markdown = Path(local_report["plots"][0]).parent / "table1.md"
    text = markdown.read_text()
    assert "| sigma2 | " in text and "(10 / 0.58)" in text  # PG's paper cell beside ours
    for png in local_report["plots"]:
        assert_picture(Path(png), min_width=600, colours=(WHITE, TAB_BLUE))


@pytest.mark.slow
def test_ray_backend_gives_the_same_results(local_report: dict[str, Any], tmp_path: Path) -> None:
    pytest.importorskip("ray")
    ray_report = run_benchmark(
        "table1", ("tsr", "pg"), tmp_path / "ray.json", backend="ray", **SMALL
    )
    assert [_comparable(r) for r in ray_report["records"]] == [
        _comparable(r) for r in local_report["records"]
    ]


def _fake(job: Job, reason: str = "") -> dict[str, Any]:
    return {
        "key": job.key,
        "scene": job.case.label,
        "group": job.case.group,
        "noise": job.case.noise,
        "planner": job.planner,
        "seed": job.seed,
        "success": True,
        "reason": reason,
        "planning_time_s": 0.1,
        "trials": 0,
        "execution_successes": 0,
        "error": "",
    }


def test_an_interrupted_run_resumes_from_its_log(tmp_path: Path) -> None:
    out = tmp_path / "table1.json"
    calls: list[str] = []

    def interrupted(job: Job) -> dict[str, Any]:
        if len(calls) == 4:
            raise KeyboardInterrupt
        calls.append(job.key)
        return _fake(job, reason="first run")

    with pytest.raises(KeyboardInterrupt):
        run_benchmark("table1", ("tsr", "pg"), out, work=interrupted, **{**SMALL, "workers": 1})
    log = out.with_name("table1.json.jobs.jsonl")
    assert len(log.read_text().splitlines()) == 4
    with log.open("a") as handle:
        handle.write('{"config": "cut short by the interrup')
    report = run_benchmark("table1", ("tsr", "pg"), out, work=_fake, **{**SMALL, "workers": 1})
    assert [r["key"] for r in report["records"] if r["reason"] == "first run"] == calls
    assert len(report["records"]) == 6 and all(r["success"] for r in report["records"])


def _crash_on_medium_tsr(job: Job) -> dict[str, Any]:
    """Kills its worker process on one job; fakes the others quickly."""
    if job.case.label == "medium_00" and job.planner == "tsr":
        os._exit(3)
    if job.case.label == "high_00" and job.planner == "tsr":
        raise RuntimeError("a bug in one scene")
    return _fake(job)


def test_a_crashing_job_is_marked_failed_and_the_run_goes_on(tmp_path: Path) -> None:
    report = run_benchmark(
        "table1", ("tsr", "pg"), tmp_path / "crash.json", work=_crash_on_medium_tsr, **SMALL
    )
    by_key = {r["key"]: r for r in report["records"]}
    dead = by_key["medium_00/sigma2/tsr/seed0"]
    assert not dead["success"] and "worker process died" in dead["error"]
    bug = by_key["high_00/sigma2/tsr/seed0"]
    assert not bug["success"] and "a bug in one scene" in bug["error"]
    assert sum(r["success"] for r in report["records"]) == 4
    assert report["summary"]["tsr"]["medium"]["sigma2"]["crashed"] == 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--suite", "table2"], "invalid choice: 'table2' (choose from 'table1', 'fig15'"),
        (["--suite", "table1", "--planners", "tsr,rrt"], "pushing, pick-and-place, pg, tsr"),
        (["--suite", "table1", "--backend", "dask"], "invalid choice: 'dask' (choose from"),
        (["--suite", "table1", "--noises", "sigma9"], "has sigma1, sigma2, sigma3, sigma4"),
    ],
)
def test_bad_names_are_one_error_listing_the_valid_ones(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["benchmark", *argv, "--json", str(tmp_path / "x.json")]) == 2
    assert message in capsys.readouterr().err


def test_suites_hold_the_papers_cases() -> None:
    table1 = get_suite("table1")
    assert len(table1.cases) == 10 * 3 * 4
    assert {c.noise for c in table1.cases} == {"sigma1", "sigma2", "sigma3", "sigma4"}
    fig15 = get_suite("fig15")
    assert fig15.planners == ("pushing", "pick-and-place")
    assert {c.label: c.noise for c in fig15.cases} == {
        "fig3_can_box_dumbbell": "sigma2",
        "fig15_can_box_two_graspables": "sigma2",
        "fig16_shelf_can_behind_box": "sigma2",
        "fig2_high_uncertainty": "fig2",
        "can_behind_poptarts": "sigma2",
    }
    perturbed = get_suite("perturbed")
    assert len(perturbed.cases) == 10 * len(fig15.cases)
    assert {c.group for c in perturbed.cases} == {c.label for c in fig15.cases}
    by_label = {c.label: c.scene for c in fig15.cases}
    for case in perturbed.cases:  # moved and turned, but the same objects in the same roles
        original = by_label[case.group]
        assert case.scene != original
        assert [o.name for o in case.scene.objects] == [o.name for o in original.objects]


def test_the_command_line_offers_every_suite() -> None:
    assert tuple(SUITES) == SUITE_NAMES


def test_one_markdown_table_writer() -> None:
    rows = [("a", 1, None), ("b", 0.5, "x")]
    assert markdown_table(("name", "value", "note"), rows) == [
        "| name | value | note |",
        "|---|---|---|",
        "| a | 1 | - |",
        "| b | 0.5 | x |",
    ]
