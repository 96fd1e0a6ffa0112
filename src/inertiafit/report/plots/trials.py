"""Figures of the trials: fast trials with their windows (cf. Fig. 4), inertia by speed (Fig. 5)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.plotting.style import PALETTE, figure_width, new_figure, style_context

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["plot_fast_trials", "plot_inertia_by_speed"]


def plot_fast_trials(
    traces: Sequence[dict], *, title: str = "", fig: Figure | None = None, width="double"
) -> Figure:
    """Velocity and acceleration of fast trials with the detected windows shaded (cf. Fig. 4).

    Parameters
    ----------
    traces : sequence of dict
        One per trial: ``time`` (s), ``velocity`` (rad/s), ``acceleration`` (rad/s^2), ``speed``
        (nominal deg/s), ``window`` ``(start, end)`` (s). Times are shown from the window start
        of each trial's own clock, so trials line up.
    title : str
        Figure title (the condition).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels sharing the time axis: velocity (deg/s) and acceleration (deg/s^2).
    """
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, 0.6 * w if w < 5 else 0.5 * w))
        ax_v, ax_a = fig.subplots(2, 1, sharex=True)
        speeds = sorted({float(t["speed"]) for t in traces})
        colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
        labelled = set()
        for t in traces:
            time = np.asarray(t["time"]) - float(t["window"][0])
            s = float(t["speed"])
            label = None if s in labelled else f"{s:g} °/s"
            labelled.add(s)
            ax_v.plot(time, np.degrees(t["velocity"]), color=colour[s], lw=0.5, alpha=0.7,
                      label=label)  # fmt: skip
            ax_a.plot(time, np.degrees(t["acceleration"]), color=colour[s], lw=0.5, alpha=0.7)
        for s in speeds:  # one band per speed: the median window of its trials
            span = float(
                np.median(
                    [t["window"][1] - t["window"][0] for t in traces if float(t["speed"]) == s]
                )
            )
            for ax in (ax_v, ax_a):
                ax.axvspan(0.0, span, color=colour[s], alpha=0.10, lw=0)
        ax_v.set_ylabel("velocity [°/s]")
        ax_a.set_ylabel("acceleration [°/s²]")
        ax_a.set_xlabel("time from window start [s]")
        if speeds:  # beside the panels: inside, it covered the braking curves
            fig.legend(*ax_v.get_legend_handles_labels(), loc="outside right upper",
                       title="preset speed")  # fmt: skip
        if title:
            fig.suptitle(f"{title}: fast trials, shaded = detected uniform-acceleration windows")
    return fig


def plot_inertia_by_speed(
    trials: pd.DataFrame, *, fig: Figure | None = None, width="double"
) -> Figure:
    """Per-trial inertia against nominal speed, one panel per condition (cf. Fig. 5).

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns ``condition``, ``speed`` (deg/s), ``inertia`` (kg m^2): the fast trials.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A panel per condition: trials (dots, jittered) and mean ± SD (square) per speed.
    """
    conditions = list(dict.fromkeys(trials["condition"]))
    n = max(1, len(conditions))
    w = figure_width(width)
    ncols = min(n, max(1, int(w // 1.7)))
    nrows = math.ceil(n / ncols)
    with style_context():
        fig = new_figure(fig, (w, nrows * min(2.4, 0.85 * w / ncols) + 0.2))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
        rng = np.random.default_rng(0)  # jitter only; deterministic figure
        for ax, cond in zip(axes, conditions, strict=False):
            sub = trials[trials["condition"] == cond]
            speeds = sorted(sub["speed"].unique())
            for i, s in enumerate(speeds):
                y = sub.loc[sub["speed"] == s, "inertia"].to_numpy()
                x = np.full(len(y), float(i)) + rng.uniform(-0.12, 0.12, len(y))
                ax.plot(x, y, "o", ms=2.5, color=PALETTE[0], alpha=0.6, mew=0)
                sd = y.std(ddof=1) if len(y) > 1 else 0.0
                ax.errorbar(i + 0.3, y.mean(), yerr=sd, fmt="s", color=PALETTE[1], ms=3.5,
                            capsize=2, lw=0.8)  # fmt: skip
            ax.set_xticks(range(len(speeds)), [f"{s:g}" for s in speeds])
            ax.set_xlim(-0.5, len(speeds) - 0.3)
            ax.set_xlabel("speed [°/s]")
            ax.set_ylabel("inertia $I$ [kg m$^2$]")
            ax.set_title(str(cond))
        for ax in axes[len(conditions) :]:
            ax.set_visible(False)
    return fig
