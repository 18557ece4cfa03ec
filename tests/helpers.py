"""Helpers shared by the tests: scene dicts, HERB in a bare pybullet client, seeded rollouts, the
command line in-process and the tiny training entries. Tests share code only through here."""

from __future__ import annotations

import hashlib
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from agents.cli import main
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.model import herb as hm

NEAR = (0.70, -0.25, 0.0)
"""In easy reach of the right arm (18 of 24 headings reach it, docs/reachability_table.png)."""
OUT_OF_REACH = (1.15, 0.68, 0.0)
"""The table's far left corner: no heading reaches it."""


def two_objects() -> dict[str, Any]:
    """A valid table scene: the goal can and a large box beside it."""
    return {
        "format": "clutter-gym-scene/1",
        "surface": "table",
        "objects": [
            {"name": "can", "kind": "soda_can", "pose": [0.72, -0.2, 0.0]},
            {"name": "box", "kind": "large_box", "pose": [0.76, -0.45, 0.0]},
        ],
        "goal": {"object": "can"},
        "noise": "sigma2",
    }


def lone_can(noise: str, pose: tuple[float, float, float] = NEAR) -> dict[str, Any]:
    """A scene with the goal can ``red_can`` alone at ``pose``, detected with ``noise``."""
    return {
        "format": "clutter-gym-scene/1",
        "surface": "table",
        "objects": [{"name": "red_can", "kind": "soda_can", "pose": list(pose)}],
        "goal": {"object": "red_can"},
        "noise": noise,
    }


