"""The Trial: one dynamometer recording as an :class:`xarray.Dataset` in SI units.

A Trial is the contract between the readers and the processing stage:

- coordinate ``time`` (s, float64, strictly increasing, evenly sampled, starting wherever the
  file starts);
- data variables ``angle`` (rad), ``velocity`` (rad/s) and ``torque`` (N m), float64 along
  ``time``; every variable and the coordinate carry ``attrs["units"]``; ``velocity`` has the
  sign of the derivative of ``angle``;
- dataset attrs ``source`` (str, the file), ``sampling_rate`` (Hz, float, the inverse of the
  median time step to 12 significant digits), ``format`` (the reader's name), ``torque_kind``
  (``"signed"``, or ``"magnitude"`` when the file writes the torque without its sign) and
  ``flags`` (a tuple of one-line strings: what was corrected or noticed while reading, such as
  a velocity sign reversed to follow the angle);
- when the file's EMG channels are read (``emg`` of the readers and the manifest), a variable
  ``emg`` (V, float64, dims ``muscle`` and ``time``) with the muscle names (the file's column
  names or analog labels) as coordinate ``muscle``. EMG shares the trial's time line: every
  reader that carries EMG reads it with the dynamometer's channels at the file's full rate
  (Vicon devices at 1500 Hz, C3D analog at 1 kHz), never decimated. A trial without EMG has
  neither the variable nor the coordinate.

:func:`make_trial` is the only way readers build one: it checks what every later stage relies
on (finite values, increasing and evenly sampled time, enough samples, a velocity that is the
angle's derivative) and names the file, the column and the row of the first problem.
:func:`apply_torque_sign` gives the torque its sign as the manifest's ``torque_sign`` says (a
factor of +-1, or ``"motion"`` for a torque written as a magnitude).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import permutations
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from inertiafit.errors import InputError
from inertiafit.io.units import QUANTITIES, SI_UNITS

__all__ = [
    "GAP_FACTOR",
    "MAGNITUDE_FLAG",
    "MAX_EMG",
    "MAX_MAGNITUDE",
    "MIN_SAMPLES",
    "MIN_SWEEP",
    "MOTION_FLOOR",
    "REVERSAL_SWEEP",
    "SHORT_STEP_FACTOR",
    "TIME_RESOLUTION",
    "TORQUE_SIGNS",
    "VELOCITY_AGREEMENT",
    "VELOCITY_SCALE_FLAG",
    "VELOCITY_SCALE_LIMIT",
    "VelocityCheck",
    "apply_torque_sign",
    "compare_velocity",
    "derived_velocity",
    "magnitude_evidence",
    "make_trial",
    "motion_direction",
    "reversals",
]

#: Fewest samples a trial may have; fewer cannot hold an acceleration window or a fit.
MIN_SAMPLES = 10
#: Largest size of an angle (rad), velocity (rad/s) or torque (N m) sample: far beyond any
#: dynamometer, and far below where squares and sums of squares overflow (a torque of 1e308
#: gave a NaN inertia and an overflow warning, and the error named the manifest's condition).
MAX_MAGNITUDE = 1e9
#: Largest size (V) of an EMG sample: amplifiers output +-10 V at most; a value beyond this is
#: a corrupt cell or microvolts read as volts.
MAX_EMG = 100.0
#: A time step longer than this multiple of the median step is a gap (lost samples).
GAP_FACTOR = 1.5
#: A time step shorter than this multiple of the median step is uneven sampling (a repeated or
#: inserted sample). Steps rounded in the file (1500 Hz written to 0.1 ms) stay well inside.
SHORT_STEP_FACTOR = 0.5
#: Largest float64 spacing of the time stamps, as a fraction of the time step: at this
#: resolution every step, and the sampling rate, is off by 0.1 % at most. Time stamps of 1e12 s
#: (an epoch offset) are 2**-13 s apart, and a 1 kHz step read as 2**-10 s gave 1024 Hz; an
#: epoch in seconds (1.7e9, 2.4e-7 s apart) at 1 kHz stays inside (2.4e-4 of its step).
TIME_RESOLUTION = 1e-3
#: A stretch of the trial tests the velocity against the angle only if the angle changes by at
#: least this much over it (rad): 2 deg, 32 steps of a 1/16-deg encoder, so the angle's
#: quantisation moves the comparison by 3 % at most. A trial that never moves this far
#: (isometric, or a few degrees at 1 deg/s) is not checked.
MIN_SWEEP = math.radians(2.0)
#: Lengths (s) of the stretches over which the change of the angle is compared with the
#: integral of the velocity: short ones for fast moves, long ones for 1 deg/s.
_STRETCHES = (0.05, 0.2, 1.0, 5.0, 20.0)
#: A velocity beyond this factor (either way) of d(angle)/dt is in other units than the angle:
#: the nearest mix-up is rpm read as deg/s (6); deg/rad is 57.3 and ms/s 1000.
VELOCITY_SCALE_LIMIT = 4.0
#: A velocity beyond this factor, but within the limit, is flagged: it does not match the angle,
#: but no unit explains it. The measured ratio is 0.99 on the HUMAC files.
VELOCITY_SCALE_FLAG = 1.5
#: Fraction of the stretches whose ratio must have the median's sign, and quartile ratio
#: (75th / 25th percentile of ``|ratio|``) they may not exceed, for the comparison to decide.
VELOCITY_AGREEMENT = 0.8
_VELOCITY_SPREAD = 1.5
#: A reversal of the motion counts when the angle moves at least this far (rad) each side.
REVERSAL_SWEEP = math.radians(5.0)
#: Within this time (s) of a reversal, a torque written as a magnitude falls to (near) zero.
_REVERSAL_REACH = 0.1
#: "Near zero": at most this fraction of the torque's 99th percentile.
_NEAR_ZERO = 0.02
#: Speeds (rad/s) below this, or below 5 % of the trial's 99th-percentile speed, are rest when
#: the torque is signed by the direction of motion (the quantised velocity of a shaft at rest).
MOTION_FLOOR = math.radians(2.0)
#: Default window (s) of the Savitzky-Golay derivative that gives a velocity to a file without
#: one: 101 samples at 1 kHz, whose slope has an SD of 0.34 deg/s under the real ankle's angle
#: noise (0.1 deg); a fast trial's speed-up of 30-50 ms wants a shorter one.
DERIVED_VELOCITY_WINDOW = 0.1
#: Values of the manifest's ``torque_sign``.
TORQUE_SIGNS = (1, -1, "motion")
#: How the flag of a torque written as a magnitude starts (its evidence follows).
MAGNITUDE_FLAG = "torque: a magnitude, not a signed moment"

_LONG_NAMES = {
    "time": "time",
    "angle": "angle of the dynamometer shaft",
    "velocity": "angular velocity of the shaft",
    "torque": "moment measured at the shaft",
}
#: Unit mix-ups by the ratio velocity / d(angle)/dt they cause, in SI.
_UNIT_MIXUPS = (
    (180 / math.pi, "velocity in deg/s read as rad/s, or angle in rad read as deg"),
    (math.pi / 180, "velocity in rad/s read as deg/s, or angle in deg read as rad"),
    (1000.0, "time in ms read as s"),
    (1 / 1000, "time in s read as ms"),
    (60.0, "velocity per minute read as per second"),
    (6.0, "velocity in rpm read as deg/s"),
)


def make_trial(
    time: ArrayLike,
    angle: ArrayLike,
    velocity: ArrayLike | None,
    torque: ArrayLike,
    *,
    source: str,
    format: str = "csv",
    columns: Mapping[str, str] | None = None,
    lines: ArrayLike | None = None,
    attrs: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
    flags: Sequence[str] = (),
    torque_magnitude: str | None = None,
    emg: Mapping[str, ArrayLike] | None = None,
    velocity_window: float = DERIVED_VELOCITY_WINDOW,
) -> xr.Dataset:
    """Check four channels in SI units and build a Trial dataset.

    Beyond finite values and enough samples, time must increase with even steps (no gap longer
    than ``GAP_FACTOR`` and no step shorter than ``SHORT_STEP_FACTOR`` times the median step),
    and the velocity is compared with the derivative of the angle (:func:`compare_velocity`):
    a velocity that runs against the angle is reversed and the trial flagged; one off by a unit
    factor is an error. A torque that is never negative and falls to zero where the motion
    reverses (:func:`magnitude_evidence`) is recorded as ``torque_kind = "magnitude"``.

    Parameters
    ----------
    time : array_like[nsamples]
        Sample times (s), strictly increasing.
    angle : array_like[nsamples]
        Shaft angle (rad).
    velocity : array_like[nsamples] or None
        Shaft angular velocity (rad/s). ``None`` (a file without a velocity channel): the
        angle's derivative (:func:`derived_velocity` over ``velocity_window``), recorded as
        ``attrs["velocity_source"] = "derived"``.
    torque : array_like[nsamples]
        Measured moment (N m).
    source : str
        The file the values came from; named in every error and kept in ``attrs["source"]``.
    format : str, optional
        Name of the reader, kept in ``attrs["format"]``.
    columns : mapping of str to str, optional
        The file's column name of each channel, used in error messages (default: the channel
        names).
    lines : array_like[nsamples] of int, optional
        The line number of each sample in the file, used in error messages (default: the
        1-based sample number, reported as "sample").
    attrs : mapping, optional
        Extra dataset attributes (str, int or float values) recorded by the reader.
    units : mapping of str to str, optional
        The unit each channel was read in, named in the message about a velocity that does not
        match the angle's units.
    flags : sequence of str, optional
        The reader's own flags (one line each); the trial's ``attrs["flags"]`` starts with
        them.
    torque_magnitude : str, optional
        The reader's evidence that its format writes the torque as a magnitude (a phrase such
        as ``"never negative in the whole file"``), when it knows better than this trial's own
        samples (a single stroke cut from a file shows no reversal). ``None``: look for it in
        the samples.

    Returns
    -------
    xarray.Dataset
        The Trial (see the module docstring).

    Raises
    ------
    InputError
        If the channels differ in length, have fewer than ``MIN_SAMPLES`` samples, contain a
        NaN or infinite value or an angle, velocity or torque beyond ``MAX_MAGNITUDE``, if the
        time stamps are too large for float64 to resolve their step (``TIME_RESOLUTION``), if
        time does not strictly increase, if a time step exceeds ``GAP_FACTOR`` times the
        median step (a gap) or falls short of ``SHORT_STEP_FACTOR`` times it, if the velocity
        is a unit factor away from the angle's derivative or says the shaft is still while the
        angle drifts, or if the columns look swapped (the velocity follows the derivative of
        another channel than the angle); an EMG channel of another length, with a non-finite
        value or beyond ``MAX_EMG`` volts.
    """
    names = {q: q for q in QUANTITIES}
    if columns:
        names.update({q: str(c) for q, c in columns.items() if q in names})
    arrays = {}
    for quantity, values in zip(QUANTITIES, (time, angle, velocity, torque), strict=True):
        if values is None and quantity == "velocity":
            continue
        array = np.asarray(values, dtype=np.float64)
        if array.ndim != 1:
            raise InputError(
                f"{source}: column '{names[quantity]}' must be one-dimensional, "
                f"got shape {array.shape}"
            )
        arrays[quantity] = array
    n = arrays["time"].size
    for quantity, array in arrays.items():
        if array.size != n:
            raise InputError(
                f"{source}: column '{names[quantity]}' has {array.size} values but "
                f"'{names['time']}' has {n}; every channel needs one value per sample"
            )
    if n < MIN_SAMPLES:
        raise InputError(
            f"{source}: only {n} samples; a trial needs at least {MIN_SAMPLES} "
            "(is the file empty or cut short?)"
        )

    if lines is None:
        where = np.arange(1, n + 1)
        row_word = "sample"
    else:
        where = np.asarray(lines)
        row_word = "line"

    for quantity, array in arrays.items():
        bad = ~np.isfinite(array)
        if bad.any():
            i = int(np.argmax(bad))
            more = int(bad.sum()) - 1
            extra = f" (and {more} more)" if more else ""
            raise InputError(
                f"{source}: column '{names[quantity]}' has a missing or non-finite value "
                f"({float(array[i])}) at {row_word} {where[i]}{extra}; values must be finite numbers"
            )

    for quantity in (q for q in QUANTITIES[1:] if q in arrays):
        big = np.abs(arrays[quantity]) > MAX_MAGNITUDE
        if big.any():
            i = int(np.argmax(big))
            raise InputError(
                f"{source}: column '{names[quantity]}' holds {arrays[quantity][i]:.4g} "
                f"{SI_UNITS[quantity]} at {row_word} {where[i]}, beyond {MAX_MAGNITUDE:g} "
                f"{SI_UNITS[quantity]}, which no dynamometer reaches (a corrupt value, or "
                "the wrong unit?)"
            )

    t = arrays["time"]
    _check_resolution(t, source=source, column=names["time"])
    dt = np.diff(t)
    bad = dt <= 0
    if bad.any():
        i = int(np.argmax(bad)) + 1
        raise InputError(
            f"{source}: column '{names['time']}' does not increase at {row_word} {where[i]} "
            f"({t[i]:g} s after {t[i - 1]:g} s); time must be strictly increasing"
        )
    step = float(np.median(dt))
    gaps = dt > GAP_FACTOR * step
    if gaps.any():
        i = int(np.argmax(gaps))
        raise InputError(
            f"{source}: gap in column '{names['time']}' at {row_word} {where[i + 1]}: "
            f"{dt[i]:g} s between t = {t[i]:g} s and t = {t[i + 1]:g} s, more than "
            f"{GAP_FACTOR:g} x the median step {step:g} s (samples missing?)"
        )
    short = dt < SHORT_STEP_FACTOR * step
    if short.any():
        i = int(np.argmax(short))
        raise InputError(
            f"{source}: uneven sampling in column '{names['time']}' at {row_word} "
            f"{where[i + 1]}: {dt[i]:g} s between t = {t[i]:g} s and t = {t[i + 1]:g} s, less "
            f"than {SHORT_STEP_FACTOR:g} x the median step {step:g} s (a repeated or inserted "
            "sample?); the samples must be evenly spaced"
        )

    notes = [str(f) for f in flags]
    derived = velocity is None
    if derived:  # the angle's own derivative: nothing to compare it with
        arrays["velocity"] = derived_velocity(
            arrays["angle"], step, velocity_window, where=f"{source}: velocity"
        )
    else:
        check = compare_velocity(t, arrays["angle"], arrays["velocity"], step=step)
        if not _follows_cleanly(check):  # before any advice on units or the torque's sign
            problem = _still_velocity(t, arrays, check, source=source, names=names)
            problem = problem or _swapped_columns(t, arrays, source=source, names=names)
            if problem is not None:
                raise InputError(problem)
        if check is not None:
            reverse, said = _judge_velocity(check, source=source, names=names, units=units)
            if reverse:
                arrays["velocity"] = -arrays["velocity"]
            notes.extend(said)
        else:  # the angle never sweeps MIN_SWEEP: did the velocity say it moved?
            _check_travel(t, arrays["angle"], arrays["velocity"], source, names, units)
    rate = 1.0 / step
    evidence = torque_magnitude or magnitude_evidence(arrays["angle"], arrays["torque"], rate)
    if evidence:
        notes.append(f"{MAGNITUDE_FLAG} ({evidence})")

    data_vars: dict[str, Any] = {
        q: (
            "time",
            arrays[q],
            {"units": SI_UNITS[q], "long_name": _LONG_NAMES[q]},
        )
        for q in QUANTITIES[1:]
    }
    dataset_attrs: dict[str, Any] = {
        "source": str(source),
        # 12 significant digits: 100 Hz stays 100.0 after ms -> s rounding of the steps.
        "sampling_rate": float(f"{rate:.12g}"),
        "format": str(format),
        "torque_kind": "magnitude" if evidence else "signed",
    }
    if derived:
        dataset_attrs["velocity_source"] = "derived"
    if attrs:
        dataset_attrs.update({k: v for k, v in attrs.items() if k != "flags"})
        notes = [str(f) for f in attrs.get("flags", ())] + notes
    dataset_attrs["flags"] = tuple(dict.fromkeys(notes))
    coords: dict[str, Any] = {
        "time": ("time", t, {"units": SI_UNITS["time"], "long_name": "time"})
    }
    if emg:
        muscles, signals = _emg_channels(emg, n, source=source, where=where, row_word=row_word)
        data_vars["emg"] = (
            ("muscle", "time"),
            signals,
            {"units": "V", "long_name": "electromyogram"},
        )
        coords["muscle"] = ("muscle", muscles, {"long_name": "muscle (EMG channel)"})
    return xr.Dataset(data_vars, coords=coords, attrs=dataset_attrs)


def _check_resolution(time: NDArray, *, source: str, column: str) -> None:
    """Refuse time stamps too large for float64 to resolve their step (:data:`TIME_RESOLUTION`).

    The step is the mean over the trial, ``(t[-1] - t[0]) / (n - 1)``, which rounding of the
    single stamps barely moves; a time that does not increase is left to the later checks.
    """
    mean_step = float(time[-1] - time[0]) / (time.size - 1)
    largest = float(max(abs(time[0]), abs(time[-1])))
    spacing = float(np.spacing(largest))
    if mean_step > 0 and spacing > TIME_RESOLUTION * mean_step:
        raise InputError(
            f"{source}: column '{column}' reaches {largest:.6g} s, where float64 resolves only "
            f"{spacing:.3g} s, {spacing / mean_step:.2g} of the {mean_step:.3g} s step (expected "
            f"under {TIME_RESOLUTION:g} of it): the sampling rate cannot be resolved; write the "
            "time from the trial's start (subtract the first time stamp before saving the file)"
        )


def derived_velocity(
    angle: ArrayLike, step: float, window: float = DERIVED_VELOCITY_WINDOW, *, where: str
) -> NDArray[np.float64]:
    """The angle's derivative (rad/s) for a file that records no velocity.

    A Savitzky-Golay filter (quadratic, ``scipy.signal.savgol_filter``) over ``window``
    seconds of evenly spaced samples ``step`` s apart: a least-squares slope that averages the
    angle's noise out, where a difference of neighbours would multiply it by the rate.

    Raises
    ------
    InputError
        If the window is not a finite number of seconds spanning at least 5 samples and at most
        the trial (``where`` names the option).
    """
    values = np.asarray(angle, dtype=np.float64)
    given: object = window  # from a manifest's options: any TOML value
    if (
        isinstance(given, bool)
        or not isinstance(given, int | float)
        or not math.isfinite(given)
        or given <= 0
    ):
        raise InputError(f"{where}: window {window!r}: expected a positive number of seconds")
    length = round(window / step) // 2 * 2 + 1
    if length < 5 or length > values.size:
        raise InputError(
            f"{where}: window {window:g} s is {length} samples of {step:g} s; expected at "
            f"least 5 and at most the trial's {values.size}"
        )
    from scipy.signal import savgol_filter  # lazily: reading a trial with a velocity needs none

    return savgol_filter(values, length, 2, deriv=1, delta=step)


def _emg_channels(
    emg: Mapping[str, ArrayLike], n: int, *, source: str, where: NDArray, row_word: str
) -> tuple[list[str], NDArray[np.float64]]:
    """The muscle names and a (muscle, time) array of volts, checked like the channels."""
    muscles = [str(m) for m in emg]
    rows = []
    for muscle, values in zip(muscles, emg.values(), strict=True):
        array = np.asarray(values, dtype=np.float64)
        if array.ndim != 1 or array.size != n:
            raise InputError(
                f"{source}: EMG column '{muscle}' has shape {array.shape}, expected {n} values, "
                "one per sample of the trial"
            )
        bad = ~np.isfinite(array)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                f"{source}: EMG column '{muscle}' has a missing or non-finite value "
                f"({float(array[i])}) at {row_word} {where[i]}; values must be finite numbers"
            )
        big = np.abs(array) > MAX_EMG
        if big.any():
            i = int(np.argmax(big))
            raise InputError(
                f"{source}: EMG column '{muscle}' holds {array[i]:.4g} V at {row_word} "
                f"{where[i]}, beyond {MAX_EMG:g} V, which no EMG amplifier outputs (a corrupt "
                "value, or the wrong emg unit?)"
            )
        rows.append(array)
    return muscles, np.vstack(rows)


@dataclass(frozen=True)
class VelocityCheck:
    """The velocity compared with the derivative of the angle (:func:`compare_velocity`).

    Attributes
    ----------
    ratio : float
        Median over the stretches of ``integral of velocity dt / change of angle``: 1 for a
        consistent trial, -1 for a velocity of the opposite sign, 57.3 for a velocity in deg/s
        read as rad/s.
    stretches : int
        Number of stretches compared (each sweeps at least :data:`MIN_SWEEP`).
    agreement : float
        Fraction of the stretches whose ratio has the sign of ``ratio``.
    spread : float
        75th over 25th percentile of ``|ratio|`` among those stretches.
    """

    ratio: float
    stretches: int
    agreement: float
    spread: float

    @property
    def decisive(self) -> bool:
        """Whether the stretches agree enough to correct the sign or refuse the scale."""
        return self.agreement >= VELOCITY_AGREEMENT and self.spread <= _VELOCITY_SPREAD


def _integral(time: NDArray, velocity: NDArray) -> NDArray:
    """The angle travelled since the first sample by the velocity's trapezoids (rad)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * np.diff(time) * (velocity[1:] + velocity[:-1]))))


