"""The ``isomed`` format: an IsoMed 2000 text export (whitespace columns, no header, 200 Hz).

Each line is one sample of 10 whitespace-separated numbers. As read by a public analysis tool
of these exports (omarel-edrissi/Isokinetic-kneeflexion-and-extension-analysis-tool,
``AnalyseQcon.m``, commit e039a03): column 1 is time in ms, column 2 the relative position in
tenths of a degree, column 3 the torque in tenths of a N m, column 4 the velocity in tenths of a
deg/s, column 6 a phase code (which repetition a row belongs to); the other columns are not
described. Because no manual confirms that order, every channel's column can be set by number
in the manifest (``columns = { torque = "3" }``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.validation import reject_calibration
from inertiafit.io.trial import make_trial
from inertiafit.io.units import QUANTITIES, to_si

__all__ = ["ISOMED_COLUMNS", "ISOMED_PHASE_COLUMN", "ISOMED_TENTHS", "read_isomed"]

#: Default 1-based column of each channel.
ISOMED_COLUMNS = {"time": 1, "angle": 2, "torque": 3, "velocity": 4}
#: Default 1-based column of the phase code.
ISOMED_PHASE_COLUMN = 6
#: Angle, torque and velocity are written as integers in tenths of deg, N m and deg/s.
ISOMED_TENTHS = 0.1
#: Units of the channels once the tenths are divided out; ``units`` may say otherwise.
_ISOMED_UNITS = {"time": "ms", "angle": "deg", "velocity": "deg/s", "torque": "N*m"}
#: Number of columns of the export as described; other counts are read but named in messages.
_ISOMED_WIDTH = 10


@register_reader("isomed")
def read_isomed(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    phase: int | None = None,
    phase_column: int = ISOMED_PHASE_COLUMN,
) -> xr.Dataset:
    """Read an IsoMed 2000 text export.

    Every line holds the same number of whitespace-separated numbers (10 in the exports
    described); there is no header. Time is in ms; angle, torque and velocity are in tenths
    (0.1 deg, 0.1 N m, 0.1 deg/s) and are divided by 10. The angle is the device's relative
    position, as written.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        1-based column number per channel, written as a string (``{"torque": "3"}``); default
        time 1, angle 2, torque 3, velocity 4.
    units : mapping of str to str, optional
        Unit per channel after the division by 10; default time ms, angle deg, velocity deg/s,
        torque N*m.
    calibration : None
        Not used by this format.
    phase : int, optional
        Keep only the rows whose phase code is ``phase`` (one repetition).
    phase_column : int, optional
        1-based column of the phase code (default 6); used only with ``phase``.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "isomed"``.

    Raises
    ------
    InputError
        A column number that is not a whole number within the line, lines of different
        lengths (or not whitespace-separated), a non-numeric value (line and column named), a
        ``phase`` absent from the file, and every check of
        :func:`~inertiafit.io.trial.make_trial`.
    """
    reject_calibration(path, calibration, "isomed")
    index = {q: _column_number(path, q, (columns or {}).get(q)) for q in QUANTITIES}
    if phase is not None:
        if not _whole(phase):
            raise InputError(f"{path}: option phase must be an integer, got {phase!r}")
        if not _whole(phase_column) or phase_column < 1:
            raise InputError(
                f"{path}: option phase_column must be a column number >= 1, got {phase_column!r}"
            )
        index["phase"] = phase_column
    table, lines = _parse(path, index)
    keep = np.ones(lines.size, dtype=bool)
    if phase is not None:
        codes = table.pop("phase")
        keep = codes == phase
        if not keep.any():
            present = ", ".join(f"{v:g}" for v in np.unique(codes))
            raise InputError(
                f"{path}: no rows with phase code {phase} in column {phase_column} "
                f"(codes in the file: {present})"
            )
    unit_of = _ISOMED_UNITS | dict(units or {})
    si = []
    for q in QUANTITIES:
        values = table[q][keep] * (1.0 if q == "time" else ISOMED_TENTHS)
        si.append(to_si(values, q, unit_of[q], where=f"{path}: units.{q}"))
    names = {q: f"column {n}" for q, n in index.items() if q in QUANTITIES}
    return make_trial(*si, source=str(path), format="isomed", columns=names, lines=lines[keep])


def _whole(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _column_number(path: Path, channel: str, given: object) -> int:
    if given is None:
        return ISOMED_COLUMNS[channel]
    text = str(given).strip()
    if not text.isdigit() or int(text) < 1:
        raise InputError(
            f"{path}: columns.{channel} = {given!r}: an IsoMed export has no header; give the "
            f"channel's column number (1 to {_ISOMED_WIDTH}) as a string, e.g. "
            f'{channel} = "{ISOMED_COLUMNS[channel]}"'
        )
    return int(text)


def _parse(
    path: Path, index: Mapping[str, int]
) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.int64]]:
    """The wanted columns (1-based numbers in ``index``) of every non-empty line, as floats."""
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file ({err.reason})") from None
    except OSError as err:
        raise InputError(f"{path}: cannot be opened ({err.strerror or err})") from None
    need = max(index.values())
    width = None
    columns: dict[str, list[float]] = {key: [] for key in index}
    numbers: list[int] = []
    for number, line in enumerate(text.splitlines(), start=1):
        tokens = line.split()
        if not tokens:
            continue
        if width is None:
            width = len(tokens)
            if width < need:
                raise InputError(
                    f"{path}: line {number} has {width} whitespace-separated fields, but a "
                    f"column number asks for column {need} (an IsoMed export has "
                    f"{_ISOMED_WIDTH}; is the file whitespace-separated?)"
                )
        elif len(tokens) != width:
            raise InputError(
                f"{path}: line {number} has {len(tokens)} fields, the lines before it "
                f"{width}; every line needs the same columns (cut short?)"
            )
        for key, col in index.items():
            token = tokens[col - 1]
            try:
                columns[key].append(float(token))
            except ValueError:
                raise InputError(
                    f"{path}: line {number}, column {col}: {token!r} is not a number (an "
                    "IsoMed export has no header and only numbers)"
                ) from None
        numbers.append(number)
    values = {key: np.asarray(v, dtype=np.float64) for key, v in columns.items()}
    return values, np.asarray(numbers, dtype=np.int64)
