"""HERB robot model: kinematic constants and a primitive-only URDF.

Every number comes from the Barrett WAM user manual (D1001: DH table, joint ranges), libbarrett's
``wam7w.conf``, personalrobotics/herb_description (joint origins, HERB's mounting, OWD limits) and
the BH-280 documentation (hand kinematics). The public WAM/BH meshes are GPL, so all geometry here
is built from boxes, cylinders and spheres.

Frames: the world frame is the ``herb_base`` frame (origin on the floor under the robot, x forward,
z up). Each arm link ``{side}_wam{i}`` has its URDF frame at joint i with the joint axis along its
z axis; these frames are the Spong-DH frames of WAM_DH rotated by the joint angle, which is what
lets ``clutter_gym.model.kinematics`` reproduce pybullet's forward kinematics exactly.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from clutter_gym.model.files import atomic_write_text, cache_dir
from clutter_gym.model.shapes import Shape
from clutter_gym.model.transforms import Vec3, rotation_about, rotation_rpy, rpy_of

PI = float(np.pi)
SIDES: tuple[str, str] = ("left", "right")

# --------------------------------------------------------------------------------------------
# WAM arm
# --------------------------------------------------------------------------------------------
#: Spong DH table of the 7-DoF WAM, one row per joint: (a [m], alpha [rad], d [m]).
WAM_DH = np.array(
    [
        [0.0, -PI / 2, 0.0],
        [0.0, PI / 2, 0.0],
        [0.045, -PI / 2, 0.55],
        [-0.045, PI / 2, 0.0],
        [0.0, -PI / 2, 0.3],
        [0.0, PI / 2, 0.0],
        [0.0, 0.0, 0.06],
    ]
)
#: Origin of joint 1 (the shoulder) in the ``{side}_wam_base`` frame.
WAM_BASE_TO_J1 = (0.22, 0.14, 0.346)
#: The 12 mm force/torque sensor between the WAM flange (DH frame 7) and the hand.
FT_SENSOR_LENGTH = 0.012
#: ``{side}_hand_base`` in the ``{side}_wam7`` frame: DH d7 (0.06) + sensor, then yaw pi/2.
HAND_MOUNT_XYZ = (0.0, 0.0, float(WAM_DH[6, 2]) + FT_SENSOR_LENGTH)
HAND_MOUNT_YAW = PI / 2

#: ``{side}_wam_base`` pose in ``herb_base``: (xyz, rpy). Both arms share the rotation; the
#: shoulders land at about (0.079, +-0.19, 0.915) with the j1 axis pointing forward.
ARM_MOUNT: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "left": ((-0.2667, 0.332276, 0.694588), (0.0, -PI / 2, PI)),
    "right": ((-0.2667, -0.049121, 0.694588), (0.0, -PI / 2, PI)),
}

#: HERB (OWD) joint limits. HERB's j1 carries a +180 deg offset. OWD uses the same limits on
#: both arms, so the left arm shares them (mirroring is not limit-preserving for j5).
ARM_JOINT_LOWER = np.array([-2.60 + PI, -1.96, -2.73, -0.86, -4.79, -1.56, -2.99])
ARM_JOINT_UPPER = np.array([2.60 + PI, 1.96, 2.73, 3.13, 1.30, 1.56, 2.99])
LEFT_ARM_JOINT_LOWER = ARM_JOINT_LOWER.copy()
LEFT_ARM_JOINT_UPPER = ARM_JOINT_UPPER.copy()
ARM_VELOCITY_LIMITS = np.array([0.75, 0.75, 2.0, 2.0, 2.5, 2.5, 2.5])
#: Peak joint torques [Nm]; enough to hold a 0.5 kg object at full reach (see the tests).
ARM_EFFORT_LIMITS = np.array([60.0, 60.0, 45.0, 45.0, 12.0, 12.0, 5.0])

#: Relaxed home of the left arm (herb_description): hand hanging beside the body, below the
#: table top and clear of a table placed in front of the robot.
LEFT_ARM_PARK = np.array([0.64, -1.76, 0.26, 1.96, 1.16, 0.87, 1.43])
#: Right-arm ready pose: elbow up (elbow at z ~ 1.39 m), hand_tcp at ~(0.61, -0.30, 1.00) above the
#: near table edge, approach axis (hand z) pointing forward and 40 deg down, finger plane
#: horizontal. Every joint is >= 0.7 rad from its limits and the mirrored pose fits the left arm.
RIGHT_ARM_HOME = np.array([3.32, -1.17, -0.27, 2.43, -0.26, -0.59, 1.58])
#: Where the right arm waits for a task (the env's start, every plan's first configuration): the
#: home pose with the shoulder 0.65 rad further back and the elbow 0.5 rad more bent (every joint
#: >= 0.14 rad from its limits), hand_tcp at ~(0.32, -0.27, 1.10), in front of the table's near
#: edge (x 0.45) and the shelf's opening (x 0.48). Home's hand hangs over the scene at 1.0 m,
#: where a 0.30 m box on the table (top at 1.035 m) would touch it and the shelf's top board does.
RIGHT_ARM_START = np.array([3.32, -1.82, -0.27, 2.93, -0.26, -0.59, 1.58])

#: Per joint, -1 if the angle flips sign when the configuration is mirrored between the arms
#: (axes lying in the robot's xz symmetry plane at zero), +1 otherwise.
ARM_MIRROR_SIGNS = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0])

# --------------------------------------------------------------------------------------------
# BH-280 hand
# --------------------------------------------------------------------------------------------
HAND_SPREAD_RANGE = (0.0, PI)
HAND_PROXIMAL_RANGE = (0.0, 2.443)
HAND_DISTAL_RANGE = (0.0, 0.838)
#: Distal angle = ratio * proximal angle (pybullet ignores <mimic>: the controller couples them).
HAND_DISTAL_COUPLING = 1.0 / 3.0
HAND_PALM_RADIUS = 0.045
HAND_PALM_HEIGHT = 0.075
HAND_KNUCKLE_HEIGHT = 0.0754
HAND_AW = 0.025
HAND_A1 = 0.050
HAND_A2 = 0.070
HAND_A3 = 0.050
#: Finger thickness offset: used as the half-thickness of the finger links and fingertip radius.
HAND_D3 = 0.0095
HAND_DISTAL_BEND = 0.698
HAND_FINGER_WIDTH = 0.02
#: ``{side}_hand_tcp`` on the approach axis, this far in front of ``{side}_hand_base``: the centre
#: of a soda can (r = 33 mm) held by a closed spread-0 grasp. In pybullet a can closed on from
#: 0.13-0.15 m settles at 0.118 m, resting on the knuckles (top at 0.085 m) and pinned by the
#: curled fingers (proximal ~1.7 rad).
HAND_TCP_OFFSET = 0.12
#: Fingertip centre (centre of the rounded tip) in the ``{side}_f{i}_dist`` frame.
FINGERTIP_OFFSET = (
    HAND_A3 * float(np.cos(HAND_DISTAL_BEND)),
    0.0,
    HAND_A3 * float(np.sin(HAND_DISTAL_BEND)),
)
HAND_SPREAD_EFFORT, HAND_SPREAD_VELOCITY = 2.0, 1.5
HAND_PROXIMAL_EFFORT, HAND_PROXIMAL_VELOCITY = 3.0, 2.0
HAND_DISTAL_EFFORT, HAND_DISTAL_VELOCITY = 1.5, 1.0


@dataclass(frozen=True)
class HandCommand:
    """The BH-280's command, as the env's trajectory rows carry it: ``spread`` and ``closure``
    as fractions in [0, 1] (closure 0 is the flat, fully open hand; 1 is the proximal joints at
    their upper limit)."""

    spread: float = 0.0
    closure: float = 0.0


OPEN_HAND = HandCommand()

HAND_TRANSITION_STEPS = 4
"""Hand commands at which a change of command is checked (the last is the new command)."""


def hand_transition(start: HandCommand, end: HandCommand) -> list[HandCommand]:
    """The hand's commands on the way from ``start`` to ``end`` (excluding ``start``): the
    fingers sweep everything between, and closing from a wide V preshape sweeps a neighbour
    standing between the open fingers along with the grasped object."""
    if start == end:
        return []
    return [
        HandCommand(
            start.spread + f * (end.spread - start.spread),
            start.closure + f * (end.closure - start.closure),
        )
        for f in np.linspace(0.0, 1.0, HAND_TRANSITION_STEPS + 1)[1:]
    ]


def hand_targets(hand: HandCommand) -> np.ndarray:
    """Joint targets (8,) of a hand command, in `hand_joint_names` order (pybullet ignores
    URDF <mimic>: the distal joints follow the proximal ones by the coupling ratio here)."""
    spread_angle = float(np.clip(hand.spread, 0.0, 1.0)) * HAND_SPREAD_RANGE[1]
    prox = float(np.clip(hand.closure, 0.0, 1.0)) * HAND_PROXIMAL_RANGE[1]
    dist = min(prox * HAND_DISTAL_COUPLING, HAND_DISTAL_RANGE[1])
    return np.array([spread_angle, spread_angle, prox, prox, prox, dist, dist, dist])


def arm_joint_names(side: str) -> list[str]:
    """Names of the 7 arm joints, in chain order."""
    return [f"{side}_j{i}" for i in range(1, 8)]


def hand_joint_names(side: str) -> list[str]:
    """Names of the 8 hand joints: two spreads, three proximal, three distal."""
    return (
        [f"{side}_f1_spread", f"{side}_f2_spread"]
        + [f"{side}_f{i}_prox" for i in (1, 2, 3)]
        + [f"{side}_f{i}_dist" for i in (1, 2, 3)]
    )


def arm_joint_limits(side: str) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) joint limits of one arm."""
    if side == "left":
        return LEFT_ARM_JOINT_LOWER, LEFT_ARM_JOINT_UPPER
    return ARM_JOINT_LOWER, ARM_JOINT_UPPER


