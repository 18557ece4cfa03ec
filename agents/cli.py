"""The `clutter-gym` command line.

clutter-gym demo [--scene scene.json] [--out-dir out/demo]
clutter-gym plan --scene scene.json [--planner pushing] [--execute --trials 100] [--json out.json]
    [--gif out.gif] [--figure timeline.png]
clutter-gym scene --level high --seed 3 [--surface table] [--noise sigma2] --out scene.json
clutter-gym render --scene scene.json --out scene.png
clutter-gym bench env|capture|plan|ik --json out.json [--samples 500]
clutter-gym benchmark --suite table1|fig15|perturbed [--planners tsr,pg,pushing,pick-and-place]
    --json out.json [--md out.md] [--plots dir] [--trials 10] [--workers 2] [--backend local|ray]
clutter-gym benchmark-plots --json out.json --out dir
clutter-gym train --algo ppo|sac|tqc[,...] --env ID [--config agents/hyperparams/ppo.yml]
    [--steps N] [--n-envs K] [--seed S | --seeds 0,1,2] --out DIR [--backend local|ray]
    [--workers 1] [--eval-freq F] [--eval-episodes E] [--save-freq C]
clutter-gym evaluate --agent DIR|planner:pushing|planner:pg|planner:tsr|scripted [--agent ...]
    --env ID --episodes N --seed S --json out.json [--md out.md]
    [--level none] [--goal-kind soda_can] [--noise sigma1] [--scenes a.json ...]
clutter-gym plot-training DIR... --out fig.png

Bad input is one line naming the flag, the value and what is allowed, exit status 2; every
argument is checked before any work starts.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

import numpy as np

from agents.benchmark import SUITES
from agents.cli_args import (
    input_dir,
    input_file,
    integer,
    integers,
    names,
    names_from,
    numbers,
    output_dir,
    output_file,
    positive_number,
    read_json,
)
from agents.jobs import BACKENDS
from agents.rl_config import ALGOS
from agents.validate_capture import ACTIONS as VALIDATED_ACTIONS
from clutter_gym import ENV_IDS, __version__
from clutter_gym.media import write_json, write_png
from clutter_gym.model.noise import NOISE_LEVELS, resolve_noise
from clutter_gym.model.scene import (
    GOAL_KINDS,
    LEVELS,
    generate_scene,
    load_scene,
    save_scene,
    scene_to_dict,
)
from clutter_gym.model.world import SURFACES


def _cmd_demo(args: argparse.Namespace) -> int:
    from agents.demo import run_demo

    summary = run_demo(scene=args.scene, out_dir=args.out_dir, seed=args.seed)
    outcome = (
        "success"
        if summary["success"]
        else f"failed: {summary['failure'] or summary['planning_failure']}"
    )
    print(
        f"{outcome}; goal lifted {summary['goal_lift_m']:.3f} m in "
        f"{summary['simulated_seconds']:.1f} simulated s; wrote {summary['gif']} and "
        f"{args.out_dir / 'demo.json'}"
    )
    return 0 if summary["success"] else 1


def _cmd_plan(args: argparse.Namespace) -> int:
    from agents.execute import run_plan

    trials = args.trials if args.execute else 0
    report = run_plan(
        args.scene,
        planner=args.planner,
        trials=trials,
        out=args.json,
        gif=args.gif,
        figure=args.figure,
        seed=args.seed,
        time_budget=args.budget,
        samples=args.samples,
        workers=args.workers,
        noise=args.noise,
    )
    keys = (
        "planner", "noise", "samples", "success", "reason", "planning_time_s", "actions",
        "objects_moved", "trials", "execution_successes", "execution_success_rate",
        "execution_failures", "mean_execution_simulated_s", "resumed_trials",
    )  # fmt: skip
    print(json.dumps({k: report[k] for k in keys if k in report}))
    if not report["success"]:
        for line in report["blocked_by"][:8]:
            print(f"  blocked by: {line}", file=sys.stderr)
    return 0 if report["success"] else 1


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from agents.benchmark import run_benchmark

    report = run_benchmark(
        args.suite,
        planners=args.planners,
        out=args.json,
        markdown=args.md,
        trials=args.trials,
        seed=args.seed,
        time_budget=args.budget,
        workers=args.workers,
        backend=args.backend,
        scenes_per_group=args.scenes_per_group,
        noises=args.noises,
        plots=args.plots,
    )
    for planner, groups in report["summary"].items():
        for group, noises in groups.items():
            for noise, cell in noises.items():
                print(json.dumps({"planner": planner, "group": group, "noise": noise, **cell}))
    written = [args.json, args.md, *report.get("plots", [])]
    print(f"wrote {', '.join(str(w) for w in written if w)}", file=sys.stderr)
    return 0


def _cmd_benchmark_plots(args: argparse.Namespace) -> int:
    from agents.benchmark_plots import check_report, write_plots

    report = check_report(read_json(args.json, "--json"), args.json)
    for path in write_plots(report, args.out):
        print(f"wrote {path}")
    return 0


def _cmd_scene(args: argparse.Namespace) -> int:
    scene = generate_scene(args.level, seed=args.seed, surface=args.surface, noise=args.noise)
    save_scene(scene, args.out)
    print(json.dumps(scene_to_dict(scene)))
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    import gymnasium as gym

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


def _cmd_bench(args: argparse.Namespace) -> int:
    if args.target == "capture":
        from planners.capture_bench import bench_capture

        result = bench_capture(args.objects)
    elif args.target == "plan":
        from agents.plan_bench import bench_plan

        result = bench_plan(args.seeds)
    elif args.target == "ik":
        from agents.ik_bench import bench_ik

        result = bench_ik(args.samples)
    else:
        from clutter_gym.bench import bench_env

        result = bench_env(args.steps, args.trajectory_steps, args.resets, args.primitive_steps)
    line = json.dumps(result, sort_keys=True)
    if args.json:
        write_json(args.json, result)
    print(line)
    return 0


def _cmd_validate_capture(args: argparse.Namespace) -> int:
    from agents.validate_capture import validate

    report = validate(
        args.object,
        args.trials,
        args.json,
        args.rotations,
        args.workers,
        args.action,
        args.aperture,
    )
    for rotation in args.rotations:
        print(
            json.dumps(
                {
                    "object": report["object"],
                    "aperture_m": report["aperture_m"],
                    "rotation_deg": rotation,
                    **{
                        k: v
                        for k, v in report[f"rotation_{rotation:g}deg"].items()
                        if k != "failures_inside_examples"
                    },
                }
            )
        )
    return 0


def _cmd_reachability(args: argparse.Namespace) -> int:
    from agents.reachability import build_map, plot_map

    names = tuple(SURFACES) if args.surface == "all" else (args.surface,)
    for name in names:
        built, path = build_map(name, args.workers, args.log_dir)
        figure = args.figure_dir / f"reachability_{name}.png"
        plot_map(built, SURFACES[name], figure)
        print(json.dumps({"surface": name, "map": str(path), "figure": str(figure),
                          "reachable_fraction": round(float(built.reach.mean()), 4)}))  # fmt: skip
    return 0


def _cmd_capture_region(args: argparse.Namespace) -> int:
    from agents.capture_figure import capture_figure, check_validation

    validation = None
    if args.validation is not None:
        report = read_json(args.validation, "--validation")
        validation = check_validation(report, args.validation, args.action)
    capture_figure(args.object, args.out, validation, action=args.action)
    print(f"wrote {args.out}")
    return 0


def _cmd_train(args: argparse.Namespace) -> int:
    from agents.train import GridRequest, prepare_grid, run_grid

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
    )
    jobs = prepare_grid(request)  # every check before any training
    records = run_grid(jobs, args.out, backend=args.backend, workers=args.workers)
    for record in records:
        print(json.dumps(record))
    return 0 if all(r["status"] == "finished" for r in records) else 1


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from agents.evaluate import check_envs, plan_episodes, run_evaluation, scene_keywords

    given = {
        "level": args.level,
        "goal_kind": args.goal_kind,
        "noise": args.noise,
        "surface": args.surface,
        "scenes": [str(path) for path in args.scenes] if args.scenes else None,
    }
    scenes = scene_keywords(args.agent, {k: v for k, v in given.items() if v is not None})
    jobs = plan_episodes(args.agent, args.episodes, args.seed, scenes, args.budget)
    check_envs(jobs)
    report = run_evaluation(
        args.agent, args.env, jobs, args.json, args.md, args.workers, args.backend
    )
    for label, cell in report["summary"].items():
        print(json.dumps({"agent": label, **cell}))
    print(f"wrote {', '.join(str(p) for p in (args.json, args.md) if p)}", file=sys.stderr)
    return 0


def _cmd_plot_training(args: argparse.Namespace) -> int:
    from agents.training_plots import plot_training

    curves = plot_training(args.runs, args.out, args.title)
    print(f"wrote {args.out} ({len(curves)} runs)")
    return 0


def _agent(text: str) -> object:
    """An agent of `clutter-gym evaluate`, checked now (a training directory is read)."""
    from agents.evaluate import parse_agent

    try:
        return parse_agent(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (and exit status 2), defaults shown."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _HelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """The module docstring as written, and every option's default in --help (once: a help
    text that already says its default, "(None: ...)" or "(default: ...)", keeps its own)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if "(default:" in text or "(None:" in text:
            return text
        return super()._get_help_string(action)


