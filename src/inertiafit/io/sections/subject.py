"""The ``[subject]`` table: who was measured, for a population of studies (issue 33).

``id`` (a name), ``body_mass`` (kg), optional ``height`` (m), ``sex`` (``"female"`` or
``"male"``) and any other key a number the lab records (an age, a limb girth): the covariates
a population model regresses the segments' parameters on. Each body's own
``segment_length`` (m) is a key of its ``[bodies.<name>]`` table
(:mod:`inertiafit.io.sections.bodies`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from inertiafit.io.sections.base import (
    Section,
    as_table,
    check_name,
    fail,
    number,
    number_within,
    register_section,
)

__all__ = ["BODY_MASS_RANGE", "HEIGHT_RANGE", "SEXES", "Subject", "read_subject"]

#: Body masses (kg) a subject may have: a newborn to the heaviest adults; a mass in g or lb
#: written as kg falls outside or is a slip the message names.
BODY_MASS_RANGE = (1.0, 500.0)
#: Heights (m): a height in cm (175) falls outside and is named as such.
HEIGHT_RANGE = (0.3, 2.8)
#: Values of ``sex``.
SEXES = ("female", "male")
#: Keys with a meaning of their own; every other key is a numeric covariate.
_NAMED = ("id", "body_mass", "height", "sex")


@dataclass(frozen=True)
class Subject:
    """The ``[subject]`` table.

    Attributes
    ----------
    id : str
        The subject's name in the lab's records (it may name an output folder).
    body_mass : float
        kg.
    height : float or None
        m; ``None`` when not given.
    sex : {"female", "male"} or None
    covariates : dict of str to float
        Every other key, a number, in the lab's own units (said by its name).
    """

    id: str
    body_mass: float
    height: float | None = None
    sex: str | None = None
    covariates: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """The table as ``posterior.nc`` records it (``None`` for what was not given)."""
        return {
            "id": self.id,
            "body_mass": self.body_mass,
            "height": self.height,
            "sex": self.sex,
            "covariates": dict(self.covariates),
        }


def read_subject(value: object, *, where: str) -> Subject | None:
    """The ``[subject]`` table, or ``None`` when the manifest has none."""
    if value is None:
        return None
    here = f"{where}: subject"
    table = as_table(value, where=here, what="id = ..., body_mass = kg, ...")
    if "id" not in table:
        raise fail(f"{here}.id", "missing; the subject's name in your records")
    subject_id = table["id"]
    if not isinstance(subject_id, str):
        raise fail(f"{here}.id", f"expected a name (a string), got {subject_id!r}")
    check_name(subject_id, f"{here}.id", "subject id")
    if "body_mass" not in table:
        raise fail(f"{here}.body_mass", "missing; the subject's body mass in kg")
    mass = number_within(
        table["body_mass"],
        f"{here}.body_mass",
        BODY_MASS_RANGE,
        "kg",
        what="a number in kg",
        hint=" (a mass in g or lb?)",
    )
    height = None
    if "height" in table:
        height = number_within(
            table["height"],
            f"{here}.height",
            HEIGHT_RANGE,
            "m",
            what="a number in m",
            hint=" (in cm?)",
        )
    sex = table.get("sex")
    if sex is not None and sex not in SEXES:
        raise fail(f"{here}.sex", f'expected "female" or "male", got {sex!r}')
    covariates = {
        key: number(value, where=f"{here}.{key}", what="a number (a covariate of your own)")
        for key, value in table.items()
        if key not in _NAMED
    }
    return Subject(subject_id, mass, height, sex, covariates)


register_section(
    Section("subject", lambda value, ctx: read_subject(value, where=ctx.where), "", 50)
)
