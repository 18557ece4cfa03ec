"""The physics validation harness of capture regions: grid, frames, trials, resume."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents import validate_capture as vc
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.model.objects import get_object
from planners.hand2d import default_aperture


def test_grid_covers_at_least_the_requested_trials() -> None:
    can, box = get_object("soda_can"), get_object("poptart_box")
    assert len(vc.grid(can, 1000)) >= 1000
    assert np.all(vc.grid(can, 50)[:, 2] == 0.0)
    angles = np.unique(vc.grid(box, 60)[:, 2])
    assert len(angles) == vc.BOX_ANGLES and angles.max() < math.pi
    with pytest.raises(ValueError, match="--trials"):
        vc.grid(can, 0)


def test_unknown_or_unliftable_objects_are_rejected() -> None:
    assert vc.resolve_kind("can") == "soda_can"
    with pytest.raises(ValueError, match=r"allowed: .*bottle"):
        vc.resolve_kind("teapot")
    with pytest.raises(ValueError, match="large_box"):
        vc.resolve_kind("large_box")


@pytest.mark.parametrize("rotation", [0.0, 45.0])
def test_push_frame_maps_to_the_world_along_the_heading(rotation: float) -> None:
    spec = get_object("soda_can")
    setup = vc.plan_push(spec, default_aperture(spec.footprint), rotation)
    x, y, theta = vc.world_pose(setup, (0.3, 0.0, 0.1))
    bx, by, _ = setup.hand_base
    assert math.atan2(y - by, x - bx) == pytest.approx(math.radians(rotation))
    assert math.hypot(x - bx, y - by) == pytest.approx(0.3)
    assert theta == pytest.approx(math.radians(rotation) + 0.1)
    assert setup.action.shape == (vc.WAYPOINTS, 9)


def test_a_centred_can_is_push_grasped_and_a_far_one_is_not() -> None:
    spec = get_object("soda_can")
    setup = vc.plan_push(spec, default_aperture(spec.footprint), 0.0)
    env = ClutterRetrieveEnv()
    assert vc.run_trial(env, "soda_can", setup, (0.25, 0.0, 0.0)) == "success"
    assert vc.run_trial(env, "soda_can", setup, (0.30, 0.18, 0.0)).startswith("failure")
    env.close()


def test_summary_counts_failures_inside_and_tightness() -> None:
    trials = [
        vc.Trial(0, 0.0, (0.2, 0.0, 0.0), True, "success"),
        vc.Trial(1, 0.0, (0.3, 0.1, 0.0), False, "success"),
        vc.Trial(2, 0.0, (0.3, 0.2, 0.0), False, "failure: not held"),
        vc.Trial(3, 0.0, (0.1, 0.0, 0.0), True, "skipped: overlaps"),
    ]
    summary = vc.summarize(trials)
    assert summary["trials"] == 3 and summary["skipped"] == 1
    assert summary["failures_inside"] == 0 and summary["tightness"] == pytest.approx(0.5)
