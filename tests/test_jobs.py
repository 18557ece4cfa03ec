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

from agents.cli import main
from agents.experiments.benchmark import Job, run_benchmark
from agents.runner.jobs import (
    code_digest,
    config_digest,
    log_lock,
    read_log,
    run_jobs,
)
from tests.helpers import Square, square

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent


def squares(*ns: int) -> list[Square]:
    return [Square(n) for n in ns]


def test_records_follow_the_jobs_and_a_rerun_resumes_everything(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    first = run_jobs(squares(3, 1, 2), square, log, "c1", workers=2)
    assert [r["value"] for r in first.records] == [9, 1, 4]
    assert (first.resumed, first.ran) == (0, 3)
    again = run_jobs(squares(3, 1, 2, 4), square, log, "c1", workers=1)
    assert (again.resumed, again.ran) == (3, 1)
    other = run_jobs(squares(3), square, log, "c2", workers=1)  # other settings or code: afresh
    assert other.resumed == 0


def test_a_cut_last_line_is_cut_off_before_the_next_record(tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    run_jobs(squares(1, 2), square, log, "c", workers=1)
    with log.open("a") as handle:
        handle.write('{"config": "c", "key": "job3", "rec')  # a crash mid-write
    run_jobs(squares(1, 2, 3), square, log, "c", workers=1)
    lines = log.read_text().splitlines()
    assert all(json.loads(line) for line in lines)  # no record glued to a broken line
    assert set(read_log(log, "c")) == {"job1", "job2", "job3"}


def _count_calls(job: Job) -> dict[str, Any]:
    calls = Path(os.environ["CLUTTER_GYM_TEST_CALLS"])
    with calls.open("a") as handle:
        handle.write(job.key + "\n")
    return {
        "key": job.key,
        "scene": job.case.label,
        "group": job.case.group,
        "noise": job.case.noise,
        "planner": job.planner,
        "seed": job.seed,
        "success": True,
        "reason": "",
        "planning_time_s": 0.1,
        "trials": 0,
        "execution_successes": 0,
        "error": "",
    }


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
        [sys.executable, "-c", script],
        cwd=tmp_path,
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )


def _started(directory: Path, *jobs: int, timeout: float = 60.0) -> None:
    """Wait until each of ``jobs`` runs (`gated_square` says so in ``directory``)."""
    deadline = time.monotonic() + timeout
    while not all((directory / f"started-{n}").exists() for n in jobs):
        assert time.monotonic() < deadline, f"jobs {jobs} did not all start within {timeout} s"
        time.sleep(0.02)


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


RUN_GATED = (
    "from pathlib import Path\n"
    "from agents.runner.jobs import run_jobs\n"
    "from tests.helpers import Square, gated_square\n"
    "run_jobs([Square(n) for n in (1, 2, 3, 4)], gated_square, Path('run.jsonl'), 'c', workers=2)\n"
)


def test_workers_exit_soon_after_their_parent_is_killed(tmp_path: Path) -> None:
    parent = _start(RUN_GATED, tmp_path)
    workers = _workers(parent.pid, 2)
    _started(tmp_path, 1, 2)  # never released: only the parent's death ends them
    parent.kill()
    parent.wait()
    _, alive = psutil.wait_procs(workers, timeout=5.0)
    for process in alive:
        process.kill()
    assert not alive, f"{len(alive)} workers outlived their parent by 5 s"


def test_sigint_to_the_parent_alone_keeps_the_running_jobs(tmp_path: Path) -> None:
    parent = _start(RUN_GATED, tmp_path)
    _started(tmp_path, 1, 2)  # both workers are inside their first job
    parent.send_signal(signal.SIGINT)
    assert parent.stderr is not None
    seen = []
    while not any("interrupted:" in line for line in seen):  # the parent took the SIGINT
        line = parent.stderr.readline()
        assert line, "".join(seen)
        seen.append(line)
    (tmp_path / "release").touch()
    _, rest = parent.communicate(timeout=60)
    err = "".join(seen) + rest
    assert parent.returncode != 0 and "interrupted" in err
    kept = read_log(tmp_path / "run.jsonl", "c")
    assert set(kept) == {"job1", "job2"}  # the two running jobs, none started after


def test_a_second_run_on_the_same_log_says_which_process_uses_it(tmp_path: Path) -> None:
    parent = _start(RUN_GATED, tmp_path)
    try:
        _started(tmp_path, 1, 2)  # the first run holds its log
        with pytest.raises(ValueError, match=rf"in use by process {parent.pid}\b"):
            run_jobs(squares(5), square, tmp_path / "run.jsonl", "c", workers=1)
    finally:
        (tmp_path / "release").touch()
        parent.communicate(timeout=60)
    assert parent.returncode == 0
    assert set(read_log(tmp_path / "run.jsonl", "c")) == {"job1", "job2", "job3", "job4"}
    run_jobs(squares(5), square, tmp_path / "run.jsonl", "c", workers=1)  # free again
    assert not (tmp_path / "run.jsonl.lock").exists()


def test_the_command_line_refuses_a_log_in_use_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "b.json"
    argv = [
        "benchmark",
        "--suite",
        "table1",
        "--planners",
        "tsr",
        "--json",
        str(out),
        "--scenes-per-group",
        "1",
        "--noises",
        "sigma2",
        "--trials",
        "0",
        "--workers",
        "1",
    ]
    with log_lock(out.with_name("b.json.jobs.jsonl")):
        assert main(argv) == 2
    _, err = capsys.readouterr()
    (line,) = err.strip().splitlines()
    assert line.startswith("clutter-gym benchmark: error: the job log") and str(os.getpid()) in line
    assert not out.exists()
