"""The physics validation harness of capture regions: grid, frames, trials, judging, resume."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from agents.cli import main
from agents.experiments import validate_capture as vc
from agents.experiments.capture_objects import check_validation
from agents.figures.capture_region import _view, capture_figure
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import OBJECTS, get_object
from clutter_gym.model.reachability import tcp_pose
from clutter_gym.model.transforms import tilt_of_quaternion, yaw_of_quaternion
from clutter_gym.model.world import TABLE
from planners.actions.hand_in import closing_poses, held_poses
from planners.actions.pick_and_place import PLACE_ABOVE
from planners.capture import V_APERTURES, push_grasp_region, sweep_region
from planners.hand2d import (
    GRASP_DEPTH,
    PALM_FRONT,
    STRAIGHT_APERTURE,
    default_aperture,
    push_grasp_profile,
)
from tests.helpers import WHITE, assert_picture


def test_grid_covers_at_least_the_requested_trials() -> None:
    can, box = get_object("soda_can"), get_object("poptart_box")
    assert len(vc.grid(can, 1000)) >= 1000
    assert np.all(vc.grid(can, 50)[:, 2] == 0.0)
    angles = np.unique(vc.grid(box, 60)[:, 2])
    assert len(angles) == vc.BOX_ANGLES and angles.max() < math.pi
    with pytest.raises(ValueError, match="--trials"):
        vc.grid(can, 0)


def test_a_box_sweep_grid_stands_boxes_across_the_span_at_the_regions_angles() -> None:
    """250 trials of the large box's sweep: several rows inside the hand's span at every
    orientation of the region's grid (at the grasps' 5 deg the grid had two rows, both beyond
    the span, and no sweep touched the box)."""
    box = get_object("large_box")
    region = sweep_region(box.footprint)
    poses = vc.sweep_grid(box, region, 250)
    lo, hi = region.span
    angles = np.unique(poses[:, 2])
    assert len(angles) == region.s_contact.shape[1]
    for angle in angles:
        ys = np.unique(poses[poses[:, 2] == angle, 1])
        assert np.count_nonzero((ys > lo) & (ys < hi)) >= 2


def test_sweep_grid_crosses_the_hand_side_and_the_reach() -> None:
    can = get_object("soda_can")
    region = sweep_region(can.footprint)
    poses = vc.sweep_grid(can, region, 200)
    lo, hi = region.span
    assert len(poses) >= 200
    assert poses[:, 1].min() < lo and poses[:, 1].max() > hi
    inside = region.query(poses, vc.DISTANCE)[0]
    assert inside.any() and not inside[poses[:, 0] == poses[:, 0].max()].any()


def test_unknown_or_unfit_objects_are_rejected(monkeypatch: pytest.MonkeyPatch) -> None:
    assert vc.resolve_kind("can") == "soda_can"
    assert vc.resolve_kind("large_box", "sweep") == "large_box"
    with pytest.raises(ValueError, match=r"allowed: .*bottle"):
        vc.resolve_kind("teapot")
    with pytest.raises(ValueError, match="large_box"):
        vc.resolve_kind("large_box")
    # Sweeping an object the planner never pushes is how its pushable flag is decided.
    monkeypatch.setitem(OBJECTS, "tippy", replace(get_object("soda_can"), pushable=False))
    assert vc.resolve_kind("tippy", "sweep") == "tippy"


@pytest.mark.parametrize("rotation", [0.0, 45.0])
def test_push_frame_maps_to_the_world_along_the_heading(rotation: float) -> None:
    spec = get_object("soda_can")
    setup = vc.plan_push(spec, default_aperture(spec.footprint), rotation)
    x, y, theta = vc.world_pose(setup, (0.3, 0.0, 0.1))
    bx, by = setup.frame.origin
    assert math.atan2(y - by, x - bx) == pytest.approx(math.radians(rotation))
    assert math.hypot(x - bx, y - by) == pytest.approx(0.3)
    assert theta == pytest.approx(math.radians(rotation) + 0.1)
    assert [a.shape for a in setup.actions] == [(vc.WAYPOINTS, 9)]


def test_a_centred_can_is_push_grasped_and_a_far_one_is_not() -> None:
    spec = get_object("soda_can")
    setup = vc.plan_push(spec, default_aperture(spec.footprint), 0.0)
    env = ClutterRetrieveEnv()
    assert vc.run_trial(env, "soda_can", setup, (0.25, 0.0, 0.0)) == "success"
    assert vc.run_trial(env, "soda_can", setup, (0.30, 0.18, 0.0)).startswith("failure")
    env.close()


@pytest.mark.parametrize("rotation", [0.0, 45.0])
def test_left_sweeps_mirror_right_ones_away_from_the_robot(rotation: float) -> None:
    can = get_object("soda_can")
    region = sweep_region(can.footprint)
    poses = np.array([[0.25, 0.05, 0.0]])
    (right,) = vc.plan_sweeps(can, region, rotation, 1, poses)
    (left,) = vc.plan_sweeps(can, region, rotation, -1, poses)
    for setup, approach in ((right, rotation), (left, -rotation)):
        # The hand's approach axis (the frame's y) along the rotation, mirrored for the left.
        y_axis = setup.frame.y_axis
        assert math.degrees(math.atan2(y_axis[1], y_axis[0])) == pytest.approx(approach)
        assert setup.frame.x_axis[0] >= -1e-9  # never toward the robot
        assert vc.runnable(can, setup, poses[0]) == ""
        assert setup.anchor is not None and TABLE.bounds[0] < setup.anchor[0] < TABLE.bounds[1]
    # Mirror images: ahead along each sweep, with theta mirrored.
    for setup, turn in ((right, 0.2), (left, -0.2)):
        x, y, theta = vc.world_pose(setup, (0.3, 0.05, 0.2))
        assert (np.array([x, y]) - setup.frame.origin) @ setup.frame.x_axis == pytest.approx(0.3)
        assert theta == pytest.approx(setup.frame.angle + turn)


def test_a_can_inside_the_sweep_region_is_carried_and_outside_is_not() -> None:
    """Clearly inside, clearly beyond the fingertip and clearly beyond the sweep's reach."""
    can = get_object("soda_can")
    region = sweep_region(can.footprint)
    poses = np.array([[0.25, 0.05, 0.0], [0.25, 0.26, 0.0], [0.50, 0.05, 0.0]])
    assert region.query(poses, vc.DISTANCE)[0].tolist() == [True, False, False]
    (setup,) = vc.plan_sweeps(can, region, 0.0, 1, poses)
    env = ClutterRetrieveEnv()
    inside, beside, beyond = (vc.run_trial(env, "soda_can", setup, p) for p in poses)
    env.close()
    assert inside == "success"
    assert beside.startswith("failure: off the hand's side"), beside
    assert beyond.startswith("failure: not at the hand, over 5 cm"), beyond


