"""One set of validators for numbers given to the library.

Each raises :class:`~inertiafit.errors.InputError` with one line that starts with ``where``:
the argument's name (``hdi_prob``) or a file and field (``study.toml: gravity``). The command
line turns argument names into its option names, so these messages never speak of ``--flags``.
"""

from __future__ import annotations

import math

from inertiafit.errors import InputError

__all__ = ["check_number", "check_positive", "check_probability"]


def check_number(value: object, where: str) -> float:
    """``value`` as a float (``nan`` and ``inf`` included), or an :class:`InputError`."""
    if isinstance(value, bool):
        raise InputError(f"{where}: expected a number, got {value!r}")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected a number, got {value!r}") from None


def check_positive(value: object, where: str, unit: str = "") -> float:
    """``value`` as a finite float > 0 (``unit`` is named in the message)."""
    out = check_number(value, where)
    if not math.isfinite(out) or out <= 0:
        unit_text = f" ({unit})" if unit else ""
        raise InputError(f"{where}: expected a positive finite number{unit_text}, got {value!r}")
    return out


def check_probability(value: object, where: str = "hdi_prob") -> float:
    """``value`` as a float strictly between 0 and 1."""
    out = check_number(value, where)
    if not 0 < out < 1:  # nan fails too
        raise InputError(f"{where}: expected a probability in (0, 1), got {value}")
    return out
