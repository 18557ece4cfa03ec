"""The planner as a teacher: its plans, executed as end-effector actions (`clutter-gym demos`).

An end-effector agent learns from ``(obs, action)`` sequences of its own env, so a plan of the
pushing planner (joint trajectories) is turned into the end-effector env's actions (TCP deltas,
a turn about the vertical, the hand's closure) by following it there, in physics:

1. the episode is reset with a seed; the planner plans from a detection of every object drawn
   with the env's noise, from the arm's configuration at reset (the env's ready pose), its
   push and grasp directions measured from the ready TCP and within `TURN_LIMIT_DEG` of the
   line to the object (`PlannerSettings.heading_origin`): a level hand turns little;
2. every segment of the plan becomes TCP waypoints, the forward kinematics of its joint rows
   interpolated in joint space until the TCP moves at most 1 cm between two of them; a
   free-space segment (the approach, a transit between actions) is first replaced by a
   straight level TCP line to its end, or two through a point above it, where the arm can
   follow one continuously and clear of the surface (the end-effector controller keeps the
   hand level and follows the TCP and its heading; a GoTo joint path swings the TCP a metre);
3. a proportional tracker sends, every step, the action that brings the TCP to the next
   waypoint (at most 1 cm, the env's step) and the hand's heading to the waypoint's, with the
   segment's hand closure; a closing hand is held still until its fingers stop.

In `ClutterRetrieveEELift-v0` an episode may start with the goal already gripped (the env's
planned grasp, run at reset): the teacher then does what the planner's PickUp does after
closing, a straight lift of `LIFT` with the hand closed, as TCP waypoints 1 cm apart.

The actions are recorded as they are sent. The simulation is deterministic, so replaying them
in the env reset with the same seed repeats the episode (`replay`); `record_demos` keeps every
episode, the failed ones with their reason, so that the success rate of the teacher is known.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from agents.learning.lift_env import LIFT_ENV_ID, START_KINDS, ClutterRetrieveLiftEnv
from clutter_gym.env import ClutterRetrieveEEEnv
from clutter_gym.model.collision import make_checker
from clutter_gym.model.files import atomic_write_text
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.noise import detect, resolve_noise
from clutter_gym.model.objects import get_object
from clutter_gym.model.trajectory import Trajectory
from clutter_gym.model.world import get_surface
from clutter_gym.sim.controllers import EE_STEP, YAW_STEP
from planners.actions.grasp_geometry import GRASP_CLOSURE, LIFT
from planners.actions.settings import PlannerSettings
from planners.rearrange import Plan, plan_retrieval
from planners.uncertainty import beliefs, sample_count

FREE_SPACE = ("approach", "transit")
"""Segment labels of the plan's free-space motions (joint paths from GoTo)."""
TURN_LIMIT_DEG = 45.0
"""The teacher's push and grasp directions, within this of the line from the ready TCP to the
object (`PlannerSettings.heading_origin`): the level hand turns little on its way there."""
VIA_HEIGHT = 0.10  # m above a contact segment's start for a route that comes down to it
WAYPOINT_SPACING = 0.01  # m between the TCP waypoints followed (one env step each)
REACHED = 0.004  # m: a waypoint is passed once the TCP is this close...
TURNED = 0.03  # rad: ...and the heading this close
PASSING = 0.012  # m: a waypoint on the way is passed this close (the TCP lags its target)
CLOSE_STEPS = 30  # steps a closing hand is held still at most (the BH-280 closes in about 25)
MIN_HOLD = 4  # steps a closing hand is held at least...
SETTLED = 0.01  # rad: ...until no finger moved more than this in a step
DEMOS_FILE = "demos.npz"
META_FILE = "demos.json"


@dataclass(frozen=True)
class Waypoint:
    """Where the TCP goes next, the hand's heading there and the hand's closure."""

    tcp: np.ndarray  # (3,)
    heading: float
    closure: float
    hold: int = 0  # steps to stay here once reached (a closing hand)
    passing: bool = False  # on the way: passed within `PASSING`, not stopped at


Transition = tuple[Any, np.ndarray, float, Any, bool, bool, dict[str, Any]]
"""(obs, action, reward, next_obs, terminated, truncated, info) of one env step."""


