"""Trial processing: ``process_study`` on a paper-sized study against reading + filtering alone.

The study is ``paper_study`` (62 trials at 1 kHz: two quasi-static trials of 90 s, 60 fast
ones). The floor is the least any pipeline must do with it: read the same CSV files with
pandas' C parser and run the zero-lag Butterworth low-pass (``scipy.signal.sosfiltfilt``, the
same 2nd-order 20 Hz design) over torque and velocity of every trial. The two are timed in
turn (ours, floor, ours, floor, ...) five times; the guarded ratio is the median of the five
rounds' ratios (ours / floor of the same round), printed with its spread, and must stay at or
below 5x (the 2x target of issue 18 is withdrawn: reaching it needs every fast trial processed
as one array, not worth 0.3 s of a run). Accuracy: every fast trial's inertia against the
simulated truth. The split: the floor and our reading of each kind of trial (quasi-static,
fast) and the gravity fits, timed in the same rounds (medians), and what the guard leaves for
each fast trial's processing.

Run:  .venv/bin/python benchmarks/processing.py [--quick] [--json FILE]
"""

from __future__ import annotations

import functools
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
from common import (
    guard,
    interleaved,
    load_text,
    paired_ratios,
    spread,
    spread_text,
    standalone,
    table,
)
from scipy import signal

#: Guard: the median over ROUNDS interleaved rounds of process_study / floor stays at or below.
GUARD = 5.0
ROUNDS = 5


def floor(files: list[Path], rate: float = 1000.0) -> int:
    sos = signal.butter(2, 20.0, btype="low", fs=rate, output="sos")
    n = 0
    for f in files:
        frame = pd.read_csv(f, usecols=["time", "angle", "velocity", "torque"])
        for col in ("torque", "velocity"):
            signal.sosfiltfilt(sos, frame[col].to_numpy(dtype=float))
        n += len(frame)
    return n


def read_all(specs: list) -> None:
    """Our reading of the trials: ``TrialSpec.read`` (checks and the Trial dataset)."""
    for spec in specs:
        spec.read()


def budget_rows(
    split: dict[str, float], n: dict[str, int], ours: float, floor_total: float
) -> tuple[list[dict], str]:
    """Per kind of trial: the floor, our reading and our processing, and what the guard leaves.

    ``split`` holds median times (s) measured in the same alternating rounds as the totals:
    the floor and our reading per kind, and the quasi-static gravity fits; ``n`` the trials
    of each kind. A fast trial's processing is what is left of ``ours`` after reading and the
    gravity fits.
    """
    read = split["read:quasi-static"] + split["read:fast"]
    gravity = split["gravity"]
    fast_work = max(ours - read - gravity, 0.0)
    rows = []
    for kind in ("quasi-static", "fast"):
        work = gravity if kind == "quasi-static" else fast_work
        rows.append(
            {
                "kind": kind,
                "trials": n[kind],
                "floor": 1e3 * split[f"floor:{kind}"] / n[kind],
                "read": 1e3 * split[f"read:{kind}"] / n[kind],
                "work": 1e3 * work / n[kind],
            }
        )
    allowed = GUARD * floor_total
    left = (allowed - read - gravity) / n["fast"]
    spare = (
        f"leaves {1e3 * left:.2f} ms per fast trial"
        if left > 0
        else f"is already {-left * n['fast']:.3f} s over it, with nothing left"
    )
    text = (
        f"{GUARD:g}x the floor allows {allowed:.3f} s. Reading the trials (checks, hashing "
        f"and the Trial datasets included) takes {read:.3f} s of it and the quasi-static "
        f"gravity fits {gravity:.3f} s, which {spare} for the filtering, lag, window, "
        f"standard errors and checks; they take {1e3 * fast_work / n['fast']:.2f} ms per fast "
        "trial now."
    )
    return rows, text


