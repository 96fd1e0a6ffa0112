"""Estimators and densities shared by several stages (processing, the baseline, inference).

The evidence on one observable is a Student-t in its true value (repeated trials with unknown
noise) or a Gaussian (one value with a known standard error); see docs/method.md, "Likelihood".
:func:`student_t_logpdf` and :func:`student_t_draws` evaluate and draw from either, vectorised
over many of them at once: a Gaussian is a Student-t with ``df = inf``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import gammaln

__all__ = ["inverse_variance_mean", "student_t_draws", "student_t_logpdf"]

_HALF_LOG_2PI = 0.5 * math.log(2 * math.pi)
_SCALAR = (float, int, np.floating, np.integer)


def inverse_variance_mean(values: ArrayLike, ses: ArrayLike) -> tuple[float, float]:
    """Weighted mean of estimates with standard errors ``ses``, and its standard error."""
    w = 1 / np.asarray(ses, float) ** 2
    return float(np.sum(w * np.asarray(values, float)) / w.sum()), float(1 / math.sqrt(w.sum()))


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