def compare_velocity(
    time: ArrayLike,
    angle: ArrayLike,
    velocity: ArrayLike,
    *,
    sweep: float = MIN_SWEEP,
    step: float | None = None,
) -> VelocityCheck | None:
    """Compare a velocity channel with the derivative of the angle, robustly.

    Over stretches of 0.05, 0.2, 1, 5 and 20 s that start at every sample, the change of the
    angle is compared with the integral of the velocity (trapezoids): no derivative of a
    quantised angle is taken, and only stretches over which the angle changes by at least
    :data:`MIN_SWEEP` count, so a shaft that barely moves (isometric, or 1 deg/s on a 1/16-deg
    encoder over a short stretch) cannot produce a false alarm.

    Parameters
    ----------
    time, angle, velocity : array_like[nsamples]
        Seconds, radians, radians per second (finite, time increasing).
    sweep : float, optional
        Change of the angle a stretch needs to count (default :data:`MIN_SWEEP`).
    step : float, optional
        The median time step (s), when the caller has it; computed here otherwise.

    Returns
    -------
    VelocityCheck or None
        ``None`` when no stretch sweeps ``sweep`` (nothing to compare).
    """
    t = np.asarray(time, dtype=np.float64)
    theta = np.asarray(angle, dtype=np.float64)
    omega = np.asarray(velocity, dtype=np.float64)
    n = t.size
    if n < 2:
        return None
    with np.errstate(all="ignore"):
        integral = _integral(t, omega)
        if step is None:
            step = float(np.median(np.diff(t)))
        ratios = []
        for length in sorted({min(max(round(s / step), 1), n - 1) for s in _STRETCHES}):
            change = theta[length:] - theta[:-length]
            moved = np.abs(change) >= sweep
            if moved.any():
                ratios.append((integral[length:] - integral[:-length])[moved] / change[moved])
        if not ratios:
            return None
        r = np.concatenate(ratios)
        r = r[np.isfinite(r)]
        if r.size == 0:
            return None
        ratio = float(np.median(r))
        agree = np.abs(r[np.sign(r) == np.sign(ratio)])
        agreement = agree.size / r.size
        if agree.size:
            q25, q75 = np.percentile(agree, [25, 75])
            spread = float(q75 / q25) if q25 > 0 else math.inf
        else:
            spread = math.inf
    return VelocityCheck(ratio=ratio, stretches=int(r.size), agreement=agreement, spread=spread)


