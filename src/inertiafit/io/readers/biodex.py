"""The ``biodex`` format: a Biodex System 3/4 raw text export (whitespace-delimited)."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import register_reader
from inertiafit.io.readers.validation import reject_calibration, resolve_units
from inertiafit.io.trial import make_trial
from inertiafit.io.units import QUANTITIES, canonical_unit, to_si

__all__ = ["read_biodex"]

_BIODEX_DEFAULT = {"time": "MSEC", "angle": "POSITION", "velocity": "VELOCITY", "torque": "TORQUE"}
#: Column order of the variant with 6 header lines and no column names.
_BIODEX_SIX = ("MSEC", "TORQUE", "POSITION", "POS_ANAT", "VELOCITY")
_BIODEX_TORQUE_SETTING = {"english": "ft*lbf", "metric": "N*m"}
_META_SPLIT = re.compile(r"\s*:\s*|\t+|\s{2,}")


def _read_text(path: Path) -> list[str]:
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        # Windows exports write the degree sign and similar in cp1252; latin-1 never fails.
        text = raw.decode("latin-1")
    return text.splitlines()


def _biodex_torque_unit(path: Path, metadata: list[str]) -> tuple[str | None, str]:
    """Torque unit stated in the metadata block, and the line that stated it."""
    for number, line in enumerate(metadata, start=1):
        parts = _META_SPLIT.split(line.strip(), maxsplit=1)
        if len(parts) != 2:
            continue
        key, value = parts[0].strip().lower(), parts[1].strip()
        if "unit" not in key or ("torque" not in key and key not in ("unit", "units")):
            continue
        where = f"{path}: line {number} ({line.strip()!r})"
        setting = _BIODEX_TORQUE_SETTING.get(value.lower())
        unit = setting or canonical_unit("torque", value, where=where)
        return unit, f"metadata line {number}"
    return None, "metadata"


@register_reader("biodex")
def read_biodex(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    anatomical: bool = False,
    set: int | None = None,
    rep: int | None = None,
) -> xr.Dataset:
    """Read a Biodex System 3/4 raw text export (whitespace-delimited, 100 Hz).

    Layout: a metadata block of ``key: value`` lines, then the column line
    ``Set Rep mSec TORQUE POSITION POS_ANAT VELOCITY``, then data. Time is in ms, position in
    device degrees (``POS_ANAT`` in anatomical degrees), velocity in deg/s, torque in N m or
    ft-lb: a metadata line such as ``Torque Units: ft-lbs`` or ``Units: English`` says which
    (without one, ``units.torque`` or N m). Also read: the variant with 6 header lines and
    no column line, whose columns are time (ms), torque, position, anatomical position,
    velocity.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        Column name per channel (default ``mSec``, ``POSITION``, ``VELOCITY``, ``TORQUE``),
        case-insensitive.
    units : mapping of str to str, optional
        Used where the file is silent (torque without a unit line); contradicting the file is
        an error.
    calibration : None
        Not used by this format.
    anatomical : bool, optional
        Use ``POS_ANAT`` (anatomical degrees) as the angle instead of ``POSITION``.
    set, rep : int, optional
        Keep only the rows of this set and/or repetition.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "biodex"``, ``attrs["angle_column"]`` the column used.

    Raises
    ------
    InputError
        No column line and not the 6-line variant, a missing column, a non-numeric value
        (line and column named), an unknown torque unit in the metadata, a set/rep absent
        from the file, and every check of :func:`~inertiafit.io.trial.make_trial`.
    """
    reject_calibration(path, calibration, "biodex")
    lines = _read_text(path)
    header_at = next(
        (
            i
            for i, line in enumerate(lines)
            if {"MSEC", "TORQUE"} <= {t.upper() for t in line.split()}
        ),
        None,
    )
    if header_at is not None:
        names = [t.upper() for t in lines[header_at].split()]
        metadata = lines[:header_at]
        first_data = header_at + 1
    else:
        names = list(_BIODEX_SIX)
        metadata = lines[:6]
        first_data = 6
        probe = next((ln for ln in lines[6:] if ln.strip()), "")
        if len(probe.split()) < len(names) or not _all_numbers(probe.split()[: len(names)]):
            raise InputError(
                f"{path}: no column line 'Set Rep mSec TORQUE POSITION POS_ANAT VELOCITY' "
                "found, and line 7 is not 5 numbers (the 6-header-line variant); is this a "
                "Biodex raw export?"
            )

    wanted = dict(_BIODEX_DEFAULT)
    if anatomical:
        wanted["angle"] = "POS_ANAT"
    wanted |= {q: c.strip().upper() for q, c in (columns or {}).items()}
    index = {}
    for q, name in wanted.items():
        if name not in names:
            raise InputError(
                f"{path}: column {name!r} not found (columns are: {' '.join(names)}); "
                f"set columns.{q} in the manifest"
            )
        index[q] = names.index(name)
    filters = {"SET": set, "REP": rep}
    for key, wanted_value in filters.items():
        given: object = wanted_value  # a manifest can give anything
        whole = isinstance(given, int) and not isinstance(given, bool) and given >= 0
        if given is not None and not whole:
            raise InputError(
                f"{path}: options.{key.lower()}: expected a whole number (the "
                f"{key.title()} to keep), got {wanted_value!r}"
            )
        if wanted_value is not None and key not in names:
            raise InputError(
                f"{path}: option {key.lower()} = {wanted_value} but the file has no "
                f"{key.title()} column"
            )
        if wanted_value is not None:
            index[key] = names.index(key)

    table, line_numbers = _parse_rows(path, lines, first_data, index, names)
    keep = np.ones(line_numbers.size, dtype=bool)
    for key, wanted_value in filters.items():
        if wanted_value is not None:
            keep &= table[key] == wanted_value
            if not keep.any():
                present = ", ".join(f"{v:g}" for v in np.unique(table[key]))
                raise InputError(
                    f"{path}: no rows with {key.title()} = {wanted_value} "
                    f"({key.title()} values in the file: {present})"
                )

    torque_unit, said_by = _biodex_torque_unit(path, metadata)
    unit_of = resolve_units(
        path,
        declared={"time": "ms", "angle": "deg", "velocity": "deg/s", "torque": torque_unit},
        given=units or {},
        defaults={"torque": "N*m"},
        said_by=said_by,
    )
    si = [to_si(table[q][keep], q, unit_of[q], where=f"{path}: units.{q}") for q in QUANTITIES]
    return make_trial(
        *si,
        source=str(path),
        format="biodex",
        columns=wanted,
        lines=line_numbers[keep],
        attrs={"angle_column": wanted["angle"]},
    )


def _all_numbers(tokens: list[str]) -> bool:
    try:
        [float(t) for t in tokens]
    except ValueError:
        return False
    return True


def _parse_rows(
    path: Path, lines: list[str], first: int, index: Mapping[str, int], names: list[str]
) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.int64]]:
    """Parse whitespace-separated data rows; only the columns in ``index`` are converted."""
    need = max(index.values()) + 1
    columns: dict[str, list[float]] = {key: [] for key in index}
    numbers: list[int] = []
    for number, line in enumerate(lines[first:], start=first + 1):
        tokens = line.split()
        if not tokens:
            continue
        if len(tokens) < need:
            raise InputError(
                f"{path}: line {number} has {len(tokens)} fields, expected at least {need} "
                f"({' '.join(names[:need])})"
            )
        for key, i in index.items():
            try:
                columns[key].append(float(tokens[i]))
            except ValueError:
                raise InputError(
                    f"{path}: line {number}, column {names[i]!r}: {tokens[i]!r} is not a number"
                ) from None
        numbers.append(number)
    if not numbers:
        raise InputError(f"{path}: no data rows after the header")
    return (
        {key: np.asarray(v, dtype=np.float64) for key, v in columns.items()},
        np.asarray(numbers, dtype=np.int64),
    )
