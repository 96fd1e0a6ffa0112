"""Exact single-body posterior by quadrature, the yardstick for the sampler.

For one body in one condition the posterior is a 3-D integral. On a grid in
``(m, a = m x, b = I)`` the likelihood depends on ``(a, b)`` only and the prior density
``p(m, x, rho)`` on ``(m, x, rho)`` becomes ``p(m, x, rho) / (2 m^2 rho)`` (over the Jacobian
``|d(m, a, b) / d(m, x, rho)| = 2 m^2 rho``) on the image of its support box. A midpoint rule on a fine,
data-adapted grid gives moments, quantiles and marginal densities of every parameter. This code
shares nothing with the sampler's parametrisation, so agreement between the two is a real check.
Evidence beyond the body's own condition (a weighed mass, a balance point, a second mounting,
any registered kind) enters as the same term objects the model holds
(:mod:`inertiafit.inference.terms`), evaluated on this grid of the body's parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from inertiafit import physics
from inertiafit._checks import check_positive, check_whole
from inertiafit.inference.model import (
    Condition,
    angles_at,
    feasible_measure,
    log_identified_prior,
)
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior
from inertiafit.inference.star import Star, star_structure
from inertiafit.inference.terms import ConditionEvidence, MeasuredEvidence, Term
from inertiafit.physics import GRAVITY

__all__ = ["ReferencePosterior", "gain_reference", "reference_posterior", "star_reference"]


#: The one body of :func:`reference_posterior`, as its terms name it.
_BODY = "body"


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

    def agreement(self, draws) -> tuple[float, float]:
        """How far draws are from this posterior: the yardstick of every sampler check.

        ``draws`` maps quantity names to arrays of draws (any shape). Returns the largest
        ``|mean - reference mean|`` in reference SDs and the largest ``|SD / reference SD - 1|``
        over those quantities.
        """
        worst_mean = worst_sd = 0.0
        for q, values in draws.items():
            x = np.ravel(values)
            worst_mean = max(worst_mean, abs(float(x.mean()) - self.mean(q)) / self.sd(q))
            worst_sd = max(worst_sd, abs(float(x.std()) / self.sd(q) - 1))
        return worst_mean, worst_sd

    def quantile(self, name: str, q) -> np.ndarray:
        """Posterior quantiles of a quantity."""
        order = np.argsort(self.values[name])
        v = self.values[name][order]
        c = np.cumsum(self.weights[order])
        return np.interp(np.asarray(q), c, v)


def _identified_support(prior: Prior) -> tuple[tuple[float, float], tuple[float, float]]:
    """Ranges of ``a = m x`` and ``b = I`` over the prior box (its corners bound both)."""
    lo, up = prior.lower, prior.upper
    a_rng = (lo["mass"] * lo["com_distance"], up["mass"] * up["com_distance"])
    b_rng = (
        float(physics.inertia(lo["mass"], lo["radius_of_gyration"], lo["com_distance"])),
        float(physics.inertia(up["mass"], up["radius_of_gyration"], up["com_distance"])),
    )
    return a_rng, b_rng


def _edges(center: float, half: float, support: tuple[float, float], n: int) -> np.ndarray:
    """``n + 1`` cell edges over ``center +- half`` clipped to ``support``."""
    return np.linspace(max(support[0], center - half), min(support[1], center + half), n + 1)


def _midpoints(edges: np.ndarray) -> np.ndarray:
    return 0.5 * (edges[1:] + edges[:-1])


def _angle_points(a, b, prior: Prior, n_angle: int, gravity: float):
    """Each ``(a, b)`` point (1-D arrays) split over ``n_angle`` angles on ``Psi(a, b)``.

    The angles are the midpoints of ``n_angle`` equal parts of ``Psi(a, b)``. Returns the
    flattened values of every quantity and ``(mass, x, rho)`` as ``(n, n_angle)`` arrays.
    """
    aa = np.repeat(np.asarray(a)[:, None], n_angle, 1)
    bb = np.repeat(np.asarray(b)[:, None], n_angle, 1)
    psi = angles_at(aa, bb, prior, (np.arange(n_angle) + 0.5) / n_angle)
    mass, x, rho = physics.parameters_from_identified(aa, bb, psi)
    values = {
        "mass": mass.ravel(),
        "com_distance": x.ravel(),
        "radius_of_gyration": rho.ravel(),
        "inertia": bb.ravel(),
        "gravity_moment": gravity * aa.ravel(),
    }
    return values, (mass, x, rho)


def _angle_weights(prior: Prior, mass, x, rho) -> np.ndarray:
    """How each ``(a, b)`` point's weight splits over its angles (rows of ``(n, n_angle)``).

    Equal for a box; the prior density at each angle, normalised per row, otherwise.
    """
    n_angle = np.shape(mass)[-1]
    if prior.is_box:
        return np.full(np.shape(mass), 1.0 / n_angle)
    log_p = prior.log_density(mass, x, rho, check_support=False)
    w = np.exp(log_p - log_p.max(-1, keepdims=True))
    return w / w.sum(-1, keepdims=True)


def reference_posterior(
    prior: Prior,
    inertia: Observation,
    gravity_moment: Observation,
    *,
    gravity: float = GRAVITY,
    coupling: float = 0.0,
    mass: Observation | None = None,
    com_distance: Observation | None = None,
    offset: float = 0.0,
    offset_inertia: Observation | None = None,
    offset_gravity_moment: Observation | None = None,
    terms: Sequence[Term] = (),
    n_identified: int = 120,
    n_mass: int = 400,
    tail: float = 1e-7,
) -> ReferencePosterior:
    """Posterior of one body by quadrature on a grid in ``(m, m x, I)``.

    Parameters
    ----------
    prior : Prior
        The body's prior (a box or other distributions; :meth:`Prior.log_density` weights
        each grid point).
    inertia, gravity_moment : Observation
        Evidence on ``I`` (kg m^2) and ``M_g`` (N m).
    gravity : float
        m/s^2.
    coupling : float
        The condition's ``coupling`` (:class:`~inertiafit.inference.model.Condition`): the
        inertia evidence is evaluated at ``I + coupling * (M_g_obs - M_g)``.
    mass, com_distance : Observation, optional
        A weighed mass (kg) and a balance-point centre of mass (m).
    offset, offset_inertia, offset_gravity_moment : float, Observation, Observation
        A second mounting ``offset`` metres further out and its evidence on
        ``I + 2 m x d + m d^2`` and ``m g (x + d)``.
    terms : sequence of Term
        Further evidence on this body alone (:mod:`inertiafit.inference.terms`); ``mass``,
        ``com_distance`` and the second mounting become such terms too.
    n_identified, n_mass : int
        Grid points along ``a`` and ``b`` each, and along ``m``.
    tail : float
        Likelihood mass left outside the ``(a, b)`` grid.

    Returns
    -------
    ReferencePosterior
    """
    n_identified = check_whole(n_identified, "n_identified", 2)
    n_mass = check_whole(n_mass, "n_mass", 2)
    gravity = check_positive(gravity, "gravity", "m/s^2")
    lo, up = prior.lower, prior.upper
    a_rng, b_rng = _identified_support(prior)
    ca, ha = gravity_moment.center / gravity, gravity_moment.quantile_halfwidth(tail) / gravity
    cb, hb = inertia.center, inertia.quantile_halfwidth(tail) + abs(coupling) * ha * gravity
    a_edges = _edges(ca, ha, a_rng, n_identified)
    b_edges = _edges(cb, hb, b_rng, n_identified)
    a, b = _midpoints(a_edges), _midpoints(b_edges)
    # Masses the grid can reach: rho >= 0 gives m >= a^2 / b; x inside its bounds bounds m too.
    m_min = max(lo["mass"], a_edges[0] ** 2 / b_edges[-1], a_edges[0] / up["com_distance"])
    m_max = min(up["mass"], a_edges[-1] / lo["com_distance"])
    extra: list[Term] = [
        MeasuredEvidence(_BODY, key, obs)
        for key, obs in (("mass", mass), ("com_distance", com_distance))
        if obs is not None
    ]
    if offset:
        moved = Condition(
            (_BODY,), offset_inertia, offset_gravity_moment, offset_body=_BODY, offset=offset
        )
        extra.append(ConditionEvidence(0, moved, gravity))
    extra.extend(terms)
    # Masses the extra evidence allows, over the whole (a, b) grid.
    for term in extra:
        lo_m, hi_m = term.body_masses((a_edges[0], a_edges[-1]), tail)
        m_min, m_max = max(m_min, lo_m), min(m_max, hi_m)
    m_edges = np.linspace(m_min, m_max, n_mass + 1)
    m = 0.5 * (m_edges[1:] + m_edges[:-1])

    shift = coupling * (gravity_moment.center - gravity * a)  # (a,)
    log_l = (
        inertia.logpdf(b[None, :] + shift[:, None]) + gravity_moment.logpdf(gravity * a)[:, None]
    )
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
    if not prior.is_box:  # the prior density in (m, x, rho), relative to its peak
        log_p = np.where(inside, prior.log_density(M, x, rho, check_support=False), -np.inf)
        w = w * np.exp(log_p - log_p.max())
    log_extra = np.zeros(M.shape)
    params = {
        "mass": M,
        "com_distance": x,
        "radius_of_gyration": rho,
        "first_moment": A,
        "inertia": B,
    }
    for term in extra:
        log_extra = log_extra + term.body_log_likelihood(params)
    if extra:
        top = np.max(np.where(inside, log_extra, -np.inf))
        w = w * np.exp(np.where(inside, log_extra - top, -np.inf))
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


def star_reference(
    model,
    *,
    n_grid: int = 160,
    n_angle: int = 0,
    tail: float = 1e-6,
) -> dict[str, ReferencePosterior]:
    """Exact posterior of a study of one shared body and leaves, by quadrature on grids.

    The model's structure must be the one :func:`inertiafit.inference.star.star_structure` finds,
    with exactly one shared body ``S`` (the attachment) measured alone, and each leaf ``k``
    measured once with ``S``. Each body gets a grid in its identified pair ``(a, b)``; with
    ``pi`` a body's prior density in ``(a, b)`` (``|Psi(a, b)| / a``, see
    :mod:`inertiafit.inference.model`) and ``L`` a condition's evidence,

        w_S(a, b)   = pi_S L_S (a, b)  prod_k C_k(a, b),
        C_k(a, b)   = sum over leaf k's grid of  pi_k(a_k, b_k) L_k(a + a_k, b + b_k),
        w_k(a_k, b_k) = pi_k(a_k, b_k) sum over S's grid of  w_S / C_k * L_k(a + a_k, b + b_k).

    Every sum is a product of matrices (the evidence factorises into the gravity moment and
    the inertia), so the cost is ``O(K n^3)`` for ``K`` leaves: exact to the grid's resolution
    for any ``K``. It shares with the sampler only the prior density in ``(a, b)``, which is
    tested on its own against draws from the box.

    Parameters
    ----------
    model : Model
        One shared body and its leaves.
    n_grid : int
        Grid points along each of ``a`` and ``b`` per body.
    n_angle : int
        With ``n_angle > 0``, each ``(a, b)`` point is split over that many angles
        ``psi`` uniform on ``Psi(a, b)``, so the mass, centre-of-mass distance and radius of
        gyration get weights too; with 0 only ``inertia`` and ``gravity_moment`` are filled.
    tail : float
        Evidence mass left outside each grid.

    Returns
    -------
    dict of str to ReferencePosterior
        One per body, keyed by name.
    """
    star: Star | None
    if len(model.bodies) == 1:  # no leaves: the body alone
        star = Star((0,), (), (), tuple(range(len(model.conditions))), np.zeros((0, 1)))
    else:
        star = star_structure(model)
    if star is None or len(star.shared) != 1 or not star.shared_conditions:
        raise ValueError("star_reference: needs one shared body measured alone, and leaves")
    if model.has_gain or any(c.coupling for c in model.conditions):
        raise ValueError("star_reference: no torque gain or coupled evidence (see gain_reference)")
    g = model.gravity
    shared = model.bodies[star.shared[0]]
    own = [model.conditions[ci] for ci in star.shared_conditions]
    if any(c.inertia is None or c.gravity_moment is None for c in own):
        raise ValueError("star_reference: the shared body's conditions need both observables")

    def grid(center, half, support):
        return _midpoints(_edges(center, half, support, n_grid))

    def log_prior(a, b, prior):
        return log_identified_prior(a[:, None], b[None, :], prior)

    def evidence(obs, values):
        return np.exp(obs.logpdf(values))

    # The shared body's grid, from its own evidence (the tightest of its conditions).
    c0 = min(own, key=lambda c: c.inertia.scale)  # type: ignore[union-attr]
    ca_s, ha_s = c0.gravity_moment.center / g, c0.gravity_moment.quantile_halfwidth(tail) / g  # type: ignore[union-attr]
    cb_s, hb_s = c0.inertia.center, c0.inertia.quantile_halfwidth(tail)  # type: ignore[union-attr]
    sa_rng, sb_rng = _identified_support(model.priors[shared])
    a_s, b_s = grid(ca_s, ha_s, sa_rng), grid(cb_s, hb_s, sb_rng)
    log_ws = log_prior(a_s, b_s, model.priors[shared])
    for c in own:
        log_ws = (
            log_ws + c.gravity_moment.logpdf(g * a_s)[:, None] + c.inertia.logpdf(b_s)[None, :]
        )  # type: ignore[union-attr]

    leaves = []
    log_c = []
    for j, ci in zip(star.leaves, star.leaf_conditions, strict=True):
        cond = model.conditions[ci]
        prior = model.priors[model.bodies[j]]
        obs_g, obs_i = cond.gravity_moment, cond.inertia
        ca, ha = obs_g.center / g - ca_s, (obs_g.quantile_halfwidth(tail) / g) + ha_s  # type: ignore[union-attr]
        cb, hb = obs_i.center - cb_s, obs_i.quantile_halfwidth(tail) + hb_s  # type: ignore[union-attr]
        a_rng, b_rng = _identified_support(prior)
        a_k, b_k = grid(ca, ha, a_rng), grid(cb, hb, b_rng)
        pi_k = np.exp(log_prior(a_k, b_k, prior))
        lg = evidence(obs_g, g * (a_s[:, None] + a_k[None, :]))  # (S_a, k_a)
        li = evidence(obs_i, b_s[:, None] + b_k[None, :])  # (S_b, k_b)
        with np.errstate(divide="ignore"):
            log_c.append(np.log(lg @ pi_k @ li.T))
        leaves.append((model.bodies[j], a_k, b_k, pi_k, lg, li))
    total_c = np.sum(log_c, axis=0) if log_c else 0.0
    log_w_shared = log_ws + total_c

    def normalised(log_w):
        w = np.exp(log_w - np.max(log_w))
        return w / w.sum()

    grids = {shared: (a_s, b_s, normalised(log_w_shared))}
    for (name, a_k, b_k, pi_k, lg, li), lc in zip(leaves, log_c, strict=True):
        rest = normalised(np.where(np.isfinite(lc), log_ws + total_c - lc, -np.inf))
        w_k = pi_k * (lg.T @ rest @ li)
        grids[name] = (a_k, b_k, w_k / w_k.sum())

    out = {}
    for name, (a, b, w) in grids.items():
        A, B = np.meshgrid(a, b, indexing="ij")
        keep = w > 0
        values = {"inertia": B[keep], "gravity_moment": g * A[keep]}
        weights = w[keep]
        if n_angle:
            # psi on Psi(a, b), weighted by the prior along the curve (equal for a box)
            prior = model.priors[name]
            values, (mass, x, rho) = _angle_points(A[keep], B[keep], prior, n_angle, g)
            split = _angle_weights(prior, mass, x, rho)
            weights = (weights[:, None] * split).ravel()
        out[name] = ReferencePosterior(values=values, weights=weights)
    return out


def gain_reference(
    prior: Prior,
    conditions,
    *,
    torque_gain_sd: float,
    gravity: float = GRAVITY,
    n_grid: int = 120,
    n_gain: int = 41,
    n_angle: int = 16,
    tail: float = 1e-7,
) -> ReferencePosterior:
    """Posterior of one body with a torque gain, by quadrature on a grid in ``(a', b', log g)``.

    The evidence depends on the observed-scale values ``(a', b') = gain * (a, b)`` only, so the
    grid is laid over them (where the evidence is) and over ``log gain`` (its Normal prior,
    ``+-6`` SDs); each point stands for the true ``(a, b) = (a', b') / gain`` with weight
    ``L(a', b') N(log gain) pi(a, b) / gain^2`` (``pi = |Psi| / a`` the box's density in
    ``(a, b)``, ``1 / gain^2`` the Jacobian), split over ``n_angle`` angles uniform on
    ``Psi(a, b)``. The evidence is computed here from the observations, not by the model.

    Parameters
    ----------
    prior : Prior
        The body's box.
    conditions : sequence of Condition
        Conditions holding this body alone (both observables; ``coupling`` honoured).
    torque_gain_sd : float
        SD of ``log gain``.
    gravity : float
        m/s^2.
    n_grid, n_gain, n_angle : int
        Grid points along ``a'`` and ``b'`` each, along ``log gain``, and angles per point.
    tail : float
        Evidence mass left outside the grid.
    """
    g = gravity
    tight = min(conditions, key=lambda c: c.inertia.scale)
    ca, ha = tight.gravity_moment.center / g, tight.gravity_moment.quantile_halfwidth(tail) / g
    cb = tight.inertia.center
    hb = tight.inertia.quantile_halfwidth(tail) + abs(tight.coupling) * ha * g
    a_obs = np.linspace(ca - ha, ca + ha, n_grid)
    b_obs = np.linspace(cb - hb, cb + hb, n_grid)
    log_l = np.zeros((n_grid, n_grid))
    for c in conditions:
        shift = c.coupling * (c.gravity_moment.center - g * a_obs)
        log_l = log_l + c.gravity_moment.logpdf(g * a_obs)[:, None]
        log_l = log_l + c.inertia.logpdf(b_obs[None, :] + shift[:, None])
    ell = np.linspace(-6 * torque_gain_sd, 6 * torque_gain_sd, n_gain)
    A, B, ELL = np.meshgrid(a_obs, b_obs, ell, indexing="ij")
    a, b = A * np.exp(-ELL), B * np.exp(-ELL)
    with np.errstate(divide="ignore"):
        log_w = (
            log_l[:, :, None]
            - 0.5 * (ELL / torque_gain_sd) ** 2
            + np.log(feasible_measure(a, b, prior))
            - np.log(a)
            - 2 * ELL
        )  # |Psi| / a: the box's density, times the mean of the prior along Psi below
    keep = np.isfinite(log_w)
    w = np.exp(log_w[keep] - log_w[keep].max())
    values, (mass, x, rho) = _angle_points(a[keep], b[keep], prior, n_angle, g)
    values["torque_gain"] = np.repeat(np.exp(ELL[keep]), n_angle)
    if prior.is_box:
        weights = np.repeat(w / w.sum() / n_angle, n_angle)
    else:  # each angle carries |Psi| / (a n_angle) times the prior density there
        log_p = prior.log_density(mass, x, rho, check_support=False)
        weights = (w[:, None] * np.exp(log_p - log_p.max())).ravel()
        weights = weights / weights.sum()
    return ReferencePosterior(values=values, weights=weights)
