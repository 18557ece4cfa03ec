"""`clutter-gym validate-capture`: capture regions against physics, the analogue of Fig. 11.

Each trial places one object at a grid pose of the region's frame in the pybullet env, starts the
arm where the action starts and executes the whole action with the simulated arm and hand. A
push-grasp region is tested as the planner uses it: where the region predicts a capture (it asks
for at most `DISTANCE` less its `push_margin`), the hand pushes what the planner would push,
the region's distance plus that margin (rounded down to `DISTANCE_STEP`: never further than the
planner), and closes there; elsewhere it pushes `DISTANCE`, which tells the physical successes
the region leaves out (the poses it holds only within the last margin of `DISTANCE` are counted
apart as ``failures_at_edge``). The report counts predicted-inside failures (must be 0: the
regions are conservative) and the tightness: the share of physical successes the region predicts.

Push-grasps (``--action push-grasp``): the hand preshaped to the region's aperture, a straight
push (`push_distances`), closing the fingers, a 15 cm lift. Success is the env's: held by finger
contact and lifted 10 cm.

Static grasps (``--action static-grasp``): the push-grasp set-up with no push: the hand preshaped
to the aperture closes where the object stands and lifts, on a grid from the planner's TSR depth
behind the fingertip line to just beyond it. The planner closes without pushing only where
`planners.tsr.grasped_still` says (the region needs no push and the object's centre is
`planners.hand2d.GRASP_DEPTH` behind the line, or a box stands where the closing fingers turn it
to the approach axis, `planners.hand2d.turned_to_axis`); poses the region holds without a push
but nearer the line are counted apart as ``failures_at_edge``.

Sweeps (``--action sweep``): the planner's sweep (`planners.actions.sweep`): the hand horizontal at
`PUSH_HEIGHT`, the fingers at the sweep region's aperture, straight sideways for `DISTANCE`, then
2 cm back and up. Starts are found as the planner finds them (its `Arm`: IK from HERB's home, clear
of the table with the planner's padding, a straight line back from the end), wherever the rest of
the arm then is, and placed so that the object stands on the table before and after (a few starts
cover the grid: the table is 0.74 m deep). Both sides of the hand sweep every pose: the right side
is the region's frame (`planners.hand2d.sweep_profile`), the left its mirror image, and the BH-280
is not symmetric there (F3 alone pushes on one side, level with the TCP; F1 and F2 on the other,
2.5 cm above and below it). Success is physical: where the sweep ends the object still touches
the hand (within `CONTACT_TOLERANCE` of its palm, fingers or wrist in pybullet) with its centre
within the hand's span along y (the region's own test) +- `SPAN_TOLERANCE`; after the retreat and
rise it stands upright (tilt below `UPRIGHT_TILT` then and at the sweep's end), and the env saw no
failure (nothing toppled or left the table, the robot did not touch it). An object touches the
hand at the end only if the hand carried it along from first contact: its centre's displacement
alone is no test, because a box pushed at a corner turns and then lags the hand by up to its
half-diagonal minus its half-width while still touching it.

The same grid runs with the whole scene turned by `rotations` degrees about the vertical (the
hand's approach axis along each rotation): pybullet's friction is anisotropic (two decoupled
friction directions along its axes), which an action at 45 degrees exposes.

Results stream to `<json>.trials.jsonl` as they finish (`agents.runner.jobs`), keyed by
everything that decides a trial's physics (object, action, aperture, distance, grid, starts,
trajectories) and the code; a rerun with the same set-up skips the trials already there.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.experiments.capture_objects import ACTIONS, GRASPS, resolve_kind
from agents.policies.rollout import roll_out
from agents.runner.jobs import NumberedTrial, config_digest, run_jobs
from agents.runner.markdown import markdown_table
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.media import write_json
from clutter_gym.model import herb as hm
from clutter_gym.model.collision import Volume, make_checker
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import ObjectSpec, footprint_gap, get_object
from clutter_gym.model.reachability import PUSH_HEIGHT, hand_pose, tcp_pose
from clutter_gym.model.scene import SCENE_FORMAT
from clutter_gym.model.trajectory import DEFAULT_WAYPOINTS, Segment, Trajectory
from clutter_gym.model.transforms import Frame2D, tilt_of_quaternion
from clutter_gym.model.world import TABLE
from planners.actions.arm import Arm, Free
from planners.actions.grasp_geometry import GRASP_CLOSURE, LIFT, rise_height
from planners.actions.settings import Budget, PlannerSettings, PlanStats
from planners.actions.static_grasp import TSR_DEPTH
from planners.actions.sweep import SWEEP_RETREAT
from planners.capture import (
    BOX_PUSH_GRASP_SETTINGS,
    CaptureRegion,
    SweepRegion,
    push_grasp_region,
    sweep_region,
)
from planners.hand2d import (
    check_fits,
    closure_for_aperture,
    default_aperture,
    push_grasp_profile,
    sweep_profile,
)
from planners.tsr import grasped_still

DISTANCE = 0.25  # m pushed or swept
DISTANCE_STEP = 0.005  # m: the planner's push distances are rounded down to this
WAYPOINTS = DEFAULT_WAYPOINTS
PUSH_WAYPOINTS = 10
LIFT_WAYPOINTS = 4
GRID_Y = 0.20  # m either side of the hand axis (push-grasps)
GRID_X = (0.05, 0.45)  # m ahead of hand_base (push-grasps)
STATIC_MARGIN = 0.01  # m of static-grasp grid beyond the fingertip line
BOX_ANGLES = BOX_PUSH_GRASP_SETTINGS.box_thetas
"""Object orientations over [0, pi) at which grasps stand boxes (Fig. 9(d)): every 5 deg, the
push-grasp regions' own theta grid (`planners.capture.BOX_PUSH_GRASP_SETTINGS`). At 30 deg the
grid never stood the poptart box at 67-80 deg, where closing on it within 7 mm of the fingertip
line toppled it. Sweeps stand boxes at their region's own theta grid (`sweep_grid`)."""
SIDES = {1: "right", -1: "left"}  # a sweep's handedness: the side of the hand that pushes
SWEEP_MARGIN = 0.03  # m of sweep grid beyond the hand's span and beyond the region's reach
CONTACT_TOLERANCE = 0.005  # m between a swept object and the hand where the sweep ends
SPAN_TOLERANCE = 0.01  # m a swept object's centre may end beyond the hand's span
UPRIGHT_TILT = math.radians(10.0)
HAND_LINKS = ("right_hand_base", "right_f", "right_wam7", "right_wam6")
"""pybullet links (name prefixes) of the sweep's 2D hand: palm, fingers, the wrist to its end;
the forearm and elbow beyond are not in the sweep region's model."""
MAX_STARTS = 4  # sweep starts per rotation and side
START_STEP = 0.04  # m between the sweep starts tried
START_OVERHANG = 0.25  # m before the table's near edge a sweep may start (the hand over the floor)
PUSHED_BY = ", pushed by "  # a sweep outcome's list of the links beyond the hand touching it
ANCHOR_KIND = "soda_can"
"""A sweep scene's goal: the env needs a graspable goal, which a large box is not; a can
standing in a table corner away from the sweep takes that part."""
ANCHOR_INSET = 0.10  # m from the table's edges
ANCHOR_CLEARANCE = 0.05  # m a swept object keeps from the anchor, at the start and swept


