"""Rearrange (Algorithm 1): plans satisfy the action interface (Eq. 1), backward chaining moves
what blocks the goal, and bad requests fail clearly."""

from __future__ import annotations

import json
import math
import zlib
from collections.abc import Iterator
from dataclasses import replace
from importlib import resources
from typing import Any

import numpy as np
import pytest

from agents.experiments.benchmark import Job
from agents.experiments.plan import detect_scene, plan_from_detection
from agents.experiments.suites import table1_suite
from clutter_gym.model import herb as hm
from clutter_gym.model.arm_geometry import ArmGeometry
from clutter_gym.model.collision import RobotCollision, Volume
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import get_object
from clutter_gym.model.scene import load_scene
from clutter_gym.model.trajectory import Segment, Trajectory, chunk_rows
from clutter_gym.model.world import TABLE
from planners import rearrange as rearrange_module
from planners.actions.context import PlanningContext
from planners.actions.goals import Retrieve
from planners.actions.hand_in import CLOSING_STAGES
from planners.actions.results import ActionResult, Failure, FailureLog
from planners.actions.settings import PlannerSettings
from planners.rearrange import Plan, _Candidate, _Search, plan_retrieval
from planners.uncertainty import ObjectBelief, sample_poses

SIGMA2 = (0.005, 0.034)


def belief(name: str, kind: str, pose: tuple[float, float, float], n: int = 30) -> ObjectBelief:
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    sigma = SIGMA2 if n > 1 else (0.0, 0.0)
    return ObjectBelief(name, get_object(kind), pose, sample_poses(np.array(pose), sigma, n, rng))


def figure_scene(name: str) -> list[ObjectBelief]:
    text = resources.files("clutter_gym").joinpath(f"scenes/figures/{name}.json").read_text()
    scene = load_scene(json.loads(text))
    return [belief(o.name, o.kind, o.pose) for o in scene.objects]


def plan(
    beliefs: list[ObjectBelief], goal: str = "can", planner: str = "pushing", **settings: float
) -> Plan:
    # A budget far above the few seconds these plans take: the search is deterministic for a
    # seed unless the wall-clock budget cuts it, which a loaded CI machine must not do.
    settings.setdefault("time_budget", 120.0)
    return plan_retrieval(
        TABLE,
        beliefs,
        goal,
        hm.RIGHT_ARM_HOME,
        PlannerSettings(**settings),  # type: ignore[arg-type]
        planner=planner,
    )


@pytest.fixture(scope="module")
def lone_can() -> Plan:
    return plan([belief("can", "soda_can", (0.93, -0.22, 0.0))])


@pytest.fixture(scope="module")
def fig3() -> tuple[Plan, list[ObjectBelief]]:
    beliefs = figure_scene("fig3_can_box_dumbbell")
    return plan(beliefs, "red_can"), beliefs


