"""Checks of the arguments every posterior figure takes: a body name and quantity names."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from inertiafit.physics import REPORTED

if TYPE_CHECKING:
    from inertiafit.posterior import Posterior

__all__ = ["check_body", "check_parameters"]


def check_body(posterior: Posterior, body: str) -> None:
    """Raise :class:`ValueError` unless ``body`` is one of the posterior's bodies."""
    if body not in posterior.bodies:
        raise ValueError(f"body: expected one of {', '.join(posterior.bodies)}, got {body!r}")


def check_parameters(parameters: Iterable[str]) -> tuple[str, ...]:
    """``parameters`` as a tuple, or a :class:`ValueError` for an unknown name or none."""
    params = tuple(parameters)
    bad = [p for p in params if p not in REPORTED]
    if bad or not params:
        raise ValueError(f"parameters: expected some of {', '.join(REPORTED)}, got {params!r}")
    return params