def mirror_arm_configuration(q: np.ndarray) -> np.ndarray:
    """Map an arm configuration to the mirror-image configuration of the other arm.

    j1 is wrapped into [0, 2 pi) because HERB's j1 range is centred on pi.
    """
    m = np.asarray(q, dtype=float) * ARM_MIRROR_SIGNS
    m[..., 0] = np.mod(m[..., 0], 2 * PI)
    return m


# --------------------------------------------------------------------------------------------
# URDF generation
# --------------------------------------------------------------------------------------------
_ZERO: Vec3 = (0.0, 0.0, 0.0)

_MATERIALS = {
    "herb_arm_grey": (0.62, 0.63, 0.66, 1.0),
    "herb_hand_dark": (0.16, 0.16, 0.18, 1.0),
    "herb_base_dark": (0.25, 0.27, 0.30, 1.0),
    "herb_tire_black": (0.05, 0.05, 0.05, 1.0),
}


def _fmt(values: Iterable[float]) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _origin(xyz: Vec3 = _ZERO, rpy: Vec3 = _ZERO) -> str:
    return f'<origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>'


def _urdf_geometry(shape: Shape) -> str:
    if shape.kind == "box":
        return f'<box size="{_fmt(shape.dims)}"/>'
    if shape.kind == "cylinder":
        return f'<cylinder radius="{shape.dims[0]:.9g}" length="{shape.dims[1]:.9g}"/>'
    return f'<sphere radius="{shape.dims[0]:.9g}"/>'