def transform(position: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    """4x4 pose from a pybullet position and (x, y, z, w) quaternion."""
    t = np.eye(4)
    t[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(quaternion), (3, 3))
    t[:3, 3] = position
    return t


@dataclass
class HerbBullet:
    client: BulletClient
    robot: int
    joints: dict[str, int]
    links: dict[str, int]

    def set_joints(self, names: Sequence[str], values: Sequence[float]) -> None:
        for name, value in zip(names, values, strict=True):
            self.client.resetJointState(self.robot, self.joints[name], float(value))

    def set_arm(self, side: str, q: np.ndarray) -> None:
        self.set_joints(hm.arm_joint_names(side), q)

    def link_pose(self, name: str) -> np.ndarray:
        state = self.client.getLinkState(
            self.robot, self.links[name], computeForwardKinematics=True
        )
        return transform(state[4], state[5])


def load_herb(urdf: Path, flags: int = 0) -> HerbBullet:
    client = BulletClient(connection_mode=pybullet.DIRECT)
    robot = client.loadURDF(str(urdf), useFixedBase=True, flags=flags)
    joints, links = {}, {"herb_base": -1}
    for j in range(client.getNumJoints(robot)):
        info = client.getJointInfo(robot, j)
        joints[info[1].decode()] = j
        links[info[12].decode()] = j
    return HerbBullet(client, robot, joints, links)


def run_cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """`clutter-gym` in this process: its exit status, stdout and stderr."""
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


TRAIN_ENV = "ClutterRetrieveEEDense-v0"
"""The variant the learning tests train on."""
TRAIN_SCENES: dict[str, Any] = {"level": "none", "goal_kind": "soda_can", "max_episode_steps": 20}
TINY_PPO: dict[str, Any] = {
    "policy": "MultiInputPolicy",
    "n_steps": 64,
    "batch_size": 32,
    "n_epochs": 2,
    "normalize": True,
    "policy_kwargs": {"net_arch": [16, 16]},
    "env_kwargs": TRAIN_SCENES,
}
"""A PPO entry that trains in seconds."""
TINY_SAC: dict[str, Any] = {
    "policy": "MultiInputPolicy",
    "buffer_size": 5000,
    "learning_starts": 64,
    "batch_size": 32,
    "replay_buffer_class": "HerReplayBuffer",
    "replay_buffer_kwargs": {"goal_selection_strategy": "future", "copy_info_dict": True},
    "policy_kwargs": {"net_arch": [16, 16]},
    "env_kwargs": TRAIN_SCENES,
}
"""A SAC entry with hindsight replay that trains in seconds."""


def write_config(path: Path, entry: dict[str, Any] | None = None, env: str = TRAIN_ENV) -> Path:
    import yaml  # the rl extra

    path.write_text(yaml.safe_dump({env: TINY_PPO if entry is None else entry}))
    return path


def train_argv(config: Path, out: Path, /, **flags: str | None) -> list[str]:
    """`train` of the tiny entry; ``flags`` (``n_envs="2"``) override or, with None, remove."""
    base: dict[str, str | None] = {
        "algo": "ppo",
        "env": TRAIN_ENV,
        "config": str(config),
        "out": str(out),
        "steps": "256",
        "eval_freq": "128",
        "eval_episodes": "2",
    }
    argv = ["train"]
    for flag, value in {**base, **flags}.items():
        if value is not None:
            argv += [f"--{flag.replace('_', '-')}", value]
    return argv


def registered_env(env: gym.Env) -> gym.Env:
    """What a registered id makes, below the wrappers `gym.make` adds (TimeLimit, order and
    checker): the env itself, or the primitive variant, a wrapper of the trajectory env."""
    while isinstance(env, gym.Wrapper) and type(env).__module__.startswith("gymnasium."):
        env = env.env
    return env


def hold_action(env: ClutterRetrieveEnv, obs: dict[str, np.ndarray]) -> np.ndarray:
    """A trajectory that keeps the arm where it is: cheap and never touches anything."""
    row = np.r_[obs["arm_joints"], 0.0, 0.0]
    return np.tile(row, (env.action_space.shape[0], 1)).astype(np.float32)


OPEN_AND_HOLD = np.array([0.0, 0.0, 0.0, 0.0, -1.0], dtype=np.float32)
"""An end-effector action that holds the arm where it is and keeps the hand open."""


def still_action(env: gym.Env, obs: dict[str, np.ndarray]) -> np.ndarray:
    """The action of any variant that keeps the arm where it is and the hand open."""
    if isinstance(env.unwrapped, ClutterRetrieveEnv):
        return hold_action(env.unwrapped, obs)
    return OPEN_AND_HOLD


TRAJECTORY_ID = "ClutterRetrieve-v0"
EE_IDS = (
    "ClutterRetrieveEE-v0",
    "ClutterRetrieveEEDense-v0",
    "ClutterRetrieveEEGrasp-v0",
    "ClutterRetrieveEELift-v0",
)


def rollout_digest(seed: int, env_id: str, steps: int) -> str:
    """Hash of every observation, reward and info of a seeded rollout with seeded actions."""
    env = gym.make(env_id, level="high")
    obs, info = env.reset(seed=seed)
    env.action_space.seed(seed)
    digest = hashlib.sha256()

    def feed(o: dict[str, np.ndarray], i: dict[str, object], r: float = 0.0) -> None:
        for key in sorted(o):
            digest.update(np.ascontiguousarray(o[key]).tobytes())
        digest.update(np.asarray(i["true_object_poses"]).tobytes())
        digest.update(np.float64(r).tobytes())

    feed(obs, info)
    for _ in range(steps):
        if env_id == TRAJECTORY_ID:
            action = hold_action(env.unwrapped, obs)  # type: ignore[arg-type]
            action[:, 7:] = env.action_space.sample()[:, 7:]
        else:
            action = env.action_space.sample()
        obs, reward, terminated, truncated, info = env.step(action)
        feed(obs, info, reward)
        if terminated or truncated:
            obs, info = env.reset()
    env.close()
    return digest.hexdigest()


GATE_TIMEOUT_S = 60.0


@dataclass(frozen=True)
class Square:
    """A job of the runner's tests: squaring ``n``."""

    n: int

    @property
    def key(self) -> str:
        return f"job{self.n}"

    def identity(self) -> dict[str, Any]:
        return {"n": self.n}

    def crashed(self, error: str) -> dict[str, Any]:
        return {"error": error}


def square(job: Square) -> dict[str, Any]:
    return {"value": job.n * job.n}


def gated_square(job: Square) -> dict[str, Any]:
    """A job that says it started (the file ``started-<n>`` in the working directory) and waits
    for the file ``release`` there: a test knows which jobs run, and decides when they end."""
    Path(f"started-{job.n}").touch()
    deadline = time.monotonic() + GATE_TIMEOUT_S
    while not Path("release").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    return {"value": job.n * job.n, "pid": os.getpid()}


WHITE = (255, 255, 255)
TAB_BLUE = (31, 119, 180)
"""matplotlib's first line colour."""
TAB_GREEN = (44, 160, 44)
TABLE_BROWN = (136, 88, 56)
"""The table top in a rendered frame (lit, so within the tolerance of this)."""


def assert_picture(
    path: Path,
    size: tuple[int, int] | None = None,
    min_width: int = 0,
    colours: Sequence[tuple[int, int, int]] = (),
    tolerance: int = 30,
) -> None:
    """A PNG or GIF with a picture in it: ``size`` (or at least ``min_width``), not blank (many
    colours, spread out), and each of ``colours`` somewhere (within ``tolerance`` per channel)."""
    from PIL import Image

    with Image.open(path) as image:
        assert image.format in ("PNG", "GIF"), image.format
        assert size is None or image.size == size, image.size
        assert image.width >= min_width, image.size
        pixels = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)
    assert len(np.unique(pixels, axis=0)) > 16 and pixels.std() > 10, f"{path} is blank"
    for colour in colours:
        near = np.abs(pixels - np.asarray(colour)).max(axis=1) <= tolerance
        assert near.any(), f"{path}: no pixel near {colour}"
