"""Two Matplotlib post-processing steps that make corner plots cheap to write, unchanged.

corner.py draws a 2-D panel as ``pcolor`` shading (a path per histogram cell), every draw as a
faint dot and an opaque fill over the dense region. :func:`density_as_image` redraws the
shading as one image of the same cells; :func:`drop_hidden_points` removes the dots the fill
covers. Neither changes a pixel; both cut the size and writing time of vector files.
:func:`inertiafit.plotting.corner.corner_figure` applies them.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["HIDDEN_MARGIN", "density_as_image", "drop_hidden_points"]

#: Draws whose marker lies this far (pt) inside corner.py's opaque base fill are not drawn.
HIDDEN_MARGIN = 1.0


def density_as_image(ax) -> None:
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


def drop_hidden_points(ax) -> None:
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
