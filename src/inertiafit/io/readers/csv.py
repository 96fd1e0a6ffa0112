"""The generic ``csv`` format: a header row, then one row per sample."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.tables import emg_columns
from inertiafit.io.readers.validation import DEFAULT_UNITS, reject_calibration
from inertiafit.io.trial import make_trial
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
    names = {q: q for q in QUANTITIES} | dict(columns or {})
    unit_of = DEFAULT_UNITS | dict(units or {})
    values, signals, lines = emg_columns(path, emg, emg_unit, names, delimiter, decimal)
    si = [to_si(values[q], q, unit_of[q], where=f"{path}: units.{q}") for q in QUANTITIES]
    return make_trial(*si, source=str(path), format="csv", columns=names, lines=lines, emg=signals)
