"""Scene format, validation, generator and the committed paper suite."""

from __future__ import annotations

import copy
import dataclasses
import itertools
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clutter_gym.model import scene as scene_module
from clutter_gym.model.noise import NOISE_LEVELS
from clutter_gym.model.objects import footprint_gap
from clutter_gym.model.scene import (
    HIGH_GAP,
    LEVELS,
    MAX_OBJECTS,
    MEDIUM_MIN_GAP,
    PAPER_SUITE_DIR,
    PAPER_SUITE_SEED,
    GoalSpec,
    ObjectPlacement,
    Scene,
    generate_scene,
    load_scene,
    paper_suite,
    save_scene,
    scene_from_dict,
    scene_to_dict,
    write_paper_suite,
)
from clutter_gym.model.world import SHELF, SURFACES, TABLE, get_surface
from tests.helpers import two_objects

SURFACE_NAMES = sorted(SURFACES)


def _valid() -> dict[str, Any]:
    """Two objects and a poptart box, every optional field left to its default."""
    scene = two_objects()
    del scene["noise"]
    scene["objects"].append({"name": "tart", "kind": "poptart_box", "pose": [0.87, -0.05, 0.3]})
    return scene


def _gaps(scene: Scene) -> dict[tuple[int, int], float]:
    objs = scene.objects
    return {
        (i, j): footprint_gap(
            objs[i].spec.footprint, objs[i].pose, objs[j].spec.footprint, objs[j].pose
        )
        for i, j in itertools.combinations(range(len(objs)), 2)
    }


def _set(path: tuple[Any, ...], value: Any) -> Callable[[dict[str, Any]], None]:
    def mutate(d: dict[str, Any]) -> None:
        target = d
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return mutate


def _delete(path: tuple[Any, ...]) -> Callable[[dict[str, Any]], None]:
    def mutate(d: dict[str, Any]) -> None:
        target = d
        for key in path[:-1]:
            target = target[key]
        del target[path[-1]]

    return mutate


def test_docstring_example_is_a_valid_scene() -> None:
    doc = scene_module.__doc__ or ""
    example = doc[doc.index("::") + 2 : doc.index("\n\n* ")]
    scene = scene_from_dict(json.loads(example))
    assert [o.name for o in scene.objects] == ["can", "box"]


def test_defaults_come_from_the_surface() -> None:
    scene = scene_from_dict(_valid())
    assert scene.goal == GoalSpec("can", TABLE.default_goal_region, "lift")
    assert scene.noise == "sigma2"
    assert scene.noise_sigma == NOISE_LEVELS["sigma2"]
    assert scene.goal_placement.kind == "soda_can"


def test_noise_levels_match_the_paper() -> None:
    assert NOISE_LEVELS["sigma1"] == (0.0, 0.0)
    assert NOISE_LEVELS["sigma4"] == (0.06, 0.785)
    custom = dataclasses.replace(scene_from_dict(_valid()), noise=(0.01, 0.1))
    assert custom.noise_sigma == (0.01, 0.1)


@pytest.mark.parametrize("noise", ["sigma3", {"xy": 0.01, "theta": 0.1}])
def test_dict_round_trip(noise: Any) -> None:
    d = _valid()
    d["noise"] = noise
    d["goal"]["region"] = {"x": [0.5, 0.9], "y": [-0.5, 0.0]}
    scene = scene_from_dict(d)
    assert scene_from_dict(scene_to_dict(scene)) == scene
    assert scene_from_dict(json.loads(json.dumps(scene_to_dict(scene)))) == scene


def test_file_round_trip_is_atomic(tmp_path: Path) -> None:
    scene = scene_from_dict(_valid())
    path = tmp_path / "sub" / "scene.json"
    save_scene(scene, path)
    save_scene(dataclasses.replace(scene, noise="sigma4"), path)
    assert load_scene(path) == dataclasses.replace(scene, noise="sigma4")
    assert load_scene(str(path)).noise == "sigma4"
    assert sorted(p.name for p in path.parent.iterdir()) == ["scene.json"]
    assert load_scene(_valid()) == scene


def test_file_errors_name_the_file_and_field(tmp_path: Path) -> None:
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    with pytest.raises(ValueError, match=r"broken.json: not valid JSON"):
        load_scene(broken)
    d = _valid()
    d["objects"][0]["kind"] = "mug"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"bad.json: objects\[0\].kind"):
        load_scene(bad)


