"""The registry of trial readers: one function per format name, and :func:`read_trial`.

A reader is registered with the decorator :func:`register_reader`; :func:`read_trial` checks
the common arguments (:mod:`inertiafit.io.readers.validation`) and dispatches on ``format``.
A reader registered with ``binary=True`` reads binary files (``c3d``); every other reader reads
text, and :func:`read_trial` stops a binary file (:func:`binary_kind`) before it reaches one,
with a message that names the formats that read binary files. A file given without a
``format`` is read by the binary format it is recognised as (:func:`recognised_format`: a C3D
file by ``c3d``), else as ``csv``.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import xarray as xr

from inertiafit._checks import check_path
from inertiafit.errors import InputError
from inertiafit.io.readers.validation import check_columns, check_emg, check_units
from inertiafit.io.units import emg_unit as canonical_emg_unit

__all__ = [
    "BINARY_FORMATS",
    "COMMON_PARAMETERS",
    "EMG_PARAMETERS",
    "READERS",
    "SNIFF_BYTES",
    "Reader",
    "available_formats",
    "binary_formats",
    "binary_kind",
    "carries_emg",
    "looks_like_c3d",
    "read_trial",
    "reader_options",
    "recognised_format",
    "register_reader",
]

#: A reader: ``reader(path, *, columns, units, calibration, **options) -> Trial``.
Reader = Callable[..., xr.Dataset]

#: The registered readers, format name -> reader; filled by :func:`register_reader`.
READERS: dict[str, Reader] = {}
#: Formats whose reader reads binary files (registered with ``binary=True``).
BINARY_FORMATS: set[str] = set()
#: Parameters every reader takes; any others are the reader's own options.
COMMON_PARAMETERS = ("path", "columns", "units", "calibration")
#: Parameters of a reader whose format can carry EMG channels (the names, their unit); a reader
#: without them has none, and :func:`read_trial` refuses ``emg`` for it.
EMG_PARAMETERS = ("emg", "emg_unit")
#: How many bytes from the start of a file :func:`binary_kind` looks at.
SNIFF_BYTES = 4096
#: Processor-type byte of a C3D parameter section: Intel, DEC, MIPS (the C3D manual).
_C3D_PROCESSORS = (84, 85, 86)
#: Bytes other than tab, line feed, vertical tab, form feed and carriage return below 0x20.
_CONTROL = bytes(set(range(32)) - {9, 10, 11, 12, 13})


def register_reader(name: str, *, binary: bool = False) -> Callable[[Reader], Reader]:
    """Register a reader function under the format ``name`` (a decorator).

    Parameters
    ----------
    name : str
        The format name used by ``read_trial(format=...)`` and the manifest's ``format`` key.
    binary : bool, optional
        The reader reads binary files (default ``False``: text). :func:`read_trial` refuses a
        binary file for a text format before calling its reader.

    Returns
    -------
    callable
        A decorator that registers and returns the reader unchanged. The reader must accept
        ``path`` and the keyword arguments ``columns``, ``units`` and ``calibration``; any
        other keyword-only parameters are its options.
    """

    def decorator(func: Reader) -> Reader:
        params = inspect.signature(func).parameters
        missing = [p for p in COMMON_PARAMETERS if p not in params]
        if missing:
            raise TypeError(f"reader {func.__name__} lacks parameters {missing}")
        READERS[name] = func
        if binary:
            BINARY_FORMATS.add(name)
        else:
            BINARY_FORMATS.discard(name)
        return func

    return decorator


def available_formats() -> tuple[str, ...]:
    """Return the names of the registered trial formats."""
    return tuple(READERS)


def binary_formats() -> tuple[str, ...]:
    """Return the names of the registered formats that read binary files (e.g. ``c3d``)."""
    return tuple(f for f in READERS if f in BINARY_FORMATS)


def looks_like_c3d(head: bytes) -> bool:
    """Whether ``head``, the first bytes of a file, starts like a C3D file.

    A C3D file's first byte is the number of the 512-byte block where its parameter section
    starts (at least 2), its second byte is ``0x50``, and byte 4 of the parameter section is the
    processor type (84 Intel, 85 DEC, 86 MIPS). ``head`` must reach that byte (512 times the
    first byte); a shorter ``head`` is not a C3D file.
    """
    if len(head) < 2 or head[1] != 0x50 or head[0] < 2:
        return False
    at = (head[0] - 1) * 512 + 3
    return len(head) > at and head[at] in _C3D_PROCESSORS


def binary_kind(path: Path) -> str | None:
    """Say what a file is if it is not text, else ``None``; for the messages of text formats.

    Parameters
    ----------
    path : Path
        An existing file.

    Returns
    -------
    str or None
        ``"a C3D file"``; ``"UTF-16 text"`` (a UTF-16 byte-order mark); ``"a binary file"``
        (a NUL byte, or more than 10 % control bytes, in the first ``SNIFF_BYTES`` bytes); or
        ``None`` for anything else, including text in an 8-bit encoding and an empty file.

    Raises
    ------
    InputError
        If the file cannot be opened.
    """
    try:
        with path.open("rb") as handle:
            head = handle.read(SNIFF_BYTES)
            if len(head) >= 2 and head[1] == 0x50 and head[0] * 512 > len(head):
                head += handle.read(head[0] * 512 - len(head))
    except OSError as err:
        raise InputError(f"{path}: cannot be opened ({err.strerror or err})") from None
    if looks_like_c3d(head):
        return "a C3D file"
    if head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return "UTF-16 text"
    head = head[:SNIFF_BYTES]
    if b"\x00" in head or len(head.translate(None, _CONTROL)) < 0.9 * len(head):
        return "a binary file"
    return None


#: What :func:`binary_kind` says of a file -> the format that reads it without a ``format``.
_RECOGNISED = {"a C3D file": "c3d"}


def recognised_format(path: str | Path) -> str | None:
    """The registered binary format a file is recognised as, for a file given no ``format``.

    A C3D file (:func:`looks_like_c3d`) is ``"c3d"``; ``None`` for anything else (text, an
    unknown binary, a missing file): those are read as ``csv``, whose messages name them.
    """
    path = Path(path)
    if not path.is_file():
        return None
    try:
        kind = binary_kind(path)
    except InputError:
        return None
    fmt = _RECOGNISED.get(kind or "")
    return fmt if fmt in BINARY_FORMATS else None


def carries_emg(format: str) -> bool:
    """Whether a registered format's reader reads EMG channels (has ``emg`` and ``emg_unit``).

    Raises
    ------
    InputError
        If the format is not registered.
    """
    params = inspect.signature(_get_reader(format, where="format")).parameters
    return all(p in params for p in EMG_PARAMETERS)


def reader_options(format: str) -> tuple[str, ...]:
    """Return the option names a format's reader accepts beyond columns/units/calibration/emg.

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
    try:
        return _own_options(func)
    except TypeError:  # a reader that cannot be a cache key (an unhashable callable)
        return _own_options.__wrapped__(func)


