"""The ``c3d`` format: a dynamometer's analog channels in a C3D file (e.g. from Vicon Nexus).

A C3D file is binary: a header, a parameter section (``ANALOG:LABELS``, ``ANALOG:UNITS``,
``ANALOG:RATE``, ``ANALOG:SCALE`` ...) and frames of 3-D points with several analog samples
per frame. A lab that records a dynamometer's analog outputs with Vicon gets a C3D file with no
markers and channels such as ``Angle.1``, ``Angular Velocity.1``, ``Torque.1``, usually stored
in volts. The file is parsed by the ``c3d`` package (py-c3d), which applies the file's own
``ANALOG:OFFSET``, ``ANALOG:SCALE`` and ``ANALOG:GEN_SCALE``; the manifest's ``calibration``
then turns each stored value into degrees, deg/s and N m, as for the ``analog`` format.
"""

from __future__ import annotations

import io
import struct
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import c3d
import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.readers.registry import available_formats, looks_like_c3d, register_reader
from inertiafit.io.readers.validation import (
    calibrated_unit,
    check_calibration,
    resolve_emg_unit,
)
from inertiafit.io.trial import make_trial
from inertiafit.io.units import ACCEPTED, EMG_UNITS, QUANTITIES, canonical_unit, to_si

__all__ = ["C3D_DEFAULT_LABELS", "read_c3d"]

#: Analog labels used when ``columns`` does not name a channel: what Vicon Nexus calls a
#: dynamometer's analog device channels.
C3D_DEFAULT_LABELS = {"angle": "Angle.1", "velocity": "Angular Velocity.1", "torque": "Torque.1"}
#: ``ANALOG:UNITS`` spellings that mean a voltage: such a channel needs a calibration.
_VOLTS = ("v", "mv", "volt", "volts")
#: What py-c3d raises on a damaged file (seen on truncated, random and bit-flipped files:
#: asserts on the header, struct and index errors, a variable it leaves unbound, ...).
_PARSE_ERRORS = (
    ArithmeticError,
    AssertionError,
    AttributeError,
    EOFError,
    IndexError,
    KeyError,
    NameError,
    TypeError,
    ValueError,
    struct.error,
)