def test_the_objects_alive_before_a_plan_are_frozen_while_it_searches_and_only_then(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The plan's collections scan only its own objects (`gc.freeze` during the search): the
    frozen set holds the process's objects while the search runs and is empty after it; a
    caller's own frozen set is left as it was."""
    import gc

    from planners import rearrange

    seen: list[int] = []

    def retrieve(self: object, *_: object) -> None:
        seen.append(gc.get_freeze_count())

    monkeypatch.setattr(rearrange._Search, "retrieve", retrieve)
    assert gc.get_freeze_count() == 0
    assert not plan([belief("can", "soda_can", (0.7, 0.0, 0.0))]).success
    assert seen[-1] > 1000 and gc.get_freeze_count() == 0
    gc.freeze()
    try:
        plan([belief("can", "soda_can", (0.7, 0.0, 0.0))])
        assert seen[-1] > 1000 and gc.get_freeze_count() > 1000
    finally:
        gc.unfreeze()


def test_a_free_can_is_one_pickup(lone_can: Plan) -> None:
    assert lone_can.success, lone_can.blocked_by
    assert [s.result.action for s in lone_can.steps] == ["pickup"]
    assert lone_can.objects_moved == []
    step = lone_can.steps[0]
    assert step.approach is not None and step.transit is None
    assert np.allclose(step.trajectory.start, hm.RIGHT_ARM_HOME)
    assert lone_can.stats.planning_steps == 1


def test_pickup_captures_every_sample_in_the_hand(lone_can: Plan) -> None:
    result = lone_can.steps[0].result
    assert result.held
    # The push ends with every sample (under every parameter set) between the fingertips;
    # then the closing stages (`closing_poses`).
    final = result.nu[-CLOSING_STAGES - 1]
    assert len(final) % 30 == 0
    motion = result.trajectory
    labels = [s.label for s in motion.segments]
    assert labels == ["push", "close", "lift"]
    push = motion.segments[0]
    end = ArmKinematics("right").fk_tcp(push.path[-1])
    axis = end[:3, 2]
    hand_base = end[:3, 3] - hm.HAND_TCP_OFFSET * axis
    offsets = final[:, :2] - hand_base[:2]
    along = offsets @ axis[:2]
    across = offsets @ np.array([-axis[1], axis[0]])
    aperture = result.details["aperture_m"]
    assert np.all(np.abs(across) <= aperture / 2 + 1e-6)
    assert np.all(along <= 0.20)  # behind the fingertips, in the pocket


def test_the_lift_rises_straight_up(lone_can: Plan) -> None:
    k = ArmKinematics("right")
    lift = lone_can.steps[0].result.trajectory.segments[-1].path
    tcp = k.fk_tcp_batch(lift)[:, :3, 3]
    assert tcp[-1, 2] - tcp[0, 2] == pytest.approx(0.15, abs=1e-3)
    assert np.ptp(tcp[:, 0]) < 2e-3 and np.ptp(tcp[:, 1]) < 2e-3


def test_fig3_pushes_the_dumbbell_away_then_the_box_into_its_space(
    fig3: tuple[Plan, list[ObjectBelief]],
) -> None:
    """The paper's plan (Fig. 4): "The robot first pushes the dumbbell away to clear a portion
    of the space, which it then uses to push the box into. Afterwards it uses the space in
    front of the red can to grasp" it; planned backwards, one object per planning step."""
    result, beliefs = fig3
    assert result.success, result.blocked_by
    assert [s.result.obj for s in result.steps] == ["dumbbell", "big_box", "red_can"]
    assert result.steps[-1].result.action == "pickup"
    assert [s.depth for s in result.steps] == [2, 1, 0]
    box = result.steps[1]
    by_name = {b.name: b for b in beliefs}
    z = TABLE.top_z
    # The box ends where the dumbbell stood.
    box_final = Volume.of_object("big_box", by_name["big_box"].spec, box.result.nu[-1], z)
    dumbbell = by_name["dumbbell"]
    assert box_final.intersects(Volume.of_object("dumbbell", dumbbell.spec, dumbbell.samples, z))


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="planner: the large box must leave the pickup's NGR by 0.37-0.55 m, further than one "
    "sweep stroke holds it; in two strokes the pushing planner moves the pop-tarts and the juice "
    "too, or runs out of the budget (issue 19); pick-and-place finds no way past the box",
)
def test_fig15_pushing_sweeps_the_box_where_pick_and_place_moves_two_objects() -> None:
    """Fig. 15: "The pushing planner sweeps the large box blocking the way. The pick-and-place
    planner though cannot grasp and pick up the large box, hence needs to pick up two other
    objects and avoid the large box."
    """
    beliefs = figure_scene("fig15_can_box_two_graspables")
    pushing = plan(beliefs, "red_can", time_budget=20.0)
    placing = plan(beliefs, "red_can", "pick-and-place", time_budget=20.0)
    assert pushing.success and placing.success
    assert pushing.objects_moved == ["big_box"]
    assert sorted(placing.objects_moved) == ["juice", "poptarts"]


