"""The push-grasp parameter search (§2.2.6) and the reuse of sweep simulations across goals."""

from __future__ import annotations

import dataclasses
import importlib
import math
from collections import Counter
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pytest

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import OBJECTS, get_object
from clutter_gym.model.reachability import HEIGHTS, PUSH_HEIGHT, hand_pose
from clutter_gym.model.transforms import Frame2D
from clutter_gym.model.world import SHELF, TABLE
from planners.actions.arm import Arm
from planners.actions.context import PlanningContext
from planners.actions.goals import AwayFrom
from planners.actions.hand_in import (
    CLOSING_CENTRE,
    CLOSING_SHOVE,
    CLOSING_SHOVE_ELSEWHERE,
    CYLINDER_SEAT_ASIDE,
    CYLINDER_TIP_HOLD,
    OUT_OF_REACH,
    PINCH_ONSET,
    SHELF_LIFT,
    STRIP_MARGIN,
    TURN_REST,
    closing_poses,
    held_poses,
    pull_targets,
)
from planners.actions.push_grasp import aperture_order, lateral_offsets
from planners.actions.results import ActionResult, Failure
from planners.actions.settings import PlannerSettings
from planners.capture import push_grasp_apertures
from planners.hand2d import PALM_FRONT, STRAIGHT_APERTURE, default_aperture, push_grasp_profile
from planners.uncertainty import ObjectBelief, sample_poses

# The module, not the `sweep` action the package re-exports under the same name.
sweep_action = importlib.import_module("planners.actions.sweep")
sweep_evolution = importlib.import_module("planners.actions.sweep_evolution")


STRAIGHT = push_grasp_profile(STRAIGHT_APERTURE)


def test_offsets_run_from_the_middle_of_the_spread_to_both_extremes() -> None:
    """One sample: every offset within the region's reach, centre first, a step apart."""
    offsets = lateral_offsets(np.array([[0.8, -0.2, 0.0]]), 0.3, 0.05, 0.01)
    assert offsets[0] == 0.0
    assert sorted(offsets) == pytest.approx(np.arange(-0.05, 0.051, 0.01))
    assert np.all(np.diff(np.abs(offsets)) >= -1e-12)  # never farther out before nearer


def test_offsets_are_centred_on_the_samples_and_keep_them_all_within_reach() -> None:
    heading = math.radians(30.0)
    normal = np.array([-math.sin(heading), math.cos(heading)])
    samples = np.array([[0.8, -0.2, 0.0], [0.8, -0.2, 0.0], [0.8, -0.2, 0.0]])
    samples[1, :2] += 0.06 * normal  # the spread runs from 0 to +0.08 across the push
    samples[2, :2] += 0.08 * normal
    offsets = lateral_offsets(samples, heading, 0.10, 0.01)
    assert offsets[0] == pytest.approx(0.04)
    lateral = (samples[:, :2] - samples[0, :2]) @ normal
    for o in offsets:  # the hand's axis at o: every sample within the region's reach of it
        assert np.all(np.abs(lateral - o) <= 0.10 + 1e-9)
    assert min(offsets) == pytest.approx(-0.02) and max(offsets) == pytest.approx(0.10)
    assert len(lateral_offsets(samples, heading, 0.039, 0.01)) == 0  # wider than the region


@pytest.mark.parametrize("kind", ["soda_can", "juice_bottle", "poptart_box"])
def test_every_aperture_is_tried_the_usual_one_first(kind: str) -> None:
    footprint = OBJECTS[kind].footprint
    order = aperture_order(footprint)
    assert sorted(order) == sorted(push_grasp_apertures(footprint))
    usual = default_aperture(footprint)
    assert abs(order[0] - usual) == min(abs(a - usual) for a in order)
    wider = [a for a in order if a >= order[0]]
    assert order[: len(wider)] == sorted(wider)  # then wider, then narrower


def _box_context() -> PlanningContext:
    rng = np.random.default_rng(0)
    pose = (0.75, -0.20, 0.3)
    box = ObjectBelief(
        "box", get_object("large_box"), pose, sample_poses(pose, (0.005, 0.034), 30, rng)
    )
    settings = PlannerSettings(time_budget=600.0)  # far above the test's needs
    return PlanningContext(TABLE, {"box": box}, settings, TABLE.default_goal_region, rng)


def test_a_sweep_is_simulated_once_for_every_goal(monkeypatch: pytest.MonkeyPatch) -> None:
    """The evolution of a sweep does not depend on G: a second goal asking for the same sweep
    reuses the simulation (only its stop test runs) and gets what a fresh simulation gives."""
    ctx = _box_context()
    plan = sweep_action._plan_sweep(ctx, "box", math.pi / 2, -1)
    frame, in_frame = sweep_action._frame_at(ctx, "box", plan, 0.5)
    centre = np.array([0.75, -0.20, TABLE.top_z + 0.1])
    near = Volume.of_box("ngr", centre, (0.2, 0.2, 0.2), 0.0)
    far = Volume.of_box("ngr", centre, (0.3, 0.3, 0.2), 0.0)

    def sweep_out(context: PlanningContext, ngr: Volume) -> tuple[float, np.ndarray] | None:
        return sweep_evolution.sweep_until(
            context, "box", AwayFrom(ngr), plan.region, frame, in_frame, 0.55
        )

    first = sweep_out(ctx, near)
    assert first is not None
    calls = []
    evolve = type(plan.region).evolve
    monkeypatch.setattr(
        type(plan.region), "evolve", lambda *a, **k: calls.append(1) or evolve(*a, **k)
    )
    again = sweep_out(ctx, near)
    assert again is not None and calls == []
    assert again[0] == first[0] and np.array_equal(again[1], first[1])
    farther = sweep_out(ctx, far)
    fresh = sweep_out(_box_context(), far)
    assert farther is not None and fresh is not None
    assert farther[0] > first[0] and farther[0] == fresh[0]
    assert np.allclose(farther[1], fresh[1])
    assert len(ctx.sweeps) == 1


