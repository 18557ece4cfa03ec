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
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from clutter_gym.media import write_json, write_png
from clutter_gym.scene import LEVELS, generate_scene, load_scene, save_scene, scene_to_dict
from clutter_gym.world import SURFACES


def _cmd_demo(args: argparse.Namespace) -> int:
    from agents.demo import run_demo

    summary = run_demo(scene=args.scene, out_dir=Path(args.out_dir), seed=args.seed)
    outcome = (
        "success"
        if summary["success"]
        else f"failed: {summary['failure'] or summary['planning_failure']}"
    )
    print(
        f"{outcome}; goal lifted {summary['goal_lift_m']:.3f} m in "
        f"{summary['simulated_seconds']:.1f} simulated s; wrote {summary['gif']} and "
        f"{Path(args.out_dir) / 'demo.json'}"
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
        "execution_failures", "mean_execution_simulated_s",
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
        noises=tuple(args.noises.split(",")) if args.noises else None,
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
    from agents.benchmark_plots import write_plots

    report = json.loads(args.json.read_text())
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

    scene = load_scene(Path(args.scene))
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

        objects = tuple(args.objects.split(",")) if args.objects else None
        result = bench_capture(objects)
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

    rotations = [float(r) for r in args.rotations.split(",")]
    report = validate(args.object, args.trials, args.json, rotations, args.workers)
    for rotation in rotations:
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
    from agents.capture_figure import capture_figure

    capture_figure(args.object, args.out, args.validation)
    print(f"wrote {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="clutter-gym",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="retrieve the goal object of a scene; write a GIF and JSON")
    demo.add_argument("--scene", default=None, help="scene JSON (default: the built-in demo scene)")
    demo.add_argument("--out-dir", default="out/demo")
    demo.add_argument("--seed", type=int, default=0)
    demo.set_defaults(func=_cmd_demo)

    plan = sub.add_parser(
        "plan", help="plan a retrieval with Rearrange; optionally execute it on noisy worlds"
    )
    plan.add_argument("--scene", required=True, help="scene JSON (true poses and noise)")
    plan.add_argument(
        "--planner", default="pushing", help="pushing (default), pick-and-place, pg or tsr"
    )
    plan.add_argument(
        "--noise", default=None, help="override the scene's noise: a level or 'xy,theta'"
    )
    plan.add_argument("--execute", action="store_true", help="execute the plan on true worlds")
    plan.add_argument("--trials", type=int, default=100, help="true worlds with --execute")
    plan.add_argument("--json", type=Path, default=None, help="write the report here")
    plan.add_argument("--gif", type=Path, default=None, help="record one execution as a GIF")
    plan.add_argument("--figure", type=Path, default=None, help="write the planning timeline PNG")
    plan.add_argument("--seed", type=int, default=0, help="detection, samples, worlds, OMPL")
    plan.add_argument("--budget", type=float, default=20.0, help="planning time budget [s]")
    plan.add_argument(
        "--samples", type=int, default=None, help="uncertainty samples (default: the paper's n)"
    )
    plan.add_argument("--workers", type=int, default=2)
    plan.set_defaults(func=_cmd_plan)

    benchmark = sub.add_parser(
        "benchmark", help="the paper's experiments (Table 1, pushing vs pick-and-place)"
    )
    benchmark.add_argument("--suite", required=True, help="table1 or fig15")
    benchmark.add_argument(
        "--planners",
        default=None,
        help="comma-separated: tsr, pg, pushing, pick-and-place (default: the suite's)",
    )
    benchmark.add_argument("--json", type=Path, required=True, help="report; jobs log beside it")
    benchmark.add_argument("--md", type=Path, default=None, help="write the table as Markdown")
    benchmark.add_argument(
        "--plots", type=Path, default=None, help="write PNG plots to this directory"
    )
    benchmark.add_argument("--trials", type=int, default=10, help="true worlds per plan")
    benchmark.add_argument("--seed", type=int, default=0)
    benchmark.add_argument("--budget", type=float, default=20.0, help="planning budget [s]")
    benchmark.add_argument("--workers", type=int, default=2)
    benchmark.add_argument("--backend", default="local", help="local (process pool) or ray")
    benchmark.add_argument(
        "--scenes-per-group", type=int, default=None, help="only the first N scenes per level"
    )
    benchmark.add_argument("--noises", default=None, help="only these noise levels, e.g. sigma2")
    benchmark.set_defaults(func=_cmd_benchmark)

    plots = sub.add_parser("benchmark-plots", help="PNG plots from a benchmark JSON")
    plots.add_argument("--json", type=Path, required=True)
    plots.add_argument("--out", type=Path, required=True, help="directory")
    plots.set_defaults(func=_cmd_benchmark_plots)

    scene = sub.add_parser("scene", help="generate a scene at one of the paper's clutter levels")
    scene.add_argument("--level", choices=LEVELS, required=True)
    scene.add_argument("--seed", type=int, required=True)
    scene.add_argument("--surface", choices=tuple(SURFACES), default="table")
    scene.add_argument("--noise", default="sigma2")
    scene.add_argument("--out", type=Path, required=True)
    scene.set_defaults(func=_cmd_scene)

    render = sub.add_parser("render", help="render a scene file to a PNG")
    render.add_argument("--scene", required=True)
    render.add_argument("--out", type=Path, required=True)
    render.set_defaults(func=_cmd_render)

    validate = sub.add_parser(
        "validate-capture", help="push-grasp capture region vs pybullet physics (paper Fig. 11)"
    )
    validate.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    validate.add_argument("--trials", type=int, default=1000, help="grid poses per rotation")
    validate.add_argument("--json", type=Path, required=True)
    validate.add_argument("--rotations", default="0,45", help="scene rotations in degrees")
    validate.add_argument("--workers", type=int, default=2)
    validate.set_defaults(func=_cmd_validate_capture)

    figure = sub.add_parser("capture-region", help="plot a push-grasp capture region")
    figure.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    figure.add_argument("--out", type=Path, required=True)
    figure.add_argument(
        "--validation", type=Path, default=None, help="JSON of clutter-gym validate-capture"
    )
    figure.set_defaults(func=_cmd_capture_region)

    bench = sub.add_parser("bench", help="speed and memory benchmarks, written as JSON")
    bench.add_argument("target", choices=("env", "capture", "plan"))
    bench.add_argument("--json", type=Path, default=None, help="write the result to this file")
    bench.add_argument("--steps", type=int, default=2000, help="low-level steps to time")
    bench.add_argument("--trajectory-steps", type=int, default=20)
    bench.add_argument("--resets", type=int, default=1000)
    bench.add_argument("--objects", default=None, help="capture: comma-separated kinds")
    bench.add_argument("--seeds", type=int, default=3, help="plan: detections per scene")
    bench.set_defaults(func=_cmd_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except ValueError as error:  # bad input: one clear line, no traceback
        print(f"clutter-gym {args.command}: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
