"""End to end: ``inertiafit run study.toml --out X`` as a subprocess against the cold-import floor.

The study is ``paper_study`` (62 trials at 1 kHz). The floor is a fresh interpreter importing
what ``run`` needs (``python -c "import inertiafit, emcee, arviz, corner, matplotlib, scipy,
xarray"``): no pipeline can start faster. ``run`` is timed as ``pip install inertiafit``
installs it, without the optional ``cluster`` extra (Dask): this venv has Dask for the tests,
so the child is started with ``dask`` and ``distributed`` hidden (importing them fails, as
where they are not installed). Installed, Dask costs every run about a second (xarray imports
dask.array when it first builds an array, and distributed when it writes posterior.nc): the
run with Dask is timed too and shown beside, without a target (not with ``--quick``). The floor
and ``run`` are timed in turn, five rounds; the guarded ratio is the median of the rounds'
ratios (each of two runs made side by side), printed with its spread and with the same ratio
in CPU seconds (the child's and its figure workers'); peak memory is each child's own maximum
resident set size (GNU time's ``%M``, else ``os.wait4``). Where the time goes comes from one more run in a child that wraps
the pipeline's stages with wall-clock timers (no profiler overhead), and from cProfile's top
entries of another.

Run:  .venv/bin/python benchmarks/end_to_end.py [--quick] [--json FILE]
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import (
    guard,
    load_text,
    median,
    paired_ratios,
    spread,
    spread_text,
    standalone,
    table,
)

#: Guards: the median over ROUNDS interleaved rounds (floor, run, floor, run, ...) of run /
#: floor at most RATIO_TARGET; every run's peak memory below MEMORY_TARGET_MB.
RATIO_TARGET = 4.0
MEMORY_TARGET_MB = 400.0
ROUNDS = 5
FLOOR_IMPORTS = "import inertiafit, emcee, arviz, corner, matplotlib, scipy, xarray"

# Runs in a child: times every stage of `run` by wrapping it. A function is wrapped where it is
# defined and under every module attribute bound to it (re-exports, `from x import f` in its
# callers); a name that no longer exists there stops the benchmark with the name to update.
#: Where the child runs as without the `cluster` extra: importing Dask fails.
WITHOUT_DASK = "import sys; sys.modules.update(dask=None, distributed=None)"

STAGES_CHILD = (
    WITHOUT_DASK
    + r"""
import functools, importlib, json, sys, time
T0 = time.perf_counter()
import inertiafit, emcee, arviz, corner, matplotlib, scipy, xarray
T_IMPORT = time.perf_counter() - T0
times = {}
originals = {}
def timer(fn, label):
    @functools.wraps(fn)
    def timed(*a, **k):
        t = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            times[label] = times.get(label, 0.0) + time.perf_counter() - t
    return timed
def missing(where):
    sys.exit(f"benchmarks/end_to_end.py: {where} no longer exists; update STAGES_CHILD")
def wrap(owner, attr, label):
    # a method (or any attribute) of a class or object other than a module
    fn = getattr(owner, attr, None)
    if not callable(fn):
        missing(f"{getattr(owner, '__qualname__', owner)}.{attr}")
    setattr(owner, attr, timer(fn, label))
def wrap_function(module, attr, label):
    # a function: in its defining module and in every loaded inertiafit module that binds it;
    # modules imported later bind the wrapper, since they import it from one of those
    home = importlib.import_module(module)
    fn = vars(home).get(attr)
    if not callable(fn) or getattr(fn, "__module__", None) != module:
        missing(f"function {module}.{attr}")
    timed = timer(fn, label)
    originals[id(fn)] = (fn, f"{module}.{attr}")
    for name, m in list(sys.modules.items()):
        if name.split(".")[0] == "inertiafit":
            for key, value in list(vars(m).items()):
                if value is fn:
                    setattr(m, key, timed)
