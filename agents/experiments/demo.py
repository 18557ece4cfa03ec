"""`clutter-gym demo`: one retrieval on a scene with the Rearrange planner as the policy,
recorded as a GIF with a JSON summary (plan, planning time, objects moved, outcome)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import clutter_gym  # noqa: F401  (registers the env)
from agents.policies.rearrange import RearrangePolicy
from agents.policies.rollout import roll_out
from clutter_gym.env import ClutterRetrieveEnv
from clutter_gym.media import gif_writer, write_json
from clutter_gym.model.scene import Scene, load_scene, scene_to_dict, shipped_scene
from planners.actions.settings import PlannerSettings

FRAME_EVERY = 24  # physics steps between GIF frames: 10 frames per simulated second
DEFAULT_SCENE = "figures/fig3_can_box_dumbbell"
PLANNING_BUDGET = 60.0
"""s: the demo's plan takes about 8 s on an idle 2-core machine; the wall-clock budget is
there to stop a hopeless search, not to fail the demo on a loaded machine."""
STEP_LIMIT = 40  # env steps of 16 waypoints: room for a plan that moves a few objects


def default_scene() -> Scene:
    """The paper's Figs. 3-5: a red can behind a large ungraspable box, a dumbbell beside it."""
    return load_scene(shipped_scene(DEFAULT_SCENE))


def run_demo(scene: str | Path | None, out_dir: Path, seed: int = 0) -> dict[str, Any]:
    """Plans with Rearrange from the first detection of `scene` (default: the demo scene) and
    executes the plan; writes `out_dir/demo.gif` and `out_dir/demo.json`, returns the summary."""
    chosen = default_scene() if scene is None else load_scene(scene)
    env = gym.make("ClutterRetrieve-v0", render_mode="rgb_array", max_episode_steps=STEP_LIMIT)
    base: ClutterRetrieveEnv = env.unwrapped  # type: ignore[assignment]
    gif = out_dir / "demo.gif"
    try:
        obs, info = env.reset(seed=seed, options={"scene": chosen})
        settings = PlannerSettings(time_budget=PLANNING_BUDGET, seed=seed)
        policy = RearrangePolicy(
            base.waypoints, settings=settings, names=info["object_names"], seed=seed
        )
        with (
            gif_writer(gif, fps=10) as frames,
            tqdm(desc="demo (simulated s)", bar_format="{desc}: {n:.1f} [{elapsed}]") as bar,
        ):

            def record(frame: np.ndarray) -> None:
                frames.add(frame)
                bar.update(frames.frames * FRAME_EVERY * base.sim.timestep - bar.n)

            base.start_recording(record, FRAME_EVERY)
            rollout = roll_out(env, obs, policy, info, stop=lambda: bool(policy.failure))
            base.stop_recording()
        timestep = base.sim.timestep
    finally:
        env.close()
    info = rollout.info
    goal_index = list(info["object_names"]).index(chosen.goal.object)
    summary: dict[str, Any] = {
        "scene": scene_to_dict(chosen),
        "planner": "pushing (Rearrange, planners.rearrange)",
        "plan": policy.plan.summary().as_dict() if policy.plan else None,
        "planning_failure": policy.failure,
        "success": bool(info["is_success"]),
        "failure": info["failure"],
        "goal_held": info["goal_held"],
        "goal_lift_m": round(float(info["goal_lift"]), 4),
        "env_steps": rollout.steps,
        "return": rollout.ret,
        "simulated_seconds": round(info["sim_steps"] * timestep, 3),
        "goal_true_pose_end": np.round(info["true_object_poses"][goal_index], 4).tolist(),
        "gif": str(gif),
        "frames": frames.frames,
    }
    write_json(out_dir / "demo.json", summary)
    return summary