def test_fig3_plan_respects_avoid_and_ngr(fig3: tuple[Plan, list[ObjectBelief]]) -> None:
    """Every action keeps clear of the objects moved after it (they are where they were) and
    of those moved before it (where they were left), and leaves its object out of the NGR of
    the actions after it; the transits connect the steps."""
    result, beliefs = fig3
    by_name = {b.name: b for b in beliefs}
    robot = RobotCollision(ArmKinematics("right"), ArmGeometry())
    z = TABLE.top_z
    steps = result.steps
    placed = {b.name: b.samples for b in beliefs}  # where each object is when a step runs
    for k, step in enumerate(steps):
        name = step.result.obj
        spec = by_name[name].spec
        volume = Volume.of_trajectory(robot, step.result.trajectory) + Volume.of_object(
            name, spec, step.result.nu.reshape(-1, 3), z
        )
        for other, samples in placed.items():
            if other != name:
                assert not volume.intersects(
                    Volume.of_object(other, by_name[other].spec, samples, z)
                ), (name, other)
        if k < len(steps) - 1:
            final = Volume.of_object(name, spec, step.result.nu[-1], z)
            assert len(step.ngr) > 0 and not final.intersects(step.ngr)
            assert step.transit is not None
            assert np.allclose(step.transit.end, steps[k + 1].result.trajectory.start)
            placed[name] = step.result.nu[-1]


def test_plan_trajectory_is_env_actions(fig3: tuple[Plan, list[ObjectBelief]]) -> None:
    result, _ = fig3
    rows = result.trajectory.rows()
    assert rows.shape[1] == 9
    chunks = chunk_rows(rows, 16)
    assert all(c.shape == (16, 9) and c.dtype == np.float32 for c in chunks)
    assert np.allclose(np.vstack(chunks)[: len(rows)], rows, atol=1e-6)
    per_step = result.actions(16)
    assert len(per_step) == sum(len(s.trajectory.actions(16)) for s in result.steps)


def test_unpushable_objects_are_never_moved() -> None:
    """An object a push would tip over (``pushable=False``) stays where it is, even in the
    way: here a box standing between the robot and the can."""
    box = belief("box", "poptart_box", (0.68, -0.22, 0.0))
    box = replace(box, spec=replace(box.spec, pushable=False))
    beliefs = [belief("can", "soda_can", (0.84, -0.22, 0.0)), box]
    result = plan(beliefs, time_budget=10.0)
    assert "box" not in result.objects_moved
    if not result.success:
        assert result.blocked_by


def test_unreachable_goal_fails_with_reasons() -> None:
    result = plan([belief("can", "soda_can", (1.32, 0.6, 0.0))], time_budget=5.0)
    assert not result.success and not result.steps
    assert result.planning_time < 6.0
    assert any("pickup can" in line for line in result.blocked_by)


def test_zero_time_budget_is_a_failure_not_an_exception() -> None:
    result = plan([belief("can", "soda_can", (0.93, -0.22, 0.0))], time_budget=0.0)
    assert not result.success
    assert "time budget" in result.reason


@pytest.mark.parametrize(
    ("beliefs", "goal", "message"),
    [
        ([], "can", "empty"),
        ([belief("can", "soda_can", (0.93, -0.22, 0.0))], "cup", "'cup' is not in the scene"),
    ],
)
def test_bad_requests_name_the_problem(
    beliefs: list[ObjectBelief], goal: str, message: str
) -> None:
    with pytest.raises(ValueError, match=message):
        plan(beliefs, goal)


def test_negative_budget_is_rejected() -> None:
    with pytest.raises(ValueError, match="time_budget"):
        PlannerSettings(time_budget=-1.0)


def test_same_seed_same_plan() -> None:
    beliefs = [belief("can", "soda_can", (0.93, -0.22, 0.0))]
    a, b = plan(beliefs), plan(beliefs)
    assert np.array_equal(a.trajectory.rows(), b.trajectory.rows())


