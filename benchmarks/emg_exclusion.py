"""EMG exclusion on living limbs: are the reflex trials left out, and is the forearm's I covered?

Each simulated study (``inertiafit.simulate.simulate_living_study`` with
``emg=EmgSimulation(...)``): an elbow attachment (rigid) and a forearm (living) drawn as in
``benchmarks/living_coverage.py`` (true values uniform in the +-50 % box around nominal values
that vary from study to study; the elbow's passive joint drawn by the simulator), one posture:
condition A (the attachment alone, no EMG) and condition B (attachment + forearm, EMG of
biceps and triceps at 5 µV RMS rest noise) with quasi-static sweeps both ways, three rest
trials and five fast trials at 180 deg/s; in ``--reflexes`` of the five (default 1, chosen at
random) a stretch reflex: a triceps burst 35-60 ms after the stretch starts, 8-20 x rest,
30-60 ms long, and a 0.6-2 N m torque resisting the stretch (``inertiafit.simulate.emg``).

Each study is analysed twice, as ``inertiafit run`` would (``process_study``, the study model,
the sampler): **with the check** (``[emg] on_activity = "exclude"``, the default) and
**without** (``"flag"``: the active trials stay in the evidence).

Printed: the exclusion's recall (reflex trials excluded / reflex trials) and false-alarm rate
(clean fast trials excluded / clean fast trials) with binomial 95 % intervals (issue 20's
targets: >= 90 %, <= 10 %); the reflex and clean trials' ``emg_peak_ratio`` ranges; the
reflex trials' inertia over their study's clean trials' mean; and for the forearm's ``I`` the
95 % HDI coverage, mean z-score and median error with and without the check.

Run:  .venv/bin/python benchmarks/emg_exclusion.py [--quick] [--studies N] [--reflexes K]
      [--seed S] [--json FILE]   (full: 40 studies; --quick: 8)
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from common import binomial_interval, hdi, living_forearm_bodies, standalone, table

HDI = 0.95
FAST_TRIALS = 5


def _fit_forearm(processed, seed: int, true_i: float) -> dict:
    from inertiafit.inference.evidence import study_model
    from inertiafit.inference.fit import fit
    from inertiafit.inference.sampler import SamplerSettings

    post = fit(study_model(processed), seed=seed, settings=SamplerSettings(progress=False))
    draws = post.draws("forearm", "inertia")
    lo, hi = hdi(draws, HDI)
    return {
        "inside": bool(lo <= true_i <= hi),
        "z": (float(np.mean(draws)) - true_i) / float(np.std(draws)),
        "error": (float(np.median(draws)) - true_i) / true_i,
    }


def one_study(
    seed: int, reflexes: int = 1, *, posterior: bool = True, quasi_static_speed: float = 1.0
) -> dict:
    """Simulate one living study with EMG; what the check excluded, and the forearm's I.

    ``posterior=False`` (the tests' small version) samples nothing; a faster
    ``quasi_static_speed`` (deg/s) shortens the sweeps.
    """
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from inertiafit.errors import InputError
    from inertiafit.physics import inertia
    from inertiafit.processing.study import process_study
    from inertiafit.simulate import EmgSimulation, simulate_living_study

    rng = np.random.default_rng([seed, 20])
    truth, priors = living_forearm_bodies(rng)
    fast = [f"B_upright_180_{k + 1:02d}.csv" for k in range(FAST_TRIALS)]
    chosen = sorted(rng.choice(fast, size=reflexes, replace=False).tolist())
    true_i = float(inertia(*truth["forearm"]))
    out: dict = {"seed": seed, "reflex_trials": chosen}
    with tempfile.TemporaryDirectory() as tmp:
        manifest = simulate_living_study(
            tmp,
            seed=int(rng.integers(2**31)),
            postures="one",
            bodies=truth,
            priors=priors,
            trials_per_speed=FAST_TRIALS,
            quasi_static_speed=quasi_static_speed,
            emg=EmgSimulation(reflex=chosen),
        )
        reflexes_truth = tomllib.loads((Path(tmp) / "truth.toml").read_text(encoding="utf-8"))[
            "emg"
        ]
        assert reflexes_truth["reflex_trials"] == chosen
        start = time.perf_counter()
        try:
            processed = process_study(manifest)
        except InputError as exc:  # every fast trial of the forearm excluded
            out["refused"] = str(exc)
            processed = None
        out["seconds"] = time.perf_counter() - start
        flagged = Path(tmp) / "flag.toml"
        flagged.write_text(
            manifest.read_text(encoding="utf-8").replace(
                'unit = "V"', 'unit = "V"\non_activity = "flag"'
            )
        )
        kept = process_study(flagged)
        trials = kept.all_trials
        rows = trials[(trials["kind"] == "fast") & trials["file"].str.startswith("data/B_")]
        names = rows["file"].str.removeprefix("data/")
        reflex = names.isin(chosen).to_numpy()
        out["reflex_ratio"] = rows["emg_peak_ratio"].to_numpy()[reflex].tolist()
        out["clean_ratio"] = rows["emg_peak_ratio"].to_numpy()[~reflex].tolist()
        inertias = rows["inertia"].to_numpy()
        out["reflex_inertia"] = (inertias[reflex] / inertias[~reflex].mean()).tolist()
        if processed is not None:
            all_rows = processed.all_trials
            excluded = set(
                all_rows.loc[all_rows["status"] == "excluded", "file"].str.removeprefix("data/")
            )
        else:
            excluded = set(names)
        out["hits"] = sum(n in excluded for n in chosen)
        out["false_alarms"] = sum(n in excluded for n in names if n not in chosen)
        out["clean"] = int((~reflex).sum())
        if posterior:
            if processed is not None:
                out["with"] = _fit_forearm(processed, seed, true_i)
            out["without"] = _fit_forearm(kept, seed, true_i)
    return out


def run(
    *, quick: bool = False, seed: int = 20261126, studies: int | None = None, reflexes: int = 1
) -> dict:
    n = studies or (8 if quick else 40)
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        results = list(pool.map(one_study, range(seed, seed + n), [reflexes] * n))
    hits = sum(r["hits"] for r in results)
    n_reflex = reflexes * n
    alarms = sum(r["false_alarms"] for r in results)
    n_clean = sum(r["clean"] for r in results)
    reflex_ratio = np.concatenate([r["reflex_ratio"] for r in results])
    clean_ratio = np.concatenate([r["clean_ratio"] for r in results])
    reflex_inertia = np.concatenate([r["reflex_inertia"] for r in results])
    detection = [
        {
            "quantity": "recall (reflex trials excluded)",
            "value": hits / n_reflex,
            "count": f"{hits}/{n_reflex}",
            "interval": "[{:.2f}, {:.2f}]".format(*binomial_interval(hits, n_reflex)),
            "target": ">= 0.90",
        },
        {
            "quantity": "false alarms (clean trials excluded)",
            "value": alarms / n_clean,
            "count": f"{alarms}/{n_clean}",
            "interval": "[{:.2f}, {:.2f}]".format(*binomial_interval(alarms, n_clean)),
            "target": "<= 0.10",
        },
    ]
    coverage = []
    for label in ("with", "without"):
        sub = [r[label] for r in results if label in r]
        k = sum(s["inside"] for s in sub)
        coverage.append(
            {
                "check": f"{label} the check",
                "coverage": k / len(sub),
                "interval": "[{:.2f}, {:.2f}]".format(*binomial_interval(k, len(sub))),
                "z": float(np.mean([s["z"] for s in sub])),
                "error": float(np.median([s["error"] for s in sub])),
                "studies": len(sub),
            }
        )
    out = {
        "studies": n,
        "reflexes_per_study": reflexes,
        "detection": detection,
        "coverage": coverage,
        "refused": sum("refused" in r for r in results),
        "reflex_ratio": [float(reflex_ratio.min()), float(reflex_ratio.max())],
        "clean_ratio": [float(clean_ratio.min()), float(clean_ratio.max())],
        "reflex_inertia": [
            float(reflex_inertia.min()),
            float(np.median(reflex_inertia)),
            float(reflex_inertia.max()),
        ],
        "seconds": time.perf_counter() - start,
        "results": results,
    }
    out["table"] = show(out)
    return out


def show(out: dict) -> str:
    det = [
        ("quantity", "exclusion", ""),
        ("value", "rate", ".3f"),
        ("count", "trials", ""),
        ("interval", "binomial 95%", ""),
        ("target", "issue 20", ""),
    ]
    cov = [
        ("check", "forearm I", ""),
        ("coverage", "95% HDI covers", ".2f"),
        ("interval", "binomial 95%", ""),
        ("z", "mean z", "+.2f"),
        ("error", "median error", "+.4f"),
        ("studies", "studies", "d"),
    ]
    lo, mid, hi = out["reflex_inertia"]
    return "\n".join(
        [
            (
                f"== EMG exclusion: {out['studies']} living studies, "
                f"{out['reflexes_per_study']} reflex trial(s) of {FAST_TRIALS} "
                "(benchmarks/emg_exclusion.py)"
            ),
            table(det, out["detection"]),
            (
                "emg_peak_ratio: reflex trials {:.1f}-{:.1f}, clean trials {:.2f}-{:.2f}".format(
                    *out["reflex_ratio"], *out["clean_ratio"]
                )
            ),
            (
                f"reflex trials' inertia / their study's clean mean: {lo:.3f} to {hi:.3f} "
                f"(median {mid:.3f})"
            ),
            table(cov, out["coverage"]),
            f"studies refused (every forearm trial excluded): {out['refused']}",
            f"{out['seconds']:.0f} s",
        ]
    )


def main() -> None:
    standalone(
        run,
        __doc__ or "",
        seed=20261126,
        quick_help="8 studies instead of 40",
        options={
            "--studies": {"type": int, "default": None, "help": "number of studies"},
            "--reflexes": {"type": int, "default": 1, "help": "reflex trials of the five"},
        },
    )


if __name__ == "__main__":
    sys.exit(main())
