"""Tests of the GoTo joint-space planner on HERB's right arm, with the fcl collision layer."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from clutter_gym.model import herb as hm
from clutter_gym.model.collision import CollisionChecker, interpolate, make_checker
from clutter_gym.model.herb import RIGHT_ARM_HOME
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import get_object
from clutter_gym.model.reachability import approach_rotation
from clutter_gym.model.world import TABLE
from planners.goto import GoToResult, plan_goto, upright_hand

KIN = ArmKinematics("right")
#: Hand over the table left of the box and right of it: free, but the straight joint-space line
#: between them sweeps through a large box at `BOX_POSE`.
Q_A = np.array([4.55, -0.71, 2.4, -0.71, -0.86, 0.91, -2.36])
Q_B = np.array([4.2, -0.44, 0.16, 1.76, -0.84, -0.81, -0.2])
BOX_POSE = (0.95, -0.25, 0.0)
RESOLUTION = 0.01


@pytest.fixture(scope="module")
def table_free() -> Callable[[np.ndarray], bool]:
    return make_checker(TABLE, {}).checker(objects=False)


@pytest.fixture(scope="module")
def box_checker() -> CollisionChecker:
    return make_checker(TABLE, {"box": (get_object("large_box"), BOX_POSE)})


def plan(
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    time_budget: float = 2.0,
    seed: int = 0,
) -> GoToResult:
    return plan_goto(
        start, goal, is_valid, KIN.lower, KIN.upper, time_budget, seed, resolution=RESOLUTION
    )


def assert_valid_path(
    result: GoToResult, start: np.ndarray, goal: np.ndarray, is_valid: Callable[[np.ndarray], bool]
) -> None:
    assert result.success, result.reason
    assert result.reason == ""
    assert result.path is not None
    assert result.path.ndim == 2
    assert result.path.shape[1] == 7
    np.testing.assert_allclose(result.path[0], start)
    np.testing.assert_allclose(result.path[-1], goal)
    assert np.all(result.path >= KIN.lower)
    assert np.all(result.path <= KIN.upper)
    assert all(is_valid(q) for q in interpolate(result.path, RESOLUTION))
    assert result.collision_checks > 0


def test_free_space_plan(table_free: Callable[[np.ndarray], bool]) -> None:
    assert table_free(RIGHT_ARM_HOME)
    assert table_free(Q_B)
    result = plan(RIGHT_ARM_HOME, Q_B, table_free)
    assert_valid_path(result, RIGHT_ARM_HOME, Q_B, table_free)


def test_plans_around_obstacle(box_checker: CollisionChecker) -> None:
    free = box_checker.checker()
    assert free(Q_A)
    assert free(Q_B)
    assert box_checker.swept_objects(np.array([Q_A, Q_B])) == {"box"}
    result = plan(Q_A, Q_B, free, time_budget=5.0)
    assert_valid_path(result, Q_A, Q_B, free)
    assert result.path is not None
    assert box_checker.swept_objects(result.path) == set()


def test_same_seed_same_path(box_checker: CollisionChecker) -> None:
    free = box_checker.checker()
    first = plan(Q_A, Q_B, free, time_budget=5.0, seed=7)
    second = plan(Q_A, Q_B, free, time_budget=5.0, seed=7)
    assert first.success
    assert second.success
    assert first.path is not None
    assert second.path is not None
    np.testing.assert_array_equal(first.path, second.path)


def test_start_in_collision() -> None:
    result = plan(Q_A, Q_B, lambda q: not np.array_equal(q, Q_A))
    assert not result.success
    assert result.path is None
    assert result.reason == "start configuration is in collision"
    assert result.collision_checks == 1


def test_goal_in_collision() -> None:
    result = plan(Q_A, Q_B, lambda q: not np.array_equal(q, Q_B))
    assert not result.success
    assert result.path is None
    assert result.reason == "goal configuration is in collision"


def test_goal_outside_joint_limits() -> None:
    goal = Q_B.copy()
    goal[3] = KIN.upper[3] + 0.1
    result = plan(Q_A, goal, lambda q: True)
    assert not result.success
    assert result.reason.startswith("goal outside joint limits (joint 3: ")
    assert result.collision_checks == 0


@pytest.mark.parametrize("start", [np.zeros(6), np.full(7, np.nan)])
def test_malformed_start(start: np.ndarray) -> None:
    result = plan(start, Q_B, lambda q: True)
    assert not result.success
    assert result.reason.startswith("start ")


@pytest.mark.parametrize("budget", [0.0, -1.0, float("nan")])
def test_time_budget_must_be_positive(budget: float) -> None:
    result = plan(Q_A, Q_B, lambda q: True, time_budget=budget)
    assert not result.success
    assert result.reason.startswith("time budget must be > 0 (got ")
    assert result.collision_checks == 0


def test_enclosed_goal_has_no_path() -> None:
    def near_start_or_goal(q: np.ndarray) -> bool:
        return bool(np.max(np.abs(q - Q_A)) < 0.05 or np.array_equal(q, Q_B))

    result = plan(Q_A, Q_B, near_start_or_goal, time_budget=0.5)
    assert not result.success
    assert result.path is None
    assert result.reason == "no path found within 0.5 s"
    assert result.collision_checks > 2


def test_evaluation_budget_ends_the_search_whatever_the_time_budget() -> None:
    def near_start_or_goal(q: np.ndarray) -> bool:
        return bool(np.max(np.abs(q - Q_A)) < 0.05 or np.array_equal(q, Q_B))

    result = plan_goto(
        Q_A, Q_B, near_start_or_goal, KIN.lower, KIN.upper, 60.0, max_evaluations=300
    )
    assert not result.success
    assert result.reason == "no path found within 300 evaluations"
    # Spent budget makes every state invalid, so the search stops at the 300th check.
    assert result.collision_checks == 300


def test_evaluation_budget_must_be_positive() -> None:
    result = plan_goto(Q_A, Q_B, lambda q: True, KIN.lower, KIN.upper, 1.0, max_evaluations=0)
    assert result.reason == "max_evaluations must be >= 1 (got 0)"


def test_constrained_goto_keeps_a_grasped_object_upright() -> None:
    """GoTo on the upright-hand manifold (ProjectedStateSpace) around an obstacle that the
    straight segment would cross: every configuration keeps the finger plane horizontal."""
    kinematics = ArmKinematics("right")

    def at(x: float, y: float, z: float, heading: float) -> np.ndarray:
        target = np.eye(4)
        target[:3, :3] = approach_rotation(np.array([np.cos(heading), np.sin(heading), 0.0]))
        target[:3, 3] = (x, y, z)
        q = kinematics.solve_ik(target)
        assert q is not None
        return q

    start, goal = at(0.95, -0.2, 0.90, 0.0), at(0.85, -0.45, 0.95, -0.3)

    def free(q: np.ndarray) -> bool:  # a pillar between the two hand positions
        x, y, _ = kinematics.fk_tcp(q)[:3, 3]
        return not (0.86 < x < 0.94 and -0.35 < y < -0.28)

    upright = upright_hand(kinematics)
    result = plan_goto(
        start, goal, free, kinematics.lower, kinematics.upper, 60.0, seed=1, constraint=upright
    )
    assert result.success, result.reason
    # The projection's Jacobians count against the evaluation budget, not only the checks.
    cut = plan_goto(
        start,
        goal,
        free,
        kinematics.lower,
        kinematics.upper,
        60.0,
        seed=1,
        constraint=upright,
        max_evaluations=2 * result.collision_checks,
    )
    assert cut.reason == f"no path found within {2 * result.collision_checks} evaluations"
    assert result.path is not None and len(result.path) > 2
    tilt = [float(np.abs(kinematics.fk_tcp(q)[:2, 0]).max()) for q in result.path]
    assert max(tilt) < upright.tolerance
    assert all(free(q) for q in result.path)
    assert np.allclose(result.path[0], start) and np.allclose(result.path[-1], goal, atol=1e-6)


def test_constrained_goto_rejects_endpoints_off_the_manifold() -> None:
    kinematics = ArmKinematics("right")
    tilted = np.array(hm.RIGHT_ARM_HOME)
    result = plan_goto(
        tilted,
        tilted + 0.1,
        lambda q: True,
        kinematics.lower,
        kinematics.upper,
        1.0,
        constraint=upright_hand(kinematics),
    )
    assert not result.success and "violates the constraint" in result.reason


def test_constrained_goto_joins_endpoints_level_within_its_tolerance() -> None:
    """The ends of the planner's straight lift in the shelf are level to 4.7e-4 and 6.4e-4
    (a Cartesian path's descent stops at 1e-3 rad): within the constraint's tolerance, so
    OMPL's manifold must take them (its default, 1e-4, left no path between them at all)."""
    kinematics = ArmKinematics("right")
    upright = upright_hand(kinematics)
    start = np.array([4.128, -0.78, -0.567, 2.1, -1.481, -1.061, 1.468])
    goal = np.array([4.217, -0.857, -0.772, 2.609, -1.414, -1.156, 0.932])
    errors = [float(np.abs(upright.function(q)).max()) for q in (start, goal)]
    assert 1e-4 < min(errors) and max(errors) < upright.tolerance
    result = plan_goto(
        start,
        goal,
        lambda q: True,
        kinematics.lower,
        kinematics.upper,
        60.0,
        seed=1,
        constraint=upright,
        max_evaluations=100_000,
    )
    assert result.success, result.reason
    assert result.path is not None
    assert max(float(np.abs(upright.function(q)).max()) for q in result.path) < upright.tolerance
