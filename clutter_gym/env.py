"""`ClutterRetrieve-v0`: HERB retrieves a goal object from clutter, seeing only noisy detections.

The env composes the pieces and owns none of their logic: a `Simulator` (pybullet world), `Herb`
(robot and its controllers), a `Scene` (what is where), a controller (how actions move the arm)
and a `RetrievalTask` (success, failure, reward). See the README for the spaces.

The observation is described (and encoded) in `clutter_gym.model.observation`.
True poses are only in `info["true_object_poses"]`, for evaluation.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from typing import Any, Literal

import gymnasium as gym
import numpy as np

from clutter_gym.model import herb as hm
from clutter_gym.model.fields import integer, invalid, positive_number, shown
from clutter_gym.model.herb import OPEN_HAND, HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.noise import detect, resolve_noise
from clutter_gym.model.objects import get_object
from clutter_gym.model.observation import (
    MAX_OBJECTS,
    Observation,
    encode_scene,
    encode_state,
    observation_space,
)
from clutter_gym.model.scene import LEVELS, Level, Scene, generate_scene, load_scene
from clutter_gym.model.trajectory import DEFAULT_WAYPOINTS
from clutter_gym.model.transforms import yaw_of_quaternion
from clutter_gym.model.world import SURFACES, Surface, get_surface
from clutter_gym.sim.controllers import EndEffectorDeltaController, TrajectoryController, real_array
from clutter_gym.sim.robot import Herb
from clutter_gym.sim.simulator import Camera, Simulator
from clutter_gym.sim.task import REWARD_TYPES, Outcome, RetrievalTask, RewardType

ControlMode = Literal["trajectory", "ee_delta"]
CONTROL_MODES: tuple[ControlMode, ...] = ("trajectory", "ee_delta")
DEFAULT_STEP_LIMITS: dict[str, int] = {"trajectory": 10, "ee_delta": 300}
SETTLE_STEPS = 24  # physics steps after building a scene, so objects rest on the surface
RESET_OPTIONS = ("scene", "level", "arm", "hand")
"""reset(options=...), a dict: scene (Scene, dict or JSON path), level (for a sampled scene), arm (7
start joint angles, default HERB's home; must not touch anything, or reset's info reports the
failure) and hand ((spread, closure) start command, default open)."""
MONITOR_EVERY = 8  # physics steps between task checks while a trajectory executes


class ClutterRetrieveEnv(gym.Env[Observation, np.ndarray]):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012

    def __init__(
        self,
        render_mode: str | None = None,
        control_mode: ControlMode = "trajectory",
        waypoints: int = DEFAULT_WAYPOINTS,
        level: Level | None = None,
        surface: str = "table",
        noise: str | tuple[float, float] | None = None,
        reward_type: RewardType = "sparse",
        max_hand_speed: float = 0.05,
        step_limit: int | None = None,
        camera: Camera | None = None,
    ) -> None:
        # Every keyword is checked before the Simulator exists: a bad one leaves no pybullet client.
        _check_choice("render_mode", render_mode, (None, *self.metadata["render_modes"]))
        _check_choice("control_mode", control_mode, CONTROL_MODES)
        _check_choice("level", level, (None, *LEVELS))
        _check_choice("surface", surface, tuple(SURFACES))
        _check_choice("reward_type", reward_type, REWARD_TYPES)
        if camera is not None and not isinstance(camera, Camera):
            raise invalid("camera", camera, "None or a clutter_gym.sim.simulator.Camera")
        self.render_mode = render_mode
        self.control_mode = control_mode
        self.level = level
        self.surface_name = surface
        self.noise_override = None if noise is None else resolve_noise(noise, "noise")
        self.reward_type: RewardType = reward_type
        self.waypoints = integer("waypoints", waypoints, 1)
        self._max_hand_speed = positive_number("max_hand_speed", max_hand_speed, "m/s")
        self.step_limit = (
            DEFAULT_STEP_LIMITS[control_mode]
            if step_limit is None
            else integer("step_limit", step_limit, 1)
        )
        self.camera = Camera() if camera is None else camera

        self.sim = Simulator()
        self.kinematics = ArmKinematics("right")
        self._build_world(
            generate_scene("none", seed=0, surface=surface),
            np.asarray(hm.RIGHT_ARM_HOME),
            OPEN_HAND,
        )
        self.action_space = self._controller.action_space
        self.observation_space = observation_space(MAX_OBJECTS)

        self._steps = 0
        self._sim_steps = 0
        self._ended = False
        self._recording_every = 0
        self._on_frame: Callable[[np.ndarray], object] | None = None

    # --- gymnasium API ----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        # Everything is checked, and a given scene loaded, before the RNG or the world changes.
        seed = None if seed is None else integer("seed", seed, 0)
        scene, level, arm, hand = self._reset_options(options)
        super().reset(seed=seed)
        if scene is None:
            if level is None:
                level = LEVELS[int(self.np_random.integers(len(LEVELS)))]
            scene = generate_scene(
                level, seed=int(self.np_random.integers(2**31)), surface=self.surface_name
            )
        self._build_world(scene, arm, hand)
        self._steps = 0
        self._ended = False
        true_poses = self._true_poses()
        outcome = self._task.evaluate()
        return self._observation(true_poses), self._info(outcome, true_poses, clipped=False)

    def step(self, action: np.ndarray) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        if self._ended:
            raise RuntimeError("step() after the episode ended: call reset() first")
        clipped = self._controller.execute(action, self._substep)
        self._steps += 1
        outcome = self._task.evaluate()
        reward = self._task.reward(outcome, self.reward_type)
        terminated = bool(outcome.done)
        truncated = bool(not terminated and self._steps >= self.step_limit)
        self._ended = terminated or truncated
        true_poses = self._true_poses()
        return (
            self._observation(true_poses),
            float(reward),
            terminated,
            truncated,
            self._info(outcome, true_poses, clipped),
        )

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self.sim.render(self.camera)

    def close(self) -> None:
        self.sim.close()

    # --- recording (for GIFs of whole-trajectory steps) -----------------------------------------
    def start_recording(
        self, on_frame: Callable[[np.ndarray], object], every_sim_steps: int = 24
    ) -> None:
        """Render a frame now and every `every_sim_steps` physics steps while actions execute,
        and hand each to `on_frame` (e.g. `clutter_gym.media.GifStream.add`). Frames are
        streamed, never kept here: a long rollout would otherwise hold hundreds of them."""
        every = integer("every_sim_steps", every_sim_steps, 1)
        if not callable(on_frame):
            raise invalid("on_frame", on_frame, "a callable taking an RGB frame (H, W, 3)")
        self._recording_every = every
        self._on_frame = on_frame
        on_frame(self.sim.render(self.camera))

    def stop_recording(self) -> None:
        self._recording_every = 0
        self._on_frame = None

    # --- internals ----------------------------------------------------------------------------
    @property
    def scene(self) -> Scene:
        return self._scene

    @property
    def surface(self) -> Surface:
        return self._surface

    @property
    def task(self) -> RetrievalTask:
        """The episode's rules (success, failure, reward), e.g. ``env.task.evaluate()``."""
        return self._task

    @property
    def elapsed_steps(self) -> int:
        """Env steps since the last reset."""
        return self._steps

    @property
    def sim_steps(self) -> int:
        """Physics steps since the last reset."""
        return self._sim_steps

    @property
    def recording(self) -> bool:
        return self._on_frame is not None

    def true_poses(self) -> np.ndarray:
        """True planar poses (N, 3) of the scene's objects, in scene order (for evaluation)."""
        return self._true_poses()

    def _reset_options(
        self, options: object
    ) -> tuple[Scene | None, Level | None, np.ndarray, HandCommand]:
        """The checked reset options: the scene (None: sample one at the level), arm and hand."""
        if options is None:
            options = {}
        if not isinstance(options, Mapping):
            raise invalid("options", options, f"None or a dict with keys from {RESET_OPTIONS}")
        unknown = set(options) - set(RESET_OPTIONS)
        if unknown:
            raise ValueError(
                f"options: unknown keys {shown(sorted(unknown, key=repr))}; "
                f"allowed: {RESET_OPTIONS}"
            )
        level: Level | None = options.get("level", self.level)
        _check_choice("options['level']", level, (None, *LEVELS))
        return (
            _scene_option(options.get("scene")),
            level,
            self._start_arm(options.get("arm")),
            self._start_hand(options.get("hand")),
        )

    def _start_arm(self, arm: object) -> np.ndarray:
        if arm is None:
            return np.asarray(hm.RIGHT_ARM_HOME, dtype=np.float64)
        q = real_array(arm)
        if q is None or q.shape != (7,) or not np.all(np.isfinite(q)):
            raise invalid("options['arm']", arm, "7 finite joint angles (rad)")
        lower, upper = self.kinematics.lower, self.kinematics.upper
        for i in np.flatnonzero((q < lower) | (q > upper)):
            raise ValueError(
                f"options['arm'][{i}]: {q[i]:.4f} rad is outside the joint range "
                f"[{lower[i]:.4f}, {upper[i]:.4f}]"
            )
        return q

    @staticmethod
    def _start_hand(hand: object) -> HandCommand:
        if hand is None:
            return OPEN_HAND
        values = real_array(hand)
        if values is None or values.shape != (2,) or not np.all((values >= 0.0) & (values <= 1.0)):
            raise invalid("options['hand']", hand, "(spread, closure), each in [0, 1]")
        return HandCommand(spread=float(values[0]), closure=float(values[1]))

    def _build_world(self, scene: Scene, arm: np.ndarray, hand: HandCommand) -> None:
        self.sim.clear()
        self._scene = scene
        self._surface = get_surface(scene.surface)
        self.sim.add_static_boxes("surface", self._surface.boxes)
        self.herb = Herb(self.sim)
        self._specs = {o.name: get_object(o.kind) for o in scene.objects}
        for placement in scene.objects:
            self.sim.add_object(
                placement.name, self._specs[placement.name], placement.pose, self._surface.top_z
            )
        self.herb.reset(arm, hand)
        self.sim.step(SETTLE_STEPS)
        for placement in scene.objects:
            self.sim.sleep(placement.name)
        self._sim_steps = 0
        self._sigma = self.noise_override or resolve_noise(scene.noise)
        self._static_obs = encode_scene(scene, self._sigma)
        self._task = RetrievalTask(self.sim, self.herb, scene, self._surface, self._specs)
        if self.control_mode == "trajectory":
            traj = TrajectoryController(
                self.herb, self.kinematics, self.waypoints, self._max_hand_speed, self.sim.timestep
            )
            traj.reset(hand)
            self._controller: TrajectoryController | EndEffectorDeltaController = traj
        else:
            ee = EndEffectorDeltaController(self.herb, self.kinematics)
            ee.reset(arm)
            self._controller = ee

    def _substep(self) -> bool:
        self.sim.step()
        self._sim_steps += 1
        if self._on_frame is not None and self._sim_steps % self._recording_every == 0:
            self._on_frame(self.sim.render(self.camera))
        # Long trajectories stop early once the episode is decided; an ee_delta step is only
        # 10 physics steps and is evaluated at its end.
        if self.control_mode != "trajectory" or self._sim_steps % MONITOR_EVERY:
            return False
        return self._task.evaluate().done

    def _true_poses(self) -> np.ndarray:
        poses = np.zeros((len(self._scene.objects), 3))
        for i, placement in enumerate(self._scene.objects):
            pos, quat = self.sim.base_pose(placement.name)
            poses[i] = (pos[0], pos[1], yaw_of_quaternion(quat))
        return poses

    def _observation(self, true_poses: np.ndarray) -> Observation:
        q, dq = self.herb.arm_state()
        tcp_position, tcp_quaternion = self.herb.tcp_pose()
        detected = detect(true_poses, self._sigma, self.np_random)
        obs = encode_state(q, dq, self.herb.hand_state(), tcp_position, tcp_quaternion, detected)
        obs.update({key: value.copy() for key, value in self._static_obs.items()})
        return obs

    def _info(self, outcome: Outcome, true_poses: np.ndarray, clipped: bool) -> dict[str, Any]:
        padded = np.zeros((MAX_OBJECTS, 3))
        padded[: len(true_poses)] = true_poses
        return {
            "is_success": bool(outcome.success),
            "failure": outcome.failure,
            "goal_held": bool(outcome.goal_held),
            "goal_lift": float(outcome.goal_lift),
            "true_object_poses": padded,
            "object_names": tuple(o.name for o in self._scene.objects),
            "sim_steps": int(self._sim_steps),
            "action_clipped": bool(clipped),
        }


def _check_choice(field: str, value: object, allowed: tuple[str | None, ...]) -> None:
    """Only a str (or None) is looked up: `in` compares an array element-wise, so a
    one-element array would pass and a longer one would raise numpy's ambiguity error."""
    if not (value is None or isinstance(value, str)) or value not in allowed:
        raise invalid(field, value, "one of " + ", ".join(map(repr, allowed)))


def _scene_option(scene: object) -> Scene | None:
    """The reset scene, loaded now so that a bad file fails before anything changes; the
    scene module's errors get the option's name in front."""
    if scene is None or isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping | os.PathLike) or (isinstance(scene, str) and scene):
        try:
            return load_scene(scene)
        except ValueError as err:
            raise ValueError(f"options['scene']: {err}") from err
    raise invalid(
        "options['scene']", scene, "None, a Scene, a scene dict or a non-empty JSON file path"
    )
