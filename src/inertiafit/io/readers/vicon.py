"""The ``vicon`` format: the "Devices" section of a Vicon Nexus CSV export (e.g. a Con-Trex).

Vicon Nexus writes the devices it recorded (a dynamometer's angle, velocity and torque next to
EMG channels) as a CSV with a preamble and no time column::

    (an empty line)
    Devices
    1500
    ,,Myon - Voltage,,...,Contrex - Angle,Contrex - Angular Velocity,Contrex - Force,
    Frame,Sub Frame,LTibA1,...,Angle,Angular velocity,Torque
    ,,V,...,deg,deg/s,N
    1,0,3.6e-05,...,30.9055,-0.293012,15.4029
    ...

Line ends are usually CRLF. The rate line is the device rate in Hz; ``Frame`` counts the
capture's frames from 1 and ``Sub Frame`` the device samples within a frame from 0. The
Con-Trex torque is labelled ``N`` although its values are a moment in N m (see
``docs/devices/contrex-vicon.md``).
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.validation import (
    reject_calibration,
    resolve_emg_unit,
    resolve_units,
)
from inertiafit.io.trial import make_trial
from inertiafit.io.units import EMG_UNITS, QUANTITIES, to_si

__all__ = ["VICON_DEFAULT_COLUMNS", "read_vicon"]

#: Column names used when ``columns`` does not name a channel (a Con-Trex as Nexus names it).
VICON_DEFAULT_COLUMNS = {"angle": "Angle", "velocity": "Angular velocity", "torque": "Torque"}
#: The units-row spelling of a torque column that is really N m (Nexus labels the Con-Trex
#: moment "N"); read as N m by this format only.
_MISLABELLED_TORQUE = "N"


@register_reader("vicon")
def read_vicon(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    emg: Sequence[str] | None = None,
    emg_unit: str | None = None,
) -> xr.Dataset:
    """Read the "Devices" section of a Vicon Nexus CSV export.

    The section is the line ``Devices``, the device rate (Hz), a row of device names, a row of
    column names (``Frame``, ``Sub Frame``, then one per device channel), a row of units, then
    one row per device sample, up to an empty line or the end of the file. Time is
    ``t = (Frame - 1) / frame_rate + Sub Frame / rate`` s, with ``frame_rate = rate / n`` and
    ``n`` the number of sub frames per frame (one more than the largest ``Sub Frame``), so
    ``t`` is on the capture's own time line.

    Parameters
    ----------
    path : Path
        The file (UTF-8; CRLF or LF line ends).
    columns : mapping of str to str, optional
        Column name per channel, matched against the column-name row (exactly, else ignoring
        case); default ``Angle``, ``Angular velocity``, ``Torque``. ``time`` is not a column.
    units : mapping of str to str, optional
        Used for a channel whose units cell is empty; contradicting the file is an error. A
        torque column labelled ``N`` is read as N m (the Con-Trex moment is labelled so).
    calibration : None
        Not used by this format.
    emg : sequence of str, optional
        EMG columns (``LTibA1`` ...), matched as the channels are; read into the Trial's
        ``emg`` (V) at the device rate (1500 Hz for a Con-Trex with a Myon), like every device
        column.
    emg_unit : str, optional
        ``V``, ``mV`` or ``µV`` for EMG columns whose units cell is empty (default V);
        contradicting the units row is an error.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "vicon"``; ``attrs["torque_unit_in_file"]`` the units
        cell of the torque column as written (``"N"`` for a Con-Trex).

    Raises
    ------
    InputError
        No ``Devices`` section, a bad rate line, a missing or repeated column, a missing
        ``Frame`` or ``Sub Frame`` column, a non-numeric cell (line and column named), an empty
        line inside the data, an unknown unit, and every check of
        :func:`~inertiafit.io.trial.make_trial`.
    """
    reject_calibration(path, calibration, "vicon")
    if columns and "time" in columns:
        raise InputError(
            f"{path}: columns.time: a Vicon devices export has no time column (time comes from "
            "Frame and Sub Frame); remove columns.time"
        )
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file ({err.reason})") from None
    except OSError as err:
        raise InputError(f"{path}: cannot be opened ({err.strerror or err})") from None
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if _cells(line)[0].strip() == "Devices"), None)
    if start is None:
        raise InputError(
            f"{path}: no 'Devices' line; a Vicon Nexus devices export has an empty line, "
            "'Devices', the rate, then the device, column and unit rows"
        )
    if len(lines) < start + 5:
        raise InputError(
            f"{path}: the 'Devices' section (line {start + 1}) ends before its rate, device, "
            "column and unit rows (the file is cut short?)"
        )
    rate = _rate(path, lines[start + 1], start + 2)
    names = [c.strip() for c in _cells(lines[start + 3])]
    unit_cells = [c.strip() for c in _cells(lines[start + 4])]
    index = {key: _column(path, names, name, key, start + 4) for key, name in _wanted(columns)}
    muscles = tuple(emg or ())
    for muscle in muscles:
        at = _column(path, names, muscle, "emg", start + 4)
        if at in index.values():
            raise InputError(
                f"{path}: emg: column {muscle!r} is a column of the dynamometer or the frame "
                "count, not an EMG one"
            )
        index[f"emg:{muscle}"] = at
    declared = {
        q: (unit_cells[index[q]] if index[q] < len(unit_cells) else "") or None
        for q in QUANTITIES[1:]
    }
    torque_in_file = declared["torque"] or ""
    if declared["torque"] == _MISLABELLED_TORQUE:
        declared["torque"] = "N*m"
    unit_of = resolve_units(
        path,
        declared={"time": "s"} | declared,
        given=units or {},
        defaults={"angle": "deg", "velocity": "deg/s", "torque": "N*m"},
        said_by=f"units row (line {start + 5})",
    )

    emg_units = {
        m: resolve_emg_unit(
            path,
            m,
            unit_cells[index[f"emg:{m}"]] if index[f"emg:{m}"] < len(unit_cells) else None,
            emg_unit,
            said_by=f"units row (line {start + 5})",
        )
        for m in muscles
    }

    first = start + 5
    stop = _section_end(path, lines, first)
    table = _numbers(path, lines[first:stop], first, index, names)
    frame, sub = table.pop("frame"), table.pop("sub")
    signals = {
        names[index[f"emg:{m}"]]: EMG_UNITS[emg_units[m]] * table.pop(f"emg:{m}") for m in muscles
    }
    line_numbers = np.arange(first, first + frame.size, dtype=np.int64) + 1
    time = _time(path, frame, sub, rate, line_numbers)
    si = [time] + [
        to_si(table[q], q, unit_of[q], where=f"{path}: units row, column {names[index[q]]!r}")
        for q in QUANTITIES[1:]
    ]
    return make_trial(
        *si,
        source=str(path),
        format="vicon",
        columns={"time": "Frame/Sub Frame"} | {q: names[index[q]] for q in QUANTITIES[1:]},
        lines=line_numbers,
        attrs={"torque_unit_in_file": torque_in_file},
        emg=signals,
    )


def _cells(line: str) -> list[str]:
    return line.split(",")


def _wanted(columns: Mapping[str, str] | None) -> list[tuple[str, str]]:
    chosen = VICON_DEFAULT_COLUMNS | {q: c for q, c in (columns or {}).items() if q != "time"}
    return [("frame", "Frame"), ("sub", "Sub Frame")] + [(q, chosen[q]) for q in QUANTITIES[1:]]


def _rate(path: Path, line: str, number: int) -> float:
    cell = next((c.strip() for c in _cells(line) if c.strip()), "")
    try:
        rate = float(cell)
    except ValueError:
        rate = math.nan
    if not math.isfinite(rate) or rate <= 0:
        raise InputError(
            f"{path}: line {number}: expected the device rate in Hz after 'Devices', got "
            f"{line.strip()!r}"
        )
    return rate


def _column(path: Path, names: list[str], name: str, key: str, row: int) -> int:
    hits = [i for i, n in enumerate(names) if n == name.strip()]
    if not hits:
        hits = [i for i, n in enumerate(names) if n.lower() == name.strip().lower()]
    where = f"line {row + 1}"
    if not hits:
        if key == "emg":
            hint = "set emg in the manifest"
        elif key in QUANTITIES:
            hint = f"set columns.{key} in the manifest"
        else:
            hint = "is this a devices export?"
        raise InputError(
            f"{path}: column {name!r} not found in the column row ({where}: "
            f"{', '.join(n for n in names if n)}); {hint}"
        )
    if len(hits) > 1:
        raise InputError(
            f"{path}: column {name!r} appears {len(hits)} times in the column row ({where}); "
            "each channel needs one column"
        )
    return hits[0]


def _section_end(path: Path, lines: list[str], first: int) -> int:
    """Index of the first line after the data rows: an empty line, another section or the end.

    An empty line followed by more data rows is a hole in the data, not the section's end.
    """
    for i in range(first, len(lines)):
        if lines[i].strip(", \t"):
            continue
        after = next((ln for ln in lines[i + 1 :] if ln.strip(", \t")), None)
        if after is not None and _is_number(_cells(after)[0]):
            raise InputError(
                f"{path}: line {i + 1} is empty inside the data rows (values missing?)"
            )
        return i
    return len(lines)


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _numbers(
    path: Path, rows: list[str], first: int, index: Mapping[str, int], names: list[str]
) -> dict[str, NDArray[np.float64]]:
    """The wanted columns of the data rows as floats; a non-numeric cell names its line."""
    if not rows:
        return {key: np.empty(0) for key in index}
    counts = np.array([row.count(",") + 1 for row in rows])
    need = max(index.values()) + 1
    bad = (counts != counts[0]) | (counts < need)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{path}: line {first + i + 1} has {counts[i]} comma-separated fields, expected "
            f"{max(counts[0], need)} like the column row; is the file cut short, or not "
            "comma-separated?"
        )
    wanted = sorted(set(index.values()))
    try:
        frame = pd.read_csv(
            io.StringIO("\n".join(rows)),
            header=None,
            usecols=wanted,
            dtype=str,
            keep_default_na=False,
            skip_blank_lines=False,
        )
    except (pd.errors.ParserError, ValueError) as err:
        detail = " ".join(str(err).split())
        raise InputError(f"{path}: the data rows from line {first + 1} on: {detail}") from None
    out = {}
    for key, col in index.items():
        text = frame[col].str.strip()
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=np.float64)
        bad = np.isnan(values) & (text != "").to_numpy() & (text.str.lower() != "nan").to_numpy()
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                f"{path}: line {first + i + 1}, column {names[col]!r}: {text.iloc[i]!r} is "
                "not a number"
            )
        out[key] = values
    return out


def _time(
    path: Path,
    frame: NDArray[np.float64],
    sub: NDArray[np.float64],
    rate: float,
    lines: NDArray[np.int64],
) -> NDArray[np.float64]:
    """``(Frame - 1) / frame_rate + Sub Frame / rate`` with ``frame_rate = rate / n_sub``."""
    for name, values in (("Frame", frame), ("Sub Frame", sub)):
        bad = ~np.isfinite(values) | (values != np.round(values)) | (values < 0)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                f"{path}: line {lines[i]}, column {name!r}: {values[i]:g} is not a whole "
                "number >= 0"
            )
    n_sub = int(sub.max()) + 1 if sub.size else 1
    frame_rate = rate / n_sub
    return (frame - 1) / frame_rate + sub / rate
