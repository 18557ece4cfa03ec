"""Messages for bad input, in one style everywhere: ``field: got <value>; expected <allowed>``.

Values are shown through a bounded representation: the full ``repr`` of arbitrary input can
recurse (deeply nested JSON), flood a terminal (a 100 kB string) or raise (an integer of more
than 4300 digits).
"""

from __future__ import annotations

import math
import reprlib

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
