"""The figure commands: plots of a benchmark report, of a capture region and of training runs,
and a GIF's frames on one sheet."""

from __future__ import annotations

import argparse

from agents.cli.arguments import (
    COUNT,
    input_dir,
    input_file,
    output_dir,
    output_file,
    read_json,
)
from agents.experiments.capture_objects import REGION_ACTIONS


def add_benchmark_plots(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=input_file, required=True, help="a benchmark report")
    parser.add_argument("--out", type=output_dir, required=True, help="directory for the PNGs")


def run_benchmark_plots(args: argparse.Namespace) -> int:
    from agents.figures.benchmark_plots import check_report, write_plots

    report = check_report(read_json(args.json, "--json"), args.json)
    for path in write_plots(report, args.out):
        print(f"wrote {path}")
    return 0


def add_capture_region(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--object", required=True, help="can, bottle, poptart or a kind")
    parser.add_argument(
        "--action", choices=REGION_ACTIONS, default="push-grasp", help="the region's action"
    )
    parser.add_argument("--out", type=output_file, required=True, help="PNG to write")
    parser.add_argument(
        "--validation", type=input_file, default=None, help="JSON of clutter-gym validate-capture"
    )


def run_capture_region(args: argparse.Namespace) -> int:
    from agents.experiments.capture_objects import check_validation, resolve_kind

    validation = None
    if args.validation is not None:
        report = read_json(args.validation, "--validation")
        validation = check_validation(report, args.validation, args.action)
    resolve_kind(args.object, args.action)  # before the planners load

    from agents.figures.capture_region import capture_figure

    capture_figure(args.object, args.out, validation, action=args.action)
    print(f"wrote {args.out}")
    return 0


def add_gif_frames(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--gif", type=input_file, required=True, help="e.g. out/demo/demo.gif")
    parser.add_argument("--out", type=output_file, required=True, help="PNG to write")
    parser.add_argument("--frames", type=COUNT, default=8, help="evenly spaced frames")
    parser.add_argument("--columns", type=COUNT, default=4, help="frames per row")


def run_gif_frames(args: argparse.Namespace) -> int:
    from agents.figures.gif_frames import contact_sheet

    try:
        count = contact_sheet(args.gif, args.out, args.frames, args.columns)
    except OSError as error:
        raise ValueError(f"--gif: {args.gif} is not a readable GIF ({error})") from None
    print(f"wrote {args.out} ({count} frames)")
    return 0


def add_plot_training(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", type=input_dir, nargs="+", help="training directories (or grids)")
    parser.add_argument("--out", type=output_file, required=True, help="PNG to write")
    parser.add_argument("--title", default=None, help="the figure's title")


def run_plot_training(args: argparse.Namespace) -> int:
    from agents.figures.training_curves import plot_training

    curves = plot_training(args.runs, args.out, args.title)
    print(f"wrote {args.out} ({len(curves)} runs)")
    return 0


COMMANDS = {
    "benchmark-plots": (add_benchmark_plots, run_benchmark_plots),
    "capture-region": (add_capture_region, run_capture_region),
    "gif-frames": (add_gif_frames, run_gif_frames),
    "plot-training": (add_plot_training, run_plot_training),
}
