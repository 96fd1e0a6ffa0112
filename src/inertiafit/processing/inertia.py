"""Moment of inertia of a condition from one fast trial.

Inside the uniform-acceleration window the gravity model of the same condition (from its
quasi-static trial, :class:`~inertiafit.processing.gravity.GravityFit`) is subtracted from the
torque, ``y = tau - M_g sin(theta + phi) - c``, and two estimators are reported side by side:

- ``inertia``: least squares of ``y = I alpha`` through the origin, ``sum(alpha y) /
  sum(alpha^2)``, with a standard error from the channels' noise model (white noise and a
  drift of the torque, white noise of the velocity) carried through the estimate's linear
  algebra (:func:`trial_noise`; ``docs/processing.md``, "A fast trial's standard error");
- ``inertia_frame_mean``: the paper's estimator, the mean over frames of ``y / alpha``.

With the acceleration nearly uniform in the window the two agree closely; least squares weighs
frames by ``alpha^2`` and so leans on the frames where the ratio is best determined.

The torque and the gravity model go through the same zero-lag filter as the velocity, so the
filtered torque and the acceleration derived from the filtered velocity see the same filter.

Before that, the lag of the torque channel behind the velocity is removed: estimated over the
whole move (:func:`~inertiafit.processing.lag.estimate_lag`) or fixed by the manifest, the
filtered torque is advanced by it (:func:`~inertiafit.processing.lag.advance`).

The gravity model subtracted is ``A sin(theta) + B cos(theta) + C`` (``A = M_g cos(phi)``,
``B = M_g sin(phi)``, ``C = c``); :attr:`InertiaEstimate.gravity_sensitivity` is the
derivative of the reported inertia with respect to ``(A, B, C)``, for carrying the gravity
model's error, which every fast trial of a condition shares.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from inertiafit.errors import InputError
from inertiafit.io.trial import apply_torque_sign
from inertiafit.io.units import QUANTITIES
from inertiafit.processing.filtering import (
    CUTOFF,
    ORDER,
    differentiator,
    lowpass_rows,
    sampling_rate,
    source_of,
)
from inertiafit.processing.gravity import (
    GravityFit,
    TorqueNoise,
    white_level,
)
from inertiafit.processing.lag import LAG_BOUNDS, advance, estimate_lag
from inertiafit.processing.living import StaticCurve
from inertiafit.processing.window import LEVEL, MIN_SPEED_CHANGE, TOLERANCE, find_window_arrays
from inertiafit.stats import integrated_autocorrelation_time

__all__ = [
    "LAG_SOURCES",
    "NEGATIVE_SE",
    "SATURATION_RUN",
    "InertiaEstimate",
    "estimate_inertia",
    "gravity_coefficients",
    "saturated_run",
    "torque_sign_hint",
    "trial_noise",
]

#: Identical samples at a channel's largest magnitude that count as saturation (clipping).
SATURATION_RUN = 5
#: An inertia below zero by more than this many standard errors is an error, not a flag.
NEGATIVE_SE = 3.0
#: Where a trial's lag comes from: estimated from the trial, or fixed by the manifest.
LAG_SOURCES = ("estimated", "manifest")


def _sign_hint(trial: xr.Dataset, torque_sign: int) -> str:
    """What to change about the torque's sign: never the value already set."""
    return torque_sign_hint(trial.attrs.get("torque_sign", 1), torque_sign)


def torque_sign_hint(given: int | str, torque_sign: int = 1) -> str:
    """What to change about a trial's torque sign, given its manifest's ``torque_sign``.

    Never the value already set: a trial read with ``torque_sign = -1`` is told to set 1, one
    signed by ``"motion"`` to check its columns.
    """
    if given == "motion":
        return (
            'torque sign: torque_sign = "motion" is set; check that the columns hold this '
            "trial's torque and velocity"
        )
    if int(given) * torque_sign == -1:
        return "torque sign: the torque is already flipped (torque_sign = -1); set torque_sign = 1"
    return "torque sign: set torque_sign = -1 for this trial in the manifest"