@dataclass(frozen=True)
class Demo:
    """One episode of the teacher: the env's reset seed, the actions sent, and how it ended."""

    seed: int
    actions: np.ndarray  # (T, 5) float32
    success: bool
    reason: str  # "" on success; why planning or the execution failed otherwise
    start: str = "ready"  # how the env's reset began (`ClutterRetrieveEELift-v0`'s start kinds)


def heading_of(pose: np.ndarray) -> float:
    """World yaw of a horizontal hand's approach axis (the TCP frame's z)."""
    return math.atan2(float(pose[1, 2]), float(pose[0, 2]))


def plan_waypoints(
    plan: Trajectory,
    kinematics: ArmKinematics,
    start: np.ndarray,
    free: Callable[[np.ndarray], bool],
) -> list[Waypoint]:
    """The TCP waypoints of a plan from the arm at ``start`` (module docstring)."""
    points: list[Waypoint] = []
    q = np.asarray(start, dtype=float)
    for segment in plan.segments:
        closure = float(segment.hand.closure)
        if segment.label in FREE_SPACE:
            path = _level_route(kinematics, q, segment.path[-1], free)
            if path is None:
                path = segment.path
        else:
            path = segment.path
        poses = kinematics.fk_tcp_batch(_dense(kinematics, path))
        points += [
            Waypoint(p[:3, 3].copy(), heading_of(p), closure, passing=k < len(poses) - 2)
            for k, p in enumerate(poses[1:])
        ]
        if segment.label == "close":
            end = poses[-1]
            points.append(Waypoint(end[:3, 3].copy(), heading_of(end), closure, CLOSE_STEPS))
        q = segment.path[-1]
    return points


def lift_waypoints(tcp: np.ndarray, heading: float) -> list[Waypoint]:
    """A closed hand's straight lift of `LIFT` from ``tcp``, a waypoint every centimetre."""
    rises = np.arange(1, round(LIFT / WAYPOINT_SPACING) + 1) * WAYPOINT_SPACING
    return [
        Waypoint(tcp + [0.0, 0.0, dz], heading, GRASP_CLOSURE, passing=k < len(rises) - 1)
        for k, dz in enumerate(rises)
    ]


def _level_route(
    kinematics: ArmKinematics, q: np.ndarray, goal: np.ndarray, free: Callable[[np.ndarray], bool]
) -> np.ndarray | None:
    """Joint rows of a straight TCP line from ``q`` to the configuration ``goal`` (the hand
    level, turning on the way), or of two lines through a point `VIA_HEIGHT` above ``goal``'s
    TCP; None if neither is free and continuous."""
    target = kinematics.fk_tcp(goal)
    above = target.copy()
    above[2, 3] += VIA_HEIGHT
    for route in ((target,), (above, target)):
        rows, here = [q[None]], q
        for pose in route:
            length = float(np.linalg.norm(pose[:3, 3] - kinematics.fk_tcp(here)[:3, 3]))
            n = max(2, math.ceil(length / WAYPOINT_SPACING) + 1)
            line = kinematics.cartesian_path(here, pose, n, accept=free)
            if line is None:
                break
            rows.append(line[1:])
            here = line[-1]
        else:
            return np.vstack(rows)
    return None


def _dense(kinematics: ArmKinematics, path: np.ndarray) -> np.ndarray:
    """Joint rows interpolated until the TCP moves at most `WAYPOINT_SPACING` between two."""
    rows = [path[:1]]
    for a, b in itertools.pairwise(path):
        fine = a + np.linspace(0.0, 1.0, 33)[:, None] * (b - a)
        tcp = kinematics.fk_tcp_batch(fine)[:, :3, 3]
        length = float(np.linalg.norm(np.diff(tcp, axis=0), axis=1).sum())
        n = max(1, math.ceil(length / WAYPOINT_SPACING))
        rows.append(a + np.linspace(0.0, 1.0, n + 1)[1:, None] * (b - a))
    return np.vstack(rows)


