"""The population layer on simulated cohorts: coverage, pooling's narrowing, SBC, time (issue 33).

For cohorts of 10, 20 and 40 subjects (each ``STUDIES`` cohorts, hyperparameters drawn from the
SBC hyperprior of :mod:`inertiafit.validation.population`, subjects from them, each subject's
``I`` and ``M_g`` measured to 2 % and its posterior drawn exactly under a lognormal prior
around a table value 15 % high): the population is fitted and

- the regression coefficients' 95 % HDIs (intercepts, slopes, scatters) cover the truth in
  this fraction of cohorts;
- ten held-out subjects per cohort (not in the fit): their true ``I`` and ``M_g`` in the
  population's 95 % predictive interval for their covariates;
- pooling narrows each subject's ``m``, ``x``, ``rho`` by this median ratio of 95 % HDI widths
  (pooled over own: below 1 narrower; the own posterior leans on its +-0.3 prior in log).

Then an SBC of the population layer (``SBC_COHORTS`` cohorts of five subjects, ranks of every
hyperparameter among 19 draws, chi-square of five bins) with its negative control (pooling
that does not divide out the subjects' priors), and the pooling step's time for 100 subjects
against 10 (the ratio measured in the same run).

Run:  .venv/bin/python benchmarks/population.py [--quick] [--json FILE]
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
from common import standalone, table

SIZES = (10, 20, 40)
STUDIES = 24
HELD_OUT = 10
SBC_COHORTS = 40


def _hdi(x: np.ndarray, prob: float = 0.95) -> tuple[float, float]:
    from arviz_stats import hdi

    lo, hi = (float(v) for v in hdi(np.asarray(x).ravel(), prob=prob))
    return lo, hi


def _cohort_run(n: int, seed: int) -> dict:
    from inertiafit.errors import ConvergenceWarning
    from inertiafit.inference import population as P
    from inertiafit.inference.pooling import fit_population
    from inertiafit.physics import GRAVITY, PARAMETERS
    from inertiafit.validation import population as V

    hyper = V.SBC_HYPERPRIOR
    center = np.log([V.TYPICAL[p] for p in PARAMETERS])
    rng = np.random.default_rng([seed, n])
    cohort = V.simulate_cohort(
        n + HELD_OUT, hyperprior=hyper, center=center, rng=rng, n_draws=3000
    )
    fitted = cohort.subjects[:n]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        fit = fit_population(fitted, cohort.design, hyperprior=hyper, center=center, seed=seed)
    post = P.natural_terms(cohort.design, fit.flat)
    true = P.natural_terms(cohort.design, cohort.truth[None])
    covered = {}
    for key, draws in post.items():
        if key[1].startswith("correlation"):
            continue
        lo, hi = _hdi(draws)
        covered[key] = lo <= true[key][0] <= hi
    held = []
    for i in range(n, n + HELD_OUT):
        draws = P.predictive_draws(cohort.design, fit.flat, cohort.covariates[i], rng)
        m, x, r = np.exp(cohort.theta[i])
        truth = {"inertia": m * (r * r + x * x), "gravity_moment": m * GRAVITY * x}
        for q, v in truth.items():
            lo, hi = _hdi(draws[q])
            held.append((q, lo <= v <= hi))
    ratios = {p: [] for p in PARAMETERS}
    for i, subject in enumerate(fitted):
        for k, p in enumerate(PARAMETERS):
            olo, ohi = _hdi(np.exp(subject.log_theta[:, k]))
            plo, phi = _hdi(np.exp(fit.pooled[i][:, k]))
            ratios[p].append((phi - plo) / (ohi - olo))
    return {
        "covered": covered,
        "held": held,
        "ratios": {p: float(np.median(v)) for p, v in ratios.items()},
        "variance": fit.diagnostics["loglike_variance"],
    }


def _time_pooling(n: int, seed: int) -> tuple[float, int]:
    from inertiafit.errors import ConvergenceWarning
    from inertiafit.inference.pooling import fit_population
    from inertiafit.physics import PARAMETERS
    from inertiafit.validation import population as V

    hyper = V.SBC_HYPERPRIOR
    center = np.log([V.TYPICAL[p] for p in PARAMETERS])
    cohort = V.simulate_cohort(
        n, hyperprior=hyper, center=center, rng=np.random.default_rng(seed), n_draws=5000
    )
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        fit = fit_population(
            cohort.subjects, cohort.design, hyperprior=hyper, center=center, seed=1
        )
    return time.perf_counter() - t0, fit.n_draws


def run(*, quick: bool = False, seed: int = 33) -> dict:
    from scipy import stats

    from inertiafit.validation import population as V

    studies = 3 if quick else STUDIES
    sizes = SIZES[:2] if quick else SIZES
    rows = []
    from inertiafit.errors import InputError

    for n in sizes:
        results, refused = [], 0
        for k in range(studies):
            try:
                results.append(_cohort_run(n, seed + k))
            except InputError:  # a subject whose draws cannot be reweighted: said, counted
                refused += 1
        coef = [c for r in results for c in r["covered"].values()]
        held = {
            q: [ok for r in results for qq, ok in r["held"] if qq == q]
            for q in ("inertia", "gravity_moment")
        }
        rows.append(
            {
                "subjects": str(n),
                "refused": refused,
                "coefficients": float(np.mean(coef)),
                "held_I": float(np.mean(held["inertia"])),
                "held_Mg": float(np.mean(held["gravity_moment"])),
                "narrow_m": float(np.median([r["ratios"]["mass"] for r in results])),
                "narrow_x": float(np.median([r["ratios"]["com_distance"] for r in results])),
                "narrow_rho": float(
                    np.median([r["ratios"]["radius_of_gyration"] for r in results])
                ),
                "variance": float(np.max([r["variance"] for r in results])),
            }
        )
    cols = [
        ("subjects", "subjects", ""),
        ("refused", "refused", "d"),
        ("coefficients", "coef. covered", ".2f"),
        ("held_I", "held-out I", ".2f"),
        ("held_Mg", "held-out M_g", ".2f"),
        ("narrow_m", "width m", ".2f"),
        ("narrow_x", "width x", ".2f"),
        ("narrow_rho", "width rho", ".2f"),
        ("variance", "max var log L", ".3f"),
    ]
    n_sbc = 12 if quick else SBC_COHORTS
    ranks = V.population_sbc(
        n_sbc, n_subjects=5, seed=seed, n_keep=19, n_draws=3000, chunk=100, max_steps=600
    )
    pooled = np.concatenate(list(ranks.values()))
    counts = np.bincount(pooled // 4, minlength=5)
    p_good = float(stats.chisquare(counts).pvalue)
    bad = V.population_sbc(
        max(n_sbc // 3, 6),
        n_subjects=5,
        seed=seed + 1,
        n_keep=19,
        n_draws=3000,
        chunk=100,
        max_steps=600,
        ignore_interim=True,
        prior_bias=(1.5, 1 / 1.5, 1.0),
        prior_sd_log=0.15,
    )
    bad_counts = np.bincount(np.concatenate(list(bad.values())) // 4, minlength=5)
    p_bad = float(stats.chisquare(bad_counts).pvalue)
    t10, d10 = _time_pooling(10, seed)
    t100, d100 = _time_pooling(100, seed)
    text = "\n".join(
        [
            "== The population layer on simulated cohorts (benchmarks/population.py)",
            table(cols, rows),
            (
                f"{studies} cohorts per size, {HELD_OUT} held-out subjects each; coverage of "
                "95 % HDIs (intercepts, slopes, scatters); width = pooled / own 95 % HDI "
                "(median over subjects and cohorts)"
            ),
            (
                f"SBC: {n_sbc} cohorts of 5, ranks in five bins {counts.tolist()} "
                f"(chi-square p = {p_good:.3g}, outer fifth "
                f"{np.mean(np.isin(pooled, [0, 1, 18, 19])):.2f}); negative control (priors not "
                f"divided out) {bad_counts.tolist()} (p = {p_bad:.2g})"
            ),
            (
                f"pooling time: 10 subjects {t10:.1f} s ({d10} draws each), 100 subjects "
                f"{t100:.1f} s ({d100} draws each; ratio {t100 / t10:.1f}x; 5000 draws per "
                "subject stored, every one read through the cells)"
            ),
        ]
    )
    return {
        "rows": rows,
        "sbc_counts": counts.tolist(),
        "sbc_p": p_good,
        "negative_counts": bad_counts.tolist(),
        "negative_p": p_bad,
        "seconds_10": t10,
        "seconds_100": t100,
        "table": text,
    }


def main() -> None:
    standalone(run, __doc__ or "", seed=33, quick_help="3 cohorts per size, sizes 10 and 20")


if __name__ == "__main__":
    sys.exit(main())
