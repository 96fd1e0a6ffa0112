"""The :class:`Term` protocol, the registry of term kinds and what a term is evaluated at.

A new kind of evidence is one module of this package: a class with the attributes and methods
of :class:`Term`, decorated with :func:`register_term`, imported by the package's
``__init__`` (importing registers it). The model asks every term for its log-likelihood
(:meth:`Term.log_likelihood`) and, for the terms on a body's angle (``angle_body``), for its
piece of that body's angle grid (:meth:`Term.curve`); the exact reference asks the same terms
for their value on its grid of one body's parameters (:meth:`Term.body_log_likelihood`) and
the masses they allow there (:meth:`Term.body_masses`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

if TYPE_CHECKING:
    from inertiafit.inference.model import Model

__all__ = ["CORE_SDS", "TERM_KINDS", "WINDOW_TAIL", "CurvePiece", "Point", "Term", "register_term"]

#: Tail of a term's likelihood left outside the window of masses it allows on the angle grid.
WINDOW_TAIL = 1e-8
#: Half-width, in the term's SDs, of its core (where the angle grid is refined).
CORE_SDS = 8.0


class Point:
    """Where terms are evaluated: rows ``z`` of a model's sampled coordinates.

    Parameters
    ----------
    model : Model
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

    The bodies' observed-scale :attr:`a_obs`, true :attr:`true_a` and the torque
    :attr:`gain` are computed when a term first asks.
    """

    def __init__(self, model: Model, z, total_a, total_b, mass=None) -> None:
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
    def gain(self) -> np.ndarray:
        """The torque gain, ``(...,)`` (ones without one)."""
        return np.exp(self.model.log_gain(self.z))


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


class Term(Protocol):
    """One piece of evidence in the joint density.

    ``kind`` is its key in :data:`TERM_KINDS` (a class attribute, checked when registered);
    ``VARIABLES`` every ``log_likelihood`` variable a term of its kind may write, in the order
    a saved posterior lists them.
    """

    kind: ClassVar[str]
    VARIABLES: ClassVar[tuple[str, ...]]

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

    def curve(self, point: Point | None, a_k) -> CurvePiece:
        """Its piece of :attr:`angle_body`'s angle grid for rows of the body's true ``a``.

        ``point`` holds the same rows of every body (``None`` when the model evaluates a body
        alone, for a term that involves only that body).
        """
        ...

    def body_masses(self, first_moment: tuple[float, float], tail: float) -> tuple[float, float]:
        """Masses it allows (all but ``tail``) for a lone body with ``a`` in the range."""
        ...

    def body_log_likelihood(self, params: Mapping[str, Any]) -> Any:
        """Its log-likelihood on a grid of a lone body's true parameters (no gain).

        ``params`` holds ``mass``, ``com_distance``, ``first_moment`` and ``inertia`` arrays.
        """
        ...


#: Registered kinds of term, by :attr:`Term.kind`, in registration order (the order of the
#: ``log_likelihood`` variables of a saved posterior).
TERM_KINDS: dict[str, type[Any]] = {}


def register_term[T: type](cls: T) -> T:
    """Class decorator: register a term class under its ``kind``."""
    kind = getattr(cls, "kind", None)
    if not isinstance(kind, str) or not kind:
        raise TypeError(f"register_term: {cls.__name__} needs a class attribute 'kind'")
    if kind in TERM_KINDS:
        raise ValueError(f"register_term: kind '{kind}' is already registered")
    TERM_KINDS[kind] = cls
    return cls
