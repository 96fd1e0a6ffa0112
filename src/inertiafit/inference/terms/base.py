"""The :class:`Term` protocol, the registry of term kinds and what a term is evaluated at.

A new kind of evidence is one module of this package: a class with the attributes and methods
of :class:`Term`, decorated with :func:`register_term`, imported by the package's
``__init__`` (importing registers it). The model asks every term for its log-likelihood
(:meth:`Term.log_likelihood`) and, for the terms on a body's angle (``angle_body``), for its
piece of that body's angle grid (:meth:`Term.curve`); the exact reference asks the same terms
for their value on its grid of one body's parameters (:meth:`Term.body_log_likelihood`) and
the masses they allow there (:meth:`Term.body_masses`).

A term also carries its evidence to the edges. The DataTree writer
(:func:`inertiafit.inference.fit.build_tree`) asks each kind for its observed values and
constants (:meth:`Term.data`, :class:`TermData`) and writes each ``log_likelihood`` variable
with its :class:`Source` (the name "what pins what" credits, the parameters it measures
directly) as attributes, which :mod:`inertiafit.posterior.pins` reads back from the saved
tree; the Methods text (:mod:`inertiafit.report.methods`) asks each kind what to say of the
evidence a saved tree holds (:meth:`Term.methods`, :class:`MethodsText`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar, Protocol

import numpy as np

__all__ = [
    "CORE_SDS",
    "TERM_KINDS",
    "WINDOW_TAIL",
    "CurvePiece",
    "Datum",
    "MethodsText",
    "ModelView",
    "Point",
    "Source",
    "Term",
    "TermData",
    "register_term",
]

#: Tail of a term's likelihood left outside the window of masses it allows on the angle grid.
WINDOW_TAIL = 1e-8
#: Half-width, in the term's SDs, of its core (where the angle grid is refined).
CORE_SDS = 8.0


class ModelView(Protocol):
    """What a term reads of the model (:class:`~inertiafit.inference.model.Model` is one).

    Named here rather than imported, so that the terms do not import the model that imports
    them (not even for type checking).
    """

    bodies: tuple[str, ...]

    def split(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """The bodies' observed-scale ``(a, b)`` and the rest at rows ``z``."""
        ...

    def true_identified(self, z: np.ndarray) -> tuple[np.ndarray, ...]:
        """The bodies' true ``(a, b)`` at rows ``z``."""
        ...

    def log_gain(self, z: np.ndarray) -> np.ndarray:
        """The log torque gain at rows ``z``."""
        ...


class Point:
    """Where terms are evaluated: rows ``z`` of a model's sampled coordinates.

    Parameters
    ----------
    model : ModelView
        The model (its ``bodies``, ``split``, ``true_identified`` and ``log_gain``).
    z : ndarray
        Rows of its sampled coordinates, ``(..., ndim)``.
    total_a, total_b : ndarray
        Observed-scale totals of every condition, ``(..., C)``, with known added masses; a
        moved body enters with its own ``(a, b)`` (the part of its mass is its condition
        term's).
    mass : ndarray, optional
        The bodies' true masses ``(..., K)`` (from the angle draws); terms on an angle need
        them outside the angle grid.

    The bodies' observed-scale :attr:`a_obs`, true :attr:`true_a` and :attr:`true_b` and the
    torque :attr:`gain` are computed when a term first asks; with ``mass``, a body's full
    ``(m, x, rho)`` is :meth:`parameters`.
    """

    def __init__(self, model: ModelView, z, total_a, total_b, mass=None) -> None:
        self.model = model
        self.z = z
        self.total_a = total_a
        self.total_b = total_b
        self.mass = mass

    @property
    def bodies(self) -> tuple[str, ...]:
        """The model's bodies, in column order."""
        return self.model.bodies

    def column(self, body: str) -> int:
        """The column of ``body``."""
        return self.model.bodies.index(body)

    @cached_property
    def a_obs(self) -> np.ndarray:
        """The bodies' observed-scale ``a``, ``(..., K)``."""
        return self.model.split(self.z)[0]

    @cached_property
    def true_a(self) -> np.ndarray:
        """The bodies' true ``a``, ``(..., K)``."""
        return self.model.true_identified(self.z)[0]

    @cached_property
    def true_b(self) -> np.ndarray:
        """The bodies' true ``b = I`` about the joint, ``(..., K)``."""
        return self.model.true_identified(self.z)[1]

    @cached_property
    def gain(self) -> np.ndarray:
        """The torque gain, ``(...,)`` (ones without one)."""
        return np.exp(self.model.log_gain(self.z))

    def parameters(self, body: str) -> dict[str, np.ndarray]:
        """``body``'s true ``mass``, ``com_distance`` and ``radius_of_gyration``, ``(...,)`` each.

        Needs :attr:`mass` (a term on the body's angle has it): ``x = a / m`` and
        ``rho = sqrt(I / m - x^2)``.
        """
        if self.mass is None:
            raise ValueError("Point.parameters: the masses are needed (a term on the angle)")
        k = self.column(body)
        m = self.mass[..., k]
        x = self.true_a[..., k] / m
        rho2 = self.true_b[..., k] / m - x * x
        return {
            "mass": m,
            "com_distance": x,
            "radius_of_gyration": np.sqrt(np.maximum(rho2, 0.0)),
        }


