"""The joint corner plot of every body's parameters of a posterior."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from inertiafit.physics import PARAMETERS, SYMBOLS
from inertiafit.plotting.corner import corner_figure, posterior_range
from inertiafit.plotting.style import axis_label
from inertiafit.report.plots.checks import check_body, check_parameters

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from inertiafit.posterior import Posterior

__all__ = ["plot_joint_corner"]


def plot_joint_corner(
    posterior: Posterior,
    *,
    parameters: Sequence[str] = PARAMETERS,
    truths: Mapping[str, Any] | None = None,
    ideals: Mapping[str, Any] | None = None,
    bodies: Sequence[str] | None = None,
    quantiles: Sequence[float] = (0.16, 0.5, 0.84),
    prior_box: bool | str = "band",
    fig: Figure | None = None,
    width="double",
    **corner_kwargs,
) -> Figure:
    """One corner plot over every body's parameters: correlations between bodies show.

    Bodies measured together (condition B = attachment + segment) share evidence, so their
    parameters are correlated; a per-body corner hides that.

    Parameters
    ----------
    posterior : inertiafit.posterior.Posterior
        The fit.
    parameters : sequence of str
        Quantities per body (names as :func:`plot_trace`).
    truths : mapping of str to mapping of str to float, optional
        Known values per body and parameter (SI units), e.g. ``{"weight": {"mass": 2.92}}``;
        a value may also be an object with ``as_dict()``, such as an ideal body.
    ideals : mapping of str to mapping of str to float, optional
        Ideal (textbook) values per body, drawn dashed in another colour than ``truths``.
    bodies : sequence of str, optional
        Bodies to include, in order; default all.
    quantiles : sequence of float
        Quantiles marked on the 1-D histograms.
    prior_box : {"band", True, False}
        As :meth:`~inertiafit.posterior.Posterior.corner`: axes zoomed to the posterior with
        each prior box shaded (default), axes spanning the boxes, or no boxes.
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
    params = check_parameters(parameters)
    names = tuple(posterior.bodies if bodies is None else bodies)
    for b in names:
        check_body(posterior, b)
    columns: list[np.ndarray] = []
    priors: list[np.ndarray | None] = []
    labels: list[str] = []
    titles: list[str] = []
    ranges: list[tuple[float, float]] = []
    boxes: list[tuple[float, float] | None] = []
    marks: list[float | None] = []
    ideal_marks: list[float | None] = []
    for b in names:
        box = posterior.prior_box(b)
        known = _values((truths or {}).get(b))
        ideal = _values((ideals or {}).get(b))
        for p in params:
            x = posterior.draws(b, p).ravel()
            columns.append(x)
            # the body's name on a line of its own, or neighbouring labels run together
            labels.append(axis_label(p, f"{b}\n"))
            titles.append(SYMBOLS[p])
            edges = box[p] if prior_box and p in box else None
            spanned = edges is not None and prior_box is True
            ranges.append(edges if edges is not None and spanned else posterior_range(x, edges))
            boxes.append(edges)
            priors.append(posterior.draws(b, p, "prior").ravel())
            marks.append(known.get(p))
            ideal_marks.append(ideal.get(p))
    return corner_figure(
        columns,
        labels=labels,
        titles=titles,
        ranges=ranges,
        boxes=boxes,
        priors=priors,
        truths=marks,
        ideals=ideal_marks if ideals else None,
        quantiles=quantiles,
        note=(
            "axes of $m$, $x$, $\\rho$ span the prior boxes; grey: prior"
            if prior_box is True
            else "shaded: prior box; grey: prior marginal"
        ),
        band=prior_box == "band",
        fig=fig,
        width=width,
        **corner_kwargs,
    )


def _values(known: Any) -> Mapping[str, float]:
    """Values by parameter; an ideal body (:mod:`inertiafit.shapes`) by its ``as_dict()``."""
    if not known:
        return {}
    return known if isinstance(known, Mapping) else known.as_dict()
