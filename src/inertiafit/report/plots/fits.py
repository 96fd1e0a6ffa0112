"""Each trial against the model fitted to it.

A fast trial's ``tau``-``alpha`` line; a quasi-static sweep's gravity model and its residuals.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.plotting.style import PALETTE, figure_width, new_figure, style_context

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["TAU_ALPHA_COLUMNS", "gravity_model", "plot_gravity_fit", "plot_tau_alpha"]

#: Panels per row of :func:`plot_tau_alpha` (a panel per speed).
TAU_ALPHA_COLUMNS = 3


def _windows(trace: dict) -> tuple[np.ndarray, np.ndarray]:
    """Masks of a trace's samples in its acceleration window and its deceleration window."""
    time = np.asarray(trace["time"])
    start, end = trace["window"]
    accel = (time >= start) & (time <= end)
    decel = np.zeros_like(accel)
    if "deceleration" in trace:
        d_start, d_end = trace["deceleration"]
        decel = (time >= d_start) & (time <= d_end)
    return accel, decel


def plot_tau_alpha(
    traces: Sequence[dict], *, title: str = "", fig: Figure | None = None, width="double"
) -> Figure:
    """Each fast trial's torque against its acceleration over the windows fitted, and its line.

    One panel per speed, every trial at that speed in it: the torque the inertia was fitted
    to (the filtered torque less the condition's gravity model; a living body's less its
    static curve, damping and constant) against the filtered acceleration, over the
    uniform-acceleration window (filled dots) and, for a living body's trial, the
    uniform-deceleration window (open dots), the rest of the move in grey (not fitted); each
    trial's line through the origin has its inertia as its slope (``trials.csv``). A panel
    per trial cost 1.6-1.7 s a condition of 30 trials at 300 dpi, a quarter of a study's
    figures; a fan of lines at each speed shows their spread as well. Each trial's artists
    carry ``gid = "trial-<k>"``, ``k`` its place in ``traces``.

    Parameters
    ----------
    traces : sequence of dict
        One per trial, as :func:`~inertiafit.report.result.traces_by_condition` gives them,
        each with ``inertial_torque`` (N m, on the trace's samples) and ``inertia``
        (kg m^2); trials without them are counted in the panel's title as not stored.
    title : str
        Figure title (the condition).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A panel per speed, ``alpha`` [rad/s^2] across, torque [N m] up.
    """
    w = figure_width(width)
    living = any("deceleration" in t for t in traces)
    speeds = sorted({float(t["speed"]) for t in traces}) or [math.nan]
    colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
    ncols = min(len(speeds), TAU_ALPHA_COLUMNS)
    nrows = math.ceil(len(speeds) / ncols)
    with style_context():
        fig = new_figure(fig, (w, nrows * min(w / ncols, 3.2) * 0.9 + 0.8))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
        for ax, s in zip(axes, speeds, strict=False):
            here = [(k, t) for k, t in enumerate(traces) if float(t["speed"]) == s]
            drawn, inertias = 0, []
            for k, t in here:
                tau = np.asarray(t.get("inertial_torque", []), dtype=float)
                inertia = float(t.get("inertia", math.nan))
                if tau.size == 0 or not np.isfinite(tau).any() or not math.isfinite(inertia):
                    continue
                gid = f"trial-{k}"
                alpha = np.asarray(t["acceleration"], dtype=float)
                accel, decel = _windows(t)
                rest = ~(accel | decel) & np.isfinite(tau)
                ax.plot(alpha[rest], tau[rest], ".", ms=0.8, color="0.75", zorder=0,
                        label="outside the windows (not fitted)", gid=gid)  # fmt: skip
                ax.plot(alpha[accel], tau[accel], "o", ms=1.5, mew=0, color=colour[s],
                        alpha=0.5, label="acceleration window", gid=gid)  # fmt: skip
                if decel.any():
                    ax.plot(alpha[decel], tau[decel], "o", ms=1.5, mew=0.4, mfc="none",
                            color=colour[s], alpha=0.5, label="deceleration window",
                            gid=gid)  # fmt: skip
                used = alpha[np.isfinite(tau)]
                ends = np.array([min(0.0, float(used.min())), max(0.0, float(used.max()))])
                ax.plot(ends, inertia * ends, "-", color="k", lw=0.6, alpha=0.8,
                        label="I alpha", gid=gid)  # fmt: skip
                drawn += 1
                inertias.append(inertia)
            missing = len(here) - drawn
            head = f"{s:g} °/s: {drawn} trial{'s' if drawn != 1 else ''}"
            if missing:
                head += f", {missing} not stored"
            ax.set_title(head, fontsize="small", pad=2)
            if inertias:
                ax.text(0.04, 0.96, f"I = {min(inertias):.4g} to {max(inertias):.4g}"
                        if len(inertias) > 1 else f"I = {inertias[0]:.4g}",
                        transform=ax.transAxes, ha="left", va="top",
                        fontsize="x-small")  # fmt: skip
            ax.tick_params(labelsize="x-small")
        for ax in axes[len(speeds) :]:
            ax.set_visible(False)
        fig.supxlabel("acceleration α [rad/s²]", fontsize="small")
        fig.supylabel(
            "torque less static curve, bω, c [N m]" if living else "torque less gravity [N m]",
            fontsize="small",
        )
        head = f"{title}: " if title else ""
        fig.suptitle(
            f"{head}each fast trial's torque against acceleration, a panel per speed\ndots: "
            + (
                "the acceleration (filled) and deceleration (open) windows"
                if living
                else "the window"
            )
            + " fitted, grey: the rest of the move; a line I α per trial",
            fontsize="small",
        )
    return fig


