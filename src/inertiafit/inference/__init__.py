"""From evidence to the posterior: priors, likelihood, model, sampler, exact reference.

- :mod:`~inertiafit.inference.priors`: prior boxes, from files or tables;
- :mod:`~inertiafit.inference.anthropometric`: priors from published anthropometric tables
  (de Leva, Dempster/Winter), body mass and segment length;
- :mod:`~inertiafit.inference.observations`: the likelihood of one observable;
- :mod:`~inertiafit.inference.evidence`: where a study's trials become evidence;
- :mod:`~inertiafit.inference.model`: the joint model in the sampled coordinates;
- :mod:`~inertiafit.inference.moves`: the Laplace fit and the Student-t proposal both samplers
  use;
- :mod:`~inertiafit.inference.sampler` (emcee) and :mod:`~inertiafit.inference.blocked` (the
  blocked Gibbs sampler for an attachment with segments);
- :mod:`~inertiafit.inference.fit`: where the posterior is sampled and packaged;
- :mod:`~inertiafit.inference.reference`: the exact quadrature posterior the sampler is held to.

Simulation-based calibration of all this is a validation harness outside the layer
(:mod:`inertiafit.validation.sbc`).
"""

from __future__ import annotations

__all__: list[str] = []
