"""Typed records of what the long commands measure: one execution of a plan (`TrialOutcome`), a
plan's executions summed up (`ExecutionSummary`) and one benchmark job (`BenchmarkRecord`).

Each is a frozen dataclass with ``as_dict`` (the JSON of the reports and job logs) and
``from_dict`` (a record read back from a log); the JSON has the same keys it always had, so
reports stay comparable across versions.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

Json = dict[str, Any]


@dataclass(frozen=True)
class TrialOutcome:
    """One execution of a plan on a true world; a crashed trial has no lift or time."""

    success: bool
    failure: str  # "" when nothing failed; otherwise the env's reason or "crashed: ..."
    goal_lift_m: float | None = None
    simulated_s: float | None = None

    def as_dict(self) -> Json:
        return {k: v for k, v in asdict(self).items() if v is not None}

    @classmethod
    def from_dict(cls, d: Json) -> TrialOutcome:
        return cls(
            bool(d["success"]), str(d["failure"]), d.get("goal_lift_m"), d.get("simulated_s")
        )

    @classmethod
    def crashed(cls, error: str) -> TrialOutcome:
        return cls(False, f"crashed: {error}")


@dataclass(frozen=True)
class ExecutionSummary:
    """Executions of one plan: successes, failures by reason, mean simulated time of the
    trials that ran to the end."""

    trials: int
    execution_successes: int
    execution_success_rate: float | None
    execution_failures: dict[str, int]
    mean_execution_simulated_s: float | None

    @classmethod
    def of(cls, outcomes: list[TrialOutcome]) -> ExecutionSummary:
        successes = sum(o.success for o in outcomes)
        failures: dict[str, int] = {}
        for o in outcomes:
            if not o.success:
                reason = o.failure or "goal not retrieved"
                failures[reason] = failures.get(reason, 0) + 1
        simulated = [o.simulated_s for o in outcomes if o.simulated_s is not None]
        return cls(
            trials=len(outcomes),
            execution_successes=successes,
            execution_success_rate=successes / len(outcomes) if outcomes else None,
            execution_failures=failures,
            mean_execution_simulated_s=(round(float(np.mean(simulated)), 2) if simulated else None),
        )

    def as_dict(self) -> Json:
        return asdict(self)


@dataclass(frozen=True)
class PlanFacts:
    """What a returned or failed plan looked like (absent when the job crashed)."""

    actions: int
    objects_moved: list[str]
    blocked_by: list[str]


@dataclass(frozen=True)
class BenchmarkRecord:
    """One benchmark job: a case planned by one planner and, if it planned, executed."""

    key: str
    scene: str
    group: str
    noise: str
    planner: str
    seed: int
    success: bool
    reason: str
    planning_time_s: float | None
    error: str = ""
    plan: PlanFacts | None = None
    plan_digest: str | None = None  # of the plan's trajectory rows, when there is a plan
    execution: ExecutionSummary | None = None

    @property
    def trials(self) -> int:
        return self.execution.trials if self.execution else 0

    @property
    def execution_successes(self) -> int:
        return self.execution.execution_successes if self.execution else 0

    def as_dict(self) -> Json:
        out: Json = {
            "key": self.key,
            "scene": self.scene,
            "group": self.group,
            "noise": self.noise,
            "planner": self.planner,
            "seed": self.seed,
            "success": self.success,
            "reason": self.reason,
            "planning_time_s": self.planning_time_s,
        }
        if self.plan is not None:
            out.update(asdict(self.plan))
        out.update(trials=self.trials, execution_successes=self.execution_successes)
        if self.plan_digest is not None:
            out["plan_digest"] = self.plan_digest
        if self.execution is not None:
            out.update(self.execution.as_dict())
        out["error"] = self.error
        return out

    @classmethod
    def from_dict(cls, d: Json) -> BenchmarkRecord:
        plan = (
            PlanFacts(d["actions"], list(d["objects_moved"]), list(d["blocked_by"]))
            if "actions" in d
            else None
        )
        execution = (
            ExecutionSummary(
                d["trials"],
                d["execution_successes"],
                d["execution_success_rate"],
                dict(d["execution_failures"]),
                d["mean_execution_simulated_s"],
            )
            if "execution_failures" in d
            else None
        )
        return cls(
            key=d["key"],
            scene=d["scene"],
            group=d["group"],
            noise=d["noise"],
            planner=d["planner"],
            seed=int(d["seed"]),
            success=bool(d["success"]),
            reason=d["reason"],
            planning_time_s=d["planning_time_s"],
            error=d.get("error", ""),
            plan=plan,
            plan_digest=d.get("plan_digest"),
            execution=execution,
        )
