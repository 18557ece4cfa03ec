"""The env's variants: HERB retrieves a goal object from clutter, seeing only noisy detections.

`ClutterRetrieveEnv` (`ClutterRetrieve-v0`): one step executes a whole trajectory; the Dict
observation. `ClutterRetrieveEEEnv` (`ClutterRetrieveEE-v0`, `ClutterRetrieveEEDense-v0`): one
step moves the hand a little from a ready pose; goal-conditioned observations (GoalEnv), for
low-level RL with hindsight experience replay; lift tasks on the table.

The variants compose the pieces and own none of their logic: a `Simulator` (pybullet world),
`Herb` (robot and its controllers), a `Scene` (what is where), a controller (how actions move
the arm) and a `RetrievalTask` (success, failure, the reward's terms). An episode ends here only
by success or failure: truncation is Gymnasium's TimeLimit (the `max_episode_steps` of the
registered id, or of `gym.make`).

The observations are described (and encoded) in `clutter_gym.model.observation`, the reward in
`clutter_gym.sim.task`. True poses are only in `info["true_object_poses"]`, for evaluation.
"""

from __future__ import annotations

import math
import numbers
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from clutter_gym.model import herb as hm
from clutter_gym.model.fields import integer, invalid, positive_number, shown
from clutter_gym.model.herb import OPEN_HAND, HandCommand
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.noise import detect, resolve_noise
from clutter_gym.model.objects import get_object
from clutter_gym.model.observation import (
    GOAL_SIZES,
    MAX_OBJECTS,
    Observation,
    encode_goal_observation,
    encode_scene,
    encode_state,
    goal_observation_space,
    observation_space,
)
from clutter_gym.model.scene import GOAL_KINDS, LEVELS, Level, Scene, generate_scene, load_scene
from clutter_gym.model.trajectory import DEFAULT_WAYPOINTS, Trajectory
from clutter_gym.model.world import SURFACES, Surface, get_surface
from clutter_gym.sim.controllers import (
    EE_TIMESTEP,
    EndEffectorDeltaController,
    SegmentSpeed,
    TrajectoryController,
    ready_configuration,
    real_array,
)
from clutter_gym.sim.robot import Herb
from clutter_gym.sim.simulator import TIMESTEP, Camera, Simulator
from clutter_gym.sim.task import (
    OBJECTIVES,
    REWARD_TYPES,
    Objective,
    Outcome,
    RetrievalTask,
    RewardType,
    grasped,
    lifted,
    reward,
    shaping,
)

GRASP_GOAL = np.array([0.0, 0.0, 0.0, 1.0])
"""The grasp objective's desired goal: the TCP at the grasp point, two fingers gripping."""
SETTLE_TIME = 0.1  # s of physics after building a scene, so objects rest on the surface
RESET_OPTIONS = ("scene", "level", "arm", "hand")
"""reset(options=...), a dict: scene (Scene, dict or JSON path), level (sample a scene at this
level, None for a random one), arm (7 start joint angles, default the variant's start; must not
touch anything, or reset's info reports the failure) and hand ((spread, closure) start command,
default open)."""
MONITOR_EVERY = 8  # physics steps between task checks while a trajectory executes
DEFAULT_GAMMA = 0.99

SceneSource = Scene | Mapping[str, Any] | str | os.PathLike[str]
"""A scene, a scene dict or a JSON file path."""
Controller = TrajectoryController | EndEffectorDeltaController
Pose = tuple[np.ndarray, np.ndarray]
"""A position (3,) and an (x, y, z, w) quaternion (4,)."""


class _ResetPlan(NamedTuple):
    """Checked reset options: a scene, or None to sample one (at `level` if `sample`, else from
    the `scenes` keyword), and the start arm and hand."""

    scene: Scene | None
    sample: bool
    level: Level | None
    arm: np.ndarray
    hand: HandCommand


