"""One job runner for every long command (`benchmark`, `plan --execute`, `validate-capture`).

A run is a list of independent jobs and one function that turns a job into a JSON record. Every
job type follows one protocol (`Job`): its key in the log, its identity (the fields that say
which job a record is of) and its crash record. The runner owns what makes a long run
trustworthy, so no command writes it again:

* **Nothing lost.** Every finished record is appended to a JSONL log at once; a rerun with the
  same jobs skips what the log holds. A line cut by a crash mid-write is cut off the log before
  anything is appended, so the next record never lands on a broken line.
* **Nothing stale.** Each log line carries a `config` digest: the caller's settings, the package
  version and a digest of the project's own files (code, shipped data, scenes). Records made by
  other code or settings are never resumed.
* **Nothing left behind.** Workers are spawned processes that exit on their own within a second
  of losing their parent (a ``kill -9`` of the command), and ignore SIGINT: a Ctrl-C (SIGINT to
  the whole process group, or to the parent alone) lets running jobs finish and keeps their
  records; a second Ctrl-C stops them at once.
* **One writer per log.** A run holds a lock on ``<log>.lock`` (with its pid) while it runs: a
  second run given the same log says in one line which process uses it and stops (exit status
  2 on the command line) instead of running every job again beside it.
* **Crashes are records.** A worker that dies (a native crash, the OOM killer) breaks the pool;
  the jobs it was running are retried alone in a fresh pool, and one that kills its worker alone
  becomes its crash record (`Job.crashed`). A job that raises becomes one too; the run goes on.

`backend="ray"` runs the same jobs as Ray tasks (the `ray` extra): on the cluster at
``RAY_ADDRESS``, else on a local Ray with ``workers`` CPUs.
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import json
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, TypeVar

from tqdm import tqdm

import clutter_gym

Record = dict[str, Any]
J = TypeVar("J", bound="Job")
BACKENDS = ("local", "ray")
PARENT_POLL_S = 0.5
"""How often a worker checks that the process that started it is still alive."""
_PACKAGES = ("clutter_gym", "planners", "agents")


@functools.cache
def code_digest() -> str:
    """Digest of the package version and every file of the project's packages (code, shipped
    capture regions, scenes): a record made by other code is never resumed as if it were new."""
    digest = hashlib.sha256(clutter_gym.__version__.encode())
    root = Path(__file__).resolve().parents[2]
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(root)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def config_digest(settings: object) -> str:
    """The `config` of a run: its settings (anything JSON can show) and `code_digest`."""
    text = json.dumps([settings, code_digest()], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class JobRun:
    """Records in the order of the jobs; how many came from the log and how many ran now."""

    records: list[Record]
    resumed: int
    ran: int


class Job(Protocol):
    """What the runner needs of a job: every job type (a picklable module-level class) says
    which job it is and what its record is when it crashes; the work is a separate function."""

    @property
    def key(self) -> str:
        """The job's key in the log: unique among the jobs of a run."""
        ...

    def identity(self) -> Record:
        """The fields that say which job a record is of."""
        ...

    def crashed(self, error: str) -> Record:
        """The record of the job when it raised or killed its worker, from the error text."""
        ...


class NumberedTrial:
    """Key and identity of a job that is one numbered trial of a run (executions of a plan,
    validation poses); a job dataclass inherits them and adds its ``index`` field and its
    crash record."""

    index: int

    @property
    def key(self) -> str:
        return str(self.index)

    def identity(self) -> Record:
        return {"trial": self.index}


# --------------------------------------------------------------------------------------------
# The log
# --------------------------------------------------------------------------------------------
def read_log(log: Path, config: str) -> dict[str, Record]:
    """Records of this config by key; a line cut short (a crash mid-write) is skipped."""
    done: dict[str, Record] = {}
    if not log.exists():
        return done
    for line in log.read_text(errors="replace").splitlines():
        try:
            entry = json.loads(line)
        except ValueError:
            continue
        if isinstance(entry, dict) and entry.get("config") == config and "key" in entry:
            done[str(entry["key"])] = entry["record"]
    return done


