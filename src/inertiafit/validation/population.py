"""Simulated cohorts for the population layer: truths, subjects' exact posteriors, SBC.

A cohort is drawn as the population model says (:mod:`inertiafit.inference.population`):
hyperparameters (from the hyperprior, or given), each subject's covariates and its
``(m, x, rho)``; each subject's data are its ``I`` and ``M_g`` measured with a relative
standard error, and optionally a weighed mass. Its posterior under its own *interim* prior is
drawn exactly (no sampler): ``m`` from a wide proposal, ``M_g`` and ``I`` from their Gaussian
likelihoods, mapped to ``(x, rho)`` and importance-resampled with the prior density over the
Jacobian ``|d(m, M_g, I) / d(m, x, rho)| = 2 g m^2 rho`` (as :mod:`inertiafit.inference.reference`
writes the same posterior on its grid). So the population layer is checked alone, in seconds.

The interim priors are lognormal per parameter around a "table" value (the population's mean
for the subject's covariates times a bias), as a lab's anthropometric priors are: pooling that
forgets to divide them out counts them once per subject (the negative control).
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from inertiafit.errors import ConvergenceWarning, InputError
from inertiafit.inference.pooling import fit_population
from inertiafit.inference.population import (
    Design,
    Hyperprior,
    SubjectDraws,
    correlation_cholesky,
    natural_terms,
    population_means,
    sample_hyperprior,
    split_vector,
)
from inertiafit.physics import GRAVITY, PARAMETERS

__all__ = [
    "Cohort",
    "center_vector",
    "cohort_design",
    "exact_log_likelihood",
    "exact_subject_draws",
    "population_sbc",
    "simulate_cohort",
]

#: The cohort's typical subject: an adult forearm + hand (de Leva, 75 kg, forearm 0.27 m).
TYPICAL = {"mass": 1.6, "com_distance": 0.20, "radius_of_gyration": 0.13}
TYPICAL_COVARIATES = {"body_mass": 75.0, "segment_length": 0.27}
#: The hyperprior of the SBC: cohorts like adult forearms (intercepts within about 15 % of the
#: typical subject, slopes near isometric, scatters around 8 %).
SBC_HYPERPRIOR = Hyperprior(
    intercept_sd=0.15, slope_sd=0.3, scatter_median=0.08, scatter_sd_log=0.5
)


@dataclass
class Cohort:
    """A simulated cohort and its subjects' posteriors."""

    design: Design
    truth: np.ndarray  # the sampled vector (D,)
    covariates: list[dict[str, float]]
    theta: np.ndarray  # (N, 3) true log m, log x, log rho
    subjects: list[SubjectDraws]
    observed: list[tuple[float, float]]  # each subject's measured (I, M_g)
    rel_se: float  # their relative standard error
    weighed: tuple[int, ...] = ()  # subjects that also brought a weighed mass


def cohort_design(n: int, rng: np.random.Generator) -> tuple[Design, list[dict[str, float]]]:
    """Covariates of ``n`` adults (body mass 50–100 kg, forearm 0.23–0.31 m) and the design."""
    covs = [
        {
            "body_mass": float(rng.uniform(50.0, 100.0)),
            "segment_length": float(rng.uniform(0.23, 0.31)),
        }
        for _ in range(n)
    ]
    covariates = {
        "mass": ("body_mass",),
        "com_distance": ("segment_length",),
        "radius_of_gyration": ("segment_length",),
    }
    # Centred on the typical subject (not the sample), so truths drawn around it stay there.
    design = Design.for_cohort(covariates, covs)
    centers = {k: math.log(v) for k, v in TYPICAL_COVARIATES.items()}
    return Design(design.covariates, centers, dict(design.scales)), covs


def _lognormal_logpdf(v: np.ndarray, median: float, sd_log: float) -> np.ndarray:
    z = (np.log(v) - math.log(median)) / sd_log
    return -0.5 * z * z - np.log(v) - math.log(sd_log)


