"""Coverage of the whole pipeline: do the 95 % HDIs hold the truth in 95 % of studies?

Simulation-based calibration (``benchmarks/sbc.py``) checks the posterior against data drawn
from the model's own likelihood. This benchmark checks everything in front of it too: trial
files simulated from physics with the imperfections of real recordings, read, filtered,
windowed, lag-corrected, gravity-corrected and fitted by ``process_study`` and the study
model, exactly as ``inertiafit run`` does.

Each simulated study: an attachment and a forearm-like segment (the issue's design: the
attachment alone and attachment + segment, 3 speeds x 10 fast trials per condition, 1 kHz),
nominal values drawn at random, a ±50 % box around each, the truth drawn uniformly from the box;
one channel lag per study drawn uniformly from 0-5 ms (the torque behind the velocity), a servo
ripple in the fast trials (0.2 of the ramp's acceleration at 15 Hz), and a torque gain error drawn from the
declared calibration (``[calibration] torque_gain_sd = 0.01``: the gain is N(1, 0.01)).
Noise levels set the trial-to-trial scatter of the attachment's inertia to 0.3 %, 1 %, 3 % and
8 % (white torque noise for up to half the variance, a per-trial torque shift for the rest;
the printed ``scatter`` is the median relative SD of a condition's fast trials, measured).

Printed per noise level and quantity: the share of studies whose 95 % HDI holds the truth (the
issue's target: 90-99 %), its binomial 95 % interval, the same share for the posterior without
any systematic-error term (``none``: no coupling or shared gravity error, no gain) and for the
one with the gravity terms but no gain (``no gain``), the mean HDI width relative to ``none``
for the full posterior and for ``no gain``, the mean HDI width relative to the truth,
and the share of conditions whose per-speed means differ (one-way ANOVA p < 0.05; 5 % when the
speeds share one inertia: the evidence for or against a speed-to-speed random effect). The
quantities are each condition's ``I`` and ``M_g`` and each body's ``I`` and ``M_g``; ``m``,
``x`` and ``rho`` are not identified by one rotation axis with a box prior and are not listed.

Run:  .venv/bin/python benchmarks/coverage.py [--quick] [--studies N] [--levels 1%,3%]
      [--seed S] [--json FILE]
      (full: 40 studies per level, 4 levels; about 25 minutes on 2 cores; --quick: 12)
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from common import hdi, standalone, table

#: The levels: target relative SD of the attachment's per-trial inertia.
LEVELS = {"0.3%": 0.003, "1%": 0.01, "3%": 0.03, "8%": 0.08}
#: Per-trial inertia SD (kg m^2) per N m of white torque noise (default drift and filter),
#: measured on simulated trials (``Noise.paper``'s docstring: 0.0015 at 0.4 N m).
CHANNEL_SCATTER = 0.0015 / 0.4
#: The ramp's acceleration (rad/s^2): a per-trial torque shift ``d`` moves ``I`` by ``d / ALPHA``.
ALPHA = math.radians(2000.0)
GAIN_SD = 0.01
MAX_LAG = 0.005
HDI = 0.95


def _box_draw(rng, nominal):
    """A truth uniform in the ±50 % box around ``nominal`` (mass, rho, x)."""
    return tuple(v * rng.uniform(0.5, 1.5) for v in nominal)


def level_noise(fraction: float, inertia: float) -> dict[str, float]:
    """``Noise`` settings that give the attachment a per-trial scatter of ``fraction``.

    The white torque noise (and the drift with it) contributes at most half the variance; a
    per-trial torque shift makes up the rest.
    """
    target = fraction * inertia
    torque_sd = min(0.4, math.sqrt(0.5) * target / CHANNEL_SCATTER)
    channel = CHANNEL_SCATTER * torque_sd
    return {
        "torque_sd": torque_sd,
        "drift_sd": 0.03 * torque_sd / 0.4,
        "trial_offset_sd": ALPHA * math.sqrt(max(target**2 - channel**2, 0.0)),
    }


def one_study(level: str, seed: int) -> dict:
    """Simulate, process and fit one study; the truth's place in every HDI."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from scipy import stats

    from inertiafit.inference.evidence import study_model
    from inertiafit.inference.fit import fit
    from inertiafit.inference.model import Condition, Model
    from inertiafit.inference.sampler import SamplerSettings
    from inertiafit.processing.study import process_study
    from inertiafit.simulate import Noise, simulate_study

    rng = np.random.default_rng([seed, 7])
    nominal = {
        "attachment": (2.91 * rng.uniform(0.8, 1.2), 0.13 * rng.uniform(0.8, 1.2), 0.225),
        "segment": (1.6 * rng.uniform(0.7, 1.3), 0.16 * rng.uniform(0.8, 1.2), 0.08),
    }
    truth = {b: _box_draw(rng, v) for b, v in nominal.items()}
    lag = float(rng.uniform(0.0, MAX_LAG))
    gain = float(np.exp(GAIN_SD * rng.standard_normal()))
    from inertiafit.physics import inertia as inertia_of

    i_att = float(inertia_of(*truth["attachment"]))
    noise = Noise(servo_ripple=0.2, lag=lag, torque_gain=gain, **level_noise(LEVELS[level], i_att))
    priors = {
        b: {"mass": v[0], "radius_of_gyration": v[1], "com_distance": v[2]}
        for b, v in nominal.items()
    }
    settings = SamplerSettings(progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        manifest = simulate_study(
            tmp,
            bodies=truth,
            conditions=[("attachment",), ("attachment", "segment")],
            seed=int(rng.integers(2**31)),
            noise=noise,
            quasi_static_noise=dataclasses.replace(noise, servo_ripple=0.0),
            priors=priors,
            phi=float(rng.uniform(-0.3, 0.3)),
            offset=float(rng.normal(0, 1)),
        )
        with open(manifest, "a", encoding="utf-8") as fh:
            fh.write(f"\n[calibration]\ntorque_gain_sd = {GAIN_SD}\n")
        processed = process_study(manifest)
        model = study_model(processed)
        post = fit(model, seed=seed, settings=settings)
        plain = Model(
            model.priors,
            [
                Condition(c.bodies, c.inertia.with_shared_error(0.0), c.gravity_moment, c.label)
                for c in model.conditions
            ],
            gravity=model.gravity,
        )
        plain_post = fit(plain, seed=seed, settings=settings)
        no_gain = Model(model.priors, model.conditions, gravity=model.gravity)
        no_gain_post = fit(no_gain, seed=seed, settings=settings)

    from inertiafit.physics import gravity_moment, inertia

    true_q = {}
    for b, (m, rho, x) in truth.items():
        true_q[f"{b} I"] = float(inertia(m, rho, x))
        true_q[f"{b} M_g"] = float(gravity_moment(m, x, model.gravity))
    true_q["A: I"] = true_q["attachment I"]
    true_q["A: M_g"] = true_q["attachment M_g"]
    true_q["A+S: I"] = true_q["attachment I"] + true_q["segment I"]
    true_q["A+S: M_g"] = true_q["attachment M_g"] + true_q["segment M_g"]

    def quantities(p) -> dict[str, np.ndarray]:
        out = {}
        for b in ("attachment", "segment"):
            out[f"{b} I"] = p.draws(b, "inertia")
            out[f"{b} M_g"] = p.draws(b, "gravity_moment")
        out["A: I"] = out["attachment I"]
        out["A: M_g"] = out["attachment M_g"]
        out["A+S: I"] = out["attachment I"] + out["segment I"]
        out["A+S: M_g"] = out["attachment M_g"] + out["segment M_g"]
        return out

    q_post, q_plain, q_gravity = quantities(post), quantities(plain_post), quantities(no_gain_post)
    rows = {}
    for name, draws in q_post.items():
        lo, hi = hdi(draws, HDI)
        plo, phi_ = hdi(q_plain[name], HDI)
        glo, ghi = hdi(q_gravity[name], HDI)
        rows[name] = {
            "inside": lo <= true_q[name] <= hi,
            "plain_inside": plo <= true_q[name] <= phi_,
            "gravity_inside": glo <= true_q[name] <= ghi,
            "width_ratio": (hi - lo) / (phi_ - plo),
            "gravity_width_ratio": (ghi - glo) / (phi_ - plo),
            "rel_width": (hi - lo) / true_q[name],
        }
    fast = processed.trials[processed.trials["kind"] == "fast"]
    scatter, anova = [], []
    for _, rows_c in fast.groupby("condition"):
        scatter.append(float(rows_c["inertia"].std(ddof=1) / rows_c["inertia"].mean()))
        groups = [g["inertia"].to_numpy() for _, g in rows_c.groupby("speed")]
        anova.append(float(stats.f_oneway(*groups).pvalue))
    lags = fast["lag"].to_numpy() if "lag" in fast else np.array([np.nan])
    return {
        "level": level,
        "seed": seed,
        "rows": rows,
        "scatter": scatter,
        "anova_p": anova,
        "lag_error_ms": float(1e3 * (np.median(lags) - lag)),
        "lag_ms": 1e3 * lag,
        "converged": bool(post.converged and plain_post.converged and no_gain_post.converged),
    }


def _binom_interval(k: int, n: int) -> tuple[float, float]:
    from scipy import stats

    ci = stats.binomtest(k, n).proportion_ci(0.95)
    return float(ci.low), float(ci.high)


def run(
    *, quick: bool = False, seed: int = 2026, studies: int | None = None, levels: str | None = None
) -> dict:
    n = studies or (12 if quick else 40)
    chosen = [name.strip() for name in levels.split(",")] if levels else list(LEVELS)
    unknown = [name for name in chosen if name not in LEVELS]
    if unknown:
        raise SystemExit(f"--levels: unknown level {unknown[0]!r} (expected {', '.join(LEVELS)})")
    t0 = time.perf_counter()
    # every level its own studies: the truths and gain draws of one level tell nothing of another
    jobs = [
        (level, seed * 1000 + 100 * k + i)
        for k, level in enumerate(LEVELS)
        if level in chosen
        for i in range(n)
    ]
    workers = max(1, min(2, os.cpu_count() or 1))
    with ProcessPoolExecutor(workers) as pool:
        results = list(pool.map(one_study, *zip(*jobs, strict=True)))
    table_rows, targets = [], []
    for level in chosen:
        res = [r for r in results if r["level"] == level]
        scatter = float(np.median([s for r in res for s in r["scatter"]]))
        speed = float(np.mean([p < 0.05 for r in res for p in r["anova_p"]]))
        lag_err = float(np.median(np.abs([r["lag_error_ms"] for r in res])))
        first = True
        for q in res[0]["rows"]:
            hits = sum(r["rows"][q]["inside"] for r in res)
            plain_hits = sum(r["rows"][q]["plain_inside"] for r in res)
            gravity_hits = sum(r["rows"][q]["gravity_inside"] for r in res)
            cover = hits / len(res)
            lo, hi = _binom_interval(hits, len(res))
            ok = 0.90 <= cover <= 0.99
            targets.append({"level": level, "quantity": q, "coverage": cover, "met": ok})
            table_rows.append(
                {
                    "level": level if first else "",
                    "scatter": f"{100 * scatter:.2f}%" if first else "",
                    "quantity": q,
                    "coverage": cover,
                    "ci": f"[{lo:.2f}, {hi:.2f}]",
                    "plain": plain_hits / len(res),
                    "gravity": gravity_hits / len(res),
                    "width": float(np.mean([r["rows"][q]["width_ratio"] for r in res])),
                    "gravity_width": float(
                        np.mean([r["rows"][q]["gravity_width_ratio"] for r in res])
                    ),
                    "rel_width": f"{100 * np.mean([r['rows'][q]['rel_width'] for r in res]):.2f}%",
                    "speed": f"{100 * speed:.0f}%" if first else "",
                    "lag": f"{lag_err:.3f}" if first else "",
                }
            )
            first = False
    columns = [
        ("level", "level", ""),
        ("scatter", "scatter", ""),
        ("quantity", "quantity", ""),
        ("coverage", "95% HDI cover", ".3f"),
        ("ci", "binomial 95% CI", ""),
        ("plain", "cover: none", ".3f"),
        ("gravity", "cover: no gain", ".3f"),
        ("width", "width / none", ".2f"),
        ("gravity_width", "no gain / none", ".2f"),
        ("rel_width", "HDI width", ""),
        ("speed", "speeds differ", ""),
        ("lag", "|lag err| ms", ""),
    ]
    text = table(columns, table_rows)
    # the same coverage split by the simulated lag: 0-2.5 ms and 2.5-5 ms
    by_lag = []
    for lo, hi in ((0.0, 2.5), (2.5, 5.0)):
        res = [r for r in results if lo <= r["lag_ms"] < hi]
        if res:
            cover = [np.mean([r["rows"][q]["inside"] for r in res]) for q in res[0]["rows"]]
            by_lag.append(
                f"lag {lo:g}-{hi:g} ms: {len(res)} studies, coverage "
                f"{min(cover):.3f}-{max(cover):.3f} over the quantities"
            )
    if by_lag:
        text += "\n" + "\n".join(by_lag)
    unconverged = sum(not r["converged"] for r in results)
    text += (
        f"\n{n} studies per level, {len(results)} in all, {unconverged} not converged; "
        f"{time.perf_counter() - t0:.0f} s on {workers} processes"
    )
    return {
        "title": "9. Coverage: the whole pipeline on simulated trial files (95 % HDI)",
        "rows": table_rows,
        "targets": targets,
        "table": text,
        "studies_per_level": n,
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=2026,
        quick_help="12 studies per level instead of 40",
        options={
            "--studies": {"type": int, "default": None, "help": "studies per level"},
            "--levels": {"default": None, "help": "comma-separated levels (default: all)"},
        },
    )


if __name__ == "__main__":
    sys.exit(main())