BAD_INPUTS = [
    ("format", _delete(("format",))),
    ("format", _set(("format",), "clutter-gym-scene/2")),
    ("colour", _set(("colour",), "red")),
    ("surface", _set(("surface",), "desk")),
    ("surface", _set(("surface",), 3)),
    ("objects", _set(("objects",), {"can": 1})),
    ("objects", _set(("objects",), [])),
    (
        "objects",
        _set(
            ("objects",),
            [
                {"name": f"c{i}", "kind": "soda_can", "pose": [0.90, -0.2, 0]}
                for i in range(MAX_OBJECTS + 1)
            ],
        ),
    ),
    ("objects[1]", _set(("objects", 1), "box")),
    ("objects[1].pose", _delete(("objects", 1, "pose"))),
    ("objects[1].color", _set(("objects", 1, "color"), "red")),
    ("objects[1].kind", _set(("objects", 1, "kind"), "mug")),
    ("objects[1].kind", _set(("objects", 1, "kind"), 5)),
    ("objects[1].name", _set(("objects", 1, "name"), "can")),
    ("objects[1].name", _set(("objects", 1, "name"), "")),
    ("objects[1].name", _set(("objects", 1, "name"), None)),
    ("objects[1].pose", _set(("objects", 1, "pose"), [0.95, -0.45])),
    ("objects[1].pose", _set(("objects", 1, "pose"), "0.95 -0.45 0")),
    ("objects[1].pose[0]", _set(("objects", 1, "pose", 0), math.nan)),
    ("objects[1].pose[1]", _set(("objects", 1, "pose", 1), -math.inf)),
    ("objects[1].pose[2]", _set(("objects", 1, "pose", 2), True)),
    ("objects[1].pose[2]", _set(("objects", 1, "pose", 2), "0")),
    ("goal", _set(("goal",), "can")),
    ("goal.object", _delete(("goal", "object"))),
    ("goal.object", _set(("goal", "object"), "ghost")),
    ("goal.object", _set(("goal", "object"), "box")),
    ("goal.target", _set(("goal", "target"), "shelf")),
    ("goal.success", _set(("goal", "success"), "throw")),
    ("goal.region.x", _set(("goal", "region"), {"x": [0.9, 0.5], "y": [-0.5, 0.0]})),
    ("goal.region.y", _set(("goal", "region"), {"x": [0.5, 0.9]})),
    ("goal.region.y[1]", _set(("goal", "region"), {"x": [0.5, 0.9], "y": [0.0, math.nan]})),
    ("goal.region.x", _set(("goal", "region"), {"x": [0.5], "y": [0.0, 0.1]})),
    ("noise", _set(("noise",), "sigma9")),
    ("noise", _set(("noise",), 0.01)),
    ("noise.xy", _set(("noise",), {"xy": -0.01, "theta": 0.1})),
    ("noise.theta", _set(("noise",), {"xy": 0.01})),
    ("noise.theta", _set(("noise",), {"xy": 0.01, "theta": math.inf})),
    ("noise.sigma", _set(("noise",), {"xy": 0.01, "theta": 0.1, "sigma": 1})),
]


@pytest.mark.parametrize(("field", "mutate"), BAD_INPUTS, ids=[f for f, _ in BAD_INPUTS])
def test_bad_input_names_the_field(field: str, mutate: Callable[[dict[str, Any]], None]) -> None:
    d = _valid()
    mutate(d)
    with pytest.raises(ValueError) as err:
        scene_from_dict(d)
    assert str(err.value).startswith(f"{field}:"), str(err.value)


def test_scene_must_be_a_mapping() -> None:
    with pytest.raises(ValueError, match=r"^scene:"):
        scene_from_dict([1, 2])  # type: ignore[arg-type]


def test_unliftable_goal_needs_region_success() -> None:
    d = _valid()
    d["objects"][1] = {"name": "bell", "kind": "dumbbell", "pose": [0.76, -0.45, 0.0]}
    d["goal"]["object"] = "bell"
    with pytest.raises(ValueError, match=r"^goal.object:.*liftable"):
        scene_from_dict(d)
    d["goal"]["success"] = "region"
    # The table's default region is its whole top, which the dumbbell already stands in.
    d["goal"]["region"] = {"x": [1.0, 1.19], "y": [-1.125, 0.725]}
    assert scene_from_dict(d).goal.success == "region"


