"""The one job runner (`agents.runner.jobs`): resumable log, cut lines, Ctrl-C, a killed parent."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import psutil
import pytest

from agents.experiments.benchmark import Job, run_benchmark
from agents.runner.jobs import JobSpec, code_digest, config_digest, read_log, run_jobs

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent


def _square(n: int) -> dict[str, Any]:
    return {"value": n * n}


def _slow_square(n: int) -> dict[str, Any]:
    time.sleep(3.0)
    return {"value": n * n, "pid": os.getpid()}


def _key(n: int) -> str:
    return f"job{n}"


def _crashed(n: int, error: str) -> dict[str, Any]:
    return {"error": error}


SQUARES = JobSpec(work=_square, key=_key, crashed=_crashed)
SLOW_SQUARES = JobSpec(work=_slow_square, key=_key, crashed=_crashed)


def test_records_follow_the_jobs_and_a_rerun_resumes_everything(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    first = run_jobs([3, 1, 2], SQUARES, log, "c1", workers=2)
    assert [r["value"] for r in first.records] == [9, 1, 4]
    assert (first.resumed, first.ran) == (0, 3)
    again = run_jobs([3, 1, 2, 4], SQUARES, log, "c1", workers=1)
    assert (again.resumed, again.ran) == (3, 1)
    other = run_jobs([3], SQUARES, log, "c2", workers=1)  # other settings or code: not resumed
    assert other.resumed == 0


def test_a_cut_last_line_is_cut_off_before_the_next_record(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    run_jobs([1, 2], SQUARES, log, "c", workers=1)
    with log.open("a") as handle:
        handle.write('{"config": "c", "key": "job3", "rec')  # a crash mid-write
    run_jobs([1, 2, 3], SQUARES, log, "c", workers=1)
    lines = log.read_text().splitlines()
    assert all(json.loads(line) for line in lines)  # no record glued to a broken line
    assert set(read_log(log, "c")) == {"job1", "job2", "job3"}


def _count_calls(job: Job) -> dict[str, Any]:
    calls = Path(os.environ["CLUTTER_GYM_TEST_CALLS"])
    with calls.open("a") as handle:
        handle.write(job.key + "\n")
    return {"key": job.key, "scene": job.case.label, "group": job.case.group,
            "noise": job.case.noise, "planner": job.planner, "seed": job.seed, "success": True,
            "reason": "", "planning_time_s": 0.1, "trials": 0, "execution_successes": 0,
            "error": ""}  # fmt: skip


def test_benchmark_keeps_every_record_after_a_cut_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On the old code the first record after a cut line was glued to it and run again."""
    calls = tmp_path / "calls.txt"
    monkeypatch.setenv("CLUTTER_GYM_TEST_CALLS", str(calls))
    out = tmp_path / "t.json"
    small = {"scenes_per_group": 1, "noises": ("sigma2",), "trials": 0, "workers": 1}
    run_benchmark("table1", ("tsr",), out, work=_count_calls, **small)
    log = out.with_name("t.json.jobs.jsonl")
    lines = log.read_text().splitlines()
    log.write_text("\n".join(lines[:1]) + "\n" + lines[1][: len(lines[1]) // 2])  # cut line 2
    run_benchmark("table1", ("tsr",), out, work=_count_calls, **small)  # reruns the cut job
    run_benchmark("table1", ("tsr",), out, work=_count_calls, **small)  # reruns nothing
    assert len(calls.read_text().splitlines()) == 3 + 2


def test_code_digest_covers_the_packages() -> None:
    assert len(code_digest()) == 16
    assert config_digest({"a": 1}) != config_digest({"a": 2})


def _start(script: str, tmp_path: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen(
        [sys.executable, "-c", script], cwd=tmp_path, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip


def _workers(parent: int, count: int, timeout: float = 60.0) -> list[psutil.Process]:
    """The pool's worker processes once ``count`` of them run (spawn's helpers excluded)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        children = psutil.Process(parent).children()
        workers = [c for c in children if "resource_tracker" not in " ".join(c.cmdline())]
        if len(workers) >= count:
            return workers
        time.sleep(0.2)
    raise AssertionError(f"no {count} workers started within {timeout} s")


RUN_SLOW = (
    "from pathlib import Path\n"
    "from agents.runner.jobs import run_jobs\n"
    "from tests.test_jobs import SLOW_SQUARES\n"
    "run_jobs([1, 2, 3, 4], SLOW_SQUARES, Path('run.jsonl'), 'c', workers=2)\n"
)


def test_workers_exit_soon_after_their_parent_is_killed(tmp_path: Path) -> None:
    parent = _start(RUN_SLOW, tmp_path)
    workers = _workers(parent.pid, 2)
    parent.kill()
    parent.wait()
    _, alive = psutil.wait_procs(workers, timeout=5.0)
    for process in alive:
        process.kill()
    assert not alive, f"{len(alive)} workers outlived their parent by 5 s"


def test_sigint_to_the_parent_alone_keeps_the_running_jobs(tmp_path: Path) -> None:
    parent = _start(RUN_SLOW, tmp_path)
    _workers(parent.pid, 2)
    time.sleep(1.0)  # both workers are inside their first 3 s job
    parent.send_signal(signal.SIGINT)
    _, err = parent.communicate(timeout=60)
    assert parent.returncode != 0 and "interrupted" in err
    kept = read_log(tmp_path / "run.jsonl", "c")
    assert set(kept) == {"job1", "job2"}  # the two running jobs, none started after