def measured(
    truth: Sequence[float], rel_se: float, rng: np.random.Generator, gravity: float = GRAVITY
) -> tuple[float, float]:
    """A subject's ``I`` and ``M_g`` as measured.

    ``truth`` is ``(m, x, rho)``; each is off by a relative standard error ``rel_se`` (``I``
    drawn first).
    """
    m, x, rho = truth
    i_obs = m * (rho**2 + x**2) * (1 + rel_se * rng.standard_normal())
    g_obs = m * gravity * x * (1 + rel_se * rng.standard_normal())
    return float(i_obs), float(g_obs)


def exact_subject_draws(
    name: str,
    truth: Sequence[float],
    covariates: dict[str, float],
    *,
    prior_median: Sequence[float],
    prior_sd_log: float,
    rel_se: float,
    rng: np.random.Generator,
    n_draws: int = 1000,
    n_proposal: int = 40000,
    gravity: float = GRAVITY,
    mass_sd: float | None = None,
    observed: tuple[float, float] | None = None,
) -> SubjectDraws:
    """Exact posterior draws of one subject's ``(m, x, rho)`` from its ``I`` and ``M_g``.

    ``truth`` is ``(m, x, rho)``; the data are one ``I`` and one ``M_g`` with relative
    standard error ``rel_se`` (and a weighed mass with SD ``mass_sd``, if given). The prior is
    lognormal per parameter (``prior_median``, ``prior_sd_log``) on ``median * exp(+-4.753
    sd_log)``. ``observed`` gives ``(I, M_g)`` as measured instead of drawing them.
    """
    i_obs, g_obs = measured(truth, rel_se, rng, gravity) if observed is None else observed
    i_se, g_se = rel_se * i_obs, rel_se * g_obs
    half = 4.753 * prior_sd_log
    lo = np.asarray(prior_median) * math.exp(-half)
    hi = np.asarray(prior_median) * math.exp(half)
    m_obs = None if mass_sd is None else truth[0] + mass_sd * rng.standard_normal()
    m = np.exp(rng.uniform(math.log(lo[0]), math.log(hi[0]), n_proposal))  # log-uniform m
    a = rng.normal(g_obs, g_se, n_proposal)
    b = rng.normal(i_obs, i_se, n_proposal)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = a / (m * gravity)
        rho = np.sqrt(b / m - x * x)
        log_p = sum(
            _lognormal_logpdf(v, prior_median[k], prior_sd_log) for k, v in enumerate((m, x, rho))
        )
        # prior over Jacobian, over the proposal's log-uniform m (density 1/m)
        log_w = log_p - np.log(2 * gravity * m * m * rho) + np.log(m)
        if m_obs is not None and mass_sd is not None:
            log_w -= 0.5 * ((m - m_obs) / mass_sd) ** 2
    inside = np.all((np.stack([m, x, rho], 1) >= lo) & (np.stack([m, x, rho], 1) <= hi), axis=1)
    log_w = np.where(inside & np.isfinite(log_w), log_w, -np.inf)
    w = np.exp(log_w - log_w.max())
    w /= w.sum()
    idx = rng.choice(n_proposal, size=n_draws, p=w)
    theta = np.log(np.stack([m[idx], x[idx], rho[idx]], axis=1))
    log_interim = sum(
        _lognormal_logpdf(np.exp(theta[:, k]), prior_median[k], prior_sd_log) for k in range(3)
    )
    return SubjectDraws(
        name, theta, np.asarray(log_interim), dict(covariates), np.stack([lo, hi], 1)
    )


