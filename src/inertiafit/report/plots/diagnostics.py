"""Sampler diagnostics as figures: walkers' traces and rank plots."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from inertiafit.physics import LABELS, PARAMETERS
from inertiafit.plotting.style import (
    PALETTE,
    axis_label,
    figure_width,
    new_figure,
    style_context,
)
from inertiafit.report.plots.checks import check_body, check_parameters

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from inertiafit.posterior import Posterior

__all__ = ["plot_rank", "plot_trace", "rank_groups"]


def _walker_subset(n_chain: int, max_walkers: int) -> np.ndarray:
    k = max(1, min(n_chain, max_walkers))
    return np.unique(np.round(np.linspace(0, n_chain - 1, k)).astype(int))


def plot_trace(
    posterior: Posterior,
    body: str,
    *,
    parameters: Sequence[str] = PARAMETERS,
    max_walkers: int = 16,
    fig: Figure | None = None,
    width="double",
) -> Figure:
    """Walkers' traces over the kept draws, with each parameter's marginal histogram.

    Well-mixed walkers overlap as a stationary band with no trends or stuck walkers.

    Parameters
    ----------
    posterior : inertiafit.posterior.Posterior
        The fit.
    body : str
        Which body.
    parameters : sequence of str
        Quantities, a row each: ``mass`` (kg), ``com_distance`` (m), ``radius_of_gyration``
        (m), ``inertia`` (kg m^2), ``gravity_moment`` (N m).
    max_walkers : int
        Largest number of walkers drawn (evenly spaced indices); the histograms use them all.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A row per parameter: traces (left, wide) and histogram (right, sharing the value axis).

    Raises
    ------
    ValueError
        An unknown body or parameter.
    """
    check_body(posterior, body)
    params = check_parameters(parameters)
    w = figure_width(width)
    with style_context():
        fig = new_figure(fig, (w, 1.15 * len(params) + 0.45))
        axes = fig.subplots(len(params), 2, squeeze=False, sharex="col", sharey="row",
                            gridspec_kw={"width_ratios": (4, 1)})  # fmt: skip
        n_chain = 0
        shown = np.empty(0, dtype=int)
        for row, p in enumerate(params):
            x = posterior.draws(body, p)  # (chain, draw)
            n_chain = x.shape[0]
            shown = _walker_subset(n_chain, max_walkers)
            ax_t, ax_h = axes[row]
            for k, c in enumerate(shown):
                ax_t.plot(x[c], lw=0.4, alpha=0.8, color=PALETTE[k % len(PALETTE)])
            ax_t.set_xlim(0, x.shape[1] - 1)
            ax_t.set_ylabel(axis_label(p))
            ax_h.hist(x.ravel(), bins=40, orientation="horizontal", histtype="stepfilled",
                      color=PALETTE[0], alpha=0.6)  # fmt: skip
            ax_h.tick_params(labelleft=False)
        axes[-1, 0].set_xlabel("draw (kept, after burn-in)")
        axes[-1, 1].set_xlabel("draws")
        fig.suptitle(f"{body}: traces of {len(shown)} of {n_chain} walkers")
    return fig


def rank_groups(draws: np.ndarray, groups: int = 4) -> list[np.ndarray]:
    """Ranks of all draws (1..N, ties averaged), split into groups of contiguous walkers.

    Parameters
    ----------
    draws : array_like of shape (chain, draw)
        One parameter's draws, walkers along the first axis.
    groups : int
        Number of walker groups (fewer if there are fewer walkers).

    Returns
    -------
    list of ndarray
        The ranks of each group's draws, flattened.
    """
    from scipy.stats import rankdata

    x = np.asarray(draws, dtype=float)
    ranks = rankdata(x.ravel(), method="average").reshape(x.shape)
    return [
        ranks[idx].ravel() for idx in np.array_split(np.arange(x.shape[0]), groups) if idx.size
    ]


def plot_rank(
    posterior: Posterior,
    body: str,
    *,
    parameters: Sequence[str] = PARAMETERS,
    groups: int = 4,
    bins: int = 20,
    fig: Figure | None = None,
    width="double",
) -> Figure:
    """Rank plots: each group of walkers should spread evenly over the whole posterior.

    All draws of a parameter are rank-normalised together; the walkers are split into
    ``groups`` contiguous groups and each group's ranks are histogrammed as a fraction of its
    draws. Under good mixing every group samples every part of the posterior equally, so each
    histogram scatters about the uniform level ``1/bins`` (dashed line); a group above it at one
    end and below at the other has not explored the whole posterior.

    Parameters
    ----------
    posterior : inertiafit.posterior.Posterior
        The fit.
    body : str
        Which body.
    parameters : sequence of str
        Quantities, a panel each (names as :func:`plot_trace`).
    groups : int
        Number of walker groups.
    bins : int
        Number of rank bins.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in, panels stacked), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A panel per parameter.

    Raises
    ------
    ValueError
        An unknown body or parameter, or ``groups``/``bins`` below 1.
    """
    check_body(posterior, body)
    params = check_parameters(parameters)
    if groups < 1 or bins < 1:
        raise ValueError(f"groups, bins: expected >= 1, got {groups}, {bins}")
    w = figure_width(width)
    ncols = len(params) if w >= 5 else 1
    nrows = math.ceil(len(params) / ncols)
    with style_context():
        fig = new_figure(fig, (w, nrows * min(1.9, 0.75 * w / ncols) + 0.6))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False, sharey=True).ravel())
        for ax in axes[len(params) :]:
            ax.set_visible(False)
        for ax, p in zip(axes, params, strict=False):
            x = posterior.draws(body, p)
            n = x.size
            edges = np.linspace(0.5, n + 0.5, bins + 1)
            walkers = np.array_split(np.arange(x.shape[0]), groups)
            for k, (ranks, idx) in enumerate(zip(rank_groups(x, groups), walkers, strict=False)):
                counts, _ = np.histogram(ranks, bins=edges)
                ax.stairs(counts / ranks.size, edges, color=PALETTE[k % len(PALETTE)], lw=0.9,
                          label=f"walkers {idx[0]}–{idx[-1]}")  # fmt: skip
            ax.axhline(1.0 / bins, color="k", ls="--", lw=0.8, label="uniform (perfect mixing)")
            ax.set_xlim(edges[0], edges[-1])
            ax.set_ylim(bottom=0)
            ax.set_title(LABELS[p])
            ax.set_xlabel("rank among all draws")
        for ax in axes[::ncols]:
            ax.set_ylabel("fraction of group's draws")
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=min(len(labels), 5))
        fig.suptitle(f"{body}: rank plots, {x.shape[0]} walkers in {len(walkers)} groups")
    return fig
