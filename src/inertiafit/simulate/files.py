"""Hand-written files of a simulated study: a trial's CSV, and values written as TOML.

The simulator writes its files itself, without pandas or a TOML library, so that the same seed
gives the same bytes (the demo's outputs are compared byte for byte). Units are converted from
SI with :func:`inertiafit.io.units.from_si`, the package's one unit table.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from inertiafit.io.units import from_si

__all__ = ["VELOCITY_UNITS", "WRITTEN_UNITS", "check_units", "toml_value", "write_trial_csv"]

#: The units the simulator can write, per channel (the velocity's follows the angle's).
WRITTEN_UNITS = {"angle": ("deg", "rad"), "torque": ("N*m", "ft*lbf"), "time": ("s", "ms")}
#: The velocity unit written with each angle unit.
VELOCITY_UNITS = {"deg": "deg/s", "rad": "rad/s"}


def check_units(*, angle_unit: str, torque_unit: str, time_unit: str) -> None:
    """Check that the simulator can write these units (see :data:`WRITTEN_UNITS`).

    Raises
    ------
    ValueError
        ``"unknown unit ...; expected one of [...]"`` for the first unit not written.
    """
    for unit, allowed in (
        (angle_unit, WRITTEN_UNITS["angle"]),
        (torque_unit, WRITTEN_UNITS["torque"]),
        (time_unit, WRITTEN_UNITS["time"]),
    ):
        if unit not in allowed:
            msg = f"unknown unit {unit!r}; expected one of {sorted(allowed)}"
            raise ValueError(msg)


def toml_value(value: Any) -> str:
    """Write a value as TOML: a bool, number, string, inline table or array of these.

    Floats are written with ``repr`` (round-trip exact); strings as JSON strings, which are
    TOML basic strings for the ASCII names the simulator writes.

    Raises
    ------
    TypeError
        For a value of another type.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for the ASCII names we write
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, Iterable):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    msg = f"cannot write {value!r} to TOML"
    raise TypeError(msg)


def write_trial_csv(
    path: Path,
    trial: xr.Dataset,
    *,
    angle_unit: str,
    torque_unit: str,
    time_unit: str,
    emg: Mapping[str, np.ndarray] | None = None,
) -> None:
    """Write a Trial as the generic CSV format, in the given units.

    Parameters
    ----------
    path : Path
        The file to write (replaced).
    trial : xarray.Dataset
        A Trial in SI units.
    angle_unit, torque_unit, time_unit : str
        Units of the columns, among :data:`WRITTEN_UNITS`; the velocity is written in the
        angle unit per second.

    Notes
    -----
    The header is ``time,angle,velocity,torque``; every value has 10 significant digits
    (``%.10g``).
    """
    where = f"{path}: simulated trial"
    columns = np.column_stack(
        [
            from_si(trial["time"].values, "time", time_unit, where=where),
            from_si(trial["angle"].values, "angle", angle_unit, where=where),
            from_si(trial["velocity"].values, "velocity", VELOCITY_UNITS[angle_unit], where=where),
            from_si(trial["torque"].values, "torque", torque_unit, where=where),
            *(np.asarray(v, dtype=np.float64) for v in (emg or {}).values()),
        ]
    )
    # One %-format over the whole table: the bytes np.savetxt writes with fmt="%.10g", four
    # times faster (savetxt formats row by row from NumPy scalars).
    header = ",".join(["time", "angle", "velocity", "torque", *(emg or {})])
    row = ",".join(["%.10g"] * columns.shape[1]) + "\n"
    body = (row * len(columns)) % tuple(columns.ravel().tolist())
    path.write_text(f"{header}\n{body}", encoding="utf-8", newline="\n")
