"""Bad input to the env API: one ValueError that names the keyword, shows the value (briefly)
and says what is allowed, raised before the world, the RNG or a pybullet client is touched."""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import clutter_gym
import clutter_gym.env as env_module
from clutter_gym.env import ClutterRetrieveEEEnv, ClutterRetrieveEnv
from clutter_gym.model.fields import shown
from clutter_gym.model.scene import generate_scene
from clutter_gym.sim.simulator import Camera
from tests.helpers import lone_can

SCENE = lone_can("sigma1")


def bad_value(field: str, value: object) -> AbstractContextManager[object]:
    """Expects `field: got <short repr of value>; expected <what is allowed>`."""
    pattern = rf"^{re.escape(field)}: got {re.escape(shown(value))}; expected \S"
    return pytest.raises(ValueError, match=pattern)


ONE_MODE = pytest.mark.parametrize("env", ["ClutterRetrieve-v0"], indirect=True)
"""For checks that do not depend on the variant."""
Env = ClutterRetrieveEnv | ClutterRetrieveEEEnv


RETRIEVAL_IDS = tuple(
    i for i in clutter_gym.ENV_IDS if str(gym.spec(i).entry_point).startswith("clutter_gym.")
)
"""The variants clutter_gym defines (the primitive-level wrapper has its own tests)."""


@pytest.fixture(scope="module", params=RETRIEVAL_IDS)
def env(request: pytest.FixtureRequest) -> Iterator[Env]:
    env = gym.make(request.param).unwrapped
    assert isinstance(env, Env)
    yield env
    env.close()


def world_state(env: Env) -> tuple[object, ...]:
    """Everything a rejected call must leave as it was."""
    arm, velocities = env.herb.arm_state()
    return (
        env.true_poses().tolist(),
        arm.tolist(),
        velocities.tolist(),
        env.herb.hand_state().tolist(),
        env.sim_steps,
        env.elapsed_steps,
        env.scene,
        env.np_random.bit_generator.state,
    )


@pytest.fixture
def fresh(env: Env) -> Env:
    env.reset(seed=0, options={"scene": SCENE})
    return env


# --- reset(options=...) ------------------------------------------------------------------------


@pytest.mark.parametrize("options", [["scene"], [{"scene": None}], "x", 5, []])
def test_options_must_be_a_dict(fresh: Env, options: object) -> None:
    before = world_state(fresh)
    with bad_value("options", options):
        fresh.reset(seed=1, options=options)  # type: ignore[arg-type]
    assert world_state(fresh) == before


def test_unknown_option_keys_of_mixed_types_are_listed(fresh: Env) -> None:
    with pytest.raises(ValueError, match=r"^options: unknown keys \['colour', 1\]; allowed"):
        fresh.reset(options={"colour": "red", 1: 2})  # type: ignore[dict-item]


@pytest.mark.parametrize("scene", [5, "", [1, 2], b"scene.json", 1.5])
def test_scene_option_must_be_a_scene_mapping_or_path(fresh: Env, scene: object) -> None:
    before = world_state(fresh)
    with bad_value("options['scene']", scene):
        fresh.reset(seed=1, options={"scene": scene})
    assert world_state(fresh) == before


def test_scene_load_errors_name_the_option(fresh: Env, tmp_path: Path) -> None:
    before = world_state(fresh)
    bad = lone_can("sigma1")
    bad["objects"][0]["kind"] = "teapot"
    with pytest.raises(ValueError, match=r"^options\['scene'\]: objects\[0\]\.kind: got 'teapot'"):
        fresh.reset(seed=1, options={"scene": bad})
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(ValueError, match=r"^options\['scene'\]: " + re.escape(str(path))):
        fresh.reset(seed=1, options={"scene": path})
    assert world_state(fresh) == before


@ONE_MODE
def test_scene_none_samples_and_a_path_like_loads(env: Env, tmp_path: Path) -> None:
    _, info = env.reset(seed=0, options={"scene": None, "level": "none"})
    assert len(info["object_names"]) == 1
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(SCENE))
    _, info = env.reset(seed=0, options={"scene": path})
    assert info["object_names"] == ("red_can",)


@pytest.mark.parametrize(
    "arm",
    ["abc", {"a": 1}, [1, 2, "x", 4, 5, 6, 7], [1j] * 7, [[0.0, 0.0], 0, 0, 0, 0, 0, 0], True],
)
def test_arm_option_must_be_seven_finite_angles(fresh: Env, arm: object) -> None:
    before = world_state(fresh)
    with bad_value("options['arm']", arm):
        fresh.reset(seed=1, options={"scene": SCENE, "arm": arm})
    assert world_state(fresh) == before


