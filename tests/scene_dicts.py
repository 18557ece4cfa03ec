"""Scene dicts shared by the CLI and policy tests: one soda can alone on the table."""

from __future__ import annotations

from typing import Any

NEAR = (0.95, -0.25, 0.0)
"""In easy reach of the right arm."""
OUT_OF_REACH = (1.33, 0.65, 0.0)
"""The table's far left corner: no grasp reaches it."""


def lone_can(noise: str, pose: tuple[float, float, float] = NEAR) -> dict[str, Any]:
    """A scene with the goal can ``red_can`` alone at ``pose``, detected with ``noise``."""
    return {
        "format": "clutter-gym-scene/1",
        "surface": "table",
        "objects": [{"name": "red_can", "kind": "soda_can", "pose": list(pose)}],
        "goal": {"object": "red_can"},
        "noise": noise,
    }