def stage_profile(manifest: Path) -> list[dict]:
    """Cumulative time of process_study's parts, from one profiled call."""
    import cProfile
    import pstats

    from inertiafit.processing.study import process_study

    prof = cProfile.Profile()
    prof.enable()
    process_study(manifest)
    prof.disable()
    stats = pstats.Stats(prof)
    total = max(v[3] for k, v in stats.stats.items() if k[2] == "process_study")
    # (file, function names): a stage's time is the largest cumulative time among its
    # functions, so a function and the one it wraps are not counted twice. A name that is no
    # longer called shows 0 s: check the table after moving a function.
    wanted = {
        "read (TrialSpec.read: CSV -> Trial)": ("sections/trials.py", ("read",)),
        "  pandas read_csv + column checks": ("tables.py", ("load_table",)),
        "  make_trial (xarray Dataset, checks)": ("trial.py", ("make_trial",)),
        "    compare_velocity": ("trial.py", ("compare_velocity",)),
        "fit_gravity (quasi-static)": ("gravity.py", ("fit_gravity",)),
        "  drift refit for the fast trials": ("gravity.py", ("_drift_given_white",)),
        "estimate_inertia (fast)": ("inertia.py", ("estimate_inertia",)),
        "  low-pass (all calls: channels, SE weights)": ("filtering.py", ("lowpass_rows",)),
        "    sosfilt (the passes)": ("_signaltools.py", ("sosfilt",)),
        "  acceleration, SE weights (derivative)": (
            "filtering.py",
            ("derivative", "spectral_derivative"),
        ),
        "  lag (estimate_lag)": ("lag.py", ("estimate_lag",)),
        "  SE from the noise model (W Sigma W')": ("inertia.py", ("_noise_covariance",)),
        "  find_window_arrays": ("window.py", ("find_window", "find_window_arrays")),
        "  integrated_autocorrelation_time": ("stats.py", ("integrated_autocorrelation_time",)),
        "fast_trial_flags (plausibility)": ("plausibility.py", ("fast_trial_flags",)),
        "cruise_slope (the gravity model's scale)": ("plausibility.py", ("cruise_slope",)),
    }
    rows = []
    for label, (fname, funcs) in wanted.items():
        seconds = max(
            sum(v[3] for k, v in stats.stats.items() if k[0].endswith(fname) and k[2] == func)
            for func in funcs
        )
        rows.append({"stage": label, "seconds": seconds, "share": seconds / total})
    rows.append({"stage": "process_study (profiled total)", "seconds": total, "share": 1.0})
    return rows


