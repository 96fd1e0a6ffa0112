"""``kind = "mvc"``: a maximal contraction, read for its EMG's MVC levels, never evidence."""

from __future__ import annotations

from typing import TYPE_CHECKING

from inertiafit.processing.kinds.base import Stage, register_kind

if TYPE_CHECKING:
    import xarray as xr

    from inertiafit.io import TrialSpec

__all__ = ["Mvc"]


class Mvc:
    """Its row (``status`` ``"reference"``: each muscle's peak envelope), nothing else."""

    name = "mvc"

    def read(self, stage: Stage, spec: TrialSpec, ds: xr.Dataset) -> None:
        """The row of the MVC trial (the manifest gives such a trial EMG)."""
        assert stage.emg is not None
        stage.run.reference(spec, stage.emg.mvc_row(spec, ds, reader=stage.run.reader_flags(spec)))

    def after_gravity(self, stage: Stage, trials: list[tuple[TrialSpec, xr.Dataset]]) -> None:
        """Nothing: an MVC trial is done once read."""


register_kind(Mvc())
