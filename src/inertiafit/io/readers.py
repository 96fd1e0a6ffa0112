"""Readers that turn a trial file into a Trial dataset, behind one interface.

Every reader is a function registered under a format name::

    @register_reader("myformat")
    def read_myformat(path, *, columns=None, units=None, calibration=None, my_option=1):
        ...
        return make_trial(time, angle, velocity, torque, source=str(path), format="myformat")

and :func:`read_trial` dispatches on ``format``. A reader receives the ``columns``, ``units`` and
``calibration`` mappings of the manifest (or ``None``) and its own keyword options; it converts
every channel to SI once (with :mod:`inertiafit.io.units`) and builds the Trial with
:func:`~inertiafit.io.trial.make_trial`. Formats shipped: ``csv``, ``biodex``, ``humac`` and
``analog`` (see ``docs/formats.md``; their layouts follow ``DOMAIN.md``).
"""

from __future__ import annotations

import csv
import inspect
import math
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.trial import make_trial
from inertiafit.io.units import ACCEPTED, QUANTITIES, canonical_unit, to_si

Reader = Callable[..., xr.Dataset]

_READERS: dict[str, Reader] = {}
_COMMON = ("path", "columns", "units", "calibration")

#: Units assumed by the generic ``csv`` and ``analog`` readers when the manifest gives none.
DEFAULT_UNITS = {"time": "s", "angle": "deg", "velocity": "deg/s", "torque": "N*m"}
#: Keys of one channel's entry in ``calibration``.
CALIBRATION_KEYS = ("scale", "offset", "unit")


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
        missing = [p for p in _COMMON if p not in params]
        if missing:
            raise TypeError(f"reader {func.__name__} lacks parameters {missing}")
        _READERS[name] = func
        return func

    return decorator


def available_formats() -> tuple[str, ...]:
    """Return the names of the registered trial formats."""
    return tuple(_READERS)


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
    return tuple(p for p in inspect.signature(func).parameters if p not in _COMMON)


def _get_reader(format: object, *, where: str) -> Reader:
    if not isinstance(format, str) or format not in _READERS:
        raise InputError(
            f"{where}: unknown trial format {format!r} (formats: {', '.join(_READERS)})"
        )
    return _READERS[format]


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


def check_columns(columns: object, *, where: str) -> dict[str, str]:
    """Check a ``columns`` mapping (channel -> file column name) and return it as a dict.

    Raises
    ------
    InputError
        If it is not a mapping of known channels to strings.
    """
    if columns is None:
        return {}
    if not isinstance(columns, Mapping):
        raise InputError(f"{where}: expected a table of channel = column name, got {columns!r}")
    for key, value in columns.items():
        if key not in QUANTITIES:
            raise InputError(f"{where}.{key}: unknown channel (channels: {', '.join(QUANTITIES)})")
        if not isinstance(value, str) or not value.strip():
            raise InputError(f"{where}.{key}: expected a column name (a string), got {value!r}")
    return dict(columns)


def check_units(units: object, *, where: str) -> dict[str, str]:
    """Check a ``units`` mapping (channel -> unit) and return it with canonical spellings.

    Raises
    ------
    InputError
        If a channel is unknown or a unit is not accepted.
    """
    if units is None:
        return {}
    if not isinstance(units, Mapping):
        raise InputError(f"{where}: expected a table of channel = unit, got {units!r}")
    out = {}
    for key, value in units.items():
        if key not in QUANTITIES:
            raise InputError(f"{where}.{key}: unknown channel (channels: {', '.join(QUANTITIES)})")
        out[key] = canonical_unit(key, value, where=f"{where}.{key}")
    return out