def _link(
    name: str,
    mass: float,
    shapes: Sequence[Shape],
    material: str,
    inertia_shape: Shape | None = None,
) -> str:
    """A link whose inertia is that of one primitive (the first by default) carrying all mass."""
    body = inertia_shape or shapes[0]
    ixx, iyy, izz = body.principal_inertia(mass)
    parts = [
        f'<link name="{name}">',
        "<inertial>",
        _origin(body.xyz, body.rpy),
        f'<mass value="{mass:.9g}"/>',
        f'<inertia ixx="{ixx:.9g}" ixy="0" ixz="0" iyy="{iyy:.9g}" iyz="0" izz="{izz:.9g}"/>',
        "</inertial>",
    ]
    for s in shapes:
        mat = f'<material name="{material}"/>'
        geom = f"<geometry>{_urdf_geometry(s)}</geometry>"
        parts.append(f"<visual>{_origin(s.xyz, s.rpy)}{geom}{mat}</visual>")
        parts.append(f"<collision>{_origin(s.xyz, s.rpy)}{geom}</collision>")
    parts.append("</link>")
    return "\n".join(parts)


def _joint(
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz: Vec3 = _ZERO,
    rpy: Vec3 = _ZERO,
    axis: Vec3 = (0.0, 0.0, 1.0),
    limits: tuple[float, float, float, float] | None = None,
    fixed_at: float | None = None,
) -> str:
    """A joint; ``limits`` is (lower, upper, effort, velocity) for revolute joints.

    ``fixed_at`` freezes a revolute joint at that angle: it becomes a fixed joint whose origin
    carries the rotation, so the simulator spends nothing on it (a parked arm).
    """
    if kind == "revolute" and fixed_at is not None:
        rotation = rotation_rpy(rpy) @ rotation_about(axis, fixed_at)
        kind, rpy, limits = "fixed", rpy_of(rotation), None
    parts = [
        f'<joint name="{name}" type="{kind}">',
        f'<parent link="{parent}"/>',
        f'<child link="{child}"/>',
        _origin(xyz, rpy),
    ]
    if kind == "revolute" and limits is not None:
        lo, hi, effort, vel = limits
        parts.append(f'<axis xyz="{_fmt(axis)}"/>')
        parts.append(
            f'<limit lower="{lo:.9g}" upper="{hi:.9g}" effort="{effort:.9g}" velocity="{vel:.9g}"/>'
        )
    parts.append("</joint>")
    return "\n".join(parts)


