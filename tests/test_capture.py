"""Capture regions: membership and push distance, nesting, cache, bad input."""

from __future__ import annotations

import shutil
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from clutter_gym.model.objects import OBJECTS, Footprint
from planners.capture import (
    V_APERTURES,
    CaptureRegion,
    push_grasp_apertures,
    push_grasp_region,
    push_grasp_settings,
    sweep_region,
)
from planners.capture_build import SHIPPED_DIR, CaptureSettings, cache_name
from planners.hand2d import (
    GRASP_DEPTH,
    MAX_APERTURE,
    PALM_FRONT,
    PALM_SEAT,
    PROXIMAL_STRAIGHT,
    STRAIGHT_APERTURE,
    aperture_for_proximal,
    closure_for_aperture,
    default_aperture,
    proximal_for_aperture,
)

CAN = OBJECTS["soda_can"].footprint
APERTURE = 0.15


@pytest.fixture(scope="module")
def can_region(tmp_path_factory: pytest.TempPathFactory) -> CaptureRegion:
    return push_grasp_region(CAN, APERTURE, cache_dir=tmp_path_factory.mktemp("capture"))


def test_known_points(can_region: CaptureRegion) -> None:
    g = can_region.grasp_line
    poses = np.array(
        [
            [g + 0.2, 0.0, 0.0],  # on the centre line in front of the palm
            [g + 0.2, 0.4, 0.0],  # far to the side
            [g - 0.02, 0.0, 1.0],  # already between the fingers, GRASP_DEPTH past the line
            [g + 1.5, 0.0, 0.0],  # beyond D_max
            [0.05, 0.0, 0.0],  # inside the palm
        ]
    )
    inside, d = can_region.query(poses)
    assert inside.tolist() == [True, False, True, False, False]
    # Pushed until its centre is GRASP_DEPTH behind the fingertips, where closing holds it.
    assert d[0] == pytest.approx(0.2 + GRASP_DEPTH, abs=2e-3)
    assert d[2] == 0.0
    assert np.isinf(d[1])


def test_capture_region_shape(can_region: CaptureRegion) -> None:
    """Wider than the aperture ahead of the hand (objects rolling in off the fingertips) and
    needing a longer push at the sides than on the centre line."""
    ys = np.linspace(-0.15, 0.15, 301)
    poses = np.column_stack([np.full_like(ys, can_region.grasp_line + 0.3), ys, np.zeros_like(ys)])
    inside, d = can_region.query(poses)
    width = ys[inside].max() - ys[inside].min()
    assert APERTURE - CAN.min_width < width < APERTURE + 2 * CAN.radius
    assert d[inside].max() > d[150] + 0.05


def test_nested_in_push_distance(can_region: CaptureRegion) -> None:
    rng = np.random.default_rng(0)
    poses = np.column_stack(
        [rng.uniform(0.0, 1.3, 4000), rng.uniform(-0.15, 0.15, 4000), rng.uniform(-3, 3, 4000)]
    )
    previous = np.zeros(len(poses), dtype=bool)
    for distance in (0.0, 0.1, 0.3, 0.6, 1.0):
        now = can_region.contains(poses, distance)
        assert np.all(now[previous])
        previous = now
    assert previous.sum() > 100


def test_evolution_funnels_into_the_hand(can_region: CaptureRegion) -> None:
    g = can_region.grasp_line
    samples = np.array([[g + 0.1, 0.03, 0.0], [g + 0.1, -0.03, 0.0], [g + 0.05, 0.0, 0.0]])
    inside, d = can_region.query(samples)
    assert inside.all()
    stages = can_region.evolve(samples, float(d.max()), 4)
    assert stages.shape == (5, 1, 3, 3)
    final = stages[-1, 0]
    assert np.all(final[:, 0] <= g + 2e-3) and np.all(np.abs(final[:, 1]) <= APERTURE / 2)


def test_cache_round_trip_and_corruption(tmp_path: Path) -> None:
    coarse = CaptureSettings(y_resolution=0.01)
    first = push_grasp_region(CAN, 0.12, coarse, cache_dir=tmp_path)
    files = list(tmp_path.glob("push_grasp_circle_*.npz"))
    assert len(files) == 1
    mtime = files[0].stat().st_mtime_ns
    again = push_grasp_region(CAN, 0.12, coarse, cache_dir=tmp_path)
    assert files[0].stat().st_mtime_ns == mtime  # loaded, not rebuilt
    np.testing.assert_array_equal(first.s_req, again.s_req)
    files[0].write_bytes(b"not an npz")
    rebuilt = push_grasp_region(CAN, 0.12, coarse, cache_dir=tmp_path)
    np.testing.assert_array_equal(first.s_req, rebuilt.s_req)
    other = push_grasp_region(CAN, 0.13, coarse, cache_dir=tmp_path)  # another hash, another file
    assert len(list(tmp_path.glob("push_grasp_circle_*.npz"))) == 2
    assert other.aperture == 0.13
    assert not list(tmp_path.glob(".*tmp"))


