"""The planning timeline (the paper's Fig. 5) as a PNG: one panel per planning step.

Planning runs backwards: step 1 plans the goal's PickUp, step 2 the move that clears its way,
and so on. Each panel is a top view of the table or shelf with every object's uncertainty
samples (outlines), the negative goal region the step had to clear (purple: the robot's and the
moved objects' swept volumes of the steps planned before it, projected onto the surface), the
object's evolution nu_o (its final samples in colour) and the hand's path (TCP, black).
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Polygon as PolygonPatch
from scipy.spatial import ConvexHull

from agents.figures.capture_region import draw_outline
from clutter_gym.model.collision import Volume, part_points
from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.kinematics import ArmKinematics
from clutter_gym.model.world import Surface
from planners.rearrange import Plan
from planners.uncertainty import ObjectBelief

NGR_HEIGHT = 0.35  # m above the surface: parts of the NGR above every object are not drawn


def volume_outlines(volume: Volume, surface_z: float) -> list[np.ndarray]:
    """Top-view outlines (convex hulls of the hull points of `collision.part_points`) of a
    volume's parts below ``NGR_HEIGHT`` above the surface."""
    outlines = []
    for obj, geometry, _ in volume.parts:
        corners = part_points(obj, geometry)
        if corners[:, 2].min() > surface_z + NGR_HEIGHT:
            continue
        xy = corners[:, :2]
        outlines.append(xy[ConvexHull(xy).vertices])
    return outlines


def _view(poses: np.ndarray) -> np.ndarray:
    """World poses drawn from above with x (away from the robot) up and y (its left) to the
    left: axes swapped here, the horizontal axis inverted in `_panel`."""
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    return np.column_stack([p[:, 1], p[:, 0], np.pi / 2 - p[:, 2]])


def _panel(
    ax: Axes,
    plan: Plan,
    index: int,
    beliefs: dict[str, ObjectBelief],
    surface: Surface,
    kinematics: ArmKinematics,
) -> None:
    step = plan.steps[index]
    x0, x1, y0, y1 = surface.bounds
    ax.add_patch(
        PolygonPatch(np.array([[y0, x0], [y0, x1], [y1, x1], [y1, x0]]), color="0.93", zorder=0)
    )
    for outline in volume_outlines(step.ngr, surface.top_z):
        ax.add_patch(PolygonPatch(outline[:, ::-1], color="tab:purple", alpha=0.05, lw=0))
    for belief in beliefs.values():
        for pose in _view(belief.samples):
            draw_outline(
                ax, belief.spec.footprint, pose, color=belief.spec.rgba[:3], lw=0.5, alpha=0.35
            )
    moved = step.result
    spec = beliefs[moved.obj].spec
    final = moved.nu[-1]
    for pose in _view(final[:: max(1, len(final) // 60)]):
        draw_outline(ax, spec.footprint, pose, color="tab:green", lw=0.6, alpha=0.6)
    rows = step.result.trajectory.rows()
    tcp = kinematics.fk_tcp_batch(rows[:, :7])[:, :3, 3]
    ax.plot(tcp[:, 1], tcp[:, 0], "k-", lw=1.5, zorder=4)
    ax.plot(tcp[0, 1], tcp[0, 0], "ko", ms=3, zorder=4)
    ax.set_title(f"step {step.depth + 1}: {moved.action} {moved.obj}", fontsize=9)
    ax.set_xlim(min(y1, 0.35), max(y0, -0.9))  # inverted: the robot's left on the left
    ax.set_ylim(x0, min(x1, 1.3))
    ax.set_aspect("equal")
    ax.tick_params(labelsize=6)


def write_timeline(plan: Plan, beliefs: list[ObjectBelief], surface: Surface, out: Path) -> None:
    """Save the timeline PNG (planning order: the goal's step first)."""
    if not plan.steps:
        raise ValueError("the plan has no steps to draw")
    by_name = {b.name: b for b in beliefs}
    kinematics = ArmKinematics("right")
    order = sorted(range(len(plan.steps)), key=lambda i: plan.steps[i].depth)
    fig, axes = plt.subplots(1, len(order), figsize=(3.6 * len(order), 4.2), squeeze=False)
    for ax, index in zip(axes[0], order, strict=True):
        _panel(ax, plan, index, by_name, surface, kinematics)
        ax.set_xlabel("y [m] (robot's left)", fontsize=7)
        ax.set_ylabel("x [m] (away from the robot)", fontsize=7)
    fig.suptitle(
        f"planning timeline: {len(plan.steps)} steps, {plan.planning_time:.2f} s; purple: NGR",
        fontsize=10,
    )
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(Path(out), buffer.getvalue())
