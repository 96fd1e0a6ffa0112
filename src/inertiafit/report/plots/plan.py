"""The figure of ``inertiafit plan``: predicted HDI width per parameter, body and design."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from inertiafit.physics import REPORTED, SYMBOLS, UNITS
from inertiafit.plotting.style import PALETTE, figure_width, new_figure, style_context

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["plot_plan"]


def plot_plan(
    table: pd.DataFrame, *, hdi_prob: float = 0.95, fig: Figure | None = None, width="double"
) -> Figure:
    """Predicted HDI width of every parameter, a panel per parameter, a bar per design.

    Parameters
    ----------
    table : pandas.DataFrame
        ``plan.csv``: columns ``design``, ``body``, ``parameter``, ``hdi_width`` and
        ``target_width`` (drawn as a dashed line where finite).
    hdi_prob : float
        Probability of the HDIs (for the axis label).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width.

    Returns
    -------
    matplotlib.figure.Figure
        Five panels (m, x, rho, I, M_g); within each, groups of bars per body, one bar per
        design in the order of the table.
    """
    designs = list(dict.fromkeys(table["design"]))
    bodies = list(dict.fromkeys(table["body"]))
    w = figure_width(width)
    pct = round(100 * hdi_prob)
    with style_context():
        fig = new_figure(fig, (w, 0.85 * w))
        axes = fig.subplots(3, 2).ravel()
        bar = 0.8 / max(len(designs), 1)
        for ax, p in zip(axes, REPORTED, strict=False):
            sub = table[table["parameter"] == p]
            for j, d in enumerate(designs):
                rows = sub[sub["design"] == d].set_index("body")
                heights = [float(rows["hdi_width"].get(b, np.nan)) for b in bodies]
                x = np.arange(len(bodies)) - 0.4 + bar * (j + 0.5)
                ax.bar(x, heights, bar, color=PALETTE[j % len(PALETTE)], label=d)
            for i, b in enumerate(bodies):
                t = sub[(sub["body"] == b)]["target_width"].dropna()
                if len(t):
                    ax.hlines(float(t.iloc[0]), i - 0.45, i + 0.45, colors="k", linestyles="--")
            ax.set_xticks(np.arange(len(bodies)), bodies)
            ax.set_ylabel(f"{SYMBOLS[p]} [{UNITS[p].replace('^2', '$^2$')}]")
            ax.set_title(f"{pct} % HDI width", fontsize="small")
        handles, labels = axes[0].get_legend_handles_labels()
        axes[-1].axis("off")
        axes[-1].legend(handles, labels, loc="center", fontsize="small", frameon=False)
    return fig