def repair_log(log: Path) -> None:
    """Cut a last line that was not finished (no newline), so appends start on a new line."""
    if not log.exists():
        return
    with log.open("rb+") as handle:
        data = handle.read()
        if data and not data.endswith(b"\n"):
            handle.truncate(data.rfind(b"\n") + 1)


@contextmanager
def log_lock(log: Path) -> Iterator[None]:
    """Hold ``<log>.lock`` (an flock, with this process's pid in it) for the block; ValueError
    naming the process that holds it. The lock goes with the process, however it ends."""
    path = log.with_name(f"{log.name}.lock")
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise ValueError(
                f"the job log {log} is in use by process {holder} (another run with the same "
                "log); wait for it to finish or write elsewhere"
            ) from None
        if os.path.exists(path) and os.stat(path).st_ino == os.fstat(fd).st_ino:
            break  # the file the next run opens is the one we hold
        os.close(fd)  # a finished run removed the file between our open and our lock
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        path.unlink(missing_ok=True)
        os.close(fd)


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------
def run_jobs(
    jobs: Sequence[J],
    work: Callable[[J], Record],
    log: Path,
    config: str,
    *,
    workers: int = 2,
    backend: str = "local",
    desc: str = "jobs",
    describe: Callable[[Record], str] | None = None,
) -> JobRun:
    """Run (or resume) ``jobs``, each by ``work`` (a picklable module-level function); every
    record is in ``log`` before this returns or raises."""
    if backend not in BACKENDS:
        raise ValueError(f"backend: {backend!r} is unknown; allowed: {', '.join(BACKENDS)}")
    if workers < 1:
        raise ValueError(f"workers: {workers}; must be >= 1")
    keys = [job.key for job in jobs]
    if len(set(keys)) != len(keys):
        raise ValueError("jobs: two jobs share a key; every job needs its own")
    log.parent.mkdir(parents=True, exist_ok=True)
    with log_lock(log):
        return _run_logged(jobs, keys, work, log, config, workers, backend, desc, describe)


def _run_logged(
    jobs: Sequence[J],
    keys: list[str],
    work: Callable[[J], Record],
    log: Path,
    config: str,
    workers: int,
    backend: str,
    desc: str,
    describe: Callable[[Record], str] | None,
) -> JobRun:
    """`run_jobs` once it holds the log."""
    repair_log(log)
    done = read_log(log, config)
    todo = [job for job, k in zip(jobs, keys, strict=True) if k not in done]
    resumed = len(jobs) - len(todo)
    if resumed:
        print(
            f"resumed {resumed} of {len(jobs)} {desc} records from {log} (delete it to redo them)",
            file=sys.stderr,
        )
    runner = _ray if backend == "ray" else _local
    with (
        log.open("a") as handle,
        tqdm(total=len(jobs), initial=resumed, desc=desc, unit="job") as bar,
    ):
        for job, record in runner(todo, work, workers):
            key = job.key
            handle.write(json.dumps({"config": config, "key": key, "record": record}) + "\n")
            handle.flush()
            done[key] = record
            bar.update()
            if describe is not None:
                bar.set_postfix_str(f"{key}: {describe(record)}")
    return JobRun([done[k] for k in keys], resumed, len(todo))


def _guarded(work: Callable[[J], Record], job: J) -> Record:
    """The job's record; an exception it raises becomes its crash record."""
    try:
        return work(job)
    except Exception as error:
        return job.crashed(f"{type(error).__name__}: {error}")


Finished = Iterator[tuple[Any, Record]]


