"""Many subjects pooled: :func:`population` and its :class:`PopulationPosterior` (issue 33).

Each source is a ``run`` or ``fit`` output (its ``posterior.nc``) or a ``run-many`` output (every
study its ``batch.csv`` lists as ``ok``). Every body name held by at least
:data:`MIN_SUBJECTS` studies whose covariates are all known is pooled by the population model
of :mod:`inertiafit.inference.population`: its hyperparameters sampled with emcee from the
subjects' stored draws reweighted from their own priors, each subject's estimate pooled with the
others, and a new subject's parameters predicted from its body mass and segment length.
"""

from __future__ import annotations

import contextlib
import json
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from inertiafit import __version__
from inertiafit._checks import check_finite, check_positive, check_probability, check_seed
from inertiafit.errors import ConvergenceWarning, InertiafitWarning, InputError
from inertiafit.inference import population as model
from inertiafit.inference.population import (
    DEFAULT_COVARIATES,
    MIN_ESS,
    Design,
    Hyperprior,
    PopulationFit,
    SubjectDraws,
)
from inertiafit.inference.priors import priors_from_posterior
from inertiafit.physics import GRAVITY, PARAMETERS, REPORTED, UNITS
from inertiafit.posterior import Posterior, open_posterior

__all__ = [
    "MIN_SUBJECTS",
    "POPULATION_COLUMNS",
    "PREDICT_COLUMNS",
    "SUBJECT_COLUMNS",
    "PopulationPosterior",
    "StudyPosterior",
    "fit_population",
    "gather",
    "open_population",
    "population",
]

#: Warm-up chunks after each of which the independence proposal is refitted.
ADAPT = 2
#: Largest nested R-hat of a hyperparameter over :data:`SUPERCHAINS` groups of walkers
#: (:func:`~inertiafit.inference.sampler.convergence_check`). R-hat with each of 32 walkers a
#: chain stays above 1.02 until the bulk ESS is about 1600 (its split halves' means scatter by
#: their own Monte Carlo error): on a simulated cohort of 10 it held sampling to 12 500 steps
#: at ESS 2100-2600 in every coordinate, where nested R-hat was 1.005 at 5000 steps (ESS 545).
R_HAT_MAX = 1.01
#: Groups of walkers nested R-hat compares.
SUPERCHAINS = 4
#: Largest variance of the estimated log likelihood a population is accepted with without a
#: warning (Talbot & Golomb 2023, MNRAS 526:3495, on why it must be small): the cells' error
#: (:class:`Cells`), from split halves of each subject's draws (:func:`_split_half_noise`),
#: its variance over the posterior's draws, the part that changes the posterior's shape.
#: SBC of 30 cohorts of five (benchmarks/population.py): with 3000 draws per subject 21 % of
#: the ranks in the outer fifth, where 20 % belong (the mean over single draws with its ESS
#: cut gave 25 %, and 22 % with 5000); with 500 draws 25 % (31-33 %).
MAX_LOGLIKE_VARIANCE = 0.1
#: Hyperprior draws each term's prior SD is measured from (``decided_by``).
PRIOR_SD_DRAWS = 4000
#: Hyperparameter draws each subject's ESS and the density's noise are measured at.
CHECKED_DRAWS = 200
#: Studies a body must be in to be pooled.
MIN_SUBJECTS = 3
#: Columns of ``population.csv``.
POPULATION_COLUMNS = [
    "body",
    "parameter",
    "term",
    "median",
    "hdi_lower",
    "hdi_upper",
    "hdi_prob",
    "unit",
    "ess_bulk",
    "r_hat",
    "decided_by",
    "reference",
]
#: Columns of ``subjects.csv``.
SUBJECT_COLUMNS = [
    "subject",
    "study",
    "body",
    "parameter",
    "own_median",
    "own_hdi_lower",
    "own_hdi_upper",
    "pooled_median",
    "pooled_hdi_lower",
    "pooled_hdi_upper",
    "width_ratio",
    "unit",
    "importance_ess",
    "box_mass",
]
#: Columns of :meth:`PopulationPosterior.predict`.
PREDICT_COLUMNS = ["parameter", "median", "hdi_lower", "hdi_upper", "hdi_prob", "unit"]
#: Population mass inside a subject's prior box below which the run warns.
MIN_BOX_MASS = 0.95


@dataclass(frozen=True)
class StudyPosterior:
    """One study's posterior with who was measured.

    Attributes
    ----------
    label : str
        Where it came from (its folder, or ``posterior k`` for an object).
    posterior : Posterior
    subject : dict or None
        The ``[subject]`` table as recorded (``id``, ``body_mass``, ``height``, ``sex``,
        ``covariates``).
    segment_length : dict of str to float
        Each body's ``segment_length`` (m), where given.
    """

    label: str
    posterior: Posterior
    subject: dict | None
    segment_length: dict[str, float] = field(default_factory=dict)

    @property
    def name(self) -> str:
        """The subject's id, else the label."""
        return str(self.subject["id"]) if self.subject else self.label

    def covariates(self, body: str) -> dict[str, float]:
        """Every number known of this subject and body."""
        out: dict[str, float] = {}
        if self.subject:
            for key in ("body_mass", "height"):
                if self.subject.get(key) is not None:
                    out[key] = float(self.subject[key])
            out.update({k: float(v) for k, v in (self.subject.get("covariates") or {}).items()})
        if body in self.segment_length:
            out["segment_length"] = float(self.segment_length[body])
        return out


def _inputs(post: Posterior) -> dict:
    try:
        return json.loads(post.attrs.get("inputs", "{}") or "{}")
    except json.JSONDecodeError:
        return {}


def _study(label: str, post: Posterior) -> StudyPosterior:
    inputs = _inputs(post)
    seg = inputs.get("segment_length") or {}
    return StudyPosterior(
        label, post, inputs.get("subject"), {k: float(v) for k, v in seg.items()}
    )


def _open(path: Path, label: str) -> StudyPosterior:
    return _study(label, open_posterior(path))


