"""What a kind of trial's handler is given, and the registry the handlers join.

:func:`~inertiafit.processing.study.process_study` reads every trial, then hands each to the
handler of its kind (:data:`KINDS`) in two passes: :meth:`TrialKind.read`, trial by trial in
the manifest's order, before any gravity model exists (a quasi-static sweep's fit, a rest
hold, an MVC trial's levels), and :meth:`TrialKind.after_gravity`, all the kind's trials at
once, once every condition's gravity model (and a living joint's static fit) is known (a
fast trial's inertia, judged with its condition's other fast trials). Both share one
:class:`Stage`: what the run has gathered so far.

A new kind of trial is one module: a class with these two methods, registered with
:func:`register_kind` and imported by :mod:`inertiafit.processing.kinds`; the manifest's
``kind`` names it (:data:`inertiafit.io.manifest.KINDS`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from collections.abc import Callable

    import xarray as xr

    from inertiafit.io import Study, TrialSpec
    from inertiafit.processing.gravity import GravityFit
    from inertiafit.processing.inertia import InertiaEstimate
    from inertiafit.processing.living import LivingStatics, StaticRecord
    from inertiafit.processing.trials import EmgCheck, TrialRun

__all__ = ["KINDS", "Stage", "TrialKind", "register_kind"]


@dataclass
class Stage:
    """What one :func:`~inertiafit.processing.study.process_study` call has gathered.

    The handlers read and fill it: ``run`` (rows, notes, skips), the conditions' quasi-static
    fits (``qs_fits``; a rigid sweep away from its condition's fast trials in
    ``rotation_fits``, by posture), a living condition's static records, a rigid sweep's samples as
    fitted (``sweeps``), and after the gravity models (``gravity``, ``statics``) the fast
    trials' estimates and traces.
    """

    study: Study
    run: TrialRun
    emg: EmgCheck | None
    living: set[str]
    homes: dict[str, str]
    cutoff: float
    order: int
    say: Callable[[str], None]
    qs_fits: dict[str, list[GravityFit]] = field(default_factory=dict)
    rotation_fits: dict[str, dict[str, list[GravityFit]]] = field(default_factory=dict)
    records: list[StaticRecord] = field(default_factory=list)
    gravity: dict[str, GravityFit] = field(default_factory=dict)
    statics: LivingStatics | None = None
    fast_estimates: list[tuple[TrialSpec, InertiaEstimate]] = field(default_factory=list)
    traces: list[dict] = field(default_factory=list)
    sweeps: list[dict] = field(default_factory=list)

    @property
    def rows(self) -> dict[int, dict]:
        """The rows of the trials processed, by manifest index."""
        return self.run.rows

    @property
    def notes(self) -> list[str]:
        """The study's warnings, one line each."""
        return self.run.notes


class TrialKind(Protocol):
    """A kind of trial's handler: the manifest's ``kind`` and its two passes."""

    name: str

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """One trial, before the gravity models: its row, its fit, its record."""

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Every trial of this kind, once the gravity models are known."""


#: Every kind's handler, by the manifest's ``kind``.
KINDS: dict[str, TrialKind] = {}


def register_kind(handler: TrialKind) -> TrialKind:
    """Add a handler to :data:`KINDS` under its ``name`` (one per kind)."""
    if handler.name in KINDS:
        msg = f"kind {handler.name!r} has a handler already"
        raise ValueError(msg)
    KINDS[handler.name] = handler
    return handler
