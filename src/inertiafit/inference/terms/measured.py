"""A direct measurement of one body (a weighed mass, a balance point) as a likelihood term.

Gaussian in the quantity read (:class:`inertiafit.measured.MeasuredQuantity`): a function of
the body's mass and CoM distance, so of its angle once its ``(a, b)`` is fixed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from inertiafit.errors import InputError
from inertiafit.inference.observations import Observation
from inertiafit.inference.terms.base import CORE_SDS, WINDOW_TAIL, CurvePiece, Point, register_term
from inertiafit.measured import MEASURED_QUANTITIES, MeasuredQuantity, measured_quantity

__all__ = ["MeasuredEvidence"]


@register_term
@dataclass(frozen=True)
class MeasuredEvidence:
    """``body``'s ``quantity`` (a name of ``MEASURED_QUANTITIES``) measured as ``observation``."""

    body: str
    quantity: str
    observation: Observation
    kind: ClassVar[str] = "measured"
    VARIABLES: ClassVar[tuple[str, ...]] = tuple(MEASURED_QUANTITIES)

    def __post_init__(self) -> None:
        measured_quantity(self.quantity, where=f"measured.{self.body}")
        if not isinstance(self.observation, Observation):
            raise InputError(f"measured.{self.body}.{self.quantity}: expected an Observation")

    @property
    def measured(self) -> MeasuredQuantity:
        """Its declaration in the registry."""
        return measured_quantity(self.quantity, where=f"measured.{self.body}")

    @property
    def variables(self) -> tuple[str, ...]:
        """One ``log_likelihood`` variable, named after the quantity."""
        return (self.quantity,)

    @property
    def bodies(self) -> tuple[str, ...]:
        """The body measured."""
        return (self.body,)

    @property
    def angle_body(self) -> str:
        """The body measured: its quantity is a function of its angle."""
        return self.body

    @property
    def label(self) -> str:
        """Its coordinate: the body."""
        return self.body

    def dims(self) -> dict[str, str]:
        """The quantity's body dimension."""
        return {self.quantity: self.measured.body_dim}

    def log_likelihood(self, point: Point) -> dict[str, np.ndarray]:
        """The Gaussian at the body's true mass (``point.mass``) and ``x = a / m``."""
        assert point.mass is not None
        k = point.column(self.body)
        m_k = point.mass[..., k]
        value = self.measured.value(m_k, point.true_a[..., k] / m_k)
        return {self.quantity: self.observation.logpdf(value)}

    def _masses(self, a, half: float):
        c = self.observation.center
        return self.measured.masses(c - half, c + half, a)

    @cached_property
    def _curve_halfwidths(self) -> tuple[float, float]:
        """Half-widths of the reading's window and core on the curve (:meth:`curve`)."""
        obs = self.observation
        return obs.quantile_halfwidth(WINDOW_TAIL), CORE_SDS * obs.total_scale

    def curve(self, point: Point | None, a_k) -> CurvePiece:
        """The Gaussian on the body's curve; the masses where the quantity is near its reading."""
        del point  # a function of the body's own parameters only
        obs, q = self.observation, self.measured
        window, core = self._curve_halfwidths
        return CurvePiece(
            lambda m, x: obs.logpdf(q.value(m, x)),
            self._masses(a_k, window),
            self._masses(a_k, core),
        )

    def body_masses(self, first_moment: tuple[float, float], tail: float) -> tuple[float, float]:
        """Masses the reading allows over ``a`` in ``first_moment`` (all but ``tail``)."""
        h = self.observation.quantile_halfwidth(tail)
        lo = self._masses(np.asarray(first_moment[0], float), h)[0]
        hi = self._masses(np.asarray(first_moment[1], float), h)[1]
        return float(lo), float(hi)

    def body_log_likelihood(self, params: Mapping[str, Any]):
        """The Gaussian at a lone body's mass and CoM distance."""
        return self.observation.logpdf(self.measured.value(params["mass"], params["com_distance"]))
