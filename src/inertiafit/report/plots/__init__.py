"""Figures of a study and of a posterior, sized for journal columns.

One module per kind of figure: :mod:`~inertiafit.report.plots.intervals` (every body's
quantities against their prior, the report's first figure),
:mod:`~inertiafit.report.plots.trials` (fast trials, inertia by speed),
:mod:`~inertiafit.report.plots.fits` (each fast trial's ``tau``-``alpha`` line, each sweep's
gravity model and residuals), :mod:`~inertiafit.report.plots.identification` (the identification curve),
:mod:`~inertiafit.report.plots.diagnostics` (traces, rank plots),
:mod:`~inertiafit.report.plots.emg` (EMG envelopes against their thresholds),
:mod:`~inertiafit.report.plots.living` (a living joint's passive curve, static fit and fast
trials with their deceleration windows) and
:mod:`~inertiafit.report.plots.corner` (the joint corner plot). Posterior figures take a
:class:`inertiafit.posterior.Posterior` (walkers are the ``chain`` dimension of its tree) and a
body name. The house style, sizes and saving are :mod:`inertiafit.plotting`'s (not re-exported:
one name, one home).
``docs/figures.md`` says how to read each figure.
"""

from __future__ import annotations

from inertiafit.report.plots.corner import plot_joint_corner
from inertiafit.report.plots.diagnostics import plot_rank, plot_trace, rank_groups
from inertiafit.report.plots.emg import plot_emg_envelopes
from inertiafit.report.plots.fits import gravity_model, plot_gravity_fit, plot_tau_alpha
from inertiafit.report.plots.identification import CURVE_PAIRS, plot_identification_curve
from inertiafit.report.plots.intervals import VERDICT_STYLE, interval_table, plot_intervals
from inertiafit.report.plots.living import (
    plot_living_fast_trials,
    plot_passive_curve,
    plot_static_fit,
)
from inertiafit.report.plots.trials import plot_fast_trials, plot_inertia_by_speed

__all__ = [
    "CURVE_PAIRS",
    "VERDICT_STYLE",
    "gravity_model",
    "interval_table",
    "plot_emg_envelopes",
    "plot_fast_trials",
    "plot_gravity_fit",
    "plot_identification_curve",
    "plot_inertia_by_speed",
    "plot_intervals",
    "plot_joint_corner",
    "plot_living_fast_trials",
    "plot_passive_curve",
    "plot_rank",
    "plot_static_fit",
    "plot_tau_alpha",
    "plot_trace",
    "rank_groups",
]
