"""Every output file of a result: tables, figures, ``posterior.nc``, ``report.html``.

:func:`write_outputs` writes the whole set (``inertiafit run``, ``demo``, ``report``);
:func:`write_fit_outputs` the compact set of ``inertiafit fit``. Both draw only from a
:class:`~inertiafit.report.result.Result`; neither reads trial files.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

from inertiafit.io.outputs import write_csv
from inertiafit.processing.study import usable_trials
from inertiafit.report import plots
from inertiafit.report.html import figure_png, study_report
from inertiafit.report.result import Result, traces_by_condition
from inertiafit.report.tables import (
    comparison_display,
    speed_effect_display,
    summary_display,
    write_table,
)

__all__ = ["DATA_FILES", "figure_makers", "write_fit_outputs", "write_outputs", "write_tables"]

#: Files written once, when the posterior is sampled; redrawing a report reads them.
DATA_FILES = ("posterior.nc", "trials.csv", "traces.csv")


def _corner_stem(result: Result, body: str) -> str:
    return "corner" if result.from_numbers else f"corner-{body}"


def figure_makers(result: Result) -> dict[str, Callable[[], Any]]:
    """The result's figures by file stem, each as a function that draws it.

    Drawing one figure at a time, saving and dropping it, keeps one figure in memory rather
    than all of them.
    """
    post = result.posterior
    makers: dict[str, Callable[[], Any]] = {}
    for body in post.bodies:
        truths = result.ideals.get(body) or None
        makers[_corner_stem(result, body)] = functools.partial(post.corner, body, truths=truths)
        makers[f"identification-{body}"] = functools.partial(
            plots.plot_identification_curve, post, body, baseline=result.baselines.get(body)
        )
        makers[f"trace-{body}"] = functools.partial(plots.plot_trace, post, body)
        makers[f"rank-{body}"] = functools.partial(plots.plot_rank, post, body)
    if len(post.bodies) > 1:
        makers["corner-joint"] = functools.partial(
            plots.plot_joint_corner, post, truths=result.ideals or None
        )
    for cond, traces in traces_by_condition(result.traces).items():
        makers[f"fast-trials-{cond}"] = functools.partial(
            plots.plot_fast_trials, traces, title=cond
        )
    used = usable_trials(result.trials)  # a skipped trial has no inertia to draw
    fast = used[used["kind"] == "fast"]
    if len(fast):
        makers["inertia-by-speed"] = functools.partial(plots.plot_inertia_by_speed, fast)
    return makers


def write_tables(folder: Path, result: Result, *, hdi_prob: float) -> None:
    """summary, identification, comparison and speed_effect as CSV (+ .md, .tex)."""
    post = result.posterior
    summary = post.summary(hdi_prob)
    write_table(
        summary,
        folder,
        "summary",
        display=summary_display(summary),
        caption=f"Posterior of every body: median and {100 * hdi_prob:g}% HDI.",
    )
    write_table(
        post.identification(),
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


def write_outputs(
    folder: Path,
    result: Result,
    *,
    hdi_prob: float | None = None,
    formats: tuple[str, ...] = ("pdf", "png"),
    save_data: bool = True,
) -> list[str]:
    """Every output file into ``folder`` (which must exist); the names written, sorted.

    ``save_data`` writes :data:`DATA_FILES` too (``posterior.nc``, ``trials.csv`` and
    ``traces.csv``): once, when the posterior is sampled; a redraw reads them instead.
    """
    hdi_prob = result.hdi_prob if hdi_prob is None else hdi_prob
    before = {p.name for p in folder.iterdir()}
    write_tables(folder, result, hdi_prob=hdi_prob)
    if save_data:
        result.posterior.save(folder / "posterior.nc")
        if len(result.trials):
            write_csv(result.trials, folder / "trials.csv")
        if len(result.traces):
            write_csv(result.traces, folder / "traces.csv")
    # One figure at a time: drawn, saved, its PNG kept for report.html, then let go.
    embedded: dict[str, bytes] = {}
    for stem, make in figure_makers(result).items():
        fig = make()
        plots.save_figure(fig, folder / stem, formats, dpi=150)
        # Embed the PNG just written rather than drawing the figure once more.
        embedded[stem] = (
            (folder / f"{stem}.png").read_bytes() if "png" in formats else figure_png(fig)
        )
        del fig
    study_report(folder / "report.html", result, embedded, hdi_prob)
    return sorted({p.name for p in folder.iterdir()} - before)


def write_fit_outputs(folder: Path, result: Result) -> None:
    """``inertiafit fit``: the compact set of outputs of one body fitted from numbers.

    ``summary.csv``, ``identification.csv``, ``comparison.csv``, ``posterior.nc`` and
    ``corner.pdf``/``.png`` into ``folder``.
    """
    post = result.posterior
    write_csv(post.summary(result.hdi_prob), folder / "summary.csv")
    write_csv(post.identification(), folder / "identification.csv")
    write_csv(result.comparison[result.comparison_columns], folder / "comparison.csv")
    post.save(folder / "posterior.nc")
    fig = post.corner()
    plots.save_figure(fig, folder / "corner", ("pdf", "png"), dpi=150)
