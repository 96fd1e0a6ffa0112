"""Peer: PyMC's NUTS on the same model and posteriors as benchmarks/sampler.py.

The model a PyMC user would write: uniform box priors on (m, x, rho), I = m (rho^2 + x^2) and
M_g = g m x, and the likelihood of ``inertiafit.inference.observations.Observation`` (a Student-t with
``n - 1`` degrees of freedom and scale SE for repeated trials, a Gaussian for a value with its
SE) on each. PyMC's defaults (4 chains, 1000 tuning + 1000 draws, target_accept 0.8), run one
chain after another on one core (``cores=1``) as inertiafit's sampler does. Judged by the
minimum bulk ESS per second of the whole ``pm.sample`` call (tuning included, compilation
warmed up by a first call) and the error against the quadrature reference.

PyMC is optional: without it this prints a message and exits 0. To run it from another venv
that has PyMC and inertiafit:  /path/to/venv/bin/python benchmarks/peer_pymc.py [--json FILE]
"""

from __future__ import annotations

import time

import numpy as np
from common import QUANTITIES, accuracy, standalone, table

G = 9.81


def available() -> bool:
    try:
        import pymc  # noqa: F401
    except ImportError:
        return False
    return True


def _likelihood(pm, name, obs, mu):
    if obs.is_gaussian:
        return pm.Normal(name, mu=mu, sigma=obs.scale, observed=obs.center)
    return pm.StudentT(name, nu=obs.df, mu=mu, sigma=obs.scale, observed=obs.center)


def nuts(prior, obs_i, obs_g, *, seed: int, draws: int, tune: int, chains: int):
    import pymc as pm

    lo, hi = prior.bounds[:, 0], prior.bounds[:, 1]  # order: mass, com_distance, rho
    with pm.Model():
        m = pm.Uniform("mass", lo[0], hi[0])
        x = pm.Uniform("com_distance", lo[1], hi[1])
        rho = pm.Uniform("radius_of_gyration", lo[2], hi[2])
        inertia = pm.Deterministic("inertia", m * (rho**2 + x**2))
        gm = pm.Deterministic("gravity_moment", G * m * x)
        _likelihood(pm, "inertia_obs", obs_i, inertia)
        _likelihood(pm, "gravity_moment_obs", obs_g, gm)
        t0 = time.perf_counter()
        idata = pm.sample(
            draws=draws,
            tune=tune,
            chains=chains,
            cores=1,
            random_seed=seed,
            progressbar=False,
            compute_convergence_checks=False,
        )
        seconds = time.perf_counter() - t0
    post = idata["posterior"]
    out = {q: np.asarray(post[q].values) for q in QUANTITIES}
    stats = idata["sample_stats"]
    diverging = int(np.asarray(stats["diverging"].values).sum())
    n_grad = float(np.asarray(stats["n_steps"].values).mean())
    return out, seconds, diverging, n_grad


def run(*, quick: bool = False, seed: int = 1) -> dict:
    import logging

    from arviz_stats import ess
    from sampler import cases

    from inertiafit.inference.reference import reference_posterior

    if not available():
        return {
            "name": "peer_pymc",
            "title": "2. Peer: PyMC NUTS",
            "skipped": "PyMC is not importable here (pip install 'pymc>=5'); peer skipped",
            "rows": [],
            "table": "skipped: PyMC is not importable (pip install 'pymc>=5')",
            "targets": [],
        }
    import pymc

    logging.getLogger("pymc").setLevel(logging.ERROR)
    draws, tune = (500, 500) if quick else (1000, 1000)
    chains = 4
    rows = []
    for name, (prior, obs_i, obs_g) in cases().items():
        ref = reference_posterior(prior, obs_i, obs_g)
        # Warm-up: PyTensor compiles the model's C code on first use; cache it out of the timing.
        nuts(prior, obs_i, obs_g, seed=seed + 100, draws=50, tune=50, chains=1)
        out, seconds, diverging, n_grad = nuts(
            prior, obs_i, obs_g, seed=seed, draws=draws, tune=tune, chains=chains
        )
        min_ess = min(float(ess(v, method="bulk")) for v in out.values())
        err, sd_err = accuracy(out, ref)
        rows.append(
            {
                "posterior": name,
                "pymc_version": pymc.__version__,
                "chains": chains,
                "draws": draws,
                "tune": tune,
                "seconds": seconds,
                "min_ess_bulk": min_ess,
                "ess_per_s": min_ess / seconds,
                "draws_per_ess": chains * draws / min_ess,
                "divergences": diverging,
                "leapfrog_steps_mean": n_grad,
                "mean_err_sd": err,
                "sd_err": sd_err,
            }
        )
    text = table(
        [
            ("posterior", "posterior", ""),
            ("seconds", "wall (s)", ".2f"),
            ("min_ess_bulk", "min bulk ESS", ".0f"),
            ("ess_per_s", "ESS/s", ".0f"),
            ("draws_per_ess", "draws/ESS", ".2f"),
            ("leapfrog_steps_mean", "leapfrog/draw", ".1f"),
            ("divergences", "divergences", "d"),
            ("mean_err_sd", "mean err (SD)", ".3f"),
            ("sd_err", "|SD ratio-1|", ".3f"),
        ],
        rows,
    )
    text += (
        f"\nPyMC {pymc.__version__} NUTS, {chains} chains x ({tune} tune + {draws} draws), "
        "cores=1; wall = the whole pm.sample call (tuning included, compilation warmed up)."
    )
    return {
        "name": "peer_pymc",
        "title": "2. Peer: PyMC NUTS on (m, x, rho)",
        "rows": rows,
        "table": text,
        "targets": [],
    }


def main() -> None:
    standalone(run, __doc__, seed=1, quick_help="500 tuning + 500 draws")


if __name__ == "__main__":
    main()