@pytest.mark.parametrize("hand", ["open", {"spread": 0}, [0, 1j], [0, None]])
def test_hand_option_must_be_two_fractions(fresh: Env, hand: object) -> None:
    before = world_state(fresh)
    with bad_value("options['hand']", hand):
        fresh.reset(seed=1, options={"scene": SCENE, "hand": hand})
    assert world_state(fresh) == before


@pytest.mark.parametrize("level", [["none"], np.array(["none", "high"]), {}, "extreme"])
@pytest.mark.parametrize("with_scene", [False, True])
def test_level_option_must_be_a_level_name(fresh: Env, level: object, with_scene: bool) -> None:
    before = world_state(fresh)
    options = {"level": level, **({"scene": SCENE} if with_scene else {})}
    with bad_value("options['level']", level):
        fresh.reset(seed=1, options=options)
    assert world_state(fresh) == before


@pytest.mark.parametrize("seed", [-1, 1.5, "0", True])
def test_seed_must_be_a_non_negative_integer(fresh: Env, seed: object) -> None:
    before = world_state(fresh)
    with bad_value("seed", seed):
        fresh.reset(seed=seed, options={"scene": SCENE})  # type: ignore[arg-type]
    assert world_state(fresh) == before


@ONE_MODE
def test_numpy_integer_seed_is_a_seed(env: Env) -> None:
    _, a = env.reset(seed=np.int64(5))  # type: ignore[arg-type]
    _, b = env.reset(seed=5)
    assert np.array_equal(a["true_object_poses"], b["true_object_poses"])


# --- step(action) ------------------------------------------------------------------------------


BAD_ACTIONS: dict[str, Callable[[tuple[int, ...]], object]] = {
    "dict": lambda shape: {"a": 1},
    "str": lambda shape: "x",
    "none": lambda shape: None,
    "complex": lambda shape: np.zeros(shape, complex),
    "object": lambda shape: np.zeros(shape, object),
    "bool": lambda shape: np.zeros(shape, bool),
    "ragged": lambda shape: [[0.0, 0.0], 0.0],
}


@pytest.mark.parametrize("make_action", BAD_ACTIONS.values(), ids=BAD_ACTIONS.keys())
def test_bad_action_types_raise_before_anything_moves(
    fresh: Env, make_action: Callable[[tuple[int, ...]], object]
) -> None:
    before = world_state(fresh)
    with pytest.raises(ValueError, match=r"^action: got .+; expected a real-valued array of shape"):
        fresh.step(make_action(fresh.action_space.shape))  # type: ignore[arg-type]
    assert world_state(fresh) == before


def test_action_errors_show_arrays_by_dtype_and_shape(fresh: Env) -> None:
    shape = fresh.action_space.shape
    assert shape is not None
    shown = re.escape(f"action: got array of dtype complex128, shape {shape}; expected")
    with pytest.raises(ValueError, match=f"^{shown}"):
        fresh.step(np.zeros(shape, complex))
    huge = "x" * 100_000
    with pytest.raises(ValueError) as caught:
        fresh.step(huge)  # type: ignore[arg-type]
    assert len(str(caught.value)) < 200


# --- recording -----------------------------------------------------------------------------------


@ONE_MODE
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"on_frame": print, "every_sim_steps": 0}, "every_sim_steps"),
        ({"on_frame": print, "every_sim_steps": 2.5}, "every_sim_steps"),
        ({"on_frame": print, "every_sim_steps": "24"}, "every_sim_steps"),
        ({"on_frame": "print"}, "on_frame"),
    ],
)
def test_bad_recording_arguments(env: Env, kwargs: dict[str, Any], field: str) -> None:
    with bad_value(field, kwargs[field]):
        env.start_recording(**kwargs)
    assert not env.recording


# --- gym.make keywords ---------------------------------------------------------------------------


@pytest.fixture
def no_simulator(monkeypatch: pytest.MonkeyPatch) -> None:
    """A bad keyword must be rejected before a pybullet client exists."""

    def created(*args: object, **kwargs: object) -> None:
        raise AssertionError("a Simulator (pybullet client) was created")

    monkeypatch.setattr(env_module, "Simulator", created)