def simulate_cohort(
    n: int,
    *,
    truth: np.ndarray | None = None,
    hyperprior: Hyperprior,
    center: np.ndarray,
    rng: np.random.Generator,
    rel_se: float = 0.02,
    prior_bias: float | Sequence[float] = 1.15,
    prior_sd_log: float = 0.3,
    n_draws: int = 1000,
    weighed: Sequence[int] = (),
) -> Cohort:
    """A cohort of ``n`` subjects: truth from the hyperprior unless given, then each posterior.

    Each interim prior is centred on the population mean for the subject (at the hyperprior's
    centre, not the truth) times ``prior_bias``; the subjects whose index is in ``weighed`` also
    bring a weighed mass (SD 2 %).
    """
    design, covs = cohort_design(n, rng)
    if truth is None:
        truth = sample_hyperprior(design, hyperprior, center, 1, rng)[0]
    matrices = design.matrices(covs)
    mu = population_means(design, matrices, truth[None])[0]  # (N, 3)
    _, log_sigma, t = split_vector(design, truth[None])
    chol = np.exp(log_sigma)[0][:, None] * correlation_cholesky(np.tanh(t))[0]
    theta = mu + rng.standard_normal((n, 3)) @ chol.T
    table = np.exp(
        population_means(design, matrices, center_vector(design, center)[None])[0]
    ) * np.asarray(prior_bias)
    subjects, observed = [], []
    for i in range(n):
        observed.append(measured(np.exp(theta[i]), rel_se, rng))  # kept, for the reference
        subjects.append(
            exact_subject_draws(
                f"S{i + 1:02d}",
                np.exp(theta[i]),
                covs[i],
                prior_median=table[i],
                prior_sd_log=prior_sd_log,
                rel_se=rel_se,
                rng=rng,
                n_draws=n_draws,
                mass_sd=0.02 * float(np.exp(theta[i, 0])) if i in weighed else None,
                observed=observed[-1],
            )
        )
    return Cohort(design, truth, covs, theta, subjects, observed, rel_se, tuple(weighed))


#: Gauss-Hermite nodes (probabilists') for the measured I and M_g in
#: :func:`exact_log_likelihood`; seven reproduce a Monte Carlo integral of 2 000 000
#: population draws within 0.01 in log.
_HERMITE = np.polynomial.hermite_e.hermegauss(7)


def exact_log_likelihood(cohort: Cohort, z: np.ndarray, n_mass: int = 1200) -> np.ndarray:
    """Each subject's population likelihood ``(K, N)`` at hyperparameters ``z`` ``(K, D)``.

    the log of the integral of ``p_pop(theta | z) L_i(theta)`` over the subject's prior box (the draws
    cannot see beyond it), with ``L_i`` its Gaussian likelihood of the measured ``I`` and
    ``M_g``, up to a constant per subject: what the importance estimate of
    :mod:`inertiafit.inference.population` estimates, here by quadrature (no draws) in the
    coordinates ``(log m, M_g, I)``: ``n_mass`` points of ``log m`` over the box and
    Gauss-Hermite nodes in ``M_g`` and ``I``, with ``x = M_g / (m g)``,
    ``rho = sqrt(I / m - x^2)`` and the Jacobian ``|d(m, M_g, I) / d(m, x, rho)| = 2 g m^2
    rho``. Subjects that brought a weighed mass are refused (their likelihood has a third
    factor this does not hold).
    """
    if cohort.weighed:
        raise InputError("exact_log_likelihood: the cohort has weighed subjects; expected none")
    z = np.atleast_2d(z)
    design = cohort.design
    n = len(cohort.subjects)
    mu = population_means(design, design.matrices(cohort.covariates[:n]), z)  # (K, N, 3)
    _, log_sigma, t = split_vector(design, z)
    chol = np.exp(log_sigma)[:, :, None] * correlation_cholesky(np.tanh(t))
    precision = np.linalg.inv(chol @ np.swapaxes(chol, 1, 2))
    log_norm = -np.log(np.abs(np.linalg.det(chol))) - 1.5 * math.log(2 * math.pi)  # (K,)
    nodes, weights = _HERMITE
    log_w = np.log(weights / weights.sum())
    log_w = log_w[:, None] + log_w[None, :]
    out = np.empty((len(z), n))
    for i, (subject, (i_obs, g_obs)) in enumerate(
        zip(cohort.subjects, cohort.observed, strict=False)
    ):
        lo, hi = subject.support[:, 0], subject.support[:, 1]
        log_m = np.linspace(math.log(lo[0]), math.log(hi[0]), n_mass)
        m = np.exp(log_m)[:, None, None]
        x = (g_obs * (1 + cohort.rel_se * nodes))[None, :, None] / (m * GRAVITY)
        rho2 = (i_obs * (1 + cohort.rel_se * nodes))[None, None, :] / m - x * x
        rho = np.sqrt(np.where(rho2 > 0, rho2, 1.0))
        theta = np.stack(np.broadcast_arrays(np.log(m), np.log(x), np.log(rho)), axis=-1)
        v = np.exp(theta)
        inside = (rho2 > 0) & np.all((v >= lo) & (v <= hi), axis=-1)
        # p_pop(theta) = N(log theta) / (m x rho); d theta = dm dM_g dI / (2 g m^2 rho); dm =
        # m d(log m)
        base = -theta.sum(axis=-1) - np.log(2 * GRAVITY * m * rho) + log_w
        base = np.where(inside, base, -np.inf)
        for k in range(len(z)):
            d = theta - mu[k, i]
            q = np.einsum("...j,jk,...k->...", d, precision[k], d)
            lp = base - 0.5 * q
            top = lp.max()
            out[k, i] = (
                top + math.log(np.exp(lp - top).sum() * (log_m[1] - log_m[0])) + log_norm[k]
            )
    return out


