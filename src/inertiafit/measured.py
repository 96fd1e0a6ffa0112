"""What can be measured of a body directly: each quantity declared once, and passed as data.

A :class:`MeasuredQuantity` says everything the package needs to know about one direct
measurement — a weighed mass, a balance point: its name (the ``[bodies.<name>]`` key of the
manifest and the body parameter it constrains), its SI unit and the kind of unit the manifest
may write it in, what it is called in words, where it goes in a saved posterior (the
``log_likelihood`` and ``observed_data`` variable, the body dimension they share, the
``constant_data`` variables of its value and SD), and the value it reads of a body's true
parameters. :data:`MEASURED_QUANTITIES` is the registry: the
manifest, the model's likelihood terms (:mod:`inertiafit.inference.terms`), the DataTree
writer, the posterior's display, the simulator and the validation harnesses look a quantity
up here instead of comparing its name. A new direct measurement is one entry here (and its
likelihood follows from :meth:`MeasuredQuantity.value` and :meth:`MeasuredQuantity.masses`;
the planner reads its SDs from the :class:`~inertiafit.planning.Design` field it names).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inertiafit.errors import InputError
from inertiafit.physics import UNITS

__all__ = [
    "MEASURED_QUANTITIES",
    "MeasuredQuantity",
    "Measurement",
    "measured_quantity",
    "measurements",
]


@dataclass(frozen=True)
class MeasuredQuantity:
    """One quantity of a body that can be measured directly.

    Attributes
    ----------
    name : str
        The body parameter it reads (:data:`inertiafit.physics.PARAMETERS`), which is also its
        key in a manifest's ``[bodies.<name>]`` table, in ``Model(measured=...)`` and the
        ``log_likelihood`` / ``observed_data`` variable of a saved posterior.
    quantity : str
        The kind of unit the manifest accepts (:mod:`inertiafit.io.units`: ``"mass"``,
        ``"length"``).
    label : str
        What it is called in words (``"weighed mass"``).
    body_dim : str
        The dimension of its ``log_likelihood`` and ``observed_data`` variables (bodies that
        have it, in model order).
    increasing : bool
        Whether the value read grows with the body's mass at a fixed first moment ``a``.
    plan_key : str
        Its key in a plan file's design (``weigh = { body = sd }``).
    design_field : str
        The :class:`inertiafit.planning.Design` field holding each measured body's SD
        (``weighed``).
    """

    name: str
    quantity: str
    label: str
    body_dim: str
    increasing: bool
    plan_key: str
    design_field: str

    @property
    def unit(self) -> str:
        """Its SI unit (what :meth:`value` returns and the saved posterior holds)."""
        return UNITS[self.name]

    @property
    def constant_vars(self) -> tuple[str, str]:
        """The ``constant_data`` variables of its value and SD per body (NaN where none)."""
        return f"measured_{self.name}", f"measured_{self.name}_sd"

    def value(self, mass, com_distance):
        """The value read for a body of true mass ``m`` and CoM distance ``x`` (arrays)."""
        return {"mass": mass, "com_distance": com_distance}[self.name]

    def masses(self, low, high, first_moment):
        """The masses at which :meth:`value` lies in ``[low, high]``, as ``(lo, hi)`` arrays.

        The parameter read is the mass itself when :attr:`increasing`, otherwise
        ``x = a / m``.

        ``first_moment`` (``a``, arrays) fixes the body's curve; the bounds broadcast with it.
        An unbounded end is ``inf``.
        """
        low = np.asarray(low, float)
        high = np.asarray(high, float)
        ones = np.ones_like(np.asarray(first_moment, float))
        if self.increasing:  # the mass itself
            return ones * low, ones * high
        with np.errstate(divide="ignore"):  # x = a / m, decreasing in m
            return (
                first_moment / high,
                np.where(low > 0, first_moment / np.where(low > 0, low, 1.0), np.inf),
            )


#: The registry of direct measurements, by name (the order a manifest's are read in).
MEASURED_QUANTITIES: dict[str, MeasuredQuantity] = {
    q.name: q
    for q in (
        MeasuredQuantity(
            "mass",
            "mass",
            "weighed mass",
            "mass_body",
            increasing=True,
            plan_key="weigh",
            design_field="weighed",
        ),
        MeasuredQuantity(
            "com_distance",
            "length",
            "balance point",
            "com_body",
            increasing=False,
            plan_key="balance",
            design_field="balanced",
        ),
    )
}


def measured_quantity(name: str, *, where: str) -> MeasuredQuantity:
    """The registered quantity ``name``; an :class:`InputError` naming ``where`` otherwise."""
    try:
        return MEASURED_QUANTITIES[name]
    except KeyError:
        raise InputError(
            f"{where}: unknown quantity '{name}' (expected one of "
            f"{', '.join(MEASURED_QUANTITIES)})"
        ) from None


@dataclass(frozen=True)
class Measurement:
    """One direct measurement of a body: what was measured, its reading and the reading's SD.

    Built once where a measurement enters (a command line's options, :func:`measurements`)
    and passed as it is to the model (:func:`inertiafit.inference.fit.fit_body`'s
    ``measured``), which checks the SD.

    Attributes
    ----------
    quantity : MeasuredQuantity
        What was measured (an entry of :data:`MEASURED_QUANTITIES`).
    value : float
        The reading, in the quantity's SI unit (:attr:`MeasuredQuantity.unit`).
    sd : float
        Its SD, in the same unit.
    """

    quantity: MeasuredQuantity
    value: float
    sd: float

    @property
    def name(self) -> str:
        """The quantity's name (``mass``, ``com_distance``)."""
        return self.quantity.name


def measurements(**given: tuple[float | None, float | None]) -> tuple[Measurement, ...]:
    """Direct measurements given as numbers, ``name=(value, sd)`` by a quantity's name.

    A pair of ``None`` is left out; a value without its SD (or an SD without its value) is an
    :class:`InputError` naming ``name`` and ``name_sd`` (the keyword arguments of
    :func:`~inertiafit.inference.fit.fit_body`, the options ``--name`` and ``--name-sd`` of
    ``inertiafit fit``). The measurements come in the order given.
    """
    out = []
    for name, (value, sd) in given.items():
        quantity = measured_quantity(name, where="measured")
        if value is None and sd is None:
            continue
        if sd is None:
            raise InputError(f"{name}: needs its SD {name}_sd too")
        if value is None:
            raise InputError(f"{name}_sd: needs the value {name} too")
        out.append(Measurement(quantity, value, sd))
    return tuple(out)
