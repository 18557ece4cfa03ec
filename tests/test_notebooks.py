"""Every notebook runs as written: its code cells in order, in a fresh namespace, from an
unrelated working directory (a notebook must not depend on where it is opened from)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib
import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("*.ipynb"))


def run_notebook(path: Path) -> dict[str, Any]:
    """Execute the code cells of a notebook; the namespace they leave behind."""
    namespace: dict[str, Any] = {}
    for cell in json.loads(path.read_text())["cells"]:
        if cell["cell_type"] == "code":
            exec(compile("".join(cell["source"]), path.name, "exec"), namespace)
    return namespace


def test_there_are_notebooks() -> None:
    assert NOTEBOOKS


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs_from_any_directory(
    notebook: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace = run_notebook(notebook)
    if notebook.name == "quickstart.ipynb":
        assert namespace["info"]["is_success"]
    if notebook.name == "learning.ipynb":
        assert len(namespace["evaluation"]["summary"]) == 2  # the trained agent and PG
        assert namespace["figure"].is_file()
        ee = namespace["grasp_evaluation"]["summary"]
        assert (
            len(ee) == 2 and ee["planner:pushing"]["episodes"] == 2
        )  # the SAC agent and the teacher
        assert namespace["grasp_figure"].is_file()
