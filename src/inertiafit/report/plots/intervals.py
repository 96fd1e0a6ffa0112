"""The answer at a glance: every body's quantities as posterior intervals over their prior's.

One row per body and quantity (``m``, ``x``, ``rho``, ``I``, ``M_g``): the prior's central
interval (a grey bar) and the posterior's HDI of the same probability (a coloured bar, a marker
at the median), both divided by the prior's median and drawn on one log axis, so bodies of any
size share the panel and a bar as wide as the grey one is a quantity the prior decides. The
colour and marker are the identification table's one verdict (``identified_by``,
:func:`inertiafit.posterior.pins.verdict`); the numbers on the right are the posterior median
and HDI in SI units.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from inertiafit._checks import check_probability
from inertiafit.physics import REPORTED, SYMBOLS, UNITS
from inertiafit.plotting.style import (
    PALETTE,
    PRIOR_COLOUR,
    figure_width,
    new_figure,
    style_context,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from inertiafit.posterior import Posterior

__all__ = ["INTERVAL_COLUMNS", "VERDICT_STYLE", "interval_table", "plot_intervals"]

#: Colour and marker of each verdict of the identification table's ``identified_by``.
VERDICT_STYLE: dict[str, tuple[str, str]] = {
    "data": (PALETTE[0], "o"),
    "data + prior": (PALETTE[4], "D"),
    "prior": (PALETTE[1], "s"),
}
#: Colour of the prior's bar (light, behind the posterior's).
PRIOR_BAR = "0.82"
#: Labelled ticks of the ratio axis (those inside its limits).
_TICKS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1, 2, 3, 5, 10, 20, 50, 100)
_FINE_TICKS = (0.5, 0.6, 0.7, 0.8, 0.9, 1, 1.1, 1.25, 1.5, 2)
#: Columns of :func:`interval_table`.
INTERVAL_COLUMNS = [
    "body",
    "parameter",
    "median",
    "hdi_lower",
    "hdi_upper",
    "prior_median",
    "prior_lower",
    "prior_upper",
    "identified_by",
    "prior_data_conflict",
]


def interval_table(posterior: Posterior, hdi_prob: float = 0.95) -> pd.DataFrame:
    """What :func:`plot_intervals` draws, a row per body and quantity (SI units).

    ``median``, ``hdi_lower``, ``hdi_upper``: the posterior's, as
    :meth:`~inertiafit.posterior.Posterior.summary` gives them; ``prior_median``,
    ``prior_lower``, ``prior_upper``: the median and central ``hdi_prob`` interval of the
    body's prior, from its exact draws (:func:`inertiafit.posterior.conflict.prior_draws`, the
    draws the identification table's ``prior_sd`` comes from), ``I`` and ``M_g`` included;
    ``identified_by`` and ``prior_data_conflict``: the identification table's.
    """
    from inertiafit.posterior.conflict import prior_draws
    from inertiafit.posterior.pins import prior_specs

    check_probability(hdi_prob, "hdi_prob")
    summary = posterior.summary(hdi_prob).set_index(["body", "parameter"])
    ident = posterior.identification().set_index(["body", "parameter"])
    specs = prior_specs(posterior.tree)
    g = float(posterior.tree["constant_data"]["gravity"])
    tails = [0.5 - hdi_prob / 2, 0.5, 0.5 + hdi_prob / 2]
    rows = []
    for body in posterior.bodies:
        prior = prior_draws(specs[body], g)
        for p in REPORTED:
            low, mid, high = (float(v) for v in np.quantile(prior[p], tails))
            s, i = summary.loc[(body, p)], ident.loc[(body, p)]
            rows.append(
                [
                    body,
                    p,
                    float(s["median"]),
                    float(s["hdi_lower"]),
                    float(s["hdi_upper"]),
                    mid,
                    low,
                    high,
                    str(i["identified_by"]),
                    bool(i["prior_data_conflict"]),
                ]
            )
    return pd.DataFrame(rows, columns=INTERVAL_COLUMNS)


def _si(value: float) -> str:
    return f"{value:#.3g}".rstrip(".")  # 3.00, not 3: three figures throughout


def _unit(parameter: str) -> str:
    return UNITS[parameter].replace("^2", "²")


def plot_intervals(
    posterior: Posterior,
    hdi_prob: float = 0.95,
    *,
    fig: Figure | None = None,
    width="double",
) -> Figure:
    """Every body's ``m``, ``x``, ``rho``, ``I`` and ``M_g`` against its prior, one panel.

    Each row is one body's quantity: a grey bar, the prior's central ``hdi_prob`` interval,
    and over it the posterior's ``hdi_prob`` HDI with a marker at its median, coloured and
    marked by who decides the quantity (the identification table's ``identified_by``:
    :data:`VERDICT_STYLE`). Both are divided by the prior's median and drawn on a log axis:
    1 is the prior's median, and a posterior bar much shorter than its grey bar is decided
    by the data. The right-hand labels give the posterior median and HDI in SI units, and
    name a prior-data conflict. The numbers drawn are :func:`interval_table`'s; each bar's
    :class:`~matplotlib.lines.Line2D` has the gid ``posterior:<body>:<quantity>`` or
    ``prior:<body>:<quantity>``.

    Parameters
    ----------
    posterior : inertiafit.posterior.Posterior
        The fit.
    hdi_prob : float
        Probability of both intervals.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        One panel, its legend below it.
    """
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    table = interval_table(posterior, hdi_prob)
    pct = f"{100 * hdi_prob:g} %"
    bodies = list(posterior.bodies)
    w = figure_width(width)
    # rows top to bottom: quantity by quantity, every body within each; a gap between groups
    order = list(table.sort_values("parameter", key=_order, kind="stable").index)
    ys = [k + 0.6 * (k // len(bodies)) for k in range(len(order))]
    y_of = dict(zip(order, ys, strict=True))
    n = len(table)
    with style_context():
        fig = new_figure(fig, (w, 1.25 + 0.2 * n + 0.12 * (len(REPORTED) - 1)))
        ax = fig.subplots()
        ratios = []
        for idx, r in table.iterrows():
            yy = y_of[idx]
            scale = r["prior_median"]
            prior = np.array([r["prior_lower"], r["prior_upper"]]) / scale
            post = np.array([r["hdi_lower"], r["hdi_upper"]]) / scale
            colour, marker = VERDICT_STYLE.get(r["identified_by"], ("k", "o"))
            ax.plot(
                prior,
                [yy, yy],
                color=PRIOR_BAR,
                lw=7,
                solid_capstyle="butt",
                gid=f"prior:{r['body']}:{r['parameter']}",
                zorder=1,
            )
            ax.plot(
                post,
                [yy, yy],
                color=colour,
                lw=2.0,
                solid_capstyle="butt",
                gid=f"posterior:{r['body']}:{r['parameter']}",
                zorder=3,
            )
            ax.plot(
                [r["median"] / scale],
                [yy],
                ls="none",
                marker=marker,
                ms=4.5,
                color=colour,
                mec="white",
                mew=0.5,
                zorder=4,
            )
            ratios += [*prior, *post]
        ax.axvline(1.0, color=PRIOR_COLOUR, lw=0.6, ls=":", zorder=0)
        ax.set_xscale("log")
        finite = [v for v in ratios if np.isfinite(v) and v > 0]
        lo, hi = min(finite), max(finite)
        span = (hi / lo) ** 0.04
        ax.set_xlim(lo / span, hi * span)
        ax.set_ylim(max(ys) + 0.8, -0.8)
        ax.set_yticks(
            [y_of[i] for i in order],
            [f"{table.at[i, 'body']}  {SYMBOLS[table.at[i, 'parameter']]}" for i in order]
            if len(bodies) > 1
            else [SYMBOLS[table.at[i, "parameter"]] for i in order],
        )
        ax.tick_params(axis="y", length=0)
        right = ax.twinx()
        right.set_yscale(ax.get_yscale())
        right.set_ylim(ax.get_ylim())
        right.set_yticks(
            [y_of[i] for i in order],
            [
                f"{_si(table.at[i, 'median'])} [{_si(table.at[i, 'hdi_lower'])}, "
                f"{_si(table.at[i, 'hdi_upper'])}] {_unit(table.at[i, 'parameter'])}"
                + ("  prior-data conflict" if table.at[i, "prior_data_conflict"] else "")
                for i in order
            ],
        )
        right.tick_params(axis="y", length=0)
        for k in range(1, len(REPORTED)):  # a faint line between quantities
            ax.axhline(ys[k * len(bodies)] - 0.8, color="0.9", lw=0.5, zorder=0)
        ax.set_xlabel("value / prior median (log scale)")
        ticks = [t for t in _TICKS if lo / span <= t <= hi * span]
        if len(ticks) < 3:  # a narrow range: finer steps about 1
            ticks = [t for t in _FINE_TICKS if lo / span <= t <= hi * span]
        ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        handles = [
            Line2D([], [], color=PRIOR_BAR, lw=7, label=f"prior: central {pct}"),
            *(
                Line2D(
                    [],
                    [],
                    color=c,
                    lw=2.0,
                    marker=m,
                    ms=4.5,
                    mec="white",
                    mew=0.5,
                    label=f"posterior {pct} HDI, decided by {who}",
                )
                for who, (c, m) in VERDICT_STYLE.items()
            ),
        ]
        fig.legend(handles=handles, loc="outside lower center", ncols=2 if w >= 5 else 1)
        fig.suptitle(
            f"{', '.join(bodies)}: posterior {pct} HDI (median marked) against the prior"
            if w >= 5
            else f"{', '.join(bodies)}:\nposterior against the prior"
        )
    return fig


def _order(column: pd.Series) -> pd.Series:
    """Sort key of quantities in table order (m, x, rho, I, M_g)."""
    return column.map({p: k for k, p in enumerate(REPORTED)})
