"""Scaling: one attachment with K segments in one study, and many small studies in a batch.

Studies come from ``simulate_study``: conditions "attachment alone" and "attachment + segment
k" for each k, one quasi-static trial (at 4 deg/s, so it is 22 s long) and three fast trials
at 240 deg/s per condition, 1 kHz. Each segment's truth is drawn at random and its prior box
(+-50 %) is centred on the truth scaled by a random factor in [0.85, 1.15], so the prior is not
the answer. Timed: the two stages of ``inertiafit.study.analyse_study`` that scale with K, run the same
way — ``process_study`` and ``fit`` (Laplace start, emcee, convergence checks, DataTree) —
with the sampler's defaults except a bound on the steps (``--max-steps``, default 2000; quick
1000): with the default bound of 20 000, K = 20 alone takes tens of minutes (see
docs/benchmarks.md). A run that hits the bound is reported as not converged, with its tau.
Accuracy: the fraction of bodies whose 95 % HDI of the inertia contains the truth.

The batch part analyses several small paper-shaped studies (three fast trials per speed)
one after another in one process: time per study.

Run:  .venv/bin/python benchmarks/scaling.py [--quick] [--json FILE]
"""

from __future__ import annotations

import tempfile
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
from common import standalone, table


def segment_study(folder: Path, k: int, seed: int) -> Path:
    from inertiafit.simulate import Noise, simulate_study

    rng = np.random.default_rng([seed, k])
    bodies = {"attachment": (2.85, 0.12, 0.24)}
    for j in range(1, k + 1):
        bodies[f"seg{j:02d}"] = (
            rng.uniform(1.0, 4.0),
            rng.uniform(0.04, 0.10),
            rng.uniform(0.10, 0.30),
        )
    priors = {}
    for name, (m, rho, x) in bodies.items():
        f = rng.uniform(0.85, 1.15, 3)
        priors[name] = {
            "mass": m * f[0],
            "radius_of_gyration": rho * f[1],
            "com_distance": x * f[2],
            "spread": 0.5,
        }
    conditions = [("attachment",)] + [("attachment", b) for b in bodies if b != "attachment"]
    return simulate_study(
        folder,
        bodies=bodies,
        conditions=conditions,
        speeds=(240.0,),
        trials_per_speed=3,
        quasi_static_speed=4.0,
        seed=seed,
        noise=Noise(trial_offset_sd=0.1),
        priors=priors,
        name=f"attachment with {k} segments",
    )


def timed_stages(manifest: Path, seed: int, max_steps: int) -> tuple[dict, object, object]:
    """process_study + fit as analyse_study runs them, each timed; the step bound is ours."""
    from inertiafit.inference import fit
    from inertiafit.sampler import SamplerSettings
    from inertiafit.study import process_study, study_model

    t0 = time.perf_counter()
    processed = process_study(manifest)
    t1 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # not converging is reported in the table
        post = fit(
            study_model(processed),
            seed=seed,
            settings=SamplerSettings(max_steps=max_steps, progress=False),
        )
    t2 = time.perf_counter()
    times = {
        "total": t2 - t0,
        "processing": t1 - t0,
        "fit": t2 - t1,
        "emcee": float(post.attrs["sampling_seconds"]),
    }
    return times, processed, post


def timed_analysis(manifest: Path, seed: int) -> tuple[dict, object]:
    """The whole analyse_study (defaults), with processing split off by its progress lines."""
    from inertiafit.study import analyse_study

    marks: dict[str, float] = {}

    def echo(msg: str) -> None:
        marks.setdefault(msg.split(maxsplit=1)[0], time.perf_counter())

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = analyse_study(manifest, seed=seed, echo=echo)
    total = time.perf_counter() - t0
    return {"total": total, "processing": marks.get("sampling", t0) - t0}, result


def hdi_coverage(post, truth_file: Path) -> tuple[float, int, bool, float]:
    truth = tomllib.loads(truth_file.read_text())["bodies"]
    s = post.summary(0.95)
    s = s[s["parameter"] == "inertia"].set_index("body")
    inside = [
        bool(s.loc[b, "hdi_lower"] <= t["inertia"] <= s.loc[b, "hdi_upper"])
        for b, t in truth.items()
    ]
    width = float(np.median((s["hdi_upper"] - s["hdi_lower"]) / s["median"]))
    return float(np.mean(inside)), len(inside), bool(post.converged), width


