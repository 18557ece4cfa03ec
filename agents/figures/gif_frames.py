"""A contact sheet of a GIF: evenly spaced frames in a grid, read left to right, top to bottom
(the README's picture of `clutter-gym demo`), so a rollout can be seen on a page."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageSequence

from clutter_gym.media import write_png


def frame_indices(total: int, count: int) -> list[int]:
    """``count`` frame numbers spread over ``total`` frames, the first and the last included."""
    if total < 1 or count < 1:
        raise ValueError(f"a sheet needs frames: the GIF has {total}, {count} were asked for")
    return sorted({round(float(i)) for i in np.linspace(0, total - 1, min(count, total))})


def contact_sheet(gif: Path, out: Path, count: int = 8, columns: int = 4) -> int:
    """Write ``count`` evenly spaced frames of ``gif`` as one PNG, ``columns`` to a row; the
    number of frames on the sheet. A GIF stores changed rectangles, so frames are composed
    in order (PIL's iterator does that) and the chosen ones copied."""
    with Image.open(gif) as image:
        total = int(getattr(image, "n_frames", 1))  # a still picture has no n_frames
        wanted = set(frame_indices(total, count))
        chosen = [
            np.asarray(frame.convert("RGB"))
            for i, frame in enumerate(ImageSequence.Iterator(image))
            if i in wanted
        ]
    height, width = chosen[0].shape[:2]
    rows = -(-len(chosen) // columns)
    sheet = np.full((rows * height, min(columns, len(chosen)) * width, 3), 255, dtype=np.uint8)
    for k, frame in enumerate(chosen):
        r, c = divmod(k, columns)
        sheet[r * height : (r + 1) * height, c * width : (c + 1) * width] = frame
    write_png(out, sheet)
    return len(chosen)
