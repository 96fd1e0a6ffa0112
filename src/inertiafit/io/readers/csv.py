"""The generic ``csv`` format: a header row, then one row per sample."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.tables import emg_columns
from inertiafit.io.readers.validation import DEFAULT_UNITS, reject_calibration
from inertiafit.io.trial import DERIVED_VELOCITY_WINDOW, make_trial
from inertiafit.io.units import QUANTITIES, to_si

__all__ = ["read_csv"]


@register_reader("csv")
def read_csv(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    delimiter: str = ",",
    decimal: str = ".",
    emg: Sequence[str] | None = None,
    emg_unit: str | None = None,
    derive_velocity: bool | float = False,
) -> xr.Dataset:
    """Read a generic CSV trial: a header row, then one row per sample.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        Column name per channel; default: ``time``, ``angle``, ``velocity``, ``torque``.
    units : mapping of str to str, optional
        Unit per channel; default: time s, angle deg, velocity deg/s, torque N*m.
    calibration : None
        Not used by this format; giving one is an error.
    delimiter : str, optional
        Field separator (default ``","``; ``";"`` for exports with a decimal comma).
    decimal : str, optional
        Decimal mark (default ``"."``).
    emg : sequence of str, optional
        EMG columns, read into the Trial's ``emg`` (V) at the file's own rate.
    emg_unit : str, optional
        Their unit, ``V`` (default), ``mV`` or ``µV``.
    derive_velocity : bool or float, optional
        The file has no velocity column: ``True`` takes the angle's derivative over
        ``DERIVED_VELOCITY_WINDOW`` (0.1 s), a number over that many seconds
        (:func:`~inertiafit.io.trial.derived_velocity`). Default ``False``: a velocity column.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "csv"``.

    Raises
    ------
    InputError
        Missing column (the message lists the file's columns), non-numeric cell, unknown
        unit, and every check of :func:`~inertiafit.io.trial.make_trial`.
    """
    reject_calibration(path, calibration, "csv")
    window = _velocity_window(path, derive_velocity, columns, units)
    names = {q: q for q in QUANTITIES} | dict(columns or {})
    if window is not None:
        del names["velocity"]
    unit_of = DEFAULT_UNITS | dict(units or {})
    values, signals, lines = emg_columns(path, emg, emg_unit, names, delimiter, decimal)
    si = {q: to_si(values[q], q, unit_of[q], where=f"{path}: units.{q}") for q in names}
    return make_trial(
        si["time"],
        si["angle"],
        si.get("velocity"),
        si["torque"],
        source=str(path),
        format="csv",
        columns=names,
        lines=lines,
        emg=signals,
        velocity_window=DERIVED_VELOCITY_WINDOW if window is None else window,
    )


def _velocity_window(
    path: Path, derive: object, columns: Mapping[str, str] | None, units: Mapping[str, str] | None
) -> float | None:
    """The derivative's window (s) of ``derive_velocity``, or ``None`` for a velocity column."""
    if derive is False:
        return None
    if derive is True:
        window = DERIVED_VELOCITY_WINDOW
    elif isinstance(derive, int | float) and not isinstance(derive, bool):
        window = float(derive)
    else:
        raise InputError(
            f"{path}: options.derive_velocity: {derive!r}; expected true, false or a window "
            "in seconds"
        )
    for given, what in ((columns, "columns"), (units, "units")):
        if given and "velocity" in given:
            raise InputError(
                f"{path}: {what}.velocity: the velocity is derived from the angle "
                "(options.derive_velocity); remove one of them"
            )
    return window
