"""Likelihood terms: each kind of evidence one small object, one registry.

A term (:class:`~inertiafit.inference.terms.base.Term`) holds one piece of evidence and knows
the bodies it touches, its pointwise log-likelihood (vectorised over draws, one column per
``log_likelihood`` variable it writes) and, when it depends on a body's angle ``psi`` once the
body's ``(a, b)`` is fixed, its contribution along that body's curve and the masses it allows
there. :class:`~inertiafit.inference.model.Model` holds a list of them; the angle grid, the
samplers (through the model) and the exact reference
(:func:`~inertiafit.inference.reference.reference_posterior`) iterate the same objects.

Kinds, one module each, registered by :func:`~inertiafit.inference.terms.base.register_term`:

- :mod:`~inertiafit.inference.terms.condition`: a condition's evidence on its total ``I``
  (Student-t) and ``M_g`` (Gaussian), on the angle of its moved body when it has one;
- :mod:`~inertiafit.inference.terms.measured`: a direct measurement of one body
  (:data:`inertiafit.measured.MEASURED_QUANTITIES`), on that body's angle.

Each kind also carries its evidence to the outputs: its observed values and constants
(:meth:`~inertiafit.inference.terms.base.Term.data`, written into ``posterior.nc``), the
:class:`~inertiafit.inference.terms.base.Source` of each variable ("what pins what") and what
the Methods text says of it (:meth:`~inertiafit.inference.terms.base.Term.methods`).
"""

from inertiafit.inference.terms.base import (
    CORE_SDS,
    TERM_KINDS,
    WINDOW_TAIL,
    CurvePiece,
    Datum,
    MethodsText,
    Point,
    Source,
    Term,
    TermData,
    register_term,
)
from inertiafit.inference.terms.condition import ConditionEvidence
from inertiafit.inference.terms.measured import MeasuredEvidence

__all__ = [
    "CORE_SDS",
    "TERM_KINDS",
    "WINDOW_TAIL",
    "ConditionEvidence",
    "CurvePiece",
    "Datum",
    "MeasuredEvidence",
    "MethodsText",
    "Point",
    "Source",
    "Term",
    "TermData",
    "register_term",
]
