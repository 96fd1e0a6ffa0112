"""What is mounted in a condition: bodies, a body moved along the lever, known added masses.

One :class:`Mounting` describes a condition wherever it appears: a manifest's conditions
(:attr:`inertiafit.io.Study.mountings`), the model's evidence
(:class:`inertiafit.inference.model.Condition` holds one), a planned design
(:class:`inertiafit.planning.design.Design`), a simulated study and the validation harnesses.
Its :attr:`~Mounting.label` is the condition's name in ``trials.csv`` and ``posterior.nc``, and
:meth:`~Mounting.totals` its true ``I`` and ``M_g`` from the bodies' parameters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from inertiafit import physics
from inertiafit.errors import InputError
from inertiafit.physics import GRAVITY

__all__ = ["Mounting"]


def _length_label(metres: float) -> str:
    """A distance for a label: whole centimetres as ``5cm``, else millimetres (``12.5mm``)."""
    cm = metres * 100.0
    if abs(cm - round(cm)) < 1e-9:
        return f"{round(cm)}cm"
    return f"{metres * 1000.0:.6g}mm"


@dataclass(frozen=True)
class Mounting:
    """The bodies mounted together in one condition, as they are mounted.

    Attributes
    ----------
    bodies : tuple of str
        The mounted bodies; their ``I`` and ``M_g`` add up.
    offset_body, offset : str, float
        A second mounting: body ``offset_body`` sits ``offset`` metres further out along the
        lever than where its ``(m, x, rho)`` are defined (``x -> x + offset``), so it adds
        ``a + m d`` and ``I + 2 a d + m d^2`` (:func:`inertiafit.physics.moved_moments`). At
        most one body is moved; ``""`` and ``0.0`` for none.
    added : tuple of (float, float, float)
        Known masses mounted with the bodies, ``(mass, com_distance, radius_of_gyration)`` each
        in kg, m, m (:func:`inertiafit.physics.point_moments`).
    posture : str or None
        The posture the bodies are held in (room for segments whose parameters change with
        it); ``None``: the one posture. Not part of the label yet.
    """

    bodies: tuple[str, ...]
    offset_body: str = ""
    offset: float = 0.0
    added: tuple[tuple[float, float, float], ...] = ()
    posture: str | None = None

    def __post_init__(self) -> None:
        bodies: tuple[Any, ...] = tuple(self.bodies)  # checked here, whatever was given
        object.__setattr__(self, "bodies", bodies)
        object.__setattr__(self, "added", tuple(tuple(float(v) for v in m) for m in self.added))
        where = f"condition '{'+'.join(map(str, bodies))}'"
        if not bodies or not all(isinstance(b, str) and b != "" for b in bodies):
            raise InputError(f"{where}: bodies: expected one or more body names, got {bodies!r}")
        twice = sorted({b for b in bodies if bodies.count(b) > 1})
        if twice:  # one body cannot be mounted twice: its mass would count twice
            raise InputError(f"{where}: bodies: a body is listed twice: {', '.join(twice)}")
        if self.offset_body:
            if self.offset_body not in bodies:
                raise InputError(
                    f"{where}: offset body '{self.offset_body}' is not mounted in it "
                    f"(bodies: {', '.join(bodies)})"
                )
            if not (math.isfinite(self.offset) and self.offset != 0):
                raise InputError(
                    f"{where}: offset of '{self.offset_body}': expected a non-zero distance "
                    f"in m, got {self.offset!r}"
                )
        elif self.offset:
            raise InputError(f"{where}: an offset needs the body it moves (offset_body)")
        given: tuple[tuple[Any, ...], ...] = self.added
        for mass in given:
            finite = len(mass) == 3 and all(math.isfinite(v) for v in mass)
            if not finite or mass[0] <= 0 or mass[2] < 0:
                raise InputError(
                    f"{where}: added mass: expected (mass > 0 kg, com_distance m, "
                    f"radius_of_gyration >= 0 m), got {mass!r}"
                )

    @property
    def label(self) -> str:
        """The condition's readable label, safe in a file name.

        The mounted bodies joined by ``+`` (``attachment+disk``, the label of every condition
        without offset or added mass); a body moved along the lever appends ``@<body>+<d>``
        (``attachment+disk@disk+5cm``; ``-`` for a negative offset); each added mass appends
        ``+added<mass>kg@<distance>`` (``attachment+added0.5kg@30cm``). Distances are whole
        centimetres or millimetres. :func:`~inertiafit.io.load_study` makes a study's labels
        unique (``_2``, ``_3``, ... after a label already taken by another condition, e.g.
        masses that differ only in their radius of gyration).
        """
        label = "+".join(self.bodies)
        if self.offset_body:
            sign = "-" if self.offset < 0 else "+"
            label += f"@{self.offset_body}{sign}{_length_label(abs(self.offset))}"
        for mass, distance, _radius in self.added:
            where = f"{'-' if distance < 0 else ''}{_length_label(abs(distance))}"
            label += f"+added{mass:.6g}kg@{where}"
        return label

    @property
    def plain(self) -> bool:
        """Whether the bodies are mounted as they are (no offset, no added mass)."""
        return not self.offset_body and not self.added

    @property
    def added_moments(self) -> tuple[float, float]:
        """``(m x, I)`` of the added masses together, kg m and kg m^2 (0 without any)."""
        a = i = 0.0
        for mass, distance, radius in self.added:
            da, di = physics.point_moments(mass, distance, radius)
            a, i = a + float(da), i + float(di)
        return a, i

    def totals(
        self, values: Mapping[str, Mapping[str, Any]], gravity: float = GRAVITY
    ) -> tuple[Any, Any]:
        """The condition's true inertia ``I`` (kg m^2) and gravity moment ``M_g`` (N m).

        ``values[body]`` holds the body's own ``inertia`` and ``gravity_moment`` (floats, or
        arrays of one shape), and the moved body's ``mass``. Each body adds its own; the moved
        one its moved moments (:func:`~inertiafit.physics.moved_moments`), each added mass its
        :func:`~inertiafit.physics.point_moments`.
        """
        inertia: Any = 0.0
        moment: Any = 0.0
        for body in self.bodies:
            v = values[body]
            i, g = v["inertia"], v["gravity_moment"]
            if body == self.offset_body:
                a, i = physics.moved_moments(g / gravity, i, v["mass"], self.offset)
                g = gravity * a
            inertia = inertia + i
            moment = moment + g
        for mass, distance, radius in self.added:
            a, i = physics.point_moments(mass, distance, radius)
            inertia = inertia + float(i)
            moment = moment + float(a) * gravity
        return inertia, moment