def check_calibration(
    calibration: object, *, where: str
) -> dict[str, tuple[float, float, str | None]]:
    """Check an ``analog`` calibration table and return ``{channel: (scale, offset, unit)}``.

    Parameters
    ----------
    calibration : mapping
        ``{channel: {"scale": float, "offset": float = 0, "unit": str = None}}`` for channels
        ``angle``, ``velocity``, ``torque``.
    where : str
        ``"<file>: <key path>"`` for error messages.

    Returns
    -------
    dict
        Channel -> ``(scale, offset, canonical unit or None)``.

    Raises
    ------
    InputError
        If the table, a channel or a key is malformed; a scale must be finite and non-zero.
    """
    if calibration is None:
        return {}
    if not isinstance(calibration, Mapping):
        raise InputError(f"{where}: expected a table of channel = {{ scale, offset, unit }}")
    out: dict[str, tuple[float, float, str | None]] = {}
    for channel, entry in calibration.items():
        here = f"{where}.{channel}"
        if channel not in QUANTITIES[1:]:
            raise InputError(f"{here}: unknown channel (channels: angle, velocity, torque)")
        if not isinstance(entry, Mapping):
            raise InputError(f"{here}: expected a table {{ scale = ..., offset = ..., unit }}")
        bad = [k for k in entry if k not in CALIBRATION_KEYS]
        if bad:
            raise InputError(
                f"{here}.{bad[0]}: unknown key (allowed: {', '.join(CALIBRATION_KEYS)})"
            )
        if "scale" not in entry:
            raise InputError(f"{here}.scale: missing (value = scale x volts + offset)")
        scale = _number(entry["scale"], where=f"{here}.scale")
        if scale == 0.0:
            raise InputError(f"{here}.scale: must be non-zero, got 0")
        offset = _number(entry.get("offset", 0.0), where=f"{here}.offset")
        unit = entry.get("unit")
        if unit is not None:
            unit = canonical_unit(channel, unit, where=f"{here}.unit")
        out[channel] = (scale, offset, unit)
    return out


def _number(value: object, *, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def _no_calibration(path: Path, calibration: object, format: str) -> None:
    if calibration:
        raise InputError(
            f"{path}: calibration is only used by format 'analog' (this trial's format is "
            f"'{format}'); remove it or set format = \"analog\""
        )


def _resolve_units(
    path: Path,
    *,
    declared: Mapping[str, str | None],
    given: Mapping[str, str],
    defaults: Mapping[str, str],
    said_by: str,
) -> dict[str, str]:
    """Units per channel: what the file declares, else what the user gave, else the default.

    A user's unit that contradicts the file's is an error rather than a silent override: a
    manifest-wide default must never rescale a vendor file that states its own unit.
    """
    out = {}
    for q in QUANTITIES:
        file_unit = declared.get(q)
        user_unit = given.get(q)
        if user_unit is not None:
            user_unit = canonical_unit(q, user_unit, where=f"{path}: units.{q}")
        if file_unit is not None:
            file_unit = canonical_unit(q, file_unit, where=f"{path}: {said_by}")
            if user_unit is not None and user_unit != file_unit:
                raise InputError(
                    f"{path}: units.{q} = {user_unit!r} contradicts the file, whose {said_by} "
                    f"says {file_unit!r}; remove units.{q} or correct the file"
                )
            out[q] = file_unit
        else:
            out[q] = user_unit if user_unit is not None else defaults[q]
    return out


# --------------------------------------------------------------------------------------------
# Delimited text through pandas (csv, analog, humac)


def _load_table(
    path: Path,
    wanted: Mapping[str, str],
    *,
    delimiter: str = ",",
    decimal: str = ".",
    hint: str = "columns",
) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.int64]]:
    """Read the named columns of a delimited file with a header row as float arrays.

    Returns the arrays keyed like ``wanted`` and the file line number of every row (the
    header is line 1). Blank lines at the end are dropped; any other blank or non-numeric
    cell is an error naming its line and column.
    """
    try:
        frame = pd.read_csv(
            path,
            sep=delimiter,
            decimal=decimal,
            skipinitialspace=True,
            skip_blank_lines=False,
            encoding="utf-8-sig",
            low_memory=False,
        )
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: file is empty (expected a header row and data)") from None
    except pd.errors.ParserError as err:
        detail = " ".join(str(err).split())
        raise InputError(f"{path}: cannot be read as delimited text: {detail}") from None
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not a UTF-8 text file ({err.reason})") from None
    present = [str(c).strip() for c in frame.columns]
    for key, name in wanted.items():
        if name not in present:
            listed = ", ".join(present)
            raise InputError(
                f"{path}: column {name!r} not found (columns are: {listed}); "
                f"set {hint}.{key} in the manifest"
            )
        if present.count(name) > 1:
            raise InputError(
                f"{path}: column {name!r} appears {present.count(name)} times in the header; "
                "each channel needs one column"
            )
    # Column by column on numpy arrays: selecting, masking and converting a DataFrame costs
    # half as much again as parsing the file.
    columns = {name: frame.iloc[:, present.index(name)] for name in wanted.values()}
    numeric = {
        name: not pd.api.types.is_bool_dtype(series) and pd.api.types.is_numeric_dtype(series)
        for name, series in columns.items()
    }
    values = {
        name: series.to_numpy(dtype=np.float64, na_value=np.nan)
        for name, series in columns.items()
        if numeric[name]
    }
    # Trailing blank lines come back as all-empty rows; only those are harmless.
    empty = np.logical_and.reduce(
        [
            np.isnan(values[name]) if numeric[name] else series.isna().to_numpy()
            for name, series in columns.items()
        ]
    )
    filled = np.flatnonzero(~empty)
    n = int(filled[-1]) + 1 if filled.size else 0
    lines = np.arange(n, dtype=np.int64) + 2
    out = {}
    for key, name in wanted.items():
        if numeric[name]:
            out[key] = values[name][:n]
            continue
        series = columns[name].iloc[:n]
        converted = pd.to_numeric(series, errors="coerce")
        text = series.astype("string").str.strip()
        bad = (converted.isna() & text.notna() & (text != "")).to_numpy()
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                f"{path}: line {lines[i]}, column {name!r}: {text.iloc[i]!r} is not a number"
            )
        out[key] = converted.to_numpy(dtype=np.float64, na_value=np.nan)
    return out, lines