def test_the_large_box_is_swept_left_as_in_figure_3() -> None:
    box = get_object("large_box")
    region = sweep_region(box.footprint)
    pose = np.array([[0.40, 0.05, math.pi / 2]])
    assert region.query(pose, vc.DISTANCE)[0].all()
    (setup,) = vc.plan_sweeps(box, region, 0.0, -1, pose)
    env = ClutterRetrieveEnv()
    assert vc.run_trial(env, "large_box", setup, pose[0]) == "success"
    env.close()


@pytest.mark.parametrize(
    ("end", "outcome"),
    [
        (vc.SweepEnd(0.0, 0.05, 0.01, ""), "success"),
        (vc.SweepEnd(0.004, 0.175, 0.01, ""), "success"),  # within the tolerances
        (vc.SweepEnd(0.0, 0.05, 0.01, "object toppled"), "failure: object toppled"),
        (vc.SweepEnd(0.0, 0.05, math.radians(12), ""), "failure: tilted 12 deg"),
        (vc.SweepEnd(0.0, 0.19, 0.0, ""), "failure: off the hand's side (y = 0.190 m)"),
        (vc.SweepEnd(math.inf, 0.0, 0.0, ""), "failure: not at the hand, over 5 cm from it"),
        (
            vc.SweepEnd(0.009, 0.0, 0.0, "", ("right_wam4",)),
            "failure: not at the hand, 0.9 cm from it, pushed by right_wam4",
        ),
    ],
)
def test_a_sweep_succeeds_only_upright_and_against_the_hand(end: vc.SweepEnd, outcome: str) -> None:
    assert vc.judge_sweep(end, (-0.072, 0.168)) == outcome