BAD_KEYWORDS: list[tuple[str, object]] = [
    ("camera", "top"),
    ("camera", {"eye": (0, 0, 1)}),
    ("level", np.array(["none"])),
    ("level", []),
    ("surface", ["table"]),
    ("reward_type", {"dense"}),
    ("goal_kind", "teapot"),
    ("goal_kind", "large_box"),  # not graspable: never a goal
    ("goal_kind", ["soda_can"]),
    ("gamma", 0),
    ("gamma", 1.01),
    ("gamma", "0.99"),
    ("gamma", float("nan")),
    ("gamma", True),
    ("scenes", []),
    ("scenes", 5),
    ("scenes", ""),
]
"""Bad values of the keywords every variant takes."""
TRAJECTORY_BAD_KEYWORDS: list[tuple[str, object]] = [
    ("waypoints", 2.5),
    ("waypoints", "16"),
    ("waypoints", True),
    ("waypoints", 0),
    ("waypoints", 16.0),
    ("waypoints", np.int64(-3)),
    ("max_hand_speed", "fast"),
    ("max_hand_speed", float("inf")),
    ("max_hand_speed", float("nan")),
    ("max_hand_speed", -1),
    ("max_hand_speed", 0),
    ("max_hand_speed", None),
    ("max_hand_speed", True),
]


@pytest.mark.parametrize(
    ("env_id", "keyword", "value"),
    [(i, *bad) for i in RETRIEVAL_IDS for bad in BAD_KEYWORDS]
    + [("ClutterRetrieve-v0", *bad) for bad in TRAJECTORY_BAD_KEYWORDS],
)
def test_bad_keywords_raise_before_the_simulator(
    no_simulator: None, env_id: str, keyword: str, value: object
) -> None:
    with bad_value(keyword, value):
        gym.make(env_id, **{keyword: value})


@pytest.mark.parametrize("env_id", RETRIEVAL_IDS)
def test_a_bad_scene_in_the_scenes_list_is_named_by_its_index(
    no_simulator: None, env_id: str
) -> None:
    good = lone_can("sigma1")
    bad = lone_can("sigma1")
    bad["objects"][0]["kind"] = "teapot"
    with pytest.raises(ValueError, match=r"^scenes\[1\]: objects\[0\]\.kind: got 'teapot'"):
        gym.make(env_id, scenes=[good, bad])
    with bad_value("scenes[0]", 5):
        gym.make(env_id, scenes=[5])


@pytest.mark.parametrize("keyword", ["level", "goal_kind", "surface"])
def test_sampling_keywords_conflict_with_scenes(no_simulator: None, keyword: str) -> None:
    value = {"level": "high", "goal_kind": "soda_can", "surface": "table"}[keyword]
    with bad_value(keyword, value):
        gym.make("ClutterRetrieve-v0", scenes=lone_can("sigma1"), **{keyword: value})


@pytest.mark.parametrize("env_id", ["ClutterRetrieveEE-v0", "ClutterRetrieveEEDense-v0"])
def test_end_effector_variants_lift_on_the_table_only(no_simulator: None, env_id: str) -> None:
    with bad_value("surface", "shelf"):
        gym.make(env_id, surface="shelf")
    shelf = generate_scene("medium", seed=0, surface="shelf")
    with pytest.raises(ValueError, match=r"^scenes: a shelf scene .* expected a lift task"):
        gym.make(env_id, scenes=shelf)


@pytest.mark.parametrize("noise", [{"a": 1}, [1, 2, 3], "sigma9", (-0.1, 0.0)])
def test_bad_noise_raises_before_the_simulator(no_simulator: None, noise: object) -> None:
    with pytest.raises(ValueError, match=r"^noise"):
        gym.make("ClutterRetrieve-v0", noise=noise)


@pytest.mark.parametrize("render_mode", [["rgb_array"], 5, "human"])
def test_bad_render_mode_raises_before_the_simulator(
    no_simulator: None, render_mode: object
) -> None:
    # Not through gym.make: it calls render_mode.endswith() itself on a value outside
    # metadata["render_modes"], so a list fails inside Gymnasium before the env is built.
    with bad_value("render_mode", render_mode):
        ClutterRetrieveEnv(render_mode=render_mode)  # type: ignore[arg-type]


def test_numpy_and_plain_numbers_are_accepted() -> None:
    env = gym.make(
        "ClutterRetrieve-v0",
        waypoints=np.int64(4),
        max_hand_speed=np.float32(0.1),
        gamma=np.float32(0.5),
        camera=Camera(width=64, height=48),
    ).unwrapped
    assert isinstance(env, ClutterRetrieveEnv)
    assert env.action_space.shape == (4, 9)
    assert type(env.gamma) is float and env.gamma == 0.5
    env.close()
    env = gym.make("ClutterRetrieve-v0", max_hand_speed=1, gamma=1).unwrapped
    assert isinstance(env, ClutterRetrieveEnv)
    env.close()