def _body() -> list[str]:
    """Segway base, wheels, torso column and sensor mast as one fixed root link."""
    along_y: Vec3 = (PI / 2, 0.0, 0.0)
    chassis = Shape("box", (0.60, 0.50, 0.30), (-0.15, 0.0, 0.20))
    shapes = [
        chassis,
        Shape("cylinder", (0.24, 0.08), (-0.15, 0.30, 0.24), along_y),
        Shape("cylinder", (0.24, 0.08), (-0.15, -0.30, 0.24), along_y),
        Shape("box", (0.18, 0.40, 0.75), (-0.36, 0.0, 0.725)),
        Shape("cylinder", (0.03, 0.40), (-0.36, 0.0, 1.30)),
        Shape("box", (0.12, 0.28, 0.10), (-0.33, 0.0, 1.55)),
    ]
    return [_link("herb_base", 120.0, shapes, "herb_base_dark", chassis)]


class LinkSpec(NamedTuple):
    """Mass and primitives of one link (collision = visual), shared by URDF and fcl geometry."""

    mass: float
    shapes: tuple[Shape, ...]


class FingerJoint(NamedTuple):
    """A hand joint's origin and axis (names without the side prefix), for URDF and FK alike."""

    parent: str
    child: str
    xyz: Vec3
    rpy: Vec3
    axis: Vec3


def arm_links() -> dict[str, LinkSpec]:
    """WAM links wam_base, wam1..wam7 (without the side prefix), in URDF order."""
    along_y: Vec3 = (PI / 2, 0.0, 0.0)
    j1 = WAM_BASE_TO_J1
    return {
        # Motor housing behind the shoulder (j1 axis = wam_base z).
        "wam_base": LinkSpec(10.0, (Shape("box", (0.20, 0.18, 0.20), (j1[0], j1[1], 0.10)),)),
        # j1 housing, coaxial with the j1 axis, behind the shoulder (clear of a folded-back
        # upper arm).
        "wam1": LinkSpec(10.8, (Shape("cylinder", (0.07, 0.056), (0.0, 0.0, -0.118)),)),
        # Shoulder pitch housing around the j2 axis.
        "wam2": LinkSpec(3.9, (Shape("cylinder", (0.065, 0.17)),)),
        # Upper arm tube along the j3 axis, towards the elbow at z = 0.55.
        "wam3": LinkSpec(1.8, (Shape("cylinder", (0.045, 0.38), (0.0, 0.0, 0.31)),)),
        # Elbow drum on the j4 axis + forearm tube along the j5 axis (-y here).
        "wam4": LinkSpec(
            2.4,
            (
                Shape("cylinder", (0.04, 0.20), (-0.045, -0.15, 0.0), along_y),
                Shape("cylinder", (0.055, 0.10)),
            ),
        ),
        # Wrist yaw housing at the forearm end.
        "wam5": LinkSpec(0.4, (Shape("cylinder", (0.045, 0.05), (0.0, 0.0, 0.225)),)),
        # Wrist pitch housing on the j6 axis through the wrist centre.
        "wam6": LinkSpec(0.4, (Shape("cylinder", (0.045, 0.09)),)),
        # Wrist roll output flange + force/torque sensor.
        "wam7": LinkSpec(0.25, (Shape("cylinder", (0.04, 0.027), (0.0, 0.0, 0.0585)),)),
    }


