"""Sampler efficiency: inertiafit's sampler against plain emcee on the same posteriors.

Plain emcee is what a researcher would write first: 32 walkers, the default stretch move,
sampling (m, x, rho) directly with the same likelihood and the uniform box prior. Both are
judged by the integrated autocorrelation time tau (steps), the minimum bulk ESS per second of
wall time over the five reported quantities, and their error against the quadrature reference.
The limit row of each posterior is independent draws (tau = 1): as many exact draws from the
quadrature reference as inertiafit kept, with ESS = number of draws in inertiafit's wall time;
its error is the Monte Carlo noise floor of the error columns.

Robust to a busy machine: five rounds per posterior, inertiafit and plain emcee in turn (round
k seeds both with seed + k); the ratio is the median of the rounds' ESS/s ratios, printed with
its smallest and largest and with the same ratio in CPU seconds. Guards: that median at least
5x on every posterior and inertiafit's median tau at most 3 steps (PASS/FAIL; ``run.py`` exits
with status 3 when a guard fails).

Run:  .venv/bin/python benchmarks/sampler.py [--quick] [--json FILE]
"""

from __future__ import annotations

import time

import emcee
import numpy as np
from arviz_stats import ess
from common import (
    QUANTITIES,
    accuracy,
    guard,
    interleaved,
    load_text,
    median,
    paired_ratios,
    spread,
    spread_text,
    standalone,
    table,
)

from inertiafit.inference.fit import fit
from inertiafit.inference.model import Condition, Model
from inertiafit.inference.observations import Observation
from inertiafit.inference.priors import Prior, load_prior, parse_prior
from inertiafit.inference.reference import reference_posterior
from inertiafit.inference.sampler import SamplerSettings
from inertiafit.physics import inertia

G = 9.81


def shaped(kind: str) -> Prior:
    """The attachment's nominal values, every parameter of one distribution (docs/priors.md)."""
    nominal = {"mass": 2.91, "com_distance": 0.225, "radius_of_gyration": 0.13}
    table = {}
    for p, v in nominal.items():
        table[p] = {
            "normal": {"distribution": "normal", "mean": v, "sd": 0.1 * v},
            "lognormal": {"distribution": "lognormal", "median": v, "sd_log": 0.12},
            "truncated-normal": {
                "distribution": "truncated-normal",
                "mean": v,
                "sd": 0.2 * v,
                "lower": 0.75 * v,
                "upper": 1.3 * v,
            },
        }[kind]
    return parse_prior(table, name=kind, where=kind)


def cases():
    """The posteriors: the paper's attachment, its disk, a wide box with few trials, the
    attachment's evidence under a normal, a lognormal and a truncated-normal prior, and with
    each piece of extra information."""
    attachment = (
        Observation.from_mean_sd(0.216, 0.017, 30),
        Observation.from_mean_se(7.415, 0.05),
    )
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
        **{f"attachment, {kind} prior": (shaped(kind), *attachment) for kind in KINDS},
        **{
            f"attachment, {what}": (load_prior("biodex-elbow-attachment"), *attachment, extra)
            for what, extra in EXTRA.items()
        },
    }


#: Extra information on the attachment (docs/method.md): its reference keywords. Its
#: evidence gives a = M_g / g = 0.7559 kg m and I = 0.216 kg m^2; the extra information
#: points at m = 3.5 kg (x = 0.216 m, rho = 0.123 m, inside the box). The second mounting
#: moves it 0.1 m out: a(d) = 1.1059 kg m, I(d) = I + 2 a d + m d^2 = 0.4022 kg m^2.
EXTRA = {
    "weighed mass": {"mass": Observation.from_mean_se(3.5, 0.01)},
    "balance point": {"com_distance": Observation.from_mean_se(0.216, 0.002)},
    "second mounting": {
        "offset": 0.1,
        "offset_inertia": Observation.from_mean_sd(0.4022, 0.017, 30),
        "offset_gravity_moment": Observation.from_mean_se(G * 1.1059, 0.05),
    },
}