def track(env: gym.Env, points: list[Waypoint]) -> Iterator[np.ndarray]:
    """The tracker's actions, one per step, until the waypoints are done; the caller steps
    the env with each (the tracker reads the robot's TCP, as proprioception)."""
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEEEnv)
    for point in points:
        held = 0
        fingers = base.herb.hand_state()[1:]
        for _ in range(4 * point.hold + 60):  # a waypoint the arm cannot reach is let go
            tcp, quaternion = base.herb.tcp_pose()
            error = point.tcp - tcp
            turn = math.remainder(point.heading - _heading(quaternion), math.tau)
            near, turned = (PASSING, 3 * TURNED) if point.passing else (REACHED, TURNED)
            before, fingers = fingers, base.herb.hand_state()[1:]
            if np.linalg.norm(error) < near and abs(turn) < turned:
                held += 1
                # A closing hand is held until its fingers stop (on the object, or closed).
                settled = held > MIN_HOLD and float(np.abs(fingers - before).max()) < SETTLED
                if held > point.hold or settled:
                    break
            move = np.clip(error / EE_STEP, -1.0, 1.0)
            yaw = np.clip(turn / YAW_STEP, -1.0, 1.0)
            yield np.r_[move, yaw, 2.0 * point.closure - 1.0].astype(np.float32)


def _heading(quaternion: np.ndarray) -> float:
    x, y, z, w = (float(v) for v in quaternion)
    return math.atan2(2 * (y * z - w * x), 2 * (x * z + w * y))


def record_demo(
    env: gym.Env, planner: str, seed: int, budget: float, kinematics: ArmKinematics
) -> Demo:
    """One episode of the teacher (module docstring)."""
    _, reset_info = env.reset(seed=seed)
    start = str(reset_info.get("start", "ready"))
    base = env.unwrapped
    assert isinstance(base, ClutterRetrieveEEEnv)
    tcp, quaternion = base.herb.tcp_pose()
    if start == "grasp failed":
        return Demo(seed, np.zeros((0, 5), np.float32), False, "the grasp at reset failed", start)
    if start == "grasped":
        points = lift_waypoints(tcp, _heading(quaternion))
    else:
        plan = _plan(base, planner, seed, budget, tcp)
        if not plan.success:
            return Demo(seed, np.zeros((0, 5), np.float32), False, f"no plan: {plan.reason}")
        # The exact surface: the planner's 1.5 cm padding, for the position-controlled arm's
        # lag, rules out the wrist passing 1 cm over the table's front edge, which the
        # end-effector controller's TCP-level motion does.
        free = make_checker(base.surface, {}, padding=0.0).checker(objects=False)
        points = plan_waypoints(plan.trajectory, kinematics, base.herb.arm_state()[0], free)
    actions: list[np.ndarray] = []
    info: dict[str, Any] = {}
    ended = False
    for action in track(env, points):
        actions.append(action)
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            ended = True
            break
    recorded = np.array(actions, dtype=np.float32).reshape(-1, 5)
    if info.get("is_success"):
        return Demo(seed, recorded, True, "", start)
    why = info.get("failure") or ("the time limit" if ended else "the plan ended")
    return Demo(seed, recorded, False, f"execution: {why}", start)


def _plan(
    base: ClutterRetrieveEEEnv, planner: str, seed: int, budget: float, tcp: np.ndarray
) -> Plan:
    """The planner's plan from the env's first state, on detections drawn with its noise."""
    scene = base.scene
    rng = np.random.default_rng(seed)
    sigma = base.noise_override or resolve_noise(scene.noise)  # what the env detects with
    truth = np.array([o.pose for o in scene.objects], dtype=float)
    detected = detect(truth, sigma, rng)
    believed = beliefs(
        [
            (o.name, get_object(o.kind), (float(d[0]), float(d[1]), float(d[2])))
            for o, d in zip(scene.objects, detected, strict=True)
        ],
        sigma,
        sample_count(sigma),
        rng,
    )
    settings = PlannerSettings(
        time_budget=budget,
        seed=seed,
        max_heading_deg=TURN_LIMIT_DEG,
        heading_origin=(float(tcp[0]), float(tcp[1])),
    )
    return plan_retrieval(
        get_surface(scene.surface),
        believed,
        scene.goal.object,
        base.herb.arm_state()[0],
        settings,
        scene.goal.region,
        planner,
    )


