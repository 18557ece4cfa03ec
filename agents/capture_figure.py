"""`clutter-gym capture-region`: the push-grasp capture region as the paper draws it.

Three panels in the hand frame (x along the push, y to the left, hand_base at the origin):
(a) the regions of several push distances nested in each other (Fig. 9(c)); (b) the uncertainty
samples of a noisy detection inside a region, each drawn as the object's outline (Fig. 12);
(c) the physical validation grid of `clutter-gym validate-capture`, successes and failures over
the region of the validated push distance (Fig. 11(a)), when its JSON is given.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon as PolygonPatch

from agents.validate_capture import resolve_kind
from clutter_gym.model.files import atomic_write_bytes
from clutter_gym.model.noise import NOISE_LEVELS
from clutter_gym.model.objects import Footprint, get_object
from planners.capture import CaptureRegion, push_grasp_region
from planners.hand2d import default_aperture, push_grasp_profile

DISTANCES = (0.05, 0.1, 0.2, 0.3, 0.5, 1.0)
EXTENT = ((-0.05, 1.05), (-0.22, 0.22))  # x, y of the plots [m]


def _region_mask(region: CaptureRegion, distance: float, resolution: float = 0.004) -> tuple:
    xs = np.arange(*EXTENT[0], resolution)
    ys = np.arange(*EXTENT[1], resolution)
    gx, gy = np.meshgrid(xs, ys)
    poses = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
    return gx, gy, region.contains(poses, distance).reshape(gx.shape).astype(float)


def _draw_hand(ax: Axes, aperture: float) -> None:
    pusher = push_grasp_profile(aperture).pusher
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


def check_validation(report: object, source: Path) -> dict[str, Any]:
    """A `clutter-gym validate-capture` report, or ValueError naming the file."""
    needed = ("push_distance_m", "trials", "rotation_0deg")
    if not isinstance(report, dict) or any(key not in report for key in needed):
        raise ValueError(
            f"--validation: {source} is not a clutter-gym validate-capture report with the "
            f"0 deg rotation (it needs the keys {', '.join(needed)})"
        )
    return report


def capture_figure(
    name: str, out: Path, validation: dict[str, Any] | None = None, seed: int = 0
) -> None:
    """(a) nested regions, (b) sigma3 samples in a region, (c) the physical validation when
    ``validation`` (a checked `validate-capture` report) is given."""
    kind = resolve_kind(name)
    spec = get_object(kind)
    aperture = default_aperture(spec.footprint)
    region = push_grasp_region(spec.footprint, aperture)
    panels = 3 if validation is not None else 2
    fig, axes = plt.subplots(1, panels, figsize=(5.2 * panels, 4.2), constrained_layout=True)

    ax = axes[0]
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(DISTANCES)))
    for distance, colour in zip(DISTANCES, colours, strict=True):
        gx, gy, mask = _region_mask(region, distance)
        ax.contour(gx, gy, mask, levels=[0.5], colors=[colour], linewidths=1.5)
        ax.plot([], [], color=colour, label=f"d = {distance:g} m")
    ax.set_title(f"(a) {kind}, aperture {aperture:.3f} m")
    ax.legend(loc="upper right", fontsize=8)

    ax = axes[1]
    distance = 0.3
    sigma_xy, sigma_theta = NOISE_LEVELS["sigma3"]
    rng = np.random.default_rng(seed)
    detection = np.array([0.45, 0.0, 0.0])
    samples = detection + rng.standard_normal((50, 3)) * [sigma_xy, sigma_xy, sigma_theta]
    inside = region.contains(samples, distance)
    gx, gy, mask = _region_mask(region, distance)
    ax.contourf(gx, gy, mask, levels=[0.5, 1.5], colors=["#cfe8cf"])
    for sample, ok in zip(samples, inside, strict=True):
        draw_outline(ax, spec.footprint, sample, color="g" if ok else "r", lw=0.6)
    ax.set_title(f"(b) sigma3 samples in the {distance} m region: {inside.sum()}/50")

    if validation is not None:
        ax = axes[2]
        report = validation
        gx, gy, mask = _region_mask(region, report["push_distance_m"])
        ax.contour(gx, gy, mask, levels=[0.5], colors=["k"], linewidths=1.5)
        # The unrotated scene, and for boxes the theta = 0 slice the contours are drawn for.
        trials = [t for t in report["trials"] if t["rotation_deg"] == 0.0 and t["pose"][2] == 0.0]
        for outcome, marker, colour in (("success", "o", "g"), ("failure", "x", "r")):
            pts = np.array([t["pose"][:2] for t in trials if t["outcome"].startswith(outcome)])
            if len(pts):
                ax.scatter(pts[:, 0], pts[:, 1], s=9, marker=marker, c=colour, label=outcome)
        summary = report["rotation_0deg"]
        ax.set_title(
            f"(c) pybullet: {summary['failures_inside']} failures inside (all theta), "
            f"tightness {summary['tightness']:.2f}"
        )
        ax.legend(loc="upper right", fontsize=8)

    for ax in axes:
        _draw_hand(ax, aperture)
        ax.set_xlim(*EXTENT[0])
        ax.set_ylim(*EXTENT[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x along the push [m]")
        ax.set_ylabel("y [m]")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(out, buffer.getvalue())
