"""Hostile scene input: every bad value is one ValueError that names its field."""

from __future__ import annotations

import copy
import dataclasses
import math
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clutter_gym.model.scene import (
    LEVELS,
    ObjectPlacement,
    Scene,
    generate_scene,
    load_scene,
    resolve_noise,
    scene_from_dict,
)
from clutter_gym.model.world import SURFACES
from tests.helpers import two_objects

FIELD_PATH = re.compile(r"^(scene|format|surface|objects|goal|noise)[\w\[\]\.]*: ")
SHORT = 400
"""Longest acceptable error message: values are shown abbreviated."""


def _shelf(pose: list[float]) -> dict[str, Any]:
    """A can alone on the shelf; the default goal region is the front strip x [0.48, 0.58]."""
    d = two_objects()
    d["surface"] = "shelf"
    d["objects"] = [{"name": "can", "kind": "soda_can", "pose": pose}]
    return d


def _nested(depth: int) -> list[Any]:
    value: list[Any] = []
    for _ in range(depth):
        value = [value]
    return value


def _error(d: Any) -> str:
    with pytest.raises(ValueError) as err:
        scene_from_dict(d)
    return str(err.value)


def _with(field: str, value: Any, d: dict[str, Any] | None = None) -> dict[str, Any]:
    """``d`` (default: the valid scene) with ``field`` (``a.b[i]`` path) set to ``value``."""
    d = two_objects() if d is None else d
    keys: list[Any] = [int(k) if k.isdigit() else k for k in re.findall(r"\w+", field)]
    target: Any = d
    for key in keys[:-1]:
        target = target[key]
    target[keys[-1]] = value
    return d


# --- numbers too large for a float ----------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("objects[0].pose[0]", 10**400),
        ("objects[1].pose[2]", -(10**400)),
        ("objects[0].pose[1]", 10**5000),  # too long even to print
        ("goal.region.x[1]", 10**400),
        ("noise.xy", 10**400),
        ("noise.theta", -(10**400)),
    ],
    ids=lambda v: v if isinstance(v, str) else "huge",
)
def test_integers_too_large_for_a_float_name_the_field(field: str, value: int) -> None:
    d = two_objects()
    d["goal"]["region"] = {"x": [0.63, 1.37], "y": [-1.125, 0.725]}
    d["noise"] = {"xy": 0.01, "theta": 0.1}
    message = _error(_with(field, value, d))
    assert message.startswith(f"{field}: "), message
    assert "finite number" in message and len(message) < SHORT, message


def test_direct_construction_with_a_huge_integer_names_the_field() -> None:
    scene = scene_from_dict(two_objects())
    with pytest.raises(ValueError, match=r"^objects\[0\].pose\[0\]: "):
        dataclasses.replace(scene, objects=(ObjectPlacement("can", "soda_can", (10**400, 0, 0)),))
    with pytest.raises(ValueError, match=r"^noise.xy: "):
        dataclasses.replace(scene, noise=(10**400, 0.1))


# --- deep nesting and long values -----------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "[" * 100_000 + "]" * 100_000,
        '{"format": ' + '{"a": ' * 100_000 + "1" + "}" * 100_001,
    ],
    ids=["list", "object"],
)
def test_deeply_nested_json_names_the_file(tmp_path: Path, text: str) -> None:
    path = tmp_path / "deep.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=r"deep.json: not valid JSON: nested too deeply"):
        load_scene(path)


def test_deeply_nested_value_is_shown_briefly() -> None:
    message = _error(_with("objects[0].pose", _nested(10_000)))
    assert message.startswith("objects[0].pose: got [[[") and len(message) < SHORT, message


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("objects[0].kind", "mug" * 100_000),
        ("surface", "desk" * 100_000),
        ("goal.success", "x" * 100_000),
        ("objects[0].pose", list(range(100_000))),
        ("objects", {f"k{i}": i for i in range(100_000)}),
    ],
)
def test_long_values_are_truncated_in_messages(field: str, value: Any) -> None:
    message = _error(_with(field, value))
    assert message.startswith(f"{field}: ") and len(message) < SHORT, message[:SHORT]


