"""Delimited text tables through pandas, for the ``csv``, ``analog`` and ``humac`` readers."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.validation import header_listing
from inertiafit.io.units import EMG_UNITS, emg_unit

__all__ = ["emg_columns", "load_table"]


def load_table(
    path: Path,
    wanted: Mapping[str, str],
    *,
    delimiter: str = ",",
    decimal: str = ".",
    hint: str = "columns",
    hints: Mapping[str, str] | None = None,
) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.int64]]:
    """Read the named columns of a delimited file with a header row as float arrays.

    Returns the arrays keyed like ``wanted`` and the file line number of every row (the
    header is line 1). Blank lines at the end are dropped; any other blank or non-numeric
    cell is an error naming its line and column.

    Parameters
    ----------
    path : Path
        The file (UTF-8, a byte-order mark allowed).
    wanted : mapping of str to str
        Key -> column name in the header (cells are compared with surrounding spaces removed).
    delimiter, decimal : str, optional
        Field separator and decimal mark.
    hint : str, optional
        The manifest table to name in the message about a missing column
        (``"<hint>.<key>"``).
    hints : mapping of str to str, optional
        Key -> the manifest setting to name instead, for some keys (``"emg"``).

    Returns
    -------
    values : dict of str to ndarray of float64
        One array per key of ``wanted``; empty cells are NaN.
    lines : ndarray of int64
        The file line number of each row.

    Raises
    ------
    InputError
        An empty or unparsable file, a missing or repeated column, a non-numeric cell.
    """
    for key, mark, examples in (
        ("delimiter", delimiter, "',' ';' or '\\t'"),
        ("decimal", decimal, "'.' or ','"),
    ):
        given: object = mark  # a manifest can give anything
        if not (isinstance(given, str) and len(given) == 1 and given not in "\r\n"):
            raise InputError(
                f"{path}: options.{key}: expected one character such as {examples}, got {mark!r}"
            )
    if delimiter == decimal:
        raise InputError(
            f"{path}: options.delimiter and options.decimal are both {delimiter!r}; "
            "they must differ"
        )
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
            listed = header_listing(present, wanted.values())
            setting = (hints or {}).get(key, f"{hint}.{key}")
            raise InputError(
                f"{path}: column {name!r} not found ({listed}); set {setting} in the manifest"
            )
        if present.count(name) > 1:
            raise InputError(
                f"{path}: column {name!r} appears {present.count(name)} times in the header; "
                "each channel needs one column"
            )
    # Column by column on numpy arrays: selecting, masking and converting a DataFrame costs
    # half as much again as parsing the file. A column by its label (unique: pandas renames
    # repeated ones) costs a fifth of one by position.
    columns = {name: _column(frame, present.index(name)) for name in wanted.values()}
    numeric = {
        name: not pd.api.types.is_bool_dtype(series) and pd.api.types.is_numeric_dtype(series)
        for name, series in columns.items()
    }
    values = {name: _floats(series) for name, series in columns.items() if numeric[name]}
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


def _column(frame: pd.DataFrame, position: int) -> pd.Series:
    """The frame's column at ``position``."""
    column = frame[frame.columns[position]]
    return column if isinstance(column, pd.Series) else frame.iloc[:, position]


def _floats(series: pd.Series) -> NDArray[np.float64]:
    """A numeric column as a new float64 array, missing cells NaN.

    A float64 column already holds NaN where a cell is missing: copied as it is (pandas
    hands out a read-only view of its own data), without the missing-value pass.
    """
    if series.dtype == np.float64:
        return np.array(series.to_numpy(), dtype=np.float64)
    return series.to_numpy(dtype=np.float64, na_value=np.nan)


def emg_columns(
    path: Path,
    emg: Sequence[str] | None,
    unit: str | None,
    names: Mapping[str, str],
    delimiter: str,
    decimal: str,
) -> tuple[dict[str, NDArray[np.float64]], dict[str, NDArray[np.float64]], NDArray[np.int64]]:
    """The trial's channels and its EMG columns (in V) of a table with a header row.

    For the ``csv`` and ``analog`` readers: ``names`` maps the channels to their columns, and
    ``emg`` names EMG columns in ``unit`` (default V; the header says nothing of units).
    Returns the channels' values, the EMG columns in volts by name, and the line numbers.
    """
    muscles = tuple(emg or ())
    taken = {n: q for q, n in names.items()}
    for muscle in muscles:
        if muscle in taken:
            raise InputError(
                f"{path}: emg: column {muscle!r} is the {taken[muscle]} channel, not an EMG one"
            )
    factor = EMG_UNITS[emg_unit(unit, where=f"{path}: emg unit")] if unit is not None else 1.0
    wanted = dict(names) | {f"emg:{m}": m for m in muscles}
    values, lines = load_table(
        path,
        wanted,
        delimiter=delimiter,
        decimal=decimal,
        hints={f"emg:{m}": "emg" for m in muscles},
    )
    signals = {m: factor * values.pop(f"emg:{m}") for m in muscles}
    return values, signals, lines