def test_sweep_region(tmp_path: Path) -> None:
    bottle = OBJECTS["juice_bottle"].footprint
    region = sweep_region(bottle, cache_dir=tmp_path)
    lo, hi = region.span
    mid = 0.5 * (lo + hi)
    front = region.grid.x_start
    poses = np.array([[front + 0.1, mid, 0.0], [front + 0.1, hi + 0.1, 0.0], [front + 2, mid, 0]])
    inside, contact = region.query(poses, distance=0.5)
    assert inside.tolist() == [True, False, False]
    assert 0.0 < contact[0] < 0.2


def test_aperture_and_closure() -> None:
    assert 0.18 < STRAIGHT_APERTURE < 0.2 < 0.26 < MAX_APERTURE < 0.3
    for aperture in (0.1, STRAIGHT_APERTURE, 0.25, MAX_APERTURE):
        q = proximal_for_aperture(aperture)
        assert aperture_for_proximal(q) == pytest.approx(aperture)
        assert 0 < closure_for_aperture(aperture) < 1
    assert proximal_for_aperture(0.25) < PROXIMAL_STRAIGHT  # a V preshape: less curled
    assert closure_for_aperture(0.05) > closure_for_aperture(0.1) > closure_for_aperture(0.25)


@pytest.mark.parametrize("kind", ["soda_can", "juice_bottle", "poptart_box"])
def test_apertures_span_the_object_to_the_widest_v(kind: str) -> None:
    """§2.2.6: "a changes between the maximum hand aperture and the minimum hand aperture for
    the object": narrowest first, from the object's width plus a fingertip to the widest V."""
    footprint = OBJECTS[kind].footprint
    apertures = push_grasp_apertures(footprint)
    assert list(apertures) == sorted(apertures)
    assert apertures[0] == pytest.approx(footprint.min_width + 0.02)
    assert apertures[-1] == MAX_APERTURE and STRAIGHT_APERTURE in apertures
    assert max(np.diff(apertures)) <= 0.06 and min(np.diff(apertures)) >= 0.015


def test_v_preshapes_capture_wider_spreads(tmp_path: Path) -> None:
    """The V preshape captures the can farther off the hand's axis than the straight one (the
    sigma4 spread), and its region still ends between the fingertips."""
    straight = push_grasp_region(CAN, STRAIGHT_APERTURE, cache_dir=tmp_path)
    widest = push_grasp_region(CAN, MAX_APERTURE, cache_dir=tmp_path)
    assert widest.lateral_reach > straight.lateral_reach + 0.03
    assert widest.lateral_reach < MAX_APERTURE / 2 + CAN.radius
    ahead = widest.grasp_line + 0.3
    off_axis = np.array([[ahead, straight.lateral_reach + 0.02, 0.0]])
    assert widest.query(off_axis)[0].all() and not straight.query(off_axis)[0].any()


def test_a_v_preshape_counts_a_box_captured_only_at_the_palm() -> None:
    """Pushed the distance the V region asks, a box rests within PALM_SEAT of the palm under
    every (mu_c, c), where closing holds it; the pose is one validate-capture saw topple when
    the region counted it captured on the splayed links 2 cm ahead of the palm."""
    box = OBJECTS["poptart_box"].footprint
    hx, hy = box.half_extents
    region = push_grasp_region(box, V_APERTURES[0])
    rng = np.random.default_rng(1)
    poses = np.column_stack(
        [rng.uniform(0.1, 0.35, 400), rng.uniform(-0.15, 0.15, 400), rng.uniform(0, np.pi, 400)]
    )
    inside, need = region.query(poses)
    toppled = np.array([0.1833, -0.04, np.pi / 3])
    tested = [(p, d) for p, d in zip(poses[inside][:6], need[inside][:6], strict=True)]
    toppled_inside, toppled_need = region.query(toppled[None])
    if toppled_inside[0]:
        tested.append((toppled, toppled_need[0]))
    assert len(tested) >= 6
    for pose, distance in tested:
        end = region.evolve(pose[None], float(distance), 1)[-1, :, 0]
        back = end[:, 0] - hx * np.abs(np.cos(end[:, 2])) - hy * np.abs(np.sin(end[:, 2]))
        assert back.max() <= PALM_FRONT + PALM_SEAT + region.step, (pose, back.max())


