"""The object library: geometry agrees across mesh, fcl and footprint, and the flags are sane."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import (
    MAX_GRASP_WIDTH,
    OBJECTS,
    Footprint,
    ObjectSpec,
    footprint_gap,
    get_object,
)
from clutter_gym.model.shapes import CYLINDER_SECTIONS, Shape

# A regular n-gon prism has n/(2π)·sin(2π/n) of its circumscribed cylinder's volume.
_POLYGON_FACTOR = CYLINDER_SECTIONS / (2 * math.pi) * math.sin(2 * math.pi / CYLINDER_SECTIONS)


def _analytic_mesh_volume(spec: ObjectSpec) -> float:
    return sum(
        p.volume * (_POLYGON_FACTOR if p.kind == "cylinder" else 1.0) for p in spec.primitives
    )


def _placed(spec: ObjectSpec, pose: tuple[float, float, float], z: float) -> Volume:
    return Volume.of_object("object", spec, np.array([pose]), z)


def _hits(spec: ObjectSpec, pose: tuple[float, float, float], z: float, point: tuple) -> bool:
    return _placed(spec, pose, z).intersects(
        Volume.of_box("probe", np.array(point), (1e-3,) * 3, 0)
    )


@pytest.mark.parametrize("kind", sorted(OBJECTS))
def test_mesh_volume_matches_analytic(kind: str) -> None:
    spec = OBJECTS[kind]
    mesh = spec.mesh()
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(_analytic_mesh_volume(spec), rel=1e-9)
    assert mesh.volume == pytest.approx(spec.volume, rel=3e-3)


@pytest.mark.parametrize("kind", sorted(OBJECTS))
def test_mesh_sits_on_its_base_inside_its_footprint(kind: str) -> None:
    spec = OBJECTS[kind]
    (x0, y0, z0), (x1, y1, z1) = spec.mesh().bounds
    assert z0 == pytest.approx(0.0, abs=1e-12)
    assert z1 == pytest.approx(spec.height)
    fx0, fx1, fy0, fy1 = spec.footprint.aabb((0.0, 0.0, 0.0))
    assert (x0, x1, y0, y1) == pytest.approx((fx0, fx1, fy0, fy1), abs=1e-9)
    assert 0 < spec.com_height < spec.height


@pytest.mark.parametrize("kind", sorted(OBJECTS))
@pytest.mark.parametrize("theta", [0.0, 0.4, -2.0, math.pi / 2])
def test_footprint_aabb_is_exact_for_rotated_mesh(kind: str, theta: float) -> None:
    spec = OBJECTS[kind]
    c, s = math.cos(theta), math.sin(theta)
    xy = spec.mesh().vertices[:, :2] @ np.array([[c, s], [-s, c]]) + np.array([0.7, -0.2])
    x0, x1, y0, y1 = spec.footprint.aabb((0.7, -0.2, theta))
    tolerance = 0.0 if spec.footprint.shape == "box" else spec.footprint.radius * 2e-3
    assert xy[:, 0].min() >= x0 - 1e-9 and xy[:, 0].max() <= x1 + 1e-9
    assert xy[:, 1].min() >= y0 - 1e-9 and xy[:, 1].max() <= y1 + 1e-9
    assert xy[:, 0].min() <= x0 + tolerance + 1e-9 and xy[:, 1].max() >= y1 - tolerance - 1e-9


def test_fcl_geometry_is_placed_at_the_pose_on_the_surface() -> None:
    can, z = get_object("soda_can"), 0.735
    pose = (0.7, -0.2, 0.3)
    ((obj, _, _),) = _placed(can, pose, z).parts
    assert obj.getTranslation() == pytest.approx([0.7, -0.2, z + 0.061])
    assert _hits(can, pose, z, (0.7 + 0.030, -0.2, z + 0.01))
    assert not _hits(can, pose, z, (0.7 + 0.036, -0.2, z + 0.01))
    assert _hits(can, pose, z, (0.7, -0.2, z + 0.120))
    assert not _hits(can, pose, z, (0.7, -0.2, z + 0.124))
    assert not _hits(can, pose, z, (0.7, -0.2, z - 0.002))


def test_fcl_geometry_follows_the_yaw() -> None:
    box, z = get_object("poptart_box"), 0.735
    # At yaw 90° the box's 0.14 m long side runs along world y.
    pose = (0.8, 0.0, math.pi / 2)
    assert _hits(box, pose, z, (0.8, 0.068, z + 0.1))
    assert not _hits(box, pose, z, (0.8, 0.072, z + 0.1))
    assert _hits(box, pose, z, (0.823, 0.0, z + 0.1))
    assert not _hits(box, pose, z, (0.827, 0.0, z + 0.1))


def test_dumbbell_lies_on_two_heads_joined_by_a_raised_handle() -> None:
    """Off-axis primitives are placed (and turned with the yaw) where the spec puts them."""
    dumbbell, z = get_object("dumbbell"), 0.0
    pose = (0.0, 0.0, 0.0)
    assert len(_placed(dumbbell, pose, z)) == 3
    assert _hits(dumbbell, pose, z, (0.11, 0.05, 0.09))  # a head
    assert _hits(dumbbell, pose, z, (-0.11, -0.05, 0.01))  # the other head
    assert _hits(dumbbell, pose, z, (0.0, 0.0, 0.055))  # the handle
    assert not _hits(dumbbell, pose, z, (0.0, 0.0, 0.02))  # under the handle
    assert not _hits(dumbbell, pose, z, (0.0, 0.03, 0.055))  # beside it
    turned = (0.5, 0.2, math.pi / 2)  # the handle along world y
    assert _hits(dumbbell, turned, z, (0.5, 0.2 + 0.11, 0.05))
    assert not _hits(dumbbell, turned, z, (0.5 + 0.11, 0.2, 0.05))
    assert dumbbell.footprint == Footprint("box", half_extents=(0.125, 0.055))
    assert dumbbell.height == pytest.approx(0.10)
    assert dumbbell.com_height == pytest.approx(0.05, abs=0.001)  # mostly the heads


def test_footprint_gap_is_the_planar_distance() -> None:
    can, bottle = get_object("soda_can").footprint, get_object("juice_bottle").footprint
    assert footprint_gap(can, (0, 0, 0), bottle, (0.2, 0, 1.0)) == pytest.approx(0.127)
    box = get_object("poptart_box").footprint
    assert footprint_gap(box, (0, 0, 0), box, (0.3, 0, 0)) == pytest.approx(0.16)
    assert footprint_gap(box, (0, 0, 0), box, (0, 0.3, math.pi / 2)) == pytest.approx(0.205)
    assert footprint_gap(box, (0, 0, 0), can, (0.05, 0, 0)) < 0


def test_library_sizes_and_masses() -> None:
    can = get_object("soda_can")
    assert can.footprint == Footprint("circle", radius=0.033)
    assert (can.height, can.mass) == pytest.approx((0.122, 0.35))
    assert get_object("poptart_box").footprint.half_extents == pytest.approx((0.07, 0.025))
    assert get_object("large_box").footprint.min_width == pytest.approx(0.26)
    assert get_object("dumbbell").mass == 5.0
    for spec in OBJECTS.values():
        assert 0.3 <= spec.lateral_friction <= 0.7
        assert spec.spinning_friction >= 0 and spec.rolling_friction >= 0


@pytest.mark.parametrize("kind", sorted(OBJECTS))
def test_graspable_iff_narrow_enough(kind: str) -> None:
    spec = OBJECTS[kind]
    assert spec.graspable == (spec.footprint.min_width <= MAX_GRASP_WIDTH)


def test_flags_match_the_paper() -> None:
    assert not get_object("large_box").graspable
    assert get_object("dumbbell").graspable and not get_object("dumbbell").liftable
    for kind in ("soda_can", "juice_bottle", "poptart_box"):
        assert get_object(kind).graspable and get_object(kind).liftable


def test_too_wide_object_cannot_be_declared_graspable() -> None:
    with pytest.raises(ValueError, match=r"MAX_GRASP_WIDTH"):
        ObjectSpec(
            kind="crate",
            primitives=(Shape("box", (0.3, 0.3, 0.2), (0.0, 0.0, 0.1)),),
            mass=1.0,
            lateral_friction=0.5,
            spinning_friction=0.0,
            rolling_friction=0.0,
            rgba=(1, 1, 1, 1),
            graspable=True,
            liftable=True,
        )


@pytest.mark.parametrize(
    ("shape", "size"), [("box", (0.1, 0.1)), ("cylinder", (0.1, -0.2)), ("cone", (0.1, 0.2))]
)
def test_bad_primitive_is_rejected(shape: str, size: tuple[float, ...]) -> None:
    with pytest.raises(ValueError, match=r"Shape"):
        Shape(shape, size, (0.0, 0.0, 0.1))  # type: ignore[arg-type]


def test_unknown_kind_lists_the_allowed_kinds() -> None:
    with pytest.raises(ValueError, match=r"mug.*soda_can"):
        get_object("mug")