# --- noise ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("noise", "field", "allowed"),
    [
        ({"xy": 1e300, "theta": 0.1}, "noise.xy", "[0, 1] m"),
        ({"xy": 1.5, "theta": 0.1}, "noise.xy", "[0, 1] m"),
        ({"xy": 0.01, "theta": 3.2}, "noise.theta", "[0, pi] rad"),
        ({"xy": 0.01, "theta": 1e300}, "noise.theta", "[0, pi] rad"),
    ],
)
def test_absurd_noise_is_rejected(noise: dict[str, float], field: str, allowed: str) -> None:
    message = _error(_with("noise", noise))
    assert message.startswith(f"{field}: ") and allowed in message, message


def test_noise_bounds_are_inclusive() -> None:
    assert resolve_noise((1, math.pi)) == (1.0, math.pi)
    assert resolve_noise([0, 0]) == (0.0, 0.0)
    assert scene_from_dict(_with("noise", {"xy": 1, "theta": math.pi})).noise == (1.0, math.pi)


@pytest.mark.parametrize(
    "noise",
    [
        None,
        0.01,
        5,
        True,
        {"sigma": 0.01},
        {"xy": 0.01},
        {"xy": 0.01, "theta": 0.1, "extra": 1},
        [[0.01], 0.1],
        [0.01, 0.1, 0.2],
        "0.01,0.1",
        b"sigma2",
        object(),
        {0.01, 0.1},
        (x for x in (0.01, 0.1)),
    ],
    ids=lambda v: type(v).__name__,
)
def test_resolve_noise_rejects_other_inputs_naming_the_path(noise: Any) -> None:
    with pytest.raises(ValueError) as err:
        resolve_noise(noise, path="env.noise")
    assert str(err.value).startswith("env.noise"), str(err.value)
    assert len(str(err.value)) < SHORT


def test_resolve_noise_accepts_the_scene_file_mapping() -> None:
    assert resolve_noise({"xy": 0.01, "theta": 0.1}) == (0.01, 0.1)
    with pytest.raises(ValueError, match=r"^env.noise.theta: got 4"):
        resolve_noise({"xy": 0.01, "theta": 4}, path="env.noise")


def test_scene_noise_is_stored_as_a_name_or_a_pair() -> None:
    scene = scene_from_dict(two_objects())
    custom = dataclasses.replace(scene, noise={"xy": 0.01, "theta": 0.1})  # type: ignore[arg-type]
    assert custom.noise == (0.01, 0.1)
    assert hash(custom) == hash(dataclasses.replace(scene, noise=(0.01, 0.1)))


# --- goal regions ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("region", "field"),
    [
        ({"x": [0.0, 0.4], "y": [-0.5, 0.0]}, "goal.region.x"),  # in front of the table
        ({"x": [0.0, 0.45], "y": [-0.5, 0.0]}, "goal.region.x"),  # touches its front edge
        ({"x": [0.7, 0.9], "y": [0.8, 2.0]}, "goal.region.y"),  # left of it
        ({"x": [0.9, 0.9], "y": [-0.5, 0.0]}, "goal.region.x"),  # no area
        ({"x": [0.7, 0.9], "y": [0.0, 0.0]}, "goal.region.y"),
    ],
)
def test_goal_region_must_overlap_the_surface_top(region: dict[str, Any], field: str) -> None:
    message = _error(_with("goal.region", region))
    assert message.startswith(f"{field}: "), message


def test_goal_region_may_reach_past_the_surface() -> None:
    d = _with("goal.region", {"x": [0.0, 0.7], "y": [-5.0, 5.0]})
    assert scene_from_dict(d).goal.region == ((0.0, 0.7), (-5.0, 5.0))


@pytest.mark.parametrize(
    "d",
    [
        _shelf([0.53, -0.2, 0.0]),  # already in the shelf's front strip
        _shelf([0.53, 0.05, 0.0]),  # on its edge: the task counts that as inside
        _with("goal", {"object": "can", "success": "region"}),  # the table's whole top
        _with(
            "goal",
            {"object": "can", "region": {"x": [0.65, 0.8], "y": [-0.3, 0.0]}, "success": "region"},
        ),
    ],
)
def test_region_goal_solved_at_reset_is_rejected(d: dict[str, Any]) -> None:
    message = _error(d)
    assert re.match(r"^goal.region: .*already stands inside it", message), message