def _local(jobs: list[J], work: Callable[[J], Record], workers: int) -> Finished:
    """In this process for one worker; else a spawn pool with at most ``workers`` jobs in
    flight, fresh pools after a worker died (its jobs retried one at a time)."""
    if workers <= 1:
        for job in jobs:
            yield job, _guarded(work, job)
        return
    queue, suspects = list(jobs), list[J]()
    with FirstInterrupt("finishing the running jobs and keeping their results") as interrupt:
        while (queue and not interrupt.seen) or suspects:
            alone = bool(suspects)
            batch, limit = (suspects, 1) if alone else (queue, workers)
            pool = ProcessPoolExecutor(
                limit,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=_worker_init,
                initargs=(os.getpid(),),
            )
            try:
                yield from _drain(pool, batch, limit, work, suspects, interrupt)
            except BaseException:  # a second Ctrl-C, or the consumer gave up: stop them now
                _terminate(pool)
                raise
            pool.shutdown(wait=True)
            if interrupt.seen:
                suspects.clear()
    if interrupt.seen:
        raise KeyboardInterrupt


def _drain(
    pool: ProcessPoolExecutor,
    batch: list[J],
    limit: int,
    work: Callable[[J], Record],
    suspects: list[J],
    interrupt: FirstInterrupt,
) -> Finished:
    """Run jobs of ``batch`` in the pool, ``limit`` at a time, until the batch is done (or an
    interrupt stops new ones). A worker that dies breaks the pool: the jobs running then join
    ``suspects`` to be retried alone, and one that dies alone becomes its crash record."""
    alone = batch is suspects
    running: dict[Future[Record], J] = {}
    while (batch and not interrupt.seen) or running:
        while batch and not interrupt.seen and len(running) < limit:
            job = batch.pop(0)
            running[pool.submit(_guarded, work, job)] = job
        finished, _ = wait(running, timeout=0.2, return_when=FIRST_COMPLETED)
        for future in finished:
            job = running.pop(future)
            try:
                record = future.result()
            except BrokenProcessPool:
                if alone:
                    yield job, job.crashed("the worker process died running it")
                else:
                    suspects.append(job)
                suspects.extend(running.values())  # empty when alone
                return
            yield job, record


class FirstInterrupt:
    """While active, the first SIGINT only sets `seen` and prints ``message`` (the caller
    finishes what runs and keeps it); the second raises KeyboardInterrupt as usual. A no-op
    outside the main thread."""

    def __init__(self, message: str) -> None:
        self.seen = False
        self.message = message
        self._previous: Any = None

    def __enter__(self) -> FirstInterrupt:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *_: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)

    def _handle(self, *_: object) -> None:
        self.seen = True
        signal.signal(signal.SIGINT, signal.default_int_handler)
        print(f"\ninterrupted: {self.message} (Ctrl-C again to stop now)", file=sys.stderr)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Kill a pool's workers now (Python 3.11 has no public call for it)."""
    for process in list(getattr(pool, "_processes", {}).values()):
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _worker_init(parent: int) -> None:
    """Workers leave SIGINT to the parent (which lets them finish their job) and exit by
    themselves when the parent is gone, whatever killed it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_with_parent, args=(parent,), daemon=True).start()


def _exit_with_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


def _ray(jobs: list[J], work: Callable[[J], Record], workers: int) -> Finished:
    """The same jobs as Ray tasks; a task whose worker dies is retried once, then crashed."""
    try:
        import ray
    except ImportError:
        raise ValueError("backend: 'ray' needs the ray extra: pip install -e '.[ray]'") from None
    started = False
    if not ray.is_initialized():
        options: dict[str, Any] = {"log_to_driver": False}
        if not os.environ.get("RAY_ADDRESS"):
            options.update(num_cpus=workers, include_dashboard=False)
        ray.init(**options)
        started = True
    try:
        remote: Any = ray.remote(num_cpus=1, max_retries=1)(_guarded)
        pending = {remote.remote(work, job): job for job in jobs}
        while pending:
            (ready,), _ = ray.wait(list(pending), num_returns=1)
            job = pending.pop(ready)
            try:
                yield job, ray.get(ready)
            except ray.exceptions.RayError as error:
                yield job, job.crashed(f"{type(error).__name__}: {error}".splitlines()[0])
    finally:
        if started:
            ray.shutdown()
