"""Writing what the env shows: GIFs of rollouts, PNG stills and JSON summaries (atomically)."""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from clutter_gym.files import atomic_write_bytes, atomic_write_text


def write_json(path: Path, payload: dict[str, Any]) -> None:
    atomic_write_text(path, json.dumps(payload, indent=2, sort_keys=True) + "\n")


def write_png(path: Path, frame: np.ndarray) -> None:
    buffer = io.BytesIO()
    Image.fromarray(np.asarray(frame, dtype=np.uint8)).save(buffer, format="PNG")
    atomic_write_bytes(path, buffer.getvalue())


def write_gif(path: Path, frames: Sequence[np.ndarray], fps: int = 10) -> None:
    if not frames:
        raise ValueError("frames: empty; a GIF needs at least one frame")
    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    buffer = io.BytesIO()
    images[0].save(
        buffer,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=int(1000 / fps),
        loop=0,
    )
    atomic_write_bytes(path, buffer.getvalue())
