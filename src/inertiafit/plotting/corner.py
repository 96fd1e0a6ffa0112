"""The corner-plot engine: a corner plot of arrays in the house style, with prior boxes.

:func:`corner_figure` knows nothing of posteriors: it takes one array of draws per dimension
with labels, axis ranges, prior-box bounds and prior draws. :meth:`Posterior.corner
<inertiafit.posterior.Posterior.corner>` and :func:`inertiafit.report.plots.plot_joint_corner`
gather those from a posterior.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from inertiafit.plotting import raster
from inertiafit.plotting.style import (
    PALETTE,
    PRIOR_COLOUR,
    figure_width,
    new_figure,
    style_context,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["IDEAL_COLOUR", "IDEAL_LABEL", "TRUTH_LABEL", "corner_figure", "posterior_range"]


def corner_figure(
    columns: Sequence[np.ndarray],
    *,
    labels: Sequence[str],
    titles: Sequence[str],
    ranges: Sequence[tuple[float, float]],
    boxes: Sequence[tuple[float, float] | None],
    priors: Sequence[np.ndarray | None],
    truths: Sequence[float | None] | None = None,
    ideals: Sequence[float | None] | None = None,
    quantiles: Sequence[float] = (0.16, 0.5, 0.84),
    note: str = "",
    band: bool = False,
    fig: Figure | None = None,
    width="double",
    **corner_kwargs,
) -> Figure:
    """Corner plot in the house style, with prior-box edges and prior marginals.

    The engine behind :meth:`inertiafit.posterior.Posterior.corner` and
    :func:`inertiafit.report.plots.plot_joint_corner`; use those.

    Parameters
    ----------
    columns : sequence of ndarray
        Draws per dimension, each of shape ``(nsamples,)``.
    labels, titles : sequence of str
        Axis labels (with units) and 1-D panel titles per dimension.
    ranges : sequence of (float, float)
        Axis limits per dimension.
    boxes : sequence of (float, float) or None
        Prior-box bounds per dimension (dashed lines where inside the axes), or None.
    priors : sequence of ndarray or None
        Prior draws per dimension, histogrammed in grey on the diagonal, scaled to the
        posterior's number of draws; or None.
    truths : sequence of float or None, optional
        Known values drawn as lines (solid, :data:`PALETTE` ``[1]``): a simulation's truth;
        None entries are skipped. The legend names them :data:`TRUTH_LABEL`.
    ideals : sequence of float or None, optional
        Reference values drawn as dashed lines in :data:`IDEAL_COLOUR` (an ideal, textbook
        body), apart from ``truths``; None entries are skipped. The legend names them
        :data:`IDEAL_LABEL`.
    quantiles : sequence of float
        Quantiles marked on the diagonal.
    note : str
        Text in the top right corner.
    band : bool
        Shade each prior box on its diagonal panel (for axes zoomed to the posterior,
        :func:`posterior_range`, where the box's frame no longer shows it).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into; without a layout engine (corner.py sets the margins).
    width : {"single", "double"} or float
        Figure width (and height: the figure is square).
    **corner_kwargs
        Passed on to :func:`corner.corner`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import corner

    data = np.column_stack(columns)
    k = data.shape[1]
    w = figure_width(width)
    bins = int(corner_kwargs.pop("bins", 30))
    kwargs: dict[str, Any] = {
        "labels": list(labels),
        "titles": list(titles),
        "quantiles": list(quantiles),
        "show_titles": True,
        "title_fmt": ".3g",
        "range": list(ranges),
        "bins": bins,
        "smooth": 0.8,
        "color": PALETTE[0],
        "truth_color": PALETTE[1],
        "max_n_ticks": 4,
        "labelpad": 0.12,
        "hist_kwargs": {"lw": 0.9},
        "contour_kwargs": {"linewidths": 0.7},
    }
    if truths is not None and any(t is not None for t in truths):
        kwargs["truths"] = list(truths)
    kwargs.update(corner_kwargs)
    with style_context():
        fig = new_figure(fig, (w, w), layout=None)
        fig = corner.corner(data, fig=fig, **kwargs)
        for ax in fig.axes:
            raster.density_as_image(ax)
        # corner.py sizes margins and places labels (in axes fractions) for 2-in panels; at
        # journal sizes that puts labels off the figure, so fix both in inches.
        lines = max(1, *(str(lab).count("\n") + 1 for lab in kwargs["labels"] or [""]))
        lb, right, space = min(0.3, (0.5 + 0.14 * lines) / w), 0.985, 0.06
        fig.subplots_adjust(left=lb, bottom=lb, right=right, top=1 - 0.3 / w, wspace=space,
                            hspace=space)  # fmt: skip
        axes = np.asarray(fig.axes).reshape(k, k)
        panel = (right - lb) * w / (k + (k - 1) * space)
        for ax in axes[-1, :]:
            ax.xaxis.set_label_coords(0.5, -0.4 / panel)
        for ax in axes[1:, 0]:
            ax.yaxis.set_label_coords(-0.4 / panel, 0.5)
        for ax in fig.axes:
            raster.drop_hidden_points(ax)
        edge = {"color": PRIOR_COLOUR, "ls": (0, (3, 2)), "lw": 0.8, "clip_on": False}
        rng = kwargs["range"]
        for i in range(k):
            ax = axes[i, i]
            box = boxes[i]
            if band and box is not None:
                ax.axvspan(box[0], box[1], color=PRIOR_COLOUR, alpha=0.12, lw=0, zorder=0)
            prior = priors[i]
            if prior is not None:
                edges = np.linspace(float(min(rng[i])), float(max(rng[i])), bins + 1)
                counts, _ = np.histogram(prior, bins=edges)
                scaled = counts * data.shape[0] / max(1, len(prior))
                ax.stairs(scaled, edges, color=PRIOR_COLOUR, lw=0.7)
                ax.set_ylim(0, max(ax.get_ylim()[1], 1.1 * float(scaled.max(initial=0.0))))
            for j in range(i + 1):
                for b, vertical in ((boxes[j], True), (boxes[i], False)):
                    if b is None or (i == j and not vertical):
                        continue
                    dim = j if vertical else i
                    lo, hi = sorted(rng[dim])
                    for v in b:
                        if lo <= v <= hi:
                            line = axes[i, j].axvline if vertical else axes[i, j].axhline
                            line(v, **edge)
        if ideals is not None:
            _ideal_lines(axes, ideals, rng)
        if note:
            fig.text(0.98, 0.98, note, ha="right", va="top", fontsize=8)
        _legend(fig, truths=truths, ideals=ideals, below_note=bool(note))
    return fig


#: Legend labels of the reference lines (the figure's legend, in its empty upper right).
TRUTH_LABEL = "truth (simulation)"
IDEAL_LABEL = "ideal body (textbook)"


def _legend(
    fig: Figure,
    *,
    truths: Sequence[float | None] | None,
    ideals: Sequence[float | None] | None,
    below_note: bool,
) -> None:
    """A legend for the truth and ideal lines drawn, in the empty upper triangle."""
    from matplotlib.lines import Line2D

    handles = []
    if truths is not None and any(t is not None for t in truths):
        handles.append(Line2D([], [], color=PALETTE[1], lw=1.0, label=TRUTH_LABEL))
    if ideals is not None and any(v is not None for v in ideals):
        handles.append(
            Line2D([], [], color=IDEAL_COLOUR, ls=(0, (4, 2)), lw=0.9, label=IDEAL_LABEL)
        )
    if handles:
        fig.legend(
            handles=handles,
            loc="upper right",
            bbox_to_anchor=(0.985, 0.955 if below_note else 0.985),
            frameon=False,
            fontsize=7,
        )


#: Colour of the ideal body's dashed lines (the truth's are ``PALETTE[1]``).
IDEAL_COLOUR = PALETTE[2]


def _ideal_lines(axes: np.ndarray, ideals: Sequence[float | None], rng: Sequence) -> None:
    """Dashed lines at the ideal values, on every panel of their dimension."""
    style = {"color": IDEAL_COLOUR, "ls": (0, (4, 2)), "lw": 0.9}
    k = axes.shape[0]
    for i in range(k):
        for j in range(i + 1):
            for dim, vertical in ((j, True), (i, False)):
                v = ideals[dim]
                if v is None or (i == j and not vertical):
                    continue
                lo, hi = sorted(rng[dim])
                if lo <= v <= hi:
                    (axes[i, j].axvline if vertical else axes[i, j].axhline)(v, **style)


def posterior_range(
    draws: np.ndarray, box: tuple[float, float] | None = None
) -> tuple[float, float]:
    """Axis limits that show the draws: their 0.1-99.9 % range padded by 10 % each side.

    With a prior ``box``, the limits reach at most 5 % of its width beyond it, so a posterior
    that fills its box shows the box's edges, and a pinned one is not a one-bin spike.
    """
    lo, hi = (float(v) for v in np.quantile(draws, [0.001, 0.999]))
    pad = 0.1 * (hi - lo) if hi > lo else 0.05 * max(abs(lo), 1e-12)
    lo, hi = lo - pad, hi + pad
    if box is not None:
        margin = 0.05 * (box[1] - box[0])
        lo, hi = max(lo, box[0] - margin), min(hi, box[1] + margin)
    return lo, hi