#: The velocity channel is taken to be the angle's derivative, with no search for swapped
#: columns, when it follows the angle decisively, within VELOCITY_SCALE_FLAG, and with its
#: stretches' quartile ratio at most this (1.00-1.16 on every real export; 1.3-1.5 for a
#: one-signed torque against the angle of a constant-speed move).
_CLEAN_SPREAD = 1.25
#: Swapped columns: a channel "follows the derivative" of another when, over stretches that
#: change the other by at least ``_SWAP_SWEEP`` of its range (channels of other quantities are
#: in other units, so no fixed sweep applies), at least ``_SWAP_STRETCHES`` stretches count,
#: ``_SWAP_AGREEMENT`` of them agree in sign and their quartile ratio is ``_SWAP_SPREAD`` or less.
_SWAP_SWEEP = 0.1
_SWAP_STRETCHES = 20
_SWAP_AGREEMENT = 0.95
_SWAP_SPREAD = 1.2


def _follows_cleanly(check: VelocityCheck | None) -> bool:
    """Whether the velocity follows the angle beyond doubt (no column swap to look for)."""
    return (
        check is not None
        and check.decisive
        and 1 / VELOCITY_SCALE_FLAG <= abs(check.ratio) <= VELOCITY_SCALE_FLAG
        and check.spread <= _CLEAN_SPREAD
    )


