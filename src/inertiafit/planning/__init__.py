"""Planning a session (``inertiafit plan``): predicted posterior widths of candidate designs.

- :mod:`~inertiafit.planning.design`: what a session would measure (:class:`Design`, its
  :class:`Mounting` conditions) and the noise of a trial (:class:`NoiseLevels`);
- :mod:`~inertiafit.planning.planner`: :func:`plan`, the predicted SD and HDI width of every
  body's parameters per design (and the fewest trials reaching requested widths);
- :mod:`~inertiafit.planning.files`: a design file (TOML) and a pilot study's outputs as the
  planner's inputs.

The command that writes ``plan.csv`` is :func:`inertiafit.pipeline.plan.run_plan`; the check of
the predictions against full simulated studies is :mod:`inertiafit.validation.widths`.
"""

from __future__ import annotations

__all__: list[str] = []
