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

#: Panels per row of :func:`plot_tau_alpha` at a page's width (fewer at a column's).
TAU_ALPHA_COLUMNS = 6


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

    One panel per trial: the torque the inertia was fitted to (the filtered torque less the
    condition's gravity model; a living body's less its static curve, damping and constant)
    against the filtered acceleration, over the uniform-acceleration window (filled dots)
    and, for a living body's trial, the uniform-deceleration window (open dots), the rest of
    the move in grey (not fitted); the line through the origin has the trial's inertia as
    its slope (``trials.csv``).

    Parameters
    ----------
    traces : sequence of dict
        One per trial, as :func:`~inertiafit.report.result.traces_by_condition` gives them,
        each with ``inertial_torque`` (N m, on the trace's samples) and ``inertia``
        (kg m^2); a trial without them gets an empty panel saying so.
    title : str
        Figure title (the condition).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A grid of panels, ``alpha`` [rad/s^2] across, torque [N m] up, in trial order.
    """
    w = figure_width(width)
    n = max(1, len(traces))
    full = max(2, int(w / 7.0 * TAU_ALPHA_COLUMNS))
    ncols = min(n, full)
    nrows = math.ceil(n / ncols)
    living = any("deceleration" in t for t in traces)
    speeds = sorted({float(t["speed"]) for t in traces})
    colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
    with style_context():
        fig = new_figure(fig, (w, nrows * w / full * 0.95 + 0.7))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
        for k, (ax, t) in enumerate(zip(axes, traces, strict=False)):
            s = float(t["speed"])
            ax.set_title(f"#{k + 1}, {s:g} °/s", fontsize="small", pad=2)
            tau = np.asarray(t.get("inertial_torque", []), dtype=float)
            inertia = float(t.get("inertia", math.nan))
            if tau.size == 0 or not np.isfinite(tau).any() or not math.isfinite(inertia):
                ax.text(0.5, 0.5, "not stored", ha="center", va="center",
                        transform=ax.transAxes, fontsize="small")  # fmt: skip
                continue
            alpha = np.asarray(t["acceleration"], dtype=float)
            accel, decel = _windows(t)
            rest = ~(accel | decel) & np.isfinite(tau)
            ax.plot(alpha[rest], tau[rest], ".", ms=1.0, color="0.7", zorder=0,
                    label="outside the windows (not fitted)")  # fmt: skip
            ax.plot(alpha[accel], tau[accel], "o", ms=1.8, mew=0, color=colour[s], alpha=0.7,
                    label="acceleration window")  # fmt: skip
            if decel.any():
                ax.plot(alpha[decel], tau[decel], "o", ms=1.8, mew=0.4, mfc="none",
                        color=colour[s], alpha=0.7, label="deceleration window")  # fmt: skip
            used = alpha[np.isfinite(tau)]
            ends = np.array([min(0.0, float(used.min())), max(0.0, float(used.max()))])
            ax.plot(ends, inertia * ends, "-", color="k", lw=0.8, label="I alpha")
            ax.text(0.04, 0.96, f"I = {inertia:.4g}", transform=ax.transAxes, ha="left",
                    va="top", fontsize="x-small")  # fmt: skip
            ax.tick_params(labelsize="x-small")
        for ax in axes[len(traces) :]:
            ax.set_visible(False)
        fig.supxlabel("acceleration α [rad/s²]", fontsize="small")
        fig.supylabel(
            "torque less static curve, bω, c [N m]" if living else "torque less gravity [N m]",
            fontsize="small",
        )
        head = f"{title}: " if title else ""
        fig.suptitle(
            f"{head}each fast trial's torque against acceleration\ndots: the "
            + ("acceleration (filled) and deceleration (open) windows" if living else "window")
            + " fitted, grey: the rest of the move; line: I α",
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