def _follows(time: NDArray, angle: NDArray, velocity: NDArray) -> VelocityCheck | None:
    """``velocity`` compared with the derivative of ``angle`` in any units, if it follows it.

    A channel that never changes is no velocity. Where the angle moves at one steady rate (a
    quasi-static sweep), a constant would follow it too, so the channel must follow it at
    least about as tightly as a constant does: a one-signed torque of a constant-speed move
    follows it only loosely.
    """
    span = float(np.ptp(angle))
    if not (math.isfinite(span) and span > 0) or float(np.ptp(velocity)) == 0:
        return None
    sweep = _SWAP_SWEEP * span
    check = compare_velocity(time, angle, velocity, sweep=sweep)
    if check is None or not _tight(check):
        return None
    steady = compare_velocity(time, angle, np.ones_like(angle), sweep=sweep)
    if steady is not None and _tight(steady) and check.spread > 1.05 * steady.spread:
        return None
    return check


def _tight(check: VelocityCheck) -> bool:
    """Enough stretches that agree in sign and in size for :func:`_follows`."""
    return (
        check.stretches >= _SWAP_STRETCHES
        and check.agreement >= _SWAP_AGREEMENT
        and check.spread <= _SWAP_SPREAD
    )


#: Share of the trial at each end whose median angle measures a drift: a tenth, so a glitch or
#: a jittery channel (0.5 deg SD) does not move it, while a steady drift is measured whole.
_DRIFT_END = 0.1


