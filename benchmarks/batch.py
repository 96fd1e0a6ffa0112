"""Batch: `inertiafit run-many` serially in one process vs on a local Dask cluster of 2 workers.

N paper-shaped studies from ``paper_study`` (attachment alone and with the 3 kg disk, one
quasi-static trial at 4 deg/s and three fast trials per speed at 240/270/300 deg/s, per
condition: 20 trials at 1 kHz each), each a whole ``run_study`` with the default figure formats
(pdf, png). Timed with ``inertiafit.pipeline.batch.run_many``, the function behind the command:

- serial: ``workers=1``, one study after another in this process, its figures drawn here too
  (``FIGURE_WORKERS = 1``): one core, the baseline of the target; the imports are warmed up
  first by one study outside the timing (as in a long-lived session);
- serial, figures forked: ``workers=1`` as a user runs it, each study's figures drawn in two
  forked processes when the cores are idle (``inertiafit.report.outputs.idle_cores``), so part
  of it already uses the second core: reported for what a batch gains over that default;
- dask: ``workers=2``, a ``LocalCluster`` of 2 single-threaded worker processes, its start-up
  (also reported alone) and the workers' cold imports inside the timing.

The three run in turn, ``--repeats`` times; the speed-up is the best one-process serial time over
the best dask time of this run (and per repeat), the forked-figures row's printed beside it.
The numbers of all three must be identical (``batch-summary.csv`` byte for byte). Target: speed-up >= 1.6x on a 2-core machine; the
machine and its load are printed, since other processes take the same cores.

Each row also says how many cores other processes kept busy meanwhile (``/proc/stat`` less this
process and its workers); ``--quiet-wait S`` waits up to S seconds before each timing for them
to go quiet.

Run:  .venv/bin/python benchmarks/batch.py [--quick] [--repeats N] [--studies N]
      [--quiet-wait S] [--json FILE]
"""

from __future__ import annotations

import math
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
from common import standalone, table, verdict

TARGET = 1.6
WORKERS = 2


def make_studies(folder: Path, n: int, seed: int) -> list[Path]:
    from inertiafit.simulate import paper_study

    return [
        paper_study(
            folder / f"study{i:02d}", seed=seed + i, trials_per_speed=3, quasi_static_speed=4.0
        )
        for i in range(n)
    ]


def machine_busy() -> float:
    """CPU seconds the whole machine has been busy (every core, every process): /proc/stat."""
    try:
        ticks = [
            int(x)
            for x in Path("/proc/stat").read_text(encoding="utf-8").split("\n", 1)[0].split()[1:9]
        ]
    except OSError:
        return math.nan
    idle = ticks[3] + ticks[4]  # idle, iowait
    return (sum(ticks) - idle) / os.sysconf("SC_CLK_TCK")


def own_cpu() -> float:
    """CPU seconds of this process and its finished children (the Dask workers, once closed)."""
    me, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def others_now(seconds: float = 2.0) -> float:
    """Cores kept busy by other processes over the next ``seconds``."""
    busy, own, t0 = machine_busy(), own_cpu(), time.perf_counter()
    time.sleep(seconds)
    return (machine_busy() - busy - (own_cpu() - own)) / (time.perf_counter() - t0)


def wait_for_quiet(limit: float, threshold: float = 0.25) -> float:
    """Wait up to ``limit`` s until other processes use < ``threshold`` cores; their load."""
    t0 = time.perf_counter()
    load = others_now() if limit > 0 else math.nan
    while load >= threshold and time.perf_counter() - t0 < limit:
        load = others_now()
    return load


def timed_batch(
    manifests: list[Path], out: Path, workers: int, formats, figure_workers: int = 1
) -> dict:
    from inertiafit.pipeline.batch import run_many
    from inertiafit.report import outputs

    saved, outputs.FIGURE_WORKERS = outputs.FIGURE_WORKERS, figure_workers
    try:
        busy, own = machine_busy(), own_cpu()
        t0 = time.perf_counter()
        result = run_many(manifests, out, workers=workers, formats=formats, echo=lambda _m: None)
        wall = time.perf_counter() - t0
    finally:
        outputs.FIGURE_WORKERS = saved
    others = (machine_busy() - busy - (own_cpu() - own)) / wall
    if not result.ok:
        msg = f"benchmark batch failed: {result.table[['manifest', 'error']].to_dict('records')}"
        raise RuntimeError(msg)
    per_study = result.table["seconds"].astype(float)
    return {
        "mode": (
            f"dask, {workers} workers"
            if workers > 1
            else "serial" + (", figures forked" if figure_workers > 1 else "")
        ),
        "wall": wall,
        "startup": result.startup_seconds,
        "after_startup": wall - result.startup_seconds,
        "study_mean": float(per_study.mean()),
        "study_sum": float(per_study.sum()),
        "converged": bool(result.table["converged"].all()),
        "others": max(others, 0.0),
        "summary": (out / "batch-summary.csv").read_bytes(),
    }