def test_a_sweep_the_detection_takes_into_avoid_is_refused_before_all_samples_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """nu_o holds the detected pose's path, so when the pilot (the detection alone) already
    sweeps into avoidVol the sweep fails, without simulating the other samples; with avoidVol
    out of the way the same sweep is simulated in full."""
    ctx = _box_context()
    plan = sweep_action._plan_sweep(ctx, "box", math.pi / 2, -1)
    frame, in_frame = sweep_action._frame_at(ctx, "box", plan, 0.5)
    ngr = Volume.of_box("ngr", np.array([0.75, -0.20, TABLE.top_z + 0.1]), (0.2, 0.2, 0.2), 0.0)
    goal = AwayFrom(ngr)
    pilot = sweep_evolution.sweep_until(
        ctx, "box", goal, plan.region, frame, in_frame[:1], 0.55, sweep_evolution.PILOT_STEP
    )
    assert pilot is not None
    # A post on the detection's path, halfway along its sweep.
    path = pilot[1].reshape(-1, 3)
    midway = path[len(path) // 2]
    wall = Volume.of_box(
        "wall", np.array([midway[0], midway[1], TABLE.top_z + 0.1]), (0.04, 0.04, 0.2), 0.0
    )
    assert Volume.of_object("box", ctx.beliefs["box"].spec, path, TABLE.top_z).intersects(wall)
    simulated = []
    until = sweep_evolution.sweep_until
    monkeypatch.setattr(
        sweep_evolution,
        "sweep_until",
        lambda c, n, g, r, f, samples, *a, **k: (
            simulated.append(len(samples)) or until(c, n, g, r, f, samples, *a, **k)
        ),
    )
    refused = sweep_evolution.simulate(ctx, "box", goal, plan.region, frame, in_frame, wall)
    assert refused == sweep_evolution.PILOT_INTO_AVOID
    assert simulated == [1]
    simulated.clear()
    swept = sweep_evolution.simulate(ctx, "box", goal, plan.region, frame, in_frame, Volume())
    assert not isinstance(swept, str)
    assert simulated == [1, len(in_frame)]


def test_the_hand_pushes_as_low_as_the_map_allows() -> None:
    """§2.2.1 pushes "as low as possible": the push height first, the map's next height only
    where the map rules the lowest out (close in front of the shoulder, the forearm meets the
    table), and every height the map allows in the open workspace, lowest first."""
    ctx = _box_context()
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    near_shoulder, in_workspace = np.array([0.44, -0.11]), np.array([0.70, -0.20])
    heading = math.radians(30.0)
    assert (
        arm.reach is not None and arm.reach.may_reach(near_shoulder, heading, PUSH_HEIGHT) is False
    )
    assert arm.line_heights(near_shoulder, near_shoulder, heading) == [HEIGHTS[1]]
    assert arm.line_heights(in_workspace, in_workspace, heading) == [PUSH_HEIGHT, HEIGHTS[1]]
    assert arm.line_heights(in_workspace, near_shoulder, heading) == [HEIGHTS[1]]


def test_a_line_the_map_rules_out_in_its_middle_is_refused_before_ik(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The map's check covers the whole straight line, not only its ends: a line skirting the
    hole in front of the shoulder, allowed where it starts and stops, is refused without IK."""
    from planners.actions.hand_in import hand_in
    from planners.hand2d import push_grasp_profile

    ctx = _box_context()
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    heading = math.radians(-45.0)
    start = np.array([0.36, -0.16])
    end = start + 0.2 * np.array([math.cos(heading), math.sin(heading)])
    assert arm.reach is not None
    assert all(arm.reach.may_reach(p, heading, h) for p in (start, end) for h in HEIGHTS)
    assert arm.line_heights(start, end, heading) == []
    calls: list[int] = []
    monkeypatch.setattr(Arm, "solve", lambda self, target, accept: calls.append(1))
    profile = push_grasp_profile(0.192)
    moved = hand_in(
        ctx, arm, "box", "pickup", Volume(), (start, end), heading, profile, lambda: np.empty(0)
    )
    assert isinstance(moved, Failure) and moved.reason == OUT_OF_REACH
    assert not calls


def _scene_context(*objects: tuple[str, str, tuple[float, float, float]]) -> PlanningContext:
    """A fresh planning context for (name, kind, pose) objects at sigma2, 30 samples each."""
    rng = np.random.default_rng(0)
    beliefs = {}
    for name, kind, pose in objects:
        samples = sample_poses(pose, (0.005, 0.034), 30, rng)
        beliefs[name] = ObjectBelief(name, get_object(kind), pose, samples, (0.005, 0.034))
    settings = PlannerSettings(time_budget=600.0)  # far above the tests' needs
    return PlanningContext(TABLE, beliefs, settings, TABLE.default_goal_region, rng)


def test_an_evolution_sweeps_into_avoid_as_its_fcl_volume_does() -> None:
    """`PlanningContext.sweeps_into` tests nu_o against avoidVol in the plane and in height
    where avoidVol is the named objects' samples, and with fcl shapes otherwise: the answers
    are fcl's on random evolutions among a can, a bottle, a pop-tart box and the dumbbell,
    and a volume that holds more than those samples (an object placed where an action left
    it) is seen whole."""
    ctx = _scene_context(
        ("goal", "juice_bottle", (0.75, -0.20, 0.3)),
        ("can", "soda_can", (0.72, -0.05, 0.0)),
        ("box", "poptart_box", (0.86, -0.22, 1.1)),
        ("bell", "dumbbell", (0.70, -0.36, 0.4)),
    )
    top = TABLE.top_z
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(60):
        names = [n for n in ("can", "box", "bell") if rng.random() < 0.7]
        avoid = ctx.objects_volume(names)
        start = np.array([0.75, -0.20, 0.0]) + rng.normal(0.0, [0.05, 0.05, 1.0])
        path = start + np.linspace(0.0, 1.0, 40)[:, None] * rng.normal(0.0, [0.08, 0.08, 0.5])
        nu = path[:, None, :] + rng.normal(0.0, [0.005, 0.005, 0.03], (40, 20, 3))
        spec = ctx.beliefs["goal"].spec
        expected = Volume.of_object("goal", spec, nu.reshape(-1, 3), top).intersects(avoid)
        assert ctx.sweeps_into("goal", nu, avoid) == expected
        hits += expected
    assert 10 <= hits <= 50, hits
    # An object left at a pose in avoidVol's sum: the planar path would not see it.
    nu = np.array([[0.60, 0.20, 0.0], [0.62, 0.20, 0.1]])
    left = Volume.of_object("can", ctx.beliefs["can"].spec, np.array([0.61, 0.20, 0.0]), top)
    assert not ctx.sweeps_into("goal", nu, ctx.objects_volume(["can"]))
    assert ctx.sweeps_into("goal", nu, ctx.objects_volume(["can"]) + left)


@pytest.mark.parametrize("yaw", [0.0, 1.446, 2.08])
def test_a_box_is_swept_square_to_its_faces_a_can_along_the_grid(yaw: float) -> None:
    """Sweep directions every `sweep_step_deg`, and for a box also square to each detected
    face (a box turned off the grid would otherwise meet the hand's side at a corner)."""
    from planners.actions.heuristics import sweep_directions

    ctx = _scene_context(
        ("box", "large_box", (0.70, 0.0, yaw)), ("can", "soda_can", (0.7, -0.3, 0))
    )
    shoulder = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget).heading_origin
    step = math.radians(ctx.settings.sweep_step_deg)

    def angles(name: str) -> set[float]:
        return {round(a % (2 * math.pi), 9) for a, _ in sweep_directions(ctx, shoulder, name)}

    def on_grid(a: float) -> bool:
        return abs(math.remainder(a, step)) < 1e-6

    can, box = angles("can"), angles("box")
    assert can and all(on_grid(a) for a in can)
    squares = {round((yaw + k * math.pi / 2) % (2 * math.pi), 9) for k in range(4)}
    assert {a for a in box if not on_grid(a)} == {a for a in squares if not on_grid(a)}
    assert len(squares & box) >= 2  # the hand reaches at least two of the faces


@pytest.mark.parametrize("surface", [TABLE, SHELF], ids=lambda s: s.name)
def test_sweep_directions_are_refined_in_an_enclosed_surface_only(surface: Any) -> None:
    """A sweep tries its directions at the settings' step first; in the shelf, then, the
    ones halfway between them, each (direction, side) once; on the open table no more."""
    sweep_module = importlib.import_module("planners.actions.sweep")
    from planners.actions.heuristics import sweep_directions

    ctx = _scene_context(("can", "soda_can", (0.64, -0.2, 0.0)))
    ctx.surface = surface
    arm = Arm(surface, ctx.settings, ctx.stats, ctx.budget)
    found = list(sweep_module._directions(ctx, arm, "can"))
    coarse = sweep_directions(ctx, arm.heading_origin, "can")
    assert found[: len(coarse)] == coarse
    refined = found[len(coarse) :]
    if surface is TABLE:
        assert not refined
        return
    step = math.radians(ctx.settings.sweep_step_deg)
    keys = [(round(a % (2 * math.pi), 9), h) for a, h in found]
    assert len(set(keys)) == len(keys)
    assert refined and all(
        abs(math.remainder(a - step / 2, step)) < 1e-6 for a, _ in refined
    )  # halfway between the grid's directions


def _can_beside_bottle() -> PlanningContext:
    """A can with a juice bottle 11 cm to its left, at sigma2."""
    return _scene_context(
        ("can", "soda_can", (0.70, -0.25, 0.0)), ("bottle", "juice_bottle", (0.70, -0.14, 0.0))
    )


def test_a_push_grasps_hand_motion_is_searched_once_for_every_goal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The hand's motion of a push-grasp (capture, overlap, IK, the arm's motion, nu_o) does
    not depend on G: a second goal asking to move the same object past the same avoidVol
    reuses it, meets the same failures, and ends with what a fresh search gives."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")

    centre = np.array([0.70, -0.25, TABLE.top_z + 0.1])
    goals = [AwayFrom(Volume.of_box("ngr", centre, (s, s, 0.2), 0.0)) for s in (0.1, 0.2)]

    def outcomes(ctx: PlanningContext, goal: AwayFrom) -> list[object]:
        arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
        avoid = ctx.objects_volume(["bottle"])
        found = push_grasp.push_grasp(ctx, arm, "can", goal, avoid)
        return [
            getattr(o, "reason", None) or (o.details["heading_deg"], o.details["offset_m"])
            for o in found
        ]

    searched: list[tuple[float, float]] = []  # (heading, aperture) of each new search
    search = push_grasp._over_offsets

    def recorded(*args: Any) -> Any:
        searched.append(args[-2:])
        return search(*args)

    monkeypatch.setattr(push_grasp, "_over_offsets", recorded)
    ctx = _can_beside_bottle()
    first = outcomes(ctx, goals[0])
    assert any(isinstance(o, tuple) for o in first) and any(isinstance(o, str) for o in first)
    before = len(searched)
    again = outcomes(ctx, goals[1])
    assert len(set(searched)) == len(searched)  # none searched twice in one plan
    reusing, before = len(searched) - before, len(searched)
    assert again == outcomes(_can_beside_bottle(), goals[1])
    assert reusing < len(searched) - before  # a fresh plan searches what the second goal reused