def test_summary_counts_failures_inside_and_tightness() -> None:
    trials = [
        vc.Trial(0, 0.0, (0.2, 0.0, 0.0), True, "success"),
        vc.Trial(1, 0.0, (0.3, 0.1, 0.0), False, "success"),
        vc.Trial(2, 0.0, (0.3, 0.2, 0.0), False, "failure: not held"),
        vc.Trial(3, 0.0, (0.1, 0.0, 0.0), True, "skipped: overlaps"),
    ]
    summary = vc.summarize(trials)
    assert summary["trials"] == 3 and summary["skipped"] == 1
    assert summary["failures_inside"] == 0 and summary["tightness"] == pytest.approx(0.5)


def test_failures_in_the_planners_push_margin_are_counted_apart() -> None:
    trials = [
        vc.Trial(0, 0.0, (0.2, 0.0, 0.0), True, "success"),
        vc.Trial(1, 0.0, (0.42, 0.0, 0.0), False, "failure: object toppled", at_edge=True),
        vc.Trial(2, 0.0, (0.41, 0.0, 0.0), False, "success", at_edge=True),
        vc.Trial(3, 0.0, (0.5, 0.0, 0.0), False, "failure: not held"),
    ]
    summary = vc.summarize(trials)
    assert summary["failures_inside"] == 0 and summary["failures_at_edge"] == 1
    assert summary["tightness"] == pytest.approx(0.5)


def test_push_grasp_validation_predicts_and_pushes_as_the_planner_does() -> None:
    """A pose is predicted inside only if the region's push plus the planner's margin fits,
    and is pushed that far (never further: the planner stops there); the rest `DISTANCE`."""
    spec = vc.get_object("soda_can")
    region, poses, _, jobs = vc._jobs(spec, "push-grasp", 250, (0.0,), None)
    assert isinstance(region, vc.CaptureRegion)
    predicted, edge = vc.predictions(region, poses)
    need = region.query(poses)[1]
    inside = region.contains(poses, vc.DISTANCE)
    assert predicted.any() and not (predicted & edge).any() and ((predicted | edge) == inside).all()
    assert (need[predicted] <= vc.DISTANCE - region.push_margin).all()
    assert (need[edge] > vc.DISTANCE - region.push_margin).all()
    pushed = np.array([job.setup.distance for job in jobs])
    planner = need[predicted] + region.push_margin
    assert (pushed[predicted] <= planner + 1e-9).all()
    assert (pushed[predicted] > planner - vc.DISTANCE_STEP).all()
    assert len(set(pushed[predicted])) > 5 and (pushed[~predicted] == vc.DISTANCE).all()


def test_static_grasp_validation_predicts_as_the_planner_closes() -> None:
    """Static grasps are predicted where the planner closes without a push; the poses the region
    holds without a push nearer the fingertip line are the edge, counted apart."""
    spec = vc.get_object("juice_bottle")
    region, poses, setups, _ = vc._jobs(spec, "static-grasp", 300, (0.0,), STRAIGHT_APERTURE)
    assert isinstance(region, vc.CaptureRegion)
    predicted, edge = vc.predictions(region, poses, "static-grasp")
    inside, push = region.query(poses)
    line = region.grasp_line
    assert predicted.any() and edge.any() and not (predicted & edge).any()
    assert ((predicted | edge) == (inside & (push <= 0.0))).all()
    assert (poses[predicted, 0] <= line - GRASP_DEPTH).all()
    assert (poses[edge, 0] > line - GRASP_DEPTH).all()
    assert poses[:, 0].max() > line  # the grid runs past the fingertips
    assert [s.distance for s in setups] == [0.0]