@register_reader("c3d", binary=True)
def read_c3d(
    path: Path,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    calibration: Mapping[str, Any] | None = None,
    emg: Sequence[str] | None = None,
    emg_unit: str | None = None,
) -> xr.Dataset:
    """Read the angle, velocity and torque analog channels of a C3D file, and any EMG ones.

    Each channel is found by its ``ANALOG:LABELS`` entry (surrounding spaces ignored; a
    case-insensitive match if there is no exact one). Its stored value (after the file's own
    offset and scale) becomes ``scale * value + offset`` in the unit of ``calibration.<channel>``
    when one is given; without a calibration, the channel's ``ANALOG:UNITS`` entry must be a
    unit of that channel (``deg``, ``deg/s``, ``N m`` ...) or the manifest's ``units`` must
    give one. A channel stored in volts always needs a calibration. Time comes from the analog
    rate: ``t = (first frame - 1) / POINT:RATE + k / ANALOG:RATE`` s, so it matches the time line
    of the capture software.

    Parameters
    ----------
    path : Path
        The file.
    columns : mapping of str to str, optional
        Analog label per channel; default ``Angle.1``, ``Angular Velocity.1``, ``Torque.1``.
        ``time`` is not a channel of a C3D file.
    units : mapping of str to str, optional
        Unit per channel for channels that are not calibrated and whose ``ANALOG:UNITS`` says
        nothing usable; contradicting the file (or a calibration's unit) is an error.
    calibration : mapping, optional
        ``{channel: {"scale": float, "offset": float = 0, "unit": str}}``, value
        ``= scale * stored + offset`` in ``unit`` (default ``units.<channel>``, else deg, deg/s,
        N m). A scale may be negative and large (e.g. -1.44e5 N m/V).
    emg : sequence of str, optional
        Analog labels of EMG channels (``Voltage.2`` ...), matched as the channels are; read
        into the Trial's ``emg`` (V) at the analog rate, like every analog channel.
    emg_unit : str, optional
        ``V``, ``mV`` or ``µV`` for EMG channels whose ``ANALOG:UNITS`` is empty (default V);
        contradicting the file is an error.

    Returns
    -------
    xarray.Dataset
        The Trial, ``attrs["format"] = "c3d"``, ``attrs["analog_labels"]`` the labels used
        (angle, velocity, torque, comma-separated).

    Raises
    ------
    InputError
        Not a C3D file, a file the parser cannot read or that ends before its last frame, no
        analog channels, a label not found or found twice, a channel in volts without
        calibration, an unknown unit, and every check of
        :func:`~inertiafit.io.trial.make_trial`.
    """
    if columns and "time" in columns:
        raise InputError(
            f"{path}: columns.time: a C3D file has no time channel (time comes from its analog "
            "rate); remove columns.time"
        )
    cal = check_calibration(calibration, where=f"{path}: calibration")
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise InputError(f"{path}: cannot be opened ({err.strerror or err})") from None
    if not looks_like_c3d(raw):
        text = ", ".join(f for f in available_formats() if f != "c3d")
        raise InputError(
            f"{path}: not a C3D file (its first bytes are not a C3D header); for a text export "
            f"choose its format ({text})"
        )
    analog, meta = _read_analog(path, raw)
    labels = meta["labels"]
    found: dict[str, int] = {}
    for channel in QUANTITIES[1:]:
        label = (columns or {}).get(channel, C3D_DEFAULT_LABELS[channel])
        found[channel] = _find_label(path, labels, label.strip(), channel)

    signals = {}
    for muscle in emg or ():
        index = _find_label(path, labels, muscle.strip(), "emg", setting="emg")
        if index in found.values():
            raise InputError(
                f"{path}: emg: analog channel {muscle!r} is a channel of the dynamometer, not an "
                "EMG one"
            )
        unit = resolve_emg_unit(
            path, labels[index], meta["units"][index], emg_unit, said_by="ANALOG:UNITS"
        )
        signals[labels[index]] = EMG_UNITS[unit] * analog[index]

    si = [meta["time"]]
    for channel in QUANTITIES[1:]:
        index = found[channel]
        label, file_unit = labels[index], meta["units"][index]
        values, unit = _physical(path, channel, analog[index], label, file_unit, cal, units)
        si.append(to_si(values, channel, unit, where=f"{path}: units.{channel}"))
    names = {"time": "ANALOG:RATE"} | {q: labels[i] for q, i in found.items()}
    return make_trial(
        *si,
        source=str(path),
        format="c3d",
        columns=names,
        attrs={"analog_labels": ",".join(labels[found[q]] for q in QUANTITIES[1:])},
        emg=signals,
    )