def load() -> str:
    try:
        return ", ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def run(
    *,
    quick: bool = False,
    seed: int = 7,
    repeats: int | None = None,
    studies: int | None = None,
    quiet_wait: float = 0.0,
) -> dict:
    n = studies or (4 if quick else 8)
    repeats = repeats or (1 if quick else 2)
    formats = ("png",) if quick else ("pdf", "png")
    rows = []
    load_before = load()
    with tempfile.TemporaryDirectory(prefix="inertiafit-bench-batch-") as tmp:
        tmpdir = Path(tmp)
        manifests = make_studies(tmpdir / "studies", n, seed)
        warm = make_studies(tmpdir / "warm", 1, seed + 1000)
        timed_batch(warm, tmpdir / "warm-out", 1, formats)  # imports out of the serial timing
        for r in range(repeats):
            serial, forked, dask = (
                {
                    "quiet_before": wait_for_quiet(quiet_wait),
                    **timed_batch(manifests, tmpdir / f"out-{r}-{i}", workers, formats, figs),
                }
                for i, (workers, figs) in enumerate(((1, 1), (1, WORKERS), (WORKERS, 1)))
            )
            for row in (forked, dask):
                row["speedup"] = serial["wall"] / row["wall"]
                row["same_numbers"] = serial["summary"] == row["summary"]
            dask["speedup_after_startup"] = serial["wall"] / dask["after_startup"]
            dask["over_forked"] = forked["wall"] / dask["wall"]
            rows += [{"repeat": r + 1, **serial}, {"repeat": r + 1, **forked}]
            rows += [{"repeat": r + 1, **dask}]
    for row in rows:
        del row["summary"]
    serial_rows = [r for r in rows if r["mode"] == "serial"]
    forked_rows = [r for r in rows if r["mode"] == "serial, figures forked"]
    dask_rows = [r for r in rows if r["mode"].startswith("dask")]
    best_serial = min(r["wall"] for r in serial_rows)
    best_forked = min(r["wall"] for r in forked_rows)
    best_dask = min(r["wall"] for r in dask_rows)
    ratio = best_serial / best_dask
    same = all(r["same_numbers"] for r in forked_rows + dask_rows)
    text = table(
        [
            ("repeat", "repeat", "d"),
            ("mode", "mode", ""),
            ("wall", "wall (s)", ".1f"),
            ("startup", "cluster start (s)", ".1f"),
            ("after_startup", "after start (s)", ".1f"),
            ("study_mean", "per study (s)", ".2f"),
            ("others", "others (cores)", ".2f"),
            ("speedup", "speed-up", ".2f"),
            ("speedup_after_startup", "excl. start", ".2f"),
            ("over_forked", "vs forked", ".2f"),
            ("same_numbers", "same numbers", ""),
        ],
        [
            {
                **r,
                "startup": r["startup"] if r["mode"].startswith("dask") else None,
                "same_numbers": None
                if "same_numbers" not in r
                else ("yes" if r["same_numbers"] else "NO"),
            }
            for r in rows
        ],
    )
    text += (
        f"\n{n} paper-shaped studies (20 trials each, figures {','.join(formats)}); "
        f"wall = the whole run_many call; per study: run_study's own time (on the cluster it "
        f"includes each worker's cold imports);\nothers: cores kept busy by other processes "
        f"during the run (from /proc/stat less this process and its workers): the cores the "
        f"workers had were {WORKERS} less that.\nspeed-up = one-process serial wall / the row's "
        f"wall, same repeat; best serial {best_serial:.1f} s / best dask {best_dask:.1f} s = "
        f"{ratio:.2f}x (target >= {TARGET:g}x: {verdict(ratio, TARGET, below=False)}); against "
        f"the default serial run, whose figures use the second core when it is idle: best "
        f"{best_forked:.1f} s / {best_dask:.1f} s = {best_forked / best_dask:.2f}x; "
        f"load average before: {load_before}, after: {load()}."
    )
    return {
        "name": "batch",
        "title": f"6. Batch: {n} studies serially vs a local Dask cluster of {WORKERS} workers",
        "studies": n,
        "formats": list(formats),
        "rows": rows,
        "best_serial": best_serial,
        "best_forked": best_forked,
        "best_dask": best_dask,
        "speedup": ratio,
        "speedup_median_of_pairs": float(np.median([r["speedup"] for r in dask_rows])),
        "same_numbers": same,
        "table": text,
        "targets": [
            {
                "target": f"run-many on {WORKERS} local workers >= {TARGET:g}x serial (one process)",
                "value": f"{ratio:.2f}x",
                "status": verdict(ratio, TARGET, below=False),
            },
            {
                "target": "serial and dask numbers identical",
                "value": "yes" if same else "no",
                "status": "met" if same else "NOT met",
            },
        ],
    }


def main() -> None:
    standalone(
        run,
        __doc__,
        seed=7,
        quick_help="4 studies, PNG only, one repeat",
        options={
            "--repeats": {"type": int, "help": "serial/forked/dask rounds (default 2; quick 1)"},
            "--studies": {"type": int, "help": "studies in the batch (default 8; quick 4)"},
            "--quiet-wait": {
                "type": float,
                "default": 0.0,
                "help": "wait up to this many seconds before each timing until other processes "
                "use < 0.25 cores (a shared machine)",
            },
        },
    )


if __name__ == "__main__":
    main()
