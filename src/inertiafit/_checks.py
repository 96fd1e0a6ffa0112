"""One set of validators for numbers given to the library: one function per rule.

Each raises :class:`~inertiafit.errors.InputError` with one line that starts with ``where``:
the argument's name (``hdi_prob``) or a file and field (``study.toml: gravity``). The command
line turns a leading argument name into its option name, so these messages never speak of
``--flags``.

``field`` (where given) names a key of a table in quotes after ``where``
(``prior 'x': 'mass.sd' must be positive``), the style of the prior and anthropometric files;
without it the message reads ``where: expected ...`` or ``where: must ...``.
"""

from __future__ import annotations

import math
import operator
import os
import sys
from pathlib import Path

from inertiafit.errors import InputError

__all__ = [
    "GRAVITY_RANGE",
    "SEED_MAX",
    "check_finite",
    "check_gravity",
    "check_increasing_pair",
    "check_interval",
    "check_non_negative",
    "check_number",
    "check_path",
    "check_positive",
    "check_probability",
    "check_seed",
    "check_whole",
]

#: Largest seed NumPy's legacy seeding (and so every seed of the library) accepts.
SEED_MAX = 2**32 - 1

#: Gravitational accelerations accepted (m/s^2): Earth's surface gravity is 9.78 (equator) to
#: 9.83 (poles), a little less on mountains; anything outside is a typo or a unit mix-up
#: (981 cm/s^2, 32.2 ft/s^2) that would otherwise surface as trials "outside the priors".
GRAVITY_RANGE = (9.7, 9.9)


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""


def _fail(where: str, field: str | None, must: str, expected: str) -> InputError:
    """``where: 'field' must ...`` with a field, else ``where: expected ...``."""
    if field is not None:
        return InputError(f"{where}: '{field}' {must}")
    return InputError(f"{where}: {expected}")


def _as_float(value: object) -> float | None:
    """``value`` as a float if it is a real number (not a bool, not a string), else None."""
    if isinstance(value, bool | str | bytes):
        return None
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


def check_path(value: object, where: str = "path") -> Path:
    """A file path given as a ``str`` or ``os.PathLike`` (not empty): a :class:`~pathlib.Path`."""
    if isinstance(value, (str, os.PathLike)) and str(value).strip():
        return Path(value)
    raise InputError(f"{where}: expected a file path (str or pathlib.Path), got {value!r}")


def unnameable(exc: UnicodeEncodeError) -> str:
    """What a path's character this machine's file names cannot hold is, for a message.

    An ASCII file-system encoding (``LC_ALL=C`` with UTF-8 mode off) meeting a non-ASCII
    name: ``this machine's file names cannot hold 'é' (file-system encoding ascii)``.
    """
    bad = exc.object[exc.start : exc.end]
    return (
        f"this machine's file names cannot hold {bad!r} (file-system encoding "
        f"{sys.getfilesystemencoding()})"
    )


def check_number(value: object, where: str) -> float:
    """``value`` as a float (``nan`` and ``inf`` included), or an error.

    A real number only, as for every other check here: not a bool and not text (``"1.5"`` in a
    TOML file is a quoted string, which the manifest refuses; the design and pilot files
    refused it too only where another check read it). The command line turns its arguments
    into numbers before they get here.
    """
    out = _as_float(value)
    if out is None:
        raise InputError(f"{where}: expected a number, got {value!r}")
    return out


def check_finite(value: object, where: str, unit: str = "", *, field: str | None = None) -> float:
    """``value`` as a finite float: a real number, not a bool, text, ``nan`` or ``inf``."""
    out = _as_float(value)
    if out is None:
        raise _fail(
            where,
            field,
            f"must be a number{_unit(unit)}, got {value!r}",
            f"expected a number{_unit(unit)}, got {value!r}",
        )
    if not math.isfinite(out):
        raise _fail(
            where,
            field,
            f"must be finite{_unit(unit)}, got {value!r}",
            f"expected a finite number{_unit(unit)}, got {value!r}",
        )
    return out


