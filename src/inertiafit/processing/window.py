"""The uniform-acceleration window of a fast trial (the grey box of the paper's Fig. 4).

A person finds the window by eye on the velocity trace: the stretch where the velocity climbs
along a straight line, from where it leaves rest to where it bends over towards (or past) the
preset speed. The rule does the same on the filtered velocity ``v`` (:func:`lowpass`) rather
than on the acceleration ``alpha``: ``alpha`` is the derivative of ``v`` and shows a servo
ripple near the filter's cut-off at full strength (+-25 % around its plateau is common), while
``v`` integrates it (a ripple of +-30 % of the acceleration at 10 Hz moves a 240 deg/s ramp
off its straight line by about 3 % of its rise).

1. **Direction and speed.** ``s`` is the sign of the velocity at its largest magnitude and
   ``u = s v``. The reference speed ``V`` is the preset speed (the trial's ``speed``
   attribute or argument, deg/s) or, without one, the median of ``u`` where it exceeds half
   its maximum (the speed the trial settles at: with a start overshoot the top speed can be
   twice it). A trial slower than ``MIN_SPEED`` = 10 deg/s has no window.
2. **The rise.** The search ends at the first peak of ``u``: its largest value before it
   first falls more than ``DROP`` (10 %) of ``V`` below its running maximum, or the trial's
   top speed if it never does. A start overshoot (up to twice the preset speed) settles back
   after that peak; braking ends a trial without one. The rise may pass the preset speed:
   a uniform acceleration that carries the speed past it is still one. Only the rise itself
   is searched: from the last sample within 2 % (of the rise) of its bottom to the first
   within 5 % of its top, widened by a quarter of that on each side.
3. **The straight stretch.** Among the stretches of the rise, the longest (in time) whose
   least-squares line ``u = u0 + b t`` has a positive slope ``b``, an rms deviation of ``u``
   from the line of at most ``tolerance`` (default 3 %) of the line's rise ``b T`` over the
   stretch, and a rise ``b T`` of at least ``min_speed_change`` (default one half) of ``V``.
   At most ``CANDIDATES`` start and end points are tried (every k-th sample on long rises);
   the next step places the ends to the sample.
4. **The ends.** The window runs from the first to the last sample of that stretch where
   ``s alpha`` reaches ``level`` (default one half) of ``b``. A loose line reaches a little
   into the rounded corners of the filtered ramp; a zero-lag filter rounds a corner of the
   true ramp symmetrically, so the filtered acceleration passes half its plateau at the true
   corner and the window ends there. A ripple of +-30 % never takes it that low inside the
   ramp.
5. **Checks.** The window must hold ``MIN_WINDOW`` samples and carry ``u`` through
   ``min_speed_change`` of ``V``; otherwise the trial has no usable window (a quasi-static
   trial, a trial that starts at speed, a profile without a ramp), an ``InputError`` naming
   the file, what was looked for and the manifest's ``window = [t0, t1]``.

A manual window (argument, or ``trial.attrs["window"]`` from the manifest) overrides all of
this. Windows under ``MIN_SAMPLES`` samples or ``MIN_DURATION`` seconds are flagged: at
100 Hz a 180 deg/s ramp holds about 10 samples.
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
    "CANDIDATES",
    "DROP",
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
    "plateau_speed",
]

#: The window's ends: where the acceleration reaches this fraction of the fitted slope.
LEVEL = 0.5
#: Largest rms deviation from the straight line, as a fraction of the line's rise.
TOLERANCE = 0.03
#: The rise ends where the speed first falls this fraction of the reference speed below its
#: running maximum (the first peak).
DROP = 0.1
#: Most start (and end) points of the straight stretch tried; longer rises are subsampled.
CANDIDATES = 120
#: The window must change the speed by at least this fraction of the reference speed.
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
    level : float
        The window's ends: where the acceleration reaches this fraction of the fitted slope.
    tolerance : float
        Largest rms deviation of the velocity from its straight line, as a fraction of the
        line's rise over the stretch.
    min_speed_change : float
        Least change of speed in the window, as a fraction of the reference speed.
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


def plateau_speed(u: NDArray) -> float:
    """A trial's constant speed: the median of ``u`` where it exceeds half its top."""
    top = float(np.max(u))
    return float(np.median(u[u >= 0.5 * top]))


def _reference_speed(u: NDArray, speed_deg_s: float | None) -> float:
    """The preset speed (rad/s), else the plateau of ``u`` (:func:`plateau_speed`)."""
    if speed_deg_s:
        return math.radians(float(speed_deg_s))
    return plateau_speed(u)