def test_where_the_step_after_a_push_fails_the_next_offset_is_tried_before_another_aperture(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A push that passes at one lateral offset may still fail at what follows it (the
    release, lift or placement) where the next offset's would not: the search goes on over
    the offsets of that heading and aperture before it turns to another aperture (among the
    pushes of one kind: here every push counts as holding the preferred belief mass)."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _scene_context(("can", "soda_can", (0.70, -0.25, 0.0)))
    ctx.settings = dataclasses.replace(ctx.settings, preferred_mass=0.0)
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    centre = np.array([0.70, -0.25, TABLE.top_z + 0.1])
    away = AwayFrom(Volume.of_box("ngr", centre, (0.1, 0.1, 0.2), 0.0))
    asked: list[dict[str, float]] = []
    release = push_grasp.pick_up_or_release

    def refuse_the_first(*args: object) -> object:
        details = cast(dict[str, float], args[-1])
        asked.append(details)
        if len(asked) == 1:
            return Failure("can", "push-grasp", "refused")
        return release(*args)

    monkeypatch.setattr(push_grasp, "pick_up_or_release", refuse_the_first)
    monkeypatch.setattr(push_grasp, "place", lambda *a: Failure("can", "push-grasp", "no place"))
    found = push_grasp.push_grasp(ctx, arm, "can", away, ctx.objects_volume([]))
    first = next(o for o in found if isinstance(o, ActionResult))
    refused = asked[0]
    assert first.details["heading_deg"] == refused["heading_deg"]
    assert first.details["aperture_m"] == refused["aperture_m"]
    assert first.details["offset_m"] != refused["offset_m"]


def test_hand_poses_a_neighbour_blocked_are_not_tested_again_while_it_is_avoided(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The one-move passes search the goal's push-grasps under shrinking avoidVols: a hand
    pose that the bottle blocked (planar overlap) while the bottle and the box were avoided is
    not tested again when the bottle alone is, and the search ends as a fresh one does."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    clearance = importlib.import_module("planners.actions.clearance")

    def context() -> PlanningContext:
        return _scene_context(
            ("can", "soda_can", (0.72, -0.25, 0.0)),
            ("bottle", "juice_bottle", (0.72, -0.14, 0.0)),
            ("box", "poptart_box", (0.60, -0.34, 0.4)),
        )

    def outcomes(ctx: PlanningContext, avoided: list[str]) -> list[object]:
        arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
        avoid = ctx.objects_volume(avoided)
        found = push_grasp.push_grasp(ctx, arm, "can", away, avoid)
        return [getattr(o, "reason", None) or sorted(o.details.items()) for o in found]

    # Pushed out of an NGR (no TSR draws, whose random stream a fresh context restarts).
    centre = np.array([0.72, -0.25, TABLE.top_z + 0.1])
    away = AwayFrom(Volume.of_box("ngr", centre, (0.1, 0.1, 0.2), 0.0))
    ctx = context()
    outcomes(ctx, ["bottle", "box"])
    blocked = {k for k, why in ctx.blocked_hands.items() if why.blocker == "bottle"}
    assert blocked
    tested: set[tuple[float, ...]] = set()
    lines = clearance.lines_overlapping

    def counted(c, pusher, starts, ends, heading, avoid, z):
        tested.update((heading, *np.round(e, 9)) for e in ends)
        return lines(c, pusher, starts, ends, heading, avoid, z)

    monkeypatch.setattr(push_grasp, "lines_overlapping", counted)
    again = outcomes(ctx, ["bottle"])
    # The bottle blocks hands again (it is still avoided), and none of them was tested anew.
    assert any(o == "the hand overlaps bottle where it stops" for o in again)
    blocked_ends = {
        (p.heading, *np.round(p.end, 9))
        for key in blocked
        for p in ctx.push_plans[key[:3]]
        if p is not None and p.offset == key[3]
    }
    assert len(blocked_ends) == len(blocked) and not blocked_ends & tested
    monkeypatch.setattr(push_grasp, "lines_overlapping", lines)
    assert again == outcomes(context(), ["bottle"])


def test_the_planar_hand_test_names_the_first_object_any_sample_of_which_it_overlaps() -> None:
    """`clearance._blockers` (one compiled pass over the hand poses, a pose's test ending at
    its first overlap, skipping samples whose bounding circle misses the hand's box) against
    the plain definition: per hand pose, the first object by name with any sample pose that
    the hand's cross-section overlaps."""
    from planners.actions.clearance import OVERLAP, _blockers
    from planners.hand2d import push_grasp_profile
    from planners.push_simulation import PoseSets, smallest_gap

    rng = np.random.default_rng(0)
    pusher = push_grasp_profile(0.15).pusher
    found = set()
    for _ in range(100):
        objects = []
        for name, kind in (("a", "soda_can"), ("b", "poptart_box"), ("c", "large_box")):
            centre = rng.uniform([-0.1, -0.3, -3.0], [0.5, 0.3, 3.0])
            local = centre + rng.normal(0.0, [0.02, 0.02, 0.2], (30, 3))
            objects.append((name, get_object(kind).footprint, local))
        shifts = rng.uniform([-0.2, -0.2], [0.3, 0.2], (15, 2))
        expected = []
        for shift in shifts:
            hits = [
                name
                for name, footprint, local in objects
                if (smallest_gap(footprint, pusher, local - [*shift, 0.0]) < -OVERLAP).any()
            ]
            expected.append(hits[0] if hits else "")
        packed = PoseSets.of([(footprint, local) for _, footprint, local in objects])
        assert _blockers(pusher, (("a", "b", "c"), packed), shifts) == expected
        found.update(expected)
    assert found == {"", "a", "b", "c"}


def test_the_planar_test_of_many_hand_motions_answers_each_as_alone() -> None:
    """`clearance.lines_overlapping` tests the stops of every motion at once and then the ways
    in grouped by swept length: each motion gets the answer it gets alone, which names the
    object where the stop overlaps one, else where the hand swept from the start to the stop
    does (`_swept`, the length rounded up to `SWEPT_RESOLUTION`), else nothing."""
    from planners.actions.clearance import (
        SWEPT_RESOLUTION,
        _blockers,
        _facing,
        _shifts,
        _swept,
        lines_overlapping,
    )
    from planners.hand2d import push_grasp_profile

    ctx = _scene_context(
        ("can", "soda_can", (0.72, -0.25, 0.0)),
        ("bottle", "juice_bottle", (0.72, -0.10, 0.0)),
        ("box", "poptart_box", (0.80, -0.34, 0.4)),
    )
    pusher = push_grasp_profile(0.15).pusher
    avoid = ctx.objects_volume(["bottle", "box"])
    z = TABLE.top_z + 0.02
    rng = np.random.default_rng(3)
    heading = 0.3
    along = np.array([math.cos(heading), math.sin(heading)])
    ends = rng.uniform([0.45, -0.45], [0.75, 0.05], (60, 2))
    starts = ends - rng.uniform(0.0, 0.25, (60, 1)) * along
    found = lines_overlapping(ctx, pusher, starts, ends, heading, avoid, z)
    objects = _facing(ctx, heading, 1, avoid, z)
    for start, end, answer in zip(starts, ends, found, strict=True):
        assert lines_overlapping(ctx, pusher, start, end, heading, avoid, z) == [answer]
        (at_stop,) = _blockers(pusher, objects, _shifts(end, heading))
        steps = math.ceil(float((end - start) @ along) / SWEPT_RESOLUTION - 1e-9)
        (on_way,) = _blockers(_swept(pusher, steps), objects, _shifts(start, heading))
        if at_stop:
            assert answer == (f"the hand overlaps {at_stop} where it stops", at_stop)
        elif on_way:
            assert answer == (f"the hand sweeps through {on_way} on its way in", on_way)
        else:
            assert answer == ("", "")
    assert {why.split(" ")[2] for why, _ in found if why} == {"overlaps", "sweeps"}
    assert ("", "") in found


def test_a_placement_meets_the_other_objects_exactly_where_their_shapes_overlap() -> None:
    """Pick-and-place's placement test skips poses far from an object's samples before it
    compares any shapes: over a grid of placements of a held can around two neighbours, its
    answer is the exact overlap of the placed samples with every other object's samples."""
    from planners.actions.pick_and_place import _meets_others

    ctx = _scene_context(
        ("can", "soda_can", (0.62, 0.0, 0.0)),
        ("box", "large_box", (0.75, 0.15, 0.4)),
        ("bottle", "juice_bottle", (0.70, -0.2, 0.0)),
    )
    spec = ctx.beliefs["can"].spec
    others = ["bottle", "box"]
    answers = []
    for dx in np.arange(-0.1, 0.25, 0.025):
        for dy in np.arange(-0.35, 0.35, 0.025):
            placed = ctx.beliefs["can"].samples + np.array([dx, dy, 0.0])
            exact = Volume.of_object("can", spec, placed, TABLE.top_z).intersects(
                ctx.objects_volume(others)
            )
            met = _meets_others(ctx, "can", placed, others)
            assert met == exact, (dx, dy)
            answers.append(exact)
    assert any(answers) and not all(answers)
    assert ctx.stats.seconds["placement"] > 0


def test_a_pose_whose_hand_meets_an_object_is_refused_after_one_check() -> None:
    """`Arm.solve` tests the hand (rigid with the TCP) once before trying IK solutions: a pose
    whose hand overlaps avoidVol costs one collision check, and every pose gets the answer the
    solutions' own checks give."""
    from clutter_gym.model.herb import HandCommand
    from clutter_gym.model.reachability import hand_pose

    ctx = _scene_context(("can", "soda_can", (0.75, -0.25, 0.0)))
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    avoid = ctx.objects_volume(("can",))
    free = arm.free_check(avoid, HandCommand(0.0, 0.0))
    z = TABLE.top_z + PUSH_HEIGHT
    at_can = hand_pose(np.array([0.75, -0.25]), 0.0, z)  # the palm where the can stands
    before = ctx.stats.collision_checks
    assert arm.solve(at_can, free) is None
    assert ctx.stats.collision_checks - before == 1
    solutions = arm.kinematics.ik_solutions(at_can)
    assert len(solutions) and arm.kinematics.select(solutions, free) is None
    reached = 0
    for xy in ([0.62, 0.05], [0.55, -0.45], [0.70, 0.20], [0.60, -0.25]):
        pose = hand_pose(np.array(xy), 0.0, z)
        expected = arm.kinematics.select(arm.kinematics.ik_solutions(pose), free)
        found = arm.solve(pose, free)
        assert (found is None) == (expected is None)
        if found is not None:
            reached += 1
            np.testing.assert_array_equal(found, expected)
    assert reached >= 2


def test_a_grasps_lift_and_carries_are_planned_once_for_every_goal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Pick-and-place after a push-grasp: the close, the lift and the carry to a placement do
    not depend on G, so a second goal asking to move the object past the same avoidVol carries
    it to no placement twice, and ends with what a fresh plan gives."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    pick_and_place = importlib.import_module("planners.actions.pick_and_place")

    centre = np.array([0.70, -0.30, TABLE.top_z + 0.1])
    goals = [AwayFrom(Volume.of_box("ngr", centre, (s, s, 0.2), 0.0)) for s in (0.2, 0.3)]

    def placed(ctx: PlanningContext, goal: AwayFrom) -> list[object]:
        arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
        found = push_grasp.push_grasp(ctx, arm, "can", goal, ctx.objects_volume(["bottle"]))
        return [
            (o.details["heading_deg"], o.details["offset_m"], o.nu[-1, 0, :2].round(6).tolist())
            for o in found
            if isinstance(o, ActionResult) and o.action == "pick-and-place"
        ]

    carried: list[tuple[int, float, float]] = []  # (hand-in, shift) of every carry planned
    carry = pick_and_place._carry

    def recorded(*args: Any) -> Any:
        carried.append((id(args[4]), *np.round(args[-1], 9)))
        return carry(*args)

    monkeypatch.setattr(pick_and_place, "_carry", recorded)
    ctx = _can_beside_bottle()
    first = placed(ctx, goals[0])
    assert first  # the push alone leaves the can in the NGR: it is carried out
    before = len(carried)
    again = placed(ctx, goals[1])
    assert again
    assert len(set(carried)) == len(carried)  # no carry planned twice in one plan
    reusing = len(carried) - before
    assert again == placed(_can_beside_bottle(), goals[1])
    assert reusing < len(carried) - before - reusing  # a fresh plan plans the carries reused


@pytest.mark.parametrize("kind", ["poptart_box", "soda_can"])
def test_a_pushs_pilots_are_its_nu_os_rows_of_the_detection_and_the_extreme_samples(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pilots a push-grasp tests against avoidVol before nu_o are nu_o's own rows, to the
    bit: the detected pose's under the first parameter set, then the extreme samples' under
    every set. A pilot in avoidVol is nu_o in avoidVol, so refusing the push on it refuses
    nothing nu_o would have allowed; and nu_o built on the pilots' rows is nu_o simulated
    whole (every other push below drops its pilots before nu_o)."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _scene_context(("obj", kind, (0.70, -0.25, 0.4)))
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    asked: list[tuple[Any, Any, Any]] = []

    def captured(*args: Any, **_: Any) -> Failure:
        asked.append((args[5][0], args[-2], args[-1]))
        return Failure("obj", "push-grasp", "stopped by the test")

    monkeypatch.setattr(push_grasp, "hand_in", captured)
    goal = AwayFrom(Volume.of_box("ngr", np.array([0.7, -0.25, 0.8]), (0.3, 0.3, 0.1), 0.0))
    for _ in push_grasp.push_grasp(ctx, arm, "obj", goal, Volume()):
        if len(asked) == 10:
            break
    assert len(asked) >= 10
    planned = [p for pushes in ctx.push_plans.values() for p in pushes if p is not None]
    n = len(ctx.beliefs["obj"].samples)
    pushed = 0
    for k, (start, evolve, pilots) in enumerate(asked[:10]):
        (push,) = [p for p in planned if p.start is start]
        extreme = push_grasp.extreme_samples(push.in_hand)
        ends = {int(f(push.in_hand[:, c])) for c in range(3) for f in (np.argmin, np.argmax)}
        assert extreme.tolist() == sorted(ends) and len(extreme) <= 6
        assert len(extreme) < n  # the pilots are a part of nu_o, not all of it
        detected, extremes = pilots()
        if k % 2:
            ctx.push_pilots.clear()
        rows = evolve().reshape(len(detected), -1, n, 3)  # (stages, parameter sets, samples)
        assert detected.shape == (len(rows), 1, 3)
        np.testing.assert_array_equal(detected[:, 0], rows[:, 0, 0])
        np.testing.assert_array_equal(extremes, rows[:, :, extreme].reshape(len(rows), -1, 3))
        pushed += bool(np.ptp(detected[:, 0, 0]) > 0.01)
        assert list(pilots()) == []  # nu_o itself is at hand from now on
    assert pushed  # pushes that move the object, not only grasps where it stands


def test_a_push_whose_detected_pose_sweeps_into_avoid_is_refused_before_nu_o() -> None:
    """`hand_in` tests the pilots' poses first, stage by stage, and simulates nu_o only where
    they all pass."""
    hand_in = importlib.import_module("planners.actions.hand_in")
    ctx = _scene_context(
        ("obj", "soda_can", (0.70, -0.25, 0.0)), ("wall", "soda_can", (0.8, -0.25, 0.0))
    )
    avoid = ctx.objects_volume(["wall"])
    into = np.array([[[0.70, -0.25, 0.0]], [[0.78, -0.25, 0.0]]])
    clear = np.array([[[0.70, -0.25, 0.0]], [[0.70, -0.30, 0.0]]])
    simulated: list[bool] = []

    def evolve() -> np.ndarray:
        simulated.append(True)
        return np.repeat(clear, 3, axis=1)

    later: list[bool] = []

    def pilots(*stages: np.ndarray) -> Any:
        def run() -> Any:
            for poses in stages:
                yield poses
                later.append(True)  # the next stage is computed only after this one passed

        return run

    assert hand_in._clear_evolution(ctx, "obj", avoid, evolve, pilots(into, clear)) is None
    assert not simulated and not later
    assert hand_in._clear_evolution(ctx, "obj", avoid, evolve, pilots(clear, into)) is None
    assert not simulated and later
    nu = hand_in._clear_evolution(ctx, "obj", avoid, evolve, pilots(clear, clear))
    assert nu is not None and simulated
    assert hand_in._clear_evolution(ctx, "obj", avoid, lambda: into, pilots()) is None


def test_an_ik_answer_is_found_once_per_pose_obstacles_and_hand() -> None:
    """The actions ask for the same sweep or push start under every parent candidate: the same
    volume and hand give the same check, and a pose's answer under it costs no collision check
    the second time and is the answer a fresh check gives (a copy: callers may change it)."""
    from clutter_gym.model.herb import HandCommand
    from clutter_gym.model.reachability import hand_pose

    ctx = _scene_context(("can", "soda_can", (0.75, -0.25, 0.0)))
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    avoid = ctx.objects_volume(("can",))
    hand = HandCommand(0.0, 0.0)
    free = arm.free_check(avoid, hand)
    assert arm.free_check(avoid, hand) is free
    assert arm.free_check(avoid, HandCommand(0.0, 1.0)) is not free
    assert arm.free_check(ctx.objects_volume(()), hand) is not free
    pose = hand_pose(np.array([0.62, 0.05]), 0.0, TABLE.top_z + PUSH_HEIGHT)
    first = arm.solve(pose, free)
    assert first is not None
    first[:] = 0.0
    before = ctx.stats.collision_checks
    again = arm.solve(pose, free)
    assert ctx.stats.collision_checks == before
    fresh = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    expected = fresh.solve(pose, fresh.free_check(avoid, hand))
    assert again is not None and expected is not None
    np.testing.assert_array_equal(again, expected)


def test_a_sweep_starts_with_the_arm_clear_of_the_object_it_sweeps() -> None:
    """The approach or transit brings the arm to a sweep's start with the object standing
    where it was detected, so the start must be clear of its samples too: beside a large box
    the first IK solution at the start often puts the elbow in the box (two of the four
    sweeps found here did before the start was checked against the box)."""
    ctx = _box_context()
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    centre = np.array([0.75, -0.20, TABLE.top_z + 0.1])
    goal = AwayFrom(Volume.of_box("ngr", centre, (0.25, 0.25, 0.2), 0.0))
    outcomes = sweep_action.sweep(ctx, arm, "box", goal, Volume())
    found = [o for o in outcomes if isinstance(o, ActionResult)]
    assert found
    for result in found:
        start = result.trajectory.segments[0]
        in_box = arm.free_check(ctx.uncertainty_volume("box"), start.hand)
        assert in_box(start.path[0])


def test_only_static_grasp_poses_that_reach_ik_use_up_the_ik_tries(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`TSR_IK_TRIES` bounds the poses that pay for IK and motions: a pose whose hand overlaps
    an object of avoidVol (planar test) or that the reachability map rules out is passed over
    without counting (before, Fig. 15's pick-and-place spent its tries on poses on the box or
    behind the can and never tried the can's right side)."""
    static_grasp = importlib.import_module("planners.actions.static_grasp")
    from planners.actions.goals import Retrieve

    calls: list[float] = []  # the palm's half-width: one per aperture
    blocked = [True]

    def fake_hand_in(ctx, arm, name, action, avoid, line, heading, profile, still):  # type: ignore[no-untyped-def]
        calls.append(profile.pusher.bounds[3])
        if blocked[0]:
            return Failure(name, action, "the hand overlaps box where it stops", "box")
        return Failure(name, action, "no collision-free IK solution where the hand stops")

    monkeypatch.setattr(static_grasp, "hand_in", fake_hand_in)
    ctx = _scene_context(("can", "soda_can", (0.70, -0.20, 0.0)))
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)

    def per_aperture() -> list[int]:
        calls.clear()
        list(static_grasp.static_grasp(ctx, arm, "can", Retrieve(), Volume()))
        return list(Counter(calls).values())

    ik_tries = static_grasp.TSR_IK_TRIES
    assert max(per_aperture()) > ik_tries  # every blocked pose is passed over, none counted
    blocked[0] = False
    counts = per_aperture()
    assert max(counts) == ik_tries and len(counts) > 1  # then the next aperture

    calls.clear()
    monkeypatch.setattr(Arm, "line_heights", lambda self, start, end, heading: [])
    found = list(static_grasp.static_grasp(ctx, arm, "can", Retrieve(), Volume()))
    assert not calls  # no hand-in where the map rules the hand out
    reasons = Counter(f.reason for f in found if isinstance(f, Failure))
    assert reasons[OUT_OF_REACH] > ik_tries
    assert set(reasons) <= {OUT_OF_REACH, static_grasp.NO_TSR_POSE}


@pytest.mark.parametrize("kind", ["soda_can", "poptart_box"])
def test_all_offsets_planned_at_once_are_each_offsets_own_plan(kind: str) -> None:
    """`_plan_pushes` answers every lateral offset with one region query; each answer must be
    what the hand at that offset alone gives (its frame, nearest edge and query), to the bit."""
    from clutter_gym.model.transforms import Frame2D
    from planners.actions.grasp_geometry import START_CLEARANCE, near_edge

    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _scene_context(("o", kind, (0.72, -0.25, 0.4)))
    samples = ctx.beliefs["o"].samples
    footprint = get_object(kind).footprint
    planned = 0
    for aperture in push_grasp_apertures(footprint):
        region = ctx.push_region(footprint, aperture)
        front = push_grasp.push_grasp_profile(aperture).pusher.bounds[1]
        for heading in np.radians(np.arange(-180.0, 180.0, 30.0)):
            offsets = lateral_offsets(samples, heading, region.lateral_reach, 0.01)
            plans = push_grasp._plan_pushes(ctx, "o", heading, aperture, offsets)
            for offset, plan in zip(offsets, plans, strict=True):
                v = np.array([math.cos(heading), math.sin(heading)])
                centre = samples[0, :2] + offset * np.array([-v[1], v[0]])
                local = Frame2D((float(centre[0]), float(centre[1])), heading).to_frame(samples)
                start = centre + (near_edge(footprint, local) - front - START_CLEARANCE) * v
                in_hand = Frame2D((float(start[0]), float(start[1])), heading).to_frame(samples)
                inside, need = region.query(in_hand)
                assert (plan is not None) == bool(inside.all())
                if plan is not None:
                    planned += 1
                    distance = min(need.max() + region.push_margin, region.d_max)
                    assert np.array_equal(plan.start, start)
                    assert np.array_equal(plan.in_hand, in_hand)
                    assert plan.distance == distance
                    assert np.array_equal(plan.end, start + distance * v)
    assert planned > 20


def _wide_can(preferred_mass: float = PlannerSettings.preferred_mass) -> PlanningContext:
    """A lone can at Fig. 2's noise (sigma 2 cm, 20 samples): pushes that hold every sample
    differ in how much of the belief they hold."""
    pose = (0.68, -0.25, 0.0)
    samples = sample_poses(pose, (0.02, 0.05), 20, np.random.default_rng(3))
    belief = ObjectBelief("can", get_object("soda_can"), pose, samples, (0.02, 0.05))
    settings = PlannerSettings(time_budget=600.0, preferred_mass=preferred_mass)
    rng = np.random.default_rng(0)
    return PlanningContext(TABLE, {"can": belief}, settings, TABLE.default_goal_region, rng)


def test_a_pushs_belief_mass_is_the_share_of_draws_its_region_holds() -> None:
    """`_belief_masses`, one region query for all offsets, against the definition: the draws
    of the belief seen from each push's starting hand, inside the region of its distance."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _wide_can()
    belief = ctx.beliefs["can"]
    masses: list[float] = []
    for aperture in push_grasp_apertures(belief.spec.footprint)[:3]:
        region = ctx.push_region(belief.spec.footprint, aperture)
        for heading in np.radians([-60.0, 0.0, 45.0]):
            offsets = lateral_offsets(belief.samples, heading, region.lateral_reach, 0.01)
            if not len(offsets):
                continue
            pushes = [
                p for p in push_grasp._plan_pushes(ctx, "can", heading, aperture, offsets) if p
            ]
            for push, mass in zip(
                pushes, push_grasp._belief_masses(ctx, "can", pushes), strict=True
            ):
                hand = Frame2D((float(push.start[0]), float(push.start[1])), heading)
                held = region.contains(hand.to_frame(belief.mass_draws), push.distance)
                assert mass == pytest.approx(held.mean(), abs=1e-12)
                masses.append(mass)
    assert len(masses) > 20 and min(masses) < 0.95 < max(masses)


@pytest.mark.parametrize("preferred", [0.95, 0.0])
def test_pushes_holding_the_preferred_mass_are_tried_first_at_every_heading(
    monkeypatch: pytest.MonkeyPatch, preferred: float
) -> None:
    """Every push whose region holds at least `preferred_mass` of the belief is tried (at
    every heading and aperture) before any that holds less, and within a heading and aperture
    the most mass first; with 0 every push is of the first kind."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _wide_can(preferred)
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    tried: list[tuple[float, float, float]] = []

    def refuse(c, a, name, avoid, action, push, mass):  # type: ignore[no-untyped-def]
        tried.append((push.heading, push.aperture, mass))
        return Failure(name, action, "refused")

    monkeypatch.setattr(push_grasp, "_push_at", refuse)
    away = AwayFrom(Volume.of_box("ngr", np.array([0.68, -0.25, 0.85]), (0.1, 0.1, 0.2), 0.0))
    list(push_grasp.push_grasp(ctx, arm, "can", away, ctx.objects_volume([])))
    kinds = [mass >= preferred for _, _, mass in tried]
    first_low = kinds.index(False) if False in kinds else len(kinds)
    assert all(kinds[:first_low]) and not any(kinds[first_low:])
    assert first_low > 5 and (preferred == 0.0) == (first_low == len(kinds))
    for kind in (tried[:first_low], tried[first_low:]):
        for key in {t[:2] for t in kind}:
            masses = [m for *k, m in kind if tuple(k) == key]
            assert masses == sorted(masses, reverse=True)
    headings_high = {t[0] for t in tried[:first_low]}
    assert len(headings_high) > 1  # the first kind spans headings before any of the second


def test_a_box_near_the_palm_turns_toward_the_axis_else_anywhere() -> None:
    """`closing_poses`: a box near the palm, turned less than `TURN_BAND` from the approach
    axis, sweeps only the orientations between its own and its rest; a box across the hand, or
    far ahead of the palm, may stand at any orientation."""
    box = get_object("poptart_box").footprint
    hx, hy = box.half_extents

    def stages(degrees: float, ahead: float, aside: float = 0.0) -> np.ndarray:
        theta = math.radians(degrees)
        x = PALM_FRONT + hx * abs(math.cos(theta)) + hy * abs(math.sin(theta)) + ahead
        return np.degrees(closing_poses(box, np.array([[x, aside, theta]]), STRAIGHT)[:, 0, 2])

    turned = stages(30.0, 0.0)
    assert turned.min() == pytest.approx(math.degrees(TURN_REST[0]))
    assert turned.max() == pytest.approx(30.0)
    assert stages(-40.0, 0.0).max() == pytest.approx(math.degrees(TURN_REST[1]))
    for anywhere in (stages(80.0, 0.0), stages(30.0, 0.06), stages(30.0, 0.0, 0.05)):
        assert np.ptp(anywhere) == pytest.approx(180.0 * (1 - 1 / len(anywhere)))


def test_a_closing_hand_shoves_a_box_off_the_palm_the_more_the_further_from_the_axis() -> None:
    """`closing_poses`: while the fingers close, a box moves away from the palm by the measured
    envelope (more the further it is turned from the approach axis, most across the hand) and
    ends at `CLOSING_CENTRE` across it."""
    box = get_object("poptart_box").footprint
    hx, hy = box.half_extents

    def moved(degrees: float, aside: float) -> np.ndarray:
        theta = math.radians(degrees)
        x = PALM_FRONT + hx * abs(math.cos(theta)) + hy * abs(math.sin(theta))
        stages = closing_poses(box, np.array([[x, aside, theta]]), STRAIGHT)[:, 0, :2]
        assert np.all(np.diff(stages[:, 0]) >= 0.0)  # away from the palm, never back
        return stages[-1] - (x, aside)

    shoves = [moved(degrees, 0.0)[0] for degrees in (0.0, 30.0, 50.0, 70.0, 90.0)]
    assert 0.0 < shoves[0] < shoves[1] < shoves[2] < shoves[3] == shoves[4]
    assert shoves[2] == pytest.approx(CLOSING_SHOVE[1][-1]) and shoves[3] == CLOSING_SHOVE_ELSEWHERE
    for aside in (-0.02, 0.0, 0.02):
        assert aside + moved(20.0, aside)[1] == pytest.approx(CLOSING_CENTRE)


@pytest.mark.parametrize("kind", ["soda_can", "juice_bottle"])
def test_closing_fingers_draw_a_cylinder_near_the_palm_to_its_seat(kind: str) -> None:
    """`closing_poses`: a cylinder standing well behind the fingertip line (the straight
    preshape's), anywhere across the hand, is carried
    to the palm and into `CYLINDER_SEAT_ASIDE`, and the held poses are that last stage; one
    further ahead may be drawn in or pinched by the fingertips: anywhere in `CYLINDER_TIP_HOLD`."""
    footprint = get_object(kind).footprint
    seat_x = PALM_FRONT + footprint.radius
    near = np.array([[seat_x + 0.015, 0.05, 1.0], [seat_x, -0.04, 0.0], [seat_x + 0.01, 0.0, 2.0]])
    stages = closing_poses(footprint, near, STRAIGHT)
    assert np.array_equal(stages[0], near)
    assert np.allclose(stages[-1, :, 0], seat_x)
    low, high = CYLINDER_SEAT_ASIDE
    assert np.all((stages[-1, :, 1] >= low) & (stages[-1, :, 1] <= high))
    assert np.ptp(stages[-1, :, 1]) == pytest.approx(high - low)  # the measured band, spanned
    assert np.array_equal(stages[:, :, 2], np.broadcast_to(near[:, 2], stages.shape[:2]))
    assert np.array_equal(held_poses(footprint, stages, STRAIGHT), stages[-1])
    onset = STRAIGHT.grasp_line + float(np.interp(STRAIGHT.aperture, *PINCH_ONSET))
    ahead = np.array([[onset + 0.005, 0.03, 0.0]])
    pinched = closing_poses(footprint, ahead, STRAIGHT)[:, 0]
    out, (right, left) = CYLINDER_TIP_HOLD
    assert pinched[1:, 0].min() == pytest.approx(seat_x)  # drawn in, or
    assert pinched[1:, 0].max() == pytest.approx(ahead[0, 0] + out)  # pinched further out
    assert set(pinched[1:, 1]) == {right, left}
    mixed = closing_poses(footprint, np.concatenate([near, ahead]), STRAIGHT)
    assert held_poses(footprint, mixed, STRAIGHT).shape == (mixed.size // 3, 3)  # every stage
    box = get_object("poptart_box").footprint
    box_stages = closing_poses(box, near, STRAIGHT)
    assert held_poses(box, box_stages, STRAIGHT).shape == (box_stages.size // 3, 3)


def test_push_headings_run_over_the_grid_first_then_between_its_steps() -> None:
    """The push-grasp tries the 15-degree grid's headings first (the plans it finds there stay
    what they were), then the ones between them, each direction once."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _box_context()
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    reach = 0.15
    coarse = push_grasp.push_headings(ctx, arm.heading_origin, "box", reach, Volume())
    tried = list(push_grasp._headings(ctx, arm, "box", reach, Volume()))
    assert tried[: len(coarse)] == coarse
    directions = np.round(np.degrees(np.array(tried)) % 360.0, 6)
    assert len(np.unique(directions)) == len(tried)  # no direction twice
    step = ctx.settings.heading_step_deg
    fine = step / push_grasp.HEADING_REFINE
    assert len(tried) - len(coarse) == round(360.0 / fine) - round(360.0 / step)


@pytest.mark.parametrize("liftable", [True, False])
def test_an_obstacle_too_heavy_to_lift_is_never_carried(liftable: bool) -> None:
    """Pick-and-place lifts the obstacle it carries out of the NGR; one the WAM cannot lift
    (the 5 kg dumbbell) is pushed only. The same can, declared too heavy, is never carried."""
    push_grasp = importlib.import_module("planners.actions.push_grasp")
    ctx = _scene_context(("can", "soda_can", (0.70, -0.25, 0.0)))
    belief = ctx.beliefs["can"]
    spec = dataclasses.replace(belief.spec, liftable=liftable)
    ctx.beliefs["can"] = dataclasses.replace(belief, spec=spec)
    centre = np.array([0.70, -0.25, TABLE.top_z + 0.1])
    goal = AwayFrom(Volume.of_box("ngr", centre, (0.1, 0.1, 0.2), 0.0))
    arm = Arm(TABLE, ctx.settings, ctx.stats, ctx.budget)
    outcomes = list(push_grasp.push_grasp(ctx, arm, "can", goal, ctx.objects_volume([])))
    carried = [o for o in outcomes if isinstance(o, ActionResult) and o.action == "pick-and-place"]
    refused = [o for o in outcomes if isinstance(o, Failure) and o.reason == "too heavy to lift"]
    assert bool(carried) == liftable and bool(refused) != liftable


def test_a_pull_fits_every_held_pose_in_the_goal_strip_or_is_not_offered() -> None:
    """`pull_targets`: held poses deeper than the strip at every turn of the hand get no pull; a
    seated can's do, and the first moves them into the strip (x centred, y inside by the
    margin)."""
    (x0, x1), (y0, y1) = SHELF.default_goal_region
    ctx = cast(PlanningContext, SimpleNamespace(goal_region=SHELF.default_goal_region))
    end_xy, heading, z = np.array([0.62, -0.55]), 0.0, SHELF.top_z + 0.08
    seated = np.column_stack([np.full(5, 0.74), np.linspace(-0.56, -0.55, 5), np.zeros(5)])
    targets = pull_targets(ctx, end_xy, heading, z, seated)
    assert targets
    start = hand_pose(end_xy, heading, z + SHELF_LIFT)[:2, 3]
    moved = seated[:, :2] + (targets[0][:2, 3] - start)  # the first target turns nothing
    assert np.all((moved[:, 0] > x0) & (moved[:, 0] < x1))
    assert np.all((moved[:, 1] >= y0 + STRIP_MARGIN - 1e-9) & (moved[:, 1] < y1))
    deep = x1 - x0 + 0.01  # deeper than the strip, and as wide: no turn fits it
    corners = [
        (0.70, -0.56),
        (0.70 + deep, -0.56),
        (0.70, -0.56 + deep),
        (0.70 + deep, -0.56 + deep),
    ]
    spread = np.column_stack([corners, np.zeros(4)])
    assert pull_targets(ctx, end_xy, heading, z, spread) == []
