"""`clutter-gym plot-training`: success rate against env steps from runs of `clutter-gym train`.

Runs are grouped by (algorithm, env id), read from each run's run.json; a group's seeds are put
on the union of their evaluation steps (within the steps all of them reached, interpolated where
one evaluated elsewhere) and drawn as the mean line with the min-max band. A directory that is
not a run but holds runs (a grid's ``--out``) stands for them all.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from agents.learning.runs import EVAL_CSV, RUN_JSON, read_eval_csv
from clutter_gym.model.files import atomic_file


@dataclass(frozen=True)
class Curve:
    """One run's evaluations."""

    directory: Path
    algo: str
    env_id: str
    seed: int | None
    steps: np.ndarray
    success: np.ndarray


def run_directories(paths: list[Path]) -> list[Path]:
    """Each path that is a run, or the runs directly inside it; ValueError for one with none."""
    found: list[Path] = []
    for path in paths:
        if (path / EVAL_CSV).is_file():
            found.append(path)
            continue
        inside = sorted(p for p in path.iterdir() if (p / EVAL_CSV).is_file())
        if not inside:
            raise ValueError(f"{path}: no {EVAL_CSV} in it or in its subdirectories")
        found += inside
    return list(dict.fromkeys(found))


def read_curve(directory: Path) -> Curve:
    """A run's curve; algorithm and env from run.json (the directory's name if it has none)."""
    rows = read_eval_csv(directory / EVAL_CSV)
    if not rows:
        raise ValueError(f"{directory / EVAL_CSV}: no evaluations yet")
    try:
        run = json.loads((directory / RUN_JSON).read_text())
    except (OSError, ValueError):
        run = {}
    return Curve(
        directory=directory,
        algo=str(run.get("algo", directory.name)),
        env_id=str(run.get("env", "")),
        seed=run.get("seed"),
        steps=np.array([r["timesteps"] for r in rows]),
        success=np.array([r["success_rate"] for r in rows]),
    )


def group_curves(curves: list[Curve]) -> dict[tuple[str, str], list[Curve]]:
    groups: dict[tuple[str, str], list[Curve]] = {}
    for curve in curves:
        groups.setdefault((curve.algo, curve.env_id), []).append(curve)
    return groups


def band(curves: list[Curve]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(steps, mean, min, max) of the group's success rates on the union of their evaluation
    steps up to the last step every run reached."""
    end = min(float(c.steps[-1]) for c in curves)
    steps = np.unique(np.concatenate([c.steps[c.steps <= end] for c in curves]))
    values = np.array([np.interp(steps, c.steps, c.success) for c in curves])
    return steps, values.mean(axis=0), values.min(axis=0), values.max(axis=0)


def plot_training(paths: list[Path], out: Path, title: str | None = None) -> list[Curve]:
    """Write the PNG; the curves drawn."""
    curves = [read_curve(d) for d in run_directories(paths)]
    fig, ax = plt.subplots(figsize=(7.0, 4.2), dpi=120)
    for (algo, env_id), group in sorted(group_curves(curves).items()):
        steps, mean, low, high = band(group)
        label = f"{algo} on {env_id} ({len(group)} seed{'s' if len(group) > 1 else ''})"
        (line,) = ax.plot(steps, mean, marker="o", markersize=3, label=label)
        if len(group) > 1:
            ax.fill_between(steps, low, high, color=line.get_color(), alpha=0.2, linewidth=0)
    ax.set_xlabel("env steps")
    ax.set_ylabel("evaluation success rate")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "success rate: mean over seeds, band from min to max")
    fig.tight_layout()
    with atomic_file(out) as handle:
        fig.savefig(handle, format="png")
    plt.close(fig)
    return curves