@dataclass(frozen=True)
class Trial:
    index: int
    rotation_deg: float
    pose: tuple[float, float, float]  # object in the region's frame (x ahead, y, theta)
    predicted: bool
    outcome: str  # "success", "failure: <reason>", or "skipped: <reason>"
    handedness: int = 1  # sweeps: the side of the hand that pushed (`SIDES`)
    start: int = 0  # its set-up in the report's "setups"
    at_edge: bool = False  # push-grasps: inside at `DISTANCE`, not with the planner's margin

    @property
    def success(self) -> bool:
        return self.outcome == "success"


def grid(
    spec: ObjectSpec,
    trials: int,
    xs: tuple[float, float] = GRID_X,
    ys: tuple[float, float] = (-GRID_Y, GRID_Y),
    box_angles: int = BOX_ANGLES,
) -> np.ndarray:
    """At least `trials` poses (N, 3) over x range ``xs`` and y range ``ys`` of the region's
    frame, on a regular grid (boxes at ``box_angles`` orientations over [0, pi))."""
    if trials < 1:
        raise ValueError(f"--trials: {trials}; must be >= 1")
    angles = (
        np.linspace(0.0, np.pi, box_angles, endpoint=False)
        if spec.footprint.shape == "box"
        else np.zeros(1)
    )
    per_angle = math.ceil(trials / len(angles))
    ny = max(2, round(math.sqrt(per_angle * (ys[1] - ys[0]) / (xs[1] - xs[0]))))
    nx = max(2, math.ceil(per_angle / ny))
    mesh = np.stack(
        np.meshgrid(np.linspace(*xs, nx), np.linspace(*ys, ny), angles, indexing="ij"), axis=-1
    )
    return mesh.reshape(-1, 3)


