"""Tests of ArmKinematics: agreement with pybullet, Jacobian, IK and Cartesian paths."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from clutter_gym.model import herb as hm
from clutter_gym.model.kinematics import ArmKinematics, rotation_exp, rotation_log

FRAME_LINKS = ["wam_base", *(f"wam{i}" for i in range(1, 8)), "hand_base"]


@pytest.fixture(scope="module")
def right() -> ArmKinematics:
    return ArmKinematics("right")


@pytest.fixture(scope="module")
def bullet(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[BulletClient, int]]:
    client = BulletClient(connection_mode=pybullet.DIRECT)
    path: Path = hm.write_herb_urdf(tmp_path_factory.mktemp("urdf"))
    yield client, client.loadURDF(str(path), useFixedBase=True)
    client.disconnect()


def pybullet_frames(client: BulletClient, robot: int, side: str, q: np.ndarray) -> np.ndarray:
    """World poses of the FRAME_LINKS of one arm, plus its hand_tcp, after setting q."""
    index = {}
    for j in range(client.getNumJoints(robot)):
        info = client.getJointInfo(robot, j)
        index[info[1].decode()] = index[info[12].decode()] = j
    for name, value in zip(hm.arm_joint_names(side), q, strict=True):
        client.resetJointState(robot, index[name], float(value))
    frames = []
    for link in [*FRAME_LINKS, "hand_tcp"]:
        state = client.getLinkState(robot, index[f"{side}_{link}"], computeForwardKinematics=True)
        pose = np.eye(4)
        pose[:3, :3] = np.reshape(client.getMatrixFromQuaternion(state[5]), (3, 3))
        pose[:3, 3] = state[4]
        frames.append(pose)
    return np.array(frames)


def assert_pose_close(a: np.ndarray, b: np.ndarray, pos_tol: float, rot_tol: float) -> None:
    assert np.linalg.norm(a[:3, 3] - b[:3, 3]) < pos_tol
    assert np.linalg.norm(rotation_log(a[:3, :3] @ b[:3, :3].T)) < rot_tol


@pytest.mark.parametrize("side", hm.SIDES)
def test_link_frames_and_tcp_match_pybullet(bullet: tuple[BulletClient, int], side: str) -> None:
    client, robot = bullet
    kin = ArmKinematics(side)
    rng = np.random.default_rng(3)
    for q in rng.uniform(kin.lower, kin.upper, size=(100, 7)):
        pb = pybullet_frames(client, robot, side, q)
        ours = kin.link_frames(q)
        for k in range(len(FRAME_LINKS)):
            assert_pose_close(ours[k], pb[k], 1e-6, 1e-6)
        assert_pose_close(kin.fk_tcp(q), pb[-1], 1e-6, 1e-6)
        assert_pose_close(kin.fk(q), pb[-2], 1e-6, 1e-6)


def test_fk_batch_matches_fk(right: ArmKinematics) -> None:
    rng = np.random.default_rng(4)
    qs = rng.uniform(right.lower, right.upper, size=(200, 7))
    for batched, single in ((right.fk_batch, right.fk), (right.fk_tcp_batch, right.fk_tcp)):
        np.testing.assert_allclose(batched(qs), [single(q) for q in qs], atol=1e-12)


def test_custom_base_transform_moves_the_arm(right: ArmKinematics) -> None:
    shift = np.eye(4)
    shift[:3, 3] = (1.0, -2.0, 0.5)
    moved = ArmKinematics("right", base=shift @ right.base)
    q = hm.RIGHT_ARM_HOME
    np.testing.assert_allclose(moved.fk_tcp(q), shift @ right.fk_tcp(q), atol=1e-12)


def test_rotation_log_exp_roundtrip() -> None:
    rng = np.random.default_rng(5)
    for w in [*rng.normal(size=(50, 3)), np.array([np.pi - 1e-6, 0.0, 0.0]), np.zeros(3)]:
        w = w if np.linalg.norm(w) <= np.pi else w / np.linalg.norm(w) * (np.pi - 0.1)
        np.testing.assert_allclose(rotation_log(rotation_exp(w)), w, atol=1e-6)


def test_jacobian_matches_finite_differences(right: ArmKinematics) -> None:
    rng = np.random.default_rng(6)
    eps = 1e-6
    for q in rng.uniform(right.lower, right.upper, size=(50, 7)):
        numeric = np.empty((6, 7))
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = eps
            plus, minus = right.fk_tcp(q + dq), right.fk_tcp(q - dq)
            numeric[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * eps)
            numeric[3:, i] = rotation_log(plus[:3, :3] @ minus[:3, :3].T) / (2 * eps)
        np.testing.assert_allclose(right.jacobian(q), numeric, atol=1e-7)


def test_ik_solves_random_reachable_targets_within_limits(right: ArmKinematics) -> None:
    rng = np.random.default_rng(7)
    for q in rng.uniform(right.lower, right.upper, size=(200, 7)):
        target = right.fk_tcp(q)
        sol = right.solve_ik(target, None, rng)
        assert sol is not None
        assert np.all(sol >= right.lower) and np.all(sol <= right.upper)
        assert_pose_close(right.fk_tcp(sol), target, 1e-4, 1e-3)


def test_ik_from_nearby_seed_stays_near_it(right: ArmKinematics) -> None:
    rng = np.random.default_rng(8)
    for q in rng.uniform(right.lower + 0.2, right.upper - 0.2, size=(30, 7)):
        sol = right.solve_ik(right.fk_tcp(q), q + rng.normal(0.0, 0.05, 7), rng)
        assert sol is not None and np.max(np.abs(sol - q)) < 0.3
        local = right.solve_ik(right.fk_tcp(q), q + rng.normal(0.0, 0.05, 7), rng, max_restarts=0)
        assert local is not None and np.max(np.abs(local - q)) < 0.3


def test_ik_respects_accept(right: ArmKinematics) -> None:
    rng = np.random.default_rng(9)
    target = right.fk_tcp(hm.RIGHT_ARM_HOME)
    verdicts: list[bool] = []

    def j1_high(q: np.ndarray) -> bool:
        verdicts.append(bool(q[0] > hm.RIGHT_ARM_HOME[0] + 0.5))
        return verdicts[-1]

    sol = right.solve_ik(target, hm.RIGHT_ARM_HOME, rng, accept=j1_high)
    assert sol is not None and sol[0] > hm.RIGHT_ARM_HOME[0] + 0.5
    assert verdicts[0] is False  # the solution descending from the seed was rejected
    assert right.solve_ik(target, None, rng, accept=lambda q: False, max_restarts=3) is None


def test_ik_random_seeds_are_elbow_up(right: ArmKinematics) -> None:
    rng = np.random.default_rng(10)
    seeds = [right.random_configuration(rng) for _ in range(100)]
    assert np.mean([right.elbow_height(q) > 0 for q in seeds]) > 0.95


def test_ik_unreachable_target_returns_none(right: ArmKinematics) -> None:
    rng = np.random.default_rng(11)
    target = np.eye(4)
    target[:3, 3] = (3.0, -0.2, 1.0)
    assert right.solve_ik(target, hm.RIGHT_ARM_HOME, rng) is None


def test_left_arm_ik(bullet: tuple[BulletClient, int]) -> None:
    left = ArmKinematics("left")
    rng = np.random.default_rng(12)
    for q in rng.uniform(left.lower, left.upper, size=(10, 7)):
        target = left.fk_tcp(q)
        sol = left.solve_ik(target, None, rng)
        assert sol is not None
        assert_pose_close(pybullet_frames(*bullet, "left", sol)[-1], target, 1e-4, 1e-3)


def test_cartesian_path_is_straight_and_smooth(right: ArmKinematics) -> None:
    start = right.fk_tcp(hm.RIGHT_ARM_HOME)
    target = start.copy()
    target[:3, 3] += 0.25 * start[:3, 2]  # push 25 cm along the approach axis
    target[:3, :3] = rotation_exp(np.array([0.0, 0.0, 0.3])) @ start[:3, :3]
    path = right.cartesian_path(hm.RIGHT_ARM_HOME, target, 20)
    assert path is not None and path.shape == (20, 7)
    np.testing.assert_allclose(path[0], hm.RIGHT_ARM_HOME)
    assert np.max(np.abs(np.diff(path, axis=0))) <= 0.3
    assert np.all((path >= right.lower) & (path <= right.upper))
    assert_pose_close(right.fk_tcp(path[-1]), target, 1e-4, 1e-3)
    line = target[:3, 3] - start[:3, 3]
    for q in path:
        offset = right.fk_tcp(q)[:3, 3] - start[:3, 3]
        assert np.linalg.norm(np.cross(offset, line / np.linalg.norm(line))) < 1e-3


def test_cartesian_path_fails_on_rejection_or_unreachable(right: ArmKinematics) -> None:
    start = right.fk_tcp(hm.RIGHT_ARM_HOME)
    target = start.copy()
    target[2, 3] -= 0.1
    assert right.cartesian_path(hm.RIGHT_ARM_HOME, target, 10, accept=lambda q: False) is None
    target[:3, 3] = (2.0, -0.3, 1.0)
    assert right.cartesian_path(hm.RIGHT_ARM_HOME, target, 10) is None
