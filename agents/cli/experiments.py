"""The experiment commands: demo, plan, benchmark, validate-capture, reachability and bench.
Each `add_*` uses only names and checks that load no simulator; its `run_*` imports the code it
drives."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from agents.cli.arguments import (
    COUNT,
    SEED,
    input_file,
    integer,
    names,
    noise,
    number_or_all,
    numbers,
    output_dir,
    output_file,
    positive_number,
)
from agents.experiments.capture_objects import ACTIONS as VALIDATED_ACTIONS
from agents.runner.jobs import BACKENDS

SUITE_NAMES = ("table1", "fig15", "perturbed")
"""`agents.experiments.suites.SUITES`, named here so that parsing loads no scene (a test checks
they agree)."""


def add_demo(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scene", type=input_file, default=None, help="scene JSON (default: the paper's Figs. 3-5)"
    )
    parser.add_argument("--out-dir", type=output_dir, default="out/demo", help="GIF and JSON here")
    parser.add_argument("--seed", type=SEED, default=0, help="detection and planner seed")


def run_demo(args: argparse.Namespace) -> int:
    from agents.experiments.demo import run_demo

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


def add_plan(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", type=input_file, required=True, help="scene JSON (true poses)")
    parser.add_argument("--planner", default="pushing", help="pushing, pick-and-place, pg or tsr")
    parser.add_argument(
        "--noise",
        type=noise,
        default=None,
        help="override the scene's noise: a level or 'xy,theta'",
    )
    parser.add_argument("--execute", action="store_true", help="execute the plan on true worlds")
    parser.add_argument("--trials", type=integer(0), default=100, help="true worlds with --execute")
    parser.add_argument("--json", type=output_file, default=None, help="write the report here")
    parser.add_argument("--gif", type=output_file, default=None, help="record one execution")
    parser.add_argument(
        "--figure", type=output_file, default=None, help="write the planning timeline PNG"
    )
    parser.add_argument("--seed", type=SEED, default=0, help="detection, samples, worlds, OMPL")
    parser.add_argument("--budget", type=positive_number, default=20.0, help="planning budget [s]")
    parser.add_argument(
        "--samples", type=COUNT, default=None, help="uncertainty samples (default: the paper's n)"
    )
    parser.add_argument("--workers", type=COUNT, default=2, help="processes for --execute")


def _timeline(figure: Path) -> Any:
    """The hook of `run_plan` that draws a found plan's timeline to ``figure``."""

    def draw(plan: Any, beliefs: Any, surface: Any) -> dict[str, Any]:
        from agents.figures.plan_timeline import write_timeline

        write_timeline(plan, beliefs, surface, figure)
        return {"figure": str(figure)}

    return draw


def run_plan(args: argparse.Namespace) -> int:
    from planners.kinds import planner_kind

    planner_kind(args.planner)  # before the planners and the simulator load

    from agents.experiments.plan import run_plan

    trials = args.trials if args.execute else 0
    report = run_plan(
        args.scene,
        planner=args.planner,
        trials=trials,
        out=args.json,
        gif=args.gif,
        on_plan=_timeline(args.figure) if args.figure is not None else None,
        seed=args.seed,
        time_budget=args.budget,
        samples=args.samples,
        workers=args.workers,
        noise=args.noise,
    )
    keys = (
        "planner",
        "noise",
        "samples",
        "success",
        "reason",
        "planning_time_s",
        "actions",
        "objects_moved",
        "trials",
        "execution_successes",
        "execution_success_rate",
        "execution_failures",
        "mean_execution_simulated_s",
        "resumed_trials",
    )
    print(json.dumps({k: report[k] for k in keys if k in report}))
    if not report["success"]:
        for line in report["blocked_by"][:8]:
            print(f"  blocked by: {line}", file=sys.stderr)
    return 0 if report["success"] else 1


