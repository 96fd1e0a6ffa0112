"""A living joint's passive elastic moment, with the gravity moment beside it; the static fit."""

from __future__ import annotations

from typing import TYPE_CHECKING

from inertiafit.plotting.style import (
    PALETTE,
    PRIOR_COLOUR,
    figure_width,
    new_figure,
    style_context,
)

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["plot_passive_curve", "plot_static_fit"]


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
