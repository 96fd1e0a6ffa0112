"""inertiafit: inertial parameters of a body segment from isokinetic dynamometer trials.

A slow passive move gives the gravitational moment ``M_g = m g x``; fast passive moves give the
moment of inertia about the joint ``I = m (rho^2 + x^2)``. inertiafit turns repeated trials of
both into a posterior over mass ``m``, centre-of-mass distance ``x`` and radius of gyration
``rho``, says which of them the data identify and which only the prior does, and draws corner
plots and tables for papers.

Heavy modules (emcee, arviz, corner, matplotlib) are imported only when a function needs them.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("inertiafit")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "0+unknown"

_LAZY = {
    "Prior": "inertiafit.priors",
    "load_prior": "inertiafit.priors",
    "available_priors": "inertiafit.priors",
    "Observation": "inertiafit.observations",
    "Condition": "inertiafit.model",
    "Model": "inertiafit.model",
    "fit": "inertiafit.inference",
    "fit_body": "inertiafit.inference",
    "sample": "inertiafit.sampler",
    "SamplerSettings": "inertiafit.sampler",
    "analyse_study": "inertiafit.study",
    "run_study": "inertiafit.study",
    "run_many": "inertiafit.batch",
    "Posterior": "inertiafit.result",
    "open_posterior": "inertiafit.result",
    "reference_posterior": "inertiafit.reference",
    "paper_baseline": "inertiafit.baseline",
    "read_trial": "inertiafit.io",
    "load_study": "inertiafit.io",
    "InputError": "inertiafit.errors",
    "ConvergenceWarning": "inertiafit.errors",
}

__all__ = ["__version__"]
__all__ += list(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'inertiafit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