def _noise(text: str) -> str | tuple[float, float]:
    """A noise level name, or "sigma_xy,sigma_theta" in metres and radians."""
    try:
        if "," in text:
            xy, theta = text.split(",", 1)
            return resolve_noise((float(xy), float(theta)))
        resolve_noise(text)
        return text
    except ValueError as error:
        levels = ", ".join(NOISE_LEVELS)
        why = f" ({error})" if "," in text else ""
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a noise level ({levels}) or 'sigma_xy,sigma_theta'{why}"
        ) from None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="clutter-gym", description=__doc__)
    parser.add_argument("--version", action="version", version=f"clutter-gym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    count = integer(1)
    seed = integer(0)

    demo = sub.add_parser("demo", help="retrieve the goal object of a scene; write a GIF and JSON")
    demo.add_argument(
        "--scene", type=input_file, default=None, help="scene JSON (default: the paper's Figs. 3-5)"
    )
    demo.add_argument("--out-dir", type=output_dir, default="out/demo", help="GIF and JSON here")
    demo.add_argument("--seed", type=seed, default=0, help="detection and planner seed")
    demo.set_defaults(func=_cmd_demo)

    plan = sub.add_parser(
        "plan", help="plan a retrieval with Rearrange; optionally execute it on noisy worlds"
    )
    plan.add_argument("--scene", type=input_file, required=True, help="scene JSON (true poses)")
    plan.add_argument("--planner", default="pushing", help="pushing, pick-and-place, pg or tsr")
    plan.add_argument(
        "--noise",
        type=_noise,
        default=None,
        help="override the scene's noise: a level or 'xy,theta'",
    )
    plan.add_argument("--execute", action="store_true", help="execute the plan on true worlds")
    plan.add_argument("--trials", type=integer(0), default=100, help="true worlds with --execute")
    plan.add_argument("--json", type=output_file, default=None, help="write the report here")
    plan.add_argument("--gif", type=output_file, default=None, help="record one execution")
    plan.add_argument(
        "--figure", type=output_file, default=None, help="write the planning timeline PNG"
    )
    plan.add_argument("--seed", type=seed, default=0, help="detection, samples, worlds, OMPL")
    plan.add_argument("--budget", type=positive_number, default=20.0, help="planning budget [s]")
    plan.add_argument(
        "--samples", type=count, default=None, help="uncertainty samples (default: the paper's n)"
    )
    plan.add_argument("--workers", type=count, default=2, help="processes for --execute")
    plan.set_defaults(func=_cmd_plan)

    benchmark = sub.add_parser(
        "benchmark", help="the paper's experiments (Table 1, pushing vs pick-and-place)"
    )
    benchmark.add_argument("--suite", required=True, choices=tuple(SUITES), help="which experiment")
    benchmark.add_argument(
        "--planners",
        type=names,
        default=None,
        help="comma-separated: tsr, pg, pushing, pick-and-place (default: the suite's)",
    )
    benchmark.add_argument(
        "--json", type=output_file, required=True, help="report; its jobs log goes beside it"
    )
    benchmark.add_argument("--md", type=output_file, default=None, help="the table as Markdown")
    benchmark.add_argument("--plots", type=output_dir, default=None, help="PNG plots here")
    benchmark.add_argument("--trials", type=integer(0), default=10, help="true worlds per plan")
    benchmark.add_argument("--seed", type=seed, default=0, help="seed of every detection")
    benchmark.add_argument(
        "--budget", type=positive_number, default=20.0, help="planning budget [s]"
    )
    benchmark.add_argument("--workers", type=count, default=2, help="jobs in parallel")
    benchmark.add_argument("--backend", choices=BACKENDS, default="local", help="where jobs run")
    benchmark.add_argument(
        "--scenes-per-group", type=count, default=None, help="only the first N scenes per level"
    )
    benchmark.add_argument(
        "--noises", type=names, default=None, help="only these noise levels, e.g. sigma2,sigma3"
    )
    benchmark.set_defaults(func=_cmd_benchmark)

    plots = sub.add_parser("benchmark-plots", help="PNG plots from a benchmark JSON")
    plots.add_argument("--json", type=input_file, required=True, help="a benchmark report")
    plots.add_argument("--out", type=output_dir, required=True, help="directory for the PNGs")
    plots.set_defaults(func=_cmd_benchmark_plots)

    scene = sub.add_parser("scene", help="generate a scene at one of the paper's clutter levels")
    scene.add_argument("--level", choices=LEVELS, required=True, help="clutter level")
    scene.add_argument("--seed", type=seed, required=True, help="generator seed")
    scene.add_argument("--surface", choices=tuple(SURFACES), default="table", help="support")
    scene.add_argument("--noise", type=_noise, default="sigma2", help="detection noise")
    scene.add_argument("--out", type=output_file, required=True, help="scene JSON to write")
    scene.set_defaults(func=_cmd_scene)

    render = sub.add_parser("render", help="render a scene file to a PNG")
    render.add_argument("--scene", type=input_file, required=True, help="scene JSON")
    render.add_argument("--out", type=output_file, required=True, help="PNG to write")
    render.set_defaults(func=_cmd_render)

    validate = sub.add_parser(
        "validate-capture", help="capture region vs pybullet physics (paper Fig. 11)"
    )
    validate.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    validate.add_argument(
        "--action", choices=VALIDATED_ACTIONS, default="push-grasp", help="the region's action"
    )
    validate.add_argument("--trials", type=count, default=1000, help="grid poses per rotation")
    validate.add_argument(
        "--aperture",
        type=positive_number,
        default=None,
        help="push-grasp preshape, m between the fingertips (default: one that fits the object "
        "at any orientation; the planner's are listed by planners.capture.push_grasp_apertures)",
    )
    validate.add_argument(
        "--json", type=output_file, required=True, help="report; its trials log goes beside it"
    )
    validate.add_argument(
        "--rotations", type=numbers, default="0,45", help="scene rotations in degrees"
    )
    validate.add_argument("--workers", type=count, default=2, help="trials in parallel")
    validate.set_defaults(func=_cmd_validate_capture)

    figure = sub.add_parser("capture-region", help="plot a push-grasp or sweep capture region")
    figure.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    figure.add_argument(
        "--action", choices=VALIDATED_ACTIONS, default="push-grasp", help="the region's action"
    )
    figure.add_argument("--out", type=output_file, required=True, help="PNG to write")
    figure.add_argument(
        "--validation", type=input_file, default=None, help="JSON of clutter-gym validate-capture"
    )
    figure.set_defaults(func=_cmd_capture_region)

    reach = sub.add_parser(
        "reachability", help="build the arm's reachability map of a support and plot it"
    )
    reach.add_argument("--surface", choices=(*SURFACES, "all"), default="all", help="which")
    reach.add_argument("--workers", type=count, default=2, help="rows in parallel")
    reach.add_argument(
        "--log-dir", type=output_dir, default="out/reachability", help="job logs (resumable)"
    )
    reach.add_argument("--figure-dir", type=output_dir, default="docs", help="the PNG plots")
    reach.set_defaults(func=_cmd_reachability)

    _add_rl_commands(sub, count, seed)

    bench = sub.add_parser("bench", help="speed and memory benchmarks, written as JSON")
    bench.add_argument("target", choices=("env", "capture", "plan", "ik"), help="what to measure")
    bench.add_argument("--json", type=output_file, default=None, help="also write the result here")
    bench.add_argument("--steps", type=count, default=2000, help="env: low-level steps to time")
    bench.add_argument(
        "--trajectory-steps", type=count, default=20, help="env: trajectory steps to time"
    )
    bench.add_argument("--resets", type=count, default=1000, help="env: resets to time")
    bench.add_argument(
        "--primitive-steps", type=count, default=100,
        help="env: ClutterRetrievePrimitive-v0 steps to time (random actions)",
    )  # fmt: skip
    bench.add_argument(
        "--objects", type=names, default=None, help="capture: comma-separated kinds (default all)"
    )
    bench.add_argument("--seeds", type=count, default=3, help="plan: detections per scene")
    bench.add_argument(
        "--samples", type=count, default=500, help="ik: level-hand target poses to solve"
    )
    bench.set_defaults(func=_cmd_bench)
    return parser


def _add_rl_commands(sub: Any, count: Any, seed: Any) -> None:
    """train, evaluate and plot-training (rl-baselines3-zoo's conventions)."""
    train = sub.add_parser(
        "train", help="train a stable-baselines3 / sb3-contrib agent on a variant"
    )
    train.add_argument(
        "--algo", type=names_from(ALGOS, "an algorithm"), required=True,
        help="ppo, sac or tqc; comma-separated for a grid",
    )  # fmt: skip
    train.add_argument("--env", choices=ENV_IDS, required=True, help="the variant's id")
    train.add_argument(
        "--config", type=input_file, default=None,
        help="hyperparameters YAML keyed by env id (None: agents/hyperparams/<algo>.yml)",
    )  # fmt: skip
    train.add_argument("--steps", type=count, default=None, help="env steps (None: n_timesteps)")
    train.add_argument("--n-envs", type=count, default=None, help="envs (None: n_envs, or 1)")
    seeds = train.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=seed, default=0, help="the run's seed")
    seeds.add_argument(
        "--seeds", type=integers(0), default=None, help="a grid of seeds, e.g. 0,1,2"
    )
    train.add_argument(
        "--out", type=output_dir, required=True, help="the run's directory (a grid's: one per run)"
    )
    train.add_argument("--backend", choices=BACKENDS, default="local", help="where runs go")
    train.add_argument("--workers", type=count, default=1, help="runs of a grid in parallel")
    train.add_argument(
        "--eval-freq", type=count, default=None, help="steps between evaluations (None: steps/10)"
    )
    train.add_argument("--eval-episodes", type=count, default=10, help="episodes per evaluation")
    train.add_argument(
        "--save-freq", type=count, default=None, help="steps between checkpoints (None: eval-freq)"
    )
    train.set_defaults(func=_cmd_train)

    evaluate = sub.add_parser(
        "evaluate", help="trained agents, planners and the scripted grasp on the same episodes"
    )
    evaluate.add_argument(
        "--agent", type=_agent, action="append", required=True,
        help="a training directory, planner:NAME (pushing, pg, tsr, pick-and-place) or scripted",
    )  # fmt: skip
    evaluate.add_argument("--env", choices=ENV_IDS, required=True, help="the evaluated variant")
    evaluate.add_argument("--episodes", type=count, default=10, help="episodes per agent")
    evaluate.add_argument("--seed", type=seed, default=0, help="episode k resets with seed + k")
    evaluate.add_argument(
        "--json", type=output_file, required=True, help="report; its jobs log goes beside it"
    )
    evaluate.add_argument("--md", type=output_file, default=None, help="the table as Markdown")
    evaluate.add_argument("--level", choices=LEVELS, default=None, help="clutter of the scenes")
    evaluate.add_argument("--goal-kind", choices=GOAL_KINDS, default=None, help="goal's kind")
    evaluate.add_argument("--noise", type=_noise, default=None, help="detection noise override")
    evaluate.add_argument("--surface", choices=tuple(SURFACES), default=None, help="support")
    evaluate.add_argument(
        "--scenes", type=input_file, nargs="+", default=None, help="scene files to draw from"
    )
    evaluate.add_argument("--budget", type=positive_number, default=20.0, help="planning [s]")
    evaluate.add_argument("--workers", type=count, default=1, help="episodes in parallel")
    evaluate.add_argument("--backend", choices=BACKENDS, default="local", help="where jobs run")
    evaluate.set_defaults(func=_cmd_evaluate)

    plot = sub.add_parser("plot-training", help="success rate against env steps, over seeds")
    plot.add_argument("runs", type=input_dir, nargs="+", help="training directories (or grids)")
    plot.add_argument("--out", type=output_file, required=True, help="PNG to write")
    plot.add_argument("--title", default=None, help="the figure's title")
    plot.set_defaults(func=_cmd_plot_training)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; the exit status (2 for bad input) rather than raising SystemExit."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exit_:  # --help, --version, or a usage error already printed
        return exit_.code if isinstance(exit_.code, int) else 2
    try:
        return int(args.func(args))
    except ValueError as error:  # bad input found past parsing: one clear line, no traceback
        print(f"clutter-gym {args.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"clutter-gym {args.command}: interrupted; finished work is kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
