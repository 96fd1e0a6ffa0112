"""A living joint's figures: its passive moment, its static fit, its fast trials' windows.

The passive elastic moment with the gravity moment beside it; each quasi-static and rest
trial against the static fit; a living condition's fast trials with both windows their
inertia and viscous damping were fitted over.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.plotting.style import (
    PALETTE,
    PRIOR_COLOUR,
    figure_width,
    new_figure,
    style_context,
)
from inertiafit.report.plots.trials import plot_fast_trials

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = [
    "DECELERATION_GID",
    "deceleration_spans",
    "plot_living_fast_trials",
    "plot_passive_curve",
    "plot_static_fit",
]

#: ``gid`` of each shaded deceleration window (``"deceleration-window:<speed>"``).
DECELERATION_GID = "deceleration-window"


def deceleration_spans(traces: Sequence[dict]) -> dict[float, tuple[float, float]]:
    """Per preset speed, the deceleration window drawn: ``(start, end)`` (s) from window start.

    The median over the speed's trials of each trial's deceleration window on the time axis
    of :func:`~inertiafit.report.plots.plot_fast_trials` (its own uniform-acceleration
    window's start at 0), as that figure draws one acceleration window per speed.
    """
    out = {}
    for speed in sorted({float(t["speed"]) for t in traces}):
        spans = [
            (t["deceleration"][0] - t["window"][0], t["deceleration"][1] - t["window"][0])
            for t in traces
            if float(t["speed"]) == speed and t.get("deceleration") is not None
        ]
        if spans:
            lo, hi = np.median(np.asarray(spans, dtype=np.float64), axis=0)
            out[speed] = (float(lo), float(hi))
    return out


def plot_living_fast_trials(
    traces: Sequence[dict], *, title: str = "", fig: Figure | None = None, width="double"
) -> Figure:
    """A living condition's fast trials: both windows the inertia and damping were fitted over.

    :func:`~inertiafit.report.plots.plot_fast_trials` with, per preset speed, the
    uniform-deceleration window shaded and hatched beside the acceleration window (the
    median over the speed's trials, :func:`deceleration_spans`): a living body's fast trial
    is fitted for ``I`` and the viscous damping ``b`` over both, which tells ``b omega`` from
    ``I alpha`` (the acceleration changes sign, the speed does not).

    Parameters
    ----------
    traces : sequence of dict
        As :func:`~inertiafit.report.plots.plot_fast_trials` takes them, each with its
        ``deceleration`` window ``(start, end)`` (s, the trial's clock), where it has one.
    title : str
        Figure title (the condition).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Journal column or inches.
    """
    fig = plot_fast_trials(traces, fig=fig, width=width)
    speeds = sorted({float(t["speed"]) for t in traces})
    colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
    with style_context():
        for speed, (lo, hi) in deceleration_spans(traces).items():
            for ax in fig.axes[:2]:
                span = ax.axvspan(
                    lo, hi, facecolor=colour[speed], edgecolor=colour[speed], alpha=0.15,
                    hatch="///", lw=0,
                )  # fmt: skip
                span.set_gid(f"{DECELERATION_GID}:{speed:g}")
        if title:
            fig.suptitle(  # two lines: one would run off a page-wide figure
                f"{title}: fast trials, I and b fitted over both windows\n"
                "shaded = uniform-acceleration windows, hatched = deceleration windows"
            )
    return fig


def plot_passive_curve(
    curve: pd.DataFrame, *, fig: Figure | None = None, width="single"
) -> Figure:
    """The passive elastic moment against the joint angle: median, 95 % band, prior band.

    Each living condition's gravity moment is drawn beside it, both relative to their value at
    the middle of the swept range (a constant of the passive curve is not identified).

    Parameters
    ----------
    curve : pandas.DataFrame
        ``passive.csv`` (:meth:`~inertiafit.processing.living.LivingStatics.passive_curve`).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Journal column or inches.
    """
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, 0.75 * w))
        ax = fig.add_subplot()
        x = curve["joint_angle"].to_numpy()
        ax.fill_between(
            x,
            curve["prior_lower"],
            curve["prior_upper"],
            color=PRIOR_COLOUR,
            alpha=0.15,
            lw=0,
            label="passive prior (95%)",
        )
        ax.fill_between(
            x, curve["lower"], curve["upper"], color=PALETTE[0], alpha=0.35, lw=0, label="95% band"
        )
        ax.plot(x, curve["median"], color=PALETTE[0], label="passive elastic moment")
        gravity = [c for c in curve.columns if c.startswith("gravity:")]
        for k, column in enumerate(gravity):
            ax.plot(
                x,
                curve[column],
                color=PALETTE[1 + k % (len(PALETTE) - 1)],
                ls="--",
                label=f"gravity moment, {column.removeprefix('gravity:')}",
            )
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.set_xlabel("joint angle [deg]")
        ax.set_ylabel("moment, 0 at mid-range [N m]")
        ax.legend(loc="best", fontsize="small", frameon=False)
    return fig


def plot_static_fit(
    points: pd.DataFrame, curve: pd.DataFrame, *, fig: Figure | None = None, width="double"
) -> Figure:
    """Each quasi-static and rest trial against the fitted static model, and what it left.

    Top: the static moment of each condition and posture (the midline between the sweep
    directions, with its 95 % band), each sweep's samples (means of consecutive samples,
    triangles pointing the way it moved) and each rest hold (a diamond, its bar the band
    ``+-h`` a joint at rest may hold within). Bottom: the residuals, measured minus fitted
    (a hold's: from the midline), against the joint angle.

    Parameters
    ----------
    points : pandas.DataFrame
        ``static_fit.csv`` (:attr:`~inertiafit.processing.living.LivingStatics.fit_points`).
    curve : pandas.DataFrame
        ``passive.csv``, for its ``static:`` columns.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Journal column or inches.
    """
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, 0.6 * w))
        top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (2, 1)})
        x = curve["joint_angle"].to_numpy()
        keys = [c.removeprefix("static:") for c in curve.columns if c.startswith("static:")]
        colours = {k: PALETTE[i % len(PALETTE)] for i, k in enumerate(keys)}
        for key in keys:
            colour = colours[key]
            top.fill_between(
                x,
                curve[f"static_lower:{key}"],
                curve[f"static_upper:{key}"],
                color=colour,
                alpha=0.25,
                lw=0,
            )
            top.plot(
                x, curve[f"static:{key}"], color=colour, lw=1.0, label=f"static moment, {key}"
            )
        for (cond, posture, _), trial in points.groupby(
            ["condition", "posture", "source"], sort=False
        ):
            key = f"{cond}@{posture}" if posture else cond
            colour = colours.get(key, PALETTE[0])
            angle = trial["joint_angle"].to_numpy()
            if (trial["kind"] == "rest").all():
                for ax, y in ((top, trial["measured"]), (bottom, trial["residual"])):
                    ax.errorbar(
                        angle, y, yerr=trial["allowed"], fmt="D", ms=4, color=colour,
                        mec="k", mew=0.5, elinewidth=0.8, capsize=2,
                    )  # fmt: skip
                continue
            marker = "^" if int(trial["direction"].iloc[0]) > 0 else "v"
            top.plot(angle, trial["measured"], marker, ms=2.5, color=colour, alpha=0.6, mew=0)
            bottom.plot(angle, trial["residual"], marker, ms=2.5, color=colour, alpha=0.6, mew=0)
        bottom.axhline(0.0, color="0.4", lw=0.6)
        top.set_ylabel("moment [N m]")
        bottom.set_ylabel("residual [N m]")
        bottom.set_xlabel("joint angle [deg]")
        from matplotlib.lines import Line2D

        handles = top.get_legend_handles_labels()[0] + [
            Line2D([], [], ls="", marker="^", color="0.3", label="sweep, angle increasing"),
            Line2D([], [], ls="", marker="v", color="0.3", label="sweep, angle decreasing"),
            Line2D([], [], ls="", marker="D", color="0.3", mec="k", label="rest hold (bar: +-h)"),
        ]
        top.legend(handles=handles, loc="best", fontsize="small", frameon=False)
    return fig
