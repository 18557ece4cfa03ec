"""The BH-280's 2D cross-section at pushing height, for the planar pushing model.

Why: capture regions are computed in 2D against the hand as an object sees it when the hand
moves parallel to the support with its finger plane horizontal (the push-grasp of the paper,
§2.2.1, and HERB's side approach in `planners.direct_grasp`). Every number comes from
`clutter_gym.model.herb`.

Geometry (finger plane = pushing plane; a finger's coordinates are u, outward from the hand
axis, and z, forward along the approach axis from ``hand_base``):

* Palm: the cylinder of radius HAND_PALM_RADIUS along the approach axis seen from the side, a
  rectangle z in [0, HAND_PALM_HEIGHT], |u| <= HAND_PALM_RADIUS; in front of it the knuckle
  boxes, z in [K - D3, K + D3], |u| <= A1 (K = HAND_KNUCKLE_HEIGHT, D3 = HAND_D3). The palm's
  front edge for pushing is therefore z = K + D3.
* Fingers: F1 and F2 sit at x = -+HAND_AW, above and below the pushing plane; at spread 0 both
  project onto the same side (u < 0 in the hand), F3 onto the other. Each side is a proximal
  box from (A1, K) of length A2 at angle q from the palm plane, a distal box of length A3 at
  q + q_d + HAND_DISTAL_BEND (q_d = q * HAND_DISTAL_COUPLING, as `clutter_gym.sim.robot`
  drives it), all 2 * D3 thick, and a cylindrical fingertip of radius D3 at the distal end.
* Aperture a: the distance between the inner surfaces of the two fingertips,
  a = 2 (u_tip(q) - D3), monotone in the proximal angle q. From the closed tips (a = 0) up to
  `STRAIGHT_APERTURE` (about 0.19 m) the distal links lean inward and the fingertips are the
  innermost part of the fingers; opening further gives the BH-280's V preshapes, the distal
  links splayed outward like a funnel, up to `MAX_APERTURE` (about 0.27 m at the proximal angle
  `PROXIMAL_V_LIMIT`). The paper searches "between the maximum hand aperture and the minimum
  hand aperture for the object" (§2.2.6); the V preshapes are what makes the hand wide enough
  for the sigma4 uncertainty. The env commands an aperture as the hand closure
  ``closure_for_aperture(a)`` = q / proximal range.

2D frames: the push-grasp frame has x along the approach (push) direction, origin on the hand
axis at ``hand_base``, y to the left seen from above, angles counter-clockwise; the profile
is symmetric, so which finger side is which does not matter. The sweep frame (paper §2.1.6,
Fig. 7) is that frame turned +90 degrees: x (the sweep direction) points to the hand's right
(-y), y along the approach axis. The sweep pushes with the outer side of the right-hand
finger and, toward the arm, a straight plate flush with the palm ending at the wrist link's end
(HAND_MOUNT_XYZ behind ``hand_base``). A sweep to the left is the mirror image: mirror the
scene across the approach axis (y -> -y, theta -> -theta in the hand frame).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from clutter_gym.model import herb as hm
from clutter_gym.model.objects import Footprint
from planners.push_simulation import Circle, ConvexPolygon, Pusher, rectangle

_D3 = hm.HAND_D3
_K = hm.HAND_KNUCKLE_HEIGHT


@dataclass(frozen=True)
class FingerPose:
    """One finger side in (u, z) finger-plane coordinates for proximal angle ``proximal``."""

    proximal: float
    distal: float
    base: tuple[float, float]  # proximal joint
    joint: tuple[float, float]  # distal joint
    tip: tuple[float, float]  # fingertip cylinder centre


def distal_angle(proximal: float) -> float:
    """The distal joint angle the hand controller couples to a proximal angle."""
    return min(proximal * hm.HAND_DISTAL_COUPLING, hm.HAND_DISTAL_RANGE[1])


def finger_pose(proximal: float) -> FingerPose:
    lo, hi = hm.HAND_PROXIMAL_RANGE
    if not lo <= proximal <= hi:
        raise ValueError(f"proximal angle {proximal!r} outside the joint range [{lo}, {hi}] rad")
    qd = distal_angle(proximal)
    base = (hm.HAND_A1, _K)
    joint = (base[0] + hm.HAND_A2 * math.cos(proximal), base[1] + hm.HAND_A2 * math.sin(proximal))
    phi = proximal + qd + hm.HAND_DISTAL_BEND
    tip = (joint[0] + hm.HAND_A3 * math.cos(phi), joint[1] + hm.HAND_A3 * math.sin(phi))
    return FingerPose(proximal, qd, base, joint, tip)


def aperture_for_proximal(proximal: float) -> float:
    """Gap between the inner fingertip surfaces at a proximal angle (spread 0)."""
    return 2.0 * (finger_pose(proximal).tip[0] - _D3)


PROXIMAL_STRAIGHT = (math.pi / 2 - hm.HAND_DISTAL_BEND) / (1.0 + hm.HAND_DISTAL_COUPLING)
"""Proximal angle at which the distal links point straight forward: the sweep's preshape (a flat
outer side) and the widest aperture at which the fingertips are the fingers' innermost part."""
PROXIMAL_V_LIMIT = 0.2
"""The most open V preshape the planner uses (rad). Opening further brings the fingertips back
toward the palm (4.5 cm ahead of its face at 0.2 rad, 2.2 cm at 0): a pushed bottle or can
then comes to rest against the palm with its centre in front of the fingertips, where closing
the hand pushes it away instead of wrapping it."""
PROXIMAL_CLOSED = float(brentq(aperture_for_proximal, PROXIMAL_STRAIGHT, hm.HAND_PROXIMAL_RANGE[1]))
"""Proximal angle at which the fingertips touch (a = 0)."""
STRAIGHT_APERTURE = aperture_for_proximal(PROXIMAL_STRAIGHT)
MAX_APERTURE = aperture_for_proximal(PROXIMAL_V_LIMIT)