@pytest.mark.parametrize(
    ("footprint", "aperture", "match"),
    [
        (Footprint("circle", radius=0.0), 0.1, "positive"),
        (Footprint("circle", radius=-0.01), 0.1, "positive"),
        (Footprint("box", half_extents=(0.1, float("nan"))), 0.1, "positive"),
        (Footprint("circle", radius=0.14), 0.15, "maximum aperture"),
        (CAN, 0.05, "aperture"),
        (CAN, 0.3, "aperture"),  # wider than the widest V preshape
        (CAN, float("nan"), "aperture"),
    ],
)
def test_bad_inputs(footprint: Footprint, aperture: float, match: str, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=match):
        push_grasp_region(footprint, aperture, cache_dir=tmp_path)


def test_bad_queries(can_region: CaptureRegion) -> None:
    with pytest.raises(ValueError, match="NaN"):
        can_region.query(np.array([[0.3, np.nan, 0.0]]))
    with pytest.raises(ValueError, match="shape"):
        can_region.query(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="push_distance"):
        can_region.contains(np.zeros((1, 3)), 2.0)
    with pytest.raises(ValueError, match="box_mus"):
        CaptureSettings(box_mus=(0.0,))


def test_an_object_the_arm_cannot_lift_gets_no_v_preshape() -> None:
    """A V preshape's capture rests on the closing holding the box (checked by lifting it), so
    the 5 kg dumbbell is push-grasped with the straight preshapes only."""
    dumbbell = OBJECTS["dumbbell"]
    assert not dumbbell.liftable
    apertures = push_grasp_apertures(dumbbell.footprint, liftable=False)
    assert max(apertures) == STRAIGHT_APERTURE
    assert set(apertures) < set(push_grasp_apertures(dumbbell.footprint))


def test_shipped_regions_cover_the_action_library_and_are_current(tmp_path: Path) -> None:
    """Every region the planner, the primitive env and validate-capture use by default ships
    with the package under its current key (a change to the simulation or settings would miss
    it and rebuild for minutes), and a shipped file is what a fresh build gives."""
    for spec in OBJECTS.values():
        footprint = spec.footprint
        wanted = [("sweep", STRAIGHT_APERTURE, CaptureSettings())]
        if spec.graspable:
            searched = {
                *push_grasp_apertures(footprint, spec.liftable),
                default_aperture(footprint),
            }
            grid = push_grasp_settings(footprint)
            wanted += [("push_grasp", a, grid) for a in sorted(searched)]
        for kind, aperture, settings in wanted:
            assert (SHIPPED_DIR / cache_name(kind, footprint, aperture, settings)).exists(), (
                f"{spec.kind} {kind} at {aperture}: run python -m planners.capture"
            )
    can = OBJECTS["soda_can"].footprint
    shipped = push_grasp_region(can, default_aperture(can))
    fresh = push_grasp_region(can, default_aperture(can), cache_dir=tmp_path)
    # To rounding: the compiled kernels (`planners.push_kernels`) may round the last bit
    # differently from the build that shipped the file (a push distance that differs by 1e-15).
    np.testing.assert_allclose(shipped.s_req, fresh.s_req, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shipped.s_contact, fresh.s_contact, rtol=0, atol=1e-12)


def test_a_box_a_few_degrees_off_end_on_is_captured_by_the_narrow_preshape() -> None:
    """The poptart box end-on in the 0.111 m preshape: the band of captured lateral offsets at
    0 deg is about 5 cm wide, so a sigma2 cloud (+-1 cm, +-4 deg) fits it. A pose counts only
    where the four grid nodes around it do: with 15 deg between nodes the bands at -15, 0 and
    +15 deg had to hold it at once, and they overlap over about 1 cm."""
    poptart = OBJECTS["poptart_box"].footprint
    region = push_grasp_region(poptart, 0.111)
    cloud = np.array(
        [
            (region.grid.x_start, y, np.radians(theta))
            for y in (-0.01, 0.0, 0.01)
            for theta in (-4.0, 0.0, 4.0)
        ]
    )
    assert region.query(cloud)[0].all()
    assert not region.query(cloud + [0.0, 0.04, 0.0])[0].all()  # the band has edges


def _truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _flip_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


def _directory(path: Path) -> None:
    path.unlink()
    path.mkdir()


def _nan_arrays(path: Path) -> None:
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["s_req"] = np.full_like(arrays["s_req"], np.nan)
    np.savez(path, **arrays)


CORRUPTIONS = {
    "truncated": _truncate,
    "flipped byte": _flip_byte,
    "a directory": _directory,
    "NaN arrays": _nan_arrays,
}