def add_benchmark(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--suite", required=True, choices=SUITE_NAMES, help="which experiment")
    parser.add_argument(
        "--planners",
        type=names,
        default=None,
        help="comma-separated: tsr, pg, pushing, pick-and-place (default: the suite's)",
    )
    parser.add_argument(
        "--json", type=output_file, required=True, help="report; its jobs log goes beside it"
    )
    parser.add_argument("--md", type=output_file, default=None, help="the table as Markdown")
    parser.add_argument("--plots", type=output_dir, default=None, help="PNG plots here")
    parser.add_argument("--trials", type=integer(0), default=10, help="true worlds per plan")
    parser.add_argument("--seed", type=SEED, default=0, help="seed of every detection")
    parser.add_argument("--budget", type=positive_number, default=20.0, help="planning budget [s]")
    parser.add_argument("--workers", type=COUNT, default=2, help="jobs in parallel")
    parser.add_argument("--backend", choices=BACKENDS, default="local", help="where jobs run")
    parser.add_argument(
        "--scenes-per-group", type=COUNT, default=None, help="only the first N scenes per level"
    )
    parser.add_argument(
        "--noises", type=names, default=None, help="only these noise levels, e.g. sigma2,sigma3"
    )


def run_benchmark(args: argparse.Namespace) -> int:
    from agents.experiments.suites import check_planners, get_suite, select_cases

    suite = get_suite(args.suite)  # the checks of run_benchmark, before the simulator loads
    check_planners(args.planners, suite)
    select_cases(suite, args.noises, args.scenes_per_group)

    from agents.experiments.benchmark import run_benchmark

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
    )
    if args.plots is not None:
        from agents.figures.benchmark_plots import write_plots

        report["plots"] = [str(p) for p in write_plots(report, args.plots)]
    for planner, groups in report["summary"].items():
        for group, noises in groups.items():
            for level, cell in noises.items():
                print(json.dumps({"planner": planner, "group": group, "noise": level, **cell}))
    written = [args.json, args.md, *report.get("plots", [])]
    print(f"wrote {', '.join(str(w) for w in written if w)}", file=sys.stderr)
    return 0