def test_region_goal_outside_the_region_is_accepted() -> None:
    assert scene_from_dict(_shelf([0.75, -0.2, 0.0])).goal.success == "region"
    d = _with(
        "goal",
        {"object": "can", "region": {"x": [0.9, 1.1], "y": [-1.1, 0.7]}, "success": "region"},
    )
    assert scene_from_dict(d).goal.success == "region"


def test_committed_and_generated_scenes_still_load() -> None:
    files = sorted((Path(__file__).parents[1] / "clutter_gym" / "scenes").rglob("*.json"))
    assert len(files) > 60
    for path in files:
        load_scene(path)
    for surface in SURFACES:
        for level in LEVELS:
            for seed in range(31):
                generate_scene(level, seed, surface=surface)


# --- names ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["a\nb", "\x00", "\x1b[31m", "tab\t", "x" * 65, "\u200b"])
def test_names_must_be_printable_and_short(name: str) -> None:
    message = _error(_with("objects[1].name", name))
    assert message.startswith("objects[1].name: ") and "printable" in message, message
    assert "\n" not in message and "\x1b" not in message and "\x00" not in message


def test_goal_object_name_must_be_printable() -> None:
    message = _error(_with("goal.object", "\x1b[31m"))
    assert message.startswith("goal.object: ") and "printable" in message, message


def test_names_of_64_printable_characters_are_accepted() -> None:
    d = _with("objects[0].name", "é" * 64)
    d["goal"]["object"] = "é" * 64
    assert scene_from_dict(d).goal.object == "é" * 64


# --- files ----------------------------------------------------------------------------------


def test_missing_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"^.*/missing.json: no such file"):
        load_scene(tmp_path / "missing.json")


def test_directory_names_it(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"is a directory, not a scene file"):
        load_scene(tmp_path)


def test_non_utf8_file_names_it(tmp_path: Path) -> None:
    path = tmp_path / "latin1.json"
    path.write_bytes('{"format": "caf\u00e9"}'.encode("latin-1"))
    with pytest.raises(ValueError, match=r"latin1.json: not UTF-8 text"):
        load_scene(path)


def test_empty_path_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"^scene: the file path is empty"):
        load_scene("")


def test_unknown_keys_of_any_form_name_their_object() -> None:
    d = two_objects()
    d["objects"][0]["a\nb: "] = 1
    assert _error(d).startswith("objects[0]: unknown key 'a\\nb: '; allowed keys: name,")
    d = two_objects()
    d["goal"][None] = 1
    assert _error(d).startswith("goal: unknown key None; allowed keys: object,")


def test_non_path_source_is_rejected() -> None:
    with pytest.raises(ValueError, match=r"^scene: got 5; expected"):
        load_scene(5)  # type: ignore[arg-type]


def test_overlong_json_integer_is_invalid_json(tmp_path: Path) -> None:
    path = tmp_path / "digits.json"
    path.write_text("1" * 5000)
    with pytest.raises(ValueError, match=r"digits.json: not valid JSON"):
        load_scene(path)


# --- property-based -------------------------------------------------------------------------

JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(300, 5000).map(lambda e: 10**e)
    | st.floats()
    | st.text(max_size=20),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=12,
)
FIELDS = [
    "format",
    "surface",
    "objects",
    "objects[0]",
    "objects[0].name",
    "objects[0].kind",
    "objects[0].pose",
    "goal",
    "goal.object",
    "goal.region",
    "goal.success",
    "noise",
]


def _load_or_field_error(d: Any) -> None:
    try:
        assert isinstance(scene_from_dict(d), Scene)
    except ValueError as err:
        assert FIELD_PATH.match(str(err)), str(err)


@settings(max_examples=300, deadline=None)
@given(JSON)
def test_arbitrary_json_loads_or_names_a_field(value: Any) -> None:
    _load_or_field_error(value)


@pytest.mark.parametrize("field", FIELDS)
@settings(max_examples=200, deadline=None)
@given(value=JSON)
def test_arbitrary_field_value_loads_or_names_the_field(field: str, value: Any) -> None:
    _load_or_field_error(_with(field, copy.deepcopy(value)))


@settings(max_examples=300, deadline=None)
@given(JSON)
def test_resolve_noise_returns_bounded_sigmas_or_names_the_path(value: Any) -> None:
    try:
        xy, theta = resolve_noise(value, path="noise")
    except ValueError as err:
        assert str(err).startswith("noise"), str(err)
    else:
        assert 0 <= xy <= 1 and 0 <= theta <= math.pi