def model_of(name: str, prior, obs_i, obs_g, extra: dict) -> Model:
    """One body measured once, with its extra information (a weighed mass, a balance point,
    a second mounting)."""
    conditions = [Condition((name,), obs_i, obs_g)]
    if "offset" in extra:
        conditions.append(
            Condition(
                (name,),
                extra["offset_inertia"],
                extra["offset_gravity_moment"],
                label="moved",
                offset_body=name,
                offset=extra["offset"],
            )
        )
    measured = {k: v for k, v in extra.items() if k in ("mass", "com_distance")}
    return Model({name: prior}, conditions, measured={name: measured} if measured else None)


KINDS = ("normal", "lognormal", "truncated-normal")


def derived(m, x, rho) -> dict:
    return {
        "mass": m,
        "com_distance": x,
        "radius_of_gyration": rho,
        "inertia": inertia(m, rho, x),
        "gravity_moment": G * m * x,
    }


def plain_emcee(prior, obs_i, obs_g, seed, n_steps, extra=None):
    """Default stretch move on (m, x, rho), 32 walkers, started where the likelihood is.

    Returns the draws of the five quantities, tau, and the wall and CPU seconds of run_mcmc.
    """
    lo, hi = prior.bounds[:, 0], prior.bounds[:, 1]
    extra = extra or {}

    def log_prob(p):
        m, x, rho = p[:, 0], p[:, 1], p[:, 2]
        inside = np.all((p >= lo) & (p <= hi), axis=1)
        lp = obs_i.logpdf(inertia(m, rho, x)) + obs_g.logpdf(G * m * x)
        if not prior.is_box:
            lp = lp + prior.log_density(m, x, rho, check_support=False)
        if "mass" in extra:
            lp = lp + extra["mass"].logpdf(m)
        if "com_distance" in extra:
            lp = lp + extra["com_distance"].logpdf(x)
        if "offset" in extra:
            d = extra["offset"]
            lp = lp + extra["offset_inertia"].logpdf(inertia(m, rho, x + d))
            lp = lp + extra["offset_gravity_moment"].logpdf(G * m * (x + d))
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
    t0, c0 = time.perf_counter(), time.process_time()
    sampler.run_mcmc(pts[:32], n_steps)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    chain = sampler.get_chain()
    tau = float(np.max(emcee.autocorr.integrated_time(chain, quiet=True, tol=0)))
    kept = np.swapaxes(chain[int(5 * tau) :], 0, 1)
    return derived(kept[..., 0], kept[..., 1], kept[..., 2]), tau, seconds, cpu


def independent_draws(ref, n: int, seed: int) -> dict:
    """``n`` exact independent draws from the quadrature reference (grid points by weight)."""
    idx = np.random.default_rng(seed).choice(ref.weights.size, size=n, p=ref.weights)
    return {q: ref.values[q][idx] for q in QUANTITIES}


def min_ess(draws: dict) -> float:
    # arviz-stats wants (chain, draw); independent draws are one chain.
    return min(float(ess(np.atleast_2d(v), method="bulk")) for v in draws.values())


#: Guards: every posterior's median ESS/s ratio over plain emcee at least this, and its
#: median tau at most TAU_GUARD steps; ROUNDS interleaved rounds (ours, plain, ours, ...).
RATIO_GUARD = 5.0
TAU_GUARD = 3.0
ROUNDS = 5


