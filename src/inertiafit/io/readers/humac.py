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
from inertiafit.io.readers.validation import (
    header_listing,
    reject_calibration,
    resolve_units,
)
from inertiafit.io.trial import magnitude_evidence, make_trial
from inertiafit.io.units import ACCEPTED, QUANTITIES, canonical_unit, to_si

__all__ = [
    "HUMAC_CLOSING",
    "HUMAC_END_OF_SET",
    "HUMAC_NOT_MEASURED",
    "HUMAC_SAMPLE",
    "HUMAC_STATUS",
    "read_humac",
]

_HUMAC_NAMES = {
    "time": ("time",),
    "angle": ("position", "angle"),
    "velocity": ("speed", "velocity"),
    "torque": ("torque",),
}
_HEADER_CELL = re.compile(r"^\s*(?P<name>[^()]*?)\s*(?:\((?P<unit>[^()]*)\))?\s*$")
#: Status of the closing row every export ends with: position, torque and speed all 0 at the
#: next time step. Not a sample.
HUMAC_CLOSING = 0
#: Status of an ordinary sample.
HUMAC_SAMPLE = 1
#: Status at the ends of the range (braking) and at rest before the first move. On some
#: installations its torque is written as exactly 0 (not measured), on others it is measured:
#: a run of Status-5 rows is "not measured" only when all its torques are exactly 0.
HUMAC_NOT_MEASURED = 5
#: Status of the end-of-set row, which repeats the previous sample 10 ms later. Not a sample;
#: a fatigue or isometric export has one after every contraction, each a separate recording.
HUMAC_END_OF_SET = (11, 15)
#: What a row of each known Status is (others are read as samples, and flagged).
HUMAC_STATUS = {
    HUMAC_CLOSING: "closing row",
    HUMAC_SAMPLE: "sample",
    HUMAC_NOT_MEASURED: "sample; torque not measured where a whole run writes it as 0",
    **dict.fromkeys(HUMAC_END_OF_SET, "end of set"),
}

# What each row is, once its Status (and, for Status 5, its run's torque) is known.
_SAMPLE, _NOT_MEASURED, _END_OF_SET, _CLOSING = range(4)
_BREAK_WORDS = {
    _NOT_MEASURED: "torque not measured (Status 5, written as 0)",
    _END_OF_SET: "end of set (Status 11 or 15)",
    _CLOSING: "Status 0",
}


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Half-open index ranges ``(start, stop)`` of the True runs in ``mask``."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(
        zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True)
    )


