"""Units of the four trial channels and their conversion to SI.

Readers convert every channel to SI exactly once, here: time to s, angle to rad, angular
velocity to rad/s and torque to N m. The accepted spellings are listed in ``ACCEPTED``; a unit
outside them is an :class:`~inertiafit.errors.InputError` that lists them.
"""

from __future__ import annotations

import math
import re

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertiafit.errors import InputError

#: The four channels of a trial, in the order of the Trial's data variables (time first).
QUANTITIES = ("time", "angle", "velocity", "torque")

#: SI unit of each channel, as written in ``attrs["units"]`` of a Trial.
SI_UNITS = {"time": "s", "angle": "rad", "velocity": "rad/s", "torque": "N m"}

#: Newton metres per foot pound-force: 0.3048 m x 4.4482216152605 N, both exact by definition.
#: Written as the exact decimal product; the float product 0.3048 * 4.4482216152605 rounds one
#: ulp lower.
FT_LBF = 1.3558179483314004
#: Newton metres per inch pound-force.
IN_LBF = FT_LBF / 12.0

_DEG = math.pi / 180.0

# Canonical spelling -> factor to SI, per channel. Aliases map onto canonical spellings after
# normalisation (lower case, no spaces; "·", "-" and "." read as "*").
_FACTORS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3},
    "angle": {"deg": _DEG, "rad": 1.0},
    "velocity": {"deg/s": _DEG, "rad/s": 1.0},
    "torque": {"N*m": 1.0, "ft*lbf": FT_LBF, "in*lbf": IN_LBF},
}
_ALIASES: dict[str, dict[str, str]] = {
    "time": {
        "s": "s",
        "sec": "s",
        "second": "s",
        "seconds": "s",
        "ms": "ms",
        "msec": "ms",
        "millisecond": "ms",
        "milliseconds": "ms",
    },
    "angle": {
        "deg": "deg",
        "degree": "deg",
        "degrees": "deg",
        "°": "deg",
        "rad": "rad",
        "radian": "rad",
        "radians": "rad",
    },
    "velocity": {
        "deg/s": "deg/s",
        "deg/sec": "deg/s",
        "d/s": "deg/s",
        "°/s": "deg/s",
        "degrees/s": "deg/s",
        "degrees/second": "deg/s",
        "rad/s": "rad/s",
        "rad/sec": "rad/s",
        "radians/s": "rad/s",
    },
    "torque": {
        "n*m": "N*m",
        "nm": "N*m",
        "newton*meters": "N*m",
        "newton*metres": "N*m",
        "ft*lbf": "ft*lbf",
        "ft*lb": "ft*lbf",
        "ft*lbs": "ft*lbf",
        "foot*pounds": "ft*lbf",
        "in*lbf": "in*lbf",
        "in*lb": "in*lbf",
        "in*lbs": "in*lbf",
        "inch*pounds": "in*lbf",
    },
}

#: Canonical accepted units per channel, for messages and documentation.
ACCEPTED = {q: tuple(table) for q, table in _FACTORS.items()}


def _normalise(unit: str) -> str:
    text = re.sub(r"\s*/\s*", "/", unit.strip().lower())
    for sep in ("·", "⋅", "-", "."):
        text = text.replace(sep, "*")
    return "*".join(text.split())


def canonical_unit(quantity: str, unit: object, *, where: str) -> str:
    """Return the canonical spelling of ``unit`` for channel ``quantity``.

    Parameters
    ----------
    quantity : {"time", "angle", "velocity", "torque"}
        The channel the unit belongs to.
    unit : str
        The unit as written by a user or a file, e.g. ``"ft-lb"`` or ``"N·m"``.
    where : str
        Where the unit came from, for the error message: ``"<file>: <field>"``.

    Returns
    -------
    str
        One of ``ACCEPTED[quantity]``.

    Raises
    ------
    InputError
        If ``unit`` is not a string or not an accepted spelling; the message lists the
        accepted units.
    """
    if quantity not in _FACTORS:
        raise InputError(f"{where}: unknown channel {quantity!r} (channels: time, angle, ...)")
    accepted = ", ".join(ACCEPTED[quantity])
    if not isinstance(unit, str):
        raise InputError(f"{where}: {quantity} unit must be a string, got {unit!r}")
    # A spelling that already is canonical (e.g. "N*m") skips the alias table.
    if unit.strip() in _FACTORS[quantity]:
        return unit.strip()
    found = _ALIASES[quantity].get(_normalise(unit))
    if found is None:
        raise InputError(f"{where}: unknown {quantity} unit {unit!r} (accepted: {accepted})")
    return found


def unit_factor(quantity: str, unit: object, *, where: str) -> float:
    """Return the factor that converts ``quantity`` from ``unit`` to SI.

    Parameters
    ----------
    quantity : {"time", "angle", "velocity", "torque"}
        The channel.
    unit : str
        Any accepted spelling (see :func:`canonical_unit`).
    where : str
        ``"<file>: <field>"`` for the error message.

    Returns
    -------
    float
        Multiply values in ``unit`` by this to get s, rad, rad/s or N m.

    Raises
    ------
    InputError
        If the unit is not accepted.
    """
    return _FACTORS[quantity][canonical_unit(quantity, unit, where=where)]


def to_si(values: ArrayLike, quantity: str, unit: object, *, where: str) -> NDArray[np.float64]:
    """Convert ``values`` of channel ``quantity`` from ``unit`` to SI (float64 array).

    Parameters
    ----------
    values : array_like
        Values in ``unit``.
    quantity : {"time", "angle", "velocity", "torque"}
        The channel.
    unit : str
        Any accepted spelling (see :func:`canonical_unit`).
    where : str
        ``"<file>: <field>"`` for the error message.

    Returns
    -------
    ndarray of float64
        The values in s, rad, rad/s or N m.

    Raises
    ------
    InputError
        If the unit is not accepted.
    """
    factor = unit_factor(quantity, unit, where=where)
    out = np.asarray(values, dtype=np.float64)
    return out if factor == 1.0 else out * factor