def _still_velocity(
    time: NDArray,
    arrays: Mapping[str, NDArray],
    check: VelocityCheck | None,
    *,
    source: str,
    names: Mapping[str, str],
) -> str | None:
    """The message for an angle that drifts while the velocity says the shaft is still, or None.

    A rest trial whose angle drifts (a creeping zero, or a limb settling) beside a velocity of
    about 0: the medians of the angle's first and last :data:`_DRIFT_END` give a rate that
    moves it at least :data:`MIN_SWEEP` over the trial, half the velocity's samples are below
    :data:`MOTION_FLOOR` and its mean is less than ``1 / VELOCITY_SCALE_LIMIT`` of the drift's
    rate. A velocity that follows the angle decisively by a unit's factor (``check``: rad/s
    read as deg/s) is left to the unit check. A steady torque follows the derivative of a
    steady drift, so the search for swapped columns named a swap that is not there (a swapped
    velocity column holds a torque or an angle: not still).
    """
    angle, velocity = arrays["angle"], arrays["velocity"]
    k = max(1, round(_DRIFT_END * time.size))
    span = float(np.mean(time[-k:]) - np.mean(time[:k]))
    if not span > 0:
        return None
    rate = float(np.median(angle[-k:]) - np.median(angle[:k])) / span
    duration = float(time[-1] - time[0])
    median = float(np.median(np.abs(velocity)))
    if abs(rate) * duration < MIN_SWEEP or median >= MOTION_FLOOR:
        return None
    if abs(float(np.mean(velocity)) / rate) >= 1 / VELOCITY_SCALE_LIMIT:
        return None
    if check is not None and check.decisive and check.ratio and _unit_causes(abs(check.ratio)):
        return None
    a, v = names["angle"], names["velocity"]
    return (
        f"{source}: column '{a}' drifts {math.degrees(rate):.2g} deg/s "
        f"({math.degrees(rate) * duration:.2g} deg in {duration:.3g} s) while column '{v}' says "
        f"the shaft is still (median speed {math.degrees(median):.2g} deg/s, mean "
        f"{math.degrees(float(np.mean(velocity))):.2g} deg/s): the velocity does not follow the "
        "angle; check the angle channel for a drifting zero, or the velocity channel for a dead "
        "one"
    )


