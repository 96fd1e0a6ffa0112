"""One number formatter for every table and text the library shows.

Tables (CSV aside, which keep full precision), Markdown, LaTeX, HTML and the terminal's text
all show a value with :func:`number`, an interval with :func:`interval` and a mean with its SD
with :func:`mean_sd`, so a value reads the same everywhere.
"""

from __future__ import annotations

import math
from numbers import Integral, Real

__all__ = ["interval", "mean_sd", "number", "plural"]


def number(value: object, digits: int = 4) -> str:
    """``value`` for a table: ``digits`` significant figures for a real number.

    An integer is shown whole, a bool as ``yes``/``no``, NaN and None blank, any other value
    as its text.
    """
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, Integral):
        return str(int(value))
    if isinstance(value, Real):
        v = float(value)
        return "" if math.isnan(v) else f"{v:.{digits}g}"
    return str(value)


def interval(lower: float, upper: float, digits: int = 4) -> str:
    """``[lower, upper]`` with ``digits`` significant figures each."""
    return f"[{lower:.{digits}g}, {upper:.{digits}g}]"


def mean_sd(mean: float, sd: float) -> str:
    """``mean ± sd``: the mean to 4 significant figures, its SD to 2."""
    return f"{mean:.4g} ± {sd:.2g}"


def plural(n: int, word: str, many: str | None = None) -> str:
    """A count with its noun in the right number: ``"1 body"``, ``"2 bodies"``, ``"0 trials"``.

    ``many`` is the plural when it is not ``word`` + ``s`` (or ``-y`` -> ``-ies``).
    """
    if n == 1:
        return f"1 {word}"
    if many is None:
        consonant_y = word.endswith("y") and word[-2:-1] not in ("a", "e", "i", "o", "u")
        many = word[:-1] + "ies" if consonant_y else word + "s"
    return f"{n} {many}"
