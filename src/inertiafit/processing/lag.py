"""The lag of the torque channel behind the angle and velocity channels, per fast trial.

A recording chain can delay one channel against the others: a dynamometer's own filtering of
its torque, an analog-to-digital card, a resampling step. A torque that lags by ``L`` reads, at
time ``t``, the torque of ``t - L``; in the acceleration window it then misses part of the
inertial torque at the start of the ramp and the gravity model it is compared with belongs to
a later angle. On simulated 1 kHz trials at 180-300 deg/s, 1 ms of lag takes about 0.23 % off
the inertia, 3 ms 0.9 % and 5 ms 1.8 % (``docs/processing.md``, "Lag between channels").

The estimate uses the whole move, not only the window: the corners of the ramps, where the
inertial torque jumps, carry the timing. For a trial lag ``L`` the filtered torque is advanced
by ``L`` (:func:`advance`, a band-limited fractional shift), the gravity model at the measured
angle is subtracted, and ``y_L = I alpha + c`` is fitted by least squares (``alpha`` from the
filtered velocity; ``I`` and a constant ``c`` absorb the inertia and any offset). ``L``
minimises that residual sum of squares within ``bounds`` (a grid of :data:`GRID_STEP`, then
:func:`scipy.optimize.minimize_scalar` around the best point). Its standard error is the
curvature of the sum of squares (Gauss-Newton: the derivative of the advanced torque with
respect to ``L``, its part that ``I`` and ``c`` cannot absorb), corrected for autocorrelated
residuals by their integrated autocorrelation time, as the inertia's SE is.

Problems are flags (never warnings): an estimate at a bound of the search range, a lag that
cannot be estimated (too short a move, or a torque without a corner: the trial is then
processed with no lag), and, across a study, lags that disagree with the study's median
(:func:`lag_consistency_flags`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import fft, optimize

from inertiafit.io.manifest import Calibration
from inertiafit.stats import integrated_autocorrelation_time

__all__ = [
    "GRID_STEP",
    "LAG_BOUNDS",
    "MAX_LAG_SPREAD",
    "MIN_LAG_SAMPLES",
    "MOVING",
    "PAD",
    "XATOL",
    "LagEstimate",
    "advance",
    "estimate_lag",
    "lag_consistency_flags",
]

#: Default search range of the lag (s), from :class:`~inertiafit.io.manifest.Calibration`.
LAG_BOUNDS: tuple[float, float] = Calibration().lag_bounds
#: Default difference (s) from the study's median lag beyond which a trial is flagged.
MAX_LAG_SPREAD: float = Calibration().max_lag_spread
#: A sample is moving where the filtered speed exceeds this fraction of its largest value.
MOVING = 0.02
#: Time (s) added before and after the moving part: the corners where the move starts and
#: stops, rounded by the filter.
PAD = 0.1
#: Fewest samples of the move the lag is fitted on.
MIN_LAG_SAMPLES = 20
#: Step (s) of the grid the sum of squares is first evaluated on: finer than the width of
#: its minimum, which the filter's corners (tens of ms at a 20 Hz cut-off) set.
GRID_STEP = 0.002
#: Tolerance (s) of the refined minimum: far below the lag's standard error.
XATOL = 1e-6


@dataclass(frozen=True)
class LagEstimate:
    """The lag of the torque channel in one fast trial.

    Attributes
    ----------
    lag : float
        Seconds the torque lags the angle and velocity (positive: the torque is late). 0 when
        it could not be estimated (see ``flags``).
    lag_se : float
        Its standard error (s); NaN when it could not be estimated.
    n : int
        Samples fitted (the move and its padding).
    start, end : float
        Times (s) of the first and last sample fitted.
    residual_rms : float
        RMS (N m) of the residual of ``I alpha + c`` at the estimated lag.
    flags : tuple of str
        An estimate at a bound of the search range, or a lag not estimated.
    sensitivity : tuple of float
        ``d lag / d c_j`` (s per unit) for the model terms ``terms`` given to
        :func:`estimate_lag`, whose coefficients ``c_j`` the subtracted gravity model holds:
        how the estimate moves with an error of that model. 0 when not estimated.
    weights : ndarray
        ``d lag / d y`` for the filtered torque ``y`` on the samples fitted (from
        ``start``; empty when not estimated): the estimate is linear in the torque's noise
        to first order, and a fast trial's standard errors carry it through the lag.
    first : int
        Index of the first sample fitted.
    """

    lag: float
    lag_se: float
    n: int
    start: float
    end: float
    residual_rms: float
    flags: tuple[str, ...] = ()
    sensitivity: tuple[float, ...] = ()
    weights: NDArray = field(default_factory=lambda: np.empty(0), repr=False, compare=False)
    first: int = 0


class _Shifter:
    """A signal's band-limited fractional shifts: ``x(t + s)`` and its derivative.

    The line through the first and last sample is taken off (so the periodic extension the
    FFT assumes has no jump), the rest is shifted by a phase ramp and the line is added back
    at the shifted times (a line shifts exactly).
    """

    def __init__(self, x: NDArray, rate: float) -> None:
        n = x.size
        self.n, self.rate = n, rate
        self.k = np.arange(n, dtype=np.float64)
        self.x0 = float(x[0])
        self.slope = float(x[-1] - x[0]) / max(n - 1, 1)  # per sample
        size = fft.next_fast_len(n + 1, real=True)
        self.size = size
        self.spectrum = fft.rfft(x - (self.x0 + self.slope * self.k), size)
        self.omega = 2.0 * math.pi * np.arange(self.spectrum.size) / size  # rad per sample
        self.i_omega = 1j * self.omega
        if size % 2 == 0:  # no derivative at the Nyquist bin of a real series
            self.d_omega = self.omega.copy()
            self.d_omega[-1] = 0.0
        else:
            self.d_omega = self.omega

    def shifted(self, seconds: float, part: slice | None = None) -> NDArray:
        """``x(t + seconds)``; only its samples ``part`` when given (each the same number)."""
        s = seconds * self.rate
        if s == 0.0:
            rest = fft.irfft(self.spectrum, self.size)
        else:
            rest = fft.irfft(self.spectrum * np.exp(self.i_omega * s), self.size)
        cut = slice(0, self.n) if part is None else part
        return rest[cut] + self.x0 + self.slope * (self.k[cut] + s)

    def derivative(self, seconds: float) -> NDArray:
        """d/dt of ``x(t + seconds)`` (per second)."""
        s = seconds * self.rate
        phase = 1j * self.d_omega * np.exp(1j * self.omega * s)
        return (fft.irfft(self.spectrum * phase, self.size)[: self.n] + self.slope) * self.rate


def advance(x: ArrayLike, seconds: float, rate: float) -> NDArray:
    """A uniformly sampled signal at ``t + seconds``: advanced by a fractional shift.

    Band-limited (Fourier) interpolation: exact for a signal without content above the
    Nyquist frequency, such as a low-pass filtered channel. The line through the first and
    last sample is shifted exactly and the rest by a phase ramp, so the two ends do not
    leak into each other; the first and last ``|seconds|`` of the result wrap around and
    mean nothing.

    Parameters
    ----------
    x : array_like[nsamples]
        The signal.
    seconds : float
        The advance (s); negative delays.
    rate : float
        Sampling rate (Hz).

    Returns
    -------
    ndarray[nsamples]
        ``x(t + seconds)`` on the same samples; ``x`` itself (as floats) when ``seconds`` is 0.
    """
    x = np.asarray(x, dtype=np.float64)
    if seconds == 0.0 or x.size < 2:
        return x.copy()
    return _Shifter(x, rate).shifted(seconds)


def _move(velocity: NDArray, rate: float, margin: int) -> tuple[int, int]:
    """Sample range of the move (speed above :data:`MOVING` of its peak) with :data:`PAD`.

    Kept ``margin`` samples away from each end, where a shifted signal wraps around.
    """
    speed = np.abs(velocity)
    peak = float(np.max(speed)) if speed.size else 0.0
    moving = np.flatnonzero(speed > MOVING * peak) if peak > 0 else np.array([], dtype=int)
    if moving.size == 0:
        return 0, 0
    pad = round(PAD * rate)
    lo = max(int(moving[0]) - pad, margin)
    hi = min(int(moving[-1]) + 1 + pad, velocity.size - margin)
    return lo, max(hi, lo)


def _ssr_whole(
    torque: NDArray, target: NDArray, basis: NDArray, lo: int, hi: int, shifts: NDArray
) -> NDArray:
    """The residual sums of squares for advances of ``shifts`` whole samples, all at once.

    One matrix product for the grid instead of a projection per point (the grid only picks
    the bracket of the refined minimum, so these sums need not match :func:`estimate_lag`'s
    ``ssr`` to the last digit).
    """
    windows = np.lib.stride_tricks.sliding_window_view(torque, hi - lo)[lo + shifts]
    y = windows - target
    r = y - (y @ basis) @ basis.T
    return np.einsum("ij,ij->i", r, r)


def estimate_lag(
    time: ArrayLike,
    torque: ArrayLike,
    gravity: ArrayLike,
    acceleration: ArrayLike,
    velocity: ArrayLike,
    *,
    bounds: Sequence[float] = LAG_BOUNDS,
    terms: Sequence[ArrayLike] = (),
    damping: bool = False,
    rate: float | None = None,
) -> LagEstimate:
    """Estimate the lag of the torque channel behind the velocity in a fast trial.

    Parameters
    ----------
    time : array_like[nsamples]
        Sample times (s), uniformly sampled.
    torque : array_like[nsamples]
        The filtered, signed torque (N m), as recorded (not yet shifted).
    gravity : array_like[nsamples]
        The condition's gravity model at the measured angle, through the same filter (N m).
    acceleration, velocity : array_like[nsamples]
        The filtered acceleration (rad/s^2) and velocity (rad/s).
    bounds : (float, float)
        Search range of the lag (s), lower < upper.
    terms : sequence of array_like[nsamples]
        Filtered terms of the gravity model (``sin(theta)``, ``cos(theta)``, 1), for
        :attr:`LagEstimate.sensitivity`.
    damping : bool
        Fit ``I alpha + b omega + c`` (a living body's viscous damping) instead of
        ``I alpha + c``.
    rate : float, optional
        The sampling rate (Hz), when the caller has it: ``1 / median(diff(time))``
        (:func:`~inertiafit.processing.filtering.sampling_rate`), computed here otherwise.

    Returns
    -------
    LagEstimate
        The lag minimising the residual sum of squares of ``advance(torque, L) - gravity =
        I alpha + c`` over the move, its standard error, its sensitivity to the gravity
        model and flags (an estimate at a bound; a move too short or a torque whose advance
        changes nothing, when the lag is 0 and its SE NaN).

    Notes
    -----
    The sensitivity follows from the first-order condition ``J' r = 0`` at the minimum
    (``J`` the derivative of the residual with respect to the lag, ``r`` the residual): an
    error ``d c_j`` of the model adds ``-d c_j P term_j`` to ``r`` (``P`` removes what
    ``I alpha + c`` absorbs), so ``d lag / d c_j = J' term_j / J' J``.
    """
    t = np.asarray(time, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    grav = np.asarray(gravity, dtype=np.float64)
    alpha = np.asarray(acceleration, dtype=np.float64)
    vel = np.asarray(velocity, dtype=np.float64)
    lo_bound, hi_bound = float(bounds[0]), float(bounds[1])
    if rate is None:
        rate = 1.0 / float(np.median(np.diff(t)))
    margin = math.ceil(max(abs(lo_bound), abs(hi_bound)) * rate) + 1
    lo, hi = _move(vel, rate, margin)
    n = hi - lo
    if n < MIN_LAG_SAMPLES:
        reach = max(abs(lo_bound), abs(hi_bound)) * 1e3
        return _not_estimated(
            f"{n} samples of the move lie more than {reach:.3g} ms (the lag bounds) from the "
            "ends of the recording",
            t,
            lo,
            hi,
            len(terms),
        )
    sl = slice(lo, hi)
    shifter = _Shifter(tau, rate)
    # I alpha + c over the move: an orthonormal basis, so residuals are one projection away.
    columns = [alpha[sl], vel[sl], np.ones(n)] if damping else [alpha[sl], np.ones(n)]
    basis, _ = np.linalg.qr(np.column_stack(columns))
    target = grav[sl]

    def residual(lag: float) -> NDArray:
        y = shifter.shifted(lag, sl) - target
        return y - basis @ (basis.T @ y)

    def ssr(lag: float) -> float:
        r = residual(lag)
        return float(r @ r)

    # The grid: whole-sample steps where the grid is that fine (the advanced torque is then
    # the torque itself, moved: no FFT), and the bounds themselves.
    per_sample = round(GRID_STEP * rate)
    if per_sample >= 1:
        steps = np.arange(math.ceil(lo_bound * rate), math.floor(hi_bound * rate) + 1)
        points: list[tuple[float, int | None]] = [(m / rate, int(m)) for m in steps[::per_sample]]
    else:
        count = max(math.ceil((hi_bound - lo_bound) / GRID_STEP), 2) + 1
        points = [(float(g), None) for g in np.linspace(lo_bound, hi_bound, count)]
    if not points or points[0][0] > lo_bound:
        points.insert(0, (lo_bound, None))
    if points[-1][0] < hi_bound:
        points.append((hi_bound, None))
    grid = np.array([g for g, _ in points])
    whole = [i for i, (_, m) in enumerate(points) if m is not None]
    values = np.array([ssr(g) if m is None else math.nan for g, m in points])
    if whole:
        shifts = np.array([points[i][1] for i in whole], dtype=np.intp)
        values[whole] = _ssr_whole(tau, target, basis, lo, hi, shifts)
    best = int(np.argmin(values))
    bracket = (float(grid[max(best - 1, 0)]), float(grid[min(best + 1, grid.size - 1)]))
    xatol = XATOL
    found = optimize.minimize_scalar(
        ssr, bounds=bracket, method="bounded", options={"xatol": xatol}
    )
    lag = float(found.x)
    r = residual(lag)
    jac = shifter.derivative(lag)[sl]
    jac = jac - basis @ (basis.T @ jac)
    curvature = float(jac @ jac)  # half the SSR's Gauss-Newton curvature
    if not curvature > 0:
        return _not_estimated("advancing the torque changes nothing", t, lo, hi, len(terms))
    sigma2 = float(r @ r) / max(n - 3, 1)
    se = math.sqrt(sigma2 * integrated_autocorrelation_time(r) / curvature)
    sensitivity = tuple(
        float(jac @ np.asarray(term, dtype=np.float64)[sl]) / curvature for term in terms
    )
    flags = []
    edge = 2.0 * xatol + 1e-12
    if lag - lo_bound <= edge or hi_bound - lag <= edge:
        flags.append(
            f"lag {lag * 1e3:.3g} ms at a bound of the search range "
            f"[{lo_bound * 1e3:.3g}, {hi_bound * 1e3:.3g}] ms; widen lag_bounds in the "
            "manifest's [calibration] or fix the lag (lag = seconds)"
        )
    return LagEstimate(
        lag=lag,
        lag_se=se,
        n=int(n),
        start=float(t[lo]),
        end=float(t[hi - 1]),
        residual_rms=float(np.sqrt(np.mean(r**2))),
        flags=tuple(flags),
        sensitivity=sensitivity,
        weights=-jac / curvature,  # d lag / d y: the first-order condition J' r = 0
        first=int(lo),
    )


def _not_estimated(why: str, t: NDArray, lo: int, hi: int, n_terms: int) -> LagEstimate:
    """No lag removed (0, SE NaN), with a flag saying why."""
    n = hi - lo
    return LagEstimate(
        lag=0.0,
        lag_se=math.nan,
        n=int(n),
        start=float(t[lo]) if n > 0 else math.nan,
        end=float(t[hi - 1]) if n > 0 else math.nan,
        residual_rms=math.nan,
        flags=(f"lag not estimated: {why}; no lag removed",),
        sensitivity=(0.0,) * n_terms,
    )


def lag_consistency_flags[K](
    lags: Mapping[K, tuple[float, float]], *, max_spread: float = MAX_LAG_SPREAD
) -> dict[K, str]:
    """Flags for trials whose lag disagrees with the others' (one recording chain, one lag).

    Parameters
    ----------
    lags : mapping of key to (float, float)
        Trial (its file, or any key) -> (estimated lag, its SE), in seconds. Pass only estimated lags: a lag
        the manifest fixed, or one not estimated (NaN SE), is no evidence of the chain's.
    max_spread : float
        Tolerated difference (s) from the median of the lags.

    Returns
    -------
    dict of key to str
        Trial -> flag, for every trial whose lag differs from the median by more than
        ``max(max_spread, 3 x its SE)``; empty with fewer than two finite lags.
    """
    finite = {
        f: (lag, se) for f, (lag, se) in lags.items() if math.isfinite(lag) and not math.isnan(se)
    }
    if len(finite) < 2:
        return {}
    median = float(np.median([lag for lag, _ in finite.values()]))
    out: dict[K, str] = {}
    for file, (lag, se) in finite.items():
        limit = max(max_spread, 3.0 * se)
        if abs(lag - median) > limit:
            out[file] = (
                f"lag {lag * 1e3:.3g} ms differs from the study's median lag "
                f"{median * 1e3:.3g} ms by more than {limit * 1e3:.3g} ms (one recording "
                "chain has one lag; check this trial's channels)"
            )
    return out
