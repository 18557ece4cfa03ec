"""Writing what the env shows: GIFs of rollouts, PNG stills, JSON summaries, all atomically.

Atomic writes (temp file + rename) mean an interrupted run never leaves a half-written file that
a later run would trust.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image


def atomic_write_bytes(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json(path: Path, payload: dict[str, Any]) -> None:
    atomic_write_bytes(path, (json.dumps(payload, indent=2, sort_keys=True) + "\n").encode())


def write_png(path: Path, frame: np.ndarray) -> None:
    _write_image(path, [frame], fps=1)


def write_gif(path: Path, frames: Sequence[np.ndarray], fps: int = 10) -> None:
    if not frames:
        raise ValueError("frames: empty; a GIF needs at least one frame")
    _write_image(path, frames, fps)


def _write_image(path: Path, frames: Sequence[np.ndarray], fps: int) -> None:
    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=path.suffix)
    os.close(fd)
    try:
        if len(images) == 1:
            images[0].save(tmp)
        else:
            images[0].save(
                tmp,
                save_all=True,
                append_images=images[1:],
                duration=int(1000 / fps),
                loop=0,
                optimize=False,
            )
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