def static_grid(spec: ObjectSpec, region: CaptureRegion, trials: int) -> np.ndarray:
    """Hand-frame poses where a static grasp may put the object: from the planner's TSR depth
    behind the fingertip line to `STATIC_MARGIN` beyond it, across the gap between the
    fingertips (poses overlapping the fingers are skipped)."""
    line = region.grasp_line
    xs = (line - TSR_DEPTH, line + STATIC_MARGIN)
    return grid(spec, trials, xs, (-region.half_gap, region.half_gap))


def sweep_grid(spec: ObjectSpec, region: SweepRegion, trials: int) -> np.ndarray:
    """Sweep-frame poses from just clear of the hand's side where it is flattest (the palm and
    the plate flush with it; poses overlapping the fingers are skipped) to `SWEEP_MARGIN` beyond
    the farthest a sweep of `DISTANCE` reaches (past the fingers), across the hand's span and
    `SWEEP_MARGIN` beyond. Boxes stand at the region's own orientations: the push-grasps' 5 deg
    leave a 250-trial grid two rows across, both beyond the span (no sweep touched a box)."""
    front = sweep_profile(region.aperture).pusher.bounds[1]
    footprint = spec.footprint
    near = hm.HAND_PALM_RADIUS + footprint.min_width / 2
    far = front + DISTANCE + footprint.bounding_radius
    lo, hi = region.span
    xs, ys = (near, far + SWEEP_MARGIN), (lo - SWEEP_MARGIN, hi + SWEEP_MARGIN)
    return grid(spec, trials, xs, ys, region.s_contact.shape[1])


@dataclass(frozen=True)
class Setup:
    """Where one action starts, its frame and trajectory: push-grasps one per rotation; sweeps a
    few per rotation and side, each grid pose run from the first that keeps it on the table."""

    action_type: str  # one of ACTIONS
    rotation_deg: float
    handedness: int  # push-grasps: 1
    frame: Frame2D  # the region's frame at the start, hand_base at its origin
    aperture: float
    start_arm: tuple[float, ...]
    actions: tuple[np.ndarray, ...]  # env trajectory actions (WAYPOINTS, 9), in order
    then: tuple[np.ndarray, ...] = ()  # sweeps: the retreat and rise, after the judging
    anchor: tuple[float, float, float] | None = None  # sweeps: the goal can's pose
    distance: float = DISTANCE  # m the hand moves along the frame's x


def plan_push(
    spec: ObjectSpec, aperture: float, rotation_deg: float, distance: float = DISTANCE
) -> Setup:
    """A reachable straight push of ``distance`` along heading `rotation_deg` (0 = the robot's
    forward), then close and lift; with no distance, a static grasp: close where it stands."""
    kinematics = ArmKinematics("right")
    heading = math.radians(rotation_deg)
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    preshaped = HandCommand(0.0, push_grasp_profile(aperture).closure)
    closed = HandCommand(0.0, GRASP_CLOSURE)
    z = TABLE.top_z + PUSH_HEIGHT
    tcp_offset = hm.HAND_TCP_OFFSET * direction

    def pose(tcp: np.ndarray) -> np.ndarray:
        return tcp_pose(tcp, direction)

    # Start points tried nearest the robot's usual reach first.
    for x in np.arange(0.66, 0.86, 0.02):
        for y in (-0.25, -0.30, -0.20, -0.35, -0.15, -0.40):
            hand_base = np.array([x, y, z])
            start_tcp = hand_base + tcp_offset
            q0 = kinematics.solve_ik(pose(start_tcp))
            if q0 is None:
                continue
            end_tcp = start_tcp + distance * direction
            push = (
                kinematics.cartesian_path(q0, pose(end_tcp), PUSH_WAYPOINTS)
                if distance > 0
                else np.asarray(q0)[None]
            )
            if push is None:
                continue
            lift = kinematics.cartesian_path(
                push[-1], pose(end_tcp + [0.0, 0.0, LIFT]), LIFT_WAYPOINTS + 1
            )
            if lift is None:
                continue
            push_grasp = Trajectory(
                (
                    Segment("push", push, preshaped),
                    Segment("close", push[-1:], closed),
                    Segment("lift", lift[1:], closed),
                )
            )
            (action,) = push_grasp.actions(WAYPOINTS)
            frame = Frame2D((float(x), float(y)), heading)
            kind = "push-grasp" if distance > 0 else "static-grasp"
            return Setup(
                kind, rotation_deg, 1, frame, aperture, _floats(q0), (action,), distance=distance
            )
    raise RuntimeError(f"no reachable straight push at heading {rotation_deg} deg")