@pytest.mark.parametrize("corrupt", CORRUPTIONS.values(), ids=CORRUPTIONS.keys())
def test_a_corrupt_cache_file_is_rebuilt_with_a_warning(
    tmp_path: Path, corrupt: Callable[[Path], None]
) -> None:
    coarse = CaptureSettings(y_resolution=0.01)
    first = push_grasp_region(CAN, 0.12, coarse, cache_dir=tmp_path)
    (path,) = tmp_path.glob("push_grasp_circle_*.npz")
    corrupt(path)
    with pytest.warns(UserWarning, match="capture region cache .* unusable"):
        rebuilt = push_grasp_region(CAN, 0.12, coarse, cache_dir=tmp_path)
    np.testing.assert_array_equal(first.s_req, rebuilt.s_req)


@pytest.mark.parametrize("corrupt", CORRUPTIONS.values(), ids=CORRUPTIONS.keys())
def test_a_corrupt_user_copy_never_hides_the_shipped_region(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, corrupt: Callable[[Path], None]
) -> None:
    can = OBJECTS["soda_can"].footprint
    name = cache_name("push_grasp", can, default_aperture(can), CaptureSettings())
    user = tmp_path / "clutter_gym" / "capture"
    user.mkdir(parents=True)
    shutil.copy(SHIPPED_DIR / name, user / name)
    corrupt(user / name)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped copy is used: nothing to warn about
        region = push_grasp_region(can, default_aperture(can))
    with np.load(SHIPPED_DIR / name) as shipped:
        np.testing.assert_array_equal(region.s_req, shipped["s_req"])


def test_an_unwritable_cache_still_gives_the_region(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("a regular file where the cache directory should be")
    coarse = CaptureSettings(y_resolution=0.01)
    with pytest.warns(UserWarning, match="could not be written"):
        region = push_grasp_region(CAN, 0.12, coarse, cache_dir=blocker / "capture")
    assert np.isfinite(region.s_req).any()


@pytest.mark.parametrize(
    ("kind", "action"),
    [
        ("soda_can", "push"),
        ("poptart_box", "push"),
        ("poptart_box", "sweep"),
        ("large_box", "sweep"),
    ],
)
def test_a_lookup_reads_the_worst_of_the_four_nodes_around_a_pose(kind: str, action: str) -> None:
    """Push distances read at a pose are the most conservative of the grid nodes around it:
    the largest need and earliest escape of the two lateral neighbours at the two orientation
    neighbours (a box's orientation wraps at pi; a cylinder has one). Checked against the nodes
    read one by one, on random poses across the region and beyond its edges."""
    footprint = OBJECTS[kind].footprint
    rng = np.random.default_rng(3)
    if action == "push":
        region: Any = push_grasp_region(footprint, default_aperture(footprint))
        need, early = region.s_req, region.s_contact
    else:
        region = sweep_region(footprint)
        need, early = region.s_contact, region.s_escape
    grid, (ny, nt) = region.grid, need.shape
    ys = grid.y0 + grid.dy * np.arange(ny)
    poses = np.column_stack(
        [
            grid.x_start + rng.uniform(-0.05, 0.3, 500),
            rng.uniform(ys[0] - 0.02, ys[-1] + 0.02, 500),
            rng.uniform(-2 * np.pi, 2 * np.pi, 500),
        ]
    )
    if action == "push":
        inside, distance = region.query(poses)
    else:
        inside, distance = region.query(poses, distance=region.d_max)
    for pose, kept, d in zip(poses, inside, distance, strict=True):
        i = int(np.floor((pose[1] - grid.y0) / grid.dy))
        if not 0 <= i <= ny - 2:
            assert not kept
            continue
        if grid.theta_period:
            j = int(np.floor(np.mod(pose[2], np.pi) / (np.pi / nt))) % nt
            columns = [j, (j + 1) % nt]
        else:
            columns = [0]
        worst = max(need[r, c] for r in (i, i + 1) for c in columns)
        first = min(early[r, c] for r in (i, i + 1) for c in columns)
        shift = pose[0] - grid.x_start
        if action == "push":
            d_need = max(worst - (grid.x_start - pose[0]), 0.0)
            expected = (
                np.isfinite(worst) and pose[0] >= grid.x_start - first and d_need <= region.d_max
            )
            assert kept == expected
            assert d == (d_need if expected else np.inf)
        else:
            contact, escape = worst + shift, first + shift
            expected = 0 <= contact <= region.d_max < escape
            assert kept == expected
            assert d == (contact if expected else np.inf)