def _line_ranges(lines: NDArray[np.int64], runs: list[tuple[int, int]], most: int = 4) -> str:
    parts = [f"{lines[a]}" if b - a == 1 else f"{lines[a]}-{lines[b - 1]}" for a, b in runs[:most]]
    return ", ".join(parts) + (", ..." if len(runs) > most else "")


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
    quoted. The ``Status`` column says what each row is (:data:`HUMAC_STATUS`):

    - the closing row (Status 0, all zeros) and end-of-set rows (Status 11 or 15, a repeat of
      the previous sample) are not samples;
    - a run of Status-5 rows whose torque is exactly 0 throughout was not measured; a run with
      any other torque was (it is kept);
    - the rows left are samples. Rows that are not samples before the first sample and after
      the last are dropped; between samples they cut the file into stretches (strokes cut by
      unmeasured braking, or separate sets), and ``segment`` picks one of them.

    The torque of a HUMAC export is a magnitude (never negative): the trial records
    ``torque_kind = "magnitude"``, with the whole file's evidence, and the manifest's
    ``torque_sign`` must say how to sign it (``"motion"`` for a fast trial).

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
        Keep only the ``segment``-th (1-based) stretch of samples.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "humac"``.

    Raises
    ------
    InputError
        A missing column, an unknown unit in the header, a Status that is not an integer, no
        sample at all, several stretches and no ``segment``, a ``segment`` out of range, and
        every problem :func:`~inertiafit.io.trial.make_trial` reports.
    """
    reject_calibration(path, calibration, "humac")
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            header = next(csv.reader(handle), [])
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file ({err.reason})") from None
    except csv.Error as err:
        raise InputError(f"{path}: cannot be read as CSV ({err})") from None
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
            known = [
                name
                for k in QUANTITIES
                for name in ((columns[k],) if columns and k in columns else _HUMAC_NAMES[k])
            ]
            raise InputError(
                f"{path}: column {expected!r} not found ({header_listing(cells, known, [n for n, _ in parsed])}); "
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
    if segment is not None and (isinstance(segment, bool) or not isinstance(segment, int)):
        raise InputError(f"{path}: option segment must be an integer, got {segment!r}")
    values, lines = load_table(path, wanted)
    flags: list[str] = []
    kind = _row_kinds(path, values, lines, wanted, flags)
    si = {
        q: to_si(values[q], q, unit_of[q], where=f"{path}: header {wanted[q]!r}")
        for q in QUANTITIES
    }
    evidence = _magnitude(si, kind)
    stretches = _runs(kind == _SAMPLE)
    if not stretches:
        raise InputError(
            f"{path}: no row is a measured sample (Status 5 with torque written as 0 is not "
            "measured; Status 11, 15 and 0 end a set or the file)"
        )
    if segment is not None:
        if not 1 <= segment <= len(stretches):
            raise InputError(
                f"{path}: option segment = {segment} but the file has {len(stretches)} "
                "stretch(es) of samples"
            )
        start, stop = stretches[segment - 1]
    elif len(stretches) > 1:
        raise InputError(_stretches_message(path, kind, lines, si["time"], stretches))
    else:
        start, stop = stretches[0]
    keep = slice(start, stop)
    return make_trial(
        *(si[q][keep] for q in QUANTITIES),
        source=str(path),
        format="humac",
        columns=wanted,
        lines=lines[keep],
        units=unit_of,
        flags=flags,
        torque_magnitude=evidence,
    )


def _row_kinds(
    path: Path,
    values: dict[str, NDArray[np.float64]],
    lines: NDArray[np.int64],
    wanted: Mapping[str, str],
    flags: list[str],
) -> NDArray[np.int8]:
    """What each row is (``_SAMPLE``, ...), from its Status; unknown codes add a flag."""
    n = lines.size
    kind = np.full(n, _SAMPLE, dtype=np.int8)
    torque = values["torque"]
    code = values.pop("status", None)
    if code is None:
        # No Status column: the closing row is recognised by its zeros alone (after a sample
        # that is not at 0 degrees).
        zeros = n >= 2 and values["angle"][-1] == values["velocity"][-1] == torque[-1] == 0
        if zeros and values["angle"][-2] != 0:
            kind[-1] = _CLOSING
        return kind
    bad = ~np.isfinite(code) | (code != np.round(code))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{path}: line {lines[i]}, column {wanted['status']!r}: {code[i]:g} is not a "
            "status code (an integer)"
        )
    kind[code == HUMAC_CLOSING] = _CLOSING
    kind[np.isin(code, HUMAC_END_OF_SET)] = _END_OF_SET
    for a, b in _runs(code == HUMAC_NOT_MEASURED):
        if np.all(torque[a:b] == 0):
            kind[a:b] = _NOT_MEASURED
    unknown = ~np.isin(code, list(HUMAC_STATUS))
    if unknown.any():
        listed = ", ".join(f"{c:g}" for c in np.unique(code[unknown]))
        flags.append(
            f"Status {listed} at lines {_line_ranges(lines, _runs(unknown))}: not a code this "
            "reader knows (0, 1, 5, 11, 15); read as samples"
        )
    return kind


def _magnitude(si: Mapping[str, NDArray[np.float64]], kind: NDArray[np.int8]) -> str | None:
    """The whole file's evidence that its torque is a magnitude, or None if it is signed."""
    rows = (kind == _SAMPLE) | (kind == _NOT_MEASURED)
    torque = np.where(kind == _SAMPLE, si["torque"], np.nan)[rows]
    measured = torque[np.isfinite(torque)]
    if measured.size == 0 or float(measured.min()) < 0:
        return None
    time = si["time"][rows]
    steps = np.diff(time)
    rate = 1.0 / float(np.median(steps)) if steps.size and np.median(steps) > 0 else 100.0
    found = magnitude_evidence(si["angle"][rows], torque, rate)
    return found or f"never negative in the {measured.size} samples of the file"


def _stretches_message(
    path: Path,
    kind: NDArray[np.int8],
    lines: NDArray[np.int64],
    time: NDArray[np.float64],
    stretches: list[tuple[int, int]],
) -> str:
    inside = np.zeros(kind.size, dtype=bool)
    inside[stretches[0][0] : stretches[-1][1]] = True
    reasons = []
    for what, words in _BREAK_WORDS.items():
        runs = _runs(inside & (kind == what))
        if runs:
            reasons.append(f"{words} at lines {_line_ranges(lines, runs)}")
    listed = ", ".join(
        f"{k} = lines {lines[a]}-{lines[b - 1]} ({time[a]:g}-{time[b - 1]:g} s)"
        for k, (a, b) in enumerate(stretches[:4], start=1)
    )
    more = ", ..." if len(stretches) > 4 else ""
    return (
        f"{path}: {len(stretches)} separate stretches of samples, cut by "
        f"{'; '.join(reasons)}; a trial is one stretch: pick it with option segment "
        f"({listed}{more})"
    )


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