def _rise(u: NDArray, reference: float) -> tuple[int, int, int]:
    """``(first, stop, peak)``: the part of the trial searched, and its first peak."""
    running = np.maximum.accumulate(u)
    fell = np.flatnonzero((u < running - DROP * reference) & (running >= 0.5 * reference))
    end = int(fell[0]) if fell.size else u.size
    peak = int(np.argmax(u[:end]))
    floor = float(np.min(u[: peak + 1]))
    span = float(u[peak]) - floor
    # From the last sample near the bottom of the rise to the first near its top, with a
    # margin of a quarter of that on each side: a straight stretch reaching further would lie
    # along the flat before the ramp or the speed after it.
    low = int(np.flatnonzero(u[: peak + 1] <= floor + 0.02 * span)[-1])
    high = low + int(np.argmax(u[low : peak + 1] >= u[peak] - 0.05 * span))
    margin = (high - low) // 4
    return max(0, low - margin), min(peak, high + margin) + 1, peak


def _straight_stretches(
    t: NDArray, u: NDArray, bounds: NDArray
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Least-squares lines of ``u`` on ``t`` over every stretch ``[bounds[i], bounds[j])``.

    Returns the matrices (rows: start, columns: end) of sample counts, slopes, rms deviations
    from the line and durations; entries with ``j <= i`` are meaningless (NaN or negative).
    """
    lo = int(bounds[0])
    tt = t[lo : bounds[-1]] - t[lo]
    uu = u[lo : bounds[-1]] - u[lo]
    k = bounds - lo

    def between(x: NDArray) -> NDArray:
        sums = np.concatenate(([0.0], np.cumsum(x)))[k]
        return sums[None, :] - sums[:, None]

    n = between(np.ones_like(tt))
    st, su = between(tt), between(uu)
    with np.errstate(divide="ignore", invalid="ignore"):
        sxx = between(tt * tt) - st * st / n
        sxy = between(tt * uu) - st * su / n
        syy = between(uu * uu) - su * su / n
        slope = sxy / sxx
        rms = np.sqrt(np.maximum(syy - slope * sxy, 0.0) / n)
    starts = t[np.minimum(bounds, t.size - 1)]
    ends = t[np.maximum(bounds - 1, 0)]
    return n, slope, rms, ends[None, :] - starts[:, None]


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
    u = direction * np.asarray(velocity, dtype=np.float64)
    reference = _reference_speed(u, speed_deg_s)
    slowest = math.degrees(min(reference, float(u[top])))
    if not slowest >= MIN_SPEED:
        raise InputError(
            f"{source}: no uniform-acceleration window: the trial never moves faster than "
            f"{slowest:.3g} deg/s (a fast trial reaches its preset speed, >= {MIN_SPEED:g} "
            f"deg/s; is it quasi-static?); {_hint(source)}"
        )
    first, stop, peak = _rise(u, reference)
    need = min_speed_change * reference
    looked_for = (
        f"no uniform-acceleration window: looked for the longest stretch before the first "
        f"peak of the speed ({math.degrees(u[peak]):.4g} deg/s at {t[peak]:.4g} s) "
        f"where the filtered velocity rises along a straight line (rms deviation <= "
        f"{tolerance:.0%} of the rise) by at least {min_speed_change:.0%} of "
        f"{math.degrees(reference):.4g} deg/s"
    )
    step = max(1, math.ceil((stop - first) / CANDIDATES))
    bounds = np.arange(first, stop + 1, step)
    if bounds[-1] != stop:
        bounds = np.append(bounds, stop)
    n, slope, rms, duration = _straight_stretches(t, u, bounds)
    with np.errstate(invalid="ignore"):
        rise = slope * duration
        straight = (n >= MIN_WINDOW) & (slope > 0) & (rms <= tolerance * rise)
        ok = straight & (rise >= need)
    if not ok.any():
        if straight.any():
            i, j = np.unravel_index(np.argmax(np.where(straight, rise, -np.inf)), rise.shape)
            lo, hi = int(bounds[i]), int(bounds[j])
            found = (
                f"the straight stretch that rises most ({t[lo]:.4g} to {t[hi - 1]:.4g} s) "
                f"rises by {math.degrees(u[hi - 1] - u[lo]):.3g} deg/s"
            )
        else:
            found = "no stretch of it is straight and rising"
        raise InputError(f"{source}: {looked_for}; {found}; {_hint(source)}")
    i, j = np.unravel_index(np.argmax(np.where(ok, duration, -np.inf)), duration.shape)
    lo, hi = int(bounds[i]), int(bounds[j])
    accelerating = np.flatnonzero(direction * alpha[lo:hi] >= level * slope[i, j])
    if accelerating.size:
        lo, hi = lo + int(accelerating[0]), lo + int(accelerating[-1]) + 1
    change = u[hi - 1] - u[lo] if hi > lo else 0.0
    if not accelerating.size or hi - lo < MIN_WINDOW or change < need:
        raise InputError(
            f"{source}: {looked_for}; inside the straight stretch ({t[bounds[i]]:.4g} to "
            f"{t[bounds[j] - 1]:.4g} s) the acceleration reaches {level:.0%} of the line's "
            f"slope on {hi - lo if accelerating.size else 0} samples, which change the speed "
            f"by {math.degrees(change):.3g} deg/s; {_hint(source)}"
        )
    return lo, hi
