"""Figures of a study and of a posterior, sized for journal columns.

Every plot function draws into a :class:`matplotlib.figure.Figure` (a new one, not managed by
pyplot, unless ``fig=`` is given), returns it, never shows it and never changes global rcParams:
the house style :data:`STYLE` is applied with :func:`matplotlib.rc_context` only while the
figure is built (and by :func:`save_figure` while it is written). ``width=`` takes
``"single"`` (:data:`SINGLE_COLUMN`, 3.5 in), ``"double"`` (:data:`DOUBLE_COLUMN`, 7.0 in) or a
width in inches; heights follow from the content. ``docs/figures.md`` says how to read each one.

Posterior figures take a :class:`inertiafit.result.Posterior` (walkers are the ``chain``
dimension of its tree) and a body name.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from inertiafit.physics import DERIVED, LABELS, PARAMETERS, SYMBOLS, UNITS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from inertiafit.baseline import BaselineResult
    from inertiafit.result import Posterior

#: Okabe-Ito colour-blind-safe palette.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")

#: Width of a single journal column (in).
SINGLE_COLUMN = 3.5
#: Width of a double (full-page) journal column (in).
DOUBLE_COLUMN = 7.0

#: House style, applied with :func:`matplotlib.rc_context` inside each plot function only.
STYLE: dict[str, Any] = {
    "font.size": 8.0,
    "axes.labelsize": 8.0,
    "axes.titlesize": 8.0,
    "figure.titlesize": 9.0,
    "xtick.labelsize": 7.0,
    "ytick.labelsize": 7.0,
    "legend.fontsize": 7.0,
    "lines.linewidth": 0.8,
    "lines.markersize": 3.0,
    "patch.linewidth": 0.6,
    "axes.linewidth": 0.6,
    "axes.prop_cycle": "cycler('color', [{}])".format(", ".join(f"'{c}'" for c in PALETTE)),
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "xtick.minor.width": 0.4,
    "ytick.minor.width": 0.4,
    "xtick.major.size": 2.5,
    "ytick.major.size": 2.5,
    "legend.frameon": False,
    "figure.dpi": 100,
    "savefig.dpi": 300,
    # Embed TrueType fonts (editable text in journals' tools); keep SVG text as text.
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "none",
    "svg.hashsalt": "inertiafit",  # same figure -> same SVG bytes
}

#: Colour of prior-box edges and prior histograms.
PRIOR_COLOUR = "0.35"
#: Default panels of :func:`plot_identification_curve`.
CURVE_PAIRS: tuple[tuple[str, str], ...] = (
    ("mass", "radius_of_gyration"),
    ("mass", "com_distance"),
)
SAVE_FORMATS = ("pdf", "png", "svg")


# --- style and size -----------------------------------------------------------------------------


def style_context():
    """A :func:`matplotlib.rc_context` with :data:`STYLE`; rcParams are restored on exit."""
    import matplotlib

    return matplotlib.rc_context(STYLE)  # type: ignore[arg-type]  # keys are valid rcParams


def figure_width(width: str | float) -> float:
    """Figure width (in) for ``"single"``, ``"double"`` or a positive number of inches.

    Raises
    ------
    ValueError
        For any other value.
    """
    if isinstance(width, str):
        sizes = {"single": SINGLE_COLUMN, "double": DOUBLE_COLUMN}
        if width not in sizes:
            raise ValueError(f"width: expected 'single', 'double' or inches, got {width!r}")
        return sizes[width]
    w = float(width)
    if not (math.isfinite(w) and w > 0):
        raise ValueError(f"width: expected a positive number of inches, got {width!r}")
    return w


def _figure(fig: Figure | None, size: tuple[float, float], layout: Any = "constrained") -> Figure:
    from matplotlib.figure import Figure

    return fig if fig is not None else Figure(figsize=size, layout=layout)


def _unit_tex(parameter: str) -> str:
    return UNITS[parameter].replace("^2", "$^2$")


def axis_label(parameter: str, body: str | None = None) -> str:
    """Compact axis label with unit, e.g. ``"$m$ [kg]"`` or ``"weight: $m$ [kg]"``.

    A ``body`` ending in a newline is put on a line of its own.
    """
    label = f"{SYMBOLS[parameter]} [{_unit_tex(parameter)}]"
    if not body:
        return label
    return f"{body}{label}" if body.endswith("\n") else f"{body}: {label}"


def save_figure(
    fig: Figure,
    stem: str | Path,
    formats: Sequence[str] = ("pdf", "png"),
    dpi: float = 300,
) -> list[Path]:
    """Write a figure as vector PDF (and SVG when asked) and raster PNG.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    stem : str or path-like
        Path without extension; ``.pdf``, ``.png``, ``.svg`` are appended. Its folder must exist.
    formats : sequence of {"pdf", "png", "svg"}
        Formats to write, in order.
    dpi : float
        Resolution of the PNG (dots per inch); rasterised layers of the vector files too.

    Returns
    -------
    list of pathlib.Path
        The written files, in the order of ``formats``.

    Raises
    ------
    ValueError
        An unknown format or no format at all.
    """
    formats = list(formats)
    bad = [f for f in formats if f not in SAVE_FORMATS]
    if bad or not formats:
        raise ValueError(f"formats: expected some of {', '.join(SAVE_FORMATS)}, got {formats!r}")
    # No dates in the files: the same figure gives the same bytes.
    metadata = {"pdf": {"CreationDate": None}, "svg": {"Date": None}, "png": {"Software": None}}
    paths = []
    # A layout engine (constrained layout) places the axes again at every save, the costliest
    # part of drawing small figures; the first format's layout serves the others too (the
    # backends' text metrics differ by a fraction of a point), then the engine is restored.
    engine = fig.get_layout_engine()
    with style_context():
        try:
            for fmt in formats:
                path = Path(f"{stem}.{fmt}")
                fig.savefig(path, format=fmt, dpi=dpi, metadata=metadata[fmt])
                paths.append(path)
                if engine is not None and fig.get_layout_engine() is engine:
                    fig.set_layout_engine("none")
        finally:
            if engine is not None and fig.get_layout_engine() is not engine:
                fig.set_layout_engine(engine)
    return paths


# --- study figures ------------------------------------------------------------------------------


def plot_fast_trials(
    traces: Sequence[dict], *, title: str = "", fig: Figure | None = None, width="double"
) -> Figure:
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
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels sharing the time axis: velocity (deg/s) and acceleration (deg/s^2).
    """
    w = figure_width(width)
    with style_context():
        fig = _figure(fig, (w, 0.6 * w if w < 5 else 0.5 * w))
        ax_v, ax_a = fig.subplots(2, 1, sharex=True)
        speeds = sorted({float(t["speed"]) for t in traces})
        colour = {s: PALETTE[i % len(PALETTE)] for i, s in enumerate(speeds)}
        labelled = set()
        for t in traces:
            time = np.asarray(t["time"]) - float(t["window"][0])
            s = float(t["speed"])
            label = None if s in labelled else f"{s:g} °/s"
            labelled.add(s)
            ax_v.plot(time, np.degrees(t["velocity"]), color=colour[s], lw=0.5, alpha=0.7,
                      label=label)  # fmt: skip
            ax_a.plot(time, np.degrees(t["acceleration"]), color=colour[s], lw=0.5, alpha=0.7)
        for s in speeds:  # one band per speed: the median window of its trials
            span = float(
                np.median(
                    [t["window"][1] - t["window"][0] for t in traces if float(t["speed"]) == s]
                )
            )
            for ax in (ax_v, ax_a):
                ax.axvspan(0.0, span, color=colour[s], alpha=0.10, lw=0)
        ax_v.set_ylabel("velocity [°/s]")
        ax_a.set_ylabel("acceleration [°/s²]")
        ax_a.set_xlabel("time from window start [s]")
        if speeds:
            ax_v.legend(loc="lower right")
        if title:
            fig.suptitle(f"{title}: fast trials, shaded = detected uniform-acceleration windows")
    return fig