def proximal_for_aperture(aperture: float) -> float:
    """Inverse of `aperture_for_proximal` on the usable range (it is monotone there)."""
    if not (math.isfinite(aperture) and 0.0 < aperture <= MAX_APERTURE + 1e-12):
        raise ValueError(
            f"aperture {aperture!r} m outside the hand's range (0, {MAX_APERTURE:.4f}]"
        )
    if aperture >= MAX_APERTURE:
        return PROXIMAL_V_LIMIT
    if aperture == STRAIGHT_APERTURE:
        return PROXIMAL_STRAIGHT
    # Bracketed on the V side or the curled side of the straight preshape.
    v_shaped = aperture > STRAIGHT_APERTURE
    return float(
        brentq(
            lambda q: aperture_for_proximal(q) - aperture,
            PROXIMAL_V_LIMIT if v_shaped else PROXIMAL_STRAIGHT,
            PROXIMAL_STRAIGHT if v_shaped else PROXIMAL_CLOSED,
            xtol=1e-12,
        )
    )


def closure_for_aperture(aperture: float) -> float:
    """The env's hand closure command (fraction of the proximal range) for an aperture."""
    return proximal_for_aperture(aperture) / hm.HAND_PROXIMAL_RANGE[1]


def default_aperture(footprint: Footprint) -> float:
    """An aperture that fits the object at any orientation with 2 cm either side, capped where
    the fingertips point straight ahead: the validation's default push-grasp preshape."""
    return min(STRAIGHT_APERTURE, 2.0 * footprint.bounding_radius + 0.04)


def check_footprint(footprint: Footprint) -> None:
    """ValueError unless the outline is a circle or box with positive, finite sizes."""
    sizes = (footprint.radius,) if footprint.shape == "circle" else footprint.half_extents
    if footprint.shape not in ("circle", "box") or not all(
        math.isfinite(s) and s > 0 for s in sizes
    ):
        raise ValueError(f"footprint sizes must be positive and finite, got {footprint!r}")


def check_fits(footprint: Footprint, aperture: float) -> None:
    """ValueError unless the object's narrowest width fits the hand and this aperture."""
    check_footprint(footprint)
    width = footprint.min_width
    if width >= MAX_APERTURE:
        raise ValueError(
            f"object is {width:.3f} m wide at its narrowest: wider than the hand's maximum "
            f"aperture {MAX_APERTURE:.4f} m, it cannot be push-grasped"
        )
    if not width < aperture <= MAX_APERTURE + 1e-12:
        raise ValueError(
            f"aperture {aperture!r} m must be in ({width:.4f}, {MAX_APERTURE:.4f}]: wider than "
            f"the object's narrowest width and within the hand's range"
        )


def _box(x0: float, x1: float, y0: float, y1: float) -> ConvexPolygon:
    return ConvexPolygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)))