def plan_sweeps(
    spec: ObjectSpec, region: SweepRegion, rotation_deg: float, handedness: int, poses: np.ndarray
) -> list[Setup]:
    """Up to `MAX_STARTS` sweeps of `DISTANCE` with side ``handedness`` pushing, each from the
    reachable start that keeps the most grid poses no earlier start runs on the table. The
    hand's approach axis is along `rotation_deg` (0 = the robot's forward) for the right side;
    the left side's set-up is its mirror image across the robot's forward axis (approach along
    -`rotation_deg`): both sweep away from the robot, the way the region's frame mirrors."""
    angle = handedness * (math.radians(rotation_deg) - math.pi / 2)
    z = TABLE.top_z + PUSH_HEIGHT
    hand = HandCommand(0.0, closure_for_aperture(region.aperture))
    arm = Arm(TABLE, PlannerSettings(), PlanStats(), Budget(math.inf))
    free = arm.free_check(Volume(), hand)
    risen = rise_height(TABLE.top_z, spec.height, z)

    def first(left: np.ndarray) -> Setup | None:
        for origin in _sweep_starts(spec, poses[left], Frame2D((0.0, 0.0), angle, handedness)):
            frame = Frame2D(origin, angle, handedness)
            tau = straight_action(arm, free, hand, frame, z, risen)
            if tau is not None:
                sweep, then = Trajectory(tau.segments[:1]), Trajectory(tau.segments[1:])
                return Setup(
                    "sweep",
                    rotation_deg,
                    handedness,
                    frame,
                    region.aperture,
                    _floats(tau.start),
                    tuple(sweep.actions(WAYPOINTS)),
                    tuple(then.actions(WAYPOINTS)),
                    anchor_pose(spec, frame, poses[left]),
                )
        return None

    setups: list[Setup] = []
    left = np.ones(len(poses), dtype=bool)
    while left.any() and len(setups) < MAX_STARTS:
        setup = first(left)
        kept = np.array([setup is not None and not runnable(spec, setup, p) for p in poses])
        if setup is None or not (kept & left).any():
            break
        setups.append(setup)
        left &= ~kept
    if not setups:
        raise RuntimeError(f"no reachable sweep at rotation {rotation_deg} deg, side {handedness}")
    return setups


