"""Writing what the env shows: GIFs of rollouts, PNG stills and JSON summaries (atomically)."""

from __future__ import annotations

import io
import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np
from PIL import GifImagePlugin, Image

from clutter_gym.model.files import atomic_file, atomic_write_bytes, atomic_write_text


def write_json(path: Path, payload: dict[str, Any]) -> None:
    atomic_write_text(path, json.dumps(payload, indent=2, sort_keys=True) + "\n")


def write_png(path: Path, frame: np.ndarray) -> None:
    buffer = io.BytesIO()
    Image.fromarray(np.asarray(frame, dtype=np.uint8)).save(buffer, format="PNG")
    atomic_write_bytes(path, buffer.getvalue())


@contextmanager
def gif_writer(path: Path, fps: int = 10) -> Iterator[GifStream]:
    """A looping GIF at ``path`` written frame by frame as frames come (`GifStream.add`), so a
    long rollout needs the memory of one frame, not of all of them (a 76 s demo at 10 fps is
    760 RGB frames, 400 MB). The file appears atomically when the block ends without an error."""
    with atomic_file(Path(path)) as handle:
        gif = GifStream(handle, round(1000 / fps))
        yield gif
        gif.finish()


class GifStream:
    """Frames written into an open GIF file. Each frame stores only the rectangle that changed
    since the previous one (most of a rollout's picture is a still table), quantised to its own
    256-colour palette and drawn over what is already shown."""

    def __init__(self, handle: IO[bytes], duration_ms: int) -> None:
        self._handle = handle
        self._duration_ms = duration_ms
        self._previous: np.ndarray | None = None
        self.frames = 0

    def add(self, frame: np.ndarray) -> None:
        """Append one RGB frame (H, W, 3) uint8; every frame must have the first one's size."""
        rgb = np.asarray(frame, dtype=np.uint8)
        if self._previous is None:
            image = Image.fromarray(rgb).quantize(256)
            header, _ = GifImagePlugin.getheader(image, None, {"loop": 0})
            self._handle.write(b"".join(header))
            self._write(image, (0, 0))
        elif rgb.shape != self._previous.shape:
            raise ValueError(
                f"frame {self.frames}: shape {rgb.shape}, expected {self._previous.shape}"
            )
        else:
            rows, cols = np.nonzero((rgb != self._previous).any(axis=2))
            top, left = (int(rows.min()), int(cols.min())) if len(rows) else (0, 0)
            bottom, right = (int(rows.max()) + 1, int(cols.max()) + 1) if len(rows) else (1, 1)
            patch = Image.fromarray(rgb[top:bottom, left:right]).quantize(256)
            self._write(patch, (left, top))
        self._previous = rgb
        self.frames += 1

    def _write(self, image: Image.Image, offset: tuple[int, int]) -> None:
        params = {"duration": self._duration_ms, "include_color_table": True, "disposal": 1}
        for chunk in GifImagePlugin.getdata(image, offset, **params):
            self._handle.write(chunk)

    def finish(self) -> None:
        if self._previous is None:
            raise ValueError("frames: empty; a GIF needs at least one frame")
        self._handle.write(b";")  # the GIF trailer