@dataclass(frozen=True)
class InertiaEstimate:
    """Moment of inertia of one fast trial.

    Attributes
    ----------
    inertia : float
        Least-squares estimate through the origin (kg m^2), about the joint.
    inertia_se : float
        Its standard error (kg m^2): ``sqrt(w' Sigma w)`` for the estimate's weights ``w`` on
        the raw torque (through the filter, the window and the estimated lag) and the noise
        model's covariance ``Sigma`` (:func:`trial_noise`), plus the velocity noise's part.
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
    inertial_torque : ndarray or None
        The torque the inertia was fitted to, on the same samples (N m): the filtered torque,
        advanced by the lag, less the subtracted gravity model (a living body's: less its
        static curve, the fitted damping ``b omega`` and the trial's constant ``c_t``). Its
        least squares on ``acceleration`` through the origin, over the window's samples (a
        living trial's: the acceleration's and the deceleration's), is ``inertia``.
    lag : float
        Seconds the torque channel lags the velocity (positive: the torque is late), removed
        before the estimate: estimated, or fixed by the manifest (``lag_source``).
    lag_se : float
        Its standard error (s); 0 when fixed by the manifest, NaN when it could not be
        estimated (a flag says so, and no lag was removed).
    lag_source : {"estimated", "manifest"}
        Where ``lag`` comes from.
    gravity_sensitivity : tuple of float
        ``dI/d(A, B, C)`` (kg m^2 per N m) for the subtracted gravity model ``A sin(theta) +
        B cos(theta) + C``: how the reported inertia moves with an error of the gravity
        model, including the estimated lag's response to it. For a living body's condition
        (a :class:`StaticCurve`), ``dI/d gamma`` for every coefficient of its static curve.
    damping, damping_se : float
        A living body's viscous damping ``b`` (N m s/rad) and its standard error, fitted with
        the inertia over the acceleration and the deceleration windows; ``None`` for a
        rigid condition.
    inertia_damping_cov : float
        Covariance of the errors of ``inertia`` and ``damping`` (``None`` for a rigid
        condition).
    deceleration_start, deceleration_end : float
        Times (s) of the deceleration window used with the acceleration window (``None``
        for a rigid condition).
    damping_sensitivity : tuple of float
        ``d b / d gamma`` for the static curve's coefficients (as ``gravity_sensitivity``
        for the inertia); empty for a rigid condition.
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
    inertial_torque: NDArray | None = field(default=None, repr=False, compare=False)
    lag: float = 0.0
    lag_se: float = 0.0
    lag_source: str = "manifest"
    gravity_sensitivity: tuple[float, ...] = (math.nan, math.nan, math.nan)
    damping: float | None = None
    damping_se: float | None = None
    inertia_damping_cov: float | None = None
    deceleration_start: float | None = None
    deceleration_end: float | None = None
    damping_sensitivity: tuple[float, ...] = ()


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
    gravity: GravityFit | StaticCurve,
    *,
    window: Sequence[float] | None = None,
    speed_deg_s: float | None = None,
    torque_sign: int = 1,
    cutoff: float = CUTOFF,
    order: int = ORDER,
    lag: float | None = None,
    lag_bounds: Sequence[float] = LAG_BOUNDS,
    refuse_negative: bool = True,
    noise: TorqueNoise | None = None,
) -> InertiaEstimate:
    """Estimate the moment of inertia from a fast trial.

    Parameters
    ----------
    trial : xarray.Dataset
        A fast Trial (``time`` s, ``angle`` rad, ``velocity`` rad/s, ``torque`` N m), raw.
    gravity : GravityFit or StaticCurve
        Gravity model of the same condition, from its quasi-static trial; for a condition
        that holds a living body, the static curve of its posture and direction
        (:meth:`~inertiafit.processing.living.LivingStatics.curve`): the inertia and the
        viscous damping are then fitted together over the acceleration and the deceleration
        windows (``damping``).
    window : (float, float), optional
        Manual uniform-acceleration window (s); default ``trial.attrs["window"]`` if present,
        else detected (:func:`~inertiafit.processing.window.find_window`).
    speed_deg_s : float, optional
        Preset speed (deg/s); default ``trial.attrs["speed"]``.
    torque_sign : {1, -1}
        Multiplies the torque (a device that reports the opposite sign).
    cutoff, order
        Zero-lag Butterworth low-pass applied to torque and velocity.
    lag : float, optional
        The torque channel's lag behind the velocity (s), fixed; default
        ``trial.attrs["lag"]`` if present (the manifest's ``lag``), else estimated
        (:func:`~inertiafit.processing.lag.estimate_lag`). ``lag=0`` removes none.
    lag_bounds : (float, float)
        Search range (s) of the estimated lag.
    refuse_negative : bool
        Refuse (or flag) a negative inertia here (default). ``False``: return it as it is, for
        a caller that judges a condition's fast trials together (a torque sign is advised only
        where they agree: :func:`~inertiafit.processing.plausibility.inertia_sign_checks`).
    noise : TorqueNoise, optional
        The torque's noise model for the standard errors; default :func:`trial_noise`: the
        white level of this trial, the drift of ``gravity.noise`` (the condition's sweeps).

    Returns
    -------
    InertiaEstimate
        Both estimators, the window, the lag removed, the sensitivity to the gravity model,
        flags (short window, slightly negative inertia, saturated torque or velocity, a lag at
        a bound of ``lag_bounds`` or not estimated) and the filtered velocity and
        acceleration.

    Raises
    ------
    InputError
        If ``torque_sign`` is not +-1, ``lag`` is not a finite number or ``lag_bounds`` not
        two increasing finite numbers, the trial is too short or has no usable window, or the
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
    fixed = lag if lag is not None else trial.attrs.get("lag")
    fixed = _check_lag(fixed, lag_bounds, source)
    rate = sampling_rate(trial)
    # the variables' arrays (a DataArray built per lookup costs more than some steps below)
    channel = {name: trial.variables[name].values for name in QUANTITIES}
    time = channel["time"]
    # the time line checked once: the acceleration and the SE's weights
    differentiate = differentiator(time)

    raw_torque = torque_sign * channel["torque"]
    raw_velocity = channel["velocity"]
    angle = channel["angle"]
    living = isinstance(gravity, StaticCurve)
    if isinstance(gravity, StaticCurve):
        columns = gravity.columns(angle, raw_velocity)
        coefficients = tuple(gravity.coefficients)
    else:
        columns = [np.sin(angle), np.cos(angle), 1.0]
        coefficients = gravity_coefficients(gravity)
    # The gravity model A sin(theta) + B cos(theta) + C (= gravity.torque; for a living body
    # the static curve's columns) passes through exactly the filter the torque does: by
    # linearity the same as filtering the torque minus the model. A filtered constant is the
    # constant. The channels go through the filter in one call (each row's numbers are those
    # of a call of its own).
    varying = [c for c in columns if not isinstance(c, float)]
    torque_f, velocity_f, *varying_f = lowpass_rows(
        np.stack([raw_torque, raw_velocity, *varying]),
        rate,
        cutoff=cutoff,
        order=order,
        source=source,
    )
    alpha_f = differentiate(velocity_f)
    filtered = iter(varying_f)
    terms = [
        np.full_like(time, c, dtype=np.float64) if isinstance(c, float) else next(filtered)
        for c in columns
    ]
    gravity_f = sum((c * term for c, term in zip(coefficients, terms, strict=True)), start=0.0)
    flags: list[str] = []
    lag_sensitivity: tuple[float, ...] = (0.0,) * len(terms)  # d lag / d coefficients
    lag_weights, lag_first = np.empty(0), 0  # d lag / d torque_f, from sample lag_first
    if fixed is None:
        found = estimate_lag(
            time,
            torque_f,
            gravity_f,
            alpha_f,
            velocity_f,
            bounds=lag_bounds,
            terms=terms,
            damping=living,
            rate=rate,
        )
        lag_value, lag_se, lag_source = found.lag, found.lag_se, "estimated"
        flags.extend(found.flags)
        lag_sensitivity = found.sensitivity
        lag_weights, lag_first = found.weights, found.first
    else:
        lag_value, lag_se, lag_source = fixed, 0.0, "manifest"
    shifted = advance(torque_f, lag_value, rate)
    net_f = shifted - gravity_f
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
    extra: dict[str, Any] = {}
    shifted_rate = np.gradient(shifted, time)  # d/dt of the advanced torque: dI/dL's part
    if living:
        damped = _with_damping(
            time, net_f, shifted_rate, velocity_f, alpha_f, win, terms, lag_sensitivity, source
        )
        value, solve, rows, frame_mean, sensitivity, residuals, extra = damped
        n = residuals.size
        sl = slice(win.start_index, win.stop_index)
        slopes = np.array([value, extra["damping"]])
    else:
        value, solve, rows, frame_mean, sensitivity, residuals, n, sl = _through_origin(
            net_f, shifted_rate, alpha_f, win, terms, lag_sensitivity
        )
        slopes = np.array([value])
        extra["inertial_torque"] = net_f
    # The estimates as linear functions of the filtered torque on every sample: directly
    # through the window rows, and through the estimated lag.
    laid = np.zeros((solve.shape[0], time.size))
    laid[:, rows] = solve
    if lag_weights.size:
        d_fit_d_lag = solve @ shifted_rate[rows]
        laid[:, lag_first : lag_first + lag_weights.size] += np.outer(d_fit_d_lag, lag_weights)
    cov = _noise_covariance(
        laid,
        differentiate,
        rate,
        slopes,
        trial_noise(raw_torque, gravity, noise),
        white_level(raw_velocity),
        cutoff=cutoff,
        order=order,
    )
    cov = _with_misfit(cov, solve, residuals, win.stop_index - win.start_index)
    se = math.sqrt(float(cov[0, 0]))
    if living:
        extra["damping_se"] = math.sqrt(float(cov[1, 1]))
        extra["inertia_damping_cov"] = float(cov[0, 1])
    if value < 0 and refuse_negative:
        if value + NEGATIVE_SE * se < 0:
            raise InputError(
                f"{source}: torque: inertia {value:.4g} kg m^2 is negative (the torque opposes "
                f"the acceleration in the window {win.start:.4g} to {win.end:.4g} s); "
                f"{_sign_hint(trial, torque_sign)}"
            )
        flags.append(
            f"negative inertia {value:.3g} ± {se:.2g} kg m^2; {_sign_hint(trial, torque_sign)}"
        )
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
        lag=float(lag_value),
        lag_se=float(lag_se),
        lag_source=lag_source,
        gravity_sensitivity=tuple(sensitivity),
        **extra,
    )


