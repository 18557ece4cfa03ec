"""pybullet, imported in one place without its build banner.

The native module prints "pybullet build time: ..." to the process's stdout when it loads (and
its clients print "argv[0]=" when they connect). Into a pipe, C's stdio holds that text until
the process exits, where it lands after a command's JSON lines. Every module of the env imports
pybullet from here, so the banner goes to /dev/null once, in every process (the job runner's
workers included)."""

from __future__ import annotations

import ctypes
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


def _flush_native_stdio() -> None:
    """Write out what C's stdio buffers hold (fflush(NULL)), so that it goes where fd 1 and 2
    point now."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # no C library to call: nothing buffered there either
        pass


@contextmanager
def native_output_muted(fds: tuple[int, ...] = (1,)) -> Iterator[None]:
    """Send file descriptors ``fds`` (1: stdout, 2: stderr) to /dev/null, native code's output
    included: what was written before is flushed first, what is written inside is dropped."""
    sys.stdout.flush()
    sys.stderr.flush()
    _flush_native_stdio()
    saved = [os.dup(fd) for fd in fds]
    try:
        with open(os.devnull, "w") as devnull:
            for fd in fds:
                os.dup2(devnull.fileno(), fd)
        yield
    finally:
        _flush_native_stdio()
        for fd, copy in zip(fds, saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)


@contextmanager
def native_stdout_muted() -> Iterator[None]:
    """Send stdout, native code's included, to /dev/null: a client that connects prints
    "argv[0]=" there (ours, and panda-gym's in `clutter-gym bench env`), which would land in the
    middle of a command's JSON lines (the benchmark's workers each connect)."""
    with native_output_muted((1,)):
        yield


with native_output_muted((1, 2)):
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

__all__ = ["BulletClient", "native_output_muted", "native_stdout_muted", "pybullet"]