def plot_inertia_by_speed(
    trials: pd.DataFrame, *, fig: Figure | None = None, width="double"
) -> Figure:
    """Per-trial inertia against nominal speed, one panel per condition (cf. Fig. 5).

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns ``condition``, ``speed`` (deg/s), ``inertia`` (kg m^2): the fast trials.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into.
    width : {"single", "double"} or float
        Figure width: a journal column (3.5 in), a page (7.0 in) or inches.

    Returns
    -------
    matplotlib.figure.Figure
        A panel per condition: trials (dots, jittered) and mean ± SD (square) per speed.
    """
    conditions = list(dict.fromkeys(trials["condition"]))
    n = max(1, len(conditions))
    w = figure_width(width)
    ncols = min(n, max(1, int(w // 1.7)))
    nrows = math.ceil(n / ncols)
    with style_context():
        fig = _figure(fig, (w, nrows * min(2.4, 0.85 * w / ncols) + 0.2))
        axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
        rng = np.random.default_rng(0)  # jitter only; deterministic figure
        for ax, cond in zip(axes, conditions, strict=False):
            sub = trials[trials["condition"] == cond]
            speeds = sorted(sub["speed"].unique())
            for i, s in enumerate(speeds):
                y = sub.loc[sub["speed"] == s, "inertia"].to_numpy()
                x = np.full(len(y), float(i)) + rng.uniform(-0.12, 0.12, len(y))
                ax.plot(x, y, "o", ms=2.5, color=PALETTE[0], alpha=0.6, mew=0)
                sd = y.std(ddof=1) if len(y) > 1 else 0.0
                ax.errorbar(i + 0.3, y.mean(), yerr=sd, fmt="s", color=PALETTE[1], ms=3.5,
                            capsize=2, lw=0.8)  # fmt: skip
            ax.set_xticks(range(len(speeds)), [f"{s:g}" for s in speeds])
            ax.set_xlim(-0.5, len(speeds) - 0.3)
            ax.set_xlabel("speed [°/s]")
            ax.set_ylabel("inertia $I$ [kg m$^2$]")
            ax.set_title(str(cond))
        for ax in axes[len(conditions) :]:
            ax.set_visible(False)
    return fig


# --- posterior figures --------------------------------------------------------------------------


def _box(posterior: Posterior, body: str) -> dict[str, tuple[float, float]]:
    cd = posterior.tree["constant_data"]
    return {
        p: (
            float(cd["lower"].sel(body=body, parameter=p)),
            float(cd["upper"].sel(body=body, parameter=p)),
        )
        for p in PARAMETERS
    }


def _check_body(posterior: Posterior, body: str) -> None:
    if body not in posterior.bodies:
        raise ValueError(f"body: expected one of {', '.join(posterior.bodies)}, got {body!r}")


def _check_parameters(parameters: Iterable[str]) -> tuple[str, ...]:
    known = (*PARAMETERS, *DERIVED)
    params = tuple(parameters)
    bad = [p for p in params if p not in known]
    if bad or not params:
        raise ValueError(f"parameters: expected some of {', '.join(known)}, got {params!r}")
    return params


def _curve(a: float, inertia: float, mass: np.ndarray) -> dict[str, np.ndarray]:
    """Points ``(m, x, rho)`` of the curve ``m x = a``, ``m (rho² + x²) = I`` at ``mass``."""
    x = a / mass
    rho = np.sqrt(np.clip(inertia / mass - x * x, 0.0, None))
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
    posterior : inertiafit.result.Posterior
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

    _check_body(posterior, body)
    checked = [tuple(p) for p in pairs]
    if not checked or any(len(p) != 2 or not set(p) <= set(PARAMETERS) or p[0] == p[1]
                          for p in checked):  # fmt: skip
        raise ValueError(
            f"pairs: expected pairs of distinct {', '.join(PARAMETERS)}, got {checked}"
        )
    pairs = [(str(p[0]), str(p[1])) for p in checked]
    box = _box(posterior, body)
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
        fig = _figure(fig, (w, nrows * panel_h + 1.0))
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
        data = f"$m x = M_g/g$ = {a_med:.3g} kg m, $I$ = {i_med:.3g} kg m$^2$"
        fig.suptitle(
            f"{body}: data fix {data};\nthe prior box, not the data, picks the point on the curve"
            if w >= 5
            else f"{body}\ndata fix {data};\nthe prior box picks the point on the curve"
        )
    return fig


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
    posterior : inertiafit.result.Posterior
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
    _check_body(posterior, body)
    params = _check_parameters(parameters)
    w = figure_width(width)
    with style_context():
        fig = _figure(fig, (w, 1.15 * len(params) + 0.45))
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
    posterior : inertiafit.result.Posterior
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
    _check_body(posterior, body)
    params = _check_parameters(parameters)
    if groups < 1 or bins < 1:
        raise ValueError(f"groups, bins: expected >= 1, got {groups}, {bins}")
    w = figure_width(width)
    ncols = len(params) if w >= 5 else 1
    nrows = math.ceil(len(params) / ncols)
    with style_context():
        fig = _figure(fig, (w, nrows * min(1.9, 0.75 * w / ncols) + 0.6))
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


# --- corner plots -------------------------------------------------------------------------------


def corner_figure(
    columns: Sequence[np.ndarray],
    *,
    labels: Sequence[str],
    titles: Sequence[str],
    ranges: Sequence[tuple[float, float]],
    boxes: Sequence[tuple[float, float] | None],
    priors: Sequence[np.ndarray | None],
    truths: Sequence[float | None] | None = None,
    quantiles: Sequence[float] = (0.16, 0.5, 0.84),
    note: str = "",
    fig: Figure | None = None,
    width="double",
    **corner_kwargs,
) -> Figure:
    """Corner plot in the house style, with prior-box edges and prior marginals.

    The engine behind :meth:`inertiafit.result.Posterior.corner` and
    :func:`plot_joint_corner`; use those.

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
        Known values drawn as lines; None entries are skipped.
    quantiles : sequence of float
        Quantiles marked on the diagonal.
    note : str
        Text in the top right corner.
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
        fig = _figure(fig, (w, w), layout=None)
        fig = corner.corner(data, fig=fig, **kwargs)
        for ax in fig.axes:
            _density_as_image(ax)
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
            _drop_hidden_points(ax)
        edge = {"color": PRIOR_COLOUR, "ls": (0, (3, 2)), "lw": 0.8, "clip_on": False}
        rng = kwargs["range"]
        for i in range(k):
            ax = axes[i, i]
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
        if note:
            fig.text(0.98, 0.98, note, ha="right", va="top", fontsize=8)
    return fig


def _density_as_image(ax) -> None:
    """Redraw corner.py's 2-D density shading (``pcolor``) as one image of the same cells.

    ``pcolor`` makes a path per histogram cell; a vector backend writes each one separately
    (900 per panel at 30 bins, most of the PDF's size and writing time). An image of the
    same cells, colours and place, not resampled (``interpolation="none"``), looks the same
    and is written once per panel.
    """
    from matplotlib.collections import PolyQuadMesh

    for mesh in [c for c in ax.collections if isinstance(c, PolyQuadMesh)]:
        edges = np.asarray(mesh.get_edgecolor(), dtype=float).reshape(-1, 4)
        if mesh.get_hatch() or (edges[:, 3] > 0).any():
            continue  # cell edges or hatching (pcolor_kwargs): not an image
        corners = np.asarray(mesh.get_coordinates())  # (rows + 1, columns + 1, 2), edges
        (x0, y0), (x1, y1) = corners[0, 0], corners[-1, -1]
        xlim, ylim = ax.get_xlim(), ax.get_ylim()
        ax.imshow(mesh.get_array(), cmap=mesh.get_cmap(), norm=mesh.norm, origin="lower",
                  extent=(x0, x1, y0, y1), interpolation="none", aspect="auto",
                  alpha=mesh.get_alpha(), zorder=mesh.get_zorder())  # fmt: skip
        mesh.remove()
        ax.set_xlim(xlim)
        ax.set_ylim(ylim)


#: Draws whose marker lies this far (pt) inside corner.py's opaque base fill are not drawn.
HIDDEN_MARGIN = 1.0


def _drop_hidden_points(ax) -> None:
    """Remove the posterior draws that corner.py's opaque base fill covers completely.

    corner.py plots every draw as a faint dot, then covers the dense region (inside the
    outermost contour) with a fill of the axes colour, so most dots are never seen but still
    cost drawing time in every format. Only dots whose whole marker lies at least
    :data:`HIDDEN_MARGIN` points inside the fill (and inside the frame) are removed, so the
    picture does not change. Call it once the axes have their final position: the fill is
    sampled on the page, a cell per pixel at the figure's dpi, and shrunk by the marker's
    reach.
    """
    from matplotlib.colors import to_rgba
    from matplotlib.contour import ContourSet
    from matplotlib.path import Path
    from scipy import ndimage

    fills = [c for c in ax.collections if isinstance(c, ContourSet) and c.filled]
    if not fills:
        return
    base = fills[0]  # corner.py's base fill comes first, then any contour fills
    colours = np.atleast_2d(np.asarray(base.get_facecolor(), dtype=float))
    if colours.size == 0 or np.any(colours[:, 3] < 1):
        return  # not opaque: every dot shows through
    dots = [
        line
        for line in ax.lines
        if line.get_rasterized()
        and line.get_linestyle() == "None"
        and line.get_zorder() < base.get_zorder()
    ]
    rings = [
        Path(ring)
        for path in base.get_paths()
        for ring in ax.transData.transform_path(path).to_polygons(closed_only=False)
    ]
    (x0, y0), (x1, y1) = ax.bbox.get_points()
    nx, ny = math.ceil(x1 - x0), math.ceil(y1 - y0)
    if not (dots and rings and nx > 0 and ny > 0):
        return
    cx, cy = np.meshgrid(x0 + 0.5 + np.arange(nx), y0 + 0.5 + np.arange(ny))
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    filled = np.zeros(len(centres), dtype=bool)
    for ring in rings:  # even-odd: holes in the fill are rings inside rings
        filled ^= ring.contains_points(centres)
    for line in dots:
        xy = np.column_stack([line.get_xdata(), line.get_ydata()]).astype(float)
        edge = to_rgba(line.get_markeredgecolor())[3] > 0
        radius = 0.5 * (line.get_markersize() + (line.get_markeredgewidth() if edge else 0.0))
        reach = (HIDDEN_MARGIN + radius) * ax.figure.dpi / 72
        r = math.ceil(reach) + 1
        disk = np.hypot(*np.mgrid[-r : r + 1, -r : r + 1]) <= r
        # cells whose whole disk is filled; the frame counts as unfilled (clipping differs)
        covered = ndimage.binary_erosion(filled.reshape(ny, nx), structure=disk, border_value=0)
        display = ax.transData.transform(xy)
        ix = np.floor(display[:, 0] - x0)
        iy = np.floor(display[:, 1] - y0)
        on_page = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & np.isfinite(display).all(1)
        hidden = np.zeros(len(xy), dtype=bool)
        hidden[on_page] = covered[iy[on_page].astype(int), ix[on_page].astype(int)]
        if hidden.any():
            line.set_data(xy[~hidden, 0], xy[~hidden, 1])


def plot_joint_corner(
    posterior: Posterior,
    *,
    parameters: Sequence[str] = PARAMETERS,
    truths: Mapping[str, Any] | None = None,
    bodies: Sequence[str] | None = None,
    quantiles: Sequence[float] = (0.16, 0.5, 0.84),
    fig: Figure | None = None,
    width="double",
    **corner_kwargs,
) -> Figure:
    """One corner plot over every body's parameters: correlations between bodies show.

    Bodies measured together (condition B = attachment + segment) share evidence, so their
    parameters are correlated; a per-body corner hides that.

    Parameters
    ----------
    posterior : inertiafit.result.Posterior
        The fit.
    parameters : sequence of str
        Quantities per body (names as :func:`plot_trace`). Axes of ``mass``, ``com_distance``
        and ``radius_of_gyration`` span that body's prior box.
    truths : mapping of str to mapping of str to float, optional
        Known values per body and parameter (SI units), e.g. ``{"weight": {"mass": 2.92}}``;
        a value may also be an object with ``as_dict()``, such as an ideal body.
    bodies : sequence of str, optional
        Bodies to include, in order; default all.
    quantiles : sequence of float
        Quantiles marked on the 1-D histograms.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into (without a layout engine).
    width : {"single", "double"} or float
        Figure width and height (in).
    **corner_kwargs
        Passed on to :func:`corner.corner`.

    Returns
    -------
    matplotlib.figure.Figure
        ``K x K`` axes, ``K = len(bodies) * len(parameters)``, labelled ``"body: m [kg]"``.

    Raises
    ------
    ValueError
        An unknown body or parameter.
    """
    params = _check_parameters(parameters)
    names = tuple(posterior.bodies if bodies is None else bodies)
    for b in names:
        _check_body(posterior, b)
    columns: list[np.ndarray] = []
    priors: list[np.ndarray | None] = []
    labels: list[str] = []
    titles: list[str] = []
    ranges: list[tuple[float, float]] = []
    boxes: list[tuple[float, float] | None] = []
    marks: list[float | None] = []
    for b in names:
        box = _box(posterior, b)
        known = (truths or {}).get(b) or {}
        if not isinstance(known, Mapping):  # an ideal body (inertiafit.shapes) and the like
            known = known.as_dict()
        for p in params:
            x = posterior.draws(b, p).ravel()
            columns.append(x)
            # a long body name goes on its own line, or neighbouring labels overlap
            labels.append(axis_label(p, b if len(b) <= 12 else f"{b}\n"))
            titles.append(SYMBOLS[p])
            if p in box:
                ranges.append(box[p])
                boxes.append(box[p])
            else:
                lo, hi = np.quantile(x, [0.001, 0.999])
                ranges.append((float(lo - 0.1 * (hi - lo)), float(hi + 0.1 * (hi - lo))))
                boxes.append(None)
            priors.append(posterior.draws(b, p, "prior").ravel())
            marks.append(known.get(p))
    return corner_figure(
        columns,
        labels=labels,
        titles=titles,
        ranges=ranges,
        boxes=boxes,
        priors=priors,
        truths=marks,
        quantiles=quantiles,
        note="axes of $m$, $x$, $\\rho$ span the prior boxes; grey: prior",
        fig=fig,
        width=width,
        **corner_kwargs,
    )
