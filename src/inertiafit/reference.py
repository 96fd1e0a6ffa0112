"""Exact single-body posterior by quadrature, the yardstick for the sampler.

For one body in one condition the posterior is a 3-D integral. On a grid in
``(m, a = m x, b = I)`` the likelihood depends on ``(a, b)`` only and the uniform prior on
``(m, x, rho)`` becomes the density ``1 / (2 m^2 rho)`` (the inverse of the Jacobian
``|d(m, a, b) / d(m, x, rho)| = 2 m^2 rho``) on the image of the box. A midpoint rule on a fine,
data-adapted grid gives moments, quantiles and marginal densities of every parameter. This code
shares nothing with the sampler's parametrisation, so agreement between the two is a real check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inertiafit.observations import Observation
from inertiafit.physics import GRAVITY
from inertiafit.priors import Prior

QUANTITIES = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")


@dataclass(frozen=True)
class ReferencePosterior:
    """Weighted grid points of the exact posterior.

    Attributes
    ----------
    values : dict of str to ndarray
        Each quantity at the grid points with non-zero weight (SI units).
    weights : ndarray
        Normalised posterior weights of those points.
    """

    values: dict[str, np.ndarray]
    weights: np.ndarray

    def mean(self, name: str) -> float:
        """Posterior mean of a quantity."""
        return float(np.sum(self.weights * self.values[name]))

    def sd(self, name: str) -> float:
        """Posterior standard deviation of a quantity."""
        mu = self.mean(name)
        return float(np.sqrt(np.sum(self.weights * (self.values[name] - mu) ** 2)))

    def cdf(self, name: str, x) -> np.ndarray:
        """Posterior CDF of a quantity at ``x``."""
        order = np.argsort(self.values[name])
        v = self.values[name][order]
        c = np.cumsum(self.weights[order])
        return np.interp(np.asarray(x), v, c, left=0.0, right=1.0)

    def quantile(self, name: str, q) -> np.ndarray:
        """Posterior quantiles of a quantity."""
        order = np.argsort(self.values[name])
        v = self.values[name][order]
        c = np.cumsum(self.weights[order])
        return np.interp(np.asarray(q), c, v)


def reference_posterior(
    prior: Prior,
    inertia: Observation,
    gravity_moment: Observation,
    *,
    gravity: float = GRAVITY,
    n_identified: int = 120,
    n_mass: int = 400,
    tail: float = 1e-7,
) -> ReferencePosterior:
    """Posterior of one body by quadrature on a grid in ``(m, m x, I)``.

    Parameters
    ----------
    prior : Prior
        The body's box.
    inertia, gravity_moment : Observation
        Evidence on ``I`` (kg m^2) and ``M_g`` (N m).
    gravity : float
        m/s^2.
    n_identified, n_mass : int
        Grid points along ``a`` and ``b`` each, and along ``m``.
    tail : float
        Likelihood mass left outside the ``(a, b)`` grid.

    Returns
    -------
    ReferencePosterior
    """
    lo, up = prior.lower, prior.upper
    a_lo, a_hi = lo["mass"] * lo["com_distance"], up["mass"] * up["com_distance"]
    b_lo = lo["mass"] * (lo["radius_of_gyration"] ** 2 + lo["com_distance"] ** 2)
    b_hi = up["mass"] * (up["radius_of_gyration"] ** 2 + up["com_distance"] ** 2)
    ca, ha = gravity_moment.center / gravity, gravity_moment.quantile_halfwidth(tail) / gravity
    cb, hb = inertia.center, inertia.quantile_halfwidth(tail)
    a_edges = np.linspace(max(a_lo, ca - ha), min(a_hi, ca + ha), n_identified + 1)
    b_edges = np.linspace(max(b_lo, cb - hb), min(b_hi, cb + hb), n_identified + 1)
    a = 0.5 * (a_edges[1:] + a_edges[:-1])
    b = 0.5 * (b_edges[1:] + b_edges[:-1])
    # Masses the grid can reach: rho >= 0 gives m >= a^2 / b; x inside its bounds bounds m too.
    m_min = max(lo["mass"], a_edges[0] ** 2 / b_edges[-1], a_edges[0] / up["com_distance"])
    m_max = min(up["mass"], a_edges[-1] / lo["com_distance"])
    m_edges = np.linspace(m_min, m_max, n_mass + 1)
    m = 0.5 * (m_edges[1:] + m_edges[:-1])

    log_l = inertia.logpdf(b)[None, :] + gravity_moment.logpdf(gravity * a)[:, None]
    like = np.exp(log_l - log_l.max())  # (a, b)
    M, A, B = np.meshgrid(m, a, b, indexing="ij")
    x = A / M
    rho2 = B / M - x * x
    inside = (
        (x >= lo["com_distance"])
        & (x <= up["com_distance"])
        & (rho2 >= lo["radius_of_gyration"] ** 2)
        & (rho2 <= up["radius_of_gyration"] ** 2)
    )
    rho = np.sqrt(np.where(inside, rho2, 1.0))
    w = np.where(inside, like[None, :, :] / (2 * M * M * rho), 0.0)
    keep = w > 0
    weights = w[keep]
    weights = weights / weights.sum()
    values = {
        "mass": M[keep],
        "com_distance": x[keep],
        "radius_of_gyration": rho[keep],
        "inertia": B[keep],
        "gravity_moment": gravity * A[keep],
    }
    return ReferencePosterior(values=values, weights=weights)
