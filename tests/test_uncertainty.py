"""Uncertainty samples, planar frames and Volumes: the geometry Rearrange reasons with."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clutter_gym.model.collision import Volume
from clutter_gym.model.objects import get_object
from clutter_gym.model.transforms import Frame2D
from clutter_gym.model.world import TABLE
from planners.uncertainty import MASS_DRAWS, SAMPLE_COUNTS, beliefs, sample_count, sample_poses

Z = TABLE.top_z


def test_sample_counts_follow_the_paper() -> None:
    assert sample_count((0.0, 0.0)) == 1
    assert sample_count((0.005, 0.034)) == SAMPLE_COUNTS["sigma2"] == 30
    assert sample_count((0.02, 0.175)) == 50
    assert sample_count((0.02, 0.05)) == 20  # Fig. 2
    assert sample_count((0.011, 0.3)) == 50  # not a paper level: the largest count


def test_samples_start_at_the_detection_and_follow_sigma() -> None:
    rng = np.random.default_rng(0)
    samples = sample_poses((1.0, -0.2, 0.3), (0.02, 0.1), 4000, rng)
    assert np.allclose(samples[0], (1.0, -0.2, 0.3))
    assert samples[1:, 0].std() == pytest.approx(0.02, rel=0.05)
    assert samples[1:, 2].std() == pytest.approx(0.1, rel=0.05)
    assert np.all(np.abs(samples[:, 2]) <= math.pi)


def test_mass_draws_follow_the_belief_and_repeat() -> None:
    """`ObjectBelief.mass_draws`: N(q_hat, Q) of the belief's own sigma, the same draws on
    every call and for a new belief of the same detection (plans stay deterministic); without
    noise only the detection."""
    can = get_object("soda_can")
    detected = (0.7, -0.1, 3.1)
    noisy, again = (
        beliefs([("can", can, detected)], (0.02, 0.1), 20, np.random.default_rng(seed))[0]
        for seed in (0, 1)
    )
    draws = noisy.mass_draws
    assert draws.shape == (MASS_DRAWS, 3) and np.array_equal(draws, again.mass_draws)
    assert draws[:, :2].mean(0) == pytest.approx(detected[:2], abs=0.003)  # 5 s.e.
    assert draws[:, :2].std(0) == pytest.approx([0.02, 0.02], rel=0.1)
    turn = np.angle(np.exp(1j * (draws[:, 2] - detected[2])))
    assert turn.std() == pytest.approx(0.1, rel=0.1) and np.all(np.abs(draws[:, 2]) <= math.pi)
    exact = beliefs([("can", can, detected)], (0.0, 0.0), 1, np.random.default_rng(0))[0]
    assert np.allclose(exact.mass_draws, [detected], rtol=0, atol=1e-12)


@pytest.mark.parametrize("n", [0, -3])
def test_sample_count_must_be_positive(n: int) -> None:
    with pytest.raises(ValueError, match="samples"):
        sample_poses((1.0, 0.0, 0.0), (0.01, 0.1), n, np.random.default_rng(0))


@settings(max_examples=100, deadline=None)
@given(
    st.floats(-1, 1),
    st.floats(-1, 1),
    st.floats(-3, 3),
    st.sampled_from([1, -1]),
    st.floats(-2, 2),
    st.floats(-2, 2),
    st.floats(-3, 3),
)
def test_frames_round_trip(
    ox: float, oy: float, angle: float, hand: int, x: float, y: float, theta: float
) -> None:
    frame = Frame2D((ox, oy), angle, hand)
    pose = np.array([[x, y, theta]])
    back = frame.to_world(frame.to_frame(pose))
    assert np.allclose(back[:, :2], pose[:, :2], atol=1e-9)
    assert math.isclose(math.remainder(back[0, 2] - theta, 2 * math.pi), 0.0, abs_tol=1e-9)


def test_left_handed_frame_mirrors() -> None:
    frame = Frame2D((0.0, 0.0), 0.0, -1)
    assert np.allclose(frame.to_frame(np.array([[0.0, 1.0, 0.3]])), [[0.0, -1.0, -0.3]])


def test_volume_of_object_covers_every_sample() -> None:
    can = get_object("soda_can")
    poses = np.array([[0.9, -0.2, 0.0], [1.0, -0.2, 0.0]])
    volume = Volume.of_object("can", can, poses, Z)
    assert volume.labels == {"can"} and len(volume) == 2
    # A second can probes the union: it overlaps either sample, not a pose 0.2 m away.
    for x, hit in ((0.9, True), (1.0, True), (1.2, False), (0.7, False)):
        probe = Volume.of_object("probe", can, np.array([[x, -0.2, 0.0]]), Z)
        assert probe.intersects(volume) == hit


def test_penetrated_names_only_the_objects_touched() -> None:
    box, can = get_object("large_box"), get_object("soda_can")
    sweep = Volume.of_object("box", box, np.array([[0.9, -0.2, 0.0], [0.9, 0.0, 0.0]]), Z)
    others = Volume.of_object("near", can, np.array([[0.9, 0.15, 0.0]]), Z) + Volume.of_object(
        "far", can, np.array([[0.9, 0.6, 0.0]]), Z
    )
    assert sweep.penetrated(others) == {"near"}
    assert Volume().penetrated(others) == set()


@settings(max_examples=40, deadline=None)
@given(st.floats(0.7, 1.2), st.floats(-0.5, 0.2), st.floats(0.0, 0.1), st.floats(0.0, 0.5))
def test_hull_and_floor_map_are_conservative(x: float, y: float, sxy: float, st_: float) -> None:
    """Whatever the exact union of samples hits, its hull hits too; where the floor map says
    a column is clear, the exact volume is clear."""
    rng = np.random.default_rng(0)
    box = get_object("poptart_box")
    samples = sample_poses((x, y, 0.3), (sxy, st_), 20, rng)
    volume = Volume.of_object("box", box, samples, Z)
    hull = volume.hulled()
    probes = rng.uniform([x - 0.25, y - 0.25], [x + 0.25, y + 0.25], (30, 2))
    can = get_object("soda_can")
    for px, py in probes:
        probe = Volume.of_object("can", can, np.array([[px, py, 0.0]]), Z)
        exact = probe.intersects(volume)
        if exact:
            assert probe.intersects(hull)
        r = can.footprint.radius
        lowest = volume.lowest_over(np.array([[px - r, px + r, py - r, py + r]]))[0]
        if lowest > Z + can.height:
            assert not exact