def check_positive(
    value: object, where: str, unit: str = "", *, field: str | None = None
) -> float:
    """``value`` as a finite float > 0 (``unit`` is named in the message)."""
    out = _as_float(value)
    if out is None:
        raise _fail(
            where,
            field,
            f"must be a positive number{_unit(unit)}, got {value!r}",
            f"expected a positive number{_unit(unit)}, got {value!r}",
        )
    if not math.isfinite(out):
        raise _fail(
            where,
            field,
            f"must be finite and positive{_unit(unit)}, got {value!r}",
            f"expected a positive finite number{_unit(unit)}, got {value!r}",
        )
    if out <= 0:
        raise _fail(
            where,
            field,
            f"must be positive{_unit(unit)}, got {value!r}",
            f"must be positive{_unit(unit)}, got {value!r}",
        )
    return out


def check_non_negative(
    value: object, where: str, unit: str = "", *, field: str | None = None
) -> float:
    """``value`` as a finite float >= 0."""
    out = check_finite(value, where, unit, field=field)
    if out < 0:
        raise _fail(
            where,
            field,
            f"must not be negative{_unit(unit)}, got {value!r}",
            f"must not be negative{_unit(unit)}, got {value!r}",
        )
    return out


def check_interval(
    value: object,
    where: str,
    lower: float,
    upper: float,
    unit: str = "",
    *,
    field: str | None = None,
    upper_closed: bool = False,
    lower_closed: bool = False,
) -> float:
    """``value`` as a float in ``(lower, upper)``.

    ``upper_closed`` and ``lower_closed`` include the ends: ``(lower, upper]``, ``[lower, upper)``.
    """
    span = f"{'[' if lower_closed else '('}{lower:g}, {upper:g}{']' if upper_closed else ')'}" + (
        f" {unit}" if unit else ""
    )
    out = _as_float(value)
    if out is None:
        raise _fail(
            where,
            field,
            f"must be a number{' in ' + unit if unit else ''}, got {value!r}",
            f"expected a number in {span}, got {value!r}",
        )
    beyond = operator.gt if upper_closed else operator.ge
    above = operator.ge if lower_closed else operator.gt
    if not (math.isfinite(out) and above(out, lower) and not beyond(out, upper)):
        raise _fail(
            where,
            field,
            f"must lie in {span}, got {value!r}",
            f"expected a number in {span}, got {value!r}",
        )
    return out


def check_increasing_pair(value: object, where: str, what: str) -> tuple[float, float]:
    """``value`` as two finite, increasing numbers ``(lo, hi)``: a list of two.

    ``what`` says what they are in the message (``"numbers [start, end] in s"``).
    """
    ok = (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(_as_float(v) is not None and math.isfinite(float(v)) for v in value)
    )
    if not ok or not float(value[0]) < float(value[1]):  # type: ignore[index]
        raise InputError(f"{where}: expected two increasing {what}, got {value!r}")
    return float(value[0]), float(value[1])  # type: ignore[index]


def check_probability(value: object, where: str = "hdi_prob") -> float:
    """``value`` as a float strictly between 0 and 1."""
    out = check_number(value, where)
    if not 0 < out < 1:  # nan fails too
        raise InputError(f"{where}: expected a probability in (0, 1), got {value}")
    return out


def check_whole(value: object, where: str, minimum: int = 1) -> int:
    """``value`` as an int ``>= minimum``: an integer, or a float with no fraction."""
    out = _as_float(value)
    if out is None or not math.isfinite(out) or out != int(out) or out < minimum:
        raise InputError(f"{where}: expected a whole number >= {minimum}, got {value!r}")
    return int(out)


def check_seed(value: object, where: str = "seed") -> int:
    """A seed: a whole number from 0 to :data:`SEED_MAX` (what NumPy's generators accept)."""
    out = _as_float(value)
    ok = out is not None and math.isfinite(out) and out == int(out)
    # compared as ints: a float would round 2**32 - 1 + 1 into range
    if not ok or not 0 <= int(value) <= SEED_MAX:  # type: ignore[call-overload]
        raise InputError(f"{where}: expected a whole number from 0 to {SEED_MAX}, got {value!r}")
    return int(value)  # type: ignore[call-overload]


def check_gravity(value: object, where: str = "gravity") -> float:
    """A gravitational acceleration in m/s^2: a positive number within :data:`GRAVITY_RANGE`."""
    out = check_positive(value, where, "m/s^2")
    low, high = GRAVITY_RANGE
    if not low <= out <= high:
        raise InputError(
            f"{where}: expected Earth's surface gravity, {low:g} to {high:g} m/s^2, got {value!r}"
        )
    return out