def gather(
    sources: Sequence[str | Path | Posterior] | str | Path | Posterior,
    echo: Callable[[str], None] | None = None,
) -> list[StudyPosterior]:
    """Every study of the sources: ``run``/``fit`` outputs, ``run-many`` outputs, posteriors."""
    say = echo or (lambda _m: None)
    if isinstance(sources, (str, Path, Posterior)):
        sources = [sources]
    out: list[StudyPosterior] = []
    for k, src in enumerate(sources):
        if isinstance(src, Posterior):
            out.append(_study(f"posterior {k + 1}", src))
            continue
        path = Path(src)
        if path.is_file():
            out.append(_open(path, str(path)))
        elif (path / "posterior.nc").is_file():
            out.append(_open(path / "posterior.nc", str(path)))
        elif (path / "batch.csv").is_file():
            batch = pd.read_csv(path / "batch.csv", dtype={"folder": str})
            for _, row in batch.iterrows():
                folder = path / str(row["folder"])
                if row["status"] != "ok" or not (folder / "posterior.nc").is_file():
                    say(
                        f"population: {folder}: study failed in run-many "
                        f"({row.get('error', '') or 'no posterior.nc'}); left out"
                    )
                    continue
                out.append(_open(folder / "posterior.nc", str(folder)))
        elif not path.exists():
            raise InputError(f"{path}: no such folder or file")
        else:
            raise InputError(
                f"{path}: not a run or fit output (no posterior.nc) nor a run-many output "
                "(no batch.csv)"
            )
    if not out:
        raise InputError("population: no study to pool (every run-many study failed)")
    seen: dict[str, str] = {}
    for s in out:
        if s.name in seen:
            raise InputError(
                f"population: subject {s.name!r} appears twice ({seen[s.name]}, {s.label}); "
                "pool one study per subject"
            )
        seen[s.name] = s.label
    return out


def subject_draws(study: StudyPosterior, body: str, covariates: dict[str, float]) -> SubjectDraws:
    """One study's draws of ``body`` with the log density of the prior they were made under."""
    post = study.posterior
    theta = np.column_stack([post.draws(body, p).ravel() for p in PARAMETERS])
    tree = post.tree
    if "log_prior" in tree.children and "body_prior" in tree["log_prior"].data_vars:
        log_interim = np.asarray(tree["log_prior"]["body_prior"].sel(body=body).values).ravel()
    else:  # older files: the stored prior's density
        log_interim = priors_from_posterior(post)[body].log_density(*theta.T)
    box = post.prior_box(body)
    support = np.array([box[p] for p in PARAMETERS])
    return SubjectDraws(study.name, np.log(theta), log_interim, covariates, support)


def _gravity(studies: Sequence[StudyPosterior]) -> float:
    values = []
    for s in studies:
        cd = s.posterior.tree["constant_data"]
        if "gravity" in cd:
            values.append(float(cd["gravity"]))
    return float(np.mean(values)) if values else GRAVITY


def _check_covariates(covariates: Mapping[str, Sequence[str]] | None) -> dict[str, tuple]:
    if covariates is None:
        return dict(DEFAULT_COVARIATES)
    out = {}
    for p in PARAMETERS:
        names = covariates.get(p, ())
        if isinstance(names, str):
            names = (names,)
        out[p] = tuple(str(n) for n in names)
    unknown = set(covariates) - set(PARAMETERS)
    if unknown:
        raise InputError(
            f"covariates: {', '.join(sorted(unknown))}: expected parameters "
            f"({', '.join(PARAMETERS)})"
        )
    return out


def _bodies(
    studies: Sequence[StudyPosterior],
    bodies: Sequence[str] | None,
    needed: set[str],
    say: Callable[[str], None],
) -> dict[str, list[StudyPosterior]]:
    """Each pooled body with its studies (every covariate known in each)."""
    names: dict[str, list[StudyPosterior]] = {}
    for s in studies:
        for b in s.posterior.bodies:
            names.setdefault(b, []).append(s)
    chosen = list(bodies) if bodies is not None else list(names)
    out = {}
    for b in chosen:
        held = names.get(b, [])
        missing = [
            (s, sorted(needed - set(s.covariates(b))))
            for s in held
            if needed - set(s.covariates(b))
        ]
        if bodies is not None and b not in names:
            raise InputError(f"bodies: {b!r} is in none of the studies ({', '.join(names)})")
        if missing:
            s, what = missing[0]
            line = (
                f"{s.label}: body {b!r}: no {', '.join(what)} recorded "
                f"({len(missing)} of {len(held)} studies lack a covariate); the population "
                "regresses on it (add [subject] body_mass and the body's segment_length to the "
                "manifest and run it again)"
            )
            if bodies is not None:
                raise InputError(line)
            say(f"population: body {b!r} not pooled: {line}")
            continue
        if len(held) < MIN_SUBJECTS:
            line = f"body {b!r} is in {len(held)} studies; a population needs {MIN_SUBJECTS}"
            if bodies is not None:
                raise InputError(f"population: {line}")
            say(f"population: {line}; not pooled")
            continue
        out[b] = held
    if not out:
        raise InputError(
            "population: no body to pool (each needs "
            f"{MIN_SUBJECTS} studies with {', '.join(sorted(needed))} recorded)"
        )
    return out


# -- the hyperparameters' posterior ---------------------------------------------------
#: Most draws per subject the density takes when the first share is too few: its cost
#: grows with subjects x draws (20 subjects x 12 000 draws: about 2 minutes here).
MAX_DRAWS = 12_000
#: Hyperparameter draws each subject's pooled estimate is drawn over.
POOL_DRAWS = 4000
#: Draws per subject the density uses: about this many in all, within :data:`DRAWS_RANGE`.
POINTS = 60_000
DRAWS_RANGE = (500, 5000)


