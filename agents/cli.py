"""The `clutter-gym` command line.

clutter-gym demo [--scene scene.json] [--out-dir out/demo]
clutter-gym plan --scene scene.json [--planner pushing] [--execute --trials 100] [--json out.json]
    [--gif out.gif] [--figure timeline.png]
clutter-gym scene --level high --seed 3 [--surface table] [--noise sigma2] --out scene.json
clutter-gym render --scene scene.json --out scene.png
clutter-gym bench env|capture|plan --json out.json
clutter-gym benchmark --suite table1|fig15 [--planners tsr,pg,pushing,pick-and-place]
    --json out.json [--md out.md] [--plots dir] [--trials 10] [--workers 2] [--backend local|ray]
clutter-gym benchmark-plots --json out.json --out dir

Bad input is one line naming the flag, the value and what is allowed, exit status 2; every
argument is checked before any work starts.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import NoReturn

import numpy as np

from agents.benchmark import SUITES
from agents.cli_args import (
    input_file,
    integer,
    names,
    numbers,
    output_dir,
    output_file,
    positive_number,
    read_json,
)
from agents.jobs import BACKENDS
from clutter_gym import __version__
from clutter_gym.media import write_json, write_png
from clutter_gym.model.noise import NOISE_LEVELS, resolve_noise
from clutter_gym.model.scene import LEVELS, generate_scene, load_scene, save_scene, scene_to_dict
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
    else:
        from clutter_gym.bench import bench_env

        result = bench_env(args.steps, args.trajectory_steps, args.resets)
    line = json.dumps(result, sort_keys=True)
    if args.json:
        write_json(args.json, result)
    print(line)
    return 0


def _cmd_validate_capture(args: argparse.Namespace) -> int:
    from agents.validate_capture import validate

    report = validate(args.object, args.trials, args.json, args.rotations, args.workers)
    for rotation in args.rotations:
        print(
            json.dumps(
                {
                    "object": report["object"],
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


def _cmd_capture_region(args: argparse.Namespace) -> int:
    from agents.capture_figure import capture_figure, check_validation

    validation = None
    if args.validation is not None:
        validation = check_validation(read_json(args.validation, "--validation"), args.validation)
    capture_figure(args.object, args.out, validation)
    print(f"wrote {args.out}")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line (and exit status 2), defaults shown."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _HelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """The module docstring as written, and every option's default in --help."""


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
        "validate-capture", help="push-grasp capture region vs pybullet physics (paper Fig. 11)"
    )
    validate.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    validate.add_argument("--trials", type=count, default=1000, help="grid poses per rotation")
    validate.add_argument(
        "--json", type=output_file, required=True, help="report; its trials log goes beside it"
    )
    validate.add_argument(
        "--rotations", type=numbers, default="0,45", help="scene rotations in degrees"
    )
    validate.add_argument("--workers", type=count, default=2, help="trials in parallel")
    validate.set_defaults(func=_cmd_validate_capture)

    figure = sub.add_parser("capture-region", help="plot a push-grasp capture region")
    figure.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    figure.add_argument("--out", type=output_file, required=True, help="PNG to write")
    figure.add_argument(
        "--validation", type=input_file, default=None, help="JSON of clutter-gym validate-capture"
    )
    figure.set_defaults(func=_cmd_capture_region)

    bench = sub.add_parser("bench", help="speed and memory benchmarks, written as JSON")
    bench.add_argument("target", choices=("env", "capture", "plan"), help="what to measure")
    bench.add_argument("--json", type=output_file, default=None, help="also write the result here")
    bench.add_argument("--steps", type=count, default=2000, help="env: low-level steps to time")
    bench.add_argument(
        "--trajectory-steps", type=count, default=20, help="env: trajectory steps to time"
    )
    bench.add_argument("--resets", type=count, default=1000, help="env: resets to time")
    bench.add_argument(
        "--objects", type=names, default=None, help="capture: comma-separated kinds (default all)"
    )
    bench.add_argument("--seeds", type=count, default=3, help="plan: detections per scene")
    bench.set_defaults(func=_cmd_bench)
    return parser


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