def _through_origin(net_f, shifted_rate, alpha_f, win, terms, lag_sensitivity):
    """A rigid condition: least squares of ``y = I alpha`` in the acceleration window.

    ``shifted_rate`` is the time derivative of the advanced torque (``numpy.gradient``).
    Returns ``(inertia, solve, rows, frame_mean, sensitivity, residuals, n, window slice)``:
    the estimate is ``solve @ net_f[rows]``.
    """
    sl = slice(win.start_index, win.stop_index)
    y = net_f[sl]
    alpha = alpha_f[sl]
    sxx = float(alpha @ alpha)
    value = float(alpha @ y) / sxx
    residuals = y - value * alpha
    n = residuals.size
    frame_mean = float(np.mean(y / alpha))
    # dI/d(A, B, C): directly through the model subtracted, and through the estimated lag
    # (dI/dL is the window's regression of the advanced torque's time derivative).
    d_inertia_d_lag = float(alpha @ shifted_rate[sl]) / sxx
    sensitivity = tuple(
        float(-(alpha @ term[sl]) / sxx + d_inertia_d_lag * d_lag)
        for term, d_lag in zip(terms, lag_sensitivity, strict=True)
    )
    solve = (alpha / sxx)[None, :]
    return value, solve, np.arange(sl.start, sl.stop), frame_mean, sensitivity, residuals, n, sl


