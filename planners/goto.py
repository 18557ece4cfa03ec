"""GoTo of Dogar & Srinivasa's framework: a collision-free joint-space path of HERB's 7-DoF arm.

Why this module exists: the pushing and grasping actions end where they start their motion, so
the arm needs a plain point-to-point planner between configurations. It wraps OMPL's RRTConnect
on a bounded ``RealVectorStateSpace(7)`` and takes the collision test as a callable, so the
caller decides what counts as free (surface only, objects, ignored objects).

OMPL 2.0.1's Python bindings crash on ``list(state)``/``np.array(state)`` and abort on bad
input, so states are read by index and every request is validated before OMPL sees it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from clutter_gym.model.collision import interpolate
from clutter_gym.model.kinematics import ArmKinematics

DOF = 7


@dataclass(frozen=True)
class GoToResult:
    """Outcome of one GoTo request; ``reason`` says why it failed and is empty on success."""

    path: np.ndarray | None
    """(N, 7) joint waypoints from start to goal, or None on failure."""
    success: bool
    reason: str
    planning_time: float
    """Wall-clock seconds of the whole request (validation, planning, simplification, checks)."""
    collision_checks: int
    """Calls of ``is_valid`` made for this request, by OMPL and by the checks here."""


def _request_error(
    start: np.ndarray, goal: np.ndarray, lower: np.ndarray, upper: np.ndarray, time_budget: float
) -> str:
    """Why the request cannot be planned, or "" if it can; checked here because OMPL aborts."""
    if not (math.isfinite(time_budget) and time_budget > 0):
        return f"time budget must be > 0 (got {time_budget})"
    for name, q in (("start", start), ("goal", goal), ("lower", lower), ("upper", upper)):
        if q.shape != (DOF,):
            return f"{name} must have shape ({DOF},) (got {q.shape})"
        if not np.all(np.isfinite(q)):
            return f"{name} has non-finite values"
    if np.any(lower >= upper):
        return "joint limits must satisfy lower < upper in every joint"
    for name, q in (("start", start), ("goal", goal)):
        outside = np.flatnonzero((q < lower) | (q > upper))
        if outside.size:
            i = int(outside[0])
            return (
                f"{name} outside joint limits (joint {i}: {q[i]:.4f}, "
                f"range [{lower[i]:.4f}, {upper[i]:.4f}])"
            )
    return ""


NO_PATH = "no path found"
"""How the reason of a request that planned and found nothing begins (as against bad input or
an end in collision)."""

PLAN_ATTEMPTS = 3
"""OMPL runs (seeds seed, seed + 1, ...) before a path that fails the dense re-check is final."""


def _reseed(seed: int) -> None:
    """Seed OMPL's RNGs created from now on; OMPL ignores seed 0, so seeds are shifted by one.

    Re-seeding logs an error ("generation already started") although RNGs created afterwards are
    seeded deterministically, which is all a planner built after this needs; the log is muted."""
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    try:
        ou.RNG.setSeed(seed + 1)
    finally:
        ou.setLogLevel(level)


@dataclass(frozen=True)
class JointConstraint:
    """A task constraint f(q) = 0 on the arm's joints, with its Jacobian (k, 7): GoTo then plans
    on the constraint manifold with OMPL's ProjectedStateSpace (e.g. a grasped object kept
    upright). ``tolerance`` is how far from zero |f| may be at a checked configuration."""

    codimension: int
    function: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    tolerance: float = 1e-3


class _OmplConstraint(ob.Constraint):
    def __init__(self, constraint: JointConstraint, on_jacobian: Callable[[], None]) -> None:
        super().__init__(DOF, constraint.codimension, constraint.tolerance)
        self.constraint = constraint
        self.on_jacobian = on_jacobian

    def function(self, x: np.ndarray, out: np.ndarray) -> None:
        out[:] = self.constraint.function(np.asarray(x, dtype=float))

    def jacobian(self, x: np.ndarray, out: np.ndarray) -> None:
        self.on_jacobian()
        out[:, :] = self.constraint.jacobian(np.asarray(x, dtype=float))


def upright_hand(kinematics: ArmKinematics) -> JointConstraint:
    """The hand's x axis stays vertical: the finger plane horizontal, so a grasped object
    standing upright stays upright, whatever the heading (the 2 horizontal components of the
    axis are the constraint; their Jacobian is w_i x axis from the angular Jacobian).

    OMPL's projection calls these tens of thousands of times per plan, so each call runs the
    forward kinematics once (``tcp_pose_and_jacobian``) and writes the cross product out."""

    def function(q: np.ndarray) -> np.ndarray:
        return kinematics.fk_tcp(q)[:2, 0].copy()

    def jacobian(q: np.ndarray) -> np.ndarray:
        pose, full = kinematics.tcp_pose_and_jacobian(q)
        a, w = pose[:3, 0], full[3:]
        # Rows x and y of w_i x a for every joint column i.
        return np.stack([w[1] * a[2] - w[2] * a[1], w[2] * a[0] - w[0] * a[2]])

    return JointConstraint(2, function, jacobian)


def _ompl_plan(
    start: np.ndarray,
    goal: np.ndarray,
    is_free: Callable[[np.ndarray], bool],
    lower: np.ndarray,
    upper: np.ndarray,
    stop: Callable[[], bool],
    resolution: float,
    constraint: JointConstraint | None = None,
    on_jacobian: Callable[[], None] = lambda: None,
) -> np.ndarray | None:
    """RRTConnect until ``stop()``, then shortcutting; the waypoints, or None if no exact
    solution was found."""
    ambient = ob.RealVectorStateSpace(DOF)
    bounds = ob.RealVectorBounds(DOF)
    for i in range(DOF):
        bounds.setLow(i, float(lower[i]))
        bounds.setHigh(i, float(upper[i]))
    ambient.setBounds(bounds)
    if constraint is None:
        space = ambient
        setup = og.SimpleSetup(space)
    else:
        ompl_constraint = _OmplConstraint(constraint, on_jacobian)
        space = ob.ProjectedStateSpace(ambient, ompl_constraint)
        setup = og.SimpleSetup(ob.ConstrainedSpaceInformation(space))
    setup.setStateValidityChecker(
        lambda state: is_free(np.array([state[i] for i in range(DOF)], dtype=float))
    )
    info = setup.getSpaceInformation()
    # OMPL's resolution is a fraction of the space's extent and steps along the L2 metric, so a
    # step of `resolution` in L2 moves no joint by more than `resolution` rad.
    info.setStateValidityCheckingResolution(resolution / space.getMaximumExtent())
    setup.setPlanner(og.RRTConnect(info))
    endpoints = []
    for q in (start, goal):
        state = space.allocState()
        if constraint is None:
            for i in range(DOF):
                state[i] = float(q[i])
        else:  # constrained states are filled whole (they do not take item assignment)
            state.copy([float(v) for v in q])
        endpoints.append(state)
    setup.setStartAndGoalStates(endpoints[0], endpoints[1])
    status = setup.solve(ob.PlannerTerminationCondition(stop))
    if status.getStatus() != ob.PlannerStatus.EXACT_SOLUTION:
        return None
    path = setup.getSolutionPath()
    if constraint is not None:
        # Straight joint segments would leave the manifold: keep the projected states, densely.
        path.interpolate()
        return np.array(
            [[path.getState(k)[i] for i in range(DOF)] for k in range(path.getStateCount())],
            dtype=float,
        )
    # Shortcuts with a fixed number of attempts (seeded, so deterministic); simplifyMax also
    # smooths until nothing improves, which cost 1 s of collision checks per path here.
    simplifier = og.PathSimplifier(info)
    simplifier.reduceVertices(path)
    simplifier.collapseCloseVertices(path)
    return np.array(
        [[path.getState(k)[i] for i in range(DOF)] for k in range(path.getStateCount())],
        dtype=float,
    )


def plan_goto(
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    lower: np.ndarray,
    upper: np.ndarray,
    time_budget: float = 2.0,
    seed: int = 0,
    resolution: float = 0.01,
    constraint: JointConstraint | None = None,
    max_evaluations: int | None = None,
    direct: bool = True,
) -> GoToResult:
    """Plan a collision-free joint path from start to goal within the joint limits: the
    straight joint-space segment if it is free (unless ``direct`` is False: the caller has
    found it is not), else RRTConnect; with a ``constraint``,
    RRTConnect on its manifold (ProjectedStateSpace) and a densely interpolated path.

    The search stops after ``time_budget`` seconds or ``max_evaluations`` evaluations, whichever
    comes first: collision checks, plus the constraint's Jacobian evaluations when constrained
    (projecting onto the manifold is what costs there). A count makes the outcome independent of
    the machine's speed and load (the same seed gives the same path on a busy CI worker), so
    planners should bound GoTo by evaluations and keep the time budget as a cap. Once the budget
    is spent every state counts as invalid, which ends an extension in progress at once (OMPL
    asks its termination condition only between iterations, and one constrained extension can
    walk the manifold for seconds).

    ``is_valid(q)`` is True when configuration q is free. The path is simplified and then every
    straight segment is re-checked so that no joint moves more than ``resolution`` rad between
    checked configurations; the same seed and inputs give the same path."""
    began = time.perf_counter()
    limit = math.inf if max_evaluations is None else max_evaluations
    count = _Evaluations(is_valid, limit, began + float(time_budget))

    def result(path: np.ndarray | None, reason: str) -> GoToResult:
        return GoToResult(
            path=path,
            success=path is not None,
            reason=reason,
            planning_time=time.perf_counter() - began,
            collision_checks=count.checks,
        )

    q0, q1 = (np.asarray(q, dtype=float) for q in (start, goal))
    lo, hi = (np.asarray(b, dtype=float) for b in (lower, upper))
    error = _request_error(q0, q1, lo, hi, float(time_budget)) or _settings_error(
        resolution, seed, max_evaluations
    )
    error = error or _endpoints_error(q0, q1, count.free, constraint)
    if error:
        return result(None, error)
    # Most transits between actions are free in a straight joint line: try it before OMPL.
    line = np.stack([q0, q1])
    if (
        direct
        and constraint is None
        and all(count.free(q) for q in interpolate(line, resolution)[1:-1])
    ):
        return result(line, "")
    # OMPL checks each motion at its own sample points: a path it found can still touch an
    # obstacle between them, which the dense re-check catches; the next seed plans around it.
    error = ""
    for attempt in range(PLAN_ATTEMPTS):
        level = ou.getLogLevel()
        ou.setLogLevel(ou.LogLevel.LOG_WARN)
        try:
            _reseed(seed + attempt)
            path = _ompl_plan(
                q0,
                q1,
                count.free_within_budget,
                lo,
                hi,
                count.stop,
                resolution,
                constraint,
                count.add_jacobian,
            )
        finally:
            ou.setLogLevel(level)
        if path is None:
            if count.spent():
                return result(None, f"{NO_PATH} within {max_evaluations} evaluations")
            return result(None, f"{NO_PATH} within {time_budget:g} s")
        error = _path_error(path, count.free, resolution, constraint)
        if not error:
            return result(path, "")
    return result(None, error)


class _Evaluations:
    """The evaluations of one request (collision checks, and the constraint's Jacobians when
    constrained), against their limit and the wall-clock deadline."""

    def __init__(
        self, is_valid: Callable[[np.ndarray], bool], limit: float, deadline: float
    ) -> None:
        self.is_valid = is_valid
        self.limit = limit
        self.deadline = deadline
        self.checks = 0
        self.jacobians = 0

    def free(self, q: np.ndarray) -> bool:
        self.checks += 1
        return bool(self.is_valid(q))

    def add_jacobian(self) -> None:
        self.jacobians += 1

    def spent(self) -> bool:
        return self.checks + self.jacobians >= self.limit

    def stop(self) -> bool:
        return self.spent() or time.perf_counter() >= self.deadline

    def free_within_budget(self, q: np.ndarray) -> bool:
        """Invalid once the budget is spent: ends an extension in progress at once."""
        return not self.stop() and self.free(q)


def _settings_error(resolution: float, seed: int, max_evaluations: int | None) -> str:
    if not (math.isfinite(resolution) and resolution > 0):
        return f"resolution must be > 0 (got {resolution})"
    if seed < 0:
        return f"seed must be >= 0 (got {seed})"
    if max_evaluations is not None and max_evaluations < 1:
        return f"max_evaluations must be >= 1 (got {max_evaluations})"
    return ""


def _endpoints_error(
    q0: np.ndarray,
    q1: np.ndarray,
    free: Callable[[np.ndarray], bool],
    constraint: JointConstraint | None,
) -> str:
    """Why the start or goal cannot be an endpoint (in collision, off the constraint), or ""."""
    if not free(q0):
        return "start configuration is in collision"
    if not free(q1):
        return "goal configuration is in collision"
    if constraint is not None:
        for name, q in (("start", q0), ("goal", q1)):
            if np.max(np.abs(constraint.function(q))) > constraint.tolerance:
                return f"{name} configuration violates the constraint"
    return ""


def _path_error(
    path: np.ndarray,
    free: Callable[[np.ndarray], bool],
    resolution: float,
    constraint: JointConstraint | None,
) -> str:
    """Why a found path is not kept (it collides when re-checked densely, or leaves the
    constraint), or ""."""
    if not all(free(q) for q in interpolate(path, resolution)):
        return f"simplified path collides when re-checked at {resolution:g} rad"
    if constraint is not None:
        worst = max(float(np.max(np.abs(constraint.function(q)))) for q in path)
        if worst > constraint.tolerance:
            return f"path leaves the constraint by {worst:.2g}"
    return ""