def test_direct_construction_is_validated() -> None:
    scene = scene_from_dict(_valid())
    with pytest.raises(ValueError, match=r"^noise:"):
        dataclasses.replace(scene, noise=(0.1,))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^goal.region:"):
        dataclasses.replace(scene, goal=GoalSpec("can", ((0.5, 0.9),), "lift"))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^objects\[0\].pose"):
        dataclasses.replace(
            scene, objects=(ObjectPlacement("can", "soda_can", (0.9, math.nan, 0.0)),)
        )


def test_interpenetrating_objects_are_rejected() -> None:
    d = _valid()
    d["objects"][2]["pose"] = [0.72, -0.25, 0.0]  # the poptart box cuts into the can
    with pytest.raises(ValueError, match=r"^objects\[2\].pose: 'tart'.*'can'.*mm") as err:
        scene_from_dict(d)
    assert "interpenetrates" in str(err.value)


def test_touching_objects_are_accepted() -> None:
    d = _valid()
    d["objects"][2] = {"name": "can2", "kind": "soda_can", "pose": [0.786, -0.2, 0.0]}
    assert len(scene_from_dict(d).objects) == 3
    d["objects"][2]["pose"] = [0.785, -0.2, 0.0]
    with pytest.raises(ValueError, match=r"interpenetrates"):
        scene_from_dict(d)


def test_can_between_dumbbell_heads_collides() -> None:
    d = _valid()
    d["objects"][1] = {"name": "bell", "kind": "dumbbell", "pose": [0.72, -0.2, 0.0]}
    with pytest.raises(ValueError, match=r"^objects\[1\].pose: 'bell'.*'can'"):
        scene_from_dict(d)


@pytest.mark.parametrize(
    ("surface", "pose"),
    [
        ("table", [1.36, -0.2, 0.0]),
        ("table", [0.90, -1.10, 0.0]),
        ("shelf", [0.87, -0.2, 0.0]),  # through the back wall
        ("shelf", [0.70, 0.23, 0.0]),  # through the left wall
        ("shelf", [0.49, -0.2, 0.0]),  # hangs off the front edge
    ],
)
def test_off_surface_objects_are_rejected(surface: str, pose: list[float]) -> None:
    d = _valid()
    d["surface"] = surface
    d["objects"] = [{"name": "can", "kind": "soda_can", "pose": pose}]
    with pytest.raises(ValueError, match=r"^objects\[0\].pose: 'can'.*leaves the " + surface):
        scene_from_dict(d)


def test_footprint_check_uses_the_yaw() -> None:
    d = _valid()
    d["surface"] = "shelf"
    d["objects"] = [
        {"name": "can", "kind": "soda_can", "pose": [0.75, 0.1, 0.0]},
        {"name": "box", "kind": "large_box", "pose": [0.68, -0.45, math.pi / 2]},
    ]
    assert scene_from_dict(d).surface == "shelf"
    d["objects"][1]["pose"][2] = 0.0  # 0.36 m deep fits the 0.40 m deep shelf
    assert scene_from_dict(d).surface == "shelf"
    d["objects"][1]["pose"][2] = math.pi / 4
    with pytest.raises(ValueError, match=r"leaves the shelf"):
        scene_from_dict(d)


def test_surfaces() -> None:
    for surface in (TABLE, SHELF):
        assert get_surface(surface.name) is surface
        top = max(
            b.centre[2] + b.half_extents[2] for b in surface.boxes if b.centre[2] < surface.top_z
        )
        assert top == pytest.approx(surface.top_z)
        x_min, x_max, y_min, y_max = surface.bounds
        (wx0, wx1), (wy0, wy1) = surface.workspace
        assert x_min <= wx0 < wx1 <= x_max and y_min <= wy0 < wy1 <= y_max
    assert TABLE.success == "lift" and SHELF.success == "region"
    assert SHELF.default_goal_region == ((0.48, 0.58), (-0.45, 0.05))
    with pytest.raises(ValueError, match=r"desk.*shelf, table"):
        get_surface("desk")


def test_generator_is_deterministic() -> None:
    for level in LEVELS:
        assert generate_scene(level, 7) == generate_scene(level, 7)
        assert generate_scene(level, 7) != generate_scene(level, 8)