def run(*, quick: bool = False, seed: int = 1) -> dict:
    # 50 tau of plain emcee's slowest posterior (tau ~200) in full; the ratio does not depend
    # on the length beyond that but for the share of burn-in (5 tau) dropped.
    plain_steps = 5_000 if quick else 10_000
    rows = []
    warmed = False
    load_before = load_text()
    for name, (prior, obs_i, obs_g, *more) in cases().items():
        extra = more[0] if more else {}
        ref = reference_posterior(prior, obs_i, obs_g, **extra)
        model = model_of(name, prior, obs_i, obs_g, extra)
        if not (warmed and quick):
            fit(model, seed=seed + 100)  # warm-up: imports and caches out of the timing
            warmed = True

        def ours_run(k, model=model):
            c0 = time.process_time()
            post = fit(model, seed=seed + k, settings=SamplerSettings(progress=False))
            return post, time.process_time() - c0

        def plain_run(k, prior=prior, obs_i=obs_i, obs_g=obs_g, extra=extra):
            return plain_emcee(prior, obs_i, obs_g, seed + k, plain_steps, extra)

        # Round k: inertiafit and plain emcee, each with seed + k, one after the other, so a
        # busy moment of the shared machine hits both; each round's ratio is of two runs made
        # side by side, and the figure is the median of the rounds' ratios. Other seeds in
        # each round: the spread holds the ESS estimates' own noise too.
        timed = interleaved({"ours": ours_run, "plain": plain_run}, ROUNDS)
        ours_s = [t for t, _ in timed["ours"]]
        ours_cpu = [r[1] for _, r in timed["ours"]]
        posts = [r[0] for _, r in timed["ours"]]
        plains = [r for _, r in timed["plain"]]
        plain_s = [r[2] for r in plains]
        plain_cpu = [r[3] for r in plains]
        ours_draws = [{q: post.draws(name, q) for q in QUANTITIES} for post in posts]
        ours_ess = [min_ess(d) for d in ours_draws]
        plain_ess = [min_ess(r[0]) for r in plains]
        ours_rate = paired_ratios(ours_ess, ours_s)
        plain_rate = paired_ratios(plain_ess, plain_s)
        ratios = paired_ratios(ours_rate, plain_rate)
        cpu_ratios = paired_ratios(
            paired_ratios(ours_ess, ours_cpu), paired_ratios(plain_ess, plain_cpu)
        )
        n_draws = [d["mass"].size for d in ours_draws]
        limit_rate = paired_ratios(n_draws, ours_s)
        iid = independent_draws(ref, n_draws[0], seed)
        ratio = spread(ratios)
        row = {
            "posterior": name,
            "rounds": ROUNDS,
            "inertiafit_tau": median([float(post.attrs["tau_max"]) for post in posts]),
            "inertiafit_taus": [float(post.attrs["tau_max"]) for post in posts],
            "inertiafit_draws": median(n_draws),
            "inertiafit_ess": median(ours_ess),
            "inertiafit_seconds": median(ours_s),
            "inertiafit_seconds_all": ours_s,
            "inertiafit_ess_per_s": median(ours_rate),
            "inertiafit_ess_per_s_all": ours_rate,
            "inertiafit_mean_err_sd": max(accuracy(d, ref)[0] for d in ours_draws),
            "inertiafit_sd_err": max(accuracy(d, ref)[1] for d in ours_draws),
            "plain_steps": plain_steps,
            "plain_tau": median([r[1] for r in plains]),
            "plain_ess": median(plain_ess),
            "plain_seconds": median(plain_s),
            "plain_seconds_all": plain_s,
            "plain_ess_per_s": median(plain_rate),
            "plain_ess_per_s_all": plain_rate,
            "plain_mean_err_sd": max(accuracy(r[0], ref)[0] for r in plains),
            "plain_sd_err": max(accuracy(r[0], ref)[1] for r in plains),
            "limit_tau": 1.0,
            "limit_ess_per_s": median(limit_rate),
            "limit_mean_err_sd": accuracy(iid, ref)[0],
            "limit_sd_err": accuracy(iid, ref)[1],
            "ess_per_s_ratio": ratio["median"],
            "ess_per_s_ratio_low": ratio["low"],
            "ess_per_s_ratio_high": ratio["high"],
            "ess_per_s_ratios": ratios,
            "cpu_ratio": median(cpu_ratios),
            "cpu_ratios": cpu_ratios,
            "limit_ratio": median(paired_ratios(limit_rate, plain_rate)),
        }
        row["tau_ratio"] = row["plain_tau"] / row["inertiafit_tau"]
        row["ess_per_draw"] = row["inertiafit_ess"] / row["inertiafit_draws"]
        row["guard"] = (
            "PASS"
            if ratio["median"] >= RATIO_GUARD and row["inertiafit_tau"] <= TAU_GUARD
            else "FAIL"
        )
        rows.append(row)
    load_after = load_text()
    shown = []
    for r in rows:
        for who, label in (
            ("inertiafit", "inertiafit"),
            ("plain", "plain emcee"),
            ("limit", "limit"),
        ):
            shown.append(
                {
                    "posterior": r["posterior"] if who == "inertiafit" else "",
                    "sampler": label,
                    "tau": r[f"{who}_tau"],
                    "ess_s": r[f"{who}_ess_per_s"],
                    "ratio": {
                        "inertiafit": spread_text(
                            {
                                "median": r["ess_per_s_ratio"],
                                "low": r["ess_per_s_ratio_low"],
                                "high": r["ess_per_s_ratio_high"],
                            },
                            ".2f",
                        ),
                        "plain": "1",
                        "limit": f"{r['limit_ratio']:.1f}",
                    }[who],
                    "cpu": f"{r['cpu_ratio']:.1f}" if who == "inertiafit" else "",
                    "guard": r["guard"] if who == "inertiafit" else "",
                    "err": r[f"{who}_mean_err_sd"],
                    "sderr": r[f"{who}_sd_err"],
                }
            )
    text = table(
        [
            ("posterior", "posterior", ""),
            ("sampler", "sampler", ""),
            ("tau", "tau (steps)", ".2f"),
            ("ess_s", "min bulk ESS/s", ".0f"),
            ("ratio", "vs plain", ""),
            ("cpu", "(CPU)", ""),
            ("guard", f">= {RATIO_GUARD:g}x", ""),
            ("err", "mean err (SD)", ".3f"),
            ("sderr", "|SD ratio-1|", ".3f"),
        ],
        shown,
    )
    text += (
        f"\n{ROUNDS} rounds per posterior, inertiafit and plain emcee in turn (round k: seed "
        f"{seed} + k for both). tau, ESS/s: medians over the rounds; vs plain: the median of "
        "the rounds' ESS/s ratios (smallest-largest);\n(CPU): the same ratio in CPU seconds of "
        "this process (what another process's load changes least). mean err: largest |posterior "
        "mean - quadrature mean| over the five\nquantities, in posterior SDs, worst round; "
        "|SD ratio-1|: largest relative error of the posterior SD, worst round. limit: exact "
        "independent draws,\nas many as inertiafit kept, ESS/s = draws / inertiafit's wall "
        f"time. plain emcee: {plain_steps} steps, first 5 tau dropped, its run_mcmc timed; "
        "inertiafit: the whole fit.\n"
        f"load average before {load_before}, after {load_after}."
    )
    worst = min(rows, key=lambda r: r["ess_per_s_ratio"])
    slowest = max(rows, key=lambda r: r["inertiafit_tau"])
    return {
        "name": "sampler",
        "title": "1. Sampler efficiency: inertiafit vs plain emcee (stretch, 32 walkers, (m, x, rho))",
        "rows": rows,
        "load_before": load_before,
        "load_after": load_after,
        "table": text,
        "targets": [
            guard(
                f"inertiafit ESS/s >= {RATIO_GUARD:g}x plain emcee on every posterior "
                f"(median of {ROUNDS} interleaved rounds)",
                worst["ess_per_s_ratio"],
                RATIO_GUARD,
                below=False,
                shown=f"worst {worst['ess_per_s_ratio']:.2f}x ({worst['posterior']}; rounds "
                f"{worst['ess_per_s_ratio_low']:.2f}-{worst['ess_per_s_ratio_high']:.2f}x)",
            ),
            guard(
                f"inertiafit tau <= {TAU_GUARD:g} steps on every posterior (median)",
                slowest["inertiafit_tau"],
                TAU_GUARD,
                below=True,
                shown=f"largest {slowest['inertiafit_tau']:.2f} ({slowest['posterior']})",
            ),
            {
                "target": "means within 0.1 SD of the quadrature reference (every round)",
                "value": f"worst {max(r['inertiafit_mean_err_sd'] for r in rows):.3f} SD",
                "status": "met"
                if max(r["inertiafit_mean_err_sd"] for r in rows) < 0.1
                else "NOT met",
            },
        ],
    }


def main() -> None:
    standalone(run, __doc__, seed=1, quick_help="shorter plain-emcee chains")


if __name__ == "__main__":
    main()
