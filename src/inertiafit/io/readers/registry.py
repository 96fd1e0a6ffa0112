"""The registry of trial readers: one function per format name, and :func:`read_trial`.

A reader is registered with the decorator :func:`register_reader`; :func:`read_trial` checks
the common arguments (:mod:`inertiafit.io.readers.validation`) and dispatches on ``format``.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit.errors import InputError
from inertiafit.io.readers.validation import check_columns, check_units

__all__ = [
    "COMMON_PARAMETERS",
    "READERS",
    "Reader",
    "available_formats",
    "read_trial",
    "reader_options",
    "register_reader",
]

#: A reader: ``reader(path, *, columns, units, calibration, **options) -> Trial``.
Reader = Callable[..., xr.Dataset]

#: The registered readers, format name -> reader; filled by :func:`register_reader`.
READERS: dict[str, Reader] = {}
#: Parameters every reader takes; any others are the reader's own options.
COMMON_PARAMETERS = ("path", "columns", "units", "calibration")


def register_reader(name: str) -> Callable[[Reader], Reader]:
    """Register a reader function under the format ``name`` (a decorator).

    Parameters
    ----------
    name : str
        The format name used by ``read_trial(format=...)`` and the manifest's ``format`` key.

    Returns
    -------
    callable
        A decorator that registers and returns the reader unchanged. The reader must accept
        ``path`` and the keyword arguments ``columns``, ``units`` and ``calibration``; any
        other keyword-only parameters are its options.
    """

    def decorator(func: Reader) -> Reader:
        params = inspect.signature(func).parameters
        missing = [p for p in COMMON_PARAMETERS if p not in params]
        if missing:
            raise TypeError(f"reader {func.__name__} lacks parameters {missing}")
        READERS[name] = func
        return func

    return decorator


def available_formats() -> tuple[str, ...]:
    """Return the names of the registered trial formats."""
    return tuple(READERS)


def reader_options(format: str) -> tuple[str, ...]:
    """Return the option names a format's reader accepts beyond columns/units/calibration.

    Parameters
    ----------
    format : str
        A registered format name.

    Returns
    -------
    tuple of str
        The reader's own keyword options.

    Raises
    ------
    InputError
        If the format is not registered.
    """
    func = _get_reader(format, where="format")
    return tuple(p for p in inspect.signature(func).parameters if p not in COMMON_PARAMETERS)


def _get_reader(format: object, *, where: str) -> Reader:
    if not isinstance(format, str) or format not in READERS:
        raise InputError(
            f"{where}: unknown trial format {format!r} (formats: {', '.join(READERS)})"
        )
    return READERS[format]


def read_trial(
    path: str | Path,
    *,
    format: str = "csv",
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Mapping[str, Any]] | None = None,
    **options: Any,
) -> xr.Dataset:
    """Read one trial file into a Trial dataset in SI units.

    Parameters
    ----------
    path : str or Path
        The trial file.
    format : str, optional
        A registered format: ``"csv"`` (default), ``"biodex"``, ``"humac"``, ``"analog"``, or
        one added with :func:`register_reader`.
    columns : mapping of str to str, optional
        File column name per channel (``time``, ``angle``, ``velocity``, ``torque``); channels
        left out keep the format's default names.
    units : mapping of str to str, optional
        Unit per channel, e.g. ``{"torque": "ft*lbf"}``. Vendor formats take units from the
        file and only use these where the file is silent; a contradiction is an error.
    calibration : mapping, optional
        For ``analog``: per channel ``{"scale": ..., "offset": ..., "unit": ...}`` meaning
        ``value = scale * volts + offset`` in ``unit``.
    **options
        Options of the format's reader (see :func:`reader_options`).

    Returns
    -------
    xarray.Dataset
        The Trial: coordinate ``time`` (s); variables ``angle`` (rad), ``velocity`` (rad/s),
        ``torque`` (N m); attrs ``source``, ``sampling_rate`` (Hz), ``format``.

    Raises
    ------
    InputError
        For an unknown format or option, a missing file, and every problem with the file's
        contents; the one-line message names the file and the field.
    """
    path = Path(path)
    reader = _get_reader(format, where=str(path))
    allowed = reader_options(format)
    unknown = [k for k in options if k not in allowed]
    if unknown:
        listed = ", ".join(allowed) if allowed else "none"
        raise InputError(
            f"{path}: unknown option {unknown[0]!r} for format '{format}' (options: {listed})"
        )
    if not path.is_file():
        raise InputError(f"{path}: trial file not found")
    columns = check_columns(columns, where=f"{path}: columns")
    units = check_units(units, where=f"{path}: units")
    return reader(path, columns=columns, units=units, calibration=calibration, **options)
