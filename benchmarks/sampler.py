"""Sampler efficiency: inertiafit's sampler against plain emcee on the same posteriors.

Plain emcee is what a researcher would write first: 32 walkers, the default stretch move,
sampling (m, x, rho) directly with the same likelihood and the uniform box prior. Both are
judged by the integrated autocorrelation time tau (steps), the minimum bulk ESS per second of
wall time over the five reported quantities, and their error against the quadrature reference.

Run:  .venv/bin/python benchmarks/sampler.py [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import time

import emcee
import numpy as np
from arviz_stats import ess

from inertiafit.inference import fit
from inertiafit.model import Condition, Model
from inertiafit.observations import Observation
from inertiafit.priors import Prior, load_prior
from inertiafit.reference import reference_posterior
from inertiafit.sampler import SamplerSettings

QUANTITIES = ("mass", "com_distance", "radius_of_gyration", "inertia", "gravity_moment")
G = 9.81


def cases():
    return {
        "attachment": (
            load_prior("biodex-elbow-attachment"),
            Observation.from_mean_sd(0.216, 0.017, 30),
            Observation.from_mean_se(7.415, 0.05),
        ),
        "disk": (
            load_prior("disk-3kg"),
            Observation.from_mean_se(0.594, 0.0105),
            Observation.from_mean_se(12.80, 0.05),
        ),
        "wide-box": (
            Prior.box("wide", mass=2.91, com_distance=0.225, radius_of_gyration=0.13, spread=0.8),
            Observation.from_mean_sd(0.216, 0.017, 10),
            Observation.from_mean_se(7.415, 0.15),
        ),
    }


def plain_emcee(prior, obs_i, obs_g, seed, n_steps):
    """Default stretch move on (m, x, rho), 32 walkers, started in a ball at the nominal."""
    lo, hi = prior.bounds[:, 0], prior.bounds[:, 1]

    def log_prob(p):
        m, x, rho = p[:, 0], p[:, 1], p[:, 2]
        inside = np.all((p >= lo) & (p <= hi), axis=1)
        lp = obs_i.logpdf(m * (rho**2 + x**2)) + obs_g.logpdf(G * m * x)
        return np.where(inside, lp, -np.inf)

    rng = np.random.default_rng(seed)
    # Start where the likelihood is: rejection from the box until 32 points within 3 SE.
    pts = np.empty((0, 3))
    while len(pts) < 32:
        d = prior.sample(200_000, rng)
        cand = np.column_stack([d["mass"], d["com_distance"], d["radius_of_gyration"]])
        lp = log_prob(cand)
        pts = np.vstack([pts, cand[lp > lp.max() - 9]])
    sampler = emcee.EnsembleSampler(32, 3, log_prob, vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    t0 = time.perf_counter()
    sampler.run_mcmc(pts[:32], n_steps)
    seconds = time.perf_counter() - t0
    chain = sampler.get_chain()
    tau = float(np.max(emcee.autocorr.integrated_time(chain, quiet=True, tol=0)))
    kept = np.swapaxes(chain[int(5 * tau) :], 0, 1)
    m, x, rho = kept[..., 0], kept[..., 1], kept[..., 2]
    draws = {
        "mass": m,
        "com_distance": x,
        "radius_of_gyration": rho,
        "inertia": m * (rho**2 + x**2),
        "gravity_moment": G * m * x,
    }
    return draws, tau, seconds


def accuracy(draws, ref):
    return (
        max(abs(draws[q].mean() - ref.mean(q)) / ref.sd(q) for q in QUANTITIES),
        max(abs(draws[q].std() / ref.sd(q) - 1) for q in QUANTITIES),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="also write the results as JSON to this file")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rows = []
    for name, (prior, obs_i, obs_g) in cases().items():
        ref = reference_posterior(prior, obs_i, obs_g)
        model = Model({name: prior}, [Condition((name,), obs_i, obs_g)])
        fit(model, seed=args.seed + 100)  # warm-up: imports and caches out of the timing
        t0 = time.perf_counter()
        post = fit(model, seed=args.seed, settings=SamplerSettings(progress=False))
        ours_s = time.perf_counter() - t0
        ours = {q: post.draws(name, q) for q in QUANTITIES}
        ours_ess = min(float(ess(v, method="bulk")) for v in ours.values())
        plain, plain_tau, plain_s = plain_emcee(prior, obs_i, obs_g, args.seed, 20_000)
        plain_ess = min(float(ess(v, method="bulk")) for v in plain.values())
        row = {
            "posterior": name,
            "inertiafit_tau": float(post.attrs["tau_max"]),
            "inertiafit_ess_per_s": ours_ess / ours_s,
            "inertiafit_seconds": ours_s,
            "inertiafit_mean_err_sd": accuracy(ours, ref)[0],
            "inertiafit_sd_err": accuracy(ours, ref)[1],
            "plain_tau": plain_tau,
            "plain_ess_per_s": plain_ess / plain_s,
            "plain_seconds": plain_s,
            "plain_mean_err_sd": accuracy(plain, ref)[0],
            "plain_sd_err": accuracy(plain, ref)[1],
        }
        row["ess_per_s_ratio"] = row["inertiafit_ess_per_s"] / row["plain_ess_per_s"]
        row["tau_ratio"] = row["plain_tau"] / row["inertiafit_tau"]
        rows.append(row)
    head = (
        f"{'posterior':<12}{'tau ours':>9}{'tau plain':>10}{'ESS/s ours':>12}"
        f"{'ESS/s plain':>12}{'ratio':>8}{'err ours':>10}{'err plain':>10}"
    )
    print(head)
    for r in rows:
        print(
            f"{r['posterior']:<12}{r['inertiafit_tau']:>9.2f}{r['plain_tau']:>10.1f}"
            f"{r['inertiafit_ess_per_s']:>12.0f}{r['plain_ess_per_s']:>12.0f}"
            f"{r['ess_per_s_ratio']:>7.1f}x{r['inertiafit_mean_err_sd']:>10.3f}"
            f"{r['plain_mean_err_sd']:>10.3f}"
        )
    print("(err: largest |posterior mean - quadrature mean| over the five quantities, in SDs)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=2)


if __name__ == "__main__":
    main()
