"""One number formatter for every table and text the library shows.

Tables (CSV aside, which keep full precision), Markdown, LaTeX, HTML and the terminal's text
all show a value with :func:`number`, an interval with :func:`interval` and a mean with its SD
(or a value with its SE) with :func:`mean_sd`, so a value reads the same everywhere. The
sampler's and the identification's numbers have one function each: :func:`r_hat`,
:func:`ess`, :func:`share` (the prior's share, a ratio of SDs), :func:`correlation` and
:func:`tail_probability`.
"""

from __future__ import annotations

import math
from numbers import Integral, Real

__all__ = [
    "correlation",
    "ess",
    "interval",
    "mean_sd",
    "number",
    "plural",
    "r_hat",
    "share",
    "tail_probability",
]


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


def mean_sd(mean: float, sd: float, digits: int = 4) -> str:
    """``mean ± sd``: the mean to ``digits`` significant figures, its SD to 2.

    An SD of 100 or more is shown whole (``1518 ± 3428``, not ``3.4e+03``). A value with its
    standard error reads the same.
    """
    spread = f"{sd:.0f}" if abs(sd) >= 100 else f"{sd:.2g}"
    return f"{mean:.{digits}g} ± {spread}"


def r_hat(value: float) -> str:
    """An R-hat to three decimals (``1.003``); blank for NaN (a quantity not sampled)."""
    return "" if math.isnan(value) else f"{value:.3f}"


def ess(value: float) -> str:
    """An effective sample size, whole (``1234``); blank for NaN."""
    return "" if math.isnan(value) else f"{value:.0f}"


def share(value: float) -> str:
    """A share to two decimals (``0.37``), never ``-0.00``; blank when it is not finite.

    The prior's share of a quantity, and the numbers shown beside it (the ratio of posterior
    to prior SD, the calibration's share, psense), read this way.
    """
    if not math.isfinite(value):
        return ""
    return f"{0.0 if abs(value) < 0.005 else value:.2f}"


def correlation(value: float) -> str:
    """A correlation to two decimals with its sign (``+0.93``, ``-0.12``)."""
    return f"{value:+.2f}"


def tail_probability(p: float) -> str:
    """A tail probability to two significant figures, ``< 1e-6`` below that; blank for NaN."""
    if math.isnan(p):
        return ""
    return "< 1e-6" if p < 1e-6 else f"{p:.2g}"


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
