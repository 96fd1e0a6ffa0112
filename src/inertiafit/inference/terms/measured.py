"""A direct measurement of one body (a weighed mass, a balance point) as a likelihood term.

Gaussian in the quantity read (:class:`inertiafit.measured.MeasuredQuantity`): a function of
the body's mass and CoM distance, so of its angle once its ``(a, b)`` is fixed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from inertiafit.errors import InputError
from inertiafit.inference.observations import Observation
from inertiafit.inference.terms.base import (
    CORE_SDS,
    WINDOW_TAIL,
    CurvePiece,
    Datum,
    MethodsText,
    Point,
    Source,
    TermData,
    register_term,
)
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
    #: Each quantity credited by its words (``weighed mass``), pinning the parameter it reads.
    SOURCES: ClassVar[Mapping[str, Source]] = {
        q.name: Source(q.label, (q.name,)) for q in MEASURED_QUANTITIES.values()
    }

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

    def curve(self, point: Point | None, a_k, b_k) -> CurvePiece:
        """The Gaussian on the body's curve; the masses where the quantity is near its reading."""
        del point, b_k  # a function of the body's own mass and first moment only
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

    @classmethod
    def data(cls, terms: Sequence[MeasuredEvidence], bodies: Sequence[str]) -> TermData:
        """Each quantity's readings along its body dimension, and their centre and SD per body.

        ``observed_data``: the quantity's name along ``body_dim``, for the bodies that have it
        (none: no variable). ``constant_data``: every quantity's value and SD along ``body``
        (:attr:`~inertiafit.measured.MeasuredQuantity.constant_vars`; NaN where none).
        """
        read = {(t.body, t.quantity): t.observation for t in terms}
        observed: dict[str, Datum] = {}
        constant: dict[str, Datum] = {}
        for key, q in MEASURED_QUANTITIES.items():
            for part, name in zip(("center", "total_scale"), q.constant_vars, strict=True):
                vals = [
                    float(getattr(read[b, key], part)) if (b, key) in read else math.nan
                    for b in bodies
                ]
                constant[name] = Datum("body", np.array(vals))
        for key, q in MEASURED_QUANTITIES.items():
            having = [b for b in bodies if (b, key) in read]
            if having:
                observed[key] = Datum(
                    q.body_dim,
                    np.array([read[b, key].center for b in having]),
                    q.unit,
                    {q.body_dim: having},
                )
        return TermData(observed, constant)

    @classmethod
    def methods(cls, tree: Any) -> list[MethodsText]:
        """Each quantity some body has a reading of (``constant_data``), in the registry's order."""
        cd = tree["constant_data"]
        out = []
        for q in MEASURED_QUANTITIES.values():
            name = q.constant_vars[0]
            if name in cd and np.isfinite(np.asarray(cd[name], float)).any():
                out.append(MethodsText(f"a {q.label}", measures=(q.name,)))
        return out
