"""Each kind of trial's handler, in one registry (:data:`KINDS`; :mod:`.base`).

``quasi-static`` (:mod:`.quasi_static`), ``rest`` (:mod:`.rest`), ``mvc`` (:mod:`.mvc`) and
``fast`` (:mod:`.fast`): one module each.
"""

from inertiafit.processing.kinds import fast, mvc, quasi_static, rest
from inertiafit.processing.kinds.base import KINDS, Stage, TrialKind, register_kind

__all__ = ["KINDS", "Stage", "TrialKind", "fast", "mvc", "quasi_static", "register_kind", "rest"]
