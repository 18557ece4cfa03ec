"""Tests of ArmKinematics: agreement with pybullet, Jacobian, IK and Cartesian paths."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet
import pytest
from pybullet_utils.bullet_client import BulletClient

from clutter_gym.model import herb as hm
from clutter_gym.model.collision import make_checker
from clutter_gym.model.kinematics import (
    CHECK_SPACING,
    MAX_CHECKS,
    ArmKinematics,
    rotation_exp,
    rotation_log,
)
from clutter_gym.model.reachability import HEIGHTS, PROBE_HAND, hand_pose
from clutter_gym.model.world import TABLE

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


def test_elbow_points_are_the_wam4_link_frames(right: ArmKinematics) -> None:
    qs = np.random.default_rng(3).uniform(right.lower, right.upper, (20, 7))
    expected = np.array([right.link_frames(q)[4, :3, 3] for q in qs])
    np.testing.assert_allclose(right.elbow_points(qs), expected, atol=1e-12)


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


def pose_errors(kin: ArmKinematics, qs: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(N, 2): position error [m] and rotation angle error [rad] of each row's TCP (the angle
    from the Frobenius distance, 2 sqrt(2) sin(angle / 2), exact to rounding when small)."""
    poses = kin.fk_tcp_batch(qs)
    position = np.linalg.norm(poses[:, :3, 3] - target[:3, 3], axis=1)
    chord = np.linalg.norm(poses[:, :3, :3] - target[:3, :3], axis=(1, 2)) / (2.0 * np.sqrt(2.0))
    return np.column_stack([position, 2.0 * np.arcsin(np.minimum(chord, 1.0))])


@pytest.mark.parametrize(("side", "samples"), [("right", 1000), ("left", 250)])
def test_ik_solutions_recover_random_poses(side: str, samples: int) -> None:
    """FK round trip: the pose of a random in-limit q is reached exactly by some solution,
    every solution is in the limits and reaches it, q itself is the nearest solution to the
    seed q (its j3 is swept), and the j3 grid alone comes near q (a weaker check: near the
    wrist and shoulder singularities the other joints move fast with j3)."""
    kin = ArmKinematics(side)
    rng = np.random.default_rng(7)
    pose_hits = q_hits = near_hits = 0
    far: list[str] = []
    for q in rng.uniform(kin.lower, kin.upper, size=(samples, 7)):
        target = kin.fk_tcp(q)
        sols = kin.ik_solutions(target, seed=q)
        assert np.all((sols >= kin.lower) & (sols <= kin.upper))
        errors = pose_errors(kin, sols, target)
        assert np.all(errors < 1e-6)
        pose_hits += bool(np.any(np.all(errors < 1e-9, axis=1)))
        q_hits += len(sols) > 0 and np.max(np.abs(sols[0] - q)) < 1e-6
        grid = sols[sols[:, 2] != q[2]]
        distance = float(np.min(np.max(np.abs(grid - q), axis=1))) if len(grid) else np.inf
        near_hits += distance < 0.2
        if distance >= 0.2:
            far.append(f"j2 {q[1]:+.2f} j6 {q[5]:+.3f}: {distance:.2f} rad")
    print(
        f"{side}: pose {pose_hits}/{samples}, q {q_hits}/{samples}, grid within 0.2 rad "
        f"{near_hits}/{samples}; far: {far}"
    )
    assert pose_hits >= 0.99 * samples and q_hits >= 0.99 * samples
    assert near_hits >= 0.98 * samples


def test_ik_solutions_at_singularities() -> None:
    """The wrist (j6 = 0: only j5 + j7 is determined), the shoulder (j2 = 0) and the stretched
    elbow (a double root of j4) are solved like any other pose."""
    kin = ArmKinematics("right")
    a3, a4, d3, d5 = 0.045, -0.045, 0.55, 0.3
    stretched = np.arctan2(a3 * d5 - d3 * a4, a3 * a4 + d3 * d5)  # largest shoulder-wrist span
    rng = np.random.default_rng(13)
    for joint, value in ((5, 0.0), (1, 0.0), (3, stretched)):
        for q in rng.uniform(kin.lower, kin.upper, size=(50, 7)):
            q[joint] = value
            target = kin.fk_tcp(q)
            sols = kin.ik_solutions(target, seed=q)
            assert len(sols) and np.all(pose_errors(kin, sols, target) < 1e-6)
            if joint != 3:  # a double root keeps only ~8 digits
                np.testing.assert_allclose(sols[0], q, atol=1e-9)