def _floats(values: Sequence[float] | np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def _outlines(spec: ObjectSpec, world: np.ndarray) -> np.ndarray:
    """World bounds (N, 4), (x_min, x_max, y_min, y_max), of the outlines at poses (N, 3)."""
    return np.array([spec.footprint.aabb((float(x), float(y), float(t))) for x, y, t in world])


def _on_table(bounds: np.ndarray) -> np.ndarray:
    x_min, x_max, y_min, y_max = TABLE.bounds
    return (
        (bounds[..., 0] >= x_min)
        & (bounds[..., 1] <= x_max)
        & (bounds[..., 2] >= y_min)
        & (bounds[..., 3] <= y_max)
    )


def _and_swept(poses: np.ndarray) -> np.ndarray:
    """Region-frame poses (N, 3) and the same poses `DISTANCE` further along the sweep."""
    return np.concatenate([poses, poses + [DISTANCE, 0.0, 0.0]])


def _sweep_starts(
    spec: ObjectSpec, poses: np.ndarray, turned: Frame2D
) -> Iterator[tuple[float, float]]:
    """Hand_base positions every `START_STEP` over the table and up to `START_OVERHANG` before
    its near edge, those keeping the most of
    ``poses`` on the table (at the start and swept `DISTANCE` on) first, then those whose poses
    lie nearest the middle of the table's workspace. ``turned``: the sweep's frame at the
    world's origin."""
    x_min, x_max, y_min, y_max = TABLE.bounds
    (wx0, wx1), (wy0, wy1) = TABLE.workspace
    n = len(poses)
    about_origin = _outlines(spec, turned.to_world(_and_swept(poses)))
    xs = np.arange(x_min - START_OVERHANG, x_max, START_STEP)
    ys = np.arange(y_min, y_max, START_STEP)
    origins = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    kept = np.array(
        [_on_table(about_origin + np.repeat(o, 2)).reshape(2, n).all(0).sum() for o in origins]
    )
    middle = turned.to_world(poses)[:, :2].mean(0) - [(wx0 + wx1) / 2, (wy0 + wy1) / 2]
    off_middle = np.hypot(*(origins + middle).T)
    for i in np.lexsort((off_middle, -kept)):
        if kept[i]:
            yield float(origins[i, 0]), float(origins[i, 1])


def straight_action(
    arm: Arm,
    free: Free,
    hand: HandCommand,
    frame: Frame2D,
    z: float,
    risen: float,
    distance: float = DISTANCE,
    approach: float | None = None,
    retreat: float = SWEEP_RETREAT,
) -> Trajectory | None:
    """The planner's sweep motion (`planners.actions.sweep._sweep_motion`) without objects:
    hand_base from ``frame``'s origin ``distance`` along its x at TCP height ``z``, solved at
    the end and a straight line back to the start; then ``retreat`` back (the planner's
    `SWEEP_RETREAT`) and up to ``risen``. The approach axis (world yaw) is the sweep's, along
    the frame's y, unless ``approach`` is given (a push: along the frame's x)."""
    if approach is None:
        approach = frame.angle + frame.handedness * math.pi / 2
    start = np.asarray(frame.origin)
    end = start + distance * frame.x_axis
    q_end = arm.solve(hand_pose(end, approach, z), free)
    back = None if q_end is None else arm.straight(q_end, hand_pose(start, approach, z), free)
    if q_end is None or back is None:
        return None
    back_xy = end - retreat * frame.x_axis
    away = arm.straight(q_end, hand_pose(back_xy, approach, z), free)
    rise = (
        None if away is None else arm.straight(away[-1], hand_pose(back_xy, approach, risen), free)
    )
    if away is None or rise is None:
        return None
    return Trajectory(
        (
            Segment("move", back[::-1].copy(), hand),
            Segment("retreat", away, hand),
            Segment("rise", rise, hand),
        )
    )


def anchor_pose(spec: ObjectSpec, frame: Frame2D, poses: np.ndarray) -> tuple[float, float, float]:
    """The table corner (inset by `ANCHOR_INSET`) farthest from ``poses`` on the table, at the
    start or swept."""
    x_min, x_max, y_min, y_max = TABLE.bounds
    inset = ANCHOR_INSET
    corners = np.array(
        [(x, y) for x in (x_min + inset, x_max - inset) for y in (y_min + inset, y_max - inset)]
    )
    world = frame.to_world(_and_swept(poses))
    centres = world[_on_table(_outlines(spec, world)), :2]
    clearance = np.linalg.norm(corners[:, None] - centres[None], axis=-1).min(1)
    x, y = corners[np.argmax(clearance)]
    return (float(x), float(y), 0.0)


def runnable(spec: ObjectSpec, setup: Setup, pose: Sequence[float]) -> str:
    """Why a trial at ``pose`` (region frame) cannot run from this set-up, or "": a sweep that
    would carry the object off the table, or into the anchor, would test the set-up, not the
    region."""
    if setup.anchor is None:
        return ""
    swept = setup.frame.to_world(_and_swept(np.asarray([pose], dtype=float)))
    if not _on_table(_outlines(spec, swept)).all():
        return "a sweep from here would carry it off the table"
    anchor = get_object(ANCHOR_KIND).footprint
    for x, y, theta in swept:
        if footprint_gap(spec.footprint, (x, y, theta), anchor, setup.anchor) < ANCHOR_CLEARANCE:
            return "a sweep from here would carry it into the anchor"
    return ""


def world_pose(setup: Setup, pose: Sequence[float]) -> tuple[float, float, float]:
    """An object pose in the region's frame, in the world."""
    x, y, theta = setup.frame.to_world(np.asarray(pose, dtype=float))
    return (float(x), float(y), float(theta))


def start_trial(env: ClutterRetrieveEnv, setup: Setup, kind: str, pose: Sequence[float]) -> str:
    """Reset the env with the object at ``pose`` (and the anchor, the goal, if any) and the arm
    at the set-up's start: "" or why the trial cannot run."""
    objects = [{"name": "object", "kind": kind, "pose": list(world_pose(setup, pose))}]
    if setup.anchor is not None:
        objects.append({"name": "anchor", "kind": ANCHOR_KIND, "pose": list(setup.anchor)})
    scene = {
        "format": SCENE_FORMAT,
        "surface": "table",
        "objects": objects,
        "goal": {"object": objects[-1]["name"]},
        "noise": "sigma1",
    }
    closure = float(setup.actions[0][0, 8])
    placed = {"object": (get_object(kind), world_pose(setup, pose))}
    if make_checker(TABLE, placed).touching_objects(
        np.asarray(setup.start_arm), HandCommand(0.0, closure)
    ):
        return "the arm overlaps the object at the start"
    try:
        _, info = env.reset(
            seed=0, options={"scene": scene, "arm": setup.start_arm, "hand": (0.0, closure)}
        )
    except ValueError as error:  # off the table: not a physical trial
        return str(error)
    if info["failure"] or env.sim.contacts("herb", "object"):
        return info["failure"] or "the object overlaps the hand at the start"
    return ""


def step_actions(env: ClutterRetrieveEnv, actions: Sequence[np.ndarray]) -> dict[str, Any]:
    """Step the actions until the episode ends; the last info."""
    return roll_out(env, None, actions, {"failure": "", "is_success": False}).info


def run_trial(env: ClutterRetrieveEnv, kind: str, setup: Setup, pose: Sequence[float]) -> str:
    """One trial of the set-up's action with the object at ``pose`` (region frame): its outcome."""
    reason = runnable(get_object(kind), setup, pose) or start_trial(env, setup, kind, pose)
    if reason:
        return f"skipped: {reason}"
    if setup.action_type == "sweep":
        return judge_sweep(sweep_end(env, setup), sweep_profile(setup.aperture).span)
    info = step_actions(env, setup.actions)
    return "success" if info["is_success"] else f"failure: {info['failure'] or 'not held'}"


@dataclass(frozen=True)
class SweepEnd:
    """What decides a sweep trial, measured in pybullet."""

    gap: float  # m from the object to the hand's links (`HAND_LINKS`) where the sweep ended
    y: float  # m, the object's centre along the hand's side there (region frame)
    tilt: float  # rad, the object's larger tilt of the sweep's end and the action's end
    failure: str  # the env's, after the whole action ("" for none)
    arm: tuple[str, ...] = ()  # links beyond the hand touching the object where the sweep ended


def sweep_end(env: ClutterRetrieveEnv, setup: Setup) -> SweepEnd:
    """Execute a started trial's actions, measuring where the hand's motion ends."""
    info = step_actions(env, setup.actions)
    if info["failure"]:
        return SweepEnd(math.inf, math.nan, 0.0, info["failure"])
    origin = np.asarray(setup.frame.origin) + setup.distance * setup.frame.x_axis
    end = Frame2D((float(origin[0]), float(origin[1])), setup.frame.angle, setup.frame.handedness)
    y = float(end.to_frame(info["true_object_poses"][:1])[0, 1])
    gap, arm = hand_contact(env)
    tilt = _tilt(env)
    info = step_actions(env, setup.then)
    return SweepEnd(gap, y, max(tilt, _tilt(env)), info["failure"], arm)


def hand_contact(env: ClutterRetrieveEnv, within: float = 0.05) -> tuple[float, tuple[str, ...]]:
    """m from the object to the nearest link of the hand (`HAND_LINKS`; inf beyond ``within``),
    and the links beyond the hand touching it (within `CONTACT_TOLERANCE`)."""
    client, herb, body = env.sim.client, env.herb, env.sim.body("object")
    near = {}
    for name, link in herb.link_index.items():
        points = client.getClosestPoints(herb.body_id, body, within, linkIndexA=link)
        if points:
            near[name] = min(point[8] for point in points)
    hand = [d for link, d in near.items() if link.startswith(HAND_LINKS)]
    arm = (k for k, d in near.items() if d <= CONTACT_TOLERANCE and not k.startswith(HAND_LINKS))
    return min(hand, default=math.inf), tuple(arm)


def _tilt(env: ClutterRetrieveEnv) -> float:
    return tilt_of_quaternion(env.sim.base_pose("object")[1])


def judge_sweep(end: SweepEnd, span: tuple[float, float]) -> str:
    """A sweep trial's outcome: the hand carried the object along (it touches the hand where the
    sweep ended, its centre within the hand's ``span``), and it stands upright on the table."""
    lo, hi = span
    if end.failure:
        return f"failure: {end.failure}"
    if end.tilt > UPRIGHT_TILT:
        return f"failure: tilted {math.degrees(end.tilt):.0f} deg"
    if not lo - SPAN_TOLERANCE <= end.y <= hi + SPAN_TOLERANCE:
        return f"failure: off the hand's side (y = {end.y:.3f} m)"
    if end.gap > CONTACT_TOLERANCE:
        far = f"{100 * end.gap:.1f} cm" if math.isfinite(end.gap) else "over 5 cm"
        pushed = f"{PUSHED_BY}{', '.join(end.arm)}" if end.arm else ""
        return f"failure: not at the hand, {far} from it{pushed}"
    return "success"


@dataclass(frozen=True)
class ValidationJob(NumberedTrial):
    """One trial: its index, the object kind, its set-up and the pose (region frame)."""

    index: int
    kind: str
    setup: Setup
    pose: tuple[float, float, float]

    def crashed(self, error: str) -> dict[str, Any]:
        return {"outcome": f"crashed: {error}"}


@functools.cache
def _process_env() -> ClutterRetrieveEnv:
    """One env per process, reset for every trial: a worker pays for its pybullet world once."""
    return ClutterRetrieveEnv()


def _run_validation(job: ValidationJob) -> dict[str, Any]:
    return {"outcome": run_trial(_process_env(), job.kind, job.setup, job.pose)}


def summarize(trials: Sequence[Trial]) -> dict[str, Any]:
    crashed = [t for t in trials if t.outcome.startswith("crashed")]
    ran = [t for t in trials if not t.outcome.startswith(("skipped", "crashed"))]
    successes = [t for t in ran if t.success]
    predicted = [t for t in ran if t.predicted]
    failed_inside = [t for t in predicted if not t.success]
    predicted_successes = [t for t in successes if t.predicted]
    at_edge = [t for t in ran if t.at_edge and not t.success]
    return {
        "trials": len(ran),
        "skipped": len(trials) - len(ran) - len(crashed),
        "crashed": len(crashed),
        "physical_successes": len(successes),
        "predicted_inside": len(predicted),
        "failures_inside": len(failed_inside),
        "failures_at_edge": len(at_edge),
        "tightness": len(predicted_successes) / len(successes) if successes else None,
        "failures_inside_examples": [asdict(t) for t in failed_inside[:10]],
    }


def rotation_summary(trials: Sequence[Trial], action: str) -> dict[str, Any]:
    """`summarize` of one rotation's trials; for sweeps also of each side of the hand, and how
    many failures inside had the arm beyond the hand (the forearm) touching the object, which
    the sweep region does not model."""
    summary = summarize(trials)
    if action == "sweep":
        summary["failures_inside_arm_touched"] = sum(
            1 for t in trials if t.predicted and PUSHED_BY in t.outcome
        )
        summary["sides"] = {
            name: {
                k: v
                for k, v in summarize([t for t in trials if t.handedness == side]).items()
                if k != "failures_inside_examples"
            }
            for side, name in SIDES.items()
        }
    return summary


def _jobs(
    spec: ObjectSpec, action: str, trials: int, rotations: Sequence[float], aperture: float | None
) -> tuple[CaptureRegion | SweepRegion, np.ndarray, list[Setup], list[ValidationJob]]:
    """The region validated, the grid, the set-ups and one job per trial: every grid pose at
    every rotation (sweeps: with each side, from the first of its starts that runs it)."""
    poses: np.ndarray
    region: CaptureRegion | SweepRegion
    if action in GRASPS:
        grasp = push_grasp_region(spec.footprint, aperture or default_aperture(spec.footprint))
        static = action == "static-grasp"
        poses = static_grid(spec, grasp, trials) if static else grid(spec, trials)
        distances = np.zeros(len(poses)) if static else push_distances(grasp, poses)
        plans = [
            {d: plan_push(spec, grasp.aperture, r, d) for d in sorted(set(distances.tolist()))}
            for r in rotations
        ]
        region, setups = grasp, [s for plan in plans for s in plan.values()]
        per_pose = [[plan[d] for d in distances.tolist()] for plan in plans]
    else:
        region = sweep_region(spec.footprint)
        poses = sweep_grid(spec, region, trials)
        runs = [plan_sweeps(spec, region, r, side, poses) for r in rotations for side in SIDES]
        setups = [s for starts in runs for s in starts]
        per_pose = [
            [next((s for s in starts if not runnable(spec, s, p)), starts[0]) for p in poses]
            for starts in runs
        ]
    jobs = [
        ValidationJob(i * len(poses) + j, spec.kind, setup, (float(p[0]), float(p[1]), float(p[2])))
        for i, chosen in enumerate(per_pose)
        for j, (p, setup) in enumerate(zip(poses, chosen, strict=True))
    ]
    return region, poses, setups, jobs


def push_distances(region: CaptureRegion, poses: np.ndarray) -> np.ndarray:
    """m the hand pushes each grid pose (N,): where the region predicts a capture, what the
    planner pushes (the region's distance plus its `push_margin`), rounded down to
    `DISTANCE_STEP` (a set-up per distance; never further than the planner); `DISTANCE`
    elsewhere."""
    predicted = predictions(region, poses)[0]
    planned = np.where(predicted, region.query(poses)[1] + region.push_margin, DISTANCE)
    steps = np.floor(planned / DISTANCE_STEP + 1e-9)
    return np.where(predicted, np.round(steps * DISTANCE_STEP, 6), DISTANCE)


def predictions(
    region: CaptureRegion | SweepRegion, poses: np.ndarray, action: str = "push-grasp"
) -> tuple[np.ndarray, np.ndarray]:
    """Which grid poses the region predicts a success for, and which are at its edge: push-grasp
    poses in the region at `DISTANCE` but not once the planner's `push_margin` is added; static
    grasps the region holds without a push that the planner does not close on (within
    `planners.hand2d.GRASP_DEPTH` of the fingertip line)."""
    if isinstance(region, SweepRegion):
        return region.query(poses, DISTANCE)[0], np.zeros(len(poses), dtype=bool)
    if action == "static-grasp":
        predicted = grasped_still(region, poses)
        inside, push = region.query(poses)
        return predicted, inside & (push <= 0.0) & ~predicted
    predicted = region.contains(poses, DISTANCE - region.push_margin)
    return predicted, region.contains(poses, DISTANCE) & ~predicted


def validate(
    name: str,
    trials: int,
    out: Path,
    rotations: Sequence[float] = (0.0, 45.0),
    workers: int = 2,
    action: str = "push-grasp",
    aperture: float | None = None,
) -> dict[str, Any]:
    """Run (or resume) ``trials`` grid poses of ``action`` at every rotation, push-grasps with
    the hand preshaped to ``aperture`` (default `default_aperture`); the report, also written
    to ``out`` (its trials log beside it)."""
    if action not in ACTIONS:
        raise ValueError(f"--action: {action!r}; allowed: {', '.join(ACTIONS)}")
    spec = get_object(resolve_kind(name, action))
    if aperture is not None:
        if action == "sweep":
            raise ValueError("--aperture: only grasps take an aperture (sweeps use one)")
        try:
            check_fits(spec.footprint, aperture)
        except ValueError as error:
            raise ValueError(f"--aperture: {error}") from None
    region, poses, setups, jobs = _jobs(spec, action, trials, rotations, aperture)
    predicted, edge = predictions(region, poses, action)
    physics = [
        (s.frame, s.start_arm, [a.tobytes() for a in s.actions + s.then], s.anchor) for s in setups
    ]
    config = config_digest(
        hashlib.sha256(
            repr((spec.kind, action, region.aperture, DISTANCE, poses.tobytes(), physics)).encode()
        ).hexdigest()
    )
    log = out.with_name(f"{out.name}.trials.jsonl")
    desc = f"validate {spec.kind}"
    run = run_jobs(jobs, _run_validation, log, config, workers=workers, desc=desc)
    start = {id(s): i for i, s in enumerate(setups)}
    results = [
        Trial(
            job.index,
            job.setup.rotation_deg,
            job.pose,
            bool(predicted[job.index % len(poses)]),
            r["outcome"],
            job.setup.handedness,
            start[id(job.setup)],
            bool(edge[job.index % len(poses)]),
        )
        for job, r in zip(jobs, run.records, strict=True)
    ]
    report: dict[str, Any] = {
        "object": spec.kind,
        "action": action,
        "aperture_m": region.aperture,
        "pushable": spec.pushable,  # whether the planner pushes it (a sweep run decides)
        "distance_m": DISTANCE,  # at most; a predicted push-grasp pushes the planner's distance
        "grid_points": len(poses),
        "setups": [
            {
                "rotation_deg": s.rotation_deg,
                "handedness": s.handedness,
                "origin": s.frame.origin,
                "angle": s.frame.angle,
                "start_arm": s.start_arm,
                "anchor": s.anchor,
            }
            for s in setups
        ],
    }
    for rotation in rotations:
        report[f"rotation_{rotation:g}deg"] = rotation_summary(
            [t for t in results if t.rotation_deg == rotation], action
        )
    report["trials"] = [asdict(t) for t in results]
    write_json(out, report)
    return report


def summary_lines(report: dict[str, Any], rotations: Sequence[float]) -> list[dict[str, Any]]:
    """One JSON line per rotation: the report's counts without the trial examples."""
    return [
        {
            "object": report["object"],
            "action": report["action"],
            "aperture_m": report["aperture_m"],
            "rotation_deg": rotation,
            **{
                k: v
                for k, v in report[f"rotation_{rotation:g}deg"].items()
                if k != "failures_inside_examples"
            },
        }
        for rotation in rotations
    ]


MARKDOWN_HEADER = (
    "object",
    "action",
    "aperture [m]",
    "rotation [deg]",
    "run",
    "skipped",
    "held",
    "predicted inside",
    "failures inside",
    "failures at the edge",
    "tightness",
)


def write_markdown(
    reports: Sequence[dict[str, Any]], rotations: Sequence[float], path: Path
) -> None:
    """The reports as one Markdown table, a row per region and rotation: "held" counts the
    physical successes, "tightness" the share of them the region predicts."""
    rows = []
    for line in (line for report in reports for line in summary_lines(report, rotations)):
        tightness = line["tightness"]
        rows.append(
            (
                line["object"],
                line["action"],
                f"{line['aperture_m']:.3f}",
                f"{line['rotation_deg']:g}",
                line["trials"],
                line["skipped"],
                line["physical_successes"],
                line["predicted_inside"],
                line["failures_inside"],
                line["failures_at_edge"],
                None if tightness is None else f"{tightness:.2f}",
            )
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(markdown_table(MARKDOWN_HEADER, rows)) + "\n")
