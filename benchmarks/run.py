"""Every benchmark of inertiafit in one run: tables with ratios measured in the same run.

1. sampler      inertiafit's sampler vs plain emcee (guards: ESS/s >= 5x, tau <= 3 steps)
2. peer_pymc    PyMC's NUTS on the same model (optional: skipped when PyMC is missing)
3. processing   process_study vs reading the CSVs + sosfiltfilt (guard <= 5x)
4. end_to_end   `inertiafit run` vs the cold-import floor (guards <= 4x, < 400 MB)
5. scaling      K segments in one study; a batch of small studies
6. batch        run-many: a batch serially vs a local Dask cluster of 2 workers (target >= 1.6x)
7. sbc          simulation-based calibration: rank histograms, coverage, negative controls
8. gravity_se   the quasi-static fit's SE against its empirical error (drift, friction)
9. coverage     the whole pipeline on simulated trial files: 95 % HDI coverage at 4 noise levels
10. plan        `inertiafit plan`'s predicted widths vs full simulated studies (within 20 %)

Run:  .venv/bin/python benchmarks/run.py [--quick] [--json FILE] [--only NAME ...]
      [--pymc-python PATH]   (another venv's python with PyMC and inertiafit installed)
Each benchmark also runs alone: .venv/bin/python benchmarks/NAME.py [--quick] [--json FILE].
Results are described in docs/benchmarks.md.

Guards (sampler, processing, end_to_end) print PASS or FAIL: each is a ratio against a baseline
timed in turn with it in the same run (A B A B ..., five rounds), judged on the median of the
rounds' ratios. Exit status: 0 when every guard of the benchmarks run passed, 3 when one
failed (the tables are all printed first), 1 when a benchmark crashed, 2 for a bad command
line. Other targets ("met" / "NOT met") are reported only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import batch
import common
import coverage
import end_to_end
import gravity_se
import peer_pymc
import plan
import processing
import sampler
import sbc
import scaling

HERE = Path(__file__).resolve().parent
BENCHMARKS = {
    "sampler": sampler.run,
    "peer_pymc": peer_pymc.run,
    "processing": processing.run,
    "end_to_end": end_to_end.run,
    "scaling": scaling.run,
    "batch": batch.run,
    "sbc": sbc.run,
    "gravity_se": gravity_se.run,
    "coverage": coverage.run,
    "plan": plan.run,
}


def pymc_elsewhere(python: str, quick: bool) -> dict:
    """The PyMC peer in another interpreter (PyMC need not be in the project's venv)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "peer.json"
        cmd = [python, str(HERE / "peer_pymc.py"), "--json", str(out)]
        subprocess.run(
            [*cmd, *(["--quick"] if quick else [])], check=True, stdout=subprocess.DEVNULL
        )
        return json.loads(out.read_text(encoding="utf-8"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="shrink everything (about 2 minutes in all)"
    )
    parser.add_argument("--json", help="write every result (and the machine) to this file")
    parser.add_argument("--only", nargs="+", choices=list(BENCHMARKS), help="run only these")
    parser.add_argument(
        "--pymc-python",
        default=os.environ.get("INERTIAFIT_BENCH_PYMC_PYTHON"),
        help="python of a venv with PyMC, used when PyMC is not importable here",
    )
    args = parser.parse_args()
    common.warn_blas_env()
    info = common.machine()
    print(
        f"machine: {info['nproc']} cores, {info['cpu']}, {info['memory_gib']} GiB; "
        + ", ".join(f"{k} {v}" for k, v in info["versions"].items())
        + f"; BLAS {info['blas']}; OPENBLAS_CORETYPE={info['OPENBLAS_CORETYPE']}"
    )
    print(f"mode: {'quick' if args.quick else 'full'}; inertiafit from {info['inertiafit_path']}")
    print(f"load average (1, 5, 15 min) at the start: {common.load_text()}")
    results = {}
    t_all = time.perf_counter()
    for name, func in BENCHMARKS.items():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        if name == "peer_pymc" and not peer_pymc.available() and args.pymc_python:
            res = pymc_elsewhere(args.pymc_python, args.quick)
            res["python"] = args.pymc_python
        else:
            res = func(quick=args.quick)
        res["seconds"] = time.perf_counter() - t0
        res["load_average_after"] = common.load_text()
        if name == "peer_pymc" and res["rows"] and "sampler" in results:
            ours = {r["posterior"]: r["inertiafit_ess_per_s"] for r in results["sampler"]["rows"]}
            for r in res["rows"]:
                r["inertiafit_ess_per_s_same_run"] = ours[r["posterior"]]
                r["inertiafit_over_pymc"] = ours[r["posterior"]] / r["ess_per_s"]
            res["table"] += "\ninertiafit ESS/s / PyMC ESS/s (this run): " + ", ".join(
                f"{r['posterior']} {r['inertiafit_over_pymc']:.0f}x" for r in res["rows"]
            )
        results[name] = res
        print(
            f"\n== {res['title']}  [{res['seconds']:.0f} s; load average after: "
            f"{res['load_average_after']}]"
        )
        print(res["table"])
        sys.stdout.flush()
    targets = [
        {"benchmark": name, **t} for name, res in results.items() for t in res.get("targets", [])
    ]
    if targets:
        print("\n== Targets")
        print(
            common.table(
                [
                    ("benchmark", "benchmark", ""),
                    ("target", "target", ""),
                    ("value", "measured", ""),
                    ("status", "status", ""),
                ],
                targets,
            )
        )
    failed = common.failed_guards(targets)
    guards = [t for t in targets if t.get("guard")]
    if guards:
        print(
            f"\nguards: {len(guards) - len(failed)} of {len(guards)} PASS"
            + (f"; FAIL: {'; '.join(t['target'] for t in failed)}" if failed else "")
        )
    total = time.perf_counter() - t_all
    print(f"\nall benchmarks: {total:.0f} s; load average at the end: {common.load_text()}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(
                {
                    "machine": info,
                    "quick": args.quick,
                    "seconds": total,
                    "targets": targets,
                    "guards_failed": len(failed),
                    "results": results,
                },
                fh,
                indent=2,
                default=str,
            )
        print(f"results written to {args.json}")
    if failed:
        sys.exit(common.GUARD_FAILED)


if __name__ == "__main__":
    main()