def _swapped_columns(
    time: NDArray, arrays: Mapping[str, NDArray], *, source: str, names: Mapping[str, str]
) -> str | None:
    """The message for columns mapped to the wrong channels, or ``None``.

    The velocity channel does not follow the angle's derivative (:func:`_follows_cleanly`,
    nor loosely, :func:`_follows`, over enough stretches to tell: a short piece of a sinusoid
    gives too few, and its angle and velocity follow each other either way); if another
    channel follows the derivative of another, the file's columns hold the channels in another order: a torque column holding the
    angle reads as a torque that never turns negative (which ``torque_sign`` cannot fix), an
    angle column holding the torque as gravity at the wrong angles.
    """
    channels = ("angle", "velocity", "torque")
    span = float(np.ptp(arrays["angle"]))
    declared = compare_velocity(
        time, arrays["angle"], arrays["velocity"], sweep=_SWAP_SWEEP * span
    )
    if declared is None or declared.stretches < _SWAP_STRETCHES:
        return None  # the angle moves too little to say that the declared pair does not follow
    if _follows(time, arrays["angle"], arrays["velocity"]) is not None:
        return None  # the declared pair follows too (a sinusoid also follows its derivative)
    found = []
    for angle, velocity in permutations(channels, 2):
        if (angle, velocity) != ("angle", "velocity"):
            check = _follows(time, arrays[angle], arrays[velocity])
            if check is not None:
                found.append((check.spread, angle, velocity, check))
    if not found:
        return None
    _, angle, velocity, check = min(found, key=lambda f: f[0])
    torque = next(c for c in channels if c not in (angle, velocity))
    mapping = {"angle": angle, "velocity": velocity, "torque": torque}
    moved = [c for c in channels if mapping[c] != c]
    what = ", ".join(moved[:-1]) + " and " + moved[-1]
    fix = ", ".join(f'{c} = "{names[mapping[c]]}"' for c in channels)
    over = f"over {check.stretches} stretches"
    if velocity == "velocity":
        found_text = (
            f"column '{names[velocity]}' (the velocity) follows the derivative of column "
            f"'{names[angle]}' (read as the {angle}) {over}, not of column '{names['angle']}' "
            "read as the angle"
        )
    elif angle == "angle":
        found_text = (
            f"the derivative of column '{names[angle]}' (the angle) is column "
            f"'{names[velocity]}' (read as the {velocity}) {over}, not column "
            f"'{names['velocity']}' read as the velocity"
        )
    else:
        found_text = (
            f"column '{names[velocity]}' (read as the {velocity}) follows the derivative of "
            f"column '{names[angle]}' (read as the {angle}) {over}, and column "
            f"'{names['velocity']}' read as the velocity does not follow column "
            f"'{names['angle']}' read as the angle"
        )
    return (
        f"{source}: {what} columns swapped? {found_text}: map columns = {{ {fix} }} (and "
        "their units) in the manifest"
    )


def _unit_causes(factor: float) -> list[str]:
    """The unit mix-ups (:data:`_UNIT_MIXUPS`) within 15 % of ``factor``."""
    return [text for f, text in _UNIT_MIXUPS if abs(math.log(factor / f)) < 0.15]


def _read_as(units: Mapping[str, str] | None) -> str:
    """`` (read as time 's', angle 'deg', ...)`` for a message, or nothing."""
    if not units:
        return ""
    shown = ", ".join(f"{q} {units[q]!r}" for q in ("time", "angle", "velocity") if q in units)
    return f" (read as {shown})"


#: Longest stretch (s) over which a velocity's travel is held against a still angle: short, so
#: a velocity offset of an isometric trial (1-2 deg/s) never integrates to MIN_SWEEP in it.
_TRAVEL_STRETCH = 0.2


def _check_travel(
    time: NDArray,
    angle: NDArray,
    velocity: NDArray,
    source: str,
    names: Mapping[str, str],
    units: Mapping[str, str] | None,
) -> None:
    """Refuse an angle that barely moves while the velocity travels, over short stretches.

    :func:`compare_velocity` needs the angle to sweep :data:`MIN_SWEEP`; an angle in rad read
    as deg (a 90 deg move becomes 1.6 deg) or a dead angle channel never does, and the gravity
    model would then be subtracted at the wrong angles. Here the roles swap: over stretches of
    up to :data:`_TRAVEL_STRETCH` in which the velocity's integral travels at least
    :data:`MIN_SWEEP`, the angle must change by at least ``1 / VELOCITY_SCALE_LIMIT`` of it in
    most of them (:data:`VELOCITY_AGREEMENT`).
    """
    n = time.size
    if n < 2:
        return
    with np.errstate(all="ignore"):
        integral = _integral(time, velocity)
        step = float(np.median(np.diff(time)))
        longest = min(max(round(_TRAVEL_STRETCH / step), 1), n - 1)
        travel = integral[longest:] - integral[:-longest]
        moved = np.abs(travel) >= MIN_SWEEP
        if not moved.any():
            return
        share = (angle[longest:] - angle[:-longest])[moved] / travel[moved]
    if np.mean(np.abs(share) < 1 / VELOCITY_SCALE_LIMIT) < VELOCITY_AGREEMENT:
        return
    size = float(np.median(np.abs(share)))
    v_deg = math.degrees(float(np.max(np.abs(travel))))
    a_deg = math.degrees(float(np.ptp(angle)))
    factor = 1 / size if size > 0 else math.inf
    causes = _unit_causes(factor)
    if causes:
        cause = f"{causes[0]}?"
    elif a_deg < 1e-9 or factor > 1e4:
        cause = "a dead or unplugged angle channel?"
    else:
        cause = "no unit explains the factor"
    read_as = _read_as(units)
    raise InputError(
        f"{source}: column '{names['angle']}' moves {a_deg:.3g} deg in all while the integral "
        f"of column '{names['velocity']}' travels {v_deg:.3g} deg in {_TRAVEL_STRETCH:g} s "
        f"({cause}){read_as}; correct the angle's unit or channel"
    )