@dataclass(frozen=True)
class CurvePiece:
    """A term's part of one body's angle grid, for rows of ``(a, b)``.

    Attributes
    ----------
    log_likelihood : callable
        ``(mass, com_distance) -> (rows, n)``: the term on a grid of the body's parameters.
    window : (ndarray, ndarray)
        Masses outside which the term holds less than :data:`WINDOW_TAIL` of its mass
        (``(rows,)`` each).
    core : (ndarray, ndarray)
        Masses within :data:`CORE_SDS` of the term's SDs.
    """

    log_likelihood: Callable[[Any, Any], Any]
    window: tuple[Any, Any]
    core: tuple[Any, Any]


@dataclass(frozen=True)
class Datum:
    """One variable of a saved posterior's ``observed_data`` or ``constant_data`` group.

    Attributes
    ----------
    dims : str
        Its one dimension (``"body"`` and ``"condition"`` take the model's labels).
    values : array_like
        Its values along ``dims``.
    units : str
        Its ``units`` attribute (``""``: none).
    coords : mapping
        Coordinates it brings (``{name: labels}`` of an own dimension, or
        ``{name: (dim, labels)}``).
    """

    dims: str
    values: Any
    units: str = ""
    coords: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class TermData:
    """What a kind of term writes into the ``observed_data`` and ``constant_data`` groups.

    ``observed``: the values measured (each with its ``units``); ``constant``: what the
    likelihood was built from besides them (centres, scales, SDs, settings), by variable name.
    """

    observed: Mapping[str, Datum] = field(default_factory=dict)
    constant: Mapping[str, Datum] = field(default_factory=dict)


@dataclass(frozen=True)
class Source:
    """What one ``log_likelihood`` variable is credited as in "what pins what".

    Written as attributes of the variable (:meth:`attrs`) and read back from the saved tree
    by :mod:`inertiafit.posterior.pins`.

    Attributes
    ----------
    label : str
        The source's name in ``identification.csv``'s ``pinned_by`` and the text
        (``"weighed mass"``); ``"data"`` is the dynamometer's own evidence.
    pins : tuple of str
        The parameters of the body it informs that it measures directly
        (:data:`inertiafit.physics.PARAMETERS`): named alone for them when its psense counts.
    credits : str
        Which bodies an entry informs: ``"coordinate"``, the body its coordinate names (a
        measurement of one body); ``"all"``, every body (a condition's evidence).
    moved : str
        With ``"all"``: the label an entry is credited as for the body its condition moves
        (``constant_data``'s ``offset_body`` at a non-zero ``offset``); ``""`` none.
    """

    label: str
    pins: tuple[str, ...] = ()
    credits: str = "coordinate"
    moved: str = ""

    def attrs(self) -> dict[str, str]:
        """Its attributes on the ``log_likelihood`` variable (empty ones left out)."""
        out = {"source": self.label, "credits": self.credits}
        if self.pins:
            out["pins"] = " ".join(self.pins)
        if self.moved:
            out["moved_source"] = self.moved
        return out


@dataclass(frozen=True)
class MethodsText:
    """What the Methods text says of one kind of evidence a saved posterior holds.

    ``phrase`` joins the list of "Further evidence on the bodies: ..." (``"a weighed mass"``);
    ``sentence``, when given, follows that paragraph; ``cite`` holds the keys of the works it
    cites (:data:`inertiafit.report.references.REFERENCES`), cited after the sentence (or
    the phrase). ``measures``: the parameters it measures directly: such evidence is listed
    before the rest.
    """

    phrase: str
    sentence: str = ""
    cite: tuple[str, ...] = ()
    measures: tuple[str, ...] = ()


