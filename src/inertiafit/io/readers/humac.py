"""The ``humac`` format: a Cybex / HUMAC NORM CSV export with units in its header cells."""

from __future__ import annotations

import csv
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.tables import load_table
from inertiafit.io.readers.validation import reject_calibration, resolve_units
from inertiafit.io.trial import make_trial
from inertiafit.io.units import ACCEPTED, QUANTITIES, canonical_unit, to_si

__all__ = ["HUMAC_NOT_MEASURED", "read_humac"]

_HUMAC_NAMES = {
    "time": ("time",),
    "angle": ("position", "angle"),
    "velocity": ("speed", "velocity"),
    "torque": ("torque",),
}
_HEADER_CELL = re.compile(r"^\s*(?P<name>[^()]*?)\s*(?:\((?P<unit>[^()]*)\))?\s*$")
#: HUMAC writes a Status of 5 while torque is not measured (it then writes torque as 0).
HUMAC_NOT_MEASURED = 5


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Half-open index ranges ``(start, stop)`` of the True runs in ``mask``."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(
        zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True)
    )


def _line_ranges(lines: NDArray[np.int64], runs: list[tuple[int, int]]) -> str:
    parts = [f"{lines[a]}" if b - a == 1 else f"{lines[a]}-{lines[b - 1]}" for a, b in runs[:5]]
    return ", ".join(parts) + (", ..." if len(runs) > 5 else "")


@register_reader("humac")
def read_humac(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    segment: int | None = None,
) -> xr.Dataset:
    """Read a Cybex / HUMAC NORM CSV export.

    The header is quoted cells such as ``"Time(Seconds)"``, ``"Position(Degrees)"``,
    ``"Torque(Foot-Pounds)"`` or ``"Torque(Newton-Meters)"``, ``"Speed(d/s)"`` or
    ``"Speed(deg/sec)"``; the unit in parentheses is the channel's unit. Any field may be
    quoted. Rows whose ``Status`` is 5 carry a torque of 0 that was *not measured*: such rows
    before the first and after the last measured row are dropped; inside the trial they are a
    gap and an error, unless ``segment`` picks one measured stretch.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        Header name per channel, matched against the text before the parentheses (default
        ``Time``, ``Position``, ``Speed``, ``Torque``) or the whole header cell.
    units : mapping of str to str, optional
        Used only for a channel whose header cell has no unit; contradicting it is an error.
    calibration : None
        Not used by this format.
    segment : int, optional
        Keep only the ``segment``-th (1-based) stretch of rows with torque measured.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "humac"``.

    Raises
    ------
    InputError
        A missing column, an unknown unit in the header, Status-5 rows inside the trial, a
        ``segment`` out of range, and every problem
        :func:`~inertiafit.io.readers.csv.read_csv` reports.
    """
    reject_calibration(path, calibration, "humac")
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            header = next(csv.reader(handle), [])
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file ({err.reason})") from None
    cells = [c.strip() for c in header]
    parsed = []
    for cell in cells:
        match = _HEADER_CELL.match(cell)
        parsed.append((match["name"].lower(), match["unit"]) if match else (cell.lower(), None))
    wanted: dict[str, str] = {}
    declared: dict[str, str | None] = {}
    for q in QUANTITIES:
        targets = (columns[q].strip().lower(),) if columns and q in columns else _HUMAC_NAMES[q]
        found = [
            i
            for i, (name, _) in enumerate(parsed)
            if name in targets or cells[i].lower() in targets
        ]
        if not found:
            expected = columns[q] if columns and q in columns else _HUMAC_NAMES[q][0].title()
            raise InputError(
                f"{path}: column {expected!r} not found (columns are: {', '.join(cells)}); "
                f"set columns.{q} in the manifest"
            )
        wanted[q] = cells[found[0]]
        declared[q] = parsed[found[0]][1]
    status = [cells[i] for i, (name, _) in enumerate(parsed) if name == "status"]
    if status:
        wanted["status"] = status[0]
    unit_of = resolve_units(
        path,
        declared={
            q: _humac_unit(q, u, where=f"{path}: header cell {wanted[q]!r}")
            for q, u in declared.items()
        },
        given=units or {},
        defaults={"time": "s", "angle": "deg", "velocity": "deg/s", "torque": ""},
        said_by="header",
    )
    if not unit_of["torque"]:
        raise InputError(
            f"{path}: column {wanted['torque']!r} states no unit; set units.torque "
            f"({', '.join(ACCEPTED['torque'])})"
        )
    values, lines = load_table(path, wanted)
    keep = np.ones(lines.size, dtype=bool)
    if "status" in values:
        measured = values.pop("status") != HUMAC_NOT_MEASURED
        runs = _runs(measured)
        if not runs:
            raise InputError(
                f"{path}: column {wanted['status']!r} is {HUMAC_NOT_MEASURED} (torque not "
                "measured) on every row"
            )
        if segment is not None:
            if isinstance(segment, bool) or not isinstance(segment, int):
                raise InputError(f"{path}: option segment must be an integer, got {segment!r}")
            if not 1 <= segment <= len(runs):
                raise InputError(
                    f"{path}: option segment = {segment} but the file has {len(runs)} "
                    "measured stretch(es) between Status-5 rows"
                )
            start, stop = runs[segment - 1]
        else:
            start, stop = runs[0][0], runs[-1][1]
            inside = _runs(~measured[start:stop])
            if inside:
                shifted = [(a + start, b + start) for a, b in inside]
                raise InputError(
                    f"{path}: column {wanted['status']!r} is {HUMAC_NOT_MEASURED} (torque not "
                    f"measured, written as 0) at lines {_line_ranges(lines, shifted)} inside "
                    f"the trial, a gap; trim the export or choose one of the {len(runs)} "
                    "measured stretches with option segment"
                )
        keep[:] = False
        keep[start:stop] = True
    si = [
        to_si(values[q][keep], q, unit_of[q], where=f"{path}: header {wanted[q]!r}")
        for q in QUANTITIES
    ]
    return make_trial(*si, source=str(path), format="humac", columns=wanted, lines=lines[keep])


_HUMAC_UNITS = {
    "seconds": "s",
    "milliseconds": "ms",
    "degrees": "deg",
    "radians": "rad",
    "foot-pounds": "ft*lbf",
    "newton-meters": "N*m",
    "newton-metres": "N*m",
    "d/s": "deg/s",
    "deg/sec": "deg/s",
}


def _humac_unit(quantity: str, unit: str | None, *, where: str) -> str | None:
    if unit is None or not unit.strip():
        return None
    unit = _HUMAC_UNITS.get(unit.strip().lower(), unit)
    return canonical_unit(quantity, unit, where=where)
