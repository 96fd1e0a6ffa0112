"""Every output file of a result: tables, figures, ``posterior.nc``, Methods, ``report.html``.

:func:`write_outputs` writes the whole set for every command that samples or redraws a
posterior (``inertiafit run``, ``fit``, ``demo``, ``report``). It draws only from a
:class:`~inertiafit.report.result.Result` and never reads trial files. Every path the result
holds into an output folder still being staged (the demo's simulated study, read from inside
its own output) is written as its final path (:func:`~inertiafit.io.outputs.final_text`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import multiprocessing
import os
import signal
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import pandas as pd

from inertiafit.io.outputs import final_text, write_csv
from inertiafit.plotting.style import DEFAULT_FORMATS, save_figure
from inertiafit.report.figures import FigureRecord, figure_records
from inertiafit.report.html import figure_png, study_report
from inertiafit.report.methods import write_methods
from inertiafit.report.result import Result
from inertiafit.report.tables import (
    comparison_display,
    passive_display,
    speed_effect_display,
    summary_display,
    write_table,
)

__all__ = [
    "DATA_FILES",
    "FIGURE_WORKERS",
    "draw_figures",
    "figure_workers",
    "idle_cores",
    "with_final_paths",
    "write_outputs",
    "write_tables",
]

#: Files written once, when the posterior is sampled; redrawing a report reads them.
DATA_FILES = ("posterior.nc", "trials.csv", "traces.csv", "emg_traces.csv", "sweeps.csv")


#: Figures are drawn and saved in up to this many forked processes (Linux; one where fork is
#: unavailable, in a daemonic process such as a Dask worker, or on one core). By default no
#: more than the cores other processes leave idle now (:func:`idle_cores`): on a busy machine each
#: forked worker would import matplotlib and corner again for no gain in time (measured: 23 %
#: more CPU for the command tests, which run one per core).
FIGURE_WORKERS = 2

# The figures a pool of forked workers draws, by index: set before the pool forks, so the
# workers inherit the records (their draw functions need not be pickled).
_QUEUE: list[tuple[FigureRecord, Path, tuple[str, ...]]] = []


def _draw(record: FigureRecord, folder: Path, formats: tuple[str, ...]) -> bytes:
    """Draw, save and release one figure; its PNG for report.html."""
    fig = record.make()
    wanted = record.formats_of(formats)
    if wanted:
        save_figure(fig, folder / record.stem, wanted)
    # Embed the PNG just written rather than drawing the figure once more.
    png = (folder / f"{record.stem}.png").read_bytes() if "png" in wanted else figure_png(fig)
    # A figure's artists refer to each other in cycles, which only the collector frees, and
    # it ran too seldom: each 300-dpi figure's buffers stayed alive into the next (a study's
    # twelve figures drawn in one process grew its memory from 303 to 390 MB; collected
    # after each, it stays at 321 MB). The heap from before the figures is frozen
    # (:func:`_frozen_heap`), so this collection scans the figure's objects only: over the
    # whole heap it took 0.17 s a figure.
    del fig
    gc.collect()
    return png


@contextlib.contextmanager
def _frozen_heap() -> Iterator[None]:
    """The objects alive now left out of every collection until the block ends.

    :func:`_draw` collects after each figure; with the posterior, its trees and the
    libraries' modules in the heap each full collection scanned them all again. Frozen
    (``gc.freeze``, after one last collection), they are skipped; forked workers inherit the
    frozen heap, and their collections then do not touch (and copy) the parent's pages.
    """
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _draw_queued(index: int) -> bytes:
    return _draw(*_QUEUE[index])


#: Where Linux says how many processes are running this instant (the 4th field, ``r/total``).
LOADAVG = Path("/proc/loadavg")


def idle_cores() -> int:
    """Cores this process may use that others leave idle now: at least 1.

    The cores it may run on less the processes running besides it, as the kernel counts them
    this instant (``/proc/loadavg``'s running count, which includes this process; it waits
    while the figures are drawn, so its core is counted as free). Where that count cannot be
    read, every core.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = cores or 1
    try:
        running = int(LOADAVG.read_text(encoding="utf-8").split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return cores
    return max(1, min(cores, cores - (running - 1)))


def _worker_count(figures: int, workers: int | None) -> int:
    if workers is None:
        workers = min(FIGURE_WORKERS, idle_cores()) if sys.platform.startswith("linux") else 1
    if workers < 2 or figures < 2 or not sys.platform.startswith("linux"):
        return 1
    if multiprocessing.current_process().daemon:  # may not have children (a Dask worker)
        return 1
    return min(workers, figures, len(os.sched_getaffinity(0)))


def _start_worker(warm: bool) -> None:
    """A figure worker's start: Ctrl-C left to the parent; with ``warm``, matplotlib readied.

    Ctrl-C in a terminal reaches every process of the command; the parent stops the workers
    (after the figure each is drawing) and says "interrupted", where each worker would print
    a traceback. ``warm`` imports corner and draws a small figure with mathtext, so the
    fonts, the text and mathtext engines and the PNG writer are loaded before the first
    figure.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if not warm:
        return
    import io

    import corner  # noqa: F401  # the corner plots' library, imported once per worker
    from matplotlib.figure import Figure

    from inertiafit.plotting.style import style_context

    with style_context():
        fig = Figure(figsize=(1.0, 1.0))
        fig.add_subplot().set_xlabel(r"$\rho$ [m]")
        fig.savefig(io.BytesIO(), format="png", dpi=20)
    del fig
    gc.collect()
    gc.freeze()  # the libraries' objects: out of the collection after each figure


def _fork_pool(count: int, *, warm: bool = False) -> Executor:
    """A pool of ``count`` worker processes, forked now (:func:`_start_worker` in each)."""
    from concurrent.futures import ProcessPoolExecutor

    pool = ProcessPoolExecutor(
        count,
        mp_context=multiprocessing.get_context("fork"),
        initializer=_start_worker,
        initargs=(warm,),
    )
    with warnings.catch_warnings():
        # Python warns that fork() in a process with threads (BLAS's idle pool) may deadlock
        # the child; OpenBLAS starts its pool afresh in a forked child, and the workers only
        # draw and save figures. A process is forked when a task is submitted.
        warnings.simplefilter("ignore", DeprecationWarning)
        for _ in range(count):
            pool.submit(os.getpid)
    return pool


@contextlib.contextmanager
def figure_workers(workers: int | None = None) -> Iterator[Executor | None]:
    """Start the processes that will draw a result's figures, before the result exists.

    Forked at once, each imports corner and readies matplotlib (about a second) while this
    process goes on reading trials and sampling; pass what this yields to
    :func:`write_outputs` (``pool``) inside the block. Yields ``None`` where the figures are
    drawn in this process (one worker: see :data:`FIGURE_WORKERS`); the workers stop when
    the block ends.
    """
    count = _worker_count(FIGURE_WORKERS, workers)
    if count == 1:
        yield None
        return
    pool = _fork_pool(count, warm=True)
    try:
        yield pool
    finally:
        pool.shutdown(cancel_futures=True)


def draw_figures(
    records: Sequence[FigureRecord],
    folder: Path,
    formats: tuple[str, ...],
    *,
    workers: int | None = None,
    meanwhile: Callable[[], None] | None = None,
    pool: Executor | None = None,
) -> dict[str, bytes]:
    """Save every record's figure into ``folder``; the PNG of each for report.html, by stem.

    With more than one worker the figures are drawn in forked processes (each a whole
    figure: drawn, saved, released), in the order given; a figure's files are the same bytes
    whichever process draws it. ``workers`` defaults to :data:`FIGURE_WORKERS`.
    ``pool`` (from :func:`figure_workers`) draws them in workers started earlier: the records
    are pickled to them. ``meanwhile`` is called in this process while the workers draw
    (with one worker: before the figures are drawn).
    """
    calls: list[tuple[Callable[..., bytes], tuple]]
    if pool is not None:
        calls = [(_draw, (r, folder, formats)) for r in records]
        return _draw_in(pool, records, calls, meanwhile)
    count = _worker_count(len(records), workers)
    if count == 1:
        if meanwhile is not None:
            meanwhile()
        with _frozen_heap():
            return {r.stem: _draw(r, folder, formats) for r in records}
    # Forked after the records exist: the workers inherit them (their draw functions need
    # not be pickled).
    _QUEUE[:] = [(r, folder, formats) for r in records]
    try:
        with _frozen_heap():
            forked = _fork_pool(count)
        try:
            calls = [(_draw_queued, (i,)) for i in range(len(records))]
            return _draw_in(forked, records, calls, meanwhile)
        finally:
            forked.shutdown(cancel_futures=True)
    finally:
        _QUEUE.clear()


def _draw_in(
    pool: Executor,
    records: Sequence[FigureRecord],
    calls: Sequence[tuple[Callable[..., bytes], tuple]],
    meanwhile: Callable[[], None] | None,
) -> dict[str, bytes]:
    """Each call (a function drawing one record, its arguments) run in ``pool``.

    ``meanwhile`` runs in this process while they draw.
    """
    futures = [pool.submit(fn, *args) for fn, args in calls]
    try:
        if meanwhile is not None:
            meanwhile()
        pngs = [f.result() for f in futures]
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    return {r.stem: png for r, png in zip(records, pngs, strict=True)}


def write_tables(folder: Path, result: Result, *, hdi_prob: float) -> None:
    """summary, identification, comparison and speed_effect as CSV (+ .md, .tex).

    A living body adds ``passive_parameters`` (CSV, .md, .tex), ``passive.csv`` (the
    passive elastic moment on an angle grid, median and 95 % band, and the static moment of
    each posture) and ``static_fit.csv`` (each quasi-static and rest trial beside the fit).
    """
    summary = result.summary(hdi_prob)
    write_table(
        summary,
        folder,
        "summary",
        display=summary_display(summary),
        caption=f"Posterior of every body: median and {100 * hdi_prob:g}% HDI.",
    )
    write_table(
        result.identification(),
        folder,
        "identification",
        caption="Posterior SD over prior SD: who decides each parameter.",
    )
    write_table(
        result.comparison[result.comparison_columns],
        folder,
        "comparison",
        display=comparison_display(result.comparison, hdi_prob),
        caption="Ideal bodies, the posterior and the paper's multi-start estimator.",
    )
    if len(result.trials):
        write_table(
            result.speed_effect,
            folder,
            "speed_effect",
            display=speed_effect_display(result.speed_effect),
            caption="Inertia per condition and speed; one-way ANOVA across speeds.",
        )
    if result.living:
        write_table(
            result.living["passive_parameters"],
            folder,
            "passive_parameters",
            display=passive_display(result.living["passive_parameters"]),
            caption=(
                "The living joint: passive elastic coefficients, hysteresis, viscous damping, "
                "postures, and what decided each living condition's gravity moment (95% intervals)."
            ),
        )
        write_csv(result.living["passive_curve"], folder / "passive.csv")
        if "static_fit" in result.living:
            write_csv(result.living["static_fit"], folder / "static_fit.csv")


def _final_frame(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with :func:`final_text` applied to its text columns (a copy if it changes)."""
    out = frame
    for column in frame.columns:
        if frame[column].dtype != object:
            continue
        mapped = frame[column].map(lambda v: final_text(v) if isinstance(v, str) else v)
        if not mapped.equals(frame[column]):
            out = out.copy() if out is frame else out
            out[column] = mapped
    return out


def with_final_paths(result: Result) -> Result:
    """``result`` with every path into a staging folder written as its final path.

    The texts written from it: the posterior's attributes (``inputs``, ``provenance``), the
    warnings, the manifest and the tables' text columns. The same ``result`` when nothing is
    being staged or nothing names a staging folder.
    """
    tree = result.posterior.tree
    renamed = {
        node.path: {k: final_text(v) if isinstance(v, str) else v for k, v in node.attrs.items()}
        for node in tree.subtree
    }
    changed_attrs = any(renamed[n.path] != dict(n.attrs) for n in tree.subtree)
    posterior = result.posterior
    if changed_attrs:
        copy = tree.copy(deep=False)
        for node in copy.subtree:
            node.attrs = renamed[node.path]
        posterior = type(posterior)(copy)
    changes: dict[str, Any] = {
        "warnings": tuple(final_text(w) for w in result.warnings),
        "manifest": final_text(result.manifest),
        "trials": _final_frame(result.trials),
        "living": {k: _final_frame(v) for k, v in result.living.items()},
    }
    same = (
        not changed_attrs
        and changes["warnings"] == result.warnings
        and changes["manifest"] == result.manifest
        and changes["trials"] is result.trials
        and all(changes["living"][k] is v for k, v in result.living.items())
    )
    return result if same else dataclasses.replace(result, posterior=posterior, **changes)


def write_outputs(
    folder: Path,
    result: Result,
    *,
    hdi_prob: float | None = None,
    formats: tuple[str, ...] = DEFAULT_FORMATS,
    save_data: bool = True,
    workers: int | None = None,
    pool: Executor | None = None,
) -> list[str]:
    """Every output file into ``folder`` (which must exist); the names written, sorted.

    The tables come with ``methods.md`` and ``references.bib``
    (:func:`~inertiafit.report.methods.write_methods`). ``save_data`` writes
    :data:`DATA_FILES` too (``posterior.nc``, ``trials.csv`` and ``traces.csv``): once, when
    the posterior is sampled; a redraw reads them instead.
    Every figure of :func:`~inertiafit.report.figures.figure_records` is saved in
    ``formats`` (default PNG only; PDF and SVG when asked) by :func:`draw_figures`
    (``workers`` processes, or the workers of ``pool`` from :func:`figure_workers`) and
    shown in ``report.html``.
    """
    hdi_prob = result.hdi_prob if hdi_prob is None else hdi_prob
    result = with_final_paths(result)
    before = {p.name for p in folder.iterdir()}

    def tables_and_data() -> None:
        write_tables(folder, result, hdi_prob=hdi_prob)
        write_methods(folder, result)
        if save_data:
            result.posterior.save(folder / "posterior.nc")
            if len(result.trials):
                write_csv(result.trials, folder / "trials.csv")
            if len(result.traces):
                write_csv(result.traces, folder / "traces.csv")
            if len(result.emg_traces):  # a study with EMG only
                write_csv(result.emg_traces, folder / "emg_traces.csv")
            if len(result.sweeps):  # a rigid condition's sweeps
                write_csv(result.sweeps, folder / "sweeps.csv")

    # One figure at a time per process: drawn, saved, its PNG kept for report.html, let go;
    # the tables and data files are written here while worker processes draw.
    records = figure_records(result)
    embedded = draw_figures(
        records, folder, tuple(formats), workers=workers, meanwhile=tables_and_data, pool=pool
    )
    study_report(folder / "report.html", result, embedded, hdi_prob, records)
    return sorted({p.name for p in folder.iterdir()} - before)
