"""The scene commands: `scene` generates one at a clutter level, `render` draws one to a PNG."""

from __future__ import annotations

import argparse
import json

from agents.cli.arguments import SEED, input_file, noise, output_file


def add_scene(parser: argparse.ArgumentParser) -> None:
    from clutter_gym.model.scene import LEVELS
    from clutter_gym.model.world import SURFACES

    parser.add_argument("--level", choices=LEVELS, required=True, help="clutter level")
    parser.add_argument("--seed", type=SEED, required=True, help="generator seed")
    parser.add_argument("--surface", choices=tuple(SURFACES), default="table", help="support")
    parser.add_argument("--noise", type=noise, default="sigma2", help="detection noise")
    parser.add_argument("--out", type=output_file, required=True, help="scene JSON to write")


def run_scene(args: argparse.Namespace) -> int:
    from clutter_gym.model.scene import generate_scene, save_scene, scene_to_dict

    scene = generate_scene(args.level, seed=args.seed, surface=args.surface, noise=args.noise)
    save_scene(scene, args.out)
    print(json.dumps(scene_to_dict(scene)))
    return 0


def add_render(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", type=input_file, required=True, help="scene JSON")
    parser.add_argument("--out", type=output_file, required=True, help="PNG to write")


def run_render(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    from clutter_gym.media import write_png
    from clutter_gym.model.scene import load_scene

    scene = load_scene(args.scene)
    env = gym.make("ClutterRetrieve-v0", render_mode="rgb_array")
    try:
        env.reset(seed=0, options={"scene": scene})
        frame = env.render()
    finally:
        env.close()
    assert isinstance(frame, np.ndarray)
    write_png(args.out, frame)
    print(f"wrote {args.out}")
    return 0


COMMANDS = {"scene": (add_scene, run_scene), "render": (add_render, run_render)}
