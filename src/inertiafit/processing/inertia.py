"""Moment of inertia of a condition from one fast trial.

Inside the uniform-acceleration window the gravity model of the same condition (from its
quasi-static trial, :class:`~inertiafit.processing.gravity.GravityFit`) is subtracted from the
torque, ``y = tau - M_g sin(theta + phi) - c``, and two estimators are reported side by side:

- ``inertia``: least squares of ``y = I alpha`` through the origin, ``sum(alpha y) /
  sum(alpha^2)``, with a standard error corrected for the autocorrelation of the (filtered)
  residuals;
- ``inertia_frame_mean``: the paper's estimator, the mean over frames of ``y / alpha``.

With the acceleration nearly uniform in the window the two agree closely; least squares weighs
frames by ``alpha^2`` and so leans on the frames where the ratio is best determined.

The torque and the gravity model go through the same zero-lag filter as the velocity, so the
filtered torque and the acceleration derived from the filtered velocity see the same filter.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from inertiafit.errors import InputError
from inertiafit.io.trial import apply_torque_sign
from inertiafit.processing.filtering import (
    CUTOFF,
    ORDER,
    lowpass_arrays,
    sampling_rate,
    source_of,
)
from inertiafit.processing.gravity import GravityFit, integrated_autocorrelation_time
from inertiafit.processing.window import LEVEL, MIN_SPEED_CHANGE, TOLERANCE, find_window_arrays

__all__ = [
    "NEGATIVE_SE",
    "SATURATION_RUN",
    "InertiaEstimate",
    "estimate_inertia",
    "saturated_run",
]

#: Identical samples at a channel's largest magnitude that count as saturation (clipping).
SATURATION_RUN = 5
#: An inertia below zero by more than this many standard errors is an error, not a flag.
NEGATIVE_SE = 3.0

_SIGN_HINT = "torque sign: set torque_sign = -1 for this trial in the manifest"


@dataclass(frozen=True)
class InertiaEstimate:
    """Moment of inertia of one fast trial.

    Attributes
    ----------
    inertia : float
        Least-squares estimate through the origin (kg m^2), about the joint.
    inertia_se : float
        Its standard error (kg m^2), corrected for autocorrelated residuals.
    inertia_frame_mean : float
        The paper's estimator: mean over the window of ``(tau - G) / alpha`` (kg m^2).
    window_start, window_end : float
        Times (s) of the first and last sample of the window.
    n_window : int
        Samples in the window.
    residual_rms : float
        RMS of ``tau - G - I alpha`` in the window (N m).
    flags : tuple of str
        Problems worth a look, one line each (a study lists them as ``"file: flag"``).
    source : str
        The trial's file.
    velocity, acceleration : ndarray or None
        The filtered velocity (rad/s) and acceleration (rad/s^2) of the whole trial, on its
        time samples, that the estimate was made from (for figures of the window).
    """

    inertia: float
    inertia_se: float
    inertia_frame_mean: float
    window_start: float
    window_end: float
    n_window: int
    residual_rms: float
    flags: tuple[str, ...] = ()
    source: str = ""
    velocity: NDArray | None = field(default=None, repr=False, compare=False)
    acceleration: NDArray | None = field(default=None, repr=False, compare=False)


def saturated_run(x: NDArray, *, run: int = SATURATION_RUN) -> int:
    """Length of the longest run of identical samples at the largest magnitude of ``x``.

    Returns 0 unless that run is at least ``run`` samples long.
    """
    x = np.asarray(x)
    if x.size == 0:
        return 0
    peak = np.max(np.abs(x))
    if peak == 0:
        return 0
    at_peak = np.abs(x) == peak
    same = np.concatenate([[True], x[1:] == x[:-1]])
    padded = np.concatenate([[0], (at_peak & same).astype(np.int8), [0]])
    # A run of k identical samples shows as k-1 consecutive "same as previous" marks.
    edges = np.flatnonzero(np.diff(padded))
    longest = int(np.max(edges[1::2] - edges[::2])) + 1 if edges.size else 1
    return longest if longest >= run else 0


def estimate_inertia(
    trial: xr.Dataset,
    gravity: GravityFit,
    *,
    window: Sequence[float] | None = None,
    speed_deg_s: float | None = None,
    torque_sign: int = 1,
    cutoff: float = CUTOFF,
    order: int = ORDER,
) -> InertiaEstimate:
    """Estimate the moment of inertia from a fast trial.

    Parameters
    ----------
    trial : xarray.Dataset
        A fast Trial (``time`` s, ``angle`` rad, ``velocity`` rad/s, ``torque`` N m), raw.
    gravity : GravityFit
        Gravity model of the same condition, from its quasi-static trial.
    window : (float, float), optional
        Manual uniform-acceleration window (s); default ``trial.attrs["window"]`` if present,
        else detected (:func:`~inertiafit.processing.window.find_window`).
    speed_deg_s : float, optional
        Preset speed (deg/s); default ``trial.attrs["speed"]``.
    torque_sign : {1, -1}
        Multiplies the torque (a device that reports the opposite sign).
    cutoff, order
        Zero-lag Butterworth low-pass applied to torque and velocity.

    Returns
    -------
    InertiaEstimate
        Both estimators, the window, flags (short window, slightly negative inertia, saturated
        torque or velocity) and the filtered velocity and acceleration.

    Raises
    ------
    InputError
        If ``torque_sign`` is not +-1, the trial is too short or has no usable window, or the
        inertia is negative by more than ``NEGATIVE_SE`` standard errors (with the hint to set
        ``torque_sign = -1``).
    """
    # Works on the trial's numpy arrays: xarray's copies and assignments cost more than the
    # filtering itself.
    source = source_of(trial)
    if torque_sign not in (1, -1):
        raise InputError(f"{source}: torque_sign: expected +1 or -1, got {torque_sign!r}")
    if trial.attrs.get("torque_kind") == "magnitude" and "torque_sign" not in trial.attrs:
        # read with read_trial and never signed: refuse with the real cause, not a negative
        # inertia and a torque_sign = -1 hint that cannot help
        apply_torque_sign(trial, torque_sign, kind="fast")
    rate = sampling_rate(trial)
    time = trial["time"].values
    raw_torque = torque_sign * trial["torque"].values
    raw_velocity = trial["velocity"].values
    # Subtract the gravity model before filtering: by linearity the same as filtering both,
    # and the model then passes through exactly the filter the torque does.
    net = raw_torque - gravity.torque(trial["angle"].values)
    torque_f, velocity_f, alpha_f = lowpass_arrays(
        time, net, raw_velocity, rate, cutoff=cutoff, order=order, source=source
    )
    win = find_window_arrays(
        time,
        velocity_f,
        alpha_f,
        source=source,
        window=window if window is not None else trial.attrs.get("window"),
        speed_deg_s=speed_deg_s if speed_deg_s is not None else trial.attrs.get("speed"),
        level=LEVEL,
        tolerance=TOLERANCE,
        min_speed_change=MIN_SPEED_CHANGE,
    )
    sl = slice(win.start_index, win.stop_index)
    y = torque_f[sl]
    alpha = alpha_f[sl]

    sxx = float(alpha @ alpha)
    value = float(alpha @ y) / sxx
    residuals = y - value * alpha
    n = residuals.size
    sigma2 = float(residuals @ residuals) / max(n - 1, 1)
    tau = integrated_autocorrelation_time(residuals)
    se = math.sqrt(sigma2 * tau / sxx)
    frame_mean = float(np.mean(y / alpha))

    flags = list(win.flags)
    if value < 0:
        if value + NEGATIVE_SE * se < 0:
            raise InputError(
                f"{source}: torque: inertia {value:.4g} kg m^2 is negative (the torque opposes "
                f"the acceleration in the window {win.start:.4g} to {win.end:.4g} s); "
                f"{_SIGN_HINT}"
            )
        flags.append(f"negative inertia {value:.3g} +- {se:.2g} kg m^2; {_SIGN_HINT}")
    clipped = saturated_run(raw_torque)
    if clipped:
        flags.append(
            f"saturation: torque stays at {raw_torque[np.argmax(np.abs(raw_torque))]:.4g} N m "
            f"for {clipped} samples (clipped?)"
        )
    clipped = saturated_run(raw_velocity[sl])
    if clipped:
        flags.append(
            f"saturation: velocity stays at its largest value for {clipped} samples inside "
            "the acceleration window (clipped?)"
        )
    return InertiaEstimate(
        inertia=value,
        inertia_se=se,
        inertia_frame_mean=frame_mean,
        window_start=win.start,
        window_end=win.end,
        n_window=int(n),
        residual_rms=float(np.sqrt(np.mean(residuals**2))),
        flags=tuple(flags),
        source=source,
        velocity=velocity_f,
        acceleration=alpha_f,
    )
