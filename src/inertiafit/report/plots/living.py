"""A living joint's passive elastic moment, with the gravity moment beside it."""

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

__all__ = ["plot_passive_curve"]


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
