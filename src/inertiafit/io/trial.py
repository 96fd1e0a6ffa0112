"""The Trial: one dynamometer recording as an :class:`xarray.Dataset` in SI units.

A Trial is the contract between the readers and the processing stage:

- coordinate ``time`` (s, float64, strictly increasing, starting wherever the file starts);
- data variables ``angle`` (rad), ``velocity`` (rad/s) and ``torque`` (N m), float64 along
  ``time``; every variable and the coordinate carry ``attrs["units"]``;
- dataset attrs ``source`` (str, the file), ``sampling_rate`` (Hz, float, the inverse of the
  median time step to 12 significant digits) and ``format`` (the reader's name).

:func:`make_trial` is the only way readers build one: it checks what every later stage relies
on (finite values, increasing time without gaps, enough samples) and names the file, the column
and the row of the first problem.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from inertiafit.errors import InputError
from inertiafit.io.units import QUANTITIES, SI_UNITS

__all__ = [
    "GAP_FACTOR",
    "MIN_SAMPLES",
    "make_trial",
]

#: Fewest samples a trial may have; fewer cannot hold an acceleration window or a fit.
MIN_SAMPLES = 10
#: A time step longer than this multiple of the median step is a gap (lost samples).
GAP_FACTOR = 1.5

_LONG_NAMES = {
    "time": "time",
    "angle": "angle of the dynamometer shaft",
    "velocity": "angular velocity of the shaft",
    "torque": "moment measured at the shaft",
}


def make_trial(
    time: ArrayLike,
    angle: ArrayLike,
    velocity: ArrayLike,
    torque: ArrayLike,
    *,
    source: str,
    format: str = "csv",
    columns: Mapping[str, str] | None = None,
    lines: ArrayLike | None = None,
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Check four channels in SI units and build a Trial dataset.

    Parameters
    ----------
    time : array_like[nsamples]
        Sample times (s), strictly increasing.
    angle : array_like[nsamples]
        Shaft angle (rad).
    velocity : array_like[nsamples]
        Shaft angular velocity (rad/s).
    torque : array_like[nsamples]
        Measured moment (N m).
    source : str
        The file the values came from; named in every error and kept in ``attrs["source"]``.
    format : str, optional
        Name of the reader, kept in ``attrs["format"]``.
    columns : mapping of str to str, optional
        The file's column name of each channel, used in error messages (default: the channel
        names).
    lines : array_like[nsamples] of int, optional
        The line number of each sample in the file, used in error messages (default: the
        1-based sample number, reported as "sample").
    attrs : mapping, optional
        Extra dataset attributes (str, int or float values) recorded by the reader.

    Returns
    -------
    xarray.Dataset
        The Trial (see the module docstring).

    Raises
    ------
    InputError
        If the channels differ in length, have fewer than ``MIN_SAMPLES`` samples, contain a
        NaN or infinite value, if time does not strictly increase, or if a time step exceeds
        ``GAP_FACTOR`` times the median step (a gap).
    """
    names = {q: q for q in QUANTITIES}
    if columns:
        names.update({q: str(c) for q, c in columns.items() if q in names})
    arrays = {}
    for quantity, values in zip(QUANTITIES, (time, angle, velocity, torque), strict=True):
        array = np.asarray(values, dtype=np.float64)
        if array.ndim != 1:
            raise InputError(
                f"{source}: column '{names[quantity]}' must be one-dimensional, "
                f"got shape {array.shape}"
            )
        arrays[quantity] = array
    n = arrays["time"].size
    for quantity, array in arrays.items():
        if array.size != n:
            raise InputError(
                f"{source}: column '{names[quantity]}' has {array.size} values but "
                f"'{names['time']}' has {n}; every channel needs one value per sample"
            )
    if n < MIN_SAMPLES:
        raise InputError(
            f"{source}: only {n} samples; a trial needs at least {MIN_SAMPLES} "
            "(is the file empty or cut short?)"
        )

    if lines is None:
        where = np.arange(1, n + 1)
        row_word = "sample"
    else:
        where = np.asarray(lines)
        row_word = "line"

    for quantity, array in arrays.items():
        bad = ~np.isfinite(array)
        if bad.any():
            i = int(np.argmax(bad))
            more = int(bad.sum()) - 1
            extra = f" (and {more} more)" if more else ""
            raise InputError(
                f"{source}: column '{names[quantity]}' has a missing or non-finite value "
                f"({float(array[i])}) at {row_word} {where[i]}{extra}; values must be finite numbers"
            )

    t = arrays["time"]
    dt = np.diff(t)
    bad = dt <= 0
    if bad.any():
        i = int(np.argmax(bad)) + 1
        raise InputError(
            f"{source}: column '{names['time']}' does not increase at {row_word} {where[i]} "
            f"({t[i]:g} s after {t[i - 1]:g} s); time must be strictly increasing"
        )
    step = float(np.median(dt))
    gaps = dt > GAP_FACTOR * step
    if gaps.any():
        i = int(np.argmax(gaps))
        raise InputError(
            f"{source}: gap in column '{names['time']}' at {row_word} {where[i + 1]}: "
            f"{dt[i]:g} s between t = {t[i]:g} s and t = {t[i + 1]:g} s, more than "
            f"{GAP_FACTOR:g} x the median step {step:g} s (samples missing?)"
        )

    data_vars = {
        q: (
            "time",
            arrays[q],
            {"units": SI_UNITS[q], "long_name": _LONG_NAMES[q]},
        )
        for q in QUANTITIES[1:]
    }
    dataset_attrs: dict[str, Any] = {
        "source": str(source),
        # 12 significant digits: 100 Hz stays 100.0 after ms -> s rounding of the steps.
        "sampling_rate": float(f"{1.0 / step:.12g}"),
        "format": str(format),
    }
    if attrs:
        dataset_attrs.update(attrs)
    return xr.Dataset(
        data_vars,
        coords={"time": ("time", t, {"units": SI_UNITS["time"], "long_name": "time"})},
        attrs=dataset_attrs,
    )