def test_a_deep_can_is_grasped_without_a_push() -> None:
    spec = get_object("soda_can")
    aperture = default_aperture(spec.footprint)
    setup = vc.plan_push(spec, aperture, 0.0, 0.0)
    assert setup.action_type == "static-grasp"
    line = push_grasp_profile(aperture).grasp_line
    env = ClutterRetrieveEnv()
    assert vc.run_trial(env, "soda_can", setup, (line - 0.03, 0.0, 0.0)) == "success"
    # In front of the fingertips nothing pulls it in: the closing hand misses it.
    assert vc.run_trial(env, "soda_can", setup, (line + 0.06, 0.0, 0.0)).startswith("failure")
    env.close()


def test_the_region_figure_draws_the_validated_aperture() -> None:
    """Panel (c) overlays a validation's trials on the region of the aperture it validated."""
    assert _view("juice_bottle", "push-grasp", 0.235).aperture == pytest.approx(0.235)
    default = _view("juice_bottle", "push-grasp").aperture
    assert default == pytest.approx(vc.default_aperture(vc.get_object("juice_bottle").footprint))


def test_sweep_summaries_count_each_side() -> None:
    trials = [
        vc.Trial(0, 0.0, (0.2, 0.0, 0.0), True, "success", 1),
        vc.Trial(1, 0.0, (0.2, 0.0, 0.0), True, "failure: tilted 12 deg", -1),
        vc.Trial(2, 0.0, (0.5, 0.0, 0.0), False, "success", -1),
        vc.Trial(3, 0.0, (0.4, 0.0, 0.0), True, "failure: not at the hand, pushed by wam4", 1),
    ]
    summary = vc.rotation_summary(trials, "sweep")
    assert summary["failures_inside"] == 2 and summary["tightness"] == pytest.approx(0.5)
    assert summary["failures_inside_arm_touched"] == 1
    assert summary["sides"]["right"]["failures_inside"] == 1
    assert summary["sides"]["left"]["failures_inside"] == 1
    assert summary["sides"]["left"]["tightness"] == 0.0
    assert "sides" not in vc.rotation_summary(trials, "push-grasp")


@pytest.mark.slow
def test_sweep_cli_small_run_resumes_and_draws(tmp_path: Path) -> None:
    out = tmp_path / "val.json"
    argv = ["validate-capture", "--object", "can", "--action", "sweep", "--trials", "4"]
    argv += ["--json", str(out), "--rotations", "0", "--workers", "1"]
    assert main(argv) == 0
    report = json.loads(out.read_text())
    summary = report["rotation_0deg"]
    assert report["action"] == "sweep" and report["grid_points"] == 4
    assert summary["trials"] + summary["skipped"] == 8  # every pose with each side
    assert summary["failures_inside"] == 0 and set(summary["sides"]) == {"right", "left"}
    log = tmp_path / "val.json.trials.jsonl"
    lines = log.read_text().count("\n")
    assert main(argv) == 0  # resumes: nothing to rerun
    assert log.read_text().count("\n") == lines
    png = tmp_path / "sweep.png"
    capture_figure("can", png, check_validation(report, out, "sweep"), action="sweep")
    assert_picture(png, min_width=800, colours=(WHITE, (207, 232, 207)))
    with pytest.raises(ValueError, match="--action sweep"):
        check_validation(report, out, "push-grasp")


def _assert_predicted_and_held(aperture: float, pose: tuple[float, float, float]) -> None:
    """The poptart box at ``pose`` (push frame) is inside the region at ``aperture``, and the
    push-grasp of the region's distance holds it in pybullet."""
    spec = get_object("poptart_box")
    region = push_grasp_region(spec.footprint, aperture)
    poses = np.array([pose])
    assert vc.predictions(region, poses)[0][0]
    distance = float(vc.push_distances(region, poses)[0])
    env = ClutterRetrieveEnv()
    outcome = vc.run_trial(
        env, "poptart_box", vc.plan_push(spec, aperture, 0.0, distance), poses[0]
    )
    env.close()
    assert outcome == "success", (distance, outcome)