@register_reader("csv")
def read_csv(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    delimiter: str = ",",
    decimal: str = ".",
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
    _no_calibration(path, calibration, "csv")
    names = {q: q for q in QUANTITIES} | dict(columns or {})
    unit_of = DEFAULT_UNITS | dict(units or {})
    values, lines = _load_table(path, names, delimiter=delimiter, decimal=decimal)
    si = [to_si(values[q], q, unit_of[q], where=f"{path}: units.{q}") for q in QUANTITIES]
    return make_trial(*si, source=str(path), format="csv", columns=names, lines=lines)


@register_reader("analog")
def read_analog(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    delimiter: str = ",",
    decimal: str = ".",
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
        As for :func:`read_csv`.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "analog"``.

    Raises
    ------
    InputError
        A channel without calibration, a malformed calibration, and every problem
        :func:`read_csv` reports.
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
        user_unit = (units or {}).get(channel)
        if cal_unit is not None and user_unit is not None and cal_unit != user_unit:
            raise InputError(
                f"{path}: units.{channel} = {user_unit!r} contradicts "
                f"calibration.{channel}.unit = {cal_unit!r}; give the unit once"
            )
        unit_of[channel] = cal_unit or user_unit or DEFAULT_UNITS[channel]
    names = {q: q for q in QUANTITIES} | dict(columns or {})
    volts, lines = _load_table(path, names, delimiter=delimiter, decimal=decimal)
    si = [to_si(volts["time"], "time", unit_of["time"], where=f"{path}: units.time")]
    for channel in QUANTITIES[1:]:
        scale, offset, _ = cal[channel]
        where = f"{path}: calibration.{channel}.unit"
        si.append(to_si(scale * volts[channel] + offset, channel, unit_of[channel], where=where))
    return make_trial(*si, source=str(path), format="analog", columns=names, lines=lines)


# --------------------------------------------------------------------------------------------
# Cybex / HUMAC NORM CSV

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
        ``segment`` out of range, and every problem :func:`read_csv` reports.
    """
    _no_calibration(path, calibration, "humac")
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
    unit_of = _resolve_units(
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
    values, lines = _load_table(path, wanted)
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


# --------------------------------------------------------------------------------------------
# Biodex System 3/4 raw text export

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
    _no_calibration(path, calibration, "biodex")
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
    unit_of = _resolve_units(
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
