"""Validation harnesses: checks that the posterior and the planner's predictions are right.

Nothing in the library's commands uses these; the tests and the benchmarks do.

- :mod:`~inertiafit.validation.sbc`: simulation-based calibration (truths from the prior,
  data from the likelihood, ranks of the truths among posterior draws);
- :mod:`~inertiafit.validation.widths`: the planner's predicted widths measured on full
  simulated studies (:func:`simulated_widths`).
"""

from __future__ import annotations

__all__: list[str] = []
