"""The identification curve: the bodies that fit the data, the prior box and the posterior."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from inertiafit.physics import DERIVED, LABELS, PARAMETERS, curve_at_mass
from inertiafit.plotting.style import (
    PALETTE,
    PRIOR_COLOUR,
    figure_width,
    new_figure,
    style_context,
)
from inertiafit.report.plots.checks import check_body

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from inertiafit.baseline import BaselineResult
    from inertiafit.posterior import Posterior

__all__ = ["CURVE_PAIRS", "curve_verdict", "plot_identification_curve"]

#: Default panels of :func:`plot_identification_curve`.
CURVE_PAIRS: tuple[tuple[str, str], ...] = (
    ("mass", "radius_of_gyration"),
    ("mass", "com_distance"),
)


def _curve(a: float, inertia: float, mass: np.ndarray) -> dict[str, np.ndarray]:
    """Points ``(m, x, rho)`` of the curve ``m x = a``, ``m (rho² + x²) = I`` at ``mass``."""
    x, rho = curve_at_mass(a, inertia, mass)
    return {"mass": mass, "com_distance": x, "radius_of_gyration": rho}


def _mass_grid(m_min: float, m_max: float, num: int = 400) -> np.ndarray:
    # rho ~ sqrt(m - m_min) near the bound: cluster points there so the vertical tangent is drawn.
    t = np.linspace(0.0, 1.0, num)
    return m_min + (m_max - m_min) * t * t


def plot_identification_curve(
    posterior: Posterior,
    body: str,
    *,
    baseline: BaselineResult | None = None,
    pairs: Sequence[tuple[str, str]] = CURVE_PAIRS,
    max_points: int = 4000,
    fig: Figure | None = None,
    width="double",
) -> Figure:
    """The curve of exact solutions, the prior box that picks a point on it, and the posterior.

    The data identify only ``a = m x = M_g/g`` (kg m) and ``I = m (rho² + x²)`` (kg m^2). Each
    panel shows two of ``(m, x, rho)`` with

    - the prior box (dashed rectangle);
    - the identification curve at the posterior medians of ``a`` and ``I``: thick where it lies
      inside the box, dotted outside it; every point on it fits the data equally well;
    - a band of the curves over the posterior's central 95 % of ``a`` and ``I``;
    - the posterior draws (light dots);
    - the physical bound ``m >= (M_g/g)² / I`` (``rho² >= 0``, where the curve ends) on mass
      axes, and ``x <= I g / M_g`` on CoM-distance axes;
    - with ``baseline``, the paper estimator's per-start solutions and its feasible-region mean.

    Parameters
    ----------
    posterior : inertiafit.posterior.Posterior
        The fit; its ``constant_data`` holds the prior box and ``g``.
    body : str
        Which body.
    baseline : inertiafit.baseline.BaselineResult, optional
        :func:`inertiafit.baseline.paper_baseline` for the same body.
    pairs : sequence of (str, str)
        Panels as ``(x-axis, y-axis)`` parameters from ``mass``, ``com_distance``,
        ``radius_of_gyration``; default ``(m, rho)`` and ``(m, x)``; add
        ``("com_distance", "radius_of_gyration")`` for the third view.
    max_points : int
        Largest number of posterior draws drawn (an evenly thinned subset).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in, panels stacked), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per pair, a legend below them.

    Raises
    ------
    ValueError
        An unknown body or parameter pair.
    """
    from matplotlib.patches import Rectangle

    from inertiafit.baseline import curve_mass_intervals

    check_body(posterior, body)
    checked = [tuple(p) for p in pairs]
    if not checked or any(len(p) != 2 or not set(p) <= set(PARAMETERS) or p[0] == p[1]
                          for p in checked):  # fmt: skip
        raise ValueError(
            f"pairs: expected pairs of distinct {', '.join(PARAMETERS)}, got {checked}"
        )
    pairs = [(str(p[0]), str(p[1])) for p in checked]
    box = posterior.prior_box(body)
    g = float(posterior.tree["constant_data"]["gravity"])
    draws = {p: posterior.draws(body, p).ravel() for p in (*PARAMETERS, *DERIVED)}
    a_draws, i_draws = draws["gravity_moment"] / g, draws["inertia"]
    a_med, i_med = float(np.median(a_draws)), float(np.median(i_draws))
    a_lo, a_hi = (float(v) for v in np.quantile(a_draws, [0.025, 0.975]))
    i_lo, i_hi = (float(v) for v in np.quantile(i_draws, [0.025, 0.975]))
    m_min, x_max = a_med**2 / i_med, i_med / a_med

    pad = {p: 0.08 * (hi - lo) for p, (lo, hi) in box.items()}
    limits = {p: (max(0.0, lo - pad[p]), hi + pad[p]) for p, (lo, hi) in box.items()}
    m_top = 3.0 * box["mass"][1]  # beyond every panel's view; clipped by the axes
    # The band: rho (and x) grow with I and shrink with a, so these two curves bound it.
    upper = _curve(a_lo, i_hi, _mass_grid(a_lo**2 / i_hi, m_top))
    lower = _curve(a_hi, i_lo, _mass_grid(a_hi**2 / i_lo, m_top))
    central = _curve(a_med, i_med, _mass_grid(m_min, m_top))
    inside = [
        _curve(a_med, i_med, np.linspace(m0, m1, 200))
        for m0, m1 in curve_mass_intervals(
            inertia=i_med,
            gravity_moment=a_med * g,
            lower=[box[p][0] for p in PARAMETERS],
            upper=[box[p][1] for p in PARAMETERS],
            gravity=g,
        )
    ]
    step = max(1, math.ceil(len(a_draws) / max(1, max_points)))

    w = figure_width(width)
    ncols = len(pairs) if w >= 5 else 1
    nrows = math.ceil(len(pairs) / ncols)
    panel_h = min(2.6, 0.8 * w / ncols)
    with style_context():
        fig = new_figure(fig, (w, nrows * panel_h + 1.0))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
        for ax in axes[len(pairs) :]:
            ax.set_visible(False)
        for ax, (px, py) in zip(axes, pairs, strict=False):
            ax.scatter(draws[px][::step], draws[py][::step], s=1.5, lw=0, color=PALETTE[0],
                       alpha=0.25, rasterized=True, label="posterior draws")  # fmt: skip
            ax.fill(np.r_[upper[px], lower[px][::-1]], np.r_[upper[py], lower[py][::-1]],
                    color=PALETTE[5], alpha=0.3, lw=0,
                    label="curves over 95 % of posterior $M_g/g$, $I$")  # fmt: skip
            ax.plot(central[px], central[py], ls=":", lw=0.8, color="k",
                    label="identification curve (median $M_g/g$, $I$)")  # fmt: skip
            for k, seg in enumerate(inside):
                ax.plot(seg[px], seg[py], lw=1.4, color="k",
                        label="... inside the prior box" if k == 0 else None)  # fmt: skip
            (x0, x1), (y0, y1) = box[px], box[py]
            ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ls="--", lw=0.8,
                                   ec=PRIOR_COLOUR, label="prior box"))  # fmt: skip
            if px == "mass":
                ax.axvline(m_min, color=PALETTE[2], lw=0.8, ls="-.",
                           label=r"bound $m \geq (M_g/g)^2/I$" + f" = {m_min:.3g} kg")  # fmt: skip
            elif px == "com_distance":
                ax.axvline(x_max, color=PALETTE[2], lw=0.8, ls="-.",
                           label=r"bound $x \leq I g/M_g$" + f" = {x_max:.3g} m")  # fmt: skip
            if baseline is not None:
                sol = dict(zip(PARAMETERS, np.asarray(baseline.solutions).T, strict=True))
                ax.scatter(sol[px], sol[py], s=9, marker="o", facecolors="none",
                           edgecolors=PALETTE[4], lw=0.6, zorder=4,
                           label="paper baseline: solution per start")  # fmt: skip
                ax.scatter([getattr(baseline, px)], [getattr(baseline, py)], s=50, marker="*",
                           color=PALETTE[1], edgecolors="k", lw=0.4, zorder=5,
                           label="paper baseline: feasible-region mean")  # fmt: skip
            ax.set_xlim(limits[px])
            ax.set_ylim(limits[py])
            ax.set_xlabel(LABELS[px])
            ax.set_ylabel(LABELS[py])
        legend: dict[str, Any] = {}
        for ax in axes[: len(pairs)]:
            for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
                legend.setdefault(lab, h)
        fig.legend(list(legend.values()), list(legend), loc="outside lower center",
                   ncols=2 if w >= 5 else 1, markerscale=1.5)  # fmt: skip
        data = rf"$m \cdot x = M_g/g$ = {a_med:.3g} kg m, $I$ = {i_med:.3g} kg m$^2$"
        on_curve = curve_verdict(posterior, body)
        fig.suptitle(
            f"{body}: data fix {data};\non the curve, {on_curve}"
            if w >= 5
            else f"{body}\ndata fix {data};\non the curve, {on_curve}"
        )
    return fig


def curve_verdict(posterior: Posterior, body: str) -> str:
    """Who places the body on its curve, as the identification table says: m, x and rho.

    ``"the data pin m and x; the prior box picks rho"``: the parameters grouped by their
    ``identified_by`` (:meth:`~inertiafit.posterior.Posterior.identification`).
    """
    table = posterior.identification()
    rows = table[(table["body"] == body) & table["parameter"].isin(PARAMETERS)]
    who: dict[str, list[str]] = {}
    for p, verdict in zip(rows["parameter"], rows["identified_by"], strict=True):
        who.setdefault(str(verdict), []).append(_SYMBOL[p])
    phrases = {
        "data": "the data pin {}",
        "data + prior": "data and prior box together set {}",
        "prior": "the prior box picks {}",
    }
    return "; ".join(
        phrases.get(verdict, verdict + ": {}").format(_and(names))
        for verdict, names in sorted(who.items(), key=lambda kv: list(phrases).index(kv[0])
                                     if kv[0] in phrases else 3)
    )  # fmt: skip


_SYMBOL = {"mass": "$m$", "com_distance": "$x$", "radius_of_gyration": r"$\rho$"}


def _and(names: list[str]) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