def _read_analog(path: Path, raw: bytes) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """The analog samples (channel x sample) and what the reader needs of the parameters."""
    with warnings.catch_warnings(record=True) as caught:
        # py-c3d reports a file without markers and a short file as warnings: kept, not shown.
        warnings.simplefilter("always")
        try:
            reader = c3d.Reader(io.BytesIO(raw))
            used = int(reader.analog_used)
            if used < 1:
                raise InputError(f"{path}: the C3D file has no analog channels (ANALOG:USED = 0)")
            point_rate = float(reader.point_rate)
            analog_rate = float(reader.analog_rate)
            if (
                not (np.isfinite(point_rate) and np.isfinite(analog_rate))
                or min(point_rate, analog_rate) <= 0
            ):
                raise InputError(
                    f"{path}: POINT:RATE = {point_rate:g} Hz, ANALOG:RATE = {analog_rate:g} Hz; "
                    "both must be positive"
                )
            per_frame = analog_rate / point_rate
            if abs(per_frame - round(per_frame)) > 1e-9 * per_frame:
                raise InputError(
                    f"{path}: ANALOG:RATE = {analog_rate:g} Hz is not a whole multiple of "
                    f"POINT:RATE = {point_rate:g} Hz"
                )
            labels = [str(s).strip() for s in _strings(reader, "ANALOG:LABELS")]
            file_units = [str(s).strip() for s in _strings(reader, "ANALOG:UNITS")]
            first, last = int(reader.first_frame), int(reader.last_frame)
            frames = [a for _, _, a in reader.read_frames(copy=False)]
        except InputError:
            raise
        except _PARSE_ERRORS as err:
            detail = " ".join(f"{type(err).__name__}: {err}".split())
            raise InputError(f"{path}: cannot be read as a C3D file ({detail})") from None
    expected = last - first + 1
    ended = [w for w in caught if "end of file" in str(w.message).lower()]
    if ended or len(frames) < expected:
        raise InputError(
            f"{path}: the C3D file ends after {len(frames)} of its {expected} frames "
            f"({first}-{last}); the file is truncated"
        )
    if len(labels) < used:
        labels += [f"channel {i + 1}" for i in range(len(labels), used)]
    data = np.concatenate(frames, axis=1) if frames else np.empty((used, 0))
    time = (first - 1) / point_rate + np.arange(data.shape[1]) / analog_rate
    meta = {
        "labels": labels[:used],
        "units": (file_units + [""] * used)[:used],
        "time": time,
    }
    return np.asarray(data, dtype=np.float64), meta


def _strings(reader: Any, key: str) -> list[str]:
    param = reader.get(key)
    if param is None:
        return []
    values = param.string_array
    return [values] if isinstance(values, str) else list(np.ravel(values))


def _find_label(
    path: Path, labels: list[str], label: str, channel: str, *, setting: str = ""
) -> int:
    hits = [i for i, name in enumerate(labels) if name == label]
    if not hits:
        hits = [i for i, name in enumerate(labels) if name.lower() == label.lower()]
    if not hits:
        raise InputError(
            f"{path}: analog channel {label!r} not found (ANALOG:LABELS: {', '.join(labels)}); "
            f"set {setting or f'columns.{channel}'} in the manifest"
        )
    if len(hits) > 1:
        raise InputError(
            f"{path}: analog channel {label!r} appears {len(hits)} times in ANALOG:LABELS; "
            "each channel needs one label"
        )
    return hits[0]


def _physical(
    path: Path,
    channel: str,
    stored: NDArray[np.float64],
    label: str,
    file_unit: str,
    cal: Mapping[str, tuple[float, float, str | None]],
    units: Mapping[str, str] | None,
) -> tuple[NDArray[np.float64], str]:
    """One channel's values and their unit, from its calibration or the file's unit."""
    user_unit = (units or {}).get(channel)
    if channel in cal:
        scale, offset, cal_unit = cal[channel]
        return scale * stored + offset, calibrated_unit(path, channel, cal_unit, units)
    if file_unit.lower() in _VOLTS:
        raise InputError(
            f"{path}: analog channel {label!r} is in {file_unit} (ANALOG:UNITS); give "
            f"calibration.{channel} = {{ scale, offset, unit }} (value = scale x volts + offset)"
        )
    try:
        declared = canonical_unit(channel, file_unit, where=str(path)) if file_unit else None
    except InputError:
        declared = None
    if declared is None:
        if user_unit is None:
            raise InputError(
                f"{path}: analog channel {label!r} has unit {file_unit!r} in ANALOG:UNITS, not "
                f"a {channel} unit ({', '.join(ACCEPTED[channel])}); give units.{channel} or "
                f"calibration.{channel}"
            )
        return stored, user_unit
    if user_unit is not None and user_unit != declared:
        raise InputError(
            f"{path}: units.{channel} = {user_unit!r} contradicts the file, whose ANALOG:UNITS "
            f"says {file_unit!r} for {label!r}; remove units.{channel} or correct the file"
        )
    return stored, declared