def run(*, quick: bool = False, seed: int = 5, max_steps: int | None = None) -> dict:
    from inertiafit.simulate import paper_study

    ks = (1, 5, 20) if quick else (1, 5, 20, 50)
    n_batch = 3 if quick else 8
    max_steps = max_steps or (1000 if quick else 2000)
    rows = []
    with tempfile.TemporaryDirectory(prefix="inertiafit-bench-") as tmp:
        tmpdir = Path(tmp)
        warm = segment_study(tmpdir / "warm", 1, seed + 99)
        timed_stages(warm, seed, max_steps)  # imports out of the timing
        for k in ks:
            folder = tmpdir / f"k{k}"
            manifest = segment_study(folder, k, seed)
            times, processed, post = timed_stages(manifest, seed, max_steps)
            cover, n_bodies, converged, width = hdi_coverage(post, folder / "truth.toml")
            rows.append(
                {
                    "segments": k,
                    "bodies": n_bodies,
                    "ndim": 2 * n_bodies,
                    "trials": len(processed.trials),
                    "max_steps": max_steps,
                    **times,
                    "n_walkers": int(post.attrs["n_walkers"]),
                    "n_steps": int(post.attrs["n_steps"]),
                    "tau_max": float(post.attrs["tau_max"]),
                    "converged": converged,
                    "hdi_coverage": cover,
                    "hdi_rel_width_median": width,
                }
            )
        batch = []
        for i in range(n_batch):
            folder = tmpdir / f"batch{i}"
            manifest = paper_study(folder, seed=seed + i, trials_per_speed=3)
            times, result = timed_analysis(manifest, seed)
            cover, n_bodies, converged, _ = hdi_coverage(result.posterior, folder / "truth.toml")
            batch.append({"study": i, **times, "hdi_coverage": cover, "converged": converged})
    text = table(
        [
            ("segments", "K", "d"),
            ("ndim", "dims", "d"),
            ("trials", "trials", "d"),
            ("total", "total (s)", ".2f"),
            ("processing", "process (s)", ".2f"),
            ("fit", "fit (s)", ".2f"),
            ("emcee", "sampling (s)", ".2f"),
            ("n_walkers", "walkers", "d"),
            ("n_steps", "steps", "d"),
            ("tau_max", "tau", ".1f"),
            ("converged", "converged", ""),
            ("hdi_coverage", "truth in 95% HDI", ".2f"),
            ("hdi_rel_width_median", "HDI width/median", ".3f"),
        ],
        [{**r, "converged": "yes" if r["converged"] else "NO"} for r in rows],
    )
    per_study = [b["total"] for b in batch]
    text += (
        "\ntotal = process (process_study) + fit (inference.fit: Laplace start, emcee, "
        "convergence checks, DataTree);\nsampling: the sampler's own clock (emcee + checks). "
        f"Steps bounded at {max_steps}; converged NO = bound reached first.\n"
        "truth in 95% HDI: fraction of bodies (attachment + K segments) whose inertia HDI "
        "holds the truth.\n\n"
        f"batch: {n_batch} paper-shaped studies (2 conditions, 3 fast trials per speed), "
        "each a whole analyse_study\n(default settings), one after another in one process:\n"
        + table(
            [("what", "", ""), ("value", "", "")],
            [
                {"what": "time per study, mean (s)", "value": f"{np.mean(per_study):.2f}"},
                {
                    "what": "time per study, min-max (s)",
                    "value": f"{min(per_study):.2f}-{max(per_study):.2f}",
                },
                {
                    "what": "of which processing, mean (s)",
                    "value": f"{np.mean([b['processing'] for b in batch]):.2f}",
                },
                {"what": "all converged", "value": str(all(b["converged"] for b in batch))},
                {
                    "what": "truth in 95% HDI (inertia, all bodies)",
                    "value": f"{np.mean([b['hdi_coverage'] for b in batch]):.2f}",
                },
            ],
        )
    )
    return {
        "name": "scaling",
        "title": "5. Scaling: K segments in one study; a batch of small studies",
        "rows": rows,
        "batch": batch,
        "table": text,
        "targets": [],
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=5,
        quick_help="K up to 20, 3 batch studies",
        options={"--max-steps": {"type": int, "help": "sampler step bound (2000; quick 1000)"}},
    )


if __name__ == "__main__":
    main()