def test_ik_solutions_reach_the_pose_in_pybullet(bullet: tuple[BulletClient, int]) -> None:
    kin = ArmKinematics("right")
    rng = np.random.default_rng(14)
    for q in rng.uniform(kin.lower, kin.upper, size=(10, 7)):
        target = kin.fk_tcp(q)
        sols = kin.ik_solutions(target)
        for sol in sols[:: max(1, len(sols) // 4)]:
            assert_pose_close(pybullet_frames(*bullet, "right", sol)[-1], target, 1e-6, 1e-6)


def test_solve_ik_returns_the_solution_nearest_the_seed(right: ArmKinematics) -> None:
    rng = np.random.default_rng(8)
    for q in rng.uniform(right.lower, right.upper, size=(30, 7)):
        target = right.fk_tcp(q)
        np.testing.assert_allclose(right.solve_ik(target, q), q, atol=1e-9)
        sols = right.ik_solutions(target)
        np.testing.assert_array_equal(right.solve_ik(target), sols[0])
        distances = np.linalg.norm(sols - right.home, axis=1)
        assert np.all(np.diff(distances) >= 0)


def test_ik_solutions_within_a_j3_window_are_the_full_sweeps_rows_there(
    right: ArmKinematics,
) -> None:
    """``j3_within`` solves only near the seed's j3 (the swung waypoint's search): exactly the
    rows of the whole sweep whose j3 lies in the window, in the same order."""
    rng = np.random.default_rng(11)
    compared = 0
    for q in rng.uniform(right.lower, right.upper, size=(200, 7)):
        target = right.fk_tcp(q)
        seed = np.clip(q + rng.normal(0.0, 0.2, 7), right.lower, right.upper)
        full = right.ik_solutions(target, seed)
        window = right.ik_solutions(target, seed, j3_within=0.3)
        np.testing.assert_array_equal(window, full[np.abs(full[:, 2] - seed[2]) <= 0.3])
        compared += len(window) > 0 and len(window) < len(full)
    assert compared > 100


def test_ik_respects_accept(right: ArmKinematics) -> None:
    target = right.fk_tcp(hm.RIGHT_ARM_HOME)
    verdicts: list[bool] = []

    def j1_high(q: np.ndarray) -> bool:
        verdicts.append(bool(q[0] > hm.RIGHT_ARM_HOME[0] + 0.5))
        return verdicts[-1]

    sol = right.solve_ik(target, hm.RIGHT_ARM_HOME, accept=j1_high)
    assert sol is not None and sol[0] > hm.RIGHT_ARM_HOME[0] + 0.5
    assert verdicts[0] is False and len(verdicts) <= MAX_CHECKS  # the seed itself was refused
    assert_pose_close(right.fk_tcp(sol), target, 1e-9, 1e-9)
    calls: list[np.ndarray] = []

    def never(q: np.ndarray) -> bool:
        calls.append(q)
        return False

    assert right.solve_ik(target, accept=never) is None
    # Thinned: no two checks closer than the spacing, and every solution near a refused one
    # (here 32 checks cover the pose's ~900 solutions: the branches over the whole j3 range).
    checked, sols = np.array(calls), right.ik_solutions(target)
    assert len(checked) <= MAX_CHECKS < len(sols)
    gaps = np.max(np.abs(checked[:, None] - checked[None]), axis=2) + np.eye(len(checked))
    assert np.min(gaps) >= CHECK_SPACING
    nearest = np.min(np.max(np.abs(sols[:, None] - checked[None]), axis=2), axis=1)
    assert np.all(nearest < CHECK_SPACING)
    assert np.ptp(checked[:, 2]) > 4.0


def test_ik_unreachable_target_has_no_solution(right: ArmKinematics) -> None:
    target = np.eye(4)
    target[:3, 3] = (3.0, -0.2, 1.0)
    assert right.ik_solutions(target).shape == (0, 7)
    assert right.solve_ik(target, hm.RIGHT_ARM_HOME) is None


def test_a_level_hand_close_in_front_of_the_shoulder_is_a_real_hole() -> None:
    """A level hand pointing straight ahead, its hand_base in front of the right shoulder at
    table grasp height, needs |j6| > 1.56 (beyond the limit) closer than ~0.6 m: no in-limit
    solution there (not an IK failure; with j6 unlimited there are), while at 0.75 m the arm
    reaches it clear of the table."""
    kin, unlimited = ArmKinematics("right"), ArmKinematics("right")
    unlimited.lower[5], unlimited.upper[5] = -np.pi, np.pi
    free = make_checker(TABLE, {}).checker(PROBE_HAND, objects=False)
    for height in HEIGHTS:
        for x in (0.45, 0.50, 0.55):
            target = hand_pose(np.array([x, kin.shoulder[1]]), 0.0, TABLE.top_z + height)
            assert len(kin.ik_solutions(target)) == 0
            beyond = unlimited.ik_solutions(target)
            assert len(beyond) and np.min(np.abs(beyond[:, 5])) > hm.ARM_JOINT_UPPER[5]
        target = hand_pose(np.array([0.75, kin.shoulder[1]]), 0.0, TABLE.top_z + height)
        assert kin.solve_ik(target, accept=free) is not None


def test_left_arm_ik(bullet: tuple[BulletClient, int]) -> None:
    left = ArmKinematics("left")
    rng = np.random.default_rng(12)
    for q in rng.uniform(left.lower, left.upper, size=(10, 7)):
        target = left.fk_tcp(q)
        sol = left.solve_ik(target)
        assert sol is not None
        assert_pose_close(pybullet_frames(*bullet, "left", sol)[-1], target, 1e-6, 1e-6)
    # The left arm's default seed is its own (mirrored) home pose.
    np.testing.assert_allclose(left.solve_ik(left.fk_tcp(left.home)), left.home, atol=1e-9)


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


def test_cartesian_path_continues_from_analytic_solutions(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where a waypoint's descent fails, the analytic solution nearest the previous waypoint
    stands in (its j3 is swept, so the line stays on the previous waypoint's branch)."""
    kin = ArmKinematics("right")
    monkeypatch.setattr(kin, "_descend", lambda *args, **kwargs: None)
    start = kin.fk_tcp(hm.RIGHT_ARM_HOME)
    target = start.copy()
    target[:3, 3] += 0.2 * start[:3, 2]
    path = kin.cartesian_path(hm.RIGHT_ARM_HOME, target, 12)
    assert path is not None and np.max(np.abs(np.diff(path, axis=0))) <= 0.3
    np.testing.assert_allclose(path[:, 2], hm.RIGHT_ARM_HOME[2])
    for s, q in zip(np.linspace(0.0, 1.0, 12), path, strict=True):
        waypoint = start.copy()
        waypoint[:3, 3] += s * 0.2 * start[:3, 2]
        assert_pose_close(kin.fk_tcp(q), waypoint, 1e-6, 1e-6)


def test_a_cartesian_path_may_swing_the_elbow_where_its_waypoint_is_refused() -> None:
    """A 2 cm lift under a 'ceiling' just above the elbow: the continuous solution raises the
    elbow into it, so the plain line fails; with ``connect`` the refused waypoint is another
    solution of its pose within the jump limit, and only where ``connect`` takes the motion."""
    kin = ArmKinematics("right")
    start = hand_pose(np.array([0.70, -0.20]), np.radians(30.0), 0.81)
    q0 = kin.solve_ik(start)
    assert q0 is not None
    ceiling = kin.elbow_points(q0[None])[0, 2] + 1e-4
    target = start.copy()
    target[2, 3] += 0.02

    def under(q: np.ndarray) -> bool:
        return bool(kin.elbow_points(q[None])[0, 2] <= ceiling)

    assert kin.cartesian_path(q0, target, 3) is not None  # the lift itself is reachable
    assert kin.cartesian_path(q0, target, 3, accept=under) is None
    assert kin.cartesian_path(q0, target, 3, accept=under, connect=lambda a, b: False) is None
    path = kin.cartesian_path(q0, target, 3, accept=under, connect=lambda a, b: True)
    assert path is not None and all(under(q) for q in path)
    assert np.max(np.abs(np.diff(path, axis=0))) <= 0.3
    for s, q in zip(np.linspace(0.0, 1.0, 3), path, strict=True):
        waypoint = start.copy()
        waypoint[2, 3] += s * 0.02
        assert_pose_close(kin.fk_tcp(q), waypoint, 1e-4, 1e-3)


def test_bench_ik_writes_json(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    from agents.cli import main
    from agents.experiments.speed.ik_speed import ANALYTIC, PREVIOUS

    out = tmp_path / "ik.json"
    assert main(["bench", "ik", "--samples", "4", "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    (line,) = capfd.readouterr().out.splitlines()
    assert json.loads(line) == result and result["targets"] == 4
    for name in (ANALYTIC, PREVIOUS):
        assert result[name]["calls_per_s"] > 0 and 0 <= result[name]["success_rate"] <= 1
    assert result["found_only_by_analytic"] >= 0 and result["found_only_by_lm_restarts"] >= 0
    assert set(result["solutions_ms"]) == {"full_sweep", "j3_window"}
    assert all(ms > 0 for ms in result["solutions_ms"].values())
