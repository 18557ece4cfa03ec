"""Files the project writes: atomically, so an interrupted run never leaves a half-written file
that a later run would trust, and caches under one directory."""

from __future__ import annotations

import os
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

_WARNED: set[Path] = set()


def cache_dir() -> Path:
    """`$XDG_CACHE_HOME/clutter_gym`, else `~/.cache/clutter_gym` (the generated URDF, capture
    regions not shipped with the package). When that cannot be written (a read-only home, a
    file in its place), a per-user temporary directory instead, with one warning naming both:
    a cache must never be the reason a run fails."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    preferred = Path(base) / "clutter_gym"
    problem = _unwritable(preferred)
    if not problem:
        return preferred
    fallback = Path(tempfile.gettempdir()) / f"clutter_gym-cache-{os.getuid()}"
    if preferred not in _WARNED:
        _WARNED.add(preferred)
        warnings.warn(
            f"cache directory {preferred} (XDG_CACHE_HOME) is not writable ({problem}); "
            f"using {fallback}",
            stacklevel=2,
        )
    fallback.mkdir(mode=0o700, parents=True, exist_ok=True)
    return fallback


def _unwritable(directory: Path) -> str:
    """Why files cannot be created in ``directory`` (made if missing), or "" if they can."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            return ""
    except OSError as error:
        return error.strerror or type(error).__name__


@contextmanager
def atomic_file(path: Path) -> Iterator[IO[bytes]]:
    """A binary file written through a hidden temporary file beside ``path``; it replaces
    ``path`` when the block ends without an error and is removed otherwise."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            yield handle
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give what open() would
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write via a temporary file in the same directory and `os.replace`."""
    with atomic_file(path) as handle:
        handle.write(data)


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