def _finger_shapes(proximal: float, side: float) -> tuple[list[ConvexPolygon], Circle]:
    """Proximal box, distal box and tip of one side in the push-grasp frame (x = z, y = side*u)."""
    f = finger_pose(proximal)

    def xy(p: tuple[float, float]) -> np.ndarray:
        return np.array([p[1], side * p[0]])

    links = [rectangle(xy(f.base), xy(f.joint), _D3), rectangle(xy(f.joint), xy(f.tip), _D3)]
    return links, Circle((float(xy(f.tip)[0]), float(xy(f.tip)[1])), _D3)


def _hand_shapes(proximal: float) -> tuple[list[ConvexPolygon], list[Circle]]:
    polygons = [
        _box(0.0, hm.HAND_PALM_HEIGHT, -hm.HAND_PALM_RADIUS, hm.HAND_PALM_RADIUS),
        _box(_K - _D3, _K + _D3, -hm.HAND_A1, hm.HAND_A1),
    ]
    circles = []
    for side in (1.0, -1.0):
        links, tip = _finger_shapes(proximal, side)
        polygons += links
        circles.append(tip)
    return polygons, circles


@dataclass(frozen=True)
class PushGraspProfile:
    """The hand during a push-grasp: it moves along +x; an object is grasped when its centre is
    behind ``grasp_line`` (the fingertip centres) and within ``half_gap`` of the axis."""

    aperture: float
    proximal: float
    pusher: Pusher
    grasp_line: float
    half_gap: float

    @property
    def closure(self) -> float:
        return self.proximal / hm.HAND_PROXIMAL_RANGE[1]


@functools.cache
def push_grasp_profile(aperture: float) -> PushGraspProfile:
    """The hand's cross-section preshaped to ``aperture`` (cached: the planner asks for the
    same few apertures thousands of times)."""
    q = proximal_for_aperture(aperture)
    polygons, circles = _hand_shapes(q)
    return PushGraspProfile(
        aperture, q, Pusher(tuple(polygons), tuple(circles)), finger_pose(q).tip[1], aperture / 2
    )


GRASP_DEPTH = 0.015
"""m an object's centre must stand behind the fingertip line (``grasp_line``) for fingers
closing where nothing else moved it to hold it. Measured in pybullet (`clutter-gym
validate-capture --action static-grasp --aperture all`, docs/results/capture_static.md): with
the centre within 15 mm of the line, a juice bottle toppled or was flung off the table in 53 of
214 closes at the 0.100-0.156 m preshapes, whose fingertips lean inward, meet it in front of its
centre and squeeze it out forward; in none of 340 at the straight and V preshapes, whose fingers
wrap around it; behind the 15 mm every close held, and the can held everywhere. A push-grasp's
capture region counts a cylinder that nothing touches as captured only this far behind the line
in those narrow preshapes (`grasp_depth`; a push that ends as the centre just crosses it leaves
it there: Table 1 high_04 sigma2, a bottle the fingers flung off the table at 0.12 m). Static
grasps keep it for every object at every preshape (`planners.tsr.grasped_still`): the poptart
box, which held in all 120 closes of that grid within 15 mm (turned 0, 30, ... 150 deg), toppled
standing turned 74 deg, nearly across the hand, when closed on 1 mm behind the line at every one
of five approach headings and 6 mm behind at three, and held 11 mm and more behind (Table 1
medium_04 without noise, a static grasp at 0.192 m)."""


def grasp_depth(footprint: Footprint, aperture: float) -> float:
    """m behind the fingertip line a push-grasp's capture region asks of the centre of an
    object that nothing touches: `GRASP_DEPTH` for a cylinder in a preshape narrower than the
    straight one, none otherwise (the wider preshapes wrap around a cylinder; a box pushed the
    planner's distance, its need plus `planners.capture.BOX_PUSH_MARGIN`, held in every
    close inside its regions, docs/results/capture_poptart.md)."""
    narrow = aperture < STRAIGHT_APERTURE - 1e-9
    return GRASP_DEPTH if footprint.shape == "circle" and narrow else 0.0


PALM_FRONT = _K + _D3
"""Approach-axis coordinate of the palm's front edge for pushing (the knuckle boxes' front)."""
PALM_SEAT = 0.005
"""m: how near the palm's front a box's nearest face must be for fingers closing from a V
preshape to hold it. The V's splayed links can carry a box turned across the hand a couple of
centimetres ahead of the palm; closing then turns them into it with nothing behind it, and it
topples. Measured in pybullet (`clutter-gym validate-capture --object poptart_box --aperture
0.235`, pushed the planner's distance): the poptart box toppled in 3 of 40 closes inside the
region, each where the 2D model, for some of its friction and pressure sets, had it carried up
to 2 cm ahead of the palm; pushed on to the palm it held."""


