"""What validate-capture and the capture-region figure accept: the actions, the objects (by kind
or short name) and a validate-capture report. The object specs only (no simulator), so that the
command line checks its arguments before the simulator or the planners load."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from clutter_gym.model.objects import OBJECTS

ACTIONS = ("push-grasp", "static-grasp", "sweep")
"""What validate-capture runs: a push-grasp region's pushes, the grasps of its part that needs no
push (`planners.tsr.grasped_still`), and sweeps."""
REGION_ACTIONS = ("push-grasp", "sweep")
"""The actions whose capture regions are drawn."""
GRASPS = ("push-grasp", "static-grasp")
"""The actions that close the hand on the object and lift it (it must be graspable)."""
ALIASES = {"can": "soda_can", "bottle": "juice_bottle", "poptart": "poptart_box"}


def resolve_kind(name: str, action: str = "push-grasp") -> str:
    """The object kind of a CLI name, if ``action`` can be done to it. Any object can be swept
    here, one the planner never pushes (``pushable=False``) included: whether it stays upright
    when swept is what decides that flag."""
    kind = ALIASES.get(name, name)
    if kind not in OBJECTS:
        allowed = sorted({*ALIASES, *OBJECTS})
        raise ValueError(f"--object: unknown object {name!r}; allowed: {', '.join(allowed)}")
    spec = OBJECTS[kind]
    if action in GRASPS and not (spec.graspable and spec.liftable):
        raise ValueError(f"--object: {kind} cannot be grasped and lifted")
    return kind


def check_validation(report: object, source: Path, action: str = "push-grasp") -> dict[str, Any]:
    """A `clutter-gym validate-capture` report of ``action``, or ValueError naming the file."""
    needed = ("object", "action", "distance_m", "trials", "rotation_0deg")
    if not isinstance(report, dict) or any(key not in report for key in needed):
        raise ValueError(
            f"--validation: {source} is not a clutter-gym validate-capture report with the "
            f"0 deg rotation (it needs the keys {', '.join(needed)})"
        )
    if report["action"] != action:
        raise ValueError(
            f"--validation: {source} validates {report['action']!r} regions; the figure is of "
            f"{action!r} (pass --action {report['action']})"
        )
    return report
