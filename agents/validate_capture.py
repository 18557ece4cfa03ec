"""`clutter-gym validate-capture`: capture regions against physics, the analogue of Fig. 11.

Each trial places one object at a grid pose in front of HERB's hand in the pybullet env, starts
the arm at the push start (hand preshaped to the region's aperture), and executes the whole
push-grasp with the simulated arm and hand: a straight push of `push_distance`, closing the
fingers, a 15 cm lift. A trial succeeds when the env reports success (held by finger contact and
lifted 10 cm). The capture region predicts success when the pose lies in the region of that push
distance. The report counts predicted-inside failures (must be 0: the region is conservative)
and the tightness: the share of physical successes the region predicts.

The same grid runs with the whole scene turned by `rotations` degrees about the vertical:
pybullet's friction is anisotropic (two decoupled friction directions along its axes), which a
push at 45 degrees exposes.

Results stream to `<json>.trials.jsonl` as they finish (`agents.jobs`), keyed by everything that
decides a trial's physics (object, aperture, push, grid, start configurations) and the code; a
rerun with the same set-up skips the trials already there (nothing is lost when interrupted).
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.jobs import JobSpec, config_digest, run_jobs
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.media import write_json
from clutter_gym.model import herb as hm
from clutter_gym.model.herb import HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.objects import OBJECTS, ObjectSpec, get_object
from clutter_gym.model.scene import SCENE_FORMAT
from clutter_gym.model.trajectory import DEFAULT_WAYPOINTS, Segment, Trajectory
from clutter_gym.model.world import TABLE
from planners.actions.grasp_geometry import GRASP_CLOSURE, LIFT, grasp_height, tcp_pose
from planners.capture import push_grasp_region
from planners.hand2d import default_aperture, push_grasp_profile

ALIASES = {"can": "soda_can", "bottle": "juice_bottle", "poptart": "poptart_box"}
PUSH_DISTANCE = 0.25  # m
WAYPOINTS = DEFAULT_WAYPOINTS
PUSH_WAYPOINTS = 10
LIFT_WAYPOINTS = 4
GRID_Y = 0.20  # m either side of the hand axis
GRID_X = (0.05, 0.45)  # m ahead of hand_base
BOX_ANGLES = 6  # object orientations over [0, pi) for boxes (Fig. 9(d))


@dataclass(frozen=True)
class Trial:
    index: int
    rotation_deg: float
    pose: tuple[float, float, float]  # object in the push-grasp frame (x ahead, y left, theta)
    predicted: bool
    outcome: str  # "success", "failure: <reason>", or "skipped: <reason>"

    @property
    def success(self) -> bool:
        return self.outcome == "success"


def resolve_kind(name: str) -> str:
    kind = ALIASES.get(name, name)
    if kind not in OBJECTS:
        allowed = sorted({*ALIASES, *OBJECTS})
        raise ValueError(f"--object: unknown object {name!r}; allowed: {', '.join(allowed)}")
    spec = OBJECTS[kind]
    if not (spec.graspable and spec.liftable):
        raise ValueError(f"--object: {kind} cannot be push-grasped and lifted")
    return kind


def grid(spec: ObjectSpec, trials: int) -> np.ndarray:
    """At least `trials` poses (N, 3) in the push-grasp frame, on a regular grid."""
    if trials < 1:
        raise ValueError(f"--trials: {trials}; must be >= 1")
    angles = (
        np.linspace(0.0, np.pi, BOX_ANGLES, endpoint=False)
        if spec.footprint.shape == "box"
        else np.zeros(1)
    )
    per_angle = math.ceil(trials / len(angles))
    ny = max(2, round(math.sqrt(per_angle * 2 * GRID_Y / (GRID_X[1] - GRID_X[0]))))
    nx = max(2, math.ceil(per_angle / ny))
    xs, ys = np.linspace(*GRID_X, nx), np.linspace(-GRID_Y, GRID_Y, ny)
    mesh = np.stack(np.meshgrid(xs, ys, angles, indexing="ij"), axis=-1)
    return mesh.reshape(-1, 3)


@dataclass(frozen=True)
class PushSetup:
    """Where the hand starts and the whole push-grasp trajectory, for one scene rotation."""

    rotation_deg: float
    hand_base: tuple[float, float, float]  # world position at the push start
    heading: float  # world yaw of the push direction
    start_arm: tuple[float, ...]
    action: np.ndarray  # (WAYPOINTS, 9)


def plan_push(spec: ObjectSpec, aperture: float, rotation_deg: float) -> PushSetup:
    """A reachable straight push along heading `rotation_deg` (0 = the robot's forward)."""
    kinematics = ArmKinematics("right")
    rng = np.random.default_rng(0)
    heading = math.radians(rotation_deg)
    direction = np.array([math.cos(heading), math.sin(heading), 0.0])
    preshaped = HandCommand(0.0, push_grasp_profile(aperture).closure)
    closed = HandCommand(0.0, GRASP_CLOSURE)
    z = TABLE.top_z + grasp_height(spec.height)
    tcp_offset = hm.HAND_TCP_OFFSET * direction

    def pose(tcp: np.ndarray) -> np.ndarray:
        return tcp_pose(tcp, direction)

    # Start points tried nearest the robot's usual reach first.
    for x in np.arange(0.66, 0.86, 0.02):
        for y in (-0.25, -0.30, -0.20, -0.35, -0.15, -0.40):
            hand_base = np.array([x, y, z])
            start_tcp = hand_base + tcp_offset
            q0 = kinematics.solve_ik(pose(start_tcp), hm.RIGHT_ARM_HOME, rng, n_solutions=1)
            if q0 is None:
                continue
            end_tcp = start_tcp + PUSH_DISTANCE * direction
            push = kinematics.cartesian_path(q0, pose(end_tcp), PUSH_WAYPOINTS)
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
            return PushSetup(
                rotation_deg,
                (float(hand_base[0]), float(hand_base[1]), float(hand_base[2])),
                heading,
                tuple(float(v) for v in q0),
                action,
            )
    raise RuntimeError(f"no reachable straight push at heading {rotation_deg} deg")


def world_pose(setup: PushSetup, pose: Sequence[float]) -> tuple[float, float, float]:
    """An object pose in the push-grasp frame, in the world."""
    x, y, theta = pose
    c, s = math.cos(setup.heading), math.sin(setup.heading)
    bx, by, _ = setup.hand_base
    return (bx + c * x - s * y, by + s * x + c * y, setup.heading + theta)


def run_trial(env: ClutterRetrieveEnv, kind: str, setup: PushSetup, pose: Sequence[float]) -> str:
    wx, wy, wtheta = world_pose(setup, pose)
    scene = {
        "format": SCENE_FORMAT,
        "surface": "table",
        "objects": [{"name": "object", "kind": kind, "pose": [wx, wy, wtheta]}],
        "goal": {"object": "object"},
        "noise": "sigma1",
    }
    closure = float(setup.action[0, 8])
    try:
        _, info = env.reset(
            seed=0, options={"scene": scene, "arm": setup.start_arm, "hand": (0.0, closure)}
        )
    except ValueError as error:  # off the table: not a physical trial
        return f"skipped: {error}"
    if info["failure"] or env.sim.contacts("herb", "object"):
        return "skipped: the object overlaps the hand at the start"
    _, _, _, _, info = env.step(setup.action)
    return "success" if info["is_success"] else f"failure: {info['failure'] or 'not held'}"


ValidationJob = tuple[int, str, PushSetup, tuple[float, float, float]]
"""One trial: its index, the object kind, the push set-up of its rotation and the pose."""


@functools.cache
def _process_env() -> ClutterRetrieveEnv:
    """One env per process, reset for every trial: a worker pays for its pybullet world once."""
    return ClutterRetrieveEnv()


def _run_validation(job: ValidationJob) -> dict[str, Any]:
    _, kind, setup, pose = job
    return {"outcome": run_trial(_process_env(), kind, setup, pose)}


def _validation_key(job: ValidationJob) -> str:
    return str(job[0])


def _validation_crashed(job: ValidationJob, error: str) -> dict[str, Any]:
    return {"outcome": f"crashed: {error}"}


VALIDATION = JobSpec(work=_run_validation, key=_validation_key, crashed=_validation_crashed)


def summarize(trials: Sequence[Trial]) -> dict[str, Any]:
    crashed = [t for t in trials if t.outcome.startswith("crashed")]
    ran = [t for t in trials if not t.outcome.startswith(("skipped", "crashed"))]
    successes = [t for t in ran if t.success]
    predicted = [t for t in ran if t.predicted]
    failed_inside = [t for t in predicted if not t.success]
    predicted_successes = [t for t in successes if t.predicted]
    return {
        "trials": len(ran),
        "skipped": len(trials) - len(ran) - len(crashed),
        "crashed": len(crashed),
        "physical_successes": len(successes),
        "predicted_inside": len(predicted),
        "failures_inside": len(failed_inside),
        "tightness": len(predicted_successes) / len(successes) if successes else None,
        "failures_inside_examples": [asdict(t) for t in failed_inside[:10]],
    }


def validate(
    name: str,
    trials: int,
    out: Path,
    rotations: Sequence[float] = (0.0, 45.0),
    workers: int = 2,
) -> dict[str, Any]:
    kind = resolve_kind(name)
    spec = get_object(kind)
    aperture = default_aperture(spec.footprint)
    region = push_grasp_region(spec.footprint, aperture)
    poses = grid(spec, trials)
    predicted = region.contains(poses, PUSH_DISTANCE)
    setups = {r: plan_push(spec, aperture, r) for r in rotations}
    jobs = [
        (i * len(poses) + j, kind, setups[r], (float(p[0]), float(p[1]), float(p[2])))
        for i, r in enumerate(rotations)
        for j, p in enumerate(poses)
    ]
    config = config_digest(
        hashlib.sha256(
            repr(
                (
                    kind,
                    aperture,
                    PUSH_DISTANCE,
                    poses.tobytes(),
                    [(s.hand_base, s.start_arm, s.action.tobytes()) for s in setups.values()],
                )
            ).encode()
        ).hexdigest()
    )
    log = out.with_name(f"{out.name}.trials.jsonl")
    run = run_jobs(jobs, VALIDATION, log, config, workers=workers, desc=f"validate {kind}")
    results = [
        Trial(index, setup.rotation_deg, pose, bool(predicted[index % len(poses)]), r["outcome"])
        for (index, _, setup, pose), r in zip(jobs, run.records, strict=True)
    ]
    report: dict[str, Any] = {
        "object": kind,
        "aperture_m": aperture,
        "push_distance_m": PUSH_DISTANCE,
        "grid_points": len(poses),
    }
    for rotation in rotations:
        report[f"rotation_{rotation:g}deg"] = summarize(
            [t for t in results if t.rotation_deg == rotation]
        )
    report["trials"] = [asdict(t) for t in results]
    write_json(out, report)
    return report
