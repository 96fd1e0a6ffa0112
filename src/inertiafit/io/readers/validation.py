"""Checks shared by the readers and the manifest, and the choice of each channel's unit.

The ``columns``, ``units`` and ``calibration`` tables are checked here for :func:`read_trial
<inertiafit.io.readers.registry.read_trial>` and for the manifest; :func:`resolve_units`
decides a channel's unit when both the file and the user may state it.

Every problem is one :class:`~inertiafit.errors.InputError` line that starts with ``where``
(``"<file>: <key path>"``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path

from inertiafit._checks import check_finite
from inertiafit.errors import InputError
from inertiafit.io.units import QUANTITIES, canonical_unit, emg_unit

__all__ = [
    "CALIBRATION_KEYS",
    "DEFAULT_UNITS",
    "calibrated_unit",
    "check_calibration",
    "check_channel_table",
    "check_columns",
    "check_emg",
    "check_units",
    "header_listing",
    "reject_calibration",
    "resolve_emg_unit",
    "resolve_units",
]

#: Units assumed by the generic ``csv`` and ``analog`` readers when the manifest gives none.
DEFAULT_UNITS = {"time": "s", "angle": "deg", "velocity": "deg/s", "torque": "N*m"}
#: Keys of one channel's entry in ``calibration``.
CALIBRATION_KEYS = ("scale", "offset", "unit")


def check_channel_table(
    table: object, *, where: str, what: str, convert: Callable[[str, object, str], str]
) -> dict[str, str]:
    """Check a mapping of channel -> string and convert each value (for columns and units).

    The one helper behind :func:`check_columns` and :func:`check_units`.

    Parameters
    ----------
    table : mapping or None
        Keys must be channels (``time``, ``angle``, ``velocity``, ``torque``).
    where : str
        ``"<file>: <key path>"`` for error messages.
    what : str
        What a value is (``"column name"``, ``"unit"``), for the message about a non-table.
    convert : callable
        ``convert(channel, value, where)`` checks one value and returns it, possibly
        rewritten; ``where`` is the value's key path.

    Returns
    -------
    dict of str to str
        Channel -> converted value, in the table's order; ``{}`` for ``None``.

    Raises
    ------
    InputError
        If ``table`` is not a mapping, a key is not a channel, or ``convert`` rejects a value.
    """
    if table is None:
        return {}
    if not isinstance(table, Mapping):
        raise InputError(f"{where}: expected a table of channel = {what}, got {table!r}")
    out = {}
    for key, value in table.items():
        if key not in QUANTITIES:
            raise InputError(f"{where}.{key}: unknown channel (channels: {', '.join(QUANTITIES)})")
        out[key] = convert(key, value, f"{where}.{key}")
    return out


def _column_name(_channel: str, name: object, where: str) -> str:
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"{where}: expected a column name (a string), got {name!r}")
    return name


def _unit(channel: str, unit: object, where: str) -> str:
    return canonical_unit(channel, unit, where=where)


def check_columns(columns: object, *, where: str) -> dict[str, str]:
    """Check a ``columns`` mapping (channel -> file column name) and return it as a dict.

    Raises
    ------
    InputError
        If it is not a mapping of known channels to strings.
    """
    return check_channel_table(columns, where=where, what="column name", convert=_column_name)


def check_units(units: object, *, where: str) -> dict[str, str]:
    """Check a ``units`` mapping (channel -> unit) and return it with canonical spellings.

    Raises
    ------
    InputError
        If a channel is unknown or a unit is not accepted.
    """
    return check_channel_table(units, where=where, what="unit", convert=_unit)


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
        scale = check_finite(entry["scale"], f"{here}.scale")
        if scale == 0.0:
            raise InputError(f"{here}.scale: must be non-zero, got 0")
        offset = check_finite(entry.get("offset", 0.0), f"{here}.offset")
        unit = entry.get("unit")
        if unit is not None:
            unit = canonical_unit(channel, unit, where=f"{here}.unit")
        out[channel] = (scale, offset, unit)
    return out


#: Header cells shown at most in a message about a missing column, and characters per cell.
HEADER_CELLS_SHOWN = 20
HEADER_CELL_CHARS = 40


def header_listing(
    cells: Sequence[str], known: Iterable[str], names: Sequence[str] | None = None
) -> str:
    """The header of a file, for a message about a column it lacks.

    Only a file whose header names at least one of the ``known`` columns (a trial with a
    column misnamed) has its header shown, cut to :data:`HEADER_CELLS_SHOWN` cells of
    :data:`HEADER_CELL_CHARS` characters; any other file is not a trial, and its content is
    never echoed into a message (it may be any file the manifest points at). ``names``: the
    cells' column names, if a cell holds more (``Time(Seconds)``: ``time``).
    """
    expected = [str(k).strip() for k in known]
    lowered = {n.lower() for n in expected}
    if not any(str(c).strip().lower() in lowered for c in (cells if names is None else names)):
        return (
            f"its first line names none of the columns {', '.join(expected)}: is it a trial file?"
        )
    shown = [
        c if len(c) <= HEADER_CELL_CHARS else c[: HEADER_CELL_CHARS - 3] + "..."
        for c in (str(c) for c in cells[:HEADER_CELLS_SHOWN])
    ]
    more = f", ... ({len(cells)} columns)" if len(cells) > HEADER_CELLS_SHOWN else ""
    return f"columns are: {', '.join(shown)}{more}"


def reject_calibration(path: Path, calibration: object, format: str) -> None:
    """Refuse a ``calibration`` given to a reader of calibrated values (not volts).

    Raises
    ------
    InputError
        If ``calibration`` is given (not empty).
    """
    if calibration:
        raise InputError(
            f"{path}: calibration is only used by the formats of analog channels in volts "
            f"('analog', 'c3d'; this trial's format is '{format}'); remove it or set the "
            "format of the file"
        )


def calibrated_unit(
    path: Path, channel: str, cal_unit: str | None, units: Mapping[str, str] | None
) -> str:
    """The unit of a calibrated channel: its calibration's, or ``units``'.

    Never assumed: a scale means nothing without the unit it converts to.

    Raises
    ------
    InputError
        If ``units`` and the calibration both give the channel's unit and they differ, or
        neither gives one.
    """
    user_unit = (units or {}).get(channel)
    if cal_unit is not None and user_unit is not None and cal_unit != user_unit:
        raise InputError(
            f"{path}: units.{channel} = {user_unit!r} contradicts "
            f"calibration.{channel}.unit = {cal_unit!r}; give the unit once"
        )
    if cal_unit is None and user_unit is None:
        raise InputError(
            f"{path}: calibration.{channel}.unit: missing; give the unit of scale x volts + "
            f"offset (e.g. {DEFAULT_UNITS[channel]!r}; or units.{channel})"
        )
    return cal_unit or user_unit or DEFAULT_UNITS[channel]


def resolve_units(
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

    Parameters
    ----------
    path : Path
        The file, for messages.
    declared : mapping
        Channel -> unit stated by the file, or ``None`` where it is silent.
    given : mapping
        Channel -> unit from the manifest (``units``).
    defaults : mapping
        Channel -> unit when neither states one; needed only for channels left open.
    said_by : str
        What in the file states the units (``"header"``, ``"metadata line 3"``).

    Returns
    -------
    dict of str to str
        Channel -> canonical unit, for every channel.

    Raises
    ------
    InputError
        An unknown unit, or a user's unit that contradicts the file's.
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


def check_emg(emg: object, *, where: str) -> tuple[str, ...]:
    """Check an ``emg`` setting: a list of EMG column names (or analog labels).

    Parameters
    ----------
    emg : list of str or None
        The names, each a non-empty string, none twice; ``None`` or ``[]``: no EMG.
    where : str
        ``"<file>: <key path>"`` for error messages.

    Returns
    -------
    tuple of str
        The names, in order; ``()`` for none.

    Raises
    ------
    InputError
        If it is not a list of distinct non-empty strings.
    """
    if emg is None:
        return ()
    if isinstance(emg, str) or not isinstance(emg, list | tuple):
        raise InputError(
            f'{where}: expected a list of EMG column names such as ["biceps", "triceps"], '
            f"got {emg!r}"
        )
    for name in emg:
        if not isinstance(name, str) or not name.strip():
            raise InputError(f"{where}: expected EMG column names (strings), got {name!r}")
    if len(set(emg)) != len(emg):
        twice = next(n for n in emg if list(emg).count(n) > 1)
        raise InputError(f"{where}: EMG column {twice!r} is listed twice")
    return tuple(emg)


def resolve_emg_unit(
    path: Path, name: str, declared: str | None, given: str | None, *, said_by: str
) -> str:
    """The unit of an EMG channel: what the file declares, else ``given``, else volts.

    Parameters
    ----------
    path : Path
        The file, for messages.
    name : str
        The channel's column name or label.
    declared : str or None
        The file's unit for it (a units row, ``ANALOG:UNITS``), ``None`` or ``""`` if silent.
    given : str or None
        The manifest's ``[emg] unit`` (or ``read_trial(emg_unit=...)``).
    said_by : str
        What in the file states the unit, for messages.

    Returns
    -------
    str
        ``V``, ``mV`` or ``µV``.

    Raises
    ------
    InputError
        A unit that is not a voltage (the file's or the user's), or a user's unit that
        contradicts the file's.
    """
    user = emg_unit(given, where=f"{path}: emg unit") if given is not None else None
    if declared:
        try:
            file_unit = emg_unit(declared, where=str(path))
        except InputError:
            raise InputError(
                f"{path}: EMG channel {name!r} is in {declared!r} ({said_by}), not a voltage "
                "(V, mV, uV); is it an EMG channel?"
            ) from None
        if user is not None and user != file_unit:
            raise InputError(
                f"{path}: emg unit {user!r} contradicts the file, whose {said_by} says "
                f"{declared!r} for {name!r}; remove the unit or correct the file"
            )
        return file_unit
    return user or "V"
