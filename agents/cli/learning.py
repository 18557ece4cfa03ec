"""The learning commands: `train` (stable-baselines3 / sb3-contrib runs and grids) and
`evaluate` (trained agents, planners and the scripted grasp on the same episodes)."""

from __future__ import annotations

import argparse
import json
import sys

from agents.cli.arguments import (
    COUNT,
    SEED,
    agent,
    fraction,
    input_dir,
    input_file,
    integers,
    names_from,
    noise,
    output_dir,
    output_file,
    positive_number,
)
from agents.learning.rl_config import ALGOS
from agents.runner.jobs import BACKENDS
from clutter_gym import ENV_IDS


def add_train(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--algo",
        type=names_from(ALGOS, "an algorithm"),
        required=True,
        help="ppo, sac or tqc; comma-separated for a grid",
    )
    parser.add_argument("--env", choices=ENV_IDS, required=True, help="the variant's id")
    parser.add_argument(
        "--config",
        type=input_file,
        default=None,
        help="hyperparameters YAML keyed by env id (None: agents/hyperparams/<algo>.yml)",
    )
    parser.add_argument("--steps", type=COUNT, default=None, help="env steps (None: n_timesteps)")
    parser.add_argument("--n-envs", type=COUNT, default=None, help="envs (None: n_envs, or 1)")
    seeds = parser.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=SEED, default=0, help="the run's seed")
    seeds.add_argument(
        "--seeds", type=integers(0), default=None, help="a grid of seeds, e.g. 0,1,2"
    )
    parser.add_argument(
        "--out", type=output_dir, required=True, help="the run's directory (a grid's: one per run)"
    )
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where runs go")
    parser.add_argument("--workers", type=COUNT, default=1, help="runs of a grid in parallel")
    parser.add_argument(
        "--eval-freq", type=COUNT, default=None, help="steps between evaluations (None: steps/10)"
    )
    parser.add_argument("--eval-episodes", type=COUNT, default=10, help="episodes per evaluation")
    parser.add_argument(
        "--save-freq", type=COUNT, default=None, help="steps between checkpoints (None: eval-freq)"
    )
    parser.add_argument(
        "--demos",
        type=input_dir,
        default=None,
        help="a `clutter-gym demos` directory: its successful episodes pre-fill the replay buffer",
    )


def run_train(args: argparse.Namespace) -> int:
    from agents.learning.train import GridRequest, prepare_grid, run_grid

    request = GridRequest(
        algos=args.algo,
        env_id=args.env,
        config=args.config,
        steps=args.steps,
        n_envs=args.n_envs,
        seeds=args.seeds or (args.seed,),
        grid=args.seeds is not None or len(args.algo) > 1,
        out=args.out,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        save_freq=args.save_freq,
        demos=args.demos,
    )
    jobs = prepare_grid(request)  # every check before any training
    records = run_grid(jobs, args.out, backend=args.backend, workers=args.workers)
    for record in records:
        print(json.dumps(record))
    return 0 if all(r["status"] == "finished" for r in records) else 1


def add_evaluate(parser: argparse.ArgumentParser) -> None:
    from clutter_gym.model.scene import GOAL_KINDS, LEVELS
    from clutter_gym.model.world import SURFACES

    parser.add_argument(
        "--agent",
        type=agent,
        action="append",
        required=True,
        help="a training directory, planner:NAME (pushing, pg, tsr, pick-and-place) or scripted",
    )
    parser.add_argument("--env", choices=ENV_IDS, required=True, help="the evaluated variant")
    parser.add_argument("--episodes", type=COUNT, default=10, help="episodes per agent")
    parser.add_argument("--seed", type=SEED, default=0, help="episode k resets with seed + k")
    parser.add_argument(
        "--json", type=output_file, required=True, help="report; its jobs log goes beside it"
    )
    parser.add_argument("--md", type=output_file, default=None, help="the table as Markdown")
    parser.add_argument("--level", choices=LEVELS, default=None, help="clutter of the scenes")
    parser.add_argument("--goal-kind", choices=GOAL_KINDS, default=None, help="goal's kind")
    parser.add_argument("--noise", type=noise, default=None, help="detection noise override")
    parser.add_argument("--surface", choices=tuple(SURFACES), default=None, help="support")
    parser.add_argument(
        "--scenes", type=input_file, nargs="+", default=None, help="scene files to draw from"
    )
    parser.add_argument("--budget", type=positive_number, default=20.0, help="planning [s]")
    parser.add_argument(
        "--grasped-start",
        type=fraction,
        default=None,
        help="agents trained on ClutterRetrieveEELift-v0: the fraction of episodes that start "
        "with the goal in the hand (None: as trained)",
    )
    parser.add_argument("--workers", type=COUNT, default=1, help="episodes in parallel")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where jobs run")


