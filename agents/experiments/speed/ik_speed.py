"""`clutter-gym bench ik`: the analytic IK against a random-restart reference, as JSON.

Both solve the same seeded level-hand poses over the table (the reachability map's probe: hand
horizontal at grasp height, any of the 24 headings, the table and self-collision check as
``accept``), taking turns per target, alternating which goes first, so that a change of load on
a shared machine slows both alike. The reference, random-restart Levenberg-Marquardt, is built
here on `ArmKinematics.solve_ik_local` with the settings the planner's IK had with it
(descent from the home pose, then 8 random elbow-up starts, the best of up to 3 accepted
solutions); nothing else uses it.
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from tqdm import tqdm

from clutter_gym.model import herb as hm
from clutter_gym.model.collision import make_checker
from clutter_gym.model.kinematics import (
    CHECK_SPACING,
    J3_SAMPLES,
    MAX_CHECKS,
    MAX_JUMP,
    ArmKinematics,
)
from clutter_gym.model.reachability import HEADINGS_DEG, HEIGHTS, PROBE_HAND, hand_pose
from clutter_gym.model.world import TABLE
from clutter_gym.sim.bullet import native_stdout_muted

X_RANGE = (0.45, 0.95)
"""m: hand_base x of the targets (HERB's table workspace and a margin on either side)."""
Y_RANGE = (-0.5, 0.2)
"""m: hand_base y of the targets (the right arm's side of the table)."""
ANALYTIC = "analytic"
PREVIOUS = "lm_restarts (previous solver)"

Solver = Callable[[np.ndarray], np.ndarray | None]

# The reference solver's settings: restarts, iterations and accepted solutions.
_RESTARTS = 8
_SOLUTIONS = 3
_MAX_ITER = 100
_MAX_WRIST_REACH = float(np.hypot(0.55, 0.045) + np.hypot(0.3, 0.045))


def targets(samples: int, seed: int = 0) -> list[np.ndarray]:
    """``samples`` seeded TCP poses (4x4) of a level hand over the table."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(samples):
        xy = np.array([rng.uniform(*X_RANGE), rng.uniform(*Y_RANGE)])
        heading = math.radians(HEADINGS_DEG[rng.integers(len(HEADINGS_DEG))])
        out.append(hand_pose(xy, heading, TABLE.top_z + HEIGHTS[rng.integers(len(HEIGHTS))]))
    return out


def lm_restarts(
    kinematics: ArmKinematics,
    target: np.ndarray,
    accept: Callable[[np.ndarray], bool],
    rng: np.random.Generator,
) -> np.ndarray | None:
    """The reference: `solve_ik(target, RIGHT_ARM_HOME, rng, accept, max_restarts=8)`."""
    wrist = target[:3, 3] - (hm.HAND_MOUNT_XYZ[2] + hm.HAND_TCP_OFFSET) * target[:3, 2]
    if np.linalg.norm(wrist - kinematics.shoulder) > _MAX_WRIST_REACH:
        return None
    found: list[np.ndarray] = []
    for attempt in range(1 + _RESTARTS):
        start = kinematics.home if attempt == 0 else _elbow_up(kinematics, rng)
        q = kinematics.solve_ik_local(target, start, max_iter=_MAX_ITER)
        if q is None or not accept(q):
            continue
        if attempt == 0:
            return q
        found.append(q)
        if len(found) >= _SOLUTIONS:
            break
    if not found:
        return None
    return min(found, key=lambda s: float(np.linalg.norm(s - kinematics.home)))


def _elbow_up(kinematics: ArmKinematics, rng: np.random.Generator) -> np.ndarray:
    """The reference's random restart: uniform in the limits, elbow above the shoulder-wrist line
    (the best of 16 draws if none is)."""
    qs = rng.uniform(kinematics.lower, kinematics.upper, size=(16, 7))
    score = np.array([kinematics.elbow_height(q) for q in qs])
    good = np.flatnonzero(score > 0.0)
    return qs[rng.choice(good)] if good.size else qs[int(np.argmax(score))]


def bench_ik(samples: int = 500, seed: int = 0) -> dict[str, Any]:
    """Calls per second, ms per successful and per failed call and success rate of each
    solver on the same targets, how many targets one solves that the other does not, and the
    analytic solutions' cost over the whole j3 sweep and within a swung waypoint's window."""
    if samples < 1:
        raise ValueError(f"samples: {samples}; must be >= 1")
    kinematics = ArmKinematics("right")
    free = make_checker(TABLE, {}).checker(PROBE_HAND, objects=False)
    rng = np.random.default_rng(seed)
    solvers: dict[str, Solver] = {
        ANALYTIC: lambda t: kinematics.solve_ik(t, accept=free),
        PREVIOUS: lambda t: lm_restarts(kinematics, t, free, rng),
    }
    times: dict[str, list[float]] = {name: [] for name in solvers}
    solved: dict[str, list[bool]] = {name: [] for name in solvers}
    with native_stdout_muted():
        for i, target in enumerate(tqdm(targets(samples, seed), desc="bench ik", unit="pose")):
            for name in list(solvers)[:: 1 if i % 2 == 0 else -1]:
                start = time.perf_counter()
                q = solvers[name](target)
                times[name].append(time.perf_counter() - start)
                solved[name].append(q is not None)
    result: dict[str, Any] = {
        "benchmark": "ik",
        "python": platform.python_version(),
        "targets": samples,
        "analytic_settings": {
            "j3_samples": J3_SAMPLES,
            "max_checks": MAX_CHECKS,
            "check_spacing": CHECK_SPACING,
        },
    }
    for name in solvers:
        result[name] = _summary(np.array(times[name]), np.array(solved[name]))
    ours, previous = np.array(solved[ANALYTIC]), np.array(solved[PREVIOUS])
    result["found_only_by_analytic"] = int(np.sum(ours & ~previous))
    result["found_only_by_lm_restarts"] = int(np.sum(previous & ~ours))
    result["solutions_ms"] = _sweep_ms(kinematics, targets(samples, seed))
    return result


def _sweep_ms(kinematics: ArmKinematics, poses: list[np.ndarray]) -> dict[str, float]:
    """ms per `ik_solutions` call over the whole j3 range and within `MAX_JUMP` (a swung
    waypoint's window) of the seed's j3 (the home pose's here), on the same poses, taking
    turns."""
    seconds = {"full_sweep": 0.0, "j3_window": 0.0}
    for i, pose in enumerate(poses):
        for name in list(seconds)[:: 1 if i % 2 == 0 else -1]:
            within = None if name == "full_sweep" else MAX_JUMP
            start = time.perf_counter()
            kinematics.ik_solutions(pose, kinematics.home, j3_within=within)
            seconds[name] += time.perf_counter() - start
    return {name: round(1e3 * total / len(poses), 4) for name, total in seconds.items()}


def _summary(times: np.ndarray, solved: np.ndarray) -> dict[str, float | int | None]:
    def mean_ms(mask: np.ndarray) -> float | None:
        return round(1e3 * float(times[mask].mean()), 3) if mask.any() else None

    return {
        "calls_per_s": round(len(times) / float(times.sum()), 1),
        "mean_ms_success": mean_ms(solved),
        "mean_ms_failure": mean_ms(~solved),
        "success_rate": round(float(solved.mean()), 4),
        "solved": int(solved.sum()),
    }
