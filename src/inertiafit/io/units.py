"""The package's one table of units and their conversion to and from SI.

Readers convert every channel to SI exactly once, here: time to s, angle to rad, angular
velocity to rad/s and torque to N m. The accepted spellings are listed in ``ACCEPTED``; a unit
outside them is an :class:`~inertiafit.errors.InputError` that lists them.

Besides the four channels the table holds the units of prior files, ``mass`` (kg, g) and
``length`` (m, cm, mm), which :mod:`inertiafit.inference.priors` reads through
:func:`si_factors`; and the simulator writes its trial files with :func:`from_si`.
"""

from __future__ import annotations

import math
import re

import numpy as np
from numpy.typing import ArrayLike, NDArray

from inertiafit.errors import InputError

__all__ = [
    "ACCEPTED",
    "DEG",
    "EMG_UNITS",
    "FT_LBF",
    "IN_LBF",
    "QUANTITIES",
    "SI_UNITS",
    "canonical_unit",
    "emg_unit",
    "from_si",
    "si_factors",
    "to_si",
    "unit_factor",
]

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

#: Radians per degree.
DEG = math.pi / 180.0

# Canonical spelling -> factor to SI, per quantity: the four channels, then the mass and length
# units of prior files. Aliases map onto canonical spellings after normalisation (lower case, no
# spaces; "·", "-" and "." read as "*").
_FACTORS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3},
    "angle": {"deg": DEG, "rad": 1.0},
    "velocity": {"deg/s": DEG, "rad/s": 1.0},
    "torque": {"N*m": 1.0, "ft*lbf": FT_LBF, "in*lbf": IN_LBF},
    "mass": {"kg": 1.0, "g": 1e-3},
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
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
    "mass": {"kg": "kg", "g": "g"},
    "length": {"m": "m", "cm": "cm", "mm": "mm"},
}

#: Canonical accepted units per quantity, for messages and documentation.
ACCEPTED = {q: tuple(table) for q, table in _FACTORS.items()}


def _normalise(unit: str) -> str:
    text = re.sub(r"\s*/\s*", "/", unit.strip().lower())
    for sep in ("·", "⋅", "-", "."):
        text = text.replace(sep, "*")
    return "*".join(text.split())


#: Units of an EMG channel and their factor to volts (the Trial's ``emg`` is in V).
EMG_UNITS = {"V": 1.0, "mV": 1e-3, "µV": 1e-6}
#: Spellings of the EMG units, after lower-casing: ``u`` and the Greek mu stand for the micro
#: sign.
_EMG_ALIASES = {
    "v": "V",
    "volt": "V",
    "volts": "V",
    "mv": "mV",
    "µv": "µV",
    "\u03bcv": "µV",
    "uv": "µV",
}


def emg_unit(unit: object, *, where: str) -> str:
    """Return the canonical spelling (``V``, ``mV``, ``µV``) of an EMG channel's unit.

    ``uV`` and the Greek letter mu are read as ``µV``; case does not matter.

    Raises
    ------
    InputError
        If ``unit`` is not a string or not a voltage unit; the message lists the accepted ones.
    """
    if not isinstance(unit, str):
        raise InputError(f"{where}: EMG unit must be a string, got {unit!r}")
    found = _EMG_ALIASES.get(unit.strip().lower())
    if found is None:
        raise InputError(
            f"{where}: unknown EMG unit {unit!r} (accepted: {', '.join(EMG_UNITS)}, or uV)"
        )
    return found


def si_factors(quantity: str) -> dict[str, float]:
    """Return the canonical spellings of ``quantity``'s units and their factors to SI.

    Parameters
    ----------
    quantity : {"time", "angle", "velocity", "torque", "mass", "length"}
        A channel, or a quantity of a prior file.

    Returns
    -------
    dict of str to float
        Canonical spelling -> factor that converts a value in that unit to SI (a new dict, in
        the order of ``ACCEPTED[quantity]``). For a caller that accepts the canonical
        spellings only, without the aliases of :func:`canonical_unit`.

    Raises
    ------
    KeyError
        If ``quantity`` is not in the table.
    """
    return dict(_FACTORS[quantity])


def canonical_unit(quantity: str, unit: object, *, where: str) -> str:
    """Return the canonical spelling of ``unit`` for ``quantity``.

    Parameters
    ----------
    quantity : {"time", "angle", "velocity", "torque", "mass", "length"}
        The channel (or prior quantity) the unit belongs to.
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
        raise InputError(
            f"{where}: unknown quantity {quantity!r} (quantities: {', '.join(_FACTORS)})"
        )
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
    quantity : {"time", "angle", "velocity", "torque", "mass", "length"}
        The quantity.
    unit : str
        Any accepted spelling (see :func:`canonical_unit`).
    where : str
        ``"<file>: <field>"`` for the error message.

    Returns
    -------
    float
        Multiply values in ``unit`` by this to get s, rad, rad/s, N m, kg or m.

    Raises
    ------
    InputError
        If the unit is not accepted.
    """
    return _FACTORS[quantity][canonical_unit(quantity, unit, where=where)]


def to_si(values: ArrayLike, quantity: str, unit: object, *, where: str) -> NDArray[np.float64]:
    """Convert ``values`` of ``quantity`` from ``unit`` to SI (float64 array).

    Parameters
    ----------
    values : array_like
        Values in ``unit``.
    quantity : {"time", "angle", "velocity", "torque", "mass", "length"}
        The quantity.
    unit : str
        Any accepted spelling (see :func:`canonical_unit`).
    where : str
        ``"<file>: <field>"`` for the error message.

    Returns
    -------
    ndarray of float64
        The values in s, rad, rad/s, N m, kg or m.

    Raises
    ------
    InputError
        If the unit is not accepted.
    """
    factor = unit_factor(quantity, unit, where=where)
    out = np.asarray(values, dtype=np.float64)
    return out if factor == 1.0 else out * factor


def from_si(values: ArrayLike, quantity: str, unit: object, *, where: str) -> NDArray[np.float64]:
    """Convert ``values`` of ``quantity`` from SI to ``unit`` (float64 array); undoes to_si.

    Parameters
    ----------
    values : array_like
        Values in s, rad, rad/s, N m, kg or m.
    quantity : {"time", "angle", "velocity", "torque", "mass", "length"}
        The quantity.
    unit : str
        Any accepted spelling (see :func:`canonical_unit`).
    where : str
        ``"<file>: <field>"`` for the error message.

    Returns
    -------
    ndarray of float64
        The values in ``unit``: multiplied by ``1 / factor``, not divided by ``factor`` (the
        two can differ in the last bit; the simulator's files are written this way).

    Raises
    ------
    InputError
        If the unit is not accepted.
    """
    factor = unit_factor(quantity, unit, where=where)
    out = np.asarray(values, dtype=np.float64)
    return out if factor == 1.0 else out * (1.0 / factor)