@functools.lru_cache(maxsize=128)
def _own_options(func: Reader) -> tuple[str, ...]:
    # Keyed by the reader itself, so a format registered again gets its own; a study asks
    # twice per trial (its manifest, then the read) and inspect.signature is the cost.
    common = (*COMMON_PARAMETERS, *EMG_PARAMETERS)
    return tuple(p for p in inspect.signature(func).parameters if p not in common)


def _get_reader(format: object, *, where: str) -> Reader:
    if not isinstance(format, str) or format not in READERS:
        raise InputError(
            f"{where}: unknown trial format {format!r} (formats: {', '.join(READERS)})"
        )
    return READERS[format]


def read_trial(
    path: str | Path,
    *,
    format: str | None = None,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Mapping[str, Any]] | None = None,
    emg: list[str] | tuple[str, ...] | None = None,
    emg_unit: str | None = None,
    **options: Any,
) -> xr.Dataset:
    """Read one trial file into a Trial dataset in SI units.

    Parameters
    ----------
    path : str or Path
        The trial file.
    format : str, optional
        A registered format: ``"csv"``, ``"biodex"``, ``"humac"``, ``"analog"``,
        ``"c3d"``, ``"vicon"``, ``"isomed"``, or one added with :func:`register_reader`.
        Default: the binary format the file is recognised as (:func:`recognised_format`: a
        C3D file is ``"c3d"``), else ``"csv"``.
    columns : mapping of str to str, optional
        File column name per channel (``time``, ``angle``, ``velocity``, ``torque``); channels
        left out keep the format's default names.
    units : mapping of str to str, optional
        Unit per channel, e.g. ``{"torque": "ft*lbf"}``. Vendor formats take units from the
        file and only use these where the file is silent; a contradiction is an error.
    calibration : mapping, optional
        For ``analog`` and ``c3d``: per channel ``{"scale": ..., "offset": ..., "unit": ...}``
        meaning ``value = scale * volts + offset`` in ``unit``.
    emg : list of str, optional
        EMG channels to read (column names, or analog labels of a C3D file), for the formats
        that carry them (``csv``, ``analog``, ``c3d``, ``vicon``); the Trial gains a variable
        ``emg`` in volts (dims ``muscle``, ``time``). Refused by the other formats.
    emg_unit : str, optional
        ``V``, ``mV`` or ``µV`` (``uV``) of the EMG channels where the file does not say
        (default V); contradicting the file is an error.
    **options
        Options of the format's reader (see :func:`reader_options`).

    Returns
    -------
    xarray.Dataset
        The Trial: coordinate ``time`` (s); variables ``angle`` (rad), ``velocity`` (rad/s),
        ``torque`` (N m); attrs ``source``, ``sampling_rate`` (Hz), ``format``; with ``emg``,
        the variable ``emg`` (V) and coordinate ``muscle``.

    Raises
    ------
    InputError
        For an unknown format or option, a missing file, a binary file given to a text format
        (the message names the formats that read binary files), and every problem with the
        file's contents; the one-line message names the file and the field.
    """
    path = check_path(path)
    if format is None:
        format = recognised_format(path) or "csv"
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
    if format not in BINARY_FORMATS:
        kind = binary_kind(path)
        if kind is not None:
            raise InputError(_not_text_message(path, kind, format))
    columns = check_columns(columns, where=f"{path}: columns")
    units = check_units(units, where=f"{path}: units")
    muscles = check_emg(emg, where=f"{path}: emg")
    if emg_unit is not None:
        emg_unit = canonical_emg_unit(emg_unit, where=f"{path}: emg_unit")
    if muscles or emg_unit is not None:
        if not carries_emg(format):
            raise InputError(
                f"{path}: emg: format '{format}' has no EMG channels (formats with EMG: "
                f"{', '.join(f for f in READERS if carries_emg(f))}); remove emg"
            )
        options = {**options, "emg": muscles, "emg_unit": emg_unit}
    return reader(path, columns=columns, units=units, calibration=calibration, **options)


def _not_text_message(path: Path, kind: str, format: str) -> str:
    binary = binary_formats()
    reads_binary = ", ".join(f"'{f}'" for f in binary) if binary else "none"
    listed = f"formats: {', '.join(READERS)}; reading binary files: {reads_binary}"
    if kind == "a C3D file" and "c3d" in READERS:
        return (
            f"{path}: a C3D file (binary), but format '{format}' reads text; read it with "
            f'format = "c3d" ({listed})'
        )
    if kind == "UTF-16 text":
        return (
            f"{path}: UTF-16 text (it starts with a UTF-16 byte-order mark); format '{format}' "
            f"reads UTF-8 text: save the export as UTF-8 ({listed})"
        )
    return f"{path}: {kind}, not text; format '{format}' reads text files ({listed})"