from matplotlib.figure import Figure
from inertiafit.posterior import Posterior
import inertiafit.report.outputs
# Figures drawn in this process, one after another, so that every figure's timer sees them
# (forked workers would draw them out of reach of these timers).
inertiafit.report.outputs.FIGURE_WORKERS = 1
wrap_function("inertiafit.processing.study", "process_study", "process_study")
wrap_function("inertiafit.inference.fit", "fit", "fit (sampling + DataTree)")
wrap_function("inertiafit.inference.sampler", "sample", "  sample (Laplace start + emcee + checks)")
wrap_function("inertiafit.inference.moves", "laplace_fit", "    Laplace start")
wrap_function("inertiafit.inference.fit", "build_tree", "  build_tree")
wrap_function("inertiafit.processing.speed", "speed_effect", "speed_effect")
wrap_function("inertiafit.report.comparison", "paper_baselines", "paper_baselines")
wrap_function("inertiafit.report.comparison", "comparison_table", "comparison_table")
wrap_function("inertiafit.report.outputs", "write_outputs", "write_outputs")
wrap(Posterior, "corner", "  corner plots")
wrap(Posterior, "save", "  posterior.nc")
wrap(Posterior, "summary", "summary tables (all calls)")
wrap_function("inertiafit.report.plots.corner", "plot_joint_corner", "  plot_joint_corner")
wrap_function("inertiafit.report.plots.identification", "plot_identification_curve",
              "  plot_identification_curve")
wrap_function("inertiafit.report.plots.diagnostics", "plot_trace", "  plot_trace")
wrap_function("inertiafit.report.plots.diagnostics", "plot_rank", "  plot_rank")
wrap_function("inertiafit.report.plots.trials", "plot_fast_trials", "  plot_fast_trials")
wrap_function("inertiafit.report.plots.trials", "plot_inertia_by_speed", "  plot_inertia_by_speed")
wrap_function("inertiafit.report.html", "write_report", "  report.html")
orig_savefig = Figure.savefig
def savefig(self, fname, *a, **k):
    t = time.perf_counter()
    try:
        return orig_savefig(self, fname, *a, **k)
    finally:
        key = "  savefig " + str(fname).rsplit(".", 1)[-1]
        times[key] = times.get(key, 0.0) + time.perf_counter() - t
Figure.savefig = savefig
import matplotlib.backends.backend_pdf as backend_pdf
import matplotlib.mathtext as mathtext
wrap(backend_pdf.PdfFile, "embedTTF", "    PDF font subsetting (fontTools)")
wrap(mathtext.MathTextParser, "parse", "  (in the above: mathtext parsing, all figures and formats)")
from inertiafit.cli import main
import contextlib, io
T1 = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    rc = main(sys.argv[2:])
T_MAIN = time.perf_counter() - T1
unwrapped = sorted(
    f"{name}.{key} is the unwrapped {originals[id(value)][1]}"
    for name, m in list(sys.modules.items()) if name.split(".")[0] == "inertiafit"
    for key, value in list(vars(m).items()) if id(value) in originals
    and value is originals[id(value)][0]
)
if unwrapped:
    sys.exit("benchmarks/end_to_end.py: calls not timed: " + "; ".join(unwrapped))
json.dump({"rc": rc, "import": T_IMPORT, "main": T_MAIN, "total": time.perf_counter() - T0,
           "stages": times}, open(sys.argv[1], "w"))
"""
)

PROFILE_CHILD = (
    WITHOUT_DASK
    + r"""