class Term(Protocol):
    """One piece of evidence in the joint density.

    ``kind`` is its key in :data:`TERM_KINDS` (a class attribute, checked when registered);
    ``VARIABLES`` every ``log_likelihood`` variable a term of its kind may write, in the order
    a saved posterior lists them.
    """

    kind: ClassVar[str]
    VARIABLES: ClassVar[tuple[str, ...]]
    #: The :class:`Source` of each variable of ``VARIABLES`` ("what pins what").
    SOURCES: ClassVar[Mapping[str, Source]]

    @property
    def variables(self) -> tuple[str, ...]:
        """The ``log_likelihood`` variables it writes, in order.

        Each has the dimension :meth:`dims` gives and this term's :attr:`label` along it.
        """
        ...

    @property
    def bodies(self) -> tuple[str, ...]:
        """The bodies whose parameters it involves."""
        ...

    @property
    def angle_body(self) -> str:
        """The body whose angle ``psi`` it depends on once ``(a, b)`` are fixed.

        ``""``: none; it is then a function of the sampled coordinates alone.
        """
        ...

    @property
    def label(self) -> str:
        """Its coordinate along each variable's dimension (a condition, a body)."""
        ...

    def dims(self) -> dict[str, str]:
        """The dimension of each variable of :attr:`variables`."""
        ...

    def log_likelihood(self, point: Point) -> dict[str, np.ndarray]:
        """Its pointwise log-likelihood, one ``(...,)`` array per variable it has.

        A term on an angle needs ``point.mass``.
        """
        ...

    def curve(self, point: Point | None, a_k, b_k) -> CurvePiece:
        """Its piece of :attr:`angle_body`'s angle grid for rows of the body's true ``a``, ``b``.

        ``point`` holds the same rows of every body (``None`` when the model evaluates a body
        alone, for a term that involves only that body). On the curve of the row's ``(a, b)``
        the body's ``x = a / m`` and ``rho = sqrt(b / m - x^2)``.
        """
        ...

    def body_masses(self, first_moment: tuple[float, float], tail: float) -> tuple[float, float]:
        """Masses it allows (all but ``tail``) for a lone body with ``a`` in the range."""
        ...

    def body_log_likelihood(self, params: Mapping[str, Any]) -> Any:
        """Its log-likelihood on a grid of a lone body's true parameters (no gain).

        ``params`` holds ``mass``, ``com_distance``, ``radius_of_gyration``, ``first_moment``
        and ``inertia`` arrays.
        """
        ...

    @classmethod
    def data(cls, terms: Sequence[Any], bodies: Sequence[str]) -> TermData:
        """The ``observed_data`` and ``constant_data`` variables of a model's terms of this kind.

        ``terms`` are the model's terms of the kind in model order (possibly none), ``bodies``
        the model's bodies. Asked once per registered kind by the DataTree writer.
        """
        ...

    @classmethod
    def methods(cls, tree: Any) -> list[MethodsText]:
        """What the Methods text says of this kind's evidence in a saved posterior ``tree``.

        Read from the tree's groups (what :meth:`data` and the ``log_likelihood`` variables
        hold), so that a redrawn report says the same; none when the tree holds none of it.
        """
        ...


#: Registered kinds of term, by :attr:`Term.kind`, in registration order (the order of the
#: ``log_likelihood`` variables of a saved posterior).
TERM_KINDS: dict[str, type[Any]] = {}


def _no_data(cls: type, terms: Sequence[Any], bodies: Sequence[str]) -> TermData:
    """No ``observed_data`` or ``constant_data`` (a kind that declares no :meth:`Term.data`)."""
    del cls, terms, bodies
    return TermData()


def _no_methods(cls: type, tree: Any) -> list[MethodsText]:
    """Nothing for the Methods text (a kind that declares no :meth:`Term.methods`)."""
    del cls, tree
    return []


def register_term[T: type](cls: T) -> T:
    """Class decorator: register a term class under its ``kind``.

    What it leaves out of the :class:`Term` protocol's evidence members is filled in: a
    variable without a :class:`Source` in ``SOURCES`` is credited by the kind's name, a kind
    without ``data`` writes no observed or constant variables, one without ``methods`` adds
    nothing to the Methods text.
    """
    kind = getattr(cls, "kind", None)
    if not isinstance(kind, str) or not kind:
        raise TypeError(f"register_term: {cls.__name__} needs a class attribute 'kind'")
    if kind in TERM_KINDS:
        raise ValueError(f"register_term: kind '{kind}' is already registered")
    variables = tuple(getattr(cls, "VARIABLES", ()))
    sources = dict(getattr(cls, "SOURCES", {}))
    for v in variables:  # a variable without its Source is credited by the kind's name
        sources.setdefault(v, Source(kind))
    cls.SOURCES = sources  # type: ignore[attr-defined]
    if not callable(getattr(cls, "data", None)):
        cls.data = classmethod(_no_data)  # type: ignore[attr-defined]
    if not callable(getattr(cls, "methods", None)):
        cls.methods = classmethod(_no_methods)  # type: ignore[attr-defined]
    TERM_KINDS[kind] = cls
    return cls
