"""The agents of `clutter-gym evaluate` as given on the command line: a training directory,
``planner:NAME`` or ``scripted``. Checked at parse time, so only the run's files and the
planners' names are read (no simulator, no torch)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from agents.learning.runs import TrainedRun, read_run
from planners.kinds import PLANNERS

SCRIPTED = "scripted"
PLANNER_PREFIX = "planner:"


@dataclass(frozen=True)
class AgentSpec:
    """An agent as given on the command line: a trained run, a planner or the scripted grasp."""

    label: str
    kind: str  # "trained", "planner" or "scripted"
    planner: str = ""
    run: TrainedRun | None = None
    digest: str = ""


def parse_agent(text: str) -> AgentSpec:
    """``planner:NAME``, ``scripted`` or a training directory; ValueError listing them."""
    if text == SCRIPTED:
        return AgentSpec(label=text, kind="scripted")
    if text.startswith(PLANNER_PREFIX):
        name = text[len(PLANNER_PREFIX) :]
        if name not in PLANNERS:
            raise ValueError(
                f"{text!r}: no such planner; allowed: "
                + ", ".join(PLANNER_PREFIX + p for p in PLANNERS)
            )
        return AgentSpec(label=text, kind="planner", planner=name)
    directory = Path(text)
    if not directory.is_dir():
        allowed = ", ".join([*(PLANNER_PREFIX + p for p in PLANNERS), SCRIPTED])
        raise ValueError(f"{text!r} is not a training directory, nor one of: {allowed}")
    run = read_run(directory)
    digest = hashlib.sha256(run.model.read_bytes()).hexdigest()[:16]
    return AgentSpec(label=text, kind="trained", run=run, digest=digest)