def add_validate_capture(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    parser.add_argument(
        "--action", choices=VALIDATED_ACTIONS, default="push-grasp", help="the region's action"
    )
    parser.add_argument("--trials", type=COUNT, default=1000, help="grid poses per rotation")
    parser.add_argument(
        "--aperture",
        type=number_or_all,
        default=None,
        help="push-grasp preshape, m between the fingertips, or 'all': every aperture the "
        "planner searches for the object (planners.capture.push_grasp_apertures), one report "
        "each, JSON_<aperture>.json (default: one that fits the object at any orientation)",
    )
    parser.add_argument(
        "--json", type=output_file, required=True, help="report; its trials log goes beside it"
    )
    parser.add_argument(
        "--md", type=output_file, default=None, help="a table of the reports as Markdown"
    )
    parser.add_argument(
        "--rotations", type=numbers, default="0,45", help="scene rotations in degrees"
    )
    parser.add_argument("--workers", type=COUNT, default=2, help="trials in parallel")


def run_validate_capture(args: argparse.Namespace) -> int:
    from agents.experiments.capture_objects import resolve_kind

    kind = resolve_kind(args.object, args.action)  # before the simulator loads
    apertures: list[float | None] = [args.aperture]
    if args.aperture == "all":
        if args.action == "sweep":
            raise ValueError("--aperture: only grasps take an aperture (sweeps use one)")
        from clutter_gym.model.objects import get_object
        from planners.capture import push_grasp_apertures

        spec = get_object(kind)
        apertures = list(push_grasp_apertures(spec.footprint, spec.liftable))

    from agents.experiments.validate_capture import summary_lines, validate, write_markdown

    reports = []
    for aperture in apertures:
        out = args.json
        if len(apertures) > 1:
            out = args.json.with_name(f"{args.json.stem}_{aperture:.3f}{args.json.suffix}")
        report = validate(
            args.object, args.trials, out, args.rotations, args.workers, args.action, aperture
        )
        reports.append(report)
        for line in summary_lines(report, args.rotations):
            print(json.dumps(line))
    if args.md is not None:
        write_markdown(reports, args.rotations, args.md)
    return 0


def add_reachability(parser: argparse.ArgumentParser) -> None:
    from clutter_gym.model.world import SURFACES

    parser.add_argument("--surface", choices=(*SURFACES, "all"), default="all", help="which")
    parser.add_argument("--workers", type=COUNT, default=2, help="rows in parallel")
    parser.add_argument(
        "--log-dir", type=output_dir, default="out/reachability", help="job logs (resumable)"
    )
    parser.add_argument("--figure-dir", type=output_dir, default="docs", help="the PNG plots")


def run_reachability(args: argparse.Namespace) -> int:
    from agents.experiments.reachability_map import build_map
    from agents.figures.reachability_figure import plot_map
    from clutter_gym.model.world import SURFACES

    surfaces = tuple(SURFACES) if args.surface == "all" else (args.surface,)
    for name in surfaces:
        built, path = build_map(name, args.workers, args.log_dir)
        figure = args.figure_dir / f"reachability_{name}.png"
        plot_map(built, SURFACES[name], figure)
        print(
            json.dumps(
                {
                    "surface": name,
                    "map": str(path),
                    "figure": str(figure),
                    "reachable_fraction": round(float(built.reach.mean()), 4),
                }
            )
        )
    return 0


def add_bench(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "target", choices=("env", "capture", "plan", "ik", "train"), help="what to measure"
    )
    parser.add_argument("--json", type=output_file, default=None, help="also write the result here")
    parser.add_argument("--steps", type=COUNT, default=2000, help="env: low-level steps to time")
    parser.add_argument(
        "--trajectory-steps", type=COUNT, default=20, help="env: trajectory steps to time"
    )
    parser.add_argument("--resets", type=COUNT, default=1000, help="env: resets to time")
    parser.add_argument(
        "--primitive-steps",
        type=COUNT,
        default=100,
        help="env: ClutterRetrievePrimitive-v0 steps to time (random actions)",
    )
    parser.add_argument(
        "--objects", type=names, default=None, help="capture: comma-separated kinds (default all)"
    )
    parser.add_argument("--seeds", type=COUNT, default=3, help="plan: detections per scene")
    parser.add_argument(
        "--samples", type=COUNT, default=500, help="ik: level-hand target poses to solve"
    )
    parser.add_argument(
        "--config",
        type=input_file,
        default=None,
        help="train: hyperparameters (default agents/hyperparams/sac_lone_can.yml)",
    )
    parser.add_argument("--algo", choices=("sac", "tqc"), default="sac", help="train: algorithm")
    parser.add_argument(
        "--train-steps", type=COUNT, default=2000, help="train: learning steps to time"
    )


def run_bench(args: argparse.Namespace) -> int:
    if args.target == "capture":
        from agents.experiments.speed.capture_speed import bench_capture

        result = bench_capture(args.objects)
    elif args.target == "plan":
        from agents.experiments.speed.plan_speed import bench_plan

        result = bench_plan(args.seeds)
    elif args.target == "ik":
        from agents.experiments.speed.ik_speed import bench_ik

        result = bench_ik(args.samples)
    elif args.target == "train":
        from agents.experiments.speed.train_speed import bench_train

        result = bench_train(args.algo, config=args.config, steps=args.train_steps)
    else:
        from agents.experiments.speed.env_speed import bench_env

        result = bench_env(args.steps, args.trajectory_steps, args.resets, args.primitive_steps)
    line = json.dumps(result, sort_keys=True)
    if args.json:
        from clutter_gym.media import write_json

        write_json(args.json, result)
    print(line)
    return 0


COMMANDS = {
    "demo": (add_demo, run_demo),
    "plan": (add_plan, run_plan),
    "benchmark": (add_benchmark, run_benchmark),
    "validate-capture": (add_validate_capture, run_validate_capture),
    "reachability": (add_reachability, run_reachability),
    "bench": (add_bench, run_bench),
}