import cProfile, pstats, sys, contextlib, io
prof = cProfile.Profile()
prof.enable()
from inertiafit.cli import main
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    main(sys.argv[2:])
prof.disable()
prof.dump_stats(sys.argv[1])
"""
)


def timed_child(cmd: list[str]) -> tuple[float, float, float]:
    """Wall time (s), peak resident memory (MB) and CPU time (s) of one child process.

    The peak comes from GNU time's ``%M`` where it exists: a child forked straight from this
    (large) process would inherit this process's peak in its ``ru_maxrss`` through fork. The
    CPU time (user + system) is the child's and its children's (the figure workers), from
    ``os.wait4``.
    """
    gnu_time = shutil.which("time") or (
        "/usr/bin/time" if Path("/usr/bin/time").exists() else None
    )
    with tempfile.NamedTemporaryFile(suffix=".rss") as rss:
        full = [gnu_time, "-f", "%M", "-o", rss.name, *cmd] if gnu_time else cmd
        t0 = time.perf_counter()
        proc = subprocess.Popen(full, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - t0
        err = proc.stderr.read().decode() if proc.stderr else ""
        if proc.stderr:
            proc.stderr.close()
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            raise RuntimeError(f"{cmd} failed ({proc.returncode}):\n{err[-2000:]}")
        text = Path(rss.name).read_text(encoding="utf-8").split()
        kib = int(text[-1]) if gnu_time and text else usage.ru_maxrss  # KiB on Linux
    return seconds, kib / 1024, usage.ru_utime + usage.ru_stime


def run_command(manifest: Path, out: Path, *, dask: bool = False) -> list[str]:
    """``inertiafit run``; without Dask (hidden) unless ``dask``."""
    hide = "" if dask else WITHOUT_DASK + "; "
    code = hide + "import sys; from inertiafit.cli import main; sys.exit(main())"
    return [sys.executable, "-c", code, "run", str(manifest), "--out", str(out)]


def top_entries(prof_file: Path, n: int) -> list[dict]:
    import pstats

    stats = pstats.Stats(str(prof_file))
    rows = []
    for (fname, line, func), (_, ncalls, tottime, cumtime, _) in stats.stats.items():
        short = "/".join(Path(fname).parts[-2:]) if fname != "~" else ""
        rows.append(
            {
                "function": f"{short}:{line}({func})" if short else func,
                "ncalls": ncalls,
                "tottime": tottime,
                "cumtime": cumtime,
            }
        )
    rows.sort(key=lambda r: -r["tottime"])
    return rows[:n]


def run(*, quick: bool = False, seed: int = 11) -> dict:
    from inertiafit.pipeline.batch import dask_installed
    from inertiafit.simulate import paper_study

    # Interleaved rounds (floor, run, floor, run, ...) and the median of the rounds' ratios.
    # The best of each side (before) still moved with the machine: 3.75x, 3.98x and 4.10x in
    # three runs of the same code with one of each, the floor alone between 3.2 and 3.6 s, and
    # 5.9x in a quick run on the busy machine.
    with tempfile.TemporaryDirectory(prefix="inertiafit-bench-") as tmp:
        tmpdir = Path(tmp)
        manifest = paper_study(tmpdir / "study", seed=seed)
        out = tmpdir / "out"
        floor_cmd = [sys.executable, "-c", FLOOR_IMPORTS]
        timed_child(floor_cmd)  # warm the page cache for both
        if not quick:
            timed_child(run_command(manifest, out))
        runs, floors, with_dask = [], [], []
        dask = dask_installed() and not quick  # installed here: `run` with Dask timed as well
        load_before = load_text()
        for _ in range(ROUNDS):
            floors.append(timed_child(floor_cmd))
            shutil.rmtree(out, ignore_errors=True)
            runs.append(timed_child(run_command(manifest, out)))
            if dask:
                shutil.rmtree(out, ignore_errors=True)
                with_dask.append(timed_child(run_command(manifest, out, dask=True)))
        load_after = load_text()
        outputs = sorted(p.name for p in out.iterdir())
        stage_file = tmpdir / "stages.json"
        subprocess.run(
            [
                sys.executable,
                "-c",
                STAGES_CHILD,
                str(stage_file),
                "run",
                str(manifest),
                "--out",
                str(tmpdir / "out-stages"),
            ],
            check=True,
        )
        stages = json.loads(stage_file.read_text(encoding="utf-8"))
        if stages["rc"]:
            raise RuntimeError(f"the timed `inertiafit run` exited with {stages['rc']}")
        top = []
        if not quick:  # a profiled run costs ~1.6x a plain one
            prof_file = tmpdir / "run.prof"
            subprocess.run(
                [
                    sys.executable,
                    "-c",
                    PROFILE_CHILD,
                    str(prof_file),
                    "run",
                    str(manifest),
                    "--out",
                    str(tmpdir / "out-prof"),
                ],
                check=True,
            )
            top = top_entries(prof_file, 15)
    run_all, floor_all = [r[0] for r in runs], [r[0] for r in floors]
    ratios = paired_ratios(run_all, floor_all)
    ratio_s = spread(ratios)
    cpu_ratio = spread(paired_ratios([r[2] for r in runs], [r[2] for r in floors]))
    run_sp, floor_sp = spread(run_all), spread(floor_all)
    run_s, floor_s = run_sp["median"], floor_sp["median"]
    run_mb = max(r[1] for r in runs)
    floor_mb = max(r[1] for r in floors)
    ratio = ratio_s["median"]
    dask_all = [r[0] for r in with_dask]
    dask_ratio = median(paired_ratios(dask_all, floor_all)) if with_dask else math.nan
    row = {
        "run_seconds": run_s,
        "run_all": run_all,
        "run_cpu_all": [r[2] for r in runs],
        "run_peak_mb": run_mb,
        "run_peak_mb_all": [r[1] for r in runs],
        "run_with_dask_seconds": median(dask_all) if with_dask else math.nan,
        "run_with_dask_all": dask_all,
        "run_with_dask_ratio": dask_ratio,
        "floor_seconds": floor_s,
        "floor_all": floor_all,
        "floor_cpu_all": [r[2] for r in floors],
        "floor_peak_mb": floor_mb,
        "ratio": ratio,
        "ratios_all": ratios,
        "ratio_low": ratio_s["low"],
        "ratio_high": ratio_s["high"],
        "cpu_ratio": cpu_ratio["median"],
        "load_before": load_before,
        "load_after": load_after,
        "outputs": outputs,
    }
    targets = [
        guard(
            f"run <= {RATIO_TARGET:g}x the import floor (median of {ROUNDS} interleaved rounds)",
            ratio,
            RATIO_TARGET,
            below=True,
            shown=spread_text(ratio_s, unit="x"),
        ),
        guard(
            f"peak memory < {MEMORY_TARGET_MB:g} MB (every run)",
            run_mb,
            MEMORY_TARGET_MB - 1e-9,
            below=True,
            shown=f"{run_mb:.0f} MB",
        ),
    ]
    text = table(
        [
            ("what", "what", ""),
            ("seconds", "median wall (s)", ".2f"),
            ("range", "min-max (s)", ""),
            ("ratio", "ratio", ""),
            ("cpu", "(CPU)", ""),
            ("guard", "guard", ""),
            ("mb", "peak RSS (MB)", ".0f"),
        ],
        [
            {
                "what": "inertiafit run (paper_study)",
                "seconds": run_s,
                "range": f"{run_sp['low']:.2f}-{run_sp['high']:.2f}",
                "ratio": spread_text(ratio_s, unit="x"),
                "cpu": f"{cpu_ratio['median']:.2f}x",
                "guard": f"<= {RATIO_TARGET:g}x: {targets[0]['status']}",
                "mb": run_mb,
            },
            *(
                [
                    {
                        "what": "  the same with Dask installed",
                        "seconds": median(dask_all),
                        "range": f"{min(dask_all):.2f}-{max(dask_all):.2f}",
                        "ratio": f"{dask_ratio:.2f}x",
                        "mb": max(r[1] for r in with_dask),
                    }
                ]
                if with_dask
                else []
            ),
            {
                "what": "floor: python -c 'import ...'",
                "seconds": floor_s,
                "range": f"{floor_sp['low']:.2f}-{floor_sp['high']:.2f}",
                "ratio": "1",
                "mb": floor_mb,
            },
        ],
    )
    text += (
        f"\n{ROUNDS} rounds, the floor and `run` in turn; ratio: the median of the rounds' ratios "
        "(smallest-largest); (CPU): the same in CPU seconds\n(user + system, the child's and its "
        f"figure workers'). Ratio per round: {', '.join(f'{r:.2f}' for r in ratios)}; peak RSS "
        f"per run (MB): {', '.join(f'{r[1]:.0f}' for r in runs)}; load average "
        f"before {load_before}, after {load_after}.\n"
        f"{len(outputs)} output files. `run` as `pip install inertiafit` installs it (no Dask: "
        "hidden from the child); with the `cluster` extra installed (as in this venv) xarray "
        "imports Dask in every run" + (" (timed in full runs only).\n" if not with_dask else ".\n")
    )
    # Stage breakdown: wall clock in one more child; indented stages are inside the one above.
    srows = [
        {
            "stage": "interpreter start (subprocess - in-child total)",
            "seconds": max(run_s - stages["total"], 0.0),
        },
        {"stage": "imports (the floor's modules)", "seconds": stages["import"]},
    ]
    order = [
        "process_study",
        "fit (sampling + DataTree)",
        "  sample (Laplace start + emcee + checks)",
        "    Laplace start",
        "  build_tree",
        "speed_effect",
        "paper_baselines",
        "comparison_table",
        "write_outputs",
        "  corner plots",
        "  plot_fast_trials",
        "  plot_joint_corner",
        "  plot_identification_curve",
        "  plot_trace",
        "  plot_rank",
        "  plot_inertia_by_speed",
        "  savefig pdf",
        "    PDF font subsetting (fontTools)",
        "  savefig png",
        "  (in the above: mathtext parsing, all figures and formats)",
        "  posterior.nc",
        "  report.html",
        "summary tables (all calls)",
    ]
    for key in order:
        if key in stages["stages"]:
            srows.append({"stage": key, "seconds": stages["stages"][key]})
    top_level = sum(
        v
        for k, v in stages["stages"].items()
        if not k.startswith(" ") and not k.startswith("summary")
    )
    srows.append(
        {
            "stage": "rest of main (load, lazy imports, report text)",
            "seconds": stages["main"] - top_level,
        }
    )
    srows.append({"stage": "total in child", "seconds": stages["total"]})
    for r in srows:
        r["share"] = r["seconds"] / stages["total"]
    text += (
        "\nwhere the time of `run` goes (wall clock per stage, one run with the figures drawn "
        "serially, FIGURE_WORKERS = 1, so each is timed):\n"
    )
    text += table(
        [("stage", "stage", ""), ("seconds", "seconds", ".3f"), ("share", "share", ".0%")], srows
    )
    idle = [key.strip() for key in order if key not in stages["stages"]]
    if idle:
        text += f"\nwrapped but not called in this run: {', '.join(idle)}\n"
    if top:
        text += "\n\ncProfile, top entries by own time (profiling inflates the totals):\n"
        text += table(
            [
                ("function", "function", ""),
                ("ncalls", "calls", "d"),
                ("tottime", "own (s)", ".3f"),
            ],
            top,
        )
    return {
        "name": "end_to_end",
        "title": "4. End to end: inertiafit run on paper_study vs the cold-import floor",
        "rows": [row],
        "stages": srows,
        "profile_top": top,
        "table": text,
        "targets": targets,
    }


def main() -> None:
    standalone(
        run, __doc__, seed=11, quick_help="no run with Dask, no profiled run, no warm-up run"
    )


if __name__ == "__main__":
    main()