def hand_links() -> dict[str, LinkSpec]:
    """BH-280 links (without the side prefix): palm, two spread knuckles, proximal and distal
    links of each finger (flat boxes with a rounded cylinder tip)."""
    t = 2 * HAND_D3
    along_y: Vec3 = (PI / 2, 0.0, 0.0)
    palm = Shape("cylinder", (HAND_PALM_RADIUS, HAND_PALM_HEIGHT), (0.0, 0.0, HAND_PALM_HEIGHT / 2))
    f3_knuckle = Shape(
        "box", (HAND_FINGER_WIDTH, HAND_A1, t), (0.0, HAND_A1 / 2, HAND_KNUCKLE_HEIGHT)
    )
    knuckle = Shape("box", (HAND_A1, HAND_FINGER_WIDTH, t), (HAND_A1 / 2, 0.0, 0.0))
    prox = Shape("box", (HAND_A2, HAND_FINGER_WIDTH, t), (HAND_A2 / 2, 0.0, 0.0))
    c, s = np.cos(HAND_DISTAL_BEND), np.sin(HAND_DISTAL_BEND)
    dist_box = Shape(
        "box",
        (HAND_A3, HAND_FINGER_WIDTH, t),
        (HAND_A3 / 2 * c, 0.0, HAND_A3 / 2 * s),
        (0.0, -HAND_DISTAL_BEND, 0.0),
    )
    tip = Shape("cylinder", (HAND_D3, HAND_FINGER_WIDTH), FINGERTIP_OFFSET, along_y)
    links = {
        "hand_base": LinkSpec(0.71, (palm, f3_knuckle)),
        "f1_knuckle": LinkSpec(0.05, (knuckle,)),
        "f2_knuckle": LinkSpec(0.05, (knuckle,)),
    }
    for i in (1, 2, 3):
        links[f"f{i}_prox"] = LinkSpec(0.08, (prox,))
        links[f"f{i}_dist"] = LinkSpec(0.05, (dist_box, tip))
    return links


def finger_joints() -> dict[str, FingerJoint]:
    """The 8 revolute hand joints in `hand_joint_names` order (without the side prefix).

    Finger frames have x along the finger and z towards the approach axis when open; proximal
    and distal joints turn about -y so that positive angles curl the fingers closed. F1 at
    x = -Aw turns about -z, F2 at x = +Aw about +z: positive spread mirrors them.
    """
    k = HAND_KNUCKLE_HEIGHT
    curl: Vec3 = (0.0, -1.0, 0.0)
    joints = {
        "f1_spread": FingerJoint(
            "hand_base", "f1_knuckle", (-HAND_AW, 0.0, k), (0.0, 0.0, -PI / 2), (0.0, 0.0, -1.0)
        ),
        "f2_spread": FingerJoint(
            "hand_base", "f2_knuckle", (HAND_AW, 0.0, k), (0.0, 0.0, -PI / 2), (0.0, 0.0, 1.0)
        ),
        "f1_prox": FingerJoint("f1_knuckle", "f1_prox", (HAND_A1, 0.0, 0.0), _ZERO, curl),
        "f2_prox": FingerJoint("f2_knuckle", "f2_prox", (HAND_A1, 0.0, 0.0), _ZERO, curl),
        "f3_prox": FingerJoint("hand_base", "f3_prox", (0.0, HAND_A1, k), (0.0, 0.0, PI / 2), curl),
    }
    for i in (1, 2, 3):
        joints[f"f{i}_dist"] = FingerJoint(
            f"f{i}_prox", f"f{i}_dist", (HAND_A2, 0.0, 0.0), _ZERO, curl
        )
    return joints


def _arm(side: str, parked: Mapping[str, float]) -> list[str]:
    """WAM links and joints of one arm; joint origins come straight from WAM_DH."""
    p = f"{side}_"
    j1 = WAM_BASE_TO_J1
    out = [
        _link(p + name, spec.mass, spec.shapes, "herb_arm_grey")
        for name, spec in arm_links().items()
    ]
    mount_xyz, mount_rpy = ARM_MOUNT[side]
    out.append(_joint(p + "mount", "fixed", "herb_base", p + "wam_base", mount_xyz, mount_rpy))
    lower, upper = arm_joint_limits(side)
    parents = ["wam_base"] + [f"wam{i}" for i in range(1, 7)]
    for i in range(7):
        if i == 0:
            xyz, rpy = j1, _ZERO
        else:
            a, alpha, d = (float(v) for v in WAM_DH[i - 1])
            xyz, rpy = (a, 0.0, d), (alpha, 0.0, 0.0)
        limits = (
            float(lower[i]),
            float(upper[i]),
            float(ARM_EFFORT_LIMITS[i]),
            float(ARM_VELOCITY_LIMITS[i]),
        )
        out.append(
            _joint(
                f"{p}j{i + 1}",
                "revolute",
                p + parents[i],
                f"{p}wam{i + 1}",
                xyz,
                rpy,
                limits=limits,
                fixed_at=parked.get(f"{p}j{i + 1}"),
            )
        )
    return out


