"""The commands as library functions: each runs the stages in order and writes the outputs.

- :mod:`~inertiafit.pipeline.study`: :func:`analyse_study` and :func:`run_study` (``run``);
- :mod:`~inertiafit.pipeline.fit`: :func:`run_fit` (``fit``: one body from numbers);
- :mod:`~inertiafit.pipeline.redraw`: :func:`redraw` (``report``: from saved outputs);
- :mod:`~inertiafit.pipeline.demo`: :func:`run_demo` (``demo``);
- :mod:`~inertiafit.pipeline.batch`: :func:`run_many` (``run-many``: many studies, on Dask);
- :mod:`~inertiafit.pipeline.plan`: :func:`run_plan` (``plan``: predicted widths of candidate
  designs, from the planner of :mod:`inertiafit.planning`);
- :mod:`~inertiafit.pipeline.export`: :func:`run_export` (``export``: a results folder's
  posterior as biorbd, OpenSim or JSON model files).
"""

from __future__ import annotations

__all__: list[str] = []
