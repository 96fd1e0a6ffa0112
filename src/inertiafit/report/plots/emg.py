"""The EMG check's figure: each fast trial's envelope against its threshold, per condition."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from inertiafit.plotting.style import PALETTE, figure_width, new_figure, style_context

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["plot_emg_envelopes"]

#: Colour of a trial by its status: kept trials blue, flagged orange, excluded vermilion.
_STATUS_COLOUR = {"ok": PALETTE[0], "flagged": PALETTE[4], "excluded": PALETTE[1]}


def plot_emg_envelopes(
    traces: pd.DataFrame, *, title: str = "", fig: Figure | None = None, width="double"
) -> Figure:
    """EMG envelopes over the rest level of a condition's fast trials, with their thresholds.

    Parameters
    ----------
    traces : pandas.DataFrame
        Rows of one condition (columns of
        :data:`~inertiafit.processing.study.EMG_TRACE_COLUMNS`): ``trial``, ``muscle``,
        ``time`` (s after the motion's onset), ``ratio`` (envelope over the rest level),
        ``threshold``, ``active`` and ``status``.
    title : str
        Figure title (the condition).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A panel per muscle (log scale): every trial's envelope (kept trials thin blue,
        flagged orange, excluded vermilion), the threshold dashed, and the active stretches
        that made a trial excluded or flagged shaded in its colour.
    """
    muscles = list(dict.fromkeys(str(m) for m in traces["muscle"]))
    n = max(1, len(muscles))
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, min(1.9 * n + 0.5, 9.0)))
        axes = np.atleast_1d(fig.subplots(n, 1, sharex=True, squeeze=False).ravel())
        for ax, muscle in zip(axes, muscles, strict=False):
            sub = traces[traces["muscle"].astype(str) == muscle]
            labelled: set[str] = set()
            for (_, status), rows in sub.groupby(["trial", "status"], sort=False):
                colour = _STATUS_COLOUR.get(str(status), PALETTE[7])
                time = rows["time"].to_numpy(float) * 1000.0
                ratio = rows["ratio"].to_numpy(float)
                kept = str(status) == "ok"
                label = None if status in labelled else str(status)
                labelled.add(str(status))
                ax.plot(time, ratio, color=colour, lw=0.5 if kept else 1.0,
                        alpha=0.6 if kept else 0.9, label=label)  # fmt: skip
                active = rows["active"].to_numpy(float) > 0
                if active.any() and not kept:
                    edges = np.flatnonzero(np.diff(np.concatenate(([0], active, [0]))))
                    for a, b in zip(edges[::2], edges[1::2] - 1, strict=True):
                        ax.axvspan(time[a], time[b], color=colour, alpha=0.15, lw=0)
            threshold = float(np.median(sub["threshold"].to_numpy(float))) if len(sub) else 1.0
            ax.axhline(threshold, color=PALETTE[7], lw=0.8, ls="--", label="threshold")
            ax.axhline(1.0, color=PALETTE[7], lw=0.5, ls=":", alpha=0.6)
            ax.set_yscale("log")
            ax.set_ylabel(f"{muscle}: envelope / rest")
            ax.legend(loc="upper right", fontsize="small")
        axes[-1].set_xlabel("time from motion onset [ms]")
        if title:
            fig.suptitle(f"{title}: EMG envelopes of the fast trials, shaded = active stretches")
    return fig