def _judge_velocity(
    check: VelocityCheck,
    *,
    source: str,
    names: Mapping[str, str],
    units: Mapping[str, str] | None,
) -> tuple[bool, list[str]]:
    """Whether to reverse the velocity, and the flags; raise for a unit factor."""
    v, a = names["velocity"], names["angle"]
    size = abs(check.ratio)
    if not check.decisive:
        note = (
            f"velocity: column '{v}' does not follow the derivative of '{a}' consistently "
            f"({check.agreement:.0%} of {check.stretches} stretches agree in sign, median "
            f"ratio {check.ratio:.3g}); not corrected"
        )
        return False, [note]
    if not 1 / VELOCITY_SCALE_LIMIT <= size <= VELOCITY_SCALE_LIMIT:
        raise InputError(_unit_message(source, check, names, units))
    said = []
    if check.ratio < 0:
        said.append(
            f"velocity: column '{v}' runs against the derivative of '{a}' (ratio "
            f"{check.ratio:.3g} over {check.stretches} stretches of motion); its sign was "
            "reversed to follow the angle"
        )
    if not 1 / VELOCITY_SCALE_FLAG <= size <= VELOCITY_SCALE_FLAG:
        said.append(
            f"velocity: column '{v}' is {size:.3g} x the derivative of '{a}' (over "
            f"{check.stretches} stretches of motion), a factor no unit explains; left as it is"
        )
    return check.ratio < 0, said


def _unit_message(
    source: str,
    check: VelocityCheck,
    names: Mapping[str, str],
    units: Mapping[str, str] | None,
) -> str:
    size = abs(check.ratio)
    causes = _unit_causes(size)
    cause = f" ({causes[0]}?)" if causes else ""
    read_as = _read_as(units)
    sign = "" if check.ratio > 0 else ", and of the opposite sign"
    return (
        f"{source}: column '{names['velocity']}' is {size:.3g} x the derivative of column "
        f"'{names['angle']}'{sign} (median over {check.stretches} stretches of motion): the "
        f"units of time, angle and velocity disagree{cause}{read_as}; correct the units of "
        "these columns"
    )


def reversals(angle: ArrayLike, sweep: float = REVERSAL_SWEEP) -> NDArray[np.int64]:
    """Indices where the motion reverses: turning points with ``sweep`` rad of travel each side.

    A zigzag over the angle: an extreme counts once the angle has moved ``sweep`` away from it,
    so quantisation steps and noise smaller than ``sweep`` are ignored. The first and last
    samples are never turning points.

    Parameters
    ----------
    angle : array_like[nsamples]
        Radians.
    sweep : float
        Travel (rad) needed on each side.

    Returns
    -------
    ndarray of int
        Sample indices of the turning points, increasing.
    """
    theta = np.asarray(angle, dtype=np.float64)
    turns: list[int] = []
    if theta.size < 3 or float(np.ptp(theta)) < sweep:
        return np.array(turns, dtype=np.int64)
    # Only the samples where the angle changes matter (a quantised slow move repeats values).
    keep = np.flatnonzero(np.concatenate(([True], np.diff(theta) != 0)))
    values = theta[keep].tolist()
    low = high = 0  # positions in ``values`` of the running extremes, before the first leg
    direction = 0  # +1 rising, -1 falling, 0 until the first leg of ``sweep`` is travelled
    extreme = 0
    for i, value in enumerate(values):
        if direction == 0:
            if value > values[high]:
                high = i
            if value < values[low]:
                low = i
            if values[high] - values[low] >= sweep:
                direction, extreme = (1, high) if high > low else (-1, low)
        elif direction > 0:
            if value > values[extreme]:
                extreme = i
            elif values[extreme] - value >= sweep:
                turns.append(extreme)
                direction, extreme = -1, i
        elif value < values[extreme]:
            extreme = i
        elif value - values[extreme] >= sweep:
            turns.append(extreme)
            direction, extreme = 1, i
    return keep[np.array(turns, dtype=np.int64)]


def magnitude_evidence(angle: ArrayLike, torque: ArrayLike, rate: float) -> str | None:
    """Evidence that a torque channel is a magnitude: never negative, ~0 where motion reverses.

    A signed moment changes sign as the motion reverses (the torque that drove the body one
    way brakes it, then drives it back); written as a magnitude it is never negative and
    falls to zero there instead. Both signs of evidence are required: a quasi-static trial's
    gravity moment may well be one-signed over a sweep back and forth, but it does not vanish
    at every reversal.

    Parameters
    ----------
    angle : array_like[nsamples]
        Radians.
    torque : array_like[nsamples]
        Any unit; NaN where the torque was not measured (ignored).
    rate : float
        Sampling rate (Hz).

    Returns
    -------
    str or None
        A phrase such as ``"never negative; near 0 at 9 of 9 reversals of the motion"``, or
        ``None`` unless the torque is never negative and falls within 2 % of its 99th
        percentile within 0.1 s of at least half of two or more reversals.
    """
    tau = np.asarray(torque, dtype=np.float64)
    measured = tau[np.isfinite(tau)]
    if measured.size == 0 or float(measured.min()) < 0:
        return None
    turns = reversals(angle)
    if turns.size < 2:
        return None
    scale = float(np.percentile(measured, 99))
    reach = max(1, round(_REVERSAL_REACH * rate))
    near = 0
    for i in turns:
        around = tau[max(i - reach, 0) : i + reach + 1]
        around = around[np.isfinite(around)]
        if around.size and float(around.min()) <= _NEAR_ZERO * scale:
            near += 1
    if near < 2 or near < 0.5 * turns.size:
        return None
    return f"never negative; near 0 at {near} of {turns.size} reversals of the motion"