def deceleration_window(time, velocity_f, alpha_f, *, source, speed_deg_s=None):
    """The uniform-deceleration window at the end of a fast move: ``(start, stop)`` indices.

    The window detector of the acceleration (:func:`find_window_arrays`) run on the trial
    reversed in time, where the deceleration is a rise from rest.
    """
    reversed_time = time[-1] - time[::-1]
    found = find_window_arrays(
        reversed_time,
        velocity_f[::-1],
        -alpha_f[::-1],
        source=f"{source} (deceleration)",
        speed_deg_s=speed_deg_s,
        level=LEVEL,
        tolerance=TOLERANCE,
        min_speed_change=MIN_SPEED_CHANGE,
    )
    n = time.size
    return n - found.stop_index, n - found.start_index


def _with_damping(
    time, net_f, shifted_rate, velocity_f, alpha_f, win, terms, lag_sensitivity, source
):
    """A living body: least squares of ``y = I alpha + b omega + c_t`` over both windows.

    During the acceleration ramp the speed rises with the acceleration, so ``b omega`` alone
    reads as inertia; in the deceleration window the acceleration changes sign while the
    speed stays of the same sign, which separates them. The trial's own constant ``c_t``
    takes what is the same in both windows and is not the damping: a torque zero that
    differs from the quasi-static trials', and the few hundredths of a N m by which the
    low-pass filter's rounding of the ramps' corners moves the filtered acceleration against
    the filtered torque (on noise-free simulated trials at 180 deg/s it took ``b`` 24 % high
    without ``c_t``, 6 % with it). Returns ``(inertia, se, frame_mean, sensitivity,
    residuals, extra fields)``.
    """
    try:
        start, stop = deceleration_window(time, velocity_f, alpha_f, source=source)
    except InputError:
        start, stop = 0, 0
    if start < win.stop_index:
        raise InputError(
            f"{source}: no uniform deceleration after the acceleration window (which ends at "
            f"{win.end:.4g} s): a living body's fast trial is fitted for I and the damping b "
            "over its acceleration and its deceleration, and this recording's speed does not "
            "fall back to rest along a straight line (cut short?)"
        )
    rows = np.r_[win.start_index : win.stop_index, start:stop]
    design = np.column_stack([alpha_f[rows], velocity_f[rows], np.ones(rows.size)])
    y = net_f[rows]
    gram_inv = np.linalg.inv(design.T @ design)
    coef = gram_inv @ (design.T @ y)
    residuals = y - design @ coef
    value, damping = float(coef[0]), float(coef[1])
    sl = slice(win.start_index, win.stop_index)
    frame_mean = float(np.mean((net_f[sl] - damping * velocity_f[sl]) / alpha_f[sl]))
    solve = gram_inv @ design.T  # d(I, b) / dy over the rows
    d_fit_d_lag = solve @ shifted_rate[rows]
    sensitivities = [
        tuple(
            float(-(solve[k] @ term[rows]) + d_fit_d_lag[k] * d_lag)
            for term, d_lag in zip(terms, lag_sensitivity, strict=True)
        )
        for k in (0, 1)
    ]
    sensitivity = sensitivities[0]
    extra = {
        "damping": damping,
        # what I alpha is fitted to: the torque less the damping and the trial's constant
        "inertial_torque": net_f - damping * velocity_f - float(coef[2]),
        "deceleration_start": float(time[start]),
        "deceleration_end": float(time[stop - 1]),
        "damping_sensitivity": sensitivities[1],
    }
    return value, solve[:2], rows, frame_mean, sensitivity, residuals, extra


