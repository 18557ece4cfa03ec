"""A sweep in two strokes: where the sweep region lets go of a box before it is out of the NGR,
the hand sweeps it as far as the region holds it, backs away, is placed against it again and
sweeps it on; planned here, and executed in pybullet."""

from __future__ import annotations

import importlib
import itertools
import math

import numpy as np
import pytest

from clutter_gym.model.collision import Volume
from clutter_gym.model.herb import RIGHT_ARM_START
from clutter_gym.model.objects import get_object
from clutter_gym.model.scene import load_scene
from clutter_gym.model.trajectory import Segment, Trajectory
from clutter_gym.model.world import TABLE
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import AwayFrom
from planners.actions.results import ActionResult, Failure, Outcome
from planners.actions.settings import PlannerSettings
from planners.uncertainty import ObjectBelief, sample_poses

sweep_action = importlib.import_module("planners.actions.sweep")

BOX_POSE = (0.75, -0.20, 0.3)
SIGMA = (0.005, 0.034)
DIRECTION = (math.pi / 2, -1)  # towards the robot's left, the hand's right side leading
NGR_HALF = 0.3  # m: the NGR's square around the box; a rigid shift needs 0.5 m to leave it


def _box() -> tuple[PlanningContext, Arm, AwayFrom]:
    rng = np.random.default_rng(0)
    samples = sample_poses(BOX_POSE, SIGMA, 30, rng)
    box = ObjectBelief("box", get_object("large_box"), BOX_POSE, samples, SIGMA)
    settings = PlannerSettings(time_budget=600.0)  # far above the test's needs
    ctx = PlanningContext(TABLE, {"box": box}, settings, TABLE.default_goal_region, rng)
    arm = Arm(TABLE, settings, ctx.stats, ctx.budget)
    centre = np.array([BOX_POSE[0], BOX_POSE[1], TABLE.top_z + 0.1])
    ngr = Volume.of_box("ngr", centre, (NGR_HALF, NGR_HALF, 0.2), 0.0)
    return ctx, arm, AwayFrom(ngr)


Tried = tuple[list[Outcome], list[Outcome], float | None]
"""The one-stroke sweeps in `DIRECTION`, the two-stroke ones, and the rigid shift's guess."""


def _two_strokes(ctx: PlanningContext, arm: Arm, goal: AwayFrom) -> Tried:
    """The one-stroke sweeps in `DIRECTION`, then the two-stroke ones, as `sweep` tries them."""
    guesses: dict[tuple[float, int], float | None] = {}
    one = list(sweep_action._sweep_at(ctx, arm, "box", goal, Volume(), *DIRECTION, guesses))
    two = list(
        sweep_action._two_strokes_at(
            ctx, arm, "box", goal, Volume(), *DIRECTION, guesses[DIRECTION]
        )
    )
    return one, two, guesses[DIRECTION]


@pytest.fixture(scope="module")
def swept() -> tuple[PlanningContext, Arm, AwayFrom, Tried]:
    ctx, arm, goal = _box()
    return ctx, arm, goal, _two_strokes(ctx, arm, goal)


def test_two_strokes_go_on_where_one_lets_go(
    swept: tuple[PlanningContext, Arm, AwayFrom, Tried],
) -> None:
    """No sweep in one stroke leaves the NGR in this direction (the region lets go first);
    in two, the first stroke is shorter than the rigid shift's guess, nu_o goes on from where
    it left every sample, and every sample of nu_o[1] ends out of the NGR."""
    ctx, _, goal, (one, two, guess) = swept
    assert not [o for o in one if isinstance(o, ActionResult)]
    assert any(
        isinstance(o, Failure)
        and o.reason == "the sweep capture region misses some uncertainty samples"
        for o in one
    )
    (result,) = [o for o in two if isinstance(o, ActionResult)]
    labels = [s.label for s in result.trajectory.segments]
    assert labels == ["sweep", "retreat", "shift", "sweep", "retreat", "rise"]
    segments = result.trajectory.segments
    for before, after in itertools.pairwise(segments):
        np.testing.assert_allclose(before.path[-1], after.path[0], atol=1e-9)
    (first,) = [
        stroke
        for _, stroke in ctx.first_strokes.values()
        if not isinstance(stroke, Failure) and np.array_equal(stroke.path, segments[0].path)
    ]
    assert guess is not None and sweep_action.FIRST_STROKE_MIN <= first.length < guess
    assert result.details["first_stroke_m"] == first.length
    assert result.details["sweep_m"] > first.length
    np.testing.assert_array_equal(result.nu[: len(first.nu)], first.nu)
    assert goal.accepts(ctx, "box", result.nu[-1], False)
    assert not goal.accepts(ctx, "box", first.nu[-1], False)