def motion_direction(velocity: ArrayLike, *, floor: float = MOTION_FLOOR) -> NDArray[np.float64]:
    """The direction of motion (+1 or -1) at every sample.

    Where the shaft moves (``|velocity|`` at least ``floor`` and 5 % of its 99th percentile),
    the sign of the velocity; where it rests, the direction of the motion that follows (a
    shaft at rest before a stroke is loaded in the stroke's direction), and after the last
    motion the direction of that motion.

    Parameters
    ----------
    velocity : array_like[nsamples]
        Radians per second, with the sign of the angle's derivative.
    floor : float
        Speed (rad/s) below which the shaft is at rest.

    Returns
    -------
    ndarray of float
        +1.0 or -1.0 per sample; all zeros if the shaft never moves.
    """
    omega = np.asarray(velocity, dtype=np.float64)
    speed = np.abs(omega)
    if speed.size == 0:
        return np.zeros(0)
    moving = speed >= max(floor, 0.05 * float(np.percentile(speed, 99)))
    if not moving.any():
        return np.zeros_like(omega)
    index = np.flatnonzero(moving)
    # For every sample, the next moving sample at or after it (or the last moving one).
    nxt = np.searchsorted(index, np.arange(omega.size))
    nxt = index[np.minimum(nxt, index.size - 1)]
    return np.sign(omega[nxt])


def apply_torque_sign(trial: xr.Dataset, torque_sign: object, *, kind: str) -> xr.Dataset:
    """Give a Trial's torque its sign as the manifest's ``torque_sign`` says.

    - ``1`` or ``-1`` multiplies the torque (a device that reports the opposite sign);
    - ``"motion"`` takes a torque written as a magnitude (``torque_kind = "magnitude"``) and
      gives it the direction of motion (:func:`motion_direction`). That is right where the
      torque drives the motion: in the acceleration window of a fast trial, where the body
      speeds up from rest and the torque has the sign of the acceleration, i.e. of the
      velocity. It is wrong where the torque brakes (the end of a stroke, outside the window)
      and for a quasi-static (or rest) trial, whose gravity moment may oppose the motion:
      refused there.

    A magnitude read with ``1`` or ``-1`` is refused for a fast trial (its inertia would take
    the sign of its direction of motion, and no factor fixes both directions) and flagged for a
    quasi-static one (right only while the moment keeps one sign over the sweep).

    Parameters
    ----------
    trial : xarray.Dataset
        A Trial from :func:`make_trial`.
    torque_sign : {1, -1, "motion"}
        The manifest's value.
    kind : {"quasi-static", "fast", "rest"}
        The trial's kind (a rest trial is treated as a quasi-static one).

    Returns
    -------
    xarray.Dataset
        A copy with the torque signed, ``attrs["torque_sign"]`` set and the torque's flag
        completed.

    Raises
    ------
    InputError
        An unknown ``torque_sign``; ``"motion"`` on a quasi-static trial, on a signed torque
        (one with negative values) or on a shaft that never moves; a magnitude read with
        ``1`` or ``-1`` in a fast trial.
    """
    source = trial.attrs.get("source", "trial")
    if torque_sign not in TORQUE_SIGNS or isinstance(torque_sign, bool):
        raise InputError(f'{source}: torque_sign: expected 1, -1 or "motion", got {torque_sign!r}')
    out = trial.copy()
    torque = out["torque"].values
    flags = list(out.attrs.get("flags", ()))
    magnitude = out.attrs.get("torque_kind") == "magnitude"
    evidence = next((f for f in flags if f.startswith(MAGNITUDE_FLAG)), None)
    if torque_sign == "motion":
        if kind in ("quasi-static", "rest"):
            raise InputError(
                f'{source}: torque_sign = "motion" signs the torque by the direction of motion, '
                f"which is wrong for a {kind} trial (gravity and motion can oppose); give "
                "it torque_sign = 1 or -1, the sign of the moment that holds the body"
            )
        if float(torque.min()) < 0:
            raise InputError(
                f'{source}: torque_sign = "motion" is for a torque written as a magnitude, but '
                f"this torque is signed (down to {float(torque.min()):.4g} N m); use "
                "torque_sign = 1 or -1"
            )
        direction = motion_direction(out["velocity"].values)
        if not direction.any():
            raise InputError(
                f'{source}: torque_sign = "motion" needs motion, but the velocity never exceeds '
                f"{math.degrees(MOTION_FLOOR):g} deg/s"
            )
        out["torque"] = out["torque"].copy(data=np.abs(torque) * direction)
        note = 'signed by the direction of motion (torque_sign = "motion")'
        flags = _complete(flags, evidence, note, prefix="torque: ")
    else:
        if magnitude and kind == "fast":
            detail = f" {evidence[len(MAGNITUDE_FLAG) :].strip()}" if evidence else ""
            raise InputError(
                f"{source}: torque is written as a magnitude{detail}, not a signed moment: "
                "read as it is, the inertia takes the sign of the direction of motion; set "
                'torque_sign = "motion" for this fast trial (signs it by the direction of '
                "motion, right in its acceleration window)"
            )
        if torque_sign != 1:
            out["torque"] = out["torque"].copy(data=torque_sign * torque)
        if magnitude:
            note = (
                f"read x torque_sign = {torque_sign}: right only while the moment keeps one "
                "sign over the sweep"
            )
            flags = _complete(flags, evidence, note, prefix="torque: ")
    out.attrs["flags"] = tuple(flags)
    out.attrs["torque_sign"] = torque_sign
    return out


def _complete(flags: list[str], flag: str | None, note: str, *, prefix: str) -> list[str]:
    """``flags`` with ``flag`` followed by ``note`` (or ``note`` alone, as a new flag)."""
    if flag is None:
        return [*flags, prefix + note]
    return [f"{f}; {note}" if f == flag else f for f in flags]
