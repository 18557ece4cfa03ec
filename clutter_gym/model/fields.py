"""Checked input fields: messages for bad input in one style everywhere,
``field: got <value>; expected <allowed>``, and the type checks that produce them (scene files,
env keywords and options, noise levels).

Values are shown through a bounded representation: the full ``repr`` of arbitrary input can
recurse (deeply nested JSON), flood a terminal (a 100 kB string) or raise (an integer of more
than 4300 digits).
"""

from __future__ import annotations

import math
import numbers as _numbers
import re
import reprlib
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np


class _ShortRepr(reprlib.Repr):
    """``reprlib`` that describes huge integers instead of printing them."""

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() <= 64:
            return repr(x)
        digits = int(x.bit_length() * math.log10(2)) + 1
        return f"<{'negative ' if x < 0 else ''}integer of ~{digits} digits>"

    def repr_ndarray(self, x: np.ndarray, level: int) -> str:
        """Arrays by dtype and shape: their values can be thousands."""
        return f"array of dtype {x.dtype}, shape {x.shape}"


_SHORT = _ShortRepr()
_SHORT.maxlevel = 3
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxset = _SHORT.maxdict = 4
_SHORT.maxstring = _SHORT.maxother = 60


def shown(value: object) -> str:
    """A short representation of any value: bounded depth, length and item count."""
    return _SHORT.repr(value)


def invalid(field: str, value: object, expected: str) -> ValueError:
    """The error for a bad value of a field (a JSON path, a keyword or an option)."""
    return ValueError(f"{field}: got {shown(value)}; expected {expected}")


def allowed(names: Sequence[str] | Mapping[str, Any]) -> str:
    return "one of " + ", ".join(repr(n) for n in sorted(names))


_PLAIN_KEY = re.compile(r"[A-Za-z0-9_]{1,64}")
"""An unknown key of this form is named as a field path; any other is shown abbreviated after
the path of its object, so that messages still start with a well-formed path."""


def mapping(
    value: object, path: str, required: tuple[str, ...], optional: tuple[str, ...] = ()
) -> Mapping[str, Any]:
    prefix = f"{path}." if path else ""
    if not isinstance(value, Mapping):
        raise invalid(path or "scene", value, "a JSON object")
    for key in required:
        if key not in value:
            raise ValueError(f"{prefix}{key}: missing required key")
    allowed = required + optional
    extra = [k for k in value if k not in allowed]
    if extra:
        where = (
            f"{prefix}{extra[0]}: unknown key"
            if isinstance(extra[0], str) and _PLAIN_KEY.fullmatch(extra[0])
            else f"{path or 'scene'}: unknown key {shown(extra[0])}"
        )
        raise ValueError(f"{where}; allowed keys: {', '.join(allowed)}")
    return value


def string(value: object, path: str) -> str:
    if not isinstance(value, str):
        raise invalid(path, value, "a string")
    return value


def number(value: object, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise invalid(path, value, "a number")
    try:
        number = float(value)
    except OverflowError:  # an int beyond the float range
        raise invalid(path, value, "a finite number (within ±1.8e308)") from None
    if not math.isfinite(number):
        raise invalid(path, value, "a finite number")
    return number


def numbers(value: object, path: str, length: int, what: str) -> tuple[float, ...]:
    if not isinstance(value, list | tuple) or len(value) != length:
        raise invalid(path, value, what)
    return tuple(number(v, f"{path}[{k}]") for k, v in enumerate(value))


def integer(field: str, value: object, minimum: int) -> int:
    """A Python or numpy integer >= `minimum`; not a bool or a float, which int() would
    silently turn into 1 or truncate (2.7 steps -> 2)."""
    if isinstance(value, bool) or not isinstance(value, _numbers.Integral) or value < minimum:
        raise invalid(field, value, f"an integer >= {minimum}")
    return int(value)


def positive_number(field: str, value: object, unit: str) -> float:
    """A finite Python or numpy real > 0; not a bool or a string."""
    real = float(value) if isinstance(value, _numbers.Real) else math.nan
    if isinstance(value, bool) or not (math.isfinite(real) and real > 0):
        raise invalid(field, value, f"a finite number > 0 ({unit})")
    return real