def test_a_first_stroke_is_planned_once_for_every_goal(
    swept: tuple[PlanningContext, Arm, AwayFrom, Tried],
) -> None:
    """The first stroke never depends on G: a goal that asks for it again (a larger NGR)
    reads the plan's own, failures too, and simulates nothing new for it."""
    ctx, arm, _, _ = swept
    kept = dict(ctx.first_strokes)
    centre = np.array([BOX_POSE[0], BOX_POSE[1], TABLE.top_z + 0.1])
    wider = AwayFrom(Volume.of_box("ngr", centre, (NGR_HALF + 0.02,) * 2 + (0.2,), 0.0))
    _two_strokes(ctx, arm, wider)
    assert all(ctx.first_strokes[key] is value for key, value in kept.items())


def test_two_strokes_in_pybullet_leave_the_box_where_nu_says() -> None:
    """Executed after a GoTo from the robot's start, on the detected world and two drawn from
    the belief: the box ends upright, out of the NGR, within 1 cm of a pose of nu_o[1]."""
    from agents.experiments.plan import WAYPOINTS
    from agents.policies.rollout import roll_out
    from clutter_gym.env import ClutterRetrieveEnv

    ctx, arm, goal = _box()
    _, two, _ = _two_strokes(ctx, arm, goal)
    (result,) = [o for o in two if isinstance(o, ActionResult)]
    hand = result.trajectory.segments[0].hand
    start = np.asarray(RIGHT_ARM_START)
    path, why = arm.goto(start, result.trajectory.start, ctx.uncertainty_volume("box"), hand)
    assert path is not None, why
    actions = Trajectory((Segment("approach", path, hand), *result.trajectory.segments)).actions(
        WAYPOINTS
    )
    draws = np.random.default_rng(1).normal(0.0, [SIGMA[0], SIGMA[0], SIGMA[1]], (2, 3))
    final = result.nu[-1]
    spec = ctx.beliefs["box"].spec
    for pose in [np.asarray(BOX_POSE), *(np.asarray(BOX_POSE) + draws)]:
        scene = load_scene(
            {
                "format": "clutter-gym-scene/1",
                "surface": "table",
                "objects": [
                    {"name": "box", "kind": "large_box", "pose": [float(v) for v in pose]},
                    {"name": "can", "kind": "soda_can", "pose": [0.6, 0.35, 0.0]},
                ],
                "goal": {"object": "can"},
                "noise": "sigma2",
            }
        )
        env = ClutterRetrieveEnv(waypoints=WAYPOINTS)
        try:
            obs, info = env.reset(seed=0, options={"scene": scene})
            info = roll_out(env, obs, actions, info).info
        finally:
            env.close()
        assert "box" not in info["failure"], info["failure"]
        end = info["true_object_poses"][0]
        assert not Volume.of_object("box", spec, end[None], TABLE.top_z).intersects(goal.ngr)
        assert np.min(np.linalg.norm(final[:, :2] - end[:2], axis=1)) < 0.01


def test_every_one_stroke_sweep_comes_before_any_in_two() -> None:
    """`sweep` offers its sweeps in one stroke in every direction first, so that a plan one
    stroke serves is found as before; two strokes follow only if the search goes on."""
    ctx, arm, goal = _box()
    found = list(sweep_action.sweep(ctx, arm, "box", goal, Volume()))
    two = ["first_stroke_m" in o.details for o in found if isinstance(o, ActionResult)]
    assert any(two), "no sweep in two strokes was offered"
    assert not all(two), "no sweep in one stroke was offered"
    assert two == sorted(two)  # every one-stroke sweep (False) before the first in two


def test_no_two_strokes_where_the_straight_way_out_meets_avoid() -> None:
    """A post where the box's detected pose would pass, shifted straight out of the NGR, rules
    the direction's two strokes out before any is planned."""
    ctx, arm, goal = _box()
    guesses: dict[tuple[float, int], float | None] = {}
    list(sweep_action._sweep_at(ctx, arm, "box", goal, Volume(), *DIRECTION, guesses))
    post = Volume.of_box("post", np.array([0.75, 0.1, TABLE.top_z + 0.1]), (0.04, 0.04, 0.2), 0.0)
    outcomes = list(
        sweep_action._two_strokes_at(ctx, arm, "box", goal, post, *DIRECTION, guesses[DIRECTION])
    )
    assert [o.reason for o in outcomes if isinstance(o, Failure)] == [
        sweep_action.STRAIGHT_INTO_AVOID
    ]
    assert not ctx.first_strokes