def center_vector(design: Design, center: np.ndarray) -> np.ndarray:
    """The sampled vector at the hyperprior's centre (intercepts ``center``, isometric slopes)."""
    z = []
    for k, p in enumerate(PARAMETERS):
        z.append(center[k])
        z += [1.0] * len(design.covariates[p])
    return np.asarray(z + [math.log(0.1)] * 3 + [0.0] * 3)


def population_sbc(
    n_sims: int,
    *,
    n_subjects: int = 8,
    seed: int = 0,
    hyperprior: Hyperprior | None = None,
    n_keep: int = 99,
    ignore_interim: bool = False,
    ess_target: float = 300.0,
    max_steps: int = 20000,
    prior_bias: float | Sequence[float] = 1.15,
    prior_sd_log: float = 0.3,
    chunk: int = 250,
    n_draws: int = 1000,
) -> dict[tuple[str, str], np.ndarray]:
    """Ranks of the true hyperparameters among ``n_keep`` thinned posterior draws, per term.

    ``ignore_interim=True`` is the negative control: the subjects' prior densities are not
    divided out (each draw counts as if drawn from the likelihood alone). A fit that stops at
    ``max_steps`` before its convergence targets still gives ranks (a fixed budget: the
    ranks' uniformity is the test); its warning is not raised. A cohort with a subject whose
    draws cannot be reweighted (the fit's one-line refusal) is left out of the ranks.
    """
    hyper = hyperprior or SBC_HYPERPRIOR
    center = np.log([TYPICAL[p] for p in PARAMETERS])
    ranks: dict[tuple[str, str], list[int]] = {}
    for k in range(n_sims):
        rng = np.random.default_rng([seed, k])
        cohort = simulate_cohort(
            n_subjects,
            hyperprior=hyper,
            center=center,
            rng=rng,
            prior_bias=prior_bias,
            prior_sd_log=prior_sd_log,
            n_draws=n_draws,
        )
        subjects = cohort.subjects
        if ignore_interim:
            subjects = [
                SubjectDraws(
                    s.name, s.log_theta, np.zeros(len(s.log_interim)), s.covariates, s.support
                )
                for s in subjects
            ]
        fit = None  # a cohort with a subject the population cannot reweight is left out
        with warnings.catch_warnings(), contextlib.suppress(InputError):
            warnings.simplefilter("ignore", ConvergenceWarning)
            fit = fit_population(
                subjects,
                cohort.design,
                hyperprior=hyper,
                center=center,
                seed=k,
                ess_target=ess_target,
                max_steps=max_steps,
                chunk=chunk,
                pool_draws=200,  # the subjects' pooled draws are not ranked
            )
        if fit is None:
            continue
        flat = fit.flat
        keep = flat[np.linspace(0, len(flat) - 1, n_keep).astype(int)]
        post = natural_terms(cohort.design, keep)
        true = natural_terms(cohort.design, cohort.truth[None])
        for key, draws in post.items():
            ranks.setdefault(key, []).append(int(np.sum(draws < true[key][0])))
    return {k: np.asarray(v) for k, v in ranks.items()}
