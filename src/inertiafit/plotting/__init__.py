"""Figures in the house style, from arrays: sizes, style, saving and the corner-plot engine.

Every figure is drawn into a :class:`matplotlib.figure.Figure` (a new one, not managed by
pyplot, unless ``fig=`` is given), returned, never shown, and never changes global rcParams:
the house style :data:`~inertiafit.plotting.style.STYLE` is applied with
:func:`matplotlib.rc_context` only while the figure is built (and by
:func:`~inertiafit.plotting.style.save_figure` while it is written). ``width=`` takes
``"single"`` (:data:`~inertiafit.plotting.style.SINGLE_COLUMN`, 3.5 in), ``"double"``
(:data:`~inertiafit.plotting.style.DOUBLE_COLUMN`, 7.0 in) or a width in inches; heights
follow from the content.

- :mod:`~inertiafit.plotting.style`: palette, widths, rcParams, axis labels, formats, saving;
- :mod:`~inertiafit.plotting.corner`: :func:`~inertiafit.plotting.corner.corner_figure`, a corner
  plot of arrays;
- :mod:`~inertiafit.plotting.raster`: the two steps that make corner plots cheap to write.

Nothing here knows a posterior or a study: :mod:`inertiafit.report.plots` draws those.
Matplotlib and corner are imported only when a figure is drawn.
"""

from __future__ import annotations

from inertiafit.plotting.corner import corner_figure
from inertiafit.plotting.style import (
    DEFAULT_DPI,
    DOUBLE_COLUMN,
    FIGURE_FORMATS,
    PALETTE,
    PRIOR_COLOUR,
    SINGLE_COLUMN,
    STYLE,
    axis_label,
    check_formats,
    figure_width,
    new_figure,
    save_figure,
    style_context,
)

__all__ = [
    "DEFAULT_DPI",
    "DOUBLE_COLUMN",
    "FIGURE_FORMATS",
    "PALETTE",
    "PRIOR_COLOUR",
    "SINGLE_COLUMN",
    "STYLE",
    "axis_label",
    "check_formats",
    "corner_figure",
    "figure_width",
    "new_figure",
    "save_figure",
    "style_context",
]