class _RetrievalEnv(gym.Env[Observation, np.ndarray], ABC):
    """What the variants share: keywords, scenes, reset options, the world, the task, info."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012
    timestep = TIMESTEP
    merge_fixed_links = False

    def __init__(
        self,
        render_mode: str | None = None,
        scenes: SceneSource | Sequence[SceneSource] | None = None,
        level: Level | None = None,
        goal_kind: str | None = None,
        surface: str | None = None,
        noise: str | tuple[float, float] | None = None,
        reward_type: RewardType = "sparse",
        gamma: float = DEFAULT_GAMMA,
        camera: Camera | None = None,
    ) -> None:
        # Every keyword is checked before the Simulator exists: a bad one leaves no pybullet client.
        _check_choice("render_mode", render_mode, (None, *self.metadata["render_modes"]))
        _check_choice("level", level, (None, *LEVELS))
        _check_choice("goal_kind", goal_kind, (None, *GOAL_KINDS))
        _check_choice("surface", surface, (None, *self._surfaces()))
        _check_choice("reward_type", reward_type, REWARD_TYPES)
        if camera is not None and not isinstance(camera, Camera):
            raise invalid("camera", camera, "None or a clutter_gym.sim.simulator.Camera")
        self.scenes = self._scenes_keyword(scenes)
        for field, value in (("level", level), ("goal_kind", goal_kind), ("surface", surface)):
            if self.scenes and value is not None:
                raise invalid(field, value, "None when scenes are given (it is for sampled scenes)")
        self.render_mode = render_mode
        self.level = level
        self.goal_kind = goal_kind
        self.surface_name = surface or "table"
        self.noise_override = None if noise is None else resolve_noise(noise, "noise")
        self.reward_type: RewardType = reward_type
        self.gamma = _discount(gamma)
        self.camera = Camera() if camera is None else camera

        self.sim = Simulator(timestep=self.timestep)
        self.kinematics = ArmKinematics("right")
        first = generate_scene("none", seed=0, surface=self.surface_name, goal_kind=goal_kind)
        self._build_world(first, self._start_arm_default(first), OPEN_HAND)
        self.action_space = self._controller.action_space
        self.observation_space = self._observation_space()

        self._steps = 0
        self._ended = False
        self._potential = 0.0
        self._recording_every = 0
        self._on_frame: Callable[[np.ndarray], object] | None = None

    # --- what a variant defines -------------------------------------------------------------
    @staticmethod
    def _surfaces() -> tuple[str, ...]:
        return tuple(SURFACES)

    def _check_scene(self, scene: Scene, field: str) -> Scene:
        return scene

    def _start_arm_default(self, scene: Scene) -> np.ndarray:
        return np.asarray(hm.RIGHT_ARM_START, dtype=np.float64)

    @abstractmethod
    def _make_controller(self, arm: np.ndarray, hand: HandCommand) -> Controller:
        """The controller that turns this variant's actions into motor targets."""

    @abstractmethod
    def _observation_space(self) -> spaces.Dict:
        """This variant's observation space."""

    @abstractmethod
    def _observe(self, outcome: Outcome, tcp: Pose) -> Observation:
        """This variant's observation of the current state."""

    @abstractmethod
    def _reward(self, obs: Observation, outcome: Outcome, info: dict[str, Any]) -> float:
        """This variant's reward for one step."""

    def _decided(self) -> bool:
        """Whether the episode is decided in the middle of an action (stop executing it)."""
        return False

    def _objective(self) -> Objective:
        """What the episode asks of the robot (`sim.task.Objective`)."""
        return "retrieve"

    # --- gymnasium API ----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        # Everything is checked, and a given scene loaded, before the RNG or the world changes.
        seed = None if seed is None else integer("seed", seed, 0)
        plan = self._reset_plan(options)
        super().reset(seed=seed)
        scene = plan.scene or self._draw_scene(plan)
        self._build_world(scene, plan.arm, plan.hand)
        self._steps = 0
        self._ended = False
        outcome, tcp = self._task.evaluate(), self.herb.tcp_pose()
        obs = self._observe(outcome, tcp)
        self._potential = self._task.potential(outcome, tcp[0])
        return obs, self._info(outcome, clipped=False, shaped=0.0)

    def step(self, action: np.ndarray) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        if self._ended:
            raise RuntimeError("step() after the episode ended: call reset() first")
        clipped = self._controller.execute(action, self._substep)
        return self._finish_step(clipped)

    def _finish_step(self, clipped: bool) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """Judge the world after an action: observation, reward, termination and info."""
        self._steps += 1
        outcome, tcp = self._task.evaluate(), self.herb.tcp_pose()
        obs = self._observe(outcome, tcp)
        before, self._potential = self._potential, self._task.potential(outcome, tcp[0])
        info = self._info(
            outcome, clipped, shaping(before, self._potential, outcome.done, self.gamma)
        )
        self._ended = outcome.done
        return obs, self._reward(obs, outcome, info), outcome.done, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self.sim.render(self.camera)

    def close(self) -> None:
        self.sim.close()

    # --- recording (for GIFs) -----------------------------------------------------------------
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

    # --- views --------------------------------------------------------------------------------
    @property
    def scene(self) -> Scene:
        return self._scene

    @property
    def surface(self) -> Surface:
        return self._surface

    @property
    def task(self) -> RetrievalTask:
        """The episode's rules (success, failure, the reward's terms): ``env.task.evaluate()``."""
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
        return self._task.evaluate().poses

    # --- internals ----------------------------------------------------------------------------
    def _scenes_keyword(self, scenes: object) -> tuple[Scene, ...]:
        """The `scenes` keyword as loaded scenes: one source or a non-empty list of them."""
        if scenes is None:
            return ()
        if not isinstance(scenes, list | tuple):
            return (self._check_scene(_load_scene(scenes, "scenes"), "scenes"),)
        if not scenes:
            raise invalid(
                "scenes", scenes, "a scene, a scene dict, a JSON path or a non-empty list"
            )
        return tuple(
            self._check_scene(_load_scene(source, f"scenes[{i}]"), f"scenes[{i}]")
            for i, source in enumerate(scenes)
        )

    def _reset_plan(self, options: object) -> _ResetPlan:
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
        scene = options.get("scene")
        if scene is not None:
            scene = self._check_scene(_load_scene(scene, "options['scene']"), "options['scene']")
        return _ResetPlan(
            scene=scene,
            sample="level" in options or not self.scenes,
            level=level,
            arm=self._start_arm(options.get("arm"), scene),
            hand=self._start_hand(options.get("hand")),
        )

    def _draw_scene(self, plan: _ResetPlan) -> Scene:
        """A scene from the env's RNG: one of `scenes`, or one generated at the plan's level."""
        if not plan.sample:
            return self.scenes[int(self.np_random.integers(len(self.scenes)))]
        level = plan.level or LEVELS[int(self.np_random.integers(len(LEVELS)))]
        return generate_scene(
            level,
            seed=int(self.np_random.integers(2**31)),
            surface=self.surface_name,
            goal_kind=self.goal_kind,
        )

    def _start_arm(self, arm: object, scene: Scene | None) -> np.ndarray:
        if arm is None:
            return self._start_arm_default(scene or self._scene)
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
        self.herb = Herb(self.sim, merge_fixed_links=self.merge_fixed_links)
        specs = {o.name: get_object(o.kind) for o in scene.objects}
        for placement in scene.objects:
            self.sim.add_object(
                placement.name, specs[placement.name], placement.pose, self._surface.top_z
            )
        self.herb.reset(arm, hand)
        self.sim.step(round(SETTLE_TIME / self.sim.timestep))
        for placement in scene.objects:
            self.sim.sleep(placement.name)
        self._sim_steps = 0
        self._sigma = self.noise_override or resolve_noise(scene.noise)
        self._static_obs = encode_scene(scene, self._sigma)
        self._task = RetrievalTask(
            self.sim, self.herb, scene, self._surface, specs, objective=self._objective()
        )
        self._controller = self._make_controller(arm, hand)

    def _substep(self) -> bool:
        self.herb.hold_fingers()
        self.sim.step()
        self._sim_steps += 1
        if self._on_frame is not None and self._sim_steps % self._recording_every == 0:
            self._on_frame(self.sim.render(self.camera))
        return self._decided()

    def _state(self, outcome: Outcome, tcp: Pose) -> Observation:
        """The changing entries of the Dict observation (`model.observation`), with a new
        detection of the poses `outcome` was judged on."""
        q, dq = self.herb.arm_state()
        detected = detect(outcome.poses, self._sigma, self.np_random)
        return encode_state(q, dq, self.herb.hand_state(), *tcp, detected)

    def _info(self, outcome: Outcome, clipped: bool, shaped: float) -> dict[str, Any]:
        padded = np.zeros((MAX_OBJECTS, 3))
        padded[: len(outcome.poses)] = outcome.poses
        return {
            "is_success": bool(outcome.success),
            "failure": outcome.failure,
            "goal_held": bool(outcome.goal_held),
            "goal_gripped": bool(outcome.goal_gripped),
            "goal_lift": float(outcome.goal_lift),
            "true_object_poses": padded,
            "object_names": self._task.names,
            "sim_steps": int(self._sim_steps),
            "action_clipped": bool(clipped),
            "potential": float(self._potential),
            "shaping": float(shaped),
        }