@pytest.mark.parametrize(
    ("aperture", "x"),
    [
        (0.151, 0.29),
        pytest.param(0.192, 0.21, marks=pytest.mark.slow),
        pytest.param(0.192, 0.37, marks=pytest.mark.slow),
    ],
)
def test_a_box_nearly_across_the_hand_is_held_after_the_planners_push(
    aperture: float, x: float
) -> None:
    """The poptart box turned 80 deg straight ahead of the hand, pushed the region's need plus
    1 cm, toppled or left the table when the fingers closed (validation at 5 deg, stop 38): it
    is still turning into the palm there. The planner's push for a box (`push_margin`) holds it."""
    _assert_predicted_and_held(aperture, (x, 0.0, math.radians(80.0)))


@pytest.mark.parametrize(
    "aperture", [V_APERTURES[0], pytest.param(V_APERTURES[1], marks=pytest.mark.slow)]
)
def test_a_box_pushed_end_on_into_a_v_preshape_is_predicted_and_held(aperture: float) -> None:
    """Pushed end-on into a V preshape, the poptart box rests at the palm with its centre ahead
    of the fingertip line (0.155 m against 0.154 and 0.130 m): the regions counted no such box
    captured, where closing holds it. Predicted now, and held after the planner's push."""
    _assert_predicted_and_held(aperture, (0.3, 0.0, 0.0))


def test_two_fingers_closing_on_a_box_do_not_back_drive_the_third() -> None:
    """The BH-280's worm gears hold a stalled finger. A poptart box across the hand is met by
    F1 and F2 first; position servos limited to the drive's effort let the two turn F3 back to
    fully open (0.87 -> 0 rad) and slide the box 4 cm sideways, into whatever stood beside the
    hand (Table 1 high_09). F3 must hold where it stalled, and the box move no further sideways
    than the 2.6 cm its 14 cm leave in the 19.2 cm between the fingertips."""
    spec = get_object("poptart_box")
    setup = vc.plan_push(spec, STRAIGHT_APERTURE, 0.0, 0.06)
    env = ClutterRetrieveEnv()
    assert vc.start_trial(env, setup, "poptart_box", (0.21, 0.0, math.pi / 2)) == ""
    for action in setup.actions:
        env.step(action)
    _, f1, f2, f3 = env.herb.hand_state()
    position, _ = env.sim.base_pose("object")
    frame = setup.frame
    env.close()
    assert f3 > 0.8 and min(f1, f2) > 0.8
    assert abs(frame.to_frame(np.array([[*position[:2], 0.0]]))[0, 1]) < 0.03


@pytest.mark.parametrize("angle", [0.0, math.pi / 2])
def test_a_box_set_down_and_let_go_stays_standing(angle: float) -> None:
    """Opening the hand reverses each finger from where it stands (the BH-280's worm gears): a
    poptart box push-grasped, lifted, set back down and let go stays upright on the table.
    With fingers that first squeezed on toward their old target as the hand opened, both of
    these were flung off the table or toppled."""
    spec = get_object("poptart_box")
    aperture = STRAIGHT_APERTURE
    setup = replace(vc.plan_push(spec, aperture, 0.0), anchor=(1.05, 0.55, 0.0))
    env = ClutterRetrieveEnv(waypoints=1)
    assert vc.start_trial(env, setup, "poptart_box", (0.2, 0.0, angle)) == ""
    kinematics = ArmKinematics("right")
    rows = list(setup.actions[0])
    lifted = kinematics.fk_tcp(rows[-1][:7])[:3, 3]
    forward = np.array([1.0, 0.0, 0.0])
    down = lifted - [0.0, 0.0, vc.LIFT - PLACE_ABOVE]
    lower = kinematics.cartesian_path(rows[-1][:7], tcp_pose(down, forward), 5)
    back = kinematics.cartesian_path(lower[-1], tcp_pose(down - 0.06 * forward, forward), 4)
    opened = push_grasp_profile(aperture).closure
    rows += [np.r_[q, 0.0, 1.0] for q in lower[1:]]
    rows += [np.r_[q, 0.0, opened] for q in (lower[-1], *back[1:])]
    info: dict[str, object] = {}
    for row in rows:
        _, _, terminated, truncated, info = env.step(row[None])
        assert not (terminated or truncated), info["failure"]
    _, quaternion = env.sim.base_pose("object")
    env.close()
    assert tilt_of_quaternion(quaternion) < vc.UPRIGHT_TILT