def _with_misfit(cov: NDArray, solve: NDArray, residuals: NDArray, first: int) -> NDArray:
    """The noise model's covariance; the residuals' own where the channel has no noise.

    A recording whose torque has no sample-to-sample noise (a noise-free simulation, a
    channel smoothed at the source) gives the noise model nothing (its variances a millionth
    of the residuals' or less): the covariance is then
    what the window's residuals say, their variance corrected for its autocorrelation (each
    window's integrated autocorrelation time) times ``solve solve'``. That is not used
    otherwise: a drift leaves no trace in a window's residuals, and a tenth of a second of
    filtered noise shows too short an autocorrelation (the SEs came out 1.5-2.7 times too
    small, ``benchmarks/trial_se.py``).
    """
    p = solve.shape[0] + (1 if residuals.size > first else 0)  # a living fit's c_t too
    sigma2 = float(residuals @ residuals) / max(residuals.size - p, 1)
    parts = [residuals[:first], residuals[first:]] if residuals.size > first else [residuals]
    gram = solve @ solve.T
    # "no noise": the model's variances a millionth of the residuals' or less (rounding).
    # tau is at most the longest part's length: when the model's variances stand even
    # against that, they stand whatever tau is (rounding is monotone), and tau, a tenth of
    # a fast trial's processing, need not be computed.
    longest = float(max(1, *(part.size for part in parts)))
    if np.all(np.diag(cov) > 1e-6 * np.diag(sigma2 * longest * gram)):
        return cov
    tau = max(integrated_autocorrelation_time(part) for part in parts)
    shown = sigma2 * tau * gram
    return cov if np.all(np.diag(cov) > 1e-6 * np.diag(shown)) else shown


def _ar1_quadratic(w: NDArray, rho: float) -> NDArray:
    """``W R W'`` for the rows of ``w``, ``R[i, j] = rho^|i - j|`` (an AR(1)'s correlation).

    ``R w = f + b - w`` with ``f`` the forward recursion ``f_i = w_i + rho f_(i-1)`` and
    ``b`` the backward one: linear in the samples.
    """
    forward = signal.lfilter([1.0], [1.0, -rho], w, axis=-1)
    return 2.0 * (w @ forward.T) - w @ w.T


