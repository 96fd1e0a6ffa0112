"""Estimators and densities shared by several stages (processing, the baseline, inference).

The evidence on one observable is a Student-t in its true value (repeated trials with unknown
noise) or a Gaussian (one value with a known standard error); see docs/method.md, "Likelihood".
:func:`student_t_logpdf` and :func:`student_t_draws` evaluate and draw from either, vectorised
over many of them at once: a Gaussian is a Student-t with ``df = inf``.
:class:`SmearedStudentT` is a Student-t plus an independent Gaussian error (a systematic error
shared by every trial of a condition, which their scatter cannot show).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gammaln

__all__ = [
    "BATCHES",
    "SMEAR_NEGLIGIBLE",
    "SmearedStudentT",
    "effective_sample_size",
    "integrated_autocorrelation_time",
    "inverse_variance_mean",
    "shared_error",
    "student_t_draws",
    "student_t_logpdf",
]

#: A Gaussian smear below this fraction of the Student-t's scale changes the density by less
#: than ``ratio^2 / 2`` of its curvature term; it is left out (the density is the Student-t's
#: with the variances added, an error of order ``ratio^4``).
SMEAR_NEGLIGIBLE = 1e-3
#: Grid steps per unit of the smaller of the two scales in :class:`SmearedStudentT`.
_STEPS_PER_SCALE = 32

_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)
_SCALAR = (float, int, np.floating, np.integer)


def inverse_variance_mean(values: ArrayLike, ses: ArrayLike) -> tuple[float, float]:
    """Weighted mean of estimates with standard errors ``ses``, and its standard error."""
    w = 1 / np.asarray(ses, float) ** 2
    return float(np.sum(w * np.asarray(values, float)) / w.sum()), float(1 / math.sqrt(w.sum()))


def shared_error(
    jacobian: ArrayLike, covariance: ArrayLike, gradient: ArrayLike
) -> tuple[float, float]:
    """A shared error's effect on one estimate, given its effect on another.

    An error ``delta`` (covariance ``Sigma``) moves estimate ``u`` by ``J delta`` and estimate
    ``v`` by ``g delta``. Given ``v``'s error, ``u``'s is Gaussian with mean ``coupling * v``,
    ``coupling = J Sigma g' / g Sigma g'``, and SD ``sqrt(J Sigma J' - coupling J Sigma g')``.
    Returns ``(coupling, shared_sd)`` (``coupling`` 0 when ``g Sigma g'`` is 0).
    """
    jac = np.asarray(jacobian, float)
    cov = np.asarray(covariance, float)
    g = np.asarray(gradient, float)
    var_v = float(g @ cov @ g)
    cov_uv = float(jac @ cov @ g)
    coupling = cov_uv / var_v if var_v > 0 else 0.0
    rest = float(jac @ cov @ jac) - coupling * cov_uv
    return coupling, math.sqrt(max(rest, 0.0))


@functools.lru_cache(maxsize=1024)
def _t_log_constant(scale: float, df: float) -> float:
    """Log normalising constant of a Student-t with scale ``scale`` and ``df`` d.o.f."""
    return float(
        gammaln((df + 1) / 2) - gammaln(df / 2) - 0.5 * math.log(df * math.pi) - math.log(scale)
    )


def student_t_logpdf(
    x: ArrayLike, center: ArrayLike, scale: ArrayLike, df: ArrayLike, *, normalised: bool = True
) -> NDArray:
    """Log density of Student-t distributions (Gaussian where ``df`` is infinite) at ``x``.

    Parameters
    ----------
    x : array_like
        Points, broadcast against the parameters: with ``n`` distributions given as arrays of
        shape ``(n,)``, ``x`` of shape ``(..., n)`` evaluates distribution ``i`` on column ``i``.
    center, scale : array_like
        Location and scale (``scale > 0``).
    df : array_like
        Degrees of freedom (``> 0``); ``inf`` for a Gaussian with standard deviation ``scale``.
    normalised : bool
        With ``False``, leave out every term that does not depend on ``x`` (the log normalising
        constant): enough for ratios of one distribution's densities, and cheaper.

    Returns
    -------
    ndarray
        The log densities, shape of ``x`` broadcast against the parameters. One distribution
        or many, a point gets the same digits.
    """
    x = np.asarray(x)
    if isinstance(center, _SCALAR) and isinstance(scale, _SCALAR) and isinstance(df, _SCALAR):
        # one distribution, the likelihood's hot path: no per-column selection
        c, s, nu = float(center), float(scale), float(df)
        z = (x - c) / s
        if math.isinf(nu):
            kernel = -0.5 * z * z
            return kernel - math.log(s) - _HALF_LOG_2PI if normalised else kernel
        kernel = -0.5 * (nu + 1) * np.log1p(z * z / nu)
        return _t_log_constant(s, nu) + kernel if normalised else kernel
    center, scale, df = (np.asarray(v, float) for v in (center, scale, df))
    z = (x - center) / scale
    finite = np.isfinite(df)
    dfs = np.where(finite, df, 1.0)
    kernel = np.where(finite, -0.5 * (dfs + 1) * np.log1p(z * z / dfs), -0.5 * z * z)
    if not normalised:
        return kernel
    # constants entry by entry with math.log, as for one distribution: the same digits
    scale, dfs = np.broadcast_arrays(scale, dfs)
    pairs = zip(scale.ravel().tolist(), dfs.ravel().tolist(), strict=True)
    log_scale = np.array([math.log(sc) for sc in scale.ravel().tolist()]).reshape(scale.shape)
    t_const = np.array([_t_log_constant(sc, nu) for sc, nu in pairs]).reshape(scale.shape)
    return np.where(finite, t_const + kernel, kernel - log_scale - _HALF_LOG_2PI)


def student_t_draws(
    center: ArrayLike,
    scale: ArrayLike,
    df: ArrayLike,
    size: tuple[int, ...],
    rng: np.random.Generator,
) -> NDArray:
    """Draws from Student-t distributions (Gaussian where ``df`` is infinite).

    Parameters
    ----------
    center, scale, df : array_like
        As in :func:`student_t_logpdf`, broadcast together to the shape ``shape``.
    size : tuple of int
        Leading shape: the result is ``(*size, *shape)``.
    rng : numpy.random.Generator
        Source of the draws: one standard normal per entry, then (where any ``df`` is finite)
        one chi-square per entry, ``t = z / sqrt(chi2_df / df)``.
    """
    center, scale, df = (np.asarray(v, float) for v in (center, scale, df))
    shape = np.broadcast_shapes(center.shape, scale.shape, df.shape)
    finite = np.isfinite(df)
    z = rng.standard_normal(size=(*size, *shape))
    if finite.any():
        dfs = np.where(finite, df, 1.0)
        chi = rng.chisquare(np.broadcast_to(dfs, z.shape))
        z = np.where(finite, z / np.sqrt(chi / dfs), z)
    return center + scale * z


class SmearedStudentT:
    """A Student-t plus an independent Gaussian: ``X = center + scale T_df + sd Z``.

    The density of the sum is the convolution of the two; it has no closed form for a finite
    ``df``, so it is tabulated once, in units of ``scale``, on a grid of step
    ``min(1, sd/scale) / 32`` (FFT convolution of the Student-t density with the Gaussian's
    over a range wide enough that neither is cut), and interpolated linearly in its logarithm:
    an error in the log density below ``1e-4`` near the centre. Beyond the table (where the
    Student-t's tail holds less than ``1e-10``, at most 200 scales, plus 10 Gaussian SDs) the
    Student-t's own density is used: there the Gaussian is narrow against the distance from
    the centre. A Gaussian (``df = inf``) plus a Gaussian is a Gaussian, in closed form.

    Parameters
    ----------
    center, scale, df : float
        The Student-t (``df = inf``: a Gaussian of SD ``scale``).
    sd : float
        SD of the added Gaussian (``>= 0``).
    """

    def __init__(self, center: float, scale: float, df: float, sd: float) -> None:
        self.center, self.scale, self.df, self.sd = map(float, (center, scale, df, sd))
        ratio = self.sd / self.scale
        self._table: tuple[NDArray, NDArray] | None = None
        if math.isinf(self.df) or ratio < SMEAR_NEGLIGIBLE:
            self._closed = (math.hypot(self.scale, self.sd), self.df)
            return
        from scipy import signal, stats

        step = min(1.0, ratio) / _STEPS_PER_SCALE
        half = min(float(stats.t.isf(1e-10, self.df)), 200.0) + 10.0 * ratio
        reach = 10.0 * ratio  # the Gaussian's reach, added on both sides so no mass is cut
        n_in, n_k = math.ceil(half / step), math.ceil(reach / step)
        wide = np.arange(-(n_in + n_k), n_in + n_k + 1) * step
        kernel = np.exp(-0.5 * (np.arange(-n_k, n_k + 1) * step / ratio) ** 2)
        kernel *= step / (ratio * math.sqrt(2 * math.pi))
        dens = signal.fftconvolve(stats.t.pdf(wide, self.df), kernel, mode="valid")
        grid = np.arange(-n_in, n_in + 1) * step
        log_dens = np.log(np.maximum(dens, 1e-300))
        self._table = (grid, log_dens)
        # the Student-t's tail beyond the table, shifted to meet the table at its edge
        self._tail_shift = float(log_dens[-1] - student_t_logpdf(grid[-1], 0.0, 1.0, self.df))
        self._closed = (self.scale, self.df)

    def logpdf(self, x: ArrayLike) -> NDArray:
        """Log density at ``x`` (normalised)."""
        if self._table is None:
            return student_t_logpdf(x, self.center, *self._closed)
        grid, log_dens = self._table
        u = (np.asarray(x, float) - self.center) / self.scale
        inside = np.abs(u) <= grid[-1]
        tail = student_t_logpdf(u, 0.0, 1.0, self.df) + self._tail_shift
        return np.where(inside, np.interp(u, grid, log_dens), tail) - math.log(self.scale)

    def draws(self, size: tuple[int, ...], rng: np.random.Generator) -> NDArray:
        """``size`` independent draws."""
        t = student_t_draws(self.center, self.scale, self.df, size, rng)
        return t + self.sd * rng.standard_normal(size) if self.sd else t


# --- the autocorrelation of a series (the trials' noise) -----------------------------------

#: Number of batches of the batch-means estimate of the autocorrelation time.
BATCHES = 1000


def _geyer(x: NDArray) -> float:
    """Integrated autocorrelation time by Geyer's initial monotone sequence (see below)."""
    n = x.size
    x = x - x.mean()
    var = float(x @ x)
    if n < 4 or var == 0.0:
        return 1.0
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(x, size)
    acf = np.fft.irfft(f * np.conj(f), size)[:n] / var
    pairs = acf[: 2 * (n // 2)].reshape(-1, 2).sum(axis=1)
    negative = pairs < 0
    stop = int(np.argmax(negative)) if negative.any() else pairs.size
    pairs = np.minimum.accumulate(pairs[: max(stop, 1)])
    return max(2.0 * float(pairs.sum()) - 1.0, 1.0)


def integrated_autocorrelation_time(x: ArrayLike, *, batches: int = BATCHES) -> float:
    """Integrated autocorrelation time ``tau_int = 1 + 2 sum_k rho_k`` of a series.

    ``n / tau_int`` is the number of independent samples the series is worth: the variance of
    its mean is ``var(x) tau_int / n``.

    Geyer's initial monotone sequence estimator (Geyer 1992; the one ArviZ uses for MCMC
    chains) sums the autocorrelation (by FFT) in pairs ``rho_2k + rho_2k+1``, up to the first
    negative pair, each pair capped by the one before. On its own it stops far too early when
    white noise hides a slow drift of small amplitude and long correlation time (0.4 N m white
    noise over a 0.03 N m drift: it finds a third of the true ``tau_int``). So the series is
    first cut into ``batches`` batches of ``L`` samples: averaging removes the white part, the
    drift dominates the batch means, and ``tau_int = L var(batch means) tau_means / var(x)``,
    with ``tau_means`` Geyer's estimate on the batch means. On 90 000 samples this is within
    5 % of the true value for white noise, AR(1) with correlation 0.95 and 0.995, and the
    drift-under-noise mixture. Series shorter than ``2 batches`` samples use Geyer's estimator
    alone. (The fast trials' inertia, the lag and the living fits use it; the gravity fit has its own
    noise model.)

    Parameters
    ----------
    x : array_like[nsamples]
        The series (its mean is removed).
    batches : int
        Number of batches.

    Returns
    -------
    float
        ``tau_int`` in ``[1, nsamples]`` (1 for white noise).
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    x = x - x.mean()
    var = float(x @ x) / max(n - 1, 1)
    if n < 4 or var == 0.0:
        return 1.0
    length = n // batches
    if length < 2:
        return min(_geyer(x), float(n))
    means = x[: batches * length].reshape(batches, length).mean(axis=1)
    tau = length * float(np.var(means, ddof=1)) / var * _geyer(means)
    return float(min(max(tau, 1.0), n))


def effective_sample_size(x: ArrayLike) -> float:
    """Number of independent samples a correlated series is worth, ``n / tau_int``."""
    x = np.asarray(x)
    return x.size / integrated_autocorrelation_time(x)