def palm_seat(footprint: Footprint, aperture: float) -> float | None:
    """m a box must come to the palm for a V preshape to count it captured (`PALM_SEAT`),
    wherever its centre stands against the fingertip line (the V's fingers close on a box seated
    at the palm at any orientation, end-on too: `planners.hand2d.TURN_SEAT`), or None
    where the fingertip line alone decides: cylinders, and every preshape up to the straight
    one, whose fingers close around a box's sides from behind its centre."""
    v_shaped = aperture > STRAIGHT_APERTURE + 1e-9
    return PALM_SEAT if footprint.shape == "box" and v_shaped else None


WRIST_END = -hm.HAND_MOUNT_XYZ[2]
"""Approach-axis coordinate of the wrist link's end (the WAM's wrist centre) from hand_base."""


@dataclass(frozen=True)
class SweepProfile:
    """The hand sweeping along +x of the sweep frame; an object is kept while its centre's y
    stays within ``span`` (the wrist end to the fingertip)."""

    aperture: float
    proximal: float
    pusher: Pusher
    span: tuple[float, float]


@functools.cache
def sweep_profile(aperture: float = STRAIGHT_APERTURE) -> SweepProfile:
    q = proximal_for_aperture(aperture)
    polygons, circles = _hand_shapes(q)
    polygons.append(_box(WRIST_END, 0.0, -hm.HAND_PALM_RADIUS, hm.HAND_PALM_RADIUS))

    def turn(p: tuple[float, float]) -> tuple[float, float]:  # +90 deg: (x, y) -> (-y, x)
        return (-p[1], p[0])

    pusher = Pusher(
        tuple(ConvexPolygon(tuple(turn(v) for v in p.vertices)) for p in polygons),
        tuple(Circle(turn(c.center), c.radius) for c in circles),
    )
    return SweepProfile(aperture, q, pusher, (WRIST_END, finger_pose(q).tip[1]))


TURN_BAND = math.radians(50.0)
"""A box turned at most this far from the hand's approach axis (its faces repeat every half
turn) is turned toward the axis by the closing fingers, never past
`planners.actions.hand_in.TURN_REST`."""
TURN_SEAT = ((0.023, 0.04), (0.043, 0.02))
"""(m ahead of the palm, m either side of the approach axis): where a box's nearest point and
its centre must stand for `TURN_BAND` to hold, the envelope of the measured poses."""


def outline_reach(footprint: Footprint, theta: np.ndarray) -> np.ndarray:
    """How far the outline reaches behind its centre along a frame's x, per orientation in
    that frame."""
    if footprint.shape == "circle":
        return np.full(np.shape(theta), footprint.radius)
    hx, hy = footprint.half_extents
    return np.abs(hx * np.cos(theta)) + np.abs(hy * np.sin(theta))


def turned_to_axis(footprint: Footprint, in_hand: np.ndarray) -> np.ndarray:
    """Which box poses (M, 3; hand_base's frame) the closing fingers turn toward the approach
    axis and hold: within `TURN_BAND` of the axis and in `TURN_SEAT`
    (`planners.actions.hand_in.closing_poses`)."""
    _, _, near_axis, seated = box_band(footprint, np.asarray(in_hand, dtype=float).reshape(-1, 3))
    return near_axis & seated


def box_band(
    footprint: Footprint, in_hand: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each box pose's turn off the approach axis (in [-pi/2, pi/2)), how far its nearest
    point stands ahead of the palm, whether it is within `TURN_BAND` of the axis and whether
    it is in `TURN_SEAT` (both: `turned_to_axis`)."""
    off_axis = np.mod(in_hand[:, 2] + np.pi / 2, np.pi) - np.pi / 2
    ahead = np.maximum(in_hand[:, 0] - outline_reach(footprint, off_axis) - PALM_FRONT, 0.0)
    seated = np.zeros(len(in_hand), dtype=bool)
    for most_ahead, most_aside in TURN_SEAT:
        # 1e-9: the measured poses lie on the envelope's edge, give or take rounding.
        seated |= (ahead <= most_ahead + 1e-9) & (np.abs(in_hand[:, 1]) <= most_aside + 1e-9)
    return off_axis, ahead, np.abs(off_axis) <= TURN_BAND, seated