def run_evaluate(args: argparse.Namespace) -> int:
    from agents.learning.evaluate import (
        check_agents,
        check_envs,
        plan_episodes,
        run_evaluation,
        scene_keywords,
    )

    given = {
        "level": args.level,
        "goal_kind": args.goal_kind,
        "noise": args.noise,
        "surface": args.surface,
        "scenes": [str(path) for path in args.scenes] if args.scenes else None,
    }
    scenes = scene_keywords(args.agent, {k: v for k, v in given.items() if v is not None})
    jobs = plan_episodes(
        args.agent, args.episodes, args.seed, scenes, args.budget, args.grasped_start
    )
    check_envs(jobs)
    check_agents(jobs)
    report = run_evaluation(
        args.agent, args.env, jobs, args.json, args.md, args.workers, args.backend
    )
    for label, cell in report["summary"].items():
        print(json.dumps({"agent": label, **cell}))
    print(f"wrote {', '.join(str(p) for p in (args.json, args.md) if p)}", file=sys.stderr)
    return 0


DEMO_ENVS = (
    "ClutterRetrieveEE-v0",
    "ClutterRetrieveEEDense-v0",
    "ClutterRetrieveEEGrasp-v0",
    "ClutterRetrieveEELift-v0",
)


def add_demos(parser: argparse.ArgumentParser) -> None:
    from clutter_gym.model.scene import GOAL_KINDS, LEVELS
    from planners.kinds import PLANNERS

    parser.add_argument("--planner", choices=tuple(PLANNERS), default="pushing", help="teacher")
    parser.add_argument("--env", choices=DEMO_ENVS, required=True, help="an end-effector variant")
    parser.add_argument("--episodes", type=COUNT, required=True, help="episodes recorded")
    parser.add_argument("--seed", type=SEED, default=0, help="episode k resets with seed + k")
    parser.add_argument("--out", type=output_dir, required=True, help="demos.npz, demos.json")
    parser.add_argument("--level", choices=LEVELS, default="none", help="clutter of the scenes")
    parser.add_argument("--goal-kind", choices=GOAL_KINDS, default="soda_can", help="goal's kind")
    parser.add_argument("--noise", type=noise, default="sigma1", help="detection noise")
    parser.add_argument("--budget", type=positive_number, default=20.0, help="planning [s]")
    parser.add_argument(
        "--grasped-start",
        type=fraction,
        default=None,
        help="ClutterRetrieveEELift-v0 only: the fraction of episodes that start with the goal "
        "in the hand (None: the env's default, 0.5)",
    )


def run_demos(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from agents.learning.demos import Demo, record_demos, save_demos
    from agents.learning.lift_env import LIFT_ENV_ID

    env_kwargs: dict[str, object] = {
        "level": args.level,
        "goal_kind": args.goal_kind,
        "noise": args.noise,
    }
    if args.grasped_start is not None:
        if args.env != LIFT_ENV_ID:
            raise ValueError(
                f"--grasped-start: only {LIFT_ENV_ID} starts with the goal in the hand, "
                f"not {args.env}"
            )
        env_kwargs["grasped_start"] = args.grasped_start
    with tqdm(total=args.episodes, desc=f"demos ({args.planner})", unit="episode") as bar:

        def done(demo: Demo) -> None:
            bar.update()
            bar.set_postfix(success=demo.success)

        demos = record_demos(
            args.env, env_kwargs, args.planner, args.episodes, args.seed, args.budget, done
        )
    meta = {"env": args.env, "env_kwargs": env_kwargs, "planner": args.planner, "seed": args.seed}
    save_demos(args.out, demos, meta)
    successes = sum(d.success for d in demos)
    print(
        json.dumps({**meta, "episodes": len(demos), "successes": successes, "out": str(args.out)})
    )
    return 0


COMMANDS = {
    "train": (add_train, run_train),
    "evaluate": (add_evaluate, run_evaluate),
    "demos": (add_demos, run_demos),
}
