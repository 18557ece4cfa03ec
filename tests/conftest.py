"""Fixtures shared by the test modules."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.helpers import lone_can


@pytest.fixture(autouse=True, scope="session")
def isolated_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Caches (the generated URDF, capture regions not shipped) in a directory of this test
    session, never the user's: a test run neither reads stale files nor leaves files behind."""
    directory = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CACHE_HOME", str(directory))
        yield directory


@pytest.fixture
def lone_can_file(tmp_path: Path) -> Path:
    """A scene file: the goal can alone in easy reach, detected at sigma2."""
    path = tmp_path / "can.json"
    path.write_text(json.dumps(lone_can("sigma2")))
    return path