class ClutterRetrieveEnv(_RetrievalEnv):
    """`ClutterRetrieve-v0`: one step executes a whole trajectory of `waypoints` joint rows
    (`sim.controllers.TrajectoryController`); the Dict observation of `model.observation`."""

    def __init__(
        self,
        render_mode: str | None = None,
        waypoints: int = DEFAULT_WAYPOINTS,
        max_hand_speed: float = 0.05,
        **kwargs: Any,
    ) -> None:
        self.waypoints = integer("waypoints", waypoints, 1)
        self._max_hand_speed = positive_number("max_hand_speed", max_hand_speed, "m/s")
        super().__init__(render_mode, **kwargs)

    def _make_controller(self, arm: np.ndarray, hand: HandCommand) -> Controller:
        controller = TrajectoryController(
            self.herb, self.kinematics, self.waypoints, self._max_hand_speed, self.sim.timestep
        )
        controller.reset(hand)
        return controller

    def _observation_space(self) -> spaces.Dict:
        return observation_space(MAX_OBJECTS)

    def _observe(self, outcome: Outcome, tcp: Pose) -> Observation:
        obs = self._state(outcome, tcp)
        obs.update({key: value.copy() for key, value in self._static_obs.items()})
        return obs

    def _reward(self, obs: Observation, outcome: Outcome, info: dict[str, Any]) -> float:
        return float(
            reward(outcome.success, bool(outcome.failure), info["shaping"], self.reward_type)
        )

    def _decided(self) -> bool:
        # Long trajectories stop early once the episode is decided.
        return self._sim_steps % MONITOR_EVERY == 0 and self._task.evaluate().done

    def execute_trajectory(
        self, trajectory: Trajectory, speeds: Mapping[str, SegmentSpeed] | None = None
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """One env step that runs a planned `Trajectory` segment by segment, each within the
        speed limits ``speeds[segment.label]`` (the env's `max_hand_speed` and the joints'
        default scale for labels not given), then settles once. For wrappers that act with
        planned primitives (``ClutterRetrievePrimitive-v0``): free-space motion fast, contact
        quasi-static."""
        if self._ended:
            raise RuntimeError("execute_trajectory() after the episode ended: call reset() first")
        if not isinstance(trajectory, Trajectory):
            raise invalid("trajectory", trajectory, "a clutter_gym.model.trajectory.Trajectory")
        limits = dict(speeds or {})
        for label, speed in limits.items():
            positive_number(f"speeds[{label!r}].hand", speed.hand, "m/s")
            positive_number(f"speeds[{label!r}].joints", speed.joints, "of the velocity limits")
        controller = self._controller
        assert isinstance(controller, TrajectoryController)
        low, high = controller.action_space.low[0], controller.action_space.high[0]
        clipped = False
        ended = False
        for segment in trajectory.segments:
            rows = segment.rows()
            bounded = np.clip(rows, low, high)
            clipped |= bool(np.any(bounded != rows))
            speed = limits.get(segment.label, SegmentSpeed(self._max_hand_speed))
            ended = controller.run(bounded, self._substep, speed)
            if ended:
                break
        if not ended:
            controller.settle(self._substep)
        return self._finish_step(clipped)


class ClutterRetrieveEEEnv(_RetrievalEnv):
    """`ClutterRetrieveEE-v0` (sparse) and `ClutterRetrieveEEDense-v0` (dense reward): one step
    moves the TCP by a small delta (`sim.controllers.EndEffectorDeltaController`) from a ready
    pose with the hand horizontal (`ready_configuration`).

    Goal-conditioned, as Gymnasium-Robotics' GoalEnv (observation, achieved_goal, desired_goal;
    `model.observation` defines them) for stable-baselines3's HerReplayBuffer. The lift task's
    goal is a height: `compute_reward` counts a success when the goal object is held (the env's
    finger-contact check, from `info`) and its base is at least as high as desired_goal's z.
    x and y are not scored, because pushing the object before grasping it is allowed; they tell
    the policy where the object is. For the episode's own desired goal this is exactly the
    env's success, and with a goal relabelled by HER (an achieved height) it rewards holding
    the object at least that high.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}  # noqa: RUF012
    timestep = EE_TIMESTEP
    merge_fixed_links = True  # a ~40% cheaper physics step (`sim.robot`)

    def __init__(self, *args: Any, objective: Objective = "retrieve", **kwargs: Any) -> None:
        _check_choice("objective", objective, OBJECTIVES)
        self.objective: Objective = objective
        super().__init__(*args, **kwargs)

    @staticmethod
    def _surfaces() -> tuple[str, ...]:
        return ("table",)

    def _check_scene(self, scene: Scene, field: str) -> Scene:
        if scene.goal.success != "lift":
            raise ValueError(
                f"{field}: a {scene.surface} scene whose goal is {scene.goal.success!r}; "
                "expected a lift task (a table scene): the end-effector variants lift the goal"
            )
        return scene

    def _start_arm_default(self, scene: Scene) -> np.ndarray:
        return ready_configuration(get_surface(scene.surface))

    def _objective(self) -> Objective:
        return self.objective

    def _make_controller(self, arm: np.ndarray, hand: HandCommand) -> Controller:
        controller = EndEffectorDeltaController(self.herb, self.kinematics)
        controller.reset(arm)
        return controller

    def _observation_space(self) -> spaces.Dict:
        return goal_observation_space(MAX_OBJECTS, GOAL_SIZES[self.objective])

    def _observe(self, outcome: Outcome, tcp: Pose) -> Observation:
        obs = self._state(outcome, tcp)
        obs.update(self._static_obs)
        goal = int(obs["goal_object"])
        x, y = (float(v) for v in obs["object_poses"][goal, :2])
        if self.objective == "grasp":  # the hand where this detection puts the grasp point
            offset = self._task.grasp_offset(np.array([x, y, outcome.goal_position[2]]))
            achieved = np.r_[offset, float(outcome.goal_gripped)]
            self._desired = GRASP_GOAL.copy()
        else:
            if self._steps == 0:  # the episode's first detection fixes where the goal must rise
                self._desired = np.array([x, y, self._task.goal_height])
            achieved = np.array([x, y, outcome.goal_position[2]])
        return encode_goal_observation(obs, achieved, self._desired)

    def _reward(self, obs: Observation, outcome: Outcome, info: dict[str, Any]) -> float:
        return float(self.compute_reward(obs["achieved_goal"], obs["desired_goal"], info))

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: object
    ) -> np.ndarray | float:
        """The reward of goals (B, n) with a batch of infos (a sequence of info dicts, or one
        dict of arrays), or of one goal (n,) with its info; a float for one goal. The grasp
        objective's goals are the TCP's offset from the goal's grasp point and whether two
        fingers grip it: a goal HER relabels from a step without a grip pays for bringing the
        hand to that offset again."""
        held, failed, shaped = _info_arrays(info)
        achieved = np.asarray(achieved_goal, dtype=np.float64)
        desired = np.asarray(desired_goal, dtype=np.float64)
        if self.objective == "grasp":
            holds = achieved[..., 3] >= desired[..., 3]
            success = grasped(achieved[..., :3], desired[..., :3], holds) & ~failed
        else:
            success = held & ~failed & lifted(achieved[..., 2], desired[..., 2])
        rewards = reward(success, failed, shaped, self.reward_type)
        return float(rewards) if rewards.ndim == 0 else rewards


def _info_arrays(info: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """goal_held, failed and shaping of one info dict, a dict of arrays (a vector env's) or a
    sequence of info dicts (a replay buffer's), as arrays."""
    try:
        if isinstance(info, Mapping):
            return (
                np.asarray(info["goal_held"], dtype=bool),
                np.asarray(info["failure"]) != "",
                np.asarray(info["shaping"], dtype=np.float64),
            )
        infos = list(info)  # type: ignore[call-overload]
        return (
            np.array([i["goal_held"] for i in infos], dtype=bool),
            np.array([i["failure"] != "" for i in infos], dtype=bool),
            np.array([i["shaping"] for i in infos], dtype=np.float64),
        )
    except KeyError as missing:
        raise ValueError(
            f"info: has no {missing}; compute_reward needs the step's info (goal_held, failure, "
            "shaping): with stable-baselines3's HerReplayBuffer pass "
            "replay_buffer_kwargs={'copy_info_dict': True}"
        ) from None


def _check_choice(field: str, value: object, allowed: tuple[str | None, ...]) -> None:
    """Only a str (or None) is looked up: `in` compares an array element-wise, so a
    one-element array would pass and a longer one would raise numpy's ambiguity error."""
    if not (value is None or isinstance(value, str)) or value not in allowed:
        raise invalid(field, value, "one of " + ", ".join(map(repr, allowed)))


def _discount(value: object) -> float:
    """`gamma`: a real in (0, 1], not a bool."""
    real = float(value) if isinstance(value, numbers.Real) else math.nan
    if isinstance(value, bool) or not 0.0 < real <= 1.0:
        raise invalid("gamma", value, "a discount factor in (0, 1] (the learning agent's)")
    return real


def _load_scene(scene: object, field: str) -> Scene:
    """A scene source loaded now, so that a bad file fails before anything changes; the scene
    module's errors get the field's name in front."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping | os.PathLike) or (isinstance(scene, str) and scene):
        try:
            return load_scene(scene)
        except ValueError as err:
            raise ValueError(f"{field}: {err}") from err
    raise invalid(field, scene, "a Scene, a scene dict or a non-empty JSON file path")
