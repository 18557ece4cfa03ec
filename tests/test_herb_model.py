"""Tests of the HERB URDF: structure, limits, inertias, FK against the DH table, hand geometry."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pybullet
import pytest

from clutter_gym.model import herb as hm
from clutter_gym.model.kinematics import ArmKinematics
from tests.helpers import HerbBullet, load_herb

TABLE_TOP = 0.735


def load_sim(directory: Path, flags: int = 0) -> HerbBullet:
    return load_herb(hm.write_herb_urdf(directory), flags)


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[HerbBullet]:
    s = load_sim(tmp_path_factory.mktemp("urdf"))
    yield s
    s.client.disconnect()


def rot_error(a: np.ndarray, b: np.ndarray) -> float:
    """Angle of the rotation between two 3x3 rotation matrices."""
    return float(np.arccos(np.clip((np.trace(a.T @ b) - 1.0) / 2.0, -1.0, 1.0)))


def urdf_origin(xyz: tuple[float, ...], rpy: tuple[float, ...]) -> np.ndarray:
    """Independent URDF origin -> matrix: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return trans(*xyz) @ rot("z", rpy[2]) @ rot("y", rpy[1]) @ rot("x", rpy[0])


def trans(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    t = np.eye(4)
    t[i, i], t[i, j], t[j, i], t[j, j] = c, -s, s, c
    return t


def dh_hand_pose(side: str, q: np.ndarray) -> np.ndarray:
    """hand_base pose from the Spong DH product, written independently of the package code."""
    t = urdf_origin(*hm.ARM_MOUNT[side]) @ trans(*hm.WAM_BASE_TO_J1)
    for (a, alpha, d), theta in zip(hm.WAM_DH, q, strict=True):
        t = t @ rot("z", theta) @ trans(0, 0, d) @ trans(a, 0, 0) @ rot("x", alpha)
    return t @ trans(0, 0, hm.FT_SENSOR_LENGTH) @ rot("z", hm.HAND_MOUNT_YAW)


def test_write_is_content_addressed_atomic_and_reused(tmp_path: Path) -> None:
    first = hm.write_herb_urdf(tmp_path)
    mtime = first.stat().st_mtime_ns
    second = hm.write_herb_urdf(tmp_path)
    assert first == second
    assert second.stat().st_mtime_ns == mtime
    assert first.read_text() == hm.herb_urdf()
    assert sorted(p.name for p in tmp_path.iterdir()) == [first.name]


def test_default_cache_dir_honours_xdg(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert hm.write_herb_urdf().parent == tmp_path / "clutter_gym"


def attr(element: ET.Element, path: str, key: str) -> float:
    """Float attribute ``key`` of the sub-element at ``path`` (which must exist)."""
    found = element.find(path)
    assert found is not None, path
    return float(found.get(key, "nan"))


def test_primitives_only_and_valid_inertias() -> None:
    root = ET.fromstring(hm.herb_urdf())
    assert root.find(".//mesh") is None
    hand_mass = 0.0
    for link in root.findall("link"):
        name = link.get("name", "")
        mass = attr(link, "inertial/mass", "value")
        moments = sorted(attr(link, "inertial/inertia", k) for k in ("ixx", "iyy", "izz"))
        assert mass > 0 and moments[0] > 0, name
        assert moments[0] + moments[1] >= moments[2] * (1 - 1e-9), name
        if name.startswith("right_f") or name == "right_hand_base":
            hand_mass += mass
    assert hand_mass == pytest.approx(1.2, abs=0.1)


def test_joint_names_and_limits(sim: HerbBullet) -> None:
    c = sim.client
    for side in hm.SIDES:
        for i, name in enumerate(hm.arm_joint_names(side)):
            info = c.getJointInfo(sim.robot, sim.joints[name])
            assert info[2] == pybullet.JOINT_REVOLUTE
            assert info[12].decode() == f"{side}_wam{i + 1}"
            assert info[8] == pytest.approx(hm.ARM_JOINT_LOWER[i])
            assert info[9] == pytest.approx(hm.ARM_JOINT_UPPER[i])
            assert info[10] == pytest.approx(hm.ARM_EFFORT_LIMITS[i])
            assert info[11] == pytest.approx(hm.ARM_VELOCITY_LIMITS[i])
        ranges = {"spread": hm.HAND_SPREAD_RANGE, "prox": hm.HAND_PROXIMAL_RANGE}
        ranges["dist"] = hm.HAND_DISTAL_RANGE
        for name in hm.hand_joint_names(side):
            info = c.getJointInfo(sim.robot, sim.joints[name])
            lo, hi = ranges[name.rsplit("_", 1)[1]]
            assert (info[8], info[9]) == pytest.approx((lo, hi))
        assert f"{side}_f3_spread" not in sim.joints
        for link in ("wam_base", "hand_base", "hand_tcp", "f1_knuckle", "f2_knuckle", "f3_dist"):
            assert f"{side}_{link}" in sim.links


def test_pybullet_fk_matches_dh_and_arm_kinematics(sim: HerbBullet) -> None:
    rng = np.random.default_rng(0)
    kin = ArmKinematics("right")
    for q in rng.uniform(hm.ARM_JOINT_LOWER, hm.ARM_JOINT_UPPER, size=(1000, 7)):
        sim.set_arm("right", q)
        pb = sim.link_pose("right_hand_base")
        for ref in (dh_hand_pose("right", q), kin.fk(q)):
            assert np.linalg.norm(pb[:3, 3] - ref[:3, 3]) < 1e-6
            assert rot_error(pb[:3, :3], ref[:3, :3]) < 1e-6


def test_left_arm_mirrors_right(sim: HerbBullet) -> None:
    """Mirrored configurations put the hands at mirrored places relative to the shoulders."""
    rng = np.random.default_rng(1)
    shoulders = {side: dh_hand_pose(side, np.zeros(7)) for side in hm.SIDES}
    kin = {side: ArmKinematics(side) for side in hm.SIDES}
    mirror = np.diag([1.0, -1.0, 1.0])
    configs = [hm.LEFT_ARM_PARK, *rng.uniform(hm.ARM_JOINT_LOWER, hm.ARM_JOINT_UPPER, (50, 7))]
    for q_left in configs:
        q_right = hm.mirror_arm_configuration(q_left)
        sim.set_arm("left", q_left)
        sim.set_arm("right", q_right)
        for name in ("wam4", "wam6", "hand_base", "hand_tcp", "f3_prox"):
            left = sim.link_pose(f"left_{name}")[:3, 3] - kin["left"].shoulder
            right = sim.link_pose(f"right_{name}")[:3, 3] - kin["right"].shoulder
            np.testing.assert_allclose(mirror @ left, right, atol=1e-6)
        left_z = sim.link_pose("left_hand_base")[:3, 2]
        np.testing.assert_allclose(
            mirror @ left_z, sim.link_pose("right_hand_base")[:3, 2], atol=1e-6
        )
    assert shoulders["left"][1, 3] == pytest.approx(-shoulders["right"][1, 3], abs=0.005)


def test_right_home_hand_above_table_in_front_and_elbow_up(sim: HerbBullet) -> None:
    sim.set_arm("right", hm.RIGHT_ARM_HOME)
    hand = sim.link_pose("right_hand_base")[:3, 3]
    tcp = sim.link_pose("right_hand_tcp")[:3, 3]
    shoulder = ArmKinematics("right").shoulder
    assert hand[2] > TABLE_TOP and tcp[2] > TABLE_TOP + 0.15
    assert tcp[0] > shoulder[0] + 0.4 and tcp[1] < 0
    assert sim.link_pose("right_wam4")[2, 3] > shoulder[2] + 0.3
    lo, hi = hm.ARM_JOINT_LOWER, hm.ARM_JOINT_UPPER
    assert np.all((hm.RIGHT_ARM_HOME > lo) & (hm.RIGHT_ARM_HOME < hi))
    left_home = hm.mirror_arm_configuration(hm.RIGHT_ARM_HOME)
    assert np.all((left_home > lo) & (left_home < hi))
    assert np.all((hm.LEFT_ARM_PARK > lo) & (hm.LEFT_ARM_PARK < hi))


def test_home_and_park_clear_of_self_and_table(tmp_path: Path) -> None:
    flags = pybullet.URDF_USE_SELF_COLLISION | pybullet.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT
    s = load_sim(tmp_path, flags)
    c = s.client
    half = (0.37, 0.925, 0.02)
    box = c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half)
    table = c.createMultiBody(0, box, basePosition=(1.0, 0.0, TABLE_TOP - half[2]))
    for left, right in (
        (hm.LEFT_ARM_PARK, hm.RIGHT_ARM_HOME),
        (
            hm.mirror_arm_configuration(hm.RIGHT_ARM_HOME),
            hm.mirror_arm_configuration(hm.LEFT_ARM_PARK),
        ),
    ):
        s.set_arm("left", left)
        s.set_arm("right", right)
        c.performCollisionDetection()
        assert c.getContactPoints(s.robot, s.robot) == ()
        assert c.getClosestPoints(s.robot, table, 0.05) == ()
    c.disconnect()


def test_arm_torques_hold_half_kilo_payload(sim: HerbBullet) -> None:
    """Static gravity torque of arm + hand + 0.5 kg at the tcp stays within the effort limits."""
    c = sim.client
    c.setGravity(0, 0, -9.81)
    rng = np.random.default_rng(2)
    kin = ArmKinematics("right")
    movable = [
        j
        for j in range(c.getNumJoints(sim.robot))
        if c.getJointInfo(sim.robot, j)[2] != pybullet.JOINT_FIXED
    ]
    arm = [movable.index(sim.joints[n]) for n in hm.arm_joint_names("right")]
    payload = np.array([0.0, 0.0, -0.5 * 9.81, 0.0, 0.0, 0.0])
    worst = np.zeros(7)
    for q in rng.uniform(hm.ARM_JOINT_LOWER, hm.ARM_JOINT_UPPER, size=(300, 7)):
        positions = np.zeros(len(movable))
        positions[arm] = q
        zeros = [0.0] * len(movable)
        tau = np.array(c.calculateInverseDynamics(sim.robot, list(positions), zeros, zeros))
        static = np.abs(tau[arm] - kin.jacobian(q).T @ payload)
        worst = np.maximum(worst, static)
    c.setGravity(0, 0, 0)
    assert np.all(worst < hm.ARM_EFFORT_LIMITS), worst


def fingertips(sim: HerbBullet, side: str) -> np.ndarray:
    tips = []
    for i in (1, 2, 3):
        pose = sim.link_pose(f"{side}_f{i}_dist")
        tips.append(pose[:3, :3] @ np.array(hm.FINGERTIP_OFFSET) + pose[:3, 3])
    return np.array(tips)


def test_open_hand_aperture(sim: HerbBullet) -> None:
    sim.set_arm("right", hm.RIGHT_ARM_HOME)
    for name in hm.hand_joint_names("right"):
        sim.client.resetJointState(sim.robot, sim.joints[name], 0.0)
    tips = fingertips(sim, "right")
    for i in (0, 1):
        assert np.linalg.norm(tips[i] - tips[2]) == pytest.approx(0.33, abs=0.03)
    # Open fingers lie flat: tips barely in front of the knuckles along the approach axis.
    hand = sim.link_pose("right_hand_base")
    local = (tips - hand[:3, 3]) @ hand[:3, :3]
    assert np.all(local[:, 2] < hm.HAND_KNUCKLE_HEIGHT + hm.HAND_A3)


def test_closing_fingers_meet_at_tcp(tmp_path: Path) -> None:
    s = load_sim(tmp_path)
    c = s.client
    s.set_arm("right", hm.RIGHT_ARM_HOME)
    names = [f"right_f{i}_{part}" for part in ("prox", "dist") for i in (1, 2, 3)]
    targets = [2.0] * 3 + [2.0 * hm.HAND_DISTAL_COUPLING] * 3
    forces = [hm.HAND_PROXIMAL_EFFORT] * 3 + [hm.HAND_DISTAL_EFFORT] * 3
    c.setJointMotorControlArray(
        s.robot,
        [s.joints[n] for n in names],
        pybullet.POSITION_CONTROL,
        targetPositions=targets,
        forces=forces,
    )
    for _ in range(480):
        c.stepSimulation()
    reached = [c.getJointState(s.robot, s.joints[n])[0] for n in names]
    np.testing.assert_allclose(reached, targets, atol=0.05)
    tcp = s.link_pose("right_hand_tcp")[:3, 3]
    assert np.all(np.linalg.norm(fingertips(s, "right") - tcp, axis=1) < 0.05)
    c.disconnect()
