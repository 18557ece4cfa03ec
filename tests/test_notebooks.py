"""The quickstart notebook runs as written (its code cells, in order, from its folder)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib
import pytest

QUICKSTART = Path(__file__).resolve().parents[1] / "notebooks" / "quickstart.ipynb"


def test_quickstart_runs_and_its_grasp_succeeds(monkeypatch: pytest.MonkeyPatch) -> None:
    matplotlib.use("Agg")
    monkeypatch.chdir(QUICKSTART.parent)
    namespace: dict[str, Any] = {}
    for cell in json.loads(QUICKSTART.read_text())["cells"]:
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), QUICKSTART.name, "exec"), namespace)
    assert namespace["info"]["is_success"]
