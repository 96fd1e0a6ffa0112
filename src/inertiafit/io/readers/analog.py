"""The ``analog`` format: DAQ voltages in a CSV, calibrated linearly by the manifest."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.tables import emg_columns
from inertiafit.io.readers.validation import DEFAULT_UNITS, calibrated_unit, check_calibration
from inertiafit.io.trial import make_trial
from inertiafit.io.units import QUANTITIES, to_si

__all__ = ["read_analog"]


@register_reader("analog")
def read_analog(
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
    """Read DAQ channels in volts and apply the manifest's linear calibration.

    The file is a CSV with a header: a time column and one voltage column per channel
    (default names ``time``, ``angle``, ``velocity``, ``torque``; map others with
    ``columns``). Each channel becomes ``scale * volts + offset`` in its calibration ``unit``
    (or ``units.<channel>``, or deg, deg/s, N*m), then SI.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        Column name per channel.
    units : mapping of str to str, optional
        ``units.time`` (default s); a channel unit here must agree with its calibration unit.
    calibration : mapping
        ``{"angle": {...}, "velocity": {...}, "torque": {...}}``, each
        ``{"scale": float, "offset": float = 0, "unit": str}``; all three are required.
    delimiter, decimal : str, optional
        As for :func:`~inertiafit.io.readers.csv.read_csv`.
    emg : sequence of str, optional
        EMG columns (not calibrated: the voltage the DAQ recorded), read into the Trial's
        ``emg`` (V) at the file's own rate.
    emg_unit : str, optional
        Their unit, ``V`` (default), ``mV`` or ``µV``.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "analog"``.

    Raises
    ------
    InputError
        A channel without calibration, a malformed calibration, and every problem
        :func:`~inertiafit.io.readers.csv.read_csv` reports.
    """
    cal = check_calibration(calibration, where=f"{path}: calibration")
    for channel in QUANTITIES[1:]:
        if channel not in cal:
            raise InputError(
                f"{path}: calibration.{channel} missing; the analog format needs "
                f"{{ scale, offset, unit }} for each of angle, velocity, torque "
                "(value = scale x volts + offset)"
            )
    unit_of = {"time": (units or {}).get("time", DEFAULT_UNITS["time"])}
    for channel, (_, _, cal_unit) in cal.items():
        unit_of[channel] = calibrated_unit(path, channel, cal_unit, units)
    names = {q: q for q in QUANTITIES} | dict(columns or {})
    volts, signals, lines = emg_columns(path, emg, emg_unit, names, delimiter, decimal)
    si = [to_si(volts["time"], "time", unit_of["time"], where=f"{path}: units.time")]
    for channel in QUANTITIES[1:]:
        scale, offset, _ = cal[channel]
        where = f"{path}: calibration.{channel}.unit"
        si.append(to_si(scale * volts[channel] + offset, channel, unit_of[channel], where=where))
    return make_trial(
        *si, source=str(path), format="analog", columns=names, lines=lines, emg=signals
    )