def test_shelf_pickup_carries_the_object_upright_around_a_blocked_pull() -> None:
    """When the straight pull into the goal strip is blocked, PickUp carries the object with
    the constrained GoTo: level hand, object poses following the TCP."""
    from clutter_gym.model.reachability import approach_rotation
    from clutter_gym.model.world import SHELF
    from planners.actions.arm import Arm
    from planners.actions.context import PlanningContext
    from planners.actions.hand_in import carried_poses, carry_upright

    can = belief("can", "soda_can", (1.0, -0.15, 0.0))
    settings = PlannerSettings(goto_evaluations=100_000)
    rng = np.random.default_rng(0)
    ctx = PlanningContext(SHELF, {"can": can}, settings, SHELF.default_goal_region, rng)
    arm = Arm(SHELF, settings, ctx.stats, ctx.budget)
    k = arm.kinematics

    def pose(x: float, y: float) -> np.ndarray:
        t = np.eye(4)
        t[:3, :3] = approach_rotation(np.array([1.0, 0.0, 0.0]))
        t[:3, 3] = (x, y, SHELF.top_z + 0.095)
        return t

    q_start = k.solve_ik(pose(1.0, -0.15))
    assert q_start is not None

    def free(q: np.ndarray) -> bool:  # a post on the straight line back to the strip
        x, y, _ = k.fk_tcp(q)[:3, 3]
        return not (0.86 < x < 0.92 and -0.19 < y < -0.11)

    straight = arm.straight(q_start, pose(0.78, -0.15), free)
    assert straight is None
    path = carry_upright(arm, q_start, pose(0.78, -0.15), free)
    assert path is not None and all(free(q) for q in path)
    assert max(float(np.abs(k.fk_tcp(q)[:2, 0]).max()) for q in path) < 1e-3
    carried = carried_poses(arm, path, can.samples)
    tcp_end = k.fk_tcp(path[-1])[:3, 3]
    offset = can.samples[0, :2] - k.fk_tcp(path[0])[:2, 3]
    assert np.allclose(carried[-1, 0, :2], tcp_end[:2] + offset, atol=0.02)


def test_a_shelf_pickup_beside_the_strip_pulls_the_object_into_it() -> None:
    """The strip is narrower than the shelf: a can grasped beside it is pulled sideways too,
    so every sample's centre ends inside the goal region (the env's success test)."""
    from clutter_gym.model.world import SHELF

    (x0, x1), (y0, y1) = SHELF.default_goal_region
    can = belief("can", "soda_can", (0.66, y0 - 0.05, 0.0))
    result = plan_retrieval(
        SHELF, [can], "can", hm.RIGHT_ARM_START, PlannerSettings(time_budget=120.0)
    )
    assert result.success, result.blocked_by
    final = result.steps[-1].result.nu[-1]
    assert np.all((final[:, 0] > x0) & (final[:, 0] < x1)), final[:, 0]
    assert np.all((final[:, 1] > y0) & (final[:, 1] < y1)), final[:, 1]