def run(*, quick: bool = False, seed: int = 7) -> dict:
    from inertiafit.io import load_study
    from inertiafit.processing.gravity import fit_gravity
    from inertiafit.processing.study import process_study
    from inertiafit.simulate import paper_study

    with tempfile.TemporaryDirectory(prefix="inertiafit-bench-") as tmp:
        manifest = paper_study(tmp, seed=seed)
        files = sorted((Path(tmp) / "data").glob("*.csv"))
        mb = sum(f.stat().st_size for f in files) / 1e6
        truth = tomllib.loads((Path(tmp) / "truth.toml").read_text(encoding="utf-8"))["conditions"]
        process_study(manifest)  # warm-up: imports, page cache
        floor(files)
        study = load_study(manifest)
        by_kind = {
            "quasi-static": [t for t in study.trials if t.kind == "quasi-static"],
            "fast": [t for t in study.trials if t.kind == "fast"],
        }
        sweeps = [t.read() for t in by_kind["quasi-static"]]
        pieces = {
            **{
                f"floor:{k}": functools.partial(floor, [t.file for t in v])
                for k, v in by_kind.items()
            },
            **{f"read:{k}": functools.partial(read_all, v) for k, v in by_kind.items()},
            "gravity": lambda: [fit_gravity(ds) for ds in sweeps],
        }
        # Interleaved (ours, floor, the pieces, ours, floor, ...), so a busy moment of the
        # machine hits both sides alike, and medians: on the shared 2-core machine the floor's
        # best of 3 in a row moved from 0.13 to 0.22 s between runs while ours held still.
        load_before = load_text()
        timed = interleaved(
            {
                "ours": lambda _: process_study(manifest),
                "floor": lambda _: floor(files),
                **{key: (lambda _, piece=piece: piece()) for key, piece in pieces.items()},
            },
            ROUNDS,
        )
        load_after = load_text()
        ours_all = [t for t, _ in timed["ours"]]
        floor_all = [t for t, _ in timed["floor"]]
        processed, n_samples = timed["ours"][-1][1], timed["floor"][-1][1]
        split = {key: spread([t for t, _ in timed[key]])["median"] for key in pieces}
        prof = [] if quick else stage_profile(manifest)  # a profiled run: not in --quick
    ratios = paired_ratios(ours_all, floor_all)
    ratio_s = spread(ratios)
    ours_sp, floor_sp = spread(ours_all), spread(floor_all)
    ours_s, floor_s = ours_sp["median"], floor_sp["median"]
    counts = {k: len(v) for k, v in by_kind.items()}
    budget, budget_text = budget_rows(split, counts, ours_s, floor_s)
    trials = processed.trials
    fast = trials[trials["kind"] == "fast"]
    true_i = {lab: cond["inertia"] for lab, cond in truth.items()}
    labels = dict(zip(processed.study.conditions, truth, strict=True))
    rel = [
        (row["inertia"] - true_i[labels[row["condition"]]]) / true_i[labels[row["condition"]]]
        for _, row in fast.iterrows()
    ]
    rel_means = {
        c: float(np.mean([r for r, cc in zip(rel, fast["condition"], strict=True) if cc == c]))
        for c in processed.study.conditions
    }
    ratio = ratio_s["median"]
    verdict = guard(
        f"process_study <= {GUARD:g}x the read+filter floor (median of {ROUNDS} interleaved rounds)",
        ratio,
        GUARD,
        below=True,
        shown=f"{spread_text(ratio_s, unit='x')}",
    )
    row = {
        "trials": len(files),
        "samples": n_samples,
        "megabytes": mb,
        "ours_seconds": ours_s,
        "ours_all": ours_all,
        "floor_seconds": floor_s,
        "floor_all": floor_all,
        "ratio": ratio,
        "ratios_all": ratios,
        "ratio_low": ratio_s["low"],
        "ratio_high": ratio_s["high"],
        "load_before": load_before,
        "load_after": load_after,
        "per_trial_ms": 1e3 * ours_s / len(files),
        "inertia_rel_err_mean": rel_means,
        "inertia_rel_err_sd": float(np.std(rel)),
    }
    text = table(
        [
            ("what", "what", ""),
            ("seconds", "median (s)", ".3f"),
            ("range", "min-max (s)", ""),
            ("per_trial", "per trial (ms)", ".1f"),
            ("ratio", "ratio", ""),
            ("guard", "guard", ""),
        ],
        [
            {
                "what": "process_study (ours)",
                "seconds": ours_s,
                "range": f"{ours_sp['low']:.3f}-{ours_sp['high']:.3f}",
                "per_trial": 1e3 * ours_s / len(files),
                "ratio": spread_text(ratio_s, unit="x"),
                "guard": f"<= {GUARD:g}x: {verdict['status']}",
            },
            {
                "what": "floor: read_csv + sosfiltfilt",
                "seconds": floor_s,
                "range": f"{floor_sp['low']:.3f}-{floor_sp['high']:.3f}",
                "per_trial": 1e3 * floor_s / len(files),
                "ratio": "1",
            },
        ],
    )
    text += (
        f"\n{len(files)} trials, {n_samples} rows, {mb:.1f} MB of CSV; {ROUNDS} rounds, ours and "
        "the floor in turn; ratio: the median of the rounds' ratios (smallest-largest).\n"
        f"ratio per round: {', '.join(f'{r:.2f}' for r in ratios)}; load average before "
        f"{load_before}, after {load_after}.\n"
        "accuracy: mean relative error of the per-trial inertia vs the truth, per condition: "
        + ", ".join(f"{c} {100 * v:+.2f} %" for c, v in rel_means.items())
        + f" (trial-to-trial SD {100 * row['inertia_rel_err_sd']:.1f} %, the simulated scatter)"
        + "\n\nper kind of trial (medians of the same rounds; ms per trial):\n"
        + table(
            [
                ("kind", "kind", ""),
                ("trials", "trials", "d"),
                ("floor", "floor", ".2f"),
                ("read", "our reading", ".2f"),
                ("work", "our processing", ".2f"),
            ],
            budget,
        )
        + "\n"
        + budget_text
    )
    if prof:
        text += (
            "\n\nwhere process_study's time goes (cProfile, cumulative; profiling inflates it):\n"
            + table(
                [("stage", "stage", ""), ("seconds", "seconds", ".3f"), ("share", "share", ".0%")],
                prof,
            )
        )
    return {
        "name": "processing",
        "title": "3. Trial processing: process_study on paper_study (62 trials, 1 kHz)",
        "rows": [row],
        "profile": prof,
        "budget": budget,
        "table": text,
        "targets": [verdict],
    }


def main() -> None:
    standalone(run, __doc__, seed=7, quick_help="no profiled run (five rounds either way)")


if __name__ == "__main__":
    main()
