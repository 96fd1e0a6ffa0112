"""Figures of a study: the fast trials with their acceleration windows and inertia per speed.

Every function takes ``fig=`` (a new :class:`matplotlib.figure.Figure`, not managed by pyplot,
by default), returns the Figure, never shows it and never changes global rcParams.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

#: Okabe-Ito colour-blind-safe palette.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")


def _figure(fig, size):
    from matplotlib.figure import Figure

    return fig if fig is not None else Figure(figsize=size, dpi=100, layout="constrained")


def plot_fast_trials(traces: Sequence[dict], *, title: str = "", fig=None):
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

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = _figure(fig, (7.0, 4.2))
    ax_v, ax_a = fig.subplots(2, 1, sharex=True)
    speeds = sorted({float(t["speed"]) for t in traces})
    colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
    labelled = set()
    for t in traces:
        time = np.asarray(t["time"]) - float(t["window"][0])
        c = colour[float(t["speed"])]
        label = None if t["speed"] in labelled else f"{t['speed']:g} °/s"
        labelled.add(t["speed"])
        ax_v.plot(time, np.degrees(t["velocity"]), color=c, lw=0.7, alpha=0.7, label=label)
        ax_a.plot(time, np.degrees(t["acceleration"]), color=c, lw=0.7, alpha=0.7)
    for s in speeds:  # one band per speed: the median window of its trials
        width = float(
            np.median([t["window"][1] - t["window"][0] for t in traces if float(t["speed"]) == s])
        )
        for ax in (ax_v, ax_a):
            ax.axvspan(0.0, width, color=colour[s], alpha=0.10, lw=0)
    ax_v.set_ylabel("velocity [°/s]")
    ax_a.set_ylabel("acceleration [°/s²]")
    ax_a.set_xlabel("time from window start [s]")
    ax_v.legend(frameon=False, fontsize=8, loc="lower right")
    if title:
        ax_v.set_title(
            f"{title}: fast trials, grey = detected uniform-acceleration windows", fontsize=9
        )
    return fig


def plot_inertia_by_speed(trials: pd.DataFrame, *, fig=None):
    """Per-trial inertia against nominal speed, one panel per condition (cf. Fig. 5).

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns ``condition``, ``speed`` (deg/s), ``inertia`` (kg m^2): the fast trials.
    fig : matplotlib.figure.Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    conditions = list(dict.fromkeys(trials["condition"]))
    fig = _figure(fig, (3.5 * max(1, len(conditions)), 3.0))
    axes = np.atleast_1d(fig.subplots(1, max(1, len(conditions)), squeeze=False)[0])
    rng = np.random.default_rng(0)  # jitter only; deterministic figure
    for ax, cond in zip(axes, conditions, strict=False):
        sub = trials[trials["condition"] == cond]
        speeds = sorted(sub["speed"].unique())
        for i, s in enumerate(speeds):
            y = sub.loc[sub["speed"] == s, "inertia"].to_numpy()
            x = np.full(len(y), float(i)) + rng.uniform(-0.12, 0.12, len(y))
            ax.plot(x, y, "o", ms=3, color=PALETTE[0], alpha=0.6)
            sd = y.std(ddof=1) if len(y) > 1 else 0.0
            ax.errorbar(i + 0.3, y.mean(), yerr=sd, fmt="s", color=PALETTE[1], ms=5, capsize=3)
        ax.set_xticks(range(len(speeds)), [f"{s:g}" for s in speeds])
        ax.set_xlabel("speed [°/s]")
        ax.set_ylabel("inertia I [kg m²]")
        ax.set_title(cond, fontsize=9)
    return fig