@pytest.mark.parametrize("nearest_home", [True, False])
def test_a_can_by_the_shelfs_side_wall_is_pulled_out_into_the_strip(
    nearest_home: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Grasped by the right wall, the can ends in the strip. With the IK solution nearest the
    home pose first (as before the shelf's elbow rule, `Arm._ordered`), the can is pushed and
    grasped at -19 deg, and pulled straight back at that heading the wrist is out of reach, so
    the pull turns the hand about the can (`PULL_TURNS`)."""
    from clutter_gym.model.world import SHELF
    from planners.actions.arm import Arm

    if nearest_home:
        monkeypatch.setattr(Arm, "_ordered", lambda self, solutions: solutions)
    (x0, x1), (y0, y1) = SHELF.default_goal_region
    can = belief("can", "soda_can", (0.74, -0.55, 0.0))
    result = plan_retrieval(
        SHELF, [can], "can", hm.RIGHT_ARM_START, PlannerSettings(time_budget=120.0)
    )
    assert result.success, result.blocked_by
    segments = {s.label: s.path for s in result.steps[-1].result.trajectory.segments}
    kinematics = ArmKinematics("right")

    def heading(q: np.ndarray) -> float:
        approach = kinematics.fk_tcp(q)[:3, 2]
        return math.degrees(math.atan2(approach[1], approach[0]))

    if nearest_home:
        assert abs(heading(segments["pull"][-1]) - heading(segments["push"][-1])) >= 14.0
    final = result.steps[-1].result.nu[-1]
    assert np.all((final[:, 0] > x0) & (final[:, 0] < x1)), final[:, 0]
    assert np.all((final[:, 1] > y0) & (final[:, 1] < y1)), final[:, 1]


def test_pushing_moves_no_more_objects_than_pick_and_place() -> None:
    """Shortest plans first: the pushing planner's actions include pick-and-place, so where
    pick-and-place retrieves the goal by moving one object, pushing moves at most one. The
    benchmark's high_07 without noise, where pick-and-place moves a can. (It was the sigma2
    case, where a pushing search that went deep under candidates moving a large box and the can
    ran out of its 20 s; there pick-and-place no longer plans since a round object is closed on
    only 15 mm behind the fingertips.)"""
    case = next(c for c in table1_suite().cases if c.label == "high_07" and c.noise == "sigma1")
    seed = Job(case, "pushing", 0, 0, 120.0).case_seed
    scene = replace(case.scene, noise=case.noise)
    moved = {}
    for planner in ("pick-and-place", "pushing"):
        rng = np.random.default_rng(seed)
        detection = detect_scene(scene, rng)
        settings = PlannerSettings(time_budget=120.0, seed=seed)
        result, _ = plan_from_detection(scene, detection, planner, settings, None, rng)
        assert result.success, (planner, result.blocked_by[:3])
        moved[planner] = result.objects_moved
        if planner == "pick-and-place":
            carried = result.steps[0].result
            put_down = np.array([carried.details["place_x_m"], carried.details["place_y_m"]])
            # Reported where the object ends (nu_o's last stage), away from where it stood.
            np.testing.assert_allclose(put_down, carried.nu[-1][:, :2].mean(0), atol=1e-9)
            stood = detection[[o.name for o in scene.objects].index(carried.obj), :2]
            assert np.linalg.norm(put_down - stood) > 0.05
    assert len(moved["pushing"]) <= len(moved["pick-and-place"]) == 1


def test_failure_log_ranks_the_objects_that_blocked_an_objects_actions() -> None:
    log = FailureLog()
    for blocker in ("box", "can", "box", "", "box", "can", "bottle"):
        log.record(
            Failure("goal", "pickup", f"the hand overlaps {blocker} where it stops", blocker)
        )
    log.record(Failure("can", "sweep", "the hand overlaps bottle where the sweep starts", "bottle"))
    assert log.blocking("goal") == ["box", "can", "bottle"]
    assert log.blocking("can") == ["bottle"] and log.blocking("box") == []


def _three_cans() -> PlanningContext:
    """A planning context with cans "can", "a" and "b" in a row across the table, one sample
    each."""
    places = (("can", 0.0), ("a", 0.2), ("b", -0.2))
    beliefs = [belief(n, "soda_can", (0.7, y, 0.0), n=1) for n, y in places]
    return PlanningContext(
        TABLE,
        {b.name: b for b in beliefs},
        PlannerSettings(),
        TABLE.default_goal_region,
        np.random.default_rng(0),
    )


def test_a_candidate_that_needs_two_objects_moved_waits_for_one_that_needs_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Within one action, the goal's first candidate penetrates two objects and its second
    one: the second is searched first (a shorter plan), though both could lead to a plan."""
    ctx = _three_cans()
    still = Trajectory((Segment("still", np.zeros((2, 7)), HandCommand()),))
    penetrates: dict[str, list[tuple[str, ...]]] = {"can": [("a", "b"), ("a",)], "a": [()]}
    searched: list[tuple[str, tuple[str, ...]]] = []

    def action(ctx: object, arm: object, name: str, *_: object) -> Iterator[ActionResult]:
        for k in range(len(penetrates[name])):
            yield ActionResult("fake", name, still, np.zeros((1, 1, 3)), False, {"k": k})

    def assess(
        self: _Search, result: ActionResult, o: str, move: tuple[str, ...], *_: object
    ) -> _Candidate:
        new = tuple(m for m in penetrates[o][int(result.details["k"])] if m not in move)
        return _Candidate(result, None, None if new else still, still, Volume(), new)

    def descend(self: _Search, candidate: _Candidate, o: str, *rest: Any) -> Any:
        searched.append((o, candidate.penetrated))
        return original(self, candidate, o, *rest)

    original = _Search._descend
    monkeypatch.setitem(rearrange_module.ACTIONS, "fake", action)
    monkeypatch.setattr(_Search, "_assess", assess)
    monkeypatch.setattr(_Search, "_descend", descend)
    monkeypatch.setattr(_Search, "_approach", lambda self, tau: still)
    search = _Search(ctx, None, hm.RIGHT_ARM_HOME, ("fake",))  # type: ignore[arg-type]
    search.max_depth = 2
    steps = search.rearrange("can", Retrieve(), Volume(), (), (), None, 0)
    assert steps is not None
    assert searched[0] == ("can", ("a",))
    assert ("can", ("a", "b")) not in searched  # the shorter one led to a plan
    assert [(s.result.obj, s.result.details["k"]) for s in steps] == [("a", 0), ("can", 1)]


@pytest.mark.parametrize("second", ["too deep", "complete"])
def test_only_candidates_the_arm_can_get_to_take_an_actions_slots(
    second: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With one slot per action: a first candidate whose transit or approach finds no path
    takes none, so the second is searched; once a candidate the arm can get to has taken the
    slot (here one that needs an object moved in the pass that moves none) the action offers
    no more, even a complete one."""
    ctx = _three_cans()
    ctx.settings = replace(ctx.settings, candidates_per_action=1)
    still = Trajectory((Segment("still", np.zeros((2, 7)), HandCommand()),))
    assessed: list[int] = []

    def action(ctx: object, arm: object, name: str, *_: object) -> Iterator[ActionResult]:
        for k in range(3):
            yield ActionResult("fake", name, still, np.zeros((1, 1, 3)), False, {"k": k})

    def assess(self: _Search, result: ActionResult, *_: object) -> _Candidate | None:
        k = int(result.details["k"])
        assessed.append(k)
        if k == 0:
            return None  # no path to it
        if k == 1 and second == "too deep":
            return _Candidate(result, None, None, still, Volume(), ("a",))
        return _Candidate(result, None, still, still, Volume(), ())

    monkeypatch.setitem(rearrange_module.ACTIONS, "fake", action)
    monkeypatch.setattr(_Search, "_assess", assess)
    search = _Search(ctx, None, hm.RIGHT_ARM_HOME, ("fake",))  # type: ignore[arg-type]
    steps = search.rearrange("can", Retrieve(), Volume(), (), (), None, 0)
    assert assessed == [0, 1]
    if second == "too deep":
        assert steps is None
    else:
        assert steps is not None and steps[0].result.details["k"] == 1


@pytest.mark.parametrize("reaches_from_start", [False, True])
def test_a_first_action_the_robot_cannot_reach_is_no_candidate(reaches_from_start: bool) -> None:
    """A candidate that moves nothing first executes first: its approach GoTo is part of
    assessing it, and where GoTo finds no path it is no candidate (and takes no slot)."""
    search, arm = _transit_search(reaches_from_start)
    candidate = search._assess(_moved("can"), "can", (), ("a", "b"), Volume(), None)
    assert [k for k, _ in arm.requests] == ["from start"]
    if reaches_from_start:
        assert candidate is not None and candidate.approach is not None
        assert not candidate.penetrated
    else:
        assert candidate is None


class _RecordingArm:
    """GoTo that records its requests and finds a path only from the robot's start when told;
    every configuration has the elbow inside the surface when told."""

    def __init__(self, start: np.ndarray, reaches_from_start: bool, inside: bool = False) -> None:
        self.start = start
        self.reaches_from_start = reaches_from_start
        self.inside = inside
        self.requests: list[tuple[str, Volume]] = []
        self.evaluations: list[int | None] = []  # each request's, None: the settings' own

    def elbow_inside(self, q: np.ndarray) -> bool:
        return self.inside

    def goto(
        self,
        start: np.ndarray,
        goal: np.ndarray,
        obstacles: Volume,
        hand: HandCommand,
        evaluations: int | None = None,
    ) -> tuple[np.ndarray | None, str]:
        from_start = bool(np.array_equal(start, self.start))
        self.requests.append(("from start" if from_start else "transit", obstacles))
        self.evaluations.append(evaluations)
        if from_start and self.reaches_from_start:
            return np.stack([start, goal]), ""
        return None, "no path found within 5000 evaluations"


def _transit_search(
    reaches_from_start: bool, inside: bool = False
) -> tuple[_Search, _RecordingArm]:
    ctx = _three_cans()
    arm = _RecordingArm(hm.RIGHT_ARM_HOME, reaches_from_start, inside)
    return _Search(ctx, arm, hm.RIGHT_ARM_HOME, ()), arm  # type: ignore[arg-type]


def _moved(name: str) -> ActionResult:
    still = Trajectory((Segment("sweep", np.full((2, 7), 0.1), HandCommand()),))
    return ActionResult("sweep", name, still, np.array([[[0.7, 0.4, 0.0]]]), False, {})


@pytest.mark.parametrize("reaches_from_start", [False, True])
def test_a_transit_into_a_start_goto_cannot_reach_among_avoid_alone_is_refused(
    reaches_from_start: bool,
) -> None:
    """A transit that finds no path asks once whether GoTo reaches the next action's start from
    the robot's start with only avoidVol in the way. Where it does not, the transit's second
    GoTo and every later transit into that start whose avoid holds those objects are refused
    without a GoTo; a transit with fewer objects avoided is planned. Where it does, every
    transit is planned as before."""
    search, arm = _transit_search(reaches_from_start)
    ctx = search.ctx
    r_next = (np.full(7, 0.2), HandCommand())
    avoid = ("can",)
    assert search._transit("a", _moved("a"), avoid, ctx.objects_volume(avoid), r_next) is None
    kinds = [kind for kind, _ in arm.requests]
    if reaches_from_start:
        assert kinds == ["transit", "from start", "transit"]
    else:
        assert kinds == ["transit", "from start"]
        assert arm.requests[1][1] is ctx.objects_volume(avoid)  # avoidVol alone
    # the probe searches with its own, smaller budget; transits with the settings' GoTo budget
    assert arm.evaluations[:2] == [None, ctx.settings.probe_evaluations]
    assert ctx.settings.probe_evaluations < ctx.settings.goto_evaluations
    arm.requests.clear()
    wider = ("b", "can")
    assert search._transit("a", _moved("a"), wider, ctx.objects_volume(wider), r_next) is None
    # the answer for ("can",) holds for a superset; a new avoid set is asked once more
    assert [k for k, _ in arm.requests] == (
        ["transit", "from start", "transit"] if reaches_from_start else []
    )
    arm.requests.clear()
    assert search._transit("b", _moved("b"), (), ctx.objects_volume(()), r_next) is None
    assert [k for k, _ in arm.requests][:1] == ["transit"]


@pytest.mark.parametrize("inside", [False, True])
@pytest.mark.parametrize("reaches_from_start", [False, True])
def test_a_start_with_the_elbow_inside_is_asked_of_goto_from_the_robots_start(
    reaches_from_start: bool, inside: bool
) -> None:
    """A candidate whose start has the elbow inside an enclosed surface is searched below only
    where GoTo reaches that start from the robot's start with avoidVol and the object itself
    in the way (asked once per start, before its transit); a start with the elbow outside is
    never asked."""
    search, arm = _transit_search(reaches_from_start, inside)
    ctx = search.ctx
    r_next = (np.full(7, 0.2), HandCommand())
    avoid = ("can",)
    for _ in range(2):
        candidate = search._assess(
            _moved("a"), "a", ("b",), avoid, ctx.objects_volume(avoid), r_next
        )
        assert candidate is None  # this arm's transits find no path
    asked = [volume for kind, volume in arm.requests if kind == "from start"]
    own = [v for v in asked if v is ctx.objects_volume(("can", "a"))]
    assert len(own) == (1 if inside else 0)
    transits = [kind for kind, _ in arm.requests].count("transit")
    assert (transits == 0) == (inside and not reaches_from_start)
    unreachable = [line for line in ctx.failures.blockers() if "its start" in line]
    assert unreachable == (
        ["goto a: " + rearrange_module.UNREACHABLE_OWN_START + " (2x)"]
        if inside and not reaches_from_start
        else []
    )


def test_an_approach_is_planned_once_per_start() -> None:
    """The deepening passes offer the same first action again: its approach (every object
    where it is now) is planned once, and its failure is logged each time it is asked."""
    search, arm = _transit_search(reaches_from_start=False)
    tau = _moved("a").trajectory
    assert search._approach(tau) is None and search._approach(tau) is None
    assert [k for k, _ in arm.requests] == ["from start"]
    assert search.ctx.failures.blockers() == [
        "goto robot: from the start configuration: no path found within 5000 evaluations (2x)"
    ]