def test_generator_rejects_unknown_arguments() -> None:
    with pytest.raises(ValueError, match=r"^level:"):
        generate_scene("extreme", 0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^surface:"):
        generate_scene("none", 0, surface="desk")
    with pytest.raises(ValueError, match=r"^noise:"):
        generate_scene("none", 0, noise="loud")


@pytest.mark.parametrize("surface", SURFACE_NAMES)
@pytest.mark.parametrize("level", LEVELS)
def test_generated_scenes_have_the_level_properties(level: str, surface: str) -> None:
    world = SURFACES[surface]
    counts = {"none": {1}, "medium": {2, 3}, "high": {3, 4}}[level]
    seen_counts = set()
    for seed in range(50):
        scene = generate_scene(level, seed, surface=surface)  # type: ignore[arg-type]
        seen_counts.add(len(scene.objects))
        goal = scene.goal_placement
        assert goal is scene.objects[0] and goal.kind in {"soda_can", "juice_bottle", "poptart_box"}
        assert (
            scene.goal.success == world.success and scene.goal.region == world.default_goal_region
        )
        for obj in scene.objects:
            (wx0, wx1), (wy0, wy1) = world.workspace
            x, y, _ = obj.pose
            assert wx0 <= x <= wx1 and wy0 <= y <= wy1
        if world.success == "region":
            (rx0, rx1), (ry0, ry1) = world.default_goal_region
            x0, x1, y0, y1 = goal.spec.footprint.aabb(goal.pose)
            assert x0 >= rx1 or x1 <= rx0 or y0 >= ry1 or y1 <= ry0
        gaps = _gaps(scene)
        if level == "medium":
            assert min(gaps.values()) >= MEDIUM_MIN_GAP
        if level == "high":
            assert min(gaps.values()) >= HIGH_GAP[0]
            for k in range(len(scene.objects)):
                nearest = min(g for pair, g in gaps.items() if k in pair)
                assert nearest <= HIGH_GAP[1]
    assert seen_counts == counts


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    level=st.sampled_from(LEVELS),
    surface=st.sampled_from(SURFACE_NAMES),
)
def test_generated_scenes_round_trip_through_json(seed: int, level: str, surface: str) -> None:
    scene = generate_scene(level, seed, surface=surface)  # type: ignore[arg-type]
    assert load_scene(json.loads(json.dumps(scene_to_dict(scene)))) == scene


@pytest.mark.parametrize("surface", SURFACE_NAMES)
@pytest.mark.parametrize("level", LEVELS)
def test_paper_suite_matches_the_generator(level: str, surface: str) -> None:
    suite = paper_suite(level, surface=surface)  # type: ignore[arg-type]
    expected = [generate_scene(level, PAPER_SUITE_SEED + i, surface=surface) for i in range(10)]  # type: ignore[arg-type]
    assert suite == expected


def test_paper_suite_files_are_reproducible(tmp_path: Path) -> None:
    written = write_paper_suite(tmp_path)
    assert len(written) == len(SURFACES) * len(LEVELS) * 10
    for path in written:
        committed = PAPER_SUITE_DIR / path.relative_to(tmp_path)
        assert committed.read_text() == path.read_text(), committed


def test_paper_suite_scenes_can_change_noise() -> None:
    scene = copy.deepcopy(paper_suite("high")[0])
    assert dataclasses.replace(scene, noise="sigma4").noise_sigma == NOISE_LEVELS["sigma4"]


FIGURES_OUTSIDE_WORKSPACE = {("fig16_shelf_can_behind_box", "red_can")}
"""Placements a figure needs outside its surface's workspace, each said in its description: the
can behind a 0.26 m box cannot stand inside the shelf's (0.40 m deep) workspace."""


@pytest.mark.parametrize(
    "path", sorted((scene_module.SCENES_DIR / "figures").glob("*.json")), ids=lambda p: p.stem
)
def test_figure_scenes_say_which_figure_they_follow_and_stay_in_the_workspace(path: Path) -> None:
    scene = load_scene(path)
    figure = path.stem.split("_")[0].removeprefix("fig")
    assert f"Fig. {figure}" in scene.description or f"Figs. {figure}" in scene.description
    (wx0, wx1), (wy0, wy1) = get_surface(scene.surface).workspace
    outside = {
        (path.stem, o.name)
        for o in scene.objects
        if not (wx0 <= o.pose[0] <= wx1 and wy0 <= o.pose[1] <= wy1)
    }
    assert outside <= FIGURES_OUTSIDE_WORKSPACE
    if outside:
        assert "workspace" in scene.description