@pytest.mark.parametrize(
    ("aperture", "degrees", "ahead", "y"),
    [
        (STRAIGHT_APERTURE, 40.0, 0.0, 0.0),
        (0.151, -30.0, 0.02, 0.02),
        pytest.param(0.235, 50.0, 0.04, -0.02, marks=pytest.mark.slow),
        pytest.param(0.111, -20.0, 0.04, 0.0, marks=pytest.mark.slow),
    ],
)
def test_a_box_turns_toward_the_approach_axis_as_the_planner_expects(
    aperture: float, degrees: float, ahead: float, y: float
) -> None:
    """Fingers closing on a poptart box near the palm and turned from the approach axis turn
    it toward the axis, push it no further from the palm than the planner's closing stages
    (`closing_poses`) do, and hold it: the stages span its turn, and not the half turn they
    give a box across the hand."""
    spec = get_object("poptart_box")
    hx, hy = spec.footprint.half_extents
    theta = math.radians(degrees)
    x = PALM_FRONT + hx * abs(math.cos(theta)) + hy * abs(math.sin(theta)) + 0.003 + ahead
    profile = push_grasp_profile(aperture)
    stages = closing_poses(spec.footprint, np.array([[x, y, theta]]), profile)[:, 0]
    assert np.ptp(stages[:, 2]) < math.radians(90.0)  # the band, not the half turn
    setup = vc.plan_push(spec, aperture, 0.0, 0.0)
    env = ClutterRetrieveEnv()
    assert vc.start_trial(env, setup, "poptart_box", (x, y, theta)) == ""
    start, _ = env.sim.base_pose("object")
    info = vc.step_actions(env, setup.actions)
    end, quaternion = env.sim.base_pose("object")
    env.close()
    assert info["is_success"], info["failure"]
    before, after = setup.frame.to_frame(np.array([[*start[:2], 0.0], [*end[:2], 0.0]]))
    assert after[0] - before[0] <= stages[-1, 0] - x  # shoved off the palm no further than modelled
    yaw = setup.frame.to_frame(np.array([[0.0, 0.0, yaw_of_quaternion(quaternion)]]))[0, 2]
    turned = (yaw + math.pi / 2) % math.pi - math.pi / 2  # a box's faces repeat every half turn
    assert stages[:, 2].min() - 1e-9 <= turned <= stages[:, 2].max() + 1e-9, math.degrees(turned)
    assert abs(turned) < abs(theta)  # toward the axis


@pytest.mark.parametrize(
    ("kind", "ahead", "y"),
    [("soda_can", 0.02, 0.045), ("juice_bottle", 0.01, -0.03), ("soda_can", 0.055, 0.02)],
)
def test_closing_fingers_hold_a_cylinder_where_the_planner_expects(
    kind: str, ahead: float, y: float
) -> None:
    """A cylinder standing off the approach axis in the open hand ends, closed on and lifted,
    among the planner's held poses (`held_poses`: against the palm in `CYLINDER_SEAT_ASIDE`
    when it stood near it, else where the fingertips pinch it), not where it stood."""
    spec = get_object(kind)
    x = PALM_FRONT + spec.footprint.radius + ahead
    samples = np.repeat([[x, y, 0.0]], 5, axis=0)  # several, as a belief has: the seat is a band
    profile = push_grasp_profile(STRAIGHT_APERTURE)
    held = held_poses(spec.footprint, closing_poses(spec.footprint, samples, profile), profile)
    setup = vc.plan_push(spec, STRAIGHT_APERTURE, 0.0, 0.0)
    env = ClutterRetrieveEnv()
    assert vc.start_trial(env, setup, kind, (x, y, 0.0)) == ""
    info = vc.step_actions(env, setup.actions)
    end, _ = env.sim.base_pose("object")
    env.close()
    assert info["is_success"], info["failure"]
    ended = setup.frame.to_frame(np.array([[end[0], end[1], 0.0]]))[0, :2]
    assert np.all(ended >= held[:, :2].min(axis=0) - 0.003), (ended, held)
    assert np.all(ended <= held[:, :2].max(axis=0) + 0.003), (ended, held)
    assert abs(ended[1] - y) > 0.01  # it moved across the hand