def _hand(side: str, parked: Mapping[str, float]) -> list[str]:
    """BH-280: palm, F1/F2 on mirrored spread joints, F3 fixed opposite them."""
    p = f"{side}_"
    links = hand_links()
    joints = finger_joints()
    limits = {
        "spread": (*HAND_SPREAD_RANGE, HAND_SPREAD_EFFORT, HAND_SPREAD_VELOCITY),
        "prox": (*HAND_PROXIMAL_RANGE, HAND_PROXIMAL_EFFORT, HAND_PROXIMAL_VELOCITY),
        "dist": (*HAND_DISTAL_RANGE, HAND_DISTAL_EFFORT, HAND_DISTAL_VELOCITY),
    }

    def link(name: str) -> str:
        return _link(p + name, links[name].mass, links[name].shapes, "herb_hand_dark")

    def joint(name: str) -> str:
        j = joints[name]
        return _joint(
            p + name,
            "revolute",
            p + j.parent,
            p + j.child,
            j.xyz,
            j.rpy,
            j.axis,
            limits[name.split("_")[1]],
            fixed_at=parked.get(p + name),
        )

    out = [
        link("hand_base"),
        _joint(
            p + "hand_mount",
            "fixed",
            p + "wam7",
            p + "hand_base",
            HAND_MOUNT_XYZ,
            (0.0, 0.0, HAND_MOUNT_YAW),
        ),
        _frame_link(p + "hand_tcp"),
        _joint(
            p + "hand_tcp_joint",
            "fixed",
            p + "hand_base",
            p + "hand_tcp",
            (0.0, 0.0, HAND_TCP_OFFSET),
        ),
    ]
    for i in (1, 2):
        out.extend([link(f"f{i}_knuckle"), joint(f"f{i}_spread")])
    for i in (1, 2, 3):
        out.extend(
            [link(f"f{i}_prox"), link(f"f{i}_dist"), joint(f"f{i}_prox"), joint(f"f{i}_dist")]
        )
    return out


def _frame_link(name: str) -> str:
    """A geometry-free link with a tiny valid inertia (pybullet wants mass on every link)."""
    i = 0.4 * 1e-3 * 0.005**2
    return (
        f'<link name="{name}"><inertial>{_origin()}<mass value="0.001"/>'
        f'<inertia ixx="{i:.9g}" ixy="0" ixz="0" iyy="{i:.9g}" iyz="0" izz="{i:.9g}"/>'
        "</inertial></link>"
    )


def parked_left_side() -> dict[str, float]:
    """The left arm at `LEFT_ARM_PARK` and its hand open: the env's default frozen joints."""
    parked = dict(zip(arm_joint_names("left"), (float(q) for q in LEFT_ARM_PARK), strict=True))
    parked.update({name: 0.0 for name in hand_joint_names("left")})
    return parked


def herb_urdf(parked: Mapping[str, float] | None = None) -> str:
    """URDF text of HERB (base, two WAMs, two BH-280 hands) built from primitives only.

    Joints named in ``parked`` are frozen at the given angle (fixed joints): the env parks the
    left side this way, which removes 15 simulated DoF and their motors from every physics step.
    """
    parked = dict(parked or {})
    unknown = set(parked) - {
        n for side in SIDES for n in arm_joint_names(side) + hand_joint_names(side)
    }
    if unknown:
        raise ValueError(f"parked: unknown joints {sorted(unknown)}")
    parts = ['<?xml version="1.0"?>', '<robot name="herb">']
    for name, rgba in _MATERIALS.items():
        parts.append(f'<material name="{name}"><color rgba="{_fmt(rgba)}"/></material>')
    parts.extend(_body())
    for side in SIDES:
        parts.extend(_arm(side, parked))
        parts.extend(_hand(side, parked))
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


def write_herb_urdf(
    directory: Path | None = None, parked: Mapping[str, float] | None = None
) -> Path:
    """Write the URDF to a content-addressed file and return its path.

    The hash in the name lets concurrent processes share the file safely; the write goes through
    a temporary file + os.replace so a reader never sees a partial URDF.
    """
    text = herb_urdf(parked)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    path = (Path(directory) if directory is not None else cache_dir()) / f"herb_{digest}.urdf"
    if not (path.is_file() and path.read_text() == text):
        atomic_write_text(path, text)
    return path
