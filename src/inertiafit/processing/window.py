"""The uniform-acceleration window of a fast trial (the grey box of the paper's Fig. 4).

Rule, on the filtered velocity ``v`` and acceleration ``alpha`` (:func:`lowpass`):

1. The direction of the move ``s`` is the sign of the velocity at its largest magnitude; the
   search runs from the start of the trial to the first sample where ``s v`` reaches the preset
   speed (the trial's ``speed`` attribute or argument, deg/s; without one, the top speed of the
   trial). Everything after it (isokinetic overshoot, ripple at speed, braking) is ignored.
2. The plateau level ``P``: the median of ``s alpha`` over the longest run where it exceeds
   ``level`` (default one half) of its maximum in the search region.
3. The window is the longest contiguous run where ``s alpha`` stays within ``tolerance``
   (default +-25 %) of ``P``.
4. It must carry the velocity through at least ``min_speed_change`` (default one half) of the
   preset speed (and the trial must reach at least ``MIN_SPEED`` = 10 deg/s); otherwise the trial has no usable window (a quasi-static trial, a trial that
   starts at speed, a profile without a uniform ramp).

A symmetric (zero-lag) filter turns the corners of the velocity ramp into transitions centred
on the true corners; the +-25 % band trims a few milliseconds at each end where the filtered
acceleration is still rising or falling.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.processing.filtering import CUTOFF, ORDER, lowpass, source_of

__all__ = [
    "LEVEL",
    "MIN_DURATION",
    "MIN_SAMPLES",
    "MIN_SPEED",
    "MIN_SPEED_CHANGE",
    "MIN_WINDOW",
    "TOLERANCE",
    "AccelerationWindow",
    "find_window",
    "find_window_arrays",
]

#: Fraction of the peak acceleration that defines the candidate plateau.
LEVEL = 0.5
#: Relative band around the plateau level that counts as uniform acceleration.
TOLERANCE = 0.25
#: The window must change the velocity by at least this fraction of the preset speed.
MIN_SPEED_CHANGE = 0.5
#: A window with fewer samples, or shorter than ``MIN_DURATION`` seconds, is flagged short.
MIN_SAMPLES = 20
MIN_DURATION = 0.02
#: Fewest samples a window may have at all.
MIN_WINDOW = 3
#: A fast trial must reach this speed (deg/s); slower ones have no acceleration worth fitting.
MIN_SPEED = 10.0


@dataclass(frozen=True)
class AccelerationWindow:
    """The uniform-acceleration period of a fast trial.

    Attributes
    ----------
    start, end : float
        Times (s) of the first and last sample in the window.
    n : int
        Number of samples in the window.
    start_index, stop_index : int
        The window is ``trial.isel(time=slice(start_index, stop_index))``.
    level : float
        Median acceleration in the window (rad/s^2), signed.
    manual : bool
        Whether the window was given rather than detected.
    flags : tuple of str
        ``"short window ..."`` when the window is shorter than ``MIN_SAMPLES`` samples or
        ``MIN_DURATION`` seconds.
    """

    start: float
    end: float
    n: int
    start_index: int
    stop_index: int
    level: float
    manual: bool = False
    flags: tuple[str, ...] = ()


def _runs(mask: NDArray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True in a boolean array."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _longest(mask: NDArray) -> tuple[int, int] | None:
    runs = _runs(mask)
    if not runs:
        return None
    return max(runs, key=lambda r: r[1] - r[0])


def _hint(source: str) -> str:
    return (
        f"set window = [t0, t1] (s) for {source} in the manifest's [[trials]] entry, "
        "or pass window=(t0, t1)"
    )


def find_window(
    trial: xr.Dataset,
    *,
    window: Sequence[float] | None = None,
    speed_deg_s: float | None = None,
    level: float = LEVEL,
    tolerance: float = TOLERANCE,
    min_speed_change: float = MIN_SPEED_CHANGE,
    cutoff: float = CUTOFF,
    order: int = ORDER,
) -> AccelerationWindow:
    """Find the uniform-acceleration window of a fast trial (rule in the module docstring).

    Parameters
    ----------
    trial : xarray.Dataset
        A fast Trial, raw or already filtered by :func:`lowpass` (then it has an
        ``acceleration`` variable and is used as is).
    window : (float, float), optional
        Manual window ``(t0, t1)`` in seconds of the trial's time; overrides detection. If not
        given, ``trial.attrs["window"]`` (set from the manifest) is used when present.
    speed_deg_s : float, optional
        Preset speed (deg/s); default ``trial.attrs["speed"]``, else the trial's top speed.
    level, tolerance, min_speed_change : float
        Parameters of the rule.
    cutoff, order
        Low-pass filter, when the trial is raw.

    Returns
    -------
    AccelerationWindow
        Times, sample indices, count and flags (``"short window ..."``).

    Raises
    ------
    InputError
        If no window satisfies the rule, or a manual window is malformed, outside the trial or
        holds fewer than ``MIN_WINDOW`` samples; the message names the file.
    """
    source = source_of(trial)
    filtered = trial if "acceleration" in trial else lowpass(trial, cutoff=cutoff, order=order)
    if window is None and "window" in trial.attrs:
        window = tuple(np.ravel(trial.attrs["window"]).tolist())
    return find_window_arrays(
        filtered["time"].values,
        filtered["velocity"].values,
        filtered["acceleration"].values,
        source=source,
        window=window,
        speed_deg_s=speed_deg_s if speed_deg_s is not None else trial.attrs.get("speed"),
        level=level,
        tolerance=tolerance,
        min_speed_change=min_speed_change,
    )


def find_window_arrays(
    time: NDArray,
    velocity: NDArray,
    acceleration: NDArray,
    *,
    source: str = "<trial>",
    window: Sequence[float] | None = None,
    speed_deg_s: float | None = None,
    level: float = LEVEL,
    tolerance: float = TOLERANCE,
    min_speed_change: float = MIN_SPEED_CHANGE,
) -> AccelerationWindow:
    """:func:`find_window` on arrays: filtered velocity (rad/s) and acceleration (rad/s^2).

    ``window`` and ``speed_deg_s`` are used as given (no trial attrs to fall back on);
    ``source`` names the file in messages. Raises as :func:`find_window`.
    """
    t = np.asarray(time, dtype=np.float64)
    alpha = np.asarray(acceleration)
    if window is not None:
        start, stop = _manual(t, window, source)
        manual = True
    else:
        start, stop = _detect(
            t,
            np.asarray(velocity),
            alpha,
            source=source,
            speed_deg_s=speed_deg_s,
            level=level,
            tolerance=tolerance,
            min_speed_change=min_speed_change,
        )
        manual = False
    n = stop - start
    duration = t[stop - 1] - t[start]
    flags = []
    if n < MIN_SAMPLES or duration < MIN_DURATION:
        flags.append(
            f"short window: {n} samples over {duration * 1e3:.3g} ms "
            f"(< {MIN_SAMPLES} samples or < {MIN_DURATION * 1e3:g} ms)"
        )
    return AccelerationWindow(
        start=float(t[start]),
        end=float(t[stop - 1]),
        n=int(n),
        start_index=int(start),
        stop_index=int(stop),
        level=float(np.median(alpha[start:stop])),
        manual=manual,
        flags=tuple(flags),
    )


def _manual(t: NDArray, window: Sequence[float], source: str) -> tuple[int, int]:
    try:
        t0, t1 = (float(v) for v in window)
    except (TypeError, ValueError):
        raise InputError(
            f"{source}: window: expected two times [t0, t1] in seconds, got {window!r}"
        ) from None
    if not t0 < t1:
        raise InputError(f"{source}: window: start {t0:g} s must be before end {t1:g} s")
    if t1 < t[0] or t0 > t[-1]:
        raise InputError(
            f"{source}: window: [{t0:g}, {t1:g}] s lies outside the trial "
            f"({t[0]:g} to {t[-1]:g} s)"
        )
    start = int(np.searchsorted(t, t0, side="left"))
    stop = int(np.searchsorted(t, t1, side="right"))
    if stop - start < MIN_WINDOW:
        raise InputError(
            f"{source}: window: [{t0:g}, {t1:g}] s holds {stop - start} samples; "
            f"need at least {MIN_WINDOW}"
        )
    return start, stop


def _detect(
    t: NDArray,
    velocity: NDArray,
    alpha: NDArray,
    *,
    source: str,
    speed_deg_s: float | None,
    level: float,
    tolerance: float,
    min_speed_change: float,
) -> tuple[int, int]:
    """Indices ``(start, stop)`` of the detected window; see the module docstring."""
    top = int(np.argmax(np.abs(velocity)))
    direction = 1.0 if velocity[top] >= 0 else -1.0
    v = direction * velocity
    a = direction * alpha
    target = math.radians(float(speed_deg_s)) if speed_deg_s else float(v[top])
    reached = np.flatnonzero(v >= target)
    limit = int(reached[0]) + 1 if reached.size else top + 1
    looked_for = (
        f"no uniform-acceleration window: looked for the longest run where the filtered "
        f"acceleration stays within +-{tolerance:.0%} of its plateau before the velocity "
        f"reaches {math.degrees(target):.4g} deg/s"
    )
    if math.degrees(target) < MIN_SPEED:
        raise InputError(
            f"{source}: no uniform-acceleration window: the trial never moves faster than "
            f"{math.degrees(target):.3g} deg/s (a fast trial reaches its preset speed, "
            f">= {MIN_SPEED:g} deg/s; is it quasi-static?); {_hint(source)}"
        )
    a = a[:limit]
    peak = float(a.max()) if a.size else 0.0
    if not peak > 0:
        raise InputError(f"{source}: {looked_for}, but it never accelerates; {_hint(source)}")
    run = _longest(a >= level * peak)
    plateau = float(np.median(a[run[0] : run[1]])) if run else peak
    run = _longest(np.abs(a - plateau) <= tolerance * plateau)
    if run is None or run[1] - run[0] < MIN_WINDOW:
        raise InputError(f"{source}: {looked_for}; {_hint(source)}")
    start, stop = run
    change = v[stop - 1] - v[start]
    if change < min_speed_change * target:
        raise InputError(
            f"{source}: {looked_for}; the best run ({t[start]:.4g} to {t[stop - 1]:.4g} s) "
            f"changes the speed by {math.degrees(change):.3g} deg/s, less than "
            f"{min_speed_change:.0%} of it; {_hint(source)}"
        )
    return start, stop
