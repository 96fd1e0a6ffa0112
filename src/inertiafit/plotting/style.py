"""The house style of every figure: palette, journal widths, rcParams, axis labels, saving.

Figures are drawn into a :class:`matplotlib.figure.Figure` (a new one, not managed by pyplot,
from :func:`new_figure`) inside :func:`style_context`, so the house style :data:`STYLE` never
changes global rcParams. :func:`save_figure` writes a figure in any of :data:`FIGURE_FORMATS`;
:func:`check_formats` is the one check of a list of formats, for the library and the command
line alike.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inertiafit.errors import InputError
from inertiafit.physics import SYMBOLS, UNITS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "DEFAULT_DPI",
    "DEFAULT_FORMATS",
    "DOUBLE_COLUMN",
    "DPI_RANGE",
    "DPI_VARIABLE",
    "FIGURE_FORMATS",
    "PALETTE",
    "PNG_COMPRESSION",
    "PRIOR_COLOUR",
    "SINGLE_COLUMN",
    "STYLE",
    "axis_label",
    "check_formats",
    "figure_dpi",
    "figure_width",
    "new_figure",
    "save_figure",
    "style_context",
]

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

#: Every format a figure can be written in: vector PDF and SVG, raster PNG.
FIGURE_FORMATS = ("pdf", "png", "svg")
#: The formats the commands write a result's figures in unless asked for others
#: (``--formats png,pdf``): PNG, which report.html embeds. Vector PDF costs twice the PNG's
#: time per figure, so it is written where asked.
DEFAULT_FORMATS: tuple[str, ...] = ("png",)
#: Resolution (dots per inch) of every PNG inertiafit saves, the figures of a report included:
#: what journals ask of line art with text at print size.
DEFAULT_DPI = 300
#: The environment variable that sets another resolution (:func:`figure_dpi`), for drafts
#: (100 draws a study's figures in about half the time) or a printer's demands; the test
#: suite sets it to 100.
DPI_VARIABLE = "INERTIAFIT_DPI"
#: The resolutions :data:`DPI_VARIABLE` may name.
DPI_RANGE = (50.0, 1200.0)


def figure_dpi() -> float:
    """The resolution PNGs are saved at: :data:`DPI_VARIABLE` where set, else :data:`DEFAULT_DPI`.

    Raises
    ------
    inertiafit.errors.InputError
        The variable is set to something other than a number of dots per inch in
        :data:`DPI_RANGE` (one line naming it).
    """
    text = os.environ.get(DPI_VARIABLE, "").strip()
    if not text:
        return float(DEFAULT_DPI)
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    low, high = DPI_RANGE
    if not low <= value <= high:  # nan fails too
        raise InputError(
            f"environment variable {DPI_VARIABLE}: expected dots per inch from {low:g} to "
            f"{high:g}, got {text!r}"
        )
    return value


def check_formats(formats: str | Iterable[str], where: str = "formats") -> tuple[str, ...]:
    """Figure formats checked against :data:`FIGURE_FORMATS`, stripped and lower-cased.

    Parameters
    ----------
    formats : str or iterable of str
        Format names, or one comma-separated string such as ``"pdf,png"``. Empty entries
        (``"pdf,,png"``) are skipped.
    where : str
        The argument's name, at the start of the error message.

    Returns
    -------
    tuple of str
        The formats, in the order given.

    Raises
    ------
    inertiafit.errors.InputError
        An unknown format, or none at all.
    """
    given = formats.split(",") if isinstance(formats, str) else [str(f) for f in formats]
    out = tuple(f.strip().lower() for f in given if f.strip())
    if not out or any(f not in FIGURE_FORMATS for f in out):
        raise InputError(
            f"{where}: expected a comma-separated subset of {','.join(FIGURE_FORMATS)}, "
            f"got {','.join(given)!r}"
        )
    return out


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


def new_figure(
    fig: Figure | None, size: tuple[float, float], layout: Any = "constrained"
) -> Figure:
    """``fig`` if given, else a new Figure (not managed by pyplot) of ``size`` inches.

    Parameters
    ----------
    fig : matplotlib.figure.Figure or None
        A figure to draw into, returned as it is.
    size : (float, float)
        Width and height (in) of a new figure.
    layout : str or None
        Layout engine of a new figure; None for none (corner.py sets its own margins).
    """
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


#: zlib level of saved PNGs. Pillow's default, 6, spent 12 % of a figure's save on squeezing
#: files 3-10 % smaller than level 1 does (measured on the demo's 12 figures at 150 dpi).
PNG_COMPRESSION = 1


def save_figure(
    fig: Figure,
    stem: str | Path,
    formats: str | Iterable[str] = ("pdf", "png"),
    dpi: float | None = None,
) -> list[Path]:
    """Write a figure as vector PDF (and SVG when asked) and raster PNG.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    stem : str or path-like
        Path without extension; ``.pdf``, ``.png``, ``.svg`` are appended. Its folder must exist.
    formats : iterable of {"pdf", "png", "svg"}, or a comma-separated str
        Formats to write, in order (checked by :func:`check_formats`).
    dpi : float
        Resolution of the PNG (dots per inch; default :func:`figure_dpi`); rasterised layers
        of the vector files too.

    Returns
    -------
    list of pathlib.Path
        The written files, in the order of ``formats``.

    Raises
    ------
    inertiafit.errors.InputError
        An unknown format or no format at all (a :class:`ValueError`).
    """
    checked = check_formats(formats)
    dpi = figure_dpi() if dpi is None else dpi
    # No dates in the files: the same figure gives the same bytes.
    metadata = {"pdf": {"CreationDate": None}, "svg": {"Date": None}, "png": {"Software": None}}
    paths = []
    # A layout engine (constrained layout) places the axes again at every save, the costliest
    # part of drawing small figures; the first format's layout serves the others too (the
    # backends' text metrics differ by a fraction of a point), then the engine is restored.
    engine = fig.get_layout_engine()
    with style_context():
        try:
            for fmt in checked:
                path = Path(f"{stem}.{fmt}")
                extra: dict[str, Any] = (
                    {"pil_kwargs": {"compress_level": PNG_COMPRESSION}} if fmt == "png" else {}
                )
                fig.savefig(path, format=fmt, dpi=dpi, metadata=metadata[fmt], **extra)
                paths.append(path)
                if engine is not None and fig.get_layout_engine() is engine:
                    fig.set_layout_engine("none")
        finally:
            if engine is not None and fig.get_layout_engine() is not engine:
                fig.set_layout_engine(engine)
    return paths
