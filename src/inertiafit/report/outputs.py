"""Every output file of a result: tables, figures, ``posterior.nc``, Methods, ``report.html``.

:func:`write_outputs` writes the whole set for every command that samples or redraws a
posterior (``inertiafit run``, ``fit``, ``demo``, ``report``). It draws only from a
:class:`~inertiafit.report.result.Result` and never reads trial files.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

from inertiafit.io.outputs import write_csv
from inertiafit.plotting.style import DEFAULT_FORMATS
from inertiafit.report import plots
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
    "idle_cores",
    "write_outputs",
    "write_tables",
]

#: Files written once, when the posterior is sampled; redrawing a report reads them.
DATA_FILES = ("posterior.nc", "trials.csv", "traces.csv", "emg_traces.csv")


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
        plots.save_figure(fig, folder / record.stem, wanted, dpi=150)
    # Embed the PNG just written rather than drawing the figure once more.
    return (folder / f"{record.stem}.png").read_bytes() if "png" in wanted else figure_png(fig)


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
        running = int(LOADAVG.read_text().split()[3].split("/")[0])
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


def draw_figures(
    records: Sequence[FigureRecord],
    folder: Path,
    formats: tuple[str, ...],
    *,
    workers: int | None = None,
    meanwhile: Callable[[], None] | None = None,
) -> dict[str, bytes]:
    """Save every record's figure into ``folder``; the PNG of each for report.html, by stem.

    With more than one worker the figures are drawn in forked processes (each a whole
    figure: drawn, saved, released), in the order given; a figure's files are the same bytes
    whichever process draws it. ``workers`` defaults to :data:`FIGURE_WORKERS`.
    ``meanwhile`` is called in this process while the workers draw (with one worker: before
    the figures are drawn).
    """
    count = _worker_count(len(records), workers)
    if count == 1:
        if meanwhile is not None:
            meanwhile()
        return {r.stem: _draw(r, folder, formats) for r in records}
    from concurrent.futures import ProcessPoolExecutor

    _QUEUE[:] = [(r, folder, formats) for r in records]
    try:
        with warnings.catch_warnings():
            # Python warns that fork() in a process with threads (BLAS's idle pool) may
            # deadlock the child; OpenBLAS starts its pool afresh in a forked child, and the
            # workers only draw and save figures.
            warnings.simplefilter("ignore", DeprecationWarning)
            context = multiprocessing.get_context("fork")
            with ProcessPoolExecutor(count, mp_context=context) as pool:
                futures = [pool.submit(_draw_queued, i) for i in range(len(records))]
                try:
                    if meanwhile is not None:
                        meanwhile()
                    pngs = [f.result() for f in futures]
                except BaseException:
                    pool.shutdown(cancel_futures=True)
                    raise
    finally:
        _QUEUE.clear()
    return {r.stem: png for r, png in zip(records, pngs, strict=True)}


def write_tables(folder: Path, result: Result, *, hdi_prob: float) -> None:
    """summary, identification, comparison and speed_effect as CSV (+ .md, .tex).

    A living body adds ``passive_parameters`` (CSV, .md, .tex) and ``passive.csv`` (the
    passive elastic moment on an angle grid, median and 95 % band).
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


def write_outputs(
    folder: Path,
    result: Result,
    *,
    hdi_prob: float | None = None,
    formats: tuple[str, ...] = DEFAULT_FORMATS,
    save_data: bool = True,
    workers: int | None = None,
) -> list[str]:
    """Every output file into ``folder`` (which must exist); the names written, sorted.

    The tables come with ``methods.md`` and ``references.bib``
    (:func:`~inertiafit.report.methods.write_methods`). ``save_data`` writes
    :data:`DATA_FILES` too (``posterior.nc``, ``trials.csv`` and ``traces.csv``): once, when
    the posterior is sampled; a redraw reads them instead.
    Every figure of :func:`~inertiafit.report.figures.figure_records` is saved in
    ``formats`` (default PNG only; PDF and SVG when asked) by :func:`draw_figures`
    (``workers`` processes) and shown in ``report.html``.
    """
    hdi_prob = result.hdi_prob if hdi_prob is None else hdi_prob
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

    # One figure at a time per process: drawn, saved, its PNG kept for report.html, let go;
    # the tables and data files are written here while worker processes draw.
    records = figure_records(result)
    embedded = draw_figures(
        records, folder, tuple(formats), workers=workers, meanwhile=tables_and_data
    )
    study_report(folder / "report.html", result, embedded, hdi_prob, records)
    return sorted({p.name for p in folder.iterdir()} - before)
