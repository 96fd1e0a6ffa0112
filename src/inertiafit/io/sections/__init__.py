"""The manifest's tables, one reader each (:mod:`.base`: :data:`SECTIONS`).

``[bodies]`` (:mod:`.bodies`), ``[calibration]`` (:mod:`.calibration`), ``[passive]`` (:mod:`.passive`), ``[postures]``
(:mod:`.postures`), ``[emg]`` (:mod:`.emg`), ``[subject]`` (:mod:`.subject`), ``[defaults]``
and ``[[trials]]`` (:mod:`.trials`), read in this order (each section's ``order``)
once the bodies are known.
"""

from inertiafit.io.sections import (
    bodies,
    calibration,
    emg,
    passive,
    postures,
    subject,
    trials,
)
from inertiafit.io.sections.base import SECTIONS, Section, SectionContext, register_section

__all__ = [
    "SECTIONS",
    "Section",
    "SectionContext",
    "bodies",
    "calibration",
    "emg",
    "passive",
    "postures",
    "register_section",
    "subject",
    "trials",
]
