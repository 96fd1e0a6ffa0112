"""The posterior of a fit: an ArviZ DataTree viewed as tables, a corner plot and a text report.

:class:`Posterior` (in :mod:`inertiafit.posterior.core`) holds the tree and gives the summary,
identification and prior-box views; :mod:`inertiafit.posterior.display` writes its text and
HTML displays. :func:`open_posterior` reads a saved ``posterior.nc``.
"""

from __future__ import annotations

from inertiafit.posterior.core import (
    SUMMARY_COLUMNS,
    Posterior,
    inputs_json,
    open_posterior,
)

__all__ = [
    "SUMMARY_COLUMNS",
    "Posterior",
    "inputs_json",
    "open_posterior",
]