def _thinned(subjects: Sequence[SubjectDraws], n: int | None, seed: int = 0) -> list[SubjectDraws]:
    """Each subject's draws: ``n`` of them (default from :data:`POINTS`), stratified.

    A subject's draws lie along the ridge its data leave open, and the population's density
    changes mostly along it: the draws are ranked along their first principal axis, cut
    into ``n`` strata of equal count, and one draw taken at random from each (returned in
    their stored order, which :func:`_split_half_noise` reads). On a cohort of 100 this
    halved the SD of the mean of importance weights against draws taken at random, at the
    same cost. Each
    subject its own random positions: studies sampled with one seed (``run-many`` gives
    every study the same) share their walkers' excursions at the same steps, and evenly
    spaced positions took the same tail draw from every subject, which the population then
    fitted (measured on a cohort of 20 run with seed 0).
    """
    if n is None:
        n = int(np.clip(POINTS // max(len(subjects), 1), *DRAWS_RANGE))
    n = min(n, *(len(s.log_theta) for s in subjects))  # one count for every subject
    out = []
    for k, s in enumerate(subjects):
        total = len(s.log_theta)
        if total <= n:
            out.append(s)
            continue
        centred = s.log_theta - s.log_theta.mean(axis=0)
        axis = np.linalg.svd(centred, full_matrices=False)[2][0]
        order = np.argsort(centred @ axis, kind="stable")
        edges = np.linspace(0, total, n + 1).astype(int)
        within = np.random.default_rng([seed, k]).random(n) * np.diff(edges)
        idx = np.sort(order[edges[:-1] + within.astype(int)])  # in stored order again
        out.append(s.take(idx))
    return out


def _moment_start(features: model.Features, matrices) -> np.ndarray:
    """Each parameter's regression on the subjects' mean draws, scatters 0.3, no correlation."""
    mean = features.theta.mean(axis=1)
    coefs: list[float] = []
    for k in range(3):
        coef, *_ = np.linalg.lstsq(matrices[k], mean[:, k], rcond=None)
        coefs += [float(c) for c in coef]
    return np.asarray(coefs + [math.log(0.3)] * 3 + [0.0] * 3)  # scatters set by the caller


#: Smallest scatter the EM start takes (the sampler then goes where the density says).
EM_MIN_SCATTER = 0.03


def _em_start(
    features: model.Features, design: Design, matrices, iterations: int = 60
) -> np.ndarray:
    """A starting vector by expectation-maximisation of the importance-weighted likelihood.

    Each pass weights every subject's draws by the current population (the E-step) and fits
    each parameter's regression to the weighted means and the scatter to the weighted spread
    about it (the M-step; each parameter's coefficients by their own least squares). It finds
    the neighbourhood of the mode in tens of passes, each one density evaluation; the
    Laplace proposal around it is measured there (:func:`_hessian`).
    """
    n, s, _ = features.theta.shape
    w = np.full((n, s), 1.0 / s)
    z = np.zeros(design.ndim)
    for _ in range(iterations):
        mean = np.einsum("is,isk->ik", w, features.theta)  # (N, 3)
        coefs: list[float] = []
        mu = np.empty((n, 3))
        for k in range(3):
            coef, *_ = np.linalg.lstsq(matrices[k], mean[:, k], rcond=None)
            coefs += [float(c) for c in coef]
            mu[:, k] = matrices[k] @ coef
        d = features.theta - mu[:, None, :]
        cov = np.einsum("is,isj,isk->jk", w, d, d) / n
        sd = np.sqrt(np.clip(np.diag(cov), EM_MIN_SCATTER**2, None))
        r = np.clip(cov / np.outer(sd, sd), -0.95, 0.95)
        r23 = (r[1, 2] - r[0, 1] * r[0, 2]) / math.sqrt((1 - r[0, 1] ** 2) * (1 - r[0, 2] ** 2))
        cpc = np.clip([r[0, 1], r[0, 2], r23], -0.95, 0.95)
        new = np.asarray(coefs + list(np.log(sd)) + list(np.arctanh(cpc)))
        if np.max(np.abs(new - z)) < 1e-5:
            z = new
            break
        z = new
        lw = features.log_weights(design, matrices, z)[:, 0]
        w = np.exp(lw - lw.max(axis=1, keepdims=True))
        w /= w.sum(axis=1, keepdims=True)
    return z


def _gradient(f, x: np.ndarray, h: float = 1e-5) -> tuple[float, np.ndarray]:
    """``f(x)`` and its central-difference gradient from one vectorised call of ``f``."""
    d = len(x)
    v = f(np.vstack([x, x + h * np.eye(d), x - h * np.eye(d)]))
    return float(v[0]), (v[1 : d + 1] - v[d + 1 :]) / (2 * h)


def _hessian(f, x: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Central-difference Hessian of ``f`` at ``x`` from one vectorised call."""
    d = len(x)
    e = np.eye(d) * h
    pts = [x]
    for i in range(d):
        for j in range(i, d):
            pts += [x + e[i] + e[j], x + e[i] - e[j], x - e[i] + e[j], x - e[i] - e[j]]
    v = f(np.vstack(pts))
    H = np.empty((d, d))
    k = 1
    for i in range(d):
        for j in range(i, d):
            H[i, j] = H[j, i] = (v[k] - v[k + 1] - v[k + 2] + v[k + 3]) / (4 * h * h)
            k += 4
    return H


def fit_population(
    subjects: Sequence[SubjectDraws],
    design: Design,
    *,
    hyperprior: Hyperprior | None = None,
    center: Sequence[float] | np.ndarray,
    seed: int = 0,
    n_walkers: int = 32,
    ess_target: float = 400.0,
    max_steps: int = 20000,
    chunk: int = 250,
    draws_per_subject: int | None = None,
    moves: str = "independent",
    pool_draws: int = POOL_DRAWS,
) -> PopulationFit:
    """Sample the hyperparameters' posterior with emcee, then pool every subject.

    The density reads each subject's stored draws (up to :data:`MAX_DRAWS`) as Gaussian
    cells along its ridge (:class:`~inertiafit.inference.population.Cells`); the start (EM)
    and each subject's pooled draws use a stratified share of them (``draws_per_subject``,
    default from :data:`POINTS`), and its importance-weight ESS every one. The walkers start
    around the Laplace approximation at the posterior mode and move by
    independence Metropolis-Hastings from a Student-t around it, differential evolution and
    DE-snooker (:func:`inertiafit.inference.moves.emcee_moves`); sampling runs in chunks until
    every coordinate's bulk ESS reaches ``ess_target`` and its nested R-hat (over
    :data:`SUPERCHAINS` groups of walkers) is at most :data:`R_HAT_MAX`.
    """
    import emcee
    from scipy import optimize

    from inertiafit.inference.moves import IndependenceMove, emcee_moves, run_steps
    from inertiafit.inference.sampler import convergence_check

    seed = check_seed(seed)
    hyper = hyperprior or Hyperprior()
    centre = np.asarray(
        center if hyper.intercept_mean is None else hyper.intercept_mean, dtype=float
    )
    # The density reads every stored draw (up to MAX_DRAWS), summarised in cells; a share of
    # them (stratified) gives the start and each subject's pooled draws.
    all_draws = _thinned(subjects, MAX_DRAWS, seed)
    every = model.Features(all_draws)
    cells = model.Cells(all_draws, seed=seed)
    features = model.Features(_thinned(subjects, draws_per_subject, seed))
    matrices = design.matrices([s.covariates for s in subjects])

    def log_post_model(z):
        z = np.atleast_2d(z)
        lp = model.hyper_log_prior(design, hyper, centre, z)
        ok = np.isfinite(lp) & np.all(np.abs(z) < 50, axis=1) & model.in_domain(design, z)
        out = np.full(len(z), -np.inf)
        if ok.any():
            out[ok] = lp[ok] + cells.log_likelihood(design, matrices, z[ok])
        return out

    def log_post(u):
        """The density in the sampled coordinates (:func:`to_model`), with its Jacobian."""
        z, log_jac = model.to_model(design, np.atleast_2d(u))
        out = np.full(len(z), -np.inf)
        ok = np.isfinite(log_jac)
        if ok.any():
            out[ok] = log_post_model(z[ok]) + log_jac[ok]
        return out

    def neg(u):
        v = log_post(u)
        return np.where(np.isfinite(v), -v, 1e300)

    # EM finds the likelihood's mode; a short quasi-Newton polish adds the hyperprior.
    em = model.to_sampled(design, _em_start(features, design, matrices)[None])[0]
    scatters = slice(design.ndim - 6, design.ndim - 3)
    if not np.isfinite(log_post(em))[0]:
        # EM drawn to a few draws: the subjects' means, with scatters from wide to narrow (a
        # subject's far excursion against its own prior weighs e^11 times the rest under a
        # wide population, and a narrower one gives it no weight).
        moments = _moment_start(features, matrices)
        for sigma in (0.3, 0.15, 0.08, 0.04, 0.02):
            moments[scatters] = math.log(sigma)
            candidate = model.to_sampled(design, moments[None])[0]
            if np.isfinite(log_post(candidate))[0]:
                em = candidate
                break
    while not np.isfinite(log_post(em))[0] and em[scatters].min() < math.log(2.0):
        em[scatters] += math.log(1.5)  # some subject's ESS too low there: wider scatters
    polish = optimize.minimize(
        lambda x: _gradient(neg, x), em, jac=True, method="L-BFGS-B", options={"maxiter": 60}
    )
    mode = polish.x if polish.fun <= neg(em)[0] else em
    # Curvature at the mode; a direction of negative or tiny curvature gets a variance of 1.
    hessian = _hessian(neg, mode)
    if np.all(np.isfinite(hessian)) and np.abs(hessian).max() < 1e200:
        eigval, eigvec = np.linalg.eigh(hessian)
        cov = (eigvec / np.clip(eigval, 1.0, None)) @ eigvec.T
    else:  # the mode next to where the density is zero: the warm-up finds the spread
        cov = np.eye(design.ndim) * 0.01
    rng = np.random.default_rng(seed)
    # enough walkers for the moves, in whole groups for nested R-hat
    n_walkers = SUPERCHAINS * math.ceil(max(n_walkers, 2 * design.ndim + 2) / SUPERCHAINS)
    if not np.isfinite(log_post(mode))[0]:
        z, _ = model.to_model(design, mode[None])
        subject_ess = _weight_ess(features.log_weights(design, matrices, z)[:, 0])
        worst = int(np.argmin(subject_ess))
        raise InputError(
            f"population: subject {subjects[worst].name!r}: importance-weight ESS "
            f"{subject_ess[worst]:.0f} of {features.n_draws} draws (needs {MIN_ESS:.0f}) even for a "
            "population wider than the subjects: its draws follow its own prior's shape "
            "more than its data can be reweighted; fit it with a wider prior or more draws"
        )
    start = np.empty((0, design.ndim))
    for shrink in (1.0, 0.25, 0.0625, 0.01, 1e-4):  # a start ball inside the density's support
        ball = rng.multivariate_normal(mode, cov * shrink, size=8 * n_walkers)
        start = np.vstack([start, ball[np.isfinite(log_post(ball))]])
        if len(start) >= n_walkers:
            break
    else:
        start = mode + 1e-6 * rng.standard_normal((n_walkers, design.ndim))
    start = start[:n_walkers]
    chosen = emcee_moves(moves, mode, cov)
    sampler = emcee.EnsembleSampler(n_walkers, design.ndim, log_post, vectorize=True, moves=chosen)
    sampler.random_state = np.random.RandomState(seed).get_state()
    # Warm-up: the independence proposal is refitted to the walkers' own spread after each of
    # ADAPT chunks (the Hessian at the mode misjudges the scatters' skew); then it is fixed and
    # the draws before are dropped, so detailed balance holds for every kept draw.
    state = run_steps(sampler, start, chunk)
    independence = [m for m, _ in chosen if isinstance(m, IndependenceMove)]
    for _ in range(ADAPT if independence else 0):
        recent = sampler.get_chain()[-chunk // 2 :].reshape(-1, design.ndim)
        spread = np.cov(recent.T) + np.eye(design.ndim) * 1e-8
        with contextlib.suppress(np.linalg.LinAlgError):  # walkers stuck: keep the proposal
            independence[0].refit(recent.mean(axis=0), spread)
        state = run_steps(sampler, state, chunk)
    warm = sampler.iteration
    steps, failing = 0, 0
    while True:
        state = run_steps(sampler, state, chunk)
        steps += chunk
        chain = sampler.get_chain()[warm:].swapaxes(0, 1)  # (walker, step, D)
        # each coordinate's ESS and R-hat until one fails (last time's culprit first); at
        # max_steps every one, for the record
        bulk, r, culprit = convergence_check(
            {"z": chain},
            ess_target,
            R_HAT_MAX,
            failing,
            early=steps < max_steps,
            superchains=SUPERCHAINS,
        )
        failing = culprit if culprit is not None else failing
        if culprit is None or steps >= max_steps:
            break
    if culprit is not None:
        warnings.warn(
            f"population: the hyperparameters did not converge in {steps} steps (bulk ESS "
            f"{bulk:.0f}, nested R-hat {r:.3f}); the intervals are rough",
            ConvergenceWarning,
            stacklevel=2,
        )
    draws = model.to_model(design, chain.reshape(-1, design.ndim))[0].reshape(chain.shape)
    flat = draws.reshape(-1, design.ndim)
    # Each subject pooled over (at most) POOL_DRAWS hyperparameter draws, evenly spaced.
    keep = _evenly(flat, pool_draws)
    # Each subject's ESS and the density's noise at CHECKED_DRAWS of them, evenly spaced.
    checked = _evenly(keep, CHECKED_DRAWS)
    ess_sub, ess_low, pooled = _pool(features, every, design, matrices, keep, checked, rng)
    noise = _split_half_noise(all_draws, design, matrices, checked, seed=seed)
    median = np.median(flat, axis=0)
    return PopulationFit(
        design=design,
        hyperprior=hyper,
        center=centre,
        draws=draws,
        subjects=[s.name for s in subjects],
        ess=ess_sub,
        ess_low=ess_low,
        n_draws=every.n_draws,
        pooled=pooled,
        box_mass=model.box_mass(design, median, subjects, rng),
        diagnostics={
            "steps": steps,
            "warm_up": warm,
            "n_walkers": n_walkers,
            "acceptance": float(np.mean(sampler.acceptance_fraction)),
            "ess_bulk_min": bulk,
            "r_hat_max": r,
            "loglike_variance": float(np.var(noise)),
            "mode": model.to_model(design, mode[None])[0][0].tolist(),
        },
    )


def _evenly(rows: np.ndarray, k: int) -> np.ndarray:
    """At most ``k`` of ``rows``, evenly spaced from the first to the last."""
    return rows[np.linspace(0, len(rows) - 1, min(k, len(rows))).round().astype(int)]


def _weight_ess(log_weights: np.ndarray) -> np.ndarray:
    """The importance-weight ESS, ``(sum w)^2 / sum w^2``, over the last axis."""
    w = np.exp(log_weights - log_weights.max(axis=-1, keepdims=True))
    return w.sum(axis=-1) ** 2 / np.sum(w * w, axis=-1)


def _pool(
    share: model.Features,
    every: model.Features,
    design: Design,
    matrices,
    flat: np.ndarray,
    checked: np.ndarray,
    rng,
    chunk: int = 32,
):
    """Each subject's pooled draws and its importance-weight ESS.

    Pooled draws: one of the ``share`` draws for each hyperparameter draw in ``flat``
    ``(K, D)``, by its weight. ESS with ``every`` draw: at the median of ``flat``, and its
    5th percentile over the hyperparameter draws ``checked``.
    """
    n, s = share.offset.shape
    pooled = np.empty((n, len(flat), 3))
    for i in range(0, len(flat), chunk):
        lw = share.log_weights(design, matrices, flat[i : i + chunk])  # (N, w, S)
        lw -= lw.max(axis=-1, keepdims=True)
        w = np.exp(lw)
        cdf = np.cumsum(w, axis=-1)  # (N, w, S)
        u = rng.uniform(size=(n, cdf.shape[1], 1)) * cdf[..., -1:]
        idx = np.minimum((cdf < u).sum(axis=-1), s - 1)  # (N, w)
        pooled[:, i : i + chunk] = np.take_along_axis(
            share.theta, idx[..., None].repeat(3, axis=2), axis=1
        )
    ess_all = np.concatenate(
        [
            _weight_ess(every.log_weights(design, matrices, checked[i : i + 8]))
            for i in range(0, len(checked), 8)
        ],
        axis=1,
    )  # (N, len(checked))
    at_median = _weight_ess(every.log_weights(design, matrices, np.median(flat, axis=0))[:, 0])
    return at_median, np.quantile(ess_all, 0.05, axis=1), pooled


def _split_half_noise(
    subjects: Sequence[SubjectDraws],
    design: Design,
    matrices,
    flat: np.ndarray,
    blocks: int = 16,
    seed: int = 0,
) -> np.ndarray:
    """An estimate ``(K,)`` of the cells' error in the log likelihood at each of ``flat``.

    Each subject's stored draws are cut, in their stored order, into ``blocks`` runs; the
    even runs make one half, the odd the other. Half the difference of the two halves' log
    likelihoods has the variance of the whole's error (each half's is twice the whole's).
    Runs rather than draws taken at random, so that draws next to each other in a chain
    (correlated) are not shared between the halves, which would make the halves alike and
    the noise look small. Its variance over the posterior's draws is the part of the error
    that changes the posterior's shape (a constant offset does not): on 40 independent sets
    of 1000 draws of six subjects, at ten populations 0.1 apart in log, it was 1.07 of what
    the sets scattered by, and its mean square 0.93 of the level's
    (``tests/test_population.py``). Each half has as many cells as the whole, so that their
    shapes err as the whole's do. It sees noise, not a bias the halves share: on 40 subjects
    whose cells were cut as slices (before k-means), the error's variance over the posterior
    against the exact likelihood was 50 where the halves said 0.3; with k-means cells 1.47
    where they say 1.45-1.52 (two seeds). Not all of it even so: on 20 subjects fitted by
    ``fit_body`` (7744 sampler draws each) the error's variance was 1.0 where they said 0.18.
    """
    halves: tuple[list[SubjectDraws], list[SubjectDraws]] = ([], [])
    for s in subjects:
        run = np.arange(len(s.log_theta)) * blocks // len(s.log_theta)
        for half, idx in zip(halves, (run % 2 == 0, run % 2 == 1), strict=True):
            half.append(s.take(idx))
    # as many cells in each half as in the whole (half the draws each): the noise of these
    # cells, not of coarser ones
    a, b = (
        model.Cells(half, draws_per_cell=model.CELL_DRAWS // 2, seed=seed).log_likelihood(
            design, matrices, flat
        )
        for half in halves
    )
    return (a - b) / 2.0


def _decided(draws: np.ndarray, prior_sd: float, ess: float) -> str:
    """Who decides a hyperparameter: the one verdict a body's parameters get.

    Its posterior SD over its hyperprior SD (from :data:`PRIOR_SD_DRAWS` draws of the
    hyperprior), read by :func:`inertiafit.posterior.pins.verdict` with the ratio's Monte Carlo
    SE (an SD from ``n`` effective draws has a relative SE of ``1/sqrt(2 n)``), so that the
    same cohort fitted with another seed keeps its verdict.
    """
    from inertiafit.posterior.pins import verdict

    if not prior_sd > 0:
        return "data"
    ratio = float(np.std(draws)) / prior_sd
    n = ess if math.isfinite(ess) and ess > 0 else float(len(draws))
    se = ratio * math.sqrt(1.0 / (2.0 * n) + 1.0 / (2.0 * PRIOR_SD_DRAWS))
    return verdict(ratio, se)


class PopulationPosterior:
    """The population of many subjects' studies: hyperparameters, pooled subjects, predictions.

    Attributes
    ----------
    fits : dict of str to PopulationFit
        Per pooled body.
    studies : dict of str to list of StudyPosterior
        Per pooled body, its studies (``None`` entries when opened from ``population.nc``).
    gravity : float
        m/s^2 (the studies' mean), for ``M_g``.
    """

    def __init__(
        self,
        fits: dict[str, PopulationFit],
        studies: dict[str, list[StudyPosterior]],
        *,
        gravity: float,
        seed: int,
        subjects: pd.DataFrame | None = None,
    ) -> None:
        self.fits = fits
        self.studies = studies
        self.gravity = gravity
        self.seed = seed
        self._stored = subjects  # subjects.csv as a population.nc holds it
        self._cache: dict[tuple[str, float], pd.DataFrame] = {}  # tables, by hdi_prob
        self.bodies = tuple(fits)

    # -- tables ---------------------------------------------------------------------------
    def summary(self, hdi_prob: float = 0.95) -> pd.DataFrame:
        """``population.csv``: every hyperparameter's median and HDI, per body.

        ``decided_by`` says who decides each (``data``, ``data + prior``, ``prior``: its
        posterior SD under 0.3 or over 0.7 of its hyperprior SD, as for a body's parameters).
        """
        check_probability(hdi_prob, "hdi_prob")
        key = ("summary", float(hdi_prob))
        if key not in self._cache:
            self._cache[key] = self._summary(hdi_prob)
        return self._cache[key].copy()

    def _summary(self, hdi_prob: float) -> pd.DataFrame:
        rows = []
        for body, fit in self.fits.items():
            design = fit.design
            reference = "; ".join(
                f"{c}={design.reference(c):.4g}"
                + (
                    " kg"
                    if c == "body_mass"
                    else " m"
                    if c in ("segment_length", "height")
                    else ""
                )
                for c in sorted(design.centers)
            )
            terms = model.natural_terms(design, fit.flat)
            prior_sd = self._prior_sd(body)
            chains = {k: v.reshape(fit.draws.shape[:2]) for k, v in terms.items()}
            typical = {p: np.exp(terms[p, "intercept"]) for p in PARAMETERS}
            typical["inertia"] = typical["mass"] * (
                typical["radius_of_gyration"] ** 2 + typical["com_distance"] ** 2
            )
            typical["gravity_moment"] = typical["mass"] * self.gravity * typical["com_distance"]
            for p in REPORTED:
                v = typical[p]
                chain = v.reshape(fit.draws.shape[:2])
                row = self._row(body, p, "typical", v, chain, hdi_prob, UNITS[p], reference)
                row["decided_by"] = _decided(np.log(v), prior_sd[p, "typical"], row["ess_bulk"])
                rows.append(row)
            for (p, term), v in terms.items():
                if term == "intercept":
                    continue
                unit = "" if term.startswith(("slope", "correlation")) else "log"
                row = self._row(body, p, term, v, chains[p, term], hdi_prob, unit, reference)
                row["decided_by"] = _decided(v, prior_sd[p, term], row["ess_bulk"])
                rows.append(row)
        return pd.DataFrame(rows, columns=POPULATION_COLUMNS)

    def _prior_sd(self, body: str) -> dict[tuple[str, str], float]:
        """Each reported term's SD under the hyperprior (log units for the typical values)."""
        fit = self.fits[body]
        rng = np.random.default_rng(0)
        z = model.sample_hyperprior(fit.design, fit.hyperprior, fit.center, PRIOR_SD_DRAWS, rng)
        terms = model.natural_terms(fit.design, z)
        out = {k: float(np.std(v)) for k, v in terms.items()}
        typ = {p: terms[p, "intercept"] for p in PARAMETERS}
        out.update({(p, "typical"): out[p, "intercept"] for p in PARAMETERS})
        out["inertia", "typical"] = float(
            np.std(
                typ["mass"]
                + np.log(np.exp(2 * typ["radius_of_gyration"]) + np.exp(2 * typ["com_distance"]))
            )
        )
        out["gravity_moment", "typical"] = float(np.std(typ["mass"] + typ["com_distance"]))
        return out

    def text(self, hdi_prob: float = 0.95) -> str:
        """What the population says, for the terminal."""
        table = self.summary(hdi_prob)
        pct = f"{100 * hdi_prob:g} %"
        lines = []
        for body, fit in self.fits.items():
            t = table[table["body"] == body]
            lines.append(
                f"population of {body!r}: {len(fit.subjects)} subjects; importance-weight ESS "
                f"{fit.ess.min():.0f}-{fit.ess.max():.0f} of {fit.n_draws} draws each "
                "(variance of the log likelihood "
                f"{fit.diagnostics.get('loglike_variance', float('nan')):.2g}); "
                f"hyperparameters: {fit.diagnostics.get('steps', '?')} steps, bulk ESS "
                f">= {fit.diagnostics.get('ess_bulk_min', float('nan')):.0f}, "
                f"nested R-hat <= {fit.diagnostics.get('r_hat_max', float('nan')):.3f}"
            )
            lines.append(f"  typical subject ({t['reference'].iloc[0]}), median [{pct} HDI]:")
            for _, r in t[t["term"] == "typical"].iterrows():
                lines.append(
                    f"    {r['parameter']:<19} {r['median']:.4g} [{r['hdi_lower']:.4g}, "
                    f"{r['hdi_upper']:.4g}] {r['unit']}  ({r['decided_by']})"
                )
            lines.append("  slopes (elasticities), scatter (SD of log), correlations:")
            for _, r in t[t["term"] != "typical"].iterrows():
                lines.append(
                    f"    {r['parameter'] + ' ' + r['term']:<46} {r['median']:+.3g} "
                    f"[{r['hdi_lower']:+.3g}, {r['hdi_upper']:+.3g}]  ({r['decided_by']})"
                )
            prior_only = sorted(
                f"{r['parameter']} {r['term']}"
                for _, r in t.iterrows()
                if r["decided_by"] == "prior"
            )
            if prior_only:
                lines.append(
                    "  decided by the hyperprior, not the subjects: "
                    + ", ".join(prior_only)
                    + ". With only I and M_g per subject, m, x and rho lie on a ridge that each "
                    "subject's own prior bounds; weighed segments or a second mounting would "
                    "separate them (a spread of segment lengths only narrows them)."
                )
        return "\n".join(lines)

    @staticmethod
    def _row(body, p, term, v, chain, hdi_prob, unit, reference) -> dict[str, Any]:
        from arviz_stats import ess, rhat, rhat_nested

        lo, hi = model.hdi_bounds(v, hdi_prob)
        # nested R-hat over the groups of walkers the stopping rule reads (a population.nc
        # written before walkers came in whole groups: plain R-hat)
        groups = len(chain) % SUPERCHAINS == 0
        r_hat = (
            rhat_nested(chain, superchain_ids=np.arange(len(chain)) % SUPERCHAINS)
            if groups
            else rhat(chain)
        )
        return {
            "body": body,
            "parameter": p,
            "term": term,
            "median": float(np.median(v)),
            "hdi_lower": lo,
            "hdi_upper": hi,
            "hdi_prob": hdi_prob,
            "unit": unit,
            "ess_bulk": float(ess(chain, method="bulk")),
            "r_hat": float(r_hat),
            "reference": reference,
        }

    def subjects(self, hdi_prob: float = 0.95) -> pd.DataFrame:
        """``subjects.csv``: each subject's own and pooled estimates side by side."""
        check_probability(hdi_prob, "hdi_prob")
        if self._stored is not None:
            return self._stored.copy()
        key = ("subjects", float(hdi_prob))
        if key not in self._cache:
            self._cache[key] = self._subject_rows(hdi_prob)
        return self._cache[key].copy()

    def _subject_rows(self, hdi_prob: float) -> pd.DataFrame:
        rows = []
        for body, fit in self.fits.items():
            for i, study in enumerate(self.studies[body]):
                own_log = np.log(
                    np.column_stack([study.posterior.draws(body, p).ravel() for p in PARAMETERS])
                )
                own = dict(zip(REPORTED, model.reported(own_log, self.gravity).T, strict=True))
                pooled = dict(
                    zip(REPORTED, model.reported(fit.pooled[i], self.gravity).T, strict=True)
                )
                for p in REPORTED:
                    olo, ohi = model.hdi_bounds(own[p], hdi_prob)
                    plo, phi = model.hdi_bounds(pooled[p], hdi_prob)
                    rows.append(
                        {
                            "subject": study.name,
                            "study": study.label,
                            "body": body,
                            "parameter": p,
                            "own_median": float(np.median(own[p])),
                            "own_hdi_lower": olo,
                            "own_hdi_upper": ohi,
                            "pooled_median": float(np.median(pooled[p])),
                            "pooled_hdi_lower": plo,
                            "pooled_hdi_upper": phi,
                            "width_ratio": (phi - plo) / (ohi - olo) if ohi > olo else math.nan,
                            "unit": UNITS[p],
                            "importance_ess": float(fit.ess[i]),
                            "box_mass": float(fit.box_mass[i]),
                        }
                    )
        return pd.DataFrame(rows, columns=SUBJECT_COLUMNS)

    # -- prediction -----------------------------------------------------------------------
    def predictive(
        self, body: str, *, seed: int | None = None, **covariates: float
    ) -> dict[str, np.ndarray]:
        """Draws of a new subject's ``m, x, rho, I, M_g`` (one per hyperparameter draw)."""
        fit = self._fit(body)
        needed = sorted(fit.design.centers)
        missing = [c for c in needed if c not in covariates]
        if missing:
            raise InputError(
                f"predict: {', '.join(missing)}: needed (the population of {body!r} regresses "
                f"on {', '.join(needed)})"
            )
        values = {}
        for c in needed:
            values[c] = (
                check_positive(covariates[c], f"predict: {c}")
                if c in model.LOG_COVARIATES
                else check_finite(covariates[c], f"predict: {c}")
            )
        rng = np.random.default_rng(self.seed if seed is None else check_seed(seed))
        return model.predictive_draws(fit.design, fit.flat, values, rng, self.gravity)

    def predict(self, body: str, *, hdi_prob: float = 0.95, **covariates: float) -> pd.DataFrame:
        """A new subject's ``m, x, rho, I, M_g``: median and HDI of the predictive distribution.

        ``covariates`` are the regression's (``body_mass`` in kg, ``segment_length`` in m, by
        default).
        """
        check_probability(hdi_prob, "hdi_prob")
        draws = self.predictive(body, seed=None, **covariates)
        rows = []
        for p in REPORTED:
            lo, hi = model.hdi_bounds(draws[p], hdi_prob)
            rows.append(
                {
                    "parameter": p,
                    "median": float(np.median(draws[p])),
                    "hdi_lower": lo,
                    "hdi_upper": hi,
                    "hdi_prob": hdi_prob,
                    "unit": UNITS[p],
                }
            )
        return pd.DataFrame(rows, columns=PREDICT_COLUMNS)

    def _fit(self, body: str) -> PopulationFit:
        if body not in self.fits:
            raise InputError(
                f"body: {body!r} is not in this population ({', '.join(self.fits) or 'none'})"
            )
        return self.fits[body]

    # -- storage --------------------------------------------------------------------------
    def tree(self, hdi_prob: float = 0.95):
        """The population as an ``xarray.DataTree`` (what ``population.nc`` holds)."""
        return model.population_tree(
            self.fits,
            self.subjects(hdi_prob),
            gravity=self.gravity,
            attrs={
                "inertiafit_version": __version__,
                "seed": self.seed,
                "studies": json.dumps(
                    {b: [s.label for s in studies] for b, studies in self.studies.items()}
                ),
            },
        )

    def save(self, path: str | Path, hdi_prob: float = 0.95) -> Path:
        """Write ``population.nc``."""
        path = Path(path)
        self.tree(hdi_prob).to_netcdf(path)
        return path

    def __repr__(self) -> str:
        n = {b: len(f.subjects) for b, f in self.fits.items()}
        return f"PopulationPosterior({', '.join(f'{b}: {k} subjects' for b, k in n.items())})"


def population(
    sources: Sequence[str | Path | Posterior] | str | Path,
    *,
    seed: int = 0,
    bodies: Sequence[str] | None = None,
    covariates: Mapping[str, Sequence[str]] | None = None,
    hyperprior: Hyperprior | None = None,
    echo: Callable[[str], None] | None = None,
) -> PopulationPosterior:
    """Pool many subjects' studies into a population (log-linear regressions with scatter).

    Parameters
    ----------
    sources : paths or Posterior objects
        ``run``/``fit`` output folders (or their ``posterior.nc``), ``run-many`` output
        folders (every study that succeeded), or :class:`~inertiafit.posterior.Posterior`
        objects.
    seed : int
        Seed of every random draw.
    bodies : sequence of str, optional
        The bodies to pool (default: each body in at least :data:`MIN_SUBJECTS` studies with
        every covariate recorded; the others are named in a line).
    covariates : mapping, optional
        Per parameter (``mass``, ``com_distance``, ``radius_of_gyration``) the ``[subject]``
        keys or ``segment_length`` it is regressed on (default
        :data:`~inertiafit.inference.population.DEFAULT_COVARIATES`); ``()`` for none.
    hyperprior : Hyperprior, optional

    Raises
    ------
    InputError
        A source that is no output, a subject twice, a covariate missing from a named body, or
        a subject whose draws cannot represent the population (importance-weight ESS below
        :data:`~inertiafit.inference.population.MIN_ESS` even with every stored draw).
    """
    seed = check_seed(seed)
    say = echo or (lambda _m: None)
    covs = _check_covariates(covariates)
    needed = {c for cs in covs.values() for c in cs}
    studies = gather(sources, say)
    chosen = _bodies(studies, bodies, needed, say)
    fits = {}
    for body, held in chosen.items():
        draws = [subject_draws(s, body, s.covariates(body)) for s in held]
        design = Design.for_cohort(covs, [d.covariates for d in draws])
        nominal = np.array(
            [[s.posterior.prior_values(body, "nominal")[p] for p in PARAMETERS] for s in held]
        )
        center = np.log(nominal).mean(axis=0)
        say(f"population: body {body!r}: {len(held)} subjects")
        fit = fit_population(draws, design, hyperprior=hyperprior, center=center, seed=seed)
        low = [i for i, e in enumerate(fit.ess) if e < MIN_ESS]
        if low:
            i = low[0]
            raise InputError(
                f"{held[i].label}: subject {held[i].name!r}, body {body!r}: importance-weight "
                f"ESS {fit.ess[i]:.0f} of {fit.n_draws} draws (needs {MIN_ESS:.0f}): its draws "
                "cannot represent the population (the population is far narrower than its "
                "posterior, or it lies outside the population); fit it with more draws or a "
                "narrower prior"
            )
        if fit.diagnostics["loglike_variance"] > MAX_LOGLIKE_VARIANCE:
            warnings.warn(
                f"population: body {body!r}: the variance of the estimated log likelihood is "
                f"{fit.diagnostics['loglike_variance']:.2g} (above {MAX_LOGLIKE_VARIANCE:g}) "
                f"with {fit.n_draws} draws per subject: the intervals may be narrower than "
                "they should be (fit the studies with more draws: run-many --ess-min)",
                InertiafitWarning,
                stacklevel=2,
            )
        for i in (int(k) for k in np.flatnonzero(fit.box_mass < MIN_BOX_MASS)):
            warnings.warn(
                f"{held[i].label}: subject {held[i].name!r}, body {body!r}: "
                f"{100 * (1 - fit.box_mass[i]):.0f} % of the population lies outside its prior "
                "box, where its draws cannot go; its pull on the population is cut there",
                InertiafitWarning,
                stacklevel=2,
            )
        fits[body] = fit
    return PopulationPosterior(fits, chosen, gravity=_gravity(studies), seed=seed)


def open_population(path: str | Path) -> PopulationPosterior:
    """A :class:`PopulationPosterior` from its ``population.nc`` (predictions and tables)."""
    fits, subjects, attrs = model.read_population(path)
    return PopulationPosterior(
        fits,
        {b: [] for b in fits},
        gravity=float(attrs.get("gravity", GRAVITY)),
        seed=int(attrs.get("seed", 0)),
        subjects=subjects,
    )