def trial_noise(
    torque: ArrayLike, gravity: GravityFit | StaticCurve, noise: TorqueNoise | None = None
) -> TorqueNoise:
    """The torque noise a fast trial's standard errors are computed with.

    ``noise`` when given. Else the white level of the trial itself (:func:`white_level` of
    its raw torque: thousands of samples fix it to a few per cent) and the drift of the
    condition's quasi-static noise model (``gravity.noise``, fitted by REML over a sweep a
    hundred times longer than the drift's correlation time; none when the model has none).
    A fast trial cannot measure its own drift: over its acceleration window the drift is a
    constant, which reads as inertia and leaves the residuals alone, and the whole trial
    holds only a few of the drift's correlation times under a white noise ten times larger.
    """
    if noise is not None:
        return noise
    white = white_level(torque)
    static = gravity.noise
    if static is None:
        return TorqueNoise(white)
    return TorqueNoise(white, static.drift_sd, static.drift_time)


def _noise_covariance(
    laid: NDArray,
    differentiate: Callable[[NDArray], NDArray],
    rate: float,
    slopes: NDArray,
    noise: TorqueNoise,
    velocity_sd: float,
    *,
    cutoff: float,
    order: int,
) -> NDArray:
    """Covariance of the window estimates from the channels' noise, ``W Sigma W'``.

    The estimates are ``laid @ y`` to first order, with ``y`` the filtered torque (the
    window's least squares, and the estimated lag's response): linear in the raw torque,
    with weights ``W = F' laid'`` (``F`` the zero-phase low-pass). Inside a trial, away from
    its ends, ``F`` is a symmetric convolution, so ``F' = F``: the weights are the
    low-passed rows of ``laid`` (an advance by the lag moves them, and leaves a stationary
    noise's covariance as it is). The torque's noise is white plus an AR(1) drift
    (:class:`TorqueNoise`). The velocity's white noise enters through the design's columns:
    the estimates move by ``-solve @ (dX theta)``, ``dX`` the filtered noise of the
    acceleration (``D F`` of the raw velocity's noise, ``D`` the derivative, ``D' = -D``)
    and of the filtered velocity, times their coefficients (``slopes``: ``I`` and ``b``).
    """
    weights = lowpass_rows(laid, rate, cutoff=cutoff, order=order)
    cov = noise.white_sd**2 * (weights @ weights.T)
    if noise.drift_sd > 0 and noise.drift_time > 0:
        rho = math.exp(-1.0 / (rate * noise.drift_time))
        cov += noise.drift_sd**2 * _ar1_quadratic(weights, rho)
    if velocity_sd > 0 and np.any(slopes):
        inertia, damping = float(slopes[0]), float(slopes[1]) if slopes.size > 1 else 0.0
        # F D = D F inside the trial: the derivative of the low-passed weights
        moved = np.stack([inertia * differentiate(w) - damping * w for w in weights])
        cov += velocity_sd**2 * (moved @ moved.T)
    return 0.5 * (cov + cov.T)


def gravity_coefficients(gravity: GravityFit) -> tuple[float, float, float]:
    """``(A, B, C)`` of a gravity model written ``A sin(theta) + B cos(theta) + C``.

    ``A = M_g cos(phi)``, ``B = M_g sin(phi)``, ``C = c``: the same torque as
    :meth:`GravityFit.torque`, ``M_g sin(theta + phi) + c``.
    """
    moment, phase = gravity.gravity_moment, gravity.gravity_phase
    return moment * math.cos(phase), moment * math.sin(phase), gravity.offset


def _check_lag(value: object, bounds: Sequence[float], source: str) -> float | None:
    """A fixed lag as a float (``None`` to estimate it), after checking it and the bounds."""
    try:
        lower, upper = (float(b) for b in bounds)
        ok = math.isfinite(lower) and math.isfinite(upper) and lower < upper
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(
            f"{source}: lag_bounds: expected two increasing numbers (s), got {tuple(bounds)!r}"
        )
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
        raise InputError(f"{source}: lag: expected a number of seconds, got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"{source}: lag: expected a finite number of seconds, got {value!r}")
    return float(value)
