"""A population of subjects: regressions of a segment's ``(m, x, rho)`` with between-subject scatter.

Each subject's study gives draws of a body's ``(m, x, rho)`` under the prior it was fitted with
(its *interim* prior ``pi_i``). The population model says, per body name,

    log m_i   = a_m + sum_k b_mk c_ik + e_im
    log x_i   = a_x + sum_k b_xk c_ik + e_ix        e_i ~ N(0, Sigma)
    log rho_i = a_r + sum_k b_rk c_ik + e_ir

with ``Sigma = D R D`` (``D`` the scatters ``sigma_p``, ``R`` a correlation matrix). The
covariates ``c`` are the log of ``body_mass``, ``segment_length`` and ``height`` (centred on
the cohort's geometric mean, so ``a`` is the log value of a typical subject and ``b`` an
elasticity: 1 is isometric scaling) or any other number the ``[subject]`` table holds (centred
and divided by its SD across the cohort).

The hyperparameters ``lambda = (a, b, sigma, R)`` are inferred from the stored draws by
importance reweighting (Hogg, Myers & Bovy 2010, ApJ 725:2166): each subject's marginal
likelihood is, up to a constant, the mean over its draws ``s`` of
``p_pop(theta_s | lambda) / pi_i(theta_s)``, with ``p_pop`` the population density in
``(m, x, rho)`` (the log-normal above over ``m x rho``). The estimate is good where the draws
cover the population density: each subject's importance-weight ESS says so, and the draws
cannot represent population mass outside the subject's prior box (:func:`box_mass` measures it).

Hyperprior (:class:`Hyperprior`): intercepts normal around the subjects' own priors' nominal
values (SD ``intercept_sd`` in log units), slopes on log covariates normal around 1 and on
others around 0, each scatter lognormal around 10 %, and ``R`` from the LKJ distribution, written through
its canonical partial correlations (Lewandowski, Kurowicka & Joe 2009, J Multivar Anal
100:1989): for three parameters ``r_12, r_13 ~ Beta(eta + 1/2)`` and ``r_23|1 ~ Beta(eta)``
on ``(-1, 1)``. emcee samples ``(a, b, log sigma, atanh r)``.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from inertiafit._checks import check_positive
from inertiafit.errors import InputError
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED, gravity_moment, inertia

__all__ = [
    "DEFAULT_COVARIATES",
    "LOG_COVARIATES",
    "MIN_ESS",
    "Cells",
    "Design",
    "Hyperprior",
    "PopulationFit",
    "SubjectDraws",
    "box_mass",
    "correlation_matrix",
    "hdi_bounds",
    "hyper_log_prior",
    "log_likelihood",
    "predictive_draws",
    "reported",
    "sample_hyperprior",
]

#: What each parameter is regressed on unless told otherwise.
DEFAULT_COVARIATES: dict[str, tuple[str, ...]] = {
    "mass": ("body_mass",),
    "com_distance": ("segment_length",),
    "radius_of_gyration": ("segment_length",),
}
#: Covariates that enter by their logarithm (positive sizes); any other is centred and scaled.
LOG_COVARIATES = frozenset({"body_mass", "segment_length", "height"})
#: Importance-weight ESS below which a subject's draws cannot represent the population (its
#: pooled draws are then a few of its own; :func:`log_likelihood` can cut the density there,
#: since as a scatter shrinks toward zero the mean over single draws is carried by the one
#: nearest the regression and grows without bound, where the exact likelihood stays finite:
#: measured, five subjects' population ran to ESS 1 for one subject with every stored draw;
#: :class:`Cells` has no such limit).
MIN_ESS = 30.0
_LOG_2PI = math.log(2 * math.pi)
_PAIRS = ((0, 1), (0, 2), (1, 2))


@dataclass(frozen=True)
class Hyperprior:
    """The prior of the population's hyperparameters (log units for ``a``, ``sigma``).

    Attributes
    ----------
    intercept_sd : float
        SD of each intercept around its centre (1.0: a factor of e either way).
    intercept_mean : tuple of float or None
        Centre of each intercept (log SI units, order ``mass, com_distance,
        radius_of_gyration``); ``None``: the log geometric mean of the subjects' own priors'
        nominal values.
    slope_sd : float
        SD of every slope; a log covariate's slope is centred on 1 (isometry), another's on 0.
    scatter_median, scatter_sd_log : float
        Each scatter ``sigma_p`` is lognormal: median 0.1 (10 % between subjects of the same
        covariates), SD of its log 0.75 (95 % between 2.3 % and 43 %). Published tables miss
        individual segments by up to 40 % (Durkin & Dowling 2003) and DXA models by about 5 %
        (DOMAIN.md); a half-normal scatter, with its mode at 0, gave the sampler a funnel it
        could not leave when the subjects do not bound the scatter (measured: 20 000 steps
        unconverged for five subjects).
    lkj_eta : float
        Shape of the LKJ prior of the correlation matrix (1: uniform; 2: mild shrinkage to 0).
    """

    intercept_sd: float = 1.0
    intercept_mean: tuple[float, float, float] | None = None
    slope_sd: float = 1.0
    scatter_median: float = 0.1
    scatter_sd_log: float = 0.75
    lkj_eta: float = 2.0

    def __post_init__(self) -> None:
        for name in ("intercept_sd", "slope_sd", "scatter_median", "scatter_sd_log", "lkj_eta"):
            check_positive(getattr(self, name), f"hyperprior: {name}")
        if self.intercept_mean is not None and len(self.intercept_mean) != 3:
            raise InputError("hyperprior: intercept_mean: expected three log values (m, x, rho)")


@dataclass(frozen=True)
class Design:
    """Which covariates each parameter is regressed on, and how they are centred.

    Attributes
    ----------
    covariates : dict of str to tuple of str
        Per parameter (``mass``, ``com_distance``, ``radius_of_gyration``), its covariates.
    centers, scales : dict of str to float
        Per covariate: the centre (log units for a :data:`LOG_COVARIATES` covariate, else its
        own) and the scale (1 for a log covariate, else the cohort's SD).
    """

    covariates: dict[str, tuple[str, ...]]
    centers: dict[str, float]
    scales: dict[str, float]

    @classmethod
    def for_cohort(
        cls, covariates: Mapping[str, Sequence[str]], values: Sequence[Mapping[str, float]]
    ) -> Design:
        """The design for subjects with these covariate ``values`` (one mapping per subject)."""
        centers, scales = {}, {}
        names = sorted({c for cs in covariates.values() for c in cs})
        for name in names:
            v = np.array([float(s[name]) for s in values])
            if name in LOG_COVARIATES:
                centers[name], scales[name] = float(np.mean(np.log(v))), 1.0
            else:
                sd = float(np.std(v, ddof=1)) if len(v) > 1 else 0.0
                centers[name], scales[name] = float(np.mean(v)), sd if sd > 0 else 1.0
        return cls({p: tuple(covariates.get(p, ())) for p in PARAMETERS}, centers, scales)

    def transformed(self, name: str, value: float) -> float:
        """A covariate's value as the regression uses it."""
        if name in LOG_COVARIATES:
            return math.log(value) - self.centers[name]
        return (value - self.centers[name]) / self.scales[name]

    def reference(self, name: str) -> float:
        """The covariate's value where the intercept applies (its own units)."""
        return math.exp(self.centers[name]) if name in LOG_COVARIATES else self.centers[name]

    @property
    def terms(self) -> list[tuple[str, str]]:
        """``(parameter, term)`` of every coordinate, in the order of the sampled vector.

        ``intercept`` and one ``slope:<covariate>`` per covariate of each parameter, then
        ``scatter`` of each, then ``cpc:<p>,<q>`` (the canonical partial correlations).
        """
        out = []
        for p in PARAMETERS:
            out.append((p, "intercept"))
            out += [(p, f"slope:{c}") for c in self.covariates[p]]
        out += [(p, "scatter") for p in PARAMETERS]
        out += [(PARAMETERS[i], f"cpc:{PARAMETERS[j]}") for i, j in _PAIRS]
        return out

    @property
    def ndim(self) -> int:
        """Length of the sampled vector."""
        return len(self.terms)

    def matrices(self, subjects: Sequence[Mapping[str, float]]) -> list[np.ndarray]:
        """Per parameter, the design matrix ``(n_subjects, 1 + k_p)`` (a column of ones first)."""
        return [
            np.array(
                [[1.0, *(self.transformed(c, s[c]) for c in self.covariates[p])] for s in subjects]
            )
            for p in PARAMETERS
        ]

    def as_dict(self) -> dict:
        """JSON-ready description (``population.nc`` stores it)."""
        return {
            "covariates": {p: list(c) for p, c in self.covariates.items()},
            "centers": self.centers,
            "scales": self.scales,
            "log_covariates": sorted(LOG_COVARIATES),
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Design:
        """Inverse of :meth:`as_dict`."""
        return cls(
            {p: tuple(d["covariates"][p]) for p in PARAMETERS},
            {k: float(v) for k, v in d["centers"].items()},
            {k: float(v) for k, v in d["scales"].items()},
        )


@dataclass(frozen=True)
class SubjectDraws:
    """One subject's draws of one body, as the population layer uses them.

    Attributes
    ----------
    name : str
        The subject (its ``[subject]`` id, or its folder).
    log_theta : ndarray, shape (n, 3)
        ``log m, log x, log rho`` of the draws.
    log_interim : ndarray, shape (n,)
        The log density of the prior the draws were made under, at each draw, in
        ``(m, x, rho)`` (up to a constant).
    covariates : dict of str to float
        The subject's covariate values (own units).
    support : ndarray, shape (3, 2)
        The interim prior's bounds of ``m, x, rho`` (SI units).
    """

    name: str
    log_theta: np.ndarray
    log_interim: np.ndarray
    covariates: dict[str, float]
    support: np.ndarray

    def take(self, idx: np.ndarray) -> SubjectDraws:
        """The same subject with the draws ``idx`` (an index array or a mask), in that order."""
        return replace(self, log_theta=self.log_theta[idx], log_interim=self.log_interim[idx])

    @property
    def offset(self) -> np.ndarray:
        """``-log(m x rho) - log pi_i``: the draws' part of every log importance weight."""
        return -self.log_theta.sum(axis=1) - self.log_interim


# -- hyperparameters ------------------------------------------------------------------------
def _log_one_minus_tanh2(t: np.ndarray) -> np.ndarray:
    """``log(1 - tanh(t)^2)`` without cancellation."""
    a = np.abs(t)
    return 2.0 * (math.log(2.0) - a - np.log1p(np.exp(-2.0 * a)))


def split_vector(design: Design, z: np.ndarray):
    """The sampled vector ``(W, D)`` as per-parameter coefficients, scatters and CPCs."""
    coefs, i = [], 0
    for p in PARAMETERS:
        k = 1 + len(design.covariates[p])
        coefs.append(z[:, i : i + k])
        i += k
    return coefs, z[:, i : i + 3], z[:, i + 3 : i + 6]


def correlation_cholesky(cpc: np.ndarray) -> np.ndarray:
    """Cholesky factors ``(W, 3, 3)`` of the correlation matrices of CPCs ``(W, 3)``."""
    r12, r13, r23 = cpc[:, 0], cpc[:, 1], cpc[:, 2]
    s12, s13, s23 = (np.sqrt(np.clip(1.0 - r * r, 0.0, None)) for r in (r12, r13, r23))
    L = np.zeros((len(cpc), 3, 3))
    L[:, 0, 0] = 1.0
    L[:, 1, 0], L[:, 1, 1] = r12, s12
    L[:, 2, 0], L[:, 2, 1], L[:, 2, 2] = r13, r23 * s13, s13 * s23
    return L


def correlation_matrix(cpc: np.ndarray) -> np.ndarray:
    """Correlation matrices ``(W, 3, 3)`` from canonical partial correlations ``(W, 3)``."""
    L = correlation_cholesky(np.atleast_2d(cpc))
    return L @ np.swapaxes(L, 1, 2)


def hyper_log_prior(design: Design, hyper: Hyperprior, center: np.ndarray, z) -> np.ndarray:
    """Log hyperprior density of sampled vectors ``z`` ``(W, D)`` (up to a constant).

    ``center`` holds the three intercepts' centres (log SI units).
    """
    z = np.atleast_2d(z)
    coefs, log_sigma, t = split_vector(design, z)
    out = np.zeros(len(z))
    for k, p in enumerate(PARAMETERS):
        out -= 0.5 * ((coefs[k][:, 0] - center[k]) / hyper.intercept_sd) ** 2
        for j, c in enumerate(design.covariates[p]):
            mean = 1.0 if c in LOG_COVARIATES else 0.0
            out -= 0.5 * ((coefs[k][:, 1 + j] - mean) / hyper.slope_sd) ** 2
    z_sigma = (log_sigma - math.log(hyper.scatter_median)) / hyper.scatter_sd_log
    out -= 0.5 * np.sum(z_sigma * z_sigma, axis=1)  # lognormal sigma = normal log sigma
    betas = (hyper.lkj_eta + 0.5, hyper.lkj_eta + 0.5, hyper.lkj_eta)
    for j, beta in enumerate(betas):
        out += beta * _log_one_minus_tanh2(t[:, j])
    return out


def sample_hyperprior(
    design: Design, hyper: Hyperprior, center: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """``n`` draws ``(n, D)`` of the sampled vector from the hyperprior."""
    cols = []
    for k, p in enumerate(PARAMETERS):
        cols.append(rng.normal(center[k], hyper.intercept_sd, n))
        for c in design.covariates[p]:
            cols.append(rng.normal(1.0 if c in LOG_COVARIATES else 0.0, hyper.slope_sd, n))
    cols += [
        rng.normal(math.log(hyper.scatter_median), hyper.scatter_sd_log, n) for _ in PARAMETERS
    ]
    for beta in (hyper.lkj_eta + 0.5, hyper.lkj_eta + 0.5, hyper.lkj_eta):
        cols.append(
            np.arctanh(np.clip(2.0 * rng.beta(beta, beta, n) - 1.0, -1 + 1e-12, 1 - 1e-12))
        )
    return np.column_stack(cols)


# -- the population density ---------------------------------------------------------------
def population_means(design: Design, matrices: Sequence[np.ndarray], z: np.ndarray) -> np.ndarray:
    """Population means ``(W, N, 3)`` of ``log theta`` for each walker and subject."""
    coefs, _, _ = split_vector(design, z)
    return np.stack([coefs[k] @ matrices[k].T for k in range(3)], axis=-1)


def _precision(z: np.ndarray, design: Design) -> tuple[np.ndarray, np.ndarray]:
    """Precision matrices ``(W, 3, 3)`` and ``log det Sigma`` ``(W,)``."""
    _, log_sigma, t = split_vector(design, z)
    L = correlation_cholesky(np.tanh(t))
    sigma = np.exp(log_sigma)
    chol = sigma[:, :, None] * L  # Sigma = (D L)(D L)^T
    inv = np.linalg.inv(chol)
    precision = np.swapaxes(inv, 1, 2) @ inv
    log_det = 2.0 * (log_sigma.sum(axis=1) + np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1))
    return precision, log_det


class Features:
    """The draws of every subject in the form the vectorised density needs."""

    def __init__(self, subjects: Sequence[SubjectDraws]) -> None:
        n = min(len(s.log_theta) for s in subjects)
        self.n_draws = n
        self.theta = np.stack([s.log_theta[:n] for s in subjects])  # (N, S, 3)
        self.offset = np.stack([s.offset[:n] for s in subjects])  # (N, S)
        t = self.theta
        # [t_1^2, t_2^2, t_3^2, 2 t_1 t_2, 2 t_1 t_3, 2 t_2 t_3, t_1, t_2, t_3, 1]: the
        # Mahalanobis distance is a (subject, walker) row times this column (one batched
        # product), as sum P_jk t_j t_k - 2 (P mu)_j t_j + mu' P mu. Draws run last, so
        # every reduction over them is over contiguous memory.
        self.features = np.ascontiguousarray(
            np.concatenate(
                [
                    t * t,
                    2.0 * t[..., [0]] * t[..., [1]],
                    2.0 * t[..., [0]] * t[..., [2]],
                    2.0 * t[..., [1]] * t[..., [2]],
                    t,
                    np.ones((*t.shape[:2], 1)),
                ],
                axis=-1,
            ).swapaxes(1, 2)
        )  # (N, 10, S)

    def log_weights(self, design: Design, matrices, z: np.ndarray) -> np.ndarray:
        """Log importance weights ``(N, W, S)`` of every draw under each walker's population."""
        z = np.atleast_2d(z)
        precision, log_det = _precision(z, design)
        mu = population_means(design, matrices, z)  # (W, N, 3)
        n = self.offset.shape[0]
        pmu = np.einsum("wjk,wik->wij", precision, mu)  # (W, N, 3)
        coef = np.empty((n, len(z), 10))
        for k, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
            coef[:, :, k] = precision[:, a, b]
        coef[:, :, 6:9] = -2.0 * pmu.swapaxes(0, 1)
        coef[:, :, 9] = (np.einsum("wij,wij->wi", mu, pmu) + log_det[:, None]).T + 3 * _LOG_2PI
        out = np.matmul(coef, self.features)  # (N, W, S)
        out *= -0.5
        out += self.offset[:, None, :]
        return out


def log_likelihood(
    features: Features,
    design: Design,
    matrices,
    z: np.ndarray,
    chunk: int = 64,
    min_ess: float = 0.0,
) -> np.ndarray:
    """The population's log likelihood ``(W,)``: sum over subjects of log mean weight.

    ``-inf`` where a subject's importance-weight ESS is below ``min_ess``: there its draws
    cannot say what the population's density does (:data:`MIN_ESS`).
    """
    z = np.atleast_2d(z)
    out = np.empty(len(z))
    for i in range(0, len(z), chunk):
        lw = features.log_weights(design, matrices, z[i : i + chunk])  # (N, w, S)
        top = lw.max(axis=-1)  # (N, w)
        lw -= top[..., None]
        np.exp(lw, out=lw)
        total = lw.sum(axis=-1)
        value = (np.log(total) + top).sum(axis=0) - total.shape[0] * math.log(features.n_draws)
        if min_ess > 0:
            lw *= lw
            ess = total * total / lw.sum(axis=-1)  # (N, w)
            value[np.any(ess < min_ess, axis=0)] = -np.inf
        out[i : i + chunk] = value
    return out


#: Cells each subject's draws are summarised in (:class:`Cells`), and the fewest draws a cell
#: is made of (fewer draws, fewer cells). Against the exact likelihood over a posterior's
#: draws (variance of the error; two seeds of the k-means starts): 40 simulated subjects of
#: 3000 draws, 32 cells 1.5 and 5.5, 64 cells 1.3 and 2.0; 20 subjects fitted by
#: ``fit_body`` (7744 sampler draws each, 1 % data), 32 cells 1.0 and 1.8, 64 cells 0.25 and
#: 0.25 (the mean over single draws 0.26). But 64 cells cut a subject's rare draws far out in
#: its own prior's tail into cells of their own, each weighing up to e^11 times a typical
#: draw: five such subjects' population went to where those few draws carried it
#: (importance ESS 1-39 of 7744 at its median, the exact likelihood 1.7 lower there than
#: where 32 cells put it, ESS 2800-4900). The density's cost is in proportion to the cells.
CELLS = 32
CELL_DRAWS = 16
#: Cells (walkers x subjects x cells) the density handles at once (:meth:`Cells.log_likelihood`).
BLOCK = 16_000


#: The upper triangle of a symmetric 3x3 matrix, in the order its six components are kept.
_UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _cofactors(a00, a01, a02, a11, a12, a22) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """Cofactors ``(c00, c01, c02, c11, c12, c22)`` and determinants of symmetric 3x3 matrices.

    The components are given as arrays of one shape; the inverse is the cofactors over the
    determinant, written out, since ``np.linalg.inv`` of many tiny matrices costs more than
    the arithmetic.
    """
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    return (c00, c01, c02, c11, c12, c22), a00 * c00 + a01 * c01 + a02 * c02


def _spread_starts(points: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """``k`` of ``points`` as k-means++ picks its starts (Arthur & Vassilvitskii 2007).

    The first at random, each next with probability proportional to its squared distance
    from the nearest already picked. Here each point's distance is updated against the newest
    start only (``n k`` work); ``scipy.cluster.vq.kmeans2(minit="++")`` measures it against
    every start each time (``n k^2``): 5.7 s of a 100-subject population's 36 s at 64 cells.
    """
    n = len(points)
    picked = [int(rng.integers(n))]
    d2 = ((points - points[picked[0]]) ** 2).sum(axis=1)
    for _ in range(k - 1):
        cdf = np.cumsum(d2)
        i = min(int(np.searchsorted(cdf, rng.random() * cdf[-1], side="right")), n - 1)
        picked.append(i)
        np.minimum(d2, ((points - points[i]) ** 2).sum(axis=1), out=d2)
    return points[picked]


class Cells:
    """Each subject's draws summarised as compact Gaussian cells, for the density.

    A subject's draws are grouped into ``k`` cells by k-means (``scipy.cluster.vq.kmeans2``;
    k-means++ starts, :func:`_spread_starts`, drawn with ``seed``; each coordinate of
    ``log theta`` scaled by the subject's SD); each cell is a Gaussian (the mean and
    covariance of its draws) carrying its share of the draws, and the weight's draw-dependent
    part (``-log(m x rho) - log pi``) is taken as linear in ``log theta`` within it (least
    squares over its draws). The mean weight of a cell under a lognormal population is then
    exact for that Gaussian, ``N(m_k + C_k g_k; mu, Sigma + C_k)`` times
    ``exp(o_k + g_k' C_k g_k / 2)`` (a cell of fewer than four draws, too few for the linear
    part, is the Gaussian of their weighted moments as thick as the subject's other cells),
    so it stays finite and smooth as the population narrows, where the mean over single draws is carried
    by the one draw nearest the regression (:data:`MIN_ESS`), at ``k`` terms instead of one
    per draw. On one subject's 3000 draws it matched the likelihood integrated directly over
    populations from 20 % wide to 3 % narrow within 0.07 (one cell: off by over 0.4;
    ``tests/test_population.py``).

    Cells must be compact, not slices: cut across the first principal axis of a curved
    ridge, each of 32 equal-count slices spanned a stretch of the ridge wider than the
    population (its Gaussian the wrong shape there), and on 40 subjects the log likelihood
    leaned along the ridge by 40 per unit of the mass intercept against the exact integral
    (the posterior of the intercept 2.8 SDs off the truth); k-means cells of the same draws
    lean by 3, within what the draws' own noise does (the mean over single draws: 1).
    """

    def __init__(
        self,
        subjects: Sequence[SubjectDraws],
        k: int = CELLS,
        draws_per_cell: int = CELL_DRAWS,
        seed: int = 0,
    ) -> None:
        from scipy.cluster.vq import kmeans2

        size = min(len(s.log_theta) for s in subjects)
        k = max(1, min(k, size // draws_per_cell))
        n = len(subjects)
        # every subject's draws in one array, each labelled with its cell (subject * k + cell)
        labels, shares = [], []
        for number, s in enumerate(subjects):
            t = s.log_theta
            label = np.zeros(len(t), dtype=int)
            if k > 1:
                scaled = t / np.where(t.std(axis=0) > 0, t.std(axis=0), 1.0)
                starts = _spread_starts(scaled, k, np.random.default_rng([seed, number]))
                with warnings.catch_warnings():  # a cluster left empty weighs nothing (below)
                    warnings.filterwarnings("ignore", "One of the clusters is empty")
                    label = kmeans2(scaled, starts, minit="matrix")[1]
            labels.append(number * k + label)
            shares.append(np.full(len(t), 1.0 / len(t)))
        label = np.concatenate(labels)
        t = np.concatenate([s.log_theta for s in subjects])
        off = np.concatenate([s.offset for s in subjects])
        share = np.concatenate(shares)
        cells = n * k

        def total(values: np.ndarray) -> np.ndarray:
            return np.bincount(label, weights=values, minlength=cells)

        count = np.bincount(label, minlength=cells)
        used = np.maximum(count, 1)
        mean = np.column_stack([total(t[:, i]) for i in range(3)]) / used[:, None]
        d = t - mean[label]
        o_mean = total(off) / used
        do = off - o_mean[label]
        cov = np.empty((cells, 3, 3))
        for i, j in _UPPER:
            cov[:, i, j] = cov[:, j, i] = total(d[:, i] * d[:, j])
        dof = np.maximum(count - 1, 1)
        cov /= dof[:, None, None]
        cov_o = np.column_stack([total(d[:, i] * do) for i in range(3)]) / dof[:, None]
        # The weight's draw-dependent part, least squares on the centred draws: the intercept
        # is its mean, the slopes the covariance's pseudo-inverse times its covariance with
        # the draws (a cell of repeated draws, as a sampler leaves, has a singular covariance).
        g = np.einsum("cij,cj->ci", np.linalg.pinv(cov, hermitian=True), cov_o)
        cov_g = np.einsum("cij,cj->ci", cov, g)
        means = mean + cov_g
        with np.errstate(divide="ignore"):  # an empty cell: log 0, replaced below
            consts = np.log(total(share)) + o_mean + 0.5 * np.einsum("ci,ci->c", g, cov_g)
        # Too few draws for the linear part (fewer than four, an outlying draw or two): the
        # Gaussian of their weighted moments widened by the mean covariance of the subject's
        # other cells, so that it is as thick as they are (a point's density would grow
        # without bound under a population narrowing onto it, as the mean over single draws
        # does); none: the cell weighs nothing.
        full = (count >= draws_per_cell).reshape(n, k)
        typical = np.einsum("nk,nkij->nij", full, cov.reshape(n, k, 3, 3))
        typical /= np.maximum(full.sum(axis=1), 1)[:, None, None]
        for c in np.flatnonzero(count < 4):
            members = np.flatnonzero(label == c)
            if len(members) == 0:
                means[c], cov[c], consts[c] = 0.0, np.eye(3), -np.inf
                continue
            u, o = t[members], off[members]
            w = np.exp(o - o.max())
            m = w @ u / w.sum()
            du = u - m
            means[c] = m
            cov[c] = (w[:, None] * du).T @ du / w.sum() + typical[c // k]
            consts[c] = math.log(w @ share[members]) + o.max()
        self.n, self.k = n, k
        self.consts = consts.reshape(n, k)
        # Each component its own contiguous (N, k) array: the density adds a walker's
        # scatter to every cell (see log_likelihood for what that saves).
        cell_cov = cov.reshape(n, k, 3, 3)
        cell_mean = means.reshape(n, k, 3)
        self._cov = [np.ascontiguousarray(cell_cov[..., i, j]) for i, j in _UPPER]
        self._mean = [np.ascontiguousarray(cell_mean[..., i]) for i in range(3)]

    def log_weights(self, design: Design, matrices, z: np.ndarray) -> np.ndarray:
        """Each cell's log mean weight ``(W, N, k)`` under each walker's population."""
        z = np.atleast_2d(z)
        _, log_sigma, t = split_vector(design, z)
        chol = np.exp(log_sigma)[:, :, None] * correlation_cholesky(np.tanh(t))
        sigma = chol @ np.swapaxes(chol, 1, 2)  # (W, 3, 3)
        mu = population_means(design, matrices, z)  # (W, N, 3)
        a = [c + sigma[:, i, j, None, None] for c, (i, j) in zip(self._cov, _UPPER, strict=True)]
        (c00, c01, c02, c11, c12, c22), det = _cofactors(*a)
        d0, d1, d2 = (m - mu[:, :, i, None] for i, m in enumerate(self._mean))  # (W, N, k)
        quad = c00 * d0 * d0
        quad += c11 * d1 * d1
        quad += c22 * d2 * d2
        quad += 2.0 * (c01 * d0 * d1 + c02 * d0 * d2 + c12 * d1 * d2)
        quad /= det
        with np.errstate(invalid="ignore", divide="ignore"):
            quad += np.log(det)
        quad += 3 * _LOG_2PI
        quad *= -0.5
        quad += self.consts
        # a scatter matrix so near singular that Sigma + C_k is not positive in floating
        # point (a correlation of 1 - 1e-8 with scatters of 1e-4): no density there
        np.copyto(quad, -np.inf, where=~(det > 0))
        return quad

    def log_likelihood(self, design: Design, matrices, z: np.ndarray) -> np.ndarray:
        """The population's log likelihood ``(W,)``: sum over subjects of log mean weight.

        Walkers in blocks of about :data:`BLOCK` cells in all, so that the dozen arrays of
        that size the density makes stay in a core's cache: for 100 subjects and 32 walkers,
        one block took 11-12 ms, blocks of 5 walkers 2.6 ms (the 3x3 components strided out
        of one array, as before, 5.5 ms).
        """
        z = np.atleast_2d(z)
        step = max(1, BLOCK // self.n // self.k)
        out = np.empty(len(z))
        for i in range(0, len(z), step):
            lw = self.log_weights(design, matrices, z[i : i + step])
            top = lw.max(axis=-1, keepdims=True)
            lw -= top
            np.exp(lw, out=lw)
            out[i : i + step] = (np.log(lw.sum(axis=-1)) + top[..., 0]).sum(axis=-1)
        return out


def box_mass(
    design: Design,
    z: np.ndarray,
    subjects: Sequence[SubjectDraws],
    rng: np.random.Generator,
    n: int = 4000,
) -> np.ndarray:
    """Fraction ``(N,)`` of each subject's population density inside its prior box.

    At hyperparameters ``z`` ``(D,)``; mass outside the box is mass the subject's draws cannot
    represent (its marginal likelihood is then underestimated there).
    """
    matrices = design.matrices([s.covariates for s in subjects])
    mu = population_means(design, matrices, np.atleast_2d(z))[0]
    _, log_sigma, t = split_vector(design, np.atleast_2d(z))
    chol = np.exp(log_sigma)[0][:, None] * correlation_cholesky(np.tanh(t))[0]
    eps = rng.standard_normal((n, 3)) @ chol.T
    out = np.empty(len(subjects))
    for i, s in enumerate(subjects):
        v = np.exp(mu[i] + eps)
        out[i] = np.mean(np.all((v >= s.support[:, 0]) & (v <= s.support[:, 1]), axis=1))
    return out


def predictive_draws(
    design: Design,
    z: np.ndarray,
    covariates: Mapping[str, float],
    rng: np.random.Generator,
    gravity: float = GRAVITY,
) -> dict[str, np.ndarray]:
    """A new subject's ``m, x, rho, I, M_g``: one draw per hyperparameter draw ``z`` ``(K, D)``."""
    z = np.atleast_2d(z)
    matrices = design.matrices([covariates])
    mu = population_means(design, matrices, z)[:, 0, :]  # (K, 3)
    _, log_sigma, t = split_vector(design, z)
    chol = np.exp(log_sigma)[:, :, None] * correlation_cholesky(np.tanh(t))
    eps = np.einsum("kij,kj->ki", chol, rng.standard_normal((len(z), 3)))
    return dict(zip(REPORTED, np.moveaxis(reported(mu + eps, gravity), -1, 0), strict=True))


def hdi_bounds(x, prob: float) -> tuple[float, float]:
    """The highest-density interval of draws ``x`` (``arviz_stats.hdi``) as two floats."""
    from arviz_stats import hdi

    lo, hi = (float(v) for v in hdi(np.asarray(x).ravel(), prob=prob))
    return lo, hi


def reported(log_theta: np.ndarray, gravity: float = GRAVITY) -> np.ndarray:
    """``m, x, rho, I, M_g`` ``(..., 5)`` from ``log(m, x, rho)`` ``(..., 3)``.

    In the order of :data:`~inertiafit.physics.REPORTED`.
    """
    m, x, r = np.moveaxis(np.exp(log_theta), -1, 0)
    return np.stack([m, x, r, inertia(m, r, x), gravity_moment(m, x, gravity)], axis=-1)


def natural_terms(design: Design, z: np.ndarray) -> dict[tuple[str, str], np.ndarray]:
    """The hyperparameters as reported, each ``(K,)``: by ``(parameter, term)``.

    ``intercept`` (log SI units at the reference covariates), ``slope:<c>``, ``scatter`` (SD
    of the log between subjects) and ``correlation:<q>`` (of the log values' scatter).
    """
    z = np.atleast_2d(z)
    coefs, log_sigma, t = split_vector(design, z)
    out: dict[tuple[str, str], np.ndarray] = {}
    for k, p in enumerate(PARAMETERS):
        out[p, "intercept"] = coefs[k][:, 0]
        for j, c in enumerate(design.covariates[p]):
            out[p, f"slope:{c}"] = coefs[k][:, 1 + j]
    for k, p in enumerate(PARAMETERS):
        out[p, "scatter"] = np.exp(log_sigma[:, k])
    r = correlation_matrix(np.tanh(t))
    for i, j in _PAIRS:
        out[PARAMETERS[i], f"correlation:{PARAMETERS[j]}"] = r[:, i, j]
    return out


# -- fitting ---------------------------------------------------------------------------------
@dataclass
class PopulationFit:
    """The hyperparameters' posterior of one body and what each subject contributes.

    Attributes
    ----------
    design : Design
    hyperprior : Hyperprior
    center : ndarray (3,)
        The intercepts' prior centres (log SI units).
    draws : ndarray (chain, draw, D)
        Sampled vectors (walkers as chains).
    subjects : list of str
    ess : ndarray (N,)
        Each subject's importance-weight ESS at the posterior median hyperparameters.
    ess_low : ndarray (N,)
        Its 5th percentile over the hyperparameter draws.
    n_draws : int
        Draws per subject used.
    pooled : ndarray (N, K, 3)
        Each subject's pooled ``log theta``: one draw per hyperparameter draw ``k``, its own
        draws reweighted to the population at ``lambda_k``.
    box_mass : ndarray (N,)
        Population mass inside each subject's prior box at the median hyperparameters.
    diagnostics : dict
        Steps, acceptance, R-hat and bulk ESS of every coordinate.
    """

    design: Design
    hyperprior: Hyperprior
    center: np.ndarray
    draws: np.ndarray
    subjects: list[str]
    ess: np.ndarray
    ess_low: np.ndarray
    n_draws: int
    pooled: np.ndarray
    box_mass: np.ndarray
    diagnostics: dict = field(default_factory=dict)

    @property
    def flat(self) -> np.ndarray:
        """The draws ``(K, D)``."""
        return self.draws.reshape(-1, self.draws.shape[-1])


#: Where the sampled vector may go: scatters from 1e-4 to 20 (log units), partial
#: correlations within 1 - 1e-8 of +-1 (beyond, the density is numerically singular).
LOG_SCATTER_RANGE = (math.log(1e-4), math.log(20.0))
MAX_ATANH = 9.0


def in_domain(design: Design, z: np.ndarray) -> np.ndarray:
    """Which vectors ``(W, D)`` lie where the density is computed (see :data:`MAX_ATANH`)."""
    _, log_sigma, t = split_vector(design, z)
    ok = np.all((log_sigma > LOG_SCATTER_RANGE[0]) & (log_sigma < LOG_SCATTER_RANGE[1]), axis=1)
    return ok & np.all(np.abs(t) < MAX_ATANH, axis=1)


def intercept_indices(design: Design) -> tuple[int, int, int]:
    """Where the intercepts of ``m``, ``x`` and ``rho`` sit in the vector."""
    i_x = 1 + len(design.covariates["mass"])
    return 0, i_x, i_x + 1 + len(design.covariates["com_distance"])


def to_sampled(design: Design, z: np.ndarray) -> np.ndarray:
    """The sampled coordinates of model vectors ``z`` ``(W, D)``.

    The intercepts ``(a_m, a_x, a_rho)`` become ``(a_m, A, B)`` with ``A = a_m + a_x`` (the
    typical subject's ``log(m x)``) and ``B = a_m + log(exp(2 a_rho) + exp(2 a_x))`` (its
    ``log I``): what each subject's ``I`` and ``M_g`` measure, so the intercepts' ridge (one
    direction the data leave to the hyperprior) runs along an axis; along the curved ridge the
    walkers took ten times the steps (measured on simulated cohorts).
    """
    i_m, i_x, i_r = intercept_indices(design)
    u = np.array(z, dtype=float)
    a_m, a_x, a_r = z[:, i_m], z[:, i_x], z[:, i_r]
    u[:, i_x] = a_m + a_x
    u[:, i_r] = a_m + np.logaddexp(2 * a_r, 2 * a_x)
    return u


def to_model(design: Design, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Model vectors from sampled ones, and ``log |d z / d u|`` (``-inf`` where none exists)."""
    i_m, i_x, i_r = intercept_indices(design)
    z = np.array(u, dtype=float)
    a_m = u[:, i_m]
    a_x = u[:, i_x] - a_m
    rest = u[:, i_r] - a_m  # log(rho^2 + x^2)
    gap = rest - 2 * a_x  # log((rho^2 + x^2) / x^2) > 0
    ok = gap > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        log_r2 = 2 * a_x + np.log(np.expm1(np.where(ok, gap, 1.0)))  # log rho^2
    z[:, i_x] = a_x
    z[:, i_r] = np.where(ok, 0.5 * log_r2, 0.0)
    # d a_rho / d B = (rho^2 + x^2) / (2 rho^2); the other entries are triangular with ones.
    log_jac = np.where(ok, rest - log_r2 - math.log(2.0), -np.inf)
    return z, log_jac


# -- storage ---------------------------------------------------------------------------------
def _common_draws(fits: Mapping[str, PopulationFit]) -> int:
    """Draws per walker every body keeps in ``population.nc`` (the shortest chain's)."""
    return min(f.draws.shape[1] for f in fits.values())


def population_tree(fits: Mapping[str, PopulationFit], subjects, *, gravity: float, attrs: dict):
    """``population.nc`` as an ``xarray.DataTree``.

    ``posterior``: ``hyper`` ``(chain, draw, body, coordinate)`` (the sampled vectors, walkers
    as chains, every body thinned to the same draws) and ``terms`` ``(chain, draw, body,
    term)`` (the same as reported: ``<parameter>:<term>``); ``constant_data``: each body's
    covariate centres and scales, the intercepts' prior centres and draws per subject;
    ``subjects``: ``subjects.csv``. Root attributes: the design's covariates, the hyperprior,
    gravity, diagnostics per body and what the caller adds.
    """
    import xarray as xr

    bodies = list(fits)
    first = fits[bodies[0]]
    n_keep = _common_draws(fits)
    chains = min(f.draws.shape[0] for f in fits.values())
    coords = [f"{p}:{t}" for p, t in first.design.terms]
    hyper = np.empty((chains, n_keep, len(bodies), first.design.ndim))
    term_names = [f"{p}:{t}" for p, t in natural_terms(first.design, first.flat[:1])]
    terms = np.empty((chains, n_keep, len(bodies), len(term_names)))
    for b, body in enumerate(bodies):
        d = fits[body].draws[:chains]
        idx = np.linspace(0, d.shape[1] - 1, n_keep).round().astype(int)
        hyper[:, :, b] = d[:, idx]
        nat = natural_terms(fits[body].design, hyper[:, :, b].reshape(-1, first.design.ndim))
        for t, v in enumerate(nat.values()):
            terms[:, :, b, t] = v.reshape(chains, n_keep)
    covariates = sorted(first.design.centers)
    dims = ("chain", "draw", "body")
    posterior = xr.Dataset(
        {
            "hyper": xr.DataArray(hyper, dims=(*dims, "coordinate")),
            "terms": xr.DataArray(terms, dims=(*dims, "term")),
        },
        coords={
            "chain": np.arange(chains),
            "draw": np.arange(n_keep),
            "body": bodies,
            "coordinate": coords,
            "term": term_names,
        },
    )
    constant = xr.Dataset(
        {
            "center": (
                ("body", "covariate"),
                [[fits[b].design.centers[c] for c in covariates] for b in bodies],
            ),
            "scale": (
                ("body", "covariate"),
                [[fits[b].design.scales[c] for c in covariates] for b in bodies],
            ),
            "intercept_center": (("body", "parameter"), [list(fits[b].center) for b in bodies]),
            "draws_per_subject": (("body",), [fits[b].n_draws for b in bodies]),
        },
        coords={"body": bodies, "covariate": covariates, "parameter": list(PARAMETERS)},
    )
    table = xr.Dataset.from_dataframe(subjects.reset_index(drop=True).rename_axis("row"))
    root = {
        "kind": "inertiafit population",
        "gravity": float(gravity),
        "covariates": json.dumps({p: list(c) for p, c in first.design.covariates.items()}),
        "hyperprior": json.dumps(asdict(first.hyperprior)),
        "diagnostics": json.dumps({b: fits[b].diagnostics for b in bodies}),
        "subject_names": json.dumps({b: fits[b].subjects for b in bodies}),
        "importance_ess": json.dumps({b: fits[b].ess.tolist() for b in bodies}),
        "box_mass": json.dumps({b: fits[b].box_mass.tolist() for b in bodies}),
        **attrs,
    }
    return xr.DataTree.from_dict(
        {
            "/": xr.Dataset(attrs=root),
            "posterior": posterior,
            "constant_data": constant,
            "subjects": table,
        }
    )


def read_population(path) -> tuple[dict[str, PopulationFit], object, dict]:
    """The fits (without pooled draws), the subjects table and root attributes of a file.

    Raises
    ------
    InputError
        A file that is missing, unreadable or not a ``population.nc``.
    """
    import xarray as xr

    where = str(path)
    try:
        tree = xr.open_datatree(path)
    except FileNotFoundError:
        raise InputError(f"{where}: population file not found") from None
    except (OSError, ValueError):
        raise InputError(
            f"{where}: not a population.nc (not a netCDF file inertiafit population wrote)"
        ) from None
    with tree:
        attrs = dict(tree.attrs)
        if attrs.get("kind") != "inertiafit population" or "posterior" not in tree.children:
            raise InputError(f"{where}: not a population.nc (written by inertiafit population)")
        post = tree["posterior"].to_dataset().load()
        cd = tree["constant_data"].to_dataset().load()
        subjects = tree["subjects"].to_dataset().load().to_dataframe().reset_index(drop=True)
    covariates = {p: tuple(v) for p, v in json.loads(attrs["covariates"]).items()}
    stored = json.loads(attrs["hyperprior"])
    mean = stored.get("intercept_mean")
    hyper = Hyperprior(
        intercept_sd=float(stored["intercept_sd"]),
        intercept_mean=None if mean is None else (float(mean[0]), float(mean[1]), float(mean[2])),
        slope_sd=float(stored["slope_sd"]),
        scatter_median=float(stored["scatter_median"]),
        scatter_sd_log=float(stored["scatter_sd_log"]),
        lkj_eta=float(stored["lkj_eta"]),
    )
    diagnostics = json.loads(attrs.get("diagnostics", "{}"))
    names = json.loads(attrs.get("subject_names", "{}"))
    ess = json.loads(attrs.get("importance_ess", "{}"))
    box = json.loads(attrs.get("box_mass", "{}"))
    fits = {}
    for body in (str(b) for b in post["body"].values):
        design = Design(
            covariates,
            {
                str(c): float(cd["center"].sel(body=body, covariate=c))
                for c in cd["covariate"].values
            },
            {
                str(c): float(cd["scale"].sel(body=body, covariate=c))
                for c in cd["covariate"].values
            },
        )
        draws = np.asarray(post["hyper"].sel(body=body).values)
        fits[body] = PopulationFit(
            design=design,
            hyperprior=hyper,
            center=np.asarray(cd["intercept_center"].sel(body=body).values),
            draws=draws,
            subjects=list(names.get(body, [])),
            ess=np.asarray(ess.get(body, []), dtype=float),
            ess_low=np.asarray([], dtype=float),
            n_draws=int(cd["draws_per_subject"].sel(body=body)),
            pooled=np.empty((0, 0, 3)),
            box_mass=np.asarray(box.get(body, []), dtype=float),
            diagnostics=diagnostics.get(body, {}),
        )
    return fits, subjects, attrs


#: Keys of a population prior table besides the covariates.
POPULATION_PRIOR_KEYS = ("population", "body", "name")


def population_prior_table(
    spec: Mapping,
    *,
    where: str,
    base_dir=None,
    body: str | None = None,
    known: Mapping[str, float] | None = None,
) -> dict:
    """A prior table (lognormal per parameter) from a population's predictive distribution.

    ``spec`` is ``{population = "OUT/population.nc", body = "forearm", body_mass = 72,
    segment_length = 0.27}``: the new subject's covariates (those the population regresses
    on). ``body`` defaults to ``body``; a covariate not given is taken from ``known`` (the
    manifest's ``[subject]`` and the body's ``segment_length``). Each parameter's prior is the
    lognormal with the median and the SD of the log of the predictive draws (one per stored
    hyperparameter draw): the subject's own marginal under the population; the predictive
    correlation between ``m``, ``x`` and ``rho`` is not kept (priors are independent per
    parameter).
    """
    from pathlib import Path

    path = spec.get("population")
    if not isinstance(path, str) or not path.strip():
        raise InputError(f"{where}: population: expected the path of a population.nc")
    file = Path(path)
    if base_dir is not None and not file.is_absolute():
        file = Path(base_dir) / file
    fits, _, attrs = read_population(file)
    name = spec.get("body", body)
    if name is None:
        raise InputError(f"{where}: body: missing; the body of {file} to take ({', '.join(fits)})")
    if name not in fits:
        raise InputError(f"{where}: body: {name!r} is not in {file} (it holds {', '.join(fits)})")
    fit = fits[name]
    needed = sorted(fit.design.centers)
    extra = sorted(set(spec) - set(POPULATION_PRIOR_KEYS) - set(needed))
    if extra:
        raise InputError(
            f"{where}: {extra[0]}: not a covariate of this population (it regresses on "
            f"{', '.join(needed) or 'nothing'})"
        )
    values = {}
    for c in needed:
        v = spec.get(c, (known or {}).get(c))
        if v is None:
            raise InputError(
                f"{where}: {c}: missing; the population of {name!r} regresses on it (give it "
                "here, or in the manifest's [subject] / the body's segment_length)"
            )
        values[c] = check_positive(v, f"{where}: {c}") if c in LOG_COVARIATES else float(v)
    rng = np.random.default_rng(0)
    draws = predictive_draws(
        fit.design, fit.flat, values, rng, float(attrs.get("gravity", GRAVITY))
    )
    table: dict = {
        "description": (
            f"population of {name!r} ({len(fit.subjects)} subjects), predicted for "
            + ", ".join(f"{c} = {values[c]:g}" for c in needed)
        ),
        "source": f"inertiafit population {file}",
    }
    units = {"mass": "kg", "com_distance": "m", "radius_of_gyration": "m"}
    for p in PARAMETERS:
        logs = np.log(draws[p])
        table[p] = {
            "distribution": "lognormal",
            "median": float(np.exp(np.median(logs))),
            "sd_log": float(np.std(logs)),
            "unit": units[p],
        }
    return table