def replay(env: gym.Env, demo: Demo) -> tuple[bool, list[Transition]]:
    """Replay a demo's actions in ``env`` reset with its seed (and, in the lift env, its
    start): whether it succeeds, and the transitions (obs, action, reward, next_obs,
    terminated, truncated, info)."""
    lifting = isinstance(env.unwrapped, ClutterRetrieveLiftEnv)
    if demo.start != "ready" and not lifting:
        raise ValueError(f"demo {demo.seed}: starts {demo.start!r}, which only {LIFT_ENV_ID} has")
    options = {"grasped": demo.start != "ready"} if lifting else None
    obs, _ = env.reset(seed=demo.seed, options=options)
    transitions: list[Transition] = []
    info: dict[str, Any] = {}
    for action in demo.actions:
        next_obs, reward, terminated, truncated, info = env.step(action)
        transitions.append((obs, action, float(reward), next_obs, terminated, truncated, info))
        obs = next_obs
        if terminated or truncated:
            break
    return bool(info.get("is_success")), transitions


def record_demos(
    env_id: str,
    env_kwargs: dict[str, Any],
    planner: str,
    episodes: int,
    seed: int,
    budget: float,
    on_demo: Callable[[Demo], object] = lambda demo: None,
) -> list[Demo]:
    """Episodes ``seed``..``seed + episodes - 1`` of the teacher in one env."""
    env = gym.make(env_id, **env_kwargs)
    kinematics = ArmKinematics("right")
    demos = []
    try:
        for k in range(episodes):
            demo = record_demo(env, planner, seed + k, budget, kinematics)
            on_demo(demo)
            demos.append(demo)
    finally:
        env.close()
    return demos


def save_demos(out: Path, demos: list[Demo], meta: dict[str, Any]) -> None:
    """``out/demos.npz`` (the actions of all demos end to end, with each one's length, seed
    and success) and ``out/demos.json`` (how they were made, and the failures' reasons)."""
    out.mkdir(parents=True, exist_ok=True)
    actions = np.concatenate([d.actions for d in demos]) if demos else np.zeros((0, 5))
    np.savez_compressed(
        out / DEMOS_FILE,
        actions=actions.astype(np.float32),
        lengths=np.array([len(d.actions) for d in demos], dtype=np.int64),
        seeds=np.array([d.seed for d in demos], dtype=np.int64),
        success=np.array([d.success for d in demos], dtype=bool),
        starts=np.array([d.start for d in demos], dtype=str),
    )
    failures = {str(d.seed): d.reason for d in demos if not d.success}
    summary = {
        **meta,
        "episodes": len(demos),
        "successes": sum(d.success for d in demos),
        "starts": {start: sum(d.start == start for d in demos) for start in START_KINDS},
        "steps": int(sum(len(d.actions) for d in demos)),
        "failures": failures,
    }
    atomic_write_text(out / META_FILE, json.dumps(summary, indent=1) + "\n")


def load_demos(directory: Path) -> tuple[list[Demo], dict[str, Any]]:
    """The demos and the metadata `save_demos` wrote; ValueError naming what is missing."""
    data_path, meta_path = Path(directory) / DEMOS_FILE, Path(directory) / META_FILE
    for path in (data_path, meta_path):
        if not path.is_file():
            raise ValueError(f"demos: {directory}: no {path.name} (written by clutter-gym demos)")
    meta = json.loads(meta_path.read_text())
    failures = meta.get("failures", {})
    with np.load(data_path) as data:
        missing = [key for key in ("actions", "lengths", "seeds", "success") if key not in data]
        if missing:
            raise ValueError(
                f"demos: {data_path} has no {', '.join(missing)}; record the demos again "
                "with clutter-gym demos"
            )
        bounds = np.concatenate([[0], np.cumsum(data["lengths"])])
        # Recordings older than the lift stage keep no starts: all began at the ready pose.
        starts = data["starts"] if "starts" in data else np.full(len(data["seeds"]), "ready")
        demos = [
            Demo(
                int(seed),
                data["actions"][bounds[i] : bounds[i + 1]],
                bool(ok),
                failures.get(str(int(seed)), ""),
                str(start),
            )
            for i, (seed, ok, start) in enumerate(
                zip(data["seeds"], data["success"], starts, strict=True)
            )
        ]
    return demos, meta
