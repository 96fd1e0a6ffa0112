"""inertiafit: inertial parameters of a body segment from isokinetic dynamometer trials.

A slow passive move gives the gravitational moment ``M_g = m g x``; fast passive moves give the
moment of inertia about the joint ``I = m (rho^2 + x^2)``. inertiafit turns repeated trials of
both into a posterior over mass ``m``, centre-of-mass distance ``x`` and radius of gyration
``rho``, says which of them the data identify and which only the prior does, and draws corner
plots and tables for papers.

The public names are listed in ``__init__.pyi`` (read by type checkers and IDEs) and loaded on
first use (SPEC 1, ``lazy_loader``): emcee, arviz, corner and matplotlib cost seconds to import,
and ``import inertiafit`` should not.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

import lazy_loader

try:
    __version__ = version("inertiafit")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "0+unknown"

__getattr__, _, __all__ = lazy_loader.attach_stub(__name__, __file__)
__all__ += ["__version__"]


def __dir__() -> list[str]:
    return sorted(__all__)