def gravity_model(angle, moment: float, phase: float, offset: float) -> np.ndarray:
    """A sweep's fitted gravity model ``M_g sin(theta + phi) + c`` (N m) at ``angle`` (rad)."""
    return moment * np.sin(np.asarray(angle, dtype=float) + phase) + offset


def plot_gravity_fit(
    sweeps: pd.DataFrame, trials: pd.DataFrame, *, fig: Figure | None = None, width="double"
) -> Figure:
    """Each quasi-static sweep against its fitted gravity model, and the residuals.

    Top: each sweep's torque (means of consecutive samples, ``sweeps.csv``) and its fit
    ``M_g sin(theta + phi) + c`` from the sweep's row of ``trials.csv``. Bottom: measured
    minus fitted. A friction build-up the fit allowed for at the start of a sweep stays in
    its residuals (the line is the steady model the fast trials subtract).

    Parameters
    ----------
    sweeps : pandas.DataFrame
        Columns ``condition``, ``file``, ``angle`` (rad), ``torque`` (N m).
    trials : pandas.DataFrame
        ``trials.csv``: ``file``, ``gravity_moment``, ``gravity_phase``, ``offset``.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels sharing the angle axis (deg): torque and residual (N m).
    """
    fitted = trials.drop_duplicates("file").set_index("file")
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, 0.6 * w))
        top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (2, 1)})
        for k, (file, sweep) in enumerate(sweeps.groupby("file", sort=False)):
            if file not in fitted.index:
                continue
            row = fitted.loc[file]
            colour = PALETTE[k % len(PALETTE)]
            theta = sweep["angle"].to_numpy(float)
            torque = sweep["torque"].to_numpy(float)
            model = gravity_model(
                theta, row["gravity_moment"], row["gravity_phase"], row["offset"]
            )
            label = f"{sweep['condition'].iloc[0]}: {file}"
            top.plot(np.degrees(theta), torque, "o", ms=1.8, mew=0, color=colour, alpha=0.6,
                     label=label)  # fmt: skip
            order = np.argsort(theta)
            top.plot(np.degrees(theta[order]), model[order], "-", color=colour, lw=0.9)
            bottom.plot(np.degrees(theta), torque - model, "o", ms=1.8, mew=0, color=colour,
                        alpha=0.6)  # fmt: skip
        bottom.axhline(0.0, color="0.4", lw=0.6)
        top.set_ylabel("torque [N m]")
        bottom.set_ylabel("residual [N m]")
        bottom.set_xlabel("dynamometer angle θ [deg]")
        if top.get_legend_handles_labels()[0]:
            top.legend(loc="best", fontsize="x-small", frameon=False,
                       title="dots: sweep; line: M_g sin(θ + φ) + c",
                       title_fontsize="x-small")  # fmt: skip
    return fig
