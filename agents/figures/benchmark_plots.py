"""Plots of a `clutter-gym benchmark` report: success against noise per clutter level, and the
distributions of planning time, as PNG files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from agents.experiments.suites import PAPER_TABLE1, TABLE1_NOISES

REPORT_KEYS = ("suite", "planners", "trials", "time_budget_s", "summary", "records")


def check_report(report: object, source: Path) -> dict[str, Any]:
    """A `clutter-gym benchmark` report, or ValueError naming the file and what it lacks."""
    if not isinstance(report, dict):
        raise ValueError(f"--json: {source} is not a clutter-gym benchmark report (not an object)")
    missing = [key for key in REPORT_KEYS if key not in report]
    if missing or not isinstance(report["records"], list):
        raise ValueError(
            f"--json: {source} is not a clutter-gym benchmark report (it lacks "
            f"{', '.join(missing) or 'a list of records'})"
        )
    return report


def write_plots(report: dict[str, Any], directory: Path) -> list[Path]:
    """Write the report's plots into ``directory``; returns their paths."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = [_success_vs_noise(report, directory / f"{report['suite']}_success.png")]
    paths.append(_planning_times(report, directory / f"{report['suite']}_planning_time.png"))
    return paths


def _groups(report: dict[str, Any]) -> list[str]:
    seen: dict[str, None] = {}
    for r in report["records"]:
        seen.setdefault(r["group"], None)
    return list(seen)


def _noises(report: dict[str, Any], group: str) -> list[str]:
    seen: dict[str, None] = {}
    for r in report["records"]:
        if r["group"] == group:
            seen.setdefault(r["noise"], None)
    return list(seen)


def _success_vs_noise(report: dict[str, Any], path: Path) -> Path:
    """Per clutter level: fraction of scenes planned (solid), of executions that succeeded
    (dashed) and the paper's planned fraction (dotted, Table 1's planners), against noise."""
    groups = _groups(report)
    fig, axes = plt.subplots(1, len(groups), figsize=(4.2 * len(groups), 3.6), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, group in zip(axes[0], groups, strict=True):
        noises = _noises(report, group)
        for k, planner in enumerate(report["planners"]):
            # A small shift per planner keeps coinciding lines visible.
            x = [i + 0.04 * (k - (len(report["planners"]) - 1) / 2) for i in range(len(noises))]
            cells = [report["summary"].get(planner, {}).get(group, {}).get(n) for n in noises]
            colour = colours[k % len(colours)]
            planned = [c["solved"] / c["scenes"] if c else float("nan") for c in cells]
            ax.plot(x, planned, "o-", color=colour, label=f"{planner}: planned")
            executed = [
                c["execution_success_rate"]
                if c and c["execution_success_rate"] is not None
                else float("nan")
                for c in cells
            ]
            ax.plot(x, executed, "s--", color=colour, alpha=0.7, label=f"{planner}: executed")
            paper = PAPER_TABLE1.get((planner, group))
            if paper is not None and report["suite"] == "table1":
                values = [
                    paper[TABLE1_NOISES.index(n)][0] / 10 if n in TABLE1_NOISES else float("nan")
                    for n in noises
                ]
                ax.plot(x, values, ":", color=colour, label=f"{planner}: paper planned")
        ax.set_xticks(range(len(noises)), noises, rotation=20 if len(noises) > 4 else 0)
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(f"{group}")
        ax.set_xlabel("noise level")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("fraction of scenes / executions")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8)
    fig.suptitle(f"{report['suite']}: planned and executed, {report['trials']} worlds per plan")
    fig.tight_layout(rect=(0, 0.06 + 0.04 * (len(labels) // 5), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _planning_times(report: dict[str, Any], path: Path) -> Path:
    """Per clutter level: box plots of planning time (log scale) per planner and noise level,
    solved and failed scenes together (failed ones often run to the budget)."""
    groups = _groups(report)
    fig, axes = plt.subplots(1, len(groups), figsize=(4.2 * len(groups), 3.8), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    planners = report["planners"]
    width = 0.8 / len(planners)
    for ax, group in zip(axes[0], groups, strict=True):
        noises = _noises(report, group)
        for k, planner in enumerate(planners):
            data, positions = [], []
            for i, noise in enumerate(noises):
                times = [
                    r["planning_time_s"]
                    for r in report["records"]
                    if r["group"] == group
                    and r["noise"] == noise
                    and r["planner"] == planner
                    and r["planning_time_s"] is not None
                ]
                if times:
                    data.append([max(t, 1e-3) for t in times])
                    positions.append(i - 0.4 + width * (k + 0.5))
            if not data:
                continue
            parts = ax.boxplot(
                data, positions=positions, widths=width * 0.9, patch_artist=True, showfliers=True
            )
            for box in parts["boxes"]:
                box.set_facecolor(colours[k % len(colours)])
                box.set_alpha(0.6)
            ax.plot([], [], "s", color=colours[k % len(colours)], label=planner)
        ax.set_yscale("log")
        ax.set_xticks(range(len(noises)), noises, rotation=20 if len(noises) > 4 else 0)
        ax.set_title(group)
        ax.set_xlabel("noise level")
        ax.grid(alpha=0.3, which="both", axis="y")
    axes[0][0].set_ylabel("planning time [s]")
    axes[0][-1].legend(fontsize=8)
    fig.suptitle(
        f"{report['suite']}: planning time per scene (budget {report['time_budget_s']:g} s)"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
