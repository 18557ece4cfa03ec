"""Argument types of the `clutter-gym` command line: every bad value is rejected while the
arguments are parsed, before any work, with one line naming the flag, the value and what is
allowed (argparse adds the flag: "argument --trials: -1 is not an integer >= 0").

Output paths are checked as the writes will need them (not empty, not a directory, not under a
regular file, a directory that really accepts a new file), so a long run never fails at its end
because of where it was asked to write.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from clutter_gym.model.fields import shown


def integer(minimum: int) -> Callable[[str], int]:
    """An integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{shown(text)} is not an integer >= {minimum}"
            ) from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is not an integer >= {minimum}")
        return value

    return parse


def positive_number(text: str) -> float:
    """A finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{shown(text)} is not a number > 0") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{shown(text)} is not a finite number > 0")
    return value


def fraction(text: str) -> float:
    """A number in [0, 1]."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{shown(text)} is not a fraction in [0, 1]")
    return value


def number_or_all(text: str) -> float | str:
    """A finite number > 0, or "all"."""
    return "all" if text == "all" else positive_number(text)


def numbers(text: str) -> tuple[float, ...]:
    """A comma-separated, non-empty list of finite numbers."""
    try:
        values = tuple(float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{shown(text)} is not a comma-separated list of numbers, e.g. 0,45"
        ) from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{shown(text)} holds a value that is not finite")
    return values


def names(text: str) -> tuple[str, ...]:
    """A comma-separated, non-empty list of names (checked against the choices later)."""
    parts = tuple(dict.fromkeys(part.strip() for part in text.split(",") if part.strip()))
    if not parts:
        raise argparse.ArgumentTypeError(f"{shown(text)} names nothing; give at least one name")
    return parts


def integers(minimum: int) -> Callable[[str], tuple[int, ...]]:
    """A comma-separated, non-empty list of distinct integers >= ``minimum``, e.g. 0,1,2."""
    one = integer(minimum)

    def parse(text: str) -> tuple[int, ...]:
        parts = [part.strip() for part in text.split(",") if part.strip()]
        if not parts:
            raise argparse.ArgumentTypeError(f"{shown(text)} names nothing; give e.g. 0,1,2")
        return tuple(dict.fromkeys(one(part) for part in parts))

    return parse


def names_from(allowed: tuple[str, ...], what: str) -> Callable[[str], tuple[str, ...]]:
    """A comma-separated, non-empty list of names, each one of ``allowed``."""

    def parse(text: str) -> tuple[str, ...]:
        chosen = names(text)
        for name in chosen:
            if name not in allowed:
                raise argparse.ArgumentTypeError(
                    f"{shown(name)} is not {what}; allowed: {', '.join(allowed)}"
                )
        return chosen

    return parse


def input_dir(text: str) -> Path:
    """An existing directory."""
    if not text:
        raise argparse.ArgumentTypeError("the path is empty")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a directory")
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: no such directory")
    return path


def input_file(text: str) -> Path:
    """An existing regular file."""
    if not text:
        raise argparse.ArgumentTypeError("the path is empty")
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory, not a file")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{text}: no such file")
    return path


def output_file(text: str) -> Path:
    """A file that can be written (created with its missing parent directories)."""
    path = _output_path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory; give a file name")
    return path


def output_dir(text: str) -> Path:
    """A directory that exists or can be created, and accepts new files."""
    path = _output_path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a directory")
    return path


def _output_path(text: str) -> Path:
    if not text:
        raise argparse.ArgumentTypeError("the path is empty")
    path = Path(text)
    existing = path if path.is_dir() else path.parent
    while not existing.exists():
        existing = existing.parent
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(
            f"{text} cannot be created: {existing} is a file, not a directory"
        )
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as error:
        raise argparse.ArgumentTypeError(
            f"{text} cannot be written: {existing} does not accept new files "
            f"({error.strerror or type(error).__name__})"
        ) from None
    return path


def read_json(path: Path, flag: str) -> Any:
    """The JSON value of a file; ValueError naming the flag and the file otherwise."""
    try:
        return json.loads(path.read_text())
    except (ValueError, RecursionError) as error:
        raise ValueError(f"{flag}: {path} is not valid JSON ({error})") from None
    except OSError as error:
        raise ValueError(f"{flag}: {path} cannot be read ({error.strerror})") from None


COUNT = integer(1)
"""A count: an integer >= 1."""
SEED = integer(0)
"""A seed: an integer >= 0."""


def noise(text: str) -> str | tuple[float, float]:
    """A noise level name, or "sigma_xy,sigma_theta" in metres and radians."""
    from clutter_gym.model.noise import NOISE_LEVELS, resolve_noise

    try:
        if "," in text:
            xy, theta = text.split(",", 1)
            return resolve_noise((float(xy), float(theta)))
        resolve_noise(text)
        return text
    except ValueError as error:
        levels = ", ".join(NOISE_LEVELS)
        why = f" ({error})" if "," in text else ""
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a noise level ({levels}) or 'sigma_xy,sigma_theta'{why}"
        ) from None


def agent(text: str) -> object:
    """An agent of `clutter-gym evaluate`: a training directory (its files are read now),
    planner:NAME or scripted."""
    from agents.learning.agent_specs import parse_agent

    try:
        return parse_agent(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
