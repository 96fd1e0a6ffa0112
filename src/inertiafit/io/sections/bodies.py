"""The ``[bodies.<name>]`` tables: each body's prior, its ideal, its measurements, living or not."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from inertiafit._checks import check_positive
from inertiafit.io.sections.base import (
    Section,
    as_table,
    check_keys,
    check_name,
    fail,
    number_within,
    register_section,
)
from inertiafit.io.units import unit_factor
from inertiafit.measured import MEASURED_QUANTITIES

__all__ = ["BODY_KEYS", "MEASURED_KEYS", "SEGMENT_LENGTH_RANGE", "BodySpec", "read_bodies"]

#: Keys of a ``[bodies.<name>]`` table.
BODY_KEYS = ("prior", "ideal", *MEASURED_QUANTITIES, "living", "segment_length")
#: Segment lengths (m) a body may have: a length in cm (28) falls outside and is named.
SEGMENT_LENGTH_RANGE = (0.01, 2.0)
#: Keys of a measured quantity's table (``[bodies.<name>] mass`` or ``com_distance``: the
#: registry :data:`inertiafit.measured.MEASURED_QUANTITIES`).
MEASURED_KEYS = ("value", "sd", "resolution", "unit")


@dataclass(frozen=True)
class BodySpec:
    """One rigid body of the study, as the manifest states it.

    Attributes
    ----------
    name : str
        The key under ``[bodies]``.
    prior : str or dict
        Raw prior: a shipped prior's name, a path, or an inline table; resolved elsewhere
        (:func:`inertiafit.inference.priors.load_prior`).
    ideal : dict or None
        Optional raw table of ideal-shape values to compare against.
    measured : dict of str to (float, float)
        Direct measurements of the body, ``"mass"`` (kg, a scale) and ``"com_distance"`` (m,
        a balance point, from the joint axis in the body's own mounting): ``(value, sd)`` in
        SI units; ``sd`` is ``resolution / sqrt(12)`` for a reading given with its
        resolution. Empty when none.
    living : bool
        A living segment (``living = true``): held by a joint whose passive elastic moment,
        damping and hysteresis (:attr:`Study.passive`) add to the moments of the conditions
        that hold it. At most one per study. Default false: a rigid body.
    segment_length : float or None
        m: the body's length as the lab measured it (``segment_length``), a covariate of a
        population of studies; ``None`` when not given.
    """

    name: str
    prior: str | dict[str, Any]
    ideal: dict[str, Any] | None = None
    measured: dict[str, tuple[float, float]] = field(default_factory=dict)
    living: bool = False
    segment_length: float | None = None


def read_bodies(raw: object, *, where: str) -> dict[str, BodySpec]:
    """The ``[bodies.<name>]`` tables, in manifest order."""
    if not raw:
        raise fail(f"{where}: bodies", "no bodies; add a [bodies.<name>] table with a prior")
    raw = as_table(raw, where=f"{where}: bodies", what="[bodies.<name>] tables")
    bodies: dict[str, BodySpec] = {}
    for name, raw_entry in raw.items():
        check_name(name, f"{where}: bodies")
        here = f"{where}: bodies.{name}"
        entry = as_table(raw_entry, where=here, what="prior = ...")
        check_keys(entry, BODY_KEYS, where=here)
        if "prior" not in entry:
            raise fail(
                f"{here}.prior",
                "missing; give a prior name, a path to a prior file, or an inline table",
            )
        prior = entry["prior"]
        if not (isinstance(prior, str) and prior.strip()) and not isinstance(prior, dict):
            raise fail(
                f"{here}.prior",
                f"expected a prior name or path (a string) or an inline table, got {prior!r}",
            )
        ideal = entry.get("ideal")
        if ideal is not None:
            ideal = as_table(ideal, where=f"{here}.ideal", what="ideal-shape values")
        measured = {
            key: _measured(entry[key], key, where=f"{here}.{key}")
            for key in MEASURED_QUANTITIES
            if key in entry
        }
        living = entry.get("living", False)
        if not isinstance(living, bool):
            raise fail(f"{here}.living", f"expected true or false, got {living!r}")
        if living:
            other = next((b for b, spec in bodies.items() if spec.living), None)
            if other is not None:
                raise fail(
                    f"{here}.living",
                    f"one living body per study; '{other}' is living already (the passive "
                    "model belongs to one joint)",
                )
        length = None
        if "segment_length" in entry:
            length = number_within(
                entry["segment_length"],
                f"{here}.segment_length",
                SEGMENT_LENGTH_RANGE,
                "m",
                what="a length in m",
                hint=" (in cm?)",
            )
        bodies[name] = BodySpec(
            name=name,
            prior=prior,
            ideal=ideal,
            measured=measured,
            living=living,
            segment_length=length,
        )
    return bodies


def _measured(value: object, key: str, *, where: str) -> tuple[float, float]:
    """A measured quantity (:data:`MEASURED_QUANTITIES`): ``(value, sd)`` in its SI unit."""
    measured = MEASURED_QUANTITIES[key]
    quantity, si = measured.quantity, measured.unit
    table = as_table(
        value, where=where, what=f"{{ value = ..., sd = ... or resolution = ..., unit = {si!r} }}"
    )
    check_keys(table, MEASURED_KEYS, where=where)
    unit = table.get("unit", si)
    factor = unit_factor(quantity, unit, where=f"{where}.unit")
    if "value" not in table:
        raise fail(f"{where}.value", f"missing; the measured {key} ({unit})")
    center = check_positive(table["value"], f"{where}.value", str(unit))
    if "sd" in table and "resolution" in table:
        raise fail(
            where,
            "give sd (the measurement's SD) or resolution (the reading's step), not both",
        )
    if "sd" in table:
        sd = check_positive(table["sd"], f"{where}.sd", str(unit))
    elif "resolution" in table:
        # A reading rounded to a step q is off by a uniform error on (-q/2, q/2): SD q/sqrt(12).
        sd = check_positive(table["resolution"], f"{where}.resolution", str(unit))
        sd /= math.sqrt(12.0)
    else:
        raise fail(
            f"{where}.sd",
            f"missing; give the measurement's sd or the reading's resolution ({unit})",
        )
    return center * factor, sd * factor


register_section(
    Section("bodies", lambda value, ctx: read_bodies(value, where=ctx.where), "bodies", 5)
)
