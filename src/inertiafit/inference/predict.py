"""Posterior widths of a model without a sampler: importance sampling around its Laplace fit.

Planning a session (:mod:`inertiafit.planning`) asks how wide the posterior of each body's
``(m, x, rho, I, M_g)`` will be for a design, many designs at a time. The posterior of a model
at its *expected* data (observations centred on the nominal truth with the design's standard
errors) answers that; this module computes its SDs and HDI widths in a fraction of a second:

1. a Gaussian in the sampled coordinates ``z`` (``log a, log b`` per body, and ``log gain``)
   from the evidence linearised (it is linear in ``(a, b)``: sums over mounted bodies) and the
   prior's moments of ``(a, b)`` (:func:`evidence_gaussian`; no optimiser, which is what
   makes a design fast: :func:`~inertiafit.inference.moves.laplace_fit`'s
   Nelder-Mead took 0.9 s of 1 s);
2. points are drawn from the samplers' Student-t proposal around it (widened by
   :data:`INFLATION`) and weighted by ``exp(log_prob(z) - log q(z))``
   (:meth:`~inertiafit.inference.model.Model.log_prob` is the exact marginal density of ``z``);
3. the proposal is refitted to the weighted mean and covariance and step 2 runs again (one
   adaptive round: a Laplace fit on a kink of the prior is too narrow or too wide);
4. the weighted draws are resampled (systematic resampling) and completed with exact angle
   draws (:meth:`~inertiafit.inference.model.Model.parameters`): the unidentified part of every
   body comes from its exact conditional, not an approximation.

The result is the exact posterior up to Monte Carlo error (its effective sample size is
returned), so the only approximation of the plan is the expected data itself.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from inertiafit.inference.model import Model
from inertiafit.inference.moves import StudentTProposal, laplace_fit
from inertiafit.physics import REPORTED

__all__ = ["DRAWS", "INFLATION", "Widths", "evidence_gaussian", "hdi_width", "posterior_widths"]

#: Importance draws of the final round (the first, which only refits the proposal, has a
#: quarter of them).
DRAWS = 4000

#: Widening of the proposal's covariance, in standard deviations.
INFLATION = 1.5


@dataclass(frozen=True)
class Widths:
    """Posterior SD and HDI width of every body's reported parameters.

    Attributes
    ----------
    bodies : tuple of str
        Body names, in model order.
    sd, hdi_width : dict of str to ndarray
        Per reported parameter (:data:`inertiafit.physics.REPORTED`) an array ``(K,)``.
    hdi_prob : float
        Probability of the HDIs.
    ess : float
        Effective sample size of the final importance weights (Kish).
    """

    bodies: tuple[str, ...]
    sd: dict[str, np.ndarray]
    hdi_width: dict[str, np.ndarray]
    hdi_prob: float
    ess: float


def hdi_width(draws, prob: float) -> np.ndarray:
    """Width of the narrowest interval holding ``prob`` of equal-weight draws (axis 0).

    The same estimator as ArviZ's HDI of a unimodal sample: over the sorted draws, the
    shortest span of ``ceil(prob n)`` consecutive ones.
    """
    x = np.sort(np.asarray(draws, float), axis=0)
    n = len(x)
    k = int(np.ceil(prob * n))
    spans = x[k - 1 :] - x[: n - k + 1]
    return spans.min(axis=0)


def evidence_gaussian(model: Model, rng: np.random.Generator, n_prior: int = 2000):
    """A Gaussian ``(mean, cov)`` in ``model``'s sampled coordinates from its linear evidence.

    The gravity moment and inertia of a condition are ``g sum(a_k)`` and ``sum(b_k)`` over its
    bodies (plus known added masses): a linear Gaussian model in ``(a, b)`` with the evidence's
    variances (``scale^2 df/(df-2)`` for a Student-t, plus the shared error), combined with a
    Gaussian of the prior's mean and covariance of ``(a, b)`` (from ``n_prior`` prior draws),
    then mapped to ``log a, log b`` to first order. Conditions with a moved body are left out
    (their evidence also involves the mass), so is the coupling to the gravity model. The log
    gain, when modelled, is centred on 0 with its prior SD, independent of the rest.
    """
    k = len(model.bodies)
    draws = model.prior_draws(n_prior, rng)
    ab = np.hstack([draws["gravity_moment"] / model.gravity, draws["inertia"]])
    mu0 = ab.mean(0)
    prec = np.linalg.inv(np.cov(ab, rowvar=False) + 1e-18 * np.eye(2 * k))
    rhs = prec @ mu0
    g = model.gravity
    for ci, cond in enumerate(model.conditions):
        if cond.offset_body:
            continue
        w = model.membership[ci]
        for obs, row, known in (
            (
                cond.gravity_moment,
                np.concatenate([g * w, np.zeros(k)]),
                g * cond.added_first_moment,
            ),
            (cond.inertia, np.concatenate([np.zeros(k), w]), cond.added_inertia),
        ):
            if obs is None:
                continue
            inflate = 1.0 if obs.is_gaussian else (obs.df / (obs.df - 2) if obs.df > 2 else 3.0)
            var = obs.scale**2 * inflate
            var += obs.shared_sd**2
            prec = prec + np.outer(row, row) / var
            rhs = rhs + row * (obs.center - known) / var
    cov_ab = np.linalg.inv(prec)
    mean_ab = np.maximum(cov_ab @ rhs, 1e-6 * np.abs(mu0))
    jac = 1.0 / mean_ab  # d log(v) / dv
    order = np.empty(2 * k, dtype=int)  # (a_1..a_k, b_1..b_k) -> (a_1, b_1, a_2, ...)
    order[0::2], order[1::2] = np.arange(k), k + np.arange(k)
    mean = np.log(mean_ab)[order]
    cov = (jac[:, None] * cov_ab * jac[None, :])[np.ix_(order, order)]
    if model.has_gain:
        mean = np.append(mean, 0.0)
        cov = np.pad(cov, ((0, 1), (0, 1)))
        cov[-1, -1] = model.torque_gain_sd**2
    return mean, cov


def _weights(model: Model, proposal: StudentTProposal, n: int, rng: np.random.Generator):
    z = proposal.draw(n, rng)
    log_w = model.log_prob(z) - proposal.log_density(z)
    ok = np.isfinite(log_w)
    w = np.zeros(n)
    if ok.any():
        w[ok] = np.exp(log_w[ok] - log_w[ok].max())
        w /= w.sum()
    return z, w


def posterior_widths(
    model: Model,
    *,
    hdi_prob: float = 0.95,
    draws: int = DRAWS,
    rng: np.random.Generator | int = 0,
) -> Widths:
    """Posterior SD and HDI width of every body's parameters by importance sampling.

    Parameters
    ----------
    model : Model
        Priors and evidence (usually the expected evidence of a design).
    hdi_prob : float
        Probability of the HDIs.
    draws : int
        Importance draws of the final round (a quarter of them in the first).
    rng : numpy.random.Generator or int
        Randomness (a seed gives the same widths every time: designs compared with the same
        seed share their random numbers).

    Returns
    -------
    Widths
    """
    rng = np.random.default_rng(rng)
    df = 5.0
    mean, cov = evidence_gaussian(model, rng)
    proposal = StudentTProposal(mean, cov, df, inflate=INFLATION)
    first = max(draws // 4, 500)
    z, w = _weights(model, proposal, first, rng)
    if w.sum() == 0 or 1.0 / np.sum(w * w) < 0.02 * first:  # fall back on the Laplace fit
        mode, cov = laplace_fit(model, rng)
        proposal = StudentTProposal(mode, cov, df, inflate=INFLATION)
        z, w = _weights(model, proposal, first, rng)
    if w.sum() > 0:  # one adaptive round: the proposal refitted to the weighted draws
        mean = w @ z
        dz = z - mean
        cov2 = (w[:, None] * dz).T @ dz
        with contextlib.suppress(np.linalg.LinAlgError):
            proposal = StudentTProposal(mean, cov2, df, inflate=INFLATION)
        z2, w2 = _weights(model, proposal, draws, rng)
        if w2.sum() > 0:
            z, w = z2, w2
    ess = float(1.0 / np.sum(w * w)) if w.sum() > 0 else 0.0
    # systematic resampling to equal weights, then exact angles
    cdf = np.cumsum(w)
    cdf[-1] = 1.0
    u = (rng.uniform() + np.arange(draws)) / draws
    idx = np.searchsorted(cdf, u)
    params = model.parameters(z[idx], rng)
    sd = {p: params[p].std(axis=0, ddof=1) for p in REPORTED}
    width = {p: hdi_width(params[p], hdi_prob) for p in REPORTED}
    return Widths(model.bodies, sd, width, float(hdi_prob), ess)
