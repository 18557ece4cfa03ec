"""`clutter-gym capture-region`: a push-grasp or sweep capture region as the paper draws it.

Three panels in the region's frame (push-grasps: x along the push, y to the left; sweeps: x along
the sweep, y along the hand's approach axis; hand_base at the origin): (a) the regions of several
push or sweep distances nested in each other (Fig. 9(c)); (b) the uncertainty samples of a noisy
detection inside a region, each drawn as the object's outline (Fig. 12); (c) the physical
validation grid of `clutter-gym validate-capture`, successes and failures over the region of the
validated distance (Fig. 11(a)), when its JSON is given (sweeps: the right side of the hand).
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon as PolygonPatch

from agents.experiments.capture_objects import resolve_kind
from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.noise import NOISE_LEVELS
from clutter_gym.model.objects import Footprint, get_object
from planners.capture import push_grasp_region, sweep_region
from planners.hand2d import default_aperture, push_grasp_profile, sweep_profile
from planners.push_simulation import Pusher

DISTANCES = (0.05, 0.1, 0.2, 0.3, 0.5, 1.0)


@dataclass(frozen=True)
class _View:
    """One action's region as the panels draw it."""

    contains: Callable[[np.ndarray, float], np.ndarray]  # (poses (N, 3), distance) -> (N,)
    aperture: float
    pusher: Pusher
    extent: tuple[tuple[float, float], tuple[float, float]]  # x, y of the plots [m]
    detection: tuple[float, float, float]  # panel (b)'s detected pose
    x_label: str
    y_label: str
    margin: float = 0.0  # m the planner pushes beyond the region's need (push-grasps)


def _view(kind: str, action: str, aperture: float | None = None) -> _View:
    footprint = get_object(kind).footprint
    if action == "sweep":
        swept = sweep_region(footprint)
        pusher = sweep_profile(swept.aperture).pusher
        ahead = pusher.bounds[1] + footprint.bounding_radius + 0.1  # 10 cm clear of the fingers
        return _View(
            lambda poses, d: swept.query(poses, d)[0],
            swept.aperture,
            pusher,
            ((-0.15, 1.05), (-0.3, 0.4)),
            (ahead, 0.05, 0.0),
            "x along the sweep [m]",
            "y along the approach [m]",
        )
    region = push_grasp_region(footprint, aperture or default_aperture(footprint))
    return _View(
        region.contains,
        region.aperture,
        push_grasp_profile(region.aperture).pusher,
        ((-0.05, 1.05), (-0.22, 0.22)),
        (0.45, 0.0, 0.0),
        "x along the push [m]",
        "y [m]",
        region.push_margin,
    )


def _region_mask(view: _View, distance: float, resolution: float = 0.004) -> tuple:
    xs = np.arange(*view.extent[0], resolution)
    ys = np.arange(*view.extent[1], resolution)
    gx, gy = np.meshgrid(xs, ys)
    poses = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    return gx, gy, view.contains(poses, distance).reshape(gx.shape).astype(float)


def _draw_hand(ax: Axes, pusher: Pusher) -> None:
    for polygon in pusher.polygons:
        ax.add_patch(PolygonPatch(np.asarray(polygon.vertices), color="0.25", zorder=3))
    for circle in pusher.circles:
        ax.add_patch(CirclePatch(circle.center, circle.radius, color="0.25", zorder=3))


def draw_outline(ax: Axes, footprint: Footprint, pose: np.ndarray, **style: Any) -> None:
    x, y, theta = pose
    if footprint.shape == "circle":
        ax.add_patch(CirclePatch((x, y), footprint.radius, fill=False, **style))
        return
    corners = np.array(footprint.corners_xy((float(x), float(y), float(theta))))
    ax.add_patch(PolygonPatch(corners, fill=False, **style))


def capture_figure(
    name: str,
    out: Path,
    validation: dict[str, Any] | None = None,
    seed: int = 0,
    action: str = "push-grasp",
) -> None:
    """(a) nested regions, (b) sigma3 samples in a region, (c) the physical validation when
    ``validation`` (a checked `validate-capture` report of ``action``) is given; a push-grasp
    region at the validation's aperture, else at `default_aperture`."""
    kind = resolve_kind(name, action)
    if validation is not None and validation["object"] != kind:
        raise ValueError(f"--validation: the report is of {validation['object']}, not {kind}")
    spec = get_object(kind)
    aperture = None if validation is None else validation.get("aperture_m")
    view = _view(kind, action, aperture)
    panels = 3 if validation is not None else 2
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.2), constrained_layout=True)

    ax = axes[0]
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(DISTANCES)))
    for distance, colour in zip(DISTANCES, colours, strict=True):
        gx, gy, mask = _region_mask(view, distance)
        ax.contour(gx, gy, mask, levels=[0.5], colors=[colour], linewidths=1.5)
        ax.plot([], [], color=colour, label=f"d = {distance:g} m")
    ax.set_title(f"(a) {kind} {action}, aperture {view.aperture:.3f} m")
    ax.legend(loc="upper right", fontsize=8)

    ax = axes[1]
    distance = 0.3
    sigma_xy, sigma_theta = NOISE_LEVELS["sigma3"]
    rng = np.random.default_rng(seed)
    samples = view.detection + rng.standard_normal((50, 3)) * [sigma_xy, sigma_xy, sigma_theta]
    inside = view.contains(samples, distance)
    gx, gy, mask = _region_mask(view, distance)
    ax.contourf(gx, gy, mask, levels=[0.5, 1.5], colors=["#cfe8cf"])
    for sample, ok in zip(samples, inside, strict=True):
        draw_outline(ax, spec.footprint, sample, color="g" if ok else "r", lw=0.6)
    ax.set_title(f"(b) sigma3 samples in the {distance} m region: {inside.sum()}/50")

    if validation is not None:
        ax = axes[2]
        report = validation
        # The region the validation predicted with: a push-grasp's less the planner's margin.
        gx, gy, mask = _region_mask(view, report["distance_m"] - view.margin)
        ax.contour(gx, gy, mask, levels=[0.5], colors=["k"], linewidths=1.5)
        # The unrotated scene, the right side of the hand (sweeps) and for boxes the theta = 0
        # slice the contours are drawn for.
        trials = [
            t
            for t in report["trials"]
            if t["rotation_deg"] == 0.0 and t["pose"][2] == 0.0 and t["handedness"] == 1
        ]
        for outcome, marker, colour in (("success", "o", "g"), ("failure", "x", "r")):
            pts = np.array([t["pose"][:2] for t in trials if t["outcome"].startswith(outcome)])
            if len(pts):
                ax.scatter(pts[:, 0], pts[:, 1], s=9, marker=marker, c=colour, label=outcome)
        summary = report["rotation_0deg"]
        over = "all theta, both sides" if action == "sweep" else "all theta"
        tightness = summary["tightness"]  # None without a physical success
        ax.set_title(
            f"(c) pybullet: {summary['failures_inside']} failures inside ({over}),\n"
            f"tightness {'-' if tightness is None else f'{tightness:.2f}'}"
        )
        ax.legend(loc="upper right", fontsize=8)

    for ax in axes:
        _draw_hand(ax, view.pusher)
        ax.set_xlim(*view.extent[0])
        ax.set_ylim(*view.extent[1])
        ax.set_aspect("equal")
        ax.set_xlabel(view.x_label)
        ax.set_ylabel(view.y_label)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out, buffer.getvalue())
