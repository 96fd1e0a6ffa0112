"""A condition's evidence as a likelihood term.

A Student-t on its total ``I``, a Gaussian on its total ``M_g``
(:class:`~inertiafit.inference.model.Condition`).

A function of the sampled coordinates alone, unless a body of the condition is moved along the
lever (``Condition(offset_body=, offset=)``): its totals then grow with that body's mass
(``a + m d``, ``I + 2 a d + m d^2``), so the term lies on that body's angle.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from inertiafit import physics
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
from inertiafit.physics import UNITS


class ConditionView(Protocol):
    """What the term reads of its :class:`~inertiafit.inference.model.Condition`.

    Named here rather than imported: the model imports the terms.
    """

    @property
    def bodies(self) -> tuple[str, ...]: ...

    @property
    def label(self) -> str: ...

    @property
    def offset_body(self) -> str: ...

    @property
    def offset(self) -> float: ...

    @property
    def inertia(self) -> Observation | None: ...

    @property
    def gravity_moment(self) -> Observation | None: ...

    @property
    def coupling(self) -> float: ...

    @property
    def added_first_moment(self) -> float: ...

    @property
    def added_inertia(self) -> float: ...

    def inertia_at(self, inertia: Any, gravity_moment: Any) -> Any:
        """Where the inertia evidence is evaluated for true totals ``I`` and ``M_g``."""
        ...


__all__ = ["ConditionEvidence"]


def _interval(center, half, slope, intercept):
    """Masses where ``intercept + slope * m`` lies in ``center +- half``."""
    lo = (center - half - intercept) / slope
    hi = (center + half - intercept) / slope
    return np.minimum(lo, hi), np.maximum(lo, hi)


@register_term
@dataclass(frozen=True)
class ConditionEvidence:
    """The evidence of ``condition``, column ``index`` of the totals, under ``gravity``."""

    index: int
    condition: ConditionView
    gravity: float
    kind: ClassVar[str] = "condition"
    VARIABLES: ClassVar[tuple[str, ...]] = ("inertia", "gravity_moment")
    #: The dynamometer's own evidence informs every body; a condition that moves a body is
    #: that body's second mounting.
    SOURCES: ClassVar[Mapping[str, Source]] = {
        v: Source("data", credits="all", moved="second mounting") for v in VARIABLES
    }

    @property
    def variables(self) -> tuple[str, ...]:
        """``inertia`` and ``gravity_moment``, those the condition has."""
        return tuple(v for v in self.VARIABLES if getattr(self.condition, v) is not None)

    @property
    def bodies(self) -> tuple[str, ...]:
        """The mounted bodies."""
        return self.condition.bodies

    @property
    def angle_body(self) -> str:
        """The moved body (``""``: none)."""
        return self.condition.offset_body

    @property
    def label(self) -> str:
        """The condition's label."""
        return self.condition.label

    def dims(self) -> dict[str, str]:
        """One dimension per observable, along the conditions that have it."""
        return {"inertia": "inertia_condition", "gravity_moment": "gravity_moment_condition"}

    def at_totals(self, total_a, total_b) -> dict[str, np.ndarray]:
        """Each observable's log-likelihood at observed-scale totals ``a`` and ``I`` (arrays)."""
        cond, g = self.condition, self.gravity
        out = {}
        if cond.inertia is not None:
            out["inertia"] = cond.inertia.logpdf(cond.inertia_at(total_b, g * total_a))
        if cond.gravity_moment is not None:
            out["gravity_moment"] = cond.gravity_moment.logpdf(g * total_a)
        return out

    def _summed(self, total_a, total_b):
        """Both observables' log-likelihood summed (``M_g`` first)."""
        cond, g = self.condition, self.gravity
        out = 0.0
        if cond.gravity_moment is not None:
            out = out + cond.gravity_moment.logpdf(g * total_a)
        if cond.inertia is not None:
            out = out + cond.inertia.logpdf(cond.inertia_at(total_b, g * total_a))
        return out

    def lines(self, point: Point):
        """The totals as lines in the moved body's true mass ``m``: ``(ta, sa, tb, sb)``.

        ``A(m) = ta + sa m`` and ``B(m) = tb + sb m``: the moved body adds ``gain m d`` to
        ``a`` and ``2 a d + gain m d^2`` to ``I`` (``a`` observed-scale, ``m`` true); each
        ``(...,)``.
        """
        k = point.column(self.condition.offset_body)
        d = self.condition.offset
        ta = point.total_a[..., self.index]
        tb = point.total_b[..., self.index] + 2 * d * point.a_obs[..., k]
        return ta, point.gain * d, tb, point.gain * d * d

    def log_likelihood(self, point: Point) -> dict[str, np.ndarray]:
        """At the condition's totals; with a moved body, at its mass ``point.mass``."""
        total_a = point.total_a[..., self.index]
        total_b = point.total_b[..., self.index]
        if self.condition.offset_body:
            assert point.mass is not None
            m = point.mass[..., point.column(self.condition.offset_body)]
            ta, sa, tb, sb = self.lines(point)
            total_a, total_b = ta + sa * m, tb + sb * m
        return self.at_totals(total_a, total_b)

    def curve(self, point: Point | None, a_k, b_k) -> CurvePiece:
        """On the moved body's curve: the totals are lines in its mass (rows)."""
        del a_k, b_k  # the lines hold the moved body's own a and b
        assert point is not None
        cond, g = self.condition, self.gravity
        ta, slope_a, tb, slope_b = self.lines(point)
        lo, hi = np.zeros_like(ta), np.full_like(ta, np.inf)
        core_lo, core_hi = lo, hi
        if cond.gravity_moment is not None:
            obs = cond.gravity_moment
            lo, hi = _interval(
                obs.center, obs.quantile_halfwidth(WINDOW_TAIL), g * slope_a, g * ta
            )
            core_lo, core_hi = _interval(
                obs.center, CORE_SDS * obs.total_scale, g * slope_a, g * ta
            )
        if cond.inertia is not None:
            # evidence at B(m) + coupling (M_c - g A(m)): linear in m
            kappa = cond.coupling
            m_c = cond.gravity_moment.center if cond.gravity_moment is not None else 0.0
            intercept = tb + kappa * (m_c - g * ta)
            slope = slope_b - kappa * g * slope_a
            obs = cond.inertia
            ilo, ihi = _interval(obs.center, obs.quantile_halfwidth(WINDOW_TAIL), slope, intercept)
            clo, chi = _interval(obs.center, CORE_SDS * obs.total_scale, slope, intercept)
            lo, hi = np.maximum(lo, ilo), np.minimum(hi, ihi)
            if np.all(chi - clo < core_hi - core_lo):
                core_lo, core_hi = clo, chi

        def on_curve(m, _x):
            return self._summed(
                ta[:, None] + slope_a[:, None] * m, tb[:, None] + slope_b[:, None] * m
            )

        return CurvePiece(on_curve, (lo, hi), (core_lo, core_hi))

    def body_masses(self, first_moment: tuple[float, float], tail: float) -> tuple[float, float]:
        """For a lone moved body with ``a`` in the range: the masses its ``M_g`` allows."""
        cond = self.condition
        obs = cond.gravity_moment
        if not cond.offset_body or obs is None:
            return 0.0, np.inf
        g, d = self.gravity, cond.offset
        h = obs.quantile_halfwidth(tail) / g
        ends = sorted(
            (
                (obs.center / g - h - first_moment[1]) / d,
                (obs.center / g + h - first_moment[0]) / d,
            )
        )
        return ends[0], ends[1]

    def body_log_likelihood(self, params: Mapping[str, Any]):
        """For a lone body (no gain, no added mass): at its totals, moved when it is."""
        a, b = params["first_moment"], params["inertia"]
        if self.condition.offset_body:
            a, b = physics.moved_moments(a, b, params["mass"], self.condition.offset)
        return self._summed(a, b)

    @classmethod
    def data(cls, terms: Sequence[ConditionEvidence], bodies: Sequence[str]) -> TermData:
        """Each condition's observed ``I`` and ``M_g`` values, and the evidence as used.

        ``observed_data``: the trial values (or the centre) of ``inertia`` and
        ``gravity_moment``, along ``<name>_obs`` with their condition as
        ``<name>_condition``. ``constant_data``, along ``condition``: centre, scale, degrees
        of freedom, ``n`` and shared SD per observable (NaN where a condition has none), the
        coupling, the moved body and its offset, the known added masses' ``a`` and ``I``.
        """
        del bodies  # along the conditions
        conds = [t.condition for t in terms]
        observed: dict[str, Datum] = {}
        constant: dict[str, Datum] = {}
        for name in cls.VARIABLES:
            values: list[float] = []
            labels: list[str] = []
            for c in conds:
                o = getattr(c, name)
                if o is None:
                    continue
                vals = o.values or (o.center,)
                values.extend(vals)
                labels.extend([c.label] * len(vals))
            dim = f"{name}_obs"
            observed[name] = Datum(
                dim,
                np.array(values, float),
                UNITS[name],
                {f"{name}_condition": (dim, np.array(labels, dtype=str))},
            )
        for name in cls.VARIABLES:
            rows = [getattr(c, name) for c in conds]
            for part in ("center", "scale", "df", "n", "shared_sd"):
                vals = [float(getattr(o, part)) if o else math.nan for o in rows]
                constant[f"{name}_{part}"] = Datum("condition", np.array(vals))
        constant["coupling"] = Datum("condition", np.array([c.coupling for c in conds], float))
        constant["offset"] = Datum("condition", np.array([c.offset for c in conds], float))
        constant["offset_body"] = Datum(
            "condition", np.array([c.offset_body for c in conds], dtype=str)
        )
        constant["added_first_moment"] = Datum(
            "condition", np.array([c.added_first_moment for c in conds])
        )
        constant["added_inertia"] = Datum(
            "condition", np.array([c.added_inertia for c in conds], float)
        )
        return TermData(observed, constant)

    @classmethod
    def methods(cls, tree: Any) -> list[MethodsText]:
        """A second mounting and known added masses, where ``constant_data`` has them."""
        cd = tree["constant_data"]
        out = []
        if "offset" in cd and np.any(np.asarray(cd["offset"], float) != 0):
            out.append(MethodsText("a second mounting at another distance from the axis"))
        if "added_inertia" in cd and np.any(np.asarray(cd["added_inertia"], float) != 0):
            out.append(MethodsText("known added masses"))
        return out
